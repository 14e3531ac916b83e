"""Andrews' squeezing mechanism from femb elements (seed paper, Sect. 5.2).

Seven rigid bodies, ten hinges, one spring and one torque; planar, no gravity;
21 absolute coordinates, 20 constraints, one degree of freedom.
Data: Hairer & Wanner, Solving ODEs II, Sect. VII.7, as in the IVP test set
(Mazzia & Magherini, problem ``andrews``); see docs/benchmarks data.

Outputs (:func:`outputs`)
-------------------------
* Hairer's relative angles ``beta, Theta, gamma, Phi, delta, Omega, epsilon``
  (rad), their rates (suffix ``_d``, rad/s) and accelerations (suffix ``_dd``);
* ``xP, yP`` (m) and ``xP_dd, yP_dd`` (m/s²): position and acceleration of the
  crank–rod hinge P (seed, Figs. 6–8);
* ``lambda_1`` … ``lambda_6`` (N): the reactions at E of the hinges rod–triangle
  (``E23``), rod–body 4 (``E24``), rod–body 6 (``E26``), (x, y) each. These
  hinges have the rod as body a, so Φ = r_rod(E) − r_k(E) and the multiplier is
  the force the rod exerts on body k: the order and the sign convention
  (M q̈ = f − Gᵀλ) of the published relative-coordinate reference (IVP test set;
  see :mod:`femb.benchmarks.references.andrews`).

References
----------
G. C. Andrews, H. K. Richard, Multibody dynamics benchmark (Schiehlen, 1990).
E. Hairer, G. Wanner, Solving Ordinary Differential Equations II, 2nd ed.,
Springer, 1996, Sect. VII.7.
"""
from __future__ import annotations

import math

import numpy as np

from femb import Mechanism
from femb.elements import Hinge, RigidBody, SpringDamper, Torque

#: Data of Hairer & Wanner (1996), Sect. VII.7 (SI units).
DATA = dict(
    m=(.04325, .00365, .02373, .00706, .07050, .00706, .05498),
    i=(2.194e-6, 4.410e-7, 5.255e-6, 5.667e-7, 1.169e-5, 5.667e-7, 1.912e-5),
    xa=-.06934, ya=-.00227, xb=-.03635, yb=.03273, xc=.014, yc=.072,
    d=28e-3, da=115e-4, e=2e-2, ea=1421e-5, rr=7e-3, ra=92e-5,
    ss=35e-3, sa=1874e-5, sb=1043e-5, sc=18e-3, sd=2e-2,
    ta=2308e-5, tb=916e-5, u=4e-2, ua=1228e-5, ub=449e-5,
    zf=2e-2, zt=4e-2, fa=1421e-5, mom=0.033, c0=4530.0, l0=0.07785,
)

#: Consistent initial angles (β, Θ, γ, Φ, δ, Ω, ε), Hairer & Wanner (1996).
ANGLES0 = (-0.0617138900142764496358948458001, 0.0,
           0.455279819163070380255912382449, 0.222668390165885884674473185609,
           0.487364979543842550225598953530, -0.222668390165885884674473185609,
           1.23054744454982119249735015568)

ANGLE_NAMES = ("beta", "Theta", "gamma", "Phi", "delta", "Omega", "epsilon")

#: Names of the six multipliers at E, in the order of the published reference.
LAMBDA_NAMES = tuple(f"lambda_{k}" for k in range(1, 7))

#: The hinges whose multipliers are ``lambda_1`` … ``lambda_6`` (two each, x then y).
E_HINGES = ("E23", "E24", "E26")

#: Run settings of the seed's plots: t ∈ [0, 0.03] s, h = 3e-4 s, ρ∞ = 0.7 (Sect. 5.2, Figs. 5–7).
DEFAULTS = {"t_end": 0.03, "h": 3e-4, "rho_inf": 0.7}

#: Parameters of :func:`build`: name -> (meaning, unit), shown by ``femb list``.
PARAMETERS = {
    "mom": ("constant driving torque on body 1 (the crank b1)", "N m"),
    "c0": ("stiffness of the spring between body 3 and the ground point C", "N/m"),
    "l0": ("unstretched length of that spring", "m"),
}

_ANGLE_MEANING = {"beta": "crank b1", "Theta": "b2 relative to b1", "gamma": "b3", "Phi": "b4 relative to b5",
                  "delta": "b5", "Omega": "b6 relative to b7", "epsilon": "b7"}

