"""Rolling joints: non-holonomic (velocity-level) constraints A(q, t) v + a(q, t) = 0.

* :class:`RollingDisc` — a thin disc (a spatial body, its node at the disc centre) rolling
  without slip on a fixed plane: one holonomic condition (the lowest point of the rim stays on
  the plane) and two non-holonomic ones (the material point of the rim at the contact has no
  tangential velocity).
* :class:`PlanarWheel` — a planar wheel (its node at the centre) rolling on a fixed line.
* :class:`KnifeEdge` — a planar skate (Chaplygin sleigh): a body point moves only along a
  body-fixed blade direction.
* :class:`SpinRate` — the rate of rotation of spatial body b relative to a about an axis of a is
  held at a given value (a speed drive, e.g. a wheel motor).

Contact geometry of the disc (Neimark & Fufaev 1972, Ch. II; Meijaard et al. 2007, Appendix A):
disc centre r, axis a = R ā (unit, ā in body axes), radius ρ, plane through p₀ with unit
normal n. With c = n·a and s = √(1 − c²), the unit vector from the contact point to the centre
is d = (n − c a)/s and the contact point is r − ρ d. Holonomic:
Φ = n·(r − p₀) − ρ s = 0. Non-holonomic (t₁, t₂ fixed unit tangents of the plane):
Ψ_k = t_k·(ṙ − ρ ω × d) = t_k·ṙ − ρ (d × t_k)·ω, ω = RΩ.

Derivatives along R ← R exp(δθ̃) (δφ = R δθ): δa = δφ × a, δc = u·δφ with u = a × n,
δd = J_d δφ, J_d = (c ã − a uᵀ)/s + c d uᵀ/s²; the normal row of B is (n, ρ Rᵀh) with
h = (c/s) u and ∂h/∂φ = J_h = u uᵀ/s³ + (c/s) ñ ã. Every kernel is checked against finite
differences along x ∘ exp(εw) (``femb.check_jacobians``, ``tests/test_rolling.py``).

Reactions (M v̇ = f − Φ_qᵀλ − Aᵀμ): the plane acts on the disc at the contact point with the
force −(λ n + μ₁ t₁ + μ₂ t₂); ``contact_state`` gives the contact point, the normal force
N = −λ (positive in compression) and the tangential force.
"""
from __future__ import annotations

import numpy as np

from femb.base.jit import kernel
from femb.base.rotations import quat_to_matrix
from femb.errors import ModelError
from femb.system.element import Element

from .bodies import Body, Ground
from .spatial_bodies import SpatialBody, unit3, vector3


# ---------------------------------------------------------------------------
# small helpers (allocate: these kernels serve the Python paths, not the time loop)
# ---------------------------------------------------------------------------
@kernel(allocates=True)
def _skew(a):
    S = np.zeros((3, 3))
    S[0, 1], S[0, 2], S[1, 2] = -a[2], a[1], -a[0]
    S[1, 0], S[2, 0], S[2, 1] = a[2], -a[1], a[0]
    return S


@kernel(allocates=True)
def _cross(a, b):
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


@kernel(allocates=True)
def disc_geometry(P, x):
    """(R, a, c, s, u, d) of a disc: rotation, world axis, n·a, √(1 − c²), a × n, centre direction.

    ``P = (ρ, ā (3), n (3), p₀ (3), t₁ (3), t₂ (3))``; ``x = (r, p)`` (7).
    """
    R = quat_to_matrix(np.ascontiguousarray(x[3:7]))
    a = R @ np.ascontiguousarray(P[1:4])
    n = np.ascontiguousarray(P[4:7])
    c = n @ a
    s = np.sqrt(max(1.0 - c * c, 0.0))
    u = _cross(a, n)
    d = (n - c * a) / s
    return R, a, c, s, u, d


