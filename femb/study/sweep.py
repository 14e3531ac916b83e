"""Parameter studies on Dask: grids, case lists and random / Latin-hypercube samples.

:func:`sweep` runs one femb scene (or any ``build(**params)`` function) for
many parameter sets on a :mod:`dask.distributed` cluster — a
:class:`~dask.distributed.LocalCluster` on this machine by default, or any
running Dask scheduler — and returns a tidy :class:`pandas.DataFrame` with one
row per case.

**Design.**

* **Cases.** A *design* is a list of cases, each a dict ``{name: value}``. It
  is the full-factorial product of ``grid`` values, an explicit list of
  ``cases``, ``samples`` drawn in ``ranges`` (random or Latin hypercube, with
  a ``seed``), or the product of several of those. A name is either a keyword
  of the scene's ``build()`` or one of the run settings :data:`RUN_KEYS`
  (``t_end``, ``h``, ``rtol``, ``atol``, ``rho_inf``) and solver options
  :data:`SOLVER_KEYS`, which go to :func:`femb.simulate` (to :func:`femb.contact.simulate` for a model
  with contact elements, as ``femb run`` does: there ``h`` is the first step's size with ``rtol``, and
  the solver options are that function's).
* **Case ids.** Every case has an id: the first 16 hex digits of the SHA-256
  of the scene's identity, the case's full parameter set, the run settings,
  the requested outputs and ``t_eval``. Rows are keyed by it: a resumed sweep
  skips the ids already in the output, and no id appears twice in a result.
* **Batches.** Cases are grouped into batches (``batch_size`` cases, by
  default about eight batches per worker thread and at most 100 cases), one
  Dask task per batch, so the scheduler's per-task cost is shared by many
  cases. At most a few batches per worker thread are in flight at a time, so
  the scheduler's memory does not grow with the size of the sweep.
* **Models are reused.** Each worker keeps the loaded scenes and a few
  compiled models (keyed on the build parameters). Cases that change only run
  settings (``rho_inf``, ``h``, ...) reuse one compiled model; cases with new
  build parameters rebuild the mechanism. femb's compiled code itself is
  cached on disk under ``FEMB_CACHE_DIR``; a local cluster passes that
  variable on to its workers.
* **Failures are data.** A case whose build or simulation raises
  (:class:`~femb.errors.ConvergenceError`, :class:`~femb.errors.SingularMatrixError`,
  :class:`~femb.errors.ParameterError`, :class:`~femb.errors.ModelError`,
  :class:`~femb.errors.InitializationError`, a ``ValueError`` from ``build``)
  is a row with ``status = "failed"``, the exception class in ``error`` and its
  first line in ``message``; any other exception gives ``status = "error"``.
  A batch whose worker dies (killed, out of memory, ``client.restart()``) is
  run again, up to ``max_attempts`` times; after that its cases are rows with
  ``status = "failed"`` and ``error = "KilledWorker"``.
* **Streaming output.** With ``out=DIR`` rows are written while the sweep
  runs, as Parquet files ``DIR/part-<time>-<n>.parquet`` (one per chunk of
  about ``flush_rows`` rows or ``flush_interval`` seconds, whichever comes
  first, and at the end or on Ctrl-C), plus ``DIR/_sweep.json`` describing the
  sweep. ``pandas.read_parquet(DIR)`` or :func:`read_results` reads it back;
  ``resume=True`` skips the case ids already there.
* **Trajectories.** With ``trajectories=DIR`` every worker writes the full
  stored history of each successful case to ``DIR/case-<case_id>.npz`` (``t``,
  ``q``, ``qd``, ``lam`` and every output over time); only the file name goes
  back to the client. On a multi-machine cluster DIR must be a path every
  worker can write (a shared file system, or the files stay on each machine).

**Columns of the result.**
``case`` (position in the design), ``case_id``, the parameters (fixed and
varied), the run settings ``t_end``, ``h``, ``rho_inf`` (and ``rtol``,
``atol`` when given), one column per output at the case's final time, and
``NAME@T`` for each output at each ``t_eval`` time (linear interpolation
between the two stored steps around T, exact on the step grid), then
``steps``, ``newton_iterations``, ``wall_time`` (s, build + simulation +
outputs on the worker), ``sim_time`` (s, the time loop), ``status``
(``"success"``, ``"failed"`` or ``"error"``), ``error`` (exception class or
``""``), ``message``, ``warning`` (first warning raised, or ``""``),
``worker`` (the Dask worker's address) and ``trajectory`` (file name or ``""``).
"""
from __future__ import annotations

import contextlib
import hashlib
import inspect
import itertools
import json
import math
import os
import sys
import time
import types
import uuid
import warnings
from collections import OrderedDict
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

try:        # the sweep extra; here only for the return annotation (typing.get_type_hints)
    from pandas import DataFrame
except ImportError:     # pragma: no cover - without pandas, sweep() says which extra to install
    DataFrame = Any

from femb.errors import FembError, OutputError, ParameterError

__all__ = ["sweep", "SweepPlan", "read_results", "make_design", "full_factorial", "sample_design",
           "parse_grid_spec", "parse_range_spec", "run_batch", "plot_results", "output_columns",
           "RUN_KEYS", "SOLVER_KEYS"]

#: Run settings a case may set; they go to :func:`femb.simulate`, not to ``build()``.
RUN_KEYS = ("t_end", "h", "rtol", "atol", "rho_inf")
#: Further keyword options of :func:`femb.simulate` a case may set.
SOLVER_KEYS = ("scaling", "alpha", "phi_tol", "max_iter", "newton", "linear_solver", "predictor")
#: Column names of a result row that parameters and outputs may not use.
RESERVED = ("case", "case_id", "steps", "newton_iterations", "wall_time", "sim_time", "status",
            "error", "message", "warning", "worker", "trajectory")

#: Exceptions of a case that make a ``"failed"`` row (others make an ``"error"`` row).
EXPECTED_FAILURES = (FembError, ValueError, ArithmeticError, np.linalg.LinAlgError)

MANIFEST = "_sweep.json"


# ==========================================================================
# designs
# ==========================================================================
def _is_number(v):
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))


def _plain(v):
    """numpy scalars -> Python scalars (JSON, hashing and Parquet want plain values)."""
    if isinstance(v, np.generic):
        return v.item()
    return v


def full_factorial(grid):
    """All combinations of the grid values (the last name varies fastest).

    Parameters
    ----------
    grid : dict of str to sequence
        Parameter name -> values (non-empty, no value twice).

    Returns
    -------
    list of dict
        ``prod(len(values))`` cases.

    Raises
    ------
    ParameterError
        A name that is not an identifier, an empty or scalar value list, a repeated value.
    """
    if not isinstance(grid, dict):
        raise ParameterError(f"grid must be a dict of parameter name -> list of values, got {type(grid).__name__}")
    names, lists = [], []
    for name, values in grid.items():
        _check_name(name, "grid")
        if isinstance(values, (str, bytes)) or not hasattr(values, "__iter__"):
            raise ParameterError(f"grid '{name}': expected a list of values, got {values!r}")
        values = [_plain(v) for v in values]
        if not values:
            raise ParameterError(f"grid '{name}': no values")
        seen = set()
        for v in values:
            key = repr(v)
            if key in seen:
                raise ParameterError(f"grid '{name}': value {v!r} appears twice")
            seen.add(key)
        names.append(name)
        lists.append(values)
    return [dict(zip(names, combo)) for combo in itertools.product(*lists)]


def _check_name(name, what):
    if not isinstance(name, str) or not name.isidentifier():
        raise ParameterError(f"{what}: parameter name must be an identifier, got {name!r}")