#: Outputs of :func:`outputs`: name -> (meaning, unit), shown by ``femb list``.
OUTPUTS = {
    **{a: (f"Hairer's angle {a} ({_ANGLE_MEANING[a]})", "rad") for a in ANGLE_NAMES},
    **{a + "_d": (f"rate of {a}", "rad/s") for a in ANGLE_NAMES},
    **{a + "_dd": (f"acceleration of {a}", "rad/s^2") for a in ANGLE_NAMES},
    "xP": ("x of the crank-rod hinge P", "m"),
    "yP": ("y of the crank-rod hinge P", "m"),
    "xP_dd": ("x acceleration of P", "m/s^2"),
    "yP_dd": ("y acceleration of P", "m/s^2"),
    **{f"lambda_{2 * k + 1 + j}": (f"{'xy'[j]} force of the rod b2 on body {body} at E (hinge {hinge})", "N")
       for k, (hinge, body) in enumerate((("E23", "b3"), ("E24", "b4"), ("E26", "b6"))) for j in (0, 1)},
}

#: The h-convergence study (Fig. 9 of the seed): all seven angles and the six
#: multipliers at E at t = 0.03 s.
CONVERGENCE = {
    "t_end": 0.03,
    "h": [4e-5, 2e-5, 1e-5, 5e-6, 2.5e-6, 1.25e-6],
    "q": list(ANGLE_NAMES),
    "lambda": list(LAMBDA_NAMES),
}


def body_points(D=DATA):
    """Body-frame points of the seven bodies (relative to their centres of mass)."""
    return [
        {"O": (-D["ra"], 0.0), "P": (D["rr"] - D["ra"], 0.0)},
        {"P": (D["da"], 0.0), "E": (D["da"] - D["d"], 0.0)},
        {"B": (-D["sa"], D["sb"]), "E": (-D["sa"], D["sb"] - D["ss"]),
         "D": (D["sd"] - D["sa"], D["sb"] - D["sc"])},
        {"F": (0.0, D["e"] - D["ea"]), "E": (0.0, -D["ea"])},
        {"A": (-D["ta"], -D["tb"]), "F": (D["zt"] - D["ta"], -D["tb"])},
        {"G": (-(D["zf"] - D["fa"]), 0.0), "E": (D["fa"], 0.0)},
        {"A": (-D["ua"], -D["ub"]), "G": (-D["ua"], -D["u"] - D["ub"])},
    ]


def absolute_angles(rel):
    """Absolute body angles φ1..φ7 from Hairer's relative angles."""
    b, Th, g, Ph, dl, Om, ep = rel
    return np.array([b, Th + b, g, Ph + dl, dl, Om + ep, ep])


def relative_angles(phi):
    """Hairer's (β, Θ, γ, Φ, δ, Ω, ε) from absolute angles φ, shape (..., 7)."""
    phi = np.asarray(phi)
    p = [phi[..., k] for k in range(7)]
    return np.stack([p[0], p[1] - p[0], p[2], p[3] - p[4], p[4], p[5] - p[6], p[6]], axis=-1)


def _R(phi, s):
    c, sn = math.cos(phi), math.sin(phi)
    return np.array([c * s[0] - sn * s[1], sn * s[0] + c * s[1]])


def initial_centres(angles=ANGLES0, D=DATA):
    """Centres of mass from the angles, walking the hinges from O, B and A."""
    phi = absolute_angles(angles)
    pts = body_points(D)
    A = np.array([D["xa"], D["ya"]])
    B = np.array([D["xb"], D["yb"]])
    c = [None] * 7
    c[0] = -_R(phi[0], pts[0]["O"])
    P = c[0] + _R(phi[0], pts[0]["P"])
    c[1] = P - _R(phi[1], pts[1]["P"])
    E = c[1] + _R(phi[1], pts[1]["E"])
    c[2] = B - _R(phi[2], pts[2]["B"])
    c[3] = E - _R(phi[3], pts[3]["E"])
    c[4] = A - _R(phi[4], pts[4]["A"])
    c[5] = E - _R(phi[5], pts[5]["E"])
    c[6] = A - _R(phi[6], pts[6]["A"])
    return np.array(c), phi


