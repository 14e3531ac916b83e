"""Slider–crank with a spring–mass system, from femb elements (seed paper, Sect. 5.1).

Planar, no gravity, two degrees of freedom (crank angle θ and position x4 of
the extra mass). The mechanism is assembled from femb's element library only:

* ``crank``: :class:`~femb.elements.RigidBody`, uniform bar of length l1,
  pinned to the ground at the origin by the :class:`~femb.elements.Hinge`
  ``pivot`` (ground = body a, crank = body b);
* ``rod``: uniform bar of length l2, pinned to the crank tip (hinge ``crank_rod``)
  and to the slider (hinge ``rod_slider``);
* ``slider`` and ``mass``: :class:`~femb.elements.PointMass` held on the x axis
  by :class:`~femb.elements.PointOnLine` joints ``guide_slider``, ``guide_mass``;
* ``spring``: :class:`~femb.elements.SpringDamper` slider → mass,
  unstretched length 0.2 m (undeformed at t = 0);
* ``torque``: :class:`~femb.elements.Torque` of 1 N m on the crank.

10 free coordinates, 8 constraints (the seed's model also has 10 and 8, with
a different choice of coordinates).

Data (docs/benchmarks.md §1): l1 = 0.3 m, m1 = 0.36 kg, l2 = 0.6 m,
m2 = 0.15 kg, m3 = 0.1 kg, m4 = 0.7 kg, k = 1000 N/m, T = 1 N m, θ(0) = π/2,
at rest; bodies are uniform slender bars, J = m l²/12.

Outputs (:func:`outputs`)
-------------------------
``theta`` (rad), ``x3``, ``x4`` (m), their rates ``theta_d``, ``x3_d``,
``x4_d``, and ``R_pivot_x``, ``R_pivot_y`` (N): the force of the ground on the
crank at the pivot (the multipliers of hinge ``pivot``; same convention as
``R_pivot`` of the minimal-coordinate reference).

References
----------
M. Arnold, O. Brüls, Convergence of the generalized-α scheme for constrained
mechanical systems, Multibody Syst. Dyn. 18 (2007) 185–202, Sect. 5.1, Figs. 1–3.
"""
from __future__ import annotations

import math

import numpy as np

from femb import Mechanism
from femb.elements import Hinge, PointMass, PointOnLine, RigidBody, SpringDamper, Torque

#: Run settings of the seed's plots: t ∈ [0, 1] s, h = 5e-3 s, ρ∞ = 0.7 (Sect. 5.1, Fig. 2).
DEFAULTS = {"t_end": 1.0, "h": 5e-3, "rho_inf": 0.7}

#: Parameters of :func:`build`: name -> (meaning, unit), shown by ``femb list``.
PARAMETERS = {
    "l1": ("crank length", "m"),
    "m1": ("crank mass (uniform bar)", "kg"),
    "l2": ("connecting-rod length (> l1)", "m"),
    "m2": ("connecting-rod mass (uniform bar)", "kg"),
    "m3": ("slider mass", "kg"),
    "m4": ("mass of the extra body on the spring", "kg"),
    "k": ("spring stiffness between slider and extra mass", "N/m"),
    "L0": ("spring length, undeformed at t = 0", "m"),
    "T": ("constant torque on the crank", "N m"),
    "theta0": ("initial crank angle (start at rest)", "rad"),
}

#: Outputs of :func:`outputs`: name -> (meaning, unit), shown by ``femb list``.
OUTPUTS = {
    "theta": ("crank angle", "rad"),
    "x3": ("slider position", "m"),
    "x4": ("position of the extra mass", "m"),
    "theta_d": ("crank rate", "rad/s"),
    "x3_d": ("slider velocity", "m/s"),
    "x4_d": ("velocity of the extra mass", "m/s"),
    "R_pivot_x": ("x force of the ground on the crank at the pivot", "N"),
    "R_pivot_y": ("y force of the ground on the crank at the pivot", "N"),
}

#: The h-convergence study (Fig. 3 of the seed): θ and the pivot reaction at t = 1 s.
CONVERGENCE = {
    "t_end": 1.0,
    "h": [4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4],
    "q": ["theta"],
    "lambda": ["R_pivot_x", "R_pivot_y"],
}

#: Model data, docs/benchmarks.md §1 (SI units).
PARAMS = {"l1": 0.3, "m1": 0.36, "l2": 0.6, "m2": 0.15, "m3": 0.1, "m4": 0.7,
          "k": 1000.0, "L0": 0.2, "T": 1.0, "theta0": math.pi / 2}


