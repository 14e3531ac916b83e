"""h-convergence studies of the generalized-α scheme on benchmark scenes.

The study behind the seed's Figs. 3 and 9: run a scene with a sequence of
fixed step sizes, measure the relative errors at the final time of a set of
coordinates and of a set of Lagrange multipliers against an independent
reference, and fit the observed order (least-squares slope of log error
against log h, :func:`numpy.polyfit`).

Errors are relative, in the maximum norm over the chosen outputs::

    error_q      = max_i |q_i(h) − q_i,ref| / max_i |q_i,ref|
    error_lambda = max_j |λ_j(h) − λ_j,ref| / max_j |λ_j,ref|

(absolute values are reported as well). The result is a plain dict that is
written as JSON by ``femb bench convergence`` and reused by the benchmark
suite.

References
----------
M. Arnold, O. Brüls, Convergence of the generalized-α scheme for constrained
mechanical systems, Multibody Syst. Dyn. 18 (2007) 185–202, Sect. 5, Figs. 3, 9.
"""
from __future__ import annotations

import math
import time
import warnings

import numpy as np

from femb.errors import ParameterWarning, SolverError

from femb.study.registry import Scene, load

#: Refinement of the self-reference when a scene has no independent reference.
SELF_REFERENCE_REFINEMENT = 8


def fit_order(h, err):
    """Least-squares slope of log(err) against log(h) over the finite, positive errors.

    Parameters
    ----------
    h, err : array_like, shape (n,)

    Returns
    -------
    float
        The fitted order, or NaN with fewer than two usable points.
    """
    h = np.asarray(h, dtype=float)
    e = np.asarray([np.nan if v is None else v for v in err], dtype=float)
    ok = np.isfinite(e) & (e > 0.0) & np.isfinite(h) & (h > 0.0)
    if ok.sum() < 2:
        return float("nan")
    return float(np.polyfit(np.log(h[ok]), np.log(e[ok]), 1)[0])


def _as_scene(scene):
    return scene if isinstance(scene, Scene) else load(scene)


def run(scene, *, t_end=None, h=None, rho_inf=None, scaling=True, params=None, store=False,
        stride=1, observer=None, newton_options=None):
    """Build, compile and integrate a scene once.

    Parameters
    ----------
    scene : Scene or str
    t_end, h, rho_inf : float, optional
        Default: the scene's ``DEFAULTS``.
    scaling : bool
    params : dict, optional
        Keyword arguments of the scene's ``build``.
    store : bool
        Keep every ``stride``-th step (False: only the initial and final states).
    stride : int
    observer : callable, optional
        Passed to :func:`femb.simulate`.
    newton_options : dict, optional
        Solver options (rtol, phi_tol, max_iter, newton, ...).

    Returns
    -------
    result : femb.Result
    outputs : dict of str to ndarray (nt,)
    """
    from femb.solve.solver import simulate

    scene = _as_scene(scene)
    d = scene.defaults
    t_end = d["t_end"] if t_end is None else t_end
    h = d["h"] if h is None else h
    rho_inf = d["rho_inf"] if rho_inf is None else rho_inf
    model = scene.model(**(params or {}))
    with warnings.catch_warnings():
        if rho_inf is not None and float(rho_inf) == 1.0:
            warnings.simplefilter("ignore", ParameterWarning)   # ρ∞ = 1 is asked for on purpose
        result = simulate(model, t_end, h, rho_inf=rho_inf, scaling=scaling, store=store, stride=stride,
                          observer=observer, **(newton_options or {}))
    return result, scene.outputs(result)


def _relative(values, ref):
    v = np.asarray(values, dtype=float)
    r = np.asarray(ref, dtype=float)
    if v.size == 0:
        return float("nan"), float("nan")
    a = float(np.max(np.abs(v - r)))
    scale = float(np.max(np.abs(r)))
    return (a / scale if scale > 0.0 else a), a


