"""The engine: Newton iteration and time loop of the generalized-α scheme, compiled once.

This module is the whole time step in one place, and the one engine of every model:
it is compiled once per installation (femb's disk cache, :func:`femb.jit.engine`) and
serves any combination of element types. It learns a model's element types at run
time: the batch table of the model (``C_BATCHES``: role, first array in the pack ``G``,
flags and the addresses of the batch's kernels) drives :func:`evaluate`, which gathers
each batch's coordinates, calls its kernels through their addresses
(:func:`femb.jit.call_force` and its siblings; each kernel is compiled once per element
type for its role's signature, :func:`femb.kernels.compiled_kernel`) and scatters the
results into the residual and the iteration matrix. Index 3 and index 2
(``ip[IP_GGL]``), planar and Lie-group updates (rotation nodes present), dense and band
storage (``ip[IP_DENSE]``) are run-time branches.

The iteration matrix is stored and factorized as a band matrix after a
bandwidth-reducing symmetric permutation (computed once per model by
:mod:`femb.codegen`): ``AB[j, d + i − j]`` holds entry (i, j) of the permuted
matrix, ``d = kl + ku``, leaving room for the fill of partial pivoting (LAPACK's
``gbtrf`` storage, transposed); factors without row interchanges are moved into compact
storage for the solves (:func:`band_lu`); small systems are stored densely.

References
----------
M. Arnold, O. Brüls, Multibody Syst. Dyn. 18 (2007) 185–202, Algorithm 1.
C. L. Bottasso, D. Dopico, L. Trainelli, Multibody Syst. Dyn. 19 (2008) 3–20 (scaling).
E. Anderson et al., LAPACK Users' Guide, 3rd ed., SIAM 1999 (band LU with partial pivoting, ``dgbtf2``).
"""

import math

from numba import njit

from femb.jit import (OPTIONS, call_constraint, call_force, call_rates, engine, fview1, fview2, fview3, iview1,
                      iview2, iview3)
#: functions called from Python: no C-callable wrapper (``cfunc``), whose argument list is
#: the flattened packs G, C and W
ENTRY = dict(OPTIONS, no_cfunc_wrapper=True)
#: functions called from compiled code only: no Python wrapper either, and no cache entry of
#: their own (their code is compiled into, and cached with, every entry point that calls them)
INNER = dict(ENTRY, no_cpython_wrapper=True)
from femb.rotations import s2, s3, s7

# ---- the model constants in the pack C (femb/codegen.py, Compiled), by name ----------------
C_MP, C_PERM, C_IPERM, C_W, C_WEXT, C_QFIX, C_FCONST, C_MI = 0, 1, 2, 3, 4, 5, 6, 7
C_TFKIND, C_TFOFF, C_TFCOEF, C_MX, C_TM, C_TFV, C_SCALE0, C_ACTIVE, C_TI, C_ENV = 8, 9, 10, 11, 12, 13, 14, 15, 16, 17
C_TN, C_XMAP, C_ROT, C_PN, C_D, C_FL, C_PAIRS, C_TETA, C_BW, C_GGLW, C_BATCHES, C_LIE = (
    18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29)
# ---- the loop's work arrays in the pack W (femb/solver.py), by name: the accepted state, the
# constrained accelerations and jerks, the KKT factorizations, error-estimate work, ...
W_Q_S, W_QD_S, W_QDD_S, W_LAM_S, W_A_S, W_PQDD_S, W_PLAM_S, W_QPP = 0, 1, 2, 3, 4, 5, 6, 7
W_QPP_NEW, W_JN, W_JNEW, W_KB, W_KBACC, W_KPIV, W_KPIVACC, W_KR = 8, 9, 10, 11, 12, 13, 14, 15
W_KX, W_GAM, W_PT, W_ZQ, W_ZL, W_BV, W_TGT, W_EQ = 16, 17, 18, 19, 20, 21, 22, 23
W_EV, W_ATOLV, W_WQ, W_DU, W_LK = 24, 25, 26, 27, 28
# ---- the batch table C_BATCHES: one row per batch ------------------------------------------
#: role of the batch (ROLE_FORCE or ROLE_CONSTRAINT), its first array in G, the count of arrays,
#: 1 if its forces depend on q̇, the kernel addresses (force or constraint; rates)
B_ROLE, B_BASE, B_HASC, B_KERNEL, B_RATES = 0, 1, 2, 3, 4
NB = 5
ROLE_FORCE, ROLE_CONSTRAINT = 0, 1
# ---- a force batch's arrays in G, from its base: (name, kind f/i and rank), packed in this
# order by femb/codegen.py, and their numbers
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

# ---- status codes returned to Python (femb/solver.py raises femb's errors) -------------
ST_CHUNK = 0          # requested number of steps done
ST_DONE = 1           # t_end reached
ST_NEED_TF = 2        # Python time functions must be evaluated at info[0]
ST_NONFINITE = -1
ST_MAXITER = -2
ST_DIVERGED_SINGULAR = -3
ST_SINGULAR = -4
ST_HMIN = -5          # adaptive: the step size fell below its floor
ST_KKT_SINGULAR = -6  # the matrix [[M, Bᵀ], [B, 0]] of the error estimate is singular

# ---- indices of the integer parameters ip[...] ------------------------------------------
IP_NV, IP_NC, IP_NFIX, IP_N, IP_KL, IP_KU = 0, 1, 2, 3, 4, 5
IP_MAXIT, IP_MINIT, IP_FULL, IP_PRED, IP_NSTEPS, IP_STRIDE, IP_STORE, IP_PYTF = 6, 7, 8, 9, 10, 11, 12, 13
IP_MODE, IP_NTEST, IP_CHECK, IP_DENSE, IP_GGL, IP_CARRY = 14, 15, 16, 17, 18, 19
NIP = 20
# ---- indices of the float parameters fp[...] ---------------------------------------------
FP_H, FP_T0, FP_AM, FP_AF, FP_BETA, FP_GAMMA, FP_RTOL, FP_ATOL = 0, 1, 2, 3, 4, 5, 6, 7
FP_PHITOL, FP_L, FP_XTOL, FP_SCALED, FP_SINGTOL, FP_TEND, FP_FCONST = 8, 9, 10, 11, 12, 13, 14
FP_ERTOL, FP_HMAX, FP_HMIN, FP_CQ, FP_CV, FP_KEXP, FP_EPUS, FP_WARN = 15, 16, 17, 18, 19, 20, 21, 22
FP_TOLQ, FP_NEWTC = 23, 24
NFP = 25
# ---- indices of the run state si[...] (int) and sf[...] (float) ---------------------------
SI_STEP, SI_HASPREV, SI_LUVALID, SI_STORED, SI_REJECTED, SI_NFAIL, SI_NOGROW, SI_LASTFAIL = 0, 1, 2, 3, 4, 5, 6, 7
SI_HAVEJ, SI_PROJ, SI_RMODE, SI_RCOUNT, SI_SAVED, SI_HASPREV_S, SI_CARRY, SI_LUFRESH = 8, 9, 10, 11, 12, 13, 14, 15
NSI = 16
SF_FREF, SF_TFTIME, SF_T, SF_HNEXT, SF_HPREV, SF_ERRPREV, SF_ERRMAX, SF_ERRMAX_T, SF_WARN_T = 0, 1, 2, 3, 4, 5, 6, 7, 8
SF_WARN_ERR, SF_ETA, SF_RCHECKH, SF_FREF_S, SF_LUH = 9, 10, 11, 12, 13
NSF = 14
# ---- statistics counters ------------------------------------------------------------------
NS_STEPS, NS_EVAL, NS_FACT, NS_SOLVE, NS_ROUNDOFF, NS_KKT, NS_REFINE = 0, 1, 2, 3, 4, 5, 6
NNS = 7
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
#: modes of :func:`kkt_accelerations`: factorize, estimate of q, estimate of q and q̇
KKT_FACTOR, KKT_EST_Q, KKT_EST_QV = 0, 1, 2
#: calls of :func:`kkt_accelerations` (error estimate) between two checks of the one-correction solve
REFINE_CHECK = 16
#: largest share of the error estimate (in units of the tolerance) that the second correction
#: may carry for one correction to be trusted until the next check
REFINE_SHARE = 0.05
#: a check is also due when the step has grown by this factor since the last one
REFINE_HGROW = 1.25


def carry_rule(N, dense, correction_test, index2):
    """1 if the iteration matrix may be carried over steps (``ip[IP_CARRY]``), else 0.

    Only with the correction rule (its contraction estimates decide when a carried matrix
    is used and when it is refreshed), the index-3 step (the index-2 matrix holds B(q_n) of
    its own step) and band storage of at least ``NEWTON_CARRY_MIN_N`` unknowns.
    """
    return 1 if (correction_test and not index2 and not dense and N >= NEWTON_CARRY_MIN_N) else 0


@njit(**INNER)
def newton_rate_start(sf):
    """The contraction estimate η₀ carried into a step's Newton iteration; ``sf[SF_ETA]`` becomes unknown.

    Hairer & Wanner, *Solving ODEs II*, §IV.8 (Radau5): Newton's error after a
    correction Δ is about η‖Δ‖ with η = θ/(1 − θ), θ the contraction rate. A
    step starts with η₀ = max(η_prev, ε)^0.8, the previous step's η made a
    little more pessimistic for every step it is carried over (so a run of
    steps accepted after one correction ends with one that measures θ again).
    Returns −1 when there is no estimate (first step, or the previous Newton
    iteration failed); ``sf[SF_ETA]`` is −1 until :func:`newton_rate_end`
    stores the step's estimate, so a failed iteration leaves none.
    """
    eta = sf[SF_ETA]
    sf[SF_ETA] = -1.0
    if not (eta >= 0.0):
        return -1.0
    return max(eta, 2.220446049250313e-16) ** NEWTON_ETA_EXP


@njit(**INNER)
def newton_rate_end(sf, eta0, theta):
    """Store the contraction estimate for the next step: θ/(1 − θ), θ = ‖Δ₂‖/‖Δ₁‖ of this step.

    The rate of the step's first two corrections, the one that bears on a first
    correction: Newton with fresh matrices converges quadratically, and the rate
    of its last corrections would promise far too much (a pendulum at 128 times its
    default step was accepted after one correction with ‖Φ‖ = 9e-4 m). ``theta < 0``:
    no rate was measured (accepted after one correction), η₀ is carried on;
    θ ≥ 0.99 leaves no estimate.
    """
    if theta < 0.0:
        sf[SF_ETA] = eta0
    elif theta < 0.99:
        sf[SF_ETA] = theta / (1.0 - theta)
    else:
        sf[SF_ETA] = -1.0


@njit(**INNER)
def newton_first_accept(eta0, size, phi_ratio, fresh):
    """Accept the first correction Δ₁ of a step: η₀·‖Δ₁‖ ≤ 1 and η₀·‖Φ₀‖ ≤ Φ tolerance.

    ``size`` is ‖Δ₁‖ in tolerance units, ``phi_ratio`` ‖Φ‖/tolerance at the
    iterate the correction started from. Only for a correction of a freshly
    factored iteration matrix, or of one carried over from the previous steps
    (whose rate η₀ then measures), and a known carried estimate η₀
    (:func:`newton_rate_start`). The accepted iterate is not evaluated: Newton's
    residuals contract at the rate of its corrections, so η₀‖Φ₀‖ estimates Φ there
    (without that test, stress runs at large steps ended with ‖Φ‖ above tolerance).
    """
    return fresh and eta0 >= 0.0 and eta0 * size <= 1.0 and eta0 * phi_ratio <= 1.0


