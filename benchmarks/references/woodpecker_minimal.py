"""Glocker's woodpecker toy in minimal coordinates, Moreau's midpoint time stepping (independent reference).

An independent check of the scene ``contact_woodpecker`` (docs/contact.md §5): the model in the
minimal coordinates q = (y, φ_M, φ_S) of C. Glocker, *Dynamik von Starrkörpersystemen mit Reibung
und Stößen*, VDI Fortschritt-Berichte 18/182 (1995), and *Set-Valued Force Laws*, Springer (2001);
R. I. Leine, C. Glocker, D. H. van Campen, "Nonlinear dynamics and modeling of various wooden toys
with impact and friction", J. Vib. Control 9 (2003) 25–78; R. I. Leine, H. Nijmeijer, *Dynamics
and Bifurcations of Non-smooth Mechanical Systems*, Springer (2004), Ch. 9. It shares no code with
femb: its own equations, its own time stepping (numba), its own contact solver.

Model (Glocker's names: M the sleeve, "Muffe"; S the woodpecker, "Specht")
---------------------------------------------------------------------------
The sleeve (m_M, J_M) slides on a vertical pole of radius r_0 through a hole of radius r_M and
height 2 h_M; its centre stays on the pole's axis (x = 0) at height y and it tilts by φ_M. The
woodpecker (m_S, J_S about its centre of gravity) hangs on a hinge at distance l_M from the sleeve's
centre, its centre of gravity l_G further out; a rotational spring c_φ acts on φ_S − φ_M. Angles are
counter-clockwise, the woodpecker on the +x side of the pole, gravity g along −y. Contacts, all
against the pole's surface x = r_0 (gap = x − r_0, friction along the pole):

1. the beak, at (−l_S, h_S) from the woodpecker's centre of gravity (e_N1 = 0.5);
2. the sleeve's lower edge on the woodpecker's side, at (r_M, −h_M) from the sleeve's centre (e_N2 = 0);
3. the sleeve's upper edge on that side, at (r_M, h_M) (e_N3 = 0);

Coulomb friction μ on each, e_F = 0. The published model is the small-angle linearization
(``linear=True``): with c_X = cos φ_X ≈ 1, s_X = sin φ_X ≈ φ_X::

    g_N = (l_M + l_G − l_S − r_0 − h_S φ_S,  r_M − r_0 + h_M φ_M,  r_M − r_0 − h_M φ_M),
    γ_F = (ẏ + l_M φ̇_M + (l_G − l_S) φ̇_S,  ẏ + r_M φ̇_M,  ẏ + r_M φ̇_M),
    M = [[m_M + m_S, m_S l_M, m_S l_G], [m_S l_M, J_M + m_S l_M², m_S l_M l_G],
         [m_S l_G, m_S l_M l_G, J_S + m_S l_G²]],
    h = (−(m_M + m_S) g, −c_φ (φ_M − φ_S) − m_S g l_M, −c_φ (φ_S − φ_M) − m_S g l_G)

(Leine & Nijmeijer 2004, §9.2; the same in Glocker 2001). ``linear=False`` keeps the exact
kinematics of the same rigid bodies (the sleeve held at x = 0): the woodpecker's centre
r_S = (l_M c_M + l_G c_S, y + l_M s_M + l_G s_S), M = diag(m_M, J_M, J_S) on (y, φ_M, φ_S) plus
m_S J_Sᵀ J_S, the quadratic velocity terms −m_S J_Sᵀ J̇_S q̇, exact gaps and contact rows — the
model femb's scene builds from rigid bodies and joints.

Scheme
------
Moreau's midpoint rule (J. J. Moreau, "Unilateral contact and dry friction in finite freedom
dynamics", CISM Courses 302 (1988) 1–82; Studer, *Numerics of Unilateral Contacts and Friction*,
Springer 2009, §4): q_M = q + h/2 u; contacts with g_N(q_M) ≤ 0 are active;
M(q_M)(u⁺ − u) = h h(q_M, u) + W_N P_N + W_F P_F with Newton's impact law on the velocities,
ξ_N = ġ_N⁺ + e_N ġ_N⁻, ξ_F = γ_F⁺ (e_F = 0), 0 ≤ P_N ⊥ ξ_N ≥ 0 and P_F ∈ −μP_N Sign(ξ_F), solved by
projected Gauss–Seidel on the Delassus matrix to 1e-14 relative; q⁺ = q_M + h/2 u⁺. First order,
penetration O(h²) per step; the run settings of ``simulate`` are chosen by the caller.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

#: Glocker's parameters (Leine, Glocker & van Campen 2003; Leine & Nijmeijer 2004, §9.2).
PARAMS = {"m_M": 3e-4, "J_M": 5e-9, "m_S": 4.5e-3, "J_S": 7e-7, "r_0": 2.5e-3, "r_M": 3.1e-3, "h_M": 5.8e-3,
          "l_M": 1e-2, "l_G": 1.5e-2, "h_S": 2e-2, "l_S": 2.01e-2, "c_phi": 5.6e-3, "mu": 0.3, "g": 9.81,
          "e_N1": 0.5, "e_N2": 0.0, "e_N3": 0.0}
#: A state on the limit cycle of the linear model (same sources): y, φ_M, φ_S and their rates.
LIMIT_CYCLE_STATE = {"y": 0.0, "phi_M": -0.1036, "phi_S": -0.2788, "y_d": -0.3411, "phi_M_d": 0.0,
                     "phi_S_d": -7.4583}
_ORDER = ("m_M", "J_M", "m_S", "J_S", "r_0", "r_M", "h_M", "l_M", "l_G", "h_S", "l_S", "c_phi", "mu", "g",
          "e_N1", "e_N2", "e_N3")


def param_vector(**overrides):
    """The parameters as a float array in the order the compiled functions read them."""
    p = dict(PARAMS)
    p.update(overrides)
    return np.array([p[k] for k in _ORDER], dtype=np.float64)


@njit(cache=True)
def _system(q, u, p, linear):
    """M (3, 3), h (3,), g_N (3,), W_N (3, 3) columns, W_F (3, 3) columns at (q, u)."""
    m_M, J_M, m_S, J_S, r_0, r_M = p[0], p[1], p[2], p[3], p[4], p[5]
    h_M, l_M, l_G, h_S, l_S, c_phi, g = p[6], p[7], p[8], p[9], p[10], p[11], p[13]
    pM, pS = q[1], q[2]
    if linear:
        cM, sM, cS, sS = 1.0, pM, 1.0, pS
    else:
        cM, sM, cS, sS = math.cos(pM), math.sin(pM), math.cos(pS), math.sin(pS)
    # woodpecker's centre: x = l_M cM + l_G cS, y + l_M sM + l_G sS (linear: x fixed, y linear)
    Jx = np.array([0.0, -l_M * sM, -l_G * sS]) if not linear else np.zeros(3)
    Jy = np.array([1.0, l_M * cM, l_G * cS])
    M = m_S * (np.outer(Jx, Jx) + np.outer(Jy, Jy))
    M[0, 0] += m_M
    M[1, 1] += J_M
    M[2, 2] += J_S
    spring = c_phi * (pS - pM)
    h = np.array([-(m_M + m_S) * g, spring - m_S * g * l_M * cM, -spring - m_S * g * l_G * cS])
    if not linear:
        wM, wS = u[1], u[2]
        ax = -l_M * cM * wM * wM - l_G * cS * wS * wS
        ay = -l_M * sM * wM * wM - l_G * sS * wS * wS
        h -= m_S * (Jx * ax + Jy * ay)
    d = l_G - l_S
    gN = np.array([l_M * cM + d * cS - h_S * sS - r_0, r_M * cM + h_M * sM - r_0, r_M * cM - h_M * sM - r_0])
    WN = np.zeros((3, 3))
    WF = np.zeros((3, 3))
    if linear:
        WN[2, 0], WN[1, 1], WN[1, 2] = -h_S, h_M, -h_M
        WF[0, 0], WF[1, 0], WF[2, 0] = 1.0, l_M, d
        WF[0, 1], WF[1, 1], WF[0, 2], WF[1, 2] = 1.0, r_M, 1.0, r_M
        gN[0] = l_M + d - r_0 - h_S * pS
        gN[1] = r_M - r_0 + h_M * pM
        gN[2] = r_M - r_0 - h_M * pM
    else:
        WN[1, 0], WN[2, 0] = -l_M * sM, -d * sS - h_S * cS
        WN[1, 1], WN[1, 2] = -r_M * sM + h_M * cM, -r_M * sM - h_M * cM
        WF[0, 0], WF[1, 0], WF[2, 0] = 1.0, l_M * cM, d * cS - h_S * sS
        WF[0, 1], WF[1, 1] = 1.0, r_M * cM + h_M * sM
        WF[0, 2], WF[1, 2] = 1.0, r_M * cM - h_M * sM
    return M, h, gN, WN, WF


@njit(cache=True)
def _percussions(G, c, active, mu, tol):
    """Projected Gauss–Seidel for ξ = c + G P: P_N ≥ 0 ⊥ ξ_N ≥ 0, |P_F| ≤ μP_N, −ξ_F ∈ N(P_F)."""
    n = c.size // 2
    P = np.zeros(2 * n)
    for it in range(100000):
        change = 0.0
        for i in range(n):
            if not active[i]:
                continue
            for j in (i, n + i):
                xi = c[j] + G[j] @ P
                new = P[j] - xi / G[j, j]
                if j < n:
                    new = max(new, 0.0)
                else:
                    bound = mu * P[i]
                    new = min(max(new, -bound), bound)
                change = max(change, abs(new - P[j]))
                P[j] = new
        if change <= tol * (1e-300 + np.abs(P).max()):
            return P, it + 1
    return P, -1


@njit(cache=True)
def _integrate(q0, u0, p, linear, h, n_steps, every):
    """Moreau's midpoint steps; states every ``every`` steps (q, u) and the number of unconverged solves."""
    mu = p[12]
    e_N = p[14:17]
    n_out = n_steps // every + 1
    Q = np.zeros((n_out, 3))
    U = np.zeros((n_out, 3))
    q, u = q0.copy(), u0.copy()
    Q[0], U[0] = q, u
    failures = 0
    for k in range(n_steps):
        qm = q + 0.5 * h * u
        M, f, gN, WN, WF = _system(qm, u, p, linear)
        Minv = np.linalg.inv(M)
        u_free = u + h * (Minv @ f)
        active = gN <= 0.0
        if active.any():
            W = np.hstack((WN, WF))
            G = W.T @ Minv @ W
            c = W.T @ u_free
            c[:3] += e_N * (WN.T @ u)
            P, its = _percussions(G, c, active, mu, 1e-14)
            if its < 0:
                failures += 1
            u_new = u_free + Minv @ (W @ P)
        else:
            u_new = u_free
        q = qm + 0.5 * h * u_new
        u = u_new
        if (k + 1) % every == 0:
            Q[(k + 1) // every], U[(k + 1) // every] = q, u
    return Q, U, failures


def initial_state(linear=True, **params):
    """(q0, u0) from the published limit-cycle state; in the exact model φ_M is moved onto the sleeve's
    contact angle (where g_N2 = 0: the published φ_M = −0.1036 is the linear model's, 1.6e-5 m inside
    the pole with exact kinematics)."""
    s = LIMIT_CYCLE_STATE
    q0 = np.array([s["y"], s["phi_M"], s["phi_S"]])
    if not linear:
        q0[1] = -sleeve_contact_angle(**params)
    return q0, np.array([s["y_d"], s["phi_M_d"], s["phi_S_d"]])


def sleeve_contact_angle(**params):
    """The magnitude of φ_M at which the sleeve's edges touch the pole with exact kinematics: r_M cos φ − h_M sin φ = r_0."""
    p = dict(PARAMS)
    p.update(params)
    R = math.hypot(p["r_M"], p["h_M"])
    return math.acos(p["r_0"] / R) - math.atan2(p["h_M"], p["r_M"])


def simulate(t_end, h=1e-6, linear=True, every=10, q0=None, u0=None, **params):
    """Integrate; returns dict t (n,), q (n, 3), u (n, 3), failures (PGS solves that did not converge)."""
    p = param_vector(**params)
    if q0 is None:
        q0, u0 = initial_state(linear, **params)
    n_steps = int(round(t_end / h))
    Q, U, failures = _integrate(np.asarray(q0, float), np.asarray(u0, float), p, linear, h, n_steps, every)
    t = np.arange(Q.shape[0]) * h * every
    return {"t": t, "q": Q, "u": U, "failures": int(failures), "gN": gaps(Q, linear, **params)}


def gaps(Q, linear=True, **params):
    """g_N (n, 3) at the states Q (n, 3)."""
    p = param_vector(**params)
    return np.array([_system(q, np.zeros(3), p, linear)[2] for q in Q])
