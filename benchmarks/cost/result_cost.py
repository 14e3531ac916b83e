"""Reading spatial results: the cost of ``Result.reaction_at`` per stored step, and the energy balance.

``python -m femb.benchmarks.cost.result_cost`` runs the heavy top (t_end = 1 s,
h = 2⁻¹¹, ρ∞ = 0.9; 2049 stored steps), the IFToMM spatial slider–crank
(t_end = 1 s, h = 1e-3) and the planar slider–crank (t_end = 0.1 s, h = 1e-4),
then times ``reaction_at`` of every joint (median of ``--repeats`` calls after a
first one) and prints µs per stored step, and ``energy_balance()`` of the
conservative heavy top at h = 2⁻¹⁰ … 2⁻¹² (ρ∞ = 0.9 and index 2 at ρ∞ = 1).
"""
from __future__ import annotations

import argparse
import statistics
import time
import warnings


def reaction_cost(result, joint, repeats=7):
    """Median seconds per stored step of ``result.reaction_at(joint)`` over ``repeats`` calls (after one)."""
    result.reaction_at(joint)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        result.reaction_at(joint)
        times.append(time.perf_counter() - t0)
    return statistics.median(times) / result.t.size


def main(argv=None):
    import femb
    from femb.benchmarks.scenes.planar import slider_crank
    from femb.benchmarks.scenes.spatial import heavy_top, spatial_slider_crank

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    args = ap.parse_args(argv)
    runs = [("heavy_top", heavy_top.build().compile(), 1.0, 2.0 ** -11),
            ("spatial_slider_crank", spatial_slider_crank.build().compile(), 1.0, 1e-3),
            ("slider_crank", slider_crank.build().compile(), 0.1, 1e-4)]
    print("reaction_at, median of", args.repeats, "calls")
    for name, model, t_end, h in runs:
        r = femb.simulate(model, t_end, h, rho_inf=0.9)
        for joint in sorted(k for k, v in model.lam_index.items() if len(v)):
            print(f"  {name:22s} {joint:14s} {r.t.size:6d} steps  {1e6 * reaction_cost(r, joint, args.repeats):6.2f} µs/step")
    print("heavy top, energy_balance() over [0, 1] s")
    model = heavy_top.build().compile()
    for k in (10, 11, 12):
        r9 = femb.simulate(model, 1.0, 2.0 ** -k, rho_inf=0.9)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", femb.ParameterWarning)
            r1 = femb.simulate(model, 1.0, 2.0 ** -k, rho_inf=1.0, formulation="index2")
        print(f"  h = 2^-{k}: index 3, rho_inf = 0.9: {r9.energy_balance():.2e};  index 2, rho_inf = 1: "
              f"{r1.energy_balance():.2e}")


if __name__ == "__main__":
    main()
