"""``femb cache``: build, show and clear femb's compile cache (:mod:`femb.solve.cache`)."""
from __future__ import annotations

import sys


def _size(n):
    for unit in ("B", "kB", "MB", "GB"):
        if n < 1024 or unit == "GB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024.0


def _build_contact_loop():
    """Compile (or load) the time loop of :func:`femb.contact.simulate`: one step of the bouncing
    ball. The loop has one signature for every contact model (the element kernels are called through
    their addresses), so that afterwards no contact scene compiles it. Then one step of 25 spheres on the
    floor, which compiles the helpers of the sparse path (models above 600 unknowns)."""
    import time
    from femb.benchmarks.scenes.contact import contact_ball, contact_spheres
    from femb.contact import simulate
    t0 = time.perf_counter()
    simulate(contact_ball.build().compile(), 2e-3, 2e-3)
    simulate(contact_spheres.build(n=25).compile(), 1e-3, 1e-3)
    print(f"femb cache build: the contact time loop {time.perf_counter() - t0:.1f} s", file=sys.stderr, flush=True)


def cmd_cache(args):
    from femb.solve import cache
    what = args.cache_command
    if what == "build":
        cache.build(progress=True)
        _build_contact_loop()
        return 0
    if what == "info":
        d = cache.info()
        print(f"cache: {d['path']}")
        print(f"size:  {_size(d['bytes'])}")
        eng = [e for e in d["entries"] if e[0].startswith("engine.")]
        print(f"engine: {'compiled' if eng else 'not compiled yet'}")
        print("entries (module-source key: files, size, compiled functions):")
        for name, files, size, funcs in d["entries"]:
            shown = ", ".join(funcs[:6]) + (f", … ({len(funcs)} in all)" if len(funcs) > 6 else "")
            print(f"  {name:<40s} {files:4d} files {_size(size):>9s}  {shown}")
        print("(entries of older sources stay until 'femb cache clear'; each holds the code of one "
              "version of a module's files)")
        return 0
    if what == "clear":
        freed = cache.clear()
        print(f"cleared {_size(freed)} from {cache.info()['path']}")
        return 0
    args.cache_parser.print_help(sys.stderr)
    return 2


def add_parser(sub, parser_class=None):
    kw = {"parser_class": parser_class} if parser_class else {}
    cp = sub.add_parser("cache", help="build, show or clear the compile cache",
                        description="femb compiles its engine once per installation and the kernels of "
                        "each element type once, and keeps them in a cache directory ($FEMB_CACHE_DIR, "
                        "default ~/.cache/femb). 'build' compiles the engine, every built-in element "
                        "type and the contact time loop ahead of time (for a Docker image, a cluster node or CI); 'info' shows where "
                        "the cache is and what it holds; 'clear' deletes it.")
    csub = cp.add_subparsers(dest="cache_command", metavar="CACHE_COMMAND", **kw)
    csub.add_parser("build", help="compile the engine, every built-in kernel and the contact loop now")
    csub.add_parser("info", help="where the cache is, its size and entries")
    csub.add_parser("clear", help="delete the cache")
    cp.set_defaults(func=cmd_cache, cache_parser=cp)
