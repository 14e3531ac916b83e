"""Isosceles slider–crank (crank = rod length) passing through its singular position.

With equal crank and rod lengths l the slider position is x3 = 2 l cos θ and,
at θ = π/2 (mod π), the slider sits on the crank pivot: the crank and the rod
overlap, a second branch of configurations (slider fixed at the pivot, crank
and rod turning together) crosses the first one, and the constraint Jacobian
loses rank. A crank set turning with no load carries the mechanism through
that point; the physical motion stays on the smooth branch x3 = 2 l cos θ
(leaving it would stop the slider instantly, with an infinite force). The
benchmark suite uses the scene to stress the solver through the singular
position and when started exactly at it.

No gravity, no load: the energy ½ m(θ) θ̇² is conserved, so θ̇ = ω₀ √(m(θ₀)/m(θ))
with the generalized mass (minimal coordinate θ, rod angle −θ)

    m(θ) = m1 l²/3 + m2 l² (9/4 sin²θ + 1/4 cos²θ) + m2 l²/12 + 4 m3 l² sin²θ,

which :func:`reference` integrates with scipy (independent of femb).

Outputs (:func:`outputs`)
-------------------------
``theta`` (rad), ``theta_d`` (rad/s), ``x3`` (m), ``x3_d`` (m/s) and
``branch`` = x3 − 2 l cos θ (m), zero on the physical branch.

References
----------
E. Bayo, R. Ledesma, Augmented Lagrangian and mass-orthogonal projection
methods for constrained multibody dynamics, Nonlinear Dynamics 9 (1996)
113–130 (slider–crank through singular positions as a test of index-3 solvers).
"""
from __future__ import annotations

import math

import numpy as np

from femb import Mechanism
from femb.elements import Hinge, PointMass, PointOnLine, RigidBody

#: Scene data (SI units).
PARAMS = {"l": 0.3, "m1": 0.36, "m2": 0.36, "m3": 0.1, "theta0": 0.0, "omega0": 2 * math.pi}

#: One second from θ = 0 at 1 rev/s: the crank passes the singular position θ = π/2 once.
DEFAULTS = {"t_end": 1.0, "h": 1e-3, "rho_inf": 0.7}

#: Parameters of :func:`build`: name -> (meaning, unit), shown by ``femb list``.
PARAMETERS = {
    "l": ("crank and rod length", "m"),
    "m1": ("crank mass (uniform bar)", "kg"),
    "m2": ("rod mass (uniform bar)", "kg"),
    "m3": ("slider mass", "kg"),
    "theta0": ("initial crank angle (pi/2 is the singular position)", "rad"),
    "omega0": ("initial crank rate", "rad/s"),
}

#: Outputs of :func:`outputs`: name -> (meaning, unit), shown by ``femb list``.
OUTPUTS = {
    "theta": ("crank angle", "rad"),
    "theta_d": ("crank rate", "rad/s"),
    "x3": ("slider position", "m"),
    "x3_d": ("slider velocity", "m/s"),
    "branch": ("x3 - 2 l cos(theta), zero on the physical branch", "m"),
}

CONVERGENCE = {"t_end": 1.0, "h": [4e-3, 2e-3, 1e-3, 5e-4], "q": ["theta"], "lambda": []}


