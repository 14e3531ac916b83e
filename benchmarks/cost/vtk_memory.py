"""Peak memory of a long run with and without streamed VTK output.

A conservative pendulum (hinge to ground, gravity) is integrated for
``--steps`` steps with ``store=False``; with ``--vtk DIR`` every ``--every``-th
step is streamed to a ParaView series while the run goes. Run each variant in
its own process under ``/usr/bin/time -v`` and compare "Maximum resident set
size"; the script also prints its own peak (``resource.getrusage``).

Usage::

    /usr/bin/time -v python -m femb.benchmarks.cost.vtk_memory --steps 100000
    /usr/bin/time -v python -m femb.benchmarks.cost.vtk_memory --steps 100000 --vtk out/mem --every 10
"""
from __future__ import annotations

import argparse
import resource
import time


def build():
    import femb
    from femb.elements import Gravity, Hinge, RigidBody

    m = femb.Mechanism("pendulum")
    bar = m.add(RigidBody("bar", 1.0, 1 / 12, (0.5, 0.0), 0.0, points={"O": (-0.5, 0.0)}))
    m.add(Hinge("pivot", "ground", bar, point_b="O"))
    m.add(Gravity((0.0, -9.81)))
    return m


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=100_000)
    ap.add_argument("--h", type=float, default=1e-3)
    ap.add_argument("--vtk", default=None, help="stream frames to this folder")
    ap.add_argument("--every", type=int, default=10)
    a = ap.parse_args(argv)
    import femb

    model = build().compile()
    t0 = time.perf_counter()
    if a.vtk:
        import femb.io

        with femb.io.VTKStream(model, a.vtk, every=a.every) as vtk:
            res = femb.simulate(model, a.steps * a.h, a.h, rho_inf=0.9, store=False, observer=vtk)
        frames = vtk.writer.frames
    else:
        res = femb.simulate(model, a.steps * a.h, a.h, rho_inf=0.9, store=False)
        frames = 0
    wall = time.perf_counter() - t0
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"steps {res.steps}, frames written {frames}, wall {wall:.1f} s, "
          f"peak RSS {peak_mb:.1f} MB")


if __name__ == "__main__":
    main()