@engine(**ENTRY)
def band_lu(ABf, N, kl, ku, env, ipiv, rel_tol):
    """LU with partial pivoting of a band matrix in place (LAPACK ``dgbtf2`` logic, variable band).

    ``ABf`` is the flat storage of ``AB (N, 2 kl + ku + 1)``. ``env`` (3, N)
    bounds the work per column j from the matrix's structure, computed once
    per model (:mod:`femb.codegen`): rows j+1 … env[0, j] can hold nonzeros
    below the diagonal (the cumulative lowest row, so row interchanges stay
    inside it) and columns up to env[1, j] can be reached by the pivot row
    and the fill of partial pivoting. A chain with a few wide spots (a beam
    clamped to a hub) then costs the work of its local band, not of its widest
    one. Returns 0, or 1 if a pivot is zero, non-finite, or below ``rel_tol``
    times the largest pivot (singular for the purpose of the Newton iteration).

    **Compact factors.** When no row was interchanged (the usual case of an iteration
    matrix dominated by its mass and stiffness blocks), U has no fill above its ku
    superdiagonals; the factors are then moved in place into the first N (kl + ku + 1)
    entries, column j at j (kl + ku + 1) holding rows j − ku … j + kl, and ``ipiv[N]``
    (``ipiv`` has 2N entries) is set to 1 for :func:`band_solve`. The solve then reads
    two thirds of the storage and skips the kl empty rows above each column of U
    (25 → 17 ns per row at kl = ku = 11).
    """
    d = kl + ku
    AB = ABf.reshape((N, 2 * kl + ku + 1))
    compact = ipiv.shape[0] > N
    if compact:
        ipiv[N] = 0
    pmax = 0.0
    pmin = 1e308
    for j in range(N):
        low = env[0, j]
        ju = env[1, j]
        p = j
        amax = abs(AB[j, d])
        for i in range(j + 1, low + 1):
            v = abs(AB[j, d + i - j])
            if v > amax:
                amax = v
                p = i
        ipiv[j] = p
        if not (amax > 0.0) or amax > 1e300:
            return 1
        if p != j:
            compact = False
            for c in range(j, ju + 1):
                tmp = AB[c, d + j - c]
                AB[c, d + j - c] = AB[c, d + p - c]
                AB[c, d + p - c] = tmp
        piv = AB[j, d]
        if amax > pmax:
            pmax = amax
        if amax < pmin:
            pmin = amax
        inv = 1.0 / piv
        for i in range(j + 1, low + 1):
            AB[j, d + i - j] *= inv
        for c in range(j + 1, ju + 1):
            a = AB[c, d + j - c]
            if a != 0.0:
                off = d - c
                for i in range(j + 1, low + 1):
                    AB[c, off + i] -= AB[j, d + i - j] * a
    if pmin <= rel_tol * pmax:
        return 1
    if compact:
        # no interchange: rows j − ku − kl … j − ku − 1 of column j are empty; column j moves
        # to j ld2 (ld2 ≤ ldab: each destination lies before its source, so in place, in order)
        ld2 = kl + ku + 1
        ldab = 2 * kl + ku + 1
        for j in range(N):
            src = j * ldab + kl
            dst = j * ld2
            for k in range(ld2):
                ABf[dst + k] = ABf[src + k]
        ipiv[N] = 1
    return 0


@engine(**ENTRY)
def band_solve(ABf, N, kl, ku, env, ipiv, b):
    """Solve with the factors of :func:`band_lu`, in place on ``b`` (permuted order).

    Entry (i, j) of the factors is at j ld + off + i − j: ld = 2 kl + ku + 1, off = kl + ku
    (full storage), or ld = kl + ku + 1, off = ku (compact factors, ``ipiv[N]`` = 1, no
    interchanges, U within ku superdiagonals).
    """
    if ipiv.shape[0] > N and ipiv[N] == 1:
        ld = kl + ku + 1
        off = ku
        reach = ku
    else:
        ld = 2 * kl + ku + 1
        off = kl + ku
        reach = N
    for j in range(N):
        p = ipiv[j]
        if p != j:
            tmp = b[j]
            b[j] = b[p]
            b[p] = tmp
        bj = b[j]
        if bj != 0.0:
            o = j * ld + off - j
            for i in range(j + 1, env[0, j] + 1):
                b[i] -= ABf[o + i] * bj
    for j in range(N - 1, -1, -1):
        o = j * ld + off - j
        b[j] /= ABf[o + j]
        bj = b[j]
        if bj != 0.0:
            for i in range(max(env[2, j], j - reach), j):
                b[i] -= ABf[o + i] * bj


@njit(**INNER)
def dense_lu(Af, N, ipiv, rel_tol):
    """LU with partial pivoting of a dense row-major matrix in place, skipping zeros.

    The iteration matrices of mechanisms are sparse: only the nonzero entries of
    each pivot row and column enter the update, so the cost follows the fill of
    the factors rather than N³. ``ipiv`` has 3N + 2N² entries (``Compiled.piv_size``):
    the pivot rows, then the nonzero pattern of the factors (per pivot k the
    rows of L's column k and the columns of U's row k), so that
    :func:`dense_solve` visits nonzeros only (Andrews: 255 of 41² entries).
    Returns 0, or 1 when singular in the sense of :func:`band_lu`.
    """
    A = Af.reshape((N, N))
    ucnt = ipiv[N:2 * N]
    lcnt = ipiv[2 * N:3 * N]
    ucols = ipiv[3 * N:3 * N + N * N].reshape((N, N))
    lrows = ipiv[3 * N + N * N:3 * N + 2 * N * N].reshape((N, N))
    pmax = 0.0
    pmin = 1e308
    for k in range(N):
        p = k
        amax = abs(A[k, k])
        # the pivot search also collects the rows with a nonzero in column k
        nl = 0
        if A[k, k] != 0.0:
            lrows[k, 0] = k
            nl = 1
        for i in range(k + 1, N):
            v = abs(A[i, k])
            if v != 0.0:
                lrows[k, nl] = i
                nl += 1
                if v > amax:
                    amax = v
                    p = i
        ipiv[k] = p
        if not (amax > 0.0) or amax > 1e300:
            return 1
        if p != k:
            # swap the unfactored part only: the solve applies the interchanges as it goes (as LAPACK's gbtrs)
            for j in range(k, N):
                tmp = A[k, j]
                A[k, j] = A[p, j]
                A[p, j] = tmp
        if amax > pmax:
            pmax = amax
        if amax < pmin:
            pmin = amax
        # rows below the pivot with a nonzero in column k, after the interchange
        m = 0
        for c in range(nl):
            i = lrows[k, c]
            if i == p:
                continue
            lrows[k, m] = p if i == k else i
            m += 1
        lcnt[k] = m
        mu = 0
        for j in range(k + 1, N):
            if A[k, j] != 0.0:
                ucols[k, mu] = j
                mu += 1
        ucnt[k] = mu
        inv = 1.0 / A[k, k]
        for c in range(m):
            i = lrows[k, c]
            l = A[i, k] * inv
            A[i, k] = l
            for cc in range(mu):
                j = ucols[k, cc]
                A[i, j] -= l * A[k, j]
    if pmin <= rel_tol * pmax:
        return 1
    return 0


@njit(**INNER)
def dense_solve(Af, N, ipiv, b):
    """Solve with the factors of :func:`dense_lu`, in place on ``b`` (permuted order), nonzeros only."""
    A = Af.reshape((N, N))
    ucnt = ipiv[N:2 * N]
    lcnt = ipiv[2 * N:3 * N]
    ucols = ipiv[3 * N:3 * N + N * N].reshape((N, N))
    lrows = ipiv[3 * N + N * N:3 * N + 2 * N * N].reshape((N, N))
    for k in range(N):
        p = ipiv[k]
        if p != k:
            tmp = b[k]
            b[k] = b[p]
            b[p] = tmp
        bk = b[k]
        if bk != 0.0:
            for c in range(lcnt[k]):
                i = lrows[k, c]
                b[i] -= A[i, k] * bk
    for k in range(N - 1, -1, -1):
        s = b[k]
        for c in range(ucnt[k]):
            j = ucols[k, c]
            s -= A[k, j] * b[j]
        b[k] = s / A[k, k]


@engine(**ENTRY)
def dense_lu_solve(Af, N, ipiv, rel_tol, b):
    """:func:`dense_lu` then, if regular, :func:`dense_solve` on ``b``; returns the LU's status (for tests)."""
    st = dense_lu(Af, N, ipiv, rel_tol)
    if st == 0:
        dense_solve(Af, N, ipiv, b)
    return st


@njit(**INNER)
def factor(Af, ip, env, ipiv, rel_tol):
    """Factorize the iteration matrix in its storage (dense or band, fixed per model)."""
    if ip[IP_DENSE] != 0:
        return dense_lu(Af, ip[IP_N], ipiv, rel_tol)
    return band_lu(Af, ip[IP_N], ip[IP_KL], ip[IP_KU], env, ipiv, rel_tol)


@njit(**INNER)
def solve(Af, ip, env, ipiv, b):
    """Solve with the factors of :func:`factor`, in place on ``b`` (permuted order)."""
    if ip[IP_DENSE] != 0:
        dense_solve(Af, ip[IP_N], ipiv, b)
    else:
        band_solve(Af, ip[IP_N], ip[IP_KL], ip[IP_KU], env, ipiv, b)


@engine(**ENTRY)
def eval_time_functions(t, kind, off, coef, tfv):
    """Values (f, f', f'') of the compiled time functions at t into ``tfv (ntf, 3)``."""
    for k in range(kind.shape[0]):
        c0 = off[k]
        c1 = off[k + 1]
        if kind[k] == 1:          # polynomial Σ c_i t^i (Horner)
            f = 0.0
            df = 0.0
            ddf = 0.0
            for i in range(c1 - 1, c0 - 1, -1):
                ddf = ddf * t + 2.0 * df
                df = df * t + f
                f = f * t + coef[i]
            tfv[k, 0] = f
            tfv[k, 1] = df
            tfv[k, 2] = ddf
        elif kind[k] == 2:        # harmonic o + A sin(w t + ph): (A, w, ph, o)
            A = coef[c0]
            w = coef[c0 + 1]
            arg = w * t + coef[c0 + 2]
            s = math.sin(arg)
            tfv[k, 0] = coef[c0 + 3] + A * s
            tfv[k, 1] = A * w * math.cos(arg)
            tfv[k, 2] = -A * w * w * s


