"""Open planar chains of rigid links in minimal coordinates (reference).

Independent reference model for femb's pendulum-type scenes (double pendulum,
two-bar pendulum, spring pendulum, force pulse, bead on a circle). It uses
plain numpy/scipy only and shares no code with femb's engine.

Model
-----
Links k = 0 … n−1 form an open chain hinged to the ground at the origin.
Link k has mass ``m[k]``, centroidal inertia ``J[k]`` (0 for a point mass),
length ``l[k]`` (pivot to the next pivot) and its centre of mass at the
distance ``c[k]`` from its own pivot along the link. The minimal coordinates
are the absolute link angles φ_k measured from the x axis, e_k = (cos φ_k,
sin φ_k), e⊥_k = (−sin φ_k, cos φ_k). The centre of mass of link k is

    r_k = Σ_{j<k} l_j e_j + c_k e_k = Σ_j L_kj e_j,

so ṙ_k = Σ_j L_kj φ̇_j e⊥_j and r̈_k = Σ_j L_kj (φ̈_j e⊥_j − φ̇_j² e_j).
Lagrange's equations (virtual work of the external forces F_k at the
centres of mass and torques τ_k on the links, ∂r_k/∂φ_i = L_ki e⊥_i) read

    Σ_j [B_ij cos(φ_i − φ_j) + J_i δ_ij] φ̈_j
        = −Σ_j B_ij sin(φ_i − φ_j) φ̇_j² + Σ_k L_ki e⊥_i·F_k + τ_i,

    B_ij = Σ_k m_k L_ki L_kj,

with gravity included in F_k = m_k g + (user loads). They are integrated by
:func:`scipy.integrate.solve_ivp` (DOP853).

Reactions (Newton–Euler)
------------------------
Cutting the chain at pivot i, the force of link i−1 (the ground for i = 0)
on link i is

    R_i = Σ_{k≥i} (m_k r̈_k − F_k),

evaluated at the exact state (accelerations from the equations of motion).
"""
from __future__ import annotations

import numpy as np

__all__ = ["Chain", "solve"]


class Chain:
    """Data of an open chain (see the module docstring).

    Parameters
    ----------
    m, J, l, c : array_like, shape (n,)
        Masses (kg), centroidal inertias (kg m²), link lengths (m), distances
        pivot → centre of mass (m).
    g : (gx, gy)
        Gravity (m/s²).
    loads : callable(t, phi, phid) -> (F, tau), optional
        Extra forces at the centres of mass, F of shape (n, 2) (N), and
        torques on the links, tau of shape (n,) (N m).
    """

    def __init__(self, m, J, l, c, g=(0.0, -9.81), loads=None):
        self.m = np.asarray(m, dtype=float)
        self.J = np.asarray(J, dtype=float)
        self.l = np.asarray(l, dtype=float)
        self.c = np.asarray(c, dtype=float)
        self.n = self.m.size
        self.g = np.asarray(g, dtype=float)
        self.loads = loads
        n = self.n
        L = np.zeros((n, n))
        for k in range(n):
            L[k, :k] = self.l[:k]
            L[k, k] = self.c[k]
        self.L = L
        #: B_ij = Σ_k m_k L_ki L_kj
        self.B = np.einsum("k,ki,kj->ij", self.m, L, L)

    def external(self, t, phi, phid):
        """Forces at the centres of mass (n, 2), gravity included, and link torques (n,)."""
        F = self.m[:, None] * self.g[None, :]
        tau = np.zeros(self.n)
        if self.loads is not None:
            Fe, te = self.loads(t, phi, phid)
            F = F + np.asarray(Fe, dtype=float)
            tau = tau + np.asarray(te, dtype=float)
        return F, tau

    def positions(self, phi):
        """Centres of mass r_k, shape (n, 2), and pivot positions p_k, shape (n + 1, 2)."""
        e = np.stack((np.cos(phi), np.sin(phi)), axis=1)
        r = self.L @ e
        p = np.vstack((np.zeros(2), np.cumsum(self.l[:, None] * e, axis=0)))
        return r, p

    def accelerations(self, t, phi, phid):
        """φ̈ (n,) from Lagrange's equations."""
        d = phi[:, None] - phi[None, :]
        M = self.B * np.cos(d) + np.diag(self.J)
        # Σ_k m_k (∂r_k/∂φ_i)·(−Σ_j L_kj φ̇_j² e_j) = −Σ_j B_ij φ̇_j² e⊥_i·e_j = −Σ_j B_ij φ̇_j² sin(φ_j − φ_i)
        quad = -(self.B * np.sin(-d)) @ (phid ** 2)
        F, tau = self.external(t, phi, phid)
        eperp = np.stack((-np.sin(phi), np.cos(phi)), axis=1)
        Q = np.einsum("ki,kx,ix->i", self.L, F, eperp) + tau
        return np.linalg.solve(M, Q - quad)

    def state_outputs(self, t, phi, phid):
        """Centres of mass, their velocities and accelerations, and pivot reactions at one time."""
        phidd = self.accelerations(t, phi, phid)
        e = np.stack((np.cos(phi), np.sin(phi)), axis=1)
        ep = np.stack((-np.sin(phi), np.cos(phi)), axis=1)
        r = self.L @ e
        v = self.L @ (phid[:, None] * ep)
        a = self.L @ (phidd[:, None] * ep - (phid ** 2)[:, None] * e)
        F, _ = self.external(t, phi, phid)
        net = self.m[:, None] * a - F
        R = np.cumsum(net[::-1], axis=0)[::-1]     # R_i = Σ_{k≥i} (m_k a_k − F_k)
        return {"phidd": phidd, "r": r, "v": v, "a": a, "R": R}

    def outputs(self, t, phi, phid):
        """:meth:`state_outputs` at every time at once.

        The same formulas over a leading time axis (one batched linear solve for φ̈); only
        ``loads`` is called once per time. A Python loop over :meth:`state_outputs` was most of
        the time of a reference sampled at the 10⁴ steps of a fine run.

        Parameters
        ----------
        t : ndarray, shape (nt,)
        phi, phid : ndarray, shape (nt, n)

        Returns
        -------
        dict
            ``phidd`` (nt, n); ``r``, ``v``, ``a``, ``R`` (nt, n, 2).
        """
        nt, n = phi.shape
        if self.loads is None:
            F = np.broadcast_to(self.m[:, None] * self.g[None, :], (nt, n, 2))
            tau = np.zeros((nt, n))
        else:
            F, tau = np.empty((nt, n, 2)), np.empty((nt, n))
            for i in range(nt):
                F[i], tau[i] = self.external(t[i], phi[i], phid[i])
        d = phi[:, :, None] - phi[:, None, :]
        M = self.B * np.cos(d) + np.diag(self.J)
        quad = -np.einsum("tij,tj->ti", self.B * np.sin(-d), phid ** 2)
        e = np.stack((np.cos(phi), np.sin(phi)), axis=-1)
        ep = np.stack((-np.sin(phi), np.cos(phi)), axis=-1)
        Q = np.einsum("ki,tkx,tix->ti", self.L, F, ep) + tau
        phidd = np.linalg.solve(M, (Q - quad)[..., None])[..., 0]
        r = np.einsum("kj,tjx->tkx", self.L, e)
        v = np.einsum("kj,tjx->tkx", self.L, phid[..., None] * ep)
        a = np.einsum("kj,tjx->tkx", self.L, phidd[..., None] * ep - (phid ** 2)[..., None] * e)
        net = self.m[None, :, None] * a - F
        R = np.cumsum(net[:, ::-1], axis=1)[:, ::-1]     # R_i = Σ_{k≥i} (m_k a_k − F_k)
        return {"phidd": phidd, "r": r, "v": v, "a": a, "R": R}


