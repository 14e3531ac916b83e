"""The ``femb`` command line (femb.console.cli): subcommands, JSON contract, errors."""
import importlib
import json
import shutil
import subprocess
import sys
import textwrap

import pytest

import femb
from femb.console import cli
from femb.study import registry

SCENE_FILE = textwrap.dedent('''
    """Pendulum from a file (test scene)."""
    from femb import Mechanism
    from femb.elements import Gravity, Hinge, RigidBody

    def build(length=0.5, mass=1.0):
        mech = Mechanism("pendulum")
        bar = mech.add(RigidBody("bar", mass, mass * length ** 2 / 12, (0.5 * length, 0.0),
                                 points={"O": (-0.5 * length, 0.0)}))
        mech.add(Hinge("pivot", "ground", bar, point_b="O"), Gravity((0.0, -9.81)))
        return mech
''')

RUN_KEYS = {"scene", "t_end", "h", "rho_inf", "scaling", "steps", "newton_iterations", "wall_time_s", "outputs"}
CONV_KEYS = {"scene", "rho_inf", "h", "error_q", "error_lambda", "order_q", "order_lambda", "reference"}


def _err_line(capsys):
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert err.startswith("femb: error:")
    return err


# ------------------------------------------------------------------ helpers
def test_parse_value_and_sets():
    assert cli.parse_value("3") == 3 and isinstance(cli.parse_value("3"), int)
    assert cli.parse_value("1e3") == 1000.0
    assert cli.parse_value("-0.5") == -0.5
    assert cli.parse_value("inf") == float("inf")
    assert cli.parse_value("true") is True and cli.parse_value("None") is None
    assert cli.parse_value("(1, 2)") == (1, 2)
    assert cli.parse_value("abc") == "abc"
    assert cli.parse_sets(["T=2", "name=x"]) == {"T": 2, "name": "x"}
    with pytest.raises(cli.UsageError):
        cli.parse_sets(["novalue"])
    with pytest.raises(cli.UsageError):
        cli.parse_sets(["1x=2"])


# ------------------------------------------------------------------ list / help
def test_list_names_scenes_and_parameters(capsys):
    assert cli.main(["list"]) == 0
    out = capsys.readouterr().out
    assert "slider_crank:" in out and "andrews:" in out
    assert "mom=0.033" in out and "T=1.0" in out and "t_end=0.03" in out
    # every parameter with its unit and meaning, every scene with its outputs and units
    assert "[N m]  constant driving torque on body 1" in out
    assert "omega_s=6.0        [rad/s]  final hub angular velocity" in out
    assert "R_pivot_x [N]," in out and "root_moment [N m]," in out and "lambda_6 [N]" in out
    assert out.count("  outputs") == len(registry.names())


