"""Spatial joints between two frame nodes, as compiled kernels.

Every joint connects body ``a`` to body ``b`` (either may be the ground). The
user gives a joint frame — a point and axes (ē1, ē2, ē3; ē3 the joint axis) in
space at t0 — and the joint stores it in both bodies' axes: X_a, ē_a1..3 and
X_b, ē_b1..3, coincident at t0. At any time r_a = R_a X_a, p_a = x_a + r_a
(same for b), d = p_b − p_a, u_i = R_a ē_ai, w_i = R_b ē_bi.

Sign convention: M v̇ = f − Bᵀλ, Φ = 0 (Arnold & Brüls 2007). What each λ is:

* point rows (spherical, revolute, universal, fixed): Φ = p_a − p_b, λ (3) is
  the **force on body b** at the joint point, space axes, N (−λ on a);
* rotation-lock rows −u2·w3, u1·w3 (the axis locks of the revolute,
  cylindrical, prismatic and fixed joints, :func:`axis_locks`) and u2·w1
  (≈ ψ1, ψ2, ψ3, the small rotation of b relative to a about the joint axes
  ē1, ē2, ē3 carried by a): λ_k = −(moment on b about u_k = R_a ē_ak), N m,
  exact whenever the rows hold, at every rotation about a free axis; in
  general a row Φ = σ u·w acts on b with the moment σλ (u × w) (space axes);
* line rows u_k·d (cylindrical, prismatic): the joint acts on b at p_b with the
  force −λ u_k (space), N;
* distance: λ is the tension (N; positive pulls the points together);
* driven revolute angle: λ is the driving torque, the moment on b is −λ ē3
  (space), N m; driven prismatic displacement: the force on b is −λ u3, N.

The axis locks −u2·w3 = 0, u1·w3 = 0 (the axis of b perpendicular to the two
axes of a across the joint axis) have the gradients −u1, −u2 whatever the angle
about the axis, so they stay independent through whole turns (the earlier pair
u3·w2, u1·w3 lost rank at ±90°). Locks of a rotation that is not free (u2·w1 of
the prismatic and fixed joints) only need to hold near the reference, where the
three rows are the orthogonality conditions of the two joint frames with
independent gradients −u1, −u2, −u3 (they also vanish at a relative half turn,
which a joint held at the reference never reaches). docs/spatial.md,
"Rotation locks that hold at every angle".

References
----------
M. Géradin, A. Cardona, Flexible Multibody Dynamics, Wiley, 2001, Ch. 5.
O. Brüls, A. Cardona, M. Arnold, Lie group generalized-α time integration of
constrained flexible multibody systems, Mech. Mach. Theory 48:121–137, 2012.
P. E. Nikravesh, Computer-Aided Analysis of Mechanical Systems, 1988, Ch. 11
(spatial joints from dot-1 and dot-2 constraints).
E. J. Haug, Computer-Aided Kinematics and Dynamics of Mechanical Systems, Vol. I,
Allyn and Bacon, 1989, Sect. 9.2 (dot-1, dot-2 and parallel constraints; section
number to be checked against the book).
M. Arnold, O. Brüls, Convergence of the generalized-α scheme for constrained
mechanical systems, Multibody Syst. Dyn. 18:185–202, 2007.
"""
from __future__ import annotations

import math

import numpy as np

from femb.base import rotations as rt
from femb.base.functions import as_time_function
from femb.base.geometry import GeometryBlock
from femb.base.jit import kernel
from femb.errors import ModelError
from femb.system.element import Element

from . import _spatial as sp
from . import _spatial_geometry as sg
from ._spatial import EA, EB, NPAR_FRAME
from .bodies import Ground
from .spatial_bodies import SpatialBody, SpatialGround, spatial_ground, unit3, vector3

A1, A2, A3 = EA, EA + 3, EA + 6
B1, B2, B3 = EB, EB + 3, EB + 6


# ---------------------------------------------------------------------------
# joint frame
# ---------------------------------------------------------------------------
def joint_frame(owner, axis=None, axis1=None, frame=None):
    """Orthonormal joint axes (3, 3), columns (ē1, ē2, ē3), in space at t0.

    ``frame``: a rotation matrix whose columns are the axes; else ē3 = ``axis``
    (default z) and ē1 = ``axis1`` made orthogonal to ē3 (default: the
    coordinate axis least aligned with ē3), ē2 = ē3 × ē1.
    """
    if frame is not None:
        E = np.asarray(frame, dtype=float)
        if E.shape != (3, 3) or not np.all(np.isfinite(E)):
            raise ModelError(f"{owner}: frame must be a finite 3×3 matrix, got {frame!r}")
        if not (np.allclose(E.T @ E, np.eye(3), atol=1e-9) and np.linalg.det(E) > 0):
            raise ModelError(f"{owner}: frame must be a rotation matrix (orthonormal columns, det 1)")
        if axis is not None or axis1 is not None:
            raise ModelError(f"{owner}: give frame or axis/axis1, not both")
        return E.copy()
    e3 = unit3(owner, "axis", (0.0, 0.0, 1.0) if axis is None else axis)
    if axis1 is None:
        k = int(np.argmin(np.abs(e3)))
        h = np.zeros(3)
        h[k] = 1.0
    else:
        h = unit3(owner, "axis1", axis1)
    e1 = h - (h @ e3) * e3
    n = np.linalg.norm(e1)
    if n < 1e-8:
        raise ModelError(f"{owner}: axis1 is parallel to axis")
    e1 /= n
    return np.column_stack((e1, np.cross(e3, e1), e3))


