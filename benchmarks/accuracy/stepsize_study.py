"""Step-size studies: start-up order of the reactions, tolerance proportionality, cost to a target error.

The measurements for step-size control of generalized-α, written
against femb's public API, so that the same code measures today's fixed-step
engine and, once it exists, the adaptive one::

    femb.simulate(model, t_end, h=None, *, rtol=None, atol=None, h0=None, h_max=None,
                  t_eval=None, start="consistent" | "seed", formulation="index3" | "index2",
                  rho_inf=...)

with ``result.h_steps`` (accepted step sizes) and ``result.n_rejected``.

Every study takes a ``run(scene, **options)`` callable (default: :func:`run`)
that builds a registered scene (:mod:`femb.study.registry`), integrates it
and returns a :class:`Run`. Errors are measured against the scene's
independent ``reference()`` at the stored times (accepted steps), as the
maximum over the whole run: the error at ``t_end`` alone hides the start-up
transient (stepsize.md §2).

Studies
-------
:func:`reaction_order`
    Max-over-run error of the double pendulum's ground-hinge reaction on
    [0, 0.3] s against h and its fitted order (``np.polyfit`` of the log–log
    data). Fixed steps with today's start run now; ``start="consistent"``
    needs the new API.
:func:`large_step_runs`
    What the two silent-wrong-answer scenes return at h = 0.5 s: status,
    final angle against the reference, warnings.
:func:`fixed_to_target`, :func:`adaptive_to_target`, :func:`compare_to_target`
    Steps and wall time to a target error, by log–log interpolation along a
    ladder of fixed steps and of tolerances; adaptive step counts include the
    rejected steps.
:func:`tolerance_proportionality`
    Slope of the global error (and of the step count) against rtol (adaptive).
:func:`lambda_error_vs_h`
    Relative multiplier error on Andrews' mechanism on [0, 1e-4] s for h down
    to 1e-8 s, for a given formulation (``"index3"`` runs today; ``"index2"``
    needs the new API).

The adaptive parts call the API above and raise :class:`StepControlUnavailable`
(with the missing keywords named) until femb offers it; they are never
emulated with fixed steps.

Run ``python -m femb.benchmarks.accuracy.stepsize_study [--quick]`` for the tables.

References
----------
M. Arnold, O. Brüls, Multibody Syst. Dyn. 18 (2007) 185–202 (the scheme).
E. Hairer, G. Wanner, Solving Ordinary Differential Equations II, 2nd ed.,
Springer 1996, Sect. IV.10 (work–precision, tolerance proportionality).
"""
from __future__ import annotations

import argparse
import inspect
import math
import statistics
import sys
import time
import warnings
from dataclasses import dataclass, field

import numpy as np

import femb
from femb.errors import SolverError

from femb.study.registry import Scene, load

#: Keywords of the adaptive ``femb.simulate`` (step-size control).
ADAPTIVE_KEYWORDS = ("rtol", "atol", "h0", "h_max", "t_eval", "start", "formulation")


class StepControlUnavailable(RuntimeError):
    """The installed femb has no step-size control API yet."""


def simulate_keywords():
    """Names of the keyword parameters that ``femb.simulate`` declares (set of str): those of its
    signature and, when it takes ``**kwargs``, the solver options and run settings it forwards
    (``femb.solve.options.SolverOptions.NAMES``, ``femb.solve.solver.RUN_SETTINGS``)."""
    sig = inspect.signature(femb.simulate)
    names = {p.name for p in sig.parameters.values() if p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD)}
    if any(p.kind == p.VAR_KEYWORD for p in sig.parameters.values()):
        from femb.solve.options import SolverOptions
        from femb.solve.solver import RUN_SETTINGS

        names |= set(SolverOptions.NAMES) | set(RUN_SETTINGS)
    return names


