"""Cost of the static solver's strategies: full load at once (default) against 10 load steps.

For a few systems, prints the median wall time of ``solve_static`` over
several runs (time.perf_counter), the number of converged load levels, the
Newton iterations in total, and the largest difference between the two
equilibria (both strategies must reach the same one).

Usage::

    python -m femb.benchmarks.cost.static_strategy [--runs 5]
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np


def systems():
    """(name, model) pairs: beams (the elastica) and a rigid pendulum on a torsional spring."""
    from femb import Mechanism
    from femb.elements import Force, Gravity, Hinge, RigidBody, RotationalSpringDamper, Section, add_beam

    def elastica(P, n):
        m = Mechanism("elastica")
        b = add_beam(m, "b", Section(1e6, 1e6, 1.0, 1.0, 1e-3), m.ground, (1.0, 0.0), n)
        m.add(Force("P", b.nodes[-1], (0.0, -P)))
        return m.compile()

    def spring_pendulum():
        m = Mechanism("spring_pendulum")
        bar = m.add(RigidBody("bar", 2.0, 2.0 * 0.64 / 12, position=(0.4, 0.0), points={"O": (-0.4, 0.0)}))
        m.add(Hinge("pivot", "ground", bar, point_b="O"), RotationalSpringDamper("spring", "ground", bar, 10.0))
        m.add(Gravity((0.0, -9.81)))
        return m.compile()

    return [("elastica PL²/EI = 1, 10 elements", elastica(1.0, 10)),
            ("elastica PL²/EI = 10, 10 elements", elastica(10.0, 10)),
            ("elastica PL²/EI = 10, 80 elements", elastica(10.0, 80)),
            ("spring pendulum", spring_pendulum())]


def measure(model, runs=5, **options):
    """(median seconds, result) of ``solve_static(model, **options)`` over ``runs`` runs."""
    from femb.analysis.static import solve_static

    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        res = solve_static(model, **options)
        times.append(time.perf_counter() - t0)
    return statistics.median(times), res


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    a = ap.parse_args(argv)
    print("| system | strategy | median ms | levels | Newton iterations | max |Δq| between strategies |")
    print("|---|---|---|---|---|---|")
    for name, model in systems():
        t_d, r_d = measure(model, a.runs)
        t_s, r_s = measure(model, a.runs, load_steps=10)
        diff = float(np.abs(r_d.q[-1] - r_s.q[-1]).max())
        print(f"| {name} | {r_d.strategy} | {t_d * 1e3:.1f} | {r_d.t.size} | {int(r_d.newton_iterations.sum())} | {diff:.1e} |")
        print(f"| {name} | load_steps=10 | {t_s * 1e3:.1f} | {r_s.t.size} | {int(r_s.newton_iterations.sum())} | |")


if __name__ == "__main__":
    main()
