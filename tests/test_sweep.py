"""femb.sweep and `femb sweep`: designs, equality with serial runs, failures as rows, lost workers,
streaming and resume, command-line errors. One two-worker LocalCluster (processes) for the module."""
import os
import signal
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("dask.distributed")
pytest.importorskip("pandas")
pytest.importorskip("pyarrow")

import femb  # noqa: E402
from femb.errors import ParameterError  # noqa: E402
from femb.study import registry  # noqa: E402
from femb.study.sweep import (
    full_factorial, make_design, parse_grid_spec, parse_range_spec, read_results, sample_design)

T_END = 0.03          # 6 steps of the slider-crank's h = 5e-3: each case takes milliseconds
H = 5e-3


@pytest.fixture(scope="module")
def client():
    yield from _local_client()


def _local_client():
    from dask.distributed import Client, LocalCluster

    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                           dashboard_address=":0", silence_logs=40)
    c = Client(cluster)
    yield c
    c.close()
    cluster.close()


@pytest.fixture
def own_client():
    """A cluster of its own: after the module's cluster was restarted and had workers killed by
    earlier tests, its nannies did not bring a killed worker back (seen twice in whole-file runs)."""
    yield from _local_client()


#: seconds a killed worker's nanny may take to bring a new worker up, so that the next test finds
#: two workers: a new worker process imports numpy, numba and femb, which took more than 60 s on a
#: 2-core machine with another test worker and a docs build running (a wait, not a tolerance).
WORKER_RESTART_TIMEOUT = 300


def serial(params, rho_inf=0.7, t_end=T_END, **solver):
    """Reference: the same case run directly in this process."""
    scene = registry.load("slider_crank")
    result = femb.simulate(scene.model(**params), t_end, H, rho_inf=rho_inf, **solver)
    return result, scene.outputs(result)


# --------------------------------------------------------------------------- designs (no cluster)
def test_full_factorial_order_and_errors():
    cases = full_factorial({"k": [1.0, 2.0, 3.0], "rho_inf": [0.5, 0.9]})
    assert len(cases) == 6
    assert cases[0] == {"k": 1.0, "rho_inf": 0.5} and cases[1] == {"k": 1.0, "rho_inf": 0.9}
    with pytest.raises(ParameterError, match="grid 'k': no values"):
        full_factorial({"k": []})
    with pytest.raises(ParameterError, match="appears twice"):
        full_factorial({"k": [1.0, 1.0]})
    with pytest.raises(ParameterError, match="list of values"):
        full_factorial({"k": 3.0})


def test_samples_are_seeded_and_latin():
    ranges = {"k": (1e3, 1e5, "log"), "m4": (0.5, 1.0)}
    a = sample_design(ranges, 10, "lhs", seed=3)
    b = sample_design(ranges, 10, "lhs", seed=3)
    c = sample_design(ranges, 10, "lhs", seed=4)
    assert a == b and a != c
    # Latin hypercube: exactly one sample in each of the 10 strata of every coordinate
    m4 = np.array([s["m4"] for s in a])
    assert sorted(np.floor((m4 - 0.5) / 0.05).astype(int)) == list(range(10))
    logk = np.log10([s["k"] for s in a])
    assert sorted(np.floor((logk - 3.0) / 0.2).astype(int)) == list(range(10))
    r = sample_design(ranges, 50, "random", seed=1)
    assert all(1e3 <= s["k"] <= 1e5 and 0.5 <= s["m4"] <= 1.0 for s in r)
    with pytest.raises(ParameterError, match="range 'k'"):
        sample_design({"k": (0.0, 1.0, "log")}, 5)


def test_make_design_product_and_errors():
    d = make_design(grid={"rho_inf": [0.5, 0.9]}, cases=[{"k": 1000}, {"k": 2000.5}])
    assert len(d) == 4 and all(isinstance(c["k"], float) for c in d)
    with pytest.raises(ParameterError, match="two designs"):
        make_design(grid={"k": [1.0]}, cases=[{"k": 2.0}])
    with pytest.raises(ParameterError, match="no cases"):
        make_design()


