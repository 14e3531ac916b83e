"""Spatial double pendulum with revolute joints on skew axes, in relative coordinates (reference).

Independent of femb's engine: two rigid links, joint 1 between the ground and
link 1 at O about the skew axis n1, joint 2 between link 1 and link 2 at A about
n2 (fixed in link 1; n1, n2, O, A given in space at t0). Generalized coordinates:
the two joint angles θ = (θ1, θ2), zero at t0. With E_i = exp(θ_i n_i~):

    R1 = E1 R1₀,  c1 = O + E1 (c1₀ − O),
    R2 = E1 E2 R2₀,  c2 = O + E1 ((A − O) + E2 (c2₀ − A)),

and Kane's equations of :mod:`.kane` (exact derivatives by hyper-dual numbers),
integrated with DOP853 (rtol = atol = 1e-12 by default). Joint reaction forces
from Newton's law on each link: the force of joint 2 on link 2 is
F2 = m2 (c̈2 − g), the force of joint 1 on link 1 is F1 = m1 (c̈1 − g) + F2
(space axes, N) — femb's revolute λ[0:3] with a = ground / link 1, b = link 1 /
link 2. Data: this project's own (``DATA``).
"""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from . import kane
from .kane import RigidSystem, matmul, rodrigues


def _frame_along(d, up=(0.0, 0.0, 1.0)):
    """Rotation whose body x is along d (body z as close to ``up`` as possible)."""
    x = np.asarray(d, float) / np.linalg.norm(d)
    z = np.asarray(up, float) - (np.asarray(up, float) @ x) * x
    z /= np.linalg.norm(z)
    return np.column_stack((x, np.cross(z, x), z))


def _box(m, a, b, c):
    return np.diag([m * (b * b + c * c), m * (a * a + c * c), m * (a * a + b * b)]) / 12.0


#: the project's own data (SI units)
DATA = dict(
    O=np.array([0.0, 0.0, 0.0]),
    A=np.array([0.15, 0.45, -0.35]),
    E=np.array([0.55, 0.55, -0.6]),          # far end of link 2 (drawing only)
    n1=np.array([1.0, 0.3, 0.4]) / np.linalg.norm([1.0, 0.3, 0.4]),
    n2=np.array([0.2, -0.5, 1.0]) / np.linalg.norm([0.2, -0.5, 1.0]),
    m1=1.2, m2=0.8,
    offset1=np.array([0.02, 0.0, 0.03]),     # centre of mass off the link line (space, t0)
    g=np.array([0.0, 0.0, -9.81]),
    theta_d0=np.array([1.5, -2.0]),
)


def bodies(D=DATA):
    """Initial centres c1₀, c2₀, rotations R1₀, R2₀ and inertias J1, J2 (body axes, about the CoM)."""
    L1 = np.linalg.norm(D["A"] - D["O"])
    L2 = np.linalg.norm(D["E"] - D["A"])
    c10 = 0.5 * (D["O"] + D["A"]) + D["offset1"]
    c20 = 0.5 * (D["A"] + D["E"])
    R10 = _frame_along(D["A"] - D["O"])
    R20 = _frame_along(D["E"] - D["A"])
    J1 = _box(D["m1"], L1, 0.05, 0.03)
    J2 = _box(D["m2"], L2, 0.04, 0.04)
    return c10, c20, R10, R20, J1, J2


def system(D=DATA):
    c10, c20, R10, R20, J1, J2 = bodies(D)
    O, A = D["O"], D["A"]

    def kin(q):
        E1 = rodrigues(D["n1"], q[0])
        E2 = rodrigues(D["n2"], q[1])
        c1 = O + matmul(E1, c10 - O)
        R1 = matmul(E1, R10)
        c2 = O + matmul(E1, (A - O) + matmul(E2, c20 - A))
        R2 = matmul(E1, matmul(E2, R20))
        return [(c1, R1), (c2, R2)]

    return RigidSystem(kin, [D["m1"], D["m2"]], [J1, J2], D["g"])


def initial_velocities(D=DATA):
    """Consistent initial (ċ1, ω1, ċ2, ω2) (space axes) for θ̇0 = D['theta_d0']."""
    c10, c20, *_ = bodies(D)
    w1 = D["theta_d0"][0] * D["n1"]
    w2 = w1 + D["theta_d0"][1] * D["n2"]
    v1 = np.cross(w1, c10 - D["O"])
    v2 = np.cross(w1, D["A"] - D["O"]) + np.cross(w2, c20 - D["A"])
    return v1, w1, v2, w2


def outputs_at(sys_, q, u, D=DATA):
    ud, s = sys_.accelerations(q, u)
    out = {"theta1": q[0], "theta2": q[1], "theta1_d": u[0], "theta2_d": u[1]}
    acc = [s["Jc"][k] @ ud + s["acc_c"][k] for k in range(2)]
    F2 = D["m2"] * (acc[1] - D["g"])
    F1 = D["m1"] * (acc[0] - D["g"]) + F2
    for k in range(2):
        for i, ax in enumerate("xyz"):
            out[f"x{k + 1}_{ax}"] = s["c"][k][i]
            out[f"omega{k + 1}_{ax}"] = s["omega"][k][i]                      # space axes
            out[f"Omega{k + 1}_{ax}"] = (s["R"][k].T @ s["omega"][k])[i]       # body axes
    for i, ax in enumerate("xyz"):
        out[f"F1_{ax}"] = F1[i]
        out[f"F2_{ax}"] = F2[i]
    out["energy"] = 0.5 * u @ s["M"] @ u - sum(m * D["g"] @ s["c"][k] for k, m in enumerate((D["m1"], D["m2"])))
    return out


def solve(t_end=2.0, t_eval=None, rtol=1e-12, atol=1e-12, D=DATA):
    """Integrate; returns (t, dict of output arrays)."""
    sys_ = system(D)
    if t_eval is None:
        t_eval = np.linspace(0.0, t_end, 101)
    y0 = np.concatenate(([0.0, 0.0], D["theta_d0"]))
    sol = solve_ivp(sys_.rhs, (0.0, t_end), y0, method="DOP853", t_eval=t_eval, rtol=rtol, atol=atol)
    if not sol.success:
        raise RuntimeError(f"double-pendulum reference failed: {sol.message}")
    rows = [outputs_at(sys_, sol.y[:2, k], sol.y[2:, k], D) for k in range(sol.t.size)]
    return sol.t, {key: np.array([r[key] for r in rows]) for key in rows[0]}


__all__ = ["DATA", "bodies", "system", "initial_velocities", "outputs_at", "solve", "kane"]
