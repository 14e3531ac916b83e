"""The ``femb`` command line.

Subcommands (one function each, ``cmd_*``)::

    femb list [SCENE]                           scenes: parameters (meaning, unit), settings, outputs
    femb run SCENE [options]                    run one scene, print/write its outputs at t_end
    femb bench convergence SCENE [options]      h-convergence study (seed Figs. 3, 9)
    femb bench figures SCENE --out DIR          the seed's figures as PNG files
    femb sweep SCENE --grid NAME=VALUES ...     parameter study on Dask (femb.console.cli_sweep)

``SCENE`` is a built-in scene name (``femb list``) or a path to a Python file
that defines ``build()`` (see :mod:`femb.study.registry` for the scene
protocol). ``femb bench`` without a subcommand is reserved for the benchmark
suite; for now it prints its help and exits with status 2.

Exit status: 0 on success, 1 when a simulation fails (Newton does not
converge, singular matrix), 2 for bad arguments (one line on stderr).

JSON written by ``femb run --json FILE``::

    {"scene", "t_end", "h", "rho_inf", "scaling", "steps", "newton_iterations",
     "wall_time_s", "outputs": {name: value at t_end}, ...}

and by ``femb bench convergence --json FILE``: the dict returned by
:func:`femb.benchmarks.accuracy.convergence.convergence_study` (keys ``scene``,
``rho_inf``, ``h``, ``error_q``, ``error_lambda``, ``order_q``,
``order_lambda``, ``reference``, ...).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import textwrap
import time
import warnings
from pathlib import Path

from femb.console.cli_common import (
    SCENE_HELP, UsageError, _count, _load_scene, _positive, _rho, parse_sets, parse_value)
from femb.errors import FembError, ParameterWarning, SolverError
from femb.solve.options import ATOL_PER_RTOL

PROG = "femb"

#: (module, function) called by ``femb run --vtk DIR --every N``; see :func:`_vtk_stream`.
VTK_HOOK = ("femb.io", "write_vtk_stream")


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors (``femb run: error: ...``) and exit status 2."""

    def error(self, message):
        raise UsageError(f"{message} (see '{self.prog} --help')")


# --------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------
def _view(text):
    from femb.errors import OutputError
    from femb.io.mechanism import parse_view

    try:
        parse_view(text)
    except OutputError as exc:
        raise argparse.ArgumentTypeError(str(exc).replace("view=", "")) from None
    return text.strip().lower()


def _trace(text):
    body, _, point = text.partition(":")
    if not body.strip() or (":" in text and not point.strip()):
        raise argparse.ArgumentTypeError(f"expected BODY or BODY:POINT, got {text!r}")
    return text.strip()


def _json_value(v):
    try:
        f = float(v)
    except (TypeError, ValueError):
        return v
    return f if math.isfinite(f) else None


def _provenance(scene, params, settings):
    """What a ``--json`` record needs to be reproduced and read: femb's version, the solver settings,
    every parameter (defaults too) with value and unit, and the units of the outputs."""
    from femb import __version__
    from femb.study.parsing import parameter_record, plain

    return {"femb_version": __version__, "settings": plain(dict(settings)),
            "params": parameter_record(scene.parameter_info(), params),
            "output_units": {k: u for k, (_, u) in scene.output_info().items()}}


def _solve_settings(scene, params):
    """Settings of a static or buckling scene's ``solve``: its keyword defaults, then what --set gave it."""
    import inspect

    try:
        sig = inspect.signature(scene.module.solve)
    except (TypeError, ValueError):
        sig = None
    out = {} if sig is None else {k: p.default for k, p in sig.parameters.items()
                                  if p.default is not inspect.Parameter.empty}
    out.update({k: v for k, v in params.items() if k in out or k not in scene.parameters()})
    return out


def _write_json(data, dest):
    text = json.dumps(data, indent=2) + "\n"
    if dest == "-":
        sys.stdout.write(text)
        return
    try:
        Path(dest).parent.mkdir(parents=True, exist_ok=True)
        Path(dest).write_text(text)
    except OSError as exc:
        raise UsageError(f"cannot write {dest}: {exc}") from None


def _check_json_dest(dest):
    """Fail at once, before any run, if ``--json FILE`` cannot be written there."""
    if not dest or dest == "-":
        return
    import os

    p = Path(dest)
    if p.is_dir():
        raise UsageError(f"--json {dest}: is a folder; give a file name")
    probe = p.parent / f".femb-write-test.{os.getpid()}"
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
        with open(probe, "wb"):
            pass
        probe.unlink()
    except OSError as exc:
        raise UsageError(f"--json {dest}: cannot write there ({exc.strerror or exc}); nothing was run") from None


