"""The Python side of the compiled time loop (:mod:`femb.contact.loop`): its arrays, its entry, the
steps it hands back to the Python loop, and the result.

:func:`applies` says whether a model's steps can run compiled; :func:`run` takes the steps 1 … N
from the starting state and returns what :func:`femb.contact.simulate` returns, with the same
contents as its Python loop (docs/contact.md §7).
"""
from __future__ import annotations

import importlib
import time
from types import SimpleNamespace

import numpy as np

from femb.base.jit import jit_disabled
from femb.contact import loop
from femb.contact.adaptive import Steps, step_kind
from femb.contact.step import StepFailure, StepState, _entry_point, _owned
from femb.errors import ContactError

_F = loop.FIELDS.index


def applies(stepper):
    """Whether the steps of ``stepper``'s model run in the compiled loop: the dense path with the whole
    Newton iteration compiled (constant mass), no time functions, no equations removed as redundant."""
    if jit_disabled() or not stepper.dense or not stepper._loop_ok or stepper.Minv is None:
        return False
    return not stepper.dm.timed and stepper.dm.removed.size == 0


class _Arrays:
    """The compiled loop's outputs: a window of ``rows`` stored steps after row 0 (each call of the loop
    writes its steps into rows 1, 2, …; :class:`_Kept` takes the rows to keep), events, iterations, counters."""

    def __init__(self, rec0, rows, lay, n):
        nt = rows + 1
        self.out = tuple(np.zeros((nt,) + np.shape(a)[1:], dtype=a.dtype) for a in rec0)
        for a, b in zip(self.out, rec0):
            a[0] = b[0]
        self.ev_f, self.ev_u = np.zeros((16, 7)), np.zeros((16, 2, n))
        self.its = np.zeros(max(64, 2 * rows), dtype=np.int64)
        self.cnt = np.zeros(4, dtype=np.int64)
        self.wsum = np.array(rec0[-1][0], dtype=float)
        self.methods_fp = 0
        self.methods_P = 0

    def pack(self):
        return self.out, self.ev_f, self.ev_u, self.its, self.cnt, self.wsum

    def grow(self):
        """Double the arrays that are full (events, substeps)."""
        if self.cnt[0] + 64 >= self.ev_f.shape[0]:
            self.ev_f = np.concatenate((self.ev_f, np.zeros_like(self.ev_f)))
            self.ev_u = np.concatenate((self.ev_u, np.zeros_like(self.ev_u)))
        if self.cnt[1] + 256 >= self.its.size:
            self.its = np.concatenate((self.its, np.zeros_like(self.its)))

    def renumber(self, first, base):
        """The events from ``first`` on were booked with their step's row in the window: add ``base``."""
        self.ev_f[first:self.cnt[0], 1] += base

    def add_events(self, events, names, n):
        """Events and iterations of a step the Python loop took."""
        for e in events:
            self.grow()
            k = self.cnt[0]
            self.ev_f[k] = (e["t"], e["step"], names.index(e["contact"]), e["v_before"], e["v_after"],
                            e["Lambda_N"], e["P_N"])
            self.ev_u[k] = (e["u_before"], e["u_after"])
            self.cnt[0] += 1

    def add_iterations(self, its, methods):
        for it, m in zip(its, methods):
            self.grow()
            self.its[self.cnt[1]] = it
            self.cnt[1] += 1
            self.methods_fp += m == "fixed_point"
            self.methods_P += m == "slip_on_P"

    def steps(self, kept, names):
        """The dict of :func:`femb.contact.simulate.contact_result` of the rows ``kept`` (:class:`_Kept`)."""
        t, q, u, ud, lam, gN, gNd, lN, LN, PN, state, gF, lF, LF, PF, work = kept.arrays()
        contact = dict(gN=gN, gN_d=gNd, lam_N=lN, Lam_N=LN, P_N=PN, state=state, gam_F=gF, lam_F=lF, Lam_F=LF,
                       P_F=PF, work_N=work[:, 0].copy(), work_F=work[:, 1].copy())
        events = [dict(t=float(f[0]), step=int(f[1]), contact=names[int(f[2])], v_before=float(f[3]),
                       v_after=float(f[4]), Lambda_N=float(f[5]), P_N=float(f[6]), u_before=uu[0].copy(),
                       u_after=uu[1].copy()) for f, uu in zip(self.ev_f[:self.cnt[0]], self.ev_u[:self.cnt[0]])]
        return dict(t=t, q=q, qd=u, qdd=ud, lam=lam, contact=contact, iterations=self.its[:self.cnt[1]].copy(),
                    n_steps=kept.n, fixed_point_steps=self.methods_fp + int(self.cnt[2]),
                    slip_on_P_steps=self.methods_P + int(self.cnt[3]), events=events)


