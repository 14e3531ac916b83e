"""The impulses a contact result stores, and none left over after a contact opens (docs/contact.md §4).

1. A step split at an impact (free flight, the impact substep, the rest) stores the impulses of the
   whole step: P_N, Λ_N, P_F, Λ_F summed over its substeps, so that the discrete momentum balance of
   the scheme, M(u_{n+1} − u_n) = h f + W_Nᵀ P_N + W_Fᵀ P_F (constant gravity, constant W: the sphere on
   a floor), holds step by step and over a whole run with many impacts.
2. No leftover percussion: after a contact opens, its impulses are zero to round-off and the free
   flight is exactly ballistic, also with small steps (before, a start guess within the Newton
   tolerance carried a constant impulse of order tol·m/h per step: a spurious force ∝ 1/h²).

Both loops (compiled and Python) are checked; each test fails with the stored impulses of the last
substep only, or with the start guess accepted at the tolerance (measured: see the comments).
"""
import numpy as np
import pytest

from femb.benchmarks.scenes.contact import contact_ball
from femb.contact import core, simulate

P = contact_ball.PARAMS
M, G = P["mass"], P["g"]
LOOPS = [None, False]          # compiled loop (default), Python loop


def _momentum_residual(res, h):
    """m(u_{n+1} − u_n) − (−m g h e_y + P_N n + P_F t) per step (floor: n = +y, t = +x), shape (steps, 3)."""
    du = M * np.diff(res.qd[:, :2], axis=0)
    imp = np.zeros_like(du)
    imp[:, 1] = -M * G * np.diff(res.t) + res.contact["P_N"][1:, 0]
    imp[:, 0] = res.contact["P_F"][1:, 0]
    return du - imp


@pytest.mark.parametrize("compiled", LOOPS)
def test_split_steps_store_the_whole_step_impulse(compiled):
    """The bouncing ball (e_N = 0.5) over 1.5 s: impacts, their accumulation at t∞ and rest.

    Every impact step is split; each step's stored P_N balances its momentum change (with only the
    last substep's P_N the impact steps were off by the impact's percussion, about 2.2 N·s at the first)."""
    h = 2e-3
    res = simulate(contact_ball.build().compile(), 1.5, h, compiled=compiled)
    assert len(res.events) >= 5
    r = _momentum_residual(res, h)
    assert np.abs(r).max() < 1e-12, np.abs(r).max()
    first = int(np.searchsorted(res.t, res.events[0]["t"]))      # the step holding the first impact
    assert res.contact["P_N"][first, 0] == pytest.approx(res.events[0]["P_N"], abs=1e-12)
    # Newton's law m(1 + e_N)|v⁻| plus the weight over the impact substep (≤ 3d, d = 1e-4 h)
    assert res.contact["P_N"][first, 0] == pytest.approx(M * 1.5 * np.sqrt(2.0 * G * 0.9), abs=M * G * 3e-4 * h)
    # over the run: the momentum the floor gave is the sum of the stored impulses
    total = M * (res.qd[-1, 1] - res.qd[0, 1]) + M * G * (res.t[-1] - res.t[0])
    assert res.contact["P_N"][:, 0].sum() == pytest.approx(total, abs=1e-11)
    assert abs(res.qd[-1, 1]) < 1e-12                            # at rest after t∞


@pytest.mark.parametrize("compiled", LOOPS)
def test_backspin_impact_step_stores_the_friction_impulse(compiled):
    """The ball with backspin (e_N = 0, μ = 0.2, ω₀ = 50 rad/s): the impact step's stored P_F is the
    friction percussion μ P_N of the impact plus the sliding friction over the rest of the step."""
    h = 2e-3
    res = simulate(contact_ball.build(e_N=0.0, mu=0.2, omega0=50.0).compile(), 0.5, h, compiled=compiled)
    r = _momentum_residual(res, h)
    assert np.abs(r).max() < 1e-12, np.abs(r).max()
    k = int(np.searchsorted(res.t, res.events[0]["t"]))
    assert abs(res.contact["P_F"][k, 0]) == pytest.approx(0.2 * res.contact["P_N"][k, 0], rel=1e-9)  # sliding
    assert res.contact["P_N"][k, 0] > res.events[0]["P_N"]          # the impact, then the weight carried