def _lhs_unit(n, d, rng):
    """n Latin-hypercube points in [0, 1)^d (scipy.stats.qmc)."""
    from scipy.stats import qmc

    try:
        engine = qmc.LatinHypercube(d, rng=rng)
    except TypeError:                   # scipy < 1.15 names it seed
        engine = qmc.LatinHypercube(d, seed=rng)
    return engine.random(n)


def sample_design(ranges, n, method="lhs", seed=None):
    """``n`` random or Latin-hypercube samples of the parameters in ``ranges``.

    Parameters
    ----------
    ranges : dict of str to tuple
        ``name -> (low, high)`` for a uniform distribution or
        ``(low, high, "log")`` for a log-uniform one (0 < low).
    n : int
        Number of samples.
    method : {"lhs", "random"}
        Latin hypercube (:class:`scipy.stats.qmc.LatinHypercube`, McKay et al.
        1979) or independent uniform draws.
    seed : int or None
        Seed of :func:`numpy.random.default_rng`; the same seed gives the same samples.

    Returns
    -------
    list of dict
        ``n`` cases of floats.
    """
    if not isinstance(ranges, dict) or not ranges:
        raise ParameterError("samples need ranges: a dict name -> (low, high) or (low, high, 'log')")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ParameterError(f"samples must be a positive integer, got {n!r}")
    if method not in ("lhs", "random"):
        raise ParameterError(f"sampling must be 'lhs' or 'random', got {method!r}")
    specs = []
    for name, spec in ranges.items():
        _check_name(name, "ranges")
        specs.append((name,) + _check_range(name, spec))
    rng = np.random.default_rng(seed)
    d = len(specs)
    unit = _lhs_unit(int(n), d, rng) if method == "lhs" else rng.random((int(n), d))
    cases = []
    for row in unit:
        case = {}
        for (name, lo, hi, log), u in zip(specs, row):
            if log:
                case[name] = float(math.exp(math.log(lo) + u * (math.log(hi) - math.log(lo))))
            else:
                case[name] = float(lo + u * (hi - lo))
        cases.append(case)
    return cases


def _check_range(name, spec):
    if isinstance(spec, (str, bytes)) or not hasattr(spec, "__len__") or len(spec) not in (2, 3):
        raise ParameterError(f"range '{name}': expected (low, high) or (low, high, 'log'), got {spec!r}")
    lo, hi = spec[0], spec[1]
    log = len(spec) == 3
    if log and spec[2] != "log":
        raise ParameterError(f"range '{name}': the third entry may only be 'log', got {spec[2]!r}")
    if not (_is_number(lo) and _is_number(hi) and math.isfinite(lo) and math.isfinite(hi)):
        raise ParameterError(f"range '{name}': low and high must be finite numbers, got {spec!r}")
    if not lo < hi:
        raise ParameterError(f"range '{name}': need low < high, got {lo!r} and {hi!r}")
    if log and lo <= 0:
        raise ParameterError(f"range '{name}': a log range needs 0 < low, got {lo!r}")
    return float(lo), float(hi), log


def make_design(grid=None, cases=None, samples=None, ranges=None, sampling="lhs", seed=None):
    """The list of cases of a sweep: the product of the given designs.

    Parameters
    ----------
    grid : dict of str to sequence, optional
        Full-factorial grid (:func:`full_factorial`).
    cases : sequence of dict, optional
        Explicit cases, all with the same names.
    samples : int, optional
        Number of samples in ``ranges`` (:func:`sample_design`).
    ranges, sampling, seed
        See :func:`sample_design`.

    Returns
    -------
    list of dict
        ``cases × grid × samples`` (each factor present only if given). Integer
        values of a parameter that has float values elsewhere become floats.

    Raises
    ------
    ParameterError
        No design, a name in two designs, inconsistent explicit cases.
    """
    factors = []
    if cases is not None:
        cases = list(cases)
        if not cases:
            raise ParameterError("cases: empty list")
        names0 = None
        for i, c in enumerate(cases):
            if not isinstance(c, dict):
                raise ParameterError(f"cases[{i}]: expected a dict name -> value, got {type(c).__name__}")
            for name in c:
                _check_name(name, f"cases[{i}]")
            if names0 is None:
                names0 = set(c)
            elif set(c) != names0:
                raise ParameterError(f"cases[{i}]: names {sorted(c)} differ from those of cases[0] {sorted(names0)}")
        factors.append([{k: _plain(v) for k, v in c.items()} for c in cases])
    if grid is not None:
        factors.append(full_factorial(grid))
    if samples is not None:
        factors.append(sample_design(ranges, samples, sampling, seed))
    elif ranges is not None:
        raise ParameterError("ranges given without samples (the number of samples)")
    if not factors:
        raise ParameterError("no cases: give grid=, cases= or samples= (with ranges=)")
    seen = {}
    for i, f in enumerate(factors):
        for name in f[0]:
            if name in seen:
                raise ParameterError(f"parameter '{name}' appears in two designs (grid, cases, samples)")
            seen[name] = i
    design = [dict(itertools.chain.from_iterable(c.items() for c in combo))
              for combo in itertools.product(*factors)]
    return _normalize(design)


def _normalize(design):
    names = list(design[0]) if design else []
    for name in names:
        vals = [c.get(name) for c in design]
        if any(isinstance(v, float) for v in vals) and all(_is_number(v) for v in vals):
            for c in design:
                c[name] = float(c[name])
    return design


def parse_grid_spec(text):
    """A command-line grid: ``NAME=V1,V2,...``, ``NAME=LO:HI:N`` or ``NAME=LO:HI:N:log``.

    Values are parsed as Python literals when they are (numbers, True, None),
    else kept as strings; ``LO:HI:N`` is ``numpy.linspace(LO, HI, N)`` and
    ``LO:HI:N:log`` is ``numpy.geomspace(LO, HI, N)``.

    Returns
    -------
    (str, list)

    Raises
    ------
    ParameterError
        With a one-line message naming the spec.
    """
    from femb.study.parsing import parse_value

    name, sep, rest = str(text).partition("=")
    name = name.strip()
    if not sep or not name.isidentifier():
        raise ParameterError(f"--grid expects NAME=V1,V2,... or NAME=LO:HI:N[:log], got {text!r}")
    rest = rest.strip()
    if not rest:
        raise ParameterError(f"--grid {name}: no values in {text!r}")
    if ":" in rest and "," not in rest:
        parts = rest.split(":")
        if len(parts) not in (3, 4) or (len(parts) == 4 and parts[3].strip() != "log"):
            raise ParameterError(f"--grid {name}: a range is LO:HI:N or LO:HI:N:log, got {rest!r}")
        try:
            lo, hi = float(parts[0]), float(parts[1])
            n = int(parts[2])
        except ValueError:
            raise ParameterError(f"--grid {name}: LO and HI must be numbers and N an integer, got {rest!r}") from None
        if not (math.isfinite(lo) and math.isfinite(hi)) or n < 2 or lo == hi:
            raise ParameterError(f"--grid {name}: need finite LO != HI and N >= 2, got {rest!r}")
        if len(parts) == 4:
            if lo <= 0 or hi <= 0:
                raise ParameterError(f"--grid {name}: a log range needs positive LO and HI, got {rest!r}")
            return name, [float(v) for v in np.geomspace(lo, hi, n)]
        return name, [float(v) for v in np.linspace(lo, hi, n)]
    items = [s.strip() for s in rest.split(",")]
    if any(not s for s in items):
        raise ParameterError(f"--grid {name}: empty value in {rest!r}")
    values = [parse_value(s) for s in items]
    if len({repr(v) for v in values}) != len(values):
        raise ParameterError(f"--grid {name}: a value appears twice in {rest!r}")
    return name, values