def _vtk_stream(model, directory, every, observer=None, dt=None):
    """VTK output of ``femb run --vtk DIR --every N``.

    Calls ``femb.io.write_vtk_stream(model, directory, every=every,
    observer=observer)``, a context manager whose ``__enter__`` gives an
    observer ``callable(state, step)`` for :func:`femb.simulate` that writes
    frames while the run goes and then calls ``observer``. Should the hook be
    missing, ``--vtk`` fails with a one-line error (exit status 2).
    """
    import importlib

    module_name, func_name = VTK_HOOK
    hook = getattr(importlib.import_module(module_name), func_name, None)
    if hook is None:
        raise UsageError(f"--vtk: VTK streaming is not available in this version of femb "
                         f"({module_name}.{func_name} is missing)")
    try:
        return hook(model, directory, every=every, observer=observer, **({"dt": dt} if dt is not None else {}))
    except Exception as exc:   # output layer: bad directory, permissions, ...
        raise UsageError(f"--vtk {directory}: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}") from None


class _OutputFailure(Exception):
    """Writing output during a run failed: one line, exit status 1."""


class _NullContext:
    def __init__(self, value):
        self.value = value

    def __enter__(self):
        return self.value

    def __exit__(self, *exc):
        return False


# --------------------------------------------------------------------------
# subcommands
# --------------------------------------------------------------------------
def _fmt_default(v):
    import inspect

    return "(required)" if v is inspect.Parameter.empty else repr(v)


def _unit(u):
    return f"[{u}]" if u else ""


def _print_parameters(scene, indent):
    rows = [(f"{k}={_fmt_default(d)}", _unit(u), m) for k, (d, m, u) in scene.parameter_info().items()]
    if not rows:
        print(f"{indent}(none)")
        return
    w0 = max(len(r[0]) for r in rows)
    w1 = max(len(r[1]) for r in rows)
    for a, b, c in rows:
        print(f"{indent}{a:<{w0}}  {b:<{w1}}  {c}".rstrip())


def _print_outputs(scene, indent, *, detail):
    info = scene.output_info()
    if not info:
        if callable(getattr(scene.module, "outputs", None)):
            print(f"{indent}(named by the scene's outputs(); it has no OUTPUTS table to describe them)")
            return
        if not detail:
            print(f"{indent}(the free coordinates, named BODY.COORDINATE: the scene has no outputs())")
            return
        try:
            labels = _coordinate_labels(scene)
        except Exception as exc:  # a user's scene file: say why, do not crash
            print(f"{indent}(not described; building the mechanism failed: {type(exc).__name__}: {exc})")
            return
        print(f"{indent}(the scene has no OUTPUTS; its outputs are the free coordinates)")
        for label in labels:
            print(f"{indent}{label}")
        return
    if not detail:
        items = [f"{k} {_unit(u)}".rstrip() for k, (_, u) in info.items()]
        line = indent
        for i, item in enumerate(items):
            item += "," if i < len(items) - 1 else ""
            if line.strip() and len(line) + 1 + len(item) > 100:
                print(line)
                line = indent
            line += ("" if not line.strip() else " ") + item
        print(line)
        return
    w0 = max(len(k) for k in info)
    w1 = max(len(_unit(u)) for _, u in info.values())
    for k, (m, u) in info.items():
        print(f"{indent}{k:<{w0}}  {_unit(u):<{w1}}  {m}".rstrip())


def _coordinate_labels(scene):
    """Names ``BODY.COORDINATE`` of the free coordinates of a scene built with its defaults, read from its
    bodies' nodes without compiling the mechanism (compiling would compile element kernels)."""
    from femb.system.model import Model, _is_body

    built = scene.module.build()
    if isinstance(built, Model):
        return list(built.coord_labels)
    labels, seen = [], set()
    for e in getattr(built, "elements", ()):
        if not _is_body(e):
            continue
        for nd in e.nodes():
            if id(nd) in seen:
                continue
            seen.add(id(nd))
            labels += [f"{nd.name}.{c}" for c, fixed in zip(nd.coord_names, nd.fixed) if not fixed]
    return labels


def _print_settings(scene, indent):
    d = scene.defaults
    t_end = "(give --t-end)" if d["t_end"] is None else f"{d['t_end']!r} [s]"
    h = "(give --h)" if d["h"] is None else f"{d['h']!r} [s]"
    print(f"{indent}t_end={t_end}  h={h}  rho_inf={d['rho_inf']!r}")


def _doc_body(doc):
    """A scene docstring without its title line, up to its first numpydoc section."""
    lines = textwrap.dedent("\n".join((doc or "").strip().splitlines()[1:])).splitlines()
    for i in range(len(lines) - 1):
        under = lines[i + 1].strip()
        if lines[i].strip() and under and set(under) == {"-"} and len(under) >= len(lines[i].strip()):
            lines = lines[:i]
            break
    return "\n".join(lines).strip()


