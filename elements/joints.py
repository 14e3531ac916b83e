"""Planar joints and driven (rheonomic) constraints between two bodies.

Every joint connects body ``a`` to body ``b`` (either may be the ground or a
point mass). Sign convention: M q̈ = f − Φ_qᵀ λ, so the generalized force of
a joint on the coordinates is −Φ_qᵀ λ; for a hinge with Φ = r_a − r_b the
joint pushes body b with the force +λ and body a with −λ. What λ is for
every joint type (force or moment, on which body, in which frame, units) is
collected in ``docs/conventions.md`` and checked by
``tests/test_conventions.py``.

Each type's equations are written once, as compiled kernels (``docs/kernels.md``),
over a batch of ``nel`` joints with element coordinates ``xe (nel, 6)`` =
(x_a, y_a, θ_a, x_b, y_b, θ_b), velocities ``ve (nel, 6)``, multipliers
``le (nel, nc)``, parameters ``P (nel, npar)`` from ``pack`` and time-function
values ``tf (nel, ntf, 3)``:

* ``constraint(P, t, tf, xe, le, jac, Phi, B, H)`` writes Φ ``(nel, nc)``,
  B = Φ_q ``(nel, nc, 6)`` and, if ``jac``, H = ∂(Φ_qᵀλ)/∂q ``(nel, 6, 6)``;
* ``rates(P, t, tf, xe, ve, Phi_t, gam)`` writes Φ_t and γ = (Φ_q q̇)_q q̇ + 2 Φ_qt q̇ + Φ_tt
  ``(nel, nc)``, so that Φ_q q̈ = −γ.

References
----------
M. Géradin, A. Cardona, Flexible Multibody Dynamics, Wiley, 2001, Ch. 5 & 9.
P. E. Nikravesh, Computer-Aided Analysis of Mechanical Systems, 1988
(planar revolute and translational joints in absolute coordinates).
"""
from __future__ import annotations

import math

import numpy as np

from femb.base.functions import as_time_function
from femb.base.geometry import GeometryBlock
from femb.base.jit import kernel
from femb.errors import ModelError
from femb.system.element import Element

from ._planar import perp, rot


class PairElement(Element):
    """An element between two bodies ``a`` and ``b`` (objects or names)."""

    def __init__(self, name, a, b):
        super().__init__(name)
        self.a, self.b = a, b

    def resolve(self, lookup):
        self.a = lookup(self.a, "a")
        self.b = lookup(self.b, "b")
        if self.a is self.b:
            raise ModelError(f"{type(self).__name__} '{self.name}': bodies a and b are the same ('{self.a.name}')")

    def nodes(self):
        return [self.a.node, self.b.node]

    def _points(self, at, point_a, point_b):
        if at is not None:
            if point_a is not None or point_b is not None:
                raise ModelError(f"{type(self).__name__} '{self.name}': give either at= or point_a/point_b, not both")
            return self.a.local_from_global(at), self.b.local_from_global(at)
        sa = self.a.local((0.0, 0.0) if point_a is None else point_a, "point_a")
        sb = self.b.local((0.0, 0.0) if point_b is None else point_b, "point_b")
        return sa, sb


def _split(qe):
    return qe[:, 0:2], qe[:, 2], qe[:, 3:5], qe[:, 5]


# ---------------------------------------------------------------------------
# Hinge (revolute joint)
# ---------------------------------------------------------------------------
@kernel
def hinge_constraint(P, t, tf, xe, le, jac, Phi, B, H):
    """Φ = r_a + R(θ_a) s_a − r_b − R(θ_b) s_b; P = (s_a, s_b)."""
    for e in range(xe.shape[0]):
        ca, sa_ = math.cos(xe[e, 2]), math.sin(xe[e, 2])
        cb, sb_ = math.cos(xe[e, 5]), math.sin(xe[e, 5])
        dax = ca * P[e, 0] - sa_ * P[e, 1]
        day = sa_ * P[e, 0] + ca * P[e, 1]
        dbx = cb * P[e, 2] - sb_ * P[e, 3]
        dby = sb_ * P[e, 2] + cb * P[e, 3]
        Phi[e, 0] = xe[e, 0] - xe[e, 3] + (dax - dbx)
        Phi[e, 1] = xe[e, 1] - xe[e, 4] + (day - dby)
        B[e, 0, 0] = 1.0
        B[e, 1, 1] = 1.0
        B[e, 0, 3] = -1.0
        B[e, 1, 4] = -1.0
        B[e, 0, 2] = -day
        B[e, 1, 2] = dax
        B[e, 0, 5] = dby
        B[e, 1, 5] = -dbx
        if jac:
            H[e, 2, 2] = -(le[e, 0] * dax + le[e, 1] * day)
            H[e, 5, 5] = le[e, 0] * dbx + le[e, 1] * dby


