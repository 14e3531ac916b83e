"""The nonsmooth generalized-α scheme (femb.contact) against closed-form references."""
import math

import numpy as np
import pytest

import femb
from femb.benchmarks.scenes.contact import (
    contact_ball, contact_block, contact_painleve, contact_rocking, contact_sphere3d)
from femb.contact import simulate
from femb.elements import Gravity, RigidBody
from femb.elements.contact import SphereOnPlane
from femb.errors import ContactError, ModelError, ParameterError

H = 2e-3


def _no_penetration(res):
    assert res.contact["gN"].min() >= -1e-10 * res.model.length_scale


@pytest.fixture(scope="module")
def bouncing():
    return simulate(contact_ball.build(e_N=0.5).compile(), 1.5, H)


def test_bouncing_ball_impacts_accumulation_and_rest(bouncing):
    res = bouncing
    _no_penetration(res)
    t_ev = np.array([e["t"] for e in res.events])
    exact = contact_ball.impact_times(len(t_ev))
    assert t_ev[0] == pytest.approx(0.428353, abs=1e-6)
    assert np.max(np.abs(t_ev - exact)) < H                          # every impact time within h
    t_inf = contact_ball.accumulation_time()
    assert t_inf == pytest.approx(1.285059, abs=1e-6)
    assert abs(t_ev[-1] - t_inf) < 1e-3                              # accumulation within 1e-3 s
    after = res.t > t_ev[-1] + H
    assert np.abs(res.qd[after]).max() < 1e-8                        # at rest: zero velocity, no chattering
    assert np.all(res.contact["state"][after] != 0)                  # closed, never reopening
    assert not any(e["t"] > t_ev[-1] for e in res.events)
    v = np.array([e["v_before"] for e in res.events[:10]])
    w = np.array([e["v_after"] for e in res.events[:10]])
    np.testing.assert_allclose(w, -0.5 * v, rtol=1e-9)               # Newton's law at every impact
    E0 = 9.81 * 0.9
    Ek = 0.5 * w ** 2
    np.testing.assert_allclose(Ek / E0, 0.25 ** np.arange(1, 11), rtol=2e-3)   # e^{2k} E0


def test_bouncing_ball_energy_outputs(bouncing):
    e = bouncing.energy()
    lost = e["contact_normal"][-1]
    assert lost == pytest.approx(9.81 * 0.9, rel=1e-3)              # all of m g Δh goes into the impacts
    assert np.abs(e["balance"]).max() < 1e-2 * 9.81 * 0.9
    names = bouncing.outputs()
    for k in ("floor.gN", "floor.lambda_N", "floor.Lambda_N", "floor.gamma_F", "floor.state", "floor.slip",
              "energy.contact_normal"):
        assert k in names
        assert bouncing.series(k)[0].shape == bouncing.t.shape


@pytest.mark.parametrize("omega0", [50.0, 10.0])
def test_ball_with_backspin(omega0):
    tab = contact_ball.backspin_table(omega0)
    ref = contact_ball.backspin_reference(omega0=omega0)
    assert tab["impact t"] == pytest.approx(0.428353, abs=1e-6)
    assert tab["|xd end - exact|"] < 1e-6
    assert tab["stick step contains t_roll"]
    assert tab["slip steps after stick"] == 0
    assert tab["min g_N / L"] >= -1e-10
    if omega0 == 50.0:
        assert ref["t_roll"] == pytest.approx(0.72812, abs=1e-5)
        assert ref["xd_roll"] == pytest.approx(-10.0 / 7.0, abs=1e-12)
        assert tab["xd after impact"] == pytest.approx(-0.84043, abs=1e-5)
    else:
        assert tab["xd after impact"] == pytest.approx(-2.0 / 7.0, abs=1e-9)   # sticks at the impact


@pytest.mark.parametrize("mu", [0.2, 0.5])
def test_block_sliding_then_sticking(mu):
    tab = contact_block.table(mu)
    assert tab["max |s_d - exact|"] < 1e-9
    assert tab["max |N - exact|"] < 1e-9 and tab["max |F - exact|"] < 1e-9
    assert tab["max |N_front_minus_back - exact|"] < 1e-9
    assert tab["max |s - exact|"] < (1e-9 if mu == 0.2 else 1e-2 * 1e-2)   # the stop inside a step: first order
    assert tab["min g_N / L"] >= -1e-10


def test_smooth_phase_is_second_order():
    """Block on the incline pulled by a spring (persistent sliding contact, varying normal force):
    position and normal force converge with order ≥ 1.9 against a run at h/8 of the finest step."""
    study = contact_block.order_study()
    assert study["always sliding"]
    assert study["order s"] >= 1.9, study
    assert study["order N"] >= 1.9, study


def test_rocking_block_follows_housner():
    tab = contact_rocking.table(t_end=0.8)
    assert tab["contacts hit"][0] == "corner.c0"
    assert tab["omega- first"] == pytest.approx(tab["omega- first (exact)"], rel=1e-4)
    assert tab["max |ratio - Housner|"] < 1e-4
    assert tab["max slip speed (m/s)"] < 1e-8
    assert tab["min g_N / L"] >= -1e-10


def test_spatial_sphere_slides_then_rolls():
    tab = contact_sphere3d.table()
    assert tab["stick step contains t_roll"]
    assert tab["max |v end - exact|"] < 1e-5
    assert tab["max |z - R|"] < 1e-10


