"""Cost of the compiled force-element and beam kernels on large batches.

Times each kernel alone (no gather, no scatter) on one batch of ``n`` elements
at a perturbed state: the beam's force kernel with and without Jacobians,
undamped and damped, its mass kernel, and the spring–damper force kernel.
Prints the median over ``--runs`` samples of µs per call and ns per element
(and the fastest sample, a hint of the cost on a machine shared with other work).
With ``--numpy COMMIT`` it also times the numpy kernels these replaced, loaded
from the git history (``git show COMMIT:elements/beam.py``), in the same run.

Usage::

    python -m femb.benchmarks.cost.element_kernels [--n 10000] [--runs 7] [--numpy 97c7148]
"""
from __future__ import annotations

import argparse
import importlib.util
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def _elements(n, damping):
    """n beam elements and n spring–dampers along a straight beam, resolved and validated."""
    from femb import Mechanism
    from femb.elements import Section, SpringDamper, add_beam

    sec = Section(EA=1e7, GA=4e6, EI=50.0, rhoA=2.0, rhoI=1e-4, damping=damping)
    mech = Mechanism("kernels")
    mesh = add_beam(mech, "b", sec, (0.0, 0.0), (10.0, 0.0), n, start_joint="clamp")
    springs = [mech.add(SpringDamper(f"s{i}", mesh.nodes[i], mesh.nodes[i + 1], 1e3, damping * 1e3,
                                     point_a=(0.0, 0.01), point_b=(0.0, -0.01)))
               for i in range(n)]

    def lookup(ref, role):
        return mech[ref] if isinstance(ref, str) else ref

    for e in mesh.elements + springs:
        e.resolve(lookup)
        e.validate()
    return mesh.elements, springs


def _state(elements, rng):
    x0 = np.array([np.concatenate([nd.q0 for nd in e.nodes()]) for e in elements])
    xe = x0 + 1e-3 * rng.standard_normal(x0.shape)
    ve = rng.standard_normal(x0.shape)
    return np.ascontiguousarray(xe), np.ascontiguousarray(ve)


def _times_us(fn, runs, inner):
    """µs per call of ``runs`` samples of ``inner`` calls each (after one warm-up call)."""
    fn()                                   # compile / warm up
    out = []
    for _ in range(runs):
        t0 = time.perf_counter()
        for _ in range(inner):
            fn()
        out.append(1e6 * (time.perf_counter() - t0) / inner)
    return out


def _old_module(commit, path, name):
    root = Path(__file__).resolve().parents[1]
    src = subprocess.run(["git", "show", f"{commit}:{path}"], cwd=root, check=True, capture_output=True,
                         text=True).stdout
    tmp = Path(tempfile.mkdtemp()) / f"{name}.py"
    tmp.write_text(src)
    spec = importlib.util.spec_from_file_location(f"femb.elements.{name}", tmp)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


def measure(n=10_000, runs=7, numpy_commit=None):
    """Rows (kernel, case, median µs/call, ns/element, min µs/call[, numpy median µs/call])."""
    from femb.elements.beam import beam_force, beam_mass
    from femb.elements.forces import spring_damper_force

    rng = np.random.default_rng(0)
    inner = max(1, 200_000 // n)
    old = None
    if numpy_commit:
        old = {"beam": _old_module(numpy_commit, "elements/beam.py", "_old_beam"),
               "forces": _old_module(numpy_commit, "elements/forces.py", "_old_forces")}
    rows = []
    for damping in (0.0, 1e-3):
        beams, springs = _elements(n, damping)
        label = "damped" if damping else "undamped"
        for kind, els, kern in (("ReissnerBeam", beams, beam_force), ("SpringDamper", springs, spring_damper_force)):
            cls = type(els[0])
            P = cls.pack(els)["P"]
            xe, ve = _state(els, rng)
            tf = np.zeros((n, 0, 3))
            fe, fq, fv = np.zeros((n, 6)), np.zeros((n, 6, 6)), np.zeros((n, 6, 6))
            for jac in (True, False):
                ts = _times_us(lambda: kern(P, 0.0, tf, xe, ve, jac, fe, fq, fv), runs, inner)
                us = statistics.median(ts)
                row = [f"{kind}.force", f"{label}, jac={jac}", us, 1e3 * us / n, min(ts)]
                if old is not None:
                    ocls = getattr(old["beam" if kind == "ReissnerBeam" else "forces"], kind)
                    p = ocls.pack(els)
                    row.append(statistics.median(_times_us(lambda: ocls.force(p, 0.0, xe, ve, jac), runs,
                                                           max(1, inner // 10))))
                rows.append(row)
        if damping == 0.0:
            P = type(beams[0]).pack(beams)["P"]
            xe, _ = _state(beams, rng)
            Me = np.zeros((n, 6, 6))
            ts = _times_us(lambda: beam_mass(P, xe, Me), runs, inner)
            us = statistics.median(ts)
            row = ["ReissnerBeam.mass", "consistent", us, 1e3 * us / n, min(ts)]
            if old is not None:
                ocls = old["beam"].ReissnerBeam
                p = ocls.pack(beams)
                row.append(statistics.median(_times_us(lambda: ocls.mass(p, xe), runs, max(1, inner // 10))))
            rows.append(row)
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=10_000, help="elements per batch")
    ap.add_argument("--runs", type=int, default=7, help="samples (the median is printed)")
    ap.add_argument("--numpy", metavar="COMMIT", default=None,
                    help="also time the numpy kernels of this commit (needs the git history)")
    a = ap.parse_args(argv)
    rows = measure(a.n, a.runs, a.numpy)
    head = f"{'kernel':20s} {'case':24s} {'us/call':>10s} {'ns/elem':>9s} {'min us':>9s}"
    if a.numpy:
        head += f" {'numpy us/call':>14s} {'ratio':>7s}"
    print(f"n = {a.n} elements per batch, median of {a.runs} samples")
    print(head)
    for r in rows:
        line = f"{r[0]:20s} {r[1]:24s} {r[2]:10.1f} {r[3]:9.1f} {r[4]:9.1f}"
        if a.numpy:
            line += f" {r[5]:14.1f} {r[5] / r[2]:7.1f}"
        print(line)


if __name__ == "__main__":
    main()
