"""The stabilized index-2 step (``formulation="index2"``) against index 3 on Andrews' mechanism.

Prints, for both formulations:

1. cost at h = 3e-5 s, t_end = 0.03 s, ρ∞ = 0.7: µs per step (median of the runs'
   wall time per step, ``time.perf_counter`` around ``simulate``), Newton
   iterations, factorizations and evaluations per step, angle and relative λ
   error at t = 0.03 s against the reference;
2. h → 0 on [0, 1e-4] s: relative λ error at t = 1e-4 s against the fine reference
   for h = 1e-5 … 1e-8 s (the measurement of ``stress.h_to_zero``);
3. cond of the scaled Newton matrix against h at the state reached at 1e-4 s.

Usage::

    python -m femb.benchmarks.accuracy.index2 [--runs 7] [--quick]
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

FORMULATIONS = ("index3", "index2")


def cost(formulation, h=3e-5, t_end=0.03, runs=7):
    """Median µs per step over ``runs`` runs, Newton counters and the errors at t_end."""
    import femb
    from femb.benchmarks.scenes.planar import andrews as A

    model = A.build().compile()
    femb.simulate(model, 10 * h, h, rho_inf=0.7, formulation=formulation)     # compiled before timing
    per_step, res = [], None
    for _ in range(runs):
        t0 = time.perf_counter()
        res = femb.simulate(model, t_end, h, rho_inf=0.7, formulation=formulation)
        per_step.append(1e6 * (time.perf_counter() - t0) / res.steps)
    ref = A.reference(np.array([t_end]))
    o = A.outputs(res)
    lam_ref = np.array([ref[n][-1] for n in A.LAMBDA_NAMES])
    lam = np.array([o[n][-1] for n in A.LAMBDA_NAMES])
    return {"formulation": formulation, "us_per_step": statistics.median(per_step), "steps": res.steps,
            "newton_per_step": float(res.newton_iterations.mean()),
            "newton_max": int(res.newton_iterations.max()),
            "factorizations_per_step": res.stats["factorizations"] / res.steps,
            "evaluations_per_step": res.stats["evaluations"] / res.steps,
            "angle_err": float(max(abs(o[n][-1] - ref[n][-1]) for n in A.ANGLE_NAMES)),
            "lam_err_rel": float(np.abs(lam - lam_ref).max() / np.abs(lam_ref).max())}


def h_to_zero(formulation, hs=(1e-5, 1e-6, 3e-7, 1e-7, 3e-8, 1e-8)):
    """Relative λ error at 1e-4 s for each h (``stepsize_study.lambda_error_vs_h``)."""
    from femb.benchmarks.accuracy import stepsize_study as S
    return S.lambda_error_vs_h(formulation, hs=hs)


def conditioning(formulation, hs=(1e-5, 1e-6, 1e-7, 1e-8)):
    """{h: cond(S)} of the scaled Newton matrix at the state reached at t = 1e-4 s."""
    import femb
    from femb.benchmarks.scenes.planar import andrews as A
    from femb.solve.alpha import GeneralizedAlpha
    from femb.solve.codegen import evaluate_dense
    from femb.system.model import State

    model = A.build().compile()
    r = femb.simulate(model, 1e-4, 1e-5, rho_inf=0.7, formulation=formulation)
    st = State(float(r.t[-1]), r.q[-1].copy(), r.qd[-1].copy(), r.qdd[-1].copy(), r.lam[-1].copy())
    al = GeneralizedAlpha.from_rho_inf(0.7)
    return {h: float(np.linalg.cond(evaluate_dense(model, st, h, al, formulation=formulation)[3])) for h in hs}


def main(argv=None):
    from femb.benchmarks.accuracy import stepsize_study as S

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--quick", action="store_true", help="h → 0 down to 1e-7 s only")
    a = ap.parse_args(argv)
    print("Andrews, h = 3e-5 s, t_end = 0.03 s, ρ∞ = 0.7\n")
    rows = [cost(f, runs=a.runs) for f in FORMULATIONS]
    print(S.table(["formulation", "µs/step (median)", "Newton it./step", "max", "factorizations/step",
                   "evaluations/step", "angle err (rad)", "rel. λ err"],
                  [(r["formulation"], f"{r['us_per_step']:.2f}", f"{r['newton_per_step']:.3f}", r["newton_max"],
                    f"{r['factorizations_per_step']:.3f}", f"{r['evaluations_per_step']:.3f}",
                    f"{r['angle_err']:.3g}", f"{r['lam_err_rel']:.3g}") for r in rows]))
    hs = (1e-5, 1e-6, 1e-7) if a.quick else (1e-5, 1e-6, 3e-7, 1e-7, 3e-8, 1e-8)
    for f in FORMULATIONS:
        print("\n" + S.format_lambda(h_to_zero(f, hs)))
    print("\ncond of the scaled Newton matrix at t = 1e-4 s\n")
    conds = {f: conditioning(f) for f in FORMULATIONS}
    print(S.table(["h (s)"] + list(FORMULATIONS),
                  [(f"{h:g}",) + tuple(f"{conds[f][h]:.3g}" for f in FORMULATIONS) for h in conds["index3"]]))


if __name__ == "__main__":
    main()