def parse_range_spec(text):
    """A command-line sampling range ``NAME=LO:HI`` or ``NAME=LO:HI:log``.

    Returns
    -------
    (str, tuple)
        The name and ``(lo, hi)`` or ``(lo, hi, "log")``.
    """
    name, sep, rest = str(text).partition("=")
    name = name.strip()
    if not sep or not name.isidentifier():
        raise ParameterError(f"--range expects NAME=LO:HI or NAME=LO:HI:log, got {text!r}")
    parts = rest.strip().split(":")
    if len(parts) not in (2, 3):
        raise ParameterError(f"--range {name}: expected LO:HI or LO:HI:log, got {rest!r}")
    try:
        lo, hi = float(parts[0]), float(parts[1])
    except ValueError:
        raise ParameterError(f"--range {name}: LO and HI must be numbers, got {rest!r}") from None
    spec = (lo, hi) if len(parts) == 2 else (lo, hi, parts[2].strip())
    _check_range(name, spec)
    return name, spec


# ==========================================================================
# scenes as shipped to the workers
# ==========================================================================
@dataclass
class SceneRef:
    """What a worker needs to rebuild a scene: a registry name, a file's source, or a callable.

    Attributes
    ----------
    kind : {"registry", "file", "callable"}
    name : str
    key : str
        Identity of the scene (part of every case id).
    source : str or None
        Text of a scene file (shipped, so workers on other machines need not see the file).
    path : str or None
    build : callable or None
        ``build(**params) -> Mechanism | Model`` for kind "callable" (pickled by Dask).
    outputs : callable or None
        ``outputs(result) -> dict`` for kind "callable".
    """

    kind: str
    name: str
    key: str
    source: str | None = None
    path: str | None = None
    build: object = None
    outputs: object = None
    defaults: dict = field(default_factory=dict)
    parameters: dict | None = None      # build() keywords (None: accepts any)
    units: dict = field(default_factory=dict)   # parameter and output name -> unit (a scene's PARAMETERS, OUTPUTS)


def scene_ref(scene, outputs_fn=None):
    """A :class:`SceneRef` for a scene name, a scene file, a loaded Scene or a build callable."""
    from femb.study import registry

    if isinstance(scene, (str, os.PathLike)):
        try:
            loaded = registry.load(scene)
        except registry.SceneError as exc:
            raise ParameterError(str(exc)) from None
        scene = loaded
    if isinstance(scene, registry.Scene):
        params = None if scene.accepts_any_parameter() else scene.parameters()
        units = {k: u for k, (_, _, u) in scene.parameter_info().items()}
        units.update({k: u for k, (_, u) in scene.output_info().items()})
        if scene.source.endswith(".py") or Path(scene.source).is_file():
            text = Path(scene.source).read_text()
            digest = hashlib.sha256(text.encode()).hexdigest()[:16]
            return SceneRef("file", scene.name, f"file:{scene.name}:{digest}", source=text,
                            path=str(Path(scene.source).resolve()), outputs=outputs_fn,
                            defaults=scene.defaults, parameters=params, units=units)
        return SceneRef("registry", scene.name, f"scene:{scene.name}", outputs=outputs_fn,
                        defaults=scene.defaults, parameters=params, units=units)
    if callable(scene):
        try:
            sig = inspect.signature(scene)
        except (TypeError, ValueError):
            params = None
        else:
            if any(p.kind == p.VAR_KEYWORD for p in sig.parameters.values()):
                params = None
            else:
                params = {p.name: p.default for p in sig.parameters.values()
                          if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)}
        name = getattr(scene, "__qualname__", None) or type(scene).__name__
        key = f"callable:{getattr(scene, '__module__', '')}.{name}"
        return SceneRef("callable", name, key, build=scene, outputs=outputs_fn,
                        defaults={"t_end": None, "h": None, "rho_inf": None}, parameters=params)
    raise ParameterError(f"sweep: scene must be a scene name, a scene file, a Scene or a build "
                         f"callable, got {type(scene).__name__}")


class _Resolved:
    """Worker-side scene: ``model(**params)`` and ``outputs(result)``."""

    def __init__(self, ref):
        self.ref = ref
        self.scene = None
        if ref.kind == "registry":
            from femb.study import registry

            self.scene = registry.load(ref.name)
        elif ref.kind == "file":
            from femb.study import registry

            mod = types.ModuleType(f"femb_sweep_scene_{ref.name}_{ref.key[-8:]}")
            mod.__file__ = ref.path
            exec(compile(ref.source, ref.path or ref.name, "exec"), mod.__dict__)
            self.scene = registry.Scene(ref.name, mod, ref.path or ref.name)

    def model(self, **params):
        if self.scene is not None:
            return self.scene.model(**params)
        obj = self.ref.build(**params)
        from femb.system.model import Model

        if isinstance(obj, Model):
            return obj
        comp = getattr(obj, "compile", None)
        if comp is None:
            raise ParameterError(f"sweep: build() returned {type(obj).__name__}, expected a femb Mechanism or Model")
        return comp()

    def outputs(self, result):
        if self.ref.outputs is not None:
            return {k: np.asarray(v) for k, v in self.ref.outputs(result).items()}
        if self.scene is not None:
            return self.scene.outputs(result)
        return {label: result.q[:, i] for i, label in enumerate(result.model.coord_labels)}


# ==========================================================================
# worker side
# ==========================================================================
_SCENES: dict = {}
_MODELS: "OrderedDict" = OrderedDict()
#: Compiled models kept per worker process (least recently used dropped first).
MODEL_CACHE_SIZE = 8


class _FatalSpecError(Exception):
    """A problem of the sweep's specification that every case would hit (e.g. an unknown output)."""


def _resolved(ref):
    r = _SCENES.get(ref.key)
    if r is None:
        r = _SCENES[ref.key] = _Resolved(ref)
    return r


def _model(scene, ref, build_params):
    key = (ref.key, json.dumps(build_params, sort_keys=True, default=repr))
    m = _MODELS.get(key)
    if m is not None:
        _MODELS.move_to_end(key)
        return m, True
    m = scene.model(**build_params)
    _MODELS[key] = m
    while len(_MODELS) > MODEL_CACHE_SIZE:
        _MODELS.popitem(last=False)
    return m, False


def _first_line(exc):
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def _worker_address():
    try:
        from distributed import get_worker

        return get_worker().address
    except Exception:       # run outside Dask (serial use, tests)
        return ""


