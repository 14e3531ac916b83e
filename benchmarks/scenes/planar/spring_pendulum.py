"""Bar on a torsional spring under gravity, released horizontally: the second silent-wrong-answer case.

A uniform bar (0.8 m, 2 kg) hinged at one end to the ground and held there by
a torsional spring (30 N m/rad, unstressed with the bar horizontal), released
at rest from the horizontal under gravity (9.81 m/s², −y), t ∈ [0, 5] s. Too
large fixed steps (h = 0.5 s) without an error estimate return wrong angles as
"success" (measured before step-size control: φ(5) = −0.42 rad at ρ∞ = 0.8
where the answer is −0.063 rad). The data of the first report of this case
were not recorded; these are this scene's own.

Outputs (:func:`outputs`)
-------------------------
``phi1`` (rad, from the x axis), ``phi1_d`` (rad/s), ``R_pivot_x``,
``R_pivot_y`` (N): force of the ground on the bar at the hinge.

References
----------
Independent reference: :mod:`femb.benchmarks.references.planar_chain` with
the spring torque −k φ on the link.
"""
from __future__ import annotations

import numpy as np

from femb import Mechanism
from femb.elements import Gravity, RotationalSpringDamper

from femb.benchmarks.scenes.planar.chains import (
    add_chain, chain_output_info, chain_outputs, reference_outputs)

#: Scene data (SI units).
PARAMS = {"length": 0.8, "mass": 2.0, "k": 30.0, "g": 9.81}

DEFAULTS = {"t_end": 5.0, "h": 1e-3, "rho_inf": 0.8}

PARAMETERS = {
    "length": ("length of the uniform bar", "m"),
    "mass": ("mass of the bar", "kg"),
    "k": ("torsional stiffness, unstressed at the initial (horizontal) angle", "N m/rad"),
    "g": ("gravity along −y", "m/s^2"),
}

OUTPUTS = chain_output_info(1)

#: The too-large step and the final time of the silent-wrong-answer run.
LARGE_STEP = {"t_end": 5.0, "h": 0.5}

CONVERGENCE = {"t_end": 5.0, "h": [4e-3, 2e-3, 1e-3, 5e-4], "q": ["phi1"],
               "lambda": ["R_pivot_x", "R_pivot_y"]}


def _data(length, mass):
    return dict(lengths=[length], masses=[mass], inertias=[mass * length ** 2 / 12.0],
                com=[0.5 * length], phi0=[0.0], phid0=[0.0])


def build(length=PARAMS["length"], mass=PARAMS["mass"], k=PARAMS["k"], g=PARAMS["g"]):
    """The spring pendulum from femb elements (body ``bar1``, hinge ``pivot``, spring ``spring``).

    Parameters
    ----------
    length, mass : float
        Bar length (m) and mass (kg), uniform.
    k : float
        Torsional stiffness (N m/rad), unstressed at the initial (horizontal) angle.
    g : float
        Gravity along −y (m/s²).
    """
    if not (length > 0.0 and mass > 0.0 and k >= 0.0):
        raise ValueError(f"spring_pendulum: need length, mass > 0 and k >= 0, got {length!r}, {mass!r}, {k!r}")
    mech = Mechanism("spring_pendulum")
    (bar,) = add_chain(mech, **_data(length, mass))
    mech.add(RotationalSpringDamper("spring", mech.ground, bar, k), Gravity((0.0, -g)))
    return mech


def outputs(result):
    """Angle, rate and the ground-hinge force (dict of arrays (nt,))."""
    return chain_outputs(result, 1)


def reference(t, length=PARAMS["length"], mass=PARAMS["mass"], k=PARAMS["k"], g=PARAMS["g"]):
    """Independent reference at times ``t`` (names of :func:`outputs` plus ``"description"``)."""
    from femb.benchmarks.references.planar_chain import Chain, solve

    d = _data(length, mass)

    def loads(t, phi, phid):
        return np.zeros((1, 2)), -k * (phi - d["phi0"][0]) * np.ones(1)

    chain = Chain(d["masses"], d["inertias"], d["lengths"], d["com"], g=(0.0, -g), loads=loads)
    out = reference_outputs(solve(chain, t, d["phi0"], d["phid0"], key=("spring_pendulum", k)), 1)
    out["description"] = ("minimal coordinate φ, scipy solve_ivp DOP853 at rtol = atol = 1e-12; reaction by "
                          "Newton–Euler (femb.benchmarks.references.planar_chain)")
    return out
