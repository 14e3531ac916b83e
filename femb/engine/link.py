"""Calls between the engine's stages by symbol: every stage is optimized and compiled once.

numba links the LLVM module of every compiled callee into the module of its caller and runs the
whole -O3 pipeline and the machine-code generation again over the result (numba 0.68,
``numba/core/codegen.py``, ``CPUCodeLibrary.finalize``): a stage at depth d of the call tree is
optimized and code-generated d + 1 times, and the engine's compile time grows with the sum over
its functions of the size of their subtrees (docs/engine.md, "Compile time").

``call(stage, *args)`` in compiled code calls ``stage`` (a numba dispatcher of the engine) without
linking it: the caller's module only *declares* the stage's native function under a symbol of its
own (``femb.stage.<module>.<function>.<hash of the argument types>``: the same in every process,
unlike numba's name of the function, which carries a per-process counter), and that symbol is given the address of the
stage's compiled code (``llvmlite.binding.add_symbol``) before the caller is loaded: while the
caller compiles (the call is typed) and, when the caller comes from the disk cache, by a hook that
numba runs before it loads the caller's object code (the library's ``reload_init``). The call is
numba's native calling convention, as a linked call that LLVM does not inline (the engine's
stages are not inlined by LLVM: they are large and called from several places), and an error
status of the stage propagates to the caller.

numba hands the hooks of a compiled function's library on to the libraries it is linked into, but
not those of a function loaded from the disk cache (numba 0.68, ``CompileResult._rebuild`` runs the
hooks and leaves the loaded library without them): a caller compiled now that links such a function
would be cached without the hooks its code needs, and a later process loading it would find the
symbols unbound. :func:`_keep_hooks_of_cached_functions` gives the loaded library its hooks back.

With the JIT disabled (``NUMBA_DISABLE_JIT=1``) ``call(stage, *args)`` is ``stage(*args)``.

**The parallel build** (:mod:`femb.engine.parallel`). A caller needs only its stages' *types* to
compile (the argument types and the return type: its code declares the symbol, the address comes
at load time), so the stages can be compiled in separate processes at once. Each stage declares
its return type (:func:`declare`); a build worker (:func:`defer_stages`) types every call from
these declarations instead of compiling the stage, and binds the stage's symbol in its own process
to ``abort`` (the worker never runs what it compiles: it writes it to the disk cache, whose object
code keeps the symbol unresolved, and the process that loads it binds the stage's real code). A
declaration that differs from what the stage compiles to is an error of the engine, raised by
:func:`stage_symbol` in every ordinary compile and checked by ``tests/test_engine_parallel.py``.
"""
import functools
import hashlib
import importlib
import inspect

import llvmlite.binding as ll
from numba.core import cgutils, types
from numba.extending import intrinsic

from femb.base.jit import jit_disabled

#: the stages' symbols registered in this process: symbol -> address
_SYMBOLS = {}
#: the dispatcher of each registered symbol
_OWNERS = {}
#: the declared return type of each stage: (module, qualified name) -> numba type
_RETURNS = {}
#: whether this process is a build worker (calls typed from the declarations, stages not compiled)
_WORKER = {"on": False, "placeholder": None}


def _py(disp):
    """The Python function of the stage ``disp`` (``disp`` itself under NUMBA_DISABLE_JIT=1, where
    numba's decorators return the function)."""
    return getattr(disp, "py_func", disp)


def declare(disp, restype):
    """Declare the numba type that the stage ``disp`` returns (for every argument types)."""
    f = _py(disp)
    _RETURNS[(f.__module__, f.__qualname__)] = restype


def declared_return(disp):
    """The declared return type of ``disp``, or None."""
    f = _py(disp)
    return _RETURNS.get((f.__module__, f.__qualname__))


def defer_stages():
    """Make this process a build worker: calls by symbol are typed from the stages' declared return
    types and their symbols are bound to ``abort``; code compiled here must not be run (it is
    meant for the disk cache)."""
    import ctypes
    _WORKER["on"] = True
    _WORKER["placeholder"] = ctypes.cast(ctypes.CDLL(None).abort, ctypes.c_void_p).value


def _placeholder_symbol(disp, argtypes):
    """A build worker's symbol of a stage that is not compiled in this process (bound to abort)."""
    restype = declared_return(disp)
    if restype is None:
        raise RuntimeError(f"femb engine: stage {disp.py_func.__qualname__} has no declared return "
                           f"type (femb.engine.link.declare); a build worker cannot type its calls")
    symbol = symbol_name(disp, argtypes)
    if symbol not in _SYMBOLS:
        ll.add_symbol(symbol, _WORKER["placeholder"])
        _SYMBOLS[symbol] = _WORKER["placeholder"]
        _OWNERS[symbol] = disp
    return symbol, restype


