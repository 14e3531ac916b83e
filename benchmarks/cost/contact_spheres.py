"""Cost of the nonsmooth contact step against the number of contacts: n spheres on the floor.

For each n in ``sizes`` (default 25, 50, 100, 200, 400 spheres), two models of
:mod:`femb.benchmarks.scenes.contact.contact_spheres`, run ``repeats`` times interleaved in this process
with :func:`femb.contact.simulate`, ``steps`` fixed steps of h = 1e-3 s (ρ∞ = 0.8), the wall time of the
time loop (``Result.wall_time``: ``time.perf_counter`` around the loop; the start and the model's
compilation excluded), medians in ms per step:

* ``contact``: the spheres on the floor, each slipping and then rolling (every contact closed, a
  slip–stick transition per sphere within the first 13 steps);
* ``open``: the same model with the spheres 1 m above the floor (falling freely, every contact open).

Above ``femb.contact.step.DENSE_MAX_UNKNOWNS`` unknowns (from 25 spheres on: 6 velocities and 3 contact
rows per sphere, 11 blocks of unknowns) the step runs on the sparse path (Python, SciPy's SuperLU;
docs/contact.md §7). Printed: ms/step of both, their ratio, mean Newton iterations per step, µs per
contact and step, the slope of log(ms/step) against log(n) (1: linear; below 1 while a fixed cost per
step still weighs) and the least-squares line ms/step = a + b n.

Run ``python -m femb.benchmarks.cost.contact_spheres [--sizes 25,50,...] [--repeats R] [--steps S]``.
"""
from __future__ import annotations

import numpy as np

from femb.benchmarks.cost import penalty_spheres


def _models(n):
    from femb.benchmarks.scenes.contact import contact_spheres

    return {"contact": contact_spheres.build(n=n).compile(), "open": contact_spheres.build(n=n, lift=1.0).compile()}


def _run(model, steps, h):
    from femb.contact import simulate

    res = simulate(model, steps * h, h, rho_inf=0.8)
    return res.wall_time / (res.t.size - 1) * 1e3, float(np.mean(res.newton_iterations))


def measure(sizes=(25, 50, 100, 200, 400), repeats=3, steps=20, h=1e-3):
    """{n: {"contact": ms/step, "open": ms/step, "iter_contact", "iter_open"}} (medians)."""
    return penalty_spheres.measure(sizes, repeats, steps, h, models=_models, run=_run)


def main(argv=None):
    penalty_spheres.main(argv, __doc__, steps=20, models=_models, run=_run, digits=2)


if __name__ == "__main__":
    main()