@njit(**INNER)
def newton_step(G, C, ip, fp, si, sf, stats, q, qd, qdd, lam, a, pqdd, plam, t1, h, h_prev,
                AB, ipiv, r, Phi, rhs, x, info, wq):
    """One step t1 − h → t1 of the generalized-α scheme, in place: index 3 or stabilized index 2.

    **Index 3** (``ip[IP_GGL] == 0``): Algorithm 1 of Arnold & Brüls (2007), Newton on
    (Δq, Δλ) for r_q(q, q̇, q̈, λ) = 0 and Φ(q, t) = 0 at t_{n+1}, with the scaled iteration
    matrix [[c(Mβ' + C_tγ' + K_t), Bᵀ], [B, 0]] (c = βh², β' = (1 − α_m)/(h²β(1 − α_f)),
    γ' = γ/(hβ); Bottasso, Dopico & Trainelli 2008).

    **Stabilized index 2** (``ip[IP_GGL] != 0``): Gear, Gupta & Leimkuhler (1985) with the
    generalized-α discretization of Arnold & Brüls (2007, §5): with the Newmark increment
    Δ = h q̇_n + h²(½ − β) a_n + h²β a_{n+1} and nc more unknowns η,

        q_{n+1} = q_n + Δ + B(q_n)ᵀ η,   q̇_{n+1}, q̈_{n+1} from Δ as in Algorithm 1,
        r_q(q_{n+1}, q̇_{n+1}, q̈_{n+1}, λ) = 0,  Φ(q_{n+1}, t) = 0,  B(q_{n+1}) q̇_{n+1} + Φ_t = 0.

    Newton on (δΔ, δλ, δη) with the scaled matrix

        [ c(Mβ' + C_tγ' + K_t)   Bᵀ   0      ]   [δΔ     ]     [ c r_q    ]
        [ B                      0    B B_nᵀ ] · [δλ / c ] = − [ Φ        ]
        [ B                      0    0      ]   [δη     ]     [ g / γ'   ]

    (g = B q̇ + Φ_t; unscaled runs: c = 1 and the velocity rows γ'B, g). It drops
    c K_t B_nᵀ (O(h²)) and ∂(B q̇)/∂q (O(h) after the row scaling): Newton converges
    linearly at a rate O(h), to the solution of the exact equations. The constraint test
    holds for Φ and for g/γ' (a position-sized velocity residual).

    **Rotation nodes** (Lie group, docs/spatial.md §2; Brüls & Cardona 2010): q = q_n ∘ exp(D)
    with D = Δ (+ B_nᵀη), additive entries updated in place, rotations rebuilt from q_n and D
    (:func:`lie_update`); B T(D) in the Φ rows.

    Stopping rules (``ip[IP_NTEST]``), :func:`correction_test`: 0 the residual rule of the seed
    reproduction, 1 the correction rule (default, stepsize.md §5).

    Returns
    -------
    int
        Newton iterations (≥ 0) on success, then q, qd, qdd, lam, a hold the new step; a
        negative status code otherwise, with ``info`` = (t1, ‖r_q‖, ‖Φ‖, iteration, index of
        the largest |Φ_i|, tolerance of r_q, tolerance of Φ).
    """
    ggl = ip[IP_GGL] != 0
    lie = iview1(C, C_LIE)[0] != 0
    nv = ip[IP_NV]
    nc = ip[IP_NC]
    beta = fp[FP_BETA]
    gamma = fp[FP_GAMMA]
    bp = (1.0 - fp[FP_AM]) / (h * h * beta * (1.0 - fp[FP_AF]))
    gp = gamma / (h * beta)
    scaled = fp[FP_SCALED] != 0.0
    c = beta * h * h if scaled else 1.0
    sg = 1.0 if scaled else gp          # index 2: the velocity rows' factor in the matrix
    sr = 1.0 / gp if scaled else 1.0    # and in the right-hand side
    ka = (1.0 - fp[FP_AF]) / (1.0 - fp[FP_AM])
    iperm = iview1(C, C_IPERM)
    env = iview2(C, C_ENV)
    full = ip[IP_FULL] != 0
    tol_phi = fp[FP_PHITOL] * fp[FP_L]
    rtol = fp[FP_RTOL]
    atol = fp[FP_ATOL]
    ntest = ip[IP_NTEST]
    E = fview2(C, C_GGLW)            # index 2: η, g, Φ_t, γ
    Bn = fview2(C, C_BW)[0]          # index 2: B(q_n), flat element blocks
    if ggl:
        # B(q_n) for the step (time functions at t_{n+1}: they are evaluated before the step)
        constraint_B(G, C, t1, q, qd, Bn)
    predict(C, ip, fp, si, q, qd, qdd, lam, a, pqdd, plam, x, h, h_prev, lie)
    if ggl:
        zero1(E[0])
    F_ref = sf[SF_FREF]
    # correction rule, index 3: the contraction estimate carried over from the previous step
    eta0 = newton_rate_start(sf) if (ntest != 0 and not ggl) else -1.0
    # large band systems: the factorized matrix of an earlier step is used again while it was
    # built for this h (the same β', γ', c) and the carried estimate promises fast contraction;
    # the correction rule refreshes it when the contraction turns out poor (NT_REFRESH)
    carry = ip[IP_CARRY] != 0 and ntest != 0 and not ggl
    carried = (carry and si[SI_CARRY] != 0 and si[SI_LUVALID] != 0 and sf[SF_LUH] == h
               and 0.0 <= eta0 <= NEWTON_CARRY_ETA)
    si[SI_CARRY] = 0
    si[SI_LUFRESH] = 0
    theta_first = -1.0
    prev_norm = -1.0
    theta_prev_bad = 0
    k = 0
    maxit = ip[IP_MAXIT]
    F = F_ref
    have_lu = carried
    err_f = 0.0
    err_phi = 0.0
    redo = False
    while True:
        if redo:
            jac = True
        elif ntest == 0:
            jac = (full and k == 0) or si[SI_LUVALID] == 0
        else:
            jac = not have_lu
        scale = evaluate(G, C, t1, q, qd, qdd, lam, jac, c * bp, c * gp, c, AB, r, Phi)
        stats[NS_EVAL] += 1
        if ggl:
            velocity_residual(G, C, t1, q, qd, jac, lie, E[1])
        if not redo:
            F = scale if scale > F_ref else F_ref
            err_f = residual_norm(r, fview1(C, C_W))
            err_phi, iphi = constraint_norm(Phi, E[1], gp, ggl)
            info[0] = t1
            info[1] = err_f
            info[2] = err_phi
            info[3] = k
            info[4] = iphi
            info[5] = rtol * F + atol
            info[6] = tol_phi
            if not (math.isfinite(err_f) and math.isfinite(err_phi)):
                return ST_NONFINITE
            if ntest == 0 and k >= ip[IP_MINIT] and err_f <= rtol * F + atol and err_phi <= tol_phi:
                break
            if k == maxit:
                return ST_MAXITER
            if ntest == 0 and not jac:
                # the residual rule needs the iteration matrix at this iterate: full Newton always,
                # modified Newton when the contraction was poor
                if full:
                    redo = True
                    continue
                if prev_norm >= 0.0 and si[SI_LUVALID] != 0:
                    cur = max(err_f / max(F, 1e-300), err_phi / max(tol_phi, 1e-300))
                    if cur > 0.25 * prev_norm:
                        redo = True
                        continue
        redo = False
        if jac:
            if ggl:
                ggl_matrix(C, AB, sg)
            if factor(AB, ip, env, ipiv, fp[FP_SINGTOL]) != 0:
                si[SI_LUVALID] = 0
                return ST_DIVERGED_SINGULAR if k > 0 else ST_SINGULAR
            si[SI_LUVALID] = 1
            si[SI_LUFRESH] = 1
            sf[SF_LUH] = h
            have_lu = True
            carried = False
            stats[NS_FACT] += 1
        if ntest == 0 and not full:
            prev_norm = max(err_f / max(F, 1e-300), err_phi / max(tol_phi, 1e-300))
        for i in range(nv):
            rhs[iperm[i]] = -c * r[i]
        for j in range(nc):
            rhs[iperm[nv + j]] = -Phi[j]
        if ggl:
            for j in range(nc):
                rhs[iperm[nv + nc + j]] = -sr * E[1][j]
        solve(AB, ip, env, ipiv, rhs)
        stats[NS_SOLVE] += 1
        dqmax, qmax, dqw, qddmax = apply_correction(C, ip, q, qd, qdd, lam, rhs, wq, bp, gp, c, lie, ggl)
        k += 1
        if ntest == 0:
            # round-off floor: a correction at the level of the coordinates' own round-off
            # cannot improve the iterate (stiff elements nearly at rest)
            if (err_phi <= tol_phi and err_f <= 1e4 * (rtol * F + atol)
                    and dqmax <= fp[FP_XTOL] * (qmax + fp[FP_L])):
                stats[NS_ROUNDOFF] += 1
                break
        else:
            # a carried matrix accepts its first correction by the η₀ test only without
            # constraints: its constraint rows belong to an earlier configuration, so η₀‖Φ₀‖
            # does not bound Φ after the correction (a chain of 400 bricks ended its runs with
            # ‖Φ‖ up to half the tolerance, 2e-4 of it with fresh matrices)
            action, size, theta = correction_test(ip, fp, k, jac, carried and nc == 0, dqmax, qmax, dqw, qddmax,
                                                  bp, eta0, prev_norm, err_phi / tol_phi, theta_prev_bad)
            if theta_first < 0.0 and theta >= 0.0:
                theta_first = theta
            if action == NT_ROUNDOFF:
                stats[NS_ROUNDOFF] += 1
                break
            if action == NT_ACCEPT:
                break
            if action == NT_FAIL:
                info[3] = k
                return ST_MAXITER
            if theta >= 1.0 and jac:
                theta_prev_bad += 1
            if action == NT_REFRESH:
                have_lu = False          # slow or no contraction: refresh the iteration matrix
            prev_norm = size
    for i in range(nv):
        a[i] = x[i] + ka * qdd[i]
    if F > F_ref:
        sf[SF_FREF] = F
    if ntest != 0 and not ggl:
        newton_rate_end(sf, eta0, theta_first)
    if carry:
        si[SI_CARRY] = 1
    si[SI_HASPREV] = 1
    return k


# ---- the parts of a Newton step ---------------------------------------------------------------
#: actions of the correction rule (:func:`correction_test`)
NT_CONTINUE, NT_ACCEPT, NT_ROUNDOFF, NT_REFRESH, NT_FAIL = 0, 1, 2, 3, 4


@njit(**INNER)
def predict(C, ip, fp, si, q, qd, qdd, lam, a, pqdd, plam, x, h, h_prev, lie):
    """The predictor and (3)–(5) of Algorithm 1 (Arnold & Brüls 2007) for it, in place.

    q̈ and λ are guessed (``ip[IP_PRED]``: 0 zero, 1 previous, 2 extrapolated from the last
    two steps, scaled to the step ratio); a, q̇ and q follow from the Newmark formulas
    (rotations: q_n ∘ exp(D), the quaternions p_n saved in C's ``C_PN``). ``x[:nv]`` keeps
    a_base = (α_f q̈_n − α_m a_n)/(1 − α_m) until the step is accepted (eq. (3) needs it).
    """
    nv = ip[IP_NV]
    nc = ip[IP_NC]
    am = fp[FP_AM]
    af = fp[FP_AF]
    beta = fp[FP_BETA]
    gamma = fp[FP_GAMMA]
    ka = (1.0 - af) / (1.0 - am)
    pred = ip[IP_PRED]
    rho = h / h_prev if h_prev > 0.0 else 1.0
    xm = iview1(C, C_XMAP)
    rot = iview2(C, C_ROT)
    pn = fview2(C, C_PN)
    D = fview1(C, C_D)
    for b in range(rot.shape[0]):
        for m in range(4):
            pn[b, m] = q[rot[b, 0] + m]
    for i in range(nv):
        a_base = (af * qdd[i] - am * a[i]) / (1.0 - am)
        if pred == 0:
            g = 0.0
            a_pred = a_base
        else:
            if pred == 2 and si[SI_HASPREV] != 0:
                g = (1.0 + rho) * qdd[i] - rho * pqdd[i]
            else:
                g = qdd[i]
            a_pred = a_base + ka * g
        pqdd[i] = qdd[i]
        x[i] = a_base
        qd_new = qd[i] + (h * (1.0 - gamma)) * a[i] + (h * gamma) * a_pred
        j = xm[i]
        if j >= 0:
            q[j] = q[j] + h * qd[i] + (h * h * (0.5 - beta)) * a[i] + (h * h * beta) * a_pred
        else:
            D[i] = h * qd[i] + (h * h * (0.5 - beta)) * a[i] + (h * h * beta) * a_pred
        qd[i] = qd_new
        qdd[i] = g
    if lie:
        lie_update(q, C)
    for j in range(nc):
        if pred == 0:
            g = 0.0
        elif pred == 2 and si[SI_HASPREV] != 0:
            g = (1.0 + rho) * lam[j] - rho * plam[j]
        else:
            g = lam[j]
        plam[j] = lam[j]
        lam[j] = g


