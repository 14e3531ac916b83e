"""Stage: error estimate and step-size control.

The local error estimate of the generalized-α scheme, e_q = C_q h² Δq̈ᵖᵖ from the constrained
accelerations q̈ᵖᵖ of two steps ([[M, Bᵀ], [B, 0]] [q̈; λ] = [f; −γ]: :func:`kkt_solve`,
:func:`kkt_estimate`), its weighted norm (:func:`error_norm`), the step-size factor of the controller
(:func:`step_factor`), the re-synchronisation of a and q̇ after a change of h
(:func:`resynchronise`, :func:`project_normal_velocity`) and the Newton weights: docs/stepsize.md
§1–§4.

References
----------
M. Arnold, O. Brüls, Multibody Syst. Dyn. 18 (2007) 185–202 (the scheme's error terms).
E. Hairer, G. Wanner, Solving Ordinary Differential Equations II, 2nd ed., Springer 1996 (step control).
"""

import math

from numba import njit

from femb.base.jit import engine, fview1, iview1, iview2
from femb.engine.layout import (SEPARATE, C_ACTIVE, C_ENV, C_IPERM, C_TFCOEF, C_TFKIND, C_TFOFF, C_W, C_XMAP, ENTRY,
    FP_AF, FP_AM, FP_BETA, FP_CQ, FP_CV, FP_EPUS, FP_ERTOL, FP_L, FP_NEWTC, FP_SCALED, FP_TOLQ, INNER, IP_GGL,
    IP_NC, IP_NN, IP_NV, NS_KKT, NS_REFINE, REFINE_CHECK, REFINE_HGROW, REFINE_SHARE,
    SF_ERRPREV, SF_RCHECKH, SI_LUVALID, SI_NOGROW, SI_PROJ, SI_RCOUNT, SI_RMODE, W_ATOLV, W_BV, W_DU, W_EQ,
    W_EV, W_GAM, W_JN, W_KB, W_KBACC, W_KPIV, W_KPIVACC, W_KR, W_KX, W_LK, W_PT, W_QPP_NEW, W_TGT, W_ZL, W_ZQ)
from femb.engine.link import call
from femb.engine.linalg import (copy_into, factor, solve)
from femb.engine.evaluate import (eval_time_functions, evaluate, jacobian_times, rates)


@engine(**ENTRY)
def kkt_solve(G, C, P, N, W, t, q, qd, K, out):
    """Constrained accelerations q̈ᵖᵖ of [[M, Bᵀ], [B, 0]] [q̈; λ] = [f; −γ] at (t, q, q̇) into ``out``.

    The KKT matrix is factorized into ``K`` = (KB, kpiv) and left there for velocity projections
    at this configuration (:func:`project_normal_velocity`).

    Parameters
    ----------
    G, C, W : pack
        The element batches, the model constants, the loop's work arrays.
    P : Par
    N : NewtonArrays
        ``N.Phi`` is scratch here.
    t : float
    q : ndarray (nx,)
    qd : ndarray (nv,)
    K : (ndarray, ndarray)
        Storage of a factorization (size of ``N.AB``) and its pivots.
    out : ndarray (nv,)

    Returns
    -------
    int
        0, or 1 if the matrix is singular.
    """
    ip = P.ip
    nv = ip[IP_NV]
    nc = ip[IP_NC]
    iperm = iview1(C, C_IPERM)
    KB, kpiv = K
    kr = fview1(W, W_KR)
    kx = fview1(W, W_KX)
    gam = fview1(W, W_GAM)
    Pt = fview1(W, W_PT)
    call(evaluate, G, C, t, (q, qd, fview1(W, W_ZQ), fview1(W, W_ZL)), nv >= 0, (1.0, 0.0, 0.0), (KB, kr, N.Phi))
    if factor(KB, ip, iview2(C, C_ENV), kpiv, 1e-13) != 0:
        return 1
    call(rates, G, C, t, q, qd, Pt, gam)
    for i in range(nv):
        kx[iperm[i]] = -kr[i]                 # r = −f with q̈ = λ = 0
    for j in range(nc):
        kx[iperm[nv + j]] = -gam[j]
    solve(KB, ip, iview2(C, C_ENV), kpiv, kx)
    for i in range(nv):
        out[i] = kx[iperm[i]]
    P.stats[NS_KKT] += 1
    return 0