def _run_case(scene, ref, case, job, worker):
    """One case -> one row dict (never raises for a failing case)."""
    from femb.solve.solver import simulate

    params = case["params"]
    build = {k: v for k, v in params.items() if k not in RUN_KEYS and k not in SOLVER_KEYS}
    run = dict(job["run"])
    run.update({k: v for k, v in params.items() if k in RUN_KEYS or k in SOLVER_KEYS})
    row = {"case": case["case"], "case_id": case["case_id"]}
    row.update(params)
    for k in RUN_KEYS:
        if run.get(k) is not None and k not in row:
            row[k] = run[k]
    outs_wanted, t_eval = job["outputs"], job["t_eval"]
    need_store = bool(t_eval) or job["trajectories"] is not None
    status, error, message, warn = "success", "", "", ""
    steps = iters = 0
    sim_time = float("nan")
    values = {}
    traj = ""
    t0 = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            model, _ = _model(scene, ref, build)
            t_end = run.pop("t_end")
            kw = {k: v for k, v in run.items() if v is not None}
            if getattr(model, "n_contacts", 0):
                result = _simulate_contact(model, scene, t_end, dict(kw, store=need_store))
            else:
                result = simulate(model, t_end, store=need_store, **kw)
            steps = result.steps
            iters = int(result.newton_iterations.sum())
            sim_time = float(result.wall_time)
            outs = scene.outputs(result)
            names = list(outs) if outs_wanted is None else outs_wanted
            missing = [n for n in names if n not in outs]
            if missing:
                raise _FatalSpecError(f"unknown output(s) {', '.join(map(repr, missing))} "
                                      f"(this scene has: {', '.join(outs)})")
            arrays = {n: np.asarray(outs[n], dtype=float) for n in names}
            for n in names:
                values[n] = float(arrays[n][-1])
            for t, col in t_eval or ():
                for n in names:
                    values[col % n] = float(np.interp(t, result.t, arrays[n]))
            if job["trajectories"] is not None:
                traj = _write_trajectory(job["trajectories"], case["case_id"], result, outs)
        except _FatalSpecError:
            raise
        except EXPECTED_FAILURES as exc:
            status, error, message = "failed", type(exc).__name__, _first_line(exc)
            partial = getattr(exc, "result", None)
            if partial is not None:
                steps = partial.steps
                iters = int(partial.newton_iterations.sum())
                sim_time = float(partial.wall_time)
        except Exception as exc:     # a bug or an unexpected error of a user's build(): still data
            status, error, message = "error", type(exc).__name__, _first_line(exc)
        if caught:
            warn = f"{caught[0].category.__name__}: {_first_line(caught[0].message)}"
    if status != "success":
        values = _nan_outputs(job)
    row.update(values)
    row.update(steps=int(steps), newton_iterations=int(iters), wall_time=time.perf_counter() - t0,
               sim_time=sim_time, status=status, error=error, message=message, warning=warn,
               worker=worker, trajectory=traj)
    return row


def _simulate_contact(model, scene, t_end, kw):
    """A case of a model with contact elements: :func:`femb.contact.simulate`, as ``femb run`` does (the
    compiled engine refuses such models). With ``rtol`` its ``h`` is the first step's size: the case's,
    else the scene's."""
    from femb.contact import simulate

    kw = dict(kw)
    h = kw.pop("h", None)
    h = h if h is not None else scene.defaults.get("h")
    if h is None:
        raise ParameterError(f"scene '{scene.name}' has contact elements and no default h: give h (the first "
                             "step's size with rtol)")
    return simulate(model, t_end, h, **kw)


def _nan_outputs(job):
    names = job["outputs"] or ()
    values = {n: float("nan") for n in names}
    for _, col in job["t_eval"] or ():
        values.update({col % n: float("nan") for n in names})
    return values


def _write_trajectory(directory, case_id, result, outs):
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    dest = d / f"case-{case_id}.npz"
    tmp = d / f".case-{case_id}-{uuid.uuid4().hex[:8]}.npz"
    arrays = {"t": result.t, "q": result.q, "qd": result.qd, "lam": result.lam}
    arrays.update({f"out_{k}": np.asarray(v) for k, v in outs.items()})
    np.savez(tmp, **arrays)
    os.replace(tmp, dest)
    return str(dest)


def run_batch(ref, job, cases):
    """Run a batch of cases; the Dask task of :func:`sweep` (also usable serially).

    Parameters
    ----------
    ref : SceneRef
    job : dict
        ``run`` (run settings and solver options common to all cases),
        ``outputs`` (names or None), ``t_eval`` (list of (time, column pattern)),
        ``trajectories`` (directory or None), ``cache_dir`` (or None).
    cases : list of dict
        ``{"case": int, "case_id": str, "params": dict}``.

    Returns
    -------
    list of dict
        One row per case (see the module docstring), or ``[{"fatal": message}]``
        when the specification cannot work for any case (an unknown output).
    """
    if job.get("cache_dir"):
        os.environ["FEMB_CACHE_DIR"] = job["cache_dir"]
    try:
        scene = _resolved(ref)
    except Exception as exc:
        return [{"fatal": f"scene '{ref.name}' cannot be loaded on worker: {type(exc).__name__}: {_first_line(exc)}"}]
    worker = _worker_address()
    rows = []
    for case in cases:
        try:
            rows.append(_run_case(scene, ref, case, job, worker))
        except _FatalSpecError as exc:
            return [{"fatal": str(exc)}]
    return rows


# ==========================================================================
# client side
# ==========================================================================
def _case_id(ref, params, run, outputs, t_eval):
    blob = json.dumps({"scene": ref.key, "params": params, "run": run, "outputs": outputs,
                       "t_eval": t_eval}, sort_keys=True, default=repr)
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def _part_files(path):
    return sorted(p for p in Path(path).glob("part-*.parquet"))


def read_results(path):
    """Read a sweep's output directory into a DataFrame (one row per case id).

    Parameters
    ----------
    path : str or Path
        The ``out`` directory of :func:`sweep` (``part-*.parquet`` files).

    Returns
    -------
    pandas.DataFrame
        Rows of all chunk files, the first row of each case id kept, sorted by ``case``;
        ``df.attrs`` restored from the directory's ``_sweep.json`` as :func:`sweep` returns
        it (``parameters``, the varied names; ``fixed``; ``outputs``; ``seed``; ``out``), so
        that :func:`plot_results` and :func:`output_columns` tell parameters from outputs.
    """
    import pandas as pd
    import pyarrow.parquet as pq

    files = _part_files(path)
    if not files:
        df = pd.DataFrame(columns=["case", "case_id"])
    else:
        frames = [pq.read_table(f).to_pandas() for f in files]
        df = pd.concat(frames, ignore_index=True, sort=False)
        df = df.drop_duplicates("case_id", keep="first")
        df = df.sort_values("case", kind="stable").reset_index(drop=True)
    manifest = Path(path) / MANIFEST
    if manifest.is_file():
        try:
            meta = json.loads(manifest.read_text())
        except (OSError, ValueError):
            meta = {}
        df.attrs.update(parameters=list(meta.get("parameters") or []), fixed=list(meta.get("fixed") or []),
                        outputs=list(meta.get("outputs") or []), seed=meta.get("seed"), out=str(path),
                        femb_version=meta.get("femb_version"), settings=meta.get("run") or {},
                        params=meta.get("params") or {}, units=meta.get("units") or {})
    return df


class _Writer:
    """Buffers rows and writes them as Parquet chunks into a directory."""

    def __init__(self, path, flush_rows, flush_interval):
        self.path = Path(path) if path is not None else None
        self.flush_rows = flush_rows
        self.flush_interval = flush_interval
        self.buffer = []
        self.rows = []
        self.last = time.monotonic()
        self.n_files = 0
        self.stamp = time.strftime("%Y%m%dT%H%M%S") + f"-{uuid.uuid4().hex[:6]}"

    def add(self, rows):
        self.rows.extend(rows)
        if self.path is None:
            return
        self.buffer.extend(rows)
        if len(self.buffer) >= self.flush_rows or time.monotonic() - self.last >= self.flush_interval:
            self.flush()

    def flush(self):
        if self.path is None or not self.buffer or getattr(self, "failed", False):
            return
        import pandas as pd

        df = _frame(self.buffer, pd)
        dest = self.path / f"part-{self.stamp}-{self.n_files:05d}.parquet"
        tmp = self.path / f".{dest.name}.tmp"
        try:
            df.to_parquet(tmp, engine="pyarrow", index=False)
            os.replace(tmp, dest)
        except OSError as exc:
            with contextlib.suppress(OSError):
                tmp.unlink()
            self.failed = True              # one error: the final flush does not raise a second
            written = len(self.rows) - len(self.buffer)
            raise OutputError(f"out: writing {dest} failed ({exc.strerror or exc}); {written} rows in "
                              f"{self.n_files} files written before are in {self.path} (readable; "
                              f"--resume runs the rest)") from exc
        self.n_files += 1
        self.buffer = []
        self.last = time.monotonic()


