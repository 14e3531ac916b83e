"""Figures of the seed paper's numerical examples, as PNG files.

``femb bench figures SCENE --out DIR`` calls :func:`make_figures`. Figures
(numbers refer to Arnold & Brüls 2007):

slider_crank
    ``slider_crank_fig2_theta_x4.png``: crank angle θ(t) and position x4(t) of
    the extra mass at h = 5e-3 s (Fig. 2), with the minimal-coordinate reference;
    ``slider_crank_fig3_convergence.png``: relative errors at t = 1 s of θ and of
    the crank pivot reaction against h, log–log, slope-2 guide (Fig. 3).
andrews
    ``andrews_fig6_P_beta.png``: (x, y) position of the hinge P and angle β at
    h = 3e-4 s (Fig. 6); ``andrews_fig7_acc_lambda.png``: (x, y) acceleration of
    P and the multipliers λ1…λ6 (Fig. 7); ``andrews_fig8_acc_lambda_rho1.png``:
    the same with ρ∞ = 1, showing the oscillations of the undamped scheme
    (Fig. 8); ``andrews_fig9_convergence.png``: relative errors at t = 0.03 s of
    the angles and of the multipliers against h (Fig. 9).
other scenes
    ``<scene>_outputs.png`` (outputs against t at the default settings) and
    ``<scene>_convergence.png``.

matplotlib is imported only inside these functions, through its object API
with the Agg canvas (no pyplot, no display, no global backend switch).

References
----------
M. Arnold, O. Brüls, Convergence of the generalized-α scheme for constrained
mechanical systems, Multibody Syst. Dyn. 18 (2007) 185–202, Figs. 2, 3, 6–9.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from femb.benchmarks.accuracy.convergence import convergence_study, run
from femb.study.registry import Scene, load

#: Resolution of the PNG files (dots per inch); figures are 8 × 3.2 inches.
DPI = 90


def _figure(ncols=2, size=(8.0, 3.2)):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, layout="constrained")
    FigureCanvasAgg(fig)
    axes = [fig.add_subplot(1, ncols, k + 1) for k in range(ncols)]
    for ax in axes:
        ax.grid(True, lw=0.4, alpha=0.6)
    return fig, axes


def _save(fig, path):
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI)
    return path


def convergence_figure(study, path, *, q_label=None, lambda_label=None, title=None):
    """Log–log plot of a convergence study with a slope-2 guide line.

    Parameters
    ----------
    study : dict
        Output of :func:`~femb.benchmarks.accuracy.convergence.convergence_study`.
    path : str or Path
        PNG file to write.
    q_label, lambda_label : str, optional
        Legend labels of the two error curves.
    title : str, optional

    Returns
    -------
    Path
    """
    fig, (ax,) = _figure(1, (5.0, 3.8))
    h = np.asarray(study["h"], dtype=float)
    eq = np.array([np.nan if v is None else v for v in study["error_q"]], dtype=float)
    el = np.array([np.nan if v is None else v for v in study["error_lambda"]], dtype=float)
    oq, ol = study.get("order_q"), study.get("order_lambda")
    q_label = q_label or f"coordinates ({', '.join(study['q_names'])})"
    lambda_label = lambda_label or "multipliers"
    ax.loglog(h, eq, "o-", label=f"{q_label}: order {oq:.2f}" if oq is not None else q_label)
    ax.loglog(h, el, "s-", label=f"{lambda_label}: order {ol:.2f}" if ol is not None else lambda_label)
    ok = np.isfinite(eq) | np.isfinite(el)
    if ok.any():
        lo = np.nanmin(np.concatenate([eq[ok], el[ok]]))
        hh = np.array([h[ok].min(), h[ok].max()])
        ax.loglog(hh, 0.3 * lo * (hh / hh[0]) ** 2, "k--", lw=1.0, label="slope 2")
    from matplotlib.ticker import NullFormatter

    ax.xaxis.set_minor_formatter(NullFormatter())     # crowded minor labels on short decades
    ax.set_xlabel("step size h [s]")
    ax.set_ylabel(f"relative error at t = {study['t_end']:g} s")
    ax.set_title(title or f"{study['scene']}: convergence, ρ∞ = {study['rho_inf']:g}", fontsize=10)
    ax.legend(fontsize=8)
    return _save(fig, path)


# ---------------------------------------------------------------- slider-crank
def slider_crank_time(path, *, h=5e-3, rho_inf=0.7):
    """Fig. 2: θ(t) and x4(t) at step h, with the minimal-coordinate reference."""
    from femb.benchmarks.scenes.planar import slider_crank as sc

    res, out = run("slider_crank", h=h, rho_inf=rho_inf, store=True)
    t_ref = np.linspace(0.0, res.t[-1], 401)
    ref = sc.reference(t_ref)
    fig, (a1, a2) = _figure(2)
    a1.plot(res.t, out["theta"], label=f"femb, h = {h:g} s")
    a1.plot(t_ref, ref["theta"], "k--", lw=0.8, label="reference")
    a1.set_xlabel("t [s]")
    a1.set_ylabel("crank angle θ [rad]")
    a2.plot(res.t, out["x4"], label=f"femb, h = {h:g} s")
    a2.plot(t_ref, ref["x4"], "k--", lw=0.8, label="reference")
    a2.set_xlabel("t [s]")
    a2.set_ylabel("extra mass x4 [m]")
    a1.legend(fontsize=8)
    fig.suptitle(f"Slider–crank with spring–mass system, ρ∞ = {rho_inf:g}", fontsize=10)
    return _save(fig, path)


# ---------------------------------------------------------------- Andrews
def andrews_position(path, *, h=3e-4, rho_inf=0.7):
    """Fig. 6: (x, y) position of the hinge P and angle β against t."""
    res, out = run("andrews", h=h, rho_inf=rho_inf, store=True)
    fig, (a1, a2) = _figure(2)
    t = 1e3 * res.t
    a1.plot(t, 1e3 * out["xP"], label="x_P")
    a1.plot(t, 1e3 * out["yP"], label="y_P")
    a1.set_xlabel("t [ms]")
    a1.set_ylabel("position of P [mm]")
    a1.legend(fontsize=8)
    a2.plot(t, out["beta"])
    a2.set_xlabel("t [ms]")
    a2.set_ylabel("β [rad]")
    fig.suptitle(f"Andrews' mechanism, h = {h:g} s, ρ∞ = {rho_inf:g}", fontsize=10)
    return _save(fig, path)


def andrews_accelerations(path, *, h=3e-4, rho_inf=0.7, reference=True):
    """Figs. 7 and 8: (x, y) acceleration of P and the multipliers λ1…λ6 against t."""
    from femb.benchmarks.scenes.planar import andrews as an

    res, out = run("andrews", h=h, rho_inf=rho_inf, store=True)
    fig, (a1, a2) = _figure(2)
    t = 1e3 * res.t
    a1.plot(t, 1e-3 * out["xP_dd"], label="ẍ_P")
    a1.plot(t, 1e-3 * out["yP_dd"], label="ÿ_P")
    a1.set_xlabel("t [ms]")
    a1.set_ylabel("acceleration of P [km/s²]")
    for name in an.LAMBDA_NAMES:
        a2.plot(t, out[name], lw=1.0, label=name.replace("lambda_", "λ"))
    if reference:
        t_ref = np.linspace(0.0, res.t[-1], 301)
        ref = an.reference(t_ref)
        # the reference's own P acceleration is not an output of the relative model: show λ only
        for k, name in enumerate(an.LAMBDA_NAMES):
            a2.plot(1e3 * t_ref, ref[name], "k--", lw=0.6, label="reference" if k == 0 else None)
    a2.set_xlabel("t [ms]")
    a2.set_ylabel("multipliers at E [N]")
    a1.legend(fontsize=8)
    a2.legend(fontsize=7, ncol=2)
    fig.suptitle(f"Andrews' mechanism, h = {h:g} s, ρ∞ = {rho_inf:g}", fontsize=10)
    return _save(fig, path)


# ---------------------------------------------------------------- generic
def generic_time(scene, path, max_outputs=6):
    """The first outputs of any scene against t at its default settings."""
    res, out = run(scene, store=True)
    names = list(out)[:max_outputs]
    fig, (ax,) = _figure(1, (6.0, 3.8))
    for n in names:
        ax.plot(res.t, out[n], label=n)
    ax.set_xlabel("t [s]")
    ax.legend(fontsize=8)
    ax.set_title(scene.name, fontsize=10)
    return _save(fig, path)


def make_figures(scene, out_dir, *, rho_inf=0.7, study=None, h=None, write_json=True):
    """Write the scene's figures (and its convergence study as JSON) into ``out_dir``.

    Parameters
    ----------
    scene : Scene or str
    out_dir : str or Path
    rho_inf : float
        ρ∞ of the time plots and the convergence study (the seed uses 0.7).
    study : dict, optional
        A convergence study already computed (else it is run here).
    h : sequence of float, optional
        Step sizes of the convergence study (default: the scene's).
    write_json : bool
        Also write ``<scene>_convergence.json``.

    Returns
    -------
    list of Path
        The files written.
    """
    scene = scene if isinstance(scene, Scene) else load(scene)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if study is None:
        study = convergence_study(scene, rho_inf=rho_inf, h=h)
    files = []
    if scene.name == "slider_crank" and scene.source == "femb.benchmarks.scenes.planar.slider_crank":
        files.append(slider_crank_time(out / "slider_crank_fig2_theta_x4.png", rho_inf=rho_inf))
        files.append(convergence_figure(study, out / "slider_crank_fig3_convergence.png",
                                        q_label="crank angle θ", lambda_label="pivot reaction λ",
                                        title=f"Slider–crank: errors at t = 1 s, ρ∞ = {rho_inf:g}"))
    elif scene.name == "andrews" and scene.source == "femb.benchmarks.scenes.planar.andrews":
        files.append(andrews_position(out / "andrews_fig6_P_beta.png", rho_inf=rho_inf))
        files.append(andrews_accelerations(out / "andrews_fig7_acc_lambda.png", rho_inf=rho_inf))
        files.append(andrews_accelerations(out / "andrews_fig8_acc_lambda_rho1.png", rho_inf=1.0))
        files.append(convergence_figure(study, out / "andrews_fig9_convergence.png",
                                        q_label="angles β…ε", lambda_label="multipliers λ1…λ6",
                                        title=f"Andrews: errors at t = 0.03 s, ρ∞ = {rho_inf:g}"))
    else:
        files.append(generic_time(scene, out / f"{scene.name}_outputs.png"))
        files.append(convergence_figure(study, out / f"{scene.name}_convergence.png"))
    if write_json:
        p = out / f"{scene.name}_convergence.json"
        p.write_text(json.dumps(study, indent=2) + "\n")
        files.append(p)
    return files
