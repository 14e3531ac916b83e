"""Adaptive steps for :func:`femb.contact.simulate`: error control on the smooth part (docs/contact.md §1.2).

The nonsmooth generalized-α step is second order where the motion is smooth (between impacts, and
in persistent contact while no contact changes state). There the local error of the smooth part is
estimated as in femb's engine (docs/stepsize.md §1, §3) from the scheme's smooth accelerations u̇,
which satisfy the equations of motion and every active constraint at acceleration level (they are the
constrained accelerations q̈ᵖᵖ of the engine's estimate):

    e_q = C_q h² (u̇_{n+1} − u̇_n),    e_v = C_v h³ (j_{n+1} − j_n) / h̄,    j_{n+1} = (u̇_{n+1} − u̇_n) / h,

with C_q, C_v the error constants of generalized-α (:func:`femb.solve.options.error_constants`: the
scheme's position and velocity updates are Arnold & Brüls' plus the impulsive corrections U, Q, which
vanish on a smooth solution) and h̄ = (h + h_prev)/2. The error is the root mean square of e_q and e_v
weighted by atol + rtol · max(|x_n|, |x_{n+1}|) (rotation entries: atol alone, as in the engine); a step
with err > 1 is taken again from the same state with h · max(0.2, 0.9 err^(−1/3)), and the next step
size comes from Gustafsson's PI controller (docs/stepsize.md §4).

**At impacts and contact changes.** A step in which an impact happens (its split at the impact
included, docs/contact.md §1.1, item 2), or after which a contact's state (open, stick, slip) differs from the
step before, has no smooth error to measure: u̇ jumps there, and the scheme is first order by design.
Such a step is accepted without an error test (counted in ``stats["unchecked_steps"]``); the next step is
at most the first step's size h (impacts may accumulate, as a bouncing ball's do before it comes to rest,
and the impact location of §1.1, item 2 resolves a bounded number of them per step), and the controller and the
jerk start afresh from there. A step whose solve finds no
solution is taken again with h/4; below h_min the run stops with the time, the step and the solver's
last message.
"""
from __future__ import annotations

import math
import time

import numpy as np

from femb.contact.step import StepFailure
from femb.errors import ContactError, ParameterError
from femb.solve.options import ATOL_PER_RTOL, check_positive, error_constants


def tolerances(rtol, atol, h_max, t_span):
    """(rtol, atol, h_max, h_min) of an adaptive run, validated (atol defaults to ATOL_PER_RTOL · rtol as in
    :func:`femb.simulate`; h_min = 1e-10 · t_span)."""
    rtol = check_positive("rtol", rtol)
    atol = ATOL_PER_RTOL * rtol if atol is None else check_positive("atol", atol)
    h_max = math.inf if h_max is None else check_positive("h_max", h_max)
    return rtol, atol, h_max, 1e-10 * t_span


def weighted_error(model, s, new, h, h_prev, j_prev, ctl):
    """The weighted RMS error of the smooth part of the step s → new of size h, and the step's jerk j_{n+1}.

    ``j_prev`` is the jerk of the step before when that one was smooth too (else None: e_v is left out);
    ``ctl`` = (rtol, atol, C_q, C_v)."""
    rtol, atol, Cq, Cv = ctl
    j = (new.ud - s.ud) / h
    e_q = Cq * h * h * (new.ud - s.ud)
    w_q = atol + rtol * np.maximum(model.magnitude(s.q), model.magnitude(new.q))
    parts = [e_q / w_q]
    if j_prev is not None:
        e_v = Cv * h ** 3 * (j - j_prev) / (0.5 * (h + h_prev))
        parts.append(e_v / (atol + rtol * np.maximum(np.abs(s.u), np.abs(new.u))))
    r = np.concatenate(parts)
    return (float(np.sqrt(np.mean(r * r))) if r.size else 0.0), j


def next_factor(err, err_prev):
    """Gustafsson's PI factor with exponent 3 (docs/stepsize.md §4), within [0.2, 2]; the I controller
    0.9 err^(−1/3) when there is no previous error."""
    if err <= 0.0:
        return 2.0
    fac = 0.9 * err ** (-1.0 / 3.0) if err_prev is None else \
        0.9 * err ** (-0.7 / 3.0) * (err_prev / err) ** (0.4 / 3.0)
    return min(2.0, max(0.2, fac))