def test_painleve_rod_is_diagnosed():
    with pytest.raises(ContactError) as err:
        simulate(contact_painleve.build().compile(), 0.5, 1e-3)
    e = err.value
    msg = str(e)
    assert e.contact == "tip" and e.t == 0.0 and e.step == 0
    assert "Painlevé" in msg and "tip" in msg and "t0 = 0" in msg and "inconsistency" in msg
    a = contact_painleve.normal_response()
    assert f"{a:.4g}" in msg                                          # the closed form −0.3975
    res = simulate(contact_painleve.build(mu=0.3).compile(), 0.2, 1e-3)   # a > 0: it slides
    assert "slip" in set(res.contact_state("tip"))


def _ball(e_N, mu=0.0, y0=1.0):
    m = femb.Mechanism("ball")
    m.add(RigidBody("ball", 1.0, 0.004, position=(0.0, y0)))
    m.add(Gravity((0.0, -9.81)))
    m.add(SphereOnPlane("floor", "ball", radius=0.1, e_N=e_N, mu=mu))
    return m.compile()


def test_elastic_ball_thousand_bounces_no_hang():
    """e_N = 1 from 0.25 µm: two bounces per step, over a thousand bounces; energy kept, no penetration."""
    res = simulate(_ball(1.0, mu=0.3, y0=0.1 + 0.25e-6), 0.5, 1e-3)
    _no_penetration(res)
    assert len(res.events) > 1000
    v = np.array([e["v_before"] for e in res.events])
    np.testing.assert_allclose(np.abs(v), math.sqrt(2 * 9.81 * 0.25e-6), rtol=2e-3)
    assert res.stats["steps"] == 500


def test_plastic_ball_sticks_at_once():
    res = simulate(_ball(0.0), 0.6, H)
    _no_penetration(res)
    assert len(res.events) == 1
    i = res.t > 0.43
    assert np.abs(res.qd[i]).max() < 1e-9


def test_bad_run_parameters_are_errors():
    model = _ball(0.5)
    with pytest.raises(ParameterError, match="h"):
        simulate(model, 1.0, -1e-3)
    with pytest.raises(ParameterError, match="t_end"):
        simulate(model, 0.0, 1e-3)
    with pytest.raises(ParameterError, match="rho_inf"):
        simulate(model, 1.0, 1e-3, rho_inf=1.0)
    with pytest.raises(ModelError, match="floor.*penetrated"):
        simulate(_ball(0.5, y0=0.05), 1.0, 1e-3)


def test_engine_refuses_contact_models():
    """femb.simulate does not treat contacts yet: it says so instead of ignoring them."""
    with pytest.raises(ModelError, match="femb.contact.simulate"):
        femb.simulate(_ball(0.5), 0.1, 1e-3)


@pytest.mark.parametrize("compiled", [True, False])
def test_states_at_t0_are_those_of_the_start(compiled):
    """The first stored row holds the contacts' states at t0 as the start found them (stored open for every
    contact before 2026-11-29): a block sliding on its two bottom corners slips there, the top corners are
    open; at rest it sticks; a ball in the air is open."""
    from femb.benchmarks.scenes.contact import contact_block
    sliding = simulate(contact_block.build(mu=0.5).compile(), 0.02, 1e-2, compiled=compiled)
    assert [sliding.contact_state(f"corner.c{k}")[0] for k in range(4)] == ["slip", "slip", "open", "open"]
    assert np.all(sliding.contact["lam_N"][0, :2] > 0.0)
    resting = simulate(contact_block.build(mu=0.5, v0=0.0).compile(), 0.02, 1e-2, compiled=compiled)
    assert [resting.contact_state(f"corner.c{k}")[0] for k in range(4)] == ["stick", "stick", "open", "open"]
    assert simulate(_ball(0.5), 0.02, 1e-2, compiled=compiled).contact_state("floor")[0] == "open"


@pytest.mark.parametrize("analysis", ["solve_static", "modal_analysis", "buckling_analysis", "linearize",
                                      "linearize_sparse", "damped_modes"])
def test_analyses_refuse_contact_models(analysis):
    """The static, modal and linear analyses do not treat unilateral contacts: they say so, naming the model
    and themselves (before 2026-11-29 they ignored the contacts: modal_analysis of a block on the floor gave
    three free rigid-body modes, solve_static a 'free body' singular matrix, linearize 'not an equilibrium')."""
    from femb.analysis import linearize as lin
    from femb.analysis import modal, static
    fn = {"solve_static": static.solve_static, "modal_analysis": modal.modal_analysis,
          "buckling_analysis": modal.buckling_analysis, "linearize": lin.linearize,
          "linearize_sparse": lin.linearize_sparse, "damped_modes": lin.damped_modes}[analysis]
    with pytest.raises(ModelError, match=rf"'ball' has contact elements \(1 contacts\): .*\({analysis}\)"):
        fn(_ball(0.5))


def test_hinges_stay_exact_while_the_slider_bounces():
    """Slider–crank with translational clearance: impacts between the guides, hinges Φ = 0 to round-off."""
    from femb.benchmarks.scenes.contact import contact_slider_crank
    from femb.system import assembly
    model = contact_slider_crank.build().compile()
    res = simulate(model, 0.006, 2e-4)
    _no_penetration(res)
    assert len(res.events) >= 3
    phi = max(float(np.abs(assembly.constraint_vector(model, t, q)).max()) for t, q in zip(res.t, res.q))
    assert phi < 1e-12 * model.length_scale
    y = contact_slider_crank.outputs(res)["slider_y"]
    assert np.abs(y).max() <= 1e-3 + 1e-12                           # inside the clearance