def _clean(x):
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def convergence_study(scene, *, h=None, rho_inf=0.7, scaling=True, t_end=None, params=None,
                      q_names=None, lambda_names=None, newton_options=None, report=None):
    """Run the h-convergence study of a scene.

    Parameters
    ----------
    scene : Scene or str
        A scene (registry name or file path).
    h : sequence of float, optional
        Step sizes (default: the scene's ``CONVERGENCE["h"]``).
    rho_inf : float
        Spectral radius at infinity (0.7 in the seed).
    scaling : bool
        Scaled Newton system (method.md eq. 8).
    t_end : float, optional
        Final time at which errors are measured (default: the scene's).
    params : dict, optional
        Keyword arguments of ``build`` (the reference receives them too).
    q_names, lambda_names : list of str, optional
        Output names of the coordinates and the multipliers compared.
    newton_options : dict, optional
        Solver options passed to :func:`femb.simulate`.
    report : callable(dict), optional
        Called after each run with that run's row (for progress output).

    Returns
    -------
    dict
        JSON-ready: ``scene``, ``rho_inf``, ``scaling``, ``t_end``, ``h`` (list),
        ``error_q``, ``error_lambda`` (relative, list; None for a failed run),
        ``error_q_abs``, ``error_lambda_abs``, ``order_q``, ``order_lambda``
        (fitted slopes), ``reference`` (how the reference was obtained),
        ``q_names``, ``lambda_names``, ``steps``, ``newton_iterations``
        (total per run), ``newton_per_step``, ``wall_time_s`` (time loop),
        ``us_per_step``, ``q_final``, ``lambda_final`` (values at t_end per
        run, in the order of the names), ``q_reference``, ``lambda_reference``,
        ``failed`` (messages of failed runs), ``solver`` (settings of the
        finest run).
    """
    scene = _as_scene(scene)
    params = dict(params or {})
    setup = scene.convergence_setup()
    if setup["h"] is None and h is None:
        raise ValueError(f"scene '{scene.name}' defines no step sizes: give h")
    hs = [float(x) for x in (setup["h"] if h is None else h)]
    if not hs:
        raise ValueError("convergence_study: no step sizes")
    t_end = setup["t_end"] if t_end is None else float(t_end)
    if t_end is None:
        raise ValueError(f"scene '{scene.name}' defines no final time: give t_end")
    conv = getattr(scene.module, "CONVERGENCE", {}) or {}
    if (q_names is None and "q" not in conv) or (lambda_names is None and "lambda" not in conv):
        # the scene names no outputs for the study: learn the names from a one-step run
        _, outs = run(scene, t_end=max(hs), h=max(hs), rho_inf=rho_inf, scaling=scaling, params=params,
                      newton_options=newton_options)
        setup = scene.convergence_setup(list(outs))
    q_names = list(setup["q"] if q_names is None else q_names)
    lambda_names = list(setup["lambda"] if lambda_names is None else lambda_names)

    # ---- the reference at t_end
    if scene.has_reference:
        ref = scene.reference(np.array([t_end]), **params)
        description = ref.get("description", f"reference() of scene '{scene.name}'")
        ref_q = [float(np.atleast_1d(ref[n])[-1]) for n in q_names]
        ref_l = [float(np.atleast_1d(ref[n])[-1]) for n in lambda_names]
    else:
        h_ref = min(hs) / SELF_REFERENCE_REFINEMENT
        _, outs = run(scene, t_end=t_end, h=h_ref, rho_inf=rho_inf, scaling=scaling, params=params,
                      newton_options=newton_options)
        ref_q = [float(outs[n][-1]) for n in q_names]
        ref_l = [float(outs[n][-1]) for n in lambda_names]
        description = (f"femb itself with h = {h_ref:.6g} s ({SELF_REFERENCE_REFINEMENT}x smaller than the "
                       "finest step; no independent reference for this scene)")

    rows = {k: [] for k in ("error_q", "error_lambda", "error_q_abs", "error_lambda_abs", "steps",
                            "newton_iterations", "newton_per_step", "wall_time_s", "us_per_step",
                            "q_final", "lambda_final")}
    failed = {}
    settings = {}
    for hk in hs:
        t0 = time.perf_counter()
        try:
            res, outs = run(scene, t_end=t_end, h=hk, rho_inf=rho_inf, scaling=scaling, params=params,
                            newton_options=newton_options)
        except SolverError as err:
            failed[repr(hk)] = str(err).splitlines()[0]
            for k in rows:
                rows[k].append(None)
            if report is not None:
                report({"h": hk, "failed": failed[repr(hk)]})
            continue
        q_fin = [float(outs[n][-1]) for n in q_names]
        l_fin = [float(outs[n][-1]) for n in lambda_names]
        eq, eq_abs = _relative(q_fin, ref_q)
        el, el_abs = _relative(l_fin, ref_l)
        steps = res.steps
        iters = int(res.newton_iterations.sum())
        row = {"error_q": eq, "error_lambda": el, "error_q_abs": eq_abs, "error_lambda_abs": el_abs,
               "steps": steps, "newton_iterations": iters, "newton_per_step": iters / steps,
               "wall_time_s": res.wall_time, "us_per_step": 1e6 * res.wall_time / steps}
        for k, v in row.items():
            rows[k].append(_clean(v))
        rows["q_final"].append([_clean(v) for v in q_fin])
        rows["lambda_final"].append([_clean(v) for v in l_fin])
        settings = res.settings
        if report is not None:
            report({"h": hk, **row, "total_time_s": time.perf_counter() - t0})

    out = {
        "scene": scene.name,
        "rho_inf": float(rho_inf),
        "scaling": bool(scaling),
        "t_end": float(t_end),
        "h": hs,
        "error_q": rows["error_q"],
        "error_lambda": rows["error_lambda"],
        "order_q": _clean(fit_order(hs, rows["error_q"])),
        "order_lambda": _clean(fit_order(hs, rows["error_lambda"])),
        "reference": description,
        "error_definition": ("relative error at t_end in the max norm over the named outputs: "
                             "max|x_h - x_ref| / max|x_ref|"),
        "q_names": q_names,
        "lambda_names": lambda_names,
        "error_q_abs": rows["error_q_abs"],
        "error_lambda_abs": rows["error_lambda_abs"],
        "steps": rows["steps"],
        "newton_iterations": rows["newton_iterations"],
        "newton_per_step": rows["newton_per_step"],
        "wall_time_s": rows["wall_time_s"],
        "us_per_step": rows["us_per_step"],
        "q_reference": ref_q,
        "lambda_reference": ref_l,
        "q_final": rows["q_final"],
        "lambda_final": rows["lambda_final"],
        "params": params,
        "failed": failed,
        "solver": {k: v for k, v in settings.items() if isinstance(v, (int, float, str, bool))},
    }
    return out


