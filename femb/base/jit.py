"""numba in one place: the kernel decorator, kernel calls by address, packs, the compile cache.

Element kernels are decorated with :func:`kernel`; each is compiled once per element
type for its role's signature (:data:`ROLE_SIGNATURES`, :func:`femb.system.kernels.compiled_kernel`)
and the one engine (:mod:`femb.engine`) calls it through its address (:func:`call_force`,
:func:`call_constraint`, :func:`call_rates`). Compiled code is kept in femb's cache
(:func:`use_cache`, :func:`engine`), keyed on the source files it depends on.
``NUMBA_DISABLE_JIT=1`` runs everything as plain Python for debugging.

The cache directory is ``$FEMB_CACHE_DIR`` if set, else the user's cache
directory from ``platformdirs`` (on Linux ``$XDG_CACHE_HOME/femb`` or ``~/.cache/femb``;
``~/Library/Caches/femb`` on macOS, ``%LOCALAPPDATA%\\femb\\Cache`` on Windows).

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

import inspect
import os
from pathlib import Path

import numba
import numpy as np
from numba.core import cgutils, types
from numba.extending import intrinsic
from numba.np.arrayobj import make_array, populate_array

#: numba options of the element kernels
KERNEL_OPTIONS = dict(nogil=True, error_model="numpy", boundscheck=False, no_cfunc_wrapper=True)
#: options of the engine (femb/engine/): no reference counting of
#: arrays (the loop allocates nothing; this removes atomic increments from every call)
OPTIONS = dict(KERNEL_OPTIONS, _nrt=False)


def kernel(fn=None, *, allocates=False, **kw):
    """Decorator for element kernels and their helpers: ``numba.njit`` with femb's options.

    Kernels run without reference counting of arrays (as the engine): they
    must not create arrays (tuples of floats are fine). ``allocates=True``
    compiles a function that does (e.g. the array-returning functions of
    :mod:`femb.base.rotations`, called from Python); an element kernel that
    allocates still runs (the engine calls it through its address), a little
    slower. What Python calls directly is kept in femb's disk cache
    (:func:`use_cache`); the engine uses each element kernel's own compilation
    for its role (:func:`femb.system.kernels.compiled_kernel`). No C wrapper is compiled (the engine
    calls kernels' native code), which halves the compile time of helper-heavy kernels such as
    the spatial joints and bushings; every function keeps its Python wrapper, so that Python
    may call any of them.
    """
    opts = dict(KERNEL_OPTIONS if allocates else OPTIONS)
    opts.update(kw)

    def deco(f):
        if jit_disabled():
            f.py_func = f        # plain Python: the same attribute as a dispatcher's
            return f
        return use_cache(numba.njit(**opts)(f), extra=str(sorted(opts.items())))

    if fn is None:
        return deco
    return deco(fn)


def cache_dir() -> Path:
    """Directory of femb's compiled-code cache (created on demand when it can be).

    ``$FEMB_CACHE_DIR`` if set, else ``platformdirs.user_cache_dir("femb")`` (which honours
    ``$XDG_CACHE_HOME`` on Linux; default ``~/.cache/femb``). A directory that cannot be
    created is returned as it is; :func:`numba_cache_dir` then says so once.
    """
    env = os.environ.get("FEMB_CACHE_DIR")
    if env:
        base = Path(env)
    else:
        import platformdirs
        base = Path(platformdirs.user_cache_dir("femb", appauthor=False))
    try:
        base.mkdir(parents=True, exist_ok=True)
    except OSError:
        pass
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


def _borrow_value(context, builder, ty, val):
    """``val`` of type ``ty`` with every array in it (nested tuples included) as a view without a
    meminfo; anything else passed on as a new reference."""
    if isinstance(ty, types.Array):
        src = make_array(ty)(context, builder, value=val)
        out = make_array(ty)(context, builder)
        populate_array(out, data=src.data, shape=src.shape, strides=src.strides, itemsize=src.itemsize,
                       meminfo=None)
        return out._getvalue()
    if isinstance(ty, types.BaseTuple):
        vals = [_borrow_value(context, builder, t, builder.extract_value(val, i)) for i, t in enumerate(ty)]
        return context.make_tuple(builder, ty, vals)
    context.nrt.incref(builder, ty, val)
    return val


@intrinsic
def borrowed(typingctx, x):
    """``x`` (an array, or a tuple of arrays, nested) with its arrays as views that carry no reference
    count, for the arguments of a compiled entry point that allocates (its stages are compiled with
    reference counting).

    Every compiled function increfs at its entry, and decrefs at its exit, each array it receives, and
    each is an atomic operation; a tuple of 64 arrays passed through ten stages costs about 10³ of them
    a time step (docs/contact.md §7, "Reference counting"). The arrays an entry point receives from
    Python are owned by the caller until the call returns, so their views need no count. Never apply it
    to an array the compiled code allocates: its memory is freed when its last counted reference goes.
    """
    sig = x(x)

    def codegen(context, builder, sig_, args):
        return _borrow_value(context, builder, sig_.args[0], args[0])

    return sig, codegen


if jit_disabled():
    def borrowed(x):    # noqa: F811 (plain Python for NUMBA_DISABLE_JIT=1)
        return x


# --------------------------------------------------------------------------
# kernels compiled once per element type, called by address from the engine
# --------------------------------------------------------------------------
_F1 = types.Array(types.float64, 1, "C")
_F2 = types.Array(types.float64, 2, "C")
_F3 = types.Array(types.float64, 3, "C")
#: the signature of each kernel role (docs/kernels.md): every kernel of a role is compiled
#: for exactly this signature, so the one engine calls any of them through a function pointer
ROLE_SIGNATURES = {
    "mass": types.void(_F2, _F2, _F3),
    "force": types.void(_F2, types.float64, _F3, _F2, _F2, types.boolean, _F2, _F3, _F3),
    "constraint": types.void(_F2, types.float64, _F3, _F2, _F2, types.boolean, _F2, _F3, _F3),
    "rates": types.void(_F2, types.float64, _F3, _F2, _F2, _F2, _F2),
    "energy": types.void(_F2, types.float64, _F3, _F2, _F1),
    # non-holonomic rows Ψ = A v + a (docs/kernels.md): P, t, tf, xe, ve, le, jac, Psi, A, Psi_t, Dq, H
    "velocity_constraint": types.void(_F2, types.float64, _F3, _F2, _F2, _F2, types.boolean, _F2, _F3, _F2,
                                      _F3, _F3),
}
#: the arguments of each role, by name (for error messages)
ROLE_ARGUMENTS = {
    "mass": ("P", "xe", "Me"),
    "force": ("P", "t", "tf", "xe", "ve", "jac", "fe", "fq", "fv"),
    "constraint": ("P", "t", "tf", "xe", "le", "jac", "Phi", "B", "H"),
    "rates": ("P", "t", "tf", "xe", "ve", "Phi_t", "gam"),
    "energy": ("P", "t", "tf", "xe", "Ve"),
    "velocity_constraint": ("P", "t", "tf", "xe", "ve", "le", "jac", "Psi", "A", "Psi_t", "Dq", "H"),
}
#: with the JIT disabled, kernel "addresses" index this list of Python functions
_PY_KERNELS = []


def kernel_args_match(args, wanted):
    """Whether the numba types ``args`` can be passed to a kernel taking ``wanted`` (its signature's
    arguments): C-contiguous arrays of the same dtype and rank, numbers or booleans for scalars."""
    if len(args) != len(wanted):
        return False
    for have, want in zip(args, wanted):
        if isinstance(want, types.Array):
            if not (isinstance(have, types.Array) and have.dtype == want.dtype and have.ndim == want.ndim
                    and have.layout == "C"):
                return False
        elif not isinstance(have, (types.Number, types.Boolean)):
            return False
    return True


def _call_codegen(role, args):
    """Typing and code generation of a call of a ``role`` kernel through its address."""
    ksig = ROLE_SIGNATURES[role]
    addr, args = args[0], args[1:]
    if not isinstance(addr, types.Integer) or not kernel_args_match(args, ksig.args):
        return None
    sig = types.none(addr, *args)

    def codegen(context, builder, sig_, llargs):
        vals = [context.cast(builder, v, have, want) for v, have, want in zip(llargs[1:], args, ksig.args)]
        fnty = context.call_conv.get_function_type(types.void, ksig.args)
        fptr = builder.inttoptr(llargs[0], fnty.as_pointer())
        status, _ = context.call_conv.call_function(builder, fptr, types.void, ksig.args, vals)
        with cgutils.if_unlikely(builder, status.is_error):
            context.call_conv.return_status_propagate(builder, status)
        return context.get_dummy_value()

    return sig, codegen


def _py_call(addr, *args):
    _PY_KERNELS[addr](*args)


@intrinsic
def call_force(typingctx, addr, P, t, tf, xe, ve, jac, fe, fq, fv):
    """Call the compiled force kernel at address ``addr`` (numba's native calling convention)."""
    return _call_codegen("force", (addr, P, t, tf, xe, ve, jac, fe, fq, fv))


@intrinsic
def call_constraint(typingctx, addr, P, t, tf, xe, le, jac, Phi, B, H):
    """Call the compiled constraint kernel at address ``addr``."""
    return _call_codegen("constraint", (addr, P, t, tf, xe, le, jac, Phi, B, H))


@intrinsic
def call_rates(typingctx, addr, P, t, tf, xe, ve, Phi_t, gam):
    """Call the compiled rates kernel at address ``addr``."""
    return _call_codegen("rates", (addr, P, t, tf, xe, ve, Phi_t, gam))


@intrinsic
def call_velocity_constraint(typingctx, addr, P, t, tf, xe, ve, le, jac, Psi, A, Psi_t, Dq, H):
    """Call the compiled velocity-constraint (non-holonomic) kernel at address ``addr``."""
    return _call_codegen("velocity_constraint", (addr, P, t, tf, xe, ve, le, jac, Psi, A, Psi_t, Dq, H))


if jit_disabled():
    call_force = call_constraint = call_rates = call_velocity_constraint = _py_call      # noqa: F811 (plain Python)


# --------------------------------------------------------------------------
# femb's compile cache: one directory per source key, CPU-specific entries inside
# --------------------------------------------------------------------------
import contextlib as _contextlib
import hashlib as _hashlib
import sys as _sys
import warnings as _warnings

from numba.core import caching as _caching

_file_hashes = {}
_cache_state = {"warned": False, "damaged": 0, "in_memory": 0}


def _file_hash(path):
    h = _file_hashes.get(path)
    if h is None:
        try:
            h = _hashlib.sha256(Path(path).read_bytes()).hexdigest()
        except OSError:
            h = "missing"
        _file_hashes[path] = h
    return h


def _code_names(code):
    names = set(code.co_names)
    for c in code.co_consts:
        if hasattr(c, "co_names"):
            names |= _code_names(c)
    return names


def _is_library_file(path):
    p = str(path)
    return "site-packages" in p or "dist-packages" in p or p.startswith(_sys.base_prefix)


def dependency_files(py_func, _seen=None):
    """Source files a compiled function depends on: its own, and those of the compiled
    functions and femb intrinsics it calls (through its globals, transitively).

    numba's own cache checks only the file of the function it compiles; a kernel that calls
    a helper in another file must be recompiled when that file changes, and must not be when
    an unrelated file in the same folder changes.
    """
    seen = set() if _seen is None else _seen
    try:
        own = inspect.getsourcefile(py_func)
    except TypeError:
        own = None
    if own:
        seen.add(str(own))
    glb = getattr(py_func, "__globals__", {})
    names = _code_names(py_func.__code__)
    for name in sorted(names):
        obj = glb.get(name)
        if obj is None:
            continue
        mods = [obj] if inspect.ismodule(obj) else []
        for m in mods:       # module.attr: the attributes named in the code
            f = getattr(m, "__file__", None)
            if not f or _is_library_file(f):
                continue
            for attr in names:
                sub = getattr(m, attr, None)
                inner = getattr(sub, "py_func", None)
                if inner is not None and inspect.getsourcefile(inner) not in seen:
                    dependency_files(inner, seen)
        inner = getattr(obj, "py_func", None)
        if inner is not None:
            f = inspect.getsourcefile(inner)
            if f and str(f) not in seen and not _is_library_file(f):
                dependency_files(inner, seen)
        elif not inspect.ismodule(obj):
            mod = _sys.modules.get(getattr(obj, "__module__", "") or "")
            f = getattr(mod, "__file__", None)
            if f and not _is_library_file(f):
                seen.add(str(f))
    return seen


def source_key(py_func, extra=""):
    """Hash of everything a compiled function's machine code depends on (but the CPU,
    which numba's index records per entry): the sources of its dependency files, the
    numba, llvmlite, numpy and Python versions, and ``extra`` (compile options)."""
    import llvmlite
    h = _hashlib.sha256()
    for f in sorted(dependency_files(py_func)):
        h.update(Path(f).name.encode())
        h.update(_file_hash(f).encode())
    h.update(f"{numba.__version__} {llvmlite.__version__} {np.__version__} {_sys.version} {extra}".encode())
    return h.hexdigest()[:20]


class CacheWarning(UserWarning):
    """femb's compile cache cannot be written (code that is not in it compiles in memory), or an
    entry in it was damaged (discarded and compiled again)."""


#: seconds a process waits for another one's compile lock before it compiles by itself
LOCK_TIMEOUT = 900.0


def _warn_unwritable(where, err):
    if not _cache_state["warned"]:
        _cache_state["warned"] = True
        _warnings.warn(f"femb: the compile cache {where} is not writable ({err}): what is in it loads, what "
                       f"is not compiles in memory for this process only. Set FEMB_CACHE_DIR to a writable "
                       f"directory to keep compiled code between runs.", CacheWarning, stacklevel=3)


def numba_cache_dir():
    """Directory of femb's numba cache entries, or None if it does not exist and cannot be created.

    A directory that exists but cannot be written (a prebuilt cache in a Docker layer or on a
    cluster share) is returned: its entries load, and only code that is not in it compiles, in
    memory (one :class:`CacheWarning` when that happens, :func:`cache_writable`).
    """
    d = cache_dir() / "numba"
    try:
        d.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        if not d.is_dir():
            _warn_unwritable(d, e)
            return None
    return d


def cache_writable():
    """Whether code compiled now is kept in femb's disk cache for later runs."""
    d = None if jit_disabled() else numba_cache_dir()
    return d is not None and os.access(d, os.W_OK)


class _FembLocator(_caching._CacheLocator):
    """Cache entries of femb-compiled functions in ``<cache>/numba/<module>-<key>``."""

    _pending = {}

    def __init__(self, py_func, py_file, key, root, prefix=""):
        self._lineno = py_func.__code__.co_firstlineno
        self._py_file = py_file
        mod = prefix + Path(py_file).stem
        self._path = str(root / f"{mod}-{key}")
        self._key = key

    def ensure_cache_path(self):
        os.makedirs(self._path, exist_ok=True)

    def get_cache_path(self):
        return self._path

    def get_source_stamp(self):
        return self._key

    def get_disambiguator(self):
        return str(self._lineno)

    @classmethod
    def from_function(cls, py_func, py_file):
        key, root, prefix = cls._pending[id(py_func)]
        return cls(py_func, py_file, key, root, prefix)


class _FembCacheImpl(_caching.CompileResultCacheImpl):
    _locator_classes = [_FembLocator]


class _FembCache(_caching.FunctionCache):
    _impl_class = _FembCacheImpl

    def _writable(self):
        return os.access(self.cache_path if os.path.isdir(self.cache_path) else os.path.dirname(self.cache_path),
                         os.W_OK)

    def load_overload(self, sig, target_context):
        try:
            cres = super().load_overload(sig, target_context)
        except OSError:
            return None
        except Exception as e:            # a truncated or damaged entry (pickle, EOF, rebuild errors)
            self._discard(e)
            return None
        # an entry is only used for the signature it was compiled for (never a crash from
        # an index that points at another signature's code)
        if cres is not None:
            from numba.core import sigutils
            try:
                want = tuple(sigutils.normalize_signature(sig)[0])
            except Exception:
                return cres
            if tuple(getattr(cres.signature, "args", ())) != want:
                return None
        return cres

    def _discard(self, err):
        """Remove this function's index and data files after ``err`` reading them (one warning)."""
        cf = self._cache_file
        base = self._impl.filename_base
        files = [cf._index_path] + sorted(str(p) for p in Path(self.cache_path).glob(f"{_glob_escape(base)}.*.nbc"))
        removed = False
        if self._writable():
            try:
                with _file_lock(os.path.join(self.cache_path, base + ".lock")):
                    for f in files:
                        with _contextlib.suppress(FileNotFoundError):
                            os.unlink(f)
                removed = True
            except OSError:
                pass
        if not _cache_state["damaged"]:
            what = ("discarded it and compiling again" if removed else
                    "it cannot be removed (the cache is not writable): compiling in memory")
            _warnings.warn(f"femb: the compile cache entry {cf._index_path} is damaged "
                           f"({type(err).__name__}: {str(err)[:120]}); {what}", CacheWarning, stacklevel=4)
        _cache_state["damaged"] += 1

    def save_overload(self, sig, data):
        # numba's index/data files are not safe against two processes saving signatures of one
        # function at once: both can pick the same data file name, and the index then points
        # at the other signature's code (a crash when it is called). One writer at a time.
        if not self._writable():
            _warn_unwritable(self.cache_path, "permission denied")
            _cache_state["in_memory"] += 1
            return
        try:
            os.makedirs(self.cache_path, exist_ok=True)
            with _file_lock(os.path.join(self.cache_path, self._impl.filename_base + ".lock")):
                try:
                    super().save_overload(sig, data)
                except OSError:
                    raise
                except Exception as e:      # a damaged index in the way: discard it, save afresh
                    self._discard(e)
                    super().save_overload(sig, data)
        except OSError as e:
            _warn_unwritable(self.cache_path, e)
            _cache_state["in_memory"] += 1

    def has(self, sig, target_context):
        """Whether an entry for ``sig`` on this CPU is on disk (without loading it)."""
        try:
            key = self._index_key(sig, target_context.codegen())
            return key in self._cache_file._load_index()
        except Exception:
            return False


def _glob_escape(s):
    import glob
    return glob.escape(s)


def use_cache(disp, extra="", prefix=""):
    """Give a numba dispatcher femb's disk cache (keyed by :func:`source_key`); returns it.

    Without a cache directory the dispatcher compiles in memory (one warning); a read-only
    one serves the entries it holds.
    """
    if jit_disabled():
        return disp
    root = numba_cache_dir()
    if root is None:
        return disp
    key = source_key(disp.py_func, extra)
    _FembLocator._pending[id(disp.py_func)] = (key, root, prefix)
    try:
        disp._cache = _FembCache(disp.py_func)
    finally:
        _FembLocator._pending.pop(id(disp.py_func), None)
    return disp


def is_cached(disp, sig):
    """Whether ``disp`` has ``sig`` compiled in this process or on disk."""
    if jit_disabled():
        return True
    if tuple(sig) in disp.overloads:
        return True
    c = getattr(disp, "_cache", None)
    return isinstance(c, _FembCache) and c.has(tuple(sig), disp.targetctx)


@_contextlib.contextmanager
def compile_lock(name):
    """An exclusive lock (``<cache>/numba/<name>.lock``) held while compiling, so that several
    processes that need the same code (test workers, Dask workers) compile it once while the
    others wait, then load it from the cache. No lock without a writable cache."""
    if not cache_writable():
        yield
        return
    try:
        lock = _file_lock(numba_cache_dir() / f"{name}.lock")
        lock.__enter__()
    except OSError:
        yield
        return
    try:
        yield
    finally:
        lock.__exit__(None, None, None)


@_contextlib.contextmanager
def _file_lock(path, timeout=None):
    """An exclusive lock on ``path`` (created), held inside the ``with`` block (``filelock``:
    ``flock`` on POSIX, ``msvcrt`` locking on Windows; released when the process dies).

    After ``timeout`` seconds (default :data:`LOCK_TIMEOUT`) of waiting for another process
    the block runs without the lock (one :class:`CacheWarning`): the worst case is the same
    code compiled twice, and numba's atomic writes keep the cache usable.
    """
    import filelock
    lock = filelock.FileLock(str(path), timeout=LOCK_TIMEOUT if timeout is None else timeout)
    try:
        lock.acquire()
    except filelock.Timeout:
        _warnings.warn(f"femb: waited {lock.timeout:.0f} s for the compile lock {path} held by another "
                       f"process; compiling without it", CacheWarning, stacklevel=3)
        yield
        return
    try:
        yield
    finally:
        lock.release()


def package_files_hash(py_func):
    """Hash of every ``.py`` file in the folder of ``py_func``'s source (its package).

    The engine's stages (``femb/engine/*.py``) read named constants of ``femb/engine/layout.py``
    as compile-time globals; :func:`dependency_files` follows compiled functions, not integers,
    so the engine's key hashes the whole package: an edit of any of its files recompiles it.
    """
    folder = Path(inspect.getsourcefile(py_func)).parent
    h = _hashlib.sha256()
    for f in sorted(folder.glob("*.py")):
        h.update(f.name.encode())
        h.update(_file_hash(str(f)).encode())
    return h.hexdigest()[:20]


def engine(**opts):
    """Decorator of the engine's entry points (femb/engine/): ``numba.njit`` with femb's disk cache,
    keyed on every file of the engine's package; entries in ``<cache>/numba/engine.<stage>-<key>``."""
    def deco(fn):
        return use_cache(numba.njit(**opts)(fn), extra=package_files_hash(fn), prefix="engine.")
    return deco