@engine(**SEPARATE)
def kkt_estimate(G, C, P, S, N, W, t, h, hbar, use_v):
    """q̈ᵖᵖ at the step just taken, for its error estimate (of q; with ``use_v`` of q and q̇), into
    the work array ``qpp_new`` of W.

    With the index-3 step, one correction with the Newton matrix of the step (``N.AB``) replaces
    the factorization of :func:`kkt_solve`. That matrix, S = [[κM + c γ' C_t + c K_t, Bᵀ], [B, 0]]
    (κ = c β', see ``newton_step``), differs from the KKT matrix [[κM, Bᵀ], [B, 0]] by terms of
    order h (damping) and h² (stiffness), so the correction, started from the step's own (q̈, λ),

        S [z; μ] = −[M q̈ − f + Bᵀλ; (B q̈ + γ)/κ],   q̈ += κ z,   λ += μ,

    contracts the error by ρ(S⁻¹E), E = S − KKT (iterative refinement with the factors Newton has
    just computed). It is trusted while a second correction changes the error estimate by at
    most ``REFINE_SHARE`` of the tolerance, checked every ``REFINE_CHECK`` calls and whenever h
    has grown by ``REFINE_HGROW`` since the last check; where that fails (stiff elements at large
    steps) the KKT matrix is factorized (into W's ``KB``, ``kpiv``) until the next check.

    Returns 0, or 1 if the KKT matrix is singular.
    """
    ip, fp, si, sf, stats = P
    out = fview1(W, W_QPP_NEW)
    if ip[IP_GGL] == 0 and si[SI_LUVALID] != 0:
        due = si[SI_RCOUNT] <= 0 or h > REFINE_HGROW * sf[SF_RCHECKH]
        if not due:
            si[SI_RCOUNT] -= 1
        if due or si[SI_RMODE] == 0:
            ncorr = 2 if due else 1
            call(refine_accelerations, G, C, P, S, N, W, t, h, ncorr)
            if not due:
                return 0
            # the second correction's share of the error estimate (stepsize.md §3 with Δq̈ᵖᵖ = du)
            Cq = fp[FP_CQ]
            Cv = fp[FP_CV]
            du = fview1(W, W_DU)
            eq = fview1(W, W_EQ)
            ev = fview1(W, W_EV)
            for i in range(ip[IP_NV]):
                eq[i] = Cq * h * h * du[i]
                ev[i] = Cv * h * h * du[i] / hbar
            share = error_norm(ip, fp, C, W, S.q, S.q, S.qd, S.qd, use_v)
            if use_v and fp[FP_EPUS] != 0.0:
                share /= h
            si[SI_RCOUNT] = REFINE_CHECK
            sf[SF_RCHECKH] = h
            if share <= REFINE_SHARE:
                si[SI_RMODE] = 0
                return 0
            si[SI_RMODE] = 1
    return call(kkt_solve, G, C, P, N, W, t, S.q, S.qd, (fview1(W, W_KB), iview1(W, W_KPIV)), out)


@engine(**SEPARATE)
def refine_accelerations(G, C, P, S, N, W, t, h, ncorr):
    """``ncorr`` corrections of (q̈, λ) = the step's, towards the KKT solution, with the Newton
    matrix of the step (:func:`kkt_estimate`); q̈ into W's ``qpp_new``, the last increment κ z into
    ``du``."""
    ip, fp = P.ip, P.fp
    nv = ip[IP_NV]
    nc = ip[IP_NC]
    iperm = iview1(C, C_IPERM)
    q, qd = S.q, S.qd
    out = fview1(W, W_QPP_NEW)
    kr = fview1(W, W_KR)
    kx = fview1(W, W_KX)
    gam = fview1(W, W_GAM)
    Bu = fview1(W, W_BV)
    du = fview1(W, W_DU)
    lk = fview1(W, W_LK)
    copy_into(out, S.qdd)
    copy_into(lk, S.lam)
    call(rates, G, C, t, q, qd, fview1(W, W_PT), gam)
    if fp[FP_SCALED] != 0.0:
        kappa = (1.0 - fp[FP_AM]) / (1.0 - fp[FP_AF])
    else:
        kappa = (1.0 - fp[FP_AM]) / (h * h * fp[FP_BETA] * (1.0 - fp[FP_AF]))
    active = iview1(C, C_ACTIVE)
    for it in range(ncorr):
        call(evaluate, G, C, t, (q, qd, out, lk), nv < 0, (0.0, 0.0, 0.0), (N.AB, kr, N.Phi))
        call(jacobian_times, G, C, t, q, out, Bu)
        for i in range(nv):
            kx[iperm[i]] = -kr[i]
        for j in range(nc):
            kx[iperm[nv + j]] = -(Bu[j] + gam[j]) / kappa if active[j] != 0 else 0.0
        solve(N.AB, ip, iview2(C, C_ENV), N.ipiv, kx)
        for i in range(nv):
            d = kappa * kx[iperm[i]]
            du[i] = d
            out[i] += d
        for j in range(nc):
            lk[j] += kx[iperm[nv + j]]
    P.stats[NS_REFINE] += ncorr


