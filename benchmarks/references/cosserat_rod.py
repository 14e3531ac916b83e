"""Static Cosserat (Simo–Reissner) rod under dead end loads, solved by shooting (reference).

Independent of femb's elements and solvers (plain numpy/scipy): the continuum equations of
a shear- and extension-deformable rod with a uniform section and constant initial strains,
clamped at s = 0 and loaded at s = L by a dead force F and a dead moment M (space axes),
no distributed load. With n(s) the force and m(s) the moment that the part beyond s
exerts on the part before it (space axes),

    n(s) = F,            m′ = −x′ × F,          m(L) = M,
    x′ = R Γ,            R′ = R κ̂,
    (Γ − Γ₀, κ − κ₀) = C⁻¹ (Rᵀ n, Rᵀ m)         (C the 6 × 6 section stiffness, section axes),

(J. C. Simo, A finite strain beam formulation. The three-dimensional dynamic problem.
Part I, Comput. Methods Appl. Mech. Eng. 49:55–70, 1985, eqs. (2.11), (3.6)–(3.8); Γ₀ = e₁
for a stress-free rod whose axis is its section's first axis). The unknown m(0) is found by
shooting: the initial-value problem from the clamp is integrated with DOP853 at
rtol = atol = 1e-13 and ``scipy.optimize.root`` makes m(L) = M, the load raised in
``load_steps`` equal steps from the unloaded rod (each solution the next one's guess).
"""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import root


def _hat(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def clamped_rod(C, length, R0, kappa0, F, M=(0.0, 0.0, 0.0), x0=(0.0, 0.0, 0.0), load_steps=12,
                rtol=1e-13):
    """Equilibrium of a clamped rod under a dead end force F and moment M.

    Parameters
    ----------
    C : (6, 6) array_like
        Section stiffness for (Γ − Γ₀, κ − κ₀) in section axes (as ``SpatialSection.C``).
    length : float
        Arc length L of the rod's axis.
    R0 : (3, 3) array_like
        Section frame at the clamp (columns: axis 1 along the rod, axes 2, 3), space axes.
    kappa0 : (3,) array_like
        Constant initial curvature κ₀ (section axes): a straight rod 0, a circular arc of
        radius ρ bending towards −axis 2 about axis 3: (0, 0, −1/ρ).
    F, M : (3,) array_like
        Dead force and moment at s = L (space axes).
    x0 : (3,) array_like
        Position of the clamp.
    load_steps : int
        Equal load increments from the unloaded rod.
    rtol : float
        Tolerance of the integration (relative and absolute).

    Returns
    -------
    dict
        ``x`` (3,) end position, ``R`` (3, 3) end section frame, ``m0`` (3,) clamp moment,
        ``residual`` max |m(L) − M|.
    """
    C = np.asarray(C, dtype=float)
    Cinv = np.linalg.inv(C)
    R0 = np.asarray(R0, dtype=float)
    kappa0 = np.asarray(kappa0, dtype=float)
    F = np.asarray(F, dtype=float)
    M = np.asarray(M, dtype=float)
    x0 = np.asarray(x0, dtype=float)
    e1 = np.array([1.0, 0.0, 0.0])

    def end_state(m0, mu):
        Fm = mu * F

        def rhs(s, y):
            R = y[3:12].reshape(3, 3)
            eps = Cinv @ np.concatenate((R.T @ Fm, R.T @ y[12:15]))
            xp = R @ (e1 + eps[:3])
            return np.concatenate((xp, (R @ _hat(kappa0 + eps[3:])).ravel(), -np.cross(xp, Fm)))

        y0 = np.concatenate((x0, R0.ravel(), m0))
        return solve_ivp(rhs, (0.0, length), y0, method="DOP853", rtol=rtol, atol=rtol).y[:, -1]

    m0 = np.zeros(3)
    for mu in np.linspace(0.0, 1.0, load_steps + 1)[1:]:
        sol = root(lambda m: end_state(m, mu)[12:15] - mu * M, m0, method="hybr", options={"xtol": 1e-14})
        m0 = sol.x
    y = end_state(m0, 1.0)
    return {"x": y[0:3], "R": y[3:12].reshape(3, 3), "m0": m0, "residual": float(np.abs(y[12:15] - M).max())}