def cmd_list(args):
    """femb list [SCENE]: the scenes, their parameters (meaning, unit), run settings and outputs."""
    from femb.study import registry

    if args.scene is None:
        for name in registry.names():
            scene = registry.load(name)
            print(f"{name}: {scene.description}")
            print("  parameters:")
            _print_parameters(scene, "    ")
            print("  defaults:")
            _print_settings(scene, "    ")
            print(f"  outputs{' (independent reference: yes)' if scene.has_reference else ''}:")
            _print_outputs(scene, "    ", detail=False)
            print()
        contacts = registry.contact_names()
        if contacts:
            print("contact scenes ('femb run NAME' integrates them with the nonsmooth generalized-alpha "
                  "scheme of femb.contact, fixed steps or --rtol; 'femb bench contact NAME' validates them):")
            for name in contacts:
                print(f"  {name}: {registry.load(name).description}")
            print()
        statics = registry.static_names()
        if statics:
            print("static and buckling scenes ('femb run NAME' solves them; no time integration):")
            for name in statics:
                print(f"  {name}: {registry.load(name).description}")
            print()
        print("'femb list SCENE' describes one scene and its outputs in detail.")
        return 0
    scene = _load_scene(args.scene)
    print(f"{scene.name}: {scene.description}")
    print(f"source: {scene.source}")
    body = _doc_body(scene.module.__doc__)
    if body:
        print()
        print(body)
    print()
    print(f"parameters (femb run {scene.name} --set NAME=VALUE):")
    _print_parameters(scene, "  ")
    print("default run settings:")
    _print_settings(scene, "  ")
    print("outputs (printed by femb run at t_end; --json FILE writes them):")
    _print_outputs(scene, "  ", detail=True)
    if scene.has_reference:
        print("reference: an independent solution (femb bench convergence compares against it)")
    return 0


def cmd_run(args):
    """femb run: build a scene, integrate it, report its outputs at t_end."""
    _check_run_args(args)
    scene = _load_scene(args.scene)
    params = parse_sets(args.set)
    if callable(getattr(scene.module, "solve", None)):
        return _run_static(scene, params, args)
    d = scene.defaults
    t_end = args.t_end if args.t_end is not None else d["t_end"]
    adaptive = args.rtol is not None
    h = args.h if (args.h is not None or adaptive) else d["h"]
    rho_inf = args.rho_inf if args.rho_inf is not None else d["rho_inf"]
    missing = [opt for opt, v in (("--t-end", t_end), ("--h", h)) if v is None and not (adaptive and opt == "--h")]
    if missing:
        raise UsageError(f"scene '{scene.name}' has no DEFAULTS for {' and '.join(missing)}: give them")
    model = _build_scene_model(scene, params)
    if h is None and getattr(model, "n_contacts", 0):     # adaptive contact steps start from the scene's h
        h = d["h"]
        if h is None:
            raise UsageError(f"scene '{scene.name}' has no DEFAULTS for --h: give the first step's size")
    result, total = _integrate(model, args, t_end, h, rho_inf)
    _report_run(scene, params, args, result, rho_inf, total)
    return 0


def _check_run_args(args):
    """The option combinations ``femb run`` refuses, and the --json destination."""
    if args.every is not None and args.vtk is None:
        raise UsageError("--every needs --vtk DIR")
    if args.dt is not None and args.vtk is None:
        raise UsageError("--dt needs --vtk DIR")
    if args.dt is not None and args.every is not None:
        raise UsageError("give --every or --dt, not both")
    if args.atol is not None and args.rtol is None:
        raise UsageError("--atol needs --rtol (adaptive steps)")
    _check_json_dest(args.json)


def _build_scene_model(scene, params):
    """The scene's model for ``params``; a UsageError when build() rejects them."""
    from femb.study.registry import SceneError

    try:
        return scene.model(**params)
    except SceneError as exc:
        raise UsageError(str(exc)) from None
    except (FembError, ValueError, TypeError) as exc:
        raise UsageError(f"scene '{scene.name}': build() rejected the parameters: {exc}") from None


