"""Per-step cost against the number of SE(3) spatial beam elements (dynamic cantilever), and kernel cost.

A steel rod (L = 1 m, d = 20 mm, E = 210 GPa, G = 80.8 GPa, ρ = 7850 kg/m³) clamped at
x = 0 along x, released undeformed under gravity (0, 0, −9.81): a flexural vibration
in which every step does Newton work on all elements. n elements, fixed steps
h = 1e-4 s, ρ∞ = 0.7, from t = 0; the time loop's wall time per step (consistent
initial values excluded) is the median over ``--runs`` runs (time.perf_counter inside
:func:`femb.simulate`). The exponent p of the least-squares fit ms/step ∝ n^p is printed
for n ≥ 10³. Also printed: Newton iterations and band factorizations (``LU``) per step, and
whether the iteration matrix is carried over steps (``femb/engine/layout.py``, ``carry_rule``: band
systems of at least 1000 unknowns) or built at every step.

The force kernel (:func:`femb.elements.spatial_beam.spatial_beam_force`) is timed on its own
as well, per element, with and without the Jacobian (batches of ``nel`` elements with
random rotations, median of 15 calls after a warm-up).

With Exudyn installed (``pip install femb[peers]``) the same rod is run in Exudyn as
:mod:`femb.benchmarks.cost.spatial_beam_peer` sets it up (its headline setting; same h, ρ∞,
steps) and the ratio femb / Exudyn of the wall times per step is printed (or why the peer run failed); that
module compares the two codes in detail.

Usage::

    python -m femb.benchmarks.cost.spatial_beam_scaling [--n 10 100 1000 3000 10000] [--runs 3]
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from femb.benchmarks.cost.spatial_rod import DATA, H, RHO_INF, build  # noqa: F401  (the rod; re-exported)


def steps_for(n):
    return int(np.clip(40000 // n, 40, 400))


def measure(n, runs=3, steps=None):
    """Median ms per step over ``runs`` runs, and counters (dict)."""
    import femb

    steps = steps or steps_for(n)
    model = build(n).compile()
    per_step, res = [], None
    for _ in range(runs):
        res = femb.simulate(model, steps * H, H, rho_inf=RHO_INF, store=False)
        per_step.append(1e3 * res.wall_time / res.steps)
    return {"n": n, "nq": model.nq, "steps": res.steps, "ms_per_step": statistics.median(per_step),
            "runs": per_step, "newton_per_step": float(res.newton_iterations.mean()),
            "factorizations_per_step": res.stats["factorizations"] / res.steps,
            "linear_solver": res.settings["linear_solver"], "newton_matrix": res.settings["newton_matrix"]}


def kernel_cost(nel=2000, damping=0.0, repeat=15):
    """µs per element of the force kernel, ``{"jacobian": …, "force": …}``."""
    from femb import Mechanism
    from femb.base import rotations as rt
    from femb.elements.spatial_beam import SpatialBeam, SpatialSection, spatial_beam

    m = Mechanism("k")
    sec = SpatialSection.from_properties(1e6, 1e6, 1e6, 1e3, 1e3, 1e3, rhoA=1.0, rhoJ=(2, 1, 1), damping=damping)
    b = spatial_beam(m, "b", sec, [(0, 0, 0), (1.0, 0, 0)], nel)
    P = np.ascontiguousarray(SpatialBeam.pack(b.elements)["P"])
    rng = np.random.default_rng(0)
    x = np.zeros((nel, 14))
    for e in range(nel):
        x[e, 0:3] = np.array([e / nel, 0, 0]) + 1e-4 * rng.standard_normal(3)
        x[e, 7:10] = np.array([(e + 1) / nel, 0, 0]) + 1e-4 * rng.standard_normal(3)
        x[e, 3:7] = rt.quat_exp(0.3 * rng.standard_normal(3))
        x[e, 10:14] = rt.quat_exp(0.3 * rng.standard_normal(3))
    v = rng.standard_normal((nel, 12))
    fe, fq, fv = np.zeros((nel, 12)), np.zeros((nel, 12, 12)), np.zeros((nel, 12, 12))
    tf = np.zeros((nel, 0, 3))
    k = SpatialBeam.kernels["force"]
    out = {}
    for name, jac in (("jacobian", True), ("force", False)):
        k(P, 0.0, tf, x, v, jac, fe, fq, fv)
        ts = []
        for _ in range(repeat):
            t0 = time.perf_counter()
            k(P, 0.0, tf, x, v, jac, fe, fq, fv)
            ts.append(time.perf_counter() - t0)
        out[name] = 1e6 * float(np.median(ts)) / nel
    return out


def exudyn_measure(n, runs=3, steps=None):
    """The same rod in Exudyn, set up and run by :func:`femb.benchmarks.cost.spatial_beam_peer.exudyn_run`
    in its headline setting; dict with ``ms_per_step`` (median of ``runs``) or ``error``."""
    from femb.benchmarks.cost import spatial_beam_peer as peer

    if peer.exudyn_version() is None:
        return {"n": n, "error": "exudyn not installed"}
    steps = steps or steps_for(n)
    wall = []
    for _ in range(runs):
        r = peer.exudyn_run(n, steps, H, peer.EXUDYN_SETTINGS[peer.HEADLINE])
        if not r["ok"]:
            return {"n": n, "error": r["message"]}
        wall.append(r["wall_s"])
    return {"n": n, "ms_per_step": 1e3 * statistics.median(wall) / steps, "steps": steps}


def fit_exponent(ns, ys):
    """Exponent p of the least-squares fit y = C n^p (log–log)."""
    return float(np.polyfit(np.log(ns), np.log(ys), 1)[0])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[10, 100, 1000, 3000, 10000])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--no-exudyn", action="store_true")
    ap.add_argument("--exudyn-max", type=int, default=1000, help="largest n run in Exudyn")
    a = ap.parse_args(argv)
    for nel in (200, 2000):
        kc = kernel_cost(nel)
        kd = kernel_cost(nel, damping=1e-3)
        print(f"force kernel, {nel} elements: {kc['jacobian']:.2f} us/element with Jacobian "
              f"({kd['jacobian']:.2f} with damping), {kc['force']:.2f} us/element force only")
    print(f"dynamic cantilever under gravity, h = {H:g} s, rho_inf = {RHO_INF}, median of {a.runs} runs")
    print(f"{'n':>6s} {'nq':>7s} {'steps':>6s} {'ms/step':>9s} {'us/(step el)':>13s} {'newton':>7s} {'LU':>5s} "
          f"{'matrix':>8s}  {'exudyn ms/step':>14s} {'femb/exudyn':>11s}")
    rows = []
    for n in a.n:
        r = measure(n, a.runs)
        ex = {"error": "skipped"} if a.no_exudyn or n > a.exudyn_max else exudyn_measure(n, a.runs)
        rows.append(r)
        exs = f"{ex['ms_per_step']:14.3f} {r['ms_per_step'] / ex['ms_per_step']:6.2f}" if "ms_per_step" in ex \
            else f"  ({ex['error']})"
        print(f"{n:6d} {r['nq']:7d} {r['steps']:6d} {r['ms_per_step']:9.3f} {1e3 * r['ms_per_step'] / n:13.3f} "
              f"{r['newton_per_step']:7.2f} {r['factorizations_per_step']:5.2f} {r['newton_matrix']:>8s}  {exs}")
    ns = np.array([r["n"] for r in rows], dtype=float)
    ms = np.array([r["ms_per_step"] for r in rows])
    big = ns >= 1000
    if big.sum() >= 2:
        print(f"fitted exponent p (ms/step ~ n^p), n >= 1000: {fit_exponent(ns[big], ms[big]):.3f}")


if __name__ == "__main__":
    main()