@njit(**INNER)
def velocity_residual(G, C, t1, q, qd, jac, lie, g):
    """Index 2: g = B(q) q̇ + Φ_t, from the blocks the last ``evaluate`` left (rotation nodes:
    ``evaluate`` left B T(D) when it built the matrix, kept for :func:`ggl_matrix`, and B itself
    comes from the kernels)."""
    fl = iview2(C, C_FL)
    Bw = fview2(C, C_BW)
    Bq = Bw[1]
    E = fview2(C, C_GGLW)
    if lie:
        if jac:
            copy_B(G, C, Bw[2])
        constraint_B(G, C, t1, q, qd, Bq)
    else:
        copy_B(G, C, Bq)
    rates(G, C, t1, q, qd, E[2], E[3])
    for j in range(g.shape[0]):
        g[j] = E[2][j]
    for kk in range(fl.shape[0]):
        cj = fl[kk, 0]
        if cj >= 0:
            g[cj] += Bq[kk] * qd[fl[kk, 1]]


@njit(**INNER)
def residual_norm(r, w):
    """‖W r_q‖∞ (moments divided by the length scale); inf if not finite."""
    err = 0.0
    for i in range(r.shape[0]):
        v = abs(r[i] * w[i])
        if not (v <= err):
            err = v if v == v else math.inf
    return err


@njit(**INNER)
def constraint_norm(Phi, g, gp, ggl):
    """(‖Φ‖∞, index of the largest |Φ_j|); index 2: each row's larger of |Φ_j| and |g_j|/γ'."""
    err = 0.0
    iphi = -1
    for j in range(Phi.shape[0]):
        v = abs(Phi[j])
        if ggl:
            vg = abs(g[j]) / gp
            if vg > v or not (vg == vg):
                v = vg
        if not (v <= err):
            err = v if v == v else math.inf
            iphi = j
    return err, iphi


@njit(**INNER)
def apply_correction(C, ip, q, qd, qdd, lam, rhs, wq, bp, gp, c, lie, ggl):
    """The solved Newton correction ``rhs`` into the iterate, in place.

    Index 3: q ∘ exp(Δq), q̇ += γ'Δq, q̈ += β'Δq, λ += Δλ/c. Index 2 (``ggl``): q̇ and q̈ from
    δΔ, η += δη, and q ∘ exp(δΔ + B_nᵀδη).

    Returns (max |Δ_i| of the q̇/q̈ increment, max |q_i| of additive entries, max |δq_i|/wq_i,
    max |q̈_i|).
    """
    nv = ip[IP_NV]
    nc = ip[IP_NC]
    iperm = iview1(C, C_IPERM)
    inv_c = 1.0 / c
    for j in range(nc):
        lam[j] += rhs[iperm[nv + j]] * inv_c
    dqmax = 0.0
    qddmax = 0.0
    for i in range(nv):
        dD = rhs[iperm[i]]
        qd[i] += gp * dD
        qdd[i] += bp * dD
        if abs(dD) > dqmax:
            dqmax = abs(dD)
        if abs(qdd[i]) > qddmax:
            qddmax = abs(qdd[i])
    if ggl:
        fl = iview2(C, C_FL)
        Bn = fview2(C, C_BW)[0]
        eta = fview2(C, C_GGLW)[0]
        for j in range(nc):
            eta[j] += rhs[iperm[nv + nc + j]]
        # δq = δΔ + B_nᵀ δη, accumulated in rhs's Δ entries (their values were used above)
        for kk in range(fl.shape[0]):
            cj = fl[kk, 0]
            if cj >= 0:
                rhs[iperm[fl[kk, 1]]] += Bn[kk] * rhs[iperm[nv + nc + cj]]
    # q ∘ exp(δq): additive entries in place, rotations from q_n and the accumulated D
    xm = iview1(C, C_XMAP)
    D = fview1(C, C_D)
    qmax = 0.0
    dqw = 0.0
    for i in range(nv):
        dq = rhs[iperm[i]]
        j = xm[i]
        if j >= 0:
            q[j] += dq
            if abs(q[j]) > qmax:
                qmax = abs(q[j])
        else:
            D[i] += dq
        v = abs(dq) / wq[i]
        if v > dqw:
            dqw = v
    if lie:
        lie_update(q, C)
    return dqmax, qmax, dqw, qddmax


@njit(**INNER)
def correction_test(ip, fp, k, jac, carried, dqmax, qmax, dqw, qddmax, bp, eta0, prev_norm, phi_ratio,
                    theta_prev_bad):
    """The correction rule (stepsize.md §5) after correction k: what Newton does next.

    The correction is measured in q units (max_i |Δq_i|/wq_i) and in acceleration units
    (‖β'Δq‖∞ against 1e-8(1 + ‖q̈‖∞) + c ε (1 + ‖q‖∞) β'); ``size`` is the larger. An
    iterate is accepted once the size is ≤ 1, or early once θ/(1 − θ)·size passes (θ the
    contraction rate), or at the first correction when η₀·size ≤ 1 with the rate η₀
    carried from the previous steps (:func:`newton_first_accept`, Hairer & Wanner's Radau5
    test; ``jac``: the matrix was factorized at this step's first iterate, ``carried``: it
    was carried over from earlier steps and may accept too, see :func:`newton_step`); always
    with the constraints within tolerance
    (``phi_ratio`` ≤ 1). A growing correction of a carried matrix only refreshes it. The matrix is
    refreshed when the corrections contract slowly (θ > 0.5), grow (θ ≥ 1; Newton gives up
    when corrections of fresh matrices grow twice), or when the frozen iteration would still
    need more than ``NEWTON_FROZEN_MAX`` corrections at the observed rate
    (n = log((1 − θ)/size)/log θ, Hairer & Wanner, *Solving ODEs II*, §IV.8).

    Returns
    -------
    (action, size, theta)
        ``NT_ACCEPT``, ``NT_ROUNDOFF`` (accepted: the corrections stopped contracting within
        a factor 1e3 of the tolerance, round-off of the linear solve), ``NT_FAIL``,
        ``NT_REFRESH`` (go on with a fresh matrix) or ``NT_CONTINUE``; the size of the
        correction; θ (−1 at the first correction).
    """
    nv = ip[IP_NV]
    minit = ip[IP_MINIT]
    eps = 2.220446049250313e-16
    acc_tol = 1e-8 * (1.0 + qddmax) + fp[FP_NEWTC] * eps * (1.0 + qmax) * bp * math.sqrt(max(1.0, nv / 100.0))
    size = max(dqw, bp * dqmax / acc_tol)
    if k == 1 and k >= minit and newton_first_accept(eta0, size, phi_ratio, jac or carried):
        return NT_ACCEPT, size, -1.0
    theta = -1.0
    action = NT_CONTINUE
    if prev_norm > 0.0:
        theta = size / prev_norm
        if theta > 0.5 and size <= 1e3 and phi_ratio <= 1.0 and k >= minit:
            return NT_ROUNDOFF, size, theta
        if theta >= 1.0:
            if theta_prev_bad + (1 if jac else 0) >= 2:
                return NT_FAIL, size, theta
            action = NT_REFRESH
        elif theta > 0.5:
            action = NT_REFRESH
        elif theta > 0.0 and size > 1.0:
            # iterations the frozen matrix still needs at this rate (θ^n·size/(1−θ) ≤ 1);
            # a fresh matrix converges quadratically in two or three
            n_pred = math.log((1.0 - theta) / size) / math.log(theta)
            if n_pred > NEWTON_FROZEN_MAX or k + n_pred > ip[IP_MAXIT]:
                action = NT_REFRESH
        if theta < 1.0 and theta / (1.0 - theta) * size <= 1.0 and phi_ratio <= 1.0 and k >= minit:
            return NT_ACCEPT, size, theta
    if size <= 1.0 and phi_ratio <= 1.0 and k >= max(minit, 1):
        return NT_ACCEPT, size, theta
    return action, size, theta


@njit(**INNER)
def copy_blocks(Be, out, o):
    """out[o:] = Be (nel, nc_e, nd) in row-major order; returns the next offset."""
    for e in range(Be.shape[0]):
        for j in range(Be.shape[1]):
            for i in range(Be.shape[2]):
                out[o] = Be[e, j, i]
                o += 1
    return o


@engine(**ENTRY)
def ggl_matrix(C, ABf, sg):
    """The rows and columns of the index-2 layout that ``evaluate`` leaves out, into ABf.

    With B = B(q) (rows 1 of array 26 of C) and B_n = B(q_n) (row 0), flat per element
    block: sg·B in the velocity rows (q̇ columns), B B_nᵀ in the Φ rows (η
    columns), and a zero η diagonal for active constraints (``evaluate`` puts 1
    there for the constrained-acceleration solves). Kinds with rotation nodes use
    B T(D) (row 2, the blocks ``evaluate`` scattered) in the Φ rows.
    """
    fl = iview2(C, C_FL)
    pairs = iview2(C, C_PAIRS)
    tEta = iview1(C, C_TETA)
    Bw = fview2(C, C_BW)
    Bn = Bw[0]
    Bq = Bw[1]
    # rotation kinds: ∂Φ(q_n ∘ exp(Δ + B_nᵀη))/∂η = B(q) T(D) B_nᵀ, with B T in row 2 of C's array 26
    BT = Bw[2] if iview1(C, C_LIE)[0] != 0 else Bw[1]
    for c in range(tEta.shape[0]):
        if tEta[c] >= 0:
            ABf[tEta[c]] = 0.0
    for k in range(fl.shape[0]):
        if fl[k, 0] >= 0:
            ABf[fl[k, 2]] += sg * Bq[k]
    for p in range(pairs.shape[0]):
        ABf[pairs[p, 2]] += BT[pairs[p, 0]] * Bn[pairs[p, 1]]


