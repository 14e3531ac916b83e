"""Double pendulum of two uniform bars released with ω₁ = 3 rad/s: start-up transient of the reactions.

Two uniform bars (1 m, 1 kg each) hang from a ground hinge, the first at
0.3 rad from the downward vertical, the second straight down; the first bar is
given ω₁ = 3 rad/s, the second none. Gravity 9.81 m/s² along −y. The motion
starts with a velocity, which is what exposes the O(h) start-up transient of
λ with an inexact normal velocity (stepsize.md §2): the peak
ground-hinge reaction error over [0, 0.3] s is the measured quantity.

Angles are absolute, from the x axis (hanging straight down is −π/2).

Outputs (:func:`outputs`)
-------------------------
``phi1``, ``phi2`` (rad), ``phi1_d``, ``phi2_d`` (rad/s), ``R_pivot_x``,
``R_pivot_y`` (N): the force of the ground on bar 1 at the pivot (the
multipliers of hinge ``pivot``).

References
----------
Independent reference: :mod:`femb.benchmarks.references.planar_chain`
(minimal coordinates, DOP853 at rtol = atol = 1e-12, reactions by
Newton–Euler at the integrated state).
"""
from __future__ import annotations

import math

from femb import Mechanism
from femb.elements import Gravity

from femb.benchmarks.scenes.planar.chains import (
    add_chain, chain_output_info, chain_outputs, reference_outputs)

#: Scene data (SI units).
PARAMS = {"length": 1.0, "mass": 1.0, "g": 9.81, "theta1": 0.3, "theta2": 0.0, "omega1": 3.0, "omega2": 0.0}

#: A 2 s run at h = 1e-3 s, ρ∞ = 0.8.
DEFAULTS = {"t_end": 2.0, "h": 1e-3, "rho_inf": 0.8}

PARAMETERS = {
    "length": ("length of each uniform bar", "m"),
    "mass": ("mass of each bar (J = m l²/12)", "kg"),
    "g": ("gravity along −y", "m/s^2"),
    "theta1": ("initial angle of bar1 from the downward vertical", "rad"),
    "theta2": ("initial angle of bar2 from the downward vertical", "rad"),
    "omega1": ("initial angular velocity of bar1", "rad/s"),
    "omega2": ("initial angular velocity of bar2", "rad/s"),
}

OUTPUTS = chain_output_info(2)

#: The start-up study: angles and ground-hinge reaction over [0, 0.3] s.
CONVERGENCE = {"t_end": 0.3, "h": [8e-3, 4e-3, 2e-3, 1e-3, 5e-4], "q": ["phi1", "phi2"],
               "lambda": ["R_pivot_x", "R_pivot_y"]}


def _data(length, mass, theta1, theta2, omega1, omega2):
    L = [length, length]
    return dict(lengths=L, masses=[mass, mass], inertias=[mass * length ** 2 / 12.0] * 2,
                com=[0.5 * length] * 2, phi0=[theta1 - math.pi / 2, theta2 - math.pi / 2],
                phid0=[omega1, omega2])


def build(length=PARAMS["length"], mass=PARAMS["mass"], g=PARAMS["g"], theta1=PARAMS["theta1"],
          theta2=PARAMS["theta2"], omega1=PARAMS["omega1"], omega2=PARAMS["omega2"]):
    """The double pendulum built from femb elements.

    Parameters
    ----------
    length, mass : float
        Length (m) and mass (kg) of each uniform bar, J = m l²/12.
    g : float
        Gravity along −y (m/s²).
    theta1, theta2 : float
        Initial angles of the bars from the downward vertical (rad).
    omega1, omega2 : float
        Initial angular velocities (rad/s).

    Returns
    -------
    Mechanism
        Bodies ``bar1``, ``bar2``; hinges ``pivot`` (ground–bar1), ``hinge1``; ``gravity``.
    """
    if not (length > 0.0 and mass > 0.0):
        raise ValueError(f"double_pendulum: length and mass must be positive, got {length!r}, {mass!r}")
    mech = Mechanism("double_pendulum")
    add_chain(mech, **_data(length, mass, theta1, theta2, omega1, omega2))
    mech.add(Gravity((0.0, -g)))
    return mech


def outputs(result):
    """Angles, rates and the ground-hinge force (dict of arrays (nt,))."""
    return chain_outputs(result, 2)


def reference(t, length=PARAMS["length"], mass=PARAMS["mass"], g=PARAMS["g"], theta1=PARAMS["theta1"],
              theta2=PARAMS["theta2"], omega1=PARAMS["omega1"], omega2=PARAMS["omega2"]):
    """Independent reference at times ``t`` (names of :func:`outputs` plus ``"description"``)."""
    from femb.benchmarks.references.planar_chain import Chain, solve

    d = _data(length, mass, theta1, theta2, omega1, omega2)
    chain = Chain(d["masses"], d["inertias"], d["lengths"], d["com"], g=(0.0, -g))
    out = reference_outputs(solve(chain, t, d["phi0"], d["phid0"], key="double_pendulum"), 2)
    out["description"] = ("minimal coordinates (two absolute angles), Lagrange's equations, scipy solve_ivp "
                          "DOP853 at rtol = atol = 1e-12; reaction by Newton–Euler "
                          "(femb.benchmarks.references.planar_chain)")
    return out