def _resolve_spatial(owner, ref, lookup, role):
    if isinstance(ref, SpatialGround):
        return ref
    body = lookup(ref, role)
    if isinstance(body, Ground):
        return spatial_ground(body)
    if not isinstance(body, SpatialBody):
        raise ModelError(f"{type(owner).__name__} '{owner.name}': {role} = '{body.name}' is not a "
                         "spatial body (planar and spatial elements cannot be joined)")
    return body


class SpatialPairElement(Element):
    """An element between two spatial bodies ``a`` and ``b`` with a joint frame.

    Parameters
    ----------
    name : str
    a, b : SpatialBody, str, or the mechanism's ground (``"ground"``)
    at : (3,), optional
        The joint point in space at t0 (the same material point on a and b).
    point_a, point_b : str or (3,), optional
        The joint point on each body (name or body-axes coordinates), used
        when ``at`` is not given (default: the nodes).
    axis, axis1, frame : optional
        Joint axes, see :func:`joint_frame` (space axes at t0); ``axis`` and
        ``axis1`` may also name axes of body a.
    """

    #: acts on spatial frame nodes (femb.system.model refuses planar elements on them)
    spatial = True
    #: an element between the frames of two spatial bodies a and b, xe = (x_a, p_a, x_b, p_b):
    #: pictures mark its axes and the bodies it links (femb.io.frames reads this trait)
    frame_pair = True

    def __init__(self, name, a, b, at=None, point_a=None, point_b=None, axis=None, axis1=None,
                 frame=None):
        super().__init__(name)
        self.a, self.b = a, b
        self._spec = (at, point_a, point_b)
        self._axes = (axis, axis1, frame)
        if not isinstance(axis, str) and not isinstance(axis1, str):
            self.E = joint_frame(f"{type(self).__name__} '{name}'", axis, axis1, frame)   # early errors

    def _frame(self):
        """Joint axes in space at t0; named axes (strings) are axes of body a."""
        axis, axis1, frame = self._axes
        if isinstance(axis, str):
            axis = self.a.axis_global(axis, "axis")
        if isinstance(axis1, str):
            axis1 = self.a.axis_global(axis1, "axis1")
        return joint_frame(f"{type(self).__name__} '{self.name}'", axis, axis1, frame)

    def resolve(self, lookup):
        self.a = _resolve_spatial(self, self.a, lookup, "a")
        self.b = _resolve_spatial(self, self.b, lookup, "b")
        if self.a is self.b:
            raise ModelError(f"{type(self).__name__} '{self.name}': bodies a and b are the same ('{self.a.name}')")

    def nodes(self):
        return [self.a.node, self.b.node]

    def validate(self):
        self.E = self._frame()
        at, pa, pb = self._spec
        if at is not None:
            if pa is not None or pb is not None:
                raise ModelError(f"{type(self).__name__} '{self.name}': give either at= or point_a/point_b, not both")
            at = vector3(f"{type(self).__name__} '{self.name}'", "at", at)
            self.Xa, self.Xb = self.a.local_from_global(at), self.b.local_from_global(at)
        else:
            self.Xa = self.a.local((0.0, 0.0, 0.0) if pa is None else pa, "point_a")
            self.Xb = self.b.local((0.0, 0.0, 0.0) if pb is None else pb, "point_b")
        self.Ea = (self.a.node.rotation0.T @ self.E).T     # rows ē_a1..3 in body a axes
        self.Eb = (self.b.node.rotation0.T @ self.E).T

    def program(self):
        """The row program: list of (kind, first row, ā offset, b̄ offset, value, time-function index).

        The contract of a joint type built on this class (every joint of this file
        defines it; the spatial force elements, which also derive from this class,
        define ``pack`` instead and never call it). A user's joint type that defines
        neither gets a :class:`~femb.errors.ModelError` when its model is compiled.
        """
        raise ModelError(f"{type(self).__name__} '{self.name}': a joint type derived from "
                                  "SpatialPairElement must define program() (its constraint rows), "
                                  "or override pack()")

    @classmethod
    def pack(cls, elements):
        rows = []
        for e in elements:
            prog = np.asarray(e.program(), dtype=float).reshape(-1, SPEC)
            rows.append(np.concatenate((e.Xa, e.Ea.reshape(-1), e.Xb, e.Eb.reshape(-1),
                                        [len(prog)], prog.reshape(-1))))
        P = np.ascontiguousarray(np.array(rows, dtype=float))
        return {"P": P, "Xa": P[:, 0:3].copy(), "Xb": P[:, 12:15].copy(),
                "Ea": P[:, 3:12].reshape(-1, 3, 3).copy(), "Eb": P[:, 15:24].reshape(-1, 3, 3).copy(),
                "time_functions": [list(cls.time_functions(e)) for e in elements]}

    @classmethod
    def time_functions(cls, element):
        return []

    @classmethod
    def geometry(cls, p, t, qe, qde, lame, names):
        """Joint points with the reaction on body b, and the gap lines p_a → p_b.

        B comes from the element's own constraint kernel (its time functions
        evaluated at t for driven joints); the generalized force on b is
        −B_bᵀλ (sign convention M v̇ = f − Bᵀλ), reduced to the joint point.

        Parameters
        ----------
        p : dict
            From :meth:`pack`.
        t : float
        qe : ndarray, shape (nel, 14)
            (r_a, p_a, r_b, p_b).
        qde : ndarray, shape (nel, 12)
        lame : ndarray, shape (nel, n_constraints)
            The multipliers λ of each joint.
        names : list of str

        Returns
        -------
        list of GeometryBlock
            Two blocks named after the class: one vertex per joint at
            p_a = x_a + R_a X_a with point data ``reaction_force`` (N) and
            ``reaction_moment`` (N m, about p_a), both the action of the joint
            on body b in space axes; and one line p_a → p_b per joint with
            cell data ``gap`` = |p_b − p_a| (m, zero when the point rows hold).
        """
        F, M, pa, pb = joint_reactions(cls, p, t, qe, lame)
        n = pa.shape[0]
        return [GeometryBlock(cls.__name__, pa, [("vertex", sg.vertex_cells(n))],
                              point_data={"reaction_force": F, "reaction_moment": M}),
                GeometryBlock(cls.__name__, np.vstack((pa, pb)),
                              [("line", np.column_stack((np.arange(n), n + np.arange(n))))],
                              cell_data={"gap": [np.linalg.norm(pb - pa, axis=1)]})]


