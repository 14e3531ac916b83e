"""Open chains of rigid bars hinged to the ground, built from femb elements.

Shared by the pendulum-type scenes (:mod:`~femb.benchmarks.scenes.planar.double_pendulum`,
:mod:`~femb.benchmarks.scenes.planar.two_bar_pendulum`, :mod:`~femb.benchmarks.scenes.planar.spring_pendulum`,
:mod:`~femb.benchmarks.scenes.planar.force_pulse`, :mod:`~femb.benchmarks.scenes.planar.bead_attractor`);
their independent reference is :mod:`femb.benchmarks.references.planar_chain`,
which uses the same data (mass, inertia, length, pivot-to-centre distance per
link, absolute angles from the x axis) in minimal coordinates.
"""
from __future__ import annotations

import math

import numpy as np

from femb.elements import Hinge, RigidBody


def add_chain(mech, lengths, masses, inertias, com, phi0, phid0, prefix="bar"):
    """Add an open chain of rigid links to ``mech``, hinged to the ground at the origin.

    Parameters
    ----------
    mech : Mechanism
    lengths, masses, inertias, com : sequence of float, length n
        Link length pivot → next pivot (m), mass (kg), centroidal inertia
        (kg m²), distance pivot → centre of mass (m).
    phi0, phid0 : sequence of float, length n
        Initial absolute angles from the x axis (rad) and rates (rad/s); the
        centre velocities are set consistently with them.
    prefix : str
        Bodies are named ``prefix1`` … ``prefixn``; the ground hinge is
        ``pivot``, the hinge between links k and k+1 is ``hinge{k}``.

    Returns
    -------
    list of RigidBody
        Each with the points ``O`` (its pivot) and ``E`` (the next pivot).
    """
    n = len(lengths)
    for name, seq in (("masses", masses), ("inertias", inertias), ("com", com), ("phi0", phi0), ("phid0", phid0)):
        if len(seq) != n:
            raise ValueError(f"add_chain: {name} has {len(seq)} entries, lengths has {n}")
    pivot = np.zeros(2)
    vpivot = np.zeros(2)
    bodies = []
    for k in range(n):
        L, c, ph, w = float(lengths[k]), float(com[k]), float(phi0[k]), float(phid0[k])
        e = np.array([math.cos(ph), math.sin(ph)])
        ep = np.array([-math.sin(ph), math.cos(ph)])
        body = mech.add(RigidBody(f"{prefix}{k + 1}", float(masses[k]), float(inertias[k]),
                                  pivot + c * e, ph, velocity=vpivot + c * w * ep, omega=w,
                                  points={"O": (-c, 0.0), "E": (L - c, 0.0)},
                                  shape={"type": "bar", "width": 0.03 * L}))
        if k == 0:
            mech.add(Hinge("pivot", mech.ground, body, point_b="O"))
        else:
            mech.add(Hinge(f"hinge{k}", bodies[-1], body, point_a="E", point_b="O"))
        bodies.append(body)
        pivot = pivot + L * e
        vpivot = vpivot + L * w * ep
    return bodies


def chain_outputs(result, n, prefix="bar"):
    """Angles ``phi{k}``, rates ``phi{k}_d`` (k = 1 … n) and the ground-hinge force ``R_pivot_x/y``.

    Returns
    -------
    dict of str to ndarray (nt,)
    """
    out = {}
    for k in range(1, n + 1):
        out[f"phi{k}"] = result.body(f"{prefix}{k}")[:, 2]
        out[f"phi{k}_d"] = result.body(f"{prefix}{k}", "qd")[:, 2]
    R = result.reaction("pivot")
    out["R_pivot_x"], out["R_pivot_y"] = R[:, 0], R[:, 1]
    return out


def chain_output_info(n):
    """``OUTPUTS`` of a scene whose outputs are :func:`chain_outputs` (n bars): {name: (meaning, unit)}."""
    info = {}
    for k in range(1, n + 1):
        info[f"phi{k}"] = (f"angle of bar{k} from the x axis", "rad")
        info[f"phi{k}_d"] = (f"angular velocity of bar{k}", "rad/s")
    info["R_pivot_x"] = ("x force of the ground hinge 'pivot' on bar1", "N")
    info["R_pivot_y"] = ("y force of the ground hinge 'pivot' on bar1", "N")
    return info


def reference_outputs(sol, n):
    """The names of :func:`chain_outputs` from a :func:`planar_chain.solve` solution."""
    out = {}
    for k in range(1, n + 1):
        out[f"phi{k}"] = sol["phi"][:, k - 1]
        out[f"phi{k}_d"] = sol["phid"][:, k - 1]
    out["R_pivot_x"], out["R_pivot_y"] = sol["R"][:, 0, 0], sol["R"][:, 0, 1]
    return out
