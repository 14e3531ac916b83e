"""Checks of the fixed step of a run: is h resolving what the run excites?

An oscillation that the model keeps (no material damping), excited at the
start (a beam started stress free rings in its axial modes), is computed
with a fixed step h either damped away (hω ≳ 1, the numerical damping of
ρ∞ < 1) or with a phase lag that accumulates over the run; the result then
does not converge in h until that lag is small (docs/beams.md, "Convergence
with unresolved axial modes").

* ``numerical_decay`` and ``free_oscillation_error``: the amplitude factor per
  step of generalized-α on ẍ + ω²x = 0, and the relative error of such an
  oscillation after N steps.
* ``step_halving_order``: the observed order over a short window from runs
  with h, h/2 and h/4, over all coordinates and per coordinate (about 2 where h
  resolves the motion, below 1 where it does not); ``fixed_step_warning``: the
  text of a warning from it, for a solver to show after a fixed-step run.
* ``acceleration_roughness``: the ratio D_n = ‖Δ²q̈ᵖᵖ_n‖_w / ‖Δq̈ᵖᵖ_n‖_w of the
  second to the first difference of the constrained accelerations q̈ᵖᵖ of
  consecutive steps (the quantity of the local error estimate, e_q = C_q h²
  Δq̈ᵖᵖ, docs/stepsize.md §3), with the estimate's weights w_i = atol + rtol |q_i|:
  ≈ h/T for a motion of time scale T, 2 sin(hω/2) for an oscillation of
  frequency ω, up to 2. It shows that an unresolved oscillation dominates the
  estimate, not whether it matters: on the flexible slider-crank it does not
  separate converging from non-converging runs (docs/beams.md).
"""
from __future__ import annotations

import numpy as np

from femb.errors import ParameterError
from femb.system import assembly


def _principal_root(w, al):
    """The physical eigenvalue of the generalized-α map at hω = w: of the complex pair, the one with
    Im > 0 (the third, spurious root is real); the largest in modulus once all roots are real."""
    am, af, b, g = al.alpha_m, al.alpha_f, al.beta, al.gamma
    w2 = w * w
    # unknowns (x, h v, h² a) with h = 1, ω = w
    A = np.array([[1.0, 0.0, -b], [0.0, 1.0, -g], [(1.0 - af) * w2, 0.0, 1.0 - am]])
    B = np.array([[1.0, 1.0, 0.5 - b], [0.0, 1.0, 1.0 - g], [-af * w2, 0.0, -am]])
    ev = np.linalg.eigvals(np.linalg.solve(A, B))
    up = ev[ev.imag > 1e-14]
    return up[np.argmax(np.abs(up))] if up.size else ev[np.argmax(np.abs(ev))]


def _alpha(alpha):
    from femb.solve.alpha import GeneralizedAlpha

    return alpha if isinstance(alpha, GeneralizedAlpha) else GeneralizedAlpha.from_rho_inf(alpha)


def numerical_decay(h_omega, alpha=0.7):
    """Spectral radius ρ(hω) of generalized-α on ẍ + ω² x = 0 (amplitude factor per step).

    Parameters
    ----------
    h_omega : float or array_like
        Step times circular frequency.
    alpha : float or GeneralizedAlpha
        ρ∞ (Chung–Hulbert parameters) or the parameters.

    Returns
    -------
    float or ndarray
        max |eigenvalue| of the map (x_n, v_n, a_n) → (x_{n+1}, v_{n+1}, a_{n+1}) of
        x_{n+1} = x_n + h v_n + h²(½ − β) a_n + h²β a_{n+1},
        v_{n+1} = v_n + h(1 − γ) a_n + hγ a_{n+1},
        (1 − α_m) a_{n+1} + α_m a_n = −ω² [(1 − α_f) x_{n+1} + α_f x_n]
        (1 at hω = 0, ρ∞ as hω → ∞).
    """
    al = _alpha(alpha)
    x = np.atleast_1d(np.asarray(h_omega, dtype=float))
    am, af, b, g = al.alpha_m, al.alpha_f, al.beta, al.gamma
    out = np.empty_like(x)
    for i, w in enumerate(x):
        w2 = w * w
        A = np.array([[1.0, 0.0, -b], [0.0, 1.0, -g], [(1.0 - af) * w2, 0.0, 1.0 - am]])
        B = np.array([[1.0, 1.0, 0.5 - b], [0.0, 1.0, 1.0 - g], [-af * w2, 0.0, -am]])
        out[i] = np.max(np.abs(np.linalg.eigvals(np.linalg.solve(A, B))))
    return out if np.ndim(h_omega) else float(out[0])