def build(mom=DATA["mom"], c0=DATA["c0"], l0=DATA["l0"]):
    """Andrews' mechanism built from femb elements.

    Parameters
    ----------
    mom : float
        Driving torque on body 1 (N m).
    c0 : float
        Spring stiffness (N/m).
    l0 : float
        Spring unstretched length (m).

    Returns
    -------
    Mechanism
        Bodies ``b1`` … ``b7``; hinges ``O``, ``P``, ``E23``, ``E24``, ``E26``,
        ``B``, ``A5``, ``F``, ``A7``, ``G``; spring ``spring``; torque ``drive``.
    """
    D = DATA
    mech = Mechanism("andrews")
    g = mech.ground
    g.add_point("O", (0.0, 0.0))
    g.add_point("A", (D["xa"], D["ya"]))
    g.add_point("B", (D["xb"], D["yb"]))
    g.add_point("C", (D["xc"], D["yc"]))
    centres, phi = initial_centres()
    pts = body_points()
    b = [mech.add(RigidBody(f"b{k + 1}", D["m"][k], D["i"][k], centres[k], phi[k], points=pts[k]))
         for k in range(7)]
    mech.add(
        Hinge("O", g, b[0], point_a="O", point_b="O"),
        Hinge("P", b[0], b[1], point_a="P", point_b="P"),
        Hinge("E23", b[1], b[2], point_a="E", point_b="E"),
        Hinge("E24", b[1], b[3], point_a="E", point_b="E"),
        Hinge("E26", b[1], b[5], point_a="E", point_b="E"),
        Hinge("B", g, b[2], point_a="B", point_b="B"),
        Hinge("A5", g, b[4], point_a="A", point_b="A"),
        Hinge("F", b[3], b[4], point_a="F", point_b="F"),
        Hinge("A7", g, b[6], point_a="A", point_b="A"),
        Hinge("G", b[5], b[6], point_a="G", point_b="G"),
        SpringDamper("spring", b[2], g, stiffness=c0, length=l0, point_a="D", point_b="C"),
        Torque("drive", b[0], mom),
    )
    return mech


def angles(result):
    """Hairer's relative angles over time, shape (nt, 7)."""
    phi = np.stack([result.body(f"b{k}")[:, 2] for k in range(1, 8)], axis=1)
    return relative_angles(phi)


def rates(result):
    """Rates of Hairer's relative angles over time, shape (nt, 7)."""
    w = np.stack([result.body(f"b{k}", "qd")[:, 2] for k in range(1, 8)], axis=1)
    return relative_angles(w)


def outputs(result):
    """Named outputs over the stored time steps.

    Parameters
    ----------
    result : femb.Result
        A run of :func:`build`'s mechanism.

    Returns
    -------
    dict of str to ndarray, each of shape (nt,)
        The seven angles (rad), their rates (``_d``) and accelerations
        (``_dd``); ``xP, yP, xP_dd, yP_dd`` for the hinge P; ``lambda_1`` …
        ``lambda_6`` (N) in the published order and sign convention.
    """
    phi = np.stack([result.body(f"b{k}") for k in range(1, 8)], axis=1)        # (nt, 7, 3)
    qd = np.stack([result.body(f"b{k}", "qd") for k in range(1, 8)], axis=1)
    qdd = np.stack([result.body(f"b{k}", "qdd") for k in range(1, 8)], axis=1)
    out = {}
    for what, arr in (("", phi), ("_d", qd), ("_dd", qdd)):
        rel = relative_angles(arr[:, :, 2])
        for k, name in enumerate(ANGLE_NAMES):
            out[name + what] = rel[:, k]
    # hinge P on the crank: r = x + R(φ) s, r̈ = ẍ + R(φ)(φ̈ J s − φ̇² s)
    sP = body_points()[0]["P"]
    th, w, al = phi[:, 0, 2], qd[:, 0, 2], qdd[:, 0, 2]
    c, sn = np.cos(th), np.sin(th)
    dx, dy = c * sP[0] - sn * sP[1], sn * sP[0] + c * sP[1]      # R(φ) s
    out["xP"] = phi[:, 0, 0] + dx
    out["yP"] = phi[:, 0, 1] + dy
    out["xP_dd"] = qdd[:, 0, 0] - al * dy - w * w * dx
    out["yP_dd"] = qdd[:, 0, 1] + al * dx - w * w * dy
    lam = np.concatenate([result.reaction(name) for name in E_HINGES], axis=1)
    for k, name in enumerate(LAMBDA_NAMES):
        out[name] = lam[:, k]
    return out