def pair_points(p, qe):
    """Joint points p_a = x_a + R_a X_a, p_b (each (nel, 3)) and R_a, R_b (nel, 3, 3) of a batch."""
    Ra = sg.rotation_matrices(qe[:, 3:7])
    Rb = sg.rotation_matrices(qe[:, 10:14])
    return qe[:, 0:3] + sg.rotate(Ra, p["Xa"]), qe[:, 7:10] + sg.rotate(Rb, p["Xb"]), Ra, Rb


def joint_reactions(cls, p, t, qe, lame):
    """Force and moment of each joint of a batch on its body b, reduced to p_a (space axes).

    Parameters
    ----------
    cls : type
        The joint class (its ``kernels["constraint"]`` and ``n_constraints``).
    p : dict
        ``cls.pack(elements)``.
    t : float
    qe : ndarray, shape (nel, 14)
    lame : ndarray, shape (nel, n_constraints)

    Returns
    -------
    F, M : ndarray, shape (nel, 3)
        F (N) = the force part of −B_bᵀλ; M (N m) = R_b m − (p_a − x_b) × F with
        m the moment part of −B_bᵀλ (body b axes, about x_b).
    pa, pb : ndarray, shape (nel, 3)
    """
    qe = np.ascontiguousarray(qe, dtype=float)
    n = qe.shape[0]
    nc = int(cls.n_constraints)
    try:
        lam = np.ascontiguousarray(np.asarray(lame, dtype=float).reshape(n, nc))
    except ValueError:
        raise ModelError(f"{cls.__name__}: geometry needs {nc} multipliers per joint, got an array of "
                         f"shape {np.shape(lame)}") from None
    if qe.ndim != 2 or qe.shape[1] != 14:
        raise ModelError(f"{cls.__name__}: geometry needs (nel, 14) node coordinates (r_a, p_a, r_b, p_b), "
                         f"got shape {qe.shape}")
    tf = np.ascontiguousarray(sg.time_function_table(p.get("time_functions"), float(t), n))
    Phi = np.zeros((n, nc))
    B = np.zeros((n, nc, 12))
    H = np.zeros((n, 12, 12))
    cls.kernels["constraint"](p["P"], float(t), tf, qe, lam, False, Phi, B, H)
    f = -np.einsum("eki,ek->ei", B, lam)
    pa, pb, _, Rb = pair_points(p, qe)
    F, M = sg.wrench_at(f[:, 6:12], qe[:, 7:10], Rb, pa)
    return F, M, pa, pb