def test_list_one_scene_in_detail(capsys):
    assert cli.main(["list", "slider_crank"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("slider_crank: Slider–crank")
    assert "femb run slider_crank --set NAME=VALUE" in out
    assert "theta0=1.5707963267948966  [rad]  initial crank angle" in out
    assert "R_pivot_y  [N]      y force of the ground on the crank at the pivot" in out
    assert "andrews" not in out and "References" not in out     # one scene, docstring up to its sections
    assert cli.main(["list", "nosuch"]) == 2
    assert "unknown scene 'nosuch'" in _err_line(capsys)


def test_list_compiles_nothing(tmp_path, monkeypatch, capsys):
    """`femb list` describes scenes from their tables and builders alone: no numba compilation (nor a
    cache load, which goes through the same call), no model compiled, no background cache build."""
    import numba.core.dispatcher
    from femb.solve import cache
    from femb.system import kernels

    calls = []

    def forbid(what):
        def call(*args, **kw):
            calls.append(what)
            raise AssertionError(f"femb list called {what}")
        return call

    monkeypatch.setattr(numba.core.dispatcher.Dispatcher, "compile", forbid("numba's compiler"))
    monkeypatch.setattr(kernels, "compiled_kernel", forbid("compiled_kernel"))
    monkeypatch.setattr(cache, "start_background_build", forbid("the background build"))
    import femb.system.mechanism
    monkeypatch.setattr(femb.system.mechanism.Mechanism, "compile", forbid("Mechanism.compile"))
    p = tmp_path / "pend.py"
    p.write_text(SCENE_FILE)
    for argv in (["list", "bead_attractor"], ["list", "fourbar_driven"], ["list", str(p)], ["list"]):
        assert cli.main(argv) == 0, argv
    assert calls == []
    out = capsys.readouterr().out
    assert "see 'femb list" not in out               # no scene points back to itself
    assert "phi1_d     [rad/s]" in out and "T_drive" in out and "bar.theta" in out


def test_list_scene_file_without_descriptions(tmp_path, capsys):
    p = tmp_path / "pend.py"
    p.write_text(SCENE_FILE)
    assert cli.main(["list", str(p)]) == 0
    out = capsys.readouterr().out
    assert "pend: Pendulum from a file (test scene)." in out
    assert "length=0.5" in out and "mass=1.0" in out
    assert "t_end=(give --t-end)" in out
    assert "outputs are the free coordinates" in out and "bar.theta" in out


ALL_SCENES = ["andrews", "slider_crank", "flexible_slider_crank", "spin_up", "pendulum", "singular_slider_crank",
              "bead_attractor", "double_pendulum", "force_pulse", "fourbar_driven", "spring_pendulum",
              "two_bar_pendulum"]


@pytest.mark.parametrize("name", ALL_SCENES)
def test_scene_parameters_and_outputs_are_all_described(name):
    """PARAMETERS describes exactly build()'s parameters, OUTPUTS exactly outputs()'s names."""
    mod = importlib.import_module(registry.scene_module(name))
    scene = registry.Scene(name, mod, mod.__name__)
    assert scene.undocumented() == ([], [])
    for table in (mod.PARAMETERS, mod.OUTPUTS):
        for key, (meaning, unit) in table.items():
            assert meaning.strip() and unit.strip(), (name, key)
    kw = {"n_elements": 2} if "n_elements" in scene.parameters() else {}
    h = mod.DEFAULTS["h"]
    res = femb.simulate(scene.model(**kw), t_end=2 * h, h=h, rho_inf=0.7)
    assert list(scene.outputs(res)) == list(mod.OUTPUTS)


@pytest.mark.parametrize("argv", [["--help"], ["run", "--help"], ["list", "--help"],
                                  ["bench", "--help"], ["bench", "convergence", "--help"],
                                  ["bench", "figures", "--help"]])
def test_help_says_what_each_command_does(argv, capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(argv)
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert "usage: femb" in out and len(out.splitlines()) > 4


def test_bench_help_names_the_suite_and_its_subcommands(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["bench", "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert "--quick" in out and "--out" in out and "convergence" in out and "figures" in out


# ------------------------------------------------------------------ run
def test_run_json_contract(tmp_path, capsys):
    path = tmp_path / "run.json"
    assert cli.main(["run", "slider_crank", "--t-end", "0.05", "--h", "5e-3", "--set", "T=2",
                     "--json", str(path)]) == 0
    data = json.loads(path.read_text())
    assert RUN_KEYS <= set(data)
    assert data["scene"] == "slider_crank" and data["steps"] == 10
    assert data["t_end"] == pytest.approx(0.05) and data["h"] == pytest.approx(5e-3)
    assert data["rho_inf"] == 0.7 and data["scaling"] is True
    # every parameter, defaults included, with value and unit; femb's version and the solver settings
    assert data["params"]["T"] == {"value": 2, "unit": "N m", "given": True}
    info = registry.load("slider_crank").parameter_info()
    assert list(data["params"]) == list(info)
    for k, (default, _, unit) in info.items():
        assert data["params"][k]["unit"] == unit and (k == "T" or data["params"][k]["given"] is False)
    assert data["femb_version"] == femb.__version__
    assert data["settings"]["h"] == pytest.approx(5e-3) and data["settings"]["rho_inf"] == 0.7
    assert data["settings"]["formulation"] == "index3" and "newton_rtol" in data["settings"]
    assert data["output_units"]["theta"] == "rad"
    assert {"theta", "x3", "x4", "R_pivot_x", "R_pivot_y"} <= set(data["outputs"])
    assert all(isinstance(v, float) for v in data["outputs"].values())
    assert "theta" in capsys.readouterr().out


def test_run_json_to_stdout_and_options(capsys):
    assert cli.main(["run", "slider_crank", "--t-end", "0.05", "--rho-inf", "0.5", "--no-scaling",
                     "--h", "1e-3", "--json", "-"]) == 0
    data = json.loads(capsys.readouterr().out)      # nothing but the JSON on stdout
    assert data["scaling"] is False and data["rho_inf"] == 0.5 and data["steps"] == 50


def test_run_andrews_outputs(capsys):
    assert cli.main(["run", "andrews", "--t-end", "3e-3", "--json", "-"]) == 0
    data = json.loads(capsys.readouterr().out)
    names = ["beta", "Theta", "gamma", "Phi", "delta", "Omega", "epsilon"]
    assert set(names + [n + "_d" for n in names] + [f"lambda_{k}" for k in range(1, 7)]) <= set(data["outputs"])


def test_run_scene_file_with_set(tmp_path, capsys):
    p = tmp_path / "pend.py"
    p.write_text(SCENE_FILE)
    out = tmp_path / "o.json"
    assert cli.main(["run", str(p), "--t-end", "0.1", "--h", "1e-3", "--set", "length=1", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["scene"] == "pend" and data["params"]["length"] == {"value": 1, "unit": "", "given": True}
    assert "bar.theta" in data["outputs"]         # no outputs(): the free coordinates
    # no DEFAULTS in the file: t_end and h are required
    capsys.readouterr()
    assert cli.main(["run", str(p)]) == 2
    assert "--t-end" in _err_line(capsys)


@pytest.mark.parametrize("argv, words", [
    (["run", "no_such_scene"], "unknown scene"),
    (["run", "andrews", "--h", "-1"], "positive"),
    (["run", "andrews", "--h", "abc"], "number"),
    (["run", "andrews", "--rho-inf", "2"], "[0, 1]"),
    (["run", "andrews", "--set", "nope=1"], "no parameter 'nope'"),
    (["run", "andrews", "--set", "mom"], "NAME=VALUE"),
    (["run", "andrews", "--frobnicate"], "unrecognized"),
    (["run"], "required"),
    (["run", "slider_crank", "--set", "l1=0.9"], "l2 > l1"),
    (["run", "slider_crank", "--every", "3"], "--vtk"),
    (["run", "/nonexistent/scene.py"], "does not exist"),
    (["bench", "convergence", "andrews", "--h", "0"], "positive"),
    (["bench", "figures", "andrews"], "--out"),
    (["frobnicate"], "invalid choice"),
])
def test_bad_arguments_give_one_line_and_exit_2(argv, words, capsys):
    assert cli.main(argv) == 2
    assert words in _err_line(capsys)


def test_simulation_failure_exits_1(capsys):
    # Newton fails for h ≥ 1.5e-3 s around t = 0.012 s on Andrews (docs/benchmarks.md §2)
    assert cli.main(["run", "andrews", "--h", "3e-3"]) == 1
    assert "t = 0.01" in _err_line(capsys)


def test_vtk_hook_missing_is_a_clean_error(monkeypatch, tmp_path, capsys):
    monkeypatch.setattr(cli, "VTK_HOOK", ("femb.io", "no_such_writer"))
    assert cli.main(["run", "slider_crank", "--t-end", "0.01", "--vtk", str(tmp_path / "v")]) == 2
    assert "--vtk" in _err_line(capsys)


def test_vtk_stream_writes_frames(tmp_path):
    import femb.io

    d = tmp_path / "vtk"
    assert cli.main(["run", "slider_crank", "--t-end", "0.02", "--vtk", str(d), "--every", "2",
                     "--progress", "off"]) == 0
    frames = femb.io.read_pvd(d / "frame.pvd")
    assert [round(t, 12) for t, _ in frames] == [0.0, 0.01, 0.02]    # h = 5e-3, every 2nd step


# ------------------------------------------------------------------ bench
def test_bench_convergence_json_and_plot(tmp_path, capsys):
    js, png = tmp_path / "c.json", tmp_path / "c.png"
    assert cli.main(["bench", "convergence", "slider_crank", "--h", "2e-3", "1e-3", "5e-4",
                     "--json", str(js), "--plot", str(png)]) == 0
    data = json.loads(js.read_text())
    assert CONV_KEYS <= set(data)
    assert data["h"] == [2e-3, 1e-3, 5e-4] and len(data["error_q"]) == 3
    assert data["order_q"] > 1.8 and data["order_lambda"] > 1.8
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "fitted order" in capsys.readouterr().out


def test_bench_figures_slider_crank(tmp_path, capsys):
    assert cli.main(["bench", "figures", "slider_crank", "--out", str(tmp_path), "--h", "2e-3", "1e-3"]) == 0
    names = sorted(p.name for p in tmp_path.iterdir())
    assert "slider_crank_fig2_theta_x4.png" in names
    assert "slider_crank_fig3_convergence.png" in names
    assert "slider_crank_convergence.json" in names


# ------------------------------------------------------------------ console script
def test_console_script():
    exe = shutil.which("femb")
    cmd = [exe] if exe else [sys.executable, "-m", "femb.console.cli"]
    r = subprocess.run(cmd + ["--help"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and "run" in r.stdout and "bench" in r.stdout
    r = subprocess.run(cmd + ["run", "andrews", "--h", "x"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1


def test_run_with_the_index2_formulation(tmp_path):
    """``femb run --formulation index2`` runs the stabilized index-2 step and says so in the JSON."""
    out = tmp_path / "run.json"
    assert cli.main(["run", "pendulum", "--t-end", "0.05", "--formulation", "index2", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["formulation"] == "index2" and data["steps"] > 0
