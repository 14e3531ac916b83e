"""Vibration modes of a flexible cantilever
========================================

A steel beam meshed into geometrically exact beam elements, clamped to the
ground, linearized about its unloaded configuration with
:func:`femb.analysis.modal.modal_analysis`. Its lowest bending frequencies converge
to the Euler–Bernoulli values ω_n = (β_n L)² √(EI/(ρA L⁴)) with
β_n L = 1.8751, 4.6941, 7.8548 (e.g. Géradin & Rixen, *Mechanical
Vibrations*, 3rd ed., 2015, Sect. 5.2) as the mesh is refined (the shear
deformation of this slender beam shifts them by less than 0.1 %).
"""
import math

import matplotlib.pyplot as plt

import numpy as np

import femb
from femb.analysis.modal import modal_analysis
from femb.elements import Section, add_beam

E, G, d, rho, L = 2.1e11, 8.1e10, 0.01, 7850.0, 1.0
sec = Section.circle(E, G, d, rho)
EI, rhoA = E * math.pi * d**4 / 64, rho * math.pi * d**2 / 4
exact = np.array([1.8751, 4.6941, 7.8548]) ** 2 * math.sqrt(EI / (rhoA * L**4))

rows = {}
print(f"{'elements':>8} " + " ".join(f"{f'omega_{k + 1} [rad/s]':>17}" for k in range(3)))
for n in (4, 8, 16, 32):
    mech = femb.Mechanism("cantilever")
    add_beam(mech, "beam", sec, (0.0, 0.0), (L, 0.0), n, start_joint="clamp")
    modes = modal_analysis(mech.compile(), n_modes=6)
    bending = modes.omega[modes.omega > 0][:3]    # the axial mode is much stiffer
    rows[n] = bending
    print(f"{n:8d} " + " ".join(f"{w:17.4f}" for w in bending))
print(f"{'exact':>8} " + " ".join(f"{w:17.4f}" for w in exact))

fig, ax = plt.subplots(figsize=(7, 4.5))
ns = np.array(sorted(rows))
for k in range(3):
    err = [abs(rows[n][k] / exact[k] - 1.0) for n in ns]
    ax.loglog(ns, err, "o-", label=f"mode {k + 1}")
ax.set_xlabel("number of beam elements")
ax.set_ylabel("relative error of the frequency")
ax.set_title("Cantilever: bending frequencies against Euler–Bernoulli")
ax.legend()
plt.show()
