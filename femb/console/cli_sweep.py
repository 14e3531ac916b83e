"""``femb sweep``: parameter studies of a scene on a Dask cluster (see :mod:`femb.study.sweep`).

::

    femb sweep SCENE --grid k=1e3,1e4,1e5 --grid rho_inf=0.5,0.9 --out results.parquet
    femb sweep SCENE --range k=1e3:1e5:log --range m4=0.5:1 --samples 200 --seed 1 --out s.parquet
    femb sweep SCENE ... [--scheduler tcp://HOST:8786 | --workers N] [--resume] [--plot FILE]

Grid values are ``V1,V2,...`` (numbers, True/False, or words), ``LO:HI:N``
(N values evenly spaced) or ``LO:HI:N:log`` (geometric). Sample ranges are
``LO:HI`` (uniform) or ``LO:HI:log`` (log-uniform); ``--samples N`` draws N
Latin-hypercube points (``--sampling random``: independent uniform draws)
with ``--seed S`` (default 0). Grids and samples combine as a product. A
parameter is a keyword of the scene's ``build()`` or a run setting
(``t_end``, ``h``, ``rtol``, ``atol``, ``rho_inf``).

``--out`` is a directory of Parquet chunks written while the sweep runs
(``pandas.read_parquet(DIR)`` reads it); after Ctrl-C, ``--resume`` runs only
the cases missing from it. Exit status: 0 when the sweep ran (failed cases are
rows of the table, counted in the summary), 2 for bad arguments, 130 on Ctrl-C.
"""
from __future__ import annotations

import sys
import time

from femb.console.cli_common import SCENE_HELP, UsageError, _count, _load_scene, _positive, _rho, parse_sets
from femb.errors import ParameterError


def _usage(msg):
    return UsageError(msg)


def add_parser(sub):
    """Register ``femb sweep`` on the sub-parsers ``sub`` of :func:`femb.console.cli.build_parser`."""
    sp = sub.add_parser("sweep", help="parameter study of a scene on a Dask cluster (grids, samples)",
                        description="Run a scene for every case of a full-factorial grid and/or "
                        "Latin-hypercube samples on a local Dask cluster or a running Dask scheduler. "
                        "Rows (parameters, outputs at t_end, steps, Newton iterations, wall time, "
                        "status) stream to a Parquet directory; failed cases are rows, not crashes.",
                        epilog="Example: femb sweep slider_crank --grid k=1e3,1e4,1e5 "
                        "--grid rho_inf=0.5,0.9 --out results.parquet --plot results.png")
    sp.add_argument("scene", metavar="SCENE", help=SCENE_HELP)
    sp.add_argument("--grid", action="append", default=[], metavar="NAME=VALUES",
                    help="grid values V1,V2,... or LO:HI:N[:log] (repeatable: full factorial)")
    sp.add_argument("--range", action="append", default=[], metavar="NAME=LO:HI[:log]",
                    help="sampling range of a parameter (repeatable; with --samples)")
    sp.add_argument("--samples", type=_count, metavar="N", help="number of samples drawn in the --range box")
    sp.add_argument("--seed", type=int, default=0, metavar="S", help="seed of the samples (default 0)")
    sp.add_argument("--sampling", choices=("lhs", "random"), default="lhs",
                    help="Latin hypercube (default) or independent uniform samples")
    sp.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                    help="fixed keyword of the scene's build() for every case (repeatable)")
    sp.add_argument("--t-end", type=_positive("t_end"), metavar="T", help="final time (default: the scene's)")
    sp.add_argument("--h", type=_positive("h"), metavar="H", help="step size (default: the scene's)")
    sp.add_argument("--rtol", type=_positive("rtol"), metavar="R", help="relative tolerance, passed to femb.simulate")
    sp.add_argument("--atol", type=_positive("atol"), metavar="A", help="absolute tolerance, passed to femb.simulate")
    sp.add_argument("--rho-inf", type=_rho, metavar="R", help="spectral radius at infinity (default: the scene's)")
    sp.add_argument("--outputs", metavar="NAMES", help="comma-separated output names (default: all of the scene's)")
    sp.add_argument("--t-eval", type=float, nargs="+", metavar="T", help="also record the outputs at these times")
    where = sp.add_mutually_exclusive_group()
    where.add_argument("--scheduler", metavar="ADDRESS",
                       help="address of a running Dask scheduler (tcp://HOST:8786); default: a local cluster")
    where.add_argument("--workers", type=_count, metavar="N",
                       help="worker processes of the local cluster (default: one per core)")
    sp.add_argument("--batch-size", type=_count, metavar="N", help="cases per Dask task (default: automatic)")
    sp.add_argument("--out", required=True, metavar="DIR",
                    help="output directory of Parquet chunks (e.g. results.parquet)")
    sp.add_argument("--resume", action="store_true", help="skip the cases already in --out")
    sp.add_argument("--trajectories", metavar="DIR", help="per-case trajectory files (.npz), written by the workers")
    sp.add_argument("--plot", metavar="FILE", help="one-page PNG: outputs against the parameter, or heat maps")
    sp.add_argument("--progress", choices=("on", "off"), default="on", help="progress bar over cases on stderr")
    sp.set_defaults(func=cmd_sweep)
    return sp