@kernel(allocates=True)
def disc_constraint(P, t, tf, xe, le, jac, Phi, B, H):
    """Φ = n·(r − p₀) − ρ s; B = (n, ρ Rᵀh); H = λ ρ ((Rᵀh)~ + Rᵀ J_h R) on the rotation block."""
    for e in range(xe.shape[0]):
        p = P[e]
        rho = p[0]
        n = np.ascontiguousarray(p[4:7])
        R, a, c, s, u, d = disc_geometry(p, xe[e])
        Phi[e, 0] = n @ (xe[e, 0:3] - p[7:10]) - rho * s
        h = (c / s) * u
        Rth = R.T @ h
        for i in range(3):
            B[e, 0, i] = n[i]
            B[e, 0, 3 + i] = rho * Rth[i]
        if jac:
            Jh = np.outer(u, u) / s ** 3 + (c / s) * (_skew(n) @ _skew(a))
            Hr = le[e, 0] * rho * (_skew(Rth) + R.T @ Jh @ R)
            for i in range(3):
                for j in range(3):
                    H[e, 3 + i, 3 + j] = Hr[i, j]


@kernel(allocates=True)
def disc_rates(P, t, tf, xe, ve, Phi_t, gam):
    """Φ_t = 0; γ = ρ ωᵀ J_h ω (ω = RΩ)."""
    for e in range(xe.shape[0]):
        p = P[e]
        n = np.ascontiguousarray(p[4:7])
        R, a, c, s, u, d = disc_geometry(p, xe[e])
        w = R @ np.ascontiguousarray(ve[e, 3:6])
        Jh = np.outer(u, u) / s ** 3 + (c / s) * (_skew(n) @ _skew(a))
        gam[e, 0] = p[0] * (w @ (Jh @ w))


@kernel(allocates=True)
def disc_rolling(P, t, tf, xe, ve, le, jac, Psi, A, Psi_t, Dq, H):
    """Ψ_k = t_k·ṙ − ρ (d × t_k)·ω (k = 1, 2), its A, Dq = ∂Ψ/∂x and H = ∂(Aᵀμ)/∂x."""
    for e in range(xe.shape[0]):
        p = P[e]
        rho = p[0]
        R, a, c, s, u, d = disc_geometry(p, xe[e])
        w = R @ np.ascontiguousarray(ve[e, 3:6])
        Jd = (c * _skew(a) - np.outer(a, u)) / s + (c / (s * s)) * np.outer(d, u)
        for k in range(2):
            tk = np.ascontiguousarray(p[10 + 3 * k:13 + 3 * k])
            wk = _cross(d, tk)
            Rtw = R.T @ wk
            Psi[e, k] = tk @ ve[e, 0:3] - rho * (wk @ w)
            for i in range(3):
                A[e, k, i] = tk[i]
                A[e, k, 3 + i] = -rho * Rtw[i]
            if jac:
                g = R.T @ (-rho * (Jd.T @ _cross(tk, w) + _cross(w, wk)))
                Hr = -rho * le[e, k] * (_skew(Rtw) - R.T @ _skew(tk) @ Jd @ R)
                for i in range(3):
                    Dq[e, k, 3 + i] = g[i]
                    for j in range(3):
                        H[e, 3 + i, 3 + j] += Hr[i, j]


def _plane(owner, normal, tangent):
    n = unit3(owner, "normal", normal)
    if tangent is None:
        guess = np.eye(3)[int(np.argmin(np.abs(n)))]
        tangent = guess - (guess @ n) * n
    t1 = np.asarray(tangent, dtype=float).reshape(-1)
    if t1.shape != (3,) or not np.all(np.isfinite(t1)):
        raise ModelError(f"{owner}: tangent must be a finite 3-vector, got {tangent!r}")
    t1 = t1 - (t1 @ n) * n
    if np.linalg.norm(t1) < 1e-12:
        raise ModelError(f"{owner}: tangent {tangent!r} is parallel to the plane normal {normal!r}")
    t1 /= np.linalg.norm(t1)
    return n, t1, np.cross(n, t1)


