"""Interpolation between accepted steps (dense output for t_eval and VTK frames)."""
from __future__ import annotations

import numpy as np


def hermite(t0, t1, y0, y1, d0, d1, t):
    """Cubic Hermite interpolant of (y, y') between t0 and t1, evaluated at t."""
    h = t1 - t0
    s = (t - t0) / h
    h00 = (1 + 2 * s) * (1 - s) ** 2
    h10 = s * (1 - s) ** 2
    h01 = s * s * (3 - 2 * s)
    h11 = s * s * (s - 1)
    return h00 * y0 + h10 * h * d0 + h01 * y1 + h11 * h * d1


def configuration_between(model, t0, t1, q0, q1, v0, v1, t):
    """q at t between two accepted configurations (cubic Hermite; on the group for rotations).

    Without rotation nodes: the cubic Hermite interpolant of (q, q̇). With them
    (``model.lie``): the increment d with q1 = q0 ∘ exp(d) is interpolated in
    the tangent space, y(t0) = 0, y(t1) = d, y'(t0) = v0, y'(t1) = T(d_θ)⁻¹ v1
    on rotation entries (the derivative of the rotation vector whose
    exponential follows the body angular velocity Ω1; Brüls & Cardona 2010,
    dexp), and q(t) = q0 ∘ exp(y(t)).
    """
    if model is None or not getattr(model, "lie", False):
        return hermite(t0, t1, q0, q1, v0, v1, t)
    from femb.base import rotations as rt
    d = model.difference(q1, q0)
    d1 = np.array(v1, dtype=float)
    for _, vs in model.rot_blocks:
        d1[vs:vs + 3] = rt.tangent_inv.py_func(np.ascontiguousarray(d[vs:vs + 3])) @ v1[vs:vs + 3]
    y = hermite(t0, t1, np.zeros_like(d), d, v0, d1, t)
    return model.compose(q0, y)


def state_between(s0, s1, t, model=None):
    """(q, q̇, q̈, λ) at t between two accepted states (objects with t, q, qd, qdd, lam).

    q is cubic Hermite from q and q̇ (:func:`configuration_between`, on the
    group for rotation nodes of ``model``), q̇ cubic Hermite from q̇ and q̈,
    q̈ and λ are linear: each is accurate to the order the scheme delivers.
    """
    if t1_equal(s0.t, s1.t):
        return s1.q.copy(), s1.qd.copy(), s1.qdd.copy(), s1.lam.copy()
    q = configuration_between(model, s0.t, s1.t, s0.q, s1.q, s0.qd, s1.qd, t)
    qd = hermite(s0.t, s1.t, s0.qd, s1.qd, s0.qdd, s1.qdd, t)
    w = (t - s0.t) / (s1.t - s0.t)
    return q, qd, (1 - w) * s0.qdd + w * s1.qdd, (1 - w) * s0.lam + w * s1.lam


def t1_equal(a, b):
    return not (b > a or b < a)


def interpolate_rows(T, Q, QD, QDD, L, t_eval, model=None):
    """Arrays (q, q̇, q̈, λ) at t_eval from stored steps T (sorted); ``model`` for rotation nodes."""
    idx = np.clip(np.searchsorted(T, t_eval, side="right") - 1, 0, max(len(T) - 2, 0))
    out_q = np.empty((t_eval.size, Q.shape[1]))
    out_qd = np.empty((t_eval.size, QD.shape[1]))
    out_qdd = np.empty_like(out_qd)
    out_l = np.empty((t_eval.size, L.shape[1]))
    for n, (t, i) in enumerate(zip(t_eval, idx)):
        if len(T) == 1:
            out_q[n], out_qd[n], out_qdd[n], out_l[n] = Q[0], QD[0], QDD[0], L[0]
            continue
        t0, t1 = T[i], T[i + 1]
        out_q[n] = configuration_between(model, t0, t1, Q[i], Q[i + 1], QD[i], QD[i + 1], t)
        out_qd[n] = hermite(t0, t1, QD[i], QD[i + 1], QDD[i], QDD[i + 1], t)
        w = (t - t0) / (t1 - t0)
        out_qdd[n] = (1 - w) * QDD[i] + w * QDD[i + 1]
        out_l[n] = (1 - w) * L[i] + w * L[i + 1]
    return out_q, out_qd, out_qdd, out_l