def _integrate(model, args, t_end, h, rho_inf):
    """Run the simulation of ``femb run`` (with its VTK stream and progress bar): (result, seconds)."""
    from femb.solve.solver import simulate

    if getattr(model, "n_contacts", 0):
        return _integrate_contact(model, args, t_end, h, rho_inf)
    adaptive = args.rtol is not None
    n_steps = 0
    if not adaptive:
        from femb.solve.options import fixed_steps
        try:
            n_steps = fixed_steps(float(h), 0.0, float(t_end))[0]    # the rule simulate follows
        except FembError as exc:
            raise UsageError(str(exc)) from None
    show = {"auto": n_steps >= 5000 or args.vtk is not None or adaptive, "on": True, "off": False}[args.progress]

    stream = _NullContext(None)
    if args.vtk is not None:
        stream = _vtk_stream(model, args.vtk, args.every or 1, None, dt=args.dt)
        if not hasattr(stream, "__enter__"):
            stream = _NullContext(stream)
    t0 = time.perf_counter()
    with stream as observer, warnings.catch_warnings():
        if rho_inf == 1.0:
            warnings.simplefilter("ignore", ParameterWarning)
            if args.formulation == "index3":
                print("note: rho_inf = 1 is not strictly stable at infinity with index 3; multipliers may "
                      "oscillate (--formulation index2 runs without numerical damping)", file=sys.stderr)
        try:
            if adaptive:
                result = simulate(model, t_end, rtol=args.rtol, atol=args.atol, h0=h, rho_inf=rho_inf,
                                  scaling=not args.no_scaling, store=False, observer=observer, progress=show,
                                  formulation=args.formulation)
            else:
                result = simulate(model, t_end, h, rho_inf=rho_inf, scaling=not args.no_scaling,
                                  store=False, observer=observer, progress=show, formulation=args.formulation)
        except KeyboardInterrupt:
            raise
        except Exception as exc:
            if observer is not None and (type(exc).__name__ == "OutputError" or isinstance(exc, OSError)):
                raise _OutputFailure(f"writing output failed: {str(exc).splitlines()[0]}") from exc
            raise
    return result, time.perf_counter() - t0


def _integrate_contact(model, args, t_end, h, rho_inf):
    """``femb run`` of a model with contact elements: :func:`femb.contact.simulate` (fixed steps, or adaptive
    with ``--rtol``),
    then the VTK series of the stored steps (every ``--every``-th, or the step nearest each ``--dt``)."""
    import femb.contact
    from femb.errors import OutputError

    if args.formulation != "index3" or args.no_scaling:
        raise UsageError("--formulation and --no-scaling do not apply to the nonsmooth contact scheme "
                         "(it enforces the joints at position, velocity and acceleration level)")
    # what is kept: the first and last state only (the report reads the final outputs; events, iterations and
    # step sizes cover every step), every --every-th step for --vtk, every step for --vtk --dt (the stored
    # step nearest each multiple of dt is written)
    keep = dict(store=False) if args.vtk is None else ({} if args.dt is not None else dict(stride=args.every or 1))
    t0 = time.perf_counter()
    if args.rtol is not None:              # adaptive steps (docs/contact.md §1.2); h the first step's size
        result = femb.contact.simulate(model, t_end, h, rho_inf=rho_inf, rtol=args.rtol, atol=args.atol, **keep)
    else:
        result = femb.contact.simulate(model, t_end, h, rho_inf=rho_inf, **keep)
    if args.vtk is not None:
        try:
            result.write_vtk(args.vtk, every=1, dt=args.dt)   # --dt: the stored step nearest each
        except (OutputError, OSError) as exc:
            raise _OutputFailure(f"writing output failed: {str(exc).splitlines()[0]}") from exc
    return result, time.perf_counter() - t0


def _report_run(scene, params, args, result, rho_inf, total):
    """The outputs at t_end and the cost of ``femb run``: printed, and as JSON with --json."""
    import numpy as np

    adaptive = args.rtol is not None
    outs = scene.outputs(result)
    final = {k: _json_value(np.asarray(v)[-1]) for k, v in outs.items()}
    iters = int(result.newton_iterations.sum())
    data = {
        "scene": scene.name,
        "t_end": float(result.t[-1]),
        "h": float(result.settings.get("h") or np.median(result.h_steps)),
        "adaptive": adaptive,
        "rtol": args.rtol,
        "rejected_steps": int(getattr(result, "n_rejected", 0)),
        "rho_inf": float(rho_inf),
        "scaling": not args.no_scaling,
        "formulation": args.formulation,
        "steps": result.steps,
        "newton_iterations": iters,
        "wall_time_s": result.wall_time,
        "outputs": final,
        "newton_per_step": iters / max(result.steps, 1),
        "us_per_step": 1e6 * result.wall_time / max(result.steps, 1),
        "total_time_s": total,
        "source": scene.source,
    }
    data.update(_provenance(scene, params, result.settings))
    if args.json:
        _write_json(data, args.json)
    if args.json != "-":
        if adaptive:
            print(f"{scene.name}: {result.steps} adaptive steps (rtol = {args.rtol:g}, {data['rejected_steps']} "
                  f"rejected; h from {result.h_steps.min():.3g} to {result.h_steps.max():.3g} s) to "
                  f"t = {data['t_end']:.6g} s, rho_inf = {rho_inf:g}")
        else:
            print(f"{scene.name}: {result.steps} steps of h = {data['h']:.6g} s to t = {data['t_end']:.6g} s, "
                  f"rho_inf = {rho_inf:g}, scaling {'on' if data['scaling'] else 'off'}")
        print(f"  {iters} Newton iterations ({data['newton_per_step']:.2f}/step), "
              f"{result.wall_time:.3f} s in the time loop ({data['us_per_step']:.1f} us/step), "
              f"{total:.3f} s in all")
        width = max((len(k) for k in final), default=0)
        for k, v in final.items():
            print(f"  {k:<{width}s} = {v:.12g}" if isinstance(v, float) else f"  {k:<{width}s} = {v}")