@pytest.mark.parametrize("compiled", LOOPS)
def test_no_leftover_percussion_after_the_contact_opens(compiled):
    """A ball dropped 1 cm onto the floor (e_N = 0.5) at h = 1e-5 s: after the impact it flies exactly
    ballistically, u_y(t) = u_y⁺ − g(t − t⁺), and its contact stores no impulse.

    Measured before the start guess had to solve the step to GUESS_TOL·tol: the velocity drifted from
    the ballistic one by about 1e-8 m/s per step after the impact (h = 1e-5 s)."""
    h, y0 = 1e-5, P["radius"] + 0.01
    res = simulate(contact_ball.build(y0=y0).compile(), 0.07, h, compiled=compiled)
    assert len(res.events) == 1
    t_imp = np.sqrt(2.0 * 0.01 / G)
    assert res.events[0]["t"] == pytest.approx(t_imp, abs=1e-12)
    k = int(np.searchsorted(res.t, t_imp)) + 1                   # from the first whole step after the impact
    after = res.qd[k:, 1]
    ballistic = res.qd[k, 1] - G * (res.t[k:] - res.t[k])
    # Newton's law across the impact substep (≤ 3d, d = 1e-4 h): within g·3d of the exact rebound
    assert res.qd[k, 1] == pytest.approx(0.5 * G * t_imp - G * (res.t[k] - t_imp), abs=G * 3e-4 * h)
    assert np.abs(after - ballistic).max() < 1e-11, np.abs(after - ballistic).max()
    # what a start guess may carry: its P_N row (weight h/m) within GUESS_TOL·tol, a force below 1e-9 m·g
    # here (with the guess taken at tol: up to tol·m/h = 1e-8 N·s per step, a force of 1e-4 m·g)
    bound = core.GUESS_TOL * res.settings["tol"] * M / h
    assert bound < 1e-9 * M * G * h
    assert np.abs(res.contact["P_N"][k + 1:, 0]).max() <= bound
    assert np.all(res.contact["state"][k + 1:, 0] == 0)


def _journal():
    """A shaft spinning at 40 rad/s dropped into a horizontal bushing with radial clearance (pin_bushing:
    two end contacts, μ = 0.2, e_N = 0): it slides on the wall, which turns the contacts' normals and
    tangents (W depends on q), until friction has taken out its spin."""
    import femb
    from femb.elements import SpatialGravity, SpatialRigidBody
    from femb.elements.contact import pin_bushing
    m = femb.Mechanism("journal")
    m.add(SpatialRigidBody("shaft", 1.0, (2e-4, 3e-3, 3e-3), omega=(40.0, 0.0, 0.0)), SpatialGravity((0.0, 0.0, -G)))
    m.add(*pin_bushing("brg", "shaft", "ground", 0.021, 0.02, 0.2, axis=(1.0, 0.0, 0.0), mu=0.2))
    return m.compile()


@pytest.mark.parametrize("compiled", LOOPS)
def test_energy_balance_is_second_order_where_the_contact_directions_turn(compiled):
    """energy()["balance"] after the impact (t ≥ 0.02 s) over 0.3 s at h = 1e-3 and 5e-4 s: the contact work
    Σ ½(v_n + v_{n+1})·P (v = ġ_N, γ_F with each end's own W) is second order, so the balance is.

    Measured: 1.9e-7 and 5.6e-8 J (of 0.16 J taken out by friction); with the work summed as
    ½(u_n + u_{n+1})·W_{n+1}ᵀP before: 6.4e-4 and 3.2e-4 J, first order."""
    errs = []
    for h in (1e-3, 5e-4):
        res = simulate(_journal(), 0.3, h, compiled=compiled)
        E = res.energy()
        assert E["contact_friction"][-1] == pytest.approx(0.1598, abs=1e-3)    # the spin's energy, taken out
        k0 = int(np.searchsorted(res.t, 0.02))
        errs.append(np.abs(E["balance"][k0:] - E["balance"][k0]).max())
    assert errs[0] < 1e-6, errs
    assert errs[0] / errs[1] > 3.0, errs
