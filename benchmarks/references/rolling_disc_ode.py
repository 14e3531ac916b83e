"""A thin disc rolling without slip on a horizontal plane, and the Chaplygin sleigh (references).

Independent reference models for femb's velocity-level (non-holonomic) constraints: plain
numpy/scipy, no code shared with femb. They are checks, never the thing tested.

Rolling disc (coin)
-------------------
A rigid disc (mass m, radius ρ, central principal inertia I = diag(A, C, A) about the axis
ā = e_y of the body) on the plane z = 0 with gravity g = (0, 0, −g). With n = e_z the plane
normal, a = R ā the axis in space, c = n·a, s = √(1 − c²), the unit vector from the contact
point P to the centre G is d = (n − c a)/s. Rolling without slip makes the material point at P
still, so the centre moves with v_G = ω × ρd and the disc has three velocity degrees of freedom,
ω (space axes). Newton–Euler for the disc, with the contact force F (on the disc, at P):

    m a_G = F + m g,    I_s ω̇ + ω × I_s ω = (P − G) × F = −ρ d × F,

I_s = R I Rᵀ. With a_G = ω̇ × ρd + ω × ρḋ and F = m a_G − m g eliminated (d × (ω̇ × d) = −d̃² ω̇):

    (I_s − m ρ² d̃²) ω̇ = −ω × I_s ω − m ρ² d × (ω × ḋ) + m ρ d × g,

ȧ = ω × a, ċ = n·ȧ, ṡ = −c ċ/s, ḋ = −(ċ a + c ȧ)/s − d ṡ/s. The state is the unit quaternion of
R (Ṙ = ω̃ R), ω and the contact point (x_P, y_P) with Ṗ = v_G − ρḋ; the centre is G = P + ρd.
(Neimark & Fufaev, *Dynamics of Nonholonomic Systems*, AMS 1972, Ch. II: the rolling disc;
O'Reilly, Nonlinear Dynamics 10 (1996) 287–305: its steady motions.)

Steady motions: ω = ψ̇ n + ω_s a with the lean constant turn about n at the rate ψ̇, so
ω̇ = ψ̇ n × ω; :func:`steady_spin` finds the spin ω_s that makes the equation above hold.

Chaplygin sleigh
----------------
A planar body (mass m, inertia J about its centre of mass G, at r = (x, y), heading θ, blade
direction e = (cos θ, sin θ), l = (−sin θ, cos θ)) with a knife edge at the body point G + b e
that cannot move along l: l·ṙ + b θ̇ = 0. With ṙ = u e + w l, w = −b ω (ω = θ̇) and the
lateral force F l at the blade:

    u̇ = −b ω²,   (J + m b²) ω̇ = m b u ω,   F = m (u ω − b ω̇)

(Chaplygin 1911; Neimark & Fufaev 1972, Ch. III, §1; Bloch, *Nonholonomic Mechanics and
Control*, 2nd ed., Springer 2015, §1.7).

Both are integrated by :func:`scipy.integrate.solve_ivp` (DOP853) at rtol = atol = 1e-12.
"""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

N = np.array([0.0, 0.0, 1.0])


def _skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def quat_matrix(p):
    """Rotation matrix of the unit quaternion p = (p0, p1, p2, p3) (scalar first)."""
    p0, p1, p2, p3 = p / np.linalg.norm(p)
    return np.array([[1 - 2 * (p2 * p2 + p3 * p3), 2 * (p1 * p2 - p0 * p3), 2 * (p1 * p3 + p0 * p2)],
                     [2 * (p1 * p2 + p0 * p3), 1 - 2 * (p1 * p1 + p3 * p3), 2 * (p2 * p3 - p0 * p1)],
                     [2 * (p1 * p3 - p0 * p2), 2 * (p2 * p3 + p0 * p1), 1 - 2 * (p1 * p1 + p2 * p2)]])