@pytest.mark.parametrize("spec, message", [
    ("k", "NAME=V1,V2"), ("k=", "no values"), ("k=1,,2", "empty value"), ("k=1:2", "LO:HI:N"),
    ("k=1:2:x", "integer"), ("k=1:10:3:lin", "LO:HI:N:log"), ("k=0:1:3:log", "positive"),
    ("k=1,1", "twice"), ("2k=1,2", "NAME=V1,V2"),
])
def test_bad_grid_specs(spec, message):
    with pytest.raises(ParameterError, match=message):
        parse_grid_spec(spec)


def test_grid_and_range_specs():
    assert parse_grid_spec("k=1e3,1e4") == ("k", [1000.0, 10000.0])
    name, vals = parse_grid_spec("k=1e3:1e5:3:log")
    assert name == "k" and np.allclose(vals, [1e3, 1e4, 1e5])
    assert parse_grid_spec("scaling=True,False") == ("scaling", [True, False])
    assert parse_range_spec("k=1:2:log") == ("k", (1.0, 2.0, "log"))
    with pytest.raises(ParameterError, match="low < high"):
        parse_range_spec("k=2:1")


def test_femb_import_is_light_and_sweep_is_lazy():
    code = ("import sys, femb; assert 'dask' not in sys.modules and 'pandas' not in sys.modules; "
            "import femb.study.sweep; assert callable(femb.sweep); from femb import sweep; "
            "assert callable(sweep); assert 'dask' not in sys.modules")
    subprocess.run([sys.executable, "-c", code], check=True)


# --------------------------------------------------------------------------- on the cluster
def test_sweep_equals_serial_runs(client):
    grid = {"k": [1e3, 1e5], "rho_inf": [0.5, 0.9]}
    df = femb.sweep("slider_crank", grid=grid, t_end=T_END, h=H, t_eval=[0.01, 0.0125],
                    client=client, batch_size=1)
    assert len(df) == 4 and df["case_id"].is_unique and list(df["case"]) == [0, 1, 2, 3]
    assert (df["status"] == "success").all()
    for r in df.to_dict("records"):
        result, outs = serial({"k": r["k"]}, rho_inf=r["rho_inf"])
        for name, arr in outs.items():
            assert r[name] == arr[-1], name                     # bit-identical to a serial run
        theta = outs["theta"]
        assert r["theta@0.01"] == theta[2]                      # on the step grid: exact
        assert r["theta@0.0125"] == pytest.approx(0.5 * (theta[2] + theta[3]), rel=1e-15)
        assert r["steps"] == result.steps == 6
        assert r["newton_iterations"] == int(result.newton_iterations.sum())
        assert r["t_end"] == T_END and r["h"] == H
        assert r["wall_time"] > 0 and r["worker"].startswith("tcp://")
    # the table's record: femb's version, the run settings, every parameter with value and unit
    a = df.attrs
    assert a["femb_version"] == femb.__version__
    assert a["settings"]["h"] == H and a["settings"]["t_end"] == T_END
    info = registry.load("slider_crank").parameter_info()
    assert set(a["params"]) == set(info)          # rho_inf (varied) is a run setting, in the rows
    assert a["params"]["k"] == {"value": None, "unit": info["k"][2], "given": True, "varied": True}
    assert a["params"]["T"] == {"value": info["T"][0], "unit": "N m", "given": False}
    assert a["units"]["theta"] == "rad"