@engine(**ENTRY)
def kkt_accelerations(G, C, ip, fp, si, sf, stats, t, q, qd, qdd, lam, h, hbar, AB, ipiv, Phi, W, KB, kpiv, out,
                      mode):
    """Constrained accelerations q̈ᵖᵖ of [[M, Bᵀ], [B, 0]] [q̈; λ] = [f; −γ] at (t, q, q̇) into ``out``.

    ``mode`` 0 (``KKT_FACTOR``): factorize the KKT matrix into ``KB``/``kpiv`` (left there for
    velocity projections at this configuration) and solve. Returns 0, or 1 if
    the matrix is singular.

    ``mode`` 1 and 2 (``KKT_EST_Q``, ``KKT_EST_QV``): for the error estimate of a
    step just taken (of q; of q and q̇). With the index-3 step, one correction with the Newton
    matrix of the step (``AB``/``ipiv``) replaces the factorization. That matrix,
    S = [[κM + c γ' C_t + c K_t, Bᵀ], [B, 0]] (κ = c β', see ``newton_step``),
    differs from the KKT matrix [[κM, Bᵀ], [B, 0]] by terms of order h (damping)
    and h² (stiffness), so the correction, started from the step's own (q̈, λ),

        S [z; μ] = −[M q̈ − f + Bᵀλ; (B q̈ + γ)/κ],   q̈ += κ z,   λ += μ,

    contracts the error by ρ(S⁻¹E), E = S − KKT (iterative refinement with the
    factors Newton has just computed). It is trusted while a second correction
    changes the error estimate by at most ``REFINE_SHARE`` of the tolerance,
    checked every ``REFINE_CHECK`` calls and whenever h has grown by
    ``REFINE_HGROW`` since the last check; where that fails (stiff elements at
    large steps) the KKT matrix is factorized, as in mode 0, until the next check.
    """
    # work arrays: views into the pack W (femb/solver.py, W_FIELDS)
    kr = fview1(W, W_KR)
    kx = fview1(W, W_KX)
    gam = fview1(W, W_GAM)
    Pt = fview1(W, W_PT)
    zq = fview1(W, W_ZQ)
    zl = fview1(W, W_ZL)
    Bu = fview1(W, W_BV)
    eq = fview1(W, W_EQ)
    ev = fview1(W, W_EV)
    atolv = fview1(W, W_ATOLV)
    du = fview1(W, W_DU)
    lk = fview1(W, W_LK)
    nv = ip[IP_NV]
    nc = ip[IP_NC]
    iperm = iview1(C, C_IPERM)
    if mode != KKT_FACTOR and ip[IP_GGL] == 0 and si[SI_LUVALID] != 0:
        due = si[SI_RCOUNT] <= 0 or h > REFINE_HGROW * sf[SF_RCHECKH]
        if not due:
            si[SI_RCOUNT] -= 1
        if due or si[SI_RMODE] == 0:
            copy_into(out, qdd)
            copy_into(lk, lam)
            rates(G, C, t, q, qd, Pt, gam)
            if fp[FP_SCALED] != 0.0:
                kappa = (1.0 - fp[FP_AM]) / (1.0 - fp[FP_AF])
            else:
                kappa = (1.0 - fp[FP_AM]) / (h * h * fp[FP_BETA] * (1.0 - fp[FP_AF]))
            active = iview1(C, C_ACTIVE)
            ncorr = 2 if due else 1
            for it in range(ncorr):
                evaluate(G, C, t, q, qd, out, lk, nv < 0, 0.0, 0.0, 0.0, AB, kr, Phi)
                jacobian_times(G, C, t, q, out, Bu)
                for i in range(nv):
                    kx[iperm[i]] = -kr[i]
                for j in range(nc):
                    kx[iperm[nv + j]] = -(Bu[j] + gam[j]) / kappa if active[j] != 0 else 0.0
                solve(AB, ip, iview2(C, C_ENV), ipiv, kx)
                for i in range(nv):
                    d = kappa * kx[iperm[i]]
                    du[i] = d
                    out[i] += d
                for j in range(nc):
                    lk[j] += kx[iperm[nv + j]]
            stats[NS_REFINE] += ncorr
            if not due:
                return 0
            # the second correction's share of the error estimate (stepsize.md §3 with Δq̈ᵖᵖ = du)
            Cq = fp[FP_CQ]
            Cv = fp[FP_CV]
            for i in range(nv):
                eq[i] = Cq * h * h * du[i]
                ev[i] = Cv * h * h * du[i] / hbar
            share = error_norm(ip, fp, iview1(C, C_XMAP), q, q, qd, qd, eq, ev, atolv, mode == KKT_EST_QV)
            if mode == KKT_EST_QV and fp[FP_EPUS] != 0.0:
                share /= h
            si[SI_RCOUNT] = REFINE_CHECK
            sf[SF_RCHECKH] = h
            if share <= REFINE_SHARE:
                si[SI_RMODE] = 0
                return 0
            si[SI_RMODE] = 1
    evaluate(G, C, t, q, qd, zq, zl, nv >= 0, 1.0, 0.0, 0.0, KB, kr, Phi)
    if factor(KB, ip, iview2(C, C_ENV), kpiv, 1e-13) != 0:
        return 1
    rates(G, C, t, q, qd, Pt, gam)
    for i in range(nv):
        kx[iperm[i]] = -kr[i]                 # r = −f with q̈ = λ = 0
    for j in range(nc):
        kx[iperm[nv + j]] = -gam[j]
    solve(KB, ip, iview2(C, C_ENV), kpiv, kx)
    for i in range(nv):
        out[i] = kx[iperm[i]]
    stats[NS_KKT] += 1
    return 0


@engine(**ENTRY)
def project_normal_velocity(G, C, ip, t, q, qd, target, KB, kpiv, kx, Bv):
    """q̇ ← q̇ + δ with B δ = target − B q̇ and δ M-orthogonal to the constraint manifold.

    Solves [[M, Bᵀ], [B, 0]] [δ; μ] = [0; target − B q̇] with the factorization of
    :func:`kkt_accelerations` at this configuration.
    """
    nv = ip[IP_NV]
    nc = ip[IP_NC]
    iperm = iview1(C, C_IPERM)
    active = iview1(C, C_ACTIVE)
    jacobian_times(G, C, t, q, qd, Bv)
    for i in range(nv):
        kx[iperm[i]] = 0.0
    for j in range(nc):
        kx[iperm[nv + j]] = target[j] - Bv[j] if active[j] != 0 else 0.0
    solve(KB, ip, iview2(C, C_ENV), kpiv, kx)
    for i in range(nv):
        qd[i] += kx[iperm[i]]


@njit(**INNER)
def error_norm(ip, fp, xm, q0, q1, qd0, qd1, eq, ev, atolv, use_v):
    """RMS of the local error estimate over q (and q̇) weighted by atol + rtol·max(|x_n|, |x_{n+1}|)."""
    nv = ip[IP_NV]
    rtol = fp[FP_ERTOL]
    s = 0.0
    for i in range(nv):
        j = xm[i]
        # rotation entries (j < 0) are judged by atol alone (radians)
        wi = atolv[i] + (rtol * max(abs(q0[j]), abs(q1[j])) if j >= 0 else 0.0)
        s += (eq[i] / wi) ** 2
    n = nv
    if use_v:
        for i in range(nv):
            wi = atolv[i] + rtol * max(abs(qd0[i]), abs(qd1[i]))
            s += (ev[i] / wi) ** 2
        n += nv
    return math.sqrt(s / n)


