"""Fixed-step simulation of models with unilateral contacts and friction (docs/contact.md §4).

:func:`simulate` starts from a state consistent with the bilateral constraints and the
closed contacts (accelerations and contact forces from the acceleration-level contact
problem), advances it by :class:`femb.contact.step.NonsmoothStep`, and returns a
:class:`femb.contact.result.ContactResult`.
"""
from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from femb import assembly
from femb.alpha import GeneralizedAlpha
from femb.contact import assemble
from femb.contact.prox import prox_disc
from femb.contact.result import OPEN, SLIP, STICK, ContactResult
from femb.contact.step import NonsmoothStep, StepFailure, StepState
from femb.errors import ContactError, ModelError, ParameterError
from femb.initial import consistent_initial_state


def _kkt(model, t, q):
    """LU of [[M, Φ_qᵀ], [Φ_q, 0]] at (t, q)."""
    M = model.M_const if model.constant_mass else assembly.mass_matrix(model, q)
    B = assembly.constraint_jacobian(model, t, q)
    return spla.splu(sp.bmat([[M, B.T], [B, None]], format="csc") if model.nc else sp.csc_matrix(M))


def _solve_kkt(lu, model, rhs_q, rhs_c):
    x = lu.solve(np.concatenate((rhs_q, rhs_c)))
    return x[:model.nq], x[model.nq:]


def initial_contact_forces(model, lay, st, gap_tol, vel_tol, max_iter=20000):
    """Accelerations and contact forces at t₀ for the contacts that are closed (g_N ≤ gap_tol and
    |ġ_N| ≤ vel_tol): the acceleration-level contact problem (Signorini on g̈_N, Coulomb on γ̇_F
    or the slip law on γ_F), solved by a projected Jacobi fixed point with prox parameters
    1/(W M⁻¹ Wᵀ)_ii (Studer 2009, §3.4).

    Returns
    -------
    (ud, lam_g, lam_N, lam_F)
    """
    t, q, u = st.t, st.q, st.qd
    ev = assemble.evaluate(model, t, q, u)
    WN, WF = ev["WN"], ev["WF"]
    closed = (ev["gN"] <= gap_tol) & (np.abs(WN @ u) <= vel_tol)
    lN, lF = np.zeros(lay.nN), np.zeros(lay.nF)
    f = assembly.force_vector(model, t, q, u)
    _, gam = assembly.constraint_rates(model, t, q, u)
    lu = _kkt(model, t, q)
    ud, lg = _solve_kkt(lu, model, f, -gam)
    if not closed.any():
        return ud, lg, lN, lF
    W = sp.vstack((WN, WF)).tocsc()
    G = np.array([(W[k] @ _solve_kkt(lu, model, W[k].toarray().ravel(), np.zeros(model.nc))[0])[0]
                  for k in range(W.shape[0])])
    r = 1.0 / np.maximum(G, 1e-300)
    gF = WF @ u
    for _ in range(max_iter):
        ud, lg = _solve_kkt(lu, model, f + WN.T @ lN + WF.T @ lF, -gam)
        gNdd = WN @ ud + ev["zN"]
        gFdd = WF @ ud + ev["zF"]
        lN1 = np.where(closed, np.maximum(lN - r[:lay.nN] * gNdd, 0.0), 0.0)
        lF1 = np.zeros(lay.nF)
        for i, idx in enumerate(lay.friction):
            if not (idx.size and closed[i]):
                continue
            if np.linalg.norm(gF[idx]) > vel_tol:               # slipping: λ_F = −μ λ_N γ_F/|γ_F|
                lF1[idx] = -lay.mu[i] * lN1[i] * gF[idx] / np.linalg.norm(gF[idx])
            else:
                lF1[idx] = prox_disc(lF[idx] - r[lay.nN + idx] * gFdd[idx], lay.mu[i] * lN1[i])
        change = max(np.max(np.abs(lN1 - lN), initial=0.0), np.max(np.abs(lF1 - lF), initial=0.0))
        lN, lF = lN1, lF1
        if change <= 1e-13 * max(1.0, np.max(np.abs(lN), initial=0.0)):
            break
    ud, lg = _solve_kkt(lu, model, f + WN.T @ lN + WF.T @ lF, -gam)
    return ud, lg, lN, lF


