"""The index-3 generalized-α scheme of Arnold & Brüls (2007): the Python side of the time loop.

The time step itself (predictor, Newton iteration, band LU, chunks of steps) is
compiled code in ``femb/step.py``; this module validates options, computes
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
"""
from __future__ import annotations

import math
import sys
import time
import warnings

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from femb import assembly
from femb.alpha import GeneralizedAlpha
from femb.errors import (SINGULAR_HINT, ConvergenceError, InitializationError, ParameterError,
                         SingularMatrixError)
from femb.model import State
from femb.result import Result

#: systems with at most this many unknowns use dense LU in the (Python) initialization
DENSE_LIMIT = 200
#: steps per call of the compiled loop when nothing needs Python between steps
CHUNK = 4096

_getrf, _getrs = sla.get_lapack_funcs(("getrf", "getrs"), dtype=np.float64)


def _check_positive(name, value):
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a number, got {value!r}") from None
    if not (math.isfinite(v) and v > 0.0):
        raise ParameterError(f"{name} must be a positive finite number, got {value!r}")
    return v


def _constraint_owner(model):
    owner = np.empty(model.nc, dtype=object)
    for name, idx in model.lam_index.items():
        owner[idx] = name
    return owner


# --------------------------------------------------------------------------
# linear solves
# --------------------------------------------------------------------------
class _LU:
    """One factorization of a dense array or a CSC matrix.

    A pivot below ``rel_tol`` times the largest one is taken as singularity.
    That test is only meaningful for a well-scaled matrix (the scaled Newton
    system); the unscaled one has pivots of order h⁴ relative to the largest
    by design, so there only exact singularity (a zero pivot) is reported.
    """

    def __init__(self, S, dense, rel_tol=1e-13):
        self.dense = dense
        if dense:
            # LAPACK getrf/getrs directly: the wrappers' checks cost more than a 40x40 LU
            lu, piv, info = _getrf(S, overwrite_a=True)
            d = np.abs(np.diag(lu))
            if info > 0 or not np.all(np.isfinite(d)) or d.min() <= rel_tol * d.max():
                raise _Singular()
            self.lu = (lu, piv)
        else:
            try:
                self.lu = spla.splu(S)
            except RuntimeError:
                raise _Singular() from None
            d = np.abs(self.lu.U.diagonal())
            if not np.all(np.isfinite(d)) or d.min() <= rel_tol * d.max():
                raise _Singular()

    def solve(self, b):
        if self.dense:
            x, info = _getrs(self.lu[0], self.lu[1], b)
            return x
        return self.lu.solve(b)


class _Singular(Exception):
    pass


def _solve_augmented(A, B, rhs_top, rhs_bottom, what):
    """Solve [[A, Bᵀ], [B, 0]] [x; y] = [rhs_top; rhs_bottom] (sparse, once)."""
    K = sp.bmat([[A, B.T], [B, None]], format="csc") if B.shape[0] else sp.csc_matrix(A)
    rhs = np.concatenate((rhs_top, rhs_bottom))
    n = A.shape[0]
    try:
        if K.shape[0] <= DENSE_LIMIT:
            x = _LU(K.toarray(), True).solve(rhs)
        else:
            x = _LU(K, False).solve(rhs)
    except _Singular:
        raise InitializationError(f"{what}: the matrix [[A, Φ_qᵀ], [Φ_q, 0]] is singular; {SINGULAR_HINT}") from None
    return x[:n], x[n:]


