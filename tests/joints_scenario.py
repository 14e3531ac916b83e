"""Elements of every joint and body type of ``elements/joints.py`` and ``elements/bodies.py``.

Shared by ``tests/test_kernels_joints.py`` and ``tests/data/make_joints_reference.py``
(which builds the same elements with the numpy kernels of an earlier commit to record
reference values). ``joints`` and ``bodies`` are the modules whose classes are used.
"""
from __future__ import annotations

import numpy as np

from femb import Mechanism
from femb.base.functions import Harmonic, Polynomial

#: the joint types, in a fixed order
JOINT_TYPES = ("Hinge", "Slider", "PointOnLine", "DrivenAngle", "DrivenDisplacement")
#: the body types with a mass kernel
BODY_TYPES = ("RigidBody", "PointMass")


def build(joints, bodies):
    """Resolved and validated elements by type name: {type name: [element, ...]}.

    Every batch has two or three elements; bodies a/b include the ground and a point mass.
    """
    m = Mechanism("kernels")
    B = bodies
    b1 = m.add(B.RigidBody("b1", 1.2, 0.05, (0.1, 0.2), 0.3, points={"p": (0.2, -0.1), "q": (-0.3, 0.05)}))
    b2 = m.add(B.RigidBody("b2", 0.7, 0.02, (0.6, -0.1), -0.4, points={"p": (-0.15, 0.1)}))
    b3 = m.add(B.RigidBody("b3", 0.4, 0.01, (1.0, 0.4), 1.1))
    pm = m.add(B.PointMass("pm", 0.3, (0.5, 0.5)))
    pm2 = m.add(B.PointMass("pm2", 2.5, (-0.4, 0.9)))
    m.ground.add_point("A", (-0.2, 0.1))
    J = joints
    els = {
        "RigidBody": [b1, b2, b3],
        "PointMass": [pm, pm2],
        "Hinge": [J.Hinge("h1", "ground", b1, point_a="A", point_b="q"),
                  J.Hinge("h2", b1, b2, point_a="p", point_b="p"),
                  J.Hinge("h3", b2, pm, point_a=(0.1, 0.2))],
        "Slider": [J.Slider("s1", b2, b3, axis=(0.6, 0.8), point_a=(0.05, 0.0), point_b=(-0.1, 0.02)),
                   J.Slider("s2", "ground", b1, axis=(-1.0, 0.4), at=(0.3, 0.25)),
                   J.Slider("s3", pm, b3, axis=(0.3, -1.0), point_b=(0.2, 0.1))],
        "PointOnLine": [J.PointOnLine("l1", "ground", pm, axis=(1.0, 0.3)),
                        J.PointOnLine("l2", b2, b3, axis=(0.2, -0.7), point_a="p", point_b=(0.1, 0.3)),
                        J.PointOnLine("l3", b1, pm2, axis=(0.0, 1.0), point_a=(-0.2, 0.1))],
        "DrivenAngle": [J.DrivenAngle("da1", b1, b3, Harmonic(0.3, 5.0, 0.2)),
                        J.DrivenAngle("da2", "ground", b2, Polynomial([0.1, -0.4, 0.9, 0.3]))],
        "DrivenDisplacement": [
            J.DrivenDisplacement("dd1", b3, b2, Polynomial([0.0, 0.1, -0.4]), axis=(0.2, 1.0),
                                 point_a=(0.03, 0.01), point_b=(0.02, -0.05)),
            J.DrivenDisplacement("dd2", "ground", pm2, Harmonic(0.2, 3.0, 0.4, 0.05), axis=(1.0, -0.5),
                                 point_a="A"),
            J.DrivenDisplacement("dd3", b1, pm, 0.25, axis=(-0.3, 0.9), point_a="q")],
    }
    for name in JOINT_TYPES:
        m.add(*els[name])

    def lookup(ref, role):
        return m[ref] if isinstance(ref, str) else ref

    for name in JOINT_TYPES:
        for e in els[name]:
            e.resolve(lookup)
            e.validate()
    return els


def states(nel, seed, ndx=6):
    """Random element states: t, xe (nel, ndx), ve (nel, ndx), le (nel, 2)."""
    rng = np.random.default_rng(seed)
    xe = rng.normal(0.0, 0.6, (nel, ndx))
    xe[:, 2::3] = rng.uniform(-np.pi, np.pi, (nel, ndx // 3))
    ve = rng.normal(0.0, 1.5, (nel, ndx))
    le = rng.normal(0.0, 20.0, (nel, 2))
    t = float(rng.uniform(0.0, 2.0))
    return t, xe, ve, le
