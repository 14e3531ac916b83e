"""Adaptive against fixed steps of :func:`femb.contact.simulate`: steps, error and wall time, same run.

``python -m femb.benchmarks.cost.contact_adaptive [--repeats N]`` prints a table (docs/contact.md §1.2):

* ``tippe top``, 0.2 s of persistent sliding contact: the error of the centre's height z against the
  independent Newton–Euler reference integrated by scipy (:func:`contact_tippetop.reference`);
* ``rocking block``, 1 s: the first impact's angular speed ω⁻ against energy conservation
  (:func:`contact_rocking.first_impact_speed`);
* ``bouncing ball``, 1.4 s: the largest error of the first six impact times against the closed form,
  and whether the ball is at rest at the end.

Both run with the defaults: fixed steps many at a time in the compiled loop, adaptive steps one per call
of the compiled loop with the controller in Python. Wall time: ``Result.wall_time`` (the time loop),
median of ``repeats`` runs after one that is not timed. A second table compares the adaptive controller
over the compiled loop with the same over the Python loop (``compiled=False``): steps, largest
difference of q, time.
"""
from __future__ import annotations

import argparse
import math
import statistics

import numpy as np


def _top():
    from femb.benchmarks.scenes.contact import contact_tippetop as tt
    T = 0.2
    ref = tt.reference([T])["z"][-1]
    return tt.build().compile(), T, 1e-3, (lambda r: abs(r.q[-1][2] - ref)), "abs(z - z_ref) (m)"


def _rocking():
    from femb.benchmarks.scenes.contact import contact_rocking as rk
    w = rk.first_impact_speed()

    def err(r):
        ev = [e for e in r.events if abs(e["u_before"][2]) > 1e-6]
        return abs(abs(ev[0]["u_before"][2]) - w) if ev else math.nan
    return rk.build().compile(), 1.0, 2e-3, err, "abs(omega- - exact) (rad/s), first impact"


def _ball():
    from femb.benchmarks.scenes.contact import contact_ball as cb
    t1 = math.sqrt(2.0 * 0.9 / 9.81)
    exact = np.array([t1] + [t1 + 2 * t1 * sum(0.5 ** k for k in range(1, n + 1)) for n in range(1, 6)])

    def err(r):
        got = np.array([e["t"] for e in r.events][:6])
        rest = abs(r.qd[-1][1]) < 1e-9
        return float(np.max(np.abs(got - exact))) if got.size == 6 and rest else math.nan
    return cb.build().compile(), 1.4, 2e-3, err, "max abs error of 6 impact times (s), at rest at the end"


SCENES = {"tippe top": (_top, ((1e-3, 5e-4, 2.5e-4), (1e-4, 1e-5, 1e-6))),
          "rocking block": (_rocking, ((2e-3, 1e-3), (1e-4, 1e-6))),
          "bouncing ball": (_ball, ((2e-3,), (1e-4,)))}


def measure(repeats=3):
    """Rows (scene, run, steps, rejected, unchecked, error, error measure, ms of the time loop)."""
    from femb.contact import simulate
    rows = []
    for name, (make, (hs, rtols)) in SCENES.items():
        model, T, h0, err, what = make()
        runs = [(f"fixed h = {h:g}", (lambda h=h: simulate(model, T, h))) for h in hs]
        runs += [(f"adaptive rtol = {r:g}", (lambda r=r: simulate(model, T, h0, rtol=r))) for r in rtols]
        for label, f in runs:
            res = f()
            wall = statistics.median(f().wall_time for _ in range(repeats))
            st = res.stats
            rows.append((name, label, st["steps"], st.get("rejected_steps", "–"), st.get("unchecked_steps", "–"),
                         err(res), what, 1e3 * wall))
    return rows


def loops(repeats=3):
    """Rows (scene, steps, max |Δq| compiled − Python, ms of the time loop compiled, Python): the adaptive
    controller over the compiled loop (the default) and over the Python loop (``compiled=False``)."""
    from femb.benchmarks.scenes.contact import contact_slider_crank as sc
    from femb.contact import simulate
    cases = [(name, make()[:3]) for name, (make, _) in SCENES.items()]
    cases.append(("slider-crank", (sc.build().compile(), 0.02, 1e-4)))
    rows = []
    for name, (model, T, h0) in cases:
        runs = {c: (lambda c=c: simulate(model, T, h0, rtol=1e-5, compiled=c)) for c in (True, False)}
        res = {c: f() for c, f in runs.items()}
        ms = {c: 1e3 * statistics.median(f().wall_time for _ in range(repeats)) for c, f in runs.items()}
        a, b = res[True], res[False]
        dq = float(np.max(np.abs(a.q - b.q))) if a.q.shape == b.q.shape else math.nan
        rows.append((name, a.stats["steps"], dq, ms[True], ms[False]))
    return rows


def report(rows):
    out = ["| scene | run | steps | rejected | without error test | error | error measure | time loop (ms) |",
           "|---|---|---|---|---|---|---|---|"]
    for name, label, n, rej, unc, e, what, ms in rows:
        out.append(f"| {name} | {label} | {n} | {rej} | {unc} | {e:.2e} | {what} | {ms:.1f} |")
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)
    for line in report(measure(args.repeats)):
        print(line)
    print()
    print("| scene, rtol = 1e-5 | steps | max abs(q compiled - q Python) | time loop compiled (ms) | Python loop (ms) |")
    print("|---|---|---|---|---|")
    for name, n, dq, c, p in loops(args.repeats):
        print(f"| {name} | {n} | {dq:.1e} | {c:.1f} | {p:.1f} |")


if __name__ == "__main__":
    main()
