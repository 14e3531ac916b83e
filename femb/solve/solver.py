"""The generalized-α scheme of Arnold & Brüls (2007), index 3 and stabilized index 2: the Python side
of the time loop.

The time step itself (predictor, Newton iteration, band LU, chunks of steps) is
compiled code in ``femb/engine/``; this module validates options, computes
consistent initial values, drives the compiled loop chunk by chunk (observers,
stored steps, Python time functions) and turns its status codes into femb's
errors.

References
----------
M. Arnold, O. Brüls, Convergence of the generalized-α scheme for constrained
mechanical systems, Multibody Syst. Dyn. 18 (2007) 185–202 (Algorithm 1).

C. L. Bottasso, D. Dopico, L. Trainelli, On the optimal scaling of index
three DAEs in multibody dynamics, Multibody Syst. Dyn. 19 (2008) 3–20
(scaling of the iteration matrix).

J. Chung, G. M. Hulbert, J. Appl. Mech. 60 (1993) 371–375 (parameters).

C. W. Gear, B. Leimkuhler, G. K. Gupta, J. Comput. Appl. Math. 12–13 (1985) 77–90
(stabilized index-2 formulation).
"""
from __future__ import annotations

import dataclasses
import math
import time
import warnings
from typing import Any, Callable

import numpy as np

from femb import engine as S
from femb.base.jit import pack
from femb.errors import SINGULAR_HINT_DIVERGED, ConvergenceError, ModelError, ParameterError, SingularMatrixError
from femb.results.result import Result
from femb.results.storage import Storage
from femb.solve.alpha import GeneralizedAlpha  # noqa: F401  (in the annotations of simulate)
from femb.solve.options import MAX_STEPS, SolverOptions, check_positive, error_constants, fixed_steps  # noqa: F401
from femb.system import initial
from femb.system.initial import consistent_initial_state, singular_hint  # noqa: F401  (re-exported)
from femb.system.initial import START_RESOLUTION, start_is_resolved  # noqa: F401  (re-exported)
from femb.system.mechanism import Mechanism
from femb.system.model import Model, State

#: systems with at most this many unknowns use dense LU in the (Python) initialization
DENSE_LIMIT = 200
#: steps per call of the compiled loop when nothing needs Python between steps
CHUNK = 4096



def _multipliers(model):
    """Size of the engine's multiplier vector [λ; μ]: nc holonomic and nn velocity-constraint rows."""
    return model.nc + getattr(model, "nn", 0)


def _constraint_owner(model):
    owner = np.empty(_multipliers(model), dtype=object)
    for name, idx in model.lam_index.items():
        owner[idx] = name
    for name, idx in getattr(model, "mu_index", {}).items():
        owner[model.nc + np.asarray(idx, dtype=np.int64)] = name
    return owner


# --------------------------------------------------------------------------
# linear solves
# --------------------------------------------------------------------------
# --------------------------------------------------------------------------
# the integrator
# --------------------------------------------------------------------------
def _stepmod():
    from femb.solve import codegen
    return codegen


def _integer_steps(n_steps):
    """A step count given directly (``n_steps``): a positive integer up to ``MAX_STEPS``."""
    try:
        n = int(n_steps)
    except (TypeError, ValueError, OverflowError):
        raise ParameterError(f"n_steps must be a positive integer, got {n_steps!r}") from None
    if n != n_steps or not 1 <= n <= MAX_STEPS:
        raise ParameterError(f"n_steps must be an integer from 1 to {MAX_STEPS:.0e}, got {n_steps!r}")
    return n