def test_contact_scene_sweeps_through_the_contact_scheme(client):
    """A model with contact elements runs in femb.contact.simulate, as `femb run` does (every case failed
    with the engine's ModelError before 2026-11-29): the rows equal serial runs, fixed and adaptive."""
    from femb.benchmarks.scenes.contact import contact_block
    from femb.contact import simulate

    cases = [{"mu": 0.1, "v0": 0.5}, {"mu": 0.5, "v0": 1.0}]
    for rtol in (None, 1e-6):
        df = femb.sweep("contact_block", cases=cases, t_end=0.5, h=1e-2, rtol=rtol, outputs=["s", "s_d"],
                        client=client)
        assert (df["status"] == "success").all(), list(df["message"])
        for r, c in zip(df.to_dict("records"), cases):
            model = contact_block.build(**c).compile()
            res = simulate(model, 0.5, 1e-2, rtol=rtol)
            assert r["s"] == contact_block.outputs(res)["s"][-1] and r["steps"] == res.steps
            ref = contact_block.reference([0.5], **c)["s"][-1]        # μ = 0.5 sticks at 0.56 s: still sliding
            assert abs(r["s"] - ref) < 1e-6
    # a case keeps its first and last states only (store=False) unless t_eval needs the history
    df = femb.sweep("contact_block", cases=cases[:1], t_end=0.5, h=1e-2, outputs=["s"], t_eval=[0.25],
                    client=client)
    res = simulate(contact_block.build(**cases[0]).compile(), 0.5, 1e-2)
    s = contact_block.outputs(res)["s"]
    row = df.to_dict("records")[0]
    assert row["s"] == s[-1] and row["s@0.25"] == float(np.interp(0.25, res.t, s))


def test_failing_cases_are_rows(client):
    cases = [{"l1": 0.3, "max_iter": 50}, {"l1": 0.7, "max_iter": 50}, {"l1": 0.3, "max_iter": 1}]
    df = femb.sweep("slider_crank", cases=cases, t_end=T_END, outputs=["theta"], client=client)
    assert list(df["status"]) == ["success", "failed", "failed"]
    bad_build, no_newton = df.iloc[1], df.iloc[2]
    assert bad_build["error"] == "ValueError" and "l2 > l1" in bad_build["message"]
    assert np.isnan(bad_build["theta"]) and bad_build["steps"] == 0
    assert no_newton["error"] == "ConvergenceError" and "did not converge" in no_newton["message"]
    assert df.iloc[0]["theta"] == serial({"l1": 0.3})[1]["theta"][-1]


def test_unknown_names_fail_fast(client):
    with pytest.raises(ParameterError, match="no parameter 'stiffness'"):
        femb.sweep("slider_crank", grid={"stiffness": [1.0, 2.0]}, client=client)
    with pytest.raises(ParameterError, match="unknown output"):
        femb.sweep("slider_crank", grid={"k": [1e3]}, t_end=T_END, outputs=["nope"], client=client)


def _worker_pids(client):
    return client.run(os.getpid)


def test_killed_worker_loses_and_duplicates_nothing(client):
    n = 16
    grid = {"k": list(np.linspace(1e3, 2e3, n))}
    killed = []

    def kill_a_busy_worker(done, total, rows):
        if killed:
            return
        pids = _worker_pids(client)
        busy = [w for w, keys in client.processing().items() if keys and w in pids]
        if busy:
            os.kill(pids[busy[0]], signal.SIGKILL)
            killed.append(busy[0])

    df = femb.sweep("slider_crank", grid=grid, t_end=0.1, h=H, outputs=["theta", "x4"],
                    client=client, batch_size=1, progress=kill_a_busy_worker)
    assert killed, "no worker was busy to be killed"
    assert len(df) == n and df["case_id"].is_unique and sorted(df["case"]) == list(range(n))
    assert (df["status"] == "success").all()
    for row in df.iloc[[0, n - 1]].itertuples():
        assert row.theta == serial({"k": row.k}, t_end=0.1)[1]["theta"][-1]
    client.wait_for_workers(2, timeout=WORKER_RESTART_TIMEOUT)


