"""Contact scenes with independent references: the tippe top, a beam swinging onto a stop (femb.contact)."""
import numpy as np
import pytest

from femb.benchmarks.scenes.contact import contact_tippetop
from femb.contact import simulate


def _no_penetration(res):
    assert res.contact["gN"].min() >= -1e-10 * res.model.length_scale


def test_tippetop_rises_as_the_reference():
    """The first 0.2 s at h = 2e-3: the tilt grows from 0.1 to about 0.42 rad as the scipy reference
    (sliding on the body sphere), the centre of mass rises, the stem stays off, Jellett's λ_J holds."""
    res = simulate(contact_tippetop.build().compile(), 0.2, 2e-3)
    _no_penetration(res)
    o = contact_tippetop.outputs(res)
    ref = contact_tippetop.reference(res.t)
    assert ref["theta"][-1] > 0.4
    assert np.abs(o["theta"] - ref["theta"]).max() < 0.02                 # 2e-3 s steps, nutation period ~0.04 s
    assert np.abs(res.q[:, 2] - ref["z"]).max() < 1e-5 * 12.0              # z_G within 0.1 % of z₀
    assert o["z"][-1] > o["z"][0] + 2e-4
    assert np.all(res.contact["state"][1:, 0] == 2)                         # body sphere slides throughout
    assert np.all(res.contact["state"][:, 1] == 0)                          # stem open
    assert abs(o["jellett"][-1] / o["jellett"][0] - 1.0) < 1e-3
    np.testing.assert_allclose(o["lambda_N"][1:], ref["lambda_N"][1:], rtol=0.02)


def test_tippetop_step_size_study():
    """Errors at t = 0.025 s against the scipy reference at h = 5e-4, 2.5e-4, 1.25e-4: position, tilt,
    normal force and Jellett's drift at second order in this sliding phase (the slip direction
    turns; measured 2.00 for all four, docs/contact.md, tippe top)."""
    st = contact_tippetop.order_study(t_end=0.025, hs=(5e-4, 2.5e-4, 1.25e-4))
    assert st["order_jellett_drift"] >= 1.9
    assert st["order_err_r"] >= 1.9 and st["order_err_theta"] >= 1.9 and st["order_err_lambda_N"] >= 1.9
    assert st["err_r"][-1] < 6e-8 and st["err_lambda_N"][-1] < 1e-8            # measured 3.0e-8 m, 4.8e-9 N


def test_steel_beam_on_the_stop_runs_and_its_undamped_blow_up_is_named():
    """The steel beam (E = 2.1e11 Pa) at the scene's ρ∞ = 0.8 runs through its impacts without
    penetration (docs/contact.md §5); with ρ∞ = 0.95 its unresolved modes blow up after the impacts
    (the largest velocity from 3.9 to 1.3e4 within ten steps, and to 1.5e8 in the next step where the
    rounding lets that step through) and the step that then has no solution stops with a ContactError
    that says so, on both loops, not with a Painlevé diagnosis."""
    from femb.benchmarks.scenes.contact import contact_beam_stop
    from femb.errors import ContactError

    model = contact_beam_stop.build(E=2.1e11).compile()
    res = simulate(model, 0.29, 1e-3, rho_inf=0.8)
    _no_penetration(res)
    assert len(res.events) >= 1 and res.events[0]["t"] == pytest.approx(contact_beam_stop.rigid_impact_time(), abs=1e-4)
    for compiled in (None, False):
        with pytest.raises(ContactError, match="look numerically unstable.*smaller rho_inf") as err:
            simulate(model, 0.29, 1e-3, rho_inf=0.95, compiled=compiled)
        assert 0.27 < err.value.t < 0.29 and np.all(np.isfinite(err.value.result.t))


def test_velocity_growth_names_a_blow_up_only():
    from types import SimpleNamespace

    from femb.contact.simulate import velocity_growth
    t = np.arange(30) * 1e-3
    calm = np.ones((30, 2))
    calm[20:] *= 50.0                                        # an impact: ×50 is not a blow-up
    calm[-1] = 3000.0                                        # nor 60 × the median of the ten steps before
    assert velocity_growth(SimpleNamespace(t=t, qd=calm)) is None
    wild = calm.copy()
    wild[-1, 1] = 5e6
    why = velocity_growth(SimpleNamespace(t=t, qd=wild))
    assert "grew from 1 at t = 0.019 s to 5e+06 at t = 0.029 s" in why   # ten steps back: before the impact
    wild[-1, 1] = 5001.0                                     # just above 100 × the median, 50
    assert velocity_growth(SimpleNamespace(t=t, qd=wild)) is not None
    jump = calm.copy()                                       # a jump ×1000 five steps back, then steady growth
    jump[-5:] = 5e4 * np.arange(1, 6)[:, None]
    assert "to 5e+04 at t = 0.025 s, and 2.5e+05 at t = 0.029 s" in velocity_growth(SimpleNamespace(t=t, qd=jump))
    wild[-1, 0] = np.nan
    assert "not finite" in velocity_growth(SimpleNamespace(t=t, qd=wild))
    assert velocity_growth(SimpleNamespace(t=t[:2], qd=calm[:2])) is None


def test_beam_swings_onto_the_stop():
    """A spatial beam (E = 2.1e10, 4 elements) pinned at one end hits the stop with its tip node's
    sphere: no penetration, first impact near the rigid rod's t*, the pin exact, energy lost."""
    from femb.benchmarks.scenes.contact import contact_beam_stop

    t_star = contact_beam_stop.rigid_impact_time()
    assert t_star == pytest.approx(0.268015, abs=1e-6)
    res, row = contact_beam_stop.run(t_end=0.29)
    _no_penetration(res)
    assert row["impacts"] >= 1 and res.events[0]["contact"] == "stop"
    assert 0.0 < row["first impact"] - t_star < 2e-4                    # sags a little: later than the rigid rod
    assert row["max |Phi| pin"] <= 1e-10
    assert abs(row["balance before the first impact"]) < 1e-4           # ρ∞ = 0.8 damping only, J
    assert row["energy lost in impacts"] > 1.0                           # e_N = 0: most of ½ J α̇² goes
    o = contact_beam_stop.outputs(res)
    assert o["lambda_N"].min() >= 0.0 and o["energy_lost"][-1] == pytest.approx(row["energy lost in impacts"])
