"""The index-3 generalized-α scheme of Arnold & Brüls (2007): the one time loop.

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
import time
import warnings

import numpy as np
import scipy.linalg as sla
import scipy.sparse.linalg as spla

from femb.alpha import GeneralizedAlpha
from femb.assembly import Assembler
from femb.errors import SINGULAR_HINT_DIVERGED, ConvergenceError, ParameterError, SingularMatrixError
from femb.initial import consistent_initial_state, singular_hint  # noqa: F401  (re-exported)
from femb.model import State
from femb.result import Result

#: systems with at most this many unknowns (nq + nc) use dense LU
DENSE_LIMIT = 200

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


# --------------------------------------------------------------------------
# the integrator
# --------------------------------------------------------------------------
class GeneralizedAlphaSolver:
    """Index-3 generalized-α integrator, Algorithm 1 of Arnold & Brüls (2007).

    Contract: ``step()`` advances the state by one step of size ``h`` or
    raises (:class:`ConvergenceError`, :class:`SingularMatrixError`); it never
    accepts an unconverged step. The state (t, q, q̇, q̈, λ) satisfies the
    equations of motion and Φ = 0 at every accepted step to the Newton
    tolerance. The auxiliary variable ``a`` lives here, not in the state.

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
        ‖Δq‖∞ ≤ 64 ε (‖q‖∞ + L): then no iteration can improve it (counted in
        ``stats["roundoff_accepts"]``).
    phi_tol : float
        Constraint test ‖Φ‖∞ ≤ phi_tol · L with L the model's length scale.
        Keep it tight: a residual Φ puts an error ~‖Φ‖/h² into λ.
    max_iter : int
        Newton iteration limit per step.
    min_iter : {1, 0}
        Newton corrections taken at least per step (default 1). With 0 a
        prediction that already passes the tests is accepted as it is; its
        leftover Φ then enters λ as an error of order ‖Φ‖/(βh²), which grows
        like 1/h² for tiny steps.
    newton : {"full", "modified"}
        "full" refactors the exact iteration matrix at every iteration
        (quadratic convergence); "modified" reuses the last factorization
        across iterations and steps while Newton contracts by at least a
        factor 4 per iteration, refactoring otherwise.
    linear_solver : {"auto", "dense", "sparse"}
        Dense LAPACK LU for nq + nc ≤ ``DENSE_LIMIT``, SuperLU above (decided once).
    predictor : {"extrapolate", "previous", "zero"}
        Newton's starting guess for (q̈_{n+1}, λ_{n+1}): linear extrapolation
        2(q̈_n, λ_n) − (q̈_{n−1}, λ_{n−1}) (default), (q̈_n, λ_n), or zeros
        (Algorithm 1 as printed). q and q̇ follow from (3)–(5), so every choice
        converges to the same solution; a closer start saves iterations.
    state : State, optional
        Initial state (default: the model's, made consistent).
    t0 : float
    initialize : bool
        Compute consistent initial values (method.md §5); default True.
    """

    def __init__(self, model, h, *, rho_inf=None, alpha=None, scaling=True, rtol=1e-10, atol=0.0,
                 phi_tol=1e-12, max_iter=25, min_iter=1, newton="full", linear_solver="auto", predictor="extrapolate",
                 state=None, t0=0.0, initialize=True):
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
            raise ParameterError(f"predictor must be 'zero' or 'previous', got {predictor!r}")
        self.predictor = predictor
        N = model.nq + model.nc
        if linear_solver == "auto":
            dense = N <= DENSE_LIMIT
        elif linear_solver in ("dense", "sparse"):
            dense = linear_solver == "dense"
        else:
            raise ParameterError(f"linear_solver must be 'auto', 'dense' or 'sparse', got {linear_solver!r}")
        self.linear_solver = "dense" if dense else "sparse"
        self.assembler = Assembler(model, dense)
        self.owner = _constraint_owner(model)

        t_init = time.perf_counter()
        if initialize:
            st = consistent_initial_state(model, state, t0=float(t0 if state is None else state.t),
                                          phi_tol=self.phi_tol)
        else:
            st = (state or model.initial_state(t0)).copy()
        self.init_time = time.perf_counter() - t_init
        self.state = st
        self.t0 = st.t
        self.a = st.qdd.copy()                   # a_0 = q̈_0
        self.step_index = 0
        self.stats = {"steps": 0, "evaluations": 0, "factorizations": 0, "solves": 0,
                      "roundoff_accepts": 0}
        #: relative size of a Newton correction taken as round-off (see _step_impl)
        self.xtol_roundoff = 64.0 * np.finfo(float).eps
        self._lu = None
        self._lu_h = None
        self._prev = None
        self._qx = model.ext(st.q)
        self._qdx = model.ext_velocity(st.qd)
        qx = model.ext(st.q)
        _, _, sc, _ = self.assembler.evaluate(st.t, qx, model.ext_velocity(st.qd), st.qdd, st.lam)
        self.F_ref = sc

    # ------------------------------------------------------------------ public
    def step(self):
        """Advance one step; returns the number of Newton iterations."""
        it = self._step_impl()
        self.step_index += 1
        self.stats["steps"] += 1
        return it

    def settings(self):
        a = self.alpha
        return {"h": self.h, "rho_inf": a.rho_inf, "alpha_m": a.alpha_m, "alpha_f": a.alpha_f,
                "beta": a.beta, "gamma": a.gamma, "scaling": self.scaling, "rtol": self.rtol,
                "atol": self.atol, "phi_tol": self.phi_tol, "max_iter": self.max_iter,
                "min_iter": self.min_iter,
                "newton": self.newton, "linear_solver": self.linear_solver, "predictor": self.predictor}

    # ------------------------------------------------------------------ the step
    def _step_impl(self):
        m = self.model
        nq = m.nq
        al = self.alpha
        h = self.h
        am, af, beta, gamma = al.alpha_m, al.alpha_f, al.beta, al.gamma
        bp, gp = al.newton_factors(h)
        c = beta * h * h if self.scaling else 1.0
        st = self.state
        t1 = self.t0 + (self.step_index + 1) * h      # no accumulation of round-off in t
        # Algorithm 1. The Newton iterates keep (3)-(5) satisfied for any initial
        # guess (q̈, λ) of the new step: "zero" is Algorithm 1 as printed,
        # "previous" starts from (q̈_n, λ_n), "extrapolate" from
        # 2(q̈_n, λ_n) − (q̈_{n−1}, λ_{n−1}); all converge to the same solution.
        ka = (1.0 - af) / (1.0 - am)                  # ∂a_{n+1}/∂q̈_{n+1}, eq. (3)
        a_base = (af * st.qdd - am * self.a) / (1.0 - am)
        if self.predictor == "zero":
            qdd = np.zeros(nq)
            lam = np.zeros(m.nc)
            a_pred = a_base
        else:
            if self.predictor == "extrapolate" and self._prev is not None:
                qdd = 2.0 * st.qdd - self._prev[0]
                lam = 2.0 * st.lam - self._prev[1]
            else:
                qdd = st.qdd.copy()
                lam = st.lam.copy()
            a_pred = a_base + ka * qdd
        qd = st.qd + (h * (1.0 - gamma)) * self.a + (h * gamma) * a_pred
        q = st.q + h * st.qd + (h * h * (0.5 - beta)) * self.a + (h * h * beta) * a_pred
        qx, qdx = self._qx, self._qdx
        tol_phi = self.phi_tol * m.length_scale
        rhs = np.empty(nq + m.nc)
        weight = self.assembler.weight
        full = self.newton == "full"
        prev_norm = None
        for k in range(self.max_iter + 1):
            qx[:nq] = q
            qdx[:nq] = qd
            # Full Newton needs S_t only where it solves; the first iterate of a step
            # almost always needs a correction, later ones are usually converged, so
            # S_t is built with the residual at k = 0 and on demand after that.
            need_jac = (full and k == 0) or self._lu is None or self._lu_h != h
            r_q, Phi, scale, S = self.assembler.evaluate(t1, qx, qdx, qdd, lam, need_jac,
                                                         c * bp, c * gp, c)
            self.stats["evaluations"] += 1
            # the test uses this iterate's force scale; the running scale F_ref is
            # updated from accepted steps only (a diverging iterate must not loosen
            # the tolerance for the rest of the run)
            F = scale if scale > self.F_ref else self.F_ref
            err_f = np.abs(r_q * weight).max(initial=0.0)
            err_phi = np.abs(Phi).max(initial=0.0)
            if not (math.isfinite(err_f) and math.isfinite(err_phi)):
                raise ConvergenceError(
                    f"non-finite residual at t = {t1:.6g} s (step {self.step_index + 1}, iteration {k}): "
                    "the step diverged; try a smaller h", t=t1, step=self.step_index + 1,
                    residuals={"r_q": err_f, "Phi": err_phi})
            # at least one Newton correction per step: a prediction that already
            # passes the tests still carries a Φ residual that becomes an O(‖Φ‖/h²)
            # error in λ; one exact-Newton correction makes it quadratically small
            if k >= self.min_iter and err_f <= self.rtol * F + self.atol and err_phi <= tol_phi:
                break
            if k == self.max_iter:
                i = int(np.argmax(np.abs(Phi))) if m.nc else None
                where = f"; largest constraint residual in '{self.owner[i]}'" if i is not None else ""
                raise ConvergenceError(
                    f"Newton did not converge at t = {t1:.6g} s (step {self.step_index + 1}) within "
                    f"{self.max_iter} iterations: ‖r_q‖∞ = {err_f:.3e} N (moments / L; tolerance "
                    f"{self.rtol * F + self.atol:.3e}), ‖Φ‖∞ = {err_phi:.3e} m (tolerance "
                    f"{tol_phi:.3e}){where}; try a smaller h", t=t1, step=self.step_index + 1,
                    residuals={"r_q": err_f, "Phi": err_phi})
            if full and S is None:
                r_q, Phi, scale, S = self.assembler.evaluate(t1, qx, qdx, qdd, lam, True, c * bp, c * gp, c)
                self.stats["evaluations"] += 1
            if not full and prev_norm is not None and self._lu is not None:
                # modified Newton: refactor when contraction is poor
                cur = max(err_f / max(F, 1e-300), err_phi / max(tol_phi, 1e-300))
                if cur > 0.25 * prev_norm and S is None:
                    r_q, Phi, scale, S = self.assembler.evaluate(t1, qx, qdx, qdd, lam, True, c * bp, c * gp, c)
                    self.stats["evaluations"] += 1
            if S is not None:
                try:
                    self._lu = _LU(S, self.assembler.dense, 1e-13 if self.scaling else 0.0)
                except _Singular:
                    if k > 0:
                        raise ConvergenceError(
                            f"Newton diverged at t = {t1:.6g} s (step {self.step_index + 1}): the iteration "
                            f"matrix became singular at iteration {k} with ‖r_q‖∞ = {err_f:.3e} N, "
                            f"‖Φ‖∞ = {err_phi:.3e} m; {SINGULAR_HINT_DIVERGED}", t=t1, step=self.step_index + 1,
                            residuals={"r_q": err_f, "Phi": err_phi}) from None
                    raise SingularMatrixError(
                        f"singular iteration matrix at t = {t1:.6g} s (step {self.step_index + 1}); "
                        f"{singular_hint(m, q, t1)}", t=t1, step=self.step_index + 1,
                        residuals={"r_q": err_f, "Phi": err_phi}) from None
                self._lu_h = h
                self.stats["factorizations"] += 1
            if not full:
                prev_norm = max(err_f / max(F, 1e-300), err_phi / max(tol_phi, 1e-300))
            rhs[:nq] = r_q
            rhs[:nq] *= -c
            rhs[nq:] = -Phi
            x = self._lu.solve(rhs)
            self.stats["solves"] += 1
            dq = x[:nq]
            q += dq
            qd += gp * dq
            qdd += bp * dq
            lam += x[nq:] * (1.0 / c)
            # Round-off floor: a correction at the level of the coordinates' own
            # round-off cannot improve the iterate, so with Φ satisfied the step
            # has converged to machine precision (the force residual of stiff
            # elements stalls at ~ε·stiffness·|q|, which a relative test alone
            # would demand to beat when the motion is nearly at rest).
            if (err_phi <= tol_phi and err_f <= 1e4 * (self.rtol * F + self.atol)
                    and np.abs(dq).max() <= self.xtol_roundoff * (np.abs(q).max() + m.length_scale)):
                self.stats["roundoff_accepts"] += 1
                k += 1
                break
        self.a = a_base + ka * qdd
        if F > self.F_ref:
            self.F_ref = F
        self._prev = (st.qdd, st.lam)
        self.state = State(t1, q, qd, qdd, lam)
        return k


# --------------------------------------------------------------------------
def simulate(model, t_end, h, *, rho_inf=None, alpha=None, scaling=True, t0=0.0, state=None,
             stride=1, store=True, observer=None, initialize=True, **newton_options):
    """Integrate a model from t0 to t_end with fixed step h.

    Parameters
    ----------
    model : Model
    t_end : float
        Final time; the number of steps is round((t_end − t0)/h) and the last
        step lands on t_end exactly when (t_end − t0)/h is an integer (else h
        is reduced slightly so that it does).
    h : float
        Step size.
    rho_inf, alpha, scaling, initialize, **newton_options
        See :class:`GeneralizedAlphaSolver` (rtol, atol, phi_tol, max_iter,
        newton, linear_solver, predictor).
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
        with the current :class:`State` (do not modify it). Use it to stream
        output or show progress.

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
                                    state=state, t0=t0, initialize=initialize, **newton_options)
    st = solver.state
    T, Q, QD, QDD, L = [st.t], [st.q.copy()], [st.qd.copy()], [st.qdd.copy()], [st.lam.copy()]
    iters = np.zeros(n_steps, dtype=np.int32)
    if observer is not None:
        observer(st, 0)
    wall0 = time.perf_counter()

    def result(status, message, upto):
        return Result(model=model, t=np.array(T), q=np.array(Q), qd=np.array(QD), qdd=np.array(QDD),
                      lam=np.array(L).reshape(len(T), model.nc), newton_iterations=iters[:upto].copy(),
                      status=status, message=message, wall_time=time.perf_counter() - wall0,
                      init_time=solver.init_time, stats=dict(solver.stats), settings=solver.settings())

    n = 0
    try:
        for n in range(1, n_steps + 1):
            iters[n - 1] = solver.step()
            st = solver.state
            if n == n_steps:
                st.t = t_end          # t0 + n h_eff may differ from t_end in the last bit
            if store and (n % stride == 0 or n == n_steps):
                T.append(st.t)
                Q.append(st.q.copy())
                QD.append(st.qd.copy())
                QDD.append(st.qdd.copy())
                L.append(st.lam.copy())
            elif not store and n == n_steps:
                T.append(st.t)
                Q.append(st.q.copy())
                QD.append(st.qd.copy())
                QDD.append(st.qdd.copy())
                L.append(st.lam.copy())
            if observer is not None:
                observer(st, n)
    except (ConvergenceError, SingularMatrixError) as err:
        err.result = result("failed", str(err), n - 1)
        raise
    except KeyboardInterrupt:
        raise
    return result("success", f"reached t = {T[-1]:.6g} s in {n_steps} steps", n_steps)
