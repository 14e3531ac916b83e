"""h-convergence of the flexible slider-crank's slider position with unresolved axial modes.

The scene of :mod:`femb.benchmarks.scenes.beams.flexible_slider_crank` (8 elements, started
stress free at top dead centre with the rigid mechanism's velocities) with
and without its material damping, fixed steps h, slider position at t_end
against a run with h_ref. Printed per h:

* ``error``: |x_h − x_ref| of the slider at t_end (m), and the order between
  neighbouring h;
* ``check``: the largest value of the fixed-step accuracy check (the local
  error estimate every 16 steps, rtol = atol = 1e-3; ``AccuracyWarning`` above
  10) and whether it warned;
* ``hω₁`` and ``F₁``: the first axial mode's hω and the relative error of an
  undamped free oscillation of that frequency after the run's N steps
  (:func:`femb.solve.diagnostics.free_oscillation_error`), and ``error/F₁``;
* ``p64``: the observed order over the first 64 steps from runs with h, h/2,
  h/4 (:func:`femb.solve.diagnostics.step_halving_order`), over all coordinates,
  of the slider's x alone, and the number of coordinates with an order below 1.

and the same error for adaptive steps (rtol = atol = 1e-4 … 1e-8), and for a
smooth start without damping: at rest, the crank speed rising to ω over
20 ms (the spin-up's profile), slider x at t = 30 ms.

Then the fitted orders (least squares in log–log) over the coarse and the fine
h, and the axial mode periods of the model (:func:`femb.analysis.modal.modal_analysis`
at the consistent initial state; a mode is axial when more than half of its
squared amplitude is in x coordinates, the rod lying along x).

    python -m femb.benchmarks.accuracy.flexible_convergence [--scenes]

``--scenes`` also prints the accuracy check's largest value and ``p64`` on the
ordinary scenes (andrews, slider_crank, heavy_top, spin_up) at their default
steps; ``--roughness`` the roughness of the constrained accelerations
(:func:`femb.solve.diagnostics.acceleration_roughness`) on the flexible runs and the
ordinary scenes (about 40 s more). About 20 s (plus 30 s with ``--scenes``) on a 2-core machine.
"""
from __future__ import annotations

import argparse
import importlib
import warnings

import numpy as np

import femb
from femb.analysis.modal import modal_analysis
from femb.benchmarks.scenes.beams import flexible_slider_crank as fsc
from femb.errors import AccuracyWarning
from femb.solve.diagnostics import acceleration_roughness, free_oscillation_error, step_halving_order
from femb.system.initial import consistent_initial_state

T_END = 0.01
HS = (2e-4, 1e-4, 5e-5, 2e-5, 1e-5, 5e-6, 2e-6, 1e-6)
H_REF = 2.5e-7
N_ELEMENTS = 8
VARIANTS = ((0.0, 0.7), (fsc.DATA["damping"], 0.7), (0.0, 0.9))
#: smooth start: crank speed from 0 to ω over RAMP seconds (no damping)
RAMP = 0.02


def axial_modes(model):
    """(periods (s), circular frequencies (rad/s)) of the axial modes at the initial state, ascending."""
    st = consistent_initial_state(model)
    st = getattr(st, "state", st)
    mr = modal_analysis(model, st, n_modes=model.nq - model.nc)
    ix = [i for i, lab in enumerate(model.velocity_labels) if lab.endswith(".x")]
    w = [abs(om) for om, phi in zip(mr.omega, mr.modes) if np.sum(phi[ix] ** 2) > 0.5 * np.sum(phi ** 2)]
    w = np.array(w)
    return 2.0 * np.pi / w, w


def build(damping, ramp=None, n_elements=N_ELEMENTS):
    """The compiled scene; with ``ramp`` (s) it starts at rest and the crank speed rises smoothly to ω
    over ``ramp`` (the spin-up's profile, :func:`femb.benchmarks.scenes.beams.spin_up.spin_profile`)."""
    if ramp is None:
        return fsc.build(n_elements, damping=damping).compile()
    from femb.benchmarks.scenes.beams.spin_up import spin_profile

    mech = fsc.build(n_elements, omega=0.0, damping=damping)
    mech["drive"].fn = spin_profile(fsc.DATA["omega"], ramp)
    return mech.compile()


