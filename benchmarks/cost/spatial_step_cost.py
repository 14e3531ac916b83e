"""Per-step cost of the compiled time loop on the spatial scenes (fixed steps, warm cache).

For each scene: compile the model, run ``femb.simulate`` once (compilation and
first-call costs), then ``runs`` more times; prints the median wall time per
step (time.perf_counter around ``femb.simulate``, divided by the number of
steps), the spread of the runs and the Newton iterations per step.

Usage::

    python -m femb.benchmarks.cost.spatial_step_cost [--runs 5] [--scenes heavy_top bricard ...]
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

#: scene: (module, compile options, t_end, h, rho_inf)
SCENES = {
    "heavy_top": ("heavy_top", {}, 1.0, 2.0 ** -10, 0.9),
    "spatial_slider_crank": ("spatial_slider_crank", {}, 0.5, 1e-4, 0.9),
    "bricard": ("bricard", {"redundant": "eliminate"}, 2.0, 1e-3, 0.9),
    "spatial_double_pendulum": ("spatial_double_pendulum", {}, 2.0, 1e-3, 0.9),
}


def measure(scene, runs=5):
    """Median µs per step over ``runs`` warm runs of one scene, the runs, steps and Newton/step."""
    import importlib
    import warnings

    import femb

    mod_name, copts, t_end, h, rho = SCENES[scene]
    from femb.study import registry
    mod = importlib.import_module(registry.scene_module(mod_name))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = mod.build().compile(**copts)
    femb.simulate(model, t_end, h, rho_inf=rho, store=False)       # compile / warm-up
    per_step, res = [], None
    for _ in range(runs):
        t0 = time.perf_counter()
        res = femb.simulate(model, t_end, h, rho_inf=rho, store=False)
        per_step.append(1e6 * (time.perf_counter() - t0) / res.steps)
    return {"us_per_step": statistics.median(per_step), "runs": per_step, "steps": res.steps,
            "newton_per_step": float(np.mean(res.newton_iterations)) if len(res.newton_iterations) else
            float(res.stats.get("evaluations", 0)) / res.steps, "h": h, "t_end": t_end}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--scenes", nargs="*", default=list(SCENES), choices=list(SCENES))
    a = ap.parse_args(argv)
    print(f"spatial scenes, warm cache, median of {a.runs} runs (first call excluded)")
    print(f"{'scene':26s} {'h [s]':>10s} {'t_end':>6s} {'steps':>7s} {'Newton/step':>12s} "
          f"{'us/step':>9s}  runs [us/step]")
    for s in a.scenes:
        r = measure(s, a.runs)
        print(f"{s:26s} {r['h']:10.4g} {r['t_end']:6g} {r['steps']:7d} {r['newton_per_step']:12.2f} "
              f"{r['us_per_step']:9.1f}  {', '.join(f'{x:.1f}' for x in r['runs'])}", flush=True)


if __name__ == "__main__":
    main()