@kernel
def hinge_rates(P, t, tf, xe, ve, Phi_t, gam):
    """Φ_t = 0; γ = −d_a ω_a² + d_b ω_b²."""
    for e in range(xe.shape[0]):
        ca, sa_ = math.cos(xe[e, 2]), math.sin(xe[e, 2])
        cb, sb_ = math.cos(xe[e, 5]), math.sin(xe[e, 5])
        wa2 = ve[e, 2] * ve[e, 2]
        wb2 = ve[e, 5] * ve[e, 5]
        gam[e, 0] = -(ca * P[e, 0] - sa_ * P[e, 1]) * wa2 + (cb * P[e, 2] - sb_ * P[e, 3]) * wb2
        gam[e, 1] = -(sa_ * P[e, 0] + ca * P[e, 1]) * wa2 + (sb_ * P[e, 2] + cb * P[e, 3]) * wb2


class Hinge(PairElement):
    """Revolute joint: point P_a of body a coincides with point P_b of body b.

    Φ = r_a(P_a) − r_b(P_b) (2 equations); λ = (F_x, F_y) is the force the
    joint exerts on body b at P_b, in inertial components (N), and −λ on body
    a at P_a. The joint transmits no moment.

    Parameters
    ----------
    name : str
    a, b : Body or str
        The two bodies (``mech.ground`` or ``"ground"`` for the ground).
    at : (x, y), optional
        The hinge's inertial position in the initial configuration.
    point_a, point_b : str or (x, y), optional
        The hinge point on each body, by name or body-frame coordinates
        (default: the node, i.e. the centre of mass). Used when ``at`` is not given.

    Notes
    -----
    Kernels: :func:`hinge_constraint`, :func:`hinge_rates`; ``P = (s_a, s_b)``.
    """
    glyph = "revolute"  # how pictures draw it (femb.io.frames)

    n_constraints = 2
    constraint_names = ("x", "y")
    kernels = {"constraint": hinge_constraint, "rates": hinge_rates}

    def __init__(self, name, a, b, at=None, point_a=None, point_b=None):
        super().__init__(name, a, b)
        self._spec = (at, point_a, point_b)

    def validate(self):
        self.sa, self.sb = self._points(*self._spec)

    @classmethod
    def pack(cls, elements):
        sa = np.array([e.sa for e in elements], dtype=float).reshape(-1, 2)
        sb = np.array([e.sb for e in elements], dtype=float).reshape(-1, 2)
        return {"P": np.ascontiguousarray(np.hstack((sa, sb))), "sa": sa, "sb": sb}

    @classmethod
    def geometry(cls, p, t, qe, qde, lame, names):
        xa, tha, _, _ = _split(qe)
        pts = np.zeros((qe.shape[0], 3))
        pts[:, :2] = xa + rot(tha, p["sa"])
        F = np.zeros((qe.shape[0], 3))
        F[:, :2] = lame
        conn = np.arange(qe.shape[0])[:, None]
        return [GeometryBlock(cls.__name__, pts, [("vertex", conn)],
                              point_data={"reaction": F, "reaction_magnitude": np.linalg.norm(lame, axis=1)})]


