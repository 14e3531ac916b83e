"""The solver's options, validated once: :class:`SolverOptions`.

Every entry point that runs the generalized-α solver (:func:`femb.simulate`,
:class:`femb.solve.solver.GeneralizedAlphaSolver`, :func:`femb.study.sweep.sweep`, the command line)
builds its options here, through :meth:`SolverOptions.create`: one dataclass, validated in
small functions, one per group (step size and tolerances, scheme parameters, Newton,
linear algebra and predictor, the fixed-step check). The solver then writes them into the
engine's named fields (``femb/engine/layout.py``: ``IP_FIELDS``, ``FP_FIELDS``).

The rule for the number of fixed steps (:func:`fixed_steps`) and the defaults of the
tolerances (:func:`_tolerances`) are stated in their docstrings.

References
----------
J. Chung, G. M. Hulbert, J. Appl. Mech. 60 (1993) 371–375 (ρ∞ → α_m, α_f, β, γ).
M. Arnold, O. Brüls, Multibody Syst. Dyn. 18 (2007) 185–202 (the scheme).
"""
from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np

from femb.errors import ParameterError, ParameterWarning
from femb.solve.alpha import GeneralizedAlpha

FORMULATIONS = ("index3", "index2")
#: adaptive runs without an explicit atol: atol = ATOL_PER_RTOL · rtol (the former default pair
#: rtol = 1e-3, atol = 1e-6 is this rule at rtol = 1e-3)
ATOL_PER_RTOL = 1e-3
#: fixed steps: rtol and atol of the step-size check when neither is given
CHECK_TOL = 1e-3
#: largest number of fixed steps a run may ask for (about 10⁵ s of engine time at 1 µs per step)
MAX_STEPS = 10 ** 11
#: fixed steps: span/h within this relative distance of an integer n is n steps (round-off of t_end/h)
STEP_COUNT_RTOL = 1e-9


