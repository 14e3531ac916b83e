"""One integration of a reference ODE per process, evaluated at any output times.

The benchmark suite compares femb's runs with the independent references of the scenes at the
runs' own output times: every fixed step size and every adaptive tolerance gives other times,
and the references used to integrate their ODE again, from t = 0, for each of them (at
rtol = atol = 1e-12, in pure Python, most of the suite's time). :func:`integrate` integrates once
per ``key`` with :func:`scipy.integrate.solve_ivp` and keeps the dense output
(``dense_output=True``), then evaluates it at the times asked for.

The values are those of ``solve_ivp(..., t_eval=t)``: with ``t_eval`` solve_ivp evaluates the same
continuous extension of each step (for DOP853 the 7th-order interpolant of Hairer, Nørsett &
Wanner, Solving ODEs I, 2nd ed., 1993, Sect. II.6), and the steps do not depend on the output
times. Only an integration that ended earlier clips its last step at its end; the extension
over the longer step differs there by the local error the tolerance allows, far below the
errors the references are used to measure.

The cache lives in this process only (a module dict): nothing is written to disk, and a caller
that times the integration itself (the scipy peers of :mod:`femb.benchmarks.peers`) does not
pass a key.
"""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

#: key -> (t_end, [(t_a, t_b, OdeSolution)], nfev): the dense solutions integrated in this process
_SOLUTIONS: dict = {}


def _segments(t_end, fine):
    """[(t_a, t_b, max_step)] covering [0, t_end]; ``fine`` = (t_a, t_b, max_step) caps the step there."""
    if fine is None:
        return [(0.0, t_end, np.inf)]
    ta, tb, hmax = (float(v) for v in fine)
    cuts = ((0.0, min(ta, t_end), np.inf), (max(ta, 0.0), min(tb, t_end), hmax), (max(tb, 0.0), t_end, np.inf))
    return [(a, b, s) for a, b, s in cuts if b > a]


def _solve(rhs, y0, t_eval, fine, ivp, dense):
    """Integrate consecutive segments from t = 0 to ``t_eval[-1]``.

    Returns the values at ``t_eval`` (nt, ny) with ``dense`` False (``solve_ivp(t_eval=...)``,
    no extension of the steps without output times), else [(t_a, t_b, OdeSolution)]; and nfev.
    Raises RuntimeError on failure.
    """
    y, nfev, pieces = np.asarray(y0, dtype=float), 0, []
    Y = np.empty((t_eval.size, y.size))
    Y[t_eval == 0.0] = y
    for a, b, hmax in _segments(float(t_eval[-1]), fine):
        inside = (t_eval > a) & (t_eval <= b)
        te = t_eval[inside]
        extra = te.size == 0 or te[-1] < b
        sol = solve_ivp(rhs, (a, b), y, dense_output=dense, t_eval=None if dense else
                        (np.append(te, b) if extra else te), max_step=hmax, **ivp)
        if not sol.success:
            raise RuntimeError(f"solve_ivp failed on [{a}, {b}]: {sol.message}")
        if dense:
            pieces.append((a, b, sol.sol))
        else:
            Y[inside] = sol.y.T[:-1] if extra else sol.y.T
        y, nfev = sol.y[:, -1], nfev + sol.nfev
    return (pieces if dense else Y), nfev


def integrate(rhs, y0, t_eval, *, key=None, fine=None, **ivp):
    """y(t_eval) for y' = rhs(t, y), y(0) = y0, by :func:`scipy.integrate.solve_ivp`.

    Parameters
    ----------
    rhs : callable
        ``rhs(t, y) -> y'``, shape (ny,).
    y0 : array_like, shape (ny,)
        State at t = 0.
    t_eval : array_like, shape (nt,)
        Increasing output times, t >= 0.
    key : hashable, optional
        Everything the solution depends on but the tolerances and method (the model's data,
        ``y0``): with a key, the dense solution is kept in this process and a later call with the
        same key, tolerances and method and a ``t_eval`` that ends no later evaluates it without
        integrating. None: ``solve_ivp(..., t_eval=t_eval)`` now, nothing kept (a timed run).
    fine : (t_a, t_b, max_step), optional
        A window with a cap on the step (short loads such as pulses): the integration is split at
        t_a and t_b so that no step crosses them.
    **ivp
        ``rtol``, ``atol``, ``method`` of ``solve_ivp``.

    Returns
    -------
    Y : ndarray, shape (nt, ny)
    nfev : int
        Right-hand-side evaluations of the integration the values come from (counted once when
        they come from the cache).

    Raises
    ------
    ValueError
        If ``t_eval`` is not increasing from t >= 0.
    RuntimeError
        If the integrator fails.
    """
    t_eval = np.atleast_1d(np.asarray(t_eval, dtype=float))
    y0 = np.asarray(y0, dtype=float)
    if np.any(np.diff(t_eval) < 0.0) or t_eval[0] < 0.0:
        raise ValueError("t_eval must be increasing from t >= 0")
    t_end = float(t_eval[-1])
    if t_end <= 0.0:
        return np.tile(y0, (t_eval.size, 1)), 0
    if key is None:
        return _solve(rhs, y0, t_eval, fine, ivp, dense=False)
    full = (key, fine, tuple(sorted(ivp.items())))
    got = _SOLUTIONS.get(full)
    if got is None or got[0] < t_end:
        pieces, nfev = _solve(rhs, y0, t_eval, fine, ivp, dense=True)
        _SOLUTIONS[full] = got = (t_end, pieces, nfev)
    _, pieces, nfev = got
    Y = np.empty((t_eval.size, y0.size))
    Y[t_eval == 0.0] = y0
    for a, b, sol in pieces:
        inside = (t_eval > a) & (t_eval <= b)
        if inside.any():
            Y[inside] = sol(t_eval[inside]).T
    return Y, nfev


def clear():
    """Forget every dense solution kept in this process."""
    _SOLUTIONS.clear()
