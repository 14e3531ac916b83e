"""Proximal maps of the contact laws and their derivatives (docs/contact.md §2).

Normal cone inclusions are written as fixed points of proximal maps (Studer 2009, Ch. 3;
Capobianco et al. 2021, eqs. (128)–(142)): for r > 0,

    −λ ∈ N_{C}(x)  ⇔  λ = prox_C(λ − r x)

with C = R₀⁺ (Signorini, Newton's impact law: λ ≥ 0, x ≥ 0, λ x = 0) or the disc
C = {|λ| ≤ μ λ_N} (Coulomb's law with x the slip velocity).
"""
from __future__ import annotations

import numpy as np


def prox_nonnegative(x):
    """prox onto R₀⁺: max(x, 0) (elementwise)."""
    return np.maximum(x, 0.0)


def prox_disc(x, radius):
    """prox onto the disc (ball) {|y| ≤ radius} of the dimension of x."""
    nx = float(np.linalg.norm(x))
    if nx <= radius:
        return x.copy()
    return (radius / nx) * x


def direction(v):
    """(v/|v|, (I − v̂v̂ᵀ)/|v|): the unit vector of v and its derivative.

    For v = 0 the direction is undefined: returns (v, I) so that the slip law
    λ_F + μ λ_N v̂ reads λ_F + μ λ_N v (the slip law at zero slip degenerates to λ_F = 0).
    """
    nv = float(np.linalg.norm(v))
    k = v.size
    if nv == 0.0:
        return v.copy(), np.eye(k)
    vh = v / nv
    return vh, (np.eye(k) - np.outer(vh, vh)) / nv
