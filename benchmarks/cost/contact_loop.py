"""The compiled time loop of femb.contact against its Python loop on the contact scenes, same run.

``python -m femb.benchmarks.cost.contact_loop [--repeats N]`` runs each scene with
:func:`femb.contact.simulate` twice per repeat, ``compiled=True`` and ``compiled=False``
(interleaved, after one run of each so that no compile is timed), and prints the medians of the
wall time of the time loop (``Result.wall_time``: the start excluded), of the whole call
(``time.perf_counter`` around ``simulate``, the start included), their ratio, and the largest
difference of the coordinates between the two loops:

* ``ball``: the bouncing ball (e_N = 0.5) over 1.5 s at h = 2e-3 s (15 impacts, then at rest);
* ``slider-crank``: the slider–crank with translational clearance over 0.02 s at h = 1e-4 s
  (impacts and clusters of micro-impacts between the guides; the loops may part on round-off in a
  cluster, docs/contact.md §8);
* ``tippe top``: 0.2 s at h = 2e-3 s (spatial, sliding contact);
* ``rocking block``: 0.8 s at h = 2e-3 s (corner impacts).
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np


def cases():
    """{scene: (model, t_end, h)}."""
    from femb.benchmarks.scenes.contact import contact_ball, contact_rocking, contact_slider_crank, contact_tippetop
    return {"ball": (contact_ball.build(e_N=0.5).compile(), 1.5, 2e-3),
            "slider-crank": (contact_slider_crank.build().compile(), 0.02, 1e-4),
            "tippe top": (contact_tippetop.build().compile(), 0.2, 2e-3),
            "rocking block": (contact_rocking.build().compile(), 0.8, 2e-3)}


def _run(model, t_end, h, compiled):
    from femb.contact import simulate
    t0 = time.perf_counter()
    res = simulate(model, t_end, h, compiled=compiled)
    return res, time.perf_counter() - t0


def measure(repeats=5):
    """{scene: dict of medians (ms per step of the loop, s per call) and the two loops' largest |Δq|}."""
    out = {}
    for name, (model, t_end, h) in cases().items():
        runs = {True: [], False: []}
        last = {}
        for c in (True, False):
            _run(model, t_end, h, c)                       # compile and warm up
        for _ in range(repeats):
            for c in (True, False):
                res, wall = _run(model, t_end, h, c)
                runs[c].append((res.wall_time / (res.t.size - 1) * 1e3, wall))
                last[c] = res
        med = {c: (statistics.median(a for a, _ in v), statistics.median(b for _, b in v)) for c, v in runs.items()}
        out[name] = {"steps": last[True].t.size - 1, "substeps": last[True].stats["substeps"],
                     "compiled ms/step": med[True][0], "python ms/step": med[False][0],
                     "compiled call (s)": med[True][1], "python call (s)": med[False][1],
                     "max |dq|": float(np.abs(last[True].q - last[False].q).max())}
    return out


def report(rows):
    lines = ["| scene | steps (substeps) | compiled loop (ms/step) | Python loop (ms/step) | Python / compiled, loop | "
             "whole call: compiled / Python (s) | max abs(Δq) |", "|---|---|---|---|---|---|---|"]
    for name, r in rows.items():
        lines.append(f"| {name} | {r['steps']} ({r['substeps']}) | {r['compiled ms/step']:.4f} | "
                     f"{r['python ms/step']:.4f} | {r['python ms/step'] / r['compiled ms/step']:.1f} | "
                     f"{r['compiled call (s)']:.3f} / {r['python call (s)']:.3f} | {r['max |dq|']:.1e} |")
    return lines


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args(argv)
    for line in report(measure(args.repeats)):
        print(line)


if __name__ == "__main__":
    main()
