"""The engine compiled in parallel worker processes (femb/engine/parallel.py).

A worker compiles a caller from its stages' declared types (femb.engine.link.declare) without
their code; these tests check the declarations against the compiled stages, that an engine
built by workers gives the same trajectory as the one this test session runs, and what happens
when a worker fails or nothing can be done in parallel.
"""
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from femb.base.jit import jit_disabled
from femb.errors import ParameterError

pytestmark = pytest.mark.skipif(jit_disabled(), reason="compiled code only")


def test_every_stage_called_by_symbol_is_in_the_table_with_its_declared_types():
    from femb import engine
    from femb.engine import link
    from femb.engine.build import stage_signatures
    engine.ensure_engine(verbose=False)
    table = {**stage_signatures(), **engine.engine_signatures()}
    owners = {d for s, d in link._OWNERS.items() if s.startswith("femb.stage.femb.engine.")}
    assert owners, "no stage of the engine was registered"
    for disp in owners:
        assert disp in table, f"{disp.py_func.__qualname__} is called by symbol but not in the build table"
        assert list(disp.overloads) == [tuple(table[disp])], disp.py_func.__qualname__
        cres = disp.overloads[tuple(table[disp])]
        assert link.declared_return(disp) == cres.signature.return_type, disp.py_func.__qualname__
        assert tuple(cres.signature.args) == tuple(table[disp]), disp.py_func.__qualname__


def test_a_wrong_declaration_is_an_error_of_the_engine():
    from femb.engine import link
    from femb.engine.build import stage_signatures
    from femb.engine.linalg import dense_solve
    from numba import types as T
    sg = stage_signatures()[dense_solve]
    link.stage_symbol(dense_solve, sg)
    keep = link.declared_return(dense_solve)
    try:
        link.declare(dense_solve, T.float64)
        with pytest.raises(RuntimeError, match="dense_solve returns none, declared float64"):
            link.stage_symbol(dense_solve, sg)
    finally:
        link.declare(dense_solve, keep)


def test_split_puts_the_longest_first_onto_the_least_loaded_worker():
    from femb.engine.parallel import split
    names = [f"m:{n}" for n in ("run", "newton_step", "evaluate", "rates", "band_lu", "lie_reset")]
    shares = split(names, 2)
    assert shares[0][0] == "m:newton_step" and shares[1][0] == "m:run"
    assert sorted(sum(shares, [])) == sorted(names)
    assert split(names[:1], 4) == [["m:run"]]
    # the contact loop's Newton iteration and its evaluation share their code: one worker
    from femb.contact.loop import BUILD_COST, BUILD_TOGETHER
    contact = [f"c:{n}" for n in ("_evaluate_at", "_impact_time", "_solve", "newton_loop", "store")]
    a, b = split(contact, 2, BUILD_COST, BUILD_TOGETHER)
    assert a[:2] == ["c:newton_loop", "c:_evaluate_at"] and "c:_impact_time" in b


def test_the_number_of_workers_is_read_from_the_environment(monkeypatch):
    from femb.engine.parallel import workers_wanted
    monkeypatch.setenv("FEMB_BUILD_WORKERS", "3")
    assert workers_wanted() == 3
    monkeypatch.setenv("FEMB_BUILD_WORKERS", "two")
    with pytest.raises(ParameterError, match="FEMB_BUILD_WORKERS must be a whole number, got 'two'"):
        workers_wanted()


class _Missing:
    """A unit that no worker can find: a dispatcher's face (its function's module and name, no
    overloads, no cache) naming a function that does not exist."""

    def __init__(self, name):
        self.py_func = type("F", (), {"__module__": "femb.engine.loop", "__qualname__": name})
        self.overloads = {}
        self._cache = None


def test_a_failing_worker_is_reported_and_leaves_its_units_to_the_caller(monkeypatch, capsys):
    from numba import types as T
    from femb.engine import parallel
    monkeypatch.setenv("FEMB_BUILD_WORKERS", "2")
    monkeypatch.setattr("femb.base.jit.cache_writable", lambda: True)
    # each worker exits with an error, none hangs, and nothing is left behind
    ran = parallel.compile_in_workers({_Missing("no_such_stage_a"): (T.float64,),
                                       _Missing("no_such_stage_b"): (T.float64,)})
    assert ran == 2
    err = capsys.readouterr().err
    assert err.count("femb: an engine build worker failed (exit 1: AttributeError") == 2, err
    assert "this process compiles what it left" in err


