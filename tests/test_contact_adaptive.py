"""Adaptive steps of femb.contact.simulate (femb/contact/adaptive.py, docs/contact.md §1.2).

Checked against independent references: the tippe top's sliding phase against its Newton–Euler ODE
integrated by scipy (contact_tippetop.reference), the bouncing ball's impact times and the rocking
block's first impact against their closed forms.
"""
import math

import numpy as np
import pytest

from femb.benchmarks.scenes.contact import contact_ball, contact_beam_stop, contact_rocking, contact_tippetop
from femb.contact import simulate
from femb.contact.step import NonsmoothStep, StepFailure
from femb.errors import ContactError, ParameterError


@pytest.fixture(scope="module")
def top():
    return contact_tippetop.build().compile()


def test_tippe_top_error_follows_the_tolerance(top):
    """Persistent sliding contact (smooth): the error at t = 0.2 s falls with rtol like an order-2 method
    (steps ∝ rtol^(−1/3), error ∝ steps^(−2)), and every step is error-tested."""
    T = 0.2
    ref = contact_tippetop.reference([T])
    errs, steps = [], []
    for rtol in (1e-4, 1e-6):
        r = simulate(top, T, 1e-3, rtol=rtol)
        assert r.status == "success" and r.t[-1] == pytest.approx(T, abs=1e-12)
        assert r.stats["unchecked_steps"] == 0 and r.settings["adaptive"] and r.settings["h"] is None
        np.testing.assert_allclose(r.h_steps, np.diff(r.t))
        errs.append(abs(r.q[-1][2] - ref["z"][-1]))
        steps.append(r.stats["steps"])
    assert 3.0 < steps[1] / steps[0] < 6.0          # 100^(1/3) = 4.6
    assert errs[1] < errs[0] / 8.0                  # order 2: (4.6)² = 21
    assert errs[1] < 1e-8                           # z of order 1e-2 m


def test_bouncing_ball_impacts_exact_with_large_steps():
    """Free flights under gravity have no error (constant acceleration): the steps grow far beyond the
    fixed h, impacts are located in their steps, and the impact times are the closed form's."""
    m = contact_ball.build().compile()
    r = simulate(m, 1.4, 2e-3, rtol=1e-6)
    g, R, y0, e = 9.81, 0.1, 1.0, 0.5
    t1 = math.sqrt(2.0 * (y0 - R) / g)
    exact = [t1] + [t1 + 2 * t1 * sum(e ** k for k in range(1, n + 1)) for n in range(1, 6)]
    got = [ev["t"] for ev in r.events][:6]
    # each impact lags by the impact substep's margin d = 1e-4 h (2e-7 s, docs/contact.md §2.4), as with fixed steps
    np.testing.assert_allclose(got, exact, rtol=0, atol=1.5e-6)
    assert np.all(np.diff(np.array(got) - exact) < 2.5e-7)
    assert r.h_steps.max() > 0.1 and r.stats["steps"] < 100                # 700 fixed steps
    assert 1 <= r.stats["unchecked_steps"] <= len(r.events)   # steps with impacts (several in one) not error-tested
    assert r.contact["gN"].min() >= -1e-10 * m.length_scale
    assert abs(r.qd[-1][1]) < 1e-12 and r.contact["lam_N"][-1, 0] == pytest.approx(9.81, rel=1e-12)   # at rest


def test_rocking_block_first_impact():
    """Rocking about a corner (smooth, persistent contact) then an impact: ω⁻ by energy and Housner's
    ratio, at rtol = 1e-6."""
    r = simulate(contact_rocking.build().compile(), 1.0, 2e-3, rtol=1e-6)
    ev = [e for e in r.events if abs(e["u_before"][2]) > 1e-6]
    assert abs(abs(ev[0]["u_before"][2]) - contact_rocking.first_impact_speed()) < 1e-5
    assert abs(ev[0]["u_after"][2] / ev[0]["u_before"][2] - contact_rocking.housner_ratio()) < 1e-6
    assert r.stats["rejected_steps"] >= 0 and r.n_rejected == r.stats["rejected_steps"]


def test_flexible_beam_steps_do_not_collapse():
    """A flexible beam swinging from rest (stiff: its axial and bending modes): on steps far below the first
    one, the acceleration rows of the Newton test keep the first step's weight (NonsmoothStep.h_acc), so u̇ is
    solved and the error estimate sees the motion. With h² weights Newton accepted the previous u̇ on steps
    of 1e-6 s, the estimate read zero there and a jump on the next longer step, and the steps fell to
    2e-7 s (over 10⁵ steps for this 0.1 s)."""
    r = simulate(contact_beam_stop.build().compile(), 0.1, 1e-3, rtol=1e-3)
    assert r.status == "success" and r.stats["steps"] < 2000
    assert r.h_steps.min() > 1e-6 and r.h_steps.max() > 5e-4


