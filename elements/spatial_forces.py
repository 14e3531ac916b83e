"""Spatial force elements: springs, dampers, bushings, loads and gravity (compiled kernels).

Sign convention M v̇ = f − Bᵀλ: a kernel returns the generalized force f on the
tangent coordinates (δr in space axes, δθ in body axes) of its nodes, and
``fq = ∂f/∂(δr, δθ)`` (right perturbation R ← R exp(δθ~)), ``fv = ∂f/∂v``.

Spring–damper elements are written through *measures* m_k(x) (a length, a
relative displacement component, a rotation component, an angle) with gradient
g_k = ∂m_k/∂(δr, δθ) and Hessian H_k = ∂g_k/∂(δr, δθ): with the internal force
F_k = K_k (m_k − m0_k) + C_k ṁ_k, ṁ_k = g_k·v,

    f = −Σ F_k g_k,   fq = −Σ (F_k H_k + g_k (K_k g_k + C_k Hₖᵀv)ᵀ),   fv = −Σ C_k g_k g_kᵀ.

With C = 0 the element derives from the potential ½ Σ K_k (m_k − m0_k)²: it is
conservative.

References
----------
M. Géradin, A. Cardona, Flexible Multibody Dynamics, Wiley, 2001, Ch. 5 and 8.
O. Brüls, A. Cardona, On the use of Lie group time integrators in multibody
dynamics, J. Comput. Nonlinear Dynam. 5(3):031002, 2010 (loads on R³ × SO(3)).
"""
from __future__ import annotations

import math

import numpy as np

from femb.base import rotations as rt
from femb.base.functions import Constant, as_time_function, evaluate
from femb.base.geometry import GeometryBlock
from femb.base.jit import kernel
from femb.errors import ModelError
from femb.system.element import Element

from . import _spatial as sp
from . import _spatial_geometry as sg
from .bodies import _check_scalar
from .forces import Gravity
from .spatial_bodies import vector3
from .spatial_joints import A1, A2, A3, B1, B2, B3, SpatialPairElement, _resolve_spatial, pair_points


# ---------------------------------------------------------------------------
# measure forces
# ---------------------------------------------------------------------------
@kernel
def _tension(m, g, K, C, m0, v):
    """F = K (m − m0) + C ṁ, ṁ = g·v (v a 12-vector of tuples)."""
    return K * (m - m0) + C * sp.dot12(g, v)


@kernel
def _add_measure(F, g, hv, K, C, jac, fe, fq, fv):
    """Add a measure's force −F g to fe and, if ``jac``, −g (K g + C vᵀH)ᵀ to fq and −C g gᵀ to fv.

    The caller has added −F H (H the measure's Hessian) to fq itself; hv = vᵀH.
    """
    sp.axpy_row(fe, -F, g)
    if jac:
        sp.add_outer12(fq, -1.0, g, sp.lin12(K, g, C, hv))
        if C != 0.0:
            sp.add_outer12(fv, -C, g, g)


@kernel
def point_spring_force(P, t, tf, xe, ve, jac, fe, fq, fv):
    """Point-to-point spring–damper: measure ℓ = |p_b − p_a|; P = (frame (24), k, c, ℓ0).

    g = nᵀG, H = Gᵀ(I − nnᵀ)G/ℓ + blockdiag(0, −X_a~(R_aᵀn)~, 0, X_b~(R_bᵀn)~),
    n = d/ℓ, δd = G δq = [−I, R_a X_a~, I, −R_b X_b~] δq. ℓ = 0 gives NaN (direction undefined).
    """
    for e in range(xe.shape[0]):
        Pe = P[e]
        F = sp.frames(Pe, xe[e])
        Ra, Rb, Rab, Xa, Xb, rb, pa, pb, d, xa = F
        v = sp.vec12(ve[e])
        L = math.sqrt(sp.dot3(d, d))
        il = 1.0 / L if L > 0.0 else math.nan
        n = sp.scale3(il, d)
        G0 = sp.neg9(sp.I9)
        G1 = sp.rskew(Ra, Xa)
        G3 = sp.neg9(sp.rskew(Rb, Xb))
        g = (sp.mtv(G0, n), sp.mtv(G1, n), n, sp.mtv(G3, n))
        K, C = Pe[24], Pe[25]
        Fk = _tension(L, g, K, C, Pe[26], v)
        hv = sp.Z12
        if jac:
            c = -Fk * il
            hg = sp.gtg(fq[e], True, c, G0, G1, sp.I9, G3, v)
            sp.add_outer12(fq[e], -c, g, g)
            ha = sp.blk(fq[e], True, 3, 3, -Fk, sp.neg9(sp.skskw(Xa, sp.mtv(Ra, n))), v[1])
            hb = sp.blk(fq[e], True, 9, 9, -Fk, sp.skskw(Xb, sp.mtv(Rb, n)), v[3])
            gv = sp.dot12(g, v)
            hv = sp.lin12(il, hg, -gv * il, g)
            hv = (hv[0], sp.add3(hv[1], ha), hv[2], sp.add3(hv[3], hb))
        _add_measure(Fk, g, hv, K, C, jac, fe[e], fq[e], fv[e])


