"""Cost of a pile of spheres that declares every pair (``SpatialSpherePair``), with and without the
sparse path's solve by the unit rows first (``femb.contact.step._solve_unit_rows``), same run.

For each n in ``--sizes`` (default 20, 40, 60, 120, 200): the n spheres of
:mod:`femb.benchmarks.scenes.contact.contact_spheres` (sliding to rolling on the floor, e.g. every floor
contact closed) plus all n (n − 1) / 2 ``SpatialSpherePair`` elements between them (radius 0.05 m,
μ = 0.3; almost all far apart, open), ``--steps`` fixed steps of h = 1e-3 s with
:func:`femb.contact.simulate`, the wall time of the time loop (``Result.wall_time``, the start and the
model's compilation excluded) per step, median of ``--repeats`` runs:

* ``unit rows first``: the default: the rows of the open pairs give their unknowns at once, SuperLU
  factors the rest;
* ``whole LU``: ``UNIT_ROWS_MIN`` set beyond reach, SuperLU factors the whole Jacobian (the solve before
  2026-11-29, with the zeros that J's fixed pattern stores now removed first); run only up to
  ``--whole-max`` spheres (it takes seconds per step beyond).

Also printed: the unknowns of the step, the Newton iterations per step, the largest difference of the
coordinates between the two runs, and ms per pair and step.

Run ``python -m femb.benchmarks.cost.contact_sphere_pairs [--sizes 20,40,60] [--steps 3] [--repeats 3]``.
"""
from __future__ import annotations

import argparse
import itertools
import statistics

import numpy as np


def pile(n):
    """The compiled model: n spheres on the floor and every pair between them."""
    from femb.benchmarks.scenes.contact import contact_spheres
    from femb.elements.contact import SpatialSpherePair

    mech = contact_spheres.build(n=n)
    for i, j in itertools.combinations(range(n), 2):
        mech.add(SpatialSpherePair(f"p{i}_{j}", f"s{i}", f"s{j}", radius_a=0.05, radius_b=0.05, mu=0.3))
    return mech.compile()


def _run(model, steps, whole):
    from femb.contact import simulate
    from femb.contact import step as contact_step

    keep = contact_step.UNIT_ROWS_MIN
    contact_step.UNIT_ROWS_MIN = 10 ** 12 if whole else keep
    try:
        res = simulate(model, steps * 1e-3, 1e-3, rho_inf=0.8)
    finally:
        contact_step.UNIT_ROWS_MIN = keep
    return res.wall_time / steps * 1e3, res


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="20,40,60,120,200")
    ap.add_argument("--steps", type=int, default=3)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--whole-max", type=int, default=60)
    a = ap.parse_args(argv)
    print("| spheres | pairs | unknowns | unit rows first (ms/step) | whole LU (ms/step) | whole / unit rows "
          "| Newton it./step | max abs(Δq) | ms per pair and step |")
    print("|---|---|---|---|---|---|---|---|---|")
    for n in (int(s) for s in a.sizes.split(",")):
        model = pile(n)
        variants = [False] + ([True] if n <= a.whole_max else [])
        for whole in variants:                          # warm up (compile, caches)
            _run(model, 1, whole)
        ms = {w: [] for w in variants}
        res = {}
        for _ in range(a.repeats):
            for whole in variants:
                t, res[whole] = _run(model, a.steps, whole)
                ms[whole].append(t)
        fast = statistics.median(ms[False])
        whole = statistics.median(ms[True]) if True in ms else float("nan")
        dq = float(np.max(np.abs(res[False].q - res[True].q))) if True in res else float("nan")
        pairs = n * (n - 1) // 2
        r = res[False]
        unknowns = 3 * r.model.nq + 3 * r.model.nc + 3 * len(r.contact_names) + 2 * r.contact["lam_F"].shape[1]
        print(f"| {n} | {pairs} | {unknowns} | {fast:.1f} | {whole:.1f} | {whole / fast:.1f} | "
              f"{np.mean(r.newton_iterations):.2f} | {dq:.1e} | {fast / pairs:.3f} |")


if __name__ == "__main__":
    main()
