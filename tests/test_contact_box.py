"""A box dropped on its edge onto the floor: eight corner contacts with friction, four of them resting
on one plane (statically indeterminate normal and friction forces).

What failed here before (docs/contact.md §1.1, item 12):

* the Newton step of a rank-deficient J stopped with numpy's bare ``LinAlgError: Matrix is singular to
  machine precision`` (the null-space shift solved normal equations whose weights spread over 1e20);
* at h = 2e-3 s the prox fixed point with r = 1/(W M⁻¹ Wᵀ)_ii oscillated without settling on the landing
  step (four coupled corners) and the run stopped with "no consistent contact forces found" (now r is
  halved when the fixed point stalls, core.FP_STALL).
"""
import numpy as np
import pytest

from femb import Mechanism
from femb.contact import core, simulate
from femb.elements import SpatialGravity, SpatialRigidBody
from femb.elements.contact import SpatialSphereOnPlane
from femb.elements.spatial_forces import SpatialForce

A = 0.1     # half the box's edge (m)


def _box(mu=0.5, e_N=0.0):
    m = 1.0
    J = m * (2 * A) ** 2 / 6
    mech = Mechanism("box")
    mech.add(SpatialGravity((0.0, 0.0, -9.81)))
    c, s = np.cos(0.15), np.sin(0.15)                  # 0.3 rad about (1, 1, 0)/√2: lands on a corner, then an edge
    mech.add(SpatialRigidBody("b", m, (J, J, J), position=(0.0, 0.0, 0.4), rotation=(c, s / np.sqrt(2), s / np.sqrt(2), 0.0),
                              velocity=(0.5, 0.0, 0.0), omega=(0.0, 0.0, 3.0)))
    k = 0
    for x in (-A, A):
        for y in (-A, A):
            for z in (-A, A):
                mech.add(SpatialSphereOnPlane(f"c{k}", "b", point=(x, y, z), mu=mu, e_N=e_N))
                k += 1
    return mech.compile()


@pytest.mark.parametrize("h, compiled", [(2e-3, True), (1e-3, True), (2e-3, False)])
def test_box_lands_on_its_face_and_rests(h, compiled):
    model = _box()
    res = simulate(model, 0.45, h, compiled=compiled)
    assert res.success
    gaps = np.array([res.series(f"c{k}.gN")[0] for k in range(8)])
    assert gaps.min() >= -1e-10 * model.length_scale
    assert res.q[-1][2] == pytest.approx(A, abs=1e-9)           # on a face
    assert np.abs(res.qd[-1]).max() < 1e-9                      # at rest (e_N = 0, μ = 0.5)
    bottom = np.abs(gaps[:, -1]) < 1e-9
    assert bottom.sum() == 4
    lam = np.array([res.series(f"c{k}.lambda_N")[0][-1] for k in range(8)])
    assert lam.sum() == pytest.approx(9.81, rel=1e-9)           # the weight, however it is shared
    assert lam.min() >= -1e-9


def test_null_space_shift_with_weights_over_twenty_decades():
    """minimum_norm_step on a rank-deficient J with friction weights 1e20 beside 1 (before: LinAlgError)."""
    rng = np.random.default_rng(3)
    B = rng.standard_normal((6, 4))
    J = np.hstack((B, B[:, :2]))                              # 6 × 6 of rank 4
    R = J @ rng.standard_normal(6)
    x = rng.standard_normal(6)
    w = np.array([1.0, 1.0, 1.0, 1.0, 1e20, 1e-3])
    dx = np.zeros(6)
    core.minimum_norm_step(J, R, x, dx, w)
    assert np.all(np.isfinite(dx))
    assert np.linalg.norm(J @ dx + R) <= 1e-9 * np.linalg.norm(R)
    # the shift is within J's null space and leaves the heavily weighted unknown where the minimum-norm step put it
    dx0 = np.zeros(6)
    core.minimum_norm_step(J, R, x, dx0, np.zeros(0))
    assert abs((x + dx)[4]) <= abs((x + dx0)[4]) + 1e-12


def _pushed_box(F, mu=0.8):
    """A box resting flat on four corners, pushed along x at the top of its back face (height 2A above
    the floor): it tips about its front edge when F 2A > m g A, i.e. F > m g / 2, and slides when F > μ m g."""
    m = 1.0
    J = m * (2 * A) ** 2 / 6
    mech = Mechanism("pushed_box")
    mech.add(SpatialGravity((0.0, 0.0, -9.81)))
    mech.add(SpatialRigidBody("b", m, (J, J, J), position=(0.0, 0.0, A)))
    k = 0
    for x in (-A, A):
        for y in (-A, A):
            mech.add(SpatialSphereOnPlane(f"c{k}", "b", point=(x, y, -A), mu=mu))
            k += 1
    mech.add(SpatialForce("push", "b", (F, 0.0, 0.0), point=(-A, 0.0, A)))
    return mech.compile()


@pytest.mark.parametrize("F, tips", [(4.5, False), (6.0, True)])
def test_pushed_box_starts_and_tips_above_half_its_weight(F, tips):
    """The start's contact problem (four coupled corners, sticking) stalled before: "initial contact forces
    at t0 = 0 s: no consistent contact forces found" for every push F > 0 (now its r is halved as well)."""
    model = _pushed_box(F)
    res = simulate(model, 0.2, 1e-3)
    assert res.success
    gaps = np.array([res.series(f"c{k}.gN")[0] for k in range(4)])
    assert gaps.min() >= -1e-10 * model.length_scale
    lam0 = np.array([res.series(f"c{k}.lambda_N")[0][0] for k in range(4)])
    if tips:
        assert res.q[-1][2] - A > 1e-3                              # the centre rises: tipping about the front edge
        assert gaps[:2, -1].min() > 1e-3 and np.abs(gaps[2:, -1]).max() < 1e-9   # back corners up, front down
    else:
        assert abs(res.q[-1][2] - A) < 1e-12 and np.abs(res.q[-1][:2]).max() < 1e-9   # at rest, sticking
        assert lam0.sum() == pytest.approx(9.81, rel=1e-9)
        # the moment of the push loads the front corners: F 2A = (λ_front − λ_back) 2A (sum over each pair)
        front, back = lam0[2:].sum(), lam0[:2].sum()
        assert front - back == pytest.approx(2 * F, rel=1e-6)


def test_the_stall_rule_halves_after_twenty_iterations_without_progress_at_most_four_times():
    track = np.array([np.inf, 0.0, 0.0])
    assert not core.fp_stalled(1.0, track) and not core.fp_stalled(0.5, track)   # progress
    halvings = [k for k in range(200) if core.fp_stalled(0.7, track)]          # no progress from here on
    assert halvings == [19, 39, 59, 79]
    assert track[2] == 4
