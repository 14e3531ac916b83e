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