def require(*names):
    """Raise :class:`StepControlUnavailable` unless ``femb.simulate`` declares all ``names``.

    Today's fixed-step ``simulate`` passes unknown keywords to Newton
    (``rtol``/``atol`` there are Newton tolerances), so the test is on the
    declared signature, never on whether a call happens to succeed.
    """
    have = simulate_keywords()
    missing = [n for n in names if n not in have]
    sig = inspect.signature(femb.simulate)
    if "rtol" in names and sig.parameters.get("h") is not None and sig.parameters["h"].default is not None:
        missing.append("h=None (adaptive run)")
    if missing:
        raise StepControlUnavailable(
            "femb.simulate has no step-size control yet: it does not declare "
            + ", ".join(missing) + " (expected: simulate(model, t_end, h=None, *, rtol, atol, h0, h_max, "
            "t_eval, start, formulation)). This part of the study needs it and is not emulated with fixed steps.")


@dataclass
class Run:
    """One integration of a scene.

    Attributes
    ----------
    scene : Scene
    result : femb.Result
    outputs : dict of str to ndarray (nt,)
    wall : float
        Seconds around ``femb.simulate`` (model build and compile excluded).
    steps : int
        Steps taken, rejected ones included (adaptive: ``len(h_steps) + n_rejected``).
    warnings : list of str
        Warnings raised during the run.
    options : dict
    """

    scene: Scene
    result: object
    outputs: dict
    wall: float
    steps: int
    warnings: list = field(default_factory=list)
    options: dict = field(default_factory=dict)


def run(scene, *, t_end=None, h=None, rho_inf=None, params=None, **options):
    """Build, compile and integrate a registered scene; returns a :class:`Run`.

    Parameters
    ----------
    scene : str or Scene
        Registry name (or a loaded scene).
    t_end, h, rho_inf : float, optional
        Default: the scene's ``DEFAULTS``; ``h`` is left out (None) when
        ``rtol`` is given (adaptive run).
    params : dict, optional
        Keyword arguments of the scene's ``build``.
    **options
        Passed to ``femb.simulate``; adaptive keywords (:data:`ADAPTIVE_KEYWORDS`)
        are checked with :func:`require` first.

    Raises
    ------
    StepControlUnavailable
        An adaptive keyword is given and femb does not offer it yet.
    """
    sc = load(scene) if not isinstance(scene, Scene) else scene
    adaptive = [k for k in options if k in ADAPTIVE_KEYWORDS]
    if adaptive:
        require(*adaptive)
    d = sc.defaults
    t_end = d["t_end"] if t_end is None else t_end
    if h is None and "rtol" not in options:
        h = d["h"]
    rho_inf = d["rho_inf"] if rho_inf is None else rho_inf
    model = sc.model(**(params or {}))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        t0 = time.perf_counter()
        res = femb.simulate(model, t_end, h, rho_inf=rho_inf, **options)
        wall = time.perf_counter() - t0
    h_steps = getattr(res, "h_steps", None)
    steps = (len(h_steps) + int(getattr(res, "n_rejected", 0))) if h_steps is not None else res.steps
    return Run(sc, res, sc.outputs(res), wall, steps, [str(w.message) for w in caught],
               dict(options, t_end=t_end, h=h, rho_inf=rho_inf, params=params or {}))


def max_error(r, names, at="max"):
    """Max over ``names`` of |output − reference|, over the stored times (``at="max"``) or at t_end (``"end"``)."""
    ref = r.scene.reference(r.result.t, **r.options.get("params", {}))
    err = [np.abs(np.asarray(r.outputs[n]) - np.asarray(ref[n])) for n in names]
    if at == "end":
        return float(max(e[-1] for e in err))
    if at != "max":
        raise ValueError(f"at must be 'max' or 'end', got {at!r}")
    return float(max(np.max(e) for e in err))


