"""Figures of the compiled time loop: cost per step, beam scaling, process start-up.

Every figure is a median over ``--runs`` runs in this process (``time.perf_counter``);
ratios are taken against a reference run in the same process.

* ``steps``: µs per step of the pendulum and of Andrews' mechanism (h = 3e-5 s,
  ρ∞ = 0.7), with the defaults and with the seed reproduction's settings
  (residual Newton test, the seed's start, no step-size check), and Exudyn's
  µs per step on the same Andrews model when it is installed (``femb[peers]``).
* ``beam``: ms per step of the spin-up beam for n elements (h = 5 ms, a run from
  rest over [0, 1] s with the defaults, the whole ``simulate`` call timed) and the
  fitted exponent of cost against n for n ≥ 10³.
* ``process``: whole-process wall times of the first run (the engine's parallel build against
  ``FEMB_BUILD_WORKERS=1``, alternated): ``femb cache build`` and
  ``femb run andrews`` with an empty compile cache, each spatial scene with only the
  engine cached and after ``femb cache build``, a user-defined element type, and
  ``femb run andrews --t-end 0.003`` with a warm cache.

Usage::

    python -m femb.benchmarks.cost.compiled_loop [--part steps|beam|process|all] [--runs 5]
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

LEGACY = dict(newton_test="residual", start="seed", check_every=0)


def _loop_us(model, t_end, h, runs, **options):
    """Median µs per step of the time loop (initialization excluded) and the last result."""
    import femb
    femb.simulate(model, min(t_end, 20 * h), h, store=False, **options)      # compile / warm up
    per, res = [], None
    for _ in range(runs):
        res = femb.simulate(model, t_end, h, store=False, **options)
        per.append(1e6 * res.wall_time / res.steps)
    return statistics.median(per), min(per), max(per), res


def pendulum_model():
    import femb
    from femb.elements import Gravity, Hinge, RigidBody
    mech = femb.Mechanism("pendulum")
    bar = mech.add(RigidBody("bar", mass=1.0, inertia=1 / 12, position=(0.5, 0.0), points={"O": (-0.5, 0.0)}))
    mech.add(Hinge("pivot", "ground", bar, point_b="O"))
    mech.add(Gravity((0.0, -9.81)))
    return mech.compile()


def steps(runs=5):
    from femb.benchmarks import peers
    from femb.benchmarks.scenes.planar import andrews
    rows = []
    pend = pendulum_model()
    for label, opts in (("defaults", {}), ("seed settings", LEGACY)):
        med, lo, hi, res = _loop_us(pend, 2.0, 1e-3, runs, **opts)
        rows.append(("pendulum, h = 1e-3", label, med, lo, hi, float(res.newton_iterations.mean()),
                     res.stats["factorizations"] / res.steps))
    model = andrews.build().compile()
    for label, opts in (("defaults", {}), ("seed settings", LEGACY)):
        med, lo, hi, res = _loop_us(model, 0.03, 3e-5, runs, **opts)
        rows.append(("Andrews, h = 3e-5", label, med, lo, hi, float(res.newton_iterations.mean()),
                     res.stats["factorizations"] / res.steps))
    print(f"{'model':22s} {'settings':14s} {'us/step med':>11s} {'min':>7s} {'max':>7s} {'Newton/step':>11s} "
          f"{'LU/step':>8s}")
    for r in rows:
        print(f"{r[0]:22s} {r[1]:14s} {r[2]:11.2f} {r[3]:7.2f} {r[4]:7.2f} {r[5]:11.2f} {r[6]:8.2f}")
    ex = peers.exudyn_solve("andrews", 0.03, 1000, 0.7, 10)
    if ex["ok"]:
        walls = [peers.exudyn_solve("andrews", 0.03, 1000, 0.7, 10)["wall_s"] for _ in range(runs)]
        ex_us = 1e6 * statistics.median(walls) / 1000
        femb_us = rows[2][2]
        print(f"Exudyn {peers.status()['exudyn']['version']}, same Andrews model and scheme, h = 3e-5: "
              f"{ex_us:.2f} us/step (median of {runs}); femb defaults / Exudyn = {femb_us / ex_us:.3f}, "
              f"femb seed settings / Exudyn = {rows[3][2] / ex_us:.3f}")
    else:
        print(f"Exudyn: {ex['message']} (pip install femb[peers] to compare)")
    return rows


def beam(runs=3, ns=(10, 100, 1000, 3000, 10000), t_end=1.0, h=5e-3):
    """ms per step of the spin-up beam: a run from rest over [0, t_end], the defaults.

    ms/step: the time loop's wall time (``Result.wall_time``) / steps, after a
    short run that compiles; the consistent initial values and the start are
    timed apart (``init`` column: the whole ``simulate`` call minus the loop).
    A run from rest, not a restart from a state in motion: re-initializing such a
    state (``initialize=True``) replaces the scheme's damped accelerations by the
    exact ones, and the stiff beam then needs 2–5 Newton iterations per step for
    some 50 steps (ρ∞ = 0.7 damps the jump by 0.7 per step).
    """
    import femb
    from femb.benchmarks.scenes.beams import spin_up
    rows = []
    for n in ns:
        model = spin_up.build(n).compile()
        femb.simulate(model, 4 * h, h, store=False)        # compile / warm up
        per, init = [], []
        for _ in range(runs):
            t0 = time.perf_counter()
            r = femb.simulate(model, t_end, h, store=False)
            init.append(time.perf_counter() - t0 - r.wall_time)
            per.append(1e3 * r.wall_time / r.steps)
        rows.append((n, statistics.median(per), model.nq + model.nc, float(r.newton_iterations.mean()),
                     r.settings["band"], statistics.median(init)))
    print(f"spin-up beam, h = {h:g} s, runs from rest over [0, {t_end:g}] s, median of {runs}")
    print(f"{'n':>6s} {'unknowns':>9s} {'ms/step':>9s} {'Newton/step':>11s} {'band (kl, ku)':>14s} {'init [s]':>9s}")
    for n, ms, N, it, band, ini in rows:
        print(f"{n:6d} {N:9d} {ms:9.3f} {it:11.2f} {str(band):>14s} {ini:9.3f}")
    big = [(n, ms) for n, ms, *_ in rows if n >= 1000]
    if len(big) >= 2:
        slope = np.polyfit(np.log([b[0] for b in big]), np.log([b[1] for b in big]), 1)[0]
        print(f"fitted exponent of ms/step against n for n >= 1000: {slope:.3f}")
    return rows


USER_SCENE = """
import math
import numpy as np
import femb
from femb.system.element import Element
from femb.elements import RigidBody, Hinge, Gravity
from femb.base.jit import kernel