def energy(result, mom=DATA["mom"], c0=DATA["c0"], l0=DATA["l0"]):
    """Energy integral T + V − mom·β from femb's absolute coordinates.

    Constant along exact solutions (the torque is constant, nothing dissipates);
    computed from the bodies' centre velocities and rotation rates and from the
    spring's end points, independently of any relative-coordinate formula.

    Parameters
    ----------
    result : femb.Result
    mom, c0, l0 : float
        Torque, spring stiffness and length given to :func:`build`.

    Returns
    -------
    ndarray, shape (nt,)
        Energy integral (J) at every stored step.
    """
    D = DATA
    kin = np.zeros(result.t.size)
    for k in range(7):
        v = result.body(f"b{k + 1}", "qd")
        kin += 0.5 * (D["m"][k] * (v[:, 0] ** 2 + v[:, 1] ** 2) + D["i"][k] * v[:, 2] ** 2)
    d = result.position("b3", "D") - np.array([D["xc"], D["yc"]])
    pot = 0.5 * c0 * (np.hypot(d[:, 0], d[:, 1]) - l0) ** 2
    beta = result.body("b1")[:, 2]
    return kin + pot - mom * beta


def published():
    """The published reference solution at t = 0.03 s, by output name.

    Source: IVP test set (Mazzia & Magherini), problem ``andrews``, PSIDE at
    rtol = atol = 1e-14 (docs/benchmarks.md §2); accurate to about 3e-10
    relative in the angles, 5e-8 in the rates, 1e-6 in the multipliers.

    Returns
    -------
    dict of str to float
        ``t``, the seven angles, their rates (``_d``) and accelerations
        (``_dd``), and ``lambda_1`` … ``lambda_6``.
    """
    from femb.benchmarks.references.andrews import PUBLISHED_T003 as P

    out = {"t": float(P["t"])}
    for k, name in enumerate(ANGLE_NAMES):
        out[name] = float(P["angles"][k])
        out[name + "_d"] = float(P["rates"][k])
        out[name + "_dd"] = float(P["accelerations"][k])
    for k, name in enumerate(LAMBDA_NAMES):
        out[name] = float(P["lam"][k])
    return out


def reference(t, mom=DATA["mom"], c0=DATA["c0"], l0=DATA["l0"]):
    """Independent reference solution at times ``t``.

    The relative-coordinate model of Hairer & Wanner
    (:mod:`femb.benchmarks.references.andrews`), index-1 form integrated with
    scipy's DOP853 at rtol = atol = 1e-12, gives every output; at t = 0.03 s
    the angles and rates are replaced by the published IVP-test-set values
    (as in the seed: "a reference solution is given for the body angles at
    final time"), while the multipliers stay those of the tight-tolerance run
    (the published ones are only good to about 1e-6).

    Parameters
    ----------
    t : array_like, shape (nt,)
        Output times (s) in [0, 0.03] or beyond.
    mom, c0, l0 : float
        Must be the published values (the reference has no other data).

    Returns
    -------
    dict
        Angle, rate, acceleration and multiplier names of :func:`outputs`
        mapped to arrays (nt,), plus ``"description"`` (str).
    """
    from femb.benchmarks.references import andrews as ref

    if (mom, c0, l0) != (DATA["mom"], DATA["c0"], DATA["l0"]):
        raise ValueError("andrews.reference: the reference exists only for the published data "
                         "(mom = 0.033, c0 = 4530, l0 = 0.07785)")
    t = np.atleast_1d(np.asarray(t, dtype=float))
    sol = ref.solve(t, rtol=1e-12, atol=1e-12, cache=True)
    out = {}
    for k, name in enumerate(ANGLE_NAMES):
        out[name] = sol["angles"][:, k].copy()
        out[name + "_d"] = sol["rates"][:, k].copy()
        out[name + "_dd"] = sol["accelerations"][:, k].copy()
    for k, name in enumerate(LAMBDA_NAMES):
        out[name] = sol["lam"][:, k].copy()
    desc = ("relative coordinates (Hairer & Wanner VII.7), index-1 form, scipy solve_ivp DOP853 "
            "at rtol = atol = 1e-12 (femb.benchmarks.references.andrews)")
    pub = published()
    at = np.nonzero(np.abs(t - pub["t"]) <= 1e-12)[0]
    if at.size:
        for name in ANGLE_NAMES:
            out[name][at] = pub[name]
            out[name + "_d"][at] = pub[name + "_d"]
        desc = ("angles and rates at t = 0.03 s: published IVP test set values (Mazzia & Magherini, "
                "problem andrews, PSIDE at rtol = atol = 1e-14); multipliers (and all values at other "
                "times): " + desc)
    out["description"] = desc
    return out