# ---------------------------------------------------------------------------
# one compiled kernel pair for all joint types: a row program in P
# ---------------------------------------------------------------------------
#: row kinds of a joint program
POINT, DOT1, DOT2, DISTANCE, DRIVEN_DOT1 = 0, 1, 2, 3, 4
#: floats per program entry: (kind, first row, ā offset in P, b̄ offset in P, value, time-function index)
SPEC = 6
PROGRAM = NPAR_FRAME + 1


@kernel
def _driven_axis(P, tf, base, value, k):
    """ā(t), t̄(t) (body a axes), θ* = value + φ(t), and (φ', φ'').

    ā = −sin θ* ē_a1 + cos θ* ē_a2, t̄ = cos θ* ē_a1 + sin θ* ē_a2 (= −∂ā/∂θ*),
    ē_a1 = P[base:base+3], ē_a2 = P[base+3:base+6].
    """
    th = value + tf[k, 0]
    c, s = math.cos(th), math.sin(th)
    e1 = sp.vec3(P, base)
    e2 = sp.vec3(P, base + 3)
    abar = (-s * e1[0] + c * e2[0], -s * e1[1] + c * e2[1], -s * e1[2] + c * e2[2])
    tbar = (c * e1[0] + s * e2[0], c * e1[1] + s * e2[1], c * e1[2] + s * e2[2])
    return abar, tbar, tf[k, 1], tf[k, 2]


@kernel
def joint_ev(P, tf, x, lam, jac, Phi, B, H, rates, v, gam):
    """One element's rows from its row program.

    P = (frame (24), n, entries (n × 6)); entry = (kind, row, ia, ib, value, k):
    POINT: 3 rows Φ = p_a − p_b; DOT1: Φ = value (R_a P[ia:ia+3])·(R_b P[ib:ib+3])
    (value = ±1: the sign that makes the row ≈ +ψ_k);
    DOT2: Φ = (R_a P[ia:ia+3])·d − value (− φ_k(t) if k ≥ 0); DISTANCE: L = value;
    DRIVEN_DOT1: ā(t) = −sin θ* ē_a1 + cos θ* ē_a2 with ē_a1 = P[ia:ia+3],
    ē_a2 = P[ia+3:ia+6], θ* = value + φ_k(t), b̄ = P[ib:ib+3].

    Constraint kernel (``rates`` false): writes Φ (nc), B (nc, 12) and, if ``jac``, adds
    H = ∂(Bᵀλ)/∂(δr, δθ) to ``H``; v and gam are not used. Rates kernel (``rates``
    true): writes the convective term gam[row] = vᵀH_row v of every row (H_row the
    Hessian of that row, v the velocities (12)) and touches neither lam, Phi, B nor H.
    """
    F = sp.frames(P, x)
    n = int(P[NPAR_FRAME])
    vv = sp.vec12(v) if rates else sp.Z12
    add = jac and not rates
    for s in range(n):
        o = PROGRAM + SPEC * s
        kind = int(P[o])
        r = int(P[o + 1])
        ia = int(P[o + 2])
        ib = int(P[o + 3])
        val = P[o + 4]
        k = int(P[o + 5])
        if kind == POINT:
            if rates:
                gam[r] = sp.dot12(sp.point_hess(F, (1.0, 0.0, 0.0), H, False, 1.0, vv), vv)
                gam[r + 1] = sp.dot12(sp.point_hess(F, (0.0, 1.0, 0.0), H, False, 1.0, vv), vv)
                gam[r + 2] = sp.dot12(sp.point_hess(F, (0.0, 0.0, 1.0), H, False, 1.0, vv), vv)
            else:
                sp.point_rows(r, F, Phi, B)
                if jac:
                    sp.point_hess(F, (lam[r], lam[r + 1], lam[r + 2]), H, True, 1.0, vv)
            continue
        c = 0.0 if rates else lam[r]
        if kind == DOT1:
            phi, g, hv = sp.dot1(sp.scale3(val, sp.vec3(P, ia)), sp.vec3(P, ib), F, H, add, c, vv)
        elif kind == DOT2:
            off = val + (tf[k, 0] if k >= 0 else 0.0)
            phi, g, hv = sp.dot2(sp.vec3(P, ia), off, F, H, add, c, vv)
        elif kind == DISTANCE:
            phi, g, hv = sp.distance(val, F, H, add, c, vv)
        else:
            abar, tbar, d1, d2 = _driven_axis(P, tf, ia, val, k)
            phi, g, hv = sp.dot1(abar, sp.vec3(P, ib), F, H, add, c, vv)
        if rates:
            gam[r] = sp.dot12(hv, vv)
        else:
            Phi[r] = phi
            sp.put_row(B, r, g)