# --------------------------------------------------------------------------
# consistent initial values (method.md §5)
# --------------------------------------------------------------------------
def consistent_initial_state(model, state=None, *, t0=0.0, phi_tol=1e-12, max_iter=50):
    """Project an initial state onto the constraints at all levels.

    1. positions: least change q = argmin ‖q − q_0‖ subject to Φ(q, t_0) = 0
       (Gauss–Newton);
    2. velocities: q̇ = argmin ‖q̇ − q̇_0‖ subject to Φ_q q̇ = −Φ_t;
    3. accelerations and multipliers from
       [[M, Φ_qᵀ], [Φ_q, 0]] [q̈; λ] = [f; −γ].

    Parameters
    ----------
    model : Model
    state : State, optional
        Starting guess (default: the model's initial state).
    t0 : float
    phi_tol : float
        Relative tolerance: ‖Φ‖∞ ≤ phi_tol × model.length_scale.
    max_iter : int

    Returns
    -------
    State

    Raises
    ------
    InitializationError
        If the positions cannot be projected (names the constraint with the
        largest residual), or a matrix is singular (redundant constraints).
    """
    st = (state or model.initial_state(t0)).copy()
    t = st.t
    nq, nc = model.nq, model.nc
    I = sp.identity(nq, format="csr")
    owner = _constraint_owner(model)
    tol = phi_tol * model.length_scale
    if nc:
        q0 = st.q.copy()
        q = st.q.copy()
        for k in range(max_iter + 1):
            Phi = assembly.constraint_vector(model, t, q)
            err = np.abs(Phi).max()
            if not np.isfinite(err):
                raise InitializationError("initial positions give non-finite constraint values")
            if err <= tol:
                break
            if k == max_iter:
                i = int(np.argmax(np.abs(Phi)))
                raise InitializationError(
                    f"cannot project the initial configuration onto the constraints: ‖Φ‖ = {err:.3e} "
                    f"after {max_iter} Gauss–Newton iterations; largest residual in element "
                    f"'{owner[i]}' ({Phi[i]:.3e}). The joints cannot all be closed from these positions: "
                    "check the bodies' positions and the joints' points")
            B = assembly.constraint_jacobian(model, t, q)
            _zero_rows(B, owner)
            try:
                dq, _ = _solve_augmented(I, B, q0 - q, -Phi, "position projection")
            except InitializationError:
                i = int(np.argmax(np.abs(Phi)))
                raise InitializationError(
                    f"cannot project the initial configuration onto the constraints: ‖Φ‖ = {err:.3e} "
                    f"(largest residual in element '{owner[i]}', {Phi[i]:.3e}) and the constraint "
                    f"Jacobian is rank-deficient at Gauss–Newton iteration {k}: the joints cannot all be "
                    f"closed from these positions, or some are redundant; {SINGULAR_HINT}") from None
            q += dq
        st.q = q
        B = assembly.constraint_jacobian(model, t, st.q)
        _zero_rows(B, owner)
        Phi_t, _ = assembly.constraint_rates(model, t, st.q, st.qd)
        st.qd, _ = _solve_augmented(I, B, st.qd, -Phi_t, "velocity projection")
        _, gam = assembly.constraint_rates(model, t, st.q, st.qd)
    else:
        B = sp.csr_matrix((0, nq))
        gam = np.zeros(0)
    M = assembly.mass_matrix(model, st.q)
    f = assembly.force_vector(model, t, st.q, st.qd)
    st.qdd, st.lam = _solve_augmented(M, B, f, -gam, "initial accelerations")
    if not (np.all(np.isfinite(st.qdd)) and np.all(np.isfinite(st.lam))):
        raise InitializationError("initial accelerations are not finite")
    return st


def _zero_rows(B, owner):
    absmax = np.zeros(B.shape[0])
    Bc = B.tocoo()
    np.maximum.at(absmax, Bc.row, np.abs(Bc.data))
    bad = np.nonzero(absmax == 0.0)[0]
    if bad.size:
        raise InitializationError(
            f"constraint {int(bad[0])} of element '{owner[bad[0]]}' does not depend on any free "
            "coordinate (it acts only on fixed coordinates): remove it or free a coordinate")


# --------------------------------------------------------------------------
# the integrator
# --------------------------------------------------------------------------
def _stepmod():
    from femb import codegen
    return codegen