@kernel
def _bushing_measure(k, Pe, F, H, add, c, v):
    """Measure k of a bushing: Δ_k = u_k·d (k < 3, dot-2) or ψ_(k−3) (dot-1); (m, g, vᵀH)."""
    if k < 3:
        return sp.dot2(sp.vec3(Pe, A1 + 3 * k), 0.0, F, H, add, c, v)
    if k == 3:
        return sp.dot1(sp.vec3(Pe, A3), sp.vec3(Pe, B2), F, H, add, c, v)
    if k == 4:
        return sp.dot1(sp.vec3(Pe, A1), sp.vec3(Pe, B3), F, H, add, c, v)
    return sp.dot1(sp.vec3(Pe, A2), sp.vec3(Pe, B1), F, H, add, c, v)


@kernel
def bushing_force(P, t, tf, xe, ve, jac, fe, fq, fv):
    """Six-component bushing; P = (frame (24), K (6), C (6), m0 (6)).

    Measures in the joint frame of a: Δ_k = u_k·d − Δ0_k (k = 1, 2, 3; dot-2) and
    ψ = (u3·w2, u1·w3, u2·w1) (dot-1; the small relative rotation about ē1, ē2, ē3).
    """
    for e in range(xe.shape[0]):
        Pe = P[e]
        F = sp.frames(Pe, xe[e])
        v = sp.vec12(ve[e])
        for k in range(6):
            K, C = Pe[24 + k], Pe[30 + k]
            m, g, hv = _bushing_measure(k, Pe, F, fq[e], False, 0.0, v)
            Fk = _tension(m, g, K, C, Pe[36 + k], v)
            if jac:
                _bushing_measure(k, Pe, F, fq[e], True, -Fk, v)
            _add_measure(Fk, g, hv, K, C, jac, fe[e], fq[e], fv[e])


@kernel
def rotational_spring_force(P, t, tf, xe, ve, jac, fe, fq, fv):
    """Rotational spring–damper about ē3: measure θ = atan2(s, c) ∈ (−π, π].

    s = (R_a ā2)·w1, c = (R_a ā1)·w1 with ā1 = cos θ0 ē_a1 + sin θ0 ē_a2,
    ā2 = −sin θ0 ē_a1 + cos θ0 ē_a2 (θ0 the unstretched angle), w1 = R_b ē_b1;
    g = (c g_s − s g_c)/ρ, ρ = s² + c²,
    H = (g_s g_cᵀ − g_c g_sᵀ + c H_s − s H_c)/ρ − (c g_s − s g_c)(2 s g_s + 2 c g_c)ᵀ/ρ².
    P = (frame (24), k, c, θ0).
    """
    for e in range(xe.shape[0]):
        Pe = P[e]
        F = sp.frames(Pe, xe[e])
        v = sp.vec12(ve[e])
        th0 = Pe[26]
        ct, st = math.cos(th0), math.sin(th0)
        e1 = sp.vec3(Pe, A1)
        e2 = sp.vec3(Pe, A2)
        a1 = (ct * e1[0] + st * e2[0], ct * e1[1] + st * e2[1], ct * e1[2] + st * e2[2])
        a2 = (-st * e1[0] + ct * e2[0], -st * e1[1] + ct * e2[1], -st * e1[2] + ct * e2[2])
        b1 = sp.vec3(Pe, B1)
        s, gs, hs = sp.dot1(a2, b1, F, fq[e], False, 0.0, v)
        c, gc, hc = sp.dot1(a1, b1, F, fq[e], False, 0.0, v)
        rho = s * s + c * c
        g = sp.lin12(c / rho, gs, -s / rho, gc)
        K, C = Pe[24], Pe[25]
        Fk = _tension(math.atan2(s, c), g, K, C, 0.0, v)
        hv = sp.Z12
        if jac:
            # fq −= F H, H as in the docstring
            sp.dot1(a2, b1, F, fq[e], True, -Fk * c / rho, v)
            sp.dot1(a1, b1, F, fq[e], True, Fk * s / rho, v)
            sp.add_outer12(fq[e], -Fk / rho, gs, gc)
            sp.add_outer12(fq[e], Fk / rho, gc, gs)
            r2 = sp.lin12(2.0 * s, gs, 2.0 * c, gc)
            sp.add_outer12(fq[e], Fk / rho, g, r2)
            # vᵀH
            hv = sp.lin12(sp.dot12(v, gs) / rho, gc, -sp.dot12(v, gc) / rho, gs)
            hv = sp.lin12(1.0, hv, 1.0, sp.lin12(c / rho, hs, -s / rho, hc))
            hv = sp.lin12(1.0, hv, -sp.dot12(v, g) / rho, r2)
        _add_measure(Fk, g, hv, K, C, jac, fe[e], fq[e], fv[e])


