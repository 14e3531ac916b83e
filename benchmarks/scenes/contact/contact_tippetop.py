"""The tippe top: a spinning top on a sphere, its centre of mass below the sphere's centre, tips over.

The model of Leine & Glocker (2003) as run by Capobianco, Harsch, Eugster & Leine (2021, §10.6):
an axisymmetric rigid body (mass m, inertia I₁ = I₂ about the transverse axes and I₃ about the
symmetry axis e₃, at the centre of mass G) bounded by two spheres whose centres lie on e₃: the
body sphere (radius r₁, centre G + a₁e₃) and the stem sphere (radius r₂, centre G + a₂e₃). Each
sphere touches the floor z = 0 through a :class:`SpatialSphereOnPlane` (sphere centre off the
body node) with Coulomb friction μ and e_N = 0.

Parameters (Leine & Glocker, Eur. J. Mech. A/Solids 22 (2003) 193–216, as used by Capobianco et
al. 2021, §10.6): m = 6e-3 kg, I₁ = 8e-7, I₃ = 7e-7 kg m², a₁ = 3e-3, a₂ = 1.6e-2, r₁ = 1.5e-2,
r₂ = 5e-3 m, μ = 0.3, e_N = e_F = 0, z₀ = r₁ − a₁cos θ₀ = 1.2015e-2 m, θ₀ = 0.1 rad (tilt about
the x axis), angular velocity 180 rad/s, nothing else moving.

**Differences from the source.** (1) Leine & Glocker's contacts carry Coulomb–Contensou friction:
a drilling torque about the normal from a contact disc of radius R = 5e-4 m, coupled with the
sliding force. femb's :class:`SpatialSphereOnPlane` is a point contact with isotropic Coulomb
friction and no drilling torque (their limit R → 0). (2) Their 180 rad/s is the spin about the
symmetry axis e₃ (ψ̇₀); here ``omega0`` is given in space axes and defaults to 180 rad/s about
the vertical. With point contact and the spin about e₃ the slip (0.27 m/s at t = 0) dies out by
t ≈ 0.033 s (femb and :func:`reference` agree) and the top then rolls without slipping at
θ ≈ 0.04 rad: without Contensou's drilling friction, which keeps the contact sliding, there is no
tipping from that start. With the spin about the vertical the slip starts smaller (0.054 m/s) and
grows while the axis rises: the top tips to θ ≈ 2.36 rad within 1.1 s, its centre of mass rising
from 12.0 to 17.1 mm; then the slip vanishes and it rolls on the body sphere with the stem
0.7–0.8 mm above the floor. The full inversion onto the stem (θ → π, z_G → a₂ + r₂ = 21 mm) needs
the continued sliding that Contensou friction provides; femb has no such element.

**Jellett's integral.** While the body sphere alone touches, every contact force acts at the
contact point P = G + a₁e₃ − r₁e_z and gravity acts at G, so the angular momentum L about G obeys
L̇ = (P − G) × F; with d = P − G = a₁e₃ − r₁e_z, d/dt(L·d) = L·(a₁ ω × e₃) = 0 for an axisymmetric
body (L lies in the plane of ω and e₃). Hence λ_J = L·(r₁e_z − a₁e₃) is conserved for any force
at a point contact, sliding or rolling (J. H. Jellett, A Treatise on the Theory of Friction, 1872;
C. M. Braams, Physica 18 (1952) 503). A drilling torque changes it; femb has none, so its drift is
a check of the scheme.

**Reference.** :func:`reference` integrates the same rigid body in persistent sliding contact on
the body sphere (Newton–Euler equations, normal force from g̈_N = 0, friction −μ N ŝ along the
slip direction ŝ) by scipy's DOP853 at rtol 1e-12: independent of femb's scheme, valid while the
body sphere slides (up to 1.1 s with the default start).

Run ``python -m femb.benchmarks.scenes.contact.contact_tippetop`` for the validation table of
docs/contact.md (a 4 s run and the step-size study; a few minutes of wall time).
"""
from __future__ import annotations