def _frame(rows, pd):
    df = pd.DataFrame(rows)
    for col in df.columns:          # mixed-type parameter columns (e.g. 1 and "lu") -> strings
        if df[col].dtype == object:
            kinds = {type(v) for v in df[col] if v is not None}
            if len(kinds) > 1 and not kinds <= {int, float}:
                df[col] = df[col].map(lambda v: "" if v is None else str(v))
    return df


def _ignore_sigint_plugin():
    """Worker plugin of a local cluster: Ctrl-C in the terminal interrupts the client only.

    The client saves the finished rows and closes the cluster; without this every
    worker process of the same terminal would print its own KeyboardInterrupt.
    Re-applied by Dask to workers that restart.
    """
    from dask.distributed import WorkerPlugin

    class IgnoreSigint(WorkerPlugin):
        idempotent = True

        def setup(self, worker):
            import signal
            import threading

            if threading.current_thread() is threading.main_thread():
                signal.signal(signal.SIGINT, signal.SIG_IGN)

    return IgnoreSigint()


def _open_client(client, n_workers, cache_dir):
    """(client, owned): a Client for ``client`` (None: a new LocalCluster)."""
    from dask.distributed import Client, LocalCluster

    if client is None:
        import logging

        n = n_workers or os.cpu_count() or 1
        env = {"FEMB_CACHE_DIR": cache_dir} if cache_dir else {}
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                               dashboard_address=":0", silence_logs=logging.ERROR, env=env)
        client = Client(cluster)
        client.register_plugin(_ignore_sigint_plugin(), name="femb-sweep-ignore-sigint")
        return client, True
    if isinstance(client, str):
        try:
            return Client(client, timeout="20s"), True
        except (OSError, TimeoutError) as exc:
            raise ParameterError(f"cannot connect to the Dask scheduler at {client!r}: {_first_line(exc)}") from None
    if hasattr(client, "submit") and hasattr(client, "nthreads"):
        return client, False
    if hasattr(client, "scheduler_address"):        # a cluster object
        return Client(client), True
    raise ParameterError(f"client must be None, a dask.distributed.Client, a cluster or a scheduler "
                         f"address, got {type(client).__name__}")


def _check_names(ref, names):
    bad = [n for n in names if n in RESERVED]
    if bad:
        raise ParameterError(f"parameter name(s) {', '.join(map(repr, bad))} are result columns; rename them")
    if ref.parameters is None:
        return
    unknown = [n for n in names if n not in RUN_KEYS and n not in SOLVER_KEYS and n not in ref.parameters]
    if unknown:
        known = ", ".join(list(ref.parameters) + list(RUN_KEYS)) or "none"
        raise ParameterError(f"scene '{ref.name}' has no parameter {', '.join(map(repr, unknown))} "
                             f"(known: {known})")


def _check_solver_options(solver_options):
    """The fixed solver options of every case, validated once before any case runs
    (:class:`femb.solve.options.SolverOptions`: any of its options but the run settings ``RUN_KEYS``)."""
    from femb.solve.options import SolverOptions

    solver_options = dict(solver_options or {})
    known = [k for k in SolverOptions.NAMES if k not in RUN_KEYS]
    bad = [k for k in solver_options if k not in known]
    if bad:
        raise ParameterError(f"solver_options: unknown option(s) {', '.join(map(repr, bad))} "
                             f"(known: {', '.join(known)})")
    try:
        SolverOptions.create(None, **solver_options)
    except ParameterError as exc:
        raise ParameterError(f"solver_options: {exc}") from None
    return solver_options


def _simulate_needs_h():
    from femb.solve.solver import simulate

    p = inspect.signature(simulate).parameters.get("h")
    return p is not None and p.default is inspect.Parameter.empty


@dataclass(frozen=True)
class SweepPlan:
    """What :func:`sweep` runs and how: the design, the run settings, the outputs and the
    execution (see :func:`sweep` for each field). Build it with :meth:`create`; the values
    are checked by :func:`sweep` as it uses them."""

    grid: Mapping[str, Sequence[Any]] | None = None
    cases: Sequence[Mapping[str, Any]] | None = None
    samples: int | None = None
    ranges: Mapping[str, tuple] | None = None
    sampling: str = "lhs"
    seed: int | None = None
    params: Mapping[str, Any] | None = None
    t_end: float | None = None
    h: float | None = None
    rtol: float | None = None
    atol: float | None = None
    rho_inf: float | None = None
    solver_options: Mapping[str, Any] | None = None
    outputs: Sequence[str] | None = None
    outputs_fn: Callable[..., Any] | None = None
    t_eval: Sequence[float] | None = None
    client: Any = None
    n_workers: int | None = None
    batch_size: int | None = None
    out: str | os.PathLike | None = None
    resume: bool = False
    trajectories: str | os.PathLike | None = None
    progress: bool | Callable[..., Any] | None = None
    flush_rows: int = 2000
    flush_interval: float = 10.0
    max_attempts: int = 3
    cache_dir: str | None = None

    @classmethod
    def create(cls, plan: SweepPlan | None = None, **changes: Any) -> SweepPlan:
        """``plan`` (default: the defaults) with ``changes`` applied.

        Raises
        ------
        ParameterError
            An unknown name (naming it and the known ones), or a ``plan`` that is not a SweepPlan.
        """
        names = [f.name for f in fields(cls)]
        unknown = sorted(k for k in changes if k not in names)
        if unknown:
            raise ParameterError(f"sweep: unknown option(s) {', '.join(unknown)}; the options are "
                                 f"{', '.join(names)}")
        if plan is None:
            return cls(**changes)
        if not isinstance(plan, SweepPlan):
            raise ParameterError(f"plan must be a SweepPlan, got {type(plan).__name__}")
        return replace(plan, **changes)


