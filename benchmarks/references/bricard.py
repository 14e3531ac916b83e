"""Bricard mechanism (MBS benchmark A04) in joint coordinates with a redundant closure (reference).

Independent of femb's engine. Data (González et al. 2006, Multibody Syst. Dyn.
16:179–190, benchmark A04; ``docs/spatial.md`` §7.3): five rods of 1 m, 1 kg,
square section 0.1 m (homogeneous cuboids, centre of mass mid-length), six
revolute joints at P1 … P6 = (0,0,0), (1,0,0), (1,−1,0), (1,−1,1), (0,−1,1),
(0,0,1) with axes y, z, x, y, z, x; rod k runs from P_k to P_{k+1}; joints 1 and 6
connect rods 1 and 5 to the ground; gravity (0, −9.81, 0); start from rest (as
jgerstmayr/EXUDYN:main/pythonDev/TestModels/bricardMechanism.py).

Coordinates: the angles θ1 … θ5 of joints 1 … 5 (open chain from the ground,
zero at t0); each joint turns everything beyond it about its axis through its
point. Joint 6 is the closure Φ(θ) = 0: the end of rod 5 stays at P6 (3 rows)
and rod 5's material x axis stays along x (2 rows: its y and z components).
These 5 rows have rank 4 (Bricard's loop has one redundant condition, so the
mechanism moves with 1 degree of freedom although Grübler counts 0); the
equations [M Gᵀ; G 0][θ̈; μ] = [Q − h; −Ġθ̇] are solved by least squares
(:mod:`.kane`; θ̈ is unique), integrated with DOP853.
"""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from .kane import RigidSystem, matmul, rodrigues

L = 1.0
WIDTH = 0.1
MASS = 1.0
POINTS = np.array([[0, 0, 0], [1, 0, 0], [1, -1, 0], [1, -1, 1], [0, -1, 1], [0, 0, 1]], dtype=float) * L
AXES = np.array([[0, 1, 0], [0, 0, 1], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 0, 0]], dtype=float)
G = np.array([0.0, -9.81, 0.0])
J_ROD = np.diag([MASS * 2 * WIDTH ** 2, MASS * (L ** 2 + WIDTH ** 2), MASS * (L ** 2 + WIDTH ** 2)]) / 12.0


def rod_rotation0(k):
    """Initial rotation of rod k (0-based): body x along P_k → P_{k+1}."""
    x = POINTS[k + 1] - POINTS[k]
    x /= np.linalg.norm(x)
    # body y: a joint axis of the rod that is perpendicular to x (the rod's first joint axis)
    y = AXES[k] if abs(AXES[k] @ x) < 0.5 else AXES[k + 1]
    return np.column_stack((x, y, np.cross(x, y)))


def _chain(q):
    """Cumulative rigid motions (E, t) of the open chain: x ↦ E x + t for rods 1 … 5."""
    out = []
    E = np.eye(3, dtype=object)
    t = np.zeros(3, dtype=object)
    for k in range(5):
        Ek = rodrigues(AXES[k], q[k])
        # compose (E, t) ∘ (x ↦ P + Ek (x − P))
        P = POINTS[k]
        tk = P - matmul(Ek, P)
        t = t + matmul(E, tk)
        E = matmul(E, Ek)
        out.append((E, t))
    return out


def system():
    R0 = [rod_rotation0(k) for k in range(5)]
    c0 = [POINTS[k] + 0.5 * (POINTS[k + 1] - POINTS[k]) for k in range(5)]

    last = [None, None]     # (q, its chain): kin and closure of the same hyper-dual q share one chain

    def chain(q):
        if last[0] is not q:
            last[:] = [q, _chain(q)]
        return last[1]

    def kin(q):
        return [(matmul(E, c0[k]) + t, matmul(E, R0[k])) for k, (E, t) in enumerate(chain(q))]

    def closure(q):
        E, t = chain(q)[4]
        end = matmul(E, POINTS[5]) + t - POINTS[5]
        ax = matmul(E, AXES[5])
        return np.array([end[0], end[1], end[2], ax[1], ax[2]], dtype=object)

    return RigidSystem(kin, [MASS] * 5, [J_ROD] * 5, G, closure=closure)


def outputs_at(sys_, q, u):
    ud, s = sys_.accelerations(q, u)
    E, t = (np.array([[x for x in row] for row in M], dtype=float) if M.ndim == 2 else M.astype(float)
            for M in _chain(np.asarray(q, dtype=float))[1])
    P3 = E @ POINTS[2] + t
    out = {f"theta{k + 1}": q[k] for k in range(5)}
    out.update({"P3_x": P3[0], "P3_y": P3[1], "P3_z": P3[2],
                "energy": 0.5 * u @ s["M"] @ u - sum(MASS * G @ c for c in s["c"]),
                "closure": float(np.abs(s["Phi"]).max()),
                "closure_rank": int(np.linalg.matrix_rank(s["G"], tol=1e-9))})
    return out


def solve(t_end=10.0, t_eval=None, rtol=1e-12, atol=1e-12):
    """Integrate from rest; returns (t, dict of output arrays)."""
    sys_ = system()
    if t_eval is None:
        t_eval = np.linspace(0.0, t_end, 101)
    sol = solve_ivp(sys_.rhs, (0.0, t_end), np.zeros(10), method="DOP853", t_eval=t_eval, rtol=rtol, atol=atol)
    if not sol.success:
        raise RuntimeError(f"Bricard reference failed: {sol.message}")
    rows = [outputs_at(sys_, sol.y[:5, k], sol.y[5:, k]) for k in range(sol.t.size)]
    return sol.t, {key: np.array([r[key] for r in rows]) for key in rows[0]}
