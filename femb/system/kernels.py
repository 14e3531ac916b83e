"""Calling an element type's compiled kernels from Python, one batch at a time.

The compiled time loop (:mod:`femb.engine`) calls the kernels directly; this module
serves everything else that needs element values from Python: the user-level
assembly functions (:mod:`femb.system.assembly`), static and modal analysis, output, and
the finite-difference tests of the kernels. The arrays follow the contract of
``docs/kernels.md``: ``xe (nel, ndx)``, ``ve (nel, ndv)``, ``le (nel, nc)``.
"""
from __future__ import annotations

import inspect
import os
import sys
import time

import numba
import numpy as np
from numba.core import types

from femb.errors import ModelError
from femb.base.jit import (
    KERNEL_OPTIONS, ROLE_ARGUMENTS, ROLE_SIGNATURES, _PY_KERNELS, cache_writable, compile_lock, is_cached,
    jit_disabled, use_cache)


#: the velocity-level (non-holonomic) constraint role, A(q, t) v + a(q, t) = 0 (docs/kernels.md):
#: ``velocity_constraint(P, t, tf, xe, ve, le, jac, Psi, A, Psi_t, Dq, H)`` with Psi = A v + a
#: (nel, nn), A (nel, nn, ndv), Psi_t = ∂Psi/∂t (nel, nn); with ``jac``: Dq = ∂Psi/∂x along
#: x ∘ exp(εw) at fixed v (nel, nn, ndv) and H = ∂(Aᵀμ)/∂x (nel, ndv, ndv). The compiled engine
#: calls it by address (femb.base.jit.call_velocity_constraint); linearization and checks from Python.
_F2, _F3 = types.float64[:, ::1], types.float64[:, :, ::1]
SIGNATURES = dict(ROLE_SIGNATURES, velocity_constraint=types.void(
    _F2, types.float64, _F3, _F2, _F2, _F2, types.boolean, _F2, _F3, _F2, _F3, _F3))
ARGUMENTS = dict(ROLE_ARGUMENTS, velocity_constraint=(
    "P", "t", "tf", "xe", "ve", "le", "jac", "Psi", "A", "Psi_t", "Dq", "H"))
_N_OUTPUTS = {"mass": 1, "force": 3, "constraint": 3, "rates": 2, "energy": 1, "velocity_constraint": 5}


def _f(a):
    return np.ascontiguousarray(a, dtype=np.float64)


# --------------------------------------------------------------------------
# the unilateral-contact role (docs/contact.md): called from Python by femb.contact,
# not (yet) by the compiled engine, so its signature lives here beside the engine's roles
# --------------------------------------------------------------------------
#: contact(P, t, tf, xe, ve, le, jac, gN, W, zeta, H): gap, force directions, curvature terms
CONTACT_SIGNATURE = types.void(_F2, types.float64, _F3, _F2, _F2, _F2, types.boolean, _F2, _F3, _F2, _F3)
CONTACT_ARGUMENTS = ("P", "t", "tf", "xe", "ve", "le", "jac", "gN", "W", "zeta", "H")
SIGNATURES["contact"] = CONTACT_SIGNATURE
ARGUMENTS["contact"] = CONTACT_ARGUMENTS
_N_OUTPUTS["contact"] = 4


# --------------------------------------------------------------------------
# kernels compiled once per element type (and cached on disk)
# --------------------------------------------------------------------------
_compiled = {}


def debug_mode() -> bool:
    """Whether kernels run bounds-checked (``FEMB_DEBUG=1``): an out-of-bounds index in a
    kernel raises an error naming the element type instead of corrupting memory."""
    return os.environ.get("FEMB_DEBUG", "") not in ("", "0")


