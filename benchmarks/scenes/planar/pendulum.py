"""Conservative planar pendulum (uniform bar, hinge to the ground, gravity): long-run scene.

A uniform bar of length ``length`` and mass ``mass`` is pinned at one end to
the ground and released at rest from the angle ``psi0`` measured from the
downward vertical. Nothing dissipates, so the energy T + V is an exact
invariant; the motion has a closed form in Jacobi elliptic functions, which
:func:`reference` evaluates (independent of femb). The benchmark suite uses
this scene for its long runs (energy and constraint drift over 10⁶ steps) and
for the unit-rescaling test.

Outputs (:func:`outputs`)
-------------------------
``psi`` (rad, from the downward vertical), ``psi_d`` (rad/s), ``R_pivot_x``,
``R_pivot_y`` (N): the force of the ground on the bar at the pivot (the
multipliers of hinge ``pivot``).

References
----------
Exact solution: ψ(t) = 2 arcsin(k sn(K − ω₀t | k²)), k = sin(ψ₀/2),
ω₀² = m g (l/2) / J_O = 3g/(2l) for a uniform bar (J_O = m l²/3); e.g.
L. D. Landau, E. M. Lifshitz, Mechanics, 3rd ed., §11 (the simple pendulum,
here with ω₀ of the compound pendulum); M. Abramowitz, I. A. Stegun, Handbook
of Mathematical Functions, Ch. 16 (Jacobi elliptic functions).
"""
from __future__ import annotations

import math

import numpy as np

from femb import Mechanism
from femb.elements import Gravity, Hinge, RigidBody

#: Scene data (SI units): a 1 m, 1 kg uniform bar released at 2 rad (115°) from the vertical.
PARAMS = {"length": 1.0, "mass": 1.0, "g": 9.81, "psi0": 2.0}

#: One period of the default pendulum (4K/ω₀ = 2.5255 s) at h = 1e-3 s, ρ∞ = 0.7.
DEFAULTS = {"t_end": 2.5, "h": 1e-3, "rho_inf": 0.7}

#: Parameters of :func:`build`: name -> (meaning, unit), shown by ``femb list``.
PARAMETERS = {
    "length": ("bar length (uniform bar)", "m"),
    "mass": ("bar mass", "kg"),
    "g": ("gravity along -y", "m/s^2"),
    "psi0": ("initial angle from the downward vertical (released at rest)", "rad"),
}

#: Outputs of :func:`outputs`: name -> (meaning, unit), shown by ``femb list``.
OUTPUTS = {
    "psi": ("angle from the downward vertical", "rad"),
    "psi_d": ("angular velocity", "rad/s"),
    "R_pivot_x": ("x force of the ground on the bar at the pivot", "N"),
    "R_pivot_y": ("y force of the ground on the bar at the pivot", "N"),
}

#: The h-convergence names: the angle and the pivot reaction.
CONVERGENCE = {"t_end": 2.5, "h": [4e-3, 2e-3, 1e-3, 5e-4], "q": ["psi"],
               "lambda": ["R_pivot_x", "R_pivot_y"]}


def build(length=PARAMS["length"], mass=PARAMS["mass"], g=PARAMS["g"], psi0=PARAMS["psi0"]):
    """The pendulum built from femb elements.

    Parameters
    ----------
    length : float
        Bar length (m); the bar is uniform, J = m l²/12 about its centre.
    mass : float
        Bar mass (kg).
    g : float
        Gravity along −y (m/s²).
    psi0 : float
        Initial angle from the downward vertical (rad); released at rest.

    Returns
    -------
    Mechanism
        Body ``bar`` (point ``O`` at the pivot end), hinge ``pivot``, ``gravity``.
    """
    if not (length > 0.0 and mass > 0.0):
        raise ValueError(f"pendulum: length and mass must be positive, got {length!r}, {mass!r}")
    mech = Mechanism("pendulum")
    phi = psi0 - math.pi / 2          # body x axis from the pivot to the free end
    centre = 0.5 * length * np.array([math.cos(phi), math.sin(phi)])
    bar = mech.add(RigidBody("bar", mass, mass * length ** 2 / 12.0, centre, phi,
                             points={"O": (-0.5 * length, 0.0), "tip": (0.5 * length, 0.0)},
                             shape={"type": "bar", "width": 0.03 * length}))
    mech.add(Hinge("pivot", mech.ground, bar, point_b="O"))
    mech.add(Gravity((0.0, -g)))
    return mech