def fit_order(x, y):
    """Slope of log y against log x by least squares (``np.polyfit``); nan with < 2 finite points."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    ok = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    if ok.sum() < 2:
        return float("nan")
    return float(np.polyfit(np.log(x[ok]), np.log(y[ok]), 1)[0])


def loglog_interpolate(x, y, target):
    """x at which the piecewise log–log line through (x, y) first reaches y = target (nan if never).

    ``y`` is an error decreasing along the ladder (x: steps or wall time).
    """
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    order = np.argsort(x)
    x, y = x[order], y[order]
    for i in range(len(x) - 1):
        y0, y1 = y[i], y[i + 1]
        if not (np.isfinite(y0) and np.isfinite(y1)):
            continue
        if y0 >= target >= y1 and y0 > y1:
            s = (math.log(target) - math.log(y0)) / (math.log(y1) - math.log(y0))
            return float(math.exp(math.log(x[i]) + s * (math.log(x[i + 1]) - math.log(x[i]))))
    if len(y) and np.isfinite(y[0]) and y[0] <= target:
        return float(x[0])      # already below the target at the cheapest run: an upper bound
    return float("nan")


# ---------------------------------------------------------------------------------------- studies
def reaction_order(scene="double_pendulum", hs=(8e-3, 4e-3, 2e-3, 1e-3, 5e-4), rho_inf=0.8, t_end=0.3,
                   names=None, start=None, run=run):
    """Max-over-run multiplier error against h and its fitted order.

    Parameters
    ----------
    scene : str
    hs : sequence of float
        Fixed step sizes (s).
    rho_inf : float
    t_end : float
        The window [0, t_end] (s) over which the maximum is taken.
    names : list of str, optional
        Multiplier outputs (default: the scene's ``CONVERGENCE["lambda"]``).
    start : {"consistent", "seed"}, optional
        Passed to ``simulate`` (new API); None runs today's start.
    run : callable

    Returns
    -------
    dict
        ``rows`` (h, max_err, end_err, peak reference value), ``order`` (max
        over the run), ``order_end`` (at t_end), and the settings.
    """
    sc = load(scene)
    names = list(names or sc.convergence_setup()["lambda"])
    extra = {} if start is None else {"start": start}
    rows = []
    for h in hs:
        r = run(scene, t_end=t_end, h=h, rho_inf=rho_inf, **extra)
        ref = sc.reference(r.result.t)
        err = np.max([np.abs(r.outputs[n] - ref[n]) for n in names], axis=0)
        rows.append({"h": h, "max_err": float(err.max()), "end_err": float(err[-1]),
                     "t_of_max": float(r.result.t[int(np.argmax(err))]),
                     "ref_peak": float(max(np.max(np.abs(ref[n])) for n in names))})
    hh = [r["h"] for r in rows]
    return {"scene": scene, "rho_inf": rho_inf, "t_end": t_end, "names": names, "start": start or "today",
            "rows": rows, "order": fit_order(hh, [r["max_err"] for r in rows]),
            "order_end": fit_order(hh, [r["end_err"] for r in rows])}


def large_step_runs(scenes=("two_bar_pendulum", "spring_pendulum"), rho_infs=(0.5, 0.7, 0.8, 0.9), run=run):
    """The too-large fixed step of each scene (its ``LARGE_STEP``): status, final angle, warnings.

    Returns
    -------
    list of dict
        scene, rho_inf, h, t_end, status ("success" / the error's class), the
        final ``phi1`` and its reference value, the warnings raised.
    """
    rows = []
    for name in scenes:
        sc = load(name)
        ls = getattr(sc.module, "LARGE_STEP", {"t_end": sc.defaults["t_end"], "h": 0.5})
        ref = float(sc.reference(np.array([0.0, ls["t_end"]]))["phi1"][-1])
        for rho in rho_infs:
            row = {"scene": name, "rho_inf": rho, "h": ls["h"], "t_end": ls["t_end"], "reference": ref}
            try:
                r = run(name, t_end=ls["t_end"], h=ls["h"], rho_inf=rho)
                row.update({"status": r.result.status, "phi1": float(r.outputs["phi1"][-1]),
                            "warnings": r.warnings})
            except SolverError as exc:
                row.update({"status": type(exc).__name__, "phi1": float("nan"),
                            "warnings": [str(exc).splitlines()[0]]})
            rows.append(row)
    return rows


def fixed_to_target(scene, targets, names, hs, rho_inf=None, t_end=None, params=None, at="max", repeats=1,
                    extrapolate=False, run=run):
    """Steps and wall time of fixed-step runs to reach each target error (log–log interpolation).

    The wall time is the median of ``repeats`` runs. With ``extrapolate``, a
    target below the whole ladder is reached along the power law of its two
    finest runs (fixed steps converge with a known order, so this is how the
    cost of very small steps is predicted without running them); the result
    says so (``"extrapolated"``).

    Returns
    -------
    dict
        ``points`` (h, steps, wall, err or failure) and ``at_target``
        {target: {"steps", "wall"}}.
    """
    pts = []
    for h in hs:
        try:
            r = run(scene, t_end=t_end, h=h, rho_inf=rho_inf, params=params)
            walls = [r.wall] + [run(scene, t_end=t_end, h=h, rho_inf=rho_inf, params=params).wall
                                for _ in range(repeats - 1)]
            pts.append({"h": h, "steps": r.steps, "wall": statistics.median(walls), "err": max_error(r, names, at)})
        except SolverError as exc:
            pts.append({"h": h, "steps": None, "wall": None, "err": float("nan"),
                        "failed": str(exc).splitlines()[0]})
    return {"scene": scene, "mode": "fixed", "at": at, "points": pts,
            "at_target": _at_targets(pts, targets, extrapolate)}


def adaptive_to_target(scene, targets, names, rtols, atol_factor=1.0, rho_inf=None, t_end=None, params=None,
                       h_max=None, at="max", repeats=1, run=run):
    """As :func:`fixed_to_target` along a ladder of tolerances (atol = atol_factor·rtol).

    Raises
    ------
    StepControlUnavailable
        Until ``femb.simulate`` has the adaptive API.
    """
    require("rtol", "atol", *(("h_max",) if h_max is not None else ()))
    pts = []
    for tol in rtols:
        extra = {"h_max": h_max} if h_max is not None else {}
        try:
            kw = dict(t_end=t_end, rho_inf=rho_inf, params=params, rtol=tol, atol=atol_factor * tol, **extra)
            r = run(scene, **kw)
            walls = [r.wall] + [run(scene, **kw).wall for _ in range(repeats - 1)]
            pts.append({"rtol": tol, "steps": r.steps, "wall": statistics.median(walls), "err": max_error(r, names, at),
                        "rejected": int(getattr(r.result, "n_rejected", 0))})
        except SolverError as exc:
            pts.append({"rtol": tol, "steps": None, "wall": None, "err": float("nan"),
                        "failed": str(exc).splitlines()[0]})
    return {"scene": scene, "mode": "adaptive", "at": at, "points": pts, "at_target": _at_targets(pts, targets)}


def loglog_extrapolate(x, y, target):
    """x at which the power law through the two points of largest x reaches y = target (float)."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    i = np.argsort(x)[-2:]
    p = fit_order(x[i], y[i])
    if not (np.isfinite(p) and p < 0):
        return float("nan")
    return float(x[i[-1]] * (target / y[i[-1]]) ** (1.0 / p))


def _at_targets(pts, targets, extrapolate=False):
    ok = [p for p in pts if p.get("steps") is not None and np.isfinite(p["err"])]
    out = {}
    for tgt in targets:
        row = {"extrapolated": False}
        for key in ("steps", "wall"):
            xs, ys = [p[key] for p in ok], [p["err"] for p in ok]
            v = loglog_interpolate(xs, ys, tgt)
            if extrapolate and not np.isfinite(v) and len(ok) >= 2 and tgt < min(ys):
                v, row["extrapolated"] = loglog_extrapolate(xs, ys, tgt), True
            row[key] = v
        out[tgt] = row
    return out


def compare_to_target(scene, targets, names, hs, rtols, extrapolate=False, **kw):
    """Fixed against adaptive: steps and wall time to each target and the gain (fixed/adaptive).

    Raises
    ------
    StepControlUnavailable
        Until the adaptive API exists (the fixed part is computed first and
        is available from :func:`fixed_to_target`).
    """
    require("rtol", "atol")
    run_ = kw.pop("run", run)
    h_max = kw.pop("h_max", None)
    fx = fixed_to_target(scene, targets, names, hs, run=run_, extrapolate=extrapolate, **kw)
    ad = adaptive_to_target(scene, targets, names, rtols, h_max=h_max, run=run_, **kw)
    gain = {t: {k: fx["at_target"][t][k] / ad["at_target"][t][k] for k in ("steps", "wall")} for t in targets}
    return {"fixed": fx, "adaptive": ad, "gain": gain}


def femb_reference(scene, t_end, params=None, n_samples=200, run=run):
    """A fine fixed-step femb run as the yardstick of a scene without ``reference()``.

    The step is a quarter of the smallest step of the scene's ``CONVERGENCE``
    ladder (or of its default step). Returns the sample times (about
    ``n_samples`` of the stored steps), the outputs there, and a description.
    """
    sc = load(scene)
    cs = sc.convergence_setup()
    h_ref = min(cs["h"] or [sc.defaults["h"]]) / 4.0
    fine = run(scene, t_end=t_end, h=h_ref, params=params)
    stride = max(1, (len(fine.result.t) - 1) // n_samples)
    idx = np.unique(np.append(np.arange(0, len(fine.result.t), stride), len(fine.result.t) - 1))
    return (fine.result.t[idx], {k: np.asarray(v)[idx] for k, v in fine.outputs.items()},
            f"femb itself, fixed h = {h_ref:g} s")


def tolerance_proportionality(scenes=("andrews", "slider_crank", "spin_up"), rtols=(1e-3, 1e-4, 1e-5, 1e-6, 1e-7),
                              atol_factor=1.0, t_end=None, run=run):
    """Slope of the max-over-run position error (and of the step count) against rtol, per scene.

    Positions are the scene's ``CONVERGENCE["q"]`` outputs; ``t_end`` defaults
    to the scene's ``CONVERGENCE["t_end"]``. The error is taken against the
    scene's ``reference()`` at the accepted steps; a scene without one (spin-up)
    is compared at about 200 output times (``t_eval``, so interpolation is
    included) with a fine fixed-step femb run (:func:`femb_reference`).

    Raises
    ------
    StepControlUnavailable
        Until ``femb.simulate`` has the adaptive API.
    """
    require("rtol", "atol")
    out = {}
    for name in scenes:
        sc = load(name)
        cs = sc.convergence_setup()
        te = cs["t_end"] if t_end is None else t_end
        yardstick = None if sc.has_reference else femb_reference(name, te, run=run)
        rows = []
        for tol in rtols:
            if yardstick is None:
                r = run(name, t_end=te, rtol=tol, atol=atol_factor * tol)
                err = max_error(r, cs["q"])
            else:
                require("t_eval")
                t_s, ref, _ = yardstick
                r = run(name, t_end=te, rtol=tol, atol=atol_factor * tol, t_eval=t_s)
                err = float(max(np.max(np.abs(np.asarray(r.outputs[n]) - ref[n])) for n in cs["q"]))
            rows.append({"rtol": tol, "err": err, "steps": r.steps,
                         "rejected": int(getattr(r.result, "n_rejected", 0)), "wall": r.wall})
        tl = [r["rtol"] for r in rows]
        out[name] = {"rows": rows, "slope_err": fit_order(tl, [r["err"] for r in rows]),
                     "slope_steps": fit_order(tl, [r["steps"] for r in rows]),
                     "reference": "the scene's reference()" if yardstick is None else yardstick[2]}
    return out


def scene_orders(scenes=None, start=None, run=run):
    """Fitted orders of the max-over-run errors in q and λ, fixed steps, for every scene with a reference.

    Steps and outputs follow each scene's ``CONVERGENCE`` (its ``t_end``, its
    ladder of h, its q and λ names); scenes without ``reference()`` are listed
    as skipped. ``start`` is passed to ``simulate`` (new API) when given.

    Returns
    -------
    dict
        scene -> {"h", "err_q", "err_lambda", "order_q", "order_lambda"} or {"skipped": reason}.
    """
    from femb.study.registry import names as all_names

    extra = {} if start is None else {"start": start}
    out = {}
    for name in scenes or all_names():
        sc = load(name)
        if not sc.has_reference:
            out[name] = {"skipped": "no independent reference()"}
            continue
        cs = sc.convergence_setup()
        eq, el, hs = [], [], []
        for h in cs["h"]:
            try:
                r = run(name, t_end=cs["t_end"], h=h, **extra)
            except SolverError as exc:
                out.setdefault(name, {}).setdefault("failed", []).append(f"h = {h:g}: {str(exc).splitlines()[0]}")
                continue
            hs.append(h)
            eq.append(max_error(r, cs["q"]))
            el.append(max_error(r, cs["lambda"]) if cs["lambda"] else float("nan"))
        out[name] = dict(out.get(name, {}), h=hs, err_q=eq, err_lambda=el, order_q=fit_order(hs, eq),
                         order_lambda=fit_order(hs, el), q=cs["q"], **{"lambda": cs["lambda"]})
    return out


def lambda_error_vs_h(formulation="index3", hs=(1e-5, 1e-6, 1e-7, 3e-8, 1e-8), t_end=1e-4, rho_inf=0.7, run=run):
    """Relative multiplier error on Andrews' mechanism at t_end (s) for h → 1e-8 s.

    ``formulation="index3"`` is today's scheme and runs on the fixed-step
    engine (the keyword is passed only once ``simulate`` declares it);
    ``"index2"`` needs the new API.

    Returns
    -------
    dict
        ``rows`` (h, steps, wall, lam_err_rel, angle_err, or failure).
    """
    from femb.benchmarks.scenes.planar import andrews as A

    extra = {}
    if "formulation" in simulate_keywords():
        extra["formulation"] = formulation
    elif formulation != "index3":
        require("formulation")
    ref = A.reference(np.array([t_end]))
    lam_ref = np.array([ref[n][-1] for n in A.LAMBDA_NAMES])
    ang_ref = np.array([ref[n][-1] for n in A.ANGLE_NAMES])
    rows = []
    for h in hs:
        try:
            r = run("andrews", t_end=t_end, h=h, rho_inf=rho_inf, store=False, **extra)
        except SolverError as exc:
            rows.append({"h": h, "failed": str(exc).splitlines()[0]})
            continue
        lam = np.array([r.outputs[n][-1] for n in A.LAMBDA_NAMES])
        ang = np.array([r.outputs[n][-1] for n in A.ANGLE_NAMES])
        rows.append({"h": h, "steps": r.steps, "wall": r.wall,
                     "lam_err_rel": float(np.abs(lam - lam_ref).max() / np.abs(lam_ref).max()),
                     "angle_err": float(np.abs(ang - ang_ref).max())})
    return {"formulation": formulation, "t_end": t_end, "rho_inf": rho_inf, "rows": rows}


# ---------------------------------------------------------------------------------------- tables
def _g(x, spec=".3g"):
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "–"
    return format(x, spec)


def table(headers, rows):
    """A Markdown table (str)."""
    lines = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def format_reaction_order(res):
    rows = [(_g(r["h"]), _g(r["max_err"]), _g(r["t_of_max"]), _g(r["end_err"]), _g(r["ref_peak"]))
            for r in res["rows"]]
    head = (f"{res['scene']}, ρ∞ = {res['rho_inf']}, start: {res['start']}, max over [0, {res['t_end']}] s of "
            f"{', '.join(res['names'])}: order {res['order']:.2f} (at t_end: {res['order_end']:.2f})")
    return head + "\n\n" + table(["h (s)", "max err (N)", "t of max (s)", "err at t_end (N)", "max |ref| (N)"], rows)


def format_large_step(rows):
    body = [(r["scene"], r["rho_inf"], r["h"], r["status"], _g(r["phi1"], ".4g"), _g(r["reference"], ".4g"),
             "; ".join(w[:90] for w in r["warnings"]) or "none") for r in rows]
    return table(["scene", "ρ∞", "h (s)", "status", "φ₁(t_end) (rad)", "reference (rad)", "warnings / error"], body)


def format_target(res, targets):
    pts = res["points"]
    key = "h" if res["mode"] == "fixed" else "rtol"
    body = [(_g(p[key]), p.get("steps") if p.get("steps") is not None else "–", _g(p.get("wall")),
             _g(p["err"]), p.get("failed", "")[:80]) for p in pts]
    s = table([key, "steps", "wall (s, median)", "max err", "failure"], body)
    s += "\n\n" + table(["target", "steps (interp.)", "wall (s, interp.)", "extrapolated"],
                        [(_g(t), _g(res["at_target"][t]["steps"], ".0f"), _g(res["at_target"][t]["wall"]),
                          "yes" if res["at_target"][t].get("extrapolated") else "no") for t in targets])
    return s


def format_lambda(res):
    body = [(_g(r["h"]), r.get("steps", "–"), _g(r.get("wall")), _g(r.get("lam_err_rel")), _g(r.get("angle_err")),
             r.get("failed", "")[:80]) for r in res["rows"]]
    return (f"Andrews, {res['formulation']}, ρ∞ = {res['rho_inf']}, t_end = {res['t_end']} s\n\n"
            + table(["h (s)", "steps", "wall (s)", "rel. λ err", "angle err (rad)", "failure"], body))


def format_scene_orders(res):
    body = []
    for name, r in res.items():
        if "skipped" in r:
            body.append((name, "–", "–", "–", "–", "skipped: " + r["skipped"]))
            continue
        hs = r["h"]
        body.append((name, f"{_g(max(hs))} … {_g(min(hs))}" if hs else "–", _g(r["order_q"], ".2f"),
                     _g(r["order_lambda"], ".2f"), _g(r["err_lambda"][-1]) if hs else "–",
                     "; ".join(r.get("failed", []))[:80]))
    return table(["scene", "h (s)", "order q", "order λ", "λ err at finest h", "notes"], body)


#: Work–precision problems of stepsize.md §8 and Andrews' mechanism: scene, build parameters, t_end, outputs
#: (None: the scene's CONVERGENCE["q"]), targets, where the error is taken ("max" over the run or at "end").
WORK_PRECISION = {
    "W1 pendulum near the top": ("pendulum", {"psi0": math.pi - 0.01}, 7.0, ["psi"], [1e-2], "max"),
    "W2 force pulse": ("force_pulse", {}, 3.0, ["phi1"], [1e-3, 1e-4], "max"),
    "W2 force pulse, reaction": ("force_pulse", {}, 3.0, ["R_pivot_x", "R_pivot_y"], [1e-2, 1e-3], "max"),
    "W3 bead attractor": ("bead_attractor", {}, 10.0, ["phi1"], [1e-2, 1e-3], "max"),
    "Andrews (angles at t = 0.03 s)": ("andrews", {}, 0.03, None, [1e-6], "end"),
}


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m femb.benchmarks.accuracy.stepsize_study", description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer step sizes")
    ap.add_argument("--only", nargs="*", default=None,
                    help="parts to run: order large target lambda proportionality scenes (default: all)")
    args = ap.parse_args(argv)
    parts = set(args.only or ["order", "large", "target", "lambda", "proportionality", "scenes"])
    repeats = 1 if args.quick else 3
    out = sys.stdout
    unavailable = []

    def adaptive(label, fn):
        try:
            return fn()
        except StepControlUnavailable as exc:
            unavailable.append(label)
            print(f"\n{label}: NOT RUN. {exc}", file=out)
            return None

    if "order" in parts:
        hs = (8e-3, 4e-3, 2e-3, 1e-3) if args.quick else (8e-3, 4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4)
        print("## Peak reaction error of the double pendulum (fixed steps)\n", file=out)
        for rho in (0.8, 0.95):
            print(format_reaction_order(reaction_order(hs=hs, rho_inf=rho)) + "\n", file=out)
        print("### the same, driving torque and pivot force of the driven four-bar\n", file=out)
        print(format_reaction_order(reaction_order("fourbar_driven", hs=hs, rho_inf=0.8)) + "\n", file=out)
        for rho in (0.8, 0.95):
            res = adaptive(f"consistent start, ρ∞ = {rho}",
                           lambda: reaction_order(hs=hs, rho_inf=rho, start="consistent"))
            if res:
                print(format_reaction_order(res) + "\n", file=out)
    if "large" in parts:
        print("## Too large fixed steps (h = 0.5 s)\n", file=out)
        print(format_large_step(large_step_runs()) + "\n", file=out)
    if "target" in parts:
        for label, (scene, params, t_end, names, targets, at) in WORK_PRECISION.items():
            sc = load(scene)
            names = names or sc.convergence_setup()["q"]
            if scene == "andrews":
                hs = [4e-5, 2e-5, 1e-5, 5e-6] if args.quick else [1e-4, 5e-5, 2e-5, 1e-5, 5e-6, 2.5e-6]
            elif args.quick:
                hs = [8e-3, 4e-3, 2e-3]
            else:
                hs = [1.6e-2, 8e-3, 4e-3, 2e-3, 1e-3, 5e-4]
            where = "max over the run" if at == "max" else "at t_end"
            print(f"## {label}: fixed steps to target ({', '.join(names)}, {where})\n", file=out)
            fx = fixed_to_target(scene, targets, names, hs, t_end=t_end, params=params, at=at, repeats=repeats,
                                 extrapolate=True)
            print(format_target(fx, targets) + "\n", file=out)
            rt = [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8]
            h_max = getattr(sc.module, "H_MAX", None)
            res = adaptive(f"{label}: adaptive to target",
                           lambda: adaptive_to_target(scene, targets, names, rt, t_end=t_end, params=params,
                                                      h_max=h_max, at=at, repeats=repeats))
            if res:
                print(format_target(res, targets) + "\n", file=out)
    if "lambda" in parts:
        hs = (1e-5, 1e-6, 1e-7) if args.quick else (1e-5, 1e-6, 3e-7, 1e-7, 3e-8, 1e-8)
        print("## Multiplier error as h → 0\n", file=out)
        print(format_lambda(lambda_error_vs_h("index3", hs=hs)) + "\n", file=out)
        res = adaptive("index-2 formulation", lambda: lambda_error_vs_h("index2", hs=hs))
        if res:
            print(format_lambda(res) + "\n", file=out)
    if "proportionality" in parts:
        res = adaptive("tolerance proportionality", tolerance_proportionality)
        if res:
            for name, r in res.items():
                print(f"{name}: slope of error against rtol {r['slope_err']:.2f}, of steps {r['slope_steps']:.2f}",
                      file=out)
    if "scenes" in parts:
        print("\n## Fitted orders of the max-over-run errors, fixed steps, every scene with a reference\n", file=out)
        print(format_scene_orders(scene_orders()) + "\n", file=out)
        res = adaptive("scene orders with the consistent start", lambda: scene_orders(start="consistent"))
        if res:
            print(format_scene_orders(res) + "\n", file=out)
    if unavailable:
        print(f"\nAdaptive parts not run ({len(unavailable)}): " + "; ".join(unavailable), file=out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
