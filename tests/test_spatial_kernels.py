"""Spatial joint, body and force kernels against finite differences on R³ × SO(3).

Every Jacobian is a derivative along x ⊕ δ = (r + δr, p ∘ exp(δθ)) (right
perturbation, body-axes δθ), as the kernel contract requires (docs/kernels.md).
"""
import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from spatial_fd import oplus, random_frame_state, random_quat, tangent_jacobian  # noqa: E402

from femb import Mechanism  # noqa: E402
from femb.base.functions import Harmonic, Polynomial  # noqa: E402
from femb.elements import spatial_joints as sj  # noqa: E402
from femb.elements.spatial_bodies import SpatialRigidBody, spatial_ground  # noqa: E402
from femb.errors import ModelError  # noqa: E402


def _bodies(rng, mech):
    a = SpatialRigidBody("A", 1.0, (1.0, 2.0, 2.5), position=rng.standard_normal(3), rotation=random_quat(rng))
    b = SpatialRigidBody("B", 2.0, (1.0, 1.5, 2.0), position=rng.standard_normal(3), rotation=random_quat(rng))
    mech.add(a, b)
    return a, b


def _lookup(mech):
    return lambda ref, role: mech[ref] if isinstance(ref, str) else ref


def _joints(rng, a, b):
    at = rng.standard_normal(3)
    ax = rng.standard_normal(3)
    n1 = np.cross(ax, rng.standard_normal(3))
    drive = Harmonic(0.7, 3.0, 0.2, offset=0.1)
    return [
        sj.SphericalJoint("sph", a, b, at=at),
        sj.RevoluteJoint("rev", a, b, at=at, axis=ax),
        sj.UniversalJoint("uni", a, b, axis_a=ax, axis_b=n1, at=at),
        sj.CylindricalJoint("cyl", a, b, point_a=rng.standard_normal(3), point_b=rng.standard_normal(3), axis=ax),
        sj.PrismaticJoint("pri", a, b, at=at, axis=ax, axis1=n1),
        sj.FixedJoint("fix", a, b, at=at, axis=ax),
        sj.DistanceJoint("dist", a, b, point_a=rng.standard_normal(3), point_b=rng.standard_normal(3)),
        sj.DrivenRevoluteAngle("drv", a, b, drive, at=at, axis=ax, angle0=0.4),
        sj.DrivenPrismaticDisplacement("drd", a, b, Polynomial([0.1, -0.5, 0.8, 0.3]), at=at, axis=ax),
        sj.SphericalJoint("sph_ground", "ground", b, at=at),
    ]


def _tf(el, t):
    fns = type(el).time_functions(el)
    return np.array([[[fn.f(t), fn.df(t), fn.ddf(t)] for fn in fns]]).reshape(1, len(fns), 3)


def _prepared(seed):
    rng = np.random.default_rng(seed)
    mech = Mechanism("kernels")
    a, b = _bodies(rng, mech)
    out = []
    for j in _joints(rng, a, b):
        j.resolve(_lookup(mech))
        j.validate()
        out.append(j)
    return rng, out


def _call(j, P, t, x, lam, jac=True):
    nc = j.n_constraints
    nel = x.shape[0]
    Phi = np.zeros((nel, nc))
    B = np.zeros((nel, nc, 12))
    H = np.zeros((nel, 12, 12))
    tf = np.repeat(_tf(j, t), nel, axis=0)
    j.kernels["constraint"](P, t, tf, np.ascontiguousarray(x), lam, jac, Phi, B, H)
    return Phi, B, H


