"""Cost of a nonsmooth contact step against the compiled smooth step of the same model, same run.

``python -m femb.benchmarks.cost.contact_step_ratio [--repeats N]`` prints, for two models, the wall
time per step of the time loop (``Result.wall_time`` / steps: the start is excluded) as the median
of ``repeats`` runs interleaved in one process (each run once before, so that no compile is timed):

* ``ball``: the ball of :mod:`femb.benchmarks.scenes.contact.contact_ball`, 0.5 s at h = 2e-3 s:
  ``closed`` resting on the floor (persistent contact) and ``open`` far above it (its contact stays
  open), both with :func:`femb.contact.simulate`; ``smooth`` the same ball without its contact
  element with :func:`femb.simulate` (the compiled engine);
* ``slider-crank``: the slider–crank with translational clearance of
  :mod:`femb.benchmarks.scenes.contact.contact_slider_crank`, 0.02 s at h = 1e-4 s: ``closed`` the
  scene (its slider bounces between the guides: impacts and contact phases), ``open`` the same
  model with a clearance of 1 m (the four contacts never close), both with
  :func:`femb.contact.simulate`; ``smooth`` the same mechanism without the contact elements with
  :func:`femb.simulate`.

The ratios ``closed / smooth`` and ``open / smooth`` are the issue's "step with contact against
the same model's smooth step (contacts open)"; ``closed / open`` is the cost of the contacts in
the same stepper. ``closed_py`` and ``open_py`` are the same runs through the Python time loop
(``compiled=False``, the reference of the compiled loop, docs/contact.md §7): the last column is
their time over the compiled loop's.
"""
from __future__ import annotations

import argparse
import statistics


def _crank_without_contacts():
    from femb import Mechanism
    from femb.benchmarks.scenes.contact import contact_slider_crank as sc
    from femb.elements import Gravity, Hinge, RigidBody
    p, (m1, J1), (m2, J2), (m3, J3) = sc.PARAMS, sc.MASSES["crank"], sc.MASSES["rod"], sc.MASSES["slider"]
    l1, l2, w1 = p["l1"], p["l2"], p["omega1"]
    w2 = -w1 * l1 / l2
    mech = Mechanism("slider_crank_smooth")
    mech.add(RigidBody("crank", m1, J1, position=(0.5 * l1, 0.0), velocity=(0.0, 0.5 * l1 * w1), omega=w1))
    mech.add(RigidBody("rod", m2, J2, position=(l1 + 0.5 * l2, 0.0), velocity=(0.0, l1 * w1 + 0.5 * l2 * w2),
                       omega=w2))
    mech.add(RigidBody("slider", m3, J3, position=(l1 + l2, 0.0)))
    mech.add(Gravity((0.0, -p["g"])))
    mech.add(Hinge("O", "ground", "crank", at=(0.0, 0.0)))
    mech.add(Hinge("A", "crank", "rod", at=(l1, 0.0)))
    mech.add(Hinge("B", "rod", "slider", at=(l1 + l2, 0.0)))
    return mech.compile()


def _ball_without_contact():
    import femb
    from femb.benchmarks.scenes.contact import contact_ball
    from femb.elements import Gravity, RigidBody
    p = contact_ball.PARAMS
    mech = femb.Mechanism("ball_smooth")
    mech.add(RigidBody("ball", p["mass"], 0.4 * p["mass"] * p["radius"] ** 2, position=(0.0, p["y0"])))
    mech.add(Gravity((0.0, -p["g"])))
    return mech.compile()


def cases():
    """{model: {run: callable returning a Result}}."""
    import femb
    from femb.benchmarks.scenes.contact import contact_ball, contact_slider_crank
    from femb.contact import simulate
    ball = {"closed": contact_ball.build(y0=contact_ball.PARAMS["radius"]).compile(),
            "open": contact_ball.build(y0=100.0).compile(), "smooth": _ball_without_contact()}
    crank = {"closed": contact_slider_crank.build().compile(), "open": contact_slider_crank.build(c=1.0).compile(),
             "smooth": _crank_without_contacts()}
    out = {}
    for name, models, T, h in (("ball", ball, 0.5, 2e-3), ("slider-crank", crank, 0.02, 1e-4)):
        out[name] = {"closed": (lambda m=models["closed"], T=T, h=h: simulate(m, T, h, rho_inf=0.8)),
                     "open": (lambda m=models["open"], T=T, h=h: simulate(m, T, h, rho_inf=0.8)),
                     "closed_py": (lambda m=models["closed"], T=T, h=h: simulate(m, T, h, rho_inf=0.8, compiled=False)),
                     "open_py": (lambda m=models["open"], T=T, h=h: simulate(m, T, h, rho_inf=0.8, compiled=False)),
                     "smooth": (lambda m=models["smooth"], T=T, h=h: femb.simulate(m, t_end=T, h=h, rho_inf=0.8))}
    return out


def measure(repeats=5):
    """{model: {run: median ms per step of the time loop}}."""
    runs = cases()
    for model in runs.values():
        for f in model.values():
            f()                                  # compile and warm up
    ms = {m: {k: [] for k in r} for m, r in runs.items()}
    for _ in range(repeats):
        for m, r in runs.items():
            for k, f in r.items():
                res = f()
                ms[m][k].append(res.wall_time / (res.t.size - 1) * 1e3)
    return {m: {k: statistics.median(v) for k, v in r.items()} for m, r in ms.items()}


def report(ms):
    lines = ["| model | closed (ms/step) | open (ms/step) | smooth, engine (ms/step) | closed / smooth | "
             "open / smooth | closed / open | Python loop / compiled loop: closed, open |", "|---|---|---|---|---|---|---|---|"]
    for m, r in ms.items():
        c, o, s = r["closed"], r["open"], r["smooth"]
        lines.append(f"| {m} | {c:.4f} | {o:.4f} | {s:.4f} | {c / s:.1f} | {o / s:.1f} | {c / o:.2f} | "
                     f"{r['closed_py'] / c:.1f}, {r['open_py'] / o:.1f} |")
    return lines


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args(argv)
    for line in report(measure(args.repeats)):
        print(line)


if __name__ == "__main__":
    main()