class RollingDisc(Element):
    """A thin disc rolling without slip on a fixed plane (1 holonomic + 2 non-holonomic rows).

    Parameters
    ----------
    name : str
    body : SpatialBody or str
        The disc; its node is the disc centre.
    radius : float > 0
        ρ (m).
    axis : (3,) or str
        The disc axis ā in body axes (or a named axis of the body).
    normal : (3,)
        Unit normal n of the plane (space axes; the disc is on its positive side).
    point : (3,)
        A point p₀ of the plane (m).
    tangent : (3,), optional
        First tangent t₁ of the plane (projected on it); t₂ = n × t₁.

    Notes
    -----
    λ (1, "normal"): N = −λ is the normal force on the disc (N, positive in compression);
    μ (2, "t1", "t2"): the plane pushes the disc along t₁, t₂ with −μ₁, −μ₂ (N). The disc must
    not lie flat (c = n·a = ±1 is singular) and stays in contact (the contact does not open).
    """

    spatial = True
    n_constraints = 1
    constraint_names = ("normal",)
    constraint_units = ("N",)
    n_velocity_constraints = 2
    velocity_constraint_names = ("t1", "t2")
    velocity_constraint_units = ("N", "N")
    kernels = {"constraint": disc_constraint, "rates": disc_rates, "velocity_constraint": disc_rolling}

    def __init__(self, name, body, radius, axis, normal=(0.0, 0.0, 1.0), point=(0.0, 0.0, 0.0),
                 tangent=None):
        super().__init__(name)
        owner = f"RollingDisc '{name}'"
        self.body = body
        try:
            self.radius = float(radius)
        except (TypeError, ValueError):
            raise ModelError(f"{owner}: radius must be a number, got {radius!r}") from None
        if not (self.radius > 0.0 and np.isfinite(self.radius)):
            raise ModelError(f"{owner}: radius must be positive and finite, got {radius!r}")
        self._axis = axis
        self.n, self.t1, self.t2 = _plane(owner, normal, tangent)
        self.p0 = vector3(owner, "point", point)

    def resolve(self, lookup):
        body = lookup(self.body, "body")
        if not isinstance(body, SpatialBody) or isinstance(body, Ground):
            raise ModelError(f"RollingDisc '{self.name}': body must be a spatial body, got '{body.name}'")
        self.body = body
        owner = f"RollingDisc '{self.name}'"
        self.axis = (body.axes[self._axis] if isinstance(self._axis, str) and self._axis in body.axes
                     else unit3(owner, "axis", self._axis))

    def validate(self):
        a = self.body.node.rotation0 @ self.axis
        if abs(a @ self.n) > 1.0 - 1e-9:
            raise ModelError(f"RollingDisc '{self.name}': the disc lies flat on the plane at t0 (axis ∥ normal); "
                             "its contact point is undefined")

    def nodes(self):
        return [self.body.node]

    @classmethod
    def pack(cls, elements):
        P = np.array([[e.radius, *e.axis, *e.n, *e.p0, *e.t1, *e.t2] for e in elements], dtype=float)
        return {"P": np.ascontiguousarray(P)}

    @staticmethod
    def contact_state(P, x, v, lam, mu):
        """Contact point, normal force N and tangential force of one disc.

        Parameters
        ----------
        P : (16,) packed parameters; x : (7,) node coordinates; v : (6,) node velocities;
        lam : (1,), mu : (2,) its multipliers.

        Returns
        -------
        dict: ``point`` (3,) m, ``normal_force`` N (N, compression positive), ``tangential_force``
        (3,) N (on the disc, space axes), ``slip_velocity`` (3,) m/s (material contact point).
        """
        P = np.asarray(P, dtype=float)
        R, a, c, s, u, d = disc_geometry.py_func(P, np.asarray(x, dtype=float))
        pt = x[0:3] - P[0] * d
        w = R @ v[3:6]
        return {"point": pt, "normal_force": -float(lam[0]),
                "tangential_force": -(mu[0] * P[10:13] + mu[1] * P[13:16]),
                "slip_velocity": v[0:3] - P[0] * np.cross(w, d)}


# ---------------------------------------------------------------------------
# planar rolling and the knife edge
# ---------------------------------------------------------------------------
@kernel(allocates=True)
def wheel_constraint(P, t, tf, xe, le, jac, Phi, B, H):
    """Φ = n·(r − p₀) − ρ; P = (ρ, n (2), p₀ (2))."""
    for e in range(xe.shape[0]):
        Phi[e, 0] = P[e, 1] * (xe[e, 0] - P[e, 3]) + P[e, 2] * (xe[e, 1] - P[e, 4]) - P[e, 0]
        B[e, 0, 0] = P[e, 1]
        B[e, 0, 1] = P[e, 2]


@kernel(allocates=True)
def wheel_rates(P, t, tf, xe, ve, Phi_t, gam):
    for e in range(xe.shape[0]):
        gam[e, 0] = 0.0


