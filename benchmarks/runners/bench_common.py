"""What the benchmark suite's runners share: the floor that work_precision.py, stress.py and
adaptive_suite.py import (and that imports none of them).

JSON-ready values (:func:`clean`), the first line of an error, a scene's Newton
options, a timed ``femb.simulate``, a work–precision case's sampled outputs and
errors against its reference, Andrews' headline error and the fixed-step search,
a stress criterion with its verdict and the matplotlib module with the Agg
backend. Moved here unchanged from ``work_precision.py`` and ``stress.py`` so
that the three runners import each other one way only (``adaptive_suite`` →
here; ``stress`` → ``adaptive_suite``, here; ``work_precision`` →
``adaptive_suite``, here).
"""
from __future__ import annotations

import inspect
import math
import time
import warnings

import numpy as np

from femb.errors import ParameterWarning

#: output groups of a work–precision study
GROUPS = ("positions", "velocities", "multipliers")

#: verdicts of a stress criterion
PASS, FAIL, FINDING = "PASS", "FAIL", "FINDING"


def clean(x):
    """JSON-ready copy: numpy scalars/arrays to Python, NaN/inf to None."""
    if isinstance(x, dict):
        return {str(k): clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [clean(v) for v in x]
    if isinstance(x, np.ndarray):
        return clean(x.tolist())
    if isinstance(x, (np.bool_, bool)):
        return bool(x)
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        v = float(x)
        return v if math.isfinite(v) else None
    return x


def first_line(exc):
    text = str(exc)
    return text.splitlines()[0] if text else type(exc).__name__


def scene_newton_options(scene, params=None):
    """Solver options a scene asks for, if any.

    A scene module may define ``SOLVER_OPTIONS`` (dict) or a callable
    ``newton_options(...)``; the callable's parameters are filled from the
    scene's ``build`` defaults (and ``params``) by name.
    """
    mod = scene.module
    opts = getattr(mod, "SOLVER_OPTIONS", None)
    if isinstance(opts, dict):
        return dict(opts)
    fn = getattr(mod, "newton_options", None)
    if not callable(fn):
        return {}
    known = {k: v for k, v in scene.parameters().items() if v is not inspect.Parameter.empty}
    known.update(params or {})
    try:
        sig = inspect.signature(fn)
        kwargs = {p: known[p] for p in sig.parameters if p in known}
        out = fn(**kwargs)
    except Exception:     # a scene helper we cannot call: run with femb's defaults
        return {}
    return dict(out) if isinstance(out, dict) else {}


def simulate_timed(model, t_end, h, *, rho_inf, scaling=True, stride=1, store=True, options=None,
                   observer=None):
    """``femb.simulate`` with the wall time of the call; ParameterWarning silenced for ρ∞ = 1."""
    from femb.solve.solver import simulate

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ParameterWarning)
        t0 = time.perf_counter()
        res = simulate(model, t_end, h, rho_inf=rho_inf, scaling=scaling, stride=stride, store=store,
                       observer=observer, **(options or {}))
        wall = time.perf_counter() - t0
    return res, wall


def _groups_from_outputs(scene, names):
    setup = scene.convergence_setup(list(names))
    pos = [n for n in setup["q"] if n in names]
    lam = [n for n in setup["lambda"] if n in names]
    vel = ([n for n in setup["v"] if n in names] if "v" in setup
           else [n + "_d" for n in pos if n + "_d" in names])
    return {"positions": pos, "velocities": vel, "multipliers": lam}


def _sample_outputs(case, result):
    """Outputs of a femb run at the sample times: dict name -> array (ns+1, ...)."""
    ns1 = case.n_samples + 1
    if case.mode == "coordinates":
        return {"q": result.q, "qd": result.qd, "lam": result.lam}
    outs = case.scene.outputs(result)
    out = {}
    for k, v in outs.items():
        v = np.atleast_1d(np.asarray(v, dtype=float))
        if v.shape[0] == ns1:
            out[k] = v
        else:                      # a scene that reports only final values: final sample only
            arr = np.full(ns1, np.nan)
            arr[-1] = v.reshape(-1)[-1]
            out[k] = arr
    return out


def errors(case, outs):
    """Errors of sampled outputs against the case's reference (see the module docstring).

    Returns
    -------
    dict
        group -> {"final_abs", "final_rel", "max_abs", "max_rel"} (None when
        the group is empty or not available).
    """
    ns1 = case.n_samples + 1
    res = {}
    for g in GROUPS:
        names = case.groups.get(g) or []
        if outs is None or not names or any(n not in outs for n in names):
            res[g] = {"final_abs": None, "final_rel": None, "max_abs": None, "max_rel": None}
            continue
        X = np.column_stack([np.asarray(outs[n], dtype=float).reshape(ns1, -1) for n in names])
        R = np.column_stack([np.asarray(case.reference[n], dtype=float).reshape(ns1, -1) for n in names])
        with np.errstate(invalid="ignore"):
            E = np.abs(X - R)
        e_t = np.array([np.nanmax(row) if np.any(np.isfinite(row)) else np.nan for row in E])
        if not np.isfinite(e_t[-1]) and np.all(np.isfinite(X[-1])):
            e_t[-1] = np.inf
        fin = float(e_t[-1])
        mx = float(np.nanmax(e_t)) if np.any(np.isfinite(e_t)) else np.nan
        s_fin = float(np.max(np.abs(R[-1])))
        s_run = float(np.max(np.abs(R)))
        res[g] = {"final_abs": fin, "final_rel": fin / s_fin if s_fin > 0 else fin,
                  "max_abs": mx, "max_rel": mx / s_run if s_run > 0 else mx}
    return res


