"""Two-bar pendulum released horizontally at rest: the silent-wrong-answer case of a too large fixed step.

Two uniform bars (1 m, 1 kg each) hinged end to end and to the ground, both
lying along +x at t = 0, released at rest under gravity (9.81 m/s², −y), over
t ∈ [0, 5] s. At h = 0.5 s (ten steps) a fixed-step run without an error
estimate either fails in Newton or returns "success" with an angle thousands
of radians off, depending on ρ∞ (measured before step-size control: 2706 rad
at ρ∞ = 0.8, against −0.432 rad). The data of the first report of this case
were not recorded; these are this scene's own. The motion is chaotic after a
few seconds: small-h comparisons use t ≤ 2 s.

Outputs (:func:`outputs`)
-------------------------
``phi1``, ``phi2`` (rad, absolute, from the x axis), ``phi1_d``, ``phi2_d``
(rad/s), ``R_pivot_x``, ``R_pivot_y`` (N): force of the ground on bar 1.

References
----------
Independent reference: :mod:`femb.benchmarks.references.planar_chain`.
"""
from __future__ import annotations

from femb import Mechanism
from femb.elements import Gravity

from femb.benchmarks.scenes.planar.chains import (
    add_chain, chain_output_info, chain_outputs, reference_outputs)

#: Scene data (SI units).
PARAMS = {"length": 1.0, "mass": 1.0, "g": 9.81}

#: t ∈ [0, 5] s; h = 0.5 s is the too-large step, the default is a sound one.
DEFAULTS = {"t_end": 5.0, "h": 1e-3, "rho_inf": 0.8}

PARAMETERS = {
    "length": ("length of each uniform bar", "m"),
    "mass": ("mass of each bar (J = m l²/12)", "kg"),
    "g": ("gravity along −y", "m/s^2"),
}

OUTPUTS = chain_output_info(2)

#: The too-large step and the final time of the silent-wrong-answer run.
LARGE_STEP = {"t_end": 5.0, "h": 0.5}

CONVERGENCE = {"t_end": 2.0, "h": [4e-3, 2e-3, 1e-3, 5e-4], "q": ["phi1", "phi2"],
               "lambda": ["R_pivot_x", "R_pivot_y"]}


def _data(length, mass):
    return dict(lengths=[length, length], masses=[mass, mass], inertias=[mass * length ** 2 / 12.0] * 2,
                com=[0.5 * length] * 2, phi0=[0.0, 0.0], phid0=[0.0, 0.0])


def build(length=PARAMS["length"], mass=PARAMS["mass"], g=PARAMS["g"]):
    """The two-bar pendulum from femb elements (bodies ``bar1``, ``bar2``; hinges ``pivot``, ``hinge1``).

    Parameters
    ----------
    length, mass : float
        Length (m) and mass (kg) of each uniform bar.
    g : float
        Gravity along −y (m/s²).
    """
    if not (length > 0.0 and mass > 0.0):
        raise ValueError(f"two_bar_pendulum: length and mass must be positive, got {length!r}, {mass!r}")
    mech = Mechanism("two_bar_pendulum")
    add_chain(mech, **_data(length, mass))
    mech.add(Gravity((0.0, -g)))
    return mech


def outputs(result):
    """Angles, rates and the ground-hinge force (dict of arrays (nt,))."""
    return chain_outputs(result, 2)


def reference(t, length=PARAMS["length"], mass=PARAMS["mass"], g=PARAMS["g"]):
    """Independent reference at times ``t`` (names of :func:`outputs` plus ``"description"``)."""
    from femb.benchmarks.references.planar_chain import Chain, solve

    d = _data(length, mass)
    chain = Chain(d["masses"], d["inertias"], d["lengths"], d["com"], g=(0.0, -g))
    out = reference_outputs(solve(chain, t, d["phi0"], d["phid0"], key="two_bar_pendulum"), 2)
    out["description"] = ("minimal coordinates, scipy solve_ivp DOP853 at rtol = atol = 1e-12; reaction by "
                          "Newton–Euler (femb.benchmarks.references.planar_chain)")
    return out