@pytest.mark.parametrize("seed", range(3))
def test_joint_kernels_against_finite_differences(seed):
    rng, joints = _prepared(seed)
    t = 0.3 + 0.4 * seed
    for j in joints:
        nc = j.n_constraints
        P = type(j).pack([j, j])["P"]
        xe, ve = random_frame_state(rng, 2, 2)
        if j.name == "sph_ground":          # the ground node is fixed at the origin
            xe[:, 0:7] = [0, 0, 0, 1, 0, 0, 0]
        le = rng.standard_normal((2, nc))
        Phi, B, H = _call(j, P, t, xe, le)
        Phi2, B2, H2 = _call(j, P, t, xe, le, jac=False)
        np.testing.assert_array_equal(Phi, Phi2)
        np.testing.assert_array_equal(B, B2)
        assert not H2.any()
        J = tangent_jacobian(lambda x: _call(j, P, t, x, le)[0], xe)
        np.testing.assert_allclose(B, J, rtol=0, atol=1e-8 * max(1, np.abs(J).max()), err_msg=f"{j.name} B")
        HJ = tangent_jacobian(lambda x: np.einsum("ecd,ec->ed", _call(j, P, t, x, le)[1], le), xe)
        np.testing.assert_allclose(H, HJ, rtol=0, atol=1e-8 * max(1, np.abs(HJ).max()), err_msg=f"{j.name} H")
        # Φ_t and γ = d²/dε² Φ(x ∘ exp(εv), t + ε) at ε = 0 (B q̈ = −γ)
        Phi_t = np.zeros((2, nc))
        gam = np.zeros((2, nc))
        tf = np.repeat(_tf(j, t), 2, axis=0)
        j.kernels["rates"](P, t, tf, xe, ve, Phi_t, gam)
        eps = 1e-6
        Pt = (_call(j, P, t + eps, xe, le)[0] - _call(j, P, t - eps, xe, le)[0]) / (2 * eps)
        np.testing.assert_allclose(Phi_t, Pt, rtol=0, atol=1e-8, err_msg=f"{j.name} Phi_t")
        if not j.rheonomic:
            assert not Phi_t.any()
        e2 = 1e-4
        d2 = (_call(j, P, t + e2, oplus(xe, e2 * ve), le)[0] - 2 * Phi
              + _call(j, P, t - e2, oplus(xe, -e2 * ve), le)[0]) / e2**2
        np.testing.assert_allclose(gam, d2, rtol=0, atol=2e-5 * max(1, np.abs(d2).max()), err_msg=f"{j.name} gamma")


def test_joints_vanish_in_the_initial_configuration():
    rng, joints = _prepared(11)
    for j in joints:
        x = np.concatenate((j.a.node.q0, j.b.node.q0))[None]
        P = type(j).pack([j])["P"]
        Phi = _call(j, P, 0.0, x, np.zeros((1, j.n_constraints)))[0]
        if j.name == "drv":       # θ* = θ0 + φ(0) = 0.4 + 0.1 + 0.7 sin 0.2 differs from the initial 0
            assert abs(Phi[0, 0] + math.sin(0.5 + 0.7 * math.sin(0.2))) < 1e-14
        elif j.name == "drd":     # s(0) = 0.1
            assert abs(Phi[0, 0] + 0.1) < 1e-14
        else:
            np.testing.assert_allclose(Phi, 0.0, atol=1e-14, err_msg=j.name)


def test_reactions_have_the_documented_meaning():
    """Point rows: −B_bᵀλ on b's translation is +λ; a driven angle applies −λ ē3 on b."""
    rng, joints = _prepared(5)
    by = {j.name: j for j in joints}
    j = by["sph"]
    x = np.concatenate((j.a.node.q0, j.b.node.q0))[None]
    lam = rng.standard_normal((1, 3))
    _, B, _ = _call(j, type(j).pack([j])["P"], 0.0, x, lam)
    np.testing.assert_allclose(-(B[0].T @ lam[0])[6:9], lam[0], atol=1e-15)
    j = by["drv"]
    x = np.concatenate((j.a.node.q0, j.b.node.q0))[None]
    j.angle0 = -(0.1 + 0.7 * math.sin(0.2))     # θ* = 0 at t = 0: the initial configuration
    _, B, _ = _call(j, type(j).pack([j])["P"], 0.0, x, np.ones((1, 1)))
    Rb = j.b.node.rotation0
    moment_space = Rb @ (-(B[0, 0, 9:12]))           # body moment −B_θbᵀλ, to space axes
    np.testing.assert_allclose(moment_space, -j.E[:, 2], atol=1e-14)


