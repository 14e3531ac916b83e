"""Velocity-level (non-holonomic) constraints on flexible models: the start of flexible models
(femb/system/initial.py) with the rows A q̇ + a = 0 of rolling joints.

A coin (thin disc, ρ = 0.5 m, 1 kg) rolling on the plane z = 0 carries a flexible steel axle
(spatial beam, 4 elements, welded to the disc's centre along its axis, with a 0.2 kg tip mass)
under gravity. Started with the axle moving with the disc, the run keeps the rolling constraint
at round-off, converges at second order against a fine run and keeps its energy; a stiff axle
given no velocity is set moving with the disc by the start.
"""
import numpy as np
import pytest

import femb
from femb import Mechanism
from femb.base.rotations import expm
from femb.elements.rolling import RollingDisc
from femb.elements.spatial_beam import SpatialSection, spatial_beam
from femb.elements.spatial_bodies import SpatialRigidBody
from femb.elements.spatial_forces import SpatialGravity
from femb.elements.spatial_joints import FixedJoint
from femb.system import assembly, initial
from femb.system.motion import set_rigid_velocity

RHO, MASS = 0.5, 1.0
Z = np.array([0.0, 0.0, 1.0])


def coin_with_axle(stiffness=1.0, n=4, axle_moving=True, damping=1e-4):
    R0 = expm(np.array([0.3, 0.0, 0.0]))
    omega = R0 @ np.array([0.0, 6.0, 0.5])
    a = R0 @ np.array([0.0, 1.0, 0.0])
    c = Z @ a
    d = (Z - c * a) / np.sqrt(1.0 - c * c)
    centre = RHO * d
    m = Mechanism("coin_with_axle")
    disc = m.add(SpatialRigidBody("disc", MASS, (MASS * RHO ** 2 / 4, MASS * RHO ** 2 / 2, MASS * RHO ** 2 / 4),
                                  position=centre, rotation=R0, omega=tuple(R0.T @ omega),
                                  velocity=tuple(RHO * np.cross(omega, d))))
    m.add(RollingDisc("roll", "disc", RHO, (0.0, 1.0, 0.0)))
    sec = SpatialSection.circle(2.1e11 * stiffness, 8.1e10 * stiffness, 0.01, density=7850.0, damping=damping)
    beam = spatial_beam(m, "axle", sec, [centre, centre + 0.3 * a], n)
    m.add(FixedJoint("weld", disc, beam.nodes[0], at=centre))
    tip = m.add(SpatialRigidBody("tip", 0.2, (1e-4, 1e-4, 1e-4), position=centre + 0.3 * a))
    m.add(FixedJoint("tip_weld", beam.nodes[-1], tip, at=centre + 0.3 * a))
    if axle_moving:
        set_rigid_velocity([beam, tip], velocity=RHO * np.cross(omega, d), omega=omega, about=centre)
    m.add(SpatialGravity())
    return m.compile()


@pytest.fixture(scope="module")
def model():
    return coin_with_axle()


def _velocity_residual(model, r):
    return max(np.abs(assembly.velocity_constraints(model, r.t[k], r.q[k], r.qd[k])[0]).max()
               for k in range(r.t.size))


def test_flexible_start_takes_velocity_constraints():
    # before: ModelError "the start of flexible models does not take velocity constraints". A stiff
    # axle (E × 10⁴) given no velocity is set moving as a rigid body with the disc
    model = coin_with_axle(stiffness=1e4, axle_moving=False)
    st0 = model.initial_state(0.0)
    assert model.nn > 0 and initial.deformable_groups(model, 0.0, st0.q, st0.qd)
    w = initial.start_weights(model, st0, 0.0, 1e-3, 1.0)
    with pytest.warns(initial.InitialVelocityWarning):
        st = initial.consistent_initial_state(model, st0, weights=w)
    assert np.abs(assembly.velocity_constraints(model, 0.0, st.q, st.qd)[0]).max() < 1e-12
    assert st.lam.size == model.nc + model.nn and np.all(np.isfinite(st.lam))
    vd = model.node_velocities("disc", st.qd)
    xd = model.node_coordinates("disc", st.q)[:3]
    w_space = _quat(model.node_coordinates("disc", st.q)[3:7]) @ vd[3:]      # Ω in body axes → space
    for nm in ("axle.n2", "axle.n4", "tip"):
        x = model.node_coordinates(nm, st.q)[:3]
        v = model.node_velocities(nm, st.qd)[:3]
        np.testing.assert_allclose(v, vd[:3] + np.cross(w_space, x - xd), atol=1e-3 * np.linalg.norm(vd[:3]))


def _quat(p):
    p0, p1, p2, p3 = p / np.linalg.norm(p)
    return np.array([[1 - 2 * (p2 * p2 + p3 * p3), 2 * (p1 * p2 - p0 * p3), 2 * (p1 * p3 + p0 * p2)],
                     [2 * (p1 * p2 + p0 * p3), 1 - 2 * (p1 * p1 + p3 * p3), 2 * (p2 * p3 - p0 * p1)],
                     [2 * (p1 * p3 - p0 * p2), 2 * (p2 * p3 + p0 * p1), 1 - 2 * (p1 * p1 + p2 * p2)]])


def test_rolling_disc_with_flexible_axle_runs(model):
    # measured: velocity residual 2.7e-15 m/s, energy balance 1.9e-7
    r = femb.simulate(model, 0.2, 1e-3)
    assert r.settings["start_used"] == "consistent"
    assert _velocity_residual(model, r) < 1e-11
    assert r.energy_balance() < 1e-3


def test_rolling_disc_with_flexible_axle_converges_at_second_order(model):
    # measured: positions 2.3e-5, 6.3e-6, 1.3e-6 (orders 1.87, 2.27), multipliers (relative)
    # 5.6e-3, 1.5e-3, 3.1e-4 (orders 1.88, 2.28) at h = 1, 0.5, 0.25 ms against h = 0.125 ms
    T = 0.1
    ref = femb.simulate(model, T, 1.25e-4)
    eq, el = [], []
    for h in (1e-3, 5e-4, 2.5e-4):
        r = femb.simulate(model, T, h)
        eq.append(np.abs(model.difference(r.q[-1], ref.q[-1])).max())
        el.append(np.abs(r.lam[-1] - ref.lam[-1]).max() / np.abs(ref.lam[-1]).max())
    for e in (eq, el):
        orders = np.log2(np.array(e[:-1]) / np.array(e[1:]))
        assert np.all(orders > 1.8), (e, orders)