def build(l1=PARAMS["l1"], m1=PARAMS["m1"], l2=PARAMS["l2"], m2=PARAMS["m2"], m3=PARAMS["m3"],
          m4=PARAMS["m4"], k=PARAMS["k"], L0=PARAMS["L0"], T=PARAMS["T"], theta0=PARAMS["theta0"]):
    """The slider–crank with spring–mass system built from femb elements.

    Parameters
    ----------
    l1, m1 : float
        Crank length (m) and mass (kg); J1 = m1 l1²/12.
    l2, m2 : float
        Connecting-rod length (m) and mass (kg); J2 = m2 l2²/12; l2 > l1.
    m3, m4 : float
        Slider and extra mass (kg).
    k : float
        Spring stiffness (N/m).
    L0 : float
        Spring length (m); the spring is undeformed at t = 0.
    T : float
        Constant torque on the crank (N m).
    theta0 : float
        Initial crank angle (rad); the mechanism starts at rest.

    Returns
    -------
    Mechanism
        Bodies ``crank``, ``rod``, ``slider``, ``mass``; joints ``pivot``,
        ``crank_rod``, ``rod_slider``, ``guide_slider``, ``guide_mass``;
        ``spring``; ``torque``.
    """
    if not l2 > l1 > 0.0:
        raise ValueError(f"slider_crank: need l2 > l1 > 0, got l1 = {l1!r}, l2 = {l2!r}")
    c, s = math.cos(theta0), math.sin(theta0)
    tip = np.array([l1 * c, l1 * s])
    x3 = l1 * c + math.sqrt(l2 ** 2 - (l1 * s) ** 2)
    slider_pos = np.array([x3, 0.0])
    phi2 = math.atan2(slider_pos[1] - tip[1], slider_pos[0] - tip[0])

    mech = Mechanism("slider_crank")
    g = mech.ground
    g.add_point("O", (0.0, 0.0))
    crank = mech.add(RigidBody("crank", m1, m1 * l1 ** 2 / 12.0, 0.5 * tip, theta0,
                               points={"O": (-0.5 * l1, 0.0), "A": (0.5 * l1, 0.0)},
                               shape={"type": "bar", "width": 0.02}))
    rod = mech.add(RigidBody("rod", m2, m2 * l2 ** 2 / 12.0, 0.5 * (tip + slider_pos), phi2,
                             points={"A": (-0.5 * l2, 0.0), "B": (0.5 * l2, 0.0)},
                             shape={"type": "bar", "width": 0.015}))
    slider = mech.add(PointMass("slider", m3, slider_pos, shape={"type": "box", "size": (0.06, 0.04)}))
    mass = mech.add(PointMass("mass", m4, (x3 + L0, 0.0), shape={"type": "box", "size": (0.08, 0.06)}))
    mech.add(
        Hinge("pivot", g, crank, point_a="O", point_b="O"),
        Hinge("crank_rod", crank, rod, point_a="A", point_b="A"),
        Hinge("rod_slider", rod, slider, point_a="B"),
        PointOnLine("guide_slider", g, slider, axis=(1.0, 0.0), at=(x3, 0.0)),
        PointOnLine("guide_mass", g, mass, axis=(1.0, 0.0), at=(x3 + L0, 0.0)),
        SpringDamper("spring", slider, mass, stiffness=k, length=L0),
        Torque("torque", crank, T),
    )
    return mech


def outputs(result):
    """Named outputs over the stored time steps.

    Parameters
    ----------
    result : femb.Result
        A run of :func:`build`'s mechanism.

    Returns
    -------
    dict of str to ndarray, each of shape (nt,)
        ``theta``, ``x3``, ``x4`` and rates ``theta_d``, ``x3_d``, ``x4_d``;
        ``R_pivot_x``, ``R_pivot_y``: force of the ground on the crank (N).
    """
    crank, crank_d = result.body("crank"), result.body("crank", "qd")
    slider, slider_d = result.body("slider"), result.body("slider", "qd")
    mass, mass_d = result.body("mass"), result.body("mass", "qd")
    R = result.reaction("pivot")          # force of the hinge on body b = crank
    return {
        "theta": crank[:, 2], "x3": slider[:, 0], "x4": mass[:, 0],
        "theta_d": crank_d[:, 2], "x3_d": slider_d[:, 0], "x4_d": mass_d[:, 0],
        "R_pivot_x": R[:, 0], "R_pivot_y": R[:, 1],
    }


def reference(t, **params):
    """Independent reference: minimal coordinates (θ, x4), Lagrange's equations.

    Integrated with :func:`scipy.integrate.solve_ivp` (DOP853, rtol = atol = 1e-12)
    by :mod:`femb.benchmarks.references.slider_crank_minimal`.

    Parameters
    ----------
    t : array_like, shape (nt,)
        Output times (s).
    **params
        Keyword arguments of :func:`build` (same names as the reference's).

    Returns
    -------
    dict
        The names of :func:`outputs` mapped to arrays of shape (nt,), plus
        ``"description"`` (str).
    """
    from femb.benchmarks.references import slider_crank_minimal as ref

    sol = ref.solve(np.atleast_1d(np.asarray(t, dtype=float)), rtol=1e-12, atol=1e-12, cache=True, **params)
    return {
        "theta": sol["theta"], "x3": sol["x3"], "x4": sol["x4"],
        "theta_d": sol["theta_d"], "x3_d": sol["x3_d"], "x4_d": sol["x4_d"],
        "R_pivot_x": sol["R_pivot"][:, 0], "R_pivot_y": sol["R_pivot"][:, 1],
        "description": ("minimal coordinates (theta, x4), Lagrange's equations, "
                        "scipy solve_ivp DOP853 at rtol = atol = 1e-12 "
                        "(femb.benchmarks.references.slider_crank_minimal)"),
    }