def test_client_restart_mid_sweep_loses_nothing(client):
    restarted = []

    def restart(done, total, rows):
        if not restarted:
            restarted.append(done)
            # the restart waits for both workers: up to WORKER_RESTART_TIMEOUT (dask's default, 120 s,
            # ran out on a loaded 2-core machine while the new worker processes imported femb)
            client.restart(timeout=WORKER_RESTART_TIMEOUT)

    df = femb.sweep("slider_crank", grid={"k": list(np.linspace(1e3, 2e3, 8))}, t_end=0.1,
                    outputs=["theta"], client=client, batch_size=1, progress=restart)
    assert restarted and len(df) == 8 and df["case_id"].is_unique and (df["status"] == "success").all()
    client.wait_for_workers(2, timeout=WORKER_RESTART_TIMEOUT)


def crashing_build(k=1e3, crash=False):
    """A build() whose process dies (as on a segmentation fault) when crash is set."""
    if crash:
        os._exit(3)
    return registry.load("slider_crank").module.build(k=k)


def test_case_that_kills_its_worker_becomes_a_row(own_client):
    client = own_client
    def set_allowed_failures(dask_scheduler, n):
        old = dask_scheduler.allowed_failures
        dask_scheduler.allowed_failures = n
        return old

    old = client.run_on_scheduler(set_allowed_failures, n=0)
    try:
        df = femb.sweep(crashing_build, cases=[{"k": 1e3, "crash": False}, {"k": 2e3, "crash": True},
                                                   {"k": 3e3, "crash": False}],
                        t_end=T_END, h=H, client=client, batch_size=1, max_attempts=1)
    finally:
        client.run_on_scheduler(set_allowed_failures, n=old)
    assert len(df) == 3 and list(df["case"]) == [0, 1, 2] and df["case_id"].is_unique
    assert df.iloc[1]["status"] == "failed" and df.iloc[1]["error"] == "KilledWorker"
    assert "worker" in df.iloc[1]["message"]
    # a batch queued on the dying worker may share its fate (allowed failures are 0 here)
    for i, k in ((0, 1e3), (2, 3e3)):
        row = df.iloc[i]
        if row["status"] == "success":
            assert row["crank.theta"] == serial({"k": k})[1]["theta"][-1]
        else:
            assert row["error"] == "KilledWorker"
    client.wait_for_workers(2, timeout=WORKER_RESTART_TIMEOUT)


def test_interrupt_then_resume(client, tmp_path):
    out = tmp_path / "res.parquet"
    grid = {"k": [1e3, 2e3, 3e3, 4e3, 5e3, 6e3]}

    def interrupt(done, total, rows):
        if done >= 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        femb.sweep("slider_crank", grid=grid, t_end=T_END, outputs=["theta"], client=client,
                   batch_size=1, out=out, progress=interrupt)
    kept = read_results(out)
    assert 2 <= len(kept) < 6 and kept["case_id"].is_unique
    with pytest.raises(ParameterError, match="already holds"):
        femb.sweep("slider_crank", grid=grid, t_end=T_END, outputs=["theta"], client=client, out=out)
    df = femb.sweep("slider_crank", grid=grid, t_end=T_END, outputs=["theta"], client=client,
                    batch_size=1, out=out, resume=True)
    assert df.attrs["n_new"] == 6 - len(kept)
    assert len(df) == 6 and df["case_id"].is_unique and (df["status"] == "success").all()
    on_disk = read_results(out)
    assert len(on_disk) == 6 and set(on_disk["case_id"]) == set(df["case_id"])
    # the design comes back with the rows: parameters are not taken for outputs
    from femb.study.sweep import output_columns, plot_results
    assert on_disk.attrs["parameters"] == ["k"] and on_disk.attrs["outputs"] == df.attrs["outputs"]
    for key in ("femb_version", "settings", "params", "units"):
        assert on_disk.attrs[key] == df.attrs[key], key
    assert output_columns(on_disk, on_disk.attrs["parameters"]) == output_columns(df, df.attrs["parameters"])
    assert "k" not in output_columns(on_disk)
    plot_results(on_disk, tmp_path / "plot.png")
    # kept rows are those of the first run, not recomputed
    merged = on_disk.set_index("case_id").loc[kept["case_id"], "wall_time"]
    assert np.array_equal(merged.to_numpy(), kept["wall_time"].to_numpy())
    # a larger grid resumes too: only the new value runs, rows take their place in the new design
    grid["k"].insert(0, 500.0)
    df2 = femb.sweep("slider_crank", grid=grid, t_end=T_END, outputs=["theta"], client=client,
                     out=out, resume=True)
    assert df2.attrs["n_new"] == 1 and len(df2) == 7
    assert list(df2["case"]) == list(range(7)) and list(df2["k"]) == grid["k"]