def outputs(result):
    """Named outputs over the stored steps.

    Returns
    -------
    dict of str to ndarray (nt,)
        ``psi``, ``psi_d`` and the pivot force ``R_pivot_x``, ``R_pivot_y``.
    """
    bar = result.body("bar")
    bar_d = result.body("bar", "qd")
    R = result.reaction("pivot")
    return {"psi": bar[:, 2] + math.pi / 2, "psi_d": bar_d[:, 2], "R_pivot_x": R[:, 0], "R_pivot_y": R[:, 1]}


def period(length=PARAMS["length"], g=PARAMS["g"], psi0=PARAMS["psi0"]):
    """Exact period 4 K(k²)/ω₀ (s)."""
    from scipy.special import ellipk

    k = math.sin(psi0 / 2)
    return 4.0 * ellipk(k * k) / math.sqrt(1.5 * g / length)


def reference(t, length=PARAMS["length"], mass=PARAMS["mass"], g=PARAMS["g"], psi0=PARAMS["psi0"]):
    """Exact solution (Jacobi elliptic functions) at times ``t``.

    ψ = 2 arcsin(k sn(u | k²)), u = K − ω₀ t; ψ̇ = −2 k ω₀ cn(u) (released at
    rest from ψ₀ > 0); the pivot force follows from Newton's law for the
    centre of mass, R = m r̈_c − m g, with r_c = (l/2)(sin ψ, −cos ψ) and
    ψ̈ = −ω₀² sin ψ.

    Parameters
    ----------
    t : array_like, shape (nt,)
    length, mass, g, psi0 : float
        As for :func:`build`.

    Returns
    -------
    dict
        The names of :func:`outputs` mapped to arrays (nt,), plus ``"description"``.
    """
    from scipy.special import ellipj, ellipk

    t = np.atleast_1d(np.asarray(t, dtype=float))
    k = math.sin(psi0 / 2)
    w0 = math.sqrt(1.5 * g / length)
    K = ellipk(k * k)
    sn, cn, dn, _ = ellipj(K - w0 * t, k * k)
    psi = 2.0 * np.arcsin(k * sn)
    psi_d = -2.0 * k * w0 * cn
    psi_dd = -w0 * w0 * np.sin(psi)
    a = 0.5 * length * np.stack((np.cos(psi) * psi_dd - np.sin(psi) * psi_d ** 2,
                                 np.sin(psi) * psi_dd + np.cos(psi) * psi_d ** 2), axis=1)
    R = mass * a - mass * np.array([0.0, -g])
    return {"psi": psi, "psi_d": psi_d, "R_pivot_x": R[:, 0], "R_pivot_y": R[:, 1],
            "description": "exact solution in Jacobi elliptic functions (scipy.special.ellipj)"}


def energy(result, length=PARAMS["length"], mass=PARAMS["mass"], g=PARAMS["g"]):
    """Total energy T + V (J) at every stored step, from the absolute coordinates.

    V = m g y_c with the pivot at y = 0; T = ½ m ‖v_c‖² + ½ J ω².
    """
    q = result.body("bar")
    v = result.body("bar", "qd")
    J = mass * length ** 2 / 12.0
    return 0.5 * mass * (v[:, 0] ** 2 + v[:, 1] ** 2) + 0.5 * J * v[:, 2] ** 2 + mass * g * q[:, 1]


def energy_scale(length=PARAMS["length"], mass=PARAMS["mass"], g=PARAMS["g"]):
    """m g l (J): the scale against which energy drift is measured."""
    return mass * g * length
