"""Bending frequencies of a spatial beam against Euler–Bernoulli, per mass matrix and support.

Steel bar (E = 210 GPa, ν = 0.3, ρ = 7850 kg/m³), L = 1 m, rectangular section h × 2h with
L/h = 1000 (shear and rotary-inertia corrections below 1e-5), ``n`` SE(3) elements
(:func:`femb.elements.spatial_beam.spatial_beam`), clamped–free or free–free;
:func:`femb.analysis.modal.modal_analysis`. Bending modes in the x–z plane (EI₂) are told apart by
the translation they carry. References ω = (β_k L)² √(EI/(ρA L⁴)) with β_k L = 1.87510407,
4.69409113, 7.85475744, 10.99554073 (clamped–free) and 4.73004074, 7.85320462, 10.99560784,
14.13716549 (free–free) (R. D. Blevins, Formulas for Natural Frequency and Mode Shape,
1979, Table 8-1).

``python -m femb.benchmarks.accuracy.spatial_beam_modes [--n 20]`` prints the relative errors.
"""
from __future__ import annotations

import argparse
import math

import numpy as np

from femb import Mechanism
from femb.analysis.modal import modal_analysis
from femb.elements.spatial_beam import SpatialSection, spatial_beam

E, NU, L, RHO = 2.1e11, 0.3, 1.0, 7850.0
BETA_L = {"clamp": (1.87510407, 4.69409113, 7.85475744, 10.99554073),
          "free": (4.73004074, 7.85320462, 10.99560784, 14.13716549)}


def bending_errors(n=20, mass="consistent", support="clamp", slenderness=1000.0):
    """Relative errors (4,) of the four lowest bending frequencies in the x–z plane."""
    G = E / (2.0 * (1.0 + NU))
    h = L / slenderness
    sec = SpatialSection.rectangle(E, G, h, 2.0 * h, RHO)
    m = Mechanism("modes")
    spatial_beam(m, "b", sec, [(0.0, 0.0, 0.0), (L, 0.0, 0.0)], int(n),
                 start="clamp" if support == "clamp" else None, mass=mass)
    model = m.compile()
    r = modal_analysis(model, n_modes=min(model.nq, 60))
    w, modes = r.omega, r.modes
    if support != "clamp":
        w, modes = w[6:], modes[6:]                  # the six rigid-body modes
    tx = np.array([np.sum(v[0::6] ** 2) for v in modes])
    ty = np.array([np.sum(v[1::6] ** 2) for v in modes])
    tz = np.array([np.sum(v[2::6] ** 2) for v in modes])
    wb = np.sort(w[tz > 10.0 * (tx + ty)])
    EI = sec.C[4, 4]
    ref = np.array([b * b for b in BETA_L[support]]) * math.sqrt(EI / (sec.rhoA * L ** 4))
    return wb[:4] / ref - 1.0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=20, help="elements")
    a = ap.parse_args(argv)
    print(f"n = {a.n}: relative error of bending modes 1–4 (x–z plane) against Euler–Bernoulli")
    for mass in ("consistent", "averaged", "lumped"):
        for support in ("clamp", "free"):
            e = bending_errors(a.n, mass, support)
            print(f"  {mass:10s} {support:5s} " + "  ".join(f"{100 * v:+.2f} %" for v in e))


if __name__ == "__main__":
    main()