import math

import numpy as np

from femb import Mechanism
from femb.elements import SpatialGravity, SpatialRigidBody
from femb.elements.contact import SpatialSphereOnPlane

PARAMS = {"mass": 6e-3, "I1": 8e-7, "I3": 7e-7, "a1": 3e-3, "a2": 1.6e-2, "r1": 1.5e-2, "r2": 5e-3,
          "mu": 0.3, "theta0": 0.1, "omega0": (0.0, 0.0, 180.0), "g": 9.81}
DEFAULTS = {"t_end": 8.0, "h": 1e-3, "rho_inf": 0.8}
PARAMETERS = {"mass": ("mass of the top", "kg"), "I1": ("transverse moment of inertia at G", "kg m^2"),
              "I3": ("moment of inertia about the symmetry axis", "kg m^2"),
              "a1": ("distance from G to the centre of the body sphere (along e3)", "m"),
              "a2": ("distance from G to the centre of the stem sphere (along e3)", "m"),
              "r1": ("radius of the body sphere", "m"), "r2": ("radius of the stem sphere", "m"),
              "mu": ("friction coefficient (both spheres)", "-"), "theta0": ("initial tilt of the axis", "rad"),
              "omega0": ("initial angular velocity, space axes", "rad/s"),
              "g": ("gravity along -z", "m/s^2")}
OUTPUTS = {"theta": ("tilt of the symmetry axis from the vertical", "rad"), "z": ("height of G", "m"),
           "jellett": ("Jellett's quantity L·(r1 e_z − a1 e3)", "kg m^3/s"),
           "lambda_N": ("normal force on the body sphere", "N"), "lambda_N_stem": ("normal force on the stem", "N"),
           "spin": ("angular velocity about the symmetry axis", "rad/s")}


def _rot_x(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def build(mass=PARAMS["mass"], I1=PARAMS["I1"], I3=PARAMS["I3"], a1=PARAMS["a1"], a2=PARAMS["a2"],
          r1=PARAMS["r1"], r2=PARAMS["r2"], mu=PARAMS["mu"], theta0=PARAMS["theta0"], omega0=PARAMS["omega0"],
          g=PARAMS["g"]):
    """Body ``top`` (centre of mass at its node), contacts ``ball`` (body sphere) and ``stem``, ``gravity``."""
    mech = Mechanism("contact_tippetop")
    mech.add(SpatialRigidBody("top", mass, (I1, I1, I3), position=(0.0, 0.0, r1 - a1 * math.cos(theta0)),
                              rotation=_rot_x(theta0), omega_space=tuple(omega0)))
    mech.add(SpatialGravity((0.0, 0.0, -g)))
    mech.add(SpatialSphereOnPlane("ball", "top", radius=r1, point=(0.0, 0.0, a1), mu=mu))
    mech.add(SpatialSphereOnPlane("stem", "top", radius=r2, point=(0.0, 0.0, a2), mu=mu))
    return mech


def _quat_matrix(p):
    """Rotation matrix of the unit quaternion p = (p₀, p₁, p₂, p₃), scalar first (rows (nt, 3, 3))."""
    p = np.asarray(p, dtype=float).reshape(-1, 4)
    p = p / np.linalg.norm(p, axis=1)[:, None]
    w, x, y, z = p.T
    return np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
                     np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
                     np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)], 1)


def _invariants(R, Omega, I1, I3, a1, r1):
    """Tilt θ, Jellett's λ_J = L·(r₁e_z − a₁e₃) and the spin Ω₃.

    From the rotations R (nt, 3, 3) and the body-axes angular velocities Ω (nt, 3)."""
    e3 = R[:, :, 2]
    L = np.einsum("kij,kj->ki", R, Omega * np.array([I1, I1, I3]))
    theta = np.arccos(np.clip(e3[:, 2], -1.0, 1.0))
    jellett = r1 * L[:, 2] - a1 * np.einsum("ki,ki->k", L, e3)
    return theta, jellett, Omega[:, 2]