@engine(**ENTRY)
def project_normal_velocity(G, C, ip, W, t, q, qd, target, K):
    """q̇ ← q̇ + δ with B δ = target − B q̇ and δ M-orthogonal to the constraint manifold.

    Solves [[M, Bᵀ], [B, 0]] [δ; μ] = [0; target − B q̇] with the factorization ``K`` = (KB, kpiv)
    of :func:`kkt_solve` at this configuration (W's ``kx`` and ``Bv`` are scratch).
    """
    KB, kpiv = K
    kx = fview1(W, W_KX)
    Bv = fview1(W, W_BV)
    nv = ip[IP_NV]
    nc = ip[IP_NC]
    iperm = iview1(C, C_IPERM)
    active = iview1(C, C_ACTIVE)
    call(jacobian_times, G, C, t, q, qd, Bv)
    for i in range(nv):
        kx[iperm[i]] = 0.0
    for j in range(nc):
        kx[iperm[nv + j]] = target[j] - Bv[j] if active[j] != 0 else 0.0
    solve(KB, ip, iview2(C, C_ENV), kpiv, kx)
    for i in range(nv):
        qd[i] += kx[iperm[i]]


@njit(**INNER)
def error_norm(ip, fp, C, W, q0, q1, qd0, qd1, use_v):
    """RMS of the local error estimate (W's ``eq``, ``ev``) over q (and q̇) weighted by
    atol + rtol·max(|x_n|, |x_{n+1}|) (W's ``atolv``; stepsize.md §3)."""
    xm = iview1(C, C_XMAP)
    eq = fview1(W, W_EQ)
    ev = fview1(W, W_EV)
    atolv = fview1(W, W_ATOLV)
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


# ---- the parts of the time loop ---------------------------------------------------------------
@engine(**SEPARATE)
def resynchronise(G, C, P, S, N, W, t, h, h_prev):
    """Re-synchronise a and the normal velocity with a new step size (stepsize.md §2), in place.

    a* = a + Δ (h − h_prev) j with Δ = α_m − α_f; index 3: B q̇* = h² C_q B j − Φ_t and, on
    velocity-constraint rows, A q̇* = −a (they hold exactly at every step) (the
    index-2 step keeps B q̇ + Φ_t = 0: no normal velocity to re-synchronise), projected with
    the Newton matrix of the accepted step (``si[SI_PROJ] == 1``) or a KKT factorization at
    the accepted state. Returns 0, or 1 if that KKT matrix is singular.
    """
    ip, fp, si = P.ip, P.fp, P.si
    q, qd, a = S.q, S.qd, S.a
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
    acc = (fview1(W, W_KBACC), iview1(W, W_KPIVACC))
    # Φ_t at t: the time functions at t (Python ones were asked for before the step)
    call(eval_time_functions, t, iview1(C, C_TFKIND), iview1(C, C_TFOFF), fview1(C, C_TFCOEF), N.tfv)
    call(jacobian_times, G, C, t, q, jn, Bv)
    call(rates, G, C, t, q, qd, Pt, fview1(W, W_GAM))
    for j in range(nc):
        tgt[j] = -Pt[j] + h * h * fp[FP_CQ] * Bv[j]
    # velocity-constraint rows (the last nn): the scheme keeps A q̇ + a = 0 exactly, no h² term
    for j in range(nc - ip[IP_NN], nc):
        tgt[j] = -Pt[j]
    if si[SI_PROJ] == 1:
        # the Newton matrix of the accepted step: its constraint rows are B
        call(project_normal_velocity, G, C, ip, W, t, q, qd, tgt, (N.AB, N.ipiv))
        return 0
    if si[SI_PROJ] != 2:
        # no factorization at the accepted state (a trial was rejected): one here
        if call(kkt_solve, G, C, P, N, W, t, q, qd, acc, fview1(W, W_QPP_NEW)) != 0:
            return 1
        si[SI_PROJ] = 2
    call(project_normal_velocity, G, C, ip, W, t, q, qd, tgt, acc)
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
