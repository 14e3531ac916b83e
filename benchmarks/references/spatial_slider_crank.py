"""Spatial rigid slider–crank (IFToMM benchmark) in the minimal coordinate θ (reference).

Independent of femb's engine. Data (IFToMM multibody benchmark library, spatial
rigid slider-crank; as in ``docs/spatial.md`` §7.2): crank 0.08 m turning about
the x axis through A = (0, 0.1, 0.12), angle θ, zero with the crank along +z, so
B = A + 0.08 (0, −sin θ, cos θ); rod 0.3 m from B to the slider point
D = (s, 0, 0) on the x axis, s = √(0.09 − B_y² − B_z²) > 0; masses 0.12, 0.5, 2 kg;
inertias about the centres of mass: crank diag(1e-4, 1e-4, 1e-5) (body z along
the crank, centre mid-crank), rod diag(4e-4, 4e-3, 4e-3) (body x along the rod,
centre mid-rod), slider diag(1e-4, 1e-4, 1e-4) (does not rotate); gravity
(0, 0, −9.81); θ(0) = 0, θ̇(0) = 6 rad/s.

Rod orientation: the spherical joint at B leaves it free; the universal joint
at D has its slider-side pin along the slide x and its rod-side pin along
a = e × x/|e × x| (perpendicular to the rod axis e = (D − B)/0.3 and to x; at
t0 a ∝ (0, −2, 1)), and keeps a ⟂ x. This is the joint that reproduces the
benchmark's consistent initial rod angular velocity (1.92, −0.96, 0.48) rad/s
(a universal joint with both pins along inertial axes at t0 would give ω_z = 0
instead). The rod rotation maps the triad (e₀, a₀, e₀ × a₀) to (e, a, e × a).

Kane's equations of :mod:`.kane` with exact derivatives (hyper-dual numbers),
integrated with DOP853.
"""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from .kane import RigidSystem, cos, cross, matmul, sin, sqrt

DATA = dict(A=np.array([0.0, 0.1, 0.12]), l_crank=0.08, l_rod=0.3,
            m=(0.12, 0.5, 2.0),
            J=(np.diag([1e-4, 1e-4, 1e-5]), np.diag([4e-4, 4e-3, 4e-3]), np.diag([1e-4, 1e-4, 1e-4])),
            g=np.array([0.0, 0.0, -9.81]), theta_d0=6.0)

#: published consistent initial velocities (IFToMM; docs/spatial.md §7.2)
PUBLISHED_V0 = {"rod_v": (0.12, -0.24, 0.0), "rod_omega": (1.92, -0.96, 0.48), "slider_v": (0.24, 0.0, 0.0)}


def rod_frame0(D=DATA):
    """Initial rod rotation: body x along B → D, body z in the plane of the rod and A (as the benchmark's models)."""
    B0 = D["A"] + np.array([0.0, 0.0, D["l_crank"]])
    D0 = np.array([np.sqrt(D["l_rod"] ** 2 - B0[1] ** 2 - B0[2] ** 2), 0.0, 0.0])
    x = (D0 - B0) / D["l_rod"]
    h = B0 - (B0 @ x) * x
    z = h / np.linalg.norm(h)
    return np.column_stack((x, np.cross(z, x), z)), B0, D0


def system(D=DATA):
    A = D["A"]
    lc, lr = D["l_crank"], D["l_rod"]
    Rr0, B0, D0 = rod_frame0(D)
    e0 = (D0 - B0) / lr
    a0 = np.cross(e0, [1.0, 0.0, 0.0])
    a0 /= np.linalg.norm(a0)
    F0 = np.column_stack((e0, a0, np.cross(e0, a0)))
    Rbase = F0.T @ Rr0                          # rod rotation = F(θ) Fᵀ₀ R_rod0

    def kin(q):
        th = q[0]
        s, c = sin(th), cos(th)
        Rc = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]], dtype=object)
        cc = A + np.array([0.0, -0.5 * lc * s, 0.5 * lc * c], dtype=object)
        B = A + np.array([0.0, -lc * s, lc * c], dtype=object)
        x_s = sqrt(lr * lr - B[1] * B[1] - B[2] * B[2])
        Dp = np.array([x_s, 0.0, 0.0], dtype=object)
        e = (Dp - B) / lr
        a = np.array([0.0 * e[0], e[2], -e[1]], dtype=object)          # e × x
        a = a / sqrt(a[1] * a[1] + a[2] * a[2])
        h = cross(e, a)
        F = np.empty((3, 3), dtype=object)
        for i in range(3):
            F[i, 0], F[i, 1], F[i, 2] = e[i], a[i], h[i]
        Rr = matmul(F, Rbase)
        cr = 0.5 * (B + Dp)
        return [(cc, Rc), (cr, Rr), (Dp, np.eye(3, dtype=object))]

    return RigidSystem(kin, D["m"], D["J"], D["g"])


def outputs_at(sys_, q, u):
    ud, s = sys_.accelerations(q, u)
    out = {"theta": q[0], "theta_d": u[0], "theta_dd": ud[0],
           "slider_x": s["c"][2][0], "slider_v": s["cd"][2][0],
           "slider_a": (s["Jc"][2] @ ud + s["acc_c"][2])[0]}
    for i, ax in enumerate("xyz"):
        out[f"rod_{ax}"] = s["c"][1][i]
        out[f"rod_v{ax}"] = s["cd"][1][i]
        out[f"rod_omega_{ax}"] = s["omega"][1][i]
    out["energy"] = 0.5 * u @ s["M"] @ u - sum(m * DATA["g"] @ s["c"][k] for k, m in enumerate(DATA["m"]))
    return out


def solve(t_end=1.0, t_eval=None, rtol=1e-12, atol=1e-12, D=DATA):
    """Integrate; returns (t, dict of output arrays)."""
    sys_ = system(D)
    if t_eval is None:
        t_eval = np.linspace(0.0, t_end, 101)
    sol = solve_ivp(sys_.rhs, (0.0, t_end), [0.0, D["theta_d0"]], method="DOP853", t_eval=t_eval,
                    rtol=rtol, atol=atol)
    if not sol.success:
        raise RuntimeError(f"slider-crank reference failed: {sol.message}")
    rows = [outputs_at(sys_, sol.y[:1, k], sol.y[1:, k]) for k in range(sol.t.size)]
    return sol.t, {key: np.array([r[key] for r in rows]) for key in rows[0]}
