"""Per-step cost of the solver against the number of beam elements (spin-up scene).

Runs the spin-up scene (:mod:`femb.benchmarks.scenes.beams.spin_up`) with n beam elements
for a fixed number of steps of h = 5 ms from t = 10 s (the undeformed beam
rotating rigidly with the hub, made consistent), and prints the median
wall time per step over several runs (initialization excluded), Newton
iterations and factorizations per step, the linear solver used, and the
exponent p of a least-squares fit µs/step ∝ n^p. Linear growth (p ≈ 1) is the
goal: sparse assembly with a sparsity pattern compiled once, and sparse LU of
a banded (chain) system whose fill-in stays O(n).

Usage::

    python -m femb.benchmarks.cost.beam_scaling [--n 10 100 1000 10000] [--runs 3]
"""
from __future__ import annotations

import argparse
import statistics

import numpy as np

#: start time of the measured runs (s): inside the spin-up, hub at 4 rad/s
T0 = 10.0


def measure(n, steps, runs=3, h=5e-3, t0=T0):
    """Median µs per step for the spin-up scene with n elements, and counters.

    The run starts at ``t0`` from the rigidly rotating undeformed beam
    (:func:`femb.benchmarks.scenes.beams.spin_up.rigid_state`), so every step does real
    Newton work (centrifugal stretching and bending vibration).
    """
    import femb
    from femb.benchmarks.scenes.beams import spin_up

    model = spin_up.build(n).compile()
    state = femb.consistent_initial_state(model, spin_up.rigid_state(model, t0))
    per_step, res = [], None
    for _ in range(runs):
        res = femb.simulate(model, t0 + steps * h, h, rho_inf=0.7, store=False, state=state,
                            **spin_up.newton_options(n))
        per_step.append(1e6 * res.wall_time / res.steps)
    return {"n": n, "nq": model.nq, "nc": model.nc, "us_per_step": statistics.median(per_step),
            "runs": per_step, "steps": res.steps, "newton_per_step": float(res.newton_iterations.mean()),
            "factorizations_per_step": res.stats["factorizations"] / res.steps,
            "linear_solver": res.settings["linear_solver"],
            "tip_deflection": spin_up.final_outputs(res)["tip_deflection"]}


def fit_exponent(ns, us):
    """Exponent p of the least-squares fit us = C n^p (log–log)."""
    return float(np.polyfit(np.log(ns), np.log(us), 1)[0])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[10, 100, 1000, 10000])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--steps", type=int, default=0, help="steps per run (default: by size)")
    a = ap.parse_args(argv)
    rows = []
    print(f"spin-up scene, h = 5 ms from t = {T0:g} s, rho_inf = 0.7, full Newton; median of "
          f"{a.runs} runs")
    print(f"{'n':>6s} {'nq':>6s} {'nc':>3s} {'steps':>6s} {'us/step':>10s} {'us/(step n)':>12s} "
          f"{'newton':>7s} {'LU/step':>8s} {'us/iter':>9s}  solver")
    for n in a.n:
        steps = a.steps or int(np.clip(40000 // n, 20, 400))
        r = measure(n, steps, a.runs)
        rows.append(r)
        print(f"{n:6d} {r['nq']:6d} {r['nc']:3d} {r['steps']:6d} {r['us_per_step']:10.1f} "
              f"{r['us_per_step'] / n:12.3f} {r['newton_per_step']:7.2f} {r['factorizations_per_step']:8.2f}"
              f" {r['us_per_step'] / max(r['newton_per_step'], 1e-9):9.1f}  {r['linear_solver']}")
    ns = np.array([r["n"] for r in rows], dtype=float)
    us = np.array([r["us_per_step"] for r in rows])
    if len(ns) >= 2:
        print(f"fitted exponent p (us/step ~ n^p), all sizes: {fit_exponent(ns, us):.3f}")
    for lo in (100, 1000):
        big = ns >= lo
        if big.sum() >= 2 and big.sum() < len(ns):
            print(f"fitted exponent p, n >= {lo}: {fit_exponent(ns[big], us[big]):.3f}")
    it = np.array([r["newton_per_step"] for r in rows])
    if len(ns) >= 2:
        print(f"fitted exponent p of us per Newton iteration, all sizes: {fit_exponent(ns, us / it):.3f}")
    if len(ns) >= 3:
        # affine model us = a + b n (weighted by 1/us so small sizes count)
        A = np.column_stack((np.ones_like(ns), ns)) / us[:, None]
        a, b = np.linalg.lstsq(A, np.ones_like(us), rcond=None)[0]
        rel = (a + b * ns) / us - 1.0
        print(f"affine fit us/step = {a:.0f} + {b:.3f} n  (largest relative misfit {np.abs(rel).max():.1%})")


if __name__ == "__main__":
    main()