class GeneralizedAlphaSolver:
    """Index-3 generalized-α integrator, Algorithm 1 of Arnold & Brüls (2007).

    Contract: ``step()`` advances the state by one step of size ``h`` or
    raises (:class:`ConvergenceError`, :class:`SingularMatrixError`); it never
    accepts an unconverged step. The state (t, q, q̇, q̈, λ) satisfies the
    equations of motion and Φ = 0 at every accepted step to the Newton
    tolerance. The auxiliary variable ``a`` lives here, not in the state.
    :func:`simulate` runs many steps per call of the compiled loop.

    Parameters
    ----------
    model : Model
    h : float
        Fixed step size.
    rho_inf : float in [0, 1], optional
        Spectral radius at infinity (Chung & Hulbert); default 0.7 unless
        ``alpha`` is given.
    alpha : GeneralizedAlpha or (α_m, α_f, β, γ), optional
        Parameters given directly; conditions are checked and violations warned.
    scaling : bool
        Solve the scaled Newton system (method.md eq. 8); default True.
    rtol : float
        Dynamic residual test ‖W r_q‖∞ ≤ rtol · F + atol in force units, where
        W divides moment rows by the length scale L (so the test does not
        depend on the choice of units) and F is the largest of the iterate's
        ‖W M q̈‖∞, ‖W f‖∞, ‖W Φ_qᵀλ‖∞ and of those of the accepted steps.
    atol : float
        Absolute floor of that test (N); default 0. Independently, an iterate
        is accepted when Φ passes its test, the force residual is within 1e4 of
        its tolerance, and the last Newton correction is at round-off level,
        ‖Δq‖∞ ≤ 64 ε (‖q‖∞ + L) (counted in ``stats["roundoff_accepts"]``).
    phi_tol : float
        Constraint test ‖Φ‖∞ ≤ phi_tol · L with L the model's length scale.
    max_iter : int
        Newton iteration limit per step.
    min_iter : {1, 0}
        Newton corrections taken at least per step (default 1).
    newton : {"full", "modified"}
        "full" refactors the exact iteration matrix at every iteration;
        "modified" reuses the last factorization across iterations and steps
        while Newton contracts by at least a factor 4 per iteration.
    linear_solver : {"auto", "band", "dense", "sparse"}
        "auto" (= "band", = "sparse"): compiled band LU with partial pivoting
        after a reverse Cuthill–McKee ordering of the iteration matrix, computed
        once per model; "dense": the same LU on the full matrix in the natural
        order (kl = ku = N − 1).
    predictor : {"extrapolate", "previous", "zero"}
        Newton's starting guess for (q̈_{n+1}, λ_{n+1}).
    state : State, optional
        Initial state (default: the model's, made consistent).
    t0 : float
    initialize : bool
        Compute consistent initial values (method.md §5); default True.
    n_steps : int, optional
        Steps the solver may take (default: unlimited); ``t_end`` is reported
        as the time of step ``n_steps``.
    t_end : float, optional
    """

    def __init__(self, model, h, *, rho_inf=None, alpha=None, scaling=True, rtol=1e-10, atol=0.0,
                 phi_tol=1e-12, max_iter=25, min_iter=1, newton="full", linear_solver="auto", predictor="extrapolate",
                 state=None, t0=0.0, initialize=True, n_steps=None, t_end=None):
        from femb.model import Model
        if not isinstance(model, Model):
            raise ParameterError(f"expected a compiled Model (call mechanism.compile()), got {type(model).__name__}")
        self.model = model
        self.h = _check_positive("h", h)
        if alpha is not None and rho_inf is not None:
            raise ParameterError("give either rho_inf or alpha, not both")
        if alpha is None:
            self.alpha = GeneralizedAlpha.from_rho_inf(0.7 if rho_inf is None else rho_inf)
            if self.alpha.rho_inf == 1.0:
                warnings.warn("rho_inf = 1 is not strictly stable at infinity: Lagrange multipliers "
                              "oscillate and need not converge (Arnold & Brüls 2007, Fig. 8)",
                              category=__import__("femb.errors", fromlist=["ParameterWarning"]).ParameterWarning,
                              stacklevel=2)
        elif isinstance(alpha, GeneralizedAlpha):
            self.alpha = alpha
            alpha.check(warn=True)
        else:
            try:
                am, af, b, g = alpha
            except (TypeError, ValueError):
                raise ParameterError(f"alpha must be (alpha_m, alpha_f, beta, gamma), got {alpha!r}") from None
            self.alpha = GeneralizedAlpha.from_values(am, af, b, g)
        self.scaling = bool(scaling)
        self.rtol = _check_positive("rtol", rtol)
        self.atol = float(atol)
        if not (self.atol >= 0.0 and math.isfinite(self.atol)):
            raise ParameterError(f"atol must be a non-negative number, got {atol!r}")
        self.phi_tol = _check_positive("phi_tol", phi_tol)
        if int(max_iter) < 1:
            raise ParameterError(f"max_iter must be at least 1, got {max_iter!r}")
        self.max_iter = int(max_iter)
        if int(min_iter) not in (0, 1):
            raise ParameterError(f"min_iter must be 0 or 1, got {min_iter!r}")
        self.min_iter = int(min_iter)
        if newton not in ("full", "modified"):
            raise ParameterError(f"newton must be 'full' or 'modified', got {newton!r}")
        self.newton = newton
        if predictor not in ("zero", "previous", "extrapolate"):
            raise ParameterError(f"predictor must be 'zero', 'previous' or 'extrapolate', got {predictor!r}")
        self.predictor = predictor
        if linear_solver not in ("auto", "band", "dense", "sparse"):
            raise ParameterError(f"linear_solver must be 'auto', 'band', 'dense' or 'sparse', got {linear_solver!r}")
        self.linear_solver = "dense" if linear_solver == "dense" else "band"
        self.owner = _constraint_owner(model)

        t_init = time.perf_counter()
        if initialize:
            st = consistent_initial_state(model, state, t0=float(t0 if state is None else state.t),
                                          phi_tol=self.phi_tol)
        else:
            st = (state or model.initial_state(t0)).copy()
        self.init_time = time.perf_counter() - t_init
        self.t0 = st.t
        self.cp = _stepmod().compiled(model, ordering="natural" if self.linear_solver == "dense" else "rcm")
        cp = self.cp
        nv, nc = model.nq, model.nc
        N = nv + nc
        al = self.alpha
        self.n_steps = int(n_steps) if n_steps is not None else 2 ** 62
        self.ip = np.array([nv, nc, model.nfix, N, cp.kl, cp.ku, self.max_iter, self.min_iter,
                            1 if newton == "full" else 0,
                            {"zero": 0, "previous": 1, "extrapolate": 2}[predictor],
                            self.n_steps, 1, 1, 1 if cp.python_tf else 0], dtype=np.int64)
        self.fp = np.array([self.h, self.t0, al.alpha_m, al.alpha_f, al.beta, al.gamma, self.rtol, self.atol,
                            self.phi_tol, model.length_scale, 64.0 * np.finfo(float).eps,
                            1.0 if self.scaling else 0.0, 1e-13 if self.scaling else 0.0,
                            float(t_end) if t_end is not None else math.inf, 0.0])
        self.si = np.zeros(4, dtype=np.int64)
        self.sf = np.array([0.0, math.nan])
        self.stats_arr = np.zeros(5, dtype=np.int64)
        self.q, self.qd, self.qdd, self.lam = st.q.copy(), st.qd.copy(), st.qdd.copy(), st.lam.copy()
        self.a = st.qdd.copy()                   # a_0 = q̈_0
        self.pqdd = np.zeros(nv)
        self.plam = np.zeros(nc)
        self.AB = np.zeros(N * cp.ldab)
        self.ipiv = np.zeros(N, dtype=np.int64)
        self.r = np.zeros(nv)
        self.Phi = np.zeros(nc)
        self.rhs = np.zeros(N)
        self.x = np.zeros(N)
        self.info = np.zeros(8)
        self._bufs = None
        self._t = st.t
        # the force scale of the initial state starts the running scale F_ref
        self._evaluate_scale()
        self._compile()

    # ------------------------------------------------------------------ internals
    def _evaluate_scale(self):
        cp = self.cp
        if cp.python_tf:
            self._fill_python_tf(self.t0)
        else:
            cp.mod.eval_time_functions(self.t0, cp.C[8], cp.C[9], cp.C[10], cp.tfv)
        self.sf[0] = cp.mod.evaluate(cp.G, cp.C, self.t0, self.q, self.qd, self.qdd, self.lam, False,
                                     0.0, 0.0, 0.0, self.AB, self.r, self.Phi)

    def _fill_python_tf(self, t):
        for k, fn in self.cp.python_tf:
            self.cp.tfv[k, 0] = fn.f(t)
            self.cp.tfv[k, 1] = fn.df(t)
            self.cp.tfv[k, 2] = fn.ddf(t)
        self.sf[1] = t

    def _buffers(self, n):
        b = self._bufs
        if b is None or b[0].shape[0] < n:
            nv, nc = self.model.nq, self.model.nc
            b = (np.zeros(n), np.zeros((n, nv)), np.zeros((n, nv)), np.zeros((n, nv)), np.zeros((n, nc)))
            self._bufs = b
        return b

    def _compile(self):
        cp = self.cp
        if not cp.announced:
            cp.announced = True
            if cp.fresh:
                print(f"femb: compiling the time loop for this combination of elements "
                      f"({cp.kind_summary}); cached for later runs in {cp.cache_path}", file=sys.stderr, flush=True)
                t = time.perf_counter()
                self._run(0, np.zeros(1, dtype=np.int32))
                print(f"femb: compiled in {time.perf_counter() - t:.1f} s", file=sys.stderr, flush=True)

    def _run(self, n_chunk, iters):
        """Call the compiled loop for up to n_chunk steps; returns (status, stored)."""
        cp = self.cp
        bt, bq, bqd, bqdd, bl = self._buffers(max(1, n_chunk))
        while True:
            status = cp.mod.run_fixed(cp.G, cp.C, self.ip, self.fp, self.si, self.sf, self.stats_arr,
                                      self.q, self.qd, self.qdd, self.lam, self.a, self.pqdd, self.plam,
                                      cp.tfv, self.AB, self.ipiv, self.r, self.Phi, self.rhs, self.x, self.info,
                                      n_chunk, bt, bq, bqd, bqdd, bl, iters)
            if status == 2:                      # Python time functions needed at info[0]
                self._fill_python_tf(float(self.info[0]))
                continue
            return status, int(self.si[3])

    def _raise(self, status):
        info = self.info
        t1, err_f, err_phi, k, iphi = float(info[0]), float(info[1]), float(info[2]), int(info[3]), int(info[4])
        n = int(self.si[0]) + 1
        res = {"r_q": err_f, "Phi": err_phi}
        if status == -1:
            raise ConvergenceError(
                f"non-finite residual at t = {t1:.6g} s (step {n}, iteration {k}): the step diverged; "
                "try a smaller h", t=t1, step=n, residuals=res)
        if status == -2:
            where = f"; largest constraint residual in '{self.owner[iphi]}'" if iphi >= 0 else ""
            raise ConvergenceError(
                f"Newton did not converge at t = {t1:.6g} s (step {n}) within {self.max_iter} iterations: "
                f"‖r_q‖∞ = {err_f:.3e} N (moments / L; tolerance {info[5]:.3e}), ‖Φ‖∞ = {err_phi:.3e} m "
                f"(tolerance {info[6]:.3e}){where}; try a smaller h", t=t1, step=n, residuals=res)
        if status == -3:
            raise ConvergenceError(
                f"Newton diverged at t = {t1:.6g} s (step {n}): the iteration matrix became singular at "
                f"iteration {k} with ‖r_q‖∞ = {err_f:.3e} N, ‖Φ‖∞ = {err_phi:.3e} m; try a smaller h",
                t=t1, step=n, residuals=res)
        if status == -4:
            raise SingularMatrixError(
                f"singular iteration matrix at t = {t1:.6g} s (step {n}); {SINGULAR_HINT}",
                t=t1, step=n, residuals=res)
        raise RuntimeError(f"femb: unknown status {status} from the compiled loop")

    # ------------------------------------------------------------------ public
    @property
    def step_index(self):
        return int(self.si[0])

    @property
    def F_ref(self):
        return float(self.sf[0])

    @property
    def stats(self):
        s = self.stats_arr
        return {"steps": int(s[0]), "evaluations": int(s[1]), "factorizations": int(s[2]),
                "solves": int(s[3]), "roundoff_accepts": int(s[4])}

    @property
    def state(self):
        """The current State (copies)."""
        n = self.step_index
        t = self.t0 + n * self.h if n else self.t0
        return State(t, self.q.copy(), self.qd.copy(), self.qdd.copy(), self.lam.copy())

    def step(self):
        """Advance one step; returns the number of Newton iterations."""
        it = np.zeros(max(self.n_steps if self.n_steps < 2 ** 40 else 0, self.step_index + 1), dtype=np.int32)
        status, _ = self._run(1, it)
        if status < 0:
            self._raise(status)
        return int(it[self.step_index - 1])

    def settings(self):
        a = self.alpha
        return {"h": self.h, "rho_inf": a.rho_inf, "alpha_m": a.alpha_m, "alpha_f": a.alpha_f,
                "beta": a.beta, "gamma": a.gamma, "scaling": self.scaling, "rtol": self.rtol,
                "atol": self.atol, "phi_tol": self.phi_tol, "max_iter": self.max_iter,
                "min_iter": self.min_iter, "newton": self.newton, "linear_solver": self.linear_solver,
                "predictor": self.predictor, "band": (self.cp.kl, self.cp.ku)}


