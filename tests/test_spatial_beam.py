"""SpatialBeam (two-node SE(3) beam, elements/spatial_beam.py): kernels and strain measure.

Every Jacobian is checked along x ⊕ δ = (r + δr, p ∘ exp(δθ)) (docs/kernels.md);
the strain is checked against an independent SE(3) matrix logarithm, under
superposed rigid motions (also past 2π) and on helices (Sonneville, Cardona &
Brüls 2014: the element is exact for constant strain).
"""
import math
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla

sys.path.insert(0, str(Path(__file__).parent))
from spatial_fd import oplus, random_quat, tangent_jacobian  # noqa: E402

from femb.base import rotations as rt  # noqa: E402
from femb.elements import spatial_beam as sb  # noqa: E402
from femb.elements.spatial_beam import (SpatialBeam, SpatialBeamNode, SpatialSection,  # noqa: E402
                                        spatial_beam, spatial_beam_force, spatial_beam_mass)
from femb import Mechanism  # noqa: E402
from femb.errors import ModelError  # noqa: E402


def _section(damping=0.0):
    C = np.diag([10.0, 3.0, 4.0, 2.0, 5.0, 6.0]) + 0.3 * np.ones((6, 6))     # full, coupled C
    return SpatialSection(C, 2.0, (3.0, 1.0, 2.0), damping=damping)


def _element(rng, damping=0.0, mass="consistent"):
    nA = SpatialBeamNode("A", rng.standard_normal(3), random_quat(rng))
    nB = SpatialBeamNode("B", nA.node.q0[:3] + np.array([1.2, 0.3, -0.2]), random_quat(rng))
    Fa = rt.quat_to_matrix(random_quat(rng))
    Fb = Fa @ rt.expm(np.array([0.2, -0.3, 0.4]))        # a curved, twisted reference
    el = SpatialBeam("e", nA, nB, _section(damping), mass=mass, frame_a=Fa, frame_b=Fb)
    el.validate()
    x0 = np.concatenate((nA.node.q0, nB.node.q0))[None]
    return el, SpatialBeam.pack([el]), x0


def _force(P, xe, ve, jac=True):
    n = xe.shape[0]
    fe, fq, fv = np.zeros((n, 12)), np.zeros((n, 12, 12)), np.zeros((n, 12, 12))
    spatial_beam_force(P, 0.0, np.zeros((n, 0, 3)), xe, ve, jac, fe, fq, fv)
    return fe, fq, fv


def _rel(a, b):
    return np.abs(a - b).max() / np.abs(b).max()


@pytest.mark.parametrize("damping", [0.0, 0.05])
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_jacobians_against_finite_differences(seed, damping):
    rng = np.random.default_rng(seed)
    _, p, x0 = _element(rng, damping)
    P = p["P"]
    xe = oplus(x0, 0.6 * rng.standard_normal((1, 12)))          # large deformation
    ve = rng.standard_normal((1, 12))
    fe, fq, fv = _force(P, xe, ve)
    Jq = tangent_jacobian(lambda x: _force(P, x, ve, False)[0], xe)
    assert _rel(fq, Jq) < 1e-6
    Jv = np.zeros((1, 12, 12))
    h = 1e-6
    for j in range(12):
        dv = np.zeros((1, 12))
        dv[0, j] = h
        Jv[..., j] = (_force(P, xe, ve + dv, False)[0] - _force(P, xe, ve - dv, False)[0]) / (2 * h)
    assert _rel(fv, Jv) < 1e-6
    # the mass matrix is constant: the same at every configuration, and dM/dq = 0
    M1, M2 = np.zeros((1, 12, 12)), np.zeros((1, 12, 12))
    spatial_beam_mass(P, x0, M1)
    spatial_beam_mass(P, xe, M2)
    assert np.array_equal(M1, M2)
    assert np.allclose(M1[0], M1[0].T)
    assert np.linalg.eigvalsh(M1[0]).min() > 0.0