class GeneralizedAlphaSolver:
    """Generalized-α integrator: index 3 (Algorithm 1 of Arnold & Brüls 2007, fixed or adaptive
    steps) or stabilized index 2 (GGL-type; planar and spatial models, fixed or adaptive steps).

    Contract: :meth:`advance` runs the compiled loop (``femb/engine/``) for a
    chunk of accepted steps, or raises (:class:`ConvergenceError`,
    :class:`SingularMatrixError`); it never accepts an unconverged step. The
    state (t, q, q̇, q̈, λ) satisfies the equations of motion and Φ = 0 at every
    accepted step to the Newton tolerance. The auxiliary variable ``a`` lives
    here, not in the state. :func:`simulate` is the usual entry point.

    Parameters
    ----------
    model : Model
    h : float or None
        Fixed step size; None for adaptive steps (then ``rtol``/``atol`` set the
        local error tolerance and ``h0`` the first step).
    rho_inf : float in [0, 1], optional
        Spectral radius at infinity (Chung & Hulbert); default 0.7 unless
        ``alpha`` is given.
    alpha : GeneralizedAlpha or (α_m, α_f, β, γ), optional
        Parameters given directly; conditions are checked and violations warned.
    scaling : bool
        Solve the scaled Newton system (method.md eq. 8); default True.
    rtol, atol : float
        Local error tolerance of adaptive steps (atol may be an array of shape
        (nq,)); for fixed steps the tolerance of the step-size check (default
        1e-3 both).
    h0, h_max : float, optional
        First and largest adaptive step.
    error_per : {"step", "unit_step"}
        Adaptive error test per step (err ≤ 1, controller exponent 3; default:
        independent of the time unit) or per unit step (err/h ≤ 1, exponent 2,
        h in seconds: closer to tolerance proportionality on long runs, but
        far stricter on short ones, and limited by the round-off of q̈ᵖᵖ at
        tight tolerances).
    start : {"consistent", "seed"}
        "consistent" (default): a_0 = q̈_0 + Δ h_0 j_0 and the normal velocity
        matched to the scheme's O(h²) offset (stepsize.md §2), so that λ and
        driving forces are second order from the first step; "seed": a_0 = q̈_0
        and the exact q̇_0 (the seed paper's start, with an O(h) transient in λ).
        Fixed steps with ``initialize=False`` use the seed's start (the given
        state need not be consistent).
    newton_test : {"correction", "residual"}
        Newton stopping rule: "correction" (default; weighted correction in q
        and acceleration units, contraction-rate test; stepsize.md §5) or
        "residual" (the force-residual test of the seed reproduction, with
        ``newton_rtol``, ``newton_atol``).
    newton_rtol, newton_atol : float
        Residual test ‖W r_q‖∞ ≤ newton_rtol · F + newton_atol ("residual" rule).
    phi_tol : float
        Constraint test ‖Φ‖∞ ≤ phi_tol · L with L the model's length scale.
    max_iter : int
        Newton iteration limit per step.
    min_iter : {1, 0}
        Newton corrections taken at least per step (default 1).
    newton : {"full", "modified"}
        With the residual rule: "full" refactors at every iteration,
        "modified" reuses the factorization while Newton contracts.
        (The correction rule refactors when contraction is slow.)
    linear_solver : {"auto", "band", "dense", "sparse"}
        "auto" (= "band", = "sparse"): compiled band LU with partial pivoting
        after a reverse Cuthill–McKee ordering, computed once per model;
        "dense": the same LU on the full matrix in the natural order.
    predictor : {"extrapolate", "previous", "zero"}
        Newton's starting guess for (q̈_{n+1}, λ_{n+1}).
    check_every : int
        Fixed steps: compute the local error estimate over one step every
        ``check_every`` steps (two extra solves of the constrained
        accelerations) and warn once when it exceeds ``warn_factor`` (default
        10): the steps are then more than about twice too large for rtol/atol.
        0 disables the check.
    state : State, optional
        Initial state (default: the model's, made consistent).
    t0, t_end : float
    initialize : bool
        Compute consistent initial values (method.md §5); default True.
    n_steps : int, optional
        Fixed steps: number of steps to t_end.
    formulation : {"index3", "index2"}
        "index3" (default): Algorithm 1, constraints on position level.
        "index2": the stabilized index-2 (Gear–Gupta–Leimkuhler) form, fixed or
        adaptive steps: m more unknowns η with q_{n+1} = q_n + Δ + B(q_n)ᵀη
        (q_n ∘ exp(Δ + B(q_n)ᵀη) on models with rotation nodes), and Φ = 0 and
        B q̇ + Φ_t = 0 both enforced at every step. It also runs without
        numerical damping (ρ∞ = 1), where the index-3 scheme can diverge. λ is then free of the 1/h² amplification of
        Newton and round-off errors in Φ (relative λ error 6e-14 on Andrews at
        h = 1e-8 s, 3e-3 with index 3), and only a needs a consistent start
        (``start="consistent"`` sets a_0, not q̇_0; adaptive steps re-synchronise
        only a at a step change). Cost: nq + 2m unknowns, a
        second constraint-rate evaluation per iteration and about 1.4× the
        Newton iterations (docs/method.md §7).
    """

    def __init__(self, model, h=None, *, options=None, state=None, t0=0.0, t_end=None, initialize=True,
                 n_steps=None, **kw):
        from femb.system.model import Model
        if not isinstance(model, Model):
            raise ParameterError(f"expected a compiled Model (call mechanism.compile()), got {type(model).__name__}")
        if options is None:
            options = SolverOptions.create(h, **kw)
        elif kw or (h is not None and h != options.h):
            raise ParameterError("give the solver's options either as options=SolverOptions(...) or as keywords")
        self.model = model
        self.options = options
        for f in dataclasses.fields(options):
            setattr(self, f.name, getattr(options, f.name))
        self.adaptive = options.adaptive
        self.atol = options.atol_vector(model.nq)
        self.start_used = self.start          # the start that ran (_start may fall back to the seed's)
        self.owner = _constraint_owner(model)
        self._initial_values(state, t0, initialize, t_end)
        self._run_extent(t_end, n_steps)
        self.cp = _stepmod().compiled(model, ordering="natural" if self.linear_solver == "dense" else "rcm",
                                      layout=self.formulation)
        self.Cq, self.Cv = error_constants(self.alpha)
        self.ip = S.named_array(S.IP_FIELDS, self._int_parameters(), np.int64, "ip")
        self.fp = S.named_array(S.FP_FIELDS, self._float_parameters(), np.float64, "fp")
        self._run_state()
        self._bufs = None
        self._compile()
        self._start()

    # ------------------------------------------------------------------ set-up, by named fields
    def _initial_values(self, state, t0, initialize, t_end):
        """Consistent initial values (or the given state), timed."""
        t_init = time.perf_counter()
        self.start_weights = None
        if initialize:
            t_start = float(t0 if state is None else state.t)
            self.start_weights, st = initial.flexible_start(self.model, state, t_start, self.h or self.h0, t_end,
                                                            self.adaptive, phi_tol=self.phi_tol)
        else:
            st = (state or self.model.initial_state(t0)).copy()
        nn = getattr(self.model, "nn", 0)
        if nn and st.lam.size == self.model.nc:
            # a state without μ (initialize=False from the model's initial state): μ starts at 0
            st.lam = np.concatenate((st.lam, np.zeros(nn)))
        self.init_time = time.perf_counter() - t_init
        self._initialized = bool(initialize)
        self.initial_state = st.copy()
        self.t0 = st.t

    def _run_extent(self, t_end, n_steps):
        """t_end, the number of fixed steps and the step-size bounds."""
        if t_end is None:
            if self.adaptive:
                raise ParameterError("adaptive steps need t_end")
            # fixed steps without an end: step() as often as the caller likes
            t_end = self.t0 + self.h * n_steps if n_steps is not None else math.inf
        self.t_end = float(t_end)
        if self.adaptive or (n_steps is None and not math.isfinite(self.t_end)):
            self.n_steps = 2 ** 62
        elif n_steps is not None:
            self.n_steps = _integer_steps(n_steps)
        else:
            self.n_steps = fixed_steps(self.h, self.t0, self.t_end)[0]
        span = self.t_end - self.t0 if math.isfinite(self.t_end) else self.h * 1e6
        self.h_min = 1e-10 * max(abs(self.t_end) if math.isfinite(self.t_end) else 0.0, span)

    def _int_parameters(self):
        """The integer parameters ``ip``, by field name (``femb/engine/layout.py``, ``IP_FIELDS``)."""
        cp, m = self.cp, self.model
        correction = self.newton_test == "correction"
        ggl = self.formulation == "index2"
        return dict(nv=m.nq, nc=_multipliers(m), nfix=m.nfix, n=cp.N, kl=cp.kl, ku=cp.ku,
                    maxit=self.max_iter, minit=self.min_iter, full=int(self.newton == "full"),
                    pred={"zero": 0, "previous": 1, "extrapolate": 2}[self.predictor],
                    nsteps=self.n_steps, stride=1, store=1, pytf=int(bool(cp.python_tf)),
                    mode=int(self.adaptive), ntest=int(correction), check=0 if self.adaptive else self.check_every,
                    dense=int(bool(cp.dense)), ggl=int(ggl), carry=cp.mod.carry_rule(cp.N, cp.dense, correction, ggl),
                    nn=_multipliers(m) - m.nc)

    def _float_parameters(self):
        """The float parameters ``fp``, by field name (``femb/engine/layout.py``, ``FP_FIELDS``)."""
        al, unit = self.alpha, self.error_per == "unit_step"
        return dict(h=self.h or 0.0, t0=self.t0, am=al.alpha_m, af=al.alpha_f, beta=al.beta, gamma=al.gamma,
                    rtol=self.newton_rtol, atol=self.newton_atol, phitol=self.phi_tol, l=self.model.length_scale,
                    xtol=64.0 * np.finfo(float).eps, scaled=1.0 if self.scaling else 0.0,
                    singtol=1e-13 if self.scaling else 0.0, tend=self.t_end, fconst=0.0,
                    ertol=self.rtol, hmax=self.h_max, hmin=self.h_min, cq=self.Cq, cv=self.Cv,
                    kexp=2.0 if unit else 3.0, epus=1.0 if unit else 0.0, warn=self.warn_factor,
                    tolq=1e-3 if self.adaptive else 1e-13, newtc=1e3)

    def _run_state(self):
        """The run state (si, sf, counters), the state and the work arrays of the compiled loop."""
        cp, m, st = self.cp, self.model, self.initial_state
        self.si = S.named_array(S.SI_FIELDS, dict.fromkeys(S.SI_FIELDS, 0), np.int64, "si")
        sf0 = dict.fromkeys(S.SF_FIELDS, 0.0)
        # no Python time functions evaluated yet; no warning; no Newton contraction estimate yet
        sf0.update(tftime=math.nan, warn_t=math.nan, t=self.t0, eta=-1.0)
        self.sf = S.named_array(S.SF_FIELDS, sf0, np.float64, "sf")
        self.stats_arr = np.zeros(S.NNS, dtype=np.int64)
        self.q, self.qd, self.qdd, self.lam = st.q.copy(), st.qd.copy(), st.qdd.copy(), st.lam.copy()
        self.a = st.qdd.copy()
        self.pqdd = np.zeros(m.nq)
        self.plam = np.zeros(_multipliers(m))
        self.AB = np.zeros(cp.storage_size)
        self.ipiv = np.zeros(cp.piv_size, dtype=np.int64)
        self.r = np.zeros(m.nq)
        self.Phi = np.zeros(_multipliers(m))
        self.rhs = np.zeros(cp.N)
        self.x = np.zeros(cp.N)
        self.info = np.zeros(8)
        # the work arrays of the compiled loop, one pack (femb.base.jit.pack), by their names in W_FIELDS
        size = {"nx": m.nx, "nv": m.nq, "nc": _multipliers(m), "N": cp.N, "lu": cp.storage_size, "piv": cp.piv_size}
        self.W, self.Wv = pack([np.zeros(size[n], dtype=np.int64 if n == "piv" else np.float64)
                                for _, n in S.W_FIELDS])
        self.Wv[S.W_ATOLV][:] = self.atol
        # the named packs of the compiled loop (femb/engine/layout.py): views of the arrays above
        self.par = S.Par(self.ip, self.fp, self.si, self.sf, self.stats_arr)
        self.step_state = S.StepState(self.q, self.qd, self.qdd, self.lam, self.a, self.pqdd, self.plam)
        self.newton_arrays = S.NewtonArrays(self.AB, self.ipiv, self.r, self.Phi, self.rhs, self.x, self.info, cp.tfv)

    # ------------------------------------------------------------------ internals
    def _tf_at(self, t):
        cp = self.cp
        if cp.python_tf:
            self._fill_python_tf(t)
        cp.mod.eval_time_functions(float(t), cp.Cv[S.C_TFKIND], cp.Cv[S.C_TFOFF], cp.Cv[S.C_TFCOEF], cp.tfv)

    def _fill_python_tf(self, t):
        for k, fn in self.cp.python_tf:
            self.cp.tfv[k, 0] = fn.f(t)
            self.cp.tfv[k, 1] = fn.df(t)
            self.cp.tfv[k, 2] = fn.ddf(t)
        self.sf[S.SF_TFTIME] = t

    def _qpp(self, t, q, qd, KB, kpiv):
        """Constrained accelerations q̈ᵖᵖ at (t, q, q̇) (compiled KKT solve)."""
        cp = self.cp
        self._tf_at(t)
        out = np.zeros(self.model.nq)
        if cp.mod.kkt_solve(cp.G, cp.C, self.par, self.newton_arrays, self.W, float(t), q, qd, (KB, kpiv), out) != 0:
            raise SingularMatrixError(f"the matrix [[M, Φ_qᵀ], [Φ_q, 0]] of the constrained accelerations is "
                                      f"singular at t = {t:.6g} s (start); {singular_hint(self.model, q, t)}",
                                      t=float(t), step=0)
        return out

    def _start_engine(self):
        """The compiled pieces of the start (:class:`femb.system.initial.StartEngine`)."""
        cp, nc = self.cp, _multipliers(self.model)
        KBt = np.zeros_like(self.AB)
        kp = np.zeros_like(self.ipiv)

        def jacobian_times(t, q, v):
            out = np.zeros(nc)
            cp.mod.jacobian_times(cp.G, cp.C, float(t), q, v, out)
            return out

        def rates(t, q, qd):
            Pt, gm = np.zeros(nc), np.zeros(nc)
            self._tf_at(t)
            cp.mod.rates(cp.G, cp.C, float(t), q, qd, Pt, gm)
            return Pt

        def project(t, q, qd, target):
            cp.mod.project_normal_velocity(cp.G, cp.C, self.ip, self.W, float(t), q, qd, target,
                                           (self.Wv[S.W_KBACC], self.Wv[S.W_KPIVACC]))

        return initial.StartEngine(lambda t, q, qd: self._qpp(t, q, qd, KBt, kp), jacobian_times, rates, project)

    def _start(self):
        """Force scale, jerk j_0, consistent a_0 and q̇_0, first step (stepsize.md §2, §4)."""
        cp = self.cp
        t0 = self.t0
        self._tf_at(t0)
        self.sf[S.SF_FREF] = cp.mod.evaluate(cp.G, cp.C, t0, (self.q, self.qd, self.qdd, self.lam), False,
                                     (0.0, 0.0, 0.0), (self.AB, self.r, self.Phi))
        if self.newton_test == "residual":
            # deformable elements: their internal forces carry round-off ε K L far above ε times the loads;
            # 10⁻⁴ of it in the absolute tolerance lets the engine's round-off acceptance (corrections at
            # the coordinates' round-off, residual within 10⁴ tolerances) take a residual at that floor
            self.residual_floor = initial.residual_floor(self.model, self.initial_state)
            self.fp[S.FP_ATOL] = self.newton_atol + 1e-4 * self.residual_floor
        # the consistent start needs consistent initial values; initialize=False keeps the seed's start
        need_j = self.adaptive or (self.start == "consistent" and self._initialized)
        h0 = self.h
        if need_j:
            # central-difference step of the jerk: small against the step size (the start
            # correction is d·h·j₀), and for fixed steps independent of t_end, so that a
            # stepping solver and simulate start alike
            if self.adaptive:
                dl = min(1e-4, 1e-3 * (self.t_end - t0))
                if self.h0 is not None:
                    dl = min(dl, 1e-2 * self.h0)
            else:
                dl = min(1e-4, 1e-2 * self.h)
            st = State(t0, self.q, self.qd, self.qdd, self.lam)      # views: the start corrects q̇ in place
            engine = self._start_engine()
            j0 = initial.jerk(self.model, self.start_weights, engine, st, dl)
            # the factorization at the initial state, for re-synchronisations
            qpp0 = self._qpp(t0, self.q, self.qd, self.Wv[S.W_KBACC], self.Wv[S.W_KPIVACC])
            self.Wv[S.W_QPP][:] = qpp0
            self.Wv[S.W_JN][:] = j0
            self.si[S.SI_HAVEJ] = 1
            self.si[cp.mod.SI_PROJ] = 2        # that factorization serves the first re-synchronisation
            if self.adaptive:
                if self.h0 is not None:
                    h0 = self.h0
                else:
                    wq = self.atol + self.rtol * self.model.magnitude(self.q)
                    nrm = math.sqrt(np.mean((self.Cq * j0 / wq) ** 2))
                    expo = -0.5 if self.error_per == "unit_step" else -1.0 / 3.0
                    h0 = 0.5 * min(nrm ** expo if nrm > 0 else math.inf, 0.1)
                h0 = min(h0, 0.05 * (self.t_end - t0), self.h_max)
                self.sf[S.SF_HNEXT] = h0
                self.sf[S.SF_HPREV] = h0
            self.start_used = self.start
            if self.start == "consistent" and not self.adaptive and not start_is_resolved(h0, self.qd, j0):
                # the jerk is that of a motion the step does not resolve (a stiff element set moving
                # impulsively, e.g. a beam node turned by a driver at t0): the expansion behind the
                # consistent start does not hold, and its correction d·h·j₀ would be far larger than
                # the motion; the seed's start (a₀ = q̈₀, exact q̇₀) is used, with its O(h) transient in λ
                self.start_used = "seed (start not resolved by h)"
            if self.start_used == "consistent":
                self.a[:] = initial.consistent_start(self.model, self.start_weights, engine, st, j0, h0, self.alpha,
                                                     self.Cq, self.formulation == "index3")
        elif not self.adaptive and self.check_every:
            pass
        if not self.adaptive:
            self.sf[S.SF_HPREV] = self.h

    def _buffers(self, n):
        b = self._bufs
        if b is None or b[0].shape[0] < n:
            nv, nc = self.model.nq, _multipliers(self.model)
            b = (np.zeros(n), np.zeros((n, self.model.nx)), np.zeros((n, nv)), np.zeros((n, nv)), np.zeros((n, nc)),
                 np.zeros(n), np.zeros(n, dtype=np.int32), np.zeros(n))
            self._bufs = b
        return b

    def _compile(self):
        """Load the engine before any timing starts (it is compiled once per installation,
        :func:`femb.engine.ensure_engine`; a call of 0 steps)."""
        self.advance(0)

    def advance(self, n_chunk):
        """Run the compiled loop for up to ``n_chunk`` accepted steps.

        Returns
        -------
        status : int
            1 when t_end was reached, 0 when the chunk is done; negative codes
            are raised as femb errors by :meth:`raise_status`.
        m : int
            States written into the buffers (``self._bufs``: t, q, q̇, q̈, λ, then
            per accepted step h, Newton iterations, error estimate).
        k : int
            Accepted steps in this call.
        """
        cp = self.cp
        bt, bq, bqd, bqdd, bl, bh, bit, berr = self._buffers(max(1, n_chunk))
        before = int(self.si[S.SI_STEP])
        m = 0
        while True:
            k = int(self.si[S.SI_STEP]) - before
            try:
                out = S.Out(bt[m:], bq[m:], bqd[m:], bqdd[m:], bl[m:], bh[k:], bit[k:], berr[k:])
                status = cp.mod.run(cp.G, cp.C, self.W, self.par, self.step_state, self.newton_arrays, out, n_chunk - k)
            except IndexError as exc:      # a kernel's bounds check (FEMB_DEBUG=1)
                raise self._kernel_bounds_error(exc) from None
            m += int(self.si[S.SI_STORED])
            if status == S.ST_NEED_TF:            # Python time functions needed at info[0]
                self._fill_python_tf(float(self.info[0]))
                continue
            return status, m, int(self.si[S.SI_STEP]) - before

    def _kernel_bounds_error(self, exc):
        """The ModelError of an index out of bounds in a kernel during the run: which element type."""
        from femb.system import kernels as _k
        t = float(self.sf[S.SF_T])
        n = int(self.si[S.SI_STEP]) + 1
        model = self.model
        xq, xv = model.ext(self.q), model.ext_velocity(self.qd)
        h = float(self.sf[S.SF_HNEXT]) if self.adaptive else float(self.h)
        for tt in (t, t + h):
            for g in model.groups:
                try:
                    _k.contract_check(g, xq[g.xdofs], xv[g.dofs], t=tt)
                except ModelError as e:
                    return ModelError(f"{e} (during the run, near t = {tt:.6g} s, step {n})")
        return ModelError(f"a kernel indexed an array out of bounds near t = {t:.6g} s (step {n}): {exc}")

    def _newton_hint(self, n):
        st = self.initial_state
        flexible = bool(initial.deformable_groups(self.model, st.t, st.q, st.qd))
        return initial.newton_hint(n, flexible, self.start_weights is not None and self.start_used == "consistent")

    def raise_status(self, status):
        """Raise the femb error of a negative status of the compiled loop."""
        info = self.info
        t1, err_f, err_phi, k, iphi = float(info[0]), float(info[1]), float(info[2]), int(info[3]), int(info[4])
        n = int(self.si[S.SI_STEP]) + 1
        res = {"r_q": err_f, "Phi": err_phi}
        if status == S.ST_HMIN:
            last = int(self.si[S.SI_LASTFAIL])
            what = {-1: "non-finite residuals", -2: "Newton did not converge", -3: "Newton diverged",
                    -4: "singular iteration matrix"}.get(last, "rejected steps")
            msg = (f"step size fell below h_min = {self.h_min:.3g} s at t = {t1:.6g} s (step {n}) after "
                   f"{int(self.si[S.SI_NFAIL])} Newton failures and {int(self.si[S.SI_REJECTED])} rejected steps; "
                   f"last failure: {what}")
            if last == S.ST_SINGULAR:
                raise SingularMatrixError(f"{msg}; {singular_hint(self.model, self.q, t1)}", t=t1, step=n,
                                          residuals=res)
            raise ConvergenceError(msg + "; the motion may be singular here, or tighten phi_tol/rtol",
                                   t=t1, step=n, residuals=res)
        if status == S.ST_KKT_SINGULAR:
            raise SingularMatrixError(
                f"the matrix [[M, Φ_qᵀ], [Φ_q, 0]] of the constrained accelerations is singular at "
                f"t = {t1:.6g} s (step {n}); {singular_hint(self.model, self.q, t1)}", t=t1, step=n,
                residuals=res)
        if status == S.ST_NONFINITE:
            raise ConvergenceError(
                f"non-finite residual at t = {t1:.6g} s (step {n}, iteration {k}): the step diverged; "
                f"{self._newton_hint(n)}", t=t1, step=n, residuals=res)
        if status == S.ST_MAXITER:
            where = f"; largest constraint residual in '{self.owner[iphi]}'" if iphi >= 0 else ""
            if self.newton_test == "residual":
                detail = (f"‖r_q‖∞ = {err_f:.3e} N (moments / L; tolerance {info[5]:.3e}), ‖Φ‖∞ = {err_phi:.3e} m "
                          f"(tolerance {info[6]:.3e})")
            else:
                detail = (f"the corrections stopped contracting at iteration {k}; ‖r_q‖∞ = {err_f:.3e} N, "
                          f"‖Φ‖∞ = {err_phi:.3e} m (tolerance {info[6]:.3e})")
            raise ConvergenceError(
                f"Newton did not converge at t = {t1:.6g} s (step {n}) within {self.max_iter} iterations: "
                f"{detail}{where}; {self._newton_hint(n)}", t=t1, step=n, residuals=res)
        if status == S.ST_DIVERGED_SINGULAR:
            raise ConvergenceError(
                f"Newton diverged at t = {t1:.6g} s (step {n}): the iteration matrix became singular at "
                f"iteration {k} with ‖r_q‖∞ = {err_f:.3e} N, ‖Φ‖∞ = {err_phi:.3e} m; {SINGULAR_HINT_DIVERGED}",
                t=t1, step=n, residuals=res)
        if status == S.ST_SINGULAR:
            raise SingularMatrixError(
                f"singular iteration matrix at t = {t1:.6g} s (step {n}); "
                f"{singular_hint(self.model, self.q, t1)}", t=t1, step=n, residuals=res)
        raise RuntimeError(f"femb: unknown status {status} from the compiled loop")

    # ------------------------------------------------------------------ public
    @property
    def step_index(self):
        return int(self.si[S.SI_STEP])

    @property
    def t(self):
        return float(self.sf[S.SF_T])

    @property
    def F_ref(self):
        return float(self.sf[S.SF_FREF])

    @property
    def stats(self):
        s = self.stats_arr
        return {"steps": int(s[0]), "evaluations": int(s[1]), "factorizations": int(s[2]),
                "solves": int(s[3]), "roundoff_accepts": int(s[4]), "kkt_solves": int(s[5]),
                "kkt_refinements": int(s[6]),
                "rejected": int(self.si[S.SI_REJECTED]), "newton_failures": int(self.si[S.SI_NFAIL])}

    @property
    def state(self):
        """The current State (copies)."""
        return State(self.t, self.q.copy(), self.qd.copy(), self.qdd.copy(), self.lam.copy())

    def step(self):
        """Advance one accepted step; returns its number of Newton iterations."""
        status, _, k = self.advance(1)
        if status < 0:
            self.raise_status(status)
        if not k:
            raise ParameterError(f"the solver has reached its end (t = {self.t:.6g} s, step {self.step_index}); "
                                 "create it with a later t_end or more n_steps")
        return int(self._bufs[6][0])

    def max_error_estimate(self):
        """(largest local error estimate seen, its time); fixed steps only check every ``check_every``."""
        return float(self.sf[S.SF_ERRMAX]), float(self.sf[S.SF_ERRMAX_T])

    def settings(self):
        a = self.alpha
        return {"h": self.h, "adaptive": self.adaptive, "rtol": self.rtol,
                "atol": float(self.atol[0]) if np.all(self.atol == self.atol[0]) else self.atol.tolist(),
                "rho_inf": a.rho_inf, "alpha_m": a.alpha_m, "alpha_f": a.alpha_f,
                "beta": a.beta, "gamma": a.gamma, "scaling": self.scaling, "start": self.start,
                "start_used": self.start_used,
                "error_per": self.error_per, "newton_test": self.newton_test, "newton_rtol": self.newton_rtol,
                "newton_atol": self.newton_atol, "phi_tol": self.phi_tol, "max_iter": self.max_iter,
                "min_iter": self.min_iter, "newton": self.newton, "linear_solver": self.linear_solver,
                "predictor": self.predictor, "formulation": self.formulation, "band": (self.cp.kl, self.cp.ku),
                "storage": "dense" if self.cp.dense else "band",
                "newton_matrix": "carried" if self.ip[self.cp.mod.IP_CARRY] else "per step"}


