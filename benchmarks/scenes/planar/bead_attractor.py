"""Bead on a unit circle attracted by a point just outside it (W3 of the step-size study): fast passages.

A bead (1 kg) moves on the unit circle. femb has no distance constraint, so
the bead is a :class:`~femb.elements.RigidBody` (J = 1e-4 kg m², a sphere of
radius 1.6 cm) whose centre of mass lies 1 m from a ground hinge at the
origin: the rigid arm is part of the body and carries no mass. It is attracted by the point P = (1.05, 0) with the
potential U = −μ/|x − P| (μ = 1 N m²), no gravity, and starts at (−1, 0) with
speed 2 m/s counter-clockwise; t ∈ [0, 10] s. Each turn has one short, fast
passage near P (speed about 6.6 m/s against 2 m/s far away): stepsize.md §8, W3,
where a fixed step of 0.04 s fails in Newton and adaptive runs pass.

femb's element library has no central-force element, so this scene defines
one, :class:`PointAttractor`, through the public element contract
(:mod:`femb.system.element`, ``docs/kernels.md``): its force kernel is a compiled
``@femb.base.jit.kernel`` function, checked by ``femb.check_jacobians``; its ``"energy"``
kernel declares the potential U, so ``Result.energy()`` counts it.

Outputs (:func:`outputs`)
-------------------------
``phi1`` (rad, polar angle of the bead, from the x axis; unwrapped),
``phi1_d`` (rad/s), ``R_pivot_x``, ``R_pivot_y`` (N): force of the ground on
the arm at the hinge.

References
----------
Independent reference: :mod:`femb.benchmarks.references.planar_chain` (one
link, centre of mass at 1 m, the attraction as a load at the centre of mass).
"""
from __future__ import annotations

import math

import numpy as np

from femb import Mechanism
from femb.base.jit import kernel
from femb.errors import ModelError
from femb.system.element import Element

from femb.benchmarks.scenes.planar.chains import (
    add_chain, chain_output_info, chain_outputs, reference_outputs)

#: Scene data (SI units).
PARAMS = {"mass": 1.0, "inertia": 1e-4, "radius": 1.0, "px": 1.05, "mu": 1.0, "speed": 2.0}

DEFAULTS = {"t_end": 10.0, "h": 1e-3, "rho_inf": 0.9}

PARAMETERS = {
    "mass": ("bead mass", "kg"),
    "inertia": ("centroidal inertia of the bead", "kg m^2"),
    "radius": ("radius of the circle", "m"),
    "px": ("the attracting point is (px, 0)", "m"),
    "mu": ("strength μ of U = −μ/|x − P|", "N m^2"),
    "speed": ("initial speed at (−radius, 0), counter-clockwise", "m/s"),
}

OUTPUTS = chain_output_info(1)

CONVERGENCE = {"t_end": 10.0, "h": [2e-3, 1e-3, 5e-4, 2.5e-4], "q": ["phi1"],
               "lambda": ["R_pivot_x", "R_pivot_y"]}


@kernel
def point_attractor_force(P, t, tf, xe, ve, jac, fe, fq, fv):
    """F = −μ (x − P)/d³ and ∂F/∂x = −μ (I/d³ − 3 (x − P)(x − P)ᵀ/d⁵); P = (P_x, P_y, μ)."""
    for e in range(xe.shape[0]):
        Dx = xe[e, 0] - P[e, 0]
        Dy = xe[e, 1] - P[e, 1]
        mu = P[e, 2]
        d2 = Dx * Dx + Dy * Dy
        d = math.sqrt(d2)
        a = mu / (d2 * d)
        fe[e, 0] = -a * Dx
        fe[e, 1] = -a * Dy
        if jac:
            b = 3.0 / d2
            fq[e, 0, 0] = -a * (1.0 - b * Dx * Dx)
            fq[e, 0, 1] = a * b * Dx * Dy
            fq[e, 1, 0] = a * b * Dx * Dy
            fq[e, 1, 1] = -a * (1.0 - b * Dy * Dy)


@kernel
def point_attractor_energy(P, t, tf, xe, Ve):
    """U = −μ/|x − P|, the potential of :func:`point_attractor_force` (in ``energy()["elastic"]``)."""
    for e in range(xe.shape[0]):
        Dx = xe[e, 0] - P[e, 0]
        Dy = xe[e, 1] - P[e, 1]
        Ve[e] = -P[e, 2] / math.sqrt(Dx * Dx + Dy * Dy)