def test_bad_joint_input_is_rejected():
    mech = Mechanism("bad")
    a = mech.add(SpatialRigidBody("A", 1.0, (1, 1, 1)))
    with pytest.raises(ModelError, match="perpendicular"):
        sj.UniversalJoint("u", "ground", a, axis_a=(1, 0, 0), axis_b=(1, 1, 0))
    with pytest.raises(ModelError, match="axis1 is parallel"):
        sj.RevoluteJoint("r", "ground", a, axis=(0, 0, 1), axis1=(0, 0, 2))
    d = sj.DistanceJoint("d", "ground", a)
    d.resolve(_lookup(mech))
    with pytest.raises(ModelError, match="length must be positive"):
        d.validate()
    with pytest.raises(ModelError, match="not a rotation matrix"):
        SpatialRigidBody("C", 1.0, (1, 1, 1), rotation=np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(ModelError, match="triangle inequality"):
        SpatialRigidBody("C", 1.0, (1, 1, 3))
    j = sj.SphericalJoint("s", "ground", a)
    j.resolve(_lookup(mech))
    assert j.a is spatial_ground(mech)


# ---------------------------------------------------------------------------
# forces
# ---------------------------------------------------------------------------
from femb.elements import spatial_forces as sf  # noqa: E402
from femb.elements.spatial_bodies import SpatialPointMass, rigid_body_force, rigid_body_mass  # noqa: E402


def _forces(rng, a, b):
    at = rng.standard_normal(3)
    ax = rng.standard_normal(3)
    return [
        sf.PointSpringDamper("spring", a, b, stiffness=30.0, damping=2.0, length=0.7,
                             point_a=rng.standard_normal(3), point_b=rng.standard_normal(3)),
        sf.Bushing("bush", a, b, stiffness=(10.0, 20.0, 30.0), rotational_stiffness=(4.0, 5.0, 6.0),
                   damping=(1.0, 2.0, 3.0), rotational_damping=(0.1, 0.2, 0.3), at=at, axis=ax),
        sf.RotationalSpringDamper("torsion", a, b, stiffness=7.0, damping=0.5, angle0=0.3, at=at, axis=ax),
        sf.SpatialForce("dead", a, (1.0, -2.0, 0.5), point=rng.standard_normal(3), function=Harmonic(1.0, 2.0, offset=0.5)),
        sf.SpatialForce("follower", b, (0.3, 2.0, -1.0), point=rng.standard_normal(3), follower=True),
        sf.SpatialTorque("dead_torque", a, (1.0, 0.5, -0.7)),
        sf.SpatialTorque("follower_torque", b, (1.0, 0.5, -0.7), follower=True),
    ]


def _fcall(el, P, t, x, v, jac=True):
    nel, ndv = x.shape[0], v.shape[1]
    fe = np.zeros((nel, ndv))
    fq = np.zeros((nel, ndv, ndv))
    fv = np.zeros((nel, ndv, ndv))
    fns = type(el).time_functions(el) if hasattr(type(el), "time_functions") else []
    tf = np.array([[[fn.f(t), fn.df(t), fn.ddf(t)] for fn in fns]] * nel).reshape(nel, len(fns), 3)
    el.kernels["force"](P, t, tf, np.ascontiguousarray(x), np.ascontiguousarray(v), jac, fe, fq, fv)
    return fe, fq, fv


@pytest.mark.parametrize("seed", range(3))
def test_force_kernels_against_finite_differences(seed):
    rng = np.random.default_rng(50 + seed)
    mech = Mechanism("forces")
    a, b = _bodies(rng, mech)
    t = 0.2 + seed
    for el in _forces(rng, a, b):
        el.resolve(_lookup(mech))
        el.validate()
        P = type(el).pack([el, el])["P"]
        nn = len(el.nodes())
        xe, ve = random_frame_state(rng, nn, 2)
        fe, fq, fv = _fcall(el, P, t, xe, ve)
        fe2, fq2, fv2 = _fcall(el, P, t, xe, ve, jac=False)
        np.testing.assert_array_equal(fe, fe2)
        assert not fq2.any() and not fv2.any()
        J = tangent_jacobian(lambda x: _fcall(el, P, t, x, ve)[0], xe)
        np.testing.assert_allclose(fq, J, rtol=0, atol=1e-7 * max(1, np.abs(J).max()), err_msg=f"{el.name} fq")
        eps = 1e-6
        Jv = np.zeros_like(fv)
        for j in range(ve.shape[1]):
            dv = np.zeros_like(ve)
            dv[:, j] = eps
            Jv[..., j] = (_fcall(el, P, t, xe, ve + dv)[0] - _fcall(el, P, t, xe, ve - dv)[0]) / (2 * eps)
        np.testing.assert_allclose(fv, Jv, rtol=0, atol=1e-7 * max(1, np.abs(Jv).max()), err_msg=f"{el.name} fv")
        if not type(el).traits([el])["force_depends_on_qd"]:
            assert not Jv.any()


def _potential(el, x):
    """Independent potential of an undamped spring element (numpy, from its definition)."""
    from femb.base import rotations as rt
    Ra = rt.quat_to_matrix(np.ascontiguousarray(x[3:7]))
    Rb = rt.quat_to_matrix(np.ascontiguousarray(x[10:14]))
    pa = x[0:3] + Ra @ el.Xa
    pb = x[7:10] + Rb @ el.Xb
    d = pb - pa
    if isinstance(el, sf.PointSpringDamper):
        return 0.5 * el.k * (np.linalg.norm(d) - el.L0) ** 2
    u = [Ra @ e for e in el.Ea]
    w = [Rb @ e for e in el.Eb]
    if isinstance(el, sf.Bushing):
        m = np.array([u[0] @ d, u[1] @ d, u[2] @ d, u[2] @ w[1], u[0] @ w[2], u[1] @ w[0]]) - el.m0
        return 0.5 * np.sum(el.K * m * m)
    th = math.atan2(u[1] @ w[0], u[0] @ w[0]) - el.angle0
    th = math.remainder(th, 2 * math.pi)
    return 0.5 * el.k * th * th


def test_undamped_springs_derive_from_their_potential():
    """f = −∂V/∂(δr, δθ) along x ⊕ δ, and f(x0) = 0 when relaxed at t0."""
    rng = np.random.default_rng(9)
    mech = Mechanism("cons")
    a, b = _bodies(rng, mech)
    for el in _forces(rng, a, b)[:3]:
        el.resolve(_lookup(mech))
        if isinstance(el, sf.PointSpringDamper):
            el.L0 = None
        el.validate()
        if isinstance(el, sf.Bushing):
            el.C[:] = 0.0
        else:
            el.c = 0.0
        x0 = np.concatenate((a.node.q0, b.node.q0))[None]
        v0 = np.zeros((1, 12))
        if isinstance(el, sf.RotationalSpringDamper):
            el.angle0 = 0.0
        P = type(el).pack([el])["P"]
        np.testing.assert_allclose(_fcall(el, P, 0.0, x0, v0)[0], 0.0, atol=1e-12, err_msg=el.name)
        if isinstance(el, sf.RotationalSpringDamper):
            el.angle0 = 0.3
            P = type(el).pack([el])["P"]
        for trial in range(3):
            xe = oplus(x0, 0.3 * rng.standard_normal((1, 12)))
            f = _fcall(el, P, 0.0, xe, v0)[0][0]
            gradV = tangent_jacobian(lambda x: np.array([[_potential(el, x[0])]]), xe)[0, 0]
            np.testing.assert_allclose(f, -gradV, atol=1e-7 * max(1, np.abs(gradV).max()), err_msg=el.name)


def test_rigid_body_kernels():
    rng = np.random.default_rng(2)
    J = np.array([[2.0, 0.1, -0.2], [0.1, 3.0, 0.3], [-0.2, 0.3, 2.5]])
    body = SpatialRigidBody("b", 1.5, J, rotation=random_quat(rng))
    P = SpatialRigidBody.pack([body, body])["P"]
    xe, ve = random_frame_state(rng, 1, 2)
    Me = np.zeros((2, 6, 6))
    rigid_body_mass(P, xe, Me)
    np.testing.assert_allclose(Me[0], np.block([[1.5 * np.eye(3), np.zeros((3, 3))], [np.zeros((3, 3)), J]]))
    fe = np.zeros((2, 6)); fq = np.zeros((2, 6, 6)); fv = np.zeros((2, 6, 6))
    rigid_body_force(P, 0.0, np.zeros((2, 0, 3)), xe, ve, True, fe, fq, fv)
    np.testing.assert_allclose(fe[:, 3:], -np.cross(ve[:, 3:], ve[:, 3:] @ J.T), atol=1e-14)
    assert not fe[:, :3].any() and not fq.any()
    eps = 1e-6
    for j in range(6):
        dv = np.zeros_like(ve)
        dv[:, j] = eps
        fp = np.zeros((2, 6)); fm = np.zeros((2, 6)); z = np.zeros((2, 6, 6))
        rigid_body_force(P, 0.0, np.zeros((2, 0, 3)), xe, ve + dv, False, fp, z, z)
        rigid_body_force(P, 0.0, np.zeros((2, 0, 3)), xe, ve - dv, False, fm, z, z)
        np.testing.assert_allclose(fv[:, :, j], (fp - fm) / (2 * eps), atol=1e-8)
    pm = SpatialPointMass("pm", 2.0)
    assert list(pm.node.fixed) == [False] * 3 + [True] * 4 and list(pm.node.fixed_v) == [False] * 3 + [True] * 3


def test_named_axes_and_inertia_about_a_point():
    mech = Mechanism("named")
    R0 = random_quat(np.random.default_rng(4))
    a = mech.add(SpatialRigidBody("A", 15.0, (15.234375, 0.46875, 15.234375), rotation=R0,
                                  points={"O": (0.0, -1.0, 0.0)}, axes={"spin": (0, 1, 0), "side": (1, 0, 0)},
                                  inertia_at="O"))
    np.testing.assert_allclose(a.J, np.diag([0.234375, 0.46875, 0.234375]), atol=1e-13)
    j = sj.RevoluteJoint("r", a, "ground", point_a="O", axis="spin", axis1="side")
    j.resolve(_lookup(mech))
    j.validate()
    np.testing.assert_allclose(j.E[:, 2], a.node.rotation0 @ [0, 1, 0], atol=1e-15)
    np.testing.assert_allclose(j.E[:, 0], a.node.rotation0 @ [1, 0, 0], atol=1e-15)
    np.testing.assert_allclose(j.Ea[2], [0, 1, 0], atol=1e-15)
    # universal: axis_a names an axis of a, axis_b one of b
    b = mech.add(SpatialRigidBody("B", 1.0, (1, 1, 1), rotation=R0, axes={"pin": (1, 0, 0)}))
    u = sj.UniversalJoint("u", a, b, axis_a="spin", axis_b="pin", at=(0, 0, 0))
    u.resolve(_lookup(mech))
    u.validate()
    np.testing.assert_allclose(u.Ea[1], [0, 1, 0], atol=1e-15)
    np.testing.assert_allclose(u.Eb[0], [1, 0, 0], atol=1e-15)
    w = sj.UniversalJoint("w", a, b, axis_a="spin", axis_b=a.node.rotation0 @ [0, 1, 0], at=(0, 0, 0))
    w.resolve(_lookup(mech))
    with pytest.raises(ModelError, match="perpendicular"):
        w.validate()
    k = sj.RevoluteJoint("k", a, "ground", axis="nope")
    k.resolve(_lookup(mech))
    with pytest.raises(ModelError, match="no axis named 'nope'"):
        k.validate()