def free_oscillation_error(h_omega, n_steps, alpha=0.7):
    """Relative error of an undamped free oscillation after n_steps steps: |1 − (z e^{−ihω})^N|.

    z is the scheme's physical eigenvalue at hω (:func:`numerical_decay` gives
    its modulus); z e^{−ihω} = ρ e^{−iδ} combines the amplitude lost per step
    with the phase lag δ per step (δ ≈ (hω)³/12 for small hω at ρ∞ = 1). An
    oscillation of amplitude A that the model keeps (no material damping)
    differs from its computed version by about A times this factor: up to 2A
    once the phase lag over the run exceeds about one radian. Convergence in h
    of a result that carries such an oscillation only begins where the factor
    is well below 1.
    """
    al = _alpha(alpha)
    x = np.atleast_1d(np.asarray(h_omega, dtype=float))
    out = np.empty_like(x)
    for i, w in enumerate(x):
        z = _principal_root(w, al) * np.exp(-1j * w)
        out[i] = abs(1.0 - z ** int(n_steps))
    return out if np.ndim(h_omega) else float(out[0])


def constrained_accelerations(model, t, q, qd):
    """q̈ᵖᵖ at one state: [[M, Bᵀ], [B, 0]] [q̈; λ] = [f; −γ] on the active constraints, shape (nq,)."""
    from femb.system.initial import _solve_augmented, active_mask

    rows = np.nonzero(active_mask(model))[0] if model.nc else np.zeros(0, dtype=np.int64)
    B = assembly.constraint_jacobian(model, t, q).tocsr()[rows]
    _, gam = assembly.constraint_rates(model, t, q, qd)
    M = assembly.mass_matrix(model, q)
    f = assembly.force_vector(model, t, q, qd)
    sol = _solve_augmented(M, B, f, -gam[rows], "constrained accelerations")
    if sol is None:
        raise ParameterError(f"constrained accelerations: singular [[M, Φ_qᵀ], [Φ_q, 0]] at t = {t:.6g}")
    return sol[0]


def acceleration_roughness(result, *, rtol=1e-3, atol=1e-3, first=None):
    """Roughness D_n of the constrained accelerations of a stored fixed-step run.

    Parameters
    ----------
    result : Result
        A fixed-step run stored at every step (``stride=1``).
    rtol, atol : float
        Weights w_i = atol + rtol |q_i| (those of the fixed-step accuracy check).
    first : int, optional
        Only the first ``first`` stored states.

    Returns
    -------
    dict
        ``t`` (times of the middle step, (n−2,)), ``D`` (roughness), ``eq``
        (the weighted RMS of C_q h² Δq̈ᵖᵖ over the step pair, the quantity of the
        accuracy check), ``h``.
    """
    from femb.solve.alpha import GeneralizedAlpha
    from femb.solve.options import error_constants

    t = np.asarray(result.t)
    if first is not None:
        t = t[:first]
    n = len(t)
    if n < 3:
        raise ParameterError("acceleration_roughness needs at least 3 stored steps")
    dt = np.diff(t)
    h = float(np.median(dt))
    if np.max(np.abs(dt - h)) > 1e-6 * h:
        raise ParameterError("acceleration_roughness needs a fixed-step run stored at every step (stride=1)")
    model = result.model
    A = np.array([constrained_accelerations(model, t[k], result.q[k], result.qd[k]) for k in range(n)])
    w = atol + rtol * np.array([model.magnitude(result.q[k]) for k in range(n)])
    d1 = np.diff(A, axis=0)
    d2 = np.diff(d1, axis=0)
    ww = w[1:-1]
    n1 = np.sqrt(np.mean((d1[:-1] / ww) ** 2, axis=1))
    n2 = np.sqrt(np.mean((d2 / ww) ** 2, axis=1))
    with np.errstate(invalid="ignore", divide="ignore"):
        D = np.where(n1 > 0, n2 / n1, 0.0)
    s = result.settings or {}
    al = GeneralizedAlpha.from_values(s["alpha_m"], s["alpha_f"], s["beta"], s["gamma"], warn=False) \
        if "alpha_m" in s else GeneralizedAlpha.from_rho_inf(0.7)
    Cq = abs(error_constants(al)[0])
    return {"t": t[1:-1], "D": D, "eq": Cq * h * h * n1, "h": h}


