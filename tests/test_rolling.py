"""Rolling joints and the velocity-constraint role: kernels against finite differences, numbering, errors."""
import numpy as np
import pytest

import femb
from femb import Mechanism
from femb.base.jit import kernel
from femb.base.rotations import expm
from femb.elements import RigidBody
from femb.elements.rolling import KnifeEdge, PlanarWheel, RollingDisc, SpinRate
from femb.elements.spatial_bodies import SpatialRigidBody
from femb.elements.spatial_forces import SpatialGravity
from femb.errors import ModelError


def _disc_mechanism(tilt=0.3):
    m = Mechanism("disc")
    R0 = expm(np.array([tilt, 0.0, 0.2]))
    a = R0 @ np.array([0.0, 1.0, 0.0])
    n = np.array([0.0, 0.0, 1.0])
    c = n @ a
    d = (n - c * a) / np.sqrt(1.0 - c * c)
    m.add(SpatialRigidBody("disc", 1.0, (0.25, 0.5, 0.25), position=0.5 * d, rotation=R0,
                           omega=(0.1, 2.0, 0.3), velocity=(1.0, 0.2, 0.1)))
    m.add(RollingDisc("roll", "disc", 0.5, (0.0, 1.0, 0.0)))
    m.add(SpatialRigidBody("frame", 2.0, (0.3, 0.4, 0.5), position=(0.0, 0.0, 1.0)))
    m.add(SpinRate("drive", "frame", "disc", (0.0, 1.0, 0.0), 3.0))
    m.add(SpatialGravity())
    return m


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_disc_and_drive_kernels_match_finite_differences(seed):
    model = _disc_mechanism().compile()
    rep = femb.check_jacobians(model, seed=seed)
    assert rep.ok, str(rep)
    whats = {c.what for c in rep.checks if c.element_type == "RollingDisc"}
    assert {"velocity constraint: A", "velocity constraint: dPsi/dx (Dq)", "velocity constraint: H",
            "constraint: d(B^T lam)/dx (H)", "rates: gamma"} <= whats


def test_planar_wheel_and_knife_edge_kernels():
    m = Mechanism("planar")
    m.add(RigidBody("w", 1.0, 0.1, position=(0.0, 0.3), angle=0.2))
    m.add(PlanarWheel("pw", "w", 0.3))
    m.add(RigidBody("s", 1.0, 0.1, position=(1.0, 0.3), angle=0.2))
    m.add(KnifeEdge("k", "s", 0.3, (0.2, 0.1)))
    model = m.compile()
    assert (model.nc, model.nn) == (1, 2)
    rep = femb.check_jacobians(model)
    assert rep.ok, str(rep)


def test_numbering_and_models_without_velocity_constraints():
    model = _disc_mechanism().compile()
    assert model.nn == 3 and model.nc == 1
    assert list(model.mu_indices("roll")) == [0, 1] and list(model.mu_indices("drive")) == [2]
    assert model.mu_indices("disc").size == 0
    m = Mechanism("plain")
    m.add(RigidBody("b", 1.0, 0.1))
    plain = m.compile()
    assert plain.nn == 0 and plain.velocity_constraint_groups == [] and plain.mu_index == {}


def test_disc_contact_geometry_and_velocity_constraint_values():
    """The contact point is on the plane, below the centre; Ψ is the contact point's tangential velocity."""
    model = _disc_mechanism(tilt=0.4).compile()
    g = model.velocity_constraint_groups[0]
    x = model.node_coordinates("disc", model.q0)
    v = model.node_velocities("disc", model.qd0)
    cs = RollingDisc.contact_state(g.P[0], x, v, [-3.0], [0.5, -0.25])
    assert abs(cs["point"][2]) < 1e-12
    assert cs["normal_force"] == 3.0
    Psi = femb.system.assembly.velocity_constraints(model, 0.0, model.q0, model.qd0)[0]
    np.testing.assert_allclose(Psi[:2], [cs["slip_velocity"] @ g.P[0, 10:13], cs["slip_velocity"] @ g.P[0, 13:16]],
                               atol=1e-14)


def test_a_wrong_velocity_jacobian_is_reported():
    @kernel(allocates=True)
    def bad(P, t, tf, xe, ve, le, jac, Psi, A, Psi_t, Dq, H):
        for e in range(xe.shape[0]):
            s, c = np.sin(xe[e, 2]), np.cos(xe[e, 2])
            A[e, 0, 0], A[e, 0, 1] = -s, c
            Psi[e, 0] = -s * ve[e, 0] + c * ve[e, 1]
            if jac:
                Dq[e, 0, 2] = c * ve[e, 0] + s * ve[e, 1]     # sign error

    class BadSkate(KnifeEdge):
        kernels = {"velocity_constraint": bad}

    m = Mechanism("bad")
    m.add(RigidBody("s", 1.0, 0.1, angle=0.3))
    m.add(BadSkate("k", "s"))
    rep = femb.check_jacobians(m.compile())
    assert not rep.ok
    assert any(c.what == "velocity constraint: dPsi/dx (Dq)" for c in rep.failures)


def test_index2_refuses_velocity_constraints():
    m = Mechanism("skate")
    m.add(RigidBody("s", 1.0, 0.1))
    m.add(KnifeEdge("k", "s"))
    with pytest.raises(femb.errors.ParameterError, match="non-holonomic"):
        femb.simulate(m.compile(), 0.1, h=0.01, formulation="index2")


def test_bad_parameters_are_named():
    with pytest.raises(ModelError, match="RollingDisc 'r': radius"):
        RollingDisc("r", "disc", -1.0, (0, 1, 0))
    with pytest.raises(ModelError, match="parallel"):
        RollingDisc("r", "disc", 1.0, (0, 1, 0), normal=(0, 0, 1), tangent=(0, 0, 2))
    m = Mechanism("flat")
    m.add(SpatialRigidBody("disc", 1.0, (1, 1, 1)))
    m.add(RollingDisc("r", "disc", 0.5, (0, 0, 1)))
    with pytest.raises(ModelError, match="lies flat"):
        m.compile()
    m = Mechanism("planar_on_spatial")
    m.add(SpatialRigidBody("disc", 1.0, (1, 1, 1)))
    m.add(PlanarWheel("w", "disc", 0.5))
    with pytest.raises(ModelError, match="planar"):
        m.compile()
