"""The benchmark suite end to end: every part at quick size writes a complete report.

One run of every part at quick size (``--quick --only`` all parts: several
minutes on 2 cores) is shared by the checks below: every registry scene has its
work–precision study, every stress test its criteria with a verdict, the headline
its ratios, and every figure the report embeds exists. What ``femb bench --quick``
alone runs (a smaller set, about a minute) is checked through :func:`suite.plan`. Cheap unit checks of the suite's pieces and of its two stress scenes
(pendulum, isosceles slider–crank) against their closed-form references follow.
"""
import json
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import femb
from femb.benchmarks import peers
from femb.benchmarks.runners import adaptive_suite, stress, suite, work_precision
from femb.benchmarks.scenes.planar import pendulum, singular_slider_crank
from femb.study import registry

VERDICTS = {"PASS", "FAIL", "FINDING"}


def _cli_has_bench_suite():
    """True once ``femb bench`` accepts the suite's options (the command line wires it to suite.main)."""
    from femb.console import cli

    parser = cli.build_parser()
    for action in parser._actions:
        choices = getattr(action, "choices", None)
        if isinstance(choices, dict) and "bench" in choices:
            return any("--quick" in a.option_strings for a in choices["bench"]._actions)
    return False


@pytest.fixture(scope="module")
def quick_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench") / "report"
    # the child process imports femb.elements / femb.benchmarks as this process does (conftest.py: from
    # this checkout when femb is this checkout's, e.g. a worktree on PYTHONPATH beside an editable install)
    boot = (f"import sys; sys.path.insert(0, {str(Path(__file__).resolve().parent)!r}); import conftest; "
            "sys.argv[0] = 'femb'; ")
    # every part at quick size (femb bench --quick alone runs the smaller set of suite.plan)
    cmd = [sys.executable, "-c", boot + "from femb.benchmarks.runners.suite import main; sys.exit(main(sys.argv[1:]))",
           "--quick", "--out", str(out), "--only", ",".join(suite.PARTS)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    results = json.loads((out / "results.json").read_text())
    report = (out / "report.md").read_text()
    return out, results, report, proc


def test_quick_run_writes_report_json_and_figures(quick_report):
    out, results, report, proc = quick_report
    assert results["suite"]["mode"] == "quick"
    assert "femb bench --quick" in report or "femb.benchmarks.runners.suite --quick" in report
    assert "femb bench [" in proc.stderr               # progress was shown while running
    figures = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", report)
    assert len(figures) >= len(registry.names()) + len(stress.TESTS)
    for name in figures:
        data = (out / name).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n", name


def test_report_has_every_registry_scene(quick_report):
    _, results, report, _ = quick_report
    for name in registry.names():
        wp = results["work_precision"][name]
        assert "error" not in wp, wp.get("error")
        assert f"### {name}" in report
        series = wp["femb"]
        assert series and all(s["points"] for s in series)
        ok = [p for s in series for p in s["points"] if p.get("failed") is None]
        assert ok, f"{name}: no femb run succeeded"
        for p in ok:
            assert p["wall_s"] > 0
            assert p["errors"]["positions"]["final_rel"] is not None
        assert {s["rho_inf"] for s in series} >= {0.7}
        assert {s["scaling"] for s in series} == {True, False}
        # peers: measured, or a row that says why not
        for peer in ("scipy", "exudyn"):
            st = wp[peer]["status"]
            assert wp[peer]["series"] or st in ("not installed", "no Exudyn model of this scene",
                                                  "no minimal-coordinate peer model for this scene")


def test_report_has_every_stress_test_with_verdicts(quick_report):
    _, results, report, _ = quick_report
    assert set(results["stress"]) == set(stress.TESTS)
    n_rows = 0
    for tid, r in results["stress"].items():
        assert r["criteria"], tid
        assert f'<a id="stress-{tid.replace("_", "-")}"></a>' in report
        for c in r["criteria"]:
            assert c["verdict"] in VERDICTS
            assert c["criterion"] and c["measured"]
            if c["verdict"] == "FINDING":
                assert c.get("finding"), c
        n_rows += len(r["criteria"])
    verdict_cells = re.findall(r"\| \*\*(PASS|FAIL|FINDING)\*\* \|$", report, flags=re.M)
    assert len(verdict_cells) == n_rows
    counts = results["verdicts"]
    assert sum(counts.values()) == n_rows


def test_no_unexplained_failures(quick_report):
    """A FAIL is a criterion missed for no measured reason: a regression to look at."""
    _, results, _, _ = quick_report
    fails = [(tid, c["criterion"], c["measured"]) for tid, r in results["stress"].items()
             for c in r["criteria"] if c["verdict"] == "FAIL"]
    assert not fails, fails


def test_headline_ratios(quick_report):
    _, results, report, _ = quick_report
    hl = results["headline"]
    assert "error" not in hl, hl.get("error")
    fe = hl["codes"][0]
    assert fe["code"] == "femb" and fe["reached"] and fe["error"] <= 1e-6
    codes = {c["code"] for c in hl["codes"]}
    assert {f"scipy {m}" for m in peers.SCIPY_METHODS} <= codes
    assert "Exudyn" in codes
    for c in hl["codes"][1:]:
        if c.get("reached"):
            assert hl["ratios"][c["code"]] > 0
    if not peers.status()["exudyn"]["installed"]:
        assert "not installed" in report
    assert "Headline: time to 1e-6 rad" in report


def test_spatial_per_step(quick_report):
    """The chain's ms/step of femb (and Exudyn, when installed) and the ratio are in results and report."""
    _, results, report, _ = quick_report
    sp = results["spatial_per_step"]
    assert "error" not in sp, sp.get("error")
    assert sp["n"] == suite.SPATIAL_PER_STEP["quick"][0] and len(sp["femb_runs"]) == suite.SPATIAL_RUNS
    assert sp["femb_ms"] > 0
    assert "Spatial per step" in report and "## Spatial per step" in report
    if peers.status()["exudyn"]["installed"]:
        assert sp["exudyn_ms"] > 0 and sp["ratio"] == pytest.approx(sp["femb_ms"] / sp["exudyn_ms"])
    else:
        assert sp["ratio"] is None and "not installed" in report


def test_work_precision_has_adaptive_series(quick_report):
    """Every scene's work–precision study has the adaptive ladder beside the fixed steps, with its figure."""
    out, results, report, _ = quick_report
    for name in registry.names():
        wp = results["work_precision"][name]
        ad = wp["adaptive"]
        assert "error" not in ad, (name, ad.get("error"))
        assert [p["rtol"] for p in ad["points"]] == adaptive_suite.RTOLS["quick"]
        ok = [p for p in ad["points"] if p.get("failed") is None]
        assert ok, f"{name}: no adaptive run succeeded"
        for p in ok:
            assert p["wall_s"] > 0 and p["steps"] == p["accepted"] + p["rejected"] > 0
            assert p["errors"]["positions"]["max_rel"] is not None
        if wp["mode"] == "outputs" and len(ok) == len(ad["points"]) and ok[-1]["steps"] > ok[0]["steps"]:
            # against an independent reference, a tighter tolerance that takes more steps gives a smaller
            # position error (a quick-mode window can be so short that both tolerances take the same steps)
            e = [p["errors"]["positions"]["max_rel"] for p in ok]
            assert e[-1] < e[0], (name, e)
        assert wp["figure_adaptive"] == f"wp_adaptive_{name}.png"
        assert f"![fixed vs adaptive {name}](wp_adaptive_{name}.png)" in report
        assert (out / wp["figure_adaptive"]).read_bytes()[:4] == b"\x89PNG"


def test_andrews_adaptive_against_fixed(quick_report):
    """The largest rtol found meets 1e-6 rad, the next looser one tried does not; both runs are in the report."""
    _, results, report, _ = quick_report
    ha = results["headline"]["adaptive"]
    assert "error" not in ha, ha.get("error")
    ad, fx = ha["adaptive"], ha["fixed"]
    assert ad["reached"] and ad["error"] <= 1e-6
    assert fx["reached"] and fx["error"] <= 1e-6
    misses = [r for r in ad["tried"] if r["rtol"] > ad["rtol"]]
    assert misses and all(r.get("error") is None or r["error"] > 1e-6 for r in misses)
    assert min(r["rtol"] for r in misses) / ad["rtol"] < 10 ** 0.1       # bisected to 1/32 decade
    assert ha["steps_ratio"] == pytest.approx(ad["steps"] / fx["steps"])
    for run in (ad, fx):
        assert len(run["wall_runs"]) == 3 and run["wall_s"] == pytest.approx(sorted(run["wall_runs"])[1])
    assert set(ha["goals"]) == {"steps_ratio", "wall_s"}
    assert "### Adaptive against fixed steps (femb)" in report


def test_adaptive_stress_tests_in_report(quick_report):
    _, results, _, _ = quick_report
    assert set(adaptive_suite.TESTS) <= set(results["stress"])
    tp = results["stress"]["tolerance_proportionality"]["data"]
    assert set(tp) == set(adaptive_suite.PROPORTIONALITY_SCENES)
    for d in tp.values():
        assert d["slope_err"] is not None and d["slope_steps"] is not None
    ctrl = results["stress"]["lambda_spikes"]["data"]["control"]
    assert ctrl["seed"]["share"] > ctrl["consistent"]["share"]
    only = results["stress"]["adaptive_only"]["criteria"]
    assert only[0]["verdict"] == "PASS"       # the adaptive run gets through


# --------------------------------------------------------------------------
# cheap checks of the pieces
# --------------------------------------------------------------------------
def test_period2_amplitude_sees_an_alternating_kick_not_a_smooth_error():
    n = np.arange(200)
    smooth = 1e-3 * np.sin(0.05 * n)
    assert adaptive_suite.period2_amplitude(smooth) < 1e-3 * 1e-4
    kick = np.where(n >= 100, (-0.9) ** (n - 100) * (n - 100 + 1.0) ** 2, 0.0) * 1e-4
    amp = adaptive_suite.period2_amplitude(np.column_stack([smooth, smooth + kick]))
    assert amp > 0.5 * np.abs(kick).max()


def test_step_change_windows():
    h = np.array([1.0] * 20 + [0.5] * 20)             # one change at step 20 (h x 0.5)
    err = np.ones(41)
    err[21:31] = 7.0                                   # after the change
    w = adaptive_suite.step_change_windows(h, err, ratio=1.3, window=10)
    assert [x["n"] for x in w] == [20]
    assert w[0]["h_ratio"] == pytest.approx(0.5) and w[0]["after_over_before"] == pytest.approx(7.0)
    assert adaptive_suite.step_change_windows(np.ones(40), err) == []



def test_quick_plan_is_the_small_set_and_only_widens_it():
    parts, scenes = suite.plan(quick=True)
    assert parts == list(suite.QUICK_PARTS) and scenes == list(suite.QUICK_SCENES)
    assert set(parts) < set(suite.PARTS) and set(scenes) <= set(registry.names())
    assert suite.plan(quick=False) == (list(suite.PARTS), registry.names())
    assert suite.plan(quick=True, only=["work_precision"]) == (["work_precision"], registry.names())
    assert suite.plan(quick=True, only=["headline"]) == (["headline"], ["andrews"])
    assert _cli_has_bench_suite()


def test_main_rejects_unknown_part(tmp_path, capsys):
    assert suite.main(["--only", "nonsense", "--out", str(tmp_path), "--quiet"]) == 2
    assert "unknown part" in capsys.readouterr().err


def test_errors_max_norm_definitions():
    ts = np.linspace(0.0, 1.0, 3)
    case = work_precision.Case(scene=None, t_end=1.0, n_samples=2, n_list=[2], mode="outputs",
                               groups={"positions": ["a", "b"], "velocities": [], "multipliers": ["c"]},
                               reference={"a": np.array([1.0, 2.0, 4.0]), "b": np.array([0.0, 0.0, -1.0]),
                                          "c": np.array([1.0, 1.0, 1.0])}, reference_description="")
    outs = {"a": np.array([1.0, 2.5, 4.1]), "b": np.array([0.0, 0.0, -1.3]), "c": np.array([1.0, 1.0, 1.0])}
    e = work_precision.errors(case, outs)
    assert e["positions"]["final_abs"] == pytest.approx(0.3)
    assert e["positions"]["final_rel"] == pytest.approx(0.3 / 4.0)
    assert e["positions"]["max_abs"] == pytest.approx(0.5)
    assert e["positions"]["max_rel"] == pytest.approx(0.5 / 4.0)
    assert e["velocities"]["final_abs"] is None
    assert e["multipliers"]["max_abs"] == 0.0
    assert ts.size == 3


def test_peer_status_never_raises():
    st = peers.status()
    assert st["scipy"]["installed"]
    assert set(st["exudyn"]) == {"installed", "version"}
    if not st["exudyn"]["installed"]:
        r = peers.exudyn_solve("andrews", 0.03, 100, 0.7, 20)
        assert not r["ok"] and r["message"] == "not installed"


def test_pendulum_scene_second_order_against_elliptic_solution():
    model = pendulum.build().compile()
    errs = []
    for h in (2e-3, 1e-3):
        r = femb.simulate(model, 1.0, h, stride=int(round(0.1 / h)))
        o, ref = pendulum.outputs(r), pendulum.reference(r.t)
        errs.append(np.abs(o["psi"] - ref["psi"]).max())
        np.testing.assert_allclose(o["R_pivot_y"], ref["R_pivot_y"], atol=2e-2)
    assert errs[1] < 2e-4
    assert math.log2(errs[0] / errs[1]) > 1.8
    E = pendulum.energy(r)
    assert np.abs(E - E[0]).max() < 1e-4 * pendulum.energy_scale()


def test_singular_slider_crank_scene_through_the_singular_position():
    model = singular_slider_crank.build().compile()
    r = femb.simulate(model, 0.6, 1e-3, stride=50)       # passes θ = π/2 at t ≈ 0.44 s
    o, ref = singular_slider_crank.outputs(r), singular_slider_crank.reference(r.t)
    assert o["theta"][-1] > math.pi / 2
    assert np.abs(o["branch"]).max() < 1e-9
    assert np.abs(o["theta"] - ref["theta"]).max() < 1e-3
    m = singular_slider_crank.generalized_mass(np.array([0.3]))
    assert m[0] > 0