@kernel(allocates=True)
def wheel_rolling(P, t, tf, xe, ve, le, jac, Psi, A, Psi_t, Dq, H):
    """Ψ = t·ṙ + ρ θ̇ with t = (n_y, −n_x) (contact point at rest)."""
    for e in range(xe.shape[0]):
        tx, ty = P[e, 2], -P[e, 1]
        A[e, 0, 0], A[e, 0, 1], A[e, 0, 2] = tx, ty, P[e, 0]
        Psi[e, 0] = tx * ve[e, 0] + ty * ve[e, 1] + P[e, 0] * ve[e, 2]


class _PlanarOneBody(Element):
    def __init__(self, name, body):
        super().__init__(name)
        self.body = body

    def resolve(self, lookup):
        body = lookup(self.body, "body")
        if isinstance(body, (Ground, SpatialBody)) or not isinstance(body, Body):
            raise ModelError(f"{type(self).__name__} '{self.name}': body must be a planar body, got '{body.name}'")
        if bool(np.any(body.node.fixed)):
            raise ModelError(f"{type(self).__name__} '{self.name}': body '{body.name}' must have x, y and θ free "
                             "(a PointMass cannot roll)")
        self.body = body

    def nodes(self):
        return [self.body.node]


def _unit2(owner, what, v):
    v = np.asarray(v, dtype=float).reshape(-1)
    if v.shape != (2,) or not np.all(np.isfinite(v)) or np.linalg.norm(v) == 0.0:
        raise ModelError(f"{owner}: {what} must be a non-zero finite 2-vector, got {v!r}")
    return v / np.linalg.norm(v)


class PlanarWheel(_PlanarOneBody):
    """A planar wheel (its node at the centre) rolling without slip on a fixed line.

    Φ = n·(r − p₀) − ρ = 0 (the centre at height ρ); Ψ = t·ṙ + ρθ̇ = 0 with t = (n_y, −n_x), the
    direction in which the wheel rolls for a negative (clockwise when n = (0, 1)) θ̇.
    λ: N = −λ the normal force (N); μ: −μ the tangential force of the line on the wheel along t.
    """

    n_constraints = 1
    constraint_names = ("normal",)
    n_velocity_constraints = 1
    velocity_constraint_names = ("tangential",)
    velocity_constraint_units = ("N",)
    kernels = {"constraint": wheel_constraint, "rates": wheel_rates, "velocity_constraint": wheel_rolling}

    def __init__(self, name, body, radius, normal=(0.0, 1.0), point=(0.0, 0.0)):
        super().__init__(name, body)
        owner = f"PlanarWheel '{name}'"
        self.radius = float(radius) if np.isscalar(radius) else np.nan
        if not (self.radius > 0.0 and np.isfinite(self.radius)):
            raise ModelError(f"{owner}: radius must be a positive number, got {radius!r}")
        self.n = _unit2(owner, "normal", normal)
        self.p0 = np.asarray(point, dtype=float).reshape(2)

    @classmethod
    def pack(cls, elements):
        return {"P": np.ascontiguousarray([[e.radius, *e.n, *e.p0] for e in elements], dtype=float)}


@kernel(allocates=True)
def knife_rolling(P, t, tf, xe, ve, le, jac, Psi, A, Psi_t, Dq, H):
    """Ψ = l·ṙ + s_e θ̇, l = (−sin φ, cos φ), φ = θ + β, s_e = (cos β, sin β)·s; P = (β, s (2))."""
    for e in range(xe.shape[0]):
        phi = xe[e, 2] + P[e, 0]
        se = np.cos(P[e, 0]) * P[e, 1] + np.sin(P[e, 0]) * P[e, 2]
        sn, cs = np.sin(phi), np.cos(phi)
        A[e, 0, 0], A[e, 0, 1], A[e, 0, 2] = -sn, cs, se
        Psi[e, 0] = -sn * ve[e, 0] + cs * ve[e, 1] + se * ve[e, 2]
        if jac:
            Dq[e, 0, 2] = -cs * ve[e, 0] - sn * ve[e, 1]
            H[e, 0, 2] = -cs * le[e, 0]
            H[e, 1, 2] = -sn * le[e, 0]