def _specs(args):
    from femb.study.sweep import parse_grid_spec, parse_range_spec

    grid, ranges = {}, {}
    for text in args.grid:
        name, values = parse_grid_spec(text)
        if name in grid:
            raise ParameterError(f"--grid {name} given twice")
        grid[name] = values
    for text in args.range:
        name, spec = parse_range_spec(text)
        if name in ranges:
            raise ParameterError(f"--range {name} given twice")
        ranges[name] = spec
    if ranges and args.samples is None:
        raise ParameterError("--range needs --samples N")
    if args.samples is not None and not ranges:
        raise ParameterError("--samples needs at least one --range NAME=LO:HI")
    if not grid and not ranges:
        raise ParameterError("give at least one --grid NAME=VALUES or --range NAME=LO:HI with --samples N")
    return grid, ranges


def cmd_sweep(args):
    """femb sweep: run the design, stream the rows to --out, print a summary, plot."""
    import importlib.util

    missing = [m for m in ("distributed", "pandas", "pyarrow") if importlib.util.find_spec(m) is None]
    if missing:
        raise _usage(f"femb sweep needs Dask distributed, pandas and pyarrow ({', '.join(missing)} "
                     "missing): pip install 'femb[sweep]'")
    from femb.study.sweep import plot_results, sweep

    scene = _load_scene(args.scene)
    fixed = parse_sets(args.set)
    try:
        grid, ranges = _specs(args)
        outputs = [s.strip() for s in args.outputs.split(",") if s.strip()] if args.outputs else None
        if args.outputs is not None and not outputs:
            raise ParameterError(f"--outputs: no names in {args.outputs!r}")
    except ParameterError as exc:
        raise _usage(str(exc)) from None
    t0 = time.perf_counter()
    try:
        df = sweep(scene, grid=grid or None, samples=args.samples, ranges=ranges or None,
                   sampling=args.sampling, seed=args.seed if args.samples else None, params=fixed,
                   t_end=args.t_end, h=args.h, rtol=args.rtol, atol=args.atol, rho_inf=args.rho_inf,
                   outputs=outputs, t_eval=args.t_eval, client=args.scheduler, n_workers=args.workers,
                   batch_size=args.batch_size, out=args.out, resume=args.resume,
                   trajectories=args.trajectories, progress=args.progress == "on")
    except ParameterError as exc:
        raise _usage(str(exc)) from None
    except KeyboardInterrupt:
        print(f"femb sweep: interrupted; the finished cases are in {args.out} "
              "(run again with --resume to do the rest)", file=sys.stderr)
        raise
    total = time.perf_counter() - t0
    counts = df["status"].value_counts().to_dict() if len(df) else {}
    n_new = df.attrs.get("n_new", len(df))
    parts = ", ".join(f"{counts.get(k, 0)} {k}" for k in ("success", "failed", "error") if counts.get(k))
    print(f"{scene.name}: {len(df)} cases ({n_new} run now, {len(df) - n_new} resumed): "
          f"{parts or 'none'}; {total:.1f} s in all")
    bad = df[df["status"] != "success"] if len(df) else df
    for _, row in bad.head(3).iterrows():
        params = ", ".join(f"{p}={row[p]!r}" for p in df.attrs.get("parameters", []))
        print(f"  case {row['case']} ({params}): {row['error']}: {row['message']}")
    if len(bad) > 3:
        print(f"  ... and {len(bad) - 3} more failed cases (column 'message')")
    print(f"wrote {args.out}")
    if args.plot:
        try:
            path = plot_results(df, args.plot, title=f"femb sweep {scene.name}: {len(df)} cases"
                                + (f", {len(bad)} failed" if len(bad) else ""))
        except ParameterError as exc:
            raise _usage(f"--plot: {exc}") from None
        print(f"wrote {path}")
    return 0
