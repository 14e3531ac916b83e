"""The generalized-α scheme of Arnold & Brüls (2007), index 3 and stabilized index 2: the Python side
of the time loop.

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

C. W. Gear, B. Leimkuhler, G. K. Gupta, J. Comput. Appl. Math. 12–13 (1985) 77–90
(stabilized index-2 formulation).
"""
from __future__ import annotations

import math
import time
import warnings
from typing import Any, Callable

import numpy as np
from numpy.typing import ArrayLike

from femb.alpha import GeneralizedAlpha
from femb.errors import SINGULAR_HINT_DIVERGED, ConvergenceError, ModelError, ParameterError, SingularMatrixError
from femb.initial import consistent_initial_state, singular_hint  # noqa: F401  (re-exported)
from femb import step as S
from femb.jit import pack
from femb.mechanism import Mechanism
from femb.model import Model, State
from femb.result import Result

#: systems with at most this many unknowns use dense LU in the (Python) initialization
DENSE_LIMIT = 200
#: steps per call of the compiled loop when nothing needs Python between steps
CHUNK = 4096



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
# --------------------------------------------------------------------------
# the integrator
# --------------------------------------------------------------------------
def _stepmod():
    from femb import codegen
    return codegen


FORMULATIONS = ("index3", "index2")


def _check_formulation(formulation, model):
    """The formulation name, or a ParameterError saying why it cannot run on this model."""
    if not isinstance(formulation, str) or formulation not in FORMULATIONS:
        raise ParameterError(f"formulation must be 'index3' (Arnold & Brüls 2007) or 'index2' (stabilized "
                             f"index 2, GGL), got {formulation!r}")
    return formulation


def error_constants(alpha):
    """Local error constants (C_q, C_v) of the generalized-α scheme (stepsize.md §1).

    q(t_n + h) − q_{n+1} = C_q h³ q⃛ and q̇(t_n + h) − q̇_{n+1} = C_v h³ q⁗ with
    C_q = 1/6 − β − Δ/2, C_v = 1/6 − ½[(1 − γ)Δ² + γ(1 + Δ)²] − Δ(1 − α_m − α_f)/2,
    Δ = α_m − α_f.
    """
    am, af, beta, gamma = alpha.alpha_m, alpha.alpha_f, alpha.beta, alpha.gamma
    d = am - af
    Cq = 1.0 / 6.0 - beta - 0.5 * d
    Cv = 1.0 / 6.0 - 0.5 * ((1.0 - gamma) * d * d + gamma * (1.0 + d) ** 2) - 0.5 * d * (1.0 - am - af)
    return Cq, Cv


#: largest h·ω (ω² ≈ ‖j₀‖/‖q̇₀‖, the fastest motion the start sets going) for which the consistent
#: start's expansion in h is used
START_RESOLUTION = 1.0


def start_is_resolved(h, v0, j0):
    """Whether the step h resolves the motion that the initial jerk j₀ shows (fixed steps).

    The consistent start a₀ = q̈₀ + (α_m − α_f) h j₀ (Arnold & Brüls 2007, stepsize.md §2) is the
    leading term of an expansion in h: it needs h ω ≪ 1 for the motions present at t₀. For an
    oscillation of frequency ω, j₀ ≈ −ω² q̇₀, so ω ≈ √(‖j₀‖/‖q̇₀‖) estimates the fastest one the start
    sets going. A start at rest (q̇₀ = 0) counts as resolved: its jerk comes from drivers and loads.

    Parameters
    ----------
    h : float
    v0, j0 : (nq,) ndarray
        Initial velocities and the jerk (central differences of the constrained accelerations).

    Returns
    -------
    bool
        ``h · ω ≤ START_RESOLUTION``.
    """
    nv = float(np.linalg.norm(v0))
    nj = float(np.linalg.norm(j0))
    if nv == 0.0 or nj == 0.0:
        return math.isfinite(nj)
    return h * math.sqrt(nj / nv) <= START_RESOLUTION