# --------------------------------------------------------------------------
def simulate(model: Model | Mechanism, t_end: float, h: float | None = None, *, state: State | None = None,
             t0: float = 0.0, observer: Callable[..., Any] | None = None, options: SolverOptions | None = None,
             **kwargs: Any) -> Result:
    """Integrate a model from t0 to t_end, with fixed steps (``h``) or adaptive steps (``rtol``).

    Parameters
    ----------
    model : Model
        A compiled model (a :class:`~femb.system.mechanism.Mechanism` is compiled first).
    t_end : float
        Final time, hit exactly.
    h : float, optional
        Fixed step size: n = (t_end − t0)/h steps when that is an integer (to
        round-off), otherwise n = ⌈(t_end − t0)/h⌉ equal steps of (t_end − t0)/n,
        shorter than h: the run ends exactly on t_end and no step is longer than
        asked (:func:`femb.solve.options.fixed_steps`). At most 10¹¹ steps. With
        ``rtol`` also given, h is the first adaptive step instead.
    rtol, atol : float, optional
        Adaptive steps with local error tolerance rtol·|x| + atol on q and q̇
        (defaults: rtol = 1e-3; atol = 1e-3·rtol, so that an rtol given alone
        sets the tolerance of coordinates near zero too). With fixed steps they
        set the tolerance of the step-size check (default 1e-3 both; atol = rtol
        when rtol alone is given), which warns once when the steps are far too
        large.
    h0, h_max : float, optional
        First and largest adaptive step.
    t_eval : array_like, optional
        Output times (sorted, within [t0, t_end]): the result holds the
        solution there, interpolated between accepted steps (cubic Hermite in
        q from q and q̇, cubic Hermite in q̇ from q̇ and q̈, linear in q̈ and λ).
        Steps are not forced onto these times.
    start : {"consistent", "seed"}
        Starting values (see :class:`GeneralizedAlphaSolver`): "consistent"
        makes λ and driving forces second order from the first step; "seed" is
        the seed paper's start.
    formulation : {"index3", "index2"}
        "index3" (default): the index-3 generalized-α scheme of Arnold & Brüls
        (2007). "index2": the stabilized index-2 (GGL-type) form, planar or
        spatial, fixed or adaptive steps: Φ and the velocity constraint B q̇ + Φ_t hold
        at every step and λ stays accurate as h → 0 (no 1/h² amplification of
        errors in Φ), at the cost of m more unknowns and about 1.4× the Newton
        iterations. Pick it for very small steps or when reaction forces or
        velocity constraints must be accurate, or to run at ρ∞ = 1 (no numerical
        damping; the heavy top keeps E and L_z to O(h²)); see docs/method.md §7
        and docs/spatial.md.
    rho_inf, alpha, scaling, initialize
        See :class:`GeneralizedAlphaSolver`, as are the further solver options
        (error_per, newton_test, phi_tol, max_iter, newton, linear_solver,
        predictor, check_every, ...: :data:`femb.solve.options.SolverOptions.NAMES`).
    t0 : float
    state : State, optional
    options : SolverOptions, optional
        The solver options at once (:meth:`femb.solve.options.SolverOptions.create`; its
        ``h`` when ``h`` is not given); solver options given as keywords change them.
    stride : int
        Store every ``stride``-th accepted step (the initial and the final
        state are always stored).
    store : bool
        Keep stored steps in memory (False: only the initial and last state,
        for runs streamed through ``observer``).
    observer : callable(state, step), optional
        Called after initialization (step 0) and after every accepted step
        with the current :class:`State` — or, when the observer has an integer
        attribute ``every`` (as :class:`femb.io.VTKStream` has), after every
        ``every``-th step and the last one. The compiled loop returns to Python
        only then; without an observer it runs many steps per call.
    progress : bool
        Show a progress bar with the time remaining (rich on a terminal, plain lines otherwise).
    check_convergence : bool
        Fixed steps: after the run, repeat its first 64 steps with h, h/2 and h/4
        (:func:`femb.solve.diagnostics.fixed_step_warning`, 7 × 64 extra steps) and warn
        (``AccuracyWarning``) when some coordinate does not converge at order ≥ 1: an
        oscillation the start excites that h does not resolve (docs/beams.md,
        "Convergence with unresolved axial modes"). The step-size check inside the run
        cannot see it: the ringing's amplitude is within its tolerance.

    Returns
    -------
    Result
        With ``h_steps`` (every accepted step size), ``n_rejected``,
        ``error_estimates`` and ``newton_iterations`` per accepted step.

    Raises
    ------
    ParameterError
        Bad h, t_end, stride, rho_inf, ..., or an unknown option name.
    ConvergenceError, SingularMatrixError
        A step failed (fixed steps), or the step size fell below its floor
        (adaptive); ``err.result`` holds what was stored until then.
    """
    from femb.system.mechanism import Mechanism
    if isinstance(model, Mechanism):
        model = model.compile()
    run, solver_kw = _split_keywords(options, kwargs)
    if h is None and options is not None:
        h = options.h
    t_eval, store, progress = run["t_eval"], run["store"], run["progress"]
    t0 = float(state.t) if state is not None else float(t0)
    t_end = _check_t_end(t_end, t0)
    stride = _check_stride(run["stride"])
    # a SolverOptions with a fixed step holds the tolerances of its step-size check (resolved,
    # never None): they do not make the run adaptive, an rtol keyword does
    fixed = options is not None and options.h is not None and "rtol" not in kwargs
    opts, n_steps, h_fixed = _run_options(h, solver_kw.pop("rtol", None), solver_kw.pop("atol", None),
                                          solver_kw.pop("h0", None), (t0, t_end, fixed), solver_kw)
    if t_eval is not None:
        t_eval = _check_t_eval(t_eval, t0, t_end)
        stride, store = 1, True
    storage = Storage(model, n_steps, stride, store)
    solver = GeneralizedAlphaSolver(model, h_fixed, options=opts, state=state, t0=t0, t_end=t_end,
                                    initialize=run["initialize"], n_steps=n_steps)
    solver.ip[S.IP_STRIDE] = stride
    solver.ip[S.IP_STORE] = 1 if store else 0
    st = solver.initial_state
    storage.add_states(np.array([st.t]), st.q[None], st.qd[None], st.qdd[None], st.lam[None])
    if observer is not None:
        observer(st.copy(), 0)
    wall0 = time.perf_counter()

    def result(status, message):
        res = storage.result(model, status, message, solver, time.perf_counter() - wall0)
        if t_eval is not None and status == "success":
            res = _interpolated(res, t_eval)
        return res

    _drive(solver, storage, observer, progress, result)
    _after_run_checks(solver, opts, h_fixed, run["check_convergence"])
    n = solver.step_index
    how = "adaptive steps" if opts.adaptive else "steps"
    res = result("success", f"reached t = {storage.t_last:.6g} s in {n} {how}"
                 + (f" ({solver.si[S.SI_REJECTED]} rejected)" if opts.adaptive else ""))
    if not opts.adaptive and opts.check_every and n <= opts.check_every and solver.sf[S.SF_WARN_T] != \
            solver.sf[S.SF_WARN_T]:
        t_s = res.steps_t if t_eval is not None else res.t
        q_s, qd_s = (storage.q.array(), storage.qd.array()) if t_eval is not None else (res.q, res.qd)
        _short_run_check(solver, t_s, q_s, qd_s, h_fixed)
    return res