def _run_static(scene, params, args):
    """femb run for a scene that is not a time integration (static or buckling: its ``solve``)."""
    from femb.study.registry import SceneError

    build_params = {k: v for k, v in params.items() if k in scene.parameters()}
    try:
        model = scene.model(**build_params)
        t0 = time.perf_counter()
        result = scene.module.solve(model, **params)
    except SceneError as exc:
        raise UsageError(str(exc)) from None
    except (FembError, ValueError, TypeError) as exc:
        raise UsageError(f"scene '{scene.name}': {exc}") from None
    total = time.perf_counter() - t0
    final = {k: _json_value(v[-1]) for k, v in scene.outputs(result).items()}
    kind = getattr(scene.module, "ANALYSIS", "static")
    data = {"scene": scene.name, "analysis": kind, "levels": [float(x) for x in result.t],
            "outputs": final, "total_time_s": total, "source": scene.source}
    data.update(_provenance(scene, params, _solve_settings(scene, params)))
    if args.json:
        _write_json(data, args.json)
    if args.json != "-":
        print(f"{scene.name}: {kind} analysis, {len(result.t)} level(s), {total:.3f} s")
        width = max((len(k) for k in final), default=0)
        for k, v in final.items():
            print(f"  {k:<{width}s} = {v:.12g}" if isinstance(v, float) else f"  {k:<{width}s} = {v}")
    return 0


def cmd_bench_convergence(args):
    """femb bench convergence: the h-convergence study of one scene."""
    from femb.benchmarks.accuracy.convergence import convergence_study, format_table

    scene = _load_scene(args.scene)
    params = parse_sets(args.set)
    try:
        scene.check_parameters(params)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    quiet = args.json == "-"
    _check_json_dest(args.json)

    def report(row):
        if quiet:
            return
        if "failed" in row:
            print(f"  h = {row['h']:.3e}: failed: {row['failed']}", flush=True)
        else:
            print(f"  h = {row['h']:.3e}: {row['steps']} steps, error q {row['error_q']:.3e}, "
                  f"error lambda {row['error_lambda']:.3e}, {row['us_per_step']:.1f} us/step, "
                  f"{row['newton_per_step']:.2f} Newton/step", flush=True)

    try:
        study = convergence_study(scene, h=args.h, rho_inf=args.rho_inf, scaling=not args.no_scaling,
                                  t_end=args.t_end, params=params, report=report)
    except (FembError, ValueError, TypeError) as exc:
        if isinstance(exc, SolverError):
            raise
        raise UsageError(f"scene '{scene.name}': {exc}") from None
    if args.json:
        _write_json(study, args.json)
    if not quiet:
        print(format_table(study))
    if args.plot:
        from femb.benchmarks.accuracy.figures import convergence_figure

        path = convergence_figure(study, args.plot)
        if not quiet:
            print(f"wrote {path}")
    return 0


def cmd_bench_contact(args):
    """femb bench contact SCENE: the scene's validation tables (its module's ``main``)."""
    from femb.study import registry

    if args.scene not in registry.CONTACT_SCENES:
        raise UsageError(f"'{args.scene}' is not a contact scene (contact scenes: "
                         f"{', '.join(registry.contact_names())})")
    scene = _load_scene(args.scene)
    t0 = time.perf_counter()
    scene.module.main()
    print(f"({time.perf_counter() - t0:.1f} s)")
    return 0


def cmd_bench_figures(args):
    """femb bench figures: the seed paper's figures for a scene, as PNG files."""
    from femb.benchmarks.accuracy.figures import make_figures

    scene = _load_scene(args.scene)
    t0 = time.perf_counter()
    files = make_figures(scene, args.out, rho_inf=args.rho_inf, h=args.h)
    for f in files:
        print(f"wrote {f}")
    print(f"({time.perf_counter() - t0:.1f} s)")
    return 0


# --------------------------------------------------------------------------
# parser
# --------------------------------------------------------------------------


