"""The engine's layout: every named field and constant that crosses between Python and compiled code.

The engine (:mod:`femb.engine`) takes a model's data as packs of arrays (:func:`femb.base.jit.pack`:
``G`` the element batches, ``C`` the model constants, ``W`` the loop's work arrays), read back
as views by the numbers below (``fview1(C, C_QFIX)``), and the solver's options and run state
as the arrays ``ip``, ``fp`` (parameters), ``si``, ``sf`` (run state) and ``stats``, read by
the indices ``IP_*``, ``FP_*``, ``SI_*``, ``SF_*``, ``NS_*``. Each of those arrays is
described by ONE tuple of field names here; the index constants are generated from it
(:func:`_number`) and Python fills the arrays by name only (:func:`named_array`).

Nothing here is compiled: the constants are read by the compiled stages as globals (compile-time
constants), and the engine's cache key hashes this file with the stages (:func:`femb.base.jit.engine`).
"""
from collections import namedtuple

from femb.base.jit import OPTIONS

#: functions called from Python: no C-callable wrapper (``cfunc``), whose argument list is
#: the flattened packs G, C and W
ENTRY = dict(OPTIONS, no_cfunc_wrapper=True)
#: functions called from compiled code only: no Python wrapper either, and no cache entry of
#: their own (their code is compiled into, and cached with, every entry point that calls them)
INNER = dict(ENTRY, no_cpython_wrapper=True)
#: the stages of a step that take the named packs (``Par``, ``StepState``, ``NewtonArrays``, ...):
#: inlined into their caller by numba (``inline="always"``), so that a pack's arrays are not
#: passed as separate machine arguments at every call (docs/engine.md, "The named packs")
STAGE = dict(INNER, inline="always")
#: the large stages that several others call (the Newton step, evaluate's kernel blocks, the LU
#: factorization and solve, the error estimate, ...): no wrappers, a cache entry of their own, and
#: called through ``femb.engine.link.call`` by symbol, so that each is optimized and compiled once
#: instead of once more in every caller (docs/engine.md, "Compile time")
SEPARATE = INNER

# ---- the model constants in the pack C (built by name in femb/solve/codegen.py, Compiled) ----------
#: (name, kind) of each array of C, in pack order; C_<NAME> is its number. Kind: f/i (float64 or
#: int64) and rank. The mass matrix (CSR: mp indptr, mi indices, mx data; tm its targets in the
#: iteration matrix), the ordering (perm, iperm), force weights (w, wext), fixed coordinates
#: (qfix), constant forces (fconst, scale0), time functions (tfkind, tfoff, tfcoef, tfv), active
#: constraints, targets (ti), the band envelope (env), rotation nodes (tn, xmap, rot, pn, d), the
#: index-2 layout (fl, pairs, teta, bw, gglw), the batch table, the Lie flag and zero multipliers
#: (lamz, nc: the μ given to velocity-constraint kernels outside Newton)
C_FIELDS = (("mp", "i1"), ("perm", "i1"), ("iperm", "i1"), ("w", "f1"), ("wext", "f1"), ("qfix", "f1"),
            ("fconst", "f1"), ("mi", "i1"), ("tfkind", "i1"), ("tfoff", "i1"), ("tfcoef", "f1"), ("mx", "f1"),
            ("tm", "i1"), ("tfv", "f2"), ("scale0", "f1"), ("active", "i1"), ("ti", "i1"), ("env", "i2"),
            ("tn", "f3"), ("xmap", "i1"), ("rot", "i2"), ("pn", "f2"), ("d", "f1"), ("fl", "i2"),
            ("pairs", "i2"), ("teta", "i1"), ("bw", "f2"), ("gglw", "f2"), ("batches", "i2"), ("lie", "i1"),
            ("lamz", "f1"))
