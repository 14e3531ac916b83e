"""Stage: build: the engine's entry points, their one signature each, and their compilation.

The engine is compiled once per installation and CPU and cached on disk (:func:`femb.base.jit.engine`);
its cache key hashes every file of this package (:func:`femb.base.jit.engine`), so that an edit of
any stage or of the layout recompiles it.
"""

from femb.engine.linalg import band_lu, band_solve, dense_lu, dense_lu_solve, dense_solve
from femb.engine.evaluate import (constraint_B, copy_B, eval_time_functions, evaluate, jacobian_times,
                                    kernel_blocks, rates)
from femb.engine.control import (kkt_estimate, kkt_solve, project_normal_velocity, refine_accelerations,
                                 resynchronise)
from femb.engine.loop import run
from femb.engine.newton import ggl_matrix, lie_reset, newton_step, velocity_residual


# ---- the engine's entry points and their one signature each -----------------------------------
def engine_signatures():
    """``{entry point: argument types}``: every entry point of the engine has one signature,
    whatever the model (its data come as packs and arrays of fixed rank and dtype)."""
    from numba import types as T
    from femb.engine.layout import NewtonArrays, Out, Par, StepState
    f1, i1, i2, f2 = T.float64[::1], T.int64[::1], T.int64[:, ::1], T.float64[:, ::1]
    P = T.Tuple((f1, i1, i2))
    f, i, b = T.float64, T.int64, T.boolean
    par = T.NamedTuple((i1, f1, i1, f1, i1), Par)
    state = T.NamedUniTuple(f1, len(StepState._fields), StepState)
    newton = T.NamedTuple((f1, i1, f1, f1, f1, f1, f1, f2), NewtonArrays)
    out = T.NamedTuple((f1, f2, f2, f2, f2, f1, T.int32[::1], f1), Out)
    fac = T.Tuple((f1, i1))
    return {
        run: (P, P, P, par, state, newton, out, i),
        evaluate: (P, P, f, T.UniTuple(f1, 4), b, T.UniTuple(f, 3), T.UniTuple(f1, 3)),
        kkt_solve: (P, P, par, newton, P, f, f1, f1, fac, f1),
        project_normal_velocity: (P, P, i1, P, f, f1, f1, f1, fac),
        rates: (P, P, f, f1, f1, f1, f1),
        jacobian_times: (P, P, f, f1, f1, f1),
        constraint_B: (P, P, f, f1, f1, f1),
        copy_B: (P, P, f1),
        ggl_matrix: (P, f1, f),
        lie_reset: (P,),
        eval_time_functions: (f, i1, i1, f1, f2),
        band_lu: (f1, i, i, i, i2, i1, f),
        band_solve: (f1, i, i, i, i2, i1, f1),
        dense_lu_solve: (f1, i, i1, f, f1),
    }


def stage_signatures():
    """``{stage: argument types}`` of the stages that are called by symbol only (not from Python):
    with the entry points, every compiled unit of the engine that has a cache entry of its own
    (the parallel build, :mod:`femb.engine.parallel`, compiles each of them on its own)."""
    from numba import types as T
    sg = engine_signatures()
    P, par, state, newton = sg[run][0], sg[run][3], sg[run][4], sg[run][5]
    f1, i1 = T.float64[::1], T.int64[::1]
    f, i, b = T.float64, T.int64, T.boolean
    return {
        newton_step: (P, P, par, state, newton, f, f, f, f1),
        velocity_residual: (P, P, f, f1, f1, b, b, f1),
        kkt_estimate: (P, P, par, state, newton, P, f, f, f, b),
        refine_accelerations: (P, P, par, state, newton, P, f, f, i),
        resynchronise: (P, P, par, state, newton, P, f, f, f),
        kernel_blocks: (P, P, i1, f, f1, f1, f1, b, f, f),
        dense_lu: (f1, i, i1, f),
        dense_solve: (f1, i, i1, f1),
    }


def _declare_returns():
    """The return type of every stage called by symbol (femb.engine.link.declare): what a caller
    compiled without its stages is typed with; checked against the compiled stages."""
    from numba import types as T
    from femb.engine.link import declare
    for disp, restype in ((newton_step, T.int64), (velocity_residual, T.none), (kkt_estimate, T.int64),
                          (refine_accelerations, T.none), (resynchronise, T.int64), (kkt_solve, T.int64),
                          (project_normal_velocity, T.none), (evaluate, T.float64),
                          (kernel_blocks, T.float64), (rates, T.literal(0)), (jacobian_times, T.literal(0)),
                          (constraint_B, T.int64), (copy_B, T.int64), (eval_time_functions, T.none),
                          (ggl_matrix, T.none), (band_lu, T.int64), (band_solve, T.none),
                          (dense_lu, T.int64), (dense_solve, T.none)):
        declare(disp, restype)


_declare_returns()

#: whether the engine is loaded in this process
_ENGINE = {"ready": False}


def ensure_engine(verbose=True):
    """Compile the engine, or load it from femb's disk cache: once per installation and CPU.

    Several processes that need it at once compile it once (a file lock), the others load it.
    Says so on stderr, with the time it took, when it has to compile.

    Returns
    -------
    bool
        True when it was compiled now: the caller may then compile the built-in kernels in the
        background (:func:`femb.solve.cache.start_background_build`; the engine does not import the
        cache module, which imports it).
    """
    import sys
    import time
    from femb.base.jit import cache_writable, compile_lock, is_cached, jit_disabled
    if _ENGINE["ready"] or jit_disabled():
        return False
    from femb.engine.parallel import compile_in_workers
    sigs = engine_signatures()
    with compile_lock("engine"):
        missing = [d for d, sg in sigs.items() if not is_cached(d, sg)]
        t0 = time.perf_counter()
        if missing and verbose:
            print(f"femb: compiling the engine (once per installation; {len(missing)} entry points)",
                  file=sys.stderr, flush=True)
        if missing:
            # the stages at once in worker processes, into the disk cache; this process then loads
            # them (and compiles here whatever they could not)
            compile_in_workers({**stage_signatures(), **sigs}, verbose)
        for d, sg in sigs.items():
            d.compile(sg)
            # any other argument types are a bug of the caller, not a reason to compile again
            d.disable_compile()
    if missing and verbose:
        kept = ("cached for later runs" if cache_writable() else
                "in memory for this run only (the compile cache is not writable)")
        print(f"femb: engine compiled in {time.perf_counter() - t0:.1f} s, {kept}", file=sys.stderr, flush=True)
    _ENGINE["ready"] = True
    return bool(missing)