def cmd_render(args):
    """femb render: pictures and animations of a written VTK series."""
    from pathlib import Path

    src = Path(args.source)
    if src.is_dir():
        pvds = sorted(src.glob("*.pvd"))
        if not pvds:
            raise UsageError(f"{src}: no .pvd collection in this folder (write one with 'femb run SCENE --vtk {src}')")
        pvd = pvds[0]
    elif src.suffix == ".pvd" and src.is_file():
        pvd = src
    else:
        raise UsageError(f"{src}: not a folder with a .pvd collection nor a .pvd file")
    outs = [(k, getattr(args, k)) for k in ("gif", "mp4", "png", "strip") if getattr(args, k)]
    if not outs:
        raise UsageError("give at least one of --gif FILE, --mp4 FILE, --png FILE, --strip FILE")
    if args.time is not None and not args.png:
        raise UsageError("--time goes with --png")
    if args.overlay and not args.strip:
        raise UsageError("--overlay goes with --strip")
    trace = tuple(args.trace or ())
    import femb.io

    size = tuple(args.size) if args.size else None
    try:
        for kind, path in outs:
            t0 = time.perf_counter()
            if kind in ("gif", "mp4"):
                if Path(path).suffix.lower() != f".{kind}":
                    raise UsageError(f"--{kind} needs a file name ending in .{kind}, got {path}")
                kw = {"window_size": size} if size else {}
                femb.io.render_animation(pvd, path, fps=args.fps, every=args.every, scalars=args.scalars,
                                         show_progress=True, view=args.view, trace=trace, **kw)
            elif kind == "png":
                kw = {"window_size": size} if size else {}
                femb.io.render_png(pvd, path, time=args.time, scalars=args.scalars, view=args.view,
                                   trace=trace, **kw)
            else:
                femb.io.render_strip(pvd, path, n=args.n, scalars=args.scalars, window_size=size,
                                     view=args.view, layout="overlay" if args.overlay else "row",
                                     trace=trace)
            print(f"wrote {path} ({time.perf_counter() - t0:.1f} s)")
    except femb.io.OutputError as exc:
        msg = str(exc).splitlines()[0]
        if msg.startswith("trace"):                 # a --trace naming no body or point of the series
            raise UsageError("--" + msg) from None
        raise _OutputFailure(msg) from None
    return 0


def cmd_view(args):
    """femb view: an interactive 3-D player of a written VTK series in the browser."""
    from femb.errors import OutputError
    from femb.io.view import view

    try:
        view(args.source, port=args.port, open_browser=not args.no_browser, view=args.view, fps=args.fps,
             host=args.host)
    except OutputError as exc:
        raise _OutputFailure(str(exc).splitlines()[0]) from None
    return 0


def cmd_bench_suite(args):
    """femb bench [--quick] [--out DIR]: the benchmark suite."""
    if args.bench_command is not None:      # pragma: no cover (subcommands set their own func)
        return args.func(args)
    try:
        from femb.benchmarks.runners import suite
    except ImportError as exc:
        raise UsageError(f"the benchmark suite is not available: {exc}") from None
    argv = (["--quick"] if args.quick else []) + ["--out", args.out]
    return suite.main(argv) or 0


def build_parser():
    """The argparse parser of the ``femb`` command."""
    p = _Parser(prog=PROG, description="femb: flexible multibody dynamics with the index-3 "
                "generalized-alpha scheme. Run benchmark scenes, convergence studies and figures.",
                epilog="Exit status: 0 success, 1 simulation failure, 2 bad arguments.")
    p.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    p.add_argument("--debug", action="store_true", help="show full tracebacks on errors")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    _add_list_parser(sub)
    _add_run_parser(sub)
    _add_render_parser(sub)
    _add_view_parser(sub)
    _add_bench_parser(sub)
    from femb.console.cli_sweep import add_parser as add_sweep_parser

    add_sweep_parser(sub)
    from femb.console.cli_cache import add_parser as add_cache_parser

    add_cache_parser(sub, _Parser)
    return p



def _add_list_parser(sub):
    """The subcommand ``femb list``."""
    sp = sub.add_parser("list", help="list the built-in scenes, their parameters and outputs",
                        description="List the built-in scenes: the parameters of their build() "
                        "functions (settable with 'femb run --set') with meaning and unit, their "
                        "default run settings and their named outputs. With SCENE, describe that "
                        "scene (a built-in name or a scene file) in detail.")
    sp.add_argument("scene", metavar="SCENE", nargs="?", default=None,
                    help="describe only this scene (" + SCENE_HELP + ")")
    sp.set_defaults(func=cmd_list)