def check_positive(name, value):
    """``float(value)``, or a ParameterError naming ``name`` if it is not a positive finite number."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a number, got {value!r}") from None
    if not (math.isfinite(v) and v > 0.0):
        raise ParameterError(f"{name} must be a positive finite number, got {value!r}")
    return v


def _choice(name, value, allowed):
    if not isinstance(value, str) or value not in allowed:
        raise ParameterError(f"{name} must be one of {', '.join(repr(a) for a in allowed)}, got {value!r}")
    return value


def _integer(name, value):
    if isinstance(value, bool):
        raise ParameterError(f"{name} must be an integer, got {value!r}")
    try:
        v = int(value)
    except (TypeError, ValueError, OverflowError):
        raise ParameterError(f"{name} must be an integer, got {value!r}") from None
    if v != value:
        raise ParameterError(f"{name} must be an integer, got {value!r}")
    return v


@dataclasses.dataclass(frozen=True)
class SolverOptions:
    """The validated options of the generalized-α solver (see :func:`femb.simulate` for each).

    Build it with :meth:`create` (it validates and resolves defaults); the fields hold the
    resolved values. ``atol`` is a float or an array of shape (nq,) (:meth:`atol_vector`).
    """

    h: float | None = None               # fixed step; None: adaptive
    rtol: float = 1e-3
    atol: object = 1e-6
    h0: float | None = None
    h_max: float = math.inf
    error_per: str = "step"
    alpha: GeneralizedAlpha = dataclasses.field(default_factory=lambda: GeneralizedAlpha.from_rho_inf(0.7))
    formulation: str = "index3"
    scaling: bool = True
    start: str = "consistent"
    newton_test: str = "correction"
    newton_rtol: float = 1e-10
    newton_atol: float = 0.0
    phi_tol: float = 1e-12
    max_iter: int = 25
    min_iter: int = 1
    newton: str = "full"
    linear_solver: str = "band"
    predictor: str = "extrapolate"
    check_every: int = 16
    warn_factor: float = 10.0

    #: the names :meth:`create` accepts
    NAMES = ("h", "rtol", "atol", "h0", "h_max", "error_per", "rho_inf", "alpha", "formulation", "scaling",
             "start", "newton_test", "newton_rtol", "newton_atol", "phi_tol", "max_iter", "min_iter", "newton",
             "linear_solver", "predictor", "check_every", "warn_factor")

    #: the options whose default is written None
    NONE_IS_DEFAULT = ("rtol", "atol", "h0", "h_max", "rho_inf", "alpha")

    @property
    def adaptive(self):
        return self.h is None

    @classmethod
    def create(cls, h=None, **options):
        """Validate and resolve the solver's options.

        Parameters
        ----------
        h : float or None
            Fixed step size; None for adaptive steps.
        **options
            Any of :data:`NAMES` (see :class:`femb.solve.solver.GeneralizedAlphaSolver`); None
            means the default for those of :data:`NONE_IS_DEFAULT`.

        Returns
        -------
        SolverOptions

        Raises
        ------
        ParameterError
            An unknown option name, or a value out of its range (naming the option).
        """
        unknown = sorted(k for k in options if k not in cls.NAMES or k == "h")
        if unknown:
            raise ParameterError(f"unknown solver option(s) {', '.join(unknown)}; the options are "
                                 f"{', '.join(cls.NAMES)}")
        o = {k: v for k, v in options.items() if v is not None or k not in cls.NONE_IS_DEFAULT}
        fields = {"h": None if h is None else check_positive("h", h)}
        fields.update(_scheme(o.get("rho_inf"), o.get("alpha"), o.get("formulation", "index3")))
        fields.update(_tolerances(fields["h"] is None, o.get("rtol"), o.get("atol"), o.get("h0"),
                                  o.get("h_max"), o.get("error_per", "step")))
        fields.update(_newton(o))
        fields.update(_linear(o.get("linear_solver", "auto"), o.get("predictor", "extrapolate"),
                              o.get("scaling", True)))
        fields.update(_check(o.get("check_every", 16), o.get("warn_factor", 10.0), o.get("start", "consistent")))
        return cls(**fields)

    def replace(self, **changes):
        """A copy with some fields changed (validated again through :meth:`create`)."""
        return SolverOptions.create(**self.as_kwargs(changes))

    def as_kwargs(self, changes=None):
        """The options as keyword arguments of :meth:`create`, updated by ``changes``.

        ``alpha`` is the GeneralizedAlpha (left out when ``changes`` give ``rho_inf``), and an
        unbounded ``h_max`` is None (the default), so that ``create(**as_kwargs())`` round-trips.
        """
        changes = dict(changes or {})
        kw = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        if kw["h_max"] == math.inf:
            kw["h_max"] = None
        if "rho_inf" in changes and "alpha" not in changes:
            kw.pop("alpha")
        kw.update(changes)
        return kw

    def atol_vector(self, nq):
        """atol as an array (nq,), or a ParameterError when its shape or values do not fit."""
        a = np.asarray(self.atol, dtype=float)
        if a.ndim == 0:
            a = np.full(nq, float(a))
        if a.shape != (nq,) or not np.all(np.isfinite(a)) or np.any(a <= 0.0):
            raise ParameterError(f"atol must be a positive number or an array of {nq} positive numbers, "
                                 f"got {self.atol!r}")
        return a


# ---- validation, one function per group -----------------------------------------------------
def _scheme(rho_inf, alpha, formulation):
    """The scheme's parameters (Chung & Hulbert 1993 from ρ∞, or given) and the formulation."""
    if not isinstance(formulation, str) or formulation not in FORMULATIONS:
        raise ParameterError(f"formulation must be 'index3' (Arnold & Brüls 2007) or 'index2' (stabilized "
                             f"index 2, GGL), got {formulation!r}")
    if alpha is not None and rho_inf is not None:
        raise ParameterError("give either rho_inf or alpha, not both")
    if alpha is None:
        al = GeneralizedAlpha.from_rho_inf(0.7 if rho_inf is None else rho_inf)
        if al.rho_inf == 1.0 and formulation == "index3":
            # the index-2 form runs without numerical damping (docs/spatial.md, heavy top at ρ∞ = 1)
            warnings.warn("rho_inf = 1 is not strictly stable at infinity: with the index-3 formulation "
                          "Lagrange multipliers oscillate and need not converge (Arnold & Brüls 2007, "
                          "Fig. 8); formulation='index2' runs without numerical damping",
                          ParameterWarning, stacklevel=4)
    elif isinstance(alpha, GeneralizedAlpha):
        al = alpha
        alpha.check(warn=True)
    else:
        try:
            am, af, b, g = alpha
        except (TypeError, ValueError):
            raise ParameterError(f"alpha must be (alpha_m, alpha_f, beta, gamma), got {alpha!r}") from None
        al = GeneralizedAlpha.from_values(am, af, b, g)
    return {"alpha": al, "formulation": formulation}