def step_halving_order(model, h, *, n_window=64, t0=0.0, state=None, rho_inf=None, rtol=1e-3, atol=1e-3,
                       floor=1e-6, **options):
    """Observed order of the fixed step h over a window of n_window steps, from runs with h, h/2 and h/4.

    Runs the window [t0, t0 + n_window h] with h, h/2 and h/4 and compares the
    positions at the times of the h run, weighted by w = atol + rtol |q|:
    per coordinate d₁ᵢ = maxₙ |q_h − q_{h/2}|ᵢ/wᵢ and d₂ᵢ = maxₙ |q_{h/2} − q_{h/4}|ᵢ/wᵢ,
    pᵢ = log₂(d₁ᵢ/d₂ᵢ), and the same for the weighted RMS over all coordinates
    (``order``). A step that resolves the motion gives p ≈ 2 (the order of the
    scheme); p < 1 says that halving h does not reduce the difference as it
    should: the window holds motion the step does not resolve (an axial mode
    rung by a stress-free start, docs/beams.md). Coordinates whose own d₁ᵢ is
    below ``floor`` (round-off, or no error at all) are not judged. Costs
    7 × n_window steps. ``rho_inf`` and ``options`` (``alpha``, ``formulation``,
    Newton settings, ...) go to :func:`femb.simulate` (ρ∞ = 0.7 when neither
    ``rho_inf`` nor ``alpha`` is given).

    Returns
    -------
    dict
        ``order`` (all coordinates), ``d1``, ``d2`` (weighted RMS), ``orders``
        (per coordinate, NaN where not judged), ``unresolved`` (labels of the
        coordinates with pᵢ < 1), ``window`` (s).
    """
    import warnings

    import femb

    h = float(h)
    if not h > 0.0:
        raise ParameterError(f"h must be positive, got {h!r}")
    n_window = int(n_window)
    if n_window < 2:
        raise ParameterError(f"n_window must be at least 2, got {n_window}")
    if state is not None:
        t0 = float(state.t)
    t1 = t0 + n_window * h
    options = dict(options, check_every=0)      # the window runs need no accuracy check of their own
    runs = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for k in (1, 2, 4):
            r = femb.simulate(model, t1, h / k, rho_inf=rho_inf, state=state, t0=t0, stride=k, **options)
            runs.append(r.q[: n_window + 1])

    def dist(a, b):
        rms, per = 0.0, np.zeros(model.nq)
        for qa, qb in zip(a, b):
            w = atol + rtol * np.maximum(model.magnitude(qa), model.magnitude(qb))
            e = np.abs(model.difference(qa, qb)) / w
            rms = max(rms, float(np.sqrt(np.mean(e ** 2))))
            per = np.maximum(per, e)
        return rms, per

    (d1, e1), (d2, e2) = dist(runs[0], runs[1]), dist(runs[1], runs[2])
    p = float(np.log2(d1 / d2)) if d1 > 0.0 and d2 > 0.0 else float("nan")
    judged = (e1 > floor) & (e2 > 0.0)
    orders = np.full(model.nq, np.nan)
    orders[judged] = np.log2(e1[judged] / e2[judged])
    labels = list(getattr(model, "velocity_labels", [str(i) for i in range(model.nq)]))
    unresolved = [labels[i] for i in np.nonzero(judged & (orders < 1.0))[0]]
    return {"order": p, "d1": d1, "d2": d2, "orders": orders, "unresolved": unresolved, "window": t1 - t0}


def fixed_step_warning(model, h, *, n_window=64, max_listed=5, **kwargs):
    """A warning text when the fixed step h does not resolve what the start of the run excites, else None.

    Calls :func:`step_halving_order` (``kwargs`` go to it: ``state``, ``t0``,
    ``rho_inf``, ``alpha``, ``formulation``, Newton settings) and returns a
    message when some coordinate's observed order over the first ``n_window``
    steps is below 1. Meant to be called by the solver after a fixed-step
    run (opt-in: it costs 7 × n_window steps).
    """
    s = step_halving_order(model, h, n_window=n_window, **kwargs)
    if not s["unresolved"]:
        return None
    labels = list(getattr(model, "velocity_labels", []))
    worst = sorted(s["unresolved"], key=lambda lab: s["orders"][labels.index(lab)] if lab in labels else 0.0)
    listed = ", ".join(f"{lab} ({s['orders'][labels.index(lab)]:.2f})" if lab in labels else lab
                       for lab in worst[:max_listed])
    more = f" and {len(worst) - max_listed} more" if len(worst) > max_listed else ""
    return (f"the fixed step h = {h:.3g} s does not resolve the motion of the first {n_window} steps: "
            f"halving h does not reduce the differences of {listed}{more} as a second-order method should "
            f"(observed order in parentheses; over all coordinates {s['order']:.2f}). An oscillation the "
            f"start excites (e.g. axial modes of a beam started stress free) is then damped numerically or "
            f"out of phase, and results do not converge in h: resolve it (h well below its period, see "
            f"femb.analysis.modal.modal_analysis), add material damping, start from a deformed state, or use "
            f"adaptive steps (docs/beams.md, 'Convergence with unresolved axial modes')")