# ---------------------------------------------------------------------------
# Line constraints: slider, point on line, driven displacement
# ---------------------------------------------------------------------------
# Columns of P for every line joint: 0:2 s_a, 2:4 s_b, 4:6 w̄ (the constrained direction
# in body a's frame: n̄ = J ū for Slider and PointOnLine, ū for DrivenDisplacement),
# then 6: θ_0 (Slider) or d_0 (DrivenDisplacement).
#
# Φ = w·Δ with w = R(θ_a) w̄, Δ = r_b(P_b) − r_a(P_a) = x_b + d_b − x_a − d_a,
# d_a = R(θ_a) s_a, d_b = R(θ_b) s_b and J the rotation by +90°, J d = (−d_y, d_x):
#   Φ_q = [−w, Jw·Δ − w·J d_a, w, w·J d_b]
#   non-zero ∂²Φ/∂q²: θ_a r_a: −Jw, θ_a r_b: Jw, θ_a θ_a: −w·(Δ + d_a),
#                     θ_a θ_b: w·d_b, θ_b θ_b: −w·d_b.
@kernel
def _line_terms(P, e, xe):
    """(w_x, w_y, d_ax, d_ay, d_bx, d_by, Δ_x, Δ_y) of line joint e."""
    ca, sa_ = math.cos(xe[e, 2]), math.sin(xe[e, 2])
    cb, sb_ = math.cos(xe[e, 5]), math.sin(xe[e, 5])
    dax = ca * P[e, 0] - sa_ * P[e, 1]
    day = sa_ * P[e, 0] + ca * P[e, 1]
    dbx = cb * P[e, 2] - sb_ * P[e, 3]
    dby = sb_ * P[e, 2] + cb * P[e, 3]
    wx = ca * P[e, 4] - sa_ * P[e, 5]
    wy = sa_ * P[e, 4] + ca * P[e, 5]
    Dx = xe[e, 3] + dbx - xe[e, 0] - dax
    Dy = xe[e, 4] + dby - xe[e, 1] - day
    return wx, wy, dax, day, dbx, dby, Dx, Dy


@kernel
def _line_constraint(P, e, xe, lam, jac, B, H):
    """Φ of line joint e (returned), its Φ_q into row 0 of ``B[e]``, λ Φ_qq into ``H[e]`` if ``jac``."""
    wx, wy, dax, day, dbx, dby, Dx, Dy = _line_terms(P, e, xe)
    B[e, 0, 0] = -wx
    B[e, 0, 1] = -wy
    B[e, 0, 2] = (-wy * Dx + wx * Dy) - (-wx * day + wy * dax)
    B[e, 0, 3] = wx
    B[e, 0, 4] = wy
    B[e, 0, 5] = -wx * dby + wy * dbx
    if jac:
        # −Jw λ = (w_y, −w_x) λ
        H[e, 2, 0] = wy * lam
        H[e, 2, 1] = -wx * lam
        H[e, 0, 2] = wy * lam
        H[e, 1, 2] = -wx * lam
        H[e, 2, 3] = -wy * lam
        H[e, 2, 4] = wx * lam
        H[e, 3, 2] = -wy * lam
        H[e, 4, 2] = wx * lam
        H[e, 2, 2] = -(wx * (Dx + dax) + wy * (Dy + day)) * lam
        hab = (wx * dbx + wy * dby) * lam
        H[e, 2, 5] = hab
        H[e, 5, 2] = hab
        H[e, 5, 5] = -hab
    return wx * Dx + wy * Dy


@kernel
def _line_gamma(P, e, xe, ve):
    """q̇ᵀ Φ_qq q̇ of line joint e:
    2 ω_a Jw·(v_b − v_a) − ω_a² w·(Δ + d_a) + 2 ω_a ω_b w·d_b − ω_b² w·d_b."""
    wx, wy, dax, day, dbx, dby, Dx, Dy = _line_terms(P, e, xe)
    oa = ve[e, 2]
    ob = ve[e, 5]
    wdb = wx * dbx + wy * dby
    return (2.0 * oa * (-wy * (ve[e, 3] - ve[e, 0]) + wx * (ve[e, 4] - ve[e, 1]))
            - oa * oa * (wx * (Dx + dax) + wy * (Dy + day))
            + 2.0 * oa * ob * wdb
            - ob * ob * wdb)


@kernel
def point_on_line_constraint(P, t, tf, xe, le, jac, Phi, B, H):
    """Φ = n_a·(r_b(P_b) − r_a(P_a)), n_a = R(θ_a) n̄; P = (s_a, s_b, n̄)."""
    for e in range(xe.shape[0]):
        Phi[e, 0] = _line_constraint(P, e, xe, le[e, 0], jac, B, H)