# ---- the parts of simulate ----------------------------------------------------------------------
#: simulate's run settings (the keywords that are not solver options) and their defaults
RUN_SETTINGS = {"t_eval": None, "stride": 1, "store": True, "progress": False, "check_convergence": False,
                "initialize": True}


def _split_keywords(options, kwargs):
    """simulate's keywords: (run settings, the keywords of :meth:`SolverOptions.create` but h).

    ``options`` (a SolverOptions or None) gives the solver options that ``kwargs`` do not."""
    kwargs = dict(kwargs)
    run = {k: kwargs.pop(k, v) for k, v in RUN_SETTINGS.items()}
    if options is None:
        return run, kwargs
    if not isinstance(options, SolverOptions):
        raise ParameterError(f"options must be a femb.solve.options.SolverOptions, got {type(options).__name__}")
    base = options.as_kwargs(kwargs)
    base.pop("h")
    return run, base


def _check_t_end(t_end, t0):
    try:
        t_end = float(t_end)
    except (TypeError, ValueError):
        raise ParameterError(f"t_end must be a number, got {t_end!r}") from None
    if not math.isfinite(t_end) or t_end <= t0:
        raise ParameterError(f"t_end must be a finite time after t0 = {t0}, got {t_end!r}")
    return t_end


def _check_stride(stride):
    try:
        s = int(stride)
    except (TypeError, ValueError, OverflowError):
        raise ParameterError(f"stride must be a positive integer, got {stride!r}") from None
    if s < 1 or s != stride:
        raise ParameterError(f"stride must be a positive integer, got {stride!r}")
    return s