def _add_run_parser(sub):
    """The subcommand ``femb run``."""
    sp = sub.add_parser("run", help="run one scene and report its outputs at the final time",
                        description="Build a scene from femb elements, integrate it with the "
                        "generalized-alpha scheme at fixed step h, and print its named outputs at "
                        "t_end (optionally as JSON).")
    sp.add_argument("scene", metavar="SCENE", help=SCENE_HELP)
    sp.add_argument("--t-end", type=_positive("t_end"), metavar="T", help="final time in s (default: the scene's)")
    sp.add_argument("--h", type=_positive("h"), metavar="H",
                    help="fixed step size in s (default: the scene's); with --rtol the first step")
    sp.add_argument("--rtol", type=_positive("rtol"), metavar="R",
                    help="adaptive steps with this relative local error tolerance")
    sp.add_argument("--atol", type=_positive("atol"), metavar="A",
                    help=f"absolute local error tolerance of adaptive steps (default: {ATOL_PER_RTOL:g} x rtol)")
    sp.add_argument("--rho-inf", type=_rho, metavar="R",
                    help="spectral radius at infinity in [0, 1] (default: the scene's, usually 0.7)")
    sp.add_argument("--no-scaling", action="store_true",
                    help="solve the unscaled Newton system (default: scaled, Bottasso et al.)")
    sp.add_argument("--formulation", choices=("index3", "index2"), default="index3",
                    help="index3 (default) or the stabilized index-2 (GGL) step: velocity constraint "
                         "held, no 1/h^2 round-off in the reactions at tiny h, runs at rho_inf = 1")
    sp.add_argument("--set", action="append", metavar="NAME=VALUE", default=[],
                    help="keyword argument of the scene's build() (repeatable; numbers are parsed as numbers)")
    sp.add_argument("--json", metavar="FILE", help="write the run summary as JSON ('-' for stdout)")
    sp.add_argument("--vtk", metavar="DIR", help="stream VTK frames into DIR (ParaView .pvd collection)")
    sp.add_argument("--every", type=_count, metavar="N", help="with --vtk: write every N-th step (default 1)")
    sp.add_argument("--dt", type=_positive("dt"), metavar="DT",
                    help="with --vtk: write frames every DT seconds, interpolated between steps (adaptive runs; "
                         "contact scenes: the stored step nearest each)")
    sp.add_argument("--progress", choices=("auto", "on", "off"), default="auto",
                    help="progress bar on stderr (auto: for runs of 5000 steps or more, or with --vtk)")
    sp.set_defaults(func=cmd_run)


def _add_render_parser(sub):
    """The subcommand ``femb render``."""
    rp = sub.add_parser("render", help="render a written VTK series to a GIF, MP4 or PNG",
                        description="Render the .pvd series written by 'femb run --vtk DIR' off-screen: "
                        "an animation (GIF, or MP4 with the femb[mp4] extra), a snapshot at a time, or a "
                        "strip of motion snapshots. The camera is fitted to the whole motion.")
    rp.add_argument("source", metavar="DIR", help="folder written by --vtk (or a .pvd file)")
    rp.add_argument("--gif", metavar="FILE", help="write an animated GIF")
    rp.add_argument("--mp4", metavar="FILE", help="write an MP4 video (needs imageio-ffmpeg)")
    rp.add_argument("--png", metavar="FILE", help="write a snapshot PNG (at --time, default the last frame)")
    rp.add_argument("--strip", metavar="FILE",
                    help="write a PNG of --n instants side by side (small multiples; --overlay: in one view)")
    rp.add_argument("--time", type=float, metavar="T", help="with --png: the time of the snapshot")
    rp.add_argument("--n", type=_count, default=6, metavar="N", help="with --strip: number of snapshots (default 6)")
    rp.add_argument("--overlay", action="store_true",
                    help="with --strip: draw the instants in one view, light (early) to dark (late)")
    rp.add_argument("--trace", action="append", type=_trace, metavar="BODY[:POINT]",
                    help="draw the path of a body's centre of mass or named point (3-D mechanisms; "
                    "repeatable)")
    rp.add_argument("--fps", type=_count, default=20, metavar="N", help="frames per second of animations (default 20)")
    rp.add_argument("--every", type=_count, default=1, metavar="N", help="animate every N-th frame (default 1)")
    rp.add_argument("--scalars", metavar="NAME", help="colour by this point/cell data field")
    rp.add_argument("--size", type=_count, nargs=2, metavar=("W", "H"), help="picture size in pixels")
    rp.add_argument("--view", type=_view, default=None, metavar="VIEW",
                    help="camera: 3d, iso, front, side, top or AZIMUTH,ELEVATION in degrees (perspective, "
                    "gravity pointing down the picture), plane (straight onto a planar mechanism), or xy, xz, "
                    "yz (parallel along an axis); default plane for planar mechanisms, xy for other planar "
                    "data, else 3d")
    rp.set_defaults(func=cmd_render)


