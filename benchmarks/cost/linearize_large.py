"""Damped modes of a large flexible model: a 10⁴-element spatial beam (60 k unknowns).

A steel cantilever (L = 10 m, 2 × 1 cm rectangle, stiffness-proportional damping β = 10⁻⁴ s)
of ``n`` SE(3) elements (:func:`femb.elements.spatial_beam.spatial_beam`), clamped at one end,
linearized about its unloaded equilibrium; its 20 slowest damped modes (20 conjugate pairs, 40
eigenvalues), by one of two paths (``--path``):

* ``linearize``: :func:`femb.analysis.linearize.linearize` builds the sparse state space (A a
  LinearOperator, B, C, D with a tip force as input and the tip deflection and its rate as
  outputs), then ``lin.eig(n_modes=40)`` (shift-invert on its descriptor pair);
* ``pencil``: :func:`femb.analysis.linearize.damped_modes` (the constrained descriptor pencil
  without a null-space basis).

Prints the wall and CPU time (user + sys of every thread, ``resource.getrusage``) of the
linearization and eigen solution (the model built and compiled before), the peak memory of the
whole process (``ru_maxrss``; run one path per process to see each one's), and the check
Re s_k = −β ω_k²/2 (ζ_k = β ω_k / 2 of stiffness-proportional damping) on the eigenvalues found.

``python -m femb.benchmarks.cost.linearize_large [--n 10000] [--modes 20] [--path linearize|pencil]``
"""
from __future__ import annotations

import argparse
import resource
import time

import numpy as np

from femb import Mechanism
from femb.analysis import linearize as fl
from femb.analysis.linearize import damped_modes
from femb.elements.spatial_beam import SpatialSection, spatial_beam

E, NU, RHO, BETA = 2.1e11, 0.3, 7850.0, 1e-4


def build(n=10000, length=10.0):
    """The clamped beam with ``n`` elements (a :class:`~femb.Mechanism`)."""
    sec = SpatialSection.rectangle(E, E / (2.0 * (1.0 + NU)), 0.02, 0.01, RHO, damping=BETA)
    m = Mechanism("large_beam")
    spatial_beam(m, "beam", sec, [(0.0, 0.0, 0.0), (length, 0.0, 0.0)], int(n), start="clamp")
    return m


def linearized(model):
    """The sparse state space of the beam: input a vertical force at the free end, outputs its
    deflection and deflection rate."""
    tip = model.node_names[-1]
    label = f"{tip}.vz"
    return fl.linearize(model, inputs=[fl.force(model, model.q0, tip, (0.0, 0.0, 1.0), name="F_tip")],
                        outputs=[fl.coordinate(model, label), fl.coordinate(model, label, rate=True)])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=10000, help="elements")
    ap.add_argument("--modes", type=int, default=20, help="damped modes (conjugate pairs)")
    ap.add_argument("--path", choices=("linearize", "pencil"), default="linearize",
                    help="sparse state space then its modes, or the descriptor pencil directly")
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    model = build(a.n).compile()
    t1 = time.perf_counter()
    r1 = resource.getrusage(resource.RUSAGE_SELF)
    if a.path == "pencil":
        modes = damped_modes(model, n_modes=2 * a.modes)
    else:
        lin = linearized(model)
        modes = lin.eig(n_modes=2 * a.modes)
    t2 = time.perf_counter()
    r2 = resource.getrusage(resource.RUSAGE_SELF)
    cpu = r2.ru_utime - r1.ru_utime + r2.ru_stime - r1.ru_stime
    s = modes.eigenvalues
    up = s[s.imag > 0]
    w = np.abs(up)
    re_err = np.max(np.abs(up.real + BETA * w * w / 2.0) / w)
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    print(f"beam: {a.n} elements, {model.nq} unknowns, {model.nc} constraints")
    print(f"build + compile: {t1 - t0:.2f} s")
    if a.path == "linearize":
        print(f"state space: {lin.n} states ({'sparse' if lin.sparse else 'dense'}), B {lin.B.shape}, "
              f"C {lin.C.shape}, D {lin.D.shape}")
    print(f"[{a.path}] linearize + {2 * a.modes} eigenvalues (sparse shift-invert): wall {t2 - t1:.2f} s, "
          f"CPU (user + sys, all threads) {cpu:.2f} s")
    print(f"peak memory of the process (ru_maxrss): {rss:.0f} MB")
    print(f"slowest mode {w[0] / (2 * np.pi):.4f} Hz, fastest found {w[-1] / (2 * np.pi):.2f} Hz; {up.size} pairs; "
          f"max |Re s + βω²/2| / |s| (stiffness-proportional damping): {re_err:.1e}")


if __name__ == "__main__":
    main()