def _check_t_eval(t_eval, t0, t_end):
    t_eval = np.asarray(t_eval, dtype=float).reshape(-1)
    if t_eval.size == 0 or not np.all(np.isfinite(t_eval)) or np.any(np.diff(t_eval) < 0) \
            or t_eval[0] < t0 - 1e-12 * max(1.0, abs(t0)) or t_eval[-1] > t_end * (1 + 1e-12) + 1e-300:
        raise ParameterError(f"t_eval must be sorted finite times within [{t0}, {t_end}]")
    return t_eval


def _run_options(h, rtol, atol, h0, span, options):
    """simulate's options: ``(SolverOptions, n_steps or None, fixed h or None)``.

    Adaptive steps when rtol is given or h is not (h is then the first step), unless ``span``
    = (t0, t_end, fixed) says fixed; fixed steps follow :func:`femb.solve.options.fixed_steps` (never
    longer than h, ending on t_end).
    """
    t0, t_end, fixed = span
    if h is not None:
        h = check_positive("h", h)
    if not fixed and (rtol is not None or h is None):
        return SolverOptions.create(None, rtol=rtol, atol=atol, h0=h if h0 is None else h0, **options), None, None
    n_steps, h_fixed = fixed_steps(h, t0, t_end)
    if h > t_end - t0:
        from femb.errors import ParameterWarning
        warnings.warn(f"the step h = {h:.3g} s is longer than the run (t_end − t0 = {t_end - t0:.3g} s): one "
                      f"step of {h_fixed:.3g} s is taken. Use a smaller h", ParameterWarning, stacklevel=3)
    return SolverOptions.create(h_fixed, rtol=rtol, atol=atol, h0=h0, **options), n_steps, h_fixed