def outputs(result, I1=PARAMS["I1"], I3=PARAMS["I3"], a1=PARAMS["a1"], r1=PARAMS["r1"]):
    R = _quat_matrix(result.q[:, 3:7])
    theta, jellett, spin = _invariants(R, result.qd[:, 3:6], I1, I3, a1, r1)
    return {"theta": theta, "z": result.q[:, 2], "jellett": jellett,
            "lambda_N": result.series("ball.lambda_N")[0], "lambda_N_stem": result.series("stem.lambda_N")[0],
            "spin": spin}


# ---------------------------------------------------------------------------
# the independent reference: sliding on the body sphere, scipy ODE
# ---------------------------------------------------------------------------
def _matrix(q):
    """Rotation matrix of a quaternion q = (w, x, y, z), scalar first (normalised here)."""
    w, x, y, z = q / math.sqrt(q @ q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _cross(a, b):
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def _sliding_rhs(y, p):
    """Time derivative of y = (r, v, quaternion, Ω) in sliding contact on the body sphere, N and the slip speed."""
    m, I, a1, r1, mu, g = p
    v, q, Om = y[3:6], y[6:10], y[10:13]
    R = _matrix(q)
    e3 = R[:, 2]
    d = a1 * e3 - np.array([0.0, 0.0, r1])                     # G → contact point
    vP = v + _cross(R @ Om, d)
    slip = math.hypot(vP[0], vP[1])
    fhat = np.array([-mu * vP[0] / slip, -mu * vP[1] / slip, 1.0])   # contact force per unit N
    gyro = -_cross(Om, I * Om) / I
    tq = (R.T @ _cross(d, fhat)) / I
    # g̈_N = v̇_z + a₁ [R(Ω̇ × E₃ + Ω × (Ω × E₃))]_z = A + B N = 0, E₃ = (0, 0, 1) in body axes
    E3 = np.array([0.0, 0.0, 1.0])
    A = -g + a1 * (R[2] @ (_cross(gyro, E3) + _cross(Om, _cross(Om, E3))))
    B = 1.0 / m + a1 * (R[2] @ _cross(tq, E3))
    N = -A / B
    qd = 0.5 * np.array([-(q[1:] @ Om), *(q[0] * Om + _cross(q[1:], Om))])
    return np.concatenate((v, fhat * N / m - np.array([0.0, 0.0, g]), qd, gyro + N * tq)), N, slip


def reference(t, mass=PARAMS["mass"], I1=PARAMS["I1"], I3=PARAMS["I3"], a1=PARAMS["a1"], r1=PARAMS["r1"],
              mu=PARAMS["mu"], theta0=PARAMS["theta0"], omega0=PARAMS["omega0"], g=PARAMS["g"]):
    """The top sliding on its body sphere by scipy's DOP853 (rtol 1e-12) at the times ``t`` (≥ 0).

    Returns
    -------
    dict
        ``x``, ``y``, ``z`` (G), ``theta``, ``jellett``, ``spin``, ``lambda_N`` (nt,) and ``description``.
    """
    from scipy.integrate import solve_ivp

    t = np.atleast_1d(np.asarray(t, dtype=float))
    par = (mass, np.array([I1, I1, I3]), a1, r1, mu, g)
    c, s = math.cos(0.5 * theta0), math.sin(0.5 * theta0)
    Om0 = _rot_x(theta0).T @ np.asarray(omega0, dtype=float)
    y0 = np.array([0.0, 0.0, r1 - a1 * math.cos(theta0), 0.0, 0.0, 0.0, c, s, 0.0, 0.0, *Om0])
    sol = solve_ivp(lambda _t, y: _sliding_rhs(y, par)[0], (0.0, float(t.max())), y0, method="DOP853",
                    t_eval=t, rtol=1e-12, atol=1e-14)
    Y = sol.y.T
    R = _quat_matrix(Y[:, 6:10])
    theta, jellett, spin = _invariants(R, Y[:, 10:13], I1, I3, a1, r1)
    N = np.array([_sliding_rhs(y, par)[1] for y in Y])
    slip = np.array([_sliding_rhs(y, par)[2] for y in Y])
    return {"x": Y[:, 0], "y": Y[:, 1], "z": Y[:, 2], "theta": theta, "jellett": jellett, "spin": spin,
            "lambda_N": N, "slip": slip,
            "description": "sliding on the body sphere, Newton-Euler, scipy DOP853 rtol 1e-12"}


# ---------------------------------------------------------------------------
# validation table (docs/contact.md)
# ---------------------------------------------------------------------------
def order_study(t_end=0.05, hs=(1e-3, 5e-4, 2.5e-4, 1.25e-4), rho_inf=DEFAULTS["rho_inf"]):
    """Errors at ``t_end`` against :func:`reference` for the step sizes ``hs`` and the fitted orders.

    Returns
    -------
    dict
        ``h``, ``err_r`` (|r_G − r_ref|, m), ``err_theta`` (rad), ``err_lambda_N`` (N), ``jellett_drift``
        (relative change of λ_J over the run), and ``order_*`` (least-squares slopes in log–log).
    """
    from femb.contact import simulate

    ref = reference([t_end])
    r_ref = np.array([ref["x"][0], ref["y"][0], ref["z"][0]])
    rows = []
    for h in hs:
        res = simulate(build().compile(), t_end, h, rho_inf=rho_inf)
        o = outputs(res)
        rows.append((np.linalg.norm(res.q[-1, :3] - r_ref), abs(o["theta"][-1] - ref["theta"][0]),
                     abs(o["lambda_N"][-1] - ref["lambda_N"][0]), abs(o["jellett"][-1] / o["jellett"][0] - 1.0)))
    E = np.array(rows)
    out = {"h": list(hs)}
    for j, key in enumerate(("err_r", "err_theta", "err_lambda_N", "jellett_drift")):
        out[key] = E[:, j].tolist()
        out["order_" + key] = float(np.polyfit(np.log(hs), np.log(E[:, j]), 1)[0])
    return out


def table(h=2e-3, t_end=4.0, rho_inf=DEFAULTS["rho_inf"]):
    """The long run: tilt, height, contact states, Jellett's drift and penetration."""
    from femb.contact import simulate

    res = simulate(build().compile(), t_end, h, rho_inf=rho_inf)
    o = outputs(res)
    st = res.contact["state"][:, 0]
    stick = np.nonzero(st == 1)[0]
    k = stick[0] if stick.size else len(res.t) - 1
    ref = reference(np.linspace(0.0, 0.2, 3))
    return {"theta(0) / theta at first stick / theta(t_end)": (o["theta"][0], o["theta"][k], o["theta"][-1]),
            "first stick of the body sphere (step end)": float(res.t[k]),
            "z_G(0) / z_G(t_end)": (o["z"][0], o["z"][-1]),
            "min stem gap": float(res.contact["gN"][:, 1].min()),
            "Jellett drift while sliding (rel.)": float(o["jellett"][k] / o["jellett"][0] - 1.0),
            "theta(0.2) femb / reference": (float(np.interp(0.2, res.t, o["theta"])), float(ref["theta"][-1])),
            "impacts": len(res.events),
            "min g_N / L": float(res.contact["gN"].min() / res.model.length_scale)}


def main():
    for key, v in table().items():
        print(f"tippetop  {key:50s} {v}")
    for key, v in order_study().items():
        print(f"tippetop  {key:50s} {v}")


if __name__ == "__main__":
    main()
