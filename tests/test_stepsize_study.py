"""The step-size study library (femb.benchmarks.accuracy.stepsize_study) on data with known answers.

The studies take a ``run`` callable; here it is replaced by one that returns
the scene's reference plus a known error, so the fitted orders, the log–log
interpolation and the error measures are checked independently of femb's
integrator (tests/test_stepsize.py holds the integrator's targets).
"""
import math
from types import SimpleNamespace

import numpy as np
import pytest

from femb.benchmarks.accuracy import stepsize_study as S
from femb.study import registry


def fake_run(order, c=1.0, transient=True):
    """A run callable whose outputs are the reference plus c·hᵒʳᵈᵉʳ (as a start transient, or uniform)."""
    def run(scene, *, t_end=None, h=None, rho_inf=None, params=None, **options):
        sc = registry.load(scene)
        t = np.linspace(0.0, t_end, int(round(t_end / h)) + 1)
        ref = sc.reference(t, **(params or {}))
        bump = c * h ** order * (np.exp(-t / (2 * h)) if transient else np.ones_like(t))
        outs = {k: np.asarray(v) + bump for k, v in ref.items() if k != "description"}
        res = SimpleNamespace(t=t, status="success", steps=t.size - 1)
        return S.Run(sc, res, outs, wall=1e-3 * t.size, steps=t.size - 1, options={"params": params or {}})
    return run


@pytest.mark.parametrize("order", [1.0, 2.0])
def test_reaction_order_recovers_the_order_of_a_start_transient(order):
    res = S.reaction_order("double_pendulum", hs=(4e-3, 2e-3, 1e-3), t_end=0.05, run=fake_run(order))
    assert res["order"] == pytest.approx(order, abs=1e-9)
    # the transient has died out at t_end: the end error is far below the peak
    assert all(r["end_err"] < 1e-2 * r["max_err"] for r in res["rows"])
    assert all(r["t_of_max"] == 0.0 for r in res["rows"])


def test_fixed_to_target_interpolates_in_log_log():
    res = S.fixed_to_target("spring_pendulum", [2e-4], ["phi1"], hs=[4e-2, 2e-2, 1e-2], t_end=0.2,
                            run=fake_run(2.0, transient=False))
    # err = h², N = 0.2/h, so err = 0.04/N²: 2e-4 at N = √200
    assert res["at_target"][2e-4]["steps"] == pytest.approx(math.sqrt(200.0), rel=1e-9)
    assert res["at_target"][2e-4]["wall"] == pytest.approx(1e-3 * (math.sqrt(200.0) + 1), rel=0.05)
    assert [p["steps"] for p in res["points"]] == [5, 10, 20]


def test_loglog_interpolate_and_fit_order():
    x = np.array([10.0, 100.0, 1000.0])
    y = 3.0 * x ** -2.0
    assert S.loglog_interpolate(x, y, 3.0e-4) == pytest.approx(100.0)
    assert S.loglog_interpolate(x, y, 3.0 * 316.0 ** -2) == pytest.approx(316.0)
    assert math.isnan(S.loglog_interpolate(x, y, 1e-12))          # never reached
    assert S.loglog_interpolate(x, y, 1.0) == 10.0                # reached by the cheapest run
    assert S.fit_order(x, y) == pytest.approx(-2.0)
    assert math.isnan(S.fit_order([1.0], [1.0]))


def test_max_error_at_end_or_over_the_run():
    run = fake_run(1.0, c=1.0)
    r = run("double_pendulum", t_end=0.05, h=1e-3)
    assert S.max_error(r, ["phi1"]) == pytest.approx(1e-3, rel=1e-9)
    assert S.max_error(r, ["phi1"], at="end") == pytest.approx(1e-3 * math.exp(-25.0), rel=1e-6)
    with pytest.raises(ValueError, match="at must be"):
        S.max_error(r, ["phi1"], at="middle")


def test_require_names_what_simulate_lacks():
    with pytest.raises(S.StepControlUnavailable, match="no_such_keyword"):
        S.require("no_such_keyword")
    S.require("rho_inf")     # declared today and later


def test_format_helpers_produce_markdown_tables():
    res = S.reaction_order("double_pendulum", hs=(4e-3, 2e-3), t_end=0.02, run=fake_run(1.0))
    text = S.format_reaction_order(res)
    assert "order 1.00" in text and text.count("\n|") >= 4


def test_fixed_cost_below_the_ladder_is_extrapolated_along_the_power_law():
    res = S.fixed_to_target("spring_pendulum", [1e-6], ["phi1"], hs=[4e-2, 2e-2], t_end=0.2,
                            run=fake_run(2.0, transient=False), extrapolate=True)
    row = res["at_target"][1e-6]
    assert row["extrapolated"] and row["steps"] == pytest.approx(200.0, rel=1e-9)   # h = 1e-3
    plain = S.fixed_to_target("spring_pendulum", [1e-6], ["phi1"], hs=[4e-2, 2e-2], t_end=0.2,
                              run=fake_run(2.0, transient=False))
    assert math.isnan(plain["at_target"][1e-6]["steps"])