@kernel
def point_on_line_rates(P, t, tf, xe, ve, Phi_t, gam):
    """Φ_t = 0; γ = q̇ᵀ Φ_qq q̇."""
    for e in range(xe.shape[0]):
        gam[e, 0] = _line_gamma(P, e, xe, ve)


@kernel
def slider_constraint(P, t, tf, xe, le, jac, Phi, B, H):
    """Φ = (n_a·(r_b(P_b) − r_a(P_a)), θ_b − θ_a − θ_0); P = (s_a, s_b, n̄, θ_0)."""
    for e in range(xe.shape[0]):
        Phi[e, 0] = _line_constraint(P, e, xe, le[e, 0], jac, B, H)
        Phi[e, 1] = xe[e, 5] - xe[e, 2] - P[e, 6]
        B[e, 1, 2] = -1.0
        B[e, 1, 5] = 1.0


@kernel
def slider_rates(P, t, tf, xe, ve, Phi_t, gam):
    """Φ_t = 0; γ = (q̇ᵀ Φ_qq q̇ of the line constraint, 0)."""
    for e in range(xe.shape[0]):
        gam[e, 0] = _line_gamma(P, e, xe, ve)


@kernel
def driven_displacement_constraint(P, t, tf, xe, le, jac, Phi, B, H):
    """Φ = u_a·(r_b(P_b) − r_a(P_a)) − d_0 − d(t), u_a = R(θ_a) ū; P = (s_a, s_b, ū, d_0), tf = d."""
    for e in range(xe.shape[0]):
        Phi[e, 0] = _line_constraint(P, e, xe, le[e, 0], jac, B, H) - P[e, 6] - tf[e, 0, 0]


@kernel
def driven_displacement_rates(P, t, tf, xe, ve, Phi_t, gam):
    """Φ_t = −d′(t); γ = q̇ᵀ Φ_qq q̇ − d″(t)."""
    for e in range(xe.shape[0]):
        Phi_t[e, 0] = -tf[e, 0, 1]
        gam[e, 0] = _line_gamma(P, e, xe, ve) - tf[e, 0, 2]


class _LineJoint(PairElement):
    def __init__(self, name, a, b, axis=(1.0, 0.0), at=None, point_a=None, point_b=None):
        super().__init__(name, a, b)
        self._spec = (at, point_a, point_b)
        u = np.asarray(axis, dtype=float).reshape(-1)
        if u.size != 2 or not np.all(np.isfinite(u)) or np.linalg.norm(u) == 0.0:
            raise ModelError(f"{type(self).__name__} '{name}': axis must be a non-zero finite 2-vector, got {axis!r}")
        self.u = u / np.linalg.norm(u)

    def validate(self):
        self.sa, self.sb = self._points(*self._spec)
        self.phi0 = float(self.b.node.q0[2] - self.a.node.q0[2])
        sep = np.linalg.norm(self.b.global_point(self.sb) - self.a.global_point(self.sa))
        self.draw_length = max(2.5 * sep, 0.05)

    #: the constrained direction in body a's frame is J ū (False) or ū (True)
    _along_axis = False

    @classmethod
    def _extra(cls, e):
        """The parameters after (s_a, s_b, w̄) in a row of P."""
        return ()

    @classmethod
    def pack(cls, elements):
        """``P = (s_a, s_b, w̄, extra...)`` (nel, 6 + extra) and the arrays of :meth:`geometry`."""
        sa = np.array([e.sa for e in elements], dtype=float).reshape(-1, 2)
        sb = np.array([e.sb for e in elements], dtype=float).reshape(-1, 2)
        u = np.array([e.u for e in elements], dtype=float).reshape(-1, 2)
        w = u if cls._along_axis else perp(u)
        extra = np.array([cls._extra(e) for e in elements], dtype=float).reshape(len(elements), -1)
        P = np.ascontiguousarray(np.hstack((sa, sb, w, extra)))
        return {"P": P, "sa": sa, "sb": sb, "u": u,
                "draw_length": np.array([e.draw_length for e in elements], dtype=float)}

    @classmethod
    def geometry(cls, p, t, qe, qde, lame, names):
        xa, tha, _, _ = _split(qe)
        n = qe.shape[0]
        c = xa + rot(tha, p["sa"])
        u = rot(tha, p["u"])
        L = p["draw_length"]
        pts = np.zeros((2 * n, 3))
        pts[0::2, :2] = c - 0.5 * L[:, None] * u
        pts[1::2, :2] = c + 0.5 * L[:, None] * u
        conn = np.arange(2 * n).reshape(n, 2)
        return [GeometryBlock(cls.__name__, pts, [("line", conn)],
                              cell_data={"reaction_magnitude": [np.linalg.norm(lame, axis=1)]})]


