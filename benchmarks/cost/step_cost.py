"""Per-step cost of the solver on Andrews' mechanism (fixed h = 3e-5 s, ρ∞ = 0.7).

Prints µs per step as the median of several runs, Newton iterations per step,
factorizations per step, and with ``--profile`` where the time goes.

Usage::

    python -m femb.benchmarks.cost.step_cost [--runs 3] [--h 3e-5] [--newton full] [--profile]
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np


def measure(h=3e-5, t_end=0.03, runs=3, **options):
    """Median wall time per step (µs) over ``runs`` runs, and solver counters."""
    import femb
    from femb.benchmarks.scenes.planar import andrews

    model = andrews.build().compile()
    per_step, res = [], None
    for _ in range(runs):
        t0 = time.perf_counter()
        res = femb.simulate(model, t_end, h, rho_inf=0.7, store=False, **options)
        per_step.append(1e6 * res.wall_time / res.steps)
        del t0
    ref = np.array([15.81077119629904, -15.75637105984298, 0.04082224013073101,
                    -0.5347301163226948, 0.5244099658805304, 0.5347301163226948, 1.048080741042263])
    err = float(np.abs(andrews.angles(res)[-1] - ref).max())
    return {"us_per_step_median": statistics.median(per_step), "us_per_step_runs": per_step,
            "steps": res.steps, "newton_per_step": float(res.newton_iterations.mean()),
            "factorizations_per_step": res.stats["factorizations"] / res.steps,
            "evaluations_per_step": res.stats["evaluations"] / res.steps,
            "angle_error_t003": err}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--h", type=float, default=3e-5)
    ap.add_argument("--newton", default="full", choices=("full", "modified"))
    ap.add_argument("--profile", action="store_true", help="print a cProfile summary of one run")
    a = ap.parse_args(argv)
    r = measure(h=a.h, runs=a.runs, newton=a.newton)
    print(f"Andrews, h = {a.h:g} s, rho_inf = 0.7, newton = {a.newton}: {r['steps']} steps")
    print(f"  us/step (median of {a.runs}): {r['us_per_step_median']:.1f}   "
          f"runs: {', '.join(f'{x:.1f}' for x in r['us_per_step_runs'])}")
    print(f"  Newton iterations/step: {r['newton_per_step']:.3f}   evaluations/step: "
          f"{r['evaluations_per_step']:.3f}   factorizations/step: {r['factorizations_per_step']:.3f}")
    print(f"  max angle error at t = 0.03 vs IVP test set: {r['angle_error_t003']:.3e} rad")
    if a.profile:
        import cProfile
        import pstats

        import femb
        from femb.benchmarks.scenes.planar import andrews
        model = andrews.build().compile()
        pr = cProfile.Profile()
        pr.enable()
        femb.simulate(model, 0.03, a.h, rho_inf=0.7, store=False, newton=a.newton)
        pr.disable()
        pstats.Stats(pr).sort_stats("tottime").print_stats(15)


if __name__ == "__main__":
    main()