@kernel
def joint_time(P, tf, x, v, Phi_t, gam):
    """Φ_t and the explicit-time part 2 B_t v + Φ_tt (added to gam) of the rheonomic rows.

    DOT2 with a time function: Φ_t = −s′, Φ_tt = −s″, B_t = 0. DRIVEN_DOT1:
    Φ_t = (R_a ā̇)·w, Φ_tt = (R_a ā̈)·w, B_t = dot-1 B with c = (R_a ā̇) × w, where
    ā̇ = −φ′ t̄, ā̈ = −φ″ t̄ − φ′² ā (docs/spatial.md §4).
    """
    n = int(P[NPAR_FRAME])
    for s in range(n):
        o = PROGRAM + SPEC * s
        kind = int(P[o])
        r = int(P[o + 1])
        k = int(P[o + 5])
        if k < 0:
            continue
        if kind == DOT2:
            Phi_t[r] = -tf[k, 1]
            gam[r] += -tf[k, 2]
        elif kind == DRIVEN_DOT1:
            Ra = rt.quat_to_matrix_t(x[3], x[4], x[5], x[6])
            Rb = rt.quat_to_matrix_t(x[10], x[11], x[12], x[13])
            ia = int(P[o + 2])
            ib = int(P[o + 3])
            abar, tbar, d1, d2 = _driven_axis(P, tf, ia, P[o + 4], k)
            w = sp.mv(Rb, sp.vec3(P, ib))
            ad = sp.mv(Ra, sp.scale3(-d1, tbar))                                   # R_a ā̇
            Phi_t[r] = sp.dot3(ad, w)
            add_ = sp.mv(Ra, sp.sub3(sp.scale3(-d2, tbar), sp.scale3(d1 * d1, abar)))   # R_a ā̈
            phitt = sp.dot3(add_, w)
            ct = sp.cross3(ad, w)                    # c_t; B_t = [0, c_tᵀR_a, 0, −c_tᵀR_b]
            btv = sp.dot3(sp.mtv(Ra, ct), sp.vec3(v, 3)) - sp.dot3(sp.mtv(Rb, ct), sp.vec3(v, 9))
            gam[r] += 2.0 * btv + phitt


@kernel
def joint_constraint(P, t, tf, xe, le, jac, Phi, B, H):
    """Batch constraint kernel of every spatial joint type (Φ, B, H; docs/kernels.md)."""
    for e in range(xe.shape[0]):
        joint_ev(P[e], tf[e], xe[e], le[e], jac, Phi[e], B[e], H[e], False, le[e], Phi[e])


@kernel
def joint_rates(P, t, tf, xe, ve, Phi_t, gam):
    """Batch rates kernel of every spatial joint type: Φ_t and γ = (Bv)_x v + 2 B_t v + Φ_tt.

    The convective term of row k is vᵀ H_k v, H_k the Hessian of row k (exact;
    docs/spatial.md §2), from the primitives' vᵀH without forming H.
    """
    for e in range(xe.shape[0]):
        joint_ev(P[e], tf[e], xe[e], ve[e], False, Phi_t[e], Phi_t, Phi_t, True, ve[e], gam[e])
        joint_time(P[e], tf[e], xe[e], ve[e], Phi_t[e], gam[e])


JOINT_KERNELS = {"constraint": joint_constraint, "rates": joint_rates}


# ---------------------------------------------------------------------------
# element classes
# ---------------------------------------------------------------------------
class SphericalJoint(SpatialPairElement):
    """Ball joint: point p_a of a coincides with p_b of b (3 rows, Φ = p_a − p_b).

    λ (3): force on body b at the joint point, space axes (N). Give ``at``
    (space point at t0) or ``point_a``/``point_b``; axes are not used.
    """

    glyph = "spherical"

    n_constraints = 3
    constraint_names = ("x", "y", "z")
    constraint_units = ("N", "N", "N")
    kernels = JOINT_KERNELS

    def program(self):
        return [(POINT, 0, 0, 0, 0.0, -1)]


