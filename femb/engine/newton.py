"""Stage: the Newton step of Algorithm 1 of Arnold & Brüls (2007), index 3 and stabilized index 2.

:func:`newton_step` is one time step t_n → t_{n+1}: the predictor (:func:`predict`, the Newmark
formulas docs/method.md eqs. 3–5 with the auxiliary variable a), the Newton iteration on
S_t [Δq; Δλ] = −[r_q; r_λ] with q̇ += γ'Δq, q̈ += β'Δq (eq. 6; scaled, eq. 8; :func:`apply_correction`)
and its stopping rules (:func:`correction_test`: docs/stepsize.md §5; or the residual test).
On models with rotation nodes the update is q ∘ exp(Δ) (Brüls & Cardona 2010; :func:`lie_update`).
The index-2 form adds the velocity constraint B q̇ + Φ_t = 0 with multipliers η (Gear, Gupta &
Leimkuhler 1985; docs/method.md §7; :func:`ggl_matrix`, :func:`velocity_residual`).

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

References
----------
M. Arnold, O. Brüls, Multibody Syst. Dyn. 18 (2007) 185–202, Algorithm 1.
O. Brüls, A. Cardona, J. Comput. Nonlinear Dyn. 5 (2010) 031002 (Lie-group generalized-α).
C. L. Bottasso, D. Dopico, L. Trainelli, Multibody Syst. Dyn. 19 (2008) 3–20 (scaling).
C. W. Gear, B. Leimkuhler, G. K. Gupta, J. Comput. Appl. Math. 12–13 (1985) 77–90 (index 2).

"""

import math

from numba import njit

from femb.base.jit import engine, fview1, fview2, fview3, iview1, iview2
from femb.base.rotations import s2, s3, s7
from femb.engine.layout import (SEPARATE, STAGE, C_BW, C_D, C_ENV, C_FL, C_GGLW, C_IPERM, C_LIE, C_PAIRS, C_PN, C_ROT, C_TETA,
    C_TN, C_W, C_XMAP, ENTRY, FP_AF, FP_AM, FP_ATOL, FP_BETA, FP_GAMMA, FP_L, FP_NEWTC, FP_PHITOL, FP_RTOL,
    FP_SCALED, FP_SINGTOL, FP_XTOL, INNER, IP_CARRY, IP_FULL, IP_GGL, IP_MAXIT, IP_MINIT, IP_NC, IP_NTEST,
    IP_NV, IP_PRED, NEWTON_CARRY_ETA, NEWTON_ETA_EXP, NEWTON_FROZEN_MAX, NS_EVAL, NS_FACT, NS_ROUNDOFF,
    NS_SOLVE, SF_ETA, SF_FREF, SF_LUH, SI_CARRY, SI_HASPREV, SI_LUFRESH, SI_LUVALID, ST_DIVERGED_SINGULAR,
    ST_MAXITER, ST_NONFINITE, ST_SINGULAR)
from femb.engine.link import call
from femb.engine.linalg import (factor, solve, zero1)
from femb.engine.evaluate import (constraint_B, copy_B, evaluate, rates)

#: actions of the correction rule (:func:`correction_test`)
NT_CONTINUE, NT_ACCEPT, NT_ROUNDOFF, NT_REFRESH, NT_FAIL = 0, 1, 2, 3, 4
#: the residual rule's verdict "converged" (:func:`measure_residual`; failures are ``ST_*`` < 0)
RES_CONVERGED = 1


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