@kernel
def pull_force(P, t, tf, xe, ve, jac, fe, fq, fv):
    for e in range(xe.shape[0]):
        k = P[e, 0]
        fe[e, 0] = -k * xe[e, 0]
        fe[e, 1] = -k * xe[e, 1]
        if jac:
            fq[e, 0, 0] = -k
            fq[e, 1, 1] = -k


class Pull(Element):
    has_force = True
    kernels = {"force": pull_force}

    def __init__(self, name, body, k):
        super().__init__(name)
        self.body, self.k = body, float(k)

    def resolve(self, lookup):
        self.body = lookup(self.body, "body")

    def nodes(self):
        return [self.body.node]

    @classmethod
    def pack(cls, elements):
        return {"P": np.array([[e.k] for e in elements]).reshape(-1, 1)}


def build():
    m = femb.Mechanism("user_pull")
    b = m.add(RigidBody("bar", 1.0, 1 / 12, (0.5, 0.0), points={"O": (-0.5, 0.0)}))
    m.add(Hinge("pivot", "ground", b, point_b="O"))
    m.add(Gravity((0.0, -9.81)))
    m.add(Pull("pull", b, 20.0))
    return m


DEFAULTS = {"t_end": 0.1, "h": 1e-3}


def outputs(result):
    return {"x": result.body("bar")[:, 0]}