def axis_locks(row):
    """Row program of the two locks that keep the axis ē3 of b parallel to ē3 of a.

    Rows ``row``, ``row + 1``: Φ = (−u2·w3, u1·w3), the axis w3 of b perpendicular to
    the two axes u1, u2 of a that are perpendicular to a's axis u3 (the "parallel"
    condition as a pair of dot-1 constraints; Haug 1989, Sect. 9.2, and Nikravesh
    1988, Ch. 11 — section numbers to be checked against the books). Their
    gradients c = −u2 × w3 and u1 × w3 are −u1 and −u2 when w3 = u3: fixed in a and
    perpendicular, whatever the rotation of b about the axis, so the rows are
    independent through whole turns. Each row ≈ ψ1, ψ2 (the small rotation of b
    relative to a about u1, u2) at every angle about the axis, and the joint acts on
    b with the moment −λ_row u1 − λ_{row+1} u2 (exact when w3 = u3).

    Parameters
    ----------
    row : int
        Index of the first of the two rows in the joint's λ.

    Returns
    -------
    list of tuple
        Two DOT1 entries of the row program (ā = ∓ē_a2, ē_a1 scaled by the
        entry's value σ = −1, +1; b̄ = ē_b3).
    """
    return [(DOT1, row, A2, B3, -1.0, -1), (DOT1, row + 1, A1, B3, 1.0, -1)]


class RevoluteJoint(SpatialPairElement):
    """Revolute (hinge) joint about ē3 = ``axis`` (5 rows: point; −u2·w3; u1·w3).

    The two rotation locks keep the axis of b (w3 = R_b ē_b3) perpendicular to
    the axes u1 = R_a ē_a1, u2 = R_a ē_a2 of a (see :func:`axis_locks`); they
    stay independent at every rotation about the axis, also through many turns.

    λ[0:3]: force on b at the joint point (space axes, N). λ[3], λ[4]: the
    bearing moments, N m: the joint acts on b with the moment
    −λ[3] u1 − λ[4] u2, i.e. λ[3] and λ[4] are minus the moment on b about the
    joint axes ē1, ē2 carried by body a (sign as planar ``Slider``/``Clamp``:
    each lock row ≈ the small rotation of b relative to a about that axis).
    Exact whenever the locks hold (w3 = u3), at any angle.
    """

    glyph = "revolute"

    n_constraints = 5
    constraint_names = ("x", "y", "z", "lock_1", "lock_2")
    constraint_units = ("N", "N", "N", "N·m", "N·m")
    kernels = JOINT_KERNELS

    def program(self):
        return [(POINT, 0, 0, 0, 0.0, -1)] + axis_locks(3)


class UniversalJoint(SpatialPairElement):
    """Universal (Hooke) joint: point, and ē_a2 · ē_b1 = 0 (4 rows).

    Free rotations about ``axis_a`` (fixed in a) and ``axis_b`` (fixed in b),
    perpendicular at t0; the joint frame is ē1 = axis_b, ē2 = axis_a,
    ē3 = ē1 × ē2. λ[0:3]: force on b (space axes, N); λ[3]: the cross-lock: the
    joint acts on b with the moment λ[3] (u2 × w1), u2 = R_a ē_a2, w1 = R_b ē_b1;
    u2 × w1 is a unit vector whenever the row holds (u2 ⟂ w1), at every
    rotation about the two free axes (−ē3 at t0), so the single lock row never
    degenerates.

    Parameters
    ----------
    name, a, b, at, point_a, point_b : see :class:`SpatialPairElement`
    axis_a, axis_b : (3,) or str
        The two free axes in space at t0 (perpendicular), or names of axes of
        body a and body b.
    """

    glyph = "universal"

    n_constraints = 4
    constraint_names = ("x", "y", "z", "cross")
    constraint_units = ("N", "N", "N", "N·m")
    kernels = JOINT_KERNELS

    def __init__(self, name, a, b, axis_a, axis_b, at=None, point_a=None, point_b=None):
        super().__init__(name, a, b, at, point_a, point_b)
        self._pins = (axis_a, axis_b)
        if not isinstance(axis_a, str) and not isinstance(axis_b, str):
            self.E = self._frame()           # early errors

    def _frame(self):
        owner = f"UniversalJoint '{self.name}'"
        axis_a, axis_b = self._pins
        e2 = self.a.axis_global(axis_a, "axis_a") if isinstance(axis_a, str) else unit3(owner, "axis_a", axis_a)
        e1 = self.b.axis_global(axis_b, "axis_b") if isinstance(axis_b, str) else unit3(owner, "axis_b", axis_b)
        if abs(e1 @ e2) > 1e-9:
            raise ModelError(f"{owner}: axis_a and axis_b must be perpendicular (cos = {e1 @ e2:.3g})")
        return np.column_stack((e1, e2, np.cross(e1, e2)))

    def program(self):
        return [(POINT, 0, 0, 0, 0.0, -1), (DOT1, 3, A2, B1, 1.0, -1)]