@engine(**SEPARATE)
def newton_step(G, C, P, S, N, t1, h, h_prev, wq):
    """One step t1 − h → t1 of the generalized-α scheme, in place: index 3 or stabilized index 2.

    Index 3 (``ip[IP_GGL] == 0``), stabilized index 2 (``ip[IP_GGL] != 0``) and the Lie-group
    update of rotation nodes: their equations and iteration matrices are in the module docstring.
    Stopping rules (``ip[IP_NTEST]``), :func:`correction_test`: 0 the residual rule of the seed
    reproduction, 1 the correction rule (default, stepsize.md §5).

    Parameters
    ----------
    G, C : pack
        The element batches and the model constants (:func:`femb.base.jit.pack`).
    P, S, N : Par, StepState, NewtonArrays
        Parameters and run state; the state at t_n, in place: at t_{n+1}; Newton's arrays.
    t1, h, h_prev : float
        t_{n+1}, the step, the previous step (the predictor's ratio).
    wq : ndarray (nv,)
        The q tolerance of each coordinate for the correction rule.

    Returns
    -------
    int
        Newton iterations (≥ 0) on success, then the state ``S`` (``StepState``) holds the new
        step; a negative status code otherwise, with ``N.info`` = (t1, ‖r_q‖, ‖Φ‖, iteration,
        index of the largest |Φ_i|, tolerance of r_q, tolerance of Φ).
    """
    ip, fp, si, sf, stats = P
    ggl = ip[IP_GGL] != 0
    lie = iview1(C, C_LIE)[0] != 0
    nc = ip[IP_NC]
    bp, gp, c, sg, sr = step_coefficients(fp, h)
    full = ip[IP_FULL] != 0
    tol_phi = fp[FP_PHITOL] * fp[FP_L]
    ntest = ip[IP_NTEST]
    g = fview2(C, C_GGLW)[1]         # index 2: g = B q̇ + Φ_t
    eta0, carry, carried = newton_begin(G, C, P, S, N.x, t1, h, h_prev, ggl, lie)
    F_ref = F = sf[SF_FREF]
    theta_first = prev_norm = -1.0
    theta_prev_bad = k = 0
    have_lu = carried
    err_f = err_phi = 0.0
    redo = False
    while True:
        jac = redo or (((full and k == 0) or si[SI_LUVALID] == 0) if ntest == 0 else not have_lu)
        scale = call(evaluate, G, C, t1, (S.q, S.qd, S.qdd, S.lam), jac, (c * bp, c * gp, c), (N.AB, N.r, N.Phi))
        stats[NS_EVAL] += 1
        if ggl:
            call(velocity_residual, G, C, t1, S.q, S.qd, jac, lie, g)
        if not redo:
            F = scale if scale > F_ref else F_ref
            err_f, err_phi, status = measure_residual(C, P, N, t1, k, F, gp, ggl)
            if status == RES_CONVERGED:
                break
            if status != 0:
                return status
            if ntest == 0 and not jac and residual_rule_redo(si, full, prev_norm, err_f, err_phi, F, tol_phi):
                redo = True
                continue
        redo = False
        if jac:
            status = factor_matrix(C, P, N, h, sg, ggl, k)
            if status != 0:
                return status
            have_lu = True
            carried = False
        if ntest == 0 and not full:
            prev_norm = max(err_f / max(F, 1e-300), err_phi / max(tol_phi, 1e-300))
        solve_correction(C, P, N, g, c, sr, ggl)
        m = apply_correction(C, ip, S, N.rhs, wq, bp, gp, c, lie, ggl)
        k += 1
        if ntest == 0:
            # round-off floor: a correction at the level of the coordinates' own round-off
            # cannot improve the iterate (stiff elements nearly at rest)
            if (err_phi <= tol_phi and err_f <= 1e4 * (fp[FP_RTOL] * F + fp[FP_ATOL])
                    and m[0] <= fp[FP_XTOL] * (m[1] + fp[FP_L])):
                stats[NS_ROUNDOFF] += 1
                break
        else:
            # a carried matrix accepts its first correction by the η₀ test only without
            # constraints: its constraint rows belong to an earlier configuration, so η₀‖Φ₀‖
            # does not bound Φ after the correction (a chain of 400 bricks ended its runs with
            # ‖Φ‖ up to half the tolerance, 2e-4 of it with fresh matrices)
            action, size, theta = correction_test(P, k, jac, carried and nc == 0, m, bp,
                                                  (eta0, prev_norm), err_phi / tol_phi, theta_prev_bad)
            theta_first = theta if (theta_first < 0.0 and theta >= 0.0) else theta_first
            if action == NT_ROUNDOFF:
                stats[NS_ROUNDOFF] += 1
                break
            if action == NT_ACCEPT:
                break
            if action == NT_FAIL:
                N.info[3] = k
                return ST_MAXITER
            if theta >= 1.0 and jac:
                theta_prev_bad += 1
            if action == NT_REFRESH:
                have_lu = False          # slow or no contraction: refresh the iteration matrix
            prev_norm = size
    newton_end(P, S, N.x, F, F_ref, eta0, theta_first, carry, ggl)
    return k