class _Kept:
    """The stored steps of a compiled run, taken from the window of :class:`_Arrays` after each call of the
    loop: step 0, every ``every``-th step (none with 0) and the last step taken
    (:func:`femb.contact.simulate.stored_step`), in arrays of ``capacity`` rows (fixed steps: the rows known
    ahead) that double when full (adaptive steps)."""

    def __init__(self, out, every, capacity=256):
        self.every, self.n = every, 0
        self.bufs = [np.empty((max(int(capacity), 1),) + a.shape[1:], dtype=a.dtype) for a in out]
        self.k = 0
        self._append(out, slice(0, 1, 1))
        self.last = None

    def _append(self, out, sel):
        m = len(range(*sel.indices(out[0].shape[0])))
        if self.k + m > self.bufs[0].shape[0]:
            size = max(2 * self.bufs[0].shape[0], self.k + m)
            self.bufs = [np.concatenate((b[:self.k], np.empty((size - self.k,) + b.shape[1:], dtype=b.dtype)))
                         for b in self.bufs]
        for b, a in zip(self.bufs, out):
            b[self.k:self.k + m] = a[sel]
        self.k += m

    def add(self, out, base, m):
        """Rows 1 … m of the window ``out`` hold the steps base + 1 … base + m."""
        if m <= 0:
            return
        k = self.every
        if k == 1:
            sel = slice(1, m + 1, 1)
        else:                           # rows j with (base + j) % k == 0, as a slice
            j0 = k - base % k if k else m + 1
            sel = slice(j0, m + 1, k or 1)
        self._append(out, sel)
        stop = sel.start + ((m - sel.start) // sel.step) * sel.step if sel.start <= m else -1
        self.last = None if stop == m else tuple(a[m].copy() for a in out)
        self.n = base + m

    def arrays(self):
        trim = 4 * self.k < 3 * self.bufs[0].shape[0]        # over a quarter unused (doubled arrays): copies
        cols = [b[:self.k].copy() if trim else b[:self.k] for b in self.bufs]
        if self.last is None:
            return cols
        return [np.concatenate((c, r[None])) for c, r in zip(cols, self.last)]


#: bytes of the window of stored steps of one call of the compiled loop (its rows: at most WINDOW_ROWS)
WINDOW_BYTES = 2 ** 24
WINDOW_ROWS = 4096


def window_rows(rec0, nsteps):
    """Rows of the window for a run of ``nsteps`` steps whose stored step looks like ``rec0``."""
    row = sum(a.nbytes for a in rec0)
    return int(max(1, min(nsteps, WINDOW_ROWS, WINDOW_BYTES // max(row, 1))))


def _rec0(rec):
    """The stored first step of a :class:`femb.contact.simulate._Recorder` as rows of the output arrays."""
    row = rec.rows[0]
    out = tuple(np.array(r, dtype=np.int8 if k == 10 else float).reshape(1, -1) for k, r in enumerate(row[1:15], 1))
    return (np.array([row[0]], dtype=float),) + out + (np.array([[row[15], row[16]]]),)


def _put_state(P, F, s, stepper):
    """Row 0 of P from the StepState s (with its prox parameters, as the Python loop's next solve forms them)."""
    row = P[0]
    vals = dict(t=s.t, q=s.q, u=s.u, ud=s.ud, abar=s.abar, lam_N=s.lam_N, lam_F=s.lam_F, lbar_N=s.lbar_N,
                lbar_F=s.lbar_F, gNd=s.gNd, gFd=s.gFd, x=s.x, gN=s.gN, gNdd=s.gNdd)
    vals["rN"], vals["rF"] = stepper.prox_r(s.q, s.t)
    for key, v in vals.items():
        i = _F(key)
        row[F[i]:F[i + 1]] = v


def _get_state(P, F):
    """The StepState of row 0 of P (owned arrays)."""
    row = P[0]
    v = {key: row[F[i]:F[i + 1]].copy() for i, key in enumerate(loop.FIELDS)}
    return StepState(float(v["t"][0]), v["q"], v["u"], v["ud"], v["abar"], v["lam_N"], v["lam_F"], v["lbar_N"],
                     v["lbar_F"], v["gNd"], v["gFd"], v["x"], gN=v["gN"], gNdd=v["gNdd"])


def _context(stepper, F, vel_tol, locate):
    dm = stepper.dm
    cst = np.array([stepper.tol, stepper.m_ref, stepper.am, stepper.af, stepper.beta, stepper.gamma, stepper.max_iter,
                    stepper.freeze_after, stepper.h_fixed, vel_tol, 1e-9 * stepper.model.length_scale, float(locate),
                    stepper.max_fp, float(stepper.slip_on_P), stepper.h_acc])
    mdl = (dm.recs, dm.qx, dm.ux, dm.f0, dm.removed)
    return (F, mdl, stepper._lay, stepper._fixed_law, stepper._work, cst, _owned(stepper.Minv),
            (np.zeros(0), np.zeros(stepper.lay.nN)))


def _entry(dm, args):
    """The compiled :func:`femb.contact.loop.run_steps` for the argument types of ``dm``'s model (kept on the
    DenseModel: forming the types of its batch records anew costs milliseconds a run)."""
    fn = getattr(dm, "_loop_entry", None)
    if fn is None:
        fn = dm._loop_entry = _entry_point(loop.run_steps, args, loop.build_plan)
    return fn


def _python_step(stepper, P, F, n, arr, ctx, loop_args, row=1):
    """Step n by the Python loop (its own solve found no solution in the compiled loop): stored in row
    ``row`` of the window, row 0 of P advanced. Raises StepFailure as the Python loop does."""
    sim = importlib.import_module("femb.contact.simulate")
    h, vel_tol, locate = loop_args
    s = _get_state(P, F)
    tmp = sim._Recorder(stepper.model, stepper.lay)
    s1, x, ev, sets, work = sim._step(stepper, s, h, n, tmp, vel_tol, locate)
    arr.add_iterations(tmp.iterations, tmp.methods)
    arr.add_events(tmp.events, list(stepper.lay.names), n)
    arr.wsum += work[:2]
    _put_state(P, F, s1, stepper)
    r = P[0]
    r[F[_F("PN")]:F[_F("PN") + 1]] = ev["PN"]
    r[F[_F("PF")]:F[_F("PF") + 1]] = ev["PF"]
    r[F[_F("sum_PN")]:] = work[2:]              # the step's sums: P_N, Λ_N, P_F, Λ_F (simulate._sums)
    r[F[_F("sets")]:F[_F("sets") + 1]] = np.concatenate([np.asarray(a, dtype=float) for a in sets])
    loop.store(P, row, ctx, arr.pack())


#: wall time of one call of the compiled loop in :func:`run` (the steps per call grow to it)
CALL_SECONDS = 0.1


def run(stepper, s, rec, nsteps, h, info):
    """Steps 1 … nsteps from the StepState s (stored as step 0 in ``rec``) in the compiled loop.

    ``info`` = (vel_tol, locate, rho_inf, init_time). Returns the ContactResult, with the steps that
    ``rec.every`` selects (:func:`femb.contact.simulate.stored_step`); raises ContactError as
    :func:`femb.contact.simulate.simulate` does."""
    sim = importlib.import_module("femb.contact.simulate")
    vel_tol, locate, rho_inf, init_time = info
    model, lay = stepper.model, stepper.lay
    t_load = time.perf_counter()
    F = loop.offsets(s.q.size, model.nq, stepper.nx, lay.nN, lay.nF)
    P = np.zeros((3, int(F[-1])))
    _put_state(P, F, s, stepper)
    ctx = _context(stepper, F, vel_tol, locate)
    rec0 = _rec0(rec)
    W = window_rows(rec0, nsteps)
    arr = _Arrays(rec0, W, lay, model.nq)
    kept = _Kept(arr.out, rec.every, 2 + (nsteps // rec.every if rec.every else 0))
    _entry(stepper.dm, (P, float(h), 1, 1, ctx, arr.pack()))     # compiled, or loaded from the cache
    init_time += time.perf_counter() - t_load                   # (about 1 s from the disk cache): the start's time, not the loop's
    t_loop = time.perf_counter()
    n, chunk = 1, 16
    while n <= nsteps:
        # the steps in calls of about CALL_SECONDS: between them Python sees Ctrl-C (one call over every
        # step held a KeyboardInterrupt until the run's end, 30 s for 1e6 steps of the ball); each call
        # writes its steps into rows 1, 2, … of the window, and the rows to keep are taken from there
        base, first = n - 1, int(arr.cnt[0])
        args = (P, float(h), 1, min(nsteps - base, chunk, W), ctx, arr.pack())
        t_call = time.perf_counter()
        status, j = _entry(stepper.dm, args)(*args)
        arr.renumber(first, base)
        kept.add(arr.out, base, j - 1)
        n = base + j
        if status == loop.DONE and time.perf_counter() - t_call < 0.5 * CALL_SECONDS:
            chunk *= 2
        if status == loop.FULL:
            arr.grow()
        elif status == loop.PYTHON:
            try:
                _python_step(stepper, P, F, n, arr, ctx, (h, vel_tol, locate))
            except StepFailure as err:
                res = sim.contact_result(model, lay, arr.steps(kept, list(lay.names)),
                                         (h, rho_inf, stepper.tol, init_time, time.perf_counter() - t_loop, "failed",
                                          str(err)))
                s = _get_state(P, F)
                name, why = sim.diagnose(model, lay, s, 1e-9 * model.length_scale, vel_tol, h, res)
                raise ContactError(f"contact step {n} from t = {s.t:.6g} s to t = {s.t + h:.6g} s failed: {why} "
                                   f"({err})", contact=name, t=s.t + h, step=n, result=res) from None
            kept.add(arr.out, n - 1, 1)
            n += 1
    wall = time.perf_counter() - t_loop
    return sim.contact_result(model, lay, arr.steps(kept, list(lay.names)),
                              (h, rho_inf, stepper.tol, init_time, wall, "success", ""))


class CompiledSteps(Steps):
    """The compiled loop one step at a time, for the adaptive controller (:mod:`femb.contact.adaptive`):
    each try is :func:`femb.contact.loop.run_steps` over one step of the size asked, written into row 1 of a
    window whose row 0 holds the step kept before (a step whose own solve finds no solution goes to the
    Python loop, as in :func:`run`); a step taken back restores row 0 of the state, the counters and the
    work sum. ``run_info`` = (tol, rho_inf, init_time); ``every`` the steps stored (:class:`_Kept`)."""

    def __init__(self, stepper, s, rec, vel_tol, locate, run_info):
        self.sim = importlib.import_module("femb.contact.simulate")
        self.stepper, self.vel_tol, self.locate = stepper, vel_tol, locate
        model, lay = stepper.model, stepper.lay
        t_load = time.perf_counter()
        self.F = loop.offsets(s.q.size, model.nq, stepper.nx, lay.nN, lay.nF)
        self.P = np.zeros((3, int(self.F[-1])))
        _put_state(self.P, self.F, s, stepper)
        self.ctx = _context(stepper, self.F, vel_tol, locate)
        self.arr = _Arrays(_rec0(rec), 1, lay, model.nq)
        self.kept = _Kept(self.arr.out, rec.every)
        self.entry = _entry(stepper.dm, (self.P, 1.0, 1, 1, self.ctx, self.arr.pack()))
        tol, rho_inf, init_time = run_info
        self.run_info = (tol, rho_inf, init_time + time.perf_counter() - t_load)
        F = self.F
        self._it = int(F[_F("t")])
        self._sl = [slice(int(F[_F(k)]), int(F[_F(k) + 1])) for k in ("q", "u", "ud")]

    @property
    def t(self):
        return float(self.P[0, self._it])

    def _view(self, row):
        q, u, ud = self._sl
        return SimpleNamespace(t=float(row[self._it]), q=row[q], u=row[u], ud=row[ud])

    def try_step(self, h, n):
        arr = self.arr
        self.save = (self.P[0].copy(), arr.cnt.copy(), arr.wsum.copy(), arr.methods_fp, arr.methods_P)
        while True:
            args = (self.P, float(h), 1, 1, self.ctx, arr.pack())
            status, _ = self.entry(*args)
            if status != loop.FULL:
                break
            arr.grow()
        arr.renumber(int(self.save[1][0]), n - 1)
        if status == loop.PYTHON:
            try:
                _python_step(self.stepper, self.P, self.F, n, arr, self.ctx, (h, self.vel_tol, self.locate))
            except StepFailure as err:
                self.undo()
                return str(err)
        c0, state = self.save[1], arr.out[10]
        impact = arr.cnt[0] != c0[0] or arr.cnt[1] != c0[1] + 1
        switch = n > 1 and bool((state[1] != state[0]).any())
        return self._view(self.save[0]), self._view(self.P[0].copy()), step_kind(impact, switch)

    def undo(self):
        row, cnt, wsum, fp, fP = self.save
        self.P[0, :] = row
        self.arr.cnt[:] = cnt
        self.arr.wsum[:] = wsum
        self.arr.methods_fp, self.arr.methods_P = fp, fP

    def keep(self, n):
        self.kept.add(self.arr.out, n - 1, 1)
        for a in self.arr.out:          # the step kept is row 0 of the next try's window
            a[0] = a[1]

    def state(self):
        return _get_state(self.P, self.F)

    def result(self, h0, status, message, wall):
        tol, rho_inf, init_time = self.run_info
        lay = self.stepper.lay
        return self.sim.contact_result(self.stepper.model, lay, self.arr.steps(self.kept, list(lay.names)),
                                       (h0, rho_inf, tol, init_time, wall, status, message))