# ---- the loop's work arrays in the pack W (built by name in femb/solve/solver.py): the accepted
# state, the constrained accelerations and jerks, the KKT factorizations, error-estimate work, ...
#: (name, length) of each work array, in pack order; W_<NAME> is its number. Lengths are the
#: model's sizes: nx, nv (= nq), nc, N (Newton unknowns), "lu"/"piv" (storage of a factorization)
W_FIELDS = (("q_s", "nx"), ("qd_s", "nv"), ("qdd_s", "nv"), ("lam_s", "nc"), ("a_s", "nv"),
            ("pqdd_s", "nv"), ("plam_s", "nc"), ("qpp", "nv"), ("qpp_new", "nv"), ("jn", "nv"),
            ("jnew", "nv"), ("KB", "lu"), ("KBacc", "lu"), ("kpiv", "piv"), ("kpivacc", "piv"),
            ("kr", "nv"), ("kx", "N"), ("gam", "nc"), ("Pt", "nc"), ("zq", "nv"), ("zl", "nc"),
            ("Bv", "nc"), ("tgt", "nc"), ("eq", "nv"), ("ev", "nv"), ("atolv", "nv"), ("wq", "nv"),
            ("du", "nv"), ("lk", "nc"))
# ---- the batch table C_BATCHES: one row per batch ------------------------------------------
#: role of the batch (ROLE_FORCE, ROLE_CONSTRAINT or ROLE_VELOCITY), its first array in G, the count
#: of arrays, 1 if its forces depend on q̇, the kernel addresses (force, constraint or velocity
#: constraint; rates)
B_ROLE, B_BASE, B_HASC, B_KERNEL, B_RATES = 0, 1, 2, 3, 4
NB = 5
ROLE_FORCE, ROLE_CONSTRAINT, ROLE_VELOCITY = 0, 1, 2
# ---- a force batch's arrays in G, from its base: (name, kind f/i and rank), packed in this
# order by femb/solve/codegen.py, and their numbers
FORCE_FIELDS = [("P", "f2"), ("dofs", "i2"), ("tfi", "i2"), ("tnn", "i3"), ("xe", "f2"), ("ve", "f2"),
                ("tf", "f3"), ("fe", "f2"), ("fq", "f3"), ("fv", "f3"), ("xdofs", "i2"), ("tblk", "i3")]
F_P, F_DOFS, F_TFI, F_TNN, F_XE, F_VE, F_TF, F_FE, F_FQ, F_FV, F_XDOFS, F_TBLK = range(12)
# ---- a constraint batch's arrays in G, from its base, and their numbers
CONSTRAINT_FIELDS = [("P", "f2"), ("dofs", "i2"), ("lamidx", "i2"), ("tfi", "i2"), ("tnn", "i3"), ("tB", "i3"),
                     ("tBt", "i3"), ("xe", "f2"), ("ve", "f2"), ("le", "f2"), ("tf", "f3"), ("Phe", "f2"),
                     ("Be", "f3"), ("He", "f3"), ("Pt", "f2"), ("gm", "f2"), ("xdofs", "i2"), ("tblk", "i3")]
(K_P, K_DOFS, K_LAMIDX, K_TFI, K_TNN, K_TB, K_TBT, K_XE, K_VE, K_LE, K_TF, K_PHE, K_BE, K_HE, K_PT, K_GM,
 K_XDOFS, K_TBLK) = range(18)
assert len(FORCE_FIELDS) == F_TBLK + 1 and len(CONSTRAINT_FIELDS) == K_TBLK + 1
# ---- a velocity-constraint (non-holonomic) batch's arrays in G: those of a constraint batch, read
# as Ψ = A v + a (K_PHE: Ψ, K_BE: A, K_HE: ∂(Aᵀμ)/∂x, K_PT: Ψ_t, K_GM: scratch; K_LAMIDX: the rows
# of μ in the engine's multiplier vector [λ; μ]), and ∂Ψ/∂x at fixed v (V_DQ)
VELOCITY_FIELDS = CONSTRAINT_FIELDS + [("Dq", "f3")]
V_DQ = len(CONSTRAINT_FIELDS)

# ---- status codes returned to Python (femb/solve/solver.py raises femb's errors) -------------
ST_CHUNK = 0          # requested number of steps done
ST_DONE = 1           # t_end reached
ST_NEED_TF = 2        # Python time functions must be evaluated at info[0]
ST_NONFINITE = -1
ST_MAXITER = -2
ST_DIVERGED_SINGULAR = -3
ST_SINGULAR = -4
ST_HMIN = -5          # adaptive: the step size fell below its floor
ST_KKT_SINGULAR = -6  # the matrix [[M, Bᵀ], [B, 0]] of the error estimate is singular
#: inside the loop only (never returned to Python): the stage went well, go on
ST_GO = 99