@njit(**STAGE)
def step_coefficients(fp, h):
    """(β', γ', c, s_g, s_r) of a step h: β' = (1 − α_m)/(h²β(1 − α_f)), γ' = γ/(hβ) (Arnold &
    Brüls 2007, eq. 6), the scaling c = βh² (Bottasso, Dopico & Trainelli 2008; 1 unscaled) and
    the index-2 velocity rows' factors in the matrix (s_g) and the right-hand side (s_r)."""
    beta = fp[FP_BETA]
    bp = (1.0 - fp[FP_AM]) / (h * h * beta * (1.0 - fp[FP_AF]))
    gp = fp[FP_GAMMA] / (h * beta)
    scaled = fp[FP_SCALED] != 0.0
    c = beta * h * h if scaled else 1.0
    sg = 1.0 if scaled else gp
    sr = 1.0 / gp if scaled else 1.0
    return bp, gp, c, sg, sr


@njit(**STAGE)
def newton_begin(G, C, P, S, x, t1, h, h_prev, ggl, lie):
    """Before the first iterate: B(q_n) (index 2), the predictor, the carried contraction estimate
    η₀ and whether the factorized matrix of an earlier step is used again.

    Large band systems use the factorized matrix of an earlier step while it was built for this
    h (the same β', γ', c) and the carried estimate promises fast contraction; the correction rule
    refreshes it when the contraction turns out poor (``NT_REFRESH``).

    Returns
    -------
    (eta0, carry, carried) : (float, bool, bool)
    """
    ip, fp, si, sf, stats = P
    ntest = ip[IP_NTEST]
    if ggl:
        # B(q_n) for the step (time functions at t_{n+1}: they are evaluated before the step)
        call(constraint_B, G, C, t1, S.q, S.qd, fview2(C, C_BW)[0])
    predict(C, P, S, x, h, h_prev, lie)
    if ggl:
        zero1(fview2(C, C_GGLW)[0])
    # correction rule, index 3: the contraction estimate carried over from the previous step
    eta0 = newton_rate_start(sf) if (ntest != 0 and not ggl) else -1.0
    carry = ip[IP_CARRY] != 0 and ntest != 0 and not ggl
    carried = (carry and si[SI_CARRY] != 0 and si[SI_LUVALID] != 0 and sf[SF_LUH] == h
               and 0.0 <= eta0 <= NEWTON_CARRY_ETA)
    si[SI_CARRY] = 0
    si[SI_LUFRESH] = 0
    return eta0, carry, carried


