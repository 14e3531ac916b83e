"""Cost of penalty contact in the compiled engine against the number of contacts.

For each n in ``sizes`` (default 25, 50, 100, 200, 400 spheres), two models of
:mod:`femb.benchmarks.scenes.contact.penalty_spheres`, run ``repeats`` times interleaved in
this process, ``steps`` fixed steps of h = 1e-3 s (ρ∞ = 0.8), the wall time of the time loop
(``Result.wall_time``: ``time.perf_counter`` around the compiled loop, the consistent initial state
and the model's compilation excluded), medians in ms per step:

* ``contact``: the spheres resting on the floor, every contact closed all along (persistent
  contact with friction);
* ``open``: the same model with the spheres 1 m above the floor (falling freely, every contact
  open): the same elements, kernels and unknowns.

Printed: ms/step of both, their ratio, mean Newton iterations per step, µs per contact and step,
the slope of log(ms/step) against log(n) fitted over the sizes (1: linear; below 1 while a fixed
cost per step still weighs) and the least-squares line ms/step = a + b n (b: the cost per contact).

Run ``python -m femb.benchmarks.cost.penalty_spheres [--sizes 25,50,...] [--repeats R] [--steps S]``.
"""
from __future__ import annotations

import argparse

import numpy as np


def _models(n):
    from femb.benchmarks.scenes.contact import penalty_spheres

    return {"contact": penalty_spheres.build(n=n).compile(), "open": penalty_spheres.build(n=n, lift=1.0).compile()}


def _run(model, steps, h):
    import femb

    res = femb.simulate(model, t_end=steps * h, h=h, rho_inf=0.8)
    return res.wall_time / (res.t.size - 1) * 1e3, float(np.mean(res.newton_iterations))


def measure(sizes=(25, 50, 100, 200, 400), repeats=3, steps=200, h=1e-3, models=None, run=None):
    """{n: {"contact": ms/step, "open": ms/step, "iter_contact", "iter_open"}} (medians). ``models(n)`` gives
    the two models ({"contact", "open"}), ``run(model, steps, h)`` (ms/step, Newton iterations per step)
    (default: this module's penalty spheres in the engine)."""
    models_of, _time = models or _models, run or _run
    out = {}
    for n in sizes:
        models = models_of(n)
        for m in models.values():                  # warm up (compile, caches)
            _time(m, 5, h)
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


def slope(sizes, ms):
    """Fitted exponent p of ms ∝ nᵖ (least squares in log–log)."""
    return float(np.polyfit(np.log(np.asarray(sizes, dtype=float)), np.log(np.asarray(ms)), 1)[0])


def report(sizes, res, digits=3):
    """The table and the fits of :func:`measure`'s result, as lines."""
    lines = ["| spheres (contacts) | ms/step, contact | ms/step, open | contact/open | Newton it./step contact, open "
             "| µs per contact and step |", "|---|---|---|---|---|---|"]
    for n in sizes:
        r = res[n]
        lines.append(f"| {n} | {r['contact']:.{digits}f} | {r['open']:.{digits}f} | {r['contact'] / r['open']:.2f} | "
                     f"{r['iter_contact']:.2f}, {r['iter_open']:.2f} | {r['contact'] / n * 1e3:.2f} |")
    if len(sizes) > 1:
        for k in ("contact", "open"):
            b, a = np.polyfit(sizes, [res[n][k] for n in sizes], 1)
            lines.append(f"linear fit, {k}: ms/step = {a:.3f} + {b * 1e3:.3f} µs × n")
        lines.append(f"fitted slope of log(ms/step) against log(n): contact "
                     f"{slope(sizes, [res[n]['contact'] for n in sizes]):.3f}, "
                     f"open {slope(sizes, [res[n]['open'] for n in sizes]):.3f} (1: linear)")
    return lines


def main(argv=None, doc=__doc__, steps=200, models=None, run=None, digits=3):
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--sizes", default="25,50,100,200,400")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--steps", type=int, default=steps)
    a = ap.parse_args(argv)
    sizes = [int(s) for s in a.sizes.split(",")]
    for line in report(sizes, measure(sizes, a.repeats, a.steps, models=models, run=run), digits):
        print(line)

if __name__ == "__main__":
    main()
