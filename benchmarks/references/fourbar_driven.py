"""Four-bar linkage with a prescribed crank angle: exact kinematics and Newton–Euler forces (reference).

Independent reference for :mod:`femb.benchmarks.scenes.planar.fourbar_driven`; plain numpy,
no code shared with femb's engine.

Model
-----
Ground pivots O = (0, 0) and C = (l4, 0); crank O → A (length l1, angle θ1),
coupler A → B (l2, θ2), rocker C → B (l3, θ3); uniform bars, centres at mid
length, J_k = m_k l_k²/12; gravity (0, −g). The crank angle is prescribed,
θ1(t) = θ1(0) + ω t, so the linkage has no degree of freedom left: the motion
is pure kinematics, solved here in closed form (no time integration needed):

* position: B is the intersection of the circles |B − A| = l2 and
  the distance from B to C equals l3, on the side given at t = 0 (left of A → C);
* velocity and acceleration: the loop closure
  l1 e1 + l2 e2 − l3 e3 − (l4, 0) = 0 differentiated once and twice, two
  linear 2 × 2 solves for (θ̇2, θ̇3) and (θ̈2, θ̈3).

Forces (Newton–Euler, nine equations for nine unknowns at every time): with
R_O the force of the ground on the crank, R_A of the crank on the coupler,
R_B of the coupler on the rocker, R_C of the ground on the rocker and τ the
driving torque on the crank,

    crank:    m1 a1 = R_O − R_A + m1 g,   J1 α1 = τ + (O − c1) × R_O − (A − c1) × R_A
    coupler:  m2 a2 = R_A − R_B + m2 g,   J2 α2 = (A − c2) × R_A − (B − c2) × R_B
    rocker:   m3 a3 = R_B + R_C + m3 g,   J3 α3 = (B − c3) × R_B + (C − c3) × R_C
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["PARAMS", "solve"]

#: Data (SI): lengths, masses, gravity, initial crank angle and the constant crank rate.
PARAMS = {"l1": 0.4, "l2": 1.0, "l3": 0.8, "l4": 0.9, "m1": 1.0, "m2": 2.0, "m3": 1.5, "g": 9.81,
          "theta1": math.radians(70.0), "omega": 3.0}


def _e(th):
    return np.array([math.cos(th), math.sin(th)])


def _n(th):
    return np.array([-math.sin(th), math.cos(th)])


def _cross(u, v):
    return u[0] * v[1] - u[1] * v[0]


def _position(th1, p):
    A = p["l1"] * _e(th1)
    C = np.array([p["l4"], 0.0])
    d = float(np.linalg.norm(C - A))
    a = (p["l2"] ** 2 - p["l3"] ** 2 + d * d) / (2.0 * d)
    h2 = p["l2"] ** 2 - a * a
    if h2 <= 0.0:
        raise ValueError(f"four-bar cannot close at crank angle {th1!r} rad")
    u = (C - A) / d
    B = A + a * u + math.sqrt(h2) * np.array([-u[1], u[0]])
    return A, B, C


def state(t, **overrides):
    """Angles, rates, accelerations, body accelerations and forces at one time t (dict)."""
    p = dict(PARAMS, **overrides)
    l1, l2, l3 = p["l1"], p["l2"], p["l3"]
    th1 = p["theta1"] + p["omega"] * t
    w1, al1 = p["omega"], 0.0
    A, B, C = _position(th1, p)
    th2 = math.atan2(B[1] - A[1], B[0] - A[0])
    th3 = math.atan2(B[1] - C[1], B[0] - C[0])
    K = np.column_stack((l2 * _n(th2), -l3 * _n(th3)))
    w2, w3 = np.linalg.solve(K, -l1 * w1 * _n(th1))
    rhs = -(l1 * (al1 * _n(th1) - w1 ** 2 * _e(th1)) - l2 * w2 ** 2 * _e(th2) + l3 * w3 ** 2 * _e(th3))
    al2, al3 = np.linalg.solve(K, rhs)
    # centres and their accelerations
    c1, c2, c3 = 0.5 * A, 0.5 * (A + B), 0.5 * (C + B)
    aA = l1 * (al1 * _n(th1) - w1 ** 2 * _e(th1))
    a1 = 0.5 * aA
    a2 = aA + 0.5 * l2 * (al2 * _n(th2) - w2 ** 2 * _e(th2))
    a3 = 0.5 * l3 * (al3 * _n(th3) - w3 ** 2 * _e(th3))
    m = (p["m1"], p["m2"], p["m3"])
    J = tuple(mk * lk ** 2 / 12.0 for mk, lk in zip(m, (l1, l2, l3)))
    g = np.array([0.0, -p["g"]])
    O = np.zeros(2)
    # unknowns x = [R_O (2), R_A (2), R_B (2), R_C (2), tau]
    E = np.zeros((9, 9))
    b = np.zeros(9)
    I2 = np.eye(2)

    def cr(d):       # row of d × R in R's two components
        return np.array([-d[1], d[0]])

    E[0:2, 0:2], E[0:2, 2:4] = I2, -I2
    b[0:2] = m[0] * a1 - m[0] * g
    E[2, 0:2], E[2, 2:4], E[2, 8] = cr(O - c1), -cr(A - c1), 1.0
    b[2] = J[0] * al1
    E[3:5, 2:4], E[3:5, 4:6] = I2, -I2
    b[3:5] = m[1] * a2 - m[1] * g
    E[5, 2:4], E[5, 4:6] = cr(A - c2), -cr(B - c2)
    b[5] = J[1] * al2
    E[6:8, 4:6], E[6:8, 6:8] = I2, I2
    b[6:8] = m[2] * a3 - m[2] * g
    E[8, 4:6], E[8, 6:8] = cr(B - c3), cr(C - c3)
    b[8] = J[2] * al3
    x = np.linalg.solve(E, b)
    return {"theta": np.array([th1, th2, th3]), "omega": np.array([w1, w2, w3]),
            "alpha": np.array([al1, al2, al3]), "centres": np.array([c1, c2, c3]),
            "acc": np.array([a1, a2, a3]), "R_O": x[0:2], "R_A": x[2:4], "R_B": x[4:6], "R_C": x[6:8],
            "tau": x[8], "params": p}


def solve(t_eval, **overrides):
    """The reference at times ``t_eval`` (s).

    Returns
    -------
    dict
        ``theta``, ``omega``, ``alpha`` (nt, 3): angles from the x axis of
        crank, coupler, rocker and their derivatives; ``R_O``, ``R_A``,
        ``R_B``, ``R_C`` (nt, 2) (see the module docstring); ``tau`` (nt,):
        driving torque on the crank (N m).
    """
    sts = [state(float(t), **overrides) for t in np.atleast_1d(np.asarray(t_eval, dtype=float))]
    return {k: np.array([s[k] for s in sts]) for k in ("theta", "omega", "alpha", "R_O", "R_A", "R_B", "R_C", "tau")}