@njit(**STAGE)
def measure_residual(C, P, N, t1, k, F, gp, ggl):
    """‖W r_q‖∞ and ‖Φ‖∞ of the iterate k into ``N.info``, and the residual rule's verdict.

    Returns
    -------
    (err_f, err_phi, status)
        status: ``RES_CONVERGED`` (residual rule, ``ip[IP_NTEST] == 0``: r_q and Φ within their
        tolerances after at least ``IP_MINIT`` iterations), ``ST_NONFINITE``, ``ST_MAXITER``
        (k = ``IP_MAXIT``) or 0 (go on).
    """
    ip, fp, si, sf, stats = P
    info = N.info
    tol_phi = fp[FP_PHITOL] * fp[FP_L]
    tol_f = fp[FP_RTOL] * F + fp[FP_ATOL]
    err_f = residual_norm(N.r, fview1(C, C_W))
    err_phi, iphi = constraint_norm(N.Phi, fview2(C, C_GGLW)[1], gp, ggl)
    info[0] = t1
    info[1] = err_f
    info[2] = err_phi
    info[3] = k
    info[4] = iphi
    info[5] = tol_f
    info[6] = tol_phi
    if not (math.isfinite(err_f) and math.isfinite(err_phi)):
        return err_f, err_phi, ST_NONFINITE
    if ip[IP_NTEST] == 0 and k >= ip[IP_MINIT] and err_f <= tol_f and err_phi <= tol_phi:
        return err_f, err_phi, RES_CONVERGED
    if k == ip[IP_MAXIT]:
        return err_f, err_phi, ST_MAXITER
    return err_f, err_phi, 0


@njit(**STAGE)
def residual_rule_redo(si, full, prev_norm, err_f, err_phi, F, tol_phi):
    """The residual rule needs the iteration matrix at this iterate: full Newton always, modified
    Newton when the contraction was poor (the relative residual fell by less than 4)."""
    if full:
        return True
    if prev_norm >= 0.0 and si[SI_LUVALID] != 0:
        cur = max(err_f / max(F, 1e-300), err_phi / max(tol_phi, 1e-300))
        if cur > 0.25 * prev_norm:
            return True
    return False


@njit(**STAGE)
def factor_matrix(C, P, N, h, sg, ggl, k):
    """Factorize the iteration matrix ``N.AB`` (index 2: with the rows of :func:`ggl_matrix`).

    Returns 0, or ``ST_DIVERGED_SINGULAR`` / ``ST_SINGULAR`` (after k > 0 corrections / at the
    predictor) when a pivot is below ``FP_SINGTOL``.
    """
    ip, fp, si, sf, stats = P
    if ggl:
        call(ggl_matrix, C, N.AB, sg)
    if factor(N.AB, ip, iview2(C, C_ENV), N.ipiv, fp[FP_SINGTOL]) != 0:
        si[SI_LUVALID] = 0
        return ST_DIVERGED_SINGULAR if k > 0 else ST_SINGULAR
    si[SI_LUVALID] = 1
    si[SI_LUFRESH] = 1
    sf[SF_LUH] = h
    stats[NS_FACT] += 1
    return 0


@njit(**STAGE)
def solve_correction(C, P, N, g, c, sr, ggl):
    """The Newton correction into ``N.rhs``: S_t [Δq; Δλ/c (; δη)] = −[c r_q; Φ (; s_r g)] (eq. 8)."""
    ip = P.ip
    nv = ip[IP_NV]
    nc = ip[IP_NC]
    iperm = iview1(C, C_IPERM)
    rhs = N.rhs
    r = N.r
    Phi = N.Phi
    for i in range(nv):
        rhs[iperm[i]] = -c * r[i]
    for j in range(nc):
        rhs[iperm[nv + j]] = -Phi[j]
    if ggl:
        for j in range(nc):
            rhs[iperm[nv + nc + j]] = -sr * g[j]
    solve(N.AB, ip, iview2(C, C_ENV), N.ipiv, rhs)
    P.stats[NS_SOLVE] += 1


@njit(**STAGE)
def newton_end(P, S, x, F, F_ref, eta0, theta_first, carry, ggl):
    """After the accepted iterate: a += (1 − α_f)/(1 − α_m) q̈ (eq. 3, a_base kept in ``x``), the
    force scale, the contraction estimate for the next step and the carry flag."""
    ip, fp, si, sf, stats = P
    ka = (1.0 - fp[FP_AF]) / (1.0 - fp[FP_AM])
    a = S.a
    qdd = S.qdd
    for i in range(ip[IP_NV]):
        a[i] = x[i] + ka * qdd[i]
    if F > F_ref:
        sf[SF_FREF] = F
    if ip[IP_NTEST] != 0 and not ggl:
        newton_rate_end(sf, eta0, theta_first)
    if carry:
        si[SI_CARRY] = 1
    si[SI_HASPREV] = 1

