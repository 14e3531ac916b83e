"""Convergence with unresolved axial modes (docs/beams.md): femb.solve.diagnostics and the benchmark."""
import math

import numpy as np
import pytest

import femb
from femb import Mechanism
from femb.elements import PointMass, PointOnLine, SpringDamper


def test_numerical_decay_limits_and_monotone():
    from femb.solve.diagnostics import numerical_decay

    for rho in (0.5, 0.7, 0.9):
        assert numerical_decay(1e-4, rho) == pytest.approx(1.0, abs=1e-12)
        # the three roots meet at −ρ∞ (a triple root): the limit is approached like (hω)^(−2/3)
        assert numerical_decay(1e7, rho) == pytest.approx(rho, abs=1e-4)
        r = numerical_decay(np.logspace(-2, 3, 40), rho)
        assert np.all(np.diff(r) <= 1e-12)
    assert numerical_decay(3.0, 1.0) == pytest.approx(1.0, abs=1e-12)


def test_free_oscillation_error_is_the_trapezoidal_phase_lag_at_rho_one():
    from femb.solve.diagnostics import free_oscillation_error

    # ρ∞ = 1 is the trapezoidal rule: z = e^{2i arctan(hω/2)}, no amplitude loss
    for w, n in ((0.1, 1000), (0.5, 37), (2.0, 5)):
        lag = n * (w - 2.0 * math.atan(0.5 * w))
        assert free_oscillation_error(w, n, 1.0) == pytest.approx(abs(1.0 - np.exp(-1j * lag)), rel=1e-9)
    # ρ∞ < 1 loses amplitude: the factor tends to 1 once the oscillation is gone
    assert free_oscillation_error(3.0, 400, 0.7) == pytest.approx(1.0, abs=1e-6)


def _oscillator(k=400.0, m=1.0):
    mech = Mechanism("oscillator")
    b = mech.add(PointMass("b", m, position=(1.1, 0.0)))
    mech.add(PointOnLine("g", mech.ground, b, axis=(1.0, 0.0)))
    mech.add(SpringDamper("s", mech.ground, b, k, 0.0, 1.0))
    return mech.compile(), math.sqrt(k / m)


def test_acceleration_roughness_of_a_resolved_oscillation():
    from femb.solve.diagnostics import acceleration_roughness

    model, w = _oscillator()
    h = 0.5 / w
    r = femb.simulate(model, 200 * h, h, rho_inf=0.7)
    d = acceleration_roughness(r)
    assert np.median(d["D"]) == pytest.approx(2.0 * math.sin(0.25), rel=0.1)
    assert d["h"] == pytest.approx(h)


def test_acceleration_roughness_needs_every_step():
    from femb.errors import ParameterError
    from femb.solve.diagnostics import acceleration_roughness

    model, w = _oscillator()
    r = femb.simulate(model, 0.5, 0.01, rho_inf=0.7, stride=3)
    with pytest.raises(ParameterError):
        acceleration_roughness(r)


def test_step_halving_order_flags_the_unresolved_axial_mode_only():
    from femb.benchmarks.scenes.beams import flexible_slider_crank as fsc
    from femb.benchmarks.scenes.planar import slider_crank
    from femb.solve.diagnostics import step_halving_order

    bare = fsc.build(8, damping=0.0).compile()
    damped = fsc.build(8).compile()
    # h = 0.1 ms: hω = 1.6 for the first axial mode (T = 0.40 ms)
    s = step_halving_order(bare, 1e-4)
    assert s["order"] < 0.5
    assert "slider.x" in s["unresolved"]
    d = step_halving_order(damped, 1e-4)
    assert d["order"] > 1.2 and d["unresolved"] == []
    rigid = slider_crank.build().compile()
    r = step_halving_order(rigid, slider_crank.DEFAULTS["h"])
    assert r["order"] == pytest.approx(2.0, abs=0.1)
    assert r["unresolved"] == [] and np.nanmin(r["orders"]) > 1.5


def test_undamped_rod_does_not_converge_until_the_phase_lag_is_small():
    from femb.benchmarks.accuracy import flexible_convergence as fc

    rows, w = fc.study(0.0, 0.7, hs=(1e-4, 2e-5, 5e-6), h_ref=5e-7)
    periods = 2 * np.pi / w
    assert periods[0] == pytest.approx(3.96e-4, rel=0.01)
    err = [r[1] for r in rows]
    # flat between 0.1 ms and 20 µs (h ω₁ = 1.6 … 0.32), then it converges
    assert err[1] > 0.5 * err[0]
    assert err[2] < 0.1 * err[1]
    # the error is one amplitude times the free-oscillation factor F₁
    ratio = [r[1] / r[5] for r in rows]
    assert max(ratio) / min(ratio) < 3.0
    # and the fixed-step accuracy check does not warn
    assert not any(r[3] for r in rows)
    drows, _ = fc.study(fc.fsc.DATA["damping"], 0.7, hs=(1e-4, 2e-5), h_ref=5e-7)
    assert drows[1][1] < 0.1 * drows[0][1]


def test_fixed_step_warning_names_the_unresolved_coordinates():
    from femb.benchmarks.scenes.beams import flexible_slider_crank as fsc
    from femb.benchmarks.scenes.planar import slider_crank
    from femb.benchmarks.scenes.spatial import heavy_top
    from femb.solve.diagnostics import fixed_step_warning

    msg = fixed_step_warning(fsc.build(8, damping=0.0).compile(), 1e-4)
    assert msg is not None and "rod.n" in msg and "h = 0.0001 s" in msg and "more" in msg
    assert fixed_step_warning(fsc.build(8).compile(), 1e-4) is None
    assert fixed_step_warning(slider_crank.build().compile(), slider_crank.DEFAULTS["h"]) is None
    top = heavy_top.DEFAULTS
    assert fixed_step_warning(heavy_top.build().compile(), top["h"], rho_inf=top["rho_inf"],
                              check_every=16) is None


def test_smooth_start_leaves_a_much_smaller_ringing():
    from femb.benchmarks.accuracy import flexible_convergence as fc

    rows, _ = fc.study(0.0, 0.7, hs=(1e-4,), h_ref=1e-6, ramp=fc.RAMP)
    h, err, chk, warned = rows[0][:4]
    # stress free at full speed: 1.6e-5 m at this h (docs/beams.md); started at rest and ramped: ~1e-9 m
    assert err < 1e-7 and not warned


def test_simulate_warns_about_an_unresolved_start_only_when_asked_and_only_when_true():
    """simulate(..., check_convergence=True): the undamped rod at h = 0.1 ms warns, the damped rod
    and the rigid slider-crank at their steps do not; without the keyword nothing is checked."""
    import warnings

    from femb.benchmarks.scenes.beams import flexible_slider_crank as fsc
    from femb.benchmarks.scenes.planar import slider_crank
    from femb.errors import AccuracyWarning
    bare = fsc.build(8, damping=0.0).compile()
    with pytest.warns(AccuracyWarning, match="does not resolve the motion of the first 64 steps"):
        femb.simulate(bare, 0.01, 1e-4, check_convergence=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error", AccuracyWarning)
        femb.simulate(bare, 0.01, 1e-4)
        femb.simulate(fsc.build(8).compile(), 0.01, 1e-4, check_convergence=True)
        femb.simulate(slider_crank.build().compile(), 0.05, slider_crank.DEFAULTS["h"], check_convergence=True)
