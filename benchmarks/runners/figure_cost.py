"""CPU time of the benchmark suite's work–precision figures: plain log axes against matplotlib's defaults.

Renders the two figures of one work–precision study (:func:`femb.benchmarks.runners.work_precision.figure`
and :func:`~femb.benchmarks.runners.work_precision.adaptive_figure`) of a synthetic study (five femb
series, an adaptive series and a scipy series of six points each, errors over eight decades) with
the log axes of :func:`femb.benchmarks.runners.bench_common.save_figure` (minor ticks at 2 and 5,
plain-text labels) and with matplotlib's defaults (minor ticks at 2 … 9, math-text labels),
interleaved in one process, and prints the median CPU time (``time.process_time``) per pair of
figures and the ratio.

Usage::

    python -m femb.benchmarks.runners.figure_cost [--runs 5]
"""
from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np


def synthetic_study(n=6):
    """A work–precision study dict with the keys the figures read (errors ∝ h², wall ∝ 1/h)."""
    h = 1e-3 / 2.0 ** np.arange(n)

    def points(scale, err0):
        out = []
        for k, hk in enumerate(h):
            e = err0 * (hk / h[0]) ** 2
            out.append({"h": float(hk), "rtol": float(10.0 ** -(4 + k)), "wall_s": float(scale * h[0] / hk),
                        "steps": int(100 * 2 ** k), "failed": None,
                        "errors": {g: {"final_rel": e * f, "max_rel": 2 * e * f}
                                   for g, f in (("positions", 1.0), ("velocities", 3.0), ("multipliers", 10.0))}})
        return out

    femb = [{"rho_inf": r, "scaling": s, "points": points(0.01 * (1 + i), 1e-2 * (1 + i))}
            for i, (r, s) in enumerate(((0.0, True), (0.5, True), (0.7, True), (0.9, True), (0.7, False)))]
    return {"scene": "synthetic", "t_end": 1.0, "mode": "outputs", "femb": femb,
            "groups": {"positions": ["x"], "velocities": ["x_d"], "multipliers": ["lambda"]},
            "adaptive": {"rho_inf": 0.7, "points": points(0.02, 3e-2)},
            "exudyn": {"series": []}, "scipy": {"series": [{"method": "Radau", "points": points(0.5, 1e-3)}]}}


def measure(runs=5):
    """{"plain": [s], "default": [s]}: CPU time per pair of figures, interleaved runs."""
    from femb.benchmarks.runners import bench_common, work_precision

    wp = synthetic_study()
    out = {"plain": [], "default": []}
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        work_precision.figure(wp, d / "warm.png")            # imports, fonts
        for _ in range(runs):
            for style in out:
                bench_common.PLAIN_LOG_AXES = style == "plain"
                c0 = time.process_time()
                work_precision.figure(wp, d / f"wp_{style}.png")
                work_precision.adaptive_figure(wp, d / f"wpa_{style}.png")
                out[style].append(time.process_time() - c0)
    bench_common.PLAIN_LOG_AXES = True
    return out


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--runs", type=int, default=5)
    args = p.parse_args(argv)
    res = measure(args.runs)
    med = {k: statistics.median(v) for k, v in res.items()}
    for k, v in res.items():
        print(f"{k:8s} CPU s per pair of figures: median {med[k]:.3f} (runs: {', '.join(f'{x:.3f}' for x in v)})")
    print(f"plain / default: {med['plain'] / med['default']:.2f}")


if __name__ == "__main__":  # pragma: no cover
    main()
