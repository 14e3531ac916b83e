"""The benchmark suite end to end: ``femb bench --quick`` writes a complete report.

One quick run (about a minute on 2 cores) is shared by the checks below: every
registry scene has its work–precision study, every stress test its criteria
with a verdict, the headline its ratios, and every figure the report embeds
exists. Cheap unit checks of the suite's pieces and of its two stress scenes
(pendulum, isosceles slider–crank) against their closed-form references follow.
"""
import json
import math
import re
import subprocess
import sys

import numpy as np
import pytest

import femb
from femb.benchmarks import peers, pendulum, registry, singular_slider_crank, stress, suite, work_precision

VERDICTS = {"PASS", "FAIL", "FINDING"}


def _cli_has_bench_suite():
    """True once ``femb bench`` accepts the suite's options (the command line wires it to suite.main)."""
    from femb import cli

    parser = cli.build_parser()
    for action in parser._actions:
        choices = getattr(action, "choices", None)
        if isinstance(choices, dict) and "bench" in choices:
            return any("--quick" in a.option_strings for a in choices["bench"]._actions)
    return False


@pytest.fixture(scope="module")
def quick_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench") / "report"
    if _cli_has_bench_suite():
        cmd = [sys.executable, "-m", "femb.cli", "bench", "--quick", "--out", str(out)]
    else:   # until the command line forwards to the suite: the same entry point, called directly
        cmd = [sys.executable, "-m", "femb.benchmarks.suite", "--quick", "--out", str(out)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    results = json.loads((out / "results.json").read_text())
    report = (out / "report.md").read_text()
    return out, results, report, proc


def test_quick_run_writes_report_json_and_figures(quick_report):
    out, results, report, proc = quick_report
    assert results["suite"]["mode"] == "quick"
    assert "femb bench --quick" in report or "femb.benchmarks.suite --quick" in report
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


# --------------------------------------------------------------------------
# cheap checks of the pieces
# --------------------------------------------------------------------------
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