# ---- the named fields of the solver's parameter and state arrays ----------------------------
# Each array that crosses into compiled code is described by ONE tuple of field names below;
# the constants PREFIX_<NAME> (its index) and N<PREFIX> (its length) are generated from it
# (:func:`_number`), and Python fills the arrays by name only (:func:`named_array`), which
# refuses a missing, unknown or repeated name. Compiled code reads ``fp[FP_H]``: a constant index.
#: integer parameters ip: sizes, Newton options, the loop's mode
IP_FIELDS = ("nv", "nc", "nfix", "n", "kl", "ku",            # sizes; N Newton unknowns; band widths
             "maxit", "minit", "full", "pred",               # Newton: iterations, full/modified, predictor
             "nsteps", "stride", "store", "pytf",            # fixed steps; storage; Python time functions
             "mode", "ntest", "check", "dense", "ggl", "carry",  # adaptive; Newton test; check; layout
             "nn")                                           # velocity-constraint rows: the last nn of nc
#: float parameters fp
FP_FIELDS = ("h", "t0", "am", "af", "beta", "gamma",         # step, start, α_m, α_f, β, γ
             "rtol", "atol", "phitol", "l", "xtol",          # Newton residual test; length scale; round-off
             "scaled", "singtol", "tend", "fconst",          # scaling; pivot floor; end; constant force scale
             "ertol", "hmax", "hmin", "cq", "cv",            # error control: rtol, h bounds, error constants
             "kexp", "epus", "warn", "tolq", "newtc")        # controller exponent; per unit step; warn factor; ...
#: integer run state si (the loop's counters and flags, kept between calls)
SI_FIELDS = ("step", "hasprev", "luvalid", "stored", "rejected", "nfail", "nogrow", "lastfail",
             "havej", "proj", "rmode", "rcount", "saved", "hasprev_s", "carry", "lufresh")
#: float run state sf
SF_FIELDS = ("fref", "tftime", "t", "hnext", "hprev", "errprev", "errmax", "errmax_t", "warn_t",
             "warn_err", "eta", "rcheckh", "fref_s", "luh")
#: statistics counters
NS_FIELDS = ("steps", "eval", "fact", "solve", "roundoff", "kkt", "refine")


# ---- the solver's arrays, as named packs (numba namedtuples: one type whatever the model) ---------
#: the solver's parameters and run state: ``ip``, ``fp`` (IP_FIELDS, FP_FIELDS), ``si``, ``sf``
#: (SI_FIELDS, SF_FIELDS) and the counters ``stats`` (NS_FIELDS)
Par = namedtuple("Par", ("ip", "fp", "si", "sf", "stats"))
#: the step's state (nv or nc entries each; q has nx): q, q̇, q̈, λ, the auxiliary variable a of
#: Arnold & Brüls (2007), and q̈, λ of the step before (the predictor's extrapolation)
StepState = namedtuple("StepState", ("q", "qd", "qdd", "lam", "a", "pqdd", "plam"))
#: Newton's arrays: the iteration matrix ``AB`` (band or dense storage) and its pivots, the
#: residuals r_q (nv) and Φ (nc), the right-hand side and a_base (N), the failure report
#: ``info`` (8: t, ‖r_q‖, ‖Φ‖, iteration, largest Φ, tolerances) and the time functions' values
#: ``tfv`` (ntf, 3)
NewtonArrays = namedtuple("NewtonArrays", ("AB", "ipiv", "r", "Phi", "rhs", "x", "info", "tfv"))
#: the caller's buffers of one chunk: stored states (t, q, q̇, q̈, λ) and, per accepted step,
#: h, Newton iterations and the error estimate
Out = namedtuple("Out", ("t", "q", "qd", "qdd", "lam", "h", "it", "err"))


def _number(prefix, names):
    """``{PREFIX_NAME: index}`` for the fields ``names`` and ``{N<PREFIX>: len(names)}``."""
    out = {f"{prefix}_{n.upper()}": k for k, n in enumerate(names)}
    assert len(out) == len(names), f"repeated field name in {prefix}"
    out["N" + prefix.replace("_", "")] = len(names)
    return out