class GeneralizedAlphaSolver:
    """Generalized-α integrator: index 3 (Algorithm 1 of Arnold & Brüls 2007, fixed or adaptive
    steps) or stabilized index 2 (GGL-type; planar and spatial models, fixed or adaptive steps).

    Contract: :meth:`advance` runs the compiled loop (``femb/step.py``) for a
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

    def __init__(self, model, h=None, *, rho_inf=None, alpha=None, scaling=True, rtol=None, atol=None,
                 h0=None, h_max=None, error_per="step", start="consistent", newton_test="correction",
                 newton_rtol=1e-10, newton_atol=0.0, phi_tol=1e-12, max_iter=25, min_iter=1, newton="full",
                 linear_solver="auto", predictor="extrapolate", check_every=16, warn_factor=10.0,
                 state=None, t0=0.0, t_end=None, initialize=True, n_steps=None, formulation="index3"):
        from femb.model import Model
        if not isinstance(model, Model):
            raise ParameterError(f"expected a compiled Model (call mechanism.compile()), got {type(model).__name__}")
        self.model = model
        self.adaptive = h is None
        self.formulation = _check_formulation(formulation, model)
        self.h = None if h is None else _check_positive("h", h)
        if alpha is not None and rho_inf is not None:
            raise ParameterError("give either rho_inf or alpha, not both")
        if alpha is None:
            self.alpha = GeneralizedAlpha.from_rho_inf(0.7 if rho_inf is None else rho_inf)
            if self.alpha.rho_inf == 1.0 and self.formulation == "index3":
                # the index-2 form runs without numerical damping (docs/spatial.md, heavy top at ρ∞ = 1)
                warnings.warn("rho_inf = 1 is not strictly stable at infinity: with the index-3 formulation "
                              "Lagrange multipliers oscillate and need not converge (Arnold & Brüls 2007, "
                              "Fig. 8); formulation='index2' runs without numerical damping",
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
        self.rtol = 1e-3 if rtol is None else _check_positive("rtol", rtol)
        atol = 1e-3 if (atol is None and not self.adaptive) else (1e-6 if atol is None else atol)
        atolv = np.asarray(atol, dtype=float)
        if atolv.ndim == 0:
            atolv = np.full(model.nq, float(atolv))
        if atolv.shape != (model.nq,) or not np.all(np.isfinite(atolv)) or np.any(atolv <= 0.0):
            raise ParameterError(f"atol must be a positive number or an array of {model.nq} positive numbers, "
                                 f"got {atol!r}")
        self.atol = atolv
        if error_per not in ("unit_step", "step"):
            raise ParameterError(f"error_per must be 'unit_step' or 'step', got {error_per!r}")
        self.error_per = error_per
        if start not in ("consistent", "seed"):
            raise ParameterError(f"start must be 'consistent' or 'seed', got {start!r}")
        self.start = start
        self.start_used = start          # the start that ran (_start may fall back to the seed's)
        if newton_test not in ("correction", "residual"):
            raise ParameterError(f"newton_test must be 'correction' or 'residual', got {newton_test!r}")
        self.newton_test = newton_test
        self.newton_rtol = _check_positive("newton_rtol", newton_rtol)
        self.newton_atol = float(newton_atol)
        if not (self.newton_atol >= 0.0 and math.isfinite(self.newton_atol)):
            raise ParameterError(f"newton_atol must be a non-negative number, got {newton_atol!r}")
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
        check_every = int(check_every)
        if check_every < 0 or check_every == 1:
            raise ParameterError(f"check_every must be 0 (off) or at least 2, got {check_every}")
        self.check_every = check_every
        self.warn_factor = _check_positive("warn_factor", warn_factor)
        self.owner = _constraint_owner(model)
        self.h0 = None if h0 is None else _check_positive("h0", h0)

        t_init = time.perf_counter()
        if initialize:
            st = consistent_initial_state(model, state, t0=float(t0 if state is None else state.t),
                                          phi_tol=self.phi_tol)
        else:
            st = (state or model.initial_state(t0)).copy()
        self.init_time = time.perf_counter() - t_init
        self._initialized = bool(initialize)
        self.initial_state = st.copy()
        self.t0 = st.t
        if t_end is None:
            if self.adaptive:
                raise ParameterError("adaptive steps need t_end")
            # fixed steps without an end: step() as often as the caller likes
            t_end = self.t0 + self.h * n_steps if n_steps is not None else math.inf
        self.t_end = float(t_end)
        self.cp = _stepmod().compiled(model, ordering="natural" if self.linear_solver == "dense" else "rcm",
                                      layout=self.formulation)
        cp = self.cp
        NFP, NNS, NSF, NSI = cp.mod.NFP, cp.mod.NNS, cp.mod.NSF, cp.mod.NSI
        nv, nc = model.nq, model.nc
        N = cp.N
        al = self.alpha
        self.Cq, self.Cv = error_constants(al)
        if not self.adaptive:
            if n_steps is not None:
                self.n_steps = int(n_steps)
            elif math.isfinite(self.t_end):
                self.n_steps = max(1, int(round((self.t_end - self.t0) / self.h)))
            else:
                self.n_steps = 2 ** 62
        else:
            self.n_steps = 2 ** 62
        span = self.t_end - self.t0 if math.isfinite(self.t_end) else self.h * 1e6
        self.h_max = math.inf if h_max is None else _check_positive("h_max", h_max)
        self.h_min = 1e-10 * max(abs(self.t_end) if math.isfinite(self.t_end) else 0.0, span)
        self.ip = np.zeros(cp.mod.NIP, dtype=np.int64)
        self.ip[:] = [nv, nc, model.nfix, N, cp.kl, cp.ku, self.max_iter, self.min_iter,
                      1 if newton == "full" else 0, {"zero": 0, "previous": 1, "extrapolate": 2}[predictor],
                      self.n_steps, 1, 1, 1 if cp.python_tf else 0, 1 if self.adaptive else 0,
                      1 if newton_test == "correction" else 0, 0 if self.adaptive else check_every,
                      1 if cp.dense else 0, 1 if self.formulation == "index2" else 0,
                      cp.mod.carry_rule(N, cp.dense, newton_test == "correction", self.formulation == "index2")]
        self.fp = np.zeros(NFP)
        self.fp[:] = [self.h or 0.0, self.t0, al.alpha_m, al.alpha_f, al.beta, al.gamma, self.newton_rtol,
                      self.newton_atol, self.phi_tol, model.length_scale, 64.0 * np.finfo(float).eps,
                      1.0 if self.scaling else 0.0, 1e-13 if self.scaling else 0.0, self.t_end, 0.0,
                      self.rtol, self.h_max, self.h_min, self.Cq, self.Cv,
                      2.0 if error_per == "unit_step" else 3.0, 1.0 if error_per == "unit_step" else 0.0,
                      self.warn_factor, 1e-3 if self.adaptive else 1e-13, 1e3]
        self.si = np.zeros(NSI, dtype=np.int64)
        self.sf = np.zeros(NSF)
        self.sf[1] = math.nan
        self.sf[8] = math.nan
        self.sf[2] = self.t0
        self.sf[cp.mod.SF_ETA] = -1.0     # no Newton contraction estimate yet (femb/step.py)
        self.stats_arr = np.zeros(NNS, dtype=np.int64)
        self.q, self.qd, self.qdd, self.lam = st.q.copy(), st.qd.copy(), st.qdd.copy(), st.lam.copy()
        self.a = st.qdd.copy()
        self.pqdd = np.zeros(nv)
        self.plam = np.zeros(nc)
        self.AB = np.zeros(cp.storage_size)
        self.ipiv = np.zeros(cp.piv_size, dtype=np.int64)
        self.r = np.zeros(nv)
        self.Phi = np.zeros(nc)
        self.rhs = np.zeros(N)
        self.x = np.zeros(N)
        self.info = np.zeros(8)
        z = np.zeros
        nx = model.nx
        # work arrays of the compiled loop, one pack (femb.jit.pack); the names under which
        # femb/step.py reads them: q_s … plam_s (the accepted state), qpp, qpp_new, jn, jnew,
        # KB, KBacc, kpiv, kpivacc, kr, kx, gam, Pt, zq, zl, Bv, tgt, eq, ev, atolv, wq, du, lk
        self.W, self.Wv = pack(
            [z(nx), z(nv), z(nv), z(nc), z(nv), z(nv), z(nc), z(nv), z(nv), z(nv), z(nv),
             z(cp.storage_size), z(cp.storage_size), z(cp.piv_size, dtype=np.int64), z(cp.piv_size, dtype=np.int64),
             z(nv), z(N), z(nc), z(nc), z(nv), z(nc), z(nc), z(nc), z(nv), z(nv), self.atol.copy(), z(nv),
             z(nv), z(nc)])
        self._bufs = None
        self._compile()
        self._start()

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
        self.sf[1] = t

    def _qpp(self, t, q, qd, KB, kpiv):
        """Constrained accelerations q̈ᵖᵖ at (t, q, q̇) (compiled KKT solve)."""
        cp = self.cp
        W = self.W
        self._tf_at(t)
        out = np.zeros(self.model.nq)
        if cp.mod.kkt_accelerations(cp.G, cp.C, self.ip, self.fp, self.si, self.sf, self.stats_arr, float(t), q, qd,
                                    self.qdd, self.lam, 1.0, 1.0, self.AB, self.ipiv, np.zeros(self.model.nc), W,
                                    KB, kpiv, out, 0) != 0:
            raise SingularMatrixError(f"the matrix [[M, Φ_qᵀ], [Φ_q, 0]] of the constrained accelerations is "
                                      f"singular at t = {t:.6g} s (start); {singular_hint(self.model, q, t)}",
                                      t=float(t), step=0)
        return out

    def _start(self):
        """Force scale, jerk j_0, consistent a_0 and q̇_0, first step (stepsize.md §2, §4)."""
        cp = self.cp
        t0 = self.t0
        self._tf_at(t0)
        self.sf[0] = cp.mod.evaluate(cp.G, cp.C, t0, self.q, self.qd, self.qdd, self.lam, False,
                                     0.0, 0.0, 0.0, self.AB, self.r, self.Phi)
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
            q0, v0, a0 = self.q, self.qd, self.qdd
            KBt = np.zeros_like(self.AB)
            kp = np.zeros_like(self.ipiv)
            cmp = self.model.compose
            ap = self._qpp(t0 + dl, cmp(q0, dl * v0 + 0.5 * dl * dl * a0), v0 + dl * a0, KBt, kp)
            am_ = self._qpp(t0 - dl, cmp(q0, -dl * v0 + 0.5 * dl * dl * a0), v0 - dl * a0, KBt, kp)
            j0 = (ap - am_) / (2.0 * dl)
            # the factorization at the initial state, for re-synchronisations
            qpp0 = self._qpp(t0, self.q, self.qd, self.Wv[S.W_KBACC], self.Wv[S.W_KPIVACC])
            self.Wv[S.W_QPP][:] = qpp0
            self.Wv[S.W_JN][:] = j0
            self.si[8] = 1
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
                self.sf[3] = h0
                self.sf[4] = h0
            self.start_used = self.start
            if self.start == "consistent" and not self.adaptive and not start_is_resolved(h0, v0, j0):
                # the jerk is that of a motion the step does not resolve (a stiff element set moving
                # impulsively, e.g. a beam node turned by a driver at t0): the expansion behind the
                # consistent start does not hold, and its correction d·h·j₀ would be far larger than
                # the motion; the seed's start (a₀ = q̈₀, exact q̇₀) is used, with its O(h) transient in λ
                self.start_used = "seed (start not resolved by h)"
            if self.start_used == "consistent":
                d = self.alpha.alpha_m - self.alpha.alpha_f
                self.a[:] = self.qdd + d * h0 * j0
                # the index-2 scheme keeps B q̇ + Φ_t = 0 exactly: no normal-velocity offset to match,
                # only a (which lags q̈ by Δh) is started consistently
                if self.model.nc and self.formulation == "index3":
                    Bj = np.zeros(self.model.nc)
                    cp.mod.jacobian_times(cp.G, cp.C, float(t0), self.q, j0, Bj)
                    Pt = np.zeros(self.model.nc)
                    gm = np.zeros(self.model.nc)
                    self._tf_at(t0)
                    cp.mod.rates(cp.G, cp.C, float(t0), self.q, self.qd, Pt, gm)
                    target = -Pt + h0 * h0 * self.Cq * Bj
                    if self.model.lie:
                        # the bracket term of the first increment's defect on a Lie group,
                        # h³/12 [v0, v̇0] (Arnold, Cardona & Brüls 2016; docs/spatial.md)
                        Bb = np.zeros(self.model.nc)
                        cp.mod.jacobian_times(cp.G, cp.C, float(t0), self.q,
                                              self.model.bracket(self.qd, self.qdd), Bb)
                        target = target + (h0 * h0 / 12.0) * Bb
                    cp.mod.project_normal_velocity(cp.G, cp.C, self.ip, float(t0), self.q, self.qd, target,
                                                   self.Wv[S.W_KBACC], self.Wv[S.W_KPIVACC], self.Wv[S.W_KX], self.Wv[S.W_BV])
        elif not self.adaptive and self.check_every:
            pass
        if not self.adaptive:
            self.sf[4] = self.h

    def _buffers(self, n):
        b = self._bufs
        if b is None or b[0].shape[0] < n:
            nv, nc = self.model.nq, self.model.nc
            b = (np.zeros(n), np.zeros((n, self.model.nx)), np.zeros((n, nv)), np.zeros((n, nv)), np.zeros((n, nc)),
                 np.zeros(n), np.zeros(n, dtype=np.int32), np.zeros(n))
            self._bufs = b
        return b

    def _compile(self):
        """Load the engine before any timing starts (it is compiled once per installation,
        :func:`femb.step.ensure_engine`; a call of 0 steps)."""
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
        before = int(self.si[0])
        m = 0
        while True:
            k = int(self.si[0]) - before
            try:
                status = cp.mod.run(cp.G, cp.C, self.ip, self.fp, self.si, self.sf, self.stats_arr,
                                    self.q, self.qd, self.qdd, self.lam, self.a, self.pqdd, self.plam,
                                    cp.tfv, self.AB, self.ipiv, self.r, self.Phi, self.rhs, self.x, self.info,
                                    self.W, n_chunk - k, bt[m:], bq[m:], bqd[m:], bqdd[m:], bl[m:], bh[k:],
                                    bit[k:], berr[k:])
            except IndexError as exc:      # a kernel's bounds check (FEMB_DEBUG=1)
                raise self._kernel_bounds_error(exc) from None
            m += int(self.si[3])
            if status == 2:                      # Python time functions needed at info[0]
                self._fill_python_tf(float(self.info[0]))
                continue
            return status, m, int(self.si[0]) - before

    def _kernel_bounds_error(self, exc):
        """The ModelError of an index out of bounds in a kernel during the run: which element type."""
        from femb import kernels as _k
        t = float(self.sf[2])
        n = int(self.si[0]) + 1
        model = self.model
        xq, xv = model.ext(self.q), model.ext_velocity(self.qd)
        h = float(self.sf[3]) if self.adaptive else float(self.h)
        for tt in (t, t + h):
            for g in model.groups:
                try:
                    _k.contract_check(g, xq[g.xdofs], xv[g.dofs], t=tt)
                except ModelError as e:
                    return ModelError(f"{e} (during the run, near t = {tt:.6g} s, step {n})")
        return ModelError(f"a kernel indexed an array out of bounds near t = {t:.6g} s (step {n}): {exc}")

    def raise_status(self, status):
        """Raise the femb error of a negative status of the compiled loop."""
        info = self.info
        t1, err_f, err_phi, k, iphi = float(info[0]), float(info[1]), float(info[2]), int(info[3]), int(info[4])
        n = int(self.si[0]) + 1
        res = {"r_q": err_f, "Phi": err_phi}
        if status == -5:
            last = int(self.si[7])
            what = {-1: "non-finite residuals", -2: "Newton did not converge", -3: "Newton diverged",
                    -4: "singular iteration matrix"}.get(last, "rejected steps")
            msg = (f"step size fell below h_min = {self.h_min:.3g} s at t = {t1:.6g} s (step {n}) after "
                   f"{int(self.si[5])} Newton failures and {int(self.si[4])} rejected steps; last failure: {what}")
            if last == -4:
                raise SingularMatrixError(f"{msg}; {singular_hint(self.model, self.q, t1)}", t=t1, step=n,
                                          residuals=res)
            raise ConvergenceError(msg + "; the motion may be singular here, or tighten phi_tol/rtol",
                                   t=t1, step=n, residuals=res)
        if status == -6:
            raise SingularMatrixError(
                f"the matrix [[M, Φ_qᵀ], [Φ_q, 0]] of the constrained accelerations is singular at "
                f"t = {t1:.6g} s (step {n}); {singular_hint(self.model, self.q, t1)}", t=t1, step=n,
                residuals=res)
        if status == -1:
            raise ConvergenceError(
                f"non-finite residual at t = {t1:.6g} s (step {n}, iteration {k}): the step diverged; "
                "try a smaller h", t=t1, step=n, residuals=res)
        if status == -2:
            where = f"; largest constraint residual in '{self.owner[iphi]}'" if iphi >= 0 else ""
            if self.newton_test == "residual":
                detail = (f"‖r_q‖∞ = {err_f:.3e} N (moments / L; tolerance {info[5]:.3e}), ‖Φ‖∞ = {err_phi:.3e} m "
                          f"(tolerance {info[6]:.3e})")
            else:
                detail = (f"the corrections stopped contracting at iteration {k}; ‖r_q‖∞ = {err_f:.3e} N, "
                          f"‖Φ‖∞ = {err_phi:.3e} m (tolerance {info[6]:.3e})")
            raise ConvergenceError(
                f"Newton did not converge at t = {t1:.6g} s (step {n}) within {self.max_iter} iterations: "
                f"{detail}{where}; try a smaller h", t=t1, step=n, residuals=res)
        if status == -3:
            raise ConvergenceError(
                f"Newton diverged at t = {t1:.6g} s (step {n}): the iteration matrix became singular at "
                f"iteration {k} with ‖r_q‖∞ = {err_f:.3e} N, ‖Φ‖∞ = {err_phi:.3e} m; {SINGULAR_HINT_DIVERGED}",
                t=t1, step=n, residuals=res)
        if status == -4:
            raise SingularMatrixError(
                f"singular iteration matrix at t = {t1:.6g} s (step {n}); "
                f"{singular_hint(self.model, self.q, t1)}", t=t1, step=n, residuals=res)
        raise RuntimeError(f"femb: unknown status {status} from the compiled loop")

    # ------------------------------------------------------------------ public
    @property
    def step_index(self):
        return int(self.si[0])

    @property
    def t(self):
        return float(self.sf[2])

    @property
    def F_ref(self):
        return float(self.sf[0])

    @property
    def stats(self):
        s = self.stats_arr
        return {"steps": int(s[0]), "evaluations": int(s[1]), "factorizations": int(s[2]),
                "solves": int(s[3]), "roundoff_accepts": int(s[4]), "kkt_solves": int(s[5]),
                "kkt_refinements": int(s[6]),
                "rejected": int(self.si[4]), "newton_failures": int(self.si[5])}

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
        return float(self.sf[6]), float(self.sf[7])

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
def simulate(model: Model | Mechanism, t_end: float, h: float | None = None, *, rtol: float | None = None,
             atol: float | ArrayLike | None = None, h0: float | None = None, h_max: float | None = None,
             t_eval: ArrayLike | None = None, start: str = "consistent", formulation: str = "index3",
             rho_inf: float | None = None, alpha: GeneralizedAlpha | None = None, scaling: bool = True,
             t0: float = 0.0, state: State | None = None, stride: int = 1, store: bool = True,
             observer: Callable[..., Any] | None = None, initialize: bool = True, progress: bool = False,
             check_convergence: bool = False, **options: Any) -> Result:
    """Integrate a model from t0 to t_end, with fixed steps (``h``) or adaptive steps (``rtol``).

    Parameters
    ----------
    model : Model
        A compiled model (a :class:`~femb.mechanism.Mechanism` is compiled first).
    t_end : float
        Final time, hit exactly.
    h : float, optional
        Fixed step size: the number of steps is round((t_end − t0)/h) and h is
        adjusted slightly so that they end on t_end. With ``rtol`` also given,
        h is the first adaptive step instead.
    rtol, atol : float, optional
        Adaptive steps with local error tolerance rtol·|x| + atol on q and q̇
        (default when neither h nor rtol is given: rtol = 1e-3, atol = 1e-6).
        With fixed steps they set the tolerance of the step-size check
        (default 1e-3 both), which warns once when the steps are far too large.
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
    rho_inf, alpha, scaling, initialize, **options
        See :class:`GeneralizedAlphaSolver` (error_per, newton_test, phi_tol,
        max_iter, newton, linear_solver, predictor, check_every, ...).
    t0 : float
    state : State, optional
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
        (:func:`femb.diagnostics.fixed_step_warning`, 7 × 64 extra steps) and warn
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
        Bad h, t_end, stride, rho_inf, ...
    ConvergenceError, SingularMatrixError
        A step failed (fixed steps), or the step size fell below its floor
        (adaptive); ``err.result`` holds what was stored until then.
    """
    from femb.mechanism import Mechanism
    from femb.errors import AccuracyWarning
    if isinstance(model, Mechanism):
        model = model.compile()
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
    adaptive = rtol is not None or h is None
    if h is not None:
        h = _check_positive("h", h)
    if adaptive:
        if h0 is None and h is not None:
            h0 = h
        n_steps = None
        h_fixed = None
    else:
        n_steps = max(1, int(round((t_end - t0) / h)))
        h_fixed = (t_end - t0) / n_steps
        if h > t_end - t0:
            from femb.errors import ParameterWarning
            warnings.warn(f"the step h = {h:.3g} s is longer than the run (t_end − t0 = {t_end - t0:.3g} s): one "
                          f"step of {h_fixed:.3g} s is taken. Use a smaller h", ParameterWarning, stacklevel=2)
    if t_eval is not None:
        t_eval = np.asarray(t_eval, dtype=float).reshape(-1)
        if t_eval.size == 0 or not np.all(np.isfinite(t_eval)) or np.any(np.diff(t_eval) < 0) \
                or t_eval[0] < t0 - 1e-12 * max(1.0, abs(t0)) or t_eval[-1] > t_end * (1 + 1e-12) + 1e-300:
            raise ParameterError(f"t_eval must be sorted finite times within [{t0}, {t_end}]")
        stride, store = 1, True
    _check_formulation(formulation, model)
    solver = GeneralizedAlphaSolver(model, h_fixed, rho_inf=rho_inf, alpha=alpha, scaling=scaling,
                                    rtol=rtol, atol=atol, h0=h0, h_max=h_max, state=state, t0=t0, t_end=t_end,
                                    initialize=initialize, n_steps=n_steps, start=start,
                                    formulation=formulation, **options)
    solver.ip[11] = stride
    solver.ip[12] = 1 if store else 0
    st = solver.initial_state
    T, Q, QD, QDD, L = [st.t], [st.q.copy()], [st.qd.copy()], [st.qdd.copy()], [st.lam.copy()]
    H, IT, ERR = [], [], []
    if observer is not None:
        observer(st.copy(), 0)
    wall0 = time.perf_counter()
    every = 1
    if observer is not None:
        every = getattr(observer, "every", 1)
        every = every if isinstance(every, (int, np.integer)) and every >= 1 else 1
    chunk = int(every) if observer is not None else (256 if progress else CHUNK)
    bar = None
    if progress:
        from femb.io.progress import progress as _progress
        bar = _progress(1000, f"{model.name} (per mille of [t0, t_end])")
        done_pm = 0

    def result(status, message):
        lam = np.array(L).reshape(len(T), model.nc)
        res = Result(model=model, t=np.array(T), q=np.array(Q), qd=np.array(QD), qdd=np.array(QDD),
                     lam=lam, newton_iterations=np.array(IT, dtype=np.int32),
                     status=status, message=message, wall_time=time.perf_counter() - wall0,
                     init_time=solver.init_time, stats=solver.stats, settings=solver.settings())
        res.h_steps = np.array(H)
        res.error_estimates = np.array(ERR)
        res.n_rejected = int(solver.si[4])
        res.n_newton_failures = int(solver.si[5])
        if t_eval is not None and status == "success":
            res = _interpolated(res, t_eval)
        return res

    def collect(m, k):
        bt, bq, bqd, bqdd, bl, bh, bit, berr = solver._bufs
        T.extend(bt[:m].tolist())
        Q.extend(bq[:m].copy())
        QD.extend(bqd[:m].copy())
        QDD.extend(bqdd[:m].copy())
        L.extend(bl[:m].copy())
        H.extend(bh[:k].tolist())
        IT.extend(bit[:k].tolist())
        ERR.extend(berr[:k].tolist())

    try:
        while True:
            status, m, k = solver.advance(chunk)
            collect(m, k)
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
                break
    finally:
        if bar is not None:
            bar.close()
    if not adaptive and solver.sf[8] == solver.sf[8]:
        warnings.warn(
            f"the fixed step h = {h_fixed:.3g} s looks far too large: the local error estimate reached "
            f"{solver.sf[9]:.3g} times the tolerance (rtol = {solver.rtol:g}, atol = {float(solver.atol.max()):g}) "
            f"at t = {solver.sf[8]:.6g} s; the result may be wrong. Use a smaller h or adaptive steps "
            f"(simulate(..., rtol=...))", AccuracyWarning, stacklevel=2)
    if check_convergence and not adaptive:
        from femb.diagnostics import fixed_step_warning
        msg = fixed_step_warning(model, h_fixed, state=solver.initial_state, alpha=solver.alpha,
                                 formulation=formulation, start=start, scaling=scaling)
        if msg:
            warnings.warn(msg, AccuracyWarning, stacklevel=2)
    n = solver.step_index
    how = "adaptive steps" if adaptive else "steps"
    res = result("success", f"reached t = {T[-1]:.6g} s in {n} {how}"
                 + (f" ({solver.si[4]} rejected)" if adaptive else ""))
    if not adaptive and solver.check_every and n <= solver.check_every and solver.sf[8] != solver.sf[8]:
        _short_run_check(solver, T, Q, QD, h_fixed)
    return res


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
    from femb.interp import interpolate_rows
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
