"""numba in one place: the kernel decorator and the on-disk cache location.

Element kernels are decorated with :func:`kernel` (``numba.njit`` without its own
cache: they are compiled into, and cached with, the generated module of each
model kind, see :mod:`femb.codegen`). ``NUMBA_DISABLE_JIT=1`` runs everything as
plain Python for debugging.

The cache directory is ``$FEMB_CACHE_DIR`` if set, else the user's cache
directory (``$XDG_CACHE_HOME/femb`` or ``~/.cache/femb``).
"""
from __future__ import annotations

import os
from pathlib import Path

import numba

#: numba options of the element kernels
KERNEL_OPTIONS = dict(nogil=True, error_model="numpy", boundscheck=False)
#: options of the time loop (femb/step.py and the generated modules): no reference counting of
#: arrays (the loop allocates nothing; this removes atomic increments from every call)
OPTIONS = dict(KERNEL_OPTIONS, _nrt=False)


def kernel(fn=None, *, allocates=False, **kw):
    """Decorator for element kernels: ``numba.njit`` with femb's options, no cache.

    Kernels run without reference counting of arrays (as the time loop): they
    must not create arrays (tuples of floats are fine). ``allocates=True``
    compiles a function that does (e.g. the array-returning functions of
    :mod:`femb.rotations`, called from Python); a model whose element kernels
    allocate still runs, with the whole time loop of its kind compiled with
    reference counting (slower; :mod:`femb.codegen`).
    """
    opts = dict(KERNEL_OPTIONS if allocates else OPTIONS)
    opts.update(kw)
    if fn is None:
        return lambda f: numba.njit(**opts)(f)
    return numba.njit(**opts)(fn)


def cache_dir() -> Path:
    """Directory of femb's compiled-code cache (created on demand)."""
    env = os.environ.get("FEMB_CACHE_DIR")
    if env:
        base = Path(env)
    else:
        xdg = os.environ.get("XDG_CACHE_HOME")
        base = (Path(xdg) if xdg else Path.home() / ".cache") / "femb"
    base.mkdir(parents=True, exist_ok=True)
    return base


def jit_disabled() -> bool:
    return bool(numba.config.DISABLE_JIT)