# ---------------------------------------------------------------------------
# potentials: V = ½ Σ K_k (m_k − m0_k)², the conservative part of the forces above
# ---------------------------------------------------------------------------
@kernel
def point_spring_energy(P, t, tf, xe, Ve):
    """V = ½ k (ℓ − ℓ0)² of point springs (P as :func:`point_spring_force`)."""
    for e in range(xe.shape[0]):
        Pe = P[e]
        d = sp.frames(Pe, xe[e])[8]
        dl = math.sqrt(sp.dot3(d, d)) - Pe[26]
        Ve[e] = 0.5 * Pe[24] * dl * dl


@kernel
def bushing_energy(P, t, tf, xe, Ve):
    """V = ½ Σ K_k (m_k − m0_k)² of bushings, m = (u_k·d, u3·w2, u1·w3, u2·w1) (u = R_a ā_k,
    w = R_b b̄_k; P as :func:`bushing_force`)."""
    for e in range(xe.shape[0]):
        Pe = P[e]
        F = sp.frames(Pe, xe[e])
        Ra, Rb, d = F[0], F[1], F[8]
        u1 = sp.mv(Ra, sp.vec3(Pe, A1))
        u2 = sp.mv(Ra, sp.vec3(Pe, A2))
        u3 = sp.mv(Ra, sp.vec3(Pe, A3))
        m = (sp.dot3(u1, d), sp.dot3(u2, d), sp.dot3(u3, d),
             sp.dot3(u3, sp.mv(Rb, sp.vec3(Pe, B2))), sp.dot3(u1, sp.mv(Rb, sp.vec3(Pe, B3))),
             sp.dot3(u2, sp.mv(Rb, sp.vec3(Pe, B1))))
        V = 0.0
        for k in range(6):
            dm = m[k] - Pe[36 + k]
            V += 0.5 * Pe[24 + k] * dm * dm
        Ve[e] = V


@kernel
def rotational_spring_energy(P, t, tf, xe, Ve):
    """V = ½ k θ², θ = atan2((R_a ā2)·w1, (R_a ā1)·w1) (P as :func:`rotational_spring_force`)."""
    for e in range(xe.shape[0]):
        Pe = P[e]
        Ra, Rb = sp.frames(Pe, xe[e])[0:2]
        ct, st = math.cos(Pe[26]), math.sin(Pe[26])
        u1 = sp.mv(Ra, sp.vec3(Pe, A1))
        u2 = sp.mv(Ra, sp.vec3(Pe, A2))
        w1 = sp.mv(Rb, sp.vec3(Pe, B1))
        c1, c2 = sp.dot3(u1, w1), sp.dot3(u2, w1)
        th = math.atan2(-st * c1 + ct * c2, ct * c1 + st * c2)
        Ve[e] = 0.5 * Pe[24] * th * th


