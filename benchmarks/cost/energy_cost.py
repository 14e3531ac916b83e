"""The cost of energies and momenta per stored step on a long spatial beam.

``python -m femb.benchmarks.cost.energy_cost`` builds the steel rod of
:mod:`femb.benchmarks.cost.spatial_beam_scaling` with ``--elements`` elements (default 10⁴;
clamped, falling under gravity, h = 1e-4 s, ρ∞ = 0.7), stores ``--steps`` steps of a
simulation, then times, interleaved in one process (median of ``--repeats`` rounds
after one warm-up round):

* ``kernel``: the strain energy by the compiled ``"energy"`` kernel of
  :class:`~femb.elements.spatial_beam.SpatialBeam` (``femb.results.energy.elastic_energy``);
* ``python``: the same energy by the type's numpy/Python method
  ``SpatialBeam.strain_energy`` (a loop over elements calling the compiled
  section frames), the alternative to a kernel role;
* ``force``: one evaluation of the batch's force kernel without tangent, the
  reference of the ratios (the compiled loop calls it at least once per Newton
  iteration);
* ``energies``: everything of ``Result.energy()`` (kinetic, gravitational,
  elastic, dissipated, ...);
* ``momentum``: ``Result.momentum()``.

It prints ms per stored step and the ratios against ``force``.
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np


def _timed(fn):
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def measure(n=10_000, steps=5, repeats=5, h=1e-4):
    """Median seconds per stored step of each operation (see the module docstring), dict."""
    import femb
    from femb.results import energy as fe
    from femb.system import kernels

    from femb.benchmarks.cost.spatial_beam_scaling import build

    model = build(n).compile()
    r = femb.simulate(model, steps * h, h, rho_inf=0.7)
    g = next(g for g in model.groups if "energy" in (g.cls.kernels or {}))
    qx = [model.ext(q) for q in r.q]
    z = np.zeros((g.nel, g.ndv))
    ops = {
        "kernel": lambda: fe.elastic_energy(r),
        "python": lambda: [g.cls.strain_energy(g.params, x[g.xdofs]).sum() for x in qx],
        "force": lambda: [kernels.force(g, 0.0, x[g.xdofs], z, jac=False) for x in qx],
        "energies": lambda: fe.energies(r),
        "momentum": lambda: fe.momentum(r),
    }
    for f in ops.values():                       # warm-up: compile, caches
        f()
    times = {k: [] for k in ops}
    for _ in range(repeats):                     # interleaved rounds
        for k, f in ops.items():
            times[k].append(_timed(f))
    nt = r.t.size
    return {k: statistics.median(v) / nt for k, v in times.items()}, nt


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--elements", type=int, default=10_000)
    ap.add_argument("--steps", type=int, default=5)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args(argv)
    res, nt = measure(args.elements, args.steps, args.repeats)
    print(f"spatial beam, {args.elements} elements, {nt} stored steps, median of {args.repeats} rounds")
    print(f"{'operation':<10s} {'ms/step':>10s} {'× force':>9s}")
    for k, v in res.items():
        print(f"{k:<10s} {1e3 * v:10.3f} {v / res['force']:9.2f}")


if __name__ == "__main__":
    main()
