"""Heavy top as a quaternion ODE integrated tightly with scipy (reference).

Independent of femb's engine (plain numpy/scipy). Data: Brüls & Cardona 2010
(J. Comput. Nonlinear Dynam. 5(3):031002), Brüls, Cardona & Arnold 2012 (Mech.
Mach. Theory 48:121–137), Arnold & Hante 2017; ``docs/spatial.md`` §7.1:

* m = 15 kg, J_C = diag(0.234375, 0.46875, 0.234375) kg m² about the centre
  of mass (body axes), centre of mass at X = (0, 1, 0) (body axes) from the
  fixed point O at the origin; J_O = J_C + m(|X|²I − XXᵀ);
* g = (0, 0, −9.81) m/s²; R0 = I, Ω0 = (0, 150, −4.61538) rad/s (body axes).

State (p, Ω): unit quaternion p (scalar first) and body angular velocity Ω,

    ṗ = ½ p ⊗ (0, Ω),   J_O Ω̇ = −Ω × J_O Ω + X × (Rᵀ m g),

integrated with DOP853 (rtol = atol = 1e-13 by default). Outputs: x_cm = R X,
ẋ_cm = R(Ω × X), ẍ_cm = R(Ω̇ × X + Ω × (Ω × X)), the support reaction (force of
the support on the top, space axes) λ = m(ẍ_cm − g), the energy
E = ½ΩᵀJ_OΩ − m g·x_cm and the spatial angular momentum about O, L = R J_O Ω.
Invariants: Ω_y (J_O is axisymmetric about body y, the axis through O and the
centre of mass), E and L_z.
"""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

M = 15.0
J_C = np.diag([0.234375, 0.46875, 0.234375])
X = np.array([0.0, 1.0, 0.0])
G = np.array([0.0, 0.0, -9.81])
OMEGA0 = np.array([0.0, 150.0, -4.61538])
J_O = J_C + M * (X @ X * np.eye(3) - np.outer(X, X))

#: published consistent initial values and invariants (docs/spatial.md §7.1)
PUBLISHED = {
    "Omega_dot0": (661.34617, 0.0, 0.0),
    "x_cm_ddot0": (0.0, -21.30173, -30.96083),
    "lambda0": (0.0, -319.52599, -317.26246),
    "energy": 5435.696790865547,
    "L_z": -70.3124296875,
}


def _R(p):
    p0, p1, p2, p3 = p
    d = p0 * p0 - (p1 * p1 + p2 * p2 + p3 * p3)
    return np.array([
        [d + 2 * p1 * p1, 2 * (p1 * p2 - p0 * p3), 2 * (p1 * p3 + p0 * p2)],
        [2 * (p1 * p2 + p0 * p3), d + 2 * p2 * p2, 2 * (p2 * p3 - p0 * p1)],
        [2 * (p1 * p3 - p0 * p2), 2 * (p2 * p3 + p0 * p1), d + 2 * p3 * p3]])


def omega_dot(p, W, m=M, J=J_O, X=X, g=G):
    """Ω̇ from Euler's equations about the fixed point."""
    R = _R(p)
    rhs = -np.cross(W, J @ W) + np.cross(X, R.T @ (m * g))
    return np.linalg.solve(J, rhs)


def rhs(t, y):
    p, W = y[:4], y[4:]
    pd = 0.5 * np.array([-p[1] * W[0] - p[2] * W[1] - p[3] * W[2],
                         p[0] * W[0] + p[2] * W[2] - p[3] * W[1],
                         p[0] * W[1] + p[3] * W[0] - p[1] * W[2],
                         p[0] * W[2] + p[1] * W[1] - p[2] * W[0]])
    return np.concatenate((pd, omega_dot(p, W)))


def outputs_at(p, W):
    """Named outputs for one state (p, Ω)."""
    p = np.asarray(p) / np.linalg.norm(p)
    R = _R(p)
    Wd = omega_dot(p, W)
    x = R @ X
    xd = R @ np.cross(W, X)
    xdd = R @ (np.cross(Wd, X) + np.cross(W, np.cross(W, X)))
    lam = M * (xdd - G)
    L = R @ (J_O @ W)
    E = 0.5 * W @ J_O @ W - M * G @ x
    return {"x_cm": x[0], "y_cm": x[1], "z_cm": x[2], "vx_cm": xd[0], "vy_cm": xd[1], "vz_cm": xd[2],
            "omega_x": W[0], "omega_y": W[1], "omega_z": W[2],
            "omega_dot_x": Wd[0], "omega_dot_y": Wd[1], "omega_dot_z": Wd[2],
            "lambda_x": lam[0], "lambda_y": lam[1], "lambda_z": lam[2],
            "energy": E, "L_z": L[2], "p0": p[0], "p1": p[1], "p2": p[2], "p3": p[3]}


def solve(t_end=2.0, t_eval=None, rtol=1e-13, atol=1e-13, omega0=OMEGA0):
    """Integrate the heavy top; returns (t (nt,), dict of output arrays (nt,))."""
    y0 = np.concatenate(([1.0, 0.0, 0.0, 0.0], np.asarray(omega0, dtype=float)))
    if t_eval is None:
        t_eval = np.linspace(0.0, t_end, 201)
    sol = solve_ivp(rhs, (0.0, t_end), y0, method="DOP853", t_eval=t_eval, rtol=rtol, atol=atol)
    if not sol.success:
        raise RuntimeError(f"heavy-top reference failed: {sol.message}")
    rows = [outputs_at(sol.y[:4, k], sol.y[4:, k]) for k in range(sol.t.size)]
    return sol.t, {key: np.array([r[key] for r in rows]) for key in rows[0]}


def rotation(p):
    """Rotation matrix of a quaternion (scalar first), for comparisons."""
    return _R(np.asarray(p) / np.linalg.norm(p))
