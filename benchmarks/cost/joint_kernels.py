"""Cost of one call of the joints' compiled kernels, per batch size.

For every joint type, builds ``nel`` joints between rigid bodies (the ground for
every third one) and times one call of the ``constraint`` kernel (with the
Hessian, ``jac=True``) and of the ``rates`` kernel on preallocated outputs, as
the compiled time loop calls them. Prints the median over repeated calls in µs
per call and ns per element.

With ``--numpy-commit C`` (in a git checkout of femb) it also times the numpy
kernels these replaced, taken from commit C (e.g. ``d1a00cd``):
``constraint_all(..., jac=True)`` plus ``constraint_rates``, and prints the ratio.

Usage::

    python -m femb.benchmarks.cost.joint_kernels [--sizes 1 10 1000] [--numpy-commit d1a00cd]
"""
from __future__ import annotations

import argparse
import statistics
import subprocess
import time
import types
from pathlib import Path

import numpy as np

TYPES = ("Hinge", "Slider", "PointOnLine", "DrivenAngle", "DrivenDisplacement")


def _elements(joints, name, nel, seed=0):
    """``nel`` resolved and validated joints of type ``name`` (classes from module ``joints``)."""
    from femb import Mechanism
    from femb.base.functions import Harmonic
    from femb.elements import RigidBody

    rng = np.random.default_rng(seed)
    m = Mechanism("bench")
    bodies = [m.add(RigidBody(f"b{k}", 1.0, 0.1, rng.normal(size=2), rng.uniform(-1, 1)))
              for k in range(nel + 1)]
    cls = getattr(joints, name)
    els = []
    for k in range(nel):
        a = m.ground if k % 3 == 0 else bodies[k]
        b = bodies[k + 1]
        if name == "Hinge":
            e = cls(f"j{k}", a, b, point_a=(0.1, 0.2), point_b=(-0.3, 0.1))
        elif name in ("Slider", "PointOnLine"):
            e = cls(f"j{k}", a, b, axis=(0.6, 0.8), point_a=(0.1, 0.0), point_b=(0.0, 0.2))
        elif name == "DrivenAngle":
            e = cls(f"j{k}", a, b, Harmonic(0.3, 5.0))
        else:
            e = cls(f"j{k}", a, b, Harmonic(0.1, 3.0), axis=(0.6, 0.8), point_a=(0.1, 0.0))
        e.resolve(lambda ref, role: ref)
        e.validate()
        els.append(e)
    return cls, els


def _median_us(fn, min_time=0.2):
    """Median time of one call of fn (µs), from batches of calls lasting ~min_time/10 each."""
    fn()
    n = 1
    while True:
        t0 = time.perf_counter()
        for _ in range(n):
            fn()
        if time.perf_counter() - t0 > min_time / 10:
            break
        n *= 2
    runs = []
    for _ in range(10):
        t0 = time.perf_counter()
        for _ in range(n):
            fn()
        runs.append((time.perf_counter() - t0) / n * 1e6)
    return statistics.median(runs)


def compiled_cost(name, nel):
    """µs per call of the compiled constraint (jac=True) + rates kernels of a batch of nel joints."""
    from femb.elements import joints

    cls, els = _elements(joints, name, nel)
    P = cls.pack(els)["P"]
    nc = cls.n_constraints
    rng = np.random.default_rng(1)
    xe, ve, le = rng.normal(size=(nel, 6)), rng.normal(size=(nel, 6)), rng.normal(size=(nel, nc))
    tf = rng.normal(size=(nel, len(getattr(cls, "time_functions", lambda e: [])(els[0])), 3))
    Phi, B, H = np.zeros((nel, nc)), np.zeros((nel, nc, 6)), np.zeros((nel, 6, 6))
    Pt, gam = np.zeros((nel, nc)), np.zeros((nel, nc))
    kc, kr = cls.kernels["constraint"], cls.kernels["rates"]

    def call():
        kc(P, 0.3, tf, xe, le, True, Phi, B, H)
        kr(P, 0.3, tf, xe, ve, Pt, gam)
    return _median_us(call)


def numpy_cost(name, nel, commit):
    """µs per call of the numpy constraint_all(jac=True) + constraint_rates of commit ``commit``."""
    root = Path(__file__).resolve().parents[1]
    src = subprocess.run(["git", "show", f"{commit}:elements/joints.py"], cwd=root, check=True,
                         capture_output=True, text=True).stdout
    mod = types.ModuleType("femb.elements._numpy_joints")
    mod.__package__ = "femb.elements"
    exec(compile(src, f"{commit}:elements/joints.py", "exec"), mod.__dict__)
    cls, els = _elements(mod, name, nel)
    p = cls.pack(els)
    rng = np.random.default_rng(1)
    xe, ve = rng.normal(size=(nel, 6)), rng.normal(size=(nel, 6))
    le = rng.normal(size=(nel, cls.n_constraints))

    def call():
        cls.constraint_all(p, 0.3, xe, le, True)
        cls.constraint_rates(p, 0.3, xe, ve)
    return _median_us(call)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[1, 10, 1000])
    ap.add_argument("--numpy-commit", default=None,
                    help="also time the numpy kernels of this git commit (e.g. d1a00cd)")
    args = ap.parse_args(argv)
    head = f"{'type':20s} {'nel':>6s} {'compiled µs':>12s} {'ns/element':>11s}"
    if args.numpy_commit:
        head += f" {'numpy µs':>10s} {'numpy/compiled':>15s}"
    print("one call of constraint (jac=True) + rates, median")
    print(head)
    for name in TYPES:
        for nel in args.sizes:
            c = compiled_cost(name, nel)
            line = f"{name:20s} {nel:6d} {c:12.3f} {1e3 * c / nel:11.1f}"
            if args.numpy_commit:
                n = numpy_cost(name, nel, args.numpy_commit)
                line += f" {n:10.2f} {n / c:15.1f}"
            print(line, flush=True)


if __name__ == "__main__":
    main()