def test_scene_file_travels_as_source(client, tmp_path):
    scene = tmp_path / "my_crank.py"
    scene.write_text('"""A scene file of a user."""\n'
                     "from femb.benchmarks.scenes.planar.slider_crank import DEFAULTS, build, outputs  # noqa: F401\n")
    df = femb.sweep(str(scene), grid={"k": [1e3, 1e4]}, t_end=T_END, outputs=["theta"], client=client)
    assert (df["status"] == "success").all()
    assert df.iloc[1]["theta"] == serial({"k": 1e4})[1]["theta"][-1]


def test_trajectories_stay_in_files(client, tmp_path):
    df = femb.sweep("slider_crank", grid={"k": [1e3, 1e4]}, t_end=T_END, outputs=["theta"],
                    client=client, trajectories=tmp_path / "traj")
    for row in df.itertuples():
        data = np.load(row.trajectory)
        assert data["t"].shape == (7,) and data["out_theta"][-1] == row.theta


def test_local_cluster_workers_inherit_cache_dir(tmp_path):
    from femb.study.sweep import _open_client

    cl, owned = _open_client(None, 1, str(tmp_path))
    try:
        assert owned
        assert list(cl.run(lambda: os.environ.get("FEMB_CACHE_DIR")).values()) == [str(tmp_path)]
    finally:
        cluster = cl.cluster
        cl.close()
        cluster.close()


# --------------------------------------------------------------------------- command line
@pytest.mark.parametrize("argv, message", [
    (["--grid", "k"], "--grid expects NAME=V1,V2"),
    (["--grid", "k=1:2"], "LO:HI:N"),
    (["--grid", "k=1,2", "--grid", "k=3,4"], "given twice"),
    (["--grid", "stiffness=1,2"], "no parameter 'stiffness'"),
    (["--samples", "5"], "needs at least one --range"),
    (["--range", "k=1:2"], "--range needs --samples"),
    (["--range", "k=2:1", "--samples", "4"], "low < high"),
    ([], "give at least one --grid"),
])
def test_cli_bad_specs_one_line_exit_2(argv, message, tmp_path, capsys):
    from femb.console.cli import main

    rc = main(["sweep", "slider_crank", "--out", str(tmp_path / "o")] + argv)
    err = capsys.readouterr().err
    assert rc == 2
    assert err.count("\n") == 1 and err.startswith("femb: error:") and message in err


def test_cli_sweep_runs_and_plots(client, tmp_path, capsys):
    from femb.console.cli import main

    out, png = tmp_path / "r.parquet", tmp_path / "r.png"
    rc = main(["sweep", "slider_crank", "--grid", "k=1e3,1e4", "--grid", "rho_inf=0.5,0.9",
               "--t-end", str(T_END), "--outputs", "theta,x4", "--scheduler", client.scheduler.address,
               "--out", str(out), "--plot", str(png), "--progress", "off"])
    text = capsys.readouterr().out
    assert rc == 0, text
    assert "4 cases (4 run now, 0 resumed): 4 success" in text
    import pandas as pd

    df = pd.read_parquet(out)
    assert len(df) == 4 and set(df.columns) >= {"k", "rho_inf", "theta", "x4", "status", "case_id"}
    assert png.stat().st_size > 10_000