@pytest.mark.parametrize("damping", [0.0, 0.05])
def test_meshed_element_fast_paths(damping):
    """The production paths: identity section offsets and a diagonal C (flags in P, 43 numbers per
    element), with rotary inertia: Jacobians against differences; in a batch with a full-C element
    (the 79-number layout) the same element gives the same forces and Jacobians bit for bit."""
    rng = np.random.default_rng(7)
    m = Mechanism("k")
    sec = SpatialSection.from_properties(10.0, 3.0, 4.0, 2.0, 5.0, 6.0, rhoA=2.0, rhoJ=(3.0, 1.0, 2.0),
                                         damping=damping)
    b = spatial_beam(m, "b", sec, [(0, 0, 0), (1.2, 0.3, -0.2)], 1)
    el = b.elements[0]
    p = SpatialBeam.pack([el])
    P = p["P"]
    assert P.shape[1] == sb.NPAR_DIAG and int(P[0, sb.FLAGS]) == sb.F_DIAG | sb.F_IDENT | sb.F_ROTARY
    x0 = np.concatenate((el.a.node.q0, el.b.node.q0))[None]
    xe = oplus(x0, 0.6 * rng.standard_normal((1, 12)))
    ve = rng.standard_normal((1, 12))
    fe, fq, fv = _force(P, xe, ve)
    Jq = tangent_jacobian(lambda x: _force(P, x, ve, False)[0], xe)
    assert _rel(fq, Jq) < 1e-6
    h = 1e-6
    Jv = np.zeros((1, 12, 12))
    for j in range(12):
        dv = np.zeros((1, 12))
        dv[0, j] = h
        Jv[..., j] = (_force(P, xe, ve + dv, False)[0] - _force(P, xe, ve - dv, False)[0]) / (2 * h)
    assert _rel(fv, Jv) < 1e-6
    full, _, xf = _element(rng, damping)
    Pm = SpatialBeam.pack([el, full])["P"]
    assert Pm.shape[1] == sb.NPAR
    np.testing.assert_array_equal(sb.section_stiffness(Pm), np.stack([sec.C, full.section.C]))
    np.testing.assert_array_equal(sb.section_stiffness(P), sec.C[None])
    fe2, fq2, fv2 = _force(np.ascontiguousarray(Pm), np.concatenate((xe, xf)), np.concatenate((ve, ve)))
    np.testing.assert_array_equal(fe2[0], fe[0])
    np.testing.assert_array_equal(fq2[0], fq[0])
    np.testing.assert_array_equal(fv2[0], fv[0])


def test_force_is_the_energy_gradient():
    rng = np.random.default_rng(7)
    _, p, x0 = _element(rng)
    xe = oplus(x0, 0.6 * rng.standard_normal((1, 12)))
    fe = _force(p["P"], xe, np.zeros((1, 12)), False)[0]
    g = tangent_jacobian(lambda x: SpatialBeam.strain_energy(p, x), xe)
    assert _rel(-g, fe) < 1e-8


def _H(q, Rbar):
    M = np.eye(4)
    M[:3, :3] = rt.quat_to_matrix(np.ascontiguousarray(q[3:7])) @ Rbar
    M[:3, 3] = q[:3]
    return M


def test_relative_motion_is_the_se3_logarithm():
    rng = np.random.default_rng(11)
    _, p, x0 = _element(rng)
    P = p["P"][0]
    xe = oplus(x0, 0.6 * rng.standard_normal((1, 12)))
    Ra = rt.quat_to_matrix(np.ascontiguousarray(P[sb.QA:sb.QA + 4]))
    Rb = rt.quat_to_matrix(np.ascontiguousarray(P[sb.QB:sb.QB + 4]))
    G = np.linalg.solve(_H(xe[0, :7], Ra), _H(xe[0, 7:], Rb))
    Lg = sla.logm(G).real
    d_ref = np.array([Lg[0, 3], Lg[1, 3], Lg[2, 3], Lg[2, 1], Lg[0, 2], Lg[1, 0]])
    d = SpatialBeam.strains(p, xe)[0] * P[sb.LEN] + P[sb.D0:sb.D0 + 6]
    assert np.abs(d - d_ref).max() < 1e-12 * np.abs(d_ref).max()