class PointOnLine(_LineJoint):
    """Point P_b of body b stays on the line through P_a of body a along ``axis``.

    Φ = n_a · (r_b(P_b) − r_a(P_a)), n_a = R(θ_a) J ū (1 equation; J the
    rotation by +90°, so n_a is the line's left normal, turning with body a).
    λ is a force (N): the joint pushes point P_b of body b with −λ n_a and
    body a with +λ n_a at the point of a that coincides with P_b (the force
    on a also has a moment about a's node). A mass resting on top of a
    horizontal line (ū = (1, 0), n_a = (0, 1)) has λ = −m g.

    Parameters
    ----------
    name : str
    a, b : Body or str
    axis : (ux, uy)
        Line direction in body a's frame.
    at, point_a, point_b : see :class:`Hinge`.

    Notes
    -----
    Kernels: :func:`point_on_line_constraint`, :func:`point_on_line_rates`;
    ``P = (s_a, s_b, J ū)``.
    """
    glyph = "prismatic"  # how pictures draw it (femb.io.frames)

    n_constraints = 1
    constraint_names = ("normal",)
    kernels = {"constraint": point_on_line_constraint, "rates": point_on_line_rates}


class Slider(_LineJoint):
    """Prismatic joint: body b translates relative to body a along ``axis`` only.

    Φ_1 = n_a · (r_b(P_b) − r_a(P_a)) (point on line), Φ_2 = θ_b − θ_a − θ_0
    (no relative rotation; θ_0 from the initial configuration). Between a
    point mass and anything, use :class:`PointOnLine` (a point mass has no
    rotation to lock, so Φ_2 would be redundant).

    λ = (λ_1, λ_2): λ_1 is a force (N) as for :class:`PointOnLine` — the
    slider pushes P_b of body b with −λ_1 n_a, n_a = R(θ_a) J ū the line's
    left normal in body a's current orientation; λ_2 is a torque (N m): the
    slider applies −λ_2 to body b and +λ_2 to body a (counter-clockwise
    positive). The total moment on b about P_b is −λ_2.

    Parameters
    ----------
    name : str
    a, b : Body or str
    axis : (ux, uy)
        Sliding direction in body a's frame.
    at, point_a, point_b : see :class:`Hinge`.

    Notes
    -----
    Kernels: :func:`slider_constraint`, :func:`slider_rates`; ``P = (s_a, s_b, J ū, θ_0)``.
    """
    glyph = "prismatic"  # how pictures draw it (femb.io.frames)

    n_constraints = 2
    constraint_names = ("normal", "moment")
    kernels = {"constraint": slider_constraint, "rates": slider_rates}

    def validate(self):
        super().validate()
        if self.a.node.fixed[2] and self.b.node.fixed[2]:
            raise ModelError(
                f"Slider '{self.name}': neither '{self.a.name}' nor '{self.b.name}' can rotate, so "
                "the rotation lock is redundant; use PointOnLine instead")

    @classmethod
    def _extra(cls, e):
        return (e.phi0,)