def slider_run(model, h, rho_inf, t_end=T_END):
    """(slider x at t_end, largest accuracy-check value, warned?) of a fixed-step run."""
    n = int(round(t_end / h))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        r = femb.simulate(model, t_end, h, rho_inf=rho_inf, stride=n)
    e = r.error_estimates[r.error_estimates >= 0]
    warned = any(issubclass(c.category, AccuracyWarning) for c in caught)
    return float(r.body("slider")[-1, 0]), float(e.max()) if e.size else float("nan"), warned


def fitted_order(h, err):
    h, err = np.asarray(h), np.asarray(err)
    return float(np.polyfit(np.log(h), np.log(err), 1)[0])


def study(damping, rho_inf, hs=HS, h_ref=H_REF, n_elements=N_ELEMENTS, ramp=None):
    """Rows (h, error, check max, warned, hω₁, F₁, p64, p64 of slider x, coordinates with p64 < 1)
    and the axial ω of one variant (with ``ramp``: started at rest, run to ramp + T_END)."""
    model = build(damping, ramp, n_elements)
    _, w = axial_modes(fsc.build(n_elements, damping=damping).compile())
    t_end = T_END + (ramp or 0.0)
    x_ref = slider_run(model, h_ref, rho_inf, t_end)[0]
    rows = []
    for h in hs:
        x, chk, warned = slider_run(model, h, rho_inf, t_end)
        F1 = free_oscillation_error(h * w[0], int(round(t_end / h)), rho_inf)
        s = step_halving_order(model, h, n_window=64, rho_inf=rho_inf)
        p_slider = s["orders"][model.velocity_labels.index("slider.x")]
        rows.append((h, abs(x - x_ref), chk, warned, h * w[0], F1, s["order"], p_slider, len(s["unresolved"])))
    return rows, w


def print_study(damping, rho_inf, rows, ramp=None):
    if ramp is None:
        print(f"\neta = {damping:g} s, rho_inf = {rho_inf}, slider x at t = {T_END} s against h_ref = {H_REF:g} s")
    else:
        print(f"\neta = {damping:g} s, rho_inf = {rho_inf}, started at rest, crank speed ramped to omega over "
              f"{ramp:g} s; slider x at t = {ramp + T_END:g} s against h_ref = {H_REF:g} s")
    print("  h (s)    error (m)  order  check max  warned  h*w1   F1     error/F1  p64    slider  p<1")
    prev = None
    for h, err, chk, warned, hw, F1, p, ps, nu in rows:
        o = f"{np.log(prev[1] / err) / np.log(prev[0] / h):5.2f}" if prev else "     "
        print(f"  {h:7.1e}  {err:9.3e}  {o}  {chk:9.3e}  {'yes' if warned else 'no':6s}  {hw:5.3f}  "
              f"{F1:5.3f}  {err / F1:8.2e}  {p:5.2f}  {ps:6.2f}  {nu:3d}")
        prev = (h, err)
    hs = np.array([r[0] for r in rows])
    err = np.array([r[1] for r in rows])
    coarse, fine = hs >= 2e-5, hs <= 5e-6
    print(f"  fitted order: {fitted_order(hs[coarse], err[coarse]):.2f} for h = {hs[coarse].min():g} … "
          f"{hs[coarse].max():g} s, {fitted_order(hs[fine], err[fine]):.2f} for h = {hs[fine].min():g} … "
          f"{hs[fine].max():g} s")


def adaptive(tols=(1e-4, 1e-5, 1e-6, 1e-7, 1e-8), rho_inf=0.7):
    """Adaptive runs of the undamped rod: rows (rtol = atol, accepted steps, rejected, error, smallest h, largest h)."""
    model = fsc.build(N_ELEMENTS, damping=0.0).compile()
    x_ref = slider_run(model, H_REF, rho_inf)[0]
    rows = []
    for tol in tols:
        r = femb.simulate(model, T_END, rtol=tol, atol=tol, rho_inf=rho_inf, stride=1 << 30)
        rows.append((tol, len(r.h_steps), r.n_rejected, abs(float(r.body("slider")[-1, 0]) - x_ref),
                     float(r.h_steps.min()), float(r.h_steps.max())))
    return rows