def _rigid(xe, qr, c):
    """Superpose the rigid motion x → R x + c, p → p_r ⊗ p on both nodes."""
    out = xe.copy()
    R = rt.quat_to_matrix(qr)
    for k in (0, 7):
        out[0, k:k + 3] = R @ xe[0, k:k + 3] + c
        out[0, k + 3:k + 7] = rt.quat_mul(qr, xe[0, k + 3:k + 7])
    return out


def test_strain_and_force_objective_under_rigid_motion_past_two_pi():
    rng = np.random.default_rng(5)
    _, p, x0 = _element(rng)
    xe = oplus(x0, 0.5 * rng.standard_normal((1, 12)))
    eps = SpatialBeam.strains(p, xe)
    fe = _force(p["P"], xe, np.zeros((1, 12)), False)[0]
    axis = rng.standard_normal(3)
    axis /= np.linalg.norm(axis)
    # unstrained reference stays unstrained; strained state keeps its strain; 15 steps of 0.5 rad
    # (7.5 rad > 2π), composed incrementally as a time integrator does
    y0, y = x0.copy(), xe.copy()
    inc = rt.quat_exp(0.5 * axis)
    for k in range(15):
        c = rng.standard_normal(3)
        y0, y = _rigid(y0, inc, c), _rigid(y, inc, c)
        assert np.abs(SpatialBeam.strains(p, y0)).max() < 1e-13
        assert np.abs(SpatialBeam.strains(p, y) - eps).max() < 1e-12
    # nodal forces rotate with the motion (x rows in space axes; θ rows in body axes are unchanged)
    R = rt.quat_to_matrix(rt.quat_exp(7.5 * axis))
    f1 = _force(p["P"], y, np.zeros((1, 12)), False)[0]
    for k in (0, 6):
        assert np.allclose(f1[0, k:k + 3], R @ fe[0, k:k + 3], atol=1e-11 * np.abs(fe).max())
        assert np.allclose(f1[0, k + 3:k + 6], fe[0, k + 3:k + 6], atol=1e-11 * np.abs(fe).max())
    # p ≡ −p: flipping a stored quaternion changes nothing
    z = y.copy()
    z[0, 10:14] *= -1.0
    assert np.abs(SpatialBeam.strains(p, z) - eps).max() < 1e-12


@pytest.mark.parametrize("strain", [(0.1, 0.05, -0.02, 0.3, -0.2, 0.25),
                                    (0.0, 0.0, 0.0, 0.4, 0.0, 0.0),
                                    (-0.05, 0.02, 0.03, 0.5, 1.2, -0.9)])
@pytest.mark.parametrize("L", [0.01, 1.0, 1.9])   # |κ| L up to 3.0 rad (< π: one element spans less than a half turn)
def test_helix_exact_for_any_element_length(strain, L):
    """Nodes on a helix H_B = H_A exp(L ε_h): one straight-reference element gives ε = ε_h − (1, 0…) exactly."""
    rng = np.random.default_rng(3)
    eh = np.array([1.0, 0, 0, 0, 0, 0]) + np.array(strain)
    qa = random_quat(rng)
    xa = rng.standard_normal(3)
    Ra = rt.quat_to_matrix(qa)
    nA = SpatialBeamNode("A", xa, qa)
    nB = SpatialBeamNode("B", xa + L * Ra[:, 0], qa)
    el = SpatialBeam("e", nA, nB, _section())
    el.validate()
    p = SpatialBeam.pack([el])
    # exact helix end by the 4 × 4 matrix exponential of L ε_h
    X = np.zeros((4, 4))
    X[:3, :3] = rt.skew(L * eh[3:])
    X[:3, 3] = L * eh[:3]
    Hb = np.eye(4)
    Hb[:3, :3] = Ra
    Hb[:3, 3] = xa
    Hb = Hb @ sla.expm(X)
    xe = np.concatenate((xa, qa, Hb[:3, 3], rt.matrix_to_quat(np.ascontiguousarray(Hb[:3, :3]))))[None]
    eps = SpatialBeam.strains(p, xe)[0]
    assert np.abs(eps - (eh - [1, 0, 0, 0, 0, 0])).max() < 2e-15 / min(L, 1.0) * 10