def sweep(scene: str | os.PathLike | Callable[..., Any], *, plan: SweepPlan | None = None,
          **options: Any) -> DataFrame:
    """Run a scene for every case of a design on a Dask cluster; one table row per case.

    Parameters
    ----------
    scene : str, Path, Scene or callable
        A built-in scene name (``"slider_crank"``), a scene file (``.py`` with
        ``build()``), a loaded :class:`~femb.study.registry.Scene`, or a
        callable ``build(**params) -> Mechanism | Model`` (pickled to the
        workers; define it in an importable module or in ``__main__``).
    plan : SweepPlan, optional
        The options below at once (:meth:`SweepPlan.create`); keywords given as
        well change them. Every option is also a keyword of its own:
    grid : dict of str to sequence, optional
        Full-factorial grid, e.g. ``{"k": [1e3, 1e4], "rho_inf": [0.5, 0.9]}``.
    cases : sequence of dict, optional
        Explicit cases.
    samples : int, optional
        Number of samples drawn in ``ranges``.
    ranges : dict of str to tuple, optional
        ``name -> (low, high)`` or ``(low, high, "log")`` for ``samples``.
    sampling : {"lhs", "random"}
        Latin hypercube or independent uniform samples.
    seed : int, optional
        Seed of the samples (None: a fresh one, stored in ``df.attrs["seed"]``).
    params : dict, optional
        Fixed ``build()`` keywords of every case.
    t_end, h, rtol, atol, rho_inf : float, optional
        Run settings of every case (a case may override any of them). ``t_end``,
        ``h`` and ``rho_inf`` default to the scene's ``DEFAULTS``; with ``rtol``
        (or ``atol``) a case runs with adaptive steps and the scene's ``h`` is
        left out (a given ``h`` is then the first step). Each is passed to
        :func:`femb.simulate` only when set.
    solver_options : dict, optional
        Further options of :func:`femb.simulate` (``scaling``, ``max_iter``, ...: any
        :class:`femb.solve.options.SolverOptions` option but the run settings above), the
        same for every case and validated before the first case runs.
    outputs : list of str, optional
        Output names of the scene to record (default: all of them).
    outputs_fn : callable, optional
        ``outputs(result) -> dict of name -> array (nt,)`` replacing the scene's outputs.
    t_eval : sequence of float, optional
        Times at which the outputs are recorded as well (columns ``NAME@T``).
    client : None, Client, cluster or str
        None starts a :class:`~dask.distributed.LocalCluster` with ``n_workers``
        single-threaded worker processes (default: one per core) and closes it
        at the end; a ``Client`` is used as is; a string is a scheduler address
        (``"tcp://host:8786"``).
    n_workers : int, optional
        Workers of the local cluster (only with ``client=None``).
    batch_size : int, optional
        Cases per Dask task (default: about eight batches per worker thread, 1–100 cases).
    out : str or Path, optional
        Directory the rows are streamed to as Parquet chunks (see the module
        docstring). It must not hold results already unless ``resume``.
    resume : bool
        Skip the case ids already in ``out``.
    trajectories : str or Path, optional
        Directory for per-case trajectory files written by the workers.
    progress : bool or callable, optional
        True: a progress bar over cases on stderr. A callable is called as
        ``progress(done, total, rows)`` after every batch (in the client).
    flush_rows, flush_interval : int, float
        Write a chunk after this many rows or seconds.
    max_attempts : int
        Runs of a batch whose worker died before its cases become failed rows.
    cache_dir : str, optional
        ``FEMB_CACHE_DIR`` of the workers. A local cluster (``client=None``)
        passes this, or else this process's ``FEMB_CACHE_DIR``, to its
        workers; with a user's cluster it is set in each task only when given
        (a path of this machine may not exist on the workers).

    Returns
    -------
    pandas.DataFrame
        One row per case of the design (resumed ones included), sorted by
        ``case``; ``df.attrs`` holds ``parameters`` (the varied names),
        ``outputs``, ``seed``, ``out`` and ``n_new`` (cases run now).

    Raises
    ------
    ParameterError
        Bad design, unknown option, parameter or output, output directory already used
        without ``resume``, ``h`` missing while femb needs it.
    """
    import pandas as pd

    o = SweepPlan.create(plan, **options)
    ref = scene_ref(scene, o.outputs_fn)
    seed = o.seed
    if o.samples is not None and seed is None:
        seed = int(np.random.SeedSequence().entropy % (2 ** 63))
    design = make_design(o.grid, o.cases, o.samples, o.ranges, o.sampling, seed)
    params = dict(o.params or {})
    for name in params:
        _check_name(name, "params")
    varied = list(design[0])
    overlap = sorted(set(varied) & set(params))
    if overlap:
        raise ParameterError(f"parameter(s) {', '.join(map(repr, overlap))} are both fixed (params) and varied")
    _check_names(ref, varied + list(params))
    all_names = set(varied) | set(params)
    run = _run_settings(ref, o, all_names)
    outputs = _check_outputs(o.outputs, all_names)
    teval = _check_t_eval(o.t_eval, design, params, run["t_end"])
    job = {"run": run, "outputs": outputs, "t_eval": teval,
           "trajectories": str(Path(o.trajectories).resolve()) if o.trajectories is not None else None,
           "cache_dir": o.cache_dir if o.client is not None else None}
    run_for_id = {k: v for k, v in run.items() if v is not None}
    todo = []
    for i, c in enumerate(design):
        p = dict(params)
        p.update(c)
        todo.append({"case": i, "case_id": _case_id(ref, p, run_for_id, outputs,
                                                    o.t_eval and [t for t, _ in teval]), "params": p})
    ids = [c["case_id"] for c in todo]
    if len(set(ids)) != len(ids):
        raise ParameterError("the design lists the same case twice")
    record = _record(ref, varied, params, run_for_id)
    done_rows, out = [], None
    if o.out is not None:
        out = Path(o.out)
        done_rows, todo = _resumed(out, o.resume, ids, todo)
        _write_manifest(out, {
            "scene": ref.name, "scene_key": ref.key, "femb_version": record["femb_version"],
            "parameters": varied, "fixed": params, "run": run_for_id, "params": record["params"],
            "units": record["units"], "outputs": outputs, "t_eval": [t for t, _ in teval] if teval else None,
            "grid": {k: list(v) for k, v in (o.grid or {}).items()}, "samples": o.samples, "ranges": o.ranges,
            "sampling": o.sampling if o.samples else None, "seed": seed, "cases": len(design)})
    writer = _Writer(out, o.flush_rows, o.flush_interval)
    report = _Progress(o.progress, f"sweep {ref.name}", len(design), len(done_rows))
    if todo:
        # a local cluster's workers get this process's FEMB_CACHE_DIR (or cache_dir) in their
        # environment; a user's cluster keeps its workers' own unless cache_dir is given
        local_cache = o.cache_dir or os.environ.get("FEMB_CACHE_DIR") or None
        _run_on_dask(ref, job, todo, o, writer, report, local_cache)
    report.close()
    rows = done_rows + writer.rows
    df = _frame(rows, pd) if rows else pd.DataFrame(columns=["case", "case_id"])
    df = df.drop_duplicates("case_id", keep="first").sort_values("case", kind="stable").reset_index(drop=True)
    df.attrs.update(parameters=varied, fixed=list(params), outputs=outputs, seed=seed, out=str(out) if out else None,
                    n_new=len(writer.rows), **record)
    return df


def _run_settings(ref, o, all_names):
    """The run settings of every case (the scene's defaults where not given) and the solver options."""
    solver_options = _check_solver_options(o.solver_options)
    d = ref.defaults
    run = {"t_end": o.t_end if o.t_end is not None else d.get("t_end"),
           "h": o.h, "rtol": o.rtol, "atol": o.atol,
           "rho_inf": o.rho_inf if o.rho_inf is not None else d.get("rho_inf")}
    if run["h"] is None and o.rtol is None:
        run["h"] = d.get("h")
    run.update(solver_options)
    if run["t_end"] is None and "t_end" not in all_names:
        raise ParameterError(f"scene '{ref.name}' has no default t_end: give t_end")
    if run["h"] is None and "h" not in all_names:
        if o.rtol is None and "rtol" not in all_names:
            raise ParameterError(f"scene '{ref.name}' has no default h: give h (or rtol)")
        if _simulate_needs_h():
            raise ParameterError("this version of femb.simulate needs a step size h "
                                 "(adaptive steps with rtol alone are not available): give h")
    return run


def _check_outputs(outputs, all_names):
    """The output names as a list (None: all of the scene's), none clashing with other columns."""
    if outputs is None:
        return None
    outputs = [outputs] if isinstance(outputs, str) else list(outputs)
    clash = [n for n in outputs if n in RESERVED or n in all_names]
    if clash:
        raise ParameterError(f"output name(s) {', '.join(map(repr, clash))} clash with parameter or result columns")
    return outputs


def _check_t_eval(t_eval, design, params, t_end):
    """[(t, column pattern "%s@t")] for the output times within every case's [0, t_end], or None."""
    if t_eval is None:
        return None
    times = [float(t) for t in np.atleast_1d(np.asarray(t_eval, dtype=float))]
    t_ends = [c.get("t_end", params.get("t_end", t_end)) for c in design]
    t_min = min(float(t) for t in t_ends)
    for t in times:
        if not (math.isfinite(t) and 0.0 <= t <= t_min):
            raise ParameterError(f"t_eval: {t!r} lies outside [0, t_end = {t_min!r}]")
    teval = [(t, "%s@" + format(t, ".10g")) for t in times]
    if len({c for _, c in teval}) != len(teval):
        raise ParameterError("t_eval: two times give the same column name")
    return teval


