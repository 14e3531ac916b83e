"""Vectorized kinematics of body-fixed points on planar nodes.

A point with body-frame coordinates ``s`` on a node (x, y, θ) sits at
r = x + R(θ) s. With d = R(θ) s and J the rotation by +90°,
J d = (−d_y, d_x):

* ∂r/∂(x, y, θ) = [I, J d]
* ∂²r/∂θ² = −d

All functions take stacked arrays with a leading element dimension. They serve
Python-side code: packing, geometry and output (``geometry`` classmethods,
``Body.global_point``). Compiled element kernels cannot call them (they are numpy
code); a kernel writes the same trigonometry with scalars (see ``docs/kernels.md``).
"""
from __future__ import annotations

import numpy as np


def rot(theta, s):
    """d = R(θ) s.  theta (nel,), s (nel, 2) -> (nel, 2).

    Computed as the complex product e^{iθ}(s_x + i s_y), viewed as real pairs.
    """
    z = np.exp(1j * theta) * (s[:, 0] + 1j * s[:, 1])
    return z.view(np.float64).reshape(-1, 2)


def rotc(theta, sc):
    """Complex form of :func:`rot`: e^{iθ} sc for complex sc (nel,); returns (nel, 2) real."""
    return (np.exp(1j * theta) * sc).view(np.float64).reshape(-1, 2)


def perp(d):
    """J d = (−d_y, d_x).  d (..., 2) -> (..., 2)."""
    out = np.empty_like(d)
    out[..., 0] = -d[..., 1]
    out[..., 1] = d[..., 0]
    return out
