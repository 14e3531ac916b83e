"""Stage: build, in parallel: the engine's stages (and the contact loop's) compiled at once in
worker processes.

A caller of a stage called by symbol (:mod:`femb.engine.link`) needs only the stage's types to
compile, not its code: so each of the engine's compiled units (the entry points and the stages
called by symbol, :func:`femb.engine.build.stage_signatures`) can be compiled on its own, in any
order, in another process. :func:`compile_in_workers` splits the units that are not in the disk
cache yet between worker processes (longest first onto the least loaded worker, by the CPU seconds
each took to compile, :data:`COST`); each worker compiles its share into the cache and exits; the
calling process then loads the engine from the cache as any later run does. With two cores the
engine's compile takes about half the wall time of one process (docs/engine.md, "Compile time").
The contact time loop (:mod:`femb.contact.loop`, ``stage_signatures``) is compiled the same way.

The workers never run the code they compile (their stages' symbols are bound to ``abort``,
:func:`femb.engine.link.defer_stages`); only a process that loads it from the cache runs it, after
binding every stage it calls to that stage's code. Nothing is done in parallel without a writable
cache (the workers could not hand their code over) or with one core; a worker that fails leaves
its units to the calling process, which compiles them as before (one line on stderr says so).

``FEMB_BUILD_WORKERS`` sets the number of workers (default: the CPUs this process may use, at
most 4; 0 or 1 compiles in the calling process only).
"""
import os
import pickle
import subprocess
import sys
import tempfile
import time

#: seconds after which the workers that have not finished are stopped (their units are then
#: compiled by the calling process)
WORKER_TIMEOUT = 1800.0

#: CPU seconds that each of the engine's units took to compile on its own, each in a process of its
#: own (2-core test machine, numba 0.68; measured 2026-11-28): only their ratios matter, for the
#: split (other callers pass their own: femb.contact.loop.BUILD_COST)
COST = {"run": 9.8, "newton_step": 10.3, "evaluate": 8.3, "kernel_blocks": 2.0, "rates": 1.7,
        "dense_lu": 1.5, "kkt_solve": 1.5, "kkt_estimate": 1.3, "band_lu": 1.2, "resynchronise": 1.2,
        "refine_accelerations": 1.1, "jacobian_times": 1.0, "copy_B": 0.8, "dense_solve": 0.7,
        "band_solve": 0.6, "project_normal_velocity": 0.6, "velocity_residual": 0.4,
        "eval_time_functions": 0.4, "constraint_B": 0.4, "ggl_matrix": 0.4, "lie_reset": 0.2,
        "dense_lu_solve": 0.2}


def _short(name):
    return name.rsplit(":", 1)[-1].rsplit(".", 1)[-1]


def unit_name(disp):
    """The name by which a worker finds a compiled unit: ``<module>:<qualified name>``."""
    return f"{disp.py_func.__module__}:{disp.py_func.__qualname__}"


def workers_wanted():
    """The number of build workers: ``FEMB_BUILD_WORKERS`` or the CPUs this process may use (≤ 4)."""
    v = os.environ.get("FEMB_BUILD_WORKERS", "").strip()
    if v:
        try:
            return max(0, int(v))
        except ValueError:
            from femb.errors import ParameterError
            raise ParameterError(f"FEMB_BUILD_WORKERS must be a whole number, got {v!r}") from None
    try:
        n = len(os.sched_getaffinity(0))
    except AttributeError:                       # not on Linux
        n = os.cpu_count() or 1
    return min(n, 4)


def split(names, n, cost=None, together=()):
    """``n`` lists of unit names, longest first onto the least loaded list (by ``cost``, the
    function name's CPU seconds, default :data:`COST`; an unknown unit counts 1 s); the units of a
    group of ``together`` (tuples of function names that share most of their code) go to one list."""
    cost = COST if cost is None else cost
    short = {u: _short(u) for u in names}

    def _cost(u):
        return cost.get(short[u], 1.0)

    items, grouped = [], set()
    for group in together:
        members = [u for u in names if short[u] in group]
        if members:
            items.append(sorted(members, key=lambda u: group.index(short[u])))
            grouped.update(members)
    items += [[u] for u in names if u not in grouped]
    shares = [[] for _ in range(n)]
    load = [0.0] * n
    for item in sorted(items, key=lambda it: -sum(_cost(u) for u in it)):
        k = load.index(min(load))
        shares[k] += item
        load[k] += sum(_cost(u) for u in item)
    return [s for s in shares if s]


def compile_in_workers(units, verbose=True, cost=None, together=()):
    """Compile the units of ``units`` (``{dispatcher: argument types}``) that are not cached yet in
    worker processes, into the disk cache, split by :func:`split` (``cost``, ``together``). Returns
    the number of workers that ran (0: nothing was done in parallel; the caller compiles everything
    itself)."""
    from femb.base.jit import cache_writable, is_cached
    n = workers_wanted()
    todo = [unit_name(d) for d, sg in units.items() if not is_cached(d, sg)]
    if n < 2 or len(todo) < 2 or not cache_writable():
        return 0
    shares = split(todo, n, cost, together)
    import femb
    # the workers import this process's femb (a checkout on sys.path may shadow an installed one)
    root = os.path.dirname(os.path.dirname(os.path.abspath(femb.__file__)))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([root] + [p for p in (os.environ.get("PYTHONPATH"),) if p]))
    procs, path = [], None
    try:
        # the argument types, for the workers (numba types pickle, as numba's cache index stores them)
        fd, path = tempfile.mkstemp(prefix="femb-build-", suffix=".pkl")
        with os.fdopen(fd, "wb") as fh:
            pickle.dump({unit_name(d): tuple(sg) for d, sg in units.items()}, fh)
        cmd = [sys.executable, "-c", "import sys; from femb.engine.parallel import worker_main; "
                                     "sys.exit(worker_main(sys.argv[1:]))", path]
        for share in shares:
            procs.append(subprocess.Popen(cmd + share, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env))
    except OSError as err:                      # a full disk, no processes left: compile here
        for p in procs:
            p.kill()
            p.wait()
        if path is not None and os.path.exists(path):
            os.unlink(path)
        if verbose:
            print(f"femb: no build workers ({err}); this process compiles everything", file=sys.stderr,
                  flush=True)
        return 0
    deadline = time.monotonic() + WORKER_TIMEOUT
    try:
        for p in procs:
            try:
                err = p.communicate(timeout=max(1.0, deadline - time.monotonic()))[1]
                err = err.decode(errors="replace").strip()
            except subprocess.TimeoutExpired:
                p.kill()
                err = p.communicate()[1].decode(errors="replace").strip() + \
                    f"\nno result after {WORKER_TIMEOUT:.0f} s, stopped"
            if p.returncode != 0 and verbose:
                last = err.splitlines()[-1] if err else ""
                print(f"femb: an engine build worker failed (exit {p.returncode}: {last}); "
                      f"this process compiles what it left", file=sys.stderr, flush=True)
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
                p.wait()
        os.unlink(path)
    return len(procs)


def worker_main(argv):
    """A build worker: ``argv`` = [the file of the units' argument types, unit names ...]. Compiles
    the named units into the disk cache (their stage calls typed from the declarations,
    :func:`femb.engine.link.defer_stages`). Returns the exit status."""
    import importlib
    from femb.engine import link
    with open(argv[0], "rb") as fh:
        argtypes = pickle.load(fh)
    link.defer_stages()
    for name in argv[1:]:
        module, qualname = name.split(":")
        disp = importlib.import_module(module)
        for part in qualname.split("."):
            disp = getattr(disp, part)
        disp.compile(argtypes[name])
    return 0