def symbol_name(disp, argtypes):
    """The symbol under which callers declare the stage ``disp`` compiled for ``argtypes`` (the same
    in every process)."""
    f = disp.py_func
    key = hashlib.sha1(repr(tuple(str(a) for a in argtypes)).encode()).hexdigest()[:16]
    return f"femb.stage.{f.__module__}.{f.__qualname__}.{key}"


def stage_symbol(disp, argtypes):
    """Compile (or load from the cache) the stage ``disp`` for ``argtypes`` and register the address
    of its native function under its symbol; returns (symbol, compile result)."""
    argtypes = tuple(argtypes)
    if argtypes not in disp.overloads:
        disp.compile(argtypes)
    cres = disp.overloads[argtypes]
    declared = declared_return(disp)
    if declared is not None and declared != cres.signature.return_type:
        raise RuntimeError(f"femb engine: stage {disp.py_func.__qualname__} returns "
                           f"{cres.signature.return_type}, declared {declared} (femb.engine.link.declare)")
    name = cres.fndesc.llvm_func_name
    symbol = symbol_name(disp, argtypes)
    if symbol not in _SYMBOLS:
        addr = cres.library.get_pointer_to_function(name)
        if not addr:
            raise RuntimeError(f"femb engine: no native code for stage {disp.py_func.__name__}")
        ll.add_symbol(symbol, addr)
        _SYMBOLS[symbol] = addr
        _OWNERS[symbol] = disp
    elif _OWNERS[symbol] is not disp:
        raise RuntimeError(f"femb engine: two stages share the symbol {symbol} (functions of the same "
                           f"module and qualified name)")
    return symbol, cres


def _register(module, name, argtypes):
    """The hook run before a caller is loaded from the cache: its stage's symbol (picklable:
    module and function by name, the argument types)."""
    stage_symbol(getattr(importlib.import_module(module), name), argtypes)


@intrinsic
def _call(typingctx, stage, *args):
    if not isinstance(stage, types.Dispatcher):
        return None
    disp = stage.dispatcher
    argtypes = tuple(types.unliteral(a) for a in args)
    if _WORKER["on"]:
        symbol, restype = _placeholder_symbol(disp, argtypes)
        want = argtypes
    else:
        symbol, cres = stage_symbol(disp, argtypes)
        restype, want = cres.signature.return_type, cres.signature.args
    hook = functools.partial(_register, disp.py_func.__module__, disp.py_func.__name__, argtypes)
    # numba hands the arguments after the stage to the code generation as one tuple
    sig = restype(stage, types.StarArgTuple.from_types(args))

    def codegen(context, builder, sig_, llargs):
        context.active_code_library._reload_init.add(hook)
        have = cgutils.unpack_tuple(builder, llargs[1], len(args))
        vals = [context.cast(builder, v, a, w) for v, a, w in zip(have, args, want)]
        fnty = context.call_conv.get_function_type(restype, want)
        fn = cgutils.get_or_insert_function(builder.module, fnty, symbol)
        status, res = context.call_conv.call_function(builder, fn, restype, want, vals)
        with cgutils.if_unlikely(builder, status.is_error):
            context.call_conv.return_status_propagate(builder, status)
        return res

    return sig, codegen


def _call_python(stage, *args):
    return stage(*args)


def _keep_hooks_of_cached_functions():
    """Patch numba's ``CompileResult._rebuild`` (a function loaded from the disk cache) so that the
    loaded library keeps its reload hooks, which numba passes on to the callers it is linked into
    (``CPUCodeLibrary.finalize``). Without it, a caller compiled in a process that loaded such a
    callee from the cache is cached without the hooks that bind its callee's stage symbols."""
    from numba.core import compiler
    cls = compiler.CompileResult
    orig = cls.__dict__["_rebuild"].__func__
    if getattr(orig, "_femb_keeps_hooks", False):
        return
    try:
        params = list(inspect.signature(orig).parameters)
        at = params.index("reload_init") - 1            # position among the arguments after cls
    except ValueError:                                   # another numba: leave it as it is
        return

    def _rebuild(klass, *args, **kw):
        cr = orig(klass, *args, **kw)
        hooks = kw.get("reload_init", args[at] if at < len(args) else None)
        if hooks:
            cr.library._reload_init.update(hooks)
        return cr

    _rebuild._femb_keeps_hooks = True
    cls._rebuild = classmethod(_rebuild)


if not jit_disabled():
    _keep_hooks_of_cached_functions()

#: ``call(stage, *args)``: the stage's result, the stage compiled once and called by symbol
call = _call_python if jit_disabled() else _call