class _LineJoint(SpatialPairElement):
    def validate(self):
        super().validate()
        # offsets of the line rows: u_k·d at t0 (zero when the points coincide)
        d = self.b.global_point(self.Xb) - self.a.global_point(self.Xa)
        self.offsets = [float(self.E[:, k] @ d) for k in range(3)]


class CylindricalJoint(_LineJoint):
    """Cylindrical joint: b slides along and turns about ē3 = ``axis`` of a (4 rows).

    Rows u1·d, u2·d (λ: force −λu_k on b at p_b, N) and the revolute's axis
    locks −u2·w3, u1·w3 (:func:`axis_locks`; independent at every rotation
    about the axis): the joint acts on b with the moment −λ[2] u1 − λ[3] u2
    (N m, u_k = R_a ē_ak; minus the bearing moments about ē1, ē2 of a).
    """

    glyph = "cylindrical"

    n_constraints = 4
    constraint_names = ("line_1", "line_2", "lock_1", "lock_2")
    constraint_units = ("N", "N", "N·m", "N·m")
    kernels = JOINT_KERNELS

    def program(self):
        return [(DOT2, 0, A1, 0, self.offsets[0], -1), (DOT2, 1, A2, 0, self.offsets[1], -1)] + axis_locks(2)


class PrismaticJoint(_LineJoint):
    """Prismatic (slider) joint along ē3 = ``axis`` of a (5 rows: cylindrical + u2·w1).

    The three rotation locks −u2·w3, u1·w3, u2·w1 (≈ ψ1, ψ2, ψ3, the small
    rotation of b relative to a) are the orthogonality conditions of the two
    frames; the relative rotation stays at the reference (identity), where their
    gradients are −u1, −u2, −u3: independent. λ[0:2]: line rows (force −λu_k on
    b, N); λ[2:5]: the joint acts on b with the moment −λ[2] u1 − λ[3] u2 −
    λ[4] u3 (N m; exact when the locks hold).
    """

    glyph = "prismatic"

    n_constraints = 5
    constraint_names = ("line_1", "line_2", "lock_1", "lock_2", "lock_3")
    constraint_units = ("N", "N", "N·m", "N·m", "N·m")
    kernels = JOINT_KERNELS

    def program(self):
        return ([(DOT2, 0, A1, 0, self.offsets[0], -1), (DOT2, 1, A2, 0, self.offsets[1], -1)]
                + axis_locks(2) + [(DOT1, 4, A2, B1, 1.0, -1)])


class FixedJoint(SpatialPairElement):
    """Weld: point and three rotation locks (6 rows).

    λ[0:3]: force on b (space axes, N). The rows −u2·w3, u1·w3, u2·w1 (≈ ψ1,
    ψ2, ψ3, as the prismatic joint's) hold the relative rotation at the
    reference, where their gradients −u1, −u2, −u3 are independent; the joint
    acts on b with the moment −λ[3] u1 − λ[4] u2 − λ[5] u3 (N m).
    """

    glyph = "fixed"

    n_constraints = 6
    constraint_names = ("x", "y", "z", "lock_1", "lock_2", "lock_3")
    constraint_units = ("N", "N", "N", "N·m", "N·m", "N·m")
    kernels = JOINT_KERNELS

    def program(self):
        return [(POINT, 0, 0, 0, 0.0, -1)] + axis_locks(3) + [(DOT1, 5, A2, B1, 1.0, -1)]


class DistanceJoint(SpatialPairElement):
    """Massless link: |p_b − p_a| = L (1 row, Φ = (d·d − L²)/(2L)).

    λ is the tension (N). ``length`` defaults to the distance at t0.

    Parameters
    ----------
    name, a, b : see :class:`SpatialPairElement`
    point_a, point_b : str or (3,)
        The two end points on the bodies.
    length : float > 0, optional
    """

    glyph = "distance"

    n_constraints = 1
    constraint_names = ("length",)
    constraint_units = ("N",)
    kernels = JOINT_KERNELS

    def __init__(self, name, a, b, point_a=None, point_b=None, length=None):
        super().__init__(name, a, b, None, point_a, point_b)
        self.L = length

    def validate(self):
        super().validate()
        d = self.b.global_point(self.Xb) - self.a.global_point(self.Xa)
        if self.L is None:
            self.L = float(np.linalg.norm(d))
        try:
            self.L = float(self.L)
        except (TypeError, ValueError):
            raise ModelError(f"DistanceJoint '{self.name}': length must be a number, got {self.L!r}") from None
        if not (self.L > 0.0 and math.isfinite(self.L)):
            raise ModelError(f"DistanceJoint '{self.name}': length must be positive and finite, got {self.L!r} "
                             "(points that coincide need a SphericalJoint)")

    def program(self):
        return [(DISTANCE, 0, 0, 0, self.L, -1)]