def _check_parameters(model, t_end, h, rho_inf, t0):
    for name, v in (("t_end", t_end), ("h", h), ("t0", t0)):
        try:
            v = float(v)
        except (TypeError, ValueError):
            raise ParameterError(f"{name} must be a number, got {v!r}") from None
        if not np.isfinite(v):
            raise ParameterError(f"{name} must be finite, got {v!r}")
    if not float(h) > 0.0:
        raise ParameterError(f"h must be positive, got {h!r}")
    if not float(t_end) > float(t0):
        raise ParameterError(f"t_end ({t_end!r}) must exceed t0 ({t0!r})")
    if not 0.0 <= float(rho_inf) < 1.0:
        raise ParameterError(f"rho_inf must lie in [0, 1) for the nonsmooth scheme (strict stability at "
                             f"infinity, docs/contact.md §2), got {rho_inf!r}")
    if not hasattr(model, "contact_groups"):
        raise ModelError("femb.contact.simulate needs a compiled femb Model (Mechanism.compile())")


def diagnose(model, lay, s, gap_tol, vel_tol):
    """Why a step has no consistent contact force: (contact name, reason) or (None, reason).

    For every closed, slipping contact i with μ_i > 0 it forms the normal acceleration's
    response to its own normal force when friction opposes the slip, a_i = W_N,i G (W_N,i −
    μ_i ŝ W_F,i)ᵀ with G the constrained inverse mass (the KKT matrix), and the free normal
    acceleration b_i. a_i ≤ 0 is Painlevé's paradox (Painlevé 1895; Génot & Brogliato,
    Eur. J. Mech. A 18 (1999) 653–677): no non-negative λ_N gives g̈_N = b_i + a_i λ_N ≥ 0 with
    complementarity when b_i < 0 (inconsistency), two solutions when b_i > 0 (indeterminacy).
    """
    t, q, u = s.t, s.q, s.u
    ev = assemble.evaluate(model, t, q, u)
    WN, WF = ev["WN"], ev["WF"]
    lu = _kkt(model, t, q)
    f = assembly.force_vector(model, t, q, u)
    _, gam = assembly.constraint_rates(model, t, q, u)
    ud0, _ = _solve_kkt(lu, model, f, -gam)
    for i, idx in enumerate(lay.friction):
        gF = WF[idx] @ u if idx.size else np.zeros(0)
        if not (idx.size and lay.mu[i] > 0 and ev["gN"][i] <= gap_tol and np.linalg.norm(gF) > vel_tol):
            continue
        shat = gF / np.linalg.norm(gF)
        w = WN[i].toarray().ravel() - lay.mu[i] * (shat @ WF[idx].toarray())
        x, _ = _solve_kkt(lu, model, w, np.zeros(model.nc))
        a = float(WN[i] @ x)
        b = float(WN[i] @ ud0 + ev["zN"][i])
        if a <= 0.0:
            kind = "inconsistency: no contact force exists" if b < 0 else "indeterminacy: the contact force is not unique"
            return lay.names[i], (f"contact '{lay.names[i]}' slips at {np.linalg.norm(gF):.4g} m/s with μ = "
                                  f"{lay.mu[i]:g}, and its normal acceleration falls as its normal force grows "
                                  f"(W_N G (W_N − μ ŝ W_F)ᵀ = {a:.4g} ≤ 0; free normal acceleration {b:.4g}): "
                                  f"Painlevé's paradox, {kind} for Coulomb friction")
    return None, "no consistent contact forces found (no slipping contact shows Painlevé's paradox)"


def _states(ev, sets, lay, vel_tol):
    A, B_, C, D, E = sets
    closed = A & (B_ | C)
    st = np.full(lay.nN, OPEN, dtype=np.int8)
    for i, idx in enumerate(lay.friction):
        if closed[i]:
            slip = idx.size and np.linalg.norm(ev["gF"][idx]) > vel_tol
            st[i] = SLIP if slip else STICK
    return st


def simulate(model, t_end, h, *, rho_inf=0.8, t0=0.0, tol=None, max_iter=40, max_fixed_point=400):
    """Integrate a model with contacts by the nonsmooth generalized-α method, fixed steps.

    Parameters
    ----------
    model : Model or Mechanism
        With contact elements (:mod:`femb.elements.contact`); bilateral joints are allowed.
    t_end : float
    h : float
        Step size (adjusted slightly so that the steps end on t_end).
    rho_inf : float in [0, 1)
        Spectral radius at infinity of the smooth part (α_m, α_f, β, γ by Chung & Hulbert).
    t0 : float
    tol : float, optional
        Newton tolerance on the residual in length units (default 1e-12 × length scale).
    max_iter, max_fixed_point : int
        Semismooth Newton iterations per step; prox fixed-point iterations of the fallback.

    Returns
    -------
    ContactResult

    Raises
    ------
    ContactError
        A step found no consistent contact forces: names the time, the step, the contact and
        why (Painlevé's paradox diagnosed, :func:`diagnose`); carries the partial result.
    ModelError
        A contact starts penetrated.
    """
    if hasattr(model, "compile") and not hasattr(model, "contact_groups"):
        model = model.compile()
    _check_parameters(model, t_end, h, rho_inf, t0)
    t0, t_end = float(t0), float(t_end)
    nsteps = max(1, int(round((t_end - t0) / float(h))))
    h = (t_end - t0) / nsteps
    L = model.length_scale
    tol = 1e-12 * L if tol is None else float(tol)
    lay = assemble.layout(model)
    stepper = NonsmoothStep(model, h, GeneralizedAlpha.from_rho_inf(rho_inf), lay, tol, max_iter, max_fixed_point)
    vel_tol = max(100.0 * tol / h, 1e-12)
    t_init = time.perf_counter()
    st = consistent_initial_state(model, t0=t0)
    ev0 = assemble.evaluate(model, t0, st.q, st.qd)
    bad = np.nonzero(ev0["gN"] < -1e-10 * L)[0]
    if bad.size:
        i = bad[0]
        raise ModelError(f"contact '{lay.names[i]}' starts penetrated: g_N = {ev0['gN'][i]:.6g} m < 0 at t0 = {t0:g}; "
                         "place the bodies apart or touching")
    ud, lg, lN, lF = initial_contact_forces(model, lay, st, 1e-9 * L, vel_tol)
    s = StepState(t0, st.q.copy(), st.qd.copy(), ud, ud.copy(), lN, lF, lN.copy(), lF.copy(),
                  ev0["WN"] @ st.qd, ev0["WF"] @ st.qd)
    x0 = np.zeros(stepper.nx)
    o = stepper.offsets
    x0[o[0]:o[1]] = ud
    x0[o[5]:o[6]] = lg
    x0[o[8]:o[9]] = lN
    x0[o[10]:o[11]] = lF
    s.x = x0
    rec = _Recorder(model, lay, nsteps)
    rec.store(s.t, s.q, s.u, ud, lg, ev0, None, np.zeros(lay.nN, dtype=np.int8), stepper, x0, s)
    init_time = time.perf_counter() - t_init
    t_loop = time.perf_counter()
    for n in range(1, nsteps + 1):
        try:
            x, ev, sets, info = stepper.solve(s)
        except StepFailure as err:
            res = rec.result(h, rho_inf, tol, init_time, time.perf_counter() - t_loop, "failed", str(err))
            name, why = diagnose(model, lay, s, 1e-9 * L, vel_tol)
            raise ContactError(f"contact step {n} from t = {s.t:.6g} s to t = {s.t + h:.6g} s failed: {why} "
                               f"({err})", contact=name, t=s.t + h, step=n, result=res) from None
        before = s.gNd
        s = _advance(stepper, s, x, ev)
        rec.iterations.append(info["iterations"])
        rec.methods.append(info["method"])
        rec.store(s.t, s.q, s.u, s.ud, stepper.split(x)[5], ev, sets, _states(ev, sets, lay, vel_tol), stepper, x,
                  s, events=(n, vel_tol, before))
    return rec.result(h, rho_inf, tol, init_time, time.perf_counter() - t_loop, "success", "")


def _advance(stepper, s, x, ev):
    """The state after an accepted step (ā, λ̄ carried as in eqs. (71), (96), (114))."""
    parts = stepper.split(x)
    return StepState(s.t + stepper.h, ev["q"], ev["u"], parts[0].copy(), ev["abar"], parts[8].copy(),
                     parts[10].copy(), ev["lbar_N"], ev["lbar_F"], ev["gNd"], ev["gF"], x.copy())


class _Recorder:
    """Stores every step and builds the :class:`ContactResult`."""

    def __init__(self, model, lay, nsteps):
        self.model, self.lay = model, lay
        self.t, self.q, self.u, self.ud, self.lam = [], [], [], [], []
        self.c = {k: [] for k in ("gN", "gN_d", "lam_N", "Lam_N", "P_N", "state", "gam_F", "lam_F", "Lam_F", "P_F",
                                  "work_N", "work_F")}
        self.iterations, self.methods, self.events = [], [], []
        self._u_prev = None
        self._wN = self._wF = 0.0

    def store(self, t, q, u, ud, lam, ev, sets, state, stepper, x, s, events=None):
        parts = stepper.split(x)
        PN = ev.get("PN", np.zeros(self.lay.nN))
        PF = ev.get("PF", np.zeros(self.lay.nF))
        if self._u_prev is not None:
            um = 0.5 * (self._u_prev + u)
            self._wN += float(um @ (ev["WN"].T @ PN))
            self._wF += float(um @ (ev["WF"].T @ PF))
        self._u_prev = u.copy()
        self.t.append(t)
        self.q.append(q.copy())
        self.u.append(u.copy())
        self.ud.append(ud.copy())
        self.lam.append(np.array(lam, dtype=float))
        for key, val in (("gN", ev["gN"]), ("gN_d", ev["WN"] @ u), ("lam_N", parts[8]), ("Lam_N", parts[7]),
                         ("P_N", PN), ("state", state), ("gam_F", ev["WF"] @ u), ("lam_F", parts[10]),
                         ("Lam_F", parts[9]), ("P_F", PF), ("work_N", self._wN), ("work_F", self._wF)):
            self.c[key].append(np.array(val, copy=True))
        if events is not None:
            self._events(*events, t, ev, parts, state)

    def _events(self, n, vel_tol, before, t, ev, parts, state):
        """Impacts: a contact closed at the end of a step that began approaching (ġ_N(t_n) < 0), with P_N > 0."""
        after = ev["WN"] @ ev["u"]
        for i in np.nonzero((before < -vel_tol) & (state != OPEN) & (ev["PN"] > 0.0))[0]:
            self.events.append(dict(t=t, step=n, contact=self.lay.names[i], v_before=float(before[i]),
                                    v_after=float(after[i]), Lambda_N=float(parts[7][i]), P_N=float(ev["PN"][i])))

    def result(self, h, rho_inf, tol, init_time, wall, status, message):
        m, lay = self.model, self.lay
        contact = {k: np.array(v) for k, v in self.c.items()}
        for k, n in (("gN", lay.nN), ("gN_d", lay.nN), ("lam_N", lay.nN), ("Lam_N", lay.nN), ("P_N", lay.nN),
                     ("state", lay.nN), ("gam_F", lay.nF), ("lam_F", lay.nF), ("Lam_F", lay.nF), ("P_F", lay.nF)):
            contact[k] = contact[k].reshape(len(self.t), n)
        its = np.array(self.iterations, dtype=np.int64)
        return ContactResult(
            model=m, t=np.array(self.t), q=np.array(self.q), qd=np.array(self.u), qdd=np.array(self.ud),
            lam=np.array(self.lam).reshape(len(self.t), m.nc), newton_iterations=its, status=status,
            message=message, wall_time=wall, init_time=init_time,
            stats={"steps": int(its.size), "fixed_point_steps": int(sum(1 for x in self.methods if x != "newton"))},
            settings={"h": h, "rho_inf": rho_inf, "tol": tol, "scheme": "nonsmooth generalized-alpha "
                      "(Capobianco, Harsch, Eugster & Leine 2021)"},
            contact=contact, contact_names=list(lay.names), friction_rows=[r.copy() for r in lay.friction],
            events=list(self.events))