def test_lumped_and_consistent_mass_and_gravity_load():
    rng = np.random.default_rng(2)
    for kind, (md, mo) in (("consistent", (1 / 3, 1 / 6)), ("lumped", (1 / 2, 0.0))):
        el, p, x0 = _element(rng, mass=kind)
        M = np.zeros((1, 12, 12))
        spatial_beam_mass(p["P"], x0, M)
        m = el.section.rhoA * el.L
        assert np.allclose(M[0, 0:3, 0:3], md * m * np.eye(3)) and np.allclose(M[0, 0:3, 6:9], mo * m * np.eye(3))
        g = np.array([0.0, 0.0, -9.81])
        ghat = np.concatenate((g, 0 * g, g, 0 * g))
        F = M[0] @ ghat
        assert np.allclose(F[0:3] + F[6:9], m * g) and np.allclose(F[0:3], 0.5 * m * g)   # ρA L g, half per node
        # rotary inertia ρJ L/2 per node in node axes
        Rb = rt.quat_to_matrix(np.ascontiguousarray(el.qbar_a))
        assert np.allclose(M[0, 3:6, 3:6], Rb @ el.section.rhoJ @ Rb.T * el.L / 2)


def test_sections():
    E, G = 2.1e11, 8.0e10
    r = SpatialSection.rectangle(E, G, 0.02, 0.05, 7850.0)
    assert np.allclose(np.diag(r.C)[[0, 4, 5]], [E * 1e-3, E * 0.02 * 0.05 ** 3 / 12, E * 0.05 * 0.02 ** 3 / 12])
    # torsion constant of a square: 0.1406 a⁴ (Roark): formula gives 0.1408 a⁴
    sq = SpatialSection.rectangle(E, G, 1.0, 1.0)
    assert abs(sq.C[3, 3] / G - 0.1406) < 0.002
    c = SpatialSection.circle(E, E / 2.0, 0.1)           # ν = 0: Cowper k = 6/7
    assert abs(c.C[1, 1] / (E / 2 * math.pi * 0.0025) - 6 / 7) < 1e-14
    t = SpatialSection.tube(E, G, 0.1, 0.0)
    assert np.allclose(t.C, SpatialSection.circle(E, G, 0.1).C)
    with pytest.raises(Exception):
        SpatialSection(np.diag([1, 1, 1, 1, 1, -1.0]))


@pytest.mark.parametrize("make, words", [
    (lambda: SpatialSection.circle(2.1e11, 8.1e10, -0.02, 7850.0), "diameter"),
    (lambda: SpatialSection.rectangle(2.1e11, 8.1e10, 0.0, 0.01), "width"),
    (lambda: SpatialSection.rectangle(2.1e11, 8.1e10, 0.01, float("nan")), "height"),
    (lambda: SpatialSection.tube(2.1e11, 8.1e10, "big", 0.01), "outer_diameter"),
])
def test_section_helpers_refuse_bad_dimensions(make, words):
    with pytest.raises(ModelError, match=words):
        make()


@pytest.mark.parametrize("path", [[(0, 0, 0), (0, 0, 0)], [(0, 0, 0), (1, 0, 0), (1, 0, 0)],
                                  lambda s: np.array([1.0, 2.0, 3.0])])
def test_mesher_refuses_a_beam_axis_without_direction(path):
    sec = SpatialSection.circle(2.1e11, 8.1e10, 0.02, 7850.0)
    m = Mechanism("zero")
    with pytest.raises(ModelError, match="spatial_beam 'b'.*no direction"):
        spatial_beam(m, "b", sec, path, 4, start="clamp")