"""


def _whole(cmd, env):
    t = time.perf_counter()
    p = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed: {p.stderr[-2000:]}")
    return time.perf_counter() - t, p.stderr


def process(runs=3, scenes=("heavy_top", "bricard", "spatial_slider_crank", "spatial_double_pendulum")):
    """Whole-process figures of the first run (issue table of the one engine).

    Each run uses a new cache directory, filled as the row says: empty; the engine only
    (copied from a cache that compiled it once); or everything (``femb cache build``).
    The background build after a fresh engine compilation is off (FEMB_BACKGROUND_BUILD=0)
    except where said, so that each row measures what its own process compiles.
    """
    import shutil
    exe = [sys.executable, "-m", "femb.console.cli"]
    base = dict(os.environ, FEMB_BACKGROUND_BUILD="0")
    rows = []
    with tempfile.TemporaryDirectory() as root:
        eng = os.path.join(root, "engine")
        full = os.path.join(root, "full")
        t_build, _ = _whole(exe + ["cache", "build"], dict(base, FEMB_CACHE_DIR=full))
        rows.append(("femb cache build, empty cache (engine and every built-in kernel)", [t_build]))
        os.makedirs(os.path.join(eng, "numba"))
        for d in os.listdir(os.path.join(full, "numba")):
            if d.startswith(("engine.", "rotations-")):
                shutil.copytree(os.path.join(full, "numba", d), os.path.join(eng, "numba", d))

        def fresh(kind, tag):
            d = os.path.join(root, f"{tag}-{len(os.listdir(root))}")
            if kind == "engine":
                shutil.copytree(eng, d)
            elif kind == "full":
                shutil.copytree(full, d)
            return dict(base, FEMB_CACHE_DIR=d)

        cold, one = [], []                   # the engine's parallel build against one process, alternated
        for _ in range(runs):
            cold.append(_whole(exe + ["run", "andrews"], fresh("empty", "cold"))[0])
            one.append(_whole(exe + ["run", "andrews"], dict(fresh("empty", "one"), FEMB_BUILD_WORKERS="1"))[0])
        rows.append(("femb run andrews, empty cache (engine and its kernels)", cold))
        rows.append(("the same, FEMB_BUILD_WORKERS=1 (the engine compiled in one process)", one))
        rows.append(("  ratio of the two, run by run", [a / b for a, b in zip(cold, one)]))
        for sc in scenes:
            t_eng = [_whole(exe + ["run", sc, "--t-end", "0.01"], fresh("engine", sc))[0] for _ in range(runs)]
            rows.append((f"femb run {sc} --t-end 0.01, engine cached, its kernels not", t_eng))
            t_full = [_whole(exe + ["run", sc, "--t-end", "0.01"], fresh("full", sc))[0] for _ in range(runs)]
            rows.append((f"femb run {sc} --t-end 0.01, after femb cache build (new combination)", t_full))
        scene_file = os.path.join(root, "user_pull.py")
        with open(scene_file, "w") as fh:
            fh.write(USER_SCENE)
        t_user = [_whole(exe + ["run", scene_file], fresh("full", "user"))[0] for _ in range(runs)]
        rows.append(("femb run <user element type>, first run (engine cached)", t_user))
        env_w = dict(base, FEMB_CACHE_DIR=full)
        _whole(exe + ["run", "andrews", "--t-end", "0.003"], env_w)
        warm = [_whole(exe + ["run", "andrews", "--t-end", "0.003"], env_w)[0] for _ in range(runs)]
        rows.append(("femb run andrews --t-end 0.003, warm cache", warm))
    w = max(len(r[0]) for r in rows)
    print(f"{'whole process':<{w}}  median [s]  runs [s]")
    for name, ts in rows:
        print(f"{name:<{w}}  {statistics.median(ts):9.2f}   {', '.join(f'{x:.2f}' for x in ts)}")
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", default="all", choices=("steps", "beam", "process", "all"))
    ap.add_argument("--runs", type=int, default=5)
    a = ap.parse_args(argv)
    if a.part in ("steps", "all"):
        steps(a.runs)
    if a.part in ("beam", "all"):
        beam(max(3, a.runs // 2))
    if a.part in ("process", "all"):
        process(max(3, a.runs // 2))


if __name__ == "__main__":
    main()
