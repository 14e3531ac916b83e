"""numba in one place: the kernel decorator and the on-disk cache location.

Element kernels are decorated with :func:`kernel` (``numba.njit`` without its own
cache: they are compiled into, and cached with, the generated module of each
model kind, see :mod:`femb.codegen`). ``NUMBA_DISABLE_JIT=1`` runs everything as
plain Python for debugging.

The cache directory is ``$FEMB_CACHE_DIR`` if set, else the user's cache
directory (``$XDG_CACHE_HOME/femb`` or ``~/.cache/femb``).

Packs: the model data handed to the compiled time loop (per-batch arrays, model
constants, work arrays) travel as a *pack* of three arrays, ``(F, I, L)``: every
float array laid end to end in ``F``, every integer array in ``I``, and in row k
of ``L`` the offset and shape of array k. Compiled code takes array k back as a
view (:func:`fview` / :func:`iview` and their fixed-rank forms). A tuple of n
arrays passed to a compiled function becomes about 8 n scalar arguments of every
function it passes through; numba's compile time grows with them (a tuple of 80
arrays through a chain of six functions: 6.6 s against 1.1 s for three arrays).
"""
from __future__ import annotations

import os
from pathlib import Path

import numba
import numpy as np
from numba.core import cgutils, types
from numba.extending import intrinsic
from numba.np.arrayobj import make_array, populate_array

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


# --------------------------------------------------------------------------
# packs of arrays (see the module docstring)
# --------------------------------------------------------------------------
def pack(arrays):
    """Lay ``arrays`` (float or integer, ndim 1 to 3) end to end: ``((F, I, L), views)``.

    Parameters
    ----------
    arrays : sequence of ndarray
        Float arrays go to ``F`` (float64), integer ones to ``I`` (int64).

    Returns
    -------
    packed : tuple (F, I, L)
        F : ndarray (nf,) float64; I : ndarray (ni,) int64; L : ndarray (n, 4) int64,
        row k = (offset of array k in F or I, its shape padded with 1).
    views : list of ndarray
        Array k as a view into F or I (writes through to what compiled code sees).
    """
    L = np.zeros((len(arrays), 4), dtype=np.int64)
    nf = ni = 0
    kinds = []
    for k, a in enumerate(arrays):
        a = np.asarray(a)
        if not 1 <= a.ndim <= 3:
            raise ValueError(f"pack: array {k} has {a.ndim} dimensions (1 to 3 allowed)")
        isf = a.dtype.kind == "f"
        if not isf and a.dtype.kind not in "iub":
            raise ValueError(f"pack: array {k} has dtype {a.dtype} (float or integer allowed)")
        L[k, 1:1 + a.ndim] = a.shape
        L[k, 1 + a.ndim:] = 1
        L[k, 0] = nf if isf else ni
        if isf:
            nf += a.size
        else:
            ni += a.size
        kinds.append(isf)
    F = np.zeros(nf, dtype=np.float64)
    I = np.zeros(ni, dtype=np.int64)
    views = []
    for k, a in enumerate(arrays):
        a = np.asarray(a)
        buf = F if kinds[k] else I
        v = buf[L[k, 0]:L[k, 0] + a.size].reshape(a.shape)
        v[...] = a
        views.append(v)
    return (F, I, L), views


def _view_intrinsic(which, nd):
    """Intrinsic ``(P, k) -> array k of the pack P`` (buffer ``P[which]``, ``nd`` dimensions).

    It reads row k of ``L`` and builds a C-contiguous array struct on the
    buffer: no copy and no reference count (a compiled function without
    reference counting may not return an array it did not receive, so this
    cannot be a plain jitted function).
    """
    @intrinsic
    def view(typingctx, P, k):
        buf_t, L_t = P.types[which], P.types[2]
        retty = types.Array(buf_t.dtype, nd, "C")
        sig = retty(P, k)

        def codegen(context, builder, sig_, args):
            pv, kv = args
            buf = make_array(buf_t)(context, builder, builder.extract_value(pv, which))
            L = make_array(L_t)(context, builder, builder.extract_value(pv, 2))
            intp = context.get_value_type(types.intp)
            kk = context.cast(builder, kv, sig_.args[1], types.intp)
            Lshape = cgutils.unpack_tuple(builder, L.shape, 2)
            Lstrides = cgutils.unpack_tuple(builder, L.strides, 2)

            def entry(j):
                ptr = cgutils.get_item_pointer2(context, builder, L.data, Lshape, Lstrides, L_t.layout,
                                                [kk, intp(j)])
                return builder.load(ptr)

            off = entry(0)
            dims = [entry(1 + d) for d in range(nd)]
            itemsize = context.get_constant(types.intp,
                                            context.get_abi_sizeof(context.get_data_type(buf_t.dtype)))
            strides = [itemsize] * nd
            for d in range(nd - 2, -1, -1):
                strides[d] = builder.mul(strides[d + 1], dims[d + 1])
            out = make_array(retty)(context, builder)
            populate_array(out, data=builder.gep(buf.data, [off]), shape=dims, strides=strides,
                           itemsize=itemsize, meminfo=None)
            return out._getvalue()

        return sig, codegen

    if jit_disabled():
        def view(P, k):    # noqa: F811 (plain Python for NUMBA_DISABLE_JIT=1)
            L = P[2]
            shape = tuple(int(d) for d in L[k, 1:1 + nd])
            n = int(np.prod(shape))
            return P[which][L[k, 0]:L[k, 0] + n].reshape(shape)
    view.__doc__ = f"{'Float' if which == 0 else 'Integer'} array k of a pack (F, I, L), {nd}-D view."
    return view


fview1, fview2, fview3 = (_view_intrinsic(0, nd) for nd in (1, 2, 3))
iview1, iview2, iview3 = (_view_intrinsic(1, nd) for nd in (1, 2, 3))
