"""Cost of the contact step (femb.contact, Python) against the compiled smooth step, same run.

Three runs of 0.5 s at h = 2e-3 s, repeated ``repeats`` times interleaved, medians of the wall
time per step (time.perf_counter around the time loop):

* ``open``: the ball of ``contact_ball`` far above the floor (its contact stays open) with
  :func:`femb.contact.simulate`;
* ``closed``: the ball resting on the floor (persistent contact) with :func:`femb.contact.simulate`;
* ``engine``: the same ball without its contact element with :func:`femb.simulate` (compiled).

Run ``python -m femb.benchmarks.cost.contact_cost``.
"""
from __future__ import annotations

import time

import numpy as np


def _runs():
    import femb
    from femb.benchmarks.scenes.contact import contact_ball
    from femb.contact import simulate

    open_model = contact_ball.build(y0=100.0).compile()
    closed_model = contact_ball.build(y0=0.1).compile()
    mech = femb.Mechanism("ball_free")
    from femb.elements import Gravity, RigidBody
    mech.add(RigidBody("ball", 1.0, 0.004, position=(0.0, 1.0)))
    mech.add(Gravity((0.0, -9.81)))
    smooth = mech.compile()
    T, h = 0.5, 2e-3
    return {"open": lambda: simulate(open_model, T, h),
            "closed": lambda: simulate(closed_model, T, h),
            "engine": lambda: femb.simulate(smooth, T, h)}


def measure(repeats=3):
    """Median ms per step of each run (dict)."""
    runs = _runs()
    for f in runs.values():             # compile / warm up
        f()
    times = {k: [] for k in runs}
    for _ in range(repeats):
        for k, f in runs.items():
            t0 = time.perf_counter()
            res = f()
            times[k].append((time.perf_counter() - t0) / (res.t.size - 1) * 1e3)
    return {k: float(np.median(v)) for k, v in times.items()}


def main():
    ms = measure()
    for k, v in ms.items():
        print(f"contact_cost  {k:8s} {v:10.4f} ms/step   ratio to engine {v / ms['engine']:10.1f}")
    print(f"contact_cost  closed/open {ms['closed'] / ms['open']:.2f}")


if __name__ == "__main__":
    main()