class KnifeEdge(_PlanarOneBody):
    """A planar knife edge (skate; Chaplygin sleigh): a body point moves only along the blade.

    Parameters
    ----------
    name : str
    body : planar body or str
    angle : float
        Blade direction in body axes, β (rad) from the body x axis.
    point : (2,)
        The blade's contact point s in body axes, relative to the node (m).

    Ψ = l·(ṙ + θ̇ ẑ × R s) = 0, l ⟂ blade; −μ is the lateral force of the ground on the blade (N, along l).
    """

    n_velocity_constraints = 1
    velocity_constraint_names = ("lateral",)
    velocity_constraint_units = ("N",)
    kernels = {"velocity_constraint": knife_rolling}

    def __init__(self, name, body, angle=0.0, point=(0.0, 0.0)):
        super().__init__(name, body)
        self.angle = float(angle)
        self.point = np.asarray(point, dtype=float).reshape(2)
        if not (np.isfinite(self.angle) and np.all(np.isfinite(self.point))):
            raise ModelError(f"KnifeEdge '{name}': angle and point must be finite")

    @classmethod
    def pack(cls, elements):
        return {"P": np.ascontiguousarray([[e.angle, *e.point] for e in elements], dtype=float)}


# ---------------------------------------------------------------------------
# a speed drive between two spatial bodies
# ---------------------------------------------------------------------------
@kernel(allocates=True)
def spin_rate(P, t, tf, xe, ve, le, jac, Psi, A, Psi_t, Dq, H):
    """Ψ = e·(ω_b − ω_a) − w₀, e = R_a ē; P = (ē (3), w₀); x = (r_a, p_a, r_b, p_b)."""
    for e in range(xe.shape[0]):
        eb = np.ascontiguousarray(P[e, 0:3])
        Ra = quat_to_matrix(np.ascontiguousarray(xe[e, 3:7]))
        Rb = quat_to_matrix(np.ascontiguousarray(xe[e, 10:14]))
        ew = Ra @ eb
        Rbe = Rb.T @ ew
        Wa = np.ascontiguousarray(ve[e, 3:6])
        Wb = np.ascontiguousarray(ve[e, 9:12])
        Psi[e, 0] = Rbe @ Wb - eb @ Wa - P[e, 3]
        for i in range(3):
            A[e, 0, 3 + i] = -eb[i]
            A[e, 0, 9 + i] = Rbe[i]
        if jac:
            ga = _cross(eb, Ra.T @ (Rb @ Wb))
            gb = _cross(Wb, Rbe)
            Hb = le[e, 0] * _skew(Rbe)
            Ha = -le[e, 0] * (Rb.T @ Ra @ _skew(eb))
            for i in range(3):
                Dq[e, 0, 3 + i] = ga[i]
                Dq[e, 0, 9 + i] = gb[i]
                for j in range(3):
                    H[e, 9 + i, 9 + j] = Hb[i, j]
                    H[e, 9 + i, 3 + j] = Ha[i, j]


class SpinRate(Element):
    """Holds the rotation rate of spatial body b relative to a about an axis of a (a speed drive).

    Ψ = e·(ω_b − ω_a) − w₀ = 0 with e = R_a ē (ē in body-a axes). μ is minus the drive torque on b
    about e (N m). Non-holonomic in form (a velocity constraint); holding a wheel's spin makes the
    forward speed of a rolling vehicle a parameter.

    Parameters
    ----------
    name : str
    a, b : SpatialBody or str
    axis : (3,)
        ē, body-a axes (normalized).
    rate : float
        w₀ (rad/s).
    """

    spatial = True
    n_velocity_constraints = 1
    velocity_constraint_names = ("rate",)
    velocity_constraint_units = ("N·m",)
    kernels = {"velocity_constraint": spin_rate}

    def __init__(self, name, a, b, axis, rate):
        super().__init__(name)
        self.a, self.b = a, b
        self.axis = unit3(f"SpinRate '{name}'", "axis", axis)
        self.rate = float(rate)
        if not np.isfinite(self.rate):
            raise ModelError(f"SpinRate '{name}': rate must be finite, got {rate!r}")

    def resolve(self, lookup):
        for role in ("a", "b"):
            body = lookup(getattr(self, role), role)
            if not isinstance(body, SpatialBody) or isinstance(body, Ground):
                raise ModelError(f"SpinRate '{self.name}': {role} must be a spatial body, got '{body.name}'")
            setattr(self, role, body)

    def nodes(self):
        return [self.a.node, self.b.node]

    @classmethod
    def pack(cls, elements):
        return {"P": np.ascontiguousarray([[*e.axis, e.rate] for e in elements], dtype=float)}