# --------------------------------------------------------------------------
def simulate(model, t_end, h, *, rho_inf=None, alpha=None, scaling=True, t0=0.0, state=None,
             stride=1, store=True, observer=None, initialize=True, **newton_options):
    """Integrate a model from t0 to t_end with fixed step h.

    Parameters
    ----------
    model : Model
        A compiled model (a :class:`~femb.mechanism.Mechanism` is compiled first).
    t_end : float
        Final time; the number of steps is round((t_end − t0)/h) and the last
        step lands on t_end exactly when (t_end − t0)/h is an integer (else h
        is reduced slightly so that it does).
    h : float
        Step size.
    rho_inf, alpha, scaling, initialize, **newton_options
        See :class:`GeneralizedAlphaSolver` (rtol, atol, phi_tol, max_iter,
        min_iter, newton, linear_solver, predictor).
    t0 : float
    state : State, optional
    stride : int
        Store every ``stride``-th step (the initial and the final state are
        always stored).
    store : bool
        Keep stored steps in memory (False: only the initial and last state,
        for runs streamed through ``observer``).
    observer : callable(state, step), optional
        Called after initialization (step 0) and after every accepted step
        with the current :class:`State`. The compiled loop then returns to
        Python after every step; without an observer it runs up to
        ``CHUNK`` steps per call.

    Returns
    -------
    Result

    Raises
    ------
    ParameterError
        Bad h, t_end, stride, rho_inf, ...
    ConvergenceError, SingularMatrixError
        A step failed; ``err.result`` holds what was stored until then.
    """
    from femb.mechanism import Mechanism
    if isinstance(model, Mechanism):
        model = model.compile()
    h = _check_positive("h", h)
    t0 = float(state.t) if state is not None else float(t0)
    try:
        t_end = float(t_end)
    except (TypeError, ValueError):
        raise ParameterError(f"t_end must be a number, got {t_end!r}") from None
    if not math.isfinite(t_end) or t_end <= t0:
        raise ParameterError(f"t_end must be a finite time after t0 = {t0}, got {t_end!r}")
    try:
        stride = int(stride)
    except (TypeError, ValueError):
        raise ParameterError(f"stride must be a positive integer, got {stride!r}") from None
    if stride < 1:
        raise ParameterError(f"stride must be a positive integer, got {stride!r}")
    n_steps = max(1, int(round((t_end - t0) / h)))
    h_eff = (t_end - t0) / n_steps
    solver = GeneralizedAlphaSolver(model, h_eff, rho_inf=rho_inf, alpha=alpha, scaling=scaling,
                                    state=state, t0=t0, initialize=initialize, n_steps=n_steps, t_end=t_end,
                                    **newton_options)
    solver.ip[11] = stride
    solver.ip[12] = 1 if store else 0
    st = solver.state
    T, Q, QD, QDD, L = [st.t], [st.q.copy()], [st.qd.copy()], [st.qdd.copy()], [st.lam.copy()]
    iters = np.zeros(n_steps, dtype=np.int32)
    if observer is not None:
        observer(st, 0)
    wall0 = time.perf_counter()
    chunk = 1 if observer is not None else min(CHUNK, n_steps)

    def result(status, message, upto):
        return Result(model=model, t=np.array(T), q=np.array(Q), qd=np.array(QD), qdd=np.array(QDD),
                      lam=np.array(L).reshape(len(T), model.nc), newton_iterations=iters[:upto].copy(),
                      status=status, message=message, wall_time=time.perf_counter() - wall0,
                      init_time=solver.init_time, stats=solver.stats, settings=solver.settings())

    def collect(m):
        bt, bq, bqd, bqdd, bl = solver._bufs
        T.extend(bt[:m].tolist())
        Q.extend(bq[:m].copy())
        QD.extend(bqd[:m].copy())
        QDD.extend(bqdd[:m].copy())
        L.extend(bl[:m].copy())

    while True:
        status, m = solver._run(chunk, iters)
        collect(m)
        if status < 0:
            try:
                solver._raise(status)
            except (ConvergenceError, SingularMatrixError) as err:
                err.result = result("failed", str(err), solver.step_index)
                raise
        if observer is not None and solver.step_index > 0:
            s = solver.state
            if solver.step_index == n_steps:
                s.t = t_end
            observer(s, solver.step_index)
        if status == 1 or solver.step_index >= n_steps:
            break
    return result("success", f"reached t = {T[-1]:.6g} s in {n_steps} steps", n_steps)
