"""The engine's large stages are compiled once and called by symbol (femb/engine/link.py).

numba links a compiled callee's LLVM module into every caller and optimizes and code-generates it
again there; the stages called through ``femb.engine.link.call`` must not be: their code is defined
in their own library only, and the callers declare the stage's symbol (docs/engine.md, "Compile
time"). The trajectories through these calls are checked bit for bit by test_engine_reference.py.
"""
import numpy as np
import pytest

from femb.base.jit import jit_disabled

pytestmark = pytest.mark.skipif(jit_disabled(), reason="compiled code only")

#: stages called by symbol, by the name numba gives their functions
SEPARATE = ("newton_step", "kkt_estimate", "resynchronise", "refine_accelerations", "kkt_solve", "evaluate",
            "kernel_blocks", "velocity_residual", "dense_lu", "band_lu", "dense_solve", "band_solve")


def _functions(disp):
    """(defined, declared) function names over every compiled version of ``disp`` (small helpers
    such as ``copy_into`` are compiled for several argument types when the engine is compiled in
    this process; loaded from the cache, only the entry points and stages are)."""
    defined, declared = [], []
    for cres in disp.overloads.values():
        mod = cres.library._get_module_for_linking()
        defined += [f.name for f in mod.functions if not f.is_declaration]
        declared += [f.name for f in mod.functions if f.is_declaration]
    return defined, declared


def _stage(name):
    import sys
    for m in ("linalg", "evaluate", "newton", "control"):
        d = getattr(sys.modules[f"femb.engine.{m}"], name, None)
        if hasattr(d, "overloads"):
            return d
    raise LookupError(name)


def _named(names, stage):
    """The names among ``names`` of the native functions of ``stage`` (or their symbols)."""
    from femb.engine.link import symbol_name
    disp = _stage(stage)
    own = {c.fndesc.llvm_func_name for c in disp.overloads.values()}
    own |= {symbol_name(disp, sig) for sig in disp.overloads}
    return [n for n in names if n in own]


def test_run_defines_none_of_the_separate_stages_and_calls_them_by_symbol():
    from femb import engine
    engine.ensure_engine(verbose=False)
    defined, declared = _functions(engine.run)
    for stage in SEPARATE:
        assert not _named(defined, stage), f"{stage} is compiled into run again"
    for stage in ("newton_step", "kkt_estimate", "resynchronise"):
        (sym,) = _named(declared, stage)
        assert sym.startswith("femb.stage.")


def test_each_separate_stage_is_defined_in_one_library_of_the_engine():
    """Over all entry points and their stages, each stage's code is in its own library only."""
    import sys
    from femb import engine
    from femb.engine import link
    engine.ensure_engine(verbose=False)
    owners = {}
    mods = [sys.modules[f"femb.engine.{m}"] for m in ("linalg", "evaluate", "newton", "control", "loop")]
    disps = {id(d): d for m in mods for d in vars(m).values() if hasattr(d, "overloads") and d.overloads}
    for d in disps.values():
        defined, _ = _functions(d)
        for stage in SEPARATE:
            if _named(defined, stage):
                owners.setdefault(stage, []).append(d.py_func.__name__)
    for stage in SEPARATE:
        assert owners.get(stage) == [stage], (stage, owners.get(stage))
    # every symbol a caller declares is registered with the address of the stage's code
    assert all(addr != 0 for addr in link._SYMBOLS.values()) and len(link._SYMBOLS) >= len(SEPARATE)


def test_a_call_by_symbol_returns_what_the_stage_returns():
    """dense_lu_solve calls dense_lu and dense_solve by symbol: its solution and status are the
    stage's (a singular matrix reports 1)."""
    from femb import engine
    rng = np.random.default_rng(3)
    n = 7
    A = rng.normal(size=(n, n)) + n * np.eye(n)
    b = rng.normal(size=n)
    x = b.copy()
    piv = np.zeros(3 * n + 2 * n * n, dtype=np.int64)
    assert engine.dense_lu_solve(A.ravel().copy(), n, piv, 1e-13, x) == 0
    assert np.allclose(A @ x, b, rtol=1e-12, atol=1e-12)
    S = A.copy()
    S[:, 2] = S[:, 4]
    assert engine.dense_lu_solve(S.ravel().copy(), n, piv, 1e-13, b.copy()) == 1


STAGES_MODULE = '''
import numpy as np
from femb.base.jit import kernel
from femb.engine.link import call


@kernel
def stage(x, k):
    return k * x[0] + x[1]


@kernel
def middle(x, k):
    return call(stage, x, k) + 1.0


@kernel
def outer(x, k):
    return middle(x, k) * 2.0
'''


def test_a_caller_linking_a_cached_callee_keeps_its_stage_symbols(tmp_path):
    """Three processes on one cache: the first compiles ``middle`` (which calls ``stage`` by symbol), the
    second compiles ``outer``, which links ``middle`` loaded from the cache, the third loads ``outer``
    from the cache and runs it. The third needs the hook that binds ``stage``'s symbol in ``outer``'s
    cache entry, which numba does not hand on from a callee loaded from the cache
    (link._keep_hooks_of_cached_functions)."""
    import subprocess
    import sys
    (tmp_path / "pkg").mkdir()
    (tmp_path / "pkg" / "stages_mod.py").write_text(STAGES_MODULE)
    env = {k: v for k, v in __import__("os").environ.items() if k != "FEMB_DEBUG"}
    env["FEMB_CACHE_DIR"] = str(tmp_path / "cache")
    script = ("import sys, numpy as np; sys.path.insert(0, {folder!r}); import stages_mod as m; "
              "x = np.array([2.0, 3.0]); print(m.{fn}(x, 5.0))")
    for fn, want in (("middle", 14.0), ("outer", 28.0), ("outer", 28.0)):
        out = subprocess.run([sys.executable, "-c", script.format(folder=str(tmp_path / "pkg"), fn=fn)], env=env,
                             capture_output=True, text=True, timeout=300)
        assert out.returncode == 0, out.stderr[-2000:]
        assert float(out.stdout.split()[-1]) == want