def format_table(study):
    """The study as a plain-text table (one row per h), with the fitted orders."""
    lines = [f"scene {study['scene']}: rho_inf = {study['rho_inf']}, scaling = {study['scaling']}, "
             f"errors at t = {study['t_end']:g} s",
             f"  q: {', '.join(study['q_names'])}",
             f"  lambda: {', '.join(study['lambda_names'])}",
             f"  reference: {study['reference']}",
             f"{'h [s]':>10s} {'steps':>7s} {'error q':>10s} {'error lam':>10s} {'us/step':>8s} {'Newton/step':>11s}"]

    def fmt(v, spec):
        width = int(spec.split(".")[0].rstrip("defg"))
        return format(v, spec) if v is not None else "failed".rjust(width)

    for i, hk in enumerate(study["h"]):
        lines.append(f"{hk:10.3e} {fmt(study['steps'][i], '7d')} {fmt(study['error_q'][i], '10.3e')} "
                     f"{fmt(study['error_lambda'][i], '10.3e')} {fmt(study['us_per_step'][i], '8.1f')} "
                     f"{fmt(study['newton_per_step'][i], '11.2f')}")
    oq, ol = study["order_q"], study["order_lambda"]
    lines.append(f"fitted order: q {oq:.3f}, lambda {ol:.3f}" if oq is not None and ol is not None
                 else f"fitted order: q {oq}, lambda {ol}")
    return "\n".join(lines)


def time_to_accuracy(scene, targets, *, rho_inf=0.7, t_end=None, params=None, names=None,
                     absolute=True, calibrate_h=None, newton_options=None, max_tries=6):
    """Wall time needed to reach given errors at t_end (fixed step, h chosen by the h² law).

    The error constant C of ``err ≈ C h²`` is calibrated with one run, the step
    for each target is predicted from it, and the step is reduced by 10 % until
    the run meets the target.

    Parameters
    ----------
    scene : Scene or str
    targets : sequence of float
        Error levels (absolute, in the outputs' units, when ``absolute``).
    rho_inf, t_end, params, newton_options
        As for :func:`convergence_study`.
    names : list of str, optional
        Outputs compared (default: the study's coordinates).
    absolute : bool
        Compare absolute (default) or relative errors.
    calibrate_h : float, optional
        Step of the calibration run (default: the coarsest convergence step).
    max_tries : int

    Returns
    -------
    list of dict
        Per target: ``target``, ``h``, ``steps``, ``error``, ``solve_s`` (time loop),
        ``total_s`` (build + compile + consistent initial values + time loop).
    """
    scene = _as_scene(scene)
    params = dict(params or {})
    setup = scene.convergence_setup()
    t_end = setup["t_end"] if t_end is None else float(t_end)
    names = list(setup["q"] if names is None else names)
    ref = scene.reference(np.array([t_end]), **params)
    ref_v = [float(np.atleast_1d(ref[n])[-1]) for n in names]

    def err_at(h):
        t0 = time.perf_counter()
        res, outs = run(scene, t_end=t_end, h=h, rho_inf=rho_inf, params=params,
                        newton_options=newton_options)
        total = time.perf_counter() - t0
        rel, ab = _relative([outs[n][-1] for n in names], ref_v)
        return (ab if absolute else rel), res, total

    h_cal = calibrate_h or max(setup["h"])
    e_cal, _, _ = err_at(h_cal)
    C = e_cal / h_cal ** 2
    out = []
    for target in targets:
        n = math.ceil(t_end / math.sqrt(target / C))
        for _ in range(max_tries):
            h = t_end / n
            e, res, total = err_at(h)
            if e <= target:
                break
            n = math.ceil(n * 1.1)
        out.append({"target": float(target), "h": h, "steps": res.steps, "error": e,
                    "solve_s": res.wall_time, "total_s": total})
    return out
