"""Four-bar linkage driven at constant crank rate: the multiplier of the driver is the driving torque.

Crank (0.4 m, 1 kg), coupler (1.0 m, 2 kg), rocker (0.8 m, 1.5 kg), ground
pivots 0.9 m apart, uniform bars, gravity 9.81 m/s² along −y. A
:class:`~femb.elements.DrivenAngle` turns the crank at 3 rad/s from 70°, so the
motion starts with velocity: the driving torque (a multiplier) shows the same
O(h) start-up transient as the double pendulum's reactions (stepsize.md §2).

Outputs (:func:`outputs`)
-------------------------
``theta1``, ``theta3`` (rad, crank and rocker from the x axis), ``theta3_d``
(rad/s), ``T_drive`` (N m, torque of the driver on the crank, = −λ of
``drive``), ``R_O_x``, ``R_O_y`` (N, force of the ground on the crank).

References
----------
Independent reference: :mod:`femb.benchmarks.references.fourbar_driven`
(closed-form kinematics, Newton–Euler forces).
"""
from __future__ import annotations

import math

import numpy as np

from femb import Mechanism
from femb.base.functions import Linear
from femb.elements import DrivenAngle, Gravity, Hinge, RigidBody

from femb.benchmarks.references.fourbar_driven import PARAMS, state

DEFAULTS = {"t_end": 2.0, "h": 1e-3, "rho_inf": 0.8}

PARAMETERS = {
    "l1": ("crank length", "m"), "l2": ("coupler length", "m"), "l3": ("rocker length", "m"),
    "l4": ("ground length (hinge C at (l4, 0))", "m"),
    "m1": ("crank mass (uniform bar)", "kg"), "m2": ("coupler mass", "kg"), "m3": ("rocker mass", "kg"),
    "g": ("gravity along −y", "m/s^2"),
    "theta1": ("initial crank angle from the x axis", "rad"),
    "omega": ("constant crank rate", "rad/s"),
}

OUTPUTS = {
    "theta1": ("crank angle from the x axis", "rad"),
    "theta3": ("rocker angle from the x axis (unwrapped)", "rad"),
    "theta3_d": ("rocker angular velocity", "rad/s"),
    "T_drive": ("driving torque on the crank", "N m"),
    "R_O_x": ("x force of the ground hinge O on the crank", "N"),
    "R_O_y": ("y force of the ground hinge O on the crank", "N"),
}

#: The start-up study. The angles are exact to round-off at every step (the driven loop has
#: no degree of freedom and Φ = 0 is solved exactly), so the rocker rate stands for "q".
CONVERGENCE = {"t_end": 0.3, "h": [8e-3, 4e-3, 2e-3, 1e-3, 5e-4], "q": ["theta3_d"],
               "lambda": ["T_drive", "R_O_x", "R_O_y"]}


def build(l1=PARAMS["l1"], l2=PARAMS["l2"], l3=PARAMS["l3"], l4=PARAMS["l4"], m1=PARAMS["m1"],
          m2=PARAMS["m2"], m3=PARAMS["m3"], g=PARAMS["g"], theta1=PARAMS["theta1"], omega=PARAMS["omega"]):
    """The driven four-bar from femb elements.

    Parameters
    ----------
    l1, l2, l3, l4 : float
        Crank, coupler, rocker, ground lengths (m).
    m1, m2, m3 : float
        Bar masses (kg); uniform bars.
    g : float
        Gravity along −y (m/s²).
    theta1 : float
        Initial crank angle from the x axis (rad).
    omega : float
        Constant crank rate (rad/s).

    Returns
    -------
    Mechanism
        Bodies ``crank``, ``coupler``, ``rocker``; hinges ``O``, ``A``, ``B``,
        ``C``; driver ``drive``; ``gravity``.
    """
    kw = dict(l1=l1, l2=l2, l3=l3, l4=l4, m1=m1, m2=m2, m3=m3, g=g, theta1=theta1, omega=omega)
    s = state(0.0, **kw)              # consistent angles and rates at t = 0 (closed form)
    th, w, c = s["theta"], s["omega"], s["centres"]
    vA = l1 * w[0] * np.array([-math.sin(th[0]), math.cos(th[0])])
    n2 = np.array([-math.sin(th[1]), math.cos(th[1])])
    n3 = np.array([-math.sin(th[2]), math.cos(th[2])])
    vel = [0.5 * vA, vA + 0.5 * l2 * w[1] * n2, 0.5 * l3 * w[2] * n3]
    mech = Mechanism("fourbar_driven")
    mech.ground.add_point("C", (l4, 0.0))
    bodies = []
    for k, (name, L, m) in enumerate((("crank", l1, m1), ("coupler", l2, m2), ("rocker", l3, m3))):
        bodies.append(mech.add(RigidBody(name, m, m * L ** 2 / 12.0, c[k], th[k], velocity=vel[k], omega=w[k],
                                         points={"s": (-0.5 * L, 0.0), "e": (0.5 * L, 0.0)},
                                         shape={"type": "bar", "width": 0.03})))
    crank, coupler, rocker = bodies
    mech.add(Hinge("O", mech.ground, crank, point_b="s"),
             Hinge("A", crank, coupler, point_a="e", point_b="s"),
             Hinge("B", coupler, rocker, point_a="e", point_b="e"),
             Hinge("C", mech.ground, rocker, point_a="C", point_b="s"),
             DrivenAngle("drive", mech.ground, crank, Linear(omega)),
             Gravity((0.0, -g)))
    return mech


def outputs(result):
    """Crank and rocker angles, rocker rate, driving torque, ground force on the crank (arrays (nt,))."""
    R = result.reaction("O")
    return {"theta1": result.body("crank")[:, 2], "theta3": np.unwrap(result.body("rocker")[:, 2]),
            "theta3_d": result.body("rocker", "qd")[:, 2], "T_drive": -result.reaction("drive")[:, 0],
            "R_O_x": R[:, 0], "R_O_y": R[:, 1]}


def reference(t, **params):
    """Independent reference at times ``t`` (names of :func:`outputs` plus ``"description"``)."""
    from femb.benchmarks.references.fourbar_driven import solve

    s = solve(t, **params)
    return {"theta1": s["theta"][:, 0], "theta3": np.unwrap(s["theta"][:, 2]), "theta3_d": s["omega"][:, 2],
            "T_drive": s["tau"], "R_O_x": s["R_O"][:, 0], "R_O_y": s["R_O"][:, 1],
            "description": ("closed-form kinematics of the driven loop and Newton–Euler forces "
                            "(femb.benchmarks.references.fourbar_driven)")}