@engine(**ENTRY)
def run(G, C, ip, fp, si, sf, stats, q, qd, qdd, lam, a, pqdd, plam, tfv, AB, ipiv, r, Phi, rhs, x, info,
        W, n_chunk, out_t, out_q, out_qd, out_qdd, out_lam, out_h, out_it, out_err):
    """Advance up to ``n_chunk`` accepted steps: the one time loop, fixed or adaptive.

    Fixed steps (``ip[IP_MODE] == 0``): t_{n} = t0 + n h; every ``IP_CHECK`` steps
    the local error estimate is computed over one step and its largest value
    kept (for the warning about steps far too large).

    Adaptive steps (``ip[IP_MODE] == 1``, stepsize.md §§2–4): local error from
    the constrained accelerations q̈ᵖᵖ of consecutive steps, e_q = C_q h² Δq̈ᵖᵖ,
    e_v = C_v h³ Δj / h̄; PI controller (Gustafsson 1994) with exponent k,
    rejected steps and Newton failures retried from the accepted state; at
    every step change a and the normal velocity are re-synchronised
    (a* = a + Δ (h − h_prev) j, B q̇* = h² C_q B j + (B q̇)_exact).

    Every state written into ``out_*`` is an accepted step (with stride);
    ``out_h``, ``out_it``, ``out_err`` record every accepted step. Returns a
    status code (ST_*); ``si[SI_STORED]`` counts the states written.
    """
    nv = ip[IP_NV]
    nc = ip[IP_NC]
    n_steps = ip[IP_NSTEPS]
    stride = ip[IP_STRIDE]
    store = ip[IP_STORE] != 0
    adaptive = ip[IP_MODE] == 1
    t0 = fp[FP_T0]
    t_end = fp[FP_TEND]
    Cq = fp[FP_CQ]
    Cv = fp[FP_CV]
    kexp = fp[FP_KEXP]
    tf_kind = iview1(C, C_TFKIND)
    tf_off = iview1(C, C_TFOFF)
    tf_coef = fview1(C, C_TFCOEF)
    # work arrays: views into the pack W (femb/solver.py)
    q_s = fview1(W, W_Q_S)
    qd_s = fview1(W, W_QD_S)
    qpp = fview1(W, W_QPP)
    qpp_new = fview1(W, W_QPP_NEW)
    jn = fview1(W, W_JN)
    jnew = fview1(W, W_JNEW)
    KB = fview1(W, W_KB)
    KBacc = fview1(W, W_KBACC)
    kpiv = iview1(W, W_KPIV)
    kpivacc = iview1(W, W_KPIVACC)
    eq = fview1(W, W_EQ)
    ev = fview1(W, W_EV)
    atolv = fview1(W, W_ATOLV)
    wq = fview1(W, W_WQ)
    xm = iview1(C, C_XMAP)
    # a run-time 0 added to the mode constants: numba compiles a function once per literal argument
    nc0 = 0 * nc
    si[SI_STORED] = 0
    done = 0
    while done < n_chunk:
        n = si[SI_STEP] + 1
        t = sf[SF_T]
        if adaptive:
            if t >= t_end:
                return ST_DONE
            h = min(sf[SF_HNEXT], fp[FP_HMAX])
            rem = t_end - t
            last = False
            if rem <= 1.05 * h:
                h = rem
                last = True
            elif rem < 2.0 * h:
                h = 0.5 * rem
            if h < fp[FP_HMIN]:
                info[0] = t
                info[1] = h
                return ST_HMIN
            t1 = t_end if last else t + h
        else:
            if n > n_steps:
                return ST_DONE
            h = fp[FP_H]
            t1 = t0 + n * h
        h_prev = sf[SF_HPREV]
        if (adaptive and si[SI_SAVED] == 0 and ip[IP_PYTF] != 0 and sf[SF_TFTIME] != t and h != h_prev
                and si[SI_HAVEJ] != 0 and nc > 0 and ip[IP_GGL] == 0):
            # the re-synchronisation below needs Φ_t at t: Python time functions are asked for first
            info[0] = t
            return ST_NEED_TF
        if adaptive and si[SI_SAVED] == 0:
            # save the accepted state: a rejected or failed trial restarts from it
            save_state(q, qd, qdd, lam, a, pqdd, plam, W)
            si[SI_HASPREV_S] = si[SI_HASPREV]
            sf[SF_FREF_S] = sf[SF_FREF]
            if h != h_prev and si[SI_HAVEJ] != 0:
                if resynchronise(G, C, ip, fp, si, sf, stats, t, h, h_prev, q, qd, qdd, lam, a, tfv, AB, ipiv, Phi,
                                 W, nc0) != 0:
                    info[0] = t
                    return ST_KKT_SINGULAR
            si[SI_SAVED] = 1
        if ip[IP_PYTF] != 0:
            if sf[SF_TFTIME] != t1:
                info[0] = t1
                return ST_NEED_TF
        eval_time_functions(t1, tf_kind, tf_off, tf_coef, tfv)
        if adaptive:
            si[SI_SAVED] = 0
        newton_weights(C, fp, q, atolv, adaptive, wq)
        k = newton_step(G, C, ip, fp, si, sf, stats, q, qd, qdd, lam, a, pqdd, plam, t1, h,
                        h_prev if h_prev > 0.0 else h, AB, ipiv, r, Phi, rhs, x, info, wq)
        if k < 0:
            if not adaptive:
                return k
            # Newton failed: retry from the accepted state with h/4, no growth next step
            back_to_accepted(si, sf, q, qd, qdd, lam, a, pqdd, plam, W)
            si[SI_NFAIL] += 1
            si[SI_LASTFAIL] = k
            si[SI_NOGROW] = 1
            sf[SF_HNEXT] = 0.25 * h
            continue
        # ---- local error estimate (stepsize.md §3)
        err = -1.0
        if adaptive:
            hbar = 0.5 * (h + (h_prev if h_prev > 0.0 else h))
            if kkt_accelerations(G, C, ip, fp, si, sf, stats, t1, q, qd, qdd, lam, h, hbar, AB, ipiv, Phi, W,
                                 KB, kpiv, qpp_new, KKT_EST_QV + nc0) != 0:
                info[0] = t1
                return ST_KKT_SINGULAR
            for i in range(nv):
                jnew[i] = (qpp_new[i] - qpp[i]) / h
                eq[i] = Cq * h * h * (qpp_new[i] - qpp[i])
                ev[i] = Cv * h * h * h * (jnew[i] - jn[i]) / hbar
            err = error_norm(ip, fp, xm, q_s, q, qd_s, qd, eq, ev, atolv, nv >= 0)
            if fp[FP_EPUS] != 0.0:
                err /= h
        elif ip[IP_CHECK] > 1:
            # fixed steps: q̈ᵖᵖ at two consecutive steps every IP_CHECK steps, e_q only
            phase = n % ip[IP_CHECK]
            if phase == 0 or (phase == 1 and si[SI_HAVEJ] != 0):
                if kkt_accelerations(G, C, ip, fp, si, sf, stats, t1, q, qd, qdd, lam, h, h, AB, ipiv, Phi, W,
                                     KB, kpiv, qpp_new, KKT_EST_Q + nc0) != 0:
                    info[0] = t1
                    return ST_KKT_SINGULAR
                if phase == 0:
                    copy_into(qpp, qpp_new)
                    si[SI_HAVEJ] = 1
                else:
                    for i in range(nv):
                        eq[i] = Cq * h * h * (qpp_new[i] - qpp[i])
                    # per step (not per unit step): the threshold of stepsize.md §9
                    err = error_norm(ip, fp, xm, q, q, qd, qd, eq, ev, atolv, nv < 0)
                    si[SI_HAVEJ] = 0
                    if err > sf[SF_ERRMAX]:
                        sf[SF_ERRMAX] = err
                        sf[SF_ERRMAX_T] = t1
                    if err > fp[FP_WARN] and not (sf[SF_WARN_T] == sf[SF_WARN_T]):
                        sf[SF_WARN_T] = t1
                        sf[SF_WARN_ERR] = err
        if adaptive:
            if err > 1.0:
                # rejected: back to the accepted state with a smaller step
                back_to_accepted(si, sf, q, qd, qdd, lam, a, pqdd, plam, W)
                si[SI_REJECTED] += 1
                si[SI_NOGROW] = 1
                sf[SF_HNEXT] = h * max(0.2, 0.9 * err ** (-1.0 / kexp))
                continue
            # accepted: next step size (PI controller)
            sf[SF_HNEXT] = h * step_factor(si, sf, err, kexp)
            if si[SI_RMODE] == 0 and ip[IP_GGL] == 0:
                # projections at the next step change use the Newton matrix if it was built in this
                # step (its constraint rows are B there); a matrix carried from earlier steps is not
                si[SI_PROJ] = 1 if si[SI_LUFRESH] != 0 else 0
            else:
                copy_into(KBacc, KB)
                copy_into(kpivacc, kpiv)
                si[SI_PROJ] = 2
            copy_into(qpp, qpp_new)
            copy_into(jn, jnew)
            if err > sf[SF_ERRMAX]:
                sf[SF_ERRMAX] = err
                sf[SF_ERRMAX_T] = t1
        sf[SF_HPREV] = h
        sf[SF_T] = t1
        si[SI_STEP] = n
        stats[NS_STEPS] += 1
        out_h[done] = h
        out_it[done] = k
        out_err[done] = err
        done += 1
        final = (t1 >= t_end) if adaptive else (n == n_steps)
        if (store and n % stride == 0) or final:
            m = si[SI_STORED]
            out_t[m] = t_end if final else t1
            store_state(m, q, qd, qdd, lam, out_q, out_qd, out_qdd, out_lam)
            si[SI_STORED] = m + 1
        if final:
            return ST_DONE
    return ST_CHUNK


# ---- the parts of the time loop ---------------------------------------------------------------
@njit(**INNER)
def resynchronise(G, C, ip, fp, si, sf, stats, t, h, h_prev, q, qd, qdd, lam, a, tfv, AB, ipiv, Phi, W, nc0):
    """Re-synchronise a and the normal velocity with a new step size (stepsize.md §2), in place.

    a* = a + Δ (h − h_prev) j with Δ = α_m − α_f; index 3: B q̇* = h² C_q B j − Φ_t (the
    index-2 step keeps B q̇ + Φ_t = 0: no normal velocity to re-synchronise), projected with
    the Newton matrix of the accepted step (``si[SI_PROJ] == 1``) or a KKT factorization at
    the accepted state. Returns 0, or 1 if that KKT matrix is singular.
    """
    nv = ip[IP_NV]
    nc = ip[IP_NC]
    jn = fview1(W, W_JN)
    delta = fp[FP_AM] - fp[FP_AF]
    for i in range(nv):
        a[i] += delta * (h - h_prev) * jn[i]
    if nc == 0 or ip[IP_GGL] != 0:
        return 0
    Bv = fview1(W, W_BV)
    Pt = fview1(W, W_PT)
    tgt = fview1(W, W_TGT)
    kx = fview1(W, W_KX)
    KBacc = fview1(W, W_KBACC)
    kpivacc = iview1(W, W_KPIVACC)
    # Φ_t at t: the time functions at t (Python ones were asked for before the step)
    eval_time_functions(t, iview1(C, C_TFKIND), iview1(C, C_TFOFF), fview1(C, C_TFCOEF), tfv)
    jacobian_times(G, C, t, q, jn, Bv)
    rates(G, C, t, q, qd, Pt, fview1(W, W_GAM))
    for j in range(nc):
        tgt[j] = -Pt[j] + h * h * fp[FP_CQ] * Bv[j]
    if si[SI_PROJ] == 1:
        # the Newton matrix of the accepted step: its constraint rows are B
        project_normal_velocity(G, C, ip, t, q, qd, tgt, AB, ipiv, kx, Bv)
        return 0
    if si[SI_PROJ] != 2:
        # no factorization at the accepted state (a trial was rejected): one here
        if kkt_accelerations(G, C, ip, fp, si, sf, stats, t, q, qd, qdd, lam, h, h, AB, ipiv, Phi, W, KBacc,
                             kpivacc, fview1(W, W_QPP_NEW), KKT_FACTOR + nc0) != 0:
            return 1
        si[SI_PROJ] = 2
    project_normal_velocity(G, C, ip, t, q, qd, tgt, KBacc, kpivacc, kx, Bv)
    return 0


@njit(**INNER)
def newton_weights(C, fp, q, atolv, adaptive, wq):
    """The q tolerance of each coordinate for Newton's correction rule (stepsize.md §5), into wq.

    Adaptive steps: a fraction ``FP_TOLQ`` of the error tolerance atol + rtol |q|. Fixed steps:
    1e-13 relative, but never below the round-off that a chain of nv coordinates accumulates
    in a correction (≈ √nv · c ε |q|).
    """
    nv = wq.shape[0]
    xm = iview1(C, C_XMAP)
    if adaptive:
        for i in range(nv):
            j = xm[i]
            wq[i] = fp[FP_TOLQ] * (atolv[i] + (fp[FP_ERTOL] * abs(q[j]) if j >= 0 else 0.0))
        return
    wC = fview1(C, C_W)
    qmax_ = 0.0
    for i in range(nv):
        j = xm[i]
        if j >= 0 and abs(q[j]) > qmax_:
            qmax_ = abs(q[j])
    floor = fp[FP_NEWTC] * 2.220446049250313e-16 * (1.0 + qmax_) * math.sqrt(max(1.0, nv / 100.0))
    for i in range(nv):
        j = xm[i]
        wq[i] = max(fp[FP_TOLQ] * ((abs(q[j]) if j >= 0 else 0.0) + fp[FP_L] * wC[i]), floor)


@njit(**INNER)
def step_factor(si, sf, err, kexp):
    """h_next / h after an accepted step: PI controller (Gustafsson 1994), in [0.2, 2], no growth
    right after a rejection or a Newton failure."""
    e = max(err, 1e-10)
    if si[SI_NOGROW] != 0 or sf[SF_ERRPREV] <= 0.0:
        fac = 0.9 * e ** (-1.0 / kexp)
    else:
        fac = 0.9 * e ** (-0.7 / kexp) * (sf[SF_ERRPREV] / e) ** (0.4 / kexp)
    fac = min(2.0, max(0.2, fac))
    if si[SI_NOGROW] != 0:
        fac = min(fac, 1.0)
    si[SI_NOGROW] = 0
    sf[SF_ERRPREV] = e
    return fac


@njit(**INNER)
def save_state(q, qd, qdd, lam, a, pqdd, plam, W):
    """The accepted state into work arrays 0 to 6 of W (a rejected trial restarts from it)."""
    copy_into(fview1(W, W_Q_S), q)
    copy_into(fview1(W, W_QD_S), qd)
    copy_into(fview1(W, W_QDD_S), qdd)
    copy_into(fview1(W, W_LAM_S), lam)
    copy_into(fview1(W, W_A_S), a)
    copy_into(fview1(W, W_PQDD_S), pqdd)
    copy_into(fview1(W, W_PLAM_S), plam)


@njit(**INNER)
def back_to_accepted(si, sf, q, qd, qdd, lam, a, pqdd, plam, W):
    """After a rejected or failed trial: the accepted state, its predictor history and force
    scale; the Newton matrix of the accepted step is gone."""
    restore_state(q, qd, qdd, lam, a, pqdd, plam, W)
    si[SI_HASPREV] = si[SI_HASPREV_S]
    sf[SF_FREF] = sf[SF_FREF_S]
    si[SI_CARRY] = 0
    if si[SI_PROJ] == 1:
        si[SI_PROJ] = 0


@njit(**INNER)
def store_state(m, q, qd, qdd, lam, out_q, out_qd, out_qdd, out_lam):
    """Row m of the output buffers = the current state."""
    copy_into(out_q[m], q)
    copy_into(out_qd[m], qd)
    copy_into(out_qdd[m], qdd)
    copy_into(out_lam[m], lam)


