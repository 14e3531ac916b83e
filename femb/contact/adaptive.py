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
Such a step is accepted without an error test (counted in ``stats["unchecked_steps"]``) where it is at most
the first step's size h; a longer step in which a contact changes state without an impact (it sticks,
starts to slip, opens, or closes at rest) is taken again with h: that change is not located, and the
step's error there is of order h², one order lower than a smooth step's, which the estimate cannot see.
After such a step the next one is at most h (impacts may accumulate, as a bouncing ball's do before it comes to rest,
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
from femb.errors import ContactError
from femb.solve.options import ATOL_PER_RTOL, check_positive, error_constants


def tolerances(rtol, atol, h_max, t_span):
    """(rtol, atol, h_max, h_min) of an adaptive run, validated (atol defaults to ATOL_PER_RTOL · rtol as in
    :func:`femb.simulate`; h_min = 1e-10 · t_span)."""
    rtol = check_positive("rtol", rtol)
    atol = ATOL_PER_RTOL * rtol if atol is None else check_positive("atol", atol)
    h_max = math.inf if h_max is None else check_positive("h_max", h_max)
    return rtol, atol, h_max, 1e-10 * t_span


class ErrorNorm:
    """The weighted RMS error of the smooth part of a step (docs/stepsize.md §3) for one model.

    ``ctl`` = (rtol, atol, C_q, C_v). Calling it with the step's start and end (``q``, ``u``, ``ud``), its size
    h, the size of the step before and that step's jerk (None when it was not smooth: e_v is left out)
    returns (err, the step's jerk j_{n+1})."""

    def __init__(self, model, ctl):
        self.rtol, self.atol, self.Cq, self.Cv = ctl
        n = model.nq
        xmap = np.asarray(model.xmap) if model.lie else np.arange(n)
        self.ix = np.maximum(xmap, 0)                  # the configuration entry of each velocity entry
        self.add = (xmap >= 0).astype(float)           # 0 on rotations: their weight is atol alone

    def __call__(self, s, new, h, h_prev, j_prev):
        rtol, atol = self.rtol, self.atol
        dud = new.ud - s.ud
        mq = np.maximum(np.abs(s.q[self.ix]), np.abs(new.q[self.ix]))
        r = (self.Cq * h * h) * dud / (atol + rtol * self.add * mq)
        ss = float(r @ r)
        j = dud / h
        m = r.size
        if j_prev is not None:
            e_v = (self.Cv * h ** 3 / (0.5 * (h + h_prev))) * (j - j_prev)
            rv = e_v / (atol + rtol * np.maximum(np.abs(s.u), np.abs(new.u)))
            ss += float(rv @ rv)
            m += rv.size
        return (float(np.sqrt(ss / m)) if m else 0.0), j


def next_factor(err, err_prev):
    """Gustafsson's PI factor with exponent 3 (docs/stepsize.md §4), within [0.2, 2]; the I controller
    0.9 err^(−1/3) when there is no previous error."""
    if err <= 0.0:
        return 2.0
    fac = 0.9 * err ** (-1.0 / 3.0) if err_prev is None else \
        0.9 * err ** (-0.7 / 3.0) * (err_prev / err) ** (0.4 / 3.0)
    return min(2.0, max(0.2, fac))


class Steps:
    """What the controller needs of a time loop: try a step, take it back, keep it, build the result.

    ``try_step(h, n)`` returns (old, new, kind) with ``old``, ``new`` having ``t``, ``q``, ``u``, ``ud``
    (the step's start and end) and ``kind`` one of :data:`SMOOTH` (one (sub)step, no impact, no change of
    a contact's state since the step before), :data:`IMPACT` (an impact, or the step split into substeps)
    and :data:`SWITCH` (one step without an impact after which a contact's state differs: it closed
    without an impact, opened, stuck or began to slip; see :func:`step_kind`); or a str (the solver's
    message) when no solution was found (nothing kept). ``undo()`` forgets the step just tried, ``keep(n)`` stores it as step n, ``state()``
    the current StepState, ``result(h0, status, message, wall)`` the ContactResult of the kept steps.
    """


#: the kinds of step ``Steps.try_step`` reports
SMOOTH, IMPACT, SWITCH = "smooth", "impact", "switch"


def step_kind(impact, switch):
    """:data:`IMPACT` when the step had an impact or substeps, else :data:`SWITCH` when a contact's state
    differs from the step before, else :data:`SMOOTH`."""
    return IMPACT if impact else (SWITCH if switch else SMOOTH)


class PythonSteps(Steps):
    """The Python time loop (:func:`femb.contact.simulate._step` and its recorder); ``sim`` the module
    :mod:`femb.contact.simulate`, ``run_info`` = (tol, rho_inf, init_time)."""

    def __init__(self, stepper, s, rec, sim, vel_tol, locate, run_info):
        self.stepper, self.s, self.rec, self.sim = stepper, s, rec, sim
        self.vel_tol, self.locate, self.run_info = vel_tol, locate, run_info
        self.state_prev = None

    @property
    def t(self):
        return self.s.t

    def try_step(self, h, n):
        rec = self.rec
        self.mark = (len(rec.events), len(rec.iterations), len(rec.methods))
        try:
            self.pending = self.sim._step(self.stepper, self.s, h, n, rec, self.vel_tol, self.locate)
        except StepFailure as err:
            self.undo()
            return str(err)
        new, x, ev, sets, work = self.pending
        self.state_now = self.sim._states(ev, sets, self.stepper.lay, self.vel_tol)
        impact = len(rec.events) != self.mark[0] or len(rec.iterations) != self.mark[1] + 1
        switch = self.state_prev is not None and bool((self.state_now != self.state_prev).any())
        return self.s, new, step_kind(impact, switch)

    def undo(self):
        del self.rec.events[self.mark[0]:], self.rec.iterations[self.mark[1]:], self.rec.methods[self.mark[2]:]

    def keep(self, n):
        new, x, ev, sets, work = self.pending
        self.rec.store(new, x, ev, self.state_now, self.stepper, work)
        self.s, self.state_prev = new, self.state_now

    def state(self):
        return self.s

    def result(self, h0, status, message, wall):
        tol, rho_inf, init_time = self.run_info
        return self.rec.result(h0, rho_inf, tol, init_time, wall, status, message)


def run(steps, model, span, ctl, alpha, diagnose, vel_tol):
    """The adaptive time loop over ``steps`` (:class:`Steps`) from its current state to t_end.

    ``span`` = (t_end, h0); ``ctl`` = (rtol, atol, h_max, h_min); ``alpha`` the scheme's GeneralizedAlpha;
    ``diagnose`` :func:`femb.contact.simulate.diagnose`. Returns the ContactResult, or raises ContactError
    (with the partial result) when h falls below h_min.
    """
    t_end, h0 = span
    rtol, atol, h_max, h_min = ctl
    weighted_error = ErrorNorm(model, (rtol, atol) + tuple(error_constants(alpha)))
    t_loop = time.perf_counter()
    j_prev, h_prev, err_prev = None, h0, None
    counts = {"rejected_steps": 0, "unchecked_steps": 0, "failed_solves": 0}
    h_taken = []                                # every accepted step's size (the steps stored may be fewer)
    after_reject = False
    n = 0
    h = h_switch = min(h0, h_max)

    def stop(why, hk):
        res = _result(steps, h0, time.perf_counter() - t_loop, why, counts, ctl, h_taken)
        s = steps.state()
        name, reason = (diagnose(model, steps.stepper.lay, s, 1e-9 * model.length_scale, vel_tol, hk, res)
                        if why != "h_min" else (None, "the error estimate"))
        raise ContactError(f"contact step {n + 1} from t = {s.t:.6g} s: no step down to h = {hk:.3g} s "
                           f"(h_min {h_min:.3g} s): {reason} ({why})", contact=name, t=s.t, step=n + 1,
                           result=res) from None

    while t_end - steps.t > 1e-12 * max(abs(t_end), 1.0):
        rest = t_end - steps.t
        hk = rest if rest <= 1.05 * h else (0.5 * rest if rest < 2.0 * h else h)
        out = steps.try_step(hk, n + 1)
        if isinstance(out, str):                 # no solution: a quarter of the step
            counts["failed_solves"] += 1
            h, j_prev, err_prev = 0.25 * hk, None, None
            if h < h_min:
                stop(out, hk)
            continue
        old, new, kind = out
        if kind == SWITCH and hk > 1.05 * h_switch:
            # a contact changed state inside the step, without an impact: that change is not located, and the
            # step's error is of order h² there (one term lower than a smooth step's), which the estimate cannot
            # see (u̇ jumps). Taken with the first step's size, as the step after an impact is.
            steps.undo()
            counts["rejected_steps"] += 1
            h, err_prev, after_reject = h_switch, None, True
            continue
        if kind == SMOOTH:
            err, j = weighted_error(old, new, hk, h_prev, j_prev)
            if not err <= 1.0:
                steps.undo()
                counts["rejected_steps"] += 1
                h = hk * max(0.2, 0.9 * err ** (-1.0 / 3.0)) if np.isfinite(err) else 0.25 * hk
                err_prev, after_reject = None, True
                if h < h_min:
                    stop("h_min", hk)
                continue
            fac = next_factor(err, err_prev)
            h_next = hk * (min(fac, 1.0) if after_reject else fac)
            err_prev, j_prev = max(err, 1e-10), j
        else:                                   # an impact, or a change of contact state in a short step: no error test
            counts["unchecked_steps"] += 1
            h_next = min(hk, h0)                # at most the first step's size: impacts may accumulate
            err_prev, j_prev = None, None
        after_reject = False
        n += 1
        steps.keep(n)
        h_taken.append(hk)
        h_prev = hk
        h = min(max(h_next, h_min), h_max)
    return _result(steps, h0, time.perf_counter() - t_loop, "", counts, ctl, h_taken)


def _result(steps, h0, wall, message, counts, ctl, h_taken):
    res = steps.result(h0, "failed" if message else "success", message, wall)
    res.stats.update(counts)
    res.settings.update(adaptive=True, h0=h0, rtol=ctl[0], atol=ctl[1], h_max=ctl[2])
    res.settings["h"] = None
    res.h_steps = np.array(h_taken, dtype=float)
    res.n_rejected = counts["rejected_steps"]
    return res
