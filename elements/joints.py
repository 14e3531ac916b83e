"""Planar joints and driven (rheonomic) constraints between two bodies.

Every joint connects body ``a`` to body ``b`` (either may be the ground or a
point mass). Sign convention: M q̈ = f − Φ_qᵀ λ, so the generalized force of
a joint on the coordinates is −Φ_qᵀ λ; for a hinge with Φ = r_a − r_b the
joint pushes body b with the force +λ and body a with −λ. What λ is for
every joint type (force or moment, on which body, in which frame, units) is
collected in ``docs/conventions.md`` and checked by
``tests/test_conventions.py``.

References
----------
M. Géradin, A. Cardona, Flexible Multibody Dynamics, Wiley, 2001, Ch. 5 & 9.
P. E. Nikravesh, Computer-Aided Analysis of Mechanical Systems, 1988
(planar revolute and translational joints in absolute coordinates).
"""
from __future__ import annotations

import math

import numpy as np

from femb.element import Element
from femb.errors import ModelError
from femb.functions import as_time_function, evaluate
from femb.geometry import GeometryBlock

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
    """

    n_constraints = 2
    constraint_names = ("x", "y")

    def __init__(self, name, a, b, at=None, point_a=None, point_b=None):
        super().__init__(name, a, b)
        self._spec = (at, point_a, point_b)

    def validate(self):
        self.sa, self.sb = self._points(*self._spec)

    @classmethod
    def pack(cls, elements):
        sa = np.array([e.sa for e in elements])
        sb = np.array([e.sb for e in elements])
        n = len(elements)
        Bq = np.zeros((n, 2, 6))        # constant part of Φ_q
        Bq[:, 0, 0] = Bq[:, 1, 1] = 1.0
        Bq[:, 0, 3] = Bq[:, 1, 4] = -1.0
        s_c = np.stack((sa[:, 0] + 1j * sa[:, 1], sb[:, 0] + 1j * sb[:, 1]), axis=1)
        return {"sa": sa, "sb": sb, "s_c": s_c, "Bq": Bq}

    @classmethod
    def constraint_all(cls, p, t, qe, lame, jac):
        # both offsets d_a = R(θ_a) s_a, d_b = R(θ_b) s_b in one complex product
        d = (np.exp(1j * qe[:, 2::3]) * p["s_c"]).view(np.float64)
        da = d[:, 0:2]
        db = d[:, 2:4]
        Phi = qe[:, 0:2] - qe[:, 3:5] + (da - db)
        Phi_q = p["Bq"].copy()
        Phi_q[:, 0, 2] = -da[:, 1]
        Phi_q[:, 1, 2] = da[:, 0]
        Phi_q[:, 0, 5] = db[:, 1]
        Phi_q[:, 1, 5] = -db[:, 0]
        if not jac:
            return Phi, Phi_q, None
        H = np.zeros((qe.shape[0], 6, 6))
        H[:, 2, 2] = -(lame[:, 0] * da[:, 0] + lame[:, 1] * da[:, 1])
        H[:, 5, 5] = lame[:, 0] * db[:, 0] + lame[:, 1] * db[:, 1]
        return Phi, Phi_q, H

    @classmethod
    def constraint(cls, p, t, qe):
        xa, tha, xb, thb = _split(qe)
        da = rot(tha, p["sa"])
        db = rot(thb, p["sb"])
        n = qe.shape[0]
        Phi = xa + da - xb - db
        Phi_q = np.zeros((n, 2, 6))
        Phi_q[:, 0, 0] = 1.0
        Phi_q[:, 1, 1] = 1.0
        Phi_q[:, 0, 3] = -1.0
        Phi_q[:, 1, 4] = -1.0
        Phi_q[:, :, 2] = perp(da)
        Phi_q[:, :, 5] = -perp(db)
        return Phi, Phi_q

    @classmethod
    def constraint_hessian(cls, p, t, qe, lame):
        _, tha, _, thb = _split(qe)
        da = rot(tha, p["sa"])
        db = rot(thb, p["sb"])
        H = np.zeros((qe.shape[0], 6, 6))
        H[:, 2, 2] = -np.einsum("ij,ij->i", lame, da)
        H[:, 5, 5] = np.einsum("ij,ij->i", lame, db)
        return H

    @classmethod
    def constraint_rates(cls, p, t, qe, qde):
        _, tha, _, thb = _split(qe)
        da = rot(tha, p["sa"])
        db = rot(thb, p["sb"])
        gamma = -da * qde[:, 2:3] ** 2 + db * qde[:, 5:6] ** 2
        return np.zeros_like(gamma), gamma

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
def _line_kernel(p, qe, w_bar):
    """Φ = (R_a w̄)·Δ with Δ = r_b(P_b) − r_a(P_a); returns Φ (nel,), Φ_q (nel, 6), parts."""
    xa, tha, xb, thb = _split(qe)
    da = rot(tha, p["sa"])
    db = rot(thb, p["sb"])
    w = rot(tha, w_bar)
    Jw = perp(w)
    D = xb + db - xa - da
    n = qe.shape[0]
    Phi = np.einsum("ij,ij->i", w, D)
    g = np.empty((n, 6))
    g[:, 0:2] = -w
    g[:, 2] = np.einsum("ij,ij->i", Jw, D) - np.einsum("ij,ij->i", w, perp(da))
    g[:, 3:5] = w
    g[:, 5] = np.einsum("ij,ij->i", w, perp(db))
    return Phi, g, (w, Jw, D, da, db)


def _line_hessian(parts, scale):
    """Σ λ ∂²Φ/∂q² of the line constraint; scale (nel,) is λ."""
    w, Jw, D, da, db = parts
    n = w.shape[0]
    H = np.zeros((n, 6, 6))
    s = scale[:, None]
    H[:, 2, 0:2] = -Jw * s
    H[:, 0:2, 2] = -Jw * s
    H[:, 2, 3:5] = Jw * s
    H[:, 3:5, 2] = Jw * s
    H[:, 2, 2] = -np.einsum("ij,ij->i", w, D + da) * scale
    hab = np.einsum("ij,ij->i", w, db) * scale
    H[:, 2, 5] = hab
    H[:, 5, 2] = hab
    H[:, 5, 5] = -hab
    return H


def _line_gamma(parts, qde):
    """q̇ᵀ (∂²Φ/∂q²) q̇ of the line constraint, (nel,)."""
    w, Jw, D, da, db = parts
    va, oa, vb, ob = qde[:, 0:2], qde[:, 2], qde[:, 3:5], qde[:, 5]
    return (2.0 * oa * np.einsum("ij,ij->i", Jw, vb - va)
            - oa * oa * np.einsum("ij,ij->i", w, D + da)
            + 2.0 * oa * ob * np.einsum("ij,ij->i", w, db)
            - ob * ob * np.einsum("ij,ij->i", w, db))


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

    @classmethod
    def pack(cls, elements):
        n = len(elements)
        u = np.array([e.u for e in elements])
        Bq = np.zeros((n, 2, 6))          # rotation-lock row of a Slider's Φ_q (constant)
        Bq[:, 1, 2] = -1.0
        Bq[:, 1, 5] = 1.0
        return {"sa": np.array([e.sa for e in elements]), "sb": np.array([e.sb for e in elements]),
                "u": u, "n": perp(u), "phi0": np.array([e.phi0 for e in elements]),
                "draw_length": np.array([e.draw_length for e in elements]), "Bq": Bq}

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
    """

    n_constraints = 1
    constraint_names = ("normal",)

    @classmethod
    def constraint(cls, p, t, qe):
        Phi, g, _ = _line_kernel(p, qe, perp(p["u"]))
        return Phi[:, None], g[:, None, :]

    @classmethod
    def constraint_all(cls, p, t, qe, lame, jac):
        Phi, g, parts = _line_kernel(p, qe, p["n"])
        return Phi[:, None], g[:, None, :], (_line_hessian(parts, lame[:, 0]) if jac else None)

    @classmethod
    def constraint_hessian(cls, p, t, qe, lame):
        _, _, parts = _line_kernel(p, qe, perp(p["u"]))
        return _line_hessian(parts, lame[:, 0])

    @classmethod
    def constraint_rates(cls, p, t, qe, qde):
        _, _, parts = _line_kernel(p, qe, perp(p["u"]))
        gam = _line_gamma(parts, qde)
        return np.zeros((qe.shape[0], 1)), gam[:, None]


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
    """

    n_constraints = 2
    constraint_names = ("normal", "moment")

    def validate(self):
        super().validate()
        if self.a.node.fixed[2] and self.b.node.fixed[2]:
            raise ModelError(
                f"Slider '{self.name}': neither '{self.a.name}' nor '{self.b.name}' can rotate, so "
                "the rotation lock is redundant; use PointOnLine instead")

    @classmethod
    def constraint(cls, p, t, qe):
        Phi1, g, _ = _line_kernel(p, qe, perp(p["u"]))
        n = qe.shape[0]
        Phi = np.empty((n, 2))
        Phi[:, 0] = Phi1
        Phi[:, 1] = qe[:, 5] - qe[:, 2] - p["phi0"]
        Phi_q = np.zeros((n, 2, 6))
        Phi_q[:, 0, :] = g
        Phi_q[:, 1, 2] = -1.0
        Phi_q[:, 1, 5] = 1.0
        return Phi, Phi_q

    @classmethod
    def constraint_hessian(cls, p, t, qe, lame):
        _, _, parts = _line_kernel(p, qe, perp(p["u"]))
        return _line_hessian(parts, lame[:, 0])

    @classmethod
    def constraint_all(cls, p, t, qe, lame, jac):
        Phi1, g, parts = _line_kernel(p, qe, p["n"])
        n = qe.shape[0]
        Phi = np.empty((n, 2))
        Phi[:, 0] = Phi1
        Phi[:, 1] = qe[:, 5] - qe[:, 2] - p["phi0"]
        Phi_q = p["Bq"].copy()
        Phi_q[:, 0, :] = g
        return Phi, Phi_q, (_line_hessian(parts, lame[:, 0]) if jac else None)

    @classmethod
    def constraint_rates(cls, p, t, qe, qde):
        _, _, parts = _line_kernel(p, qe, perp(p["u"]))
        n = qe.shape[0]
        gam = np.zeros((n, 2))
        gam[:, 0] = _line_gamma(parts, qde)
        return np.zeros((n, 2)), gam


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
    """

    n_constraints = 1
    rheonomic = True
    constraint_names = ("force",)

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
    def pack(cls, elements):
        p = super().pack(elements)
        p["d0"] = np.array([e.d0 for e in elements])
        p["fn"] = [e.fn for e in elements]
        return p

    @classmethod
    def constraint(cls, p, t, qe):
        Phi, g, _ = _line_kernel(p, qe, p["u"])
        Phi = Phi - p["d0"] - evaluate(p["fn"], t, 0)
        return Phi[:, None], g[:, None, :]

    @classmethod
    def constraint_hessian(cls, p, t, qe, lame):
        _, _, parts = _line_kernel(p, qe, p["u"])
        return _line_hessian(parts, lame[:, 0])

    @classmethod
    def constraint_all(cls, p, t, qe, lame, jac):
        Phi, g, parts = _line_kernel(p, qe, p["u"])
        Phi = Phi - p["d0"] - evaluate(p["fn"], t, 0)
        return Phi[:, None], g[:, None, :], (_line_hessian(parts, lame[:, 0]) if jac else None)

    @classmethod
    def constraint_rates(cls, p, t, qe, qde):
        _, _, parts = _line_kernel(p, qe, p["u"])
        gam = _line_gamma(parts, qde) - evaluate(p["fn"], t, 2)
        return -evaluate(p["fn"], t, 1)[:, None], gam[:, None]


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
    """

    n_constraints = 1
    rheonomic = True
    constraint_names = ("torque",)

    def __init__(self, name, a, b, angle):
        super().__init__(name, a, b)
        self.fn = as_time_function(angle, f"DrivenAngle '{name}'", "angle")

    def validate(self):
        if self.a.node.fixed[2] and self.b.node.fixed[2]:
            raise ModelError(f"DrivenAngle '{self.name}': neither '{self.a.name}' nor '{self.b.name}' can rotate")
        self.phi0 = float(self.b.node.q0[2] - self.a.node.q0[2])

    @classmethod
    def pack(cls, elements):
        return {"phi0": np.array([e.phi0 for e in elements]), "fn": [e.fn for e in elements]}

    @classmethod
    def constraint(cls, p, t, qe):
        n = qe.shape[0]
        Phi = (qe[:, 5] - qe[:, 2] - p["phi0"] - evaluate(p["fn"], t, 0))[:, None]
        Phi_q = np.zeros((n, 1, 6))
        Phi_q[:, 0, 2] = -1.0
        Phi_q[:, 0, 5] = 1.0
        return Phi, Phi_q

    @classmethod
    def constraint_hessian(cls, p, t, qe, lame):
        return None

    @classmethod
    def constraint_rates(cls, p, t, qe, qde):
        return -evaluate(p["fn"], t, 1)[:, None], -evaluate(p["fn"], t, 2)[:, None]