def _drive(solver, storage, observer, progress, result):
    """Run the compiled loop chunk by chunk to t_end: storage, observer, progress bar, errors."""
    t0, t_end = solver.t0, solver.t_end
    every = 1
    if observer is not None:
        every = getattr(observer, "every", 1)
        every = every if isinstance(every, (int, np.integer)) and every >= 1 else 1
    chunk = int(every) if observer is not None else (256 if progress else CHUNK)
    bar, done_pm = None, 0
    if progress:
        from femb.io.progress import progress as _progress
        bar = _progress(1000, f"{solver.model.name} (per mille of [t0, t_end])")
    try:
        while True:
            status, m, k = solver.advance(chunk)
            bt, bq, bqd, bqdd, bl, bh, bit, berr = solver._bufs
            storage.add_states(bt[:m], bq[:m], bqd[:m], bqdd[:m], bl[:m])
            storage.add_steps(bh[:k], bit[:k], berr[:k])
            if status < 0:
                try:
                    solver.raise_status(status)
                except (ConvergenceError, SingularMatrixError) as err:
                    err.result = result("failed", str(err))
                    raise
            if bar is not None:
                pm = int(1000 * (solver.t - t0) / (t_end - t0))
                if pm > done_pm:
                    bar.update(pm - done_pm)
                    done_pm = pm
            if observer is not None and k:
                s = solver.state
                if status == 1:
                    s.t = t_end
                observer(s, solver.step_index)
            if status == 1:
                return
    finally:
        if bar is not None:
            bar.close()