def run(stepper, s, rec, span, step, ctl, run_info):
    """The adaptive time loop from state s (stored) to t_end.

    ``span`` = (t_end, h0); ``step`` = (the one-step function of :mod:`femb.contact.simulate` with its
    signature ``(stepper, s, h, n, rec, vel_tol, locate)``, vel_tol, locate, states, diagnose); ``ctl`` = (rtol,
    atol, h_max, h_min); ``run_info`` = (tol, rho_inf, init_time) for the result. Returns the
    ContactResult, or raises ContactError (with the partial result) when h falls below h_min.
    """
    t_end, h = span
    take, vel_tol, locate, states, diagnose = step
    rtol, atol, h_max, h_min = ctl
    model, lay = stepper.model, stepper.lay
    Cq, Cv = error_constants(_alpha(stepper))
    est = (rtol, atol, Cq, Cv)
    tol, rho_inf, init_time = run_info
    t_loop = time.perf_counter()
    state_prev = None
    j_prev, h_prev, err_prev = None, h, None
    counts = {"rejected_steps": 0, "unchecked_steps": 0, "failed_solves": 0}
    after_reject = False
    n = 0
    h = min(h, h_max)
    while t_end - s.t > 1e-12 * max(abs(t_end), 1.0):
        rest = t_end - s.t
        hk = rest if rest <= 1.05 * h else (0.5 * rest if rest < 2.0 * h else h)
        mark = (len(rec.events), len(rec.iterations), len(rec.methods))
        try:
            new, x, ev, sets, work = take(stepper, s, hk, n + 1, rec, vel_tol, locate)
        except StepFailure as err:
            _rewind(rec, mark)
            counts["failed_solves"] += 1
            h = 0.25 * hk
            j_prev, err_prev = None, None
            if h < h_min:
                res = _result(rec, h, run_info, time.perf_counter() - t_loop, "failed", str(err), counts, ctl)
                name, why = diagnose(model, lay, s, 1e-9 * model.length_scale, vel_tol)
                raise ContactError(f"contact step {n + 1} from t = {s.t:.6g} s: no solution down to h = {hk:.3g} s "
                                   f"(h_min {h_min:.3g} s): {why} ({err})", contact=name, t=s.t, step=n + 1,
                                   result=res) from None
            continue
        state = states(ev, sets, lay, vel_tol)
        smooth = (len(rec.events) == mark[0] and len(rec.iterations) == mark[1] + 1
                  and (state_prev is None or np.array_equal(state, state_prev)))
        if smooth:
            err, j = weighted_error(model, s, new, hk, h_prev, j_prev, est)
            if not err <= 1.0:
                _rewind(rec, mark)
                counts["rejected_steps"] += 1
                h = hk * max(0.2, 0.9 * err ** (-1.0 / 3.0)) if np.isfinite(err) else 0.25 * hk
                err_prev, after_reject = None, True
                if h < h_min:
                    res = _result(rec, h, run_info, time.perf_counter() - t_loop, "failed", "step size below h_min",
                                  counts, ctl)
                    raise ContactError(f"contact step {n + 1} from t = {s.t:.6g} s: the error estimate {err:.3g} "
                                       f"needs h below h_min = {h_min:.3g} s", t=s.t, step=n + 1, result=res)
                continue
            fac = next_factor(err, err_prev)
            h_next = hk * (min(fac, 1.0) if after_reject else fac)
            err_prev, j_prev = max(err, 1e-10), j
        else:                                   # an impact or a change of contact state: no error test
            counts["unchecked_steps"] += 1
            h_next = min(hk, span[1])           # at most the first step's size: impacts may accumulate
            err_prev, j_prev = None, None
        after_reject = False
        rec.store(new, x, ev, state, stepper, work)
        s, state_prev, h_prev = new, state, hk
        n += 1
        h = min(max(h_next, h_min), h_max)
    return _result(rec, span[1], run_info, time.perf_counter() - t_loop, "success", "", counts, ctl)


def _alpha(stepper):
    from femb.solve.alpha import GeneralizedAlpha
    return GeneralizedAlpha.from_values(stepper.am, stepper.af, stepper.beta, stepper.gamma)


def _rewind(rec, mark):
    """Forget what a step that is taken again had booked (events, iterations, methods)."""
    del rec.events[mark[0]:], rec.iterations[mark[1]:], rec.methods[mark[2]:]


def _result(rec, h0, run_info, wall, status, message, counts, ctl):
    tol, rho_inf, init_time = run_info
    res = rec.result(h0, rho_inf, tol, init_time, wall, status, message)
    res.stats.update(counts)
    res.settings.update(adaptive=True, h0=h0, rtol=ctl[0], atol=ctl[1], h_max=ctl[2])
    res.settings["h"] = None
    res.h_steps = np.diff(res.t)
    res.n_rejected = counts["rejected_steps"]
    return res


def check_compiled(compiled):
    """The compiled loop has fixed steps only: ``compiled=True`` with rtol is a ParameterError."""
    if compiled:
        raise ParameterError("compiled=True: the compiled contact loop takes fixed steps only; adaptive steps "
                             "(rtol) run in the Python loop (docs/contact.md §1.2)")