globals().update(_number("IP", IP_FIELDS))
globals().update(_number("FP", FP_FIELDS))
globals().update(_number("SI", SI_FIELDS))
globals().update(_number("SF", SF_FIELDS))
globals().update(_number("NS", NS_FIELDS))
globals().update(_number("W", [n for n, _ in W_FIELDS]))
globals().update(_number("C", [n for n, _ in C_FIELDS]))


def named_array(fields, values, dtype, what):
    """The array whose entry k is ``values[fields[k]]``: every field by name, each exactly once.

    Parameters
    ----------
    fields : tuple of str
        The field list (``IP_FIELDS``, ``FP_FIELDS``, ...).
    values : dict
        Field name → value; must name every field and nothing else.
    dtype : numpy dtype
    what : str
        The array's name, for the error message.

    Returns
    -------
    ndarray (len(fields),)
    """
    import numpy as np
    missing = [n for n in fields if n not in values]
    unknown = [n for n in values if n not in fields]
    if missing or unknown:
        raise KeyError(f"{what}: fields not set {missing}, unknown fields {unknown}")
    return np.array([values[n] for n in fields], dtype=dtype)


# ---- Newton ---------------------------------------------------------------------------------
#: the correction rule refreshes the iteration matrix when the frozen one would
#: still need more than this many corrections at the observed contraction rate
NEWTON_FROZEN_MAX = 4.0
#: exponent of the carried contraction estimate, η₀ = max(η_prev, ε)^0.8 (Hairer & Wanner, Radau5)
NEWTON_ETA_EXP = 0.8
#: the correction rule carries the factorized iteration matrix over steps (modified Newton
#: across steps, as stiff solvers do) for band systems of at least this many unknowns
#: (``ip[IP_CARRY]``, set by :func:`carry_rule`): there the tangent and its band LU cost
#: several plain evaluations and solves (a 10⁴-element spatial beam, N = 60 000: 19 ms
#: against 4 ms), while small systems keep one fresh matrix per step (and their Newton counts)
NEWTON_CARRY_MIN_N = 1000
#: a carried matrix is used while the carried contraction estimate η₀ (θ/(1 − θ) of the
#: last measured rate, :func:`newton_rate_start`) is at most this (θ ≤ 0.2)
NEWTON_CARRY_ETA = 1e-3
# ---- constrained accelerations of the error estimate --------------------------------------
#: calls of ``kkt_estimate`` (error estimate) between two checks of the one-correction solve
REFINE_CHECK = 16
#: largest share of the error estimate (in units of the tolerance) that the second correction
#: may carry for one correction to be trusted until the next check
REFINE_SHARE = 0.05
#: a check is also due when the step has grown by this factor since the last one
REFINE_HGROW = 1.25


def named_arrays(fields, values, what):
    """The arrays ``values[name]`` in the order of ``fields`` ((name, kind) pairs), each checked
    against its kind (f/i and rank); every field by name, each exactly once.

    Returns
    -------
    list of ndarray
    """
    names = [n for n, _ in fields]
    missing = [n for n in names if n not in values]
    unknown = [n for n in values if n not in names]
    if missing or unknown:
        raise KeyError(f"{what}: fields not set {missing}, unknown fields {unknown}")
    out = []
    for name, kind in fields:
        a = values[name]
        if a.ndim != int(kind[1]) or (a.dtype.kind == "f") != (kind[0] == "f"):
            raise TypeError(f"{what}: field {name} is {a.dtype} of rank {a.ndim}, expected {kind}")
        out.append(a)
    return out


def carry_rule(N, dense, correction_test, index2):
    """1 if the iteration matrix may be carried over steps (``ip[IP_CARRY]``), else 0.

    Only with the correction rule (its contraction estimates decide when a carried matrix
    is used and when it is refreshed), the index-3 step (the index-2 matrix holds B(q_n) of
    its own step) and band storage of at least ``NEWTON_CARRY_MIN_N`` unknowns.
    """
    return 1 if (correction_test and not index2 and not dense and N >= NEWTON_CARRY_MIN_N) else 0