def _andrews_angle_error(outs):
    from femb.benchmarks.references.andrews import PUBLISHED_T003
    from femb.benchmarks.scenes.planar.andrews import ANGLE_NAMES

    ang = np.array([np.asarray(outs[n], dtype=float).reshape(-1)[-1] for n in ANGLE_NAMES])
    return float(np.max(np.abs(ang - PUBLISHED_T003["angles"])))


def _fixed_step_search(run, n_guess, target, max_tries=8):
    """Smallest-cost fixed-step run meeting ``target``: start at n_guess, grow by 10 %."""
    n = int(n_guess)
    tried = []
    for _ in range(max_tries):
        err, wall = run(n)
        tried.append({"steps": n, "error": err, "wall_s": wall})
        if err is not None and err <= target:
            return n, tried
        n = int(math.ceil(n * 1.1))
    return None, tried


def criterion(text, passed, measured, finding=None, note=""):
    """One criterion with its verdict.

    Parameters
    ----------
    text : str
        The criterion, written before the measurement.
    passed : bool
    measured : str
        The measured figures, one line.
    finding : str, optional
        The diagnosis when the criterion fails (makes the verdict FINDING).
    note : str
        Additional context (shown in the report).
    """
    if passed:
        v = PASS
    else:
        v = FINDING if finding else FAIL
    out = {"criterion": text, "measured": measured, "verdict": v}
    if not passed and finding:
        out["finding"] = finding
    if note:
        out["note"] = note
    return out


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


#: superscript digits for the plain-text decade labels of :func:`save_figure`
_SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def _decade_text(x):
    """Plain-text label of a positive tick value: ``10⁻³``, ``2×10⁻³``; ``20``, ``500`` from 1 to 10⁴."""
    if 1.0 <= x < 1e4:
        return f"{x:g}"
    e = math.floor(math.log10(x) + 1e-9)
    c = round(x / 10.0 ** e, 6)
    d = "10" + str(e).translate(_SUPERSCRIPT)
    return d if c == 1.0 else f"{c:g}×{d}"


def _plain_log_formatter(**kw):
    """A ``matplotlib.ticker.LogFormatter`` (its choice of which ticks to label) writing
    :func:`_decade_text` labels instead of math text."""
    from matplotlib.ticker import LogFormatter

    class PlainLogFormatter(LogFormatter):
        def __call__(self, x, pos=None):
            s = super().__call__(x, pos)
            return _decade_text(x) if s and x > 0 else s

    return PlainLogFormatter(**kw)


#: :func:`save_figure` gives log axes minor ticks at 2 and 5 and plain-text labels; False keeps
#: matplotlib's defaults (ticks at 2 … 9, math-text labels), for the comparison of
#: :mod:`femb.benchmarks.runners.figure_cost`
PLAIN_LOG_AXES = True


def save_figure(fig, path, dpi=90):
    """Write one of the suite's figures and close it.

    Every logarithmic axis gets minor ticks at 2 and 5 per decade (not 2 … 9) and
    plain-text labels such as ``10⁻³`` and ``2×10⁻³`` (not math text): the tick
    objects and the math-text parser took about half of the time of the suite's
    log–log figures, and more than a third of the time of ``femb bench --quick``.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    path : str or Path
    dpi : float
    """
    import matplotlib.pyplot as plt
    from matplotlib.ticker import LogLocator

    for ax in fig.axes if PLAIN_LOG_AXES else ():
        for axis, scale in ((ax.xaxis, ax.get_xscale()), (ax.yaxis, ax.get_yscale())):
            if scale == "log":
                axis.set_minor_locator(LogLocator(subs=(2.0, 5.0)))
                axis.set_major_formatter(_plain_log_formatter())
                axis.set_minor_formatter(_plain_log_formatter(labelOnlyBase=False, minor_thresholds=(1, 0.4)))
    fig.savefig(path, dpi=dpi)
    plt.close(fig)


def margins(fig, left, right, bottom, top, wspace=0.0, hspace=0.0):
    """Place a figure's grid of axes with margins and gaps given in inches.

    Instead of ``tight_layout``: that measures every tick label on a dry draw
    before the real one, which doubled the cost of the suite's log–log figures
    (their minor ticks and math-text labels); fixed margins draw once.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        With axes from ``subplots`` (one grid).
    left, right, bottom, top : float
        Margins between the figure's edges and the grid (in).
    wspace, hspace : float
        Gaps between columns and between rows of the grid (in).
    """
    w, h = fig.get_size_inches()
    grid = fig.axes[0].get_subplotspec().get_gridspec()
    nrows, ncols = grid.get_geometry()
    aw = (w - left - right - (ncols - 1) * wspace) / ncols      # one axes' width and height (in)
    ah = (h - top - bottom - (nrows - 1) * hspace) / nrows
    fig.subplots_adjust(left=left / w, right=1.0 - right / w, bottom=bottom / h, top=1.0 - top / h,
                        wspace=wspace / aw, hspace=hspace / ah)
