"""femb's compile cache: build it ahead of time, show it, clear it.

femb compiles two things, once each, and keeps the machine code on disk
(:func:`femb.base.jit.cache_dir`, ``$FEMB_CACHE_DIR``; default the user's cache directory from
``platformdirs``, ``~/.cache/femb`` on Linux):

* the **engine** (:mod:`femb.engine`: Newton iteration, LU, error estimate,
  consistent start, time loop, gather/scatter of the element batches), shared by
  every model;
* the **kernels of each element type** (:func:`femb.system.kernels.compiled_kernel`),
  built-in or the user's own, each for its role's one signature.

Entries live in ``<cache>/numba/<module>-<key>``; the key hashes the source files
the code depends on and the numba, llvmlite, numpy and Python versions, and each
entry records the CPU it was compiled for (numba's index), so one cache on a
shared file system serves machines with different CPUs (each compiles its own
entries once; ``NUMBA_CPU_NAME=generic`` makes the entries portable instead).
"""
from __future__ import annotations

import importlib
import inspect
import pkgutil
import shutil
import time
from pathlib import Path

from femb.base.jit import cache_dir


#: the kernel roles ``femb cache build`` compiles: the engine's, the velocity-constraint role
#: (called by the engine) and the contact role (called by :mod:`femb.contact`)
BUILT_ROLES = ("mass", "force", "constraint", "rates", "energy", "velocity_constraint", "contact")


def builtin_element_types():
    """Every element type of :mod:`femb.elements` that has compiled kernels, sorted by name."""
    import femb.elements as pkg
    seen = {}
    for info in pkgutil.iter_modules(pkg.__path__):
        mod = importlib.import_module(f"{pkg.__name__}.{info.name}")
        for _, cls in inspect.getmembers(mod, inspect.isclass):
            ks = getattr(cls, "kernels", None)
            if isinstance(ks, dict) and ks and cls.__module__.startswith(pkg.__name__):
                seen[f"{cls.__module__}.{cls.__qualname__}"] = cls
    return [seen[k] for k in sorted(seen)]


def _kernels_to_build():
    """(element type, role, kernel) of every built-in kernel, in a fixed order."""
    return [(cls, role, fn) for cls in builtin_element_types()
            for role, fn in cls.kernels.items() if role in BUILT_ROLES]


def _start_kernel_helpers():
    """Helper processes that compile shares of :func:`_kernels_to_build` into the cache at once with
    this process (``python -m femb.solve.cache --share k n``: every n-th kernel from the k-th), as
    many as the engine's build workers (:func:`femb.engine.parallel.workers_wanted`) less this one;
    none without a writable cache. Returns (the processes, n): this process's share is every n-th
    kernel from the first."""
    import os
    import subprocess
    import sys

    import femb
    from femb.base.jit import cache_writable, jit_disabled
    from femb.engine.parallel import workers_wanted
    n = workers_wanted()
    if n < 2 or jit_disabled() or not cache_writable():
        return [], 1
    root = os.path.dirname(os.path.dirname(os.path.abspath(femb.__file__)))
    env = dict(os.environ, FEMB_BACKGROUND_BUILD="0",
               PYTHONPATH=os.pathsep.join([root] + [p for p in (os.environ.get("PYTHONPATH"),) if p]))
    procs = []
    for k in range(1, n):
        try:
            procs.append(subprocess.Popen([sys.executable, "-m", "femb.solve.cache", "--share", str(k), str(n)],
                                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                          stdin=subprocess.DEVNULL, env=env))
        except OSError:                          # no processes left: this one compiles the rest
            break
    return procs, n


def _compile_share(k, n):
    """Compile every n-th built-in kernel from the k-th (a helper of :func:`build`)."""
    from femb.system import kernels
    for cls, role, fn in _kernels_to_build()[k::n]:
        kernels.compiled_kernel(cls.__name__, role, fn)