class DrivenDisplacement(_LineJoint):
    """Driven relative displacement along an axis (use with a :class:`Slider`).

    Φ = u_a · (r_b(P_b) − r_a(P_a)) − d_0 − d(t), u_a = R(θ_a) ū, where d_0 is
    the initial value and d(t) the prescribed displacement (d(t_0) is
    normally 0). λ is the actuator force (N): the driver pushes P_b of body
    b with −λ u_a and body a with +λ u_a, so λ > 0 pulls b back towards
    −u_a (for b ahead of a along u_a: tension) and λ < 0 pushes it along
    +u_a.

    Parameters
    ----------
    name : str
    a, b : Body or str
    displacement : TimeFunction, number or (f, df, ddf)
        d(t) with its derivatives.
    axis, at, point_a, point_b : see :class:`Slider`.

    Notes
    -----
    Kernels: :func:`driven_displacement_constraint`, :func:`driven_displacement_rates`;
    ``P = (s_a, s_b, ū, d_0)``; one time function, d(t).
    """
    glyph = "actuator"  # how pictures draw it (femb.io.frames)

    n_constraints = 1
    rheonomic = True
    constraint_names = ("force",)
    kernels = {"constraint": driven_displacement_constraint, "rates": driven_displacement_rates}
    _along_axis = True

    def __init__(self, name, a, b, displacement, axis=(1.0, 0.0), at=None, point_a=None, point_b=None):
        super().__init__(name, a, b, axis, at, point_a, point_b)
        self.fn = as_time_function(displacement, f"DrivenDisplacement '{name}'", "displacement")

    def validate(self):
        super().validate()
        ra = self.a.global_point(self.sa)
        rb = self.b.global_point(self.sb)
        th = self.a.node.q0[2]
        u = np.array([math.cos(th) * self.u[0] - math.sin(th) * self.u[1],
                      math.sin(th) * self.u[0] + math.cos(th) * self.u[1]])
        self.d0 = float(u @ (rb - ra))

    @classmethod
    def _extra(cls, e):
        return (e.d0,)

    @classmethod
    def time_functions(cls, element):
        """``[d]``: the prescribed displacement."""
        return [element.fn]


@kernel
def driven_angle_constraint(P, t, tf, xe, le, jac, Phi, B, H):
    """Φ = θ_b − θ_a − θ_0 − φ(t); P = (θ_0,), tf = φ. Φ_qq = 0: H stays zero."""
    for e in range(xe.shape[0]):
        Phi[e, 0] = xe[e, 5] - xe[e, 2] - P[e, 0] - tf[e, 0, 0]
        B[e, 0, 2] = -1.0
        B[e, 0, 5] = 1.0


@kernel
def driven_angle_rates(P, t, tf, xe, ve, Phi_t, gam):
    """Φ_t = −φ′(t); γ = −φ″(t)."""
    for e in range(xe.shape[0]):
        Phi_t[e, 0] = -tf[e, 0, 1]
        gam[e, 0] = -tf[e, 0, 2]


class DrivenAngle(PairElement):
    """Driven relative rotation (use with a :class:`Hinge`).

    Φ = θ_b − θ_a − θ_0 − φ(t), with θ_0 the initial relative angle; λ is the
    actuator torque (N m) with the sign flipped: the driver applies the
    torque −λ to body b and +λ to body a (counter-clockwise positive). The
    torque a motor delivers to b is therefore −λ.

    Parameters
    ----------
    name : str
    a, b : Body or str
    angle : TimeFunction, number or (f, df, ddf)
        φ(t) with its derivatives (φ(t_0) is normally 0).

    Notes
    -----
    Kernels: :func:`driven_angle_constraint`, :func:`driven_angle_rates`; ``P = (θ_0,)``;
    one time function, φ(t).
    """
    glyph = "motor"  # how pictures draw it (femb.io.frames)

    n_constraints = 1
    rheonomic = True
    constraint_names = ("torque",)
    kernels = {"constraint": driven_angle_constraint, "rates": driven_angle_rates}

    def __init__(self, name, a, b, angle):
        super().__init__(name, a, b)
        self.fn = as_time_function(angle, f"DrivenAngle '{name}'", "angle")

    def validate(self):
        if self.a.node.fixed[2] and self.b.node.fixed[2]:
            raise ModelError(f"DrivenAngle '{self.name}': neither '{self.a.name}' nor '{self.b.name}' can rotate")
        self.phi0 = float(self.b.node.q0[2] - self.a.node.q0[2])

    @classmethod
    def pack(cls, elements):
        """``P = (θ_0,)`` (nel, 1)."""
        phi0 = np.array([e.phi0 for e in elements], dtype=float)
        return {"P": np.ascontiguousarray(phi0.reshape(-1, 1)), "phi0": phi0}

    @classmethod
    def time_functions(cls, element):
        """``[φ]``: the prescribed relative angle."""
        return [element.fn]
