"""Cost of the nonsmooth contact step against the number of contacts: n spheres on the floor.

For each n in ``sizes`` (default 25, 50, 100, 200, 400 spheres), two models of
:mod:`femb.benchmarks.scenes.contact.contact_spheres`, run ``repeats`` times interleaved in this process
with :func:`femb.contact.simulate`, ``steps`` fixed steps of h = 1e-3 s (ρ∞ = 0.8), the wall time of the
time loop (``Result.wall_time``: ``time.perf_counter`` around the loop; the start and the model's
compilation excluded), medians in ms per step:

* ``contact``: the spheres on the floor, each slipping and then rolling (every contact closed, a
  slip–stick transition per sphere within the first 13 steps);
* ``open``: the same model with the spheres 1 m above the floor (falling freely, every contact open).

Above ``femb.contact.step.DENSE_MAX_UNKNOWNS`` unknowns (from 25 spheres on: 6 velocities and 3 contact
rows per sphere, 11 blocks of unknowns) the step runs on the sparse path (Python, SciPy's SuperLU;
docs/contact.md §7). Printed: ms/step of both, their ratio, mean Newton iterations per step, µs per
contact and step, the slope of log(ms/step) against log(n) (1: linear; below 1 while a fixed cost per
step still weighs) and the least-squares line ms/step = a + b n.

Run ``python -m femb.benchmarks.cost.contact_spheres [--sizes 25,50,...] [--repeats R] [--steps S]``.
"""
from __future__ import annotations

import argparse

import numpy as np

from femb.benchmarks.cost.penalty_spheres import slope


def _models(n):
    from femb.benchmarks.scenes.contact import contact_spheres

    return {"contact": contact_spheres.build(n=n).compile(), "open": contact_spheres.build(n=n, lift=1.0).compile()}


def _time(model, steps, h):
    from femb.contact import simulate

    res = simulate(model, steps * h, h, rho_inf=0.8)
    return res.wall_time / (res.t.size - 1) * 1e3, float(np.mean(res.newton_iterations))


def measure(sizes=(25, 50, 100, 200, 400), repeats=3, steps=20, h=1e-3):
    """{n: {"contact": ms/step, "open": ms/step, "iter_contact", "iter_open"}} (medians)."""
    out = {}
    for n in sizes:
        models = _models(n)
        for m in models.values():                  # warm up (compile, caches)
            _time(m, 2, h)
        ms = {k: [] for k in models}
        it = {}
        for _ in range(repeats):
            for k, m in models.items():
                t, i = _time(m, steps, h)
                ms[k].append(t)
                it[k] = i
        out[n] = {"contact": float(np.median(ms["contact"])), "open": float(np.median(ms["open"])),
                  "iter_contact": it["contact"], "iter_open": it["open"]}
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="25,50,100,200,400")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--steps", type=int, default=20)
    a = ap.parse_args(argv)
    sizes = [int(s) for s in a.sizes.split(",")]
    res = measure(sizes, a.repeats, a.steps)
    print("| spheres (contacts) | ms/step, contact | ms/step, open | contact/open | Newton it./step contact, open "
          "| µs per contact and step |")
    print("|---|---|---|---|---|---|")
    for n in sizes:
        r = res[n]
        print(f"| {n} | {r['contact']:.2f} | {r['open']:.2f} | {r['contact'] / r['open']:.2f} | "
              f"{r['iter_contact']:.2f}, {r['iter_open']:.2f} | {r['contact'] / n * 1e3:.0f} |")
    if len(sizes) > 1:
        for k in ("contact", "open"):
            b, a0 = np.polyfit(sizes, [res[n][k] for n in sizes], 1)
            print(f"linear fit, {k}: ms/step = {a0:.2f} + {b * 1e3:.0f} µs × n")
        print(f"fitted slope of log(ms/step) against log(n): contact {slope(sizes, [res[n]['contact'] for n in sizes]):.3f}, "
              f"open {slope(sizes, [res[n]['open'] for n in sizes]):.3f} (1: linear)")


if __name__ == "__main__":
    main()