# ---- the model's element batches: residual, iteration matrix, rates, B -------------------
@engine(**ENTRY)
def evaluate(G, C, t, q, qd, qdd, lam, jac, cM, cC, cK, ABf, r, Phi):
    """Residual r = M q̈ − f + Bᵀλ, Φ, and (jac) the iteration matrix into ABf; returns the force scale.

    ``cM``, ``cC``, ``cK`` multiply M, C_t = −∂f/∂q̇ and K_t = −∂f/∂q + ∂(Bᵀλ)/∂q in the
    matrix (Newton: the scaled β', γ' and 1). Batches run in the order of the batch table:
    forces first, then constraints.
    """
    batches = iview2(C, C_BATCHES)
    scale = mass_residual(C, qdd, r, ABf, jac, cM)
    for b in range(batches.shape[0]):
        if batches[b, B_ROLE] == ROLE_FORCE:
            scale = force_batch(G, C, batches[b], t, q, qd, jac, cC, cK, ABf, r, scale)
        else:
            scale = constraint_batch(G, C, batches[b], t, q, qd, lam, jac, cK, ABf, r, Phi, scale)
    return scale


@njit(**INNER)
def gather_batch(G, C, base, xdofs_k, dofs_k, xe_k, ve_k, q, v):
    """Element coordinates xe and velocities ve (from v) of the batch whose arrays start at ``base``."""
    qfix = fview1(C, C_QFIX)
    dofs = iview2(G, base + dofs_k)
    xe = fview2(G, base + xe_k)
    ve = fview2(G, base + ve_k)
    if iview1(C, C_LIE)[0] != 0:
        gather_x_v(q, v, qfix, iview2(G, base + xdofs_k), dofs, xe, ve, q.shape[0], v.shape[0])
    else:
        gather_xv(q, v, qfix, dofs, xe, ve, v.shape[0])


@njit(**INNER)
def force_batch(G, C, row, t, q, qd, jac, cC, cK, ABf, r, scale):
    """One force batch: f_e and its Jacobians from the kernel, −f into r, −cK ∂f/∂q − cC ∂f/∂q̇ into ABf."""
    base = row[B_BASE]
    gather_batch(G, C, base, F_XDOFS, F_DOFS, F_XE, F_VE, q, qd)
    tf = fview3(G, base + F_TF)
    gather_tf(fview2(C, C_TFV), iview2(G, base + F_TFI), tf)
    fe = fview2(G, base + F_FE)
    fq = fview3(G, base + F_FQ)
    fv = fview3(G, base + F_FV)
    zero2(fe)
    if jac:
        zero3(fq)
        zero3(fv)
    call_force(row[B_KERNEL], fview2(G, base + F_P), t, tf, fview2(G, base + F_XE), fview2(G, base + F_VE),
               jac, fe, fq, fv)
    scale = scatter_force(fe, iview2(G, base + F_DOFS), r, qd.shape[0], fview1(C, C_WEXT), scale)
    if jac:
        tnn = iview3(G, base + F_TNN)
        if iview1(C, C_LIE)[0] != 0:
            apply_tangent(fq, iview3(G, base + F_TBLK), fview3(C, C_TN), cK)
        scatter_matrix(fq, tnn, ABf, -cK)
        if row[B_HASC] != 0:
            scatter_matrix(fv, tnn, ABf, -cC)
    return scale


@njit(**INNER)
def constraint_batch(G, C, row, t, q, qd, lam, jac, cK, ABf, r, Phi, scale):
    """One constraint batch: Φ_e, B_e and H_e from the kernel; Φ, Bᵀλ into r, [B, Bᵀ, cK H] into ABf."""
    base = row[B_BASE]
    gather_batch(G, C, base, K_XDOFS, K_DOFS, K_XE, K_VE, q, qd)
    lamidx = iview2(G, base + K_LAMIDX)
    le = fview2(G, base + K_LE)
    gather_lam(lam, lamidx, le)
    tf = fview3(G, base + K_TF)
    gather_tf(fview2(C, C_TFV), iview2(G, base + K_TFI), tf)
    Phe = fview2(G, base + K_PHE)
    Be = fview3(G, base + K_BE)
    He = fview3(G, base + K_HE)
    zero2(Phe)
    zero3(Be)
    if jac:
        zero3(He)
    call_constraint(row[B_KERNEL], fview2(G, base + K_P), t, tf, fview2(G, base + K_XE), le, jac, Phe, Be, He)
    scale = scatter_constraint(Phe, Be, le, iview2(G, base + K_DOFS), lamidx, iview1(C, C_ACTIVE), Phi, r,
                               qd.shape[0], fview1(C, C_WEXT), scale)
    if jac:
        tB = iview3(G, base + K_TB)
        tBt = iview3(G, base + K_TBT)
        if iview1(C, C_LIE)[0] != 0:
            tblk = iview3(G, base + K_TBLK)
            Tn = fview3(C, C_TN)
            scatter_B_tangent(Be, tblk, Tn, cK, tB, tBt, ABf)
            apply_tangent(He, tblk, Tn, cK)
        else:
            scatter_B(Be, tB, tBt, ABf)
        scatter_matrix(He, iview3(G, base + K_TNN), ABf, cK)
    return scale


@njit(**INNER)
def constraint_blocks(G, C, row, t, q, v):
    """Run the batch's constraint kernel at (t, q) without Jacobian; its B_e blocks stay in G.
    The velocities gathered into the batch's ``ve`` are those of ``v``."""
    base = row[B_BASE]
    gather_batch(G, C, base, K_XDOFS, K_DOFS, K_XE, K_VE, q, v)
    tf = fview3(G, base + K_TF)
    gather_tf(fview2(C, C_TFV), iview2(G, base + K_TFI), tf)
    Phe = fview2(G, base + K_PHE)
    Be = fview3(G, base + K_BE)
    zero2(Phe)
    zero3(Be)
    call_constraint(row[B_KERNEL], fview2(G, base + K_P), t, tf, fview2(G, base + K_XE), fview2(G, base + K_LE),
                    v.shape[0] < 0, Phe, Be, fview3(G, base + K_HE))


@engine(**ENTRY)
def rates(G, C, t, q, qd, Phi_t, gam):
    """Φ_t and γ (B q̈ = −γ) of all constraints at (t, q, q̇)."""
    batches = iview2(C, C_BATCHES)
    active = iview1(C, C_ACTIVE)
    zero1(Phi_t)
    zero1(gam)
    for b in range(batches.shape[0]):
        if batches[b, B_ROLE] != ROLE_CONSTRAINT:
            continue
        base = batches[b, B_BASE]
        gather_batch(G, C, base, K_XDOFS, K_DOFS, K_XE, K_VE, q, qd)
        tf = fview3(G, base + K_TF)
        gather_tf(fview2(C, C_TFV), iview2(G, base + K_TFI), tf)
        Pt = fview2(G, base + K_PT)
        gm = fview2(G, base + K_GM)
        zero2(Pt)
        zero2(gm)
        call_rates(batches[b, B_RATES], fview2(G, base + K_P), t, tf, fview2(G, base + K_XE),
                   fview2(G, base + K_VE), Pt, gm)
        lamidx = iview2(G, base + K_LAMIDX)
        for e in range(lamidx.shape[0]):
            for j in range(lamidx.shape[1]):
                c = lamidx[e, j]
                if active[c] != 0:
                    Phi_t[c] = Pt[e, j]
                    gam[c] = gm[e, j]
    return 0


@engine(**ENTRY)
def jacobian_times(G, C, t, q, v, out):
    """out = B(q, t) v for all constraints."""
    batches = iview2(C, C_BATCHES)
    zero1(out)
    for b in range(batches.shape[0]):
        if batches[b, B_ROLE] != ROLE_CONSTRAINT:
            continue
        constraint_blocks(G, C, batches[b], t, q, v)
        base = batches[b, B_BASE]
        Be = fview3(G, base + K_BE)
        ve = fview2(G, base + K_VE)
        lamidx = iview2(G, base + K_LAMIDX)
        dofs = iview2(G, base + K_DOFS)
        for e in range(lamidx.shape[0]):
            for j in range(lamidx.shape[1]):
                s = 0.0
                for i in range(dofs.shape[1]):
                    s += Be[e, j, i] * ve[e, i]
                out[lamidx[e, j]] = s
    return 0


@engine(**ENTRY)
def constraint_B(G, C, t, q, qd, out):
    """out = the element blocks of B(q, t), flat (batch by batch, element, row, column; see ``copy_blocks``)."""
    batches = iview2(C, C_BATCHES)
    o = 0
    for b in range(batches.shape[0]):
        if batches[b, B_ROLE] != ROLE_CONSTRAINT:
            continue
        constraint_blocks(G, C, batches[b], t, q, qd)
        o = copy_blocks(fview3(G, batches[b, B_BASE] + K_BE), out, o)
    return o


@engine(**ENTRY)
def copy_B(G, C, out):
    """out = the element blocks of B left by the last ``evaluate``, flat."""
    batches = iview2(C, C_BATCHES)
    o = 0
    for b in range(batches.shape[0]):
        if batches[b, B_ROLE] == ROLE_CONSTRAINT:
            o = copy_blocks(fview3(G, batches[b, B_BASE] + K_BE), out, o)
    return o


# ---- gather / scatter helpers called by evaluate() -------------------------------------------
@njit(**INNER)
def gather_xv(q, qd, qfix, dofs, xe, ve, nv):
    """xe[e, i] = [q, q_fixed][dofs[e, i]], ve likewise with zero fixed velocities."""
    for e in range(dofs.shape[0]):
        for i in range(dofs.shape[1]):
            d = dofs[e, i]
            if d < nv:
                xe[e, i] = q[d]
                ve[e, i] = qd[d]
            else:
                xe[e, i] = qfix[d - nv]
                ve[e, i] = 0.0


@njit(**INNER)
def gather_lam(lam, lamidx, le):
    for e in range(lamidx.shape[0]):
        for j in range(lamidx.shape[1]):
            le[e, j] = lam[lamidx[e, j]]


@njit(**INNER)
def gather_tf(tfv, tfi, tf):
    for e in range(tfi.shape[0]):
        for k in range(tfi.shape[1]):
            i = tfi[e, k]
            tf[e, k, 0] = tfv[i, 0]
            tf[e, k, 1] = tfv[i, 1]
            tf[e, k, 2] = tfv[i, 2]


@njit(**INNER)
def scatter_force(fe, dofs, r, nv, wext, scale):
    """r −= f_e on free coordinates; returns max(scale, |f_e · w|)."""
    for e in range(dofs.shape[0]):
        for i in range(dofs.shape[1]):
            d = dofs[e, i]
            v = fe[e, i]
            s = abs(v * wext[d])
            if s > scale:
                scale = s
            if d < nv:
                r[d] -= v
    return scale


@njit(**INNER)
def scatter_constraint(Phe, Be, le, dofs, lamidx, active, Phi, r, nv, wext, scale):
    """Φ rows and r += Bᵀλ per element; returns max(scale, |(Bᵀλ)_e · w|)."""
    for e in range(dofs.shape[0]):
        for j in range(lamidx.shape[1]):
            c = lamidx[e, j]
            Phi[c] = Phe[e, j] if active[c] != 0 else 0.0
        for i in range(dofs.shape[1]):
            v = 0.0
            for j in range(lamidx.shape[1]):
                v += Be[e, j, i] * le[e, j]
            d = dofs[e, i]
            s = abs(v * wext[d])
            if s > scale:
                scale = s
            if d < nv:
                r[d] += v
    return scale