def _resumed(out, resume, ids, todo):
    """Check the output directory and create it: (rows of cases already there, cases still to run)."""
    if out.exists() and not out.is_dir():
        raise ParameterError(f"out: {out} exists and is not a directory (sweep output is a directory of Parquet files)")
    existing = _part_files(out) if out.is_dir() else []
    if existing and not resume:
        raise ParameterError(f"out: {out} already holds sweep results: resume them (resume=True, --resume) or choose another directory")
    done_rows = []
    if existing:
        prev = read_results(out)
        position = {cid: i for i, cid in enumerate(ids)}
        done_rows = [r for r in prev.to_dict("records") if r["case_id"] in position]
        for r in done_rows:             # the case's position in this design (a grid may have grown)
            r["case"] = position[r["case_id"]]
        done = {r["case_id"] for r in done_rows}
        todo = [c for c in todo if c["case_id"] not in done]
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"out: cannot create {out} ({exc.strerror or exc}); nothing was run") from None
    return done_rows, todo


def _write_manifest(out, manifest):
    try:               # the first write: a read-only or full place fails here, before any case runs
        (out / MANIFEST).write_text(json.dumps(manifest, indent=2, default=repr) + "\n")
    except OSError as exc:
        raise OutputError(f"out: cannot write into {out} ({exc.strerror or exc}); nothing was run") from None


class _Progress:
    """The progress of a sweep: a bar on stderr (``progress=True``) or the user's callable
    ``progress(done, total, rows)``, called after every batch."""

    def __init__(self, progress, desc, total, n_done):
        self.callback = progress if callable(progress) else None
        self.total, self.done = total, n_done
        self.bar = None
        if progress is True:
            from femb.io.progress import progress as _progress

            self.bar = _progress(total, desc=desc, enabled=True)
            if n_done:
                self.bar.update(n_done)

    def update(self, rows):
        self.done += len(rows)
        if self.bar is not None:
            self.bar.update(len(rows))
        if self.callback is not None:
            self.callback(self.done, self.total, rows)

    def close(self):
        if self.bar is not None:
            self.bar.close()


def _record(ref, varied, fixed, run):
    """What a sweep's table carries beside its rows (``df.attrs`` and ``_sweep.json``): femb's version,
    the run and solver settings, every build parameter with its value (fixed, default, or None when
    varied: the rows hold it) and unit, and the units of parameters and outputs."""
    from femb import __version__
    from femb.study.parsing import parameter_record, plain

    names = dict(ref.parameters or {})
    for k in list(fixed) + list(varied):
        names.setdefault(k, None)
    info = {k: (d, "", ref.units.get(k, "")) for k, d in names.items()
            if k not in RUN_KEYS and k not in SOLVER_KEYS}
    params = parameter_record(info, {k: v for k, v in fixed.items() if k in info})
    for k in varied:
        if k in params:
            params[k].update(value=None, given=True, varied=True)
    return {"femb_version": __version__, "settings": plain(run), "params": params,
            "units": dict(ref.units)}


def _default_batch(n_cases, n_threads):
    return max(1, min(100, math.ceil(n_cases / (8 * max(1, n_threads)))))


def _run_on_dask(ref, job, todo, plan, writer, report, cache_dir):
    """Run the cases ``todo`` in batches on Dask (``plan``: client, n_workers, batch_size,
    max_attempts), writing their rows through ``writer`` and reporting them to ``report``."""
    from dask.distributed import as_completed

    n_workers, batch_size, max_attempts = plan.n_workers, plan.batch_size, plan.max_attempts
    cl, owned = _open_client(plan.client, n_workers, cache_dir)
    futures = {}
    try:
        n_threads = sum(cl.nthreads().values()) or (n_workers or 1)
        bs = batch_size or _default_batch(len(todo), n_threads)
        if isinstance(bs, bool) or not isinstance(bs, (int, np.integer)) or bs < 1:
            raise ParameterError(f"batch_size must be a positive integer, got {batch_size!r}")
        batches = [todo[i:i + bs] for i in range(0, len(todo), bs)]
        pending = list(reversed(batches))
        max_inflight = 2 * n_threads + 2
        token = uuid.uuid4().hex[:8]
        ac = as_completed()

        def submit(batch, attempt):
            key = f"femb-sweep-{token}-{batch[0]['case']}-a{attempt}"
            f = cl.submit(run_batch, ref, job, batch, key=key, pure=False)
            futures[f.key] = (f, batch, attempt)
            ac.add(f)

        while pending and len(futures) < max_inflight:
            submit(pending.pop(), 1)
        for f in ac:
            _, batch, attempt = futures.pop(f.key)
            rows = None
            if f.status == "finished":
                try:
                    rows = f.result()
                except Exception:           # lost between completion and gather: run again
                    rows = None
            if rows is None:
                if attempt < max_attempts:
                    submit(batch, attempt + 1)
                    f.release()
                    continue
                exc = _future_exception(f)
                rows = [_lost_row(c, job, exc) for c in batch]
            f.release()
            if rows and "fatal" in rows[0]:
                raise ParameterError(rows[0]["fatal"])
            writer.add(rows)
            report.update(rows)
            while pending and len(futures) < max_inflight:
                submit(pending.pop(), 1)
    finally:
        for f, _, _ in futures.values():
            f.cancel()
        try:
            writer.flush()
        finally:
            if owned:
                cluster = getattr(cl, "cluster", None)
                cl.close()
                if cluster is not None:
                    cluster.close()


def _future_exception(f):
    try:
        return f.exception(timeout=5)
    except BaseException as exc:  # cancelled futures raise here
        return exc


def _lost_row(case, job, exc):
    row = {"case": case["case"], "case_id": case["case_id"]}
    row.update(case["params"])
    for k in RUN_KEYS:
        if job["run"].get(k) is not None and k not in row:
            row[k] = job["run"][k]
    row.update(_nan_outputs(job))
    name = type(exc).__name__ if exc is not None else "Cancelled"
    if exc is None or name in ("KilledWorker", "CancelledError", "FutureCancelledError", "CommClosedError"):
        message = f"the worker running this case was lost ({_first_line(exc) if exc else 'cancelled'})"
    else:
        message = f"the batch of this case failed on the worker: {name}: {_first_line(exc)}"
    row.update(steps=0, newton_iterations=0, wall_time=float("nan"), sim_time=float("nan"),
               status="failed", error=name, message=message, warning="", worker="", trajectory="")
    return row


# ==========================================================================
# one-page plot
# ==========================================================================
def output_columns(df, parameters=()):
    """Names of the output columns at t_end of a sweep table (numeric, not parameters or bookkeeping)."""
    if df.attrs.get("outputs"):
        return [c for c in df.attrs["outputs"] if c in df.columns]
    skip = set(RESERVED) | set(RUN_KEYS) | set(SOLVER_KEYS) | set(parameters) | set(df.attrs.get("fixed") or ())
    fixed = set()
    for col in df.columns:
        if col in skip or "@" in col:
            continue
        if df[col].dtype.kind != "f":
            continue
        fixed.add(col)
    return [c for c in df.columns if c in fixed]


def _log_axis(values):
    v = np.asarray([x for x in values if _is_number(x)], dtype=float)
    return v.size == len(values) and v.size > 1 and np.all(v > 0) and v.max() / v.min() >= 20.0


def _fmt(v):
    return format(v, ".4g") if _is_number(v) else str(v)


