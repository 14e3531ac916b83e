"""Cost of the spatial element kernels per element (median of repeated batch calls).

Run: ``python -m femb.benchmarks.cost.spatial_kernel_cost [nel]``. Random states, one
batch of ``nel`` elements per type; prints the median time per element of the
constraint kernel (Φ, B, H), the rates kernel and the force kernels (f, fq, fv),
measured with time.perf_counter after a warm-up call (compilation excluded). The SE(3)
beam (``SpatialBeam``, diagonal section stiffness) is timed here between two random frames;
``benchmarks/cost/spatial_beam_scaling.py`` times it on a meshed beam near its reference.
"""
from __future__ import annotations

import sys
import time

import numpy as np

from femb import Mechanism
from femb.base import rotations as rt
from femb.elements import spatial_forces as sf
from femb.elements import spatial_joints as sj
from femb.elements.spatial_beam import SpatialBeam, SpatialSection
from femb.elements.spatial_bodies import SpatialRigidBody


def _state(rng, nel, nn):
    x = np.zeros((nel, 7 * nn))
    for e in range(nel):
        for k in range(nn):
            x[e, 7 * k:7 * k + 3] = rng.standard_normal(3)
            x[e, 7 * k + 3:7 * k + 7] = rt.quat_exp(rng.standard_normal(3))
    return x, rng.standard_normal((nel, 6 * nn))


def _median(fn, repeat=15):
    fn()
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return float(np.median(ts))


def main(nel=2000):
    rng = np.random.default_rng(0)
    mech = Mechanism("cost")
    a = mech.add(SpatialRigidBody("A", 1.0, (1, 2, 2.5), position=(0.1, 0.2, 0.3)))
    b = mech.add(SpatialRigidBody("B", 1.0, (1, 2, 2.5), position=(1.0, 0.2, 0.3)))
    at, ax = (0.5, 0.2, 0.3), (0.3, 0.4, 0.8)
    joints = [sj.SphericalJoint("sph", a, b, at=at), sj.RevoluteJoint("rev", a, b, at=at, axis=ax),
              sj.UniversalJoint("uni", a, b, axis_a=(1, 0, 0), axis_b=(0, 1, 0), at=at),
              sj.PrismaticJoint("pri", a, b, at=at, axis=ax), sj.FixedJoint("fix", a, b, at=at, axis=ax),
              sj.DistanceJoint("dist", a, b), sj.DrivenRevoluteAngle("drv", a, b, 0.3, at=at, axis=ax)]
    sec = SpatialSection.from_properties(1e6, 1e6, 1e6, 1e3, 1e3, 1e3, rhoA=1.0, rhoJ=(2, 1, 1))
    forces = [sf.PointSpringDamper("spring", a, b, 10.0, 1.0), sf.Bushing("bush", a, b, (1, 2, 3), (4, 5, 6), (1, 1, 1),
                                                                          (1, 1, 1), at=at, axis=ax),
              sf.RotationalSpringDamper("torsion", a, b, 3.0, 0.1, at=at, axis=ax),
              sf.SpatialForce("force", a, (1, 2, 3), point=(0.1, 0, 0)), a, SpatialBeam("beam", a, b, sec)]
    lookup = lambda ref, role: mech[ref] if isinstance(ref, str) else ref  # noqa: E731
    print(f"spatial kernel cost, nel = {nel}, median of 15 calls, ns per element")
    print(f"{'element':22s} {'constraint+H':>13s} {'constraint':>11s} {'rates':>9s}")
    for j in joints:
        j.resolve(lookup)
        j.validate()
        P = np.ascontiguousarray(np.repeat(type(j).pack([j])["P"], nel, axis=0))
        nc = j.n_constraints
        x, v = _state(rng, nel, 2)
        tf = np.zeros((nel, len(type(j).time_functions(j)), 3))
        le = rng.standard_normal((nel, nc))
        Phi, B, H = np.zeros((nel, nc)), np.zeros((nel, nc, 12)), np.zeros((nel, 12, 12))
        k = j.kernels
        tj = _median(lambda: k["constraint"](P, 0.1, tf, x, le, True, Phi, B, H))
        tn = _median(lambda: k["constraint"](P, 0.1, tf, x, le, False, Phi, B, H))
        tr = _median(lambda: k["rates"](P, 0.1, tf, x, v, Phi, le))
        print(f"{type(j).__name__:22s} {1e9 * tj / nel:13.0f} {1e9 * tn / nel:11.0f} {1e9 * tr / nel:9.0f}")
    print(f"{'element':22s} {'force+fq+fv':>13s} {'force':>11s}")
    for f in forces:
        if f is not a:
            f.resolve(lookup)
            f.validate()
        cls = type(f)
        P = np.ascontiguousarray(np.repeat(cls.pack([f])["P"], nel, axis=0))
        nn = len(f.nodes())
        x, v = _state(rng, nel, nn)
        ntf = len(cls.time_functions(f)) if hasattr(cls, "time_functions") else 0
        tf = np.ones((nel, ntf, 3))
        nd = 6 * nn
        fe, fq, fv = np.zeros((nel, nd)), np.zeros((nel, nd, nd)), np.zeros((nel, nd, nd))
        k = f.kernels["force"]
        tj = _median(lambda: k(P, 0.1, tf, x, v, True, fe, fq, fv))
        tn = _median(lambda: k(P, 0.1, tf, x, v, False, fe, fq, fv))
        print(f"{cls.__name__:22s} {1e9 * tj / nel:13.0f} {1e9 * tn / nel:11.0f}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 2000)