def solve(chain, t_eval, phi0, phid0, rtol=1e-12, atol=1e-12, method="DOP853", fine=None, key=None):
    """Integrate the chain and evaluate its outputs at ``t_eval``.

    Parameters
    ----------
    chain : Chain
    t_eval : array_like, shape (nt,)
        Increasing output times from 0 (s).
    phi0, phid0 : array_like, shape (n,)
        Initial absolute angles (rad, from the x axis) and rates (rad/s).
    rtol, atol : float
        Tolerances of :func:`scipy.integrate.solve_ivp`.
    method : str
    fine : (t_a, t_b, max_step), optional
        A window with a cap on the integrator's step (s), for short loads
        (pulses): the run is split at t_a and t_b so no step crosses them.
    key : hashable, optional
        What ``chain.loads`` depends on (the scene's name and parameters; the
        chain's masses, lengths, gravity and the initial state are added):
        the integration is then done once per process and evaluated at later
        ``t_eval`` (:func:`femb.benchmarks.references.dense.integrate`).

    Returns
    -------
    dict
        ``t`` (nt,), ``phi``, ``phid``, ``phidd`` (nt, n), ``r``, ``v``, ``a``
        (nt, n, 2): centres of mass, ``R`` (nt, n, 2): force of link i−1 (the
        ground for i = 0) on link i at pivot i, ``nfev``.

    Raises
    ------
    ValueError
        If ``t_eval`` is not increasing from t >= 0.
    RuntimeError
        If the integrator fails.
    """
    from femb.benchmarks.references.dense import integrate

    t_eval = np.atleast_1d(np.asarray(t_eval, dtype=float))
    n = chain.n
    y0 = np.concatenate((np.asarray(phi0, dtype=float), np.asarray(phid0, dtype=float)))

    def rhs(t, y):
        return np.concatenate((y[n:], chain.accelerations(t, y[:n], y[n:])))

    if key is not None:
        key = ("planar_chain", key, y0.tobytes()) + tuple(a.tobytes() for a in (chain.m, chain.J, chain.l, chain.c,
                                                                                 chain.g))
    Y, nfev = integrate(rhs, y0, t_eval, key=key, fine=fine, rtol=rtol, atol=atol, method=method)
    out = {"t": t_eval, "phi": Y[:, :n], "phid": Y[:, n:], "nfev": nfev}
    out.update(chain.outputs(t_eval, Y[:, :n], Y[:, n:]))
    return out