def plot_results(df, path, parameters=None, outputs=None, title=None, max_outputs=6):
    """One-page PNG of a sweep: outputs against one parameter, heat maps over two.

    Parameters
    ----------
    df : pandas.DataFrame
        A table of :func:`sweep` (or :func:`read_results`).
    path : str or Path
        PNG file to write.
    parameters : list of str, optional
        The varied parameters (default ``df.attrs["parameters"]``); those with
        a single value are ignored.
    outputs : list of str, optional
        Outputs to plot (default: the output columns, at most ``max_outputs``).
    title : str, optional

    Returns
    -------
    Path

    Notes
    -----
    One varied parameter: one panel per output, the output against the
    parameter, failed cases as red crosses on the axis. Two parameters on a
    full grid: one heat map per output (failed cells blank, marked "×"). Two
    sampled parameters: the samples in the parameter plane coloured by the
    output. More parameters: each output against each parameter (scatter).
    """
    params = list(parameters if parameters is not None else df.attrs.get("parameters") or [])
    varied = [p for p in params if p in df.columns and df[p].nunique(dropna=False) > 1]
    outs = list(outputs) if outputs is not None else output_columns(df, params)[:max_outputs]
    if not outs:
        raise ParameterError("plot: the table has no output columns to plot")
    ok = (df["status"] == "success").to_numpy() if "status" in df else np.ones(len(df), bool)
    n_fail = int((~ok).sum())
    heading = title or (f"{len(df)} cases, {n_fail} failed" if n_fail else f"{len(df)} cases")
    if len(varied) <= 1:
        fig = _plot_against_one(df, varied[0] if varied else None, outs, ok)
    elif len(varied) == 2 and len(df) == df[varied[0]].nunique() * df[varied[1]].nunique() \
            and not df.duplicated(varied).any():
        fig = _plot_heat_maps(df, varied, outs, ok)
    elif len(varied) == 2:
        fig = _plot_plane(df, varied, outs, ok)
    else:
        fig = _plot_matrix(df, varied, outs, ok)
    fig.suptitle(heading, fontsize=11)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)
    return path


def _panels(n, width, height):
    """A figure for ``n`` panels, at most three a row: (figure, rows, columns)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    nc = min(3, n)
    nr = math.ceil(n / nc)
    fig = Figure(figsize=(width * nc, height * nr + 0.4), layout="constrained")
    FigureCanvasAgg(fig)
    return fig, nr, nc


def _plot_against_one(df, p, outs, ok):
    """One panel per output against the parameter ``p`` (None: against the case index); failed
    cases as red crosses on the axis."""
    fig, nr, nc = _panels(len(outs), 4.0, 3.0)
    for k, name in enumerate(outs):
        ax = fig.add_subplot(nr, nc, k + 1)
        ax.grid(True, lw=0.4, alpha=0.6)
        ax.set_ylabel(name)
        if p is None:
            ax.plot(np.arange(len(df))[ok], df[name].to_numpy()[ok], "o")
            ax.set_xlabel("case")
            continue
        x = df[p].tolist()
        numeric = all(_is_number(v) for v in x)
        xs = np.asarray(x, dtype=float) if numeric else np.arange(len(x), dtype=float)
        order = np.argsort(xs, kind="stable")
        y = df[name].to_numpy(dtype=float)
        good = order[ok[order]]
        ax.plot(xs[good], y[good], "o-", ms=4)
        bad = order[~ok[order]]
        if bad.size:
            lo = ax.get_ylim()[0]
            ax.plot(xs[bad], np.full(bad.size, lo), "x", color="tab:red", ms=7, label="failed")
            ax.legend(fontsize=8)
        if numeric and _log_axis(x):
            ax.set_xscale("log")
        if not numeric:
            ax.set_xticks(xs, [str(v) for v in x])
        ax.set_xlabel(p)
    return fig


def _plot_heat_maps(df, varied, outs, ok):
    """Two parameters on a full grid: one heat map per output (failed cells blank, marked "×")."""
    a, b = varied
    va = sorted(df[a].unique(), key=lambda v: (not _is_number(v), v if _is_number(v) else str(v)))
    vb = sorted(df[b].unique(), key=lambda v: (not _is_number(v), v if _is_number(v) else str(v)))
    ia = {v: i for i, v in enumerate(va)}
    ib = {v: i for i, v in enumerate(vb)}
    fig, nr, nc = _panels(len(outs), 4.3, 3.4)
    rows_a, rows_b = df[a].map(ia).to_numpy(), df[b].map(ib).to_numpy()
    for k, name in enumerate(outs):
        ax = fig.add_subplot(nr, nc, k + 1)
        grid = np.full((len(va), len(vb)), np.nan)
        vals = df[name].to_numpy(dtype=float)
        grid[rows_a[ok], rows_b[ok]] = vals[ok]
        im = ax.imshow(grid, origin="lower", aspect="auto", cmap="viridis")
        fig.colorbar(im, ax=ax, shrink=0.9)
        for i, j in zip(rows_a[~ok], rows_b[~ok]):
            ax.text(j, i, "×", ha="center", va="center", color="tab:red", fontsize=12)
        ax.set_yticks(range(len(va)), [_fmt(v) for v in va])
        ax.set_xticks(range(len(vb)), [_fmt(v) for v in vb], rotation=45 if len(vb) > 6 else 0)
        ax.set_ylabel(a)
        ax.set_xlabel(b)
        ax.set_title(name, fontsize=10)
    return fig


def _plot_plane(df, varied, outs, ok):
    """Two sampled parameters: the samples in the parameter plane coloured by each output."""
    a, b = varied
    fig, nr, nc = _panels(len(outs), 4.3, 3.4)
    xa, xb = df[a].to_numpy(dtype=float), df[b].to_numpy(dtype=float)
    for k, name in enumerate(outs):
        ax = fig.add_subplot(nr, nc, k + 1)
        sc = ax.scatter(xa[ok], xb[ok], c=df[name].to_numpy(dtype=float)[ok], s=18, cmap="viridis")
        fig.colorbar(sc, ax=ax, shrink=0.9)
        if (~ok).any():
            ax.plot(xa[~ok], xb[~ok], "x", color="tab:red", label="failed")
            ax.legend(fontsize=8)
        if _log_axis(list(xa)):
            ax.set_xscale("log")
        if _log_axis(list(xb)):
            ax.set_yscale("log")
        ax.set_xlabel(a)
        ax.set_ylabel(b)
        ax.set_title(name, fontsize=10)
    return fig


def _plot_matrix(df, varied, outs, ok):
    """More parameters: each output (at most four) against each parameter (at most four)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    ps, os_ = varied[:4], outs[:4]
    fig = Figure(figsize=(3.2 * len(ps), 2.6 * len(os_) + 0.4), layout="constrained")
    FigureCanvasAgg(fig)
    for i, name in enumerate(os_):
        for j, p in enumerate(ps):
            ax = fig.add_subplot(len(os_), len(ps), i * len(ps) + j + 1)
            ax.grid(True, lw=0.4, alpha=0.6)
            x = df[p].to_numpy(dtype=float)
            ax.plot(x[ok], df[name].to_numpy(dtype=float)[ok], ".", ms=4)
            if _log_axis(list(x)):
                ax.set_xscale("log")
            if i == len(os_) - 1:
                ax.set_xlabel(p)
            if j == 0:
                ax.set_ylabel(name)
    return fig


class _CallableModule(types.ModuleType):
    """Lets ``femb.sweep(...)`` work even when ``femb.sweep`` is this module (after ``import femb.study.sweep``)."""

    def __call__(self, *args, **kwargs):
        return sweep(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule
