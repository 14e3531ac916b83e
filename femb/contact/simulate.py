"""Fixed-step simulation of models with unilateral contacts and friction (docs/contact.md §4).

:func:`simulate` starts from a state consistent with the bilateral constraints and the
closed contacts (accelerations and contact forces from the acceleration-level contact
problem), advances it by :class:`femb.contact.step.NonsmoothStep`, and returns a
:class:`femb.contact.result.ContactResult`.
"""
from __future__ import annotations

import sys
import time
import warnings

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from femb.contact import assemble, broadphase, core
from femb.contact.loop import first_root, margin
from femb.contact.prox import prox_disc
from femb.contact.result import OPEN, SLIP, STICK, ContactResult
from femb.contact.step import NonsmoothStep, StepFailure, StepState
from femb.errors import SINGULAR_HINT, ContactError, InitializationError, ModelError, ParameterError
from femb.solve.alpha import GeneralizedAlpha
from femb.results.storage import check_memory
from femb.solve.options import check_positive
from femb.solve.solver import _check_stride
from femb.system import assembly
from femb.system.initial import consistent_initial_state


def _active_rows(model):
    """The constraint equations kept (``Mechanism.compile(redundant="eliminate")`` removes dependent ones),
    or None when all are."""
    act = getattr(model, "active_constraints", None)
    return None if act is None or np.all(act) else np.nonzero(np.asarray(act, bool))[0]


class _DenseLU:
    """LU factors (partial pivoting) of a small dense matrix, with the parts of SciPy's SuperLU that the
    start uses: ``shape``, ``solve`` and :func:`_u_diagonal`."""

    def __init__(self, A):
        self.shape = A.shape
        with warnings.catch_warnings():             # a singular matrix is reported by _u_diagonal's test
            warnings.simplefilter("ignore", sla.LinAlgWarning)
            self.factors = sla.lu_factor(A, check_finite=False)

    def solve(self, b):
        return sla.lu_solve(self.factors, b, check_finite=False)


def _u_diagonal(lu):
    """The diagonal of U of the factors of :func:`_kkt`."""
    return np.diag(lu.factors[0]) if isinstance(lu, _DenseLU) else lu.U.diagonal()


def _kkt(model, t, q, dense=False):
    """LU of [[M, Φ_qᵀ], [Φ_q, 0]] at (t, q), on the equations kept (:func:`_active_rows`): SciPy's sparse
    LU, or with ``dense`` a dense one (small systems: a sparse matrix costs more to build than to factor)."""
    M = model.M_const if model.constant_mass else assembly.mass_matrix(model, q)
    B = assembly.constraint_jacobian(model, t, q)
    rows = _active_rows(model)
    if rows is not None:
        B = B[rows]
    if dense:
        M, B = M.toarray(), B.toarray()
        m = B.shape[0]
        return _DenseLU(np.block([[M, B.T], [B, np.zeros((m, m))]]) if m else M)
    return spla.splu(sp.bmat([[M, B.T], [B, None]], format="csc") if B.shape[0] else sp.csc_matrix(M))


def _solve_kkt(lu, model, rhs_q, rhs_c):
    """(u̇, λ) from the KKT factors of :func:`_kkt`; λ_i = 0 on the equations removed as redundant."""
    rows = _active_rows(model)
    x = lu.solve(np.concatenate((rhs_q, rhs_c if rows is None else rhs_c[rows])))
    if rows is None:
        return x[:model.nq], x[model.nq:]
    lam = np.zeros(model.nc)
    lam[rows] = x[model.nq:]
    return x[:model.nq], lam


def _diag_W_K_Wt(lu, model, W, batch=256):
    """The diagonal of W M⁻¹ Wᵀ with the bilateral constraints held (the KKT matrix's ``lu``), (k,): the rows
    of W (sparse or dense) solved ``batch`` at a time."""
    Wt = W.T.tocsc() if sp.issparse(W) else W.T
    k = W.shape[0]
    G = np.empty(k)
    for a in range(0, k, batch):
        b = min(k, a + batch)
        R = Wt[:, a:b].toarray() if sp.issparse(Wt) else np.ascontiguousarray(Wt[:, a:b])
        X = lu.solve(np.vstack((R, np.zeros((lu.shape[0] - model.nq, b - a)))))[:model.nq]
        G[a:b] = np.einsum("ij,ij->j", R, X)
    return G


def initial_contact_forces(model, lay, st, gap_tol, vel_tol, max_iter=5000, ev=None):
    """Accelerations and contact forces at t₀ for the contacts that are closed (g_N ≤ gap_tol and
    abs(ġ_N) ≤ vel_tol): the acceleration-level contact problem (Signorini on g̈_N, Coulomb on γ̇_F
    or the slip law on γ_F), solved by a projected Jacobi fixed point with prox parameters
    1/(W M⁻¹ Wᵀ)_ii (Studer 2009, §3.4), halved when it stalls (as the step's, ``core.FP_STALL``).

    ``ev``: ``assemble.evaluate(model, st.t, st.q, st.qd)`` if the caller has it (``dense=True``: the
    KKT system is factored dense too).

    Returns
    -------
    (ud, lam_g, lam_N, lam_F)
    """
    t, q, u = st.t, st.q, st.qd
    ev = assemble.evaluate(model, t, q, u) if ev is None else ev
    WN, WF = ev["WN"], ev["WF"]
    dense = not sp.issparse(WN)
    closed = (ev["gN"] <= gap_tol) & (np.abs(WN @ u) <= vel_tol)
    lN, lF = np.zeros(lay.nN), np.zeros(lay.nF)
    f = assembly.force_vector(model, t, q, u)
    _, gam = assembly.constraint_rates(model, t, q, u)
    try:
        lu = _kkt(model, t, q, dense)
        d = np.abs(_u_diagonal(lu))
        singular = not np.all(np.isfinite(d)) or d.min() <= 1e-13 * d.max()
    except RuntimeError:
        singular = True
    if singular:                    # the test of femb.system.initial.start_accelerations, which the start skips
        raise InitializationError(f"initial accelerations: the matrix [[M, Φ_qᵀ], [Φ_q, 0]] is singular at "
                                  f"t = {t:.6g} s; {SINGULAR_HINT}")
    ud, lg = _solve_kkt(lu, model, f, -gam)
    if not closed.any():
        return ud, lg, lN, lF
    # prox parameters of the closed contacts' rows only (the others' forces stay zero)
    rows = np.concatenate((np.nonzero(closed)[0],
                           lay.nN + np.concatenate([lay.friction[i] for i in np.nonzero(closed)[0]] + [np.zeros(0, int)])))
    Wc = np.vstack((WN, WF))[rows] if dense else sp.vstack((WN, WF)).tocsr()[rows]
    r = np.ones(lay.nN + lay.nF)
    r[rows] = 1.0 / np.maximum(_diag_W_K_Wt(lu, model, Wc if dense else Wc.tocsc()), 1e-300)
    gF = WF @ u
    track = np.array([np.inf, 0.0, 0.0])           # core.fp_stalled, as the step's fixed point
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
        if core.fp_stalled(change, track):        # stalled (contacts sharing a body: a box on four corners)
            r = 0.5 * r
        if not np.all(np.isfinite(lN)) or np.max(np.abs(lN), initial=0.0) > 1e12 * _force_scale(model, f):
            break
    if not (np.all(np.isfinite(lN)) and change <= 1e-9 * max(1.0, np.max(np.abs(lN), initial=0.0))):
        return None
    ud, lg = _solve_kkt(lu, model, f + WN.T @ lN + WF.T @ lF, -gam)
    return ud, lg, lN, lF


def _force_scale(model, f):
    return max(float(np.max(np.abs(f), initial=0.0)), 1e-300)


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


def solver_options(model, solver):
    """(tol, max_iter, max_fixed_point, locate_impacts, broad_phase) from :func:`simulate`'s ``**solver`` keywords,
    validated; a ParameterError names an unknown or bad one."""
    known = {"tol": None, "max_iter": 40, "max_fixed_point": 400, "locate_impacts": True, "broad_phase": True}
    bad = sorted(set(solver) - set(known))
    if bad:
        raise ParameterError(f"femb.contact.simulate got unknown keyword(s) {', '.join(bad)}; the solver's are "
                             f"{', '.join(known)} (and stride, store: what is stored)")
    o = dict(known, **solver)
    tol = 1e-12 * model.length_scale if o["tol"] is None else check_positive("tol", o["tol"])
    counts = []
    for name in ("max_iter", "max_fixed_point"):
        v = o[name]
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise ParameterError(f"{name} must be a positive integer, got {v!r}")
        counts.append(int(v))
    return tol, counts[0], counts[1], bool(o["locate_impacts"]), bool(o["broad_phase"])


def geometry_problems(model, q):
    """Contacts whose geometry is undefined or nearly so at q (their types' ``geometry_problems``):
    a list of (element name, why)."""
    qx = model.ext(np.asarray(q, dtype=float))
    out = []
    for g in model.contact_groups:
        probe = getattr(g.cls, "geometry_problems", None)
        if probe is not None:
            out += [(g.elements[e].name, why) for e, why in probe(g.P, qx[g.xdofs])]
    return out


#: the failure's diagnosis reports an instability when the largest velocity at the last stored step exceeds
#: this factor times its median over the UNSTABLE_WINDOW steps before (:func:`velocity_growth`)
UNSTABLE_GROWTH = 1e2
UNSTABLE_WINDOW = 10


def velocity_growth(res):
    """A sentence when, at one of the last 2 UNSTABLE_WINDOW steps of the partial result ``res``, the largest
    velocity component exceeds UNSTABLE_GROWTH times its median over the UNSTABLE_WINDOW steps before that
    step (the steps before a failure look numerically unstable; an impact changes the velocities by far
    less), else None. Not only the last step: a jump of the velocities after which the run goes on for some
    steps before one fails (14 steps for a beam of 20 elements on the stop, docs/contact.md §8) is named too."""
    qd = getattr(res, "qd", None)
    if qd is None or len(qd) < 3:
        return None
    v = np.max(np.abs(np.asarray(qd, dtype=float)), axis=1)
    if not np.isfinite(v[-1]):
        return "the velocities are not finite at the last stored step: the steps before the failure look unstable"
    t = np.asarray(res.t, dtype=float)
    n = v.size
    for i in range(max(1, n - 2 * UNSTABLE_WINDOW), n):
        lo = max(0, i - UNSTABLE_WINDOW)
        if v[i] > UNSTABLE_GROWTH * max(float(np.median(v[lo:i])), 1e-300):
            then = "" if i == n - 1 else f", and {v[-1]:.3g} at t = {t[-1]:.6g} s"
            return (f"the largest velocity grew from {v[lo]:.3g} at t = {t[lo]:.6g} s to {v[i]:.3g} at "
                    f"t = {t[i]:.6g} s{then} (m/s or rad/s): the steps before the failure look numerically unstable "
                    "(for example too little numerical damping of high frequencies the step does not resolve: try "
                    "a smaller rho_inf or a shorter step)")
    return None


def diagnose(model, lay, s, gap_tol, vel_tol, h=None, res=None):
    """Why a step has no consistent contact force: (contact name, reason) or (None, reason).

    For every closed, slipping contact i with μ_i > 0 it forms the normal acceleration's
    response to its own normal force when friction opposes the slip, a_i = W_N,i G (W_N,i −
    μ_i ŝ W_F,i)ᵀ with G the constrained inverse mass (the KKT matrix), and the free normal
    acceleration b_i. a_i ≤ 0 is Painlevé's paradox (Painlevé 1895; Génot & Brogliato,
    Eur. J. Mech. A 18 (1999) 653–677): no non-negative λ_N gives g̈_N = b_i + a_i λ_N ≥ 0 with
    complementarity when b_i < 0 (inconsistency), two solutions when b_i > 0 (indeterminacy).
    Without such a contact, the contacts whose geometry is undefined or nearly so at s or, given the
    step size ``h``, at s moved by h s.u (:func:`geometry_problems`: e.g. a sphere pair whose centres
    (nearly) coincide). Without either, and given the partial result ``res``, a velocity that grew by orders
    of magnitude just before (:func:`velocity_growth`).
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
        wN = WN[i].toarray().ravel()
        a = float(wN @ x)
        b = float(wN @ ud0 + ev["zN"][i])
        if a <= 0.0:
            kind = "inconsistency: no contact force exists" if b < 0 else "indeterminacy: the contact force is not unique"
            return lay.names[i], (f"contact '{lay.names[i]}' slips at {np.linalg.norm(gF):.4g} m/s with μ = "
                                  f"{lay.mu[i]:g}, and its normal acceleration falls as its normal force grows "
                                  f"(W_N G (W_N − μ ŝ W_F)ᵀ = {a:.4g} ≤ 0; free normal acceleration {b:.4g}): "
                                  f"Painlevé's paradox, {kind} for Coulomb friction")
    bad = geometry_problems(model, q)
    if not bad and h is not None:
        bad = geometry_problems(model, model.compose(q, h * np.asarray(u, dtype=float)))
    if bad:
        name, why = bad[0]
        return name, f"contact '{name}' at t = {t:.6g} s: {why}"
    grew = velocity_growth(res) if res is not None else None
    if grew:
        return None, f"no solution found; {grew}"
    return None, "no consistent contact forces found (no slipping contact shows Painlevé's paradox)"


def _classify(closed, gF, lay, vel_tol):
    """State of each contact (nN,): OPEN, or where ``closed`` SLIP when its slip speed ‖γ_F‖ exceeds vel_tol,
    else STICK."""
    st = np.full(lay.nN, OPEN, dtype=np.int8)
    for i in np.nonzero(closed)[0]:
        idx = lay.friction[i]
        st[i] = SLIP if idx.size and np.linalg.norm(gF[idx]) > vel_tol else STICK
    return st


def _states(ev, sets, lay, vel_tol):
    """The contacts' states after a step: closed = in A and in B or C."""
    A, B_, C, D, E = sets
    return _classify(A & (B_ | C), ev["gF"], lay, vel_tol)


def _start_states(s, lay, gap_tol, vel_tol):
    """The contacts' states at t₀ (the first stored row): closed where the start closed them
    (:func:`initial_contact_forces`: g_N ≤ gap_tol and abs(ġ_N) ≤ vel_tol; until 2026-11-29 every contact was
    stored open there)."""
    return _classify((s.gN <= gap_tol) & (np.abs(s.gNd) <= vel_tol), s.gFd, lay, vel_tol)


def simulate(model, t_end, h, *, rho_inf=0.8, t0=0.0, rtol=None, atol=None, h_max=None, compiled=None, **options):
    """Integrate a model with contacts by the nonsmooth generalized-α method, fixed or adaptive steps.

    Parameters
    ----------
    model : Model or Mechanism
        With contact elements (:mod:`femb.elements.contact`); bilateral joints are allowed.
    t_end : float
    h : float
        Step size (adjusted slightly so that the steps end on t_end). With ``rtol``: the first
        step's size.
    rho_inf : float in [0, 1)
        Spectral radius at infinity of the smooth part (α_m, α_f, β, γ by Chung & Hulbert).
    t0 : float
    rtol, atol, h_max : float, optional
        Adaptive steps (:mod:`femb.contact.adaptive`, docs/contact.md §1.2) when ``rtol`` is given:
        error control on the smooth part as in :func:`femb.simulate` (atol defaults to 1e-3 · rtol),
        no error test at impacts and contact changes; steps at most ``h_max``. The controller runs in
        Python, each step in the loop ``compiled`` chooses.
    compiled : bool, optional
        Run the steps in the compiled time loop (:mod:`femb.contact.loop`, docs/contact.md §7):
        None (default) where it applies (dense systems with a constant mass matrix, no time
        functions), False the Python loop (the reference), True the compiled loop or a
        ParameterError where it does not apply. Both give the same results (to round-off).
    **options
        ``stride`` (store every stride-th step, the first and the last always; events, iterations, work
        and h_steps still cover every step, docs/contact.md §4), ``store`` (False: the first and the last
        state only) and the step's solver (:func:`solver_options`): ``tol``
        (Newton tolerance on the residual in length units, default 1e-12 × length scale), ``max_iter`` (semismooth Newton
        iterations per step, 40), ``max_fixed_point`` (prox fixed-point iterations of the fallback,
        400), ``locate_impacts`` (split a step in which an open contact closes at the impact,
        docs/contact.md §1.1, item 2, so that the impact law sees the velocity at the impact; True),
        ``broad_phase`` (with at least ``femb.contact.broadphase.BROAD_PHASE_MIN`` pair contacts, on the
        sparse path or a dense one of at least ``BROAD_PHASE_DENSE_MIN`` unknowns, solve each step on the
        contacts that can close in it, in the Python loop, docs/contact.md §7; True).

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
    ParameterError
        Bad t_end, h, t0, rho_inf, rtol, atol, h_max or solver option.
    """
    if hasattr(model, "compile") and not hasattr(model, "contact_groups"):
        model = model.compile()
    _check_parameters(model, t_end, h, rho_inf, t0)
    solver = dict(options)
    stride, store = solver.pop("stride", 1), solver.pop("store", True)
    every = _check_stride(stride) if store else 0
    t0, t_end = float(t0), float(t_end)
    nsteps = max(1, int(round((t_end - t0) / float(h))))
    if rtol is None:
        if atol is not None or h_max is not None:
            raise ParameterError("atol and h_max set the adaptive steps: give rtol too, or leave them out for "
                                 "fixed steps")
        h = (t_end - t0) / nsteps
    else:
        from femb.contact import adaptive
        ctl = adaptive.tolerances(rtol, atol, h_max, t_end - t0)
    L = model.length_scale
    opts = solver_options(model, solver)
    tol, locate_impacts = opts[0], opts[3]
    lay = assemble.layout(model)
    alpha = GeneralizedAlpha.from_rho_inf(rho_inf)
    stepper = _stepper(model, h, alpha, lay, opts, compiled)
    if rtol is not None:
        stepper.h_acc = float(h)
    vel_tol = max(100.0 * tol / h, 1e-12)
    t_init = time.perf_counter()
    s, x0, ev0 = _start(model, lay, stepper, t0, vel_tol)
    rec = _Recorder(model, lay, every)
    rec.broad_phase = getattr(stepper, "stats", None)
    rec.store(s, x0, ev0, _start_states(s, lay, 1e-9 * L, vel_tol), stepper, _sums(stepper, x0, ev0, 0.0, 0.0))
    if rtol is None:
        _check_storage(rec, nsteps)
    init_time = time.perf_counter() - t_init
    if compiled is None or compiled:
        from femb.contact import compiled as fast
        if fast.applies(stepper):
            if rtol is not None:            # adaptive: the controller in Python, each step in the compiled loop
                steps = fast.CompiledSteps(stepper, s, rec, vel_tol, locate_impacts, (tol, rho_inf, init_time))
                return adaptive.run(steps, model, (t_end, float(h)), ctl, alpha, diagnose, vel_tol)
            return fast.run(stepper, s, rec, nsteps, h, (vel_tol, locate_impacts, rho_inf, init_time))
        if compiled:
            raise ParameterError("compiled=True: the compiled time loop needs the dense path with a constant mass "
                                 "matrix, no time functions and no redundant equations (docs/contact.md §7)")
    if rtol is not None:
        steps = adaptive.PythonSteps(stepper, s, rec, sys.modules[__name__], vel_tol, locate_impacts,
                                     (tol, rho_inf, init_time))
        return adaptive.run(steps, model, (t_end, float(h)), ctl, alpha, diagnose, vel_tol)
    return _run_python(stepper, s, rec, nsteps, h, (vel_tol, locate_impacts, rho_inf, init_time))


def _stepper(model, h, alpha, lay, opts, compiled):
    """The step's solver for the options ``opts`` of :func:`solver_options`: a :class:`NonsmoothStep`, or for
    many pairs the broad phase's (:class:`femb.contact.broadphase.BroadPhaseStep`: each step on the pairs
    that can touch), which ``compiled=True`` leaves out (it runs in the Python loop)."""
    tol, max_iter, max_fixed_point, _, broad = opts
    stepper = NonsmoothStep(model, h, alpha, lay, tol, max_iter, max_fixed_point)
    bp = broadphase.for_model(model, stepper, broad and compiled is not True)
    return stepper if bp is None else broadphase.BroadPhaseStep(stepper, bp)


def _run_python(stepper, s, rec, nsteps, h, info):
    """Steps 1 … nsteps from the StepState s (stored as step 0 in ``rec``) in the Python loop, as
    :func:`femb.contact.compiled.run` in the compiled one (``info`` = (vel_tol, locate, rho_inf, init_time))."""
    vel_tol, locate, rho_inf, init_time = info
    model, lay, tol = stepper.model, stepper.lay, stepper.tol
    t_loop = time.perf_counter()
    for n in range(1, nsteps + 1):
        try:
            s, x, ev, sets, work = _step(stepper, s, h, n, rec, vel_tol, locate)
        except StepFailure as err:
            res = rec.result(h, rho_inf, tol, init_time, time.perf_counter() - t_loop, "failed", str(err))
            name, why = diagnose(model, lay, s, 1e-9 * model.length_scale, vel_tol, h, res)
            raise ContactError(f"contact step {n} from t = {s.t:.6g} s to t = {s.t + h:.6g} s failed: {why} "
                               f"({err})", contact=name, t=s.t + h, step=n, result=res) from None
        rec.store(s, x, ev, _states(ev, sets, lay, vel_tol), stepper, work)
    return rec.result(h, rho_inf, tol, init_time, time.perf_counter() - t_loop, "success", "")


#: fixed-step runs that store more than this are checked against the memory available before they start
STORAGE_CHECK_BYTES = 2 ** 26


def _check_storage(rec, nsteps):
    """A ParameterError (before the run) when the steps to store would not fit into the memory available."""
    rows = 2 + (nsteps // rec.every if rec.every else 0)
    row = sum(np.asarray(a).nbytes for a in rec.rows[0]) + 8 * len(rec.rows[0])
    if rows * row > STORAGE_CHECK_BYTES:       # (reading the memory available costs 40 µs: not for small runs)
        check_memory(rows * row, f"storing {rows} steps of {row} bytes of the contact run")


def _start(model, lay, stepper, t0, vel_tol):
    """The consistent starting state (bilateral projection, contact forces of the closed contacts)."""
    L = model.length_scale
    st = consistent_initial_state(model, t0=t0, contacts=True, accelerations=False)   # u̇ from the contact problem
    ev0 = assemble.evaluate(model, t0, st.q, st.qd, dense=stepper.dense)
    undefined = np.nonzero(~np.isfinite(ev0["gN"]))[0]
    if undefined.size:
        i = undefined[0]
        why = dict(geometry_problems(model, st.q)).get(lay.names[i], "its gap is not defined there")
        raise ModelError(f"contact '{lay.names[i]}' at t0 = {t0:g}: {why}")
    bad = np.nonzero(ev0["gN"] < -1e-10 * L)[0]
    if bad.size:
        i = bad[0]
        raise ModelError(f"contact '{lay.names[i]}' starts penetrated: g_N = {ev0['gN'][i]:.6g} m < 0 at t0 = {t0:g}; "
                         "place the bodies apart or touching")
    init = initial_contact_forces(model, lay, st, 1e-9 * L, vel_tol, ev=ev0)
    if init is None:
        probe = StepState(t0, st.q, st.qd, *([None] * 8))
        name, why = diagnose(model, lay, probe, 1e-9 * L, vel_tol)
        raise ContactError(f"initial contact forces at t0 = {t0:g} s: {why}", contact=name, t=t0, step=0)
    ud, lg, lN, lF = init
    s = StepState(t0, st.q.copy(), st.qd.copy(), ud, ud.copy(), lN, lF, lN.copy(), lF.copy(),
                  ev0["WN"] @ st.qd, ev0["WF"] @ st.qd, gN=ev0["gN"], gNdd=ev0["WN"] @ ud + ev0["zN"])
    x0 = np.zeros(stepper.nx)
    o = stepper.offsets
    x0[o[0]:o[1]] = ud
    x0[o[5]:o[6]] = lg
    x0[o[8]:o[9]] = lN
    x0[o[10]:o[11]] = lF
    s.x = x0
    # W at t0 for the first step's prox parameters (NonsmoothStep.prox_r), instead of evaluating it again
    stepper.remember_W(s.q, t0, ev0["WN"], ev0["WF"])
    ev0 = dict(ev0, PN=np.zeros(lay.nN), PF=np.zeros(lay.nF), u=st.qd)
    return s, x0, ev0


def _impact_time(stepper, s, ev, sets, H, gap_tol, vel_tol):
    """Earliest time τ ∈ [0, H) at which an open contact closes in a step of size H, or None.

    From the contact's gap at the step's start, g + ġτ + ½g̈τ² = 0 (exact for a body in free
    flight under constant forces); the secant of g over the step when that has no root in (0, H).
    A contact touching and approaching (ġ < −vel_tol) without a root, its g ≤ 0, closes at τ = 0.
    The time returned is τ − ε + 1e-3 d with ε = :func:`femb.contact.loop.margin` (τ itself where
    ε = 1e-3 d, a fast impact): the free flight ends 1e-3 d before it, ε before the impact, its gap open.
    The contacts that are open or moving at t_n (g > gap_tol or abs(ġ) > vel_tol) carry no force in
    a free flight: when one of them carries one at t_n (a contact that leaves, or one that rests a
    round-off above gap_tol), g̈ is taken without their forces (:func:`_free_gNdd`); the contacts at
    rest keep theirs.
    """
    moving = (s.gN > gap_tol) | (np.abs(s.gNd) > vel_tol)       # open, or touching and moving
    cand = np.nonzero(sets[0] & moving)[0]
    gdd = s.gNdd
    if cand.size and np.any(s.lam_N[moving] != 0.0):
        gdd = _free_gNdd(stepper.model, stepper.lay, s, moving)
    best = None
    d = 1e-4 * stepper.h_fixed
    for i in cand:
        c = s.gN[i]
        tau = first_root(0.5 * gdd[i], s.gNd[i], c, 0.0, H, False)
        v = s.gNd[i] + gdd[i] * tau                     # ġ_N at the impact
        if np.isnan(tau) and c <= gap_tol and s.gNd[i] < -vel_tol:
            tau, v = 0.0, s.gNd[i]      # touching and approaching with g_N ≤ 0 (round-off either side of 0): now
        if np.isnan(tau):
            tau = H * c / (c - ev["gN"][i]) if c - ev["gN"][i] > 0.0 else None
            v = (ev["gN"][i] - c) / H
        if tau is not None:
            tau = max(tau - margin(v, d, stepper.tol) + 1e-3 * d, 0.0)
        if tau is not None and (best is None or tau < best):
            best = tau
    return best


def _free_gNdd(model, lay, s, free):
    """g̈_N at s without the forces of the contacts ``free`` (bool, per contact), bilateral constraints kept.

    The other contacts keep their forces λ_N, λ_F at t_n (a contact resting on a guide keeps
    carrying the body that leaves the other guide): M u̇ + Φ_qᵀλ = f + W_Nᵀλ_N + W_Fᵀλ_F,
    Φ_q u̇ = −γ, with λ_N,i = 0 and λ_F,i = 0 for the contacts i in ``free``; then g̈_N = W_N u̇ + ζ_N.
    """
    lN = np.where(free, 0.0, s.lam_N)
    lF = s.lam_F.copy()
    for i in np.nonzero(free)[0]:
        lF[lay.friction[i]] = 0.0
    lu = _kkt(model, s.t, s.q)
    _, gam = assembly.constraint_rates(model, s.t, s.q, s.u)
    ev = assemble.evaluate(model, s.t, s.q, s.u)
    ud, _ = _solve_kkt(lu, model, assembly.force_vector(model, s.t, s.q, s.u) + ev["WN"].T @ lN + ev["WF"].T @ lF,
                       -gam)
    return ev["WN"] @ ud + ev["zN"]


#: a step without a solution is halved at most this deep (:func:`_step`)
MAX_HALVINGS = 6


def _step(stepper, s, h, n, rec, vel_tol, locate, depth=0, halve=True):
    """Advance s by h: one nonsmooth step, or substeps around the impact of an open contact.

    An open contact that closes in the step is located from its gap, velocity and free
    acceleration (:func:`_impact_time`): the step goes in free flight to 1e-3 d before the
    impact, d = 1e-4 h (shortened until the contact is still open at its end), takes the impact in a substep
    that ends d after it (so Newton's law sees the velocity at the impact and the bodies leave at
    once), and the rest of the step (docs/contact.md §1.1, item 2). With ``halve``, a step without a
    solution is taken as two halves (at most ``MAX_HALVINGS`` deep; docs/contact.md §1.1, item 9); the
    substeps of an impact split are not halved (a failing one abandons the split, which takes its
    unsplit step, as the compiled loop does). Returns (state, x, ev,
    sets, work) at s.t + h (work: the contact work, normal and friction, and the step's sums of P_N, Λ_N,
    P_F, Λ_F); impacts go to ``rec.events``.
    """
    stepper.set_h(h)
    gap_tol = 1e-9 * stepper.model.length_scale
    d = 1e-4 * stepper.h_fixed
    try:
        x, ev, sets, info = stepper.solve(s)
    except StepFailure as failure:
        if not halve or depth >= MAX_HALVINGS or h <= 6 * d:
            raise
        mark = (len(rec.events), len(rec.iterations), len(rec.methods))
        try:
            s1, _, _, _, w1 = _step(stepper, s, 0.5 * h, n, rec, vel_tol, locate, depth + 1)
            out = _step(stepper, s1, h - 0.5 * h, n, rec, vel_tol, locate, depth + 1)
        except StepFailure:             # the halves have none either: the whole step's failure, nothing booked
            del rec.events[mark[0]:], rec.iterations[mark[1]:], rec.methods[mark[2]:]
            raise failure from None
        finally:
            stepper.set_h(h)
        return out[:4] + (w1 + out[4],)
    tau = _impact_time(stepper, s, ev, sets, h, gap_tol, vel_tol) if locate and depth < 40 and h > 3 * d else None
    if tau is None:
        return _accept(stepper, s, x, ev, sets, info, n, rec, vel_tol)
    mark = (len(rec.events), len(rec.iterations), len(rec.methods))
    try:
        out = _split_at_impact(stepper, s, h, (tau, d, gap_tol), n, rec, vel_tol, locate, depth)
    except StepFailure:
        # the substeps around the impact found no solution (e.g. a second contact closing within d):
        # keep the unsplit step, whose impact comes at its end (the paper's scheme, first order there)
        del rec.events[mark[0]:], rec.iterations[mark[1]:], rec.methods[mark[2]:]
        stepper.set_h(h)
        return _accept(stepper, s, x, ev, sets, info, n, rec, vel_tol)
    stepper.set_h(h)
    return out


def _split_at_impact(stepper, s, h, impact, n, rec, vel_tol, locate, depth):
    """Free flight to just before the impact at tau (if it is not imminent), the impact, the rest.

    ``impact`` = (tau, d, gap_tol): the impact time within the step, the substep margin d and
    the gap tolerance (see :func:`_step`)."""
    tau, d, gap_tol = impact
    if tau > 2 * d:
        free = _free_flight(stepper, s, tau - 1e-3 * d, gap_tol, vel_tol)
        if free is not None:                            # free flight, then the impact from closer by
            x1, ev1, sets1, info1, h1 = free
            s1, _, _, _, w1 = _accept(stepper, s, x1, ev1, sets1, info1, n, rec, vel_tol)
            s2, x2, ev2, sets2, w2 = _step(stepper, s1, h - h1, n, rec, vel_tol, locate, depth + 1, False)
            return s2, x2, ev2, sets2, w1 + w2
    work = 0.0
    first = min(tau + d, 0.5 * h)
    for hk in (first, h - first):                       # the impact is imminent: take it in ≤ 3d
        s, x, ev, sets, w = _step(stepper, s, hk, n, rec, vel_tol, locate, depth + 1, False)
        work = work + w
    return s, x, ev, sets, work


def _free_flight(stepper, s, tau, gap_tol, vel_tol, tries=8):
    """A step of size ≤ tau after which the contacts open at s are still open (halved until so), or None.

    Open: a gap above ``gap_tol``, or touching and leaving faster than ``vel_tol`` (a contact at rest
    carries a ġ_N of round-off of either sign: it stays closed)."""
    was_open = (s.gN > gap_tol) | (s.gNd > vel_tol)
    for _ in range(tries):
        stepper.set_h(tau)
        x, ev, sets, info = stepper.solve(s)
        if not np.any(sets[0] & was_open):
            return x, ev, sets, info, tau
        tau *= 0.5
    return None


def _accept(stepper, s, x, ev, sets, info, n, rec, vel_tol):
    """Book an accepted (sub)step: iterations, contact work, impacts; the new state."""
    rec.iterations.append(info["iterations"])
    rec.methods.append(info["method"])
    # the contact work: the impulses times the mean of the contact velocities at the (sub)step's two ends,
    # each with its own W (½(u_n + u_{n+1})·W_{n+1}ᵀP, used before, is first order where W turns)
    work = _sums(stepper, x, ev, float(0.5 * (s.gNd + ev["gNd"]) @ ev["PN"]), float(0.5 * (s.gFd + ev["gF"]) @ ev["PF"]))
    new = _advance(stepper, s, x, ev)
    rec.impacts(n, s, new, ev, sets, stepper.split(x), vel_tol)
    return new, x, ev, sets, work


def _sums(stepper, x, ev, work_N, work_F):
    """What a (sub)step adds to its step's sums: (work_N, work_F, P_N, Λ_N, P_F, Λ_F) in one array
    (the substeps of a split step add theirs, :func:`_split_at_impact`; :meth:`_Recorder.store`)."""
    parts = stepper.split(x)
    return np.concatenate(([work_N, work_F], ev["PN"], parts[7], ev["PF"], parts[9]))


def _advance(stepper, s, x, ev):
    """The state after an accepted step (ā, λ̄ carried as in eqs. (71), (96), (114))."""
    parts = stepper.split(x)
    return StepState(s.t + stepper.h, ev["q"], ev["u"], parts[0].copy(), ev["abar"], parts[8].copy(),
                     parts[10].copy(), ev["lbar_N"], ev["lbar_F"], ev["gNd"], ev["gF"], x.copy(),
                     gN=ev["gN"], gNdd=ev["gNdd"], fresh=ev.get("fresh"))


#: the per-contact arrays a result stores per step (ContactResult.contact)
CONTACT_KEYS = ("gN", "gN_d", "lam_N", "Lam_N", "P_N", "state", "gam_F", "lam_F", "Lam_F", "P_F", "work_N", "work_F")


class _Recorder:
    """Stores the steps (step 0, every ``every``-th step, the last taken; :func:`stored_step`) and builds
    the :class:`ContactResult`; the events and iterations of every step."""

    def __init__(self, model, lay, every=1):
        self.model, self.lay, self.every = model, lay, every
        self.rows = []
        self.last = None                # the last step taken, while it is not stored
        self.n = -1                     # the step of the last call of store (0: the start)
        self.iterations, self.methods, self.events = [], [], []
        self._wN = self._wF = 0.0
        #: the broad phase's counters (femb.contact.broadphase.BroadPhaseStep.stats) when it runs
        self.broad_phase = None

    def store(self, s, x, ev, state, stepper, work):
        """Store the step that ended at s: its last (sub)step's solution x, ev; ``work`` the step's sums
        of :func:`_sums` (the impulses P_N, Λ_N, P_F, Λ_F of all its substeps, the contact work)."""
        parts = stepper.split(x)
        self._wN += work[0]
        self._wF += work[1]
        self.n += 1
        kN, kF = self.lay.nN, self.lay.nF
        PN, LN, PF, LF = np.split(np.asarray(work[2:]), np.cumsum((kN, kN, kF)))
        row = [s.t, s.q.copy(), s.u.copy(), s.ud.copy(), np.array(parts[5], dtype=float)]
        row += [np.array(v, copy=True) for v in (ev["gN"], None, parts[8], LN, PN, state, None,
                                                 parts[10], LF, PF, self._wN, self._wF)]
        # the normal and slip velocities when the row is kept (the broad phase's W of the pairs it left
        # out of the step costs their kernels: femb.contact.broadphase.Rows)
        row[6], row[11] = (ev["WN"], s.u), (ev["WF"], s.u)
        if stored_step(self.n, self.every):
            self.rows.append(self._rates(row))
            self.last = None
        else:
            self.last = row

    @staticmethod
    def _rates(row):
        for k in (6, 11):
            if isinstance(row[k], tuple):
                W, u = row[k]
                row[k] = np.array(W @ u, dtype=float)
        return row

    def impacts(self, n, s, new, ev, sets, parts, vel_tol):
        """Impacts of a (sub)step: a contact closed at its end that began approaching (ġ_N < −vel_tol), whose
        ġ_N rose by more than vel_tol, with P_N > 0 (a closed step in which the approach did not slow
        carries a P_N of round-off, of either sign: not an impact)."""
        closed = sets[0] & (sets[1] | sets[2])
        for i in np.nonzero((s.gNd < -vel_tol) & (new.gNd - s.gNd > vel_tol) & closed & (ev["PN"] > 0.0))[0]:
            tau = first_root(0.5 * s.gNdd[i], s.gNd[i], max(s.gN[i], 0.0), 0.0, new.t - s.t, True)   # impact time
            self.events.append(dict(t=new.t if np.isnan(tau) else s.t + tau, step=n, contact=self.lay.names[i],
                                    v_before=float(s.gNd[i]), v_after=float(new.gNd[i]), Lambda_N=float(parts[7][i]),
                                    P_N=float(ev["PN"][i]), u_before=s.u.copy(), u_after=new.u.copy()))

    def result(self, h, rho_inf, tol, init_time, wall, status, message):
        m, lay = self.model, self.lay
        rows = self.rows + ([self._rates(self.last)] if self.last is not None else [])
        nt = len(rows)
        cols = [np.array(c) for c in zip(*rows)] if rows else [np.zeros(0)] * (5 + len(CONTACT_KEYS))
        contact = dict(zip(CONTACT_KEYS, cols[5:]))
        for k in ("gN", "gN_d", "lam_N", "Lam_N", "P_N", "state"):
            contact[k] = contact[k].reshape(nt, lay.nN)
        for k in ("gam_F", "lam_F", "Lam_F", "P_F"):
            contact[k] = contact[k].reshape(nt, lay.nF)
        steps = dict(t=cols[0], q=cols[1], qd=cols[2], qdd=cols[3], lam=cols[4].reshape(nt, m.nc), contact=contact,
                     iterations=np.array(self.iterations, dtype=np.int64), n_steps=max(self.n, 0),
                     fixed_point_steps=int(sum(1 for x in self.methods if x == "fixed_point")),
                     slip_on_P_steps=int(sum(1 for x in self.methods if x == "slip_on_P")), events=list(self.events),
                     broad_phase=self.broad_phase)
        return contact_result(m, lay, steps, (h, rho_inf, tol, init_time, wall, status, message))


def stored_step(n, every):
    """Whether step n is stored for good (step 0 always; with ``every`` = 0, none after it). The last step
    taken is stored too: the recorders keep it until a later step replaces it."""
    return n == 0 or (every > 0 and n % every == 0)


def contact_result(model, lay, steps, run):
    """The :class:`ContactResult` of the stored ``steps`` (dict: t, q, qd, qdd, lam, contact, iterations,
    n_steps (the steps taken), fixed_point_steps, slip_on_P_steps, events) and ``run`` = (h, rho_inf, tol, init_time, wall, status, message)."""
    h, rho_inf, tol, init_time, wall, status, message = run
    its = steps["iterations"]
    out = ContactResult(
        model=model, t=steps["t"], q=steps["q"], qd=steps["qd"], qdd=steps["qdd"], lam=steps["lam"],
        newton_iterations=its, status=status, message=message, wall_time=wall, init_time=init_time,
        stats={"steps": steps["n_steps"], "substeps": int(its.size), "fixed_point_steps": steps["fixed_point_steps"],
               "slip_on_P_steps": steps["slip_on_P_steps"]},
        settings={"h": h, "rho_inf": rho_inf, "tol": tol, "scheme": "nonsmooth generalized-alpha "
                  "(Capobianco, Harsch, Eugster & Leine 2021)"},
        contact=steps["contact"], contact_names=list(lay.names), friction_rows=[r.copy() for r in lay.friction],
        events=steps["events"])
    bp = steps.get("broad_phase")
    if bp is not None:
        out.stats["broad_phase"] = {"solves": bp["solves"], "repeated": bp["repeated"], "rebuilt": bp["rebuilt"],
                                    "mean_contacts": bp["contacts"] / max(bp["solves"], 1)}
    return out