@pytest.mark.parametrize("scene, T, h, rtol", [(contact_rocking, 1.0, 2e-3, 1e-5), (contact_ball, 1.4, 2e-3, 1e-4)])
def test_compiled_and_python_steps_agree(scene, T, h, rtol):
    """The controller over the compiled loop (one step per call) and over the Python loop: the same steps,
    rejections, events and outputs (to round-off)."""
    m = scene.build().compile()
    a = simulate(m, T, h, rtol=rtol, compiled=True)
    b = simulate(m, T, h, rtol=rtol, compiled=False)
    assert a.stats == b.stats and a.stats["steps"] > 10
    np.testing.assert_allclose(a.t, b.t, rtol=0, atol=1e-13)
    np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.qd, b.qd, rtol=0, atol=1e-11)
    for k in a.contact:
        np.testing.assert_allclose(a.contact[k], b.contact[k], rtol=0, atol=1e-11, err_msg=k)
    assert [e["t"] for e in a.events] == pytest.approx([e["t"] for e in b.events], abs=1e-12)


def test_a_step_without_solution_is_retried_then_stops_with_the_partial_result(top, monkeypatch):
    """A solve that fails from t = 0.05 s on: h is cut by 4 until h_min, then ContactError names the time and
    step and carries what was computed."""
    solve = NonsmoothStep.solve

    def failing(self, s):
        if s.t >= 0.05:
            raise StepFailure("no solution (test)")
        return solve(self, s)

    monkeypatch.setattr(NonsmoothStep, "solve", failing)
    with pytest.raises(ContactError) as info:
        simulate(top, 0.2, 1e-3, rtol=1e-4, compiled=False)
    err = info.value
    assert err.t >= 0.05 and err.step > 1 and "h_min" in str(err) and "no solution (test)" in str(err)
    assert err.result.status == "failed" and err.result.t[-1] == pytest.approx(err.t)
    assert err.result.stats["failed_solves"] >= 10


@pytest.mark.parametrize("kw, words", [
    (dict(rtol=-1.0), "rtol"),
    (dict(rtol=1e-4, atol=0.0), "atol"),
    (dict(rtol=1e-4, h_max=float("nan")), "h_max"),
    (dict(atol=1e-6), "give rtol"),
    (dict(h_max=1e-3), "give rtol"),
    (dict(tolerance=1e-9), "unknown keyword"),
    (dict(max_iter=0), "max_iter"),
    (dict(max_fixed_point=2.5), "max_fixed_point"),
    (dict(tol=float("inf")), "tol"),
])
def test_bad_options(top, kw, words):
    """Adaptive and solver options: a ParameterError naming the option, before any step."""
    with pytest.raises(ParameterError, match=words):
        simulate(top, 0.01, 1e-3, **kw)


@pytest.mark.parametrize("compiled", [True, False])
def test_a_stick_in_a_long_step_is_taken_again_with_the_first_step(compiled):
    """A block sliding to a stop on an incline (μ > tan φ: closed form in contact_block.reference): free of
    error while it slides (constant deceleration), so the steps grow; the step in which it sticks has no
    impact to locate, and its error is of order h² (u̇ jumps: the estimate cannot see it). Taken as it came
    (before 2026-11-29) the block stopped 2.0e-2 m off at rtol 1e-4 and 1.7e-2 m at 1e-8; it is taken again with
    the first step's size, so the error is that of fixed steps of that size."""
    from femb.benchmarks.scenes.contact import contact_block
    model = contact_block.build(mu=0.5).compile()
    T, h0 = 1.0, 1e-3
    ref = contact_block.reference([T], mu=0.5)
    fixed = simulate(model, T, h0)
    err_fixed = abs(contact_block.outputs(fixed)["s"][-1] - ref["s"][-1])
    for rtol in (1e-4, 1e-8):
        r = simulate(model, T, h0, rtol=rtol, compiled=compiled)
        out = contact_block.outputs(r)
        err = abs(out["s"][-1] - ref["s"][-1])
        assert err <= 2.0 * err_fixed + 1e-12, (rtol, err, err_fixed)
        assert abs(out["s_d"][-1]) < 1e-12                          # at rest, stuck
        stop = np.searchsorted(r.t, ref["t_stop"])                  # the step that holds the stop
        assert r.t[stop] - r.t[stop - 1] <= 1.05 * h0
        assert r.stats["steps"] < 0.2 * T / h0                      # still far fewer steps than fixed ones


def test_sphere_rolls_at_the_closed_form_speed_with_adaptive_steps():
    """The spatial sphere sliding until it rolls (slip to stick, no impact): the rolling velocity and the
    step of the transition as with fixed steps of the first step's size, in both loops alike."""
    from femb.benchmarks.scenes.contact import contact_sphere3d
    model = contact_sphere3d.build().compile()
    ref = contact_sphere3d.reference()
    runs = [simulate(model, 0.4, 1e-3, rtol=1e-6, compiled=c) for c in (True, False)]
    np.testing.assert_allclose(runs[0].q, runs[1].q, rtol=0, atol=1e-11)
    out = contact_sphere3d.outputs(runs[0])
    v = np.array([out["vx"][-1], out["vy"][-1]])
    assert np.abs(v - ref["v_roll"]).max() < 1e-5
    k = np.searchsorted(runs[0].t, ref["t_roll"])
    assert runs[0].t[k] - runs[0].t[k - 1] <= 1.05e-3
