"""Spatial double pendulum with revolute joints on skew axes, from femb's spatial elements.

Two links (cuboids) ``link1`` and ``link2``; revolute ``J1`` ground → link1 at
O about the skew axis n1 and ``J2`` link1 → link2 at A about the skew axis n2;
gravity (0, 0, −9.81); initial joint rates θ̇0 = (1.5, −2.0) rad/s. Data:
this project's own (:data:`femb.benchmarks.references.spatial_double_pendulum.DATA`,
shared with the reference so both describe one problem). 12 velocities,
10 rows, 2 degrees of freedom.

Outputs (:func:`outputs`): ``x1_x … x2_z`` (m, centres of mass), ``Omega1_x
… Omega2_z`` (rad/s, body axes), ``F1_x … F2_z`` (N: the forces of J1 on link1
and of J2 on link2, space axes = the multipliers λ[0:3] of J1 and J2),
``energy`` (J). Reference: :mod:`femb.benchmarks.references.spatial_double_pendulum`
(relative coordinates θ1, θ2).

Registered as ``spatial_double_pendulum``.
"""
from __future__ import annotations

import numpy as np

from femb import Mechanism
from femb.benchmarks.references.spatial_double_pendulum import DATA, bodies, initial_velocities
from femb.elements.spatial_bodies import SpatialRigidBody
from femb.elements.spatial_forces import SpatialGravity
from femb.elements.spatial_joints import RevoluteJoint

PARAMETERS = {"D": ("the data dict (masses, link frames, skew axes, joint points, initial rates, g); "
                    "see femb.benchmarks.references.spatial_double_pendulum.DATA", "-")}

OUTPUTS = {**{f"x{k}_{a}": (f"centre of mass of link{k}, space {a}", "m") for k in (1, 2) for a in "xyz"},
           **{f"Omega{k}_{a}": (f"angular velocity of link{k}, body {a}", "rad/s") for k in (1, 2) for a in "xyz"},
           **{f"F{k}_{a}": (f"force of J{k} on link{k}, space {a}", "N") for k in (1, 2) for a in "xyz"},
           "energy": ("kinetic + gravitational energy", "J")}

#: t ∈ [0, 2] s; h and ρ∞ as a starting point (to be measured).
DEFAULTS = {"t_end": 2.0, "h": 1e-3, "rho_inf": 0.9}

#: Work–precision groups: centres of mass, body angular velocities, joint forces.
CONVERGENCE = {"q": [f"x{k}_{a}" for k in (1, 2) for a in "xyz"],
               "v": [f"Omega{k}_{a}" for k in (1, 2) for a in "xyz"],
               "lambda": [f"F{k}_{a}" for k in (1, 2) for a in "xyz"]}


def build(D=DATA):
    """The double pendulum as a :class:`~femb.Mechanism` (see the module docstring)."""
    c10, c20, R10, R20, J1, J2 = bodies(D)
    v1, w1, v2, w2 = initial_velocities(D)
    mech = Mechanism("spatial_double_pendulum")
    l1 = mech.add(SpatialRigidBody("link1", D["m1"], J1, position=c10, rotation=R10, velocity=v1,
                                   omega_space=w1))
    l2 = mech.add(SpatialRigidBody("link2", D["m2"], J2, position=c20, rotation=R20, velocity=v2,
                                   omega_space=w2))
    mech.add(RevoluteJoint("J1", "ground", l1, at=D["O"], axis=D["n1"]),
             RevoluteJoint("J2", l1, l2, at=D["A"], axis=D["n2"]),
             SpatialGravity(D["g"]))
    return mech


def outputs(result, D=DATA):
    """Named outputs over the stored steps (see the module docstring), each (nt,)."""
    *_, J1, J2 = bodies(D)
    out = {}
    E = 0.0
    for k, (name, m, J) in enumerate((("link1", D["m1"], J1), ("link2", D["m2"], J2)), start=1):
        x = result.body(name)
        v = result.body(name, "qd")
        for i, ax in enumerate("xyz"):
            out[f"x{k}_{ax}"] = x[:, i]
            out[f"Omega{k}_{ax}"] = v[:, 3 + i]
        E = E + 0.5 * m * np.sum(v[:, :3] ** 2, axis=1) + 0.5 * np.einsum("ni,ij,nj->n", v[:, 3:6], J, v[:, 3:6]) \
            - m * x[:, :3] @ D["g"]
        lam = result.reaction(f"J{k}")
        for i, ax in enumerate("xyz"):
            out[f"F{k}_{ax}"] = lam[:, i]
    out["energy"] = E
    return out


def reference(t_eval):
    """Reference outputs at ``t_eval`` (relative coordinates, DOP853, rtol = atol = 1e-12)."""
    from femb.benchmarks.references import spatial_double_pendulum as ref

    t_eval = np.asarray(t_eval, dtype=float)
    _, out = ref.solve(float(t_eval.max()), t_eval=t_eval)
    return out