class PointAttractor(Element):
    """Attraction of a body's centre of mass by a fixed point, potential U = −μ/|x − P|.

    The force on the body is F = −μ (x − P)/|x − P|³ (N); its Jacobian
    ∂F/∂x = −μ (I/d³ − 3 (x − P)(x − P)ᵀ/d⁵), d = |x − P|.

    Parameters
    ----------
    name : str
    body : Body or str
    point : (x, y)
        The attracting point P (m).
    strength : float > 0
        μ (N m²).
    """

    has_force = True
    work = "potential"
    kernels = {"force": point_attractor_force, "energy": point_attractor_energy}

    def __init__(self, name, body, point, strength):
        super().__init__(name)
        self.body = body
        try:
            self.P = np.array([float(point[0]), float(point[1])])
        except (TypeError, ValueError, IndexError):
            raise ModelError(f"PointAttractor '{name}': point must be (x, y), got {point!r}") from None
        try:
            self.mu = float(strength)
        except (TypeError, ValueError):
            raise ModelError(f"PointAttractor '{name}': strength must be a number, got {strength!r}") from None
        if not (math.isfinite(self.mu) and self.mu > 0.0 and np.all(np.isfinite(self.P))):
            raise ModelError(f"PointAttractor '{name}': strength must be positive and the point finite, "
                             f"got {strength!r}, {point!r}")

    def resolve(self, lookup):
        self.body = lookup(self.body, "body")

    def nodes(self):
        return [self.body.node]

    def validate(self):
        if float(np.hypot(*(self.body.node.q0[:2] - self.P))) == 0.0:
            raise ModelError(f"PointAttractor '{self.name}': the body starts on the attracting point")

    @classmethod
    def pack(cls, elements):
        return {"P": np.array([[e.P[0], e.P[1], e.mu] for e in elements], dtype=float).reshape(-1, 3)}


def _data(mass, inertia, radius, speed):
    return dict(lengths=[radius], masses=[mass], inertias=[inertia], com=[radius], phi0=[math.pi],
                phid0=[speed / radius])


def build(mass=PARAMS["mass"], inertia=PARAMS["inertia"], radius=PARAMS["radius"], px=PARAMS["px"],
          mu=PARAMS["mu"], speed=PARAMS["speed"]):
    """The bead from femb elements plus :class:`PointAttractor` (body ``bar1``, hinge ``pivot``).

    Parameters
    ----------
    mass, inertia : float
        Bead mass (kg) and centroidal inertia (kg m²).
    radius : float
        Radius of the circle (m).
    px : float
        The attracting point is (px, 0) (m); px > radius puts it just outside.
    mu : float
        Strength μ of U = −μ/|x − P| (N m²).
    speed : float
        Initial speed (m/s) at (−radius, 0), counter-clockwise.
    """
    if not (mass > 0.0 and inertia > 0.0 and radius > 0.0):
        raise ValueError(f"bead_attractor: mass, inertia, radius must be positive, got {mass!r}, {inertia!r}, {radius!r}")
    mech = Mechanism("bead_attractor")
    (bead,) = add_chain(mech, **_data(mass, inertia, radius, speed))
    mech.add(PointAttractor("attractor", bead, (px, 0.0), mu))
    return mech


def outputs(result):
    """Polar angle (unwrapped), rate and the ground-hinge force (dict of arrays (nt,))."""
    out = chain_outputs(result, 1)
    out["phi1"] = np.unwrap(out["phi1"])
    return out


def reference(t, mass=PARAMS["mass"], inertia=PARAMS["inertia"], radius=PARAMS["radius"], px=PARAMS["px"],
              mu=PARAMS["mu"], speed=PARAMS["speed"]):
    """Independent reference at times ``t`` (names of :func:`outputs` plus ``"description"``)."""
    from femb.benchmarks.references.planar_chain import Chain, solve

    d = _data(mass, inertia, radius, speed)
    P = np.array([px, 0.0])

    def loads(t, phi, phid):
        D = radius * np.array([math.cos(phi[0]), math.sin(phi[0])]) - P
        return (-mu / np.linalg.norm(D) ** 3 * D)[None, :], np.zeros(1)

    chain = Chain(d["masses"], d["inertias"], d["lengths"], d["com"], g=(0.0, 0.0), loads=loads)
    out = reference_outputs(solve(chain, t, d["phi0"], d["phid0"],
                                  key=("bead_attractor", mass, inertia, radius, px, mu, speed)), 1)
    out["description"] = ("minimal coordinate φ, scipy solve_ivp DOP853 at rtol = atol = 1e-12; reaction by "
                          "Newton–Euler (femb.benchmarks.references.planar_chain)")
    return out