def _add_view_parser(sub):
    """The subcommand ``femb view DIR_OR_PVD``."""
    vp = sub.add_parser("view", help="an interactive 3-D player of a written VTK series in the browser",
                        description="Serve a web page showing the .pvd series written by 'femb run --vtk DIR' "
                        "(bodies, joints, ground and legend as in the pictures) with a time slider and "
                        "play/pause; drag to turn, wheel to zoom. Needs the femb[view] extra. Ctrl-C stops.")
    vp.add_argument("source", metavar="DIR_OR_PVD", help="folder written by --vtk (or a .pvd file)")
    vp.add_argument("--port", type=int, default=0, metavar="P", help="port of the local server (default: a free one)")
    vp.add_argument("--host", default="localhost", metavar="HOST",
                    help="interface to listen on (default localhost; reach a remote machine by SSH port forwarding)")
    vp.add_argument("--no-browser", action="store_true", help="do not open a browser; print the address")
    vp.add_argument("--fps", type=_count, default=20, metavar="N", help="frames per second when playing (default 20)")
    vp.add_argument("--view", type=_view, default=None, metavar="VIEW",
                    help="initial camera, as for femb render (default plane for planar mechanisms, else 3d)")
    vp.set_defaults(func=cmd_view)


def _add_bench_parser(sub):
    """The subcommand ``femb bench (the suite, convergence, figures)``."""
    bp = sub.add_parser("bench", help="benchmarks: convergence studies and the paper's figures",
                        description="Benchmarks of the seed paper (Arnold & Bruls 2007). "
                        "'femb bench' alone is reserved for the benchmark suite.")
    bp.add_argument("--quick", action="store_true",
                    help="a small set at reduced size (about a minute): the pendulum's work-precision study "
                         "and four stress tests")
    bp.add_argument("--out", metavar="DIR", default="bench-report",
                    help="report folder of the suite (default bench-report/)")
    bsub = bp.add_subparsers(dest="bench_command", metavar="BENCH_COMMAND", parser_class=_Parser)
    bp.set_defaults(func=cmd_bench_suite, bench_parser=bp)

    cp = bsub.add_parser("convergence", help="h-convergence study of a scene (errors in q and lambda)",
                         description="Run a scene with a sequence of step sizes, measure the relative "
                         "errors at the final time of its coordinates and Lagrange multipliers against "
                         "an independent reference, and fit the order in h.")
    cp.add_argument("scene", metavar="SCENE", help=SCENE_HELP)
    cp.add_argument("--rho-inf", type=_rho, default=0.7, metavar="R", help="spectral radius at infinity (default 0.7)")
    cp.add_argument("--h", type=_positive("h"), nargs="+", metavar="H", help="step sizes (default: the scene's)")
    cp.add_argument("--t-end", type=_positive("t_end"), metavar="T", help="final time (default: the scene's)")
    cp.add_argument("--no-scaling", action="store_true", help="unscaled Newton system")
    cp.add_argument("--set", action="append", metavar="NAME=VALUE", default=[],
                    help="keyword argument of the scene's build() (repeatable)")
    cp.add_argument("--json", metavar="FILE", help="write the study as JSON ('-' for stdout)")
    cp.add_argument("--plot", metavar="FILE", help="write the log-log error plot (PNG)")
    cp.set_defaults(func=cmd_bench_convergence)

    kp = bsub.add_parser("contact", help="validation of a contact scene against its references",
                         description="Run a contact scene's validation (docs/contact.md §5): impact times, "
                         "rolling speeds, orders in h, Housner's restitution, … against closed forms and "
                         "independent references, printed as a table.")
    kp.add_argument("scene", metavar="SCENE", help="a contact scene (femb list shows them)")
    kp.set_defaults(func=cmd_bench_contact)

    fp = bsub.add_parser("figures", help="the seed paper's figures for a scene, as PNG files",
                         description="Write the figures of the seed paper for a scene (time plots and "
                         "the convergence plot) as PNG files, plus the convergence study as JSON.")
    fp.add_argument("scene", metavar="SCENE", help=SCENE_HELP)
    fp.add_argument("--out", required=True, metavar="DIR", help="output directory")
    fp.add_argument("--rho-inf", type=_rho, default=0.7, metavar="R", help="spectral radius at infinity (default 0.7)")
    fp.add_argument("--h", type=_positive("h"), nargs="+", metavar="H",
                    help="step sizes of the convergence study (default: the scene's)")
    fp.set_defaults(func=cmd_bench_figures)


def _version():
    try:
        from femb import __version__
        return __version__
    except Exception:   # pragma: no cover
        return "unknown"


def main(argv=None):
    """Entry point of the ``femb`` console script; returns the exit status."""
    parser = build_parser()
    argv = sys.argv[1:] if argv is None else list(argv)
    debug = "--debug" in argv
    try:
        args = parser.parse_args(argv)
        if args.command is None:
            parser.print_help(sys.stderr)
            return 2
        return args.func(args)
    except UsageError as exc:
        if debug:
            raise
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return 2
    except (SolverError, FembError) as exc:
        if debug:
            raise
        print(f"{PROG}: error: {str(exc).splitlines()[0]}", file=sys.stderr)
        return 1 if isinstance(exc, SolverError) else 2
    except _OutputFailure as exc:
        if debug:
            raise
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return 1
    except BrokenPipeError:
        # output piped into a command that stopped reading (e.g. head): not an error of ours
        import os

        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
