"""Peak memory of long runs against what they store: nothing, every step, every k-th step.

A conservative pendulum (hinge to ground, gravity; 3 coordinates, 2 multipliers) is
integrated for ``--steps`` fixed steps in a fresh process per variant (``--contact``: the bouncing
ball with e_N = 1 in :func:`femb.contact.simulate`, bouncing for ever), and each process
reports its peak resident set size (``resource.getrusage``). A run of ``--base`` steps
with nothing stored gives the process's own footprint (Python, numpy, the loaded engine);
the table prints each variant's peak above it, the bytes that the run stores (stored
states and per-step records) and the peak per step.

Usage::

    python -m femb.benchmarks.cost.long_run_memory --steps 1000000
    python -m femb.benchmarks.cost.long_run_memory --steps 10000000 --variants none stride100
    python -m femb.benchmarks.cost.long_run_memory --contact --steps 1000000 --h 1e-3
"""
from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys

from femb.benchmarks.cost.vtk_memory import build  # noqa: E402  (the same pendulum as the VTK memory study)

VARIANTS = {"none": dict(store=False), "all": dict(store=True), "stride100": dict(store=True, stride=100)}




def child(steps, variant, h, contact=False):
    """Run one variant in this process; print a JSON line with its peak RSS and what it stored."""
    import femb

    if contact:
        from femb.benchmarks.scenes.contact import contact_ball
        from femb.contact import simulate

        model = contact_ball.build(e_N=1.0).compile()
        simulate(model, 10 * h, h)                   # the compiled loop loaded before the run
        r = simulate(model, steps * h, h, **VARIANTS[variant])
        stored = sum(a.nbytes for a in (r.t, r.q, r.qd, r.qdd, r.lam, r.newton_iterations, *r.contact.values()))
    else:
        model = build().compile()
        femb.simulate(model, 10 * h, h)              # engine loaded before the run
        r = femb.simulate(model, steps * h, h, check_every=0, **VARIANTS[variant])
        stored = sum(a.nbytes for a in (r.t, r.q, r.qd, r.qdd, r.lam, r.h_steps, r.newton_iterations,
                                         r.error_estimates))
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    print(json.dumps({"peak": peak, "stored": stored, "steps": r.steps}))


def measure(steps, variant, h, contact=False):
    out = subprocess.run([sys.executable, __file__, "--child", variant, "--steps", str(steps), "--h", str(h)]
                         + (["--contact"] if contact else []), capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=1_000_000)
    ap.add_argument("--base", type=int, default=1000, help="steps of the reference run (nothing stored)")
    ap.add_argument("--h", type=float, default=1e-4)
    ap.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=list(VARIANTS))
    ap.add_argument("--contact", action="store_true", help="the bouncing ball in femb.contact.simulate")
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.child:
        return child(a.steps, a.child, a.h, a.contact)
    base = measure(a.base, "none", a.h, a.contact)["peak"]
    print(f"{'bouncing ball (contact)' if a.contact else 'pendulum'}, {a.steps} steps of h = {a.h:g} s; reference: {a.base} steps, nothing stored, "
          f"peak RSS {base / 2**20:.1f} MiB")
    print(f"{'stored':>10} {'peak RSS (MiB)':>15} {'above ref. (MiB)':>17} {'stored (MiB)':>13} {'B/step':>8}")
    for v in a.variants:
        r = measure(a.steps, v, a.h, a.contact)
        above = r["peak"] - base
        print(f"{v:>10} {r['peak'] / 2**20:15.1f} {above / 2**20:17.1f} {r['stored'] / 2**20:13.1f} "
              f"{above / r['steps']:8.1f}")


if __name__ == "__main__":
    main()