@njit(**INNER)
def predict(C, P, S, x, h, h_prev, lie):
    """The predictor and (3)–(5) of Algorithm 1 (Arnold & Brüls 2007) for it, in place.

    q̈ and λ are guessed (``ip[IP_PRED]``: 0 zero, 1 previous, 2 extrapolated from the last
    two steps, scaled to the step ratio); a, q̇ and q follow from the Newmark formulas
    (rotations: q_n ∘ exp(D), the quaternions p_n saved in C's ``C_PN``). ``x[:nv]`` keeps
    a_base = (α_f q̈_n − α_m a_n)/(1 − α_m) until the step is accepted (eq. (3) needs it).
    """
    ip, fp, si = P.ip, P.fp, P.si
    q, qd, qdd, lam, a, pqdd, plam = S
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


@engine(**SEPARATE)
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
            call(copy_B, G, C, Bw[2])
        call(constraint_B, G, C, t1, q, qd, Bq)
    else:
        call(copy_B, G, C, Bq)
    call(rates, G, C, t1, q, qd, E[2], E[3])
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


@njit(**STAGE)
def apply_correction(C, ip, S, rhs, wq, bp, gp, c, lie, ggl):
    """The solved Newton correction ``rhs`` into the iterate, in place.

    Index 3: q ∘ exp(Δq), q̇ += γ'Δq, q̈ += β'Δq, λ += Δλ/c. Index 2 (``ggl``): q̇ and q̈ from
    δΔ, η += δη, and q ∘ exp(δΔ + B_nᵀδη).

    Returns (max |Δ_i| of the q̇/q̈ increment, max |q_i| of additive entries, max |δq_i|/wq_i,
    max |q̈_i|).
    """
    q, qd, qdd, lam = S.q, S.qd, S.qdd, S.lam
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


@njit(**STAGE)
def correction_test(P, k, jac, carried, m, bp, rates, phi_ratio, theta_prev_bad):
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

    Parameters
    ----------
    m : (float, float, float, float)
        The measures of the correction (:func:`apply_correction`): max |Δ_i|, max |q_i|,
        max |δq_i|/wq_i, max |q̈_i|.
    rates : (float, float)
        η₀ (carried contraction estimate, −1 if none) and the size of the previous correction
        (−1 before the second).

    Returns
    -------
    (action, size, theta)
        ``NT_ACCEPT``, ``NT_ROUNDOFF`` (accepted: the corrections stopped contracting within
        a factor 1e3 of the tolerance, round-off of the linear solve), ``NT_FAIL``,
        ``NT_REFRESH`` (go on with a fresh matrix) or ``NT_CONTINUE``; the size of the
        correction; θ (−1 at the first correction).
    """
    ip, fp = P.ip, P.fp
    dqmax, qmax, dqw, qddmax = m
    eta0, prev_norm = rates
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


@njit(**INNER)
def lie_update(q, C):
    """Rotations of q from the step's start and increment: p = p_n ⊗ exp(D_θ), and T(D_θ).

    For each free rotation b with quaternion at x[xs:xs+4] and rotation vector at
    v[vs:vs+3] (row b of C's array 20 = (xs, vs)): q[xs:xs+4] = p_n ⊗ (cos(φ/2), s7(φ) θ),
    renormalised, θ = D[vs:vs+3], φ = |θ|; C's array 18 [b] = T(θ) = I − s2 θ~ + s3 θ~²
    (Brüls & Cardona 2010; femb/base/rotations.py for the coefficient functions).
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