def build(progress=True, stream=None):
    """Compile the engine and the kernels of every built-in element type (or load them).

    For a Docker image, a cluster node or CI: afterwards no built-in mechanism compiles.

    Returns
    -------
    dict
        ``{"engine_s": float, "kernels": int, "kernels_s": float, "total_s": float}``.
    """
    import sys

    from femb.engine import ensure_engine
    from femb.io.progress import progress as bar
    from femb.system import kernels
    out = sys.stderr if stream is None else stream
    t0 = time.perf_counter()
    ensure_engine(verbose=progress)
    t1 = time.perf_counter()
    todo = _kernels_to_build()
    helpers, stride = _start_kernel_helpers()
    share = todo[::stride]                      # helper k of them compiles todo[k::stride]
    n = 0
    pb = bar(len(todo), desc="femb cache build: kernels", enabled=progress)
    for cls, role, fn in share:                 # this process's share, then the helpers' from the cache
        kernels.compiled_kernel(cls.__name__, role, fn)
        n += 1
        pb.update(1)
    for p in helpers:
        err = p.communicate()[1].decode(errors="replace").strip()
        if p.returncode != 0 and progress:
            print(f"femb cache build: a helper process failed (exit {p.returncode}: "
                  f"{err.splitlines()[-1] if err else ''}); this process compiles what it left", file=out, flush=True)
    for cls, role, fn in (t for i, t in enumerate(todo) if i % stride):
        kernels.compiled_kernel(cls.__name__, role, fn)
        n += 1
        pb.update(1)
    pb.close()
    kernels._fresh.clear()
    t2 = time.perf_counter()
    if progress:
        from femb.base.jit import cache_writable
        where = f"in {cache_dir()}" if cache_writable() else f"in memory only ({cache_dir()} is not writable)"
        print(f"femb cache build: engine {t1 - t0:.1f} s, {n} kernels {t2 - t1:.1f} s, {where}",
              file=out, flush=True)
    return {"engine_s": t1 - t0, "kernels": n, "kernels_s": t2 - t1, "total_s": t2 - t0}


def start_background_build(verbose=True):
    """After a fresh compilation of the engine: compile the kernels of every built-in element
    type in a background process (lower priority), so that the next mechanism, whatever its
    element types, starts without compiling.

    Once per installation (it follows the engine's first compilation). A process that needs a
    kernel the background build is compiling waits for it (a lock per kernel) and loads it.
    ``FEMB_BACKGROUND_BUILD=0`` turns it off (femb's test suite does); ``femb cache build``
    does the same in the foreground.

    Returns
    -------
    subprocess.Popen or None
    """
    import os
    import subprocess
    import sys

    from femb.base.jit import jit_disabled, numba_cache_dir
    if os.environ.get("FEMB_BACKGROUND_BUILD", "1") in ("0", "", "no", "off") or jit_disabled():
        return None
    root = numba_cache_dir()
    if root is None or not os.access(root, os.W_OK):
        return None
    log = root / "background-build.log"
    try:
        with open(log, "w") as fh:
            proc = subprocess.Popen([sys.executable, "-m", "femb.solve.cache", "--background"], stdout=fh, stderr=fh,
                                    stdin=subprocess.DEVNULL, start_new_session=True,
                                    env=dict(os.environ, FEMB_BACKGROUND_BUILD="0"))
    except OSError:
        return None
    if verbose:
        print(f"femb: compiling the kernels of the other built-in element types in the background "
              f"(pid {proc.pid}, log {log}); 'femb cache build' does it in the foreground",
              file=sys.stderr, flush=True)
    return proc


def info():
    """Where the cache is, its size and what is in it.

    Returns
    -------
    dict
        ``{"path": str, "bytes": int, "entries": [(name, files, bytes, functions), ...]}``: one
        entry per compiled module and source key (``engine.<stage>-<key>`` are the engine's), with the names
        of the functions compiled there.
    """
    root = cache_dir()
    entries = []
    total = 0
    base = root / "numba"
    if base.is_dir():
        for d in sorted(p for p in base.iterdir() if p.is_dir()):
            files = [f for f in d.rglob("*") if f.is_file()]
            size = sum(f.stat().st_size for f in files)
            total += size
            # one index file per compiled function: "<module>.<function>-<line>.pyXY.nbi"
            funcs = sorted({f.name.split("-")[0].split(".", 1)[-1] for f in files if f.suffix == ".nbi"})
            entries.append((d.name, len(files), size, funcs))
    for f in root.rglob("*"):
        if f.is_file() and base not in f.parents:
            total += f.stat().st_size
    return {"path": str(root), "bytes": total, "entries": entries}


def clear():
    """Delete everything in the cache directory; returns the number of bytes freed."""
    root = cache_dir()
    if not Path(root).is_dir():
        return 0
    size = info()["bytes"]
    for p in list(Path(root).iterdir()):
        if p.is_dir():
            shutil.rmtree(p, ignore_errors=True)
        else:
            try:
                p.unlink()
            except OSError:
                pass
    return size


if __name__ == "__main__":       # the background build (start_background_build), or a helper of build
    import os
    import sys
    if "--share" in sys.argv:
        i = sys.argv.index("--share")
        _compile_share(int(sys.argv[i + 1]), int(sys.argv[i + 2]))
        sys.exit(0)
    if "--background" in sys.argv:
        try:
            os.nice(10)
        except OSError:
            pass
    build(progress=True, stream=sys.stdout)