class RollingDisc:
    """The rolling disc of the module docstring.

    Parameters
    ----------
    mass, radius : float
    inertia : (A, C)
        Central moments about a diameter and about the axis (thin disc: m ρ²/4, m ρ²/2).
    g : float
        Gravity (m/s²), along −z.
    """

    def __init__(self, mass=1.0, radius=0.5, inertia=None, g=9.81):
        self.m, self.rho, self.g = float(mass), float(radius), float(g)
        A, C = inertia if inertia is not None else (mass * radius ** 2 / 4, mass * radius ** 2 / 2)
        self.I = np.diag([A, C, A])
        self.axis = np.array([0.0, 1.0, 0.0])

    def geometry(self, R, w):
        """(a, d, ḋ) of the orientation R and the angular velocity ω (space axes)."""
        a = R @ self.axis
        c = N @ a
        s = np.sqrt(1.0 - c * c)
        d = (N - c * a) / s
        ad = np.cross(w, a)
        cd = N @ ad
        sd = -c * cd / s
        dd = -(cd * a + c * ad) / s - d * sd / s
        return a, d, dd

    def omega_dot(self, R, w):
        """ω̇ and the contact force F on the disc (space axes)."""
        m, rho = self.m, self.rho
        Is = R @ self.I @ R.T
        a, d, dd = self.geometry(R, w)
        D = _skew(d)
        gvec = np.array([0.0, 0.0, -self.g])
        lhs = Is - m * rho * rho * (D @ D)
        rhs = -np.cross(w, Is @ w) - m * rho * rho * np.cross(d, np.cross(w, dd)) + m * rho * np.cross(d, gvec)
        wd = np.linalg.solve(lhs, rhs)
        aG = rho * (np.cross(wd, d) + np.cross(w, dd))
        return wd, m * aG - m * gvec

    def rhs(self, t, y):
        p, w = y[0:4], y[4:7]
        R = quat_matrix(p)
        wd, _ = self.omega_dot(R, w)
        _, d, dd = self.geometry(R, w)
        vG = self.rho * np.cross(w, d)
        # ṗ = ½ (0, ω) ⊗ p (ω in space axes)
        pd = 0.5 * np.array([-w @ p[1:], p[0] * w[0] + w[1] * p[3] - w[2] * p[2],
                             p[0] * w[1] + w[2] * p[1] - w[0] * p[3], p[0] * w[2] + w[0] * p[2] - w[1] * p[1]])
        Pd = vG - self.rho * dd
        return np.concatenate((pd, wd, Pd[0:2]))

    def solve(self, p0, w0, P0, t_eval, rtol=1e-12, atol=1e-12):
        """Integrate from the quaternion p0, ω0 (space axes) and the contact point P0 = (x, y).

        Returns
        -------
        dict of arrays over ``t_eval``: ``p`` (nt, 4), ``omega`` (nt, 3) space axes, ``omega_body``,
        ``G`` (nt, 3) centre, ``vG`` (nt, 3), ``F`` (nt, 3) contact force on the disc.
        """
        y0 = np.concatenate((np.asarray(p0, float), np.asarray(w0, float), np.asarray(P0, float)[:2]))
        t_eval = np.asarray(t_eval, dtype=float)
        sol = solve_ivp(self.rhs, (0.0, float(t_eval[-1])), y0, method="DOP853", t_eval=t_eval,
                        rtol=rtol, atol=atol)
        if not sol.success:
            raise RuntimeError(sol.message)
        out = {k: [] for k in ("p", "omega", "omega_body", "G", "vG", "F")}
        for y in sol.y.T:
            p = y[0:4] / np.linalg.norm(y[0:4])
            R = quat_matrix(p)
            w = y[4:7]
            _, d, _ = self.geometry(R, w)
            out["p"].append(p)
            out["omega"].append(w)
            out["omega_body"].append(R.T @ w)
            out["G"].append(np.array([y[7], y[8], 0.0]) + self.rho * d)
            out["vG"].append(self.rho * np.cross(w, d))
            out["F"].append(self.omega_dot(R, w)[1])
        return {k: np.array(v) for k, v in out.items()}

    def steady_spin(self, R, yaw_rate, bracket=(-200.0, 200.0)):
        """The spin rate ω_s about the axis of a steady motion ω = ψ̇ n + ω_s a at the orientation R.

        Solves the component along e = n × d of (I_s − m ρ² d̃²) ψ̇ n × ω − rhs(ω) = 0 (the other
        components vanish by the symmetry of the steady motion)."""
        a, d, _ = self.geometry(R, N)

        def resid(ws):
            w = yaw_rate * N + ws * a
            wd, _ = self.omega_dot(R, w)
            return (wd - yaw_rate * np.cross(N, w)) @ np.cross(a, d)

        ws = brentq(resid, *bracket, xtol=1e-15, rtol=1e-15)
        w = yaw_rate * N + ws * a
        wd, _ = self.omega_dot(R, w)
        return ws, float(np.linalg.norm(wd - yaw_rate * np.cross(N, w)))


class ChaplyginSleigh:
    """The Chaplygin sleigh of the module docstring: mass m, inertia J, blade at G + b e."""

    def __init__(self, mass=2.0, inertia=0.3, b=-0.4):
        self.m, self.J, self.b = float(mass), float(inertia), float(b)

    def rhs(self, t, y):
        x, yy, th, u, w = y
        m, J, b = self.m, self.J, self.b
        ud = -b * w * w
        wd = m * b * u * w / (J + m * b * b)
        vl = -b * w
        return np.array([u * np.cos(th) - vl * np.sin(th), u * np.sin(th) + vl * np.cos(th), w, ud, wd])

    def solve(self, x0, y0, th0, u0, w0, t_eval, rtol=1e-12, atol=1e-12):
        """Integrate from the centre (x0, y0), heading θ0, forward speed u0 of G and ω0.

        Returns
        -------
        dict: ``q`` (nt, 3) = (x, y, θ), ``qd`` (nt, 3), ``F`` (nt,) lateral force on the blade along l.
        """
        t_eval = np.asarray(t_eval, dtype=float)
        sol = solve_ivp(self.rhs, (0.0, float(t_eval[-1])), [x0, y0, th0, u0, w0], method="DOP853",
                        t_eval=t_eval, rtol=rtol, atol=atol)
        if not sol.success:
            raise RuntimeError(sol.message)
        Y = sol.y.T
        qd = np.array([self.rhs(0.0, y)[0:3] for y in Y])
        wd = np.array([self.rhs(0.0, y)[4] for y in Y])
        F = self.m * (Y[:, 3] * Y[:, 4] - self.b * wd)
        return {"q": Y[:, 0:3], "qd": qd, "F": F}
