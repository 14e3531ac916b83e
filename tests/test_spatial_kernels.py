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
from femb.errors import ModelError  # noqa: E402
from femb.functions import Harmonic, Polynomial  # noqa: E402
from femb.elements import spatial_joints as sj  # noqa: E402
from femb.elements.spatial_bodies import SpatialRigidBody, spatial_ground  # noqa: E402


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
