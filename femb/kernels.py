"""Calling an element type's compiled kernels from Python, one batch at a time.

The compiled time loop (:mod:`femb.step`) calls the kernels directly; this module
serves everything else that needs element values from Python: the user-level
assembly functions (:mod:`femb.assembly`), static and modal analysis, output, and
the finite-difference tests of the kernels. The arrays follow the contract of
``docs/kernels.md``: ``xe (nel, ndx)``, ``ve (nel, ndv)``, ``le (nel, nc)``.
"""
from __future__ import annotations

import numpy as np


def _f(a):
    return np.ascontiguousarray(a, dtype=np.float64)


def _kernel(group, role):
    """The batch's compiled kernel for ``role``: the cached entry point of its model kind's
    generated module when the model has been compiled for simulation, else the kernel itself."""
    eps = getattr(group, "compiled_kernels", None)
    if eps and role in eps:
        return eps[role]
    return group.cls.kernels[role]


def time_values(group, t):
    """Time-function values of a batch at t: ``tf (nel, ntf, 3)`` = (f, f', f'')."""
    fns = group.time_functions
    nel = group.nel
    ntf = len(fns[0]) if fns else 0
    tf = np.zeros((nel, ntf, 3))
    for e in range(nel if ntf else 0):
        for k, fn in enumerate(fns[e]):
            tf[e, k, 0] = fn.f(t)
            tf[e, k, 1] = fn.df(t)
            tf[e, k, 2] = fn.ddf(t)
    return tf


def mass(group, xe):
    """Element mass matrices ``Me (nel, ndv, ndv)``."""
    xe = _f(xe)
    Me = np.zeros((xe.shape[0], group.ndv, group.ndv))
    _kernel(group, "mass")(group.P, xe, Me)
    return Me


def force(group, t, xe, ve, jac=True, raw=False):
    """Element forces ``fe (nel, ndv)`` and, with ``jac``, ``fq, fv (nel, ndv, ndv)``.

    ``fv`` is None for batches whose forces do not depend on q̇, unless ``raw``
    (then it is the array the kernel wrote, for checks).
    """
    xe, ve = _f(xe), _f(ve)
    nel, ndv = xe.shape[0], group.ndv
    fe = np.zeros((nel, ndv))
    fq = np.zeros((nel, ndv, ndv))
    fv = np.zeros((nel, ndv, ndv))
    _kernel(group, "force")(group.P, float(t), time_values(group, t), xe, ve, bool(jac), fe, fq, fv)
    if not jac:
        return fe, None, None
    traits = getattr(group, "traits", None)
    damped = raw or traits is None or bool(traits.get("force_depends_on_qd", True))
    return fe, fq, (fv if damped else None)


def constraint(group, t, xe, le=None, jac=True):
    """``Phi (nel, nc)``, ``B (nel, nc, ndv)`` and, with ``jac``, ``H (nel, ndv, ndv)``."""
    xe = _f(xe)
    nel, ndv, nc = xe.shape[0], group.ndv, group.nc
    le = np.zeros((nel, nc)) if le is None else _f(le)
    Phi = np.zeros((nel, nc))
    B = np.zeros((nel, nc, ndv))
    H = np.zeros((nel, ndv, ndv))
    _kernel(group, "constraint")(group.P, float(t), time_values(group, t), xe, le, bool(jac), Phi, B, H)
    return Phi, B, (H if jac else None)


def rates(group, t, xe, ve):
    """``Phi_t (nel, nc)`` and ``gam (nel, nc)`` (B q̈ = −gam)."""
    xe, ve = _f(xe), _f(ve)
    nel, nc = xe.shape[0], group.nc
    Phi_t = np.zeros((nel, nc))
    gam = np.zeros((nel, nc))
    _kernel(group, "rates")(group.P, float(t), time_values(group, t), xe, ve, Phi_t, gam)
    return Phi_t, gam