@njit(**INNER)
def scatter_matrix(Ke, tgt, ABf, factor):
    """ABf[tgt[e, i, j]] += factor · Ke[e, i, j] (targets < 0 are fixed coordinates)."""
    for e in range(Ke.shape[0]):
        for i in range(Ke.shape[1]):
            for j in range(Ke.shape[2]):
                t = tgt[e, i, j]
                if t >= 0:
                    ABf[t] += factor * Ke[e, i, j]


@njit(**INNER)
def scatter_B(Be, tB, tBt, ABf):
    for e in range(Be.shape[0]):
        for j in range(Be.shape[1]):
            for i in range(Be.shape[2]):
                t = tB[e, j, i]
                if t >= 0:
                    v = Be[e, j, i]
                    ABf[t] += v
                    ABf[tBt[e, j, i]] += v


@njit(**INNER)
def mass_residual(C, qdd, r, ABf, jac, cM):
    """r = M q̈ − f_const (constant M in CSR), M into the matrix; returns the force scale."""
    Mp = iview1(C, C_MP)
    w = fview1(C, C_W)
    fconst = fview1(C, C_FCONST)
    Mi = iview1(C, C_MI)
    Mx = fview1(C, C_MX)
    tM = iview1(C, C_TM)
    scale = fview1(C, C_SCALE0)[0]
    for i in range(r.shape[0]):
        s = 0.0
        for k in range(Mp[i], Mp[i + 1]):
            s += Mx[k] * qdd[Mi[k]]
        v = abs(s * w[i])
        if v > scale:
            scale = v
        r[i] = s - fconst[i]
    if jac:
        for k in range(ABf.shape[0]):
            ABf[k] = 0.0
        for k in range(tM.shape[0]):
            ABf[tM[k]] += cM * Mx[k]
        tI = iview1(C, C_TI)
        for k in range(tI.shape[0]):
            ABf[tI[k]] = 1.0
    return scale


@njit(**INNER)
def lie_update(q, C):
    """Rotations of q from the step's start and increment: p = p_n ⊗ exp(D_θ), and T(D_θ).

    For each free rotation b with quaternion at x[xs:xs+4] and rotation vector at
    v[vs:vs+3] (row b of C's array 20 = (xs, vs)): q[xs:xs+4] = p_n ⊗ (cos(φ/2), s7(φ) θ),
    renormalised, θ = D[vs:vs+3], φ = |θ|; C's array 18 [b] = T(θ) = I − s2 θ~ + s3 θ~²
    (Brüls & Cardona 2010; femb/rotations.py for the coefficient functions).
    """
    Tn = fview3(C, C_TN)
    rot = iview2(C, C_ROT)
    pn = fview2(C, C_PN)
    D = fview1(C, C_D)
    for b in range(rot.shape[0]):
        xs = rot[b, 0]
        vs = rot[b, 1]
        t0 = D[vs]
        t1 = D[vs + 1]
        t2 = D[vs + 2]
        phi = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
        c = math.cos(0.5 * phi)
        sv = s7(phi)
        e1 = sv * t0
        e2 = sv * t1
        e3 = sv * t2
        a0 = pn[b, 0]
        a1 = pn[b, 1]
        a2 = pn[b, 2]
        a3 = pn[b, 3]
        p0 = a0 * c - a1 * e1 - a2 * e2 - a3 * e3
        p1 = a0 * e1 + c * a1 + a2 * e3 - a3 * e2
        p2 = a0 * e2 + c * a2 + a3 * e1 - a1 * e3
        p3 = a0 * e3 + c * a3 + a1 * e2 - a2 * e1
        n = 1.0 / math.sqrt(p0 * p0 + p1 * p1 + p2 * p2 + p3 * p3)
        q[xs] = p0 * n
        q[xs + 1] = p1 * n
        q[xs + 2] = p2 * n
        q[xs + 3] = p3 * n
        # T = I − s2 θ~ + s3 θ~², θ~² = θθᵀ − φ² I
        c2 = s2(phi)
        c3 = s3(phi)
        ph2 = phi * phi
        for r in range(3):
            for k in range(3):
                Tn[b, r, k] = c3 * (D[vs + r] * D[vs + k]) + ((1.0 - c3 * ph2) if r == k else 0.0)
        Tn[b, 0, 1] += c2 * t2
        Tn[b, 0, 2] -= c2 * t1
        Tn[b, 1, 0] -= c2 * t2
        Tn[b, 1, 2] += c2 * t0
        Tn[b, 2, 0] += c2 * t1
        Tn[b, 2, 1] -= c2 * t0


@engine(**ENTRY)
def lie_reset(C):
    """T = I for every rotation (between steps: evaluations outside Newton use no tangent operator)."""
    Tn = fview3(C, C_TN)
    for b in range(Tn.shape[0]):
        for r in range(3):
            for k in range(3):
                Tn[b, r, k] = 1.0 if r == k else 0.0


@njit(**INNER)
def gather_x_v(q, qd, qfix, xdofs, dofs, xe, ve, nx, nv):
    """xe[e, i] = [q, q_fixed][xdofs[e, i]] (configuration), ve[e, i] = [q̇, 0][dofs[e, i]] (velocities)."""
    for e in range(xdofs.shape[0]):
        for i in range(xdofs.shape[1]):
            d = xdofs[e, i]
            xe[e, i] = q[d] if d < nx else qfix[d - nx]
        for i in range(dofs.shape[1]):
            d = dofs[e, i]
            ve[e, i] = qd[d] if d < nv else 0.0


@njit(**INNER)
def apply_tangent(K, tblk, Tn, cK):
    """K[e, :, i0:i0+3] ← K[e, :, i0:i0+3] T_b for every rotation (i0, b) of element e (Newton only: cK ≠ 0)."""
    if cK == 0.0:
        return
    for e in range(tblk.shape[0]):
        for k in range(tblk.shape[1]):
            i0 = tblk[e, k, 0]
            if i0 < 0:
                continue
            b = tblk[e, k, 1]
            for r in range(K.shape[1]):
                k0 = K[e, r, i0]
                k1 = K[e, r, i0 + 1]
                k2 = K[e, r, i0 + 2]
                for c in range(3):
                    K[e, r, i0 + c] = k0 * Tn[b, 0, c] + k1 * Tn[b, 1, c] + k2 * Tn[b, 2, c]


@njit(**INNER)
def scatter_B_tangent(Be, tblk, Tn, cK, tB, tBt, ABf):
    """Bᵀ into the upper right block, B T(Δ) into the lower left one (overwrites Be)."""
    for e in range(Be.shape[0]):
        for j in range(Be.shape[1]):
            for i in range(Be.shape[2]):
                t = tBt[e, j, i]
                if t >= 0:
                    ABf[t] += Be[e, j, i]
    apply_tangent(Be, tblk, Tn, cK)
    for e in range(Be.shape[0]):
        for j in range(Be.shape[1]):
            for i in range(Be.shape[2]):
                t = tB[e, j, i]
                if t >= 0:
                    ABf[t] += Be[e, j, i]


@njit(**INNER)
def restore_state(q, qd, qdd, lam, a, pqdd, plam, W):
    """Back to the accepted state saved at the start of the trial step (work arrays 0 to 6 of W)."""
    copy_into(q, fview1(W, W_Q_S))
    copy_into(qd, fview1(W, W_QD_S))
    copy_into(qdd, fview1(W, W_QDD_S))
    copy_into(lam, fview1(W, W_LAM_S))
    copy_into(a, fview1(W, W_A_S))
    copy_into(pqdd, fview1(W, W_PQDD_S))
    copy_into(plam, fview1(W, W_PLAM_S))


@njit(**INNER)
def copy_into(dst, src):
    """dst[...] = src for 1-D arrays of equal length."""
    for i in range(src.shape[0]):
        dst[i] = src[i]


@njit(**INNER)
def zero1(a):
    for i in range(a.shape[0]):
        a[i] = 0.0


@njit(**INNER)
def zero2(a):
    for i in range(a.shape[0]):
        for j in range(a.shape[1]):
            a[i, j] = 0.0


@njit(**INNER)
def zero3(a):
    for i in range(a.shape[0]):
        for j in range(a.shape[1]):
            for k in range(a.shape[2]):
                a[i, j, k] = 0.0


# ---- the engine's entry points and their one signature each -----------------------------------
def engine_signatures():
    """``{entry point: argument types}``: every entry point of the engine has one signature,
    whatever the model (its data come as packs and arrays of fixed rank and dtype)."""
    from numba import types as T
    f1, i1, i2, f2 = T.float64[::1], T.int64[::1], T.int64[:, ::1], T.float64[:, ::1]
    P = T.Tuple((f1, i1, i2))
    f, i, b = T.float64, T.int64, T.boolean
    loop = (P, P, i1, f1, i1, f1, i1)
    return {
        run: loop + (f1,) * 7 + (f2, f1, i1, f1, f1, f1, f1, f1, P, i, f1, f2, f2, f2, f2, f1,
                                  T.int32[::1], f1),
        evaluate: (P, P, f, f1, f1, f1, f1, b, f, f, f, f1, f1, f1),
        kkt_accelerations: loop + (f, f1, f1, f1, f1, f, f, f1, i1, f1, P, f1, i1, f1, i),
        project_normal_velocity: (P, P, i1, f, f1, f1, f1, f1, i1, f1, f1),
        rates: (P, P, f, f1, f1, f1, f1),
        jacobian_times: (P, P, f, f1, f1, f1),
        constraint_B: (P, P, f, f1, f1, f1),
        copy_B: (P, P, f1),
        ggl_matrix: (P, f1, f),
        lie_reset: (P,),
        eval_time_functions: (f, i1, i1, f1, f2),
        band_lu: (f1, i, i, i, i2, i1, f),
        band_solve: (f1, i, i, i, i2, i1, f1),
        dense_lu_solve: (f1, i, i1, f, f1),
    }


_ENGINE = {"ready": False}


def ensure_engine(verbose=True, background=True):
    """Compile the engine, or load it from femb's disk cache: once per installation and CPU.

    Several processes that need it at once compile it once (a file lock), the others load it.
    Says so on stderr, with the time it took, when it has to compile; after a fresh compilation
    the kernels of the built-in element types are compiled in a background process
    (``background``; :func:`femb.cache.start_background_build`).
    """
    import sys
    import time
    from femb.jit import cache_writable, compile_lock, is_cached, jit_disabled
    if _ENGINE["ready"] or jit_disabled():
        return
    sigs = engine_signatures()
    with compile_lock("engine"):
        missing = [d for d, sg in sigs.items() if not is_cached(d, sg)]
        t0 = time.perf_counter()
        if missing and verbose:
            print(f"femb: compiling the engine (once per installation; {len(missing)} entry points)",
                  file=sys.stderr, flush=True)
        for d, sg in sigs.items():
            d.compile(sg)
            # any other argument types are a bug of the caller, not a reason to compile again
            d.disable_compile()
    if missing and verbose:
        kept = ("cached for later runs" if cache_writable() else
                "in memory for this run only (the compile cache is not writable)")
        print(f"femb: engine compiled in {time.perf_counter() - t0:.1f} s, {kept}", file=sys.stderr, flush=True)
    _ENGINE["ready"] = True
    if missing and background and cache_writable():
        from femb.cache import start_background_build
        start_background_build(verbose=verbose)