def build(l=PARAMS["l"], m1=PARAMS["m1"], m2=PARAMS["m2"], m3=PARAMS["m3"], theta0=PARAMS["theta0"],
          omega0=PARAMS["omega0"]):
    """The isosceles slider–crank from femb elements, set turning at ω₀.

    Parameters
    ----------
    l : float
        Crank and rod length (m).
    m1, m2 : float
        Crank and rod masses (kg), uniform bars.
    m3 : float
        Slider mass (kg).
    theta0 : float
        Initial crank angle (rad); π/2 is the singular position.
    omega0 : float
        Initial crank rate (rad/s); the other velocities follow on the branch
        x3 = 2 l cos θ.

    Returns
    -------
    Mechanism
        Bodies ``crank``, ``rod``, ``slider``; joints ``pivot``, ``crank_rod``,
        ``rod_slider``, ``guide``.
    """
    c, s = math.cos(theta0), math.sin(theta0)
    w = omega0
    tip = np.array([l * c, l * s])
    slider_pos = np.array([2.0 * l * c, 0.0])
    mech = Mechanism("singular_slider_crank")
    g = mech.ground
    g.add_point("O", (0.0, 0.0))
    crank = mech.add(RigidBody("crank", m1, m1 * l * l / 12.0, 0.5 * tip, theta0,
                               velocity=(-0.5 * l * s * w, 0.5 * l * c * w), omega=w,
                               points={"O": (-0.5 * l, 0.0), "A": (0.5 * l, 0.0)},
                               shape={"type": "bar", "width": 0.02}))
    rod = mech.add(RigidBody("rod", m2, m2 * l * l / 12.0, 0.5 * (tip + slider_pos), -theta0,
                             velocity=(-1.5 * l * s * w, 0.5 * l * c * w), omega=-w,
                             points={"A": (-0.5 * l, 0.0), "B": (0.5 * l, 0.0)},
                             shape={"type": "bar", "width": 0.015}))
    slider = mech.add(PointMass("slider", m3, slider_pos, velocity=(-2.0 * l * s * w, 0.0),
                                shape={"type": "box", "size": (0.06, 0.04)}))
    mech.add(
        Hinge("pivot", g, crank, point_a="O", point_b="O"),
        Hinge("crank_rod", crank, rod, point_a="A", point_b="A"),
        Hinge("rod_slider", rod, slider, point_a="B"),
        PointOnLine("guide", g, slider, axis=(1.0, 0.0), at=(float(slider_pos[0]), 0.0)),
    )
    return mech


def outputs(result, l=PARAMS["l"]):
    """Named outputs over the stored steps (see the module docstring)."""
    crank, crank_d = result.body("crank"), result.body("crank", "qd")
    slider, slider_d = result.body("slider"), result.body("slider", "qd")
    th = crank[:, 2]
    return {"theta": th, "theta_d": crank_d[:, 2], "x3": slider[:, 0], "x3_d": slider_d[:, 0],
            "branch": slider[:, 0] - 2.0 * l * np.cos(th)}


def generalized_mass(theta, l=PARAMS["l"], m1=PARAMS["m1"], m2=PARAMS["m2"], m3=PARAMS["m3"]):
    """m(θ) of the minimal-coordinate model (kg m²)."""
    s2 = np.sin(theta) ** 2
    return (m1 * l * l / 3.0 + m2 * l * l * (2.25 * s2 + 0.25 * (1.0 - s2)) + m2 * l * l / 12.0
            + 4.0 * m3 * l * l * s2)


def reference(t, l=PARAMS["l"], m1=PARAMS["m1"], m2=PARAMS["m2"], m3=PARAMS["m3"],
              theta0=PARAMS["theta0"], omega0=PARAMS["omega0"]):
    """Minimal-coordinate reference from the energy integral.

    θ̇ = ω₀ √(m(θ₀)/m(θ)) integrated with scipy's DOP853 at rtol = atol = 1e-13.

    Returns
    -------
    dict
        The names of :func:`outputs` mapped to arrays (nt,), plus ``"description"``.
    """
    from scipy.integrate import solve_ivp

    t = np.atleast_1d(np.asarray(t, dtype=float))
    m0 = generalized_mass(theta0, l, m1, m2, m3)

    def rate(th):
        return omega0 * np.sqrt(m0 / generalized_mass(th, l, m1, m2, m3))

    if t[-1] > 0.0:
        sol = solve_ivp(lambda _t, y: [rate(y[0])], (0.0, float(t[-1])), [theta0], method="DOP853",
                        t_eval=t, rtol=1e-13, atol=1e-13)
        if not sol.success:
            raise RuntimeError(f"singular_slider_crank.reference: {sol.message}")
        th = sol.y[0]
    else:
        th = np.full(t.shape, float(theta0))
    th_d = rate(th)
    return {"theta": th, "theta_d": th_d, "x3": 2.0 * l * np.cos(th), "x3_d": -2.0 * l * np.sin(th) * th_d,
            "branch": np.zeros_like(th),
            "description": "minimal coordinate θ from the energy integral, scipy DOP853 at rtol = atol = 1e-13"}
