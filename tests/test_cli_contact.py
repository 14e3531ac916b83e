"""The contact scenes on the command line: ``femb list``, ``femb run`` (femb.contact.simulate, fixed steps,
VTK after the run) and ``femb bench contact`` (the scene's validation), with the options that do not apply
refused by name."""
import json

import numpy as np
import pytest

import femb.contact
from femb.console import cli
from femb.study import registry


def _err_line(capsys):
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert err.startswith("femb: error:")
    return err


def test_list_shows_every_contact_scene(capsys):
    assert cli.main(["list"]) == 0
    out = capsys.readouterr().out
    assert "contact scenes ('femb run NAME'" in out
    for name in registry.contact_names():
        assert f"  {name}: " in out
    assert set(registry.contact_names()).isdisjoint(registry.names())      # not in the engine's studies


@pytest.mark.parametrize("name", sorted(registry.CONTACT_SCENES))
def test_contact_scenes_follow_the_scene_protocol(name):
    """PARAMETERS describes exactly build()'s parameters, OUTPUTS exactly outputs()'s names, after two steps."""
    scene = registry.load(name)
    assert scene.undocumented() == ([], [])
    mod = scene.module
    assert {"t_end", "h", "rho_inf"} <= set(mod.DEFAULTS)
    res = femb.contact.simulate(scene.model(), 2 * mod.DEFAULTS["h"], mod.DEFAULTS["h"]) \
        if name != "contact_painleve" else None
    if res is not None:
        assert list(scene.outputs(res)) == list(mod.OUTPUTS)


def test_run_contact_ball_outputs_json_and_vtk(tmp_path, capsys):
    out = tmp_path / "run.json"
    assert cli.main(["run", "contact_ball", "--t-end", "1.4", "--json", str(out), "--vtk", str(tmp_path / "vtk"),
                     "--dt", "0.1"]) == 0
    data = json.loads(out.read_text())
    assert data["scene"] == "contact_ball" and data["t_end"] == pytest.approx(1.4)
    assert data["outputs"]["lambda_N"] == pytest.approx(9.81, rel=1e-9)       # at rest after t∞ = 1.285 s
    frames = sorted((tmp_path / "vtk").glob("*.vtu"))
    assert 15 <= len(frames) <= 16                                           # one per 0.1 s (+ the last)
    import meshio
    mesh = meshio.read(frames[-1])
    assert "contact_force" in mesh.point_data
    F = np.asarray(mesh.point_data["contact_force"])
    assert np.abs(F).max() == pytest.approx(9.81, rel=1e-9)


def test_run_contact_ball_adaptive(tmp_path, capsys):
    """``--rtol`` runs the contact scene with adaptive steps (docs/contact.md §1.2): the ball's free flights
    have no error (constant acceleration), so the steps grow, and the impacts are located exactly."""
    out = tmp_path / "run.json"
    assert cli.main(["run", "contact_ball", "--t-end", "1.4", "--rtol", "1e-4", "--json", str(out),
                     "--vtk", str(tmp_path / "vtk"), "--dt", "0.1"]) == 0
    data = json.loads(out.read_text())
    assert data["adaptive"] and data["rtol"] == 1e-4 and data["t_end"] == pytest.approx(1.4)
    assert data["steps"] < 200            # (sub)steps; 700 fixed steps of the default h
    assert data["outputs"]["lambda_N"] == pytest.approx(9.81, rel=1e-9)
    assert sorted((tmp_path / "vtk").glob("*.vtu"))
    assert "adaptive steps (rtol = 0.0001" in capsys.readouterr().out


@pytest.mark.parametrize("argv, words", [
    (["run", "contact_ball", "--formulation", "index2"], "do not apply"),
    (["bench", "contact", "andrews"], "not a contact scene"),
])
def test_options_that_do_not_apply_are_refused(argv, words, capsys):
    assert cli.main(argv) == 2
    assert words in _err_line(capsys)


def test_run_painleve_stops_with_the_diagnosis(capsys):
    assert cli.main(["run", "contact_painleve"]) == 1
    err = capsys.readouterr().err
    assert "Painlevé" in err and "tip" in err


def test_bench_contact_prints_the_validation(capsys):
    """``femb bench contact`` runs the scene's validation: Painlevé's rod, diagnosed at μ = 5/3 and run
    where a solution exists."""
    assert cli.main(["bench", "contact", "contact_painleve"]) == 0
    out = capsys.readouterr().out
    assert "mu = 1.667, gap = 0: ContactError" in out and "Painlevé" in out
    assert "mu = 0.3, gap = 0: ran to t = 0.5 s" in out


def test_cache_build_compiles_the_contact_loop_that_every_contact_scene_runs_on(capsys):
    """``femb cache build`` ends with the contact time loop (one step of the bouncing ball); the loop
    has one signature, which scenes of other element types (spatial sphere, tippe top) use too."""
    from femb.base.jit import jit_disabled
    from femb.console.cli_cache import _build_contact_loop
    from femb.contact import loop
    if jit_disabled():
        pytest.skip("compiled code only")
    _build_contact_loop()
    assert capsys.readouterr().err.startswith("femb cache build: the contact time loop ")
    sigs = set(loop.run_steps.overloads)
    assert len(sigs) == 1
    for name in ("contact_sphere3d", "contact_tippetop"):
        mod = __import__(f"femb.benchmarks.scenes.contact.{name}", fromlist=["build"])
        femb.contact.simulate(mod.build().compile(), 4e-3, 2e-3)
        assert set(loop.run_steps.overloads) == sigs, name