def _tolerances(adaptive, rtol, atol, h0, h_max, error_per):
    """rtol, atol, h0, h_max and the error norm.

    Defaults: adaptive steps take rtol = 1e-3 and atol = ``ATOL_PER_RTOL`` · rtol, so that an
    rtol given alone is not governed by a fixed atol (the former default pair 1e-3/1e-6 is this
    rule at rtol = 1e-3); the fixed-step check takes rtol = atol = 1e-3, or atol = rtol when rtol
    alone is given.
    """
    rtol_v = CHECK_TOL if rtol is None else check_positive("rtol", rtol)
    if atol is None:
        atol = ATOL_PER_RTOL * rtol_v if adaptive else (CHECK_TOL if rtol is None else rtol_v)
    elif np.ndim(atol) == 0:
        atol = check_positive("atol", atol)
    else:
        atol = np.array(atol, dtype=float)
    if error_per not in ("unit_step", "step"):
        raise ParameterError(f"error_per must be 'unit_step' or 'step', got {error_per!r}")
    return {"rtol": rtol_v, "atol": atol, "h0": None if h0 is None else check_positive("h0", h0),
            "h_max": math.inf if h_max is None else check_positive("h_max", h_max), "error_per": error_per}


def _newton(o):
    """The Newton iteration's stopping rule and limits (docs/stepsize.md §5)."""
    newton_atol = o.get("newton_atol", 0.0)
    try:
        newton_atol = float(newton_atol)
    except (TypeError, ValueError):
        newton_atol = math.nan
    if not (newton_atol >= 0.0 and math.isfinite(newton_atol)):
        raise ParameterError(f"newton_atol must be a non-negative number, got {o.get('newton_atol')!r}")
    max_iter = _integer("max_iter", o.get("max_iter", 25))
    if max_iter < 1:
        raise ParameterError(f"max_iter must be at least 1, got {max_iter!r}")
    min_iter = _integer("min_iter", o.get("min_iter", 1))
    if min_iter not in (0, 1):
        raise ParameterError(f"min_iter must be 0 or 1, got {min_iter!r}")
    return {"newton_test": _choice("newton_test", o.get("newton_test", "correction"), ("correction", "residual")),
            "newton_rtol": check_positive("newton_rtol", o.get("newton_rtol", 1e-10)),
            "newton_atol": newton_atol, "phi_tol": check_positive("phi_tol", o.get("phi_tol", 1e-12)),
            "max_iter": max_iter, "min_iter": min_iter,
            "newton": _choice("newton", o.get("newton", "full"), ("full", "modified"))}


def _linear(linear_solver, predictor, scaling):
    """Storage of the iteration matrix, Newton's starting guess, and the scaling of the system."""
    ls = _choice("linear_solver", linear_solver, ("auto", "band", "dense", "sparse"))
    return {"linear_solver": "dense" if ls == "dense" else "band",
            "predictor": _choice("predictor", predictor, ("zero", "previous", "extrapolate")),
            "scaling": bool(scaling)}


def _check(check_every, warn_factor, start):
    """The start and the fixed-step check (every ``check_every`` steps, warning above ``warn_factor``)."""
    check_every = _integer("check_every", check_every)
    if check_every < 0 or check_every == 1:
        raise ParameterError(f"check_every must be 0 (off) or at least 2, got {check_every}")
    return {"check_every": check_every, "warn_factor": check_positive("warn_factor", warn_factor),
            "start": _choice("start", start, ("consistent", "seed"))}


# ---- the scheme's error constants ------------------------------------------------------------
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


# ---- the number of fixed steps ----------------------------------------------------------------
def fixed_steps(h, t0, t_end):
    """The number of fixed steps from t0 to t_end and their size: never longer than h.

    When (t_end − t0)/h is an integer n (to ``STEP_COUNT_RTOL``, the round-off of the
    division), n steps of (t_end − t0)/n; otherwise n = ⌈(t_end − t0)/h⌉ equal steps of
    (t_end − t0)/n < h, so that the run ends exactly on t_end with steps no longer than asked
    (``simulate(m, 0.01, 0.007)`` takes two steps of 0.005 s).

    Raises
    ------
    ParameterError
        Before anything is allocated, when the count exceeds ``MAX_STEPS`` or h is below the
        round-off of t (t + h == t), naming h, t_end and the count.
    """
    span = t_end - t0
    if not span > 0.0:
        raise ParameterError(f"t_end must be a time after t0 = {t0}, got {t_end!r}")
    ratio = span / h
    if not math.isfinite(ratio) or ratio > MAX_STEPS or h <= 4.0 * np.finfo(float).eps * max(abs(t0), abs(t_end)):
        count = f"{ratio:.3g}" if math.isfinite(ratio) else "more than 1.8e308"
        raise ParameterError(f"h = {h:g} s over t_end − t0 = {span:g} s (t_end = {t_end:g} s) asks for {count} "
                             f"steps: at most {MAX_STEPS:.0e} are run, and h must exceed the round-off of t")
    n = round(ratio)
    if n < 1 or abs(ratio - n) > STEP_COUNT_RTOL * ratio:
        n = math.ceil(ratio)
    return int(n), span / n
