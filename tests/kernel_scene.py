"""A small scene with every element type of elements/forces.py and elements/beam.py.

Shared by tests/test_kernels_forces.py and by tests/data/make_kernels_forces_reference.py
(which computed the stored reference values with the numpy kernels these compiled kernels
replaced). Elements are resolved and validated as :func:`femb.system.model.compile_model` does, and
batched by ``(type, group_key())``.
"""
from types import SimpleNamespace

import numpy as np

from femb import Mechanism
from femb.elements import (Force, Gravity, PointMass, RigidBody, RotationalSpringDamper, Section,
                           SpringDamper, Torque, add_beam)
from femb.base.functions import Harmonic, Polynomial, TimeFunction
from femb.elements.bodies import Body

SEC = Section(EA=1e3, GA=4e2, EI=2.0, rhoA=1.5, rhoI=2e-3)
SEC_D = Section(EA=2e3, GA=7e2, EI=3.0, rhoA=0.8, rhoI=1e-3, damping=0.03)


def build():
    """The mechanism and its resolved, validated elements (Gravity left out: it has no kernel)."""
    m = Mechanism("kernels")
    a = m.add(RigidBody("A", 1.2, 0.05, (0.1, 0.2), 0.3, points={"p": (0.2, -0.1)}))
    b = m.add(RigidBody("B", 0.7, 0.02, (1.0, -0.4), -0.5))
    c = m.add(PointMass("C", 0.3, (0.5, 0.9)))
    m.ground.add_point("O", (-0.2, 0.1))
    m.add(SpringDamper("s1", a, b, 150.0, point_a=(0.1, 0.05), point_b=(-0.2, 0.1)))
    m.add(SpringDamper("s2", c, "ground", 60.0, length=0.4, point_b="O"))
    m.add(SpringDamper("s3", "ground", a, 80.0, 3.5, 0.7, point_a=(0.3, 0.4), point_b="p"))
    m.add(SpringDamper("s4", b, c, 40.0, 1.2, point_a=(0.05, -0.1)))
    m.add(RotationalSpringDamper("r1", a, b, 12.0))
    m.add(RotationalSpringDamper("r2", "ground", b, 5.0, 0.7, angle=0.2))
    m.add(RotationalSpringDamper("r3", a, b, 2.0, 0.1))
    m.add(Torque("T1", a, 2.5))
    m.add(Torque("T2", b, -0.5))
    m.add(Torque("T3", b, Harmonic(1.5, 3.0, 0.2)))
    m.add(Torque("T4", a, TimeFunction(lambda t: t ** 3, lambda t: 3 * t ** 2, lambda t: 6 * t)))
    m.add(Force("F1", a, (1.0, -2.0), point=(0.2, 0.1)))
    m.add(Force("F2", b, (Harmonic(2.0, 3.0, 0.1), Polynomial([0.5, 1.0, -0.3])), point=(-0.1, 0.3),
                frame="body"))
    m.add(Force("F3", c, (0.3, 0.4), frame="body"))
    m.add(Force("F4", a, (Polynomial([0.0, 2.0]), -0.7), point="p"))
    add_beam(m, "b", SEC, (a, (0.2, 0.0)), (1.4, 0.7), 3, sweep=0.8)
    add_beam(m, "d", SEC_D, (-0.5, -0.5), (b, (0.1, 0.0)), 2, start_joint="clamp", mass="lumped")
    m.add(Gravity((0.0, -9.81)))

    def lookup(ref, role):
        return m[ref] if isinstance(ref, str) else ref

    elements = []
    for e in m.elements:
        if isinstance(e, Gravity):
            continue
        e.resolve(lookup)
        e.validate()
        if not isinstance(e, Body):
            elements.append(e)
    return m, elements


def batches(elements):
    """Stand-in batch objects {label: group}, one per (type, group_key)."""
    by_key = {}
    for e in elements:
        by_key.setdefault((type(e), e.group_key()), []).append(e)
    out = {}
    for (cls, key), els in by_key.items():
        p = cls.pack(els)
        tfs = getattr(cls, "time_functions", None)
        x0 = np.array([np.concatenate([n.q0 for n in e.nodes()]) for e in els])
        out[f"{cls.__name__}{key!r}"] = SimpleNamespace(
            cls=cls, els=els, p=p, P=p.get("P"), nel=len(els), ndv=x0.shape[1], nc=cls.n_constraints,
            traits=cls.traits(els), time_functions=[tfs(e) for e in els] if tfs else [], x0=x0)
    return out


def random_state(g, rng, scale=0.2):
    """A random (t, xe, ve, le) around the initial configuration of batch g."""
    t = float(rng.uniform(0.1, 2.0))
    xe = g.x0 + scale * rng.standard_normal(g.x0.shape)
    ve = rng.standard_normal(g.x0.shape)
    le = rng.standard_normal((g.nel, g.nc))
    return t, xe, ve, le