class PointSpringDamper(SpatialPairElement):
    """Linear spring–damper between point p_a of a and p_b of b.

    Tension N = k (ℓ − ℓ0) + c ℓ̇, ℓ = |p_b − p_a|, pulls the points together:
    force −N n on b at p_b and +N n on a at p_a (n = (p_b − p_a)/ℓ).

    Parameters
    ----------
    name, a, b : see :class:`~femb.elements.spatial_joints.SpatialPairElement`
    stiffness : float ≥ 0 (N/m)
    damping : float ≥ 0 (N s/m)
    length : float ≥ 0, optional
        Unstretched length ℓ0 (default: the distance at t0).
    point_a, point_b : str or (3,)
    """

    glyph = "spring"

    has_force = True
    force_depends_on_qd = True
    work = "potential"
    kernels = {"force": point_spring_force, "energy": point_spring_energy}

    def __init__(self, name, a, b, stiffness, damping=0.0, length=None, point_a=None, point_b=None):
        super().__init__(name, a, b, None, point_a, point_b)
        owner = f"PointSpringDamper '{name}'"
        self.k = _check_scalar(owner, "stiffness", stiffness, nonneg=True)
        self.c = _check_scalar(owner, "damping", damping, nonneg=True)
        self.L0 = None if length is None else _check_scalar(owner, "length", length, nonneg=True)

    def validate(self):
        super().validate()
        if self.L0 is None:
            self.L0 = float(np.linalg.norm(self.b.global_point(self.Xb) - self.a.global_point(self.Xa)))

    @classmethod
    def traits(cls, elements):
        tr = super().traits(elements)
        tr["force_depends_on_qd"] = any(e.c != 0.0 for e in elements)
        return tr

    @classmethod
    def pack(cls, elements):
        p = _frame_pack(elements)
        p["P"] = np.ascontiguousarray(np.hstack((p["P"], [[e.k, e.c, e.L0] for e in elements])))
        return p

    @classmethod
    def geometry(cls, p, t, qe, qde, lame, names):
        """One line p_a → p_b per spring with cell data ``tension`` N = k(ℓ − ℓ0) + cℓ̇ (N,
        positive pulls the points together) and ``length`` ℓ (m); qe (nel, 14), qde (nel, 12)."""
        qe = np.asarray(qe, dtype=float)
        qde = np.asarray(qde, dtype=float)
        pa, va = sg.material_points(qe[:, 0:7], qde[:, 0:6], p["Xa"])
        pb, vb = sg.material_points(qe[:, 7:14], qde[:, 6:12], p["Xb"])
        d = pb - pa
        L = np.linalg.norm(d, axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            Ld = np.where(L > 0.0, np.einsum("ij,ij->i", d, vb - va) / np.where(L > 0.0, L, 1.0), 0.0)
        k, c, L0 = p["P"][:, 24], p["P"][:, 25], p["P"][:, 26]
        n = L.size
        return [GeometryBlock(cls.__name__, np.vstack((pa, pb)),
                              [("line", np.column_stack((np.arange(n), n + np.arange(n))))],
                              cell_data={"tension": [k * (L - L0) + c * Ld], "length": [L]})]


class Bushing(SpatialPairElement):
    """Six-component linear bushing between a and b in a joint frame.

    Measures (joint frame of a, relaxed at t0): relative displacement
    Δ_k = u_k·(p_b − p_a) − Δ0_k (k = 1, 2, 3) and relative rotation
    ψ = (u3·w2, u1·w3, u2·w1) ≈ the rotation vector of b relative to a for small
    rotations (ψ_k = sin of the angle for a rotation about one axis). Forces
    F_k = K_k Δ_k + C_k Δ̇_k, moments M_k = K_r,k ψ_k + C_r,k ψ̇_k act against the
    deflection. The element derives from the potential ½ΣK_kΔ_k² + ½ΣK_r,kψ_k²
    (conservative without damping); like the bushings of commercial codes it is
    meant for small relative rotations.

    Parameters
    ----------
    name, a, b, at, point_a, point_b, axis, axis1, frame : see
        :class:`~femb.elements.spatial_joints.SpatialPairElement`
    stiffness : (3,)  translational stiffness along ē1, ē2, ē3 (N/m)
    damping : (3,)    translational damping (N s/m)
    rotational_stiffness : (3,)  (N m/rad)
    rotational_damping : (3,)    (N m s/rad)
    """

    glyph = "bushing"

    has_force = True
    force_depends_on_qd = True
    work = "potential"
    kernels = {"force": bushing_force, "energy": bushing_energy}

    def __init__(self, name, a, b, stiffness, rotational_stiffness, damping=(0.0, 0.0, 0.0),
                 rotational_damping=(0.0, 0.0, 0.0), at=None, point_a=None, point_b=None, axis=None,
                 axis1=None, frame=None):
        super().__init__(name, a, b, at, point_a, point_b, axis, axis1, frame)
        owner = f"Bushing '{name}'"
        vals = []
        for what, v in (("stiffness", stiffness), ("rotational_stiffness", rotational_stiffness),
                        ("damping", damping), ("rotational_damping", rotational_damping)):
            a3 = vector3(owner, what, v)
            if np.any(a3 < 0):
                raise ModelError(f"{owner}: {what} must not be negative, got {a3.tolist()}")
            vals.append(a3)
        self.K = np.concatenate((vals[0], vals[1]))
        self.C = np.concatenate((vals[2], vals[3]))

    def validate(self):
        super().validate()
        d = self.b.global_point(self.Xb) - self.a.global_point(self.Xa)
        self.m0 = np.concatenate((self.E.T @ d, np.zeros(3)))

    @classmethod
    def traits(cls, elements):
        tr = super().traits(elements)
        tr["force_depends_on_qd"] = any(np.any(e.C != 0.0) for e in elements)
        return tr

    @classmethod
    def pack(cls, elements):
        p = _frame_pack(elements)
        p["P"] = np.ascontiguousarray(np.hstack((p["P"], [np.concatenate((e.K, e.C, e.m0)) for e in elements])))
        return p

    @classmethod
    def geometry(cls, p, t, qe, qde, lame, names):
        """A vertex at the joint point p_a with the bushing's action on b (see :func:`_pair_wrench_block`)."""
        return _pair_wrench_block(cls, p, t, qe, qde)


class RotationalSpringDamper(SpatialPairElement):
    """Torsion spring–damper about ē3 = ``axis`` (use with a revolute joint on the same axis).

    Moment −(k (θ − θ0) + c θ̇) ē3 on b (and the opposite on a), θ the angle of
    ē_b1 in a's (ē1, ē2) plane, zero at t0; θ − θ0 is taken in (−π, π] (a spring
    wound beyond half a turn from θ0 is outside this element's range).

    Parameters
    ----------
    name, a, b, at, point_a, point_b, axis, axis1, frame : see
        :class:`~femb.elements.spatial_joints.SpatialPairElement`
    stiffness : float ≥ 0 (N m/rad)
    damping : float ≥ 0 (N m s/rad)
    angle0 : float
        Unstretched angle θ0 (rad), default 0 (relaxed at t0).
    """

    glyph = "torsion"

    has_force = True
    force_depends_on_qd = True
    work = "potential"
    kernels = {"force": rotational_spring_force, "energy": rotational_spring_energy}

    def __init__(self, name, a, b, stiffness, damping=0.0, angle0=0.0, at=None, point_a=None,
                 point_b=None, axis=None, axis1=None, frame=None):
        super().__init__(name, a, b, at, point_a, point_b, axis, axis1, frame)
        owner = f"RotationalSpringDamper '{name}'"
        self.k = _check_scalar(owner, "stiffness", stiffness, nonneg=True)
        self.c = _check_scalar(owner, "damping", damping, nonneg=True)
        self.angle0 = _check_scalar(owner, "angle0", angle0)

    @classmethod
    def traits(cls, elements):
        tr = super().traits(elements)
        tr["force_depends_on_qd"] = any(e.c != 0.0 for e in elements)
        return tr

    @classmethod
    def pack(cls, elements):
        p = _frame_pack(elements)
        p["P"] = np.ascontiguousarray(np.hstack((p["P"], [[e.k, e.c, e.angle0] for e in elements])))
        return p

    @classmethod
    def geometry(cls, p, t, qe, qde, lame, names):
        """A vertex at the joint point p_a with the spring's action on b (see
        :func:`_pair_wrench_block`) and point data ``angle``: the relative angle
        atan2(u2·w1, u1·w1) of b about ē3 (rad, zero at t0)."""
        blocks = _pair_wrench_block(cls, p, t, qe, qde)
        qe = np.asarray(qe, dtype=float)
        _, _, Ra, Rb = pair_points(p, qe)
        w1 = sg.rotate(Rb, p["Eb"][:, 0])
        u1 = sg.rotate(Ra, p["Ea"][:, 0])
        u2 = sg.rotate(Ra, p["Ea"][:, 1])
        blocks[0].point_data["angle"] = np.arctan2(np.einsum("ij,ij->i", u2, w1), np.einsum("ij,ij->i", u1, w1))
        return blocks


def _frame_pack(elements):
    P = np.array([np.concatenate((e.Xa, e.Ea.reshape(-1), e.Xb, e.Eb.reshape(-1))) for e in elements])
    return {"P": P, "Xa": P[:, 0:3].copy(), "Xb": P[:, 12:15].copy(),
            "Ea": P[:, 3:12].reshape(-1, 3, 3).copy(), "Eb": P[:, 15:24].reshape(-1, 3, 3).copy()}


def _pair_wrench_block(cls, p, t, qe, qde):
    """The force element's action on body b, reduced to its joint point p_a.

    Evaluates the element's own force kernel: the generalized force on b,
    (f_r, f_θ) = fe[6:12], gives ``force`` F = f_r (N, space axes) and
    ``moment`` M = R_b f_θ − (p_a − x_b) × F (N m, space axes, about p_a).

    Parameters
    ----------
    cls : type
    p : dict
        ``cls.pack(elements)``.
    t : float
    qe : ndarray, shape (nel, 14)
    qde : ndarray, shape (nel, 12)

    Returns
    -------
    list of GeometryBlock
        One vertex per element at p_a.
    """
    qe = np.ascontiguousarray(qe, dtype=float)
    qde = np.ascontiguousarray(qde, dtype=float)
    if qe.ndim != 2 or qe.shape[1] != 14 or qde.shape != (qe.shape[0], 12):
        raise ModelError(f"{cls.__name__}: geometry needs (nel, 14) coordinates and (nel, 12) velocities, "
                         f"got shapes {qe.shape} and {qde.shape}")
    n = qe.shape[0]
    fe = np.zeros((n, 12))
    fq = np.zeros((n, 12, 12))
    fv = np.zeros((n, 12, 12))
    cls.kernels["force"](p["P"], float(t), np.zeros((n, 0, 3)), qe, qde, False, fe, fq, fv)
    pa, _, _, Rb = pair_points(p, qe)
    F, M = sg.wrench_at(fe[:, 6:12], qe[:, 7:10], Rb, pa)
    return [GeometryBlock(cls.__name__, pa, [("vertex", sg.vertex_cells(n))],
                          point_data={"force": F, "moment": M})]


# ---------------------------------------------------------------------------
# loads on one body
# ---------------------------------------------------------------------------
@kernel
def load_force(P, t, tf, xe, ve, jac, fe, fq, fv):
    """Force or torque on one frame node, scaled by f(t); P = (X (3), V (3), follower, torque).

    dead force F at X:      f_r = F,   f_θ = X × RᵀF,  fq(θ,θ) = X~(RᵀF)~
    follower force F_b:     f_r = RF_b, f_θ = X × F_b, fq(r,θ) = −R F_b~
    dead torque M:          f_θ = RᵀM, fq(θ,θ) = (RᵀM)~
    follower torque M_b:    f_θ = M_b
    """
    for e in range(xe.shape[0]):
        s = tf[e, 0, 0]
        X = sp.vec3(P[e], 0)
        Fv = (s * P[e, 3], s * P[e, 4], s * P[e, 5])
        follower = P[e, 6] != 0.0
        torque = P[e, 7] != 0.0
        R = rt.quat_to_matrix_t(xe[e, 3], xe[e, 4], xe[e, 5], xe[e, 6])
        a = Fv if follower else sp.mtv(R, Fv)          # body-axes load
        if torque:
            for i in range(3):
                fe[e, 3 + i] = a[i]
            if jac and not follower:
                fq[e, 3, 4] = -a[2]
                fq[e, 3, 5] = a[1]
                fq[e, 4, 3] = a[2]
                fq[e, 4, 5] = -a[0]
                fq[e, 5, 3] = -a[1]
                fq[e, 5, 4] = a[0]
            continue
        m = sp.cross3(X, a)
        for i in range(3):
            fe[e, 3 + i] = m[i]
        if not follower:
            for i in range(3):
                fe[e, i] = Fv[i]
            if jac:
                M = sp.skskw(X, a)            # X~ a~ = a Xᵀ − (X·a) I
                for i in range(3):
                    for j in range(3):
                        fq[e, 3 + i, 3 + j] = M[3 * i + j]
        else:
            f = sp.mv(R, Fv)
            K = sp.rskew(R, Fv)               # R F_b~;  fq(r, θ) = −R F_b~
            for i in range(3):
                fe[e, i] = f[i]
                if jac:
                    for j in range(3):
                        fq[e, i, 3 + j] = -K[3 * i + j]


class _Load(Element):
    #: acts on spatial frame nodes (femb.system.model refuses planar elements on them)
    spatial = True
    has_force = True
    work = "load"                     # an applied load: its work ∫ fe·ve dt (femb.results.energy)
    glyph = "load"
    kernels = {"force": load_force}
    _torque = False

    def __init__(self, name, body, value, point=None, follower=False, function=None):
        super().__init__(name)
        owner = f"{type(self).__name__} '{name}'"
        self.body = body
        self.value = vector3(owner, "torque" if self._torque else "force", value)
        self._point = point
        self.follower = bool(follower)
        self.fn = Constant(1.0) if function is None else as_time_function(function, owner, "function")

    def resolve(self, lookup):
        self.body = _resolve_spatial(self, self.body, lookup, "body")

    def nodes(self):
        return [self.body.node]

    def validate(self):
        self.X = (np.zeros(3) if self._point is None or self._torque
                  else self.body.local(self._point, "point"))

    @classmethod
    def time_functions(cls, element):
        return [element.fn]

    @classmethod
    def pack(cls, elements):
        P = np.array([[*e.X, *e.value, float(e.follower), float(e._torque)] for e in elements])
        return {"P": np.ascontiguousarray(P), "functions": [e.fn for e in elements]}

    @classmethod
    def geometry(cls, p, t, qe, qde, lame, names):
        """A vertex at the point of application x + R X (the node for a torque) with point
        data ``force`` (N) or ``torque`` (N m): f(t) F, space axes (R F for a follower load);
        qe (nel, 7)."""
        qe = np.asarray(qe, dtype=float)
        P = p["P"]
        R = sg.rotation_matrices(qe[:, 3:7])
        s = evaluate(p["functions"], float(t))[:, None]
        V = s * P[:, 3:6]
        V = np.where(P[:, 6:7] != 0.0, sg.rotate(R, V), V)
        pts = qe[:, 0:3] + sg.rotate(R, P[:, 0:3])
        n = qe.shape[0]
        return [GeometryBlock(cls.__name__, pts, [("vertex", sg.vertex_cells(n))],
                              point_data={"torque" if cls._torque else "force": V})]


class SpatialForce(_Load):
    """A force on a body point, dead (space axes) or follower (body axes), scaled by f(t).

    Parameters
    ----------
    name : str
    body : SpatialBody or str
    force : (3,)
        F (N): space axes (dead) or body axes (``follower=True``).
    point : str or (3,), optional
        Point of application in body axes (default: the node).
    follower : bool
    function : float or TimeFunction, optional
        Scale factor f(t) (default 1).
    """

    def __init__(self, name, body, force, point=None, follower=False, function=None):
        super().__init__(name, body, force, point, follower, function)


class SpatialTorque(_Load):
    """A torque on a body, dead (space axes) or follower (body axes), scaled by f(t).

    Parameters
    ----------
    name : str
    body : SpatialBody or str
    torque : (3,)
        M (N m): space axes (dead) or body axes (``follower=True``).
    follower : bool
    function : float or TimeFunction, optional
    """

    _torque = True

    def __init__(self, name, body, torque, follower=False, function=None):
        super().__init__(name, body, torque, None, follower, function)


class SpatialGravity(Gravity):
    """Uniform gravity g (3,) on every mass, through the mass matrix (as planar :class:`Gravity`).

    The generalized force is M ĝ, ĝ holding g at the translational coordinates
    of every node: exact for rigid bodies with their node at the centre of mass.
    """

    def __init__(self, g=(0.0, 0.0, -9.81), name="gravity"):
        Element.__init__(self, name)
        self.g = vector3(f"SpatialGravity '{name}'", "g", g)


__all__ = ["PointSpringDamper", "Bushing", "RotationalSpringDamper", "SpatialForce", "SpatialTorque",
           "SpatialGravity", "point_spring_force", "bushing_force", "rotational_spring_force", "load_force",
           "point_spring_energy", "bushing_energy", "rotational_spring_energy"]