def scenes():
    print("\nordinary scenes at their default steps: accuracy check, p64")
    for name in ("andrews", "slider_crank", "heavy_top", "spin_up"):
        from femb.study import registry
        mod = importlib.import_module(registry.scene_module(name))
        d = mod.DEFAULTS
        model = mod.build().compile()
        t_end = min(d["t_end"], 2.0)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            r = femb.simulate(model, t_end, d["h"], rho_inf=d["rho_inf"])
        e = r.error_estimates[r.error_estimates >= 0]
        warned = any(issubclass(c.category, AccuracyWarning) for c in caught)
        s = step_halving_order(model, d["h"], n_window=64, rho_inf=d["rho_inf"])
        print(f"  {name:13s} h = {d['h']:.3g} s, t_end = {t_end:g} s: check max {e.max():.3e}, "
              f"warned {'yes' if warned else 'no'}, p64 = {s['order']:.2f}, smallest per coordinate "
              f"{np.nanmin(s['orders']):.2f}, p<1: {len(s['unresolved'])}")


def _roughness(r, rho_inf):
    """(median D over the last quarter of the run, the hω it stands for, N, F(hω, N))."""
    D = acceleration_roughness(r)["D"]
    d = float(np.median(D[3 * len(D) // 4:]))
    hw = 2.0 * np.arcsin(min(d, 2.0) / 2.0)
    n = len(r.t) - 1
    return d, hw, n, free_oscillation_error(hw, n, rho_inf)


def roughness():
    """The roughness of the constrained accelerations (a quantity the error estimate could give) on the
    flexible runs and the ordinary scenes: it does not separate the converging from the other runs."""
    print("\nroughness D = |second difference| / |first difference| of the constrained accelerations,")
    print("median over the last quarter of the run, the h*omega it stands for (D = 2 sin(h omega / 2)),")
    print("and the free-oscillation factor F of that h*omega over the run's N steps")
    for damping in (0.0, fsc.DATA["damping"]):
        model = build(damping)
        for h in HS[:6]:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                r = femb.simulate(model, T_END, h, rho_inf=0.7)
            d, hw, n, F = _roughness(r, 0.7)
            print(f"  eta = {damping:g} s, h = {h:.0e} s: D = {d:.3f}, h*omega = {hw:.3f}, N = {n}, F = {F:.3f}")
    for name in ("andrews", "slider_crank", "heavy_top", "spin_up"):
        from femb.study import registry
        mod = importlib.import_module(registry.scene_module(name))
        dflt = mod.DEFAULTS
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = femb.simulate(mod.build().compile(), min(dflt["t_end"], 2.0), dflt["h"], rho_inf=dflt["rho_inf"])
        d, hw, n, F = _roughness(r, dflt["rho_inf"])
        print(f"  {name}, h = {dflt['h']:.3g} s: D = {d:.3f}, h*omega = {hw:.3f}, N = {n}, F = {F:.3f}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", action="store_true", help="also the ordinary scenes")
    ap.add_argument("--roughness", action="store_true",
                    help="also the roughness of the constrained accelerations (slow: a KKT solve per step in Python)")
    a = ap.parse_args(argv)
    T, w = axial_modes(fsc.build(N_ELEMENTS).compile())
    print(f"flexible slider-crank, {N_ELEMENTS} elements: axial modes T = "
          + ", ".join(f"{t * 1e3:.4f}" for t in T[:4]) + " ms (omega = "
          + ", ".join(f"{x:.0f}" for x in w[:4]) + " rad/s)")
    for damping, rho in VARIANTS:
        rows, _ = study(damping, rho)
        print_study(damping, rho, rows)
    rows, _ = study(0.0, 0.7, ramp=RAMP)
    print_study(0.0, 0.7, rows, ramp=RAMP)
    print(f"\neta = 0 s, rho_inf = 0.7, adaptive steps (rtol = atol): slider x at t = {T_END} s")
    print("  tol     steps  rejected  error (m)  h min     h max")
    for tol, n, rej, err, hmin, hmax in adaptive():
        print(f"  {tol:6.0e}  {n:5d}  {rej:8d}  {err:9.3e}  {hmin:8.2e}  {hmax:8.2e}")
    if a.scenes:
        scenes()
    if a.roughness:
        roughness()


if __name__ == "__main__":
    main()