class DrivenRevoluteAngle(SpatialPairElement):
    """Prescribed rotation angle θ(t) of b relative to a about ē3 = ``axis`` (1 row).

    Φ = u·w with ā(t) = −sin θ* ē_a1 + cos θ* ē_a2, b̄ = ē_b1, θ* = θ0 + φ(t):
    Φ = sin(θ − θ*), θ the angle of ē_b1 in a's (ē1, ē2) plane, zero at t0. Use
    with a :class:`RevoluteJoint` with the same point and axis. λ is the
    driving torque: the moment on b is −λ ē3 (space axes), N m. Multi-turn drives
    need no unwrapping.

    The row is the sin/cos form of the angle error, Φ = cos θ* (u2·w1) −
    sin θ* (u1·w1): smooth, without a branch cut, and ∂Φ/∂θ = cos(θ − θ*) = 1
    on the solution for every θ*, so it is equally well conditioned at every
    angle; its gradient there is −u3, independent of the revolute's axis locks
    (−u1, −u2) through whole turns (docs/spatial.md, "Driven angle").

    Parameters
    ----------
    name, a, b, at, point_a, point_b, axis, axis1, frame : see :class:`SpatialPairElement`
    angle : float or TimeFunction
        φ(t) (rad), e.g. ``femb.base.functions.Linear(6.0)``.
    angle0 : float
        θ0 (rad), default 0: the angle at t0 is 0 by construction.
    """

    glyph = "motor"

    n_constraints = 1
    rheonomic = True
    constraint_names = ("angle",)
    constraint_units = ("N·m",)
    kernels = JOINT_KERNELS

    def __init__(self, name, a, b, angle, at=None, point_a=None, point_b=None, axis=None, axis1=None,
                 frame=None, angle0=0.0):
        super().__init__(name, a, b, at, point_a, point_b, axis, axis1, frame)
        self.fn = as_time_function(angle, f"DrivenRevoluteAngle '{name}'", "angle")
        self.angle0 = float(angle0)

    def program(self):
        return [(DRIVEN_DOT1, 0, A1, B1, self.angle0, 0)]

    @classmethod
    def time_functions(cls, element):
        return [element.fn]


class DrivenPrismaticDisplacement(_LineJoint):
    """Prescribed displacement of p_b along ē3 = ``axis`` of a (1 row).

    Φ = u3·d − d0 − s(t), d0 = u3·d at t0. λ: the force on b at p_b is −λ u3
    (space axes), N. Use with a :class:`PrismaticJoint` or a :class:`CylindricalJoint`.

    Parameters
    ----------
    name, a, b, at, point_a, point_b, axis, axis1, frame : see :class:`SpatialPairElement`
    displacement : float or TimeFunction
        s(t) (m).
    """

    glyph = "actuator"

    n_constraints = 1
    rheonomic = True
    constraint_names = ("displacement",)
    constraint_units = ("N",)
    kernels = JOINT_KERNELS

    def __init__(self, name, a, b, displacement, at=None, point_a=None, point_b=None, axis=None,
                 axis1=None, frame=None):
        super().__init__(name, a, b, at, point_a, point_b, axis, axis1, frame)
        self.fn = as_time_function(displacement, f"DrivenPrismaticDisplacement '{name}'", "displacement")

    def program(self):
        return [(DOT2, 0, A3, 0, self.offsets[2], 0)]

    @classmethod
    def time_functions(cls, element):
        return [element.fn]


def relative_angle(Ea, Eb, xa, xb):
    """Angle of b relative to a about the joint axis: atan2(u2·w1, u1·w1) (not unwrapped).

    Ea, Eb : (3, 3) rows ē_a1..3, ē_b1..3 (body axes); xa, xb : (..., 7) node coordinates.
    """
    from femb.base import rotations as rt
    xa = np.atleast_2d(xa)
    xb = np.atleast_2d(xb)
    out = np.empty(xa.shape[0])
    for k in range(xa.shape[0]):
        Ra = rt.quat_to_matrix(np.ascontiguousarray(xa[k, 3:7]))
        Rb = rt.quat_to_matrix(np.ascontiguousarray(xb[k, 3:7]))
        w1 = Rb @ Eb[0]
        out[k] = math.atan2((Ra @ Ea[1]) @ w1, (Ra @ Ea[0]) @ w1)
    return out


__all__ = ["SpatialPairElement", "joint_frame", "SphericalJoint", "RevoluteJoint", "UniversalJoint",
           "CylindricalJoint", "PrismaticJoint", "FixedJoint", "DistanceJoint", "DrivenRevoluteAngle",
           "DrivenPrismaticDisplacement", "relative_angle", "joint_constraint", "joint_rates", "JOINT_KERNELS",
           "joint_reactions", "pair_points"]
