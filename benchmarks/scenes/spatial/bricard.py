"""Bricard mechanism (MBS benchmark A04; González et al. 2006) from femb's spatial elements.

Five rods (1 m, 1 kg, square section 0.1 m: homogeneous cuboids, centre of mass
mid-length, body x along the rod) ``rod1`` … ``rod5`` and six revolute joints
``J1`` … ``J6`` at P1 … P6 = (0,0,0), (1,0,0), (1,−1,0), (1,−1,1), (0,−1,1),
(0,0,1) with axes y, z, x, y, z, x; J1 ground → rod1, J_k rod_{k−1} → rod_k,
J6 rod5 → ground; gravity (0, −9.81, 0); from rest (as
jgerstmayr/EXUDYN:main/pythonDev/TestModels/bricardMechanism.py; the A04
specification at lim.ii.udc.es/mbsbenchmark is to be checked for the initial
velocity). 30 velocities, 30 rows, rank 29: Grübler counts 0 degrees of
freedom, the mechanism has 1 (one dependent row involving all six joints,
docs/spatial.md §5): the time loop must detect and remove it.

Outputs (:func:`outputs`): ``P3_x, P3_y, P3_z`` (m: joint point P3 on rod 2, the
benchmark's output point), ``energy`` (J, constant: nothing dissipates).
Reference: :mod:`femb.benchmarks.references.bricard` (joint coordinates with the
redundant closure solved by least squares).

Registered as ``bricard``; the registry compiles it with ``redundant="eliminate"``
(:data:`COMPILE`), which removes the dependent row and says which.
"""
from __future__ import annotations

import numpy as np

from femb import Mechanism
from femb.elements.spatial_bodies import SpatialRigidBody, box_inertia
from femb.elements.spatial_forces import SpatialGravity
from femb.elements.spatial_joints import RevoluteJoint

PARAMS = dict(length=1.0, width=0.1, mass=1.0, g=(0.0, -9.81, 0.0))
POINTS = ((0, 0, 0), (1, 0, 0), (1, -1, 0), (1, -1, 1), (0, -1, 1), (0, 0, 1))
AXES = ((0, 1, 0), (0, 0, 1), (1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 0, 0))

PARAMETERS = {"length": ("rod length", "m"), "width": ("rod section side", "m"), "mass": ("rod mass", "kg"),
              "g": ("gravity", "m/s^2")}

OUTPUTS = {"P3_x": ("far end of rod2, space x", "m"), "P3_y": ("far end of rod2, space y", "m"),
           "P3_z": ("far end of rod2, space z", "m"), "energy": ("kinetic + gravitational energy", "J")}

#: The closure is structurally redundant (one of J6's equations depends on the others):
#: compiled with the dependent equation removed, and the removal reported.
COMPILE = {"redundant": "eliminate"}

#: Benchmark run: 10 s; ρ∞ = 0.9 and h = 1e-3 s as a starting point (to be measured).
DEFAULTS = {"t_end": 10.0, "h": 1e-3, "rho_inf": 0.9}

#: Work–precision groups (the reference has no reactions).
CONVERGENCE = {"q": ["P3_x", "P3_y", "P3_z"], "v": [], "lambda": []}


def build(length=PARAMS["length"], width=PARAMS["width"], mass=PARAMS["mass"], g=PARAMS["g"]):
    """Bricard's mechanism as a :class:`~femb.Mechanism` (see the module docstring).

    Returns
    -------
    Mechanism
        Bodies ``rod1`` … ``rod5`` (point ``P3`` on ``rod2`` = its far end),
        joints ``J1`` … ``J6``, ``gravity``.
    """
    P = np.asarray(POINTS, dtype=float) * length
    ax = np.asarray(AXES, dtype=float)
    J = box_inertia(mass, length, width, width)
    mech = Mechanism("bricard")
    rods = []
    for k in range(5):
        x = (P[k + 1] - P[k]) / length
        y = ax[k] if abs(ax[k] @ x) < 0.5 else ax[k + 1]
        R0 = np.column_stack((x, y, np.cross(x, y)))
        rods.append(mech.add(SpatialRigidBody(
            f"rod{k + 1}", mass, J, position=0.5 * (P[k] + P[k + 1]), rotation=R0,
            points={"start": (-0.5 * length, 0, 0), "end": (0.5 * length, 0, 0)},
            shape={"type": "box", "size": (length, width, width)})))
    chain = ["ground"] + rods + ["ground"]
    for k in range(6):
        mech.add(RevoluteJoint(f"J{k + 1}", chain[k], chain[k + 1], at=P[k], axis=ax[k]))
    mech.add(SpatialGravity(g))
    return mech


def outputs(result, length=PARAMS["length"], width=PARAMS["width"], mass=PARAMS["mass"], g=PARAMS["g"]):
    """Named outputs over the stored steps (see the module docstring), each (nt,)."""
    from femb.benchmarks.scenes.spatial.spatial_common import point_positions

    p3 = point_positions(result.body("rod2"), (0.5 * length, 0.0, 0.0))
    J = box_inertia(mass, length, width, width)
    E = 0.0
    for k in range(5):
        x = result.body(f"rod{k + 1}")
        v = result.body(f"rod{k + 1}", "qd")
        E = E + 0.5 * mass * np.sum(v[:, :3] ** 2, axis=1) + 0.5 * np.sum(J * v[:, 3:6] ** 2, axis=1) \
            - mass * x[:, :3] @ np.asarray(g, dtype=float)
    return {"P3_x": p3[:, 0], "P3_y": p3[:, 1], "P3_z": p3[:, 2], "energy": E}


def reference(t_eval):
    """Reference outputs at ``t_eval`` (joint coordinates, DOP853, rtol = atol = 1e-12)."""
    from femb.benchmarks.references import bricard as ref

    t_eval = np.asarray(t_eval, dtype=float)
    _, out = ref.solve(float(t_eval.max()), t_eval=t_eval)
    return out
