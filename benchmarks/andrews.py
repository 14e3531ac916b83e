"""Andrews' squeezing mechanism from femb elements (seed paper, Sect. 5.2).

Seven rigid bodies, ten hinges, one spring and one torque; planar, no gravity;
21 absolute coordinates, 20 constraints, one degree of freedom.
Data: Hairer & Wanner, Solving ODEs II, Sect. VII.7, as in the IVP test set
(Mazzia & Magherini, problem ``andrews``); see docs/benchmarks data.

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