def _check_kernel(owner, role, fn):
    """The checks of a kernel before it is compiled: a function of the role's arity."""
    py = getattr(fn, "py_func", fn)
    args = ", ".join(ARGUMENTS[role])
    if not inspect.isfunction(py):
        raise ModelError(f"element type {owner}: kernels['{role}'] is {fn!r}, not a function; expected "
                         f"a function {role}({args}) (docs/kernels.md)")
    try:
        params = inspect.signature(py).parameters.values()
    except (TypeError, ValueError):
        params = []
    positional = [p for p in params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    if len(positional) != len(ARGUMENTS[role]) or any(p.kind == p.VAR_POSITIONAL for p in params):
        have = ", ".join(p.name for p in params)
        raise ModelError(f"element type {owner}: kernel {py.__name__}({have}) for the role '{role}' must take "
                         f"{len(ARGUMENTS[role])} arguments ({args}); it takes {len(positional)} "
                         f"(docs/kernels.md)")
    outputs = _N_OUTPUTS[role]
    out_names = [p.name for p in positional][-outputs:]
    used = _loaded_names(py.__code__)
    if not any(n in used for n in out_names):
        raise ModelError(f"element type {owner}: kernel {py.__name__} never uses its output arrays "
                         f"({', '.join(out_names)}); kernels write their results into them (they are zeroed "
                         f"before the call) and return nothing (docs/kernels.md)")
    return py


def _loaded_names(code):
    import dis
    names = set()
    for ins in dis.get_instructions(code):
        if ins.opname.startswith("LOAD_FAST") or ins.opname in ("LOAD_DEREF", "LOAD_CLOSURE"):
            v = ins.argval
            names.update(v if isinstance(v, tuple) else (v,))
    for c in code.co_consts:
        if hasattr(c, "co_code"):
            names |= _loaded_names(c)
    return names


def compiled_kernel(owner, role, fn, boundscheck=None):
    """``(dispatcher, address)`` of ``fn`` compiled for ``role``'s signature (``femb.base.jit.ROLE_SIGNATURES``).

    Compiled once per kernel and process, loaded from femb's disk cache when an earlier
    process compiled it (the key hashes the kernel's file and the files of the compiled
    functions it calls, see :func:`femb.base.jit.source_key`). The engine calls the kernel
    through ``address``; Python calls ``dispatcher``.

    Raises
    ------
    ModelError
        The kernel is not a function of the role's arity, never writes its outputs, does not
        compile for the role's argument types, or returns a value.
    """
    debug = debug_mode() if boundscheck is None else bool(boundscheck)
    hit = _compiled.get((fn, role, debug))
    if hit is not None:                      # (every Python-side kernel call comes here: no checks twice)
        return hit
    py = _check_kernel(owner, role, fn)
    key = (py, role, debug)
    hit = _compiled.get(key)
    if hit is not None:
        _compiled[(fn, role, debug)] = hit
        return hit
    sig = SIGNATURES[role]
    if jit_disabled():
        _PY_KERNELS.append(py)
        out = (py, len(_PY_KERNELS) - 1)
        _compiled[key] = out
        _compiled[(fn, role, debug)] = out
        return out
    opts = dict(getattr(fn, "targetoptions", None) or KERNEL_OPTIONS)
    if not hasattr(fn, "targetoptions"):
        opts = dict(KERNEL_OPTIONS)          # a plain Python function: may allocate
    opts.pop("nopython", None)
    opts["boundscheck"] = debug
    disp = use_cache(numba.njit(**opts)(py), extra=f"{sorted(opts.items())}")
    args = sig.args
    t0 = time.perf_counter()
    try:
        # one process compiles, the others wait for the lock and load its cache entry
        with compile_lock(f"kernel-{py.__module__}.{py.__qualname__}"):
            fresh = not is_cached(disp, args)
            disp.compile(args)
    except numba.core.errors.NumbaError as e:
        first = str(e).strip().splitlines()
        msg = next((ln for ln in first if ln.strip()), "")
        raise ModelError(f"element type {owner}: kernel {py.__name__} does not compile for the role '{role}' "
                         f"with the argument types {role}({', '.join(ARGUMENTS[role])}) = {args} "
                         f"(docs/kernels.md): {msg}") from None
    cres = disp.overloads[args]
    if cres.signature.return_type != types.none:
        raise ModelError(f"element type {owner}: kernel {py.__name__} returns a value "
                         f"({cres.signature.return_type}); kernels write their results into the output "
                         f"arrays ({', '.join(ARGUMENTS[role][-2:])}, ...) and return nothing (docs/kernels.md)")
    addr = cres.library.get_pointer_to_function(cres.fndesc.llvm_func_name)
    if fresh:
        _fresh.append((owner, role, time.perf_counter() - t0))
    out = (disp, int(addr))
    _compiled[key] = out
    _compiled[(fn, role, debug)] = out
    return out


_fresh = []


def announce_compiled():
    """One line on stderr for the kernels compiled (not loaded from the cache) since the last call."""
    if _fresh:
        owners = sorted({o for o, _, _ in _fresh})
        dt = sum(d for _, _, d in _fresh)
        print(f"femb: compiled {len(_fresh)} kernel{'s' if len(_fresh) > 1 else ''} of "
              f"{', '.join(owners)} in {dt:.1f} s (first use of these element types; "
              f"{'cached' if cache_writable() else 'in memory only: the compile cache is not writable'})",
              file=sys.stderr, flush=True)
        _fresh.clear()


def _kernel(group, role):
    """The batch's kernel for ``role``, compiled for its role's signature (cached)."""
    return compiled_kernel(group.cls.__name__, role, group.cls.kernels[role])[0]


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


class ForceValues:
    """Element forces ``fe (nel, ndv)`` of one batch without the tangent, called many times
    (energies over the stored steps): the kernel's unused Jacobian outputs are allocated once."""

    def __init__(self, group):
        self.group = group
        self.fn = _kernel(group, "force")
        nel, ndv = group.nel, group.ndv
        self.fq = np.zeros((nel, ndv, ndv))
        self.fv = np.zeros((nel, ndv, ndv))

    def __call__(self, t, xe, ve):
        g = self.group
        fe = np.zeros((xe.shape[0], g.ndv))
        self.fn(g.P, float(t), time_values(g, t), _f(xe), _f(ve), False, fe, self.fq, self.fv)
        return fe


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


def energy(group, t, xe):
    """Potential energy of each element ``Ve (nel,)`` (the type's ``"energy"`` kernel)."""
    xe = _f(xe)
    Ve = np.zeros(xe.shape[0])
    _kernel(group, "energy")(group.P, float(t), time_values(group, t), xe, Ve)
    return Ve


def velocity_constraint(group, t, xe, ve, le=None, jac=True):
    """``Psi (nel, nn)`` = A v + a, ``A (nel, nn, ndv)``, ``Psi_t (nel, nn)`` and, with ``jac``,
    ``Dq = ∂Psi/∂x (nel, nn, ndv)`` and ``H = ∂(Aᵀμ)/∂x (nel, ndv, ndv)`` (None without)."""
    xe, ve = _f(xe), _f(ve)
    nel, ndv, nn = xe.shape[0], group.ndv, group.nn
    le = np.zeros((nel, nn)) if le is None else _f(le)
    Psi = np.zeros((nel, nn))
    A = np.zeros((nel, nn, ndv))
    Psi_t = np.zeros((nel, nn))
    Dq = np.zeros((nel, nn, ndv))
    H = np.zeros((nel, ndv, ndv))
    _kernel(group, "velocity_constraint")(group.P, float(t), time_values(group, t), xe, ve, le, bool(jac),
                                          Psi, A, Psi_t, Dq, H)
    return Psi, A, Psi_t, (Dq if jac else None), (H if jac else None)


def contact(group, t, xe, ve, le=None, jac=True):
    """A contact batch's kernel (docs/contact.md): gaps, force directions, curvature terms.

    Parameters
    ----------
    group : Group
        A batch of a type with ``n_contacts`` = k normal and ``n_friction`` = l tangent
        directions per element (``r = k + l`` rows).
    t : float
    xe : ndarray, shape (nel, ndx)
    ve : ndarray, shape (nel, ndv)
    le : ndarray, shape (nel, r), optional
        Contact forces (λ_N, λ_F) for ``H``.
    jac : bool

    Returns
    -------
    gN : ndarray, shape (nel, k)
        Gaps g_N ≥ 0.
    W : ndarray, shape (nel, r, ndv)
        Rows W_N = ∂g_N/∂v (normal velocity ġ_N = W_N v) and W_F (slip velocities γ_F = W_F v).
    zeta : ndarray, shape (nel, r)
        Curvature terms: g̈_N = W_N v̇ + ζ_N, γ̇_F = W_F v̇ + ζ_F.
    H : ndarray, shape (nel, ndv, ndv) or None
        ∂(Wᵀ le)/∂x along x ∘ exp(δ) (with ``jac``).
    """
    xe, ve = _f(xe), _f(ve)
    nel, ndv = xe.shape[0], group.ndv
    r = group.n_contact_rows
    le = np.zeros((nel, r)) if le is None else _f(le)
    gN = np.zeros((nel, group.traits["n_contacts"]))
    W = np.zeros((nel, r, ndv))
    zeta = np.zeros((nel, r))
    H = np.zeros((nel, ndv, ndv))
    _kernel(group, "contact")(group.P, float(t), time_values(group, t), xe, ve, le, bool(jac), gN, W, zeta, H)
    return gN, W, zeta, (H if jac else None)


def is_builtin(cls):
    """Whether ``cls`` is one of femb's own element types (their kernels are tested by femb)."""
    return (cls.__module__ or "").startswith(("femb.", "elements."))


def contract_check(group, xe, ve, t=0.0):
    """Run a batch's kernels once, bounds-checked, on the batch's own array shapes.

    For element types that are not femb's own, when a model is compiled: an index out of
    bounds in a kernel (which in the compiled loop would overwrite memory it does not own)
    is reported as a :class:`ModelError` naming the element type and the kernel, and a force
    that depends on the velocities without ``force_depends_on_qd`` is warned about (its
    damping would be left out of the iteration matrix).
    """
    import warnings
    owner = group.cls.__name__
    ks = getattr(group.cls, "kernels", None) or {}
    nel, ndv = group.dofs.shape
    tf = time_values(group, t)
    P = group.P
    xe = _f(xe)
    ve = _f(ve)

    def run(role, *args):
        fn = compiled_kernel(owner, role, ks[role], boundscheck=True)[0]
        try:
            fn(*args)
        except IndexError as e:
            raise ModelError(f"element type {owner}: kernel {getattr(ks[role], '__name__', role)} ('{role}') "
                             f"indexes an array out of bounds ({e}) on batch '{group.name}' with {nel} "
                             f"elements of {ndv} coordinates: P {P.shape}, xe {xe.shape}, outputs "
                             f"(nel, ndv) = ({nel}, {ndv}); see docs/kernels.md for the shapes") from None

    if "mass" in ks and group.traits.get("has_mass"):
        run("mass", P, xe, np.zeros((nel, ndv, ndv)))
    if "force" in ks and group.traits.get("has_force"):
        fe = np.zeros((nel, ndv))
        run("force", P, float(t), tf, xe, ve, True, fe, np.zeros((nel, ndv, ndv)), np.zeros((nel, ndv, ndv)))
        if not group.traits.get("force_depends_on_qd", False):
            rng = np.random.default_rng(1)
            fe2 = np.zeros((nel, ndv))
            z = np.zeros((nel, ndv, ndv))
            run("force", P, float(t), tf, xe, ve + rng.uniform(-1.0, 1.0, ve.shape), False, fe2, z, z.copy())
            if not np.allclose(fe, fe2, rtol=1e-12, atol=1e-300):
                warnings.warn(f"element type {owner}: its force changes with the velocities, but the type does "
                              f"not declare force_depends_on_qd = True: the damping is left out of the iteration "
                              f"matrix (Newton converges slower, or not at all). Declare it, and return ∂f/∂v "
                              f"in fv (docs/kernels.md).", ContractWarning, stacklevel=4)
    nc = group.nc
    if nc and "constraint" in ks:
        run("constraint", P, float(t), tf, xe, np.zeros((nel, nc)), True, np.zeros((nel, nc)),
            np.zeros((nel, nc, ndv)), np.zeros((nel, ndv, ndv)))
        if "rates" in ks:
            run("rates", P, float(t), tf, xe, ve, np.zeros((nel, nc)), np.zeros((nel, nc)))
    if "energy" in ks:
        run("energy", P, float(t), tf, xe, np.zeros(nel))
    nn = group.nn
    if nn and "velocity_constraint" in ks:
        run("velocity_constraint", P, float(t), tf, xe, ve, np.zeros((nel, nn)), True, np.zeros((nel, nn)),
            np.zeros((nel, nn, ndv)), np.zeros((nel, nn)), np.zeros((nel, nn, ndv)), np.zeros((nel, ndv, ndv)))


class ContractWarning(UserWarning):
    """An element type's kernels break a rule of docs/kernels.md that does not make results wrong."""
