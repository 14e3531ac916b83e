"""Cost of a pile of spheres that declares every pair (``SpatialSpherePair``): the broad phase, and the
sparse path's solve by the unit rows first (``femb.contact.step._solve_unit_rows``), same run.

For each n in ``--sizes`` (default 20, 40, 60, 120, 200): the n spheres of
:mod:`femb.benchmarks.scenes.contact.contact_spheres` (sliding to rolling on the floor, e.g. every floor
contact closed; grid pitch ``--pitch``, 0.15 m: 5 cm between neighbours, or e.g. 0.104 m: 4 mm, within
the broad phase's margin) plus all n (n − 1) / 2 ``SpatialSpherePair`` elements between them (radius
0.05 m, μ = 0.3), ``--steps`` fixed steps of h = 1e-3 s with :func:`femb.contact.simulate`, the wall time
of the time loop (``Result.wall_time``, the start and the model's compilation excluded) per step, median
of ``--repeats`` runs, interleaved:

* ``broad phase``: the default (femb/contact/broadphase.py): each step solved on the floor contacts and
  the pairs that can close in it;
* ``every pair``: ``broad_phase=False``: every pair in every step, the open ones' rows solved first;
* ``whole LU``: ``broad_phase=False`` and ``UNIT_ROWS_MIN`` set beyond reach, SuperLU factors the whole
  Jacobian; run only up to ``--whole-max`` spheres (it takes seconds per step beyond);
* ``no pairs``: the same spheres without the pair elements (what the floor contacts cost).

Also printed: the pairs in a step (mean), the Newton iterations per step, the largest difference of the
coordinates against the broad phase's run, and the broad phase's ms per sphere and step.

Run ``python -m femb.benchmarks.cost.contact_sphere_pairs [--sizes 20,40,60] [--steps 3] [--repeats 3]``.
"""
from __future__ import annotations

import argparse
import itertools
import statistics

import numpy as np


def pile(n, pitch=0.15, pairs=True):
    """The compiled model: n spheres on the floor and (``pairs``) every pair between them."""
    from femb.benchmarks.scenes.contact import contact_spheres
    from femb.elements.contact import SpatialSpherePair

    mech = contact_spheres.build(n=n, pitch=pitch)
    if pairs:
        for i, j in itertools.combinations(range(n), 2):
            mech.add(SpatialSpherePair(f"p{i}_{j}", f"s{i}", f"s{j}", radius_a=0.05, radius_b=0.05, mu=0.3))
    return mech.compile()


def _run(model, steps, variant):
    from femb.contact import broadphase, simulate
    from femb.contact import step as contact_step

    keep, solve = contact_step.UNIT_ROWS_MIN, broadphase.BroadPhaseStep.solve
    seen = {}

    def counted(self, s):                          # the broad phase's stats (what it solved for)
        out = solve(self, s)
        seen.update(self.stats)
        return out

    contact_step.UNIT_ROWS_MIN = 10 ** 12 if variant == "whole" else keep
    broadphase.BroadPhaseStep.solve = counted
    try:
        res = simulate(model, steps * 1e-3, 1e-3, rho_inf=0.8, broad_phase=variant == "broad")
    finally:
        contact_step.UNIT_ROWS_MIN, broadphase.BroadPhaseStep.solve = keep, solve
    return res.wall_time / steps * 1e3, res, seen


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="20,40,60,120,200")
    ap.add_argument("--steps", type=int, default=3)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--whole-max", type=int, default=60)
    ap.add_argument("--pitch", type=float, default=0.15)
    a = ap.parse_args(argv)
    print("| spheres | pairs | pairs in a step | broad phase (ms/step) | every pair (ms/step) | whole LU (ms/step) "
          "| no pairs (ms/step) | every pair / broad phase | Newton it./step | max abs(Δq) | broad phase: ms per sphere "
          "and step |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for n in (int(s) for s in a.sizes.split(",")):
        models = {"broad": pile(n, a.pitch), "none": pile(n, a.pitch, pairs=False)}
        models["every"] = models["whole"] = models["broad"]
        variants = ["broad", "every", "none"] + (["whole"] if n <= a.whole_max else [])
        for v in variants:                              # warm up (compile, caches)
            _run(models[v], 1, v)
        ms = {v: [] for v in variants}
        res, seen = {}, {}
        for _ in range(a.repeats):
            for v in variants:
                t, res[v], st = _run(models[v], a.steps, v)
                ms[v].append(t)
                if v == "broad":
                    seen = st
        med = {v: statistics.median(ms[v]) if v in ms else float("nan") for v in ("broad", "every", "whole", "none")}
        dq = max(float(np.max(np.abs(res[v].q - res["broad"].q))) for v in variants if v != "none")
        in_step = seen["contacts"] / max(seen["solves"], 1) - n if seen else float("nan")
        r = res["broad"]
        print(f"| {n} | {n * (n - 1) // 2} | {in_step:.1f} | {med['broad']:.1f} | {med['every']:.1f} | "
              f"{med['whole']:.1f} | {med['none']:.1f} | {med['every'] / med['broad']:.1f} | "
              f"{np.mean(r.newton_iterations):.2f} | {dq:.1e} | {med['broad'] / n:.3f} |", flush=True)


if __name__ == "__main__":
    main()