def test_nothing_in_parallel_with_one_worker_or_a_read_only_cache(monkeypatch):
    from numba import types as T
    from femb.engine import parallel
    units = {_Missing("a"): (T.float64,), _Missing("b"): (T.float64,)}
    monkeypatch.setenv("FEMB_BUILD_WORKERS", "1")
    assert parallel.compile_in_workers(units) == 0
    monkeypatch.setenv("FEMB_BUILD_WORKERS", "2")
    monkeypatch.setattr("femb.base.jit.cache_writable", lambda: False)
    assert parallel.compile_in_workers(units) == 0


def test_an_engine_built_by_workers_runs_the_same_trajectory(tmp_path):
    """A fresh cache filled by two workers; a second process loads it and runs 200 steps of a
    planar scene; the coordinates equal those of this process bit for bit."""
    import femb
    from femb.benchmarks.scenes.planar import andrews
    res = femb.simulate(andrews.build().compile(), t_end=200 * 3e-5, h=3e-5)
    ref = np.asarray(res.q)
    script = textwrap.dedent("""
        import sys, numpy as np, femb
        from femb.benchmarks.scenes.planar import andrews
        res = femb.simulate(andrews.build().compile(), t_end=200 * 3e-5, h=3e-5)
        np.save(sys.argv[1], np.asarray(res.q))
    """)
    env = dict(os.environ, FEMB_CACHE_DIR=str(tmp_path / "cache"), FEMB_BACKGROUND_BUILD="0",
               FEMB_BUILD_WORKERS="2")
    out = tmp_path / "q.npy"
    p = subprocess.run([sys.executable, "-c", script, str(out)], env=env, capture_output=True, text=True,
                       timeout=900)
    assert p.returncode == 0, p.stderr[-2000:]
    assert "femb: compiling the engine" in p.stderr and "worker failed" not in p.stderr
    np.testing.assert_array_equal(np.load(out), ref)
    # the entries and stages are all in the cache: a third process compiles nothing
    p = subprocess.run([sys.executable, "-c", script, str(out)], env=env, capture_output=True, text=True,
                       timeout=300)
    assert p.returncode == 0 and "compiling the engine" not in p.stderr, p.stderr[-2000:]
    np.testing.assert_array_equal(np.load(out), ref)


def test_a_worker_that_does_not_finish_is_stopped(monkeypatch, capsys):
    from numba import types as T
    from femb.engine import parallel
    monkeypatch.setenv("FEMB_BUILD_WORKERS", "2")
    monkeypatch.setattr("femb.base.jit.cache_writable", lambda: True)
    monkeypatch.setattr(parallel, "WORKER_TIMEOUT", 2.0)
    # workers that never end: their file of argument types is a named pipe that nobody writes
    real = parallel.tempfile.mkstemp

    def pipe_file(*a, **k):
        fd, path = real(*a, **k)
        os.close(fd)
        os.unlink(path)
        os.mkfifo(path)
        return os.open(path, os.O_RDWR), path

    monkeypatch.setattr(parallel.tempfile, "mkstemp", pipe_file)
    monkeypatch.setattr(parallel.pickle, "dump", lambda obj, fh: None)
    ran = parallel.compile_in_workers({_Missing("a"): (T.float64,), _Missing("b"): (T.float64,)})
    assert ran == 2
    err = capsys.readouterr().err
    assert err.count("femb: an engine build worker failed") == 2 and "no result after 2 s, stopped" in err, err


def test_no_room_for_the_workers_file_compiles_here(monkeypatch, capsys):
    from numba import types as T
    from femb.engine import parallel
    monkeypatch.setenv("FEMB_BUILD_WORKERS", "2")
    monkeypatch.setattr("femb.base.jit.cache_writable", lambda: True)

    def full(*a, **k):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(parallel.tempfile, "mkstemp", full)
    assert parallel.compile_in_workers({_Missing("a"): (T.float64,), _Missing("b"): (T.float64,)}) == 0
    assert "femb: no build workers ([Errno 28] No space left on device); this process compiles everything" \
        in capsys.readouterr().err
