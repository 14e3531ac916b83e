"""Pendulum hit by a short Gaussian force pulse (W2 of the step-size study): a short input.

A uniform bar (1 m, 1 kg) hinged at one end, released at rest 0.5 rad from the
downward vertical under gravity; at t = 1 s a force perpendicular to the bar
(a follower force at its tip, positive counter-clockwise) acts as a Gaussian
pulse of standard deviation 0.01 s and impulse 2 N s; t ∈ [0, 3] s. A step
control must see the pulse (give h_max ≈ 0.02 s): stepsize.md §8, W2.

Outputs (:func:`outputs`)
-------------------------
``phi1`` (rad, from the x axis), ``phi1_d`` (rad/s), ``R_pivot_x``,
``R_pivot_y`` (N): force of the ground on the bar at the hinge.

References
----------
Independent reference: :mod:`femb.benchmarks.references.planar_chain`
(the pulse integrated with a step cap of 1e-3 s over [0.9, 1.1] s).
"""
from __future__ import annotations

import math

import numpy as np

from femb import Mechanism
from femb.elements import Force, Gravity

from femb.benchmarks.scenes.planar.chains import (
    add_chain, chain_output_info, chain_outputs, reference_outputs)

#: Scene data (SI units).
PARAMS = {"length": 1.0, "mass": 1.0, "g": 9.81, "theta0": 0.5, "t_pulse": 1.0, "width": 0.01,
          "impulse": 2.0}

DEFAULTS = {"t_end": 3.0, "h": 1e-3, "rho_inf": 0.9}

PARAMETERS = {
    "length": ("length of the uniform bar", "m"),
    "mass": ("mass of the bar", "kg"),
    "g": ("gravity along −y", "m/s^2"),
    "theta0": ("initial angle from the downward vertical, at rest", "rad"),
    "t_pulse": ("centre of the Gaussian force pulse", "s"),
    "width": ("standard deviation of the pulse", "s"),
    "impulse": ("impulse of the pulse", "N s"),
}

OUTPUTS = chain_output_info(1)

#: Largest step for an adaptive run (the pulse must be sampled), stepsize.md §8.
H_MAX = 0.02

CONVERGENCE = {"t_end": 3.0, "h": [4e-3, 2e-3, 1e-3, 5e-4], "q": ["phi1"],
               "lambda": ["R_pivot_x", "R_pivot_y"]}


def pulse(t_pulse=PARAMS["t_pulse"], width=PARAMS["width"], impulse=PARAMS["impulse"]):
    """The Gaussian pulse F(t) = I/(σ√(2π)) exp(−(t − t_p)²/(2σ²)) and its two derivatives.

    Returns
    -------
    (f, df, ddf) : tuple of callables float -> float
    """
    if not (width > 0.0):
        raise ValueError(f"force_pulse: width must be positive, got {width!r}")
    A = impulse / (width * math.sqrt(2.0 * math.pi))

    def f(t):
        return A * math.exp(-0.5 * ((t - t_pulse) / width) ** 2)

    def df(t):
        return -(t - t_pulse) / width ** 2 * f(t)

    def ddf(t):
        u = (t - t_pulse) / width
        return (u * u - 1.0) / width ** 2 * f(t)

    return f, df, ddf


def _data(length, mass, theta0):
    return dict(lengths=[length], masses=[mass], inertias=[mass * length ** 2 / 12.0],
                com=[0.5 * length], phi0=[theta0 - math.pi / 2], phid0=[0.0])


def build(length=PARAMS["length"], mass=PARAMS["mass"], g=PARAMS["g"], theta0=PARAMS["theta0"],
          t_pulse=PARAMS["t_pulse"], width=PARAMS["width"], impulse=PARAMS["impulse"]):
    """The pulsed pendulum from femb elements (body ``bar1``, hinge ``pivot``, force ``pulse``).

    Parameters
    ----------
    length, mass, g : float
        Uniform bar (m, kg), gravity along −y (m/s²).
    theta0 : float
        Initial angle from the downward vertical (rad), at rest.
    t_pulse, width, impulse : float
        Centre (s), standard deviation (s) and impulse (N s) of the Gaussian pulse.
    """
    if not (length > 0.0 and mass > 0.0):
        raise ValueError(f"force_pulse: length and mass must be positive, got {length!r}, {mass!r}")
    mech = Mechanism("force_pulse")
    (bar,) = add_chain(mech, **_data(length, mass, theta0))
    mech.add(Force("pulse", bar, (0.0, pulse(t_pulse, width, impulse)), point="E", frame="body"),
             Gravity((0.0, -g)))
    return mech


def outputs(result):
    """Angle, rate and the ground-hinge force (dict of arrays (nt,))."""
    return chain_outputs(result, 1)


def reference(t, length=PARAMS["length"], mass=PARAMS["mass"], g=PARAMS["g"], theta0=PARAMS["theta0"],
              t_pulse=PARAMS["t_pulse"], width=PARAMS["width"], impulse=PARAMS["impulse"]):
    """Independent reference at times ``t`` (names of :func:`outputs` plus ``"description"``).

    The follower force F e⊥ at the tip is moved to the centre of mass with the
    torque (l/2) F.
    """
    from femb.benchmarks.references.planar_chain import Chain, solve

    d = _data(length, mass, theta0)
    f = pulse(t_pulse, width, impulse)[0]

    def loads(t, phi, phid):
        F = f(t)
        return F * np.array([[-math.sin(phi[0]), math.cos(phi[0])]]), np.array([0.5 * length * F])

    chain = Chain(d["masses"], d["inertias"], d["lengths"], d["com"], g=(0.0, -g), loads=loads)
    sol = solve(chain, t, d["phi0"], d["phid0"], fine=(t_pulse - 10 * width, t_pulse + 10 * width, 1e-3),
                key=("force_pulse", length, mass, g, theta0, t_pulse, width, impulse))
    out = reference_outputs(sol, 1)
    out["description"] = ("minimal coordinate φ, scipy solve_ivp DOP853 at rtol = atol = 1e-12 (step ≤ 1e-3 s "
                          "around the pulse); reaction by Newton–Euler (femb.benchmarks.references.planar_chain)")
    return out