def _after_run_checks(solver, opts, h_fixed, check_convergence):
    """Fixed steps: the step-size check's warning, and the optional convergence check."""
    from femb.errors import AccuracyWarning
    if opts.adaptive:
        return
    if solver.sf[S.SF_WARN_T] == solver.sf[S.SF_WARN_T]:
        warnings.warn(
            f"the fixed step h = {h_fixed:.3g} s looks far too large: the local error estimate reached "
            f"{solver.sf[S.SF_WARN_ERR]:.3g} times the tolerance (rtol = {solver.rtol:g}, "
            f"atol = {float(solver.atol.max()):g}) at t = {solver.sf[S.SF_WARN_T]:.6g} s; the result may be wrong. "
            f"Use a smaller h or adaptive steps (simulate(..., rtol=...))", AccuracyWarning, stacklevel=3)
    if check_convergence:
        from femb.solve.diagnostics import fixed_step_warning
        msg = fixed_step_warning(solver.model, h_fixed, state=solver.initial_state, alpha=solver.alpha,
                                 formulation=opts.formulation, start=opts.start, scaling=opts.scaling)
        if msg:
            warnings.warn(msg, AccuracyWarning, stacklevel=3)


def _short_run_check(solver, T, Q, QD, h):
    """The fixed-step check of the compiled loop for runs too short for it (≤ ``check_every`` steps).

    The loop compares the constrained accelerations q̈ᵖᵖ of two consecutive steps
    every ``check_every`` steps (e_q = C_q h² Δq̈ᵖᵖ); a shorter run never gets there.
    Here the same estimate is formed from the stored states (consecutive steps
    with ``stride=1``; otherwise the difference over Δt is scaled to one step,
    h/Δt), and an :class:`~femb.errors.AccuracyWarning` is raised as the loop's
    would be.
    """
    from femb.errors import AccuracyWarning
    model = solver.model
    if len(T) < 2:
        return
    KB = np.zeros_like(solver.AB)
    kp = np.zeros_like(solver.ipiv)
    try:
        qpp = [solver._qpp(t, np.array(q), np.array(qd), KB, kp) for t, q, qd in zip(T, Q, QD)]
    except SingularMatrixError:            # a singular stored state: no estimate, the run itself stands
        return
    worst, t_worst = 0.0, T[0]
    for k in range(len(T) - 1):
        dt = T[k + 1] - T[k]
        if not dt > 0.0:
            continue
        eq = solver.Cq * h * h * (qpp[k + 1] - qpp[k]) * (h / dt)
        w = solver.atol + solver.rtol * np.maximum(model.magnitude(Q[k]), model.magnitude(Q[k + 1]))
        err = float(np.sqrt(np.mean((eq / w) ** 2)))
        if err > worst:
            worst, t_worst = err, T[k + 1]
    if worst > solver.warn_factor:
        warnings.warn(
            f"the fixed step h = {h:.3g} s looks far too large: the local error estimate reached {worst:.3g} times "
            f"the tolerance (rtol = {solver.rtol:g}, atol = {float(solver.atol.max()):g}) at t = {t_worst:.6g} s "
            f"(checked after this short run of {len(T) - 1} stored steps); the result may be wrong. Use a smaller h "
            "or adaptive steps (simulate(..., rtol=...))", AccuracyWarning, stacklevel=3)


def _interpolated(res, t_eval):
    """A Result at the times t_eval, interpolated between the stored accepted steps."""
    from femb.base.interp import interpolate_rows
    q, qd, qdd, lam = interpolate_rows(res.t, res.q, res.qd, res.qdd, res.lam, t_eval, res.model)
    out = Result(model=res.model, t=t_eval.copy(), q=q, qd=qd, qdd=qdd, lam=lam,
                 newton_iterations=res.newton_iterations, status=res.status, message=res.message,
                 wall_time=res.wall_time, init_time=res.init_time, stats=res.stats, settings=res.settings)
    out.h_steps = res.h_steps
    out.error_estimates = res.error_estimates
    out.n_rejected = res.n_rejected
    out.n_newton_failures = res.n_newton_failures
    out.steps_t = res.t
    return out
