"""Stage: the time loop: chunks of accepted steps, fixed or adaptive.

:func:`run` advances up to a requested number of accepted steps: the Newton step
(:func:`femb.engine.newton.newton_step`), the error estimate and the step-size control
(:mod:`femb.engine.control`), rejection and retry, and the storage of every ``ip[IP_STRIDE]``-th
state into the caller's buffers. It returns a status code (``ST_*``); Python raises femb's errors.
"""

from numba import njit

from femb.base.jit import engine, fview1, iview1
from femb.engine.layout import (STAGE, C_TFCOEF, C_TFKIND, C_TFOFF, ENTRY, FP_CQ, FP_CV, FP_EPUS, FP_H, FP_HMAX,
    FP_HMIN, FP_KEXP, FP_T0, FP_TEND, FP_WARN, INNER, IP_CHECK, IP_GGL, IP_MODE, IP_NC, IP_NSTEPS, IP_NV,
    IP_PYTF, IP_STORE, IP_STRIDE, NS_STEPS, SF_ERRMAX, SF_ERRMAX_T, SF_FREF, SF_FREF_S, SF_HNEXT, SF_HPREV,
    SF_T, SF_TFTIME, SF_WARN_ERR, SF_WARN_T, SI_CARRY, SI_HASPREV, SI_HASPREV_S, SI_HAVEJ, SI_LASTFAIL,
    SI_LUFRESH, SI_NFAIL, SI_NOGROW, SI_PROJ, SI_REJECTED, SI_RMODE, SI_SAVED, SI_STEP, SI_STORED, ST_CHUNK,
    ST_DONE, ST_GO, ST_HMIN, ST_KKT_SINGULAR, ST_NEED_TF, W_ATOLV, W_A_S, W_EQ, W_EV, W_JN, W_JNEW, W_KB,
    W_KBACC, W_KPIV, W_KPIVACC, W_LAM_S, W_PLAM_S, W_PQDD_S, W_QDD_S, W_QD_S, W_QPP, W_QPP_NEW, W_Q_S, W_WQ)
from femb.engine.link import call
from femb.engine.evaluate import eval_time_functions
from femb.engine.linalg import copy_into
from femb.engine.newton import newton_step
from femb.engine.control import (error_norm, kkt_estimate, newton_weights, resynchronise, step_factor)


@engine(**ENTRY)
def run(G, C, W, P, S, N, O, n_chunk):
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

    Every state written into ``O`` is an accepted step (with stride); ``O.h``, ``O.it``,
    ``O.err`` record every accepted step. Returns a status code (ST_*); ``si[SI_STORED]``
    counts the states written.

    Parameters
    ----------
    G, C, W : pack
        The element batches, the model constants and the loop's work arrays (W_FIELDS).
    P : Par
        ``ip``, ``fp``, ``si``, ``sf``, ``stats``.
    S : StepState
        The state, advanced in place.
    N : NewtonArrays
        Newton's arrays; ``N.info`` reports a failure (t, ...).
    O : Out
        The chunk's buffers (``n_chunk`` rows each).
    n_chunk : int
    """
    ip, fp, si, sf, stats = P
    adaptive = ip[IP_MODE] == 1
    info = N.info
    si[SI_STORED] = 0
    done = 0
    while done < n_chunk:
        n = si[SI_STEP] + 1
        t = sf[SF_T]
        status, h, t1 = step_size(ip, fp, sf, info, n, t, adaptive)
        if status != ST_GO:
            return status
        h_prev = sf[SF_HPREV]
        status = begin_trial(G, C, P, S, N, W, t, t1, h, adaptive)
        if status != ST_GO:
            return status
        newton_weights(C, fp, S.q, fview1(W, W_ATOLV), adaptive, fview1(W, W_WQ))
        k = call(newton_step, G, C, P, S, N, t1, h, h_prev if h_prev > 0.0 else h, fview1(W, W_WQ))
        if k < 0:
            if not adaptive:
                return k
            # Newton failed: retry from the accepted state with h/4, no growth next step
            back_to_accepted(si, sf, S, W)
            si[SI_NFAIL] += 1
            si[SI_LASTFAIL] = k
            si[SI_NOGROW] = 1
            sf[SF_HNEXT] = 0.25 * h
            continue
        # ---- local error estimate (stepsize.md §3)
        if adaptive:
            status, err = adaptive_error(G, C, P, S, N, W, t1, h, h_prev)
        else:
            status, err = fixed_step_check(G, C, P, S, N, W, n, t1, h)
        if status != ST_GO:
            info[0] = t1
            return status
        if adaptive and not accept_adaptive(P, S, W, t1, h, err):
            continue
        sf[SF_HPREV] = h
        sf[SF_T] = t1
        si[SI_STEP] = n
        stats[NS_STEPS] += 1
        if record_step(ip, fp, si, S, O, done, n, t1, h, (k, err, adaptive)):
            return ST_DONE
        done += 1
    return ST_CHUNK


@njit(**STAGE)
def step_size(ip, fp, sf, info, n, t, adaptive):
    """The next step: (``ST_GO``, h, t_{n+1}), or (``ST_DONE``, ...) at the end, or (``ST_HMIN``,
    ...) with ``info`` = (t, h) when an adaptive step falls below ``FP_HMIN``.

    Adaptive steps end on t_end: the last step is stretched by up to 5 %, and a remainder of less
    than two steps is split in two halves."""
    if not adaptive:
        if n > ip[IP_NSTEPS]:
            return ST_DONE, 0.0, t
        h = fp[FP_H]
        return ST_GO, h, fp[FP_T0] + n * h
    t_end = fp[FP_TEND]
    if t >= t_end:
        return ST_DONE, 0.0, t
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
        return ST_HMIN, h, t
    return ST_GO, h, (t_end if last else t + h)


@njit(**STAGE)
def begin_trial(G, C, P, S, N, W, t, t1, h, adaptive):
    """Before a trial step t → t1: save the accepted state (adaptive), re-synchronise a and q̇
    after a change of h, and the time functions at t1. Returns ``ST_GO``, or ``ST_NEED_TF``
    (Python time functions needed at ``info[0]``) or ``ST_KKT_SINGULAR``."""
    ip, fp, si, sf, stats = P
    info = N.info
    h_prev = sf[SF_HPREV]
    if (adaptive and si[SI_SAVED] == 0 and ip[IP_PYTF] != 0 and sf[SF_TFTIME] != t and h != h_prev
            and si[SI_HAVEJ] != 0 and ip[IP_NC] > 0 and ip[IP_GGL] == 0):
        # the re-synchronisation below needs Φ_t at t: Python time functions are asked for first
        info[0] = t
        return ST_NEED_TF
    if adaptive and si[SI_SAVED] == 0:
        # save the accepted state: a rejected or failed trial restarts from it
        save_state(S, W)
        si[SI_HASPREV_S] = si[SI_HASPREV]
        sf[SF_FREF_S] = sf[SF_FREF]
        if h != h_prev and si[SI_HAVEJ] != 0:
            if call(resynchronise, G, C, P, S, N, W, t, h, h_prev) != 0:
                info[0] = t
                return ST_KKT_SINGULAR
        si[SI_SAVED] = 1
    if ip[IP_PYTF] != 0:
        if sf[SF_TFTIME] != t1:
            info[0] = t1
            return ST_NEED_TF
    call(eval_time_functions, t1, iview1(C, C_TFKIND), iview1(C, C_TFOFF), fview1(C, C_TFCOEF), N.tfv)
    if adaptive:
        si[SI_SAVED] = 0
    return ST_GO


@njit(**STAGE)
def adaptive_error(G, C, P, S, N, W, t1, h, h_prev):
    """The local error estimate of an adaptive step (stepsize.md §3): e_q = C_q h² Δq̈ᵖᵖ,
    e_v = C_v h³ Δj / h̄, its weighted RMS norm (per unit step with ``FP_EPUS``).

    Returns (``ST_GO``, err) or (``ST_KKT_SINGULAR``, −1)."""
    ip, fp = P.ip, P.fp
    nv = ip[IP_NV]
    Cq = fp[FP_CQ]
    Cv = fp[FP_CV]
    hbar = 0.5 * (h + (h_prev if h_prev > 0.0 else h))
    if call(kkt_estimate, G, C, P, S, N, W, t1, h, hbar, nv >= 0) != 0:
        return ST_KKT_SINGULAR, -1.0
    qpp = fview1(W, W_QPP)
    qpp_new = fview1(W, W_QPP_NEW)
    jn = fview1(W, W_JN)
    jnew = fview1(W, W_JNEW)
    eq = fview1(W, W_EQ)
    ev = fview1(W, W_EV)
    for i in range(nv):
        jnew[i] = (qpp_new[i] - qpp[i]) / h
        eq[i] = Cq * h * h * (qpp_new[i] - qpp[i])
        ev[i] = Cv * h * h * h * (jnew[i] - jn[i]) / hbar
    err = error_norm(ip, fp, C, W, fview1(W, W_Q_S), S.q, fview1(W, W_QD_S), S.qd, nv >= 0)
    if fp[FP_EPUS] != 0.0:
        err /= h
    return ST_GO, err


@njit(**STAGE)
def fixed_step_check(G, C, P, S, N, W, n, t1, h):
    """Fixed steps: q̈ᵖᵖ at two consecutive steps every ``IP_CHECK`` steps, e_q only, per step
    (the threshold of stepsize.md §9); the largest estimate and the first one above ``FP_WARN``
    are kept in ``sf``. Returns (``ST_GO``, err or −1 when not checked) or
    (``ST_KKT_SINGULAR``, −1)."""
    ip, fp, si, sf, stats = P
    err = -1.0
    if ip[IP_CHECK] <= 1:
        return ST_GO, err
    nv = ip[IP_NV]
    phase = n % ip[IP_CHECK]
    if not (phase == 0 or (phase == 1 and si[SI_HAVEJ] != 0)):
        return ST_GO, err
    if call(kkt_estimate, G, C, P, S, N, W, t1, h, h, nv < 0) != 0:
        return ST_KKT_SINGULAR, err
    qpp = fview1(W, W_QPP)
    qpp_new = fview1(W, W_QPP_NEW)
    if phase == 0:
        copy_into(qpp, qpp_new)
        si[SI_HAVEJ] = 1
        return ST_GO, err
    Cq = fp[FP_CQ]
    eq = fview1(W, W_EQ)
    for i in range(nv):
        eq[i] = Cq * h * h * (qpp_new[i] - qpp[i])
    err = error_norm(ip, fp, C, W, S.q, S.q, S.qd, S.qd, nv < 0)
    si[SI_HAVEJ] = 0
    if err > sf[SF_ERRMAX]:
        sf[SF_ERRMAX] = err
        sf[SF_ERRMAX_T] = t1
    if err > fp[FP_WARN] and not (sf[SF_WARN_T] == sf[SF_WARN_T]):
        sf[SF_WARN_T] = t1
        sf[SF_WARN_ERR] = err
    return ST_GO, err


@njit(**STAGE)
def accept_adaptive(P, S, W, t1, h, err):
    """Accept or reject an adaptive step by its error estimate; the next step size (PI
    controller, or a smaller retry from the accepted state). Returns True when accepted."""
    ip, fp, si, sf, stats = P
    kexp = fp[FP_KEXP]
    if err > 1.0:
        # rejected: back to the accepted state with a smaller step
        back_to_accepted(si, sf, S, W)
        si[SI_REJECTED] += 1
        si[SI_NOGROW] = 1
        sf[SF_HNEXT] = h * max(0.2, 0.9 * err ** (-1.0 / kexp))
        return False
    # accepted: next step size (PI controller)
    sf[SF_HNEXT] = h * step_factor(si, sf, err, kexp)
    if si[SI_RMODE] == 0 and ip[IP_GGL] == 0:
        # projections at the next step change use the Newton matrix if it was built in this
        # step (its constraint rows are B there); a matrix carried from earlier steps is not
        si[SI_PROJ] = 1 if si[SI_LUFRESH] != 0 else 0
    else:
        copy_into(fview1(W, W_KBACC), fview1(W, W_KB))
        copy_into(iview1(W, W_KPIVACC), iview1(W, W_KPIV))
        si[SI_PROJ] = 2
    copy_into(fview1(W, W_QPP), fview1(W, W_QPP_NEW))
    copy_into(fview1(W, W_JN), fview1(W, W_JNEW))
    if err > sf[SF_ERRMAX]:
        sf[SF_ERRMAX] = err
        sf[SF_ERRMAX_T] = t1
    return True


@njit(**STAGE)
def record_step(ip, fp, si, S, O, done, n, t1, h, rec):
    """Row ``done`` of the per-step records (h, Newton iterations, error estimate: ``rec``, with the
    adaptive flag), and the state into the next stored row every ``IP_STRIDE`` steps and at the
    end. Returns True at the final step."""
    k, err, adaptive = rec
    O.h[done] = h
    O.it[done] = k
    O.err[done] = err
    t_end = fp[FP_TEND]
    final = (t1 >= t_end) if adaptive else (n == ip[IP_NSTEPS])
    if (ip[IP_STORE] != 0 and n % ip[IP_STRIDE] == 0) or final:
        m = si[SI_STORED]
        O.t[m] = t_end if final else t1
        store_state(m, S, O)
        si[SI_STORED] = m + 1
    return final


@njit(**STAGE)
def save_state(S, W):
    """The accepted state into work arrays 0 to 6 of W (a rejected trial restarts from it)."""
    copy_into(fview1(W, W_Q_S), S.q)
    copy_into(fview1(W, W_QD_S), S.qd)
    copy_into(fview1(W, W_QDD_S), S.qdd)
    copy_into(fview1(W, W_LAM_S), S.lam)
    copy_into(fview1(W, W_A_S), S.a)
    copy_into(fview1(W, W_PQDD_S), S.pqdd)
    copy_into(fview1(W, W_PLAM_S), S.plam)


@njit(**STAGE)
def back_to_accepted(si, sf, S, W):
    """After a rejected or failed trial: the accepted state, its predictor history and force
    scale; the Newton matrix of the accepted step is gone."""
    restore_state(S, W)
    si[SI_HASPREV] = si[SI_HASPREV_S]
    sf[SF_FREF] = sf[SF_FREF_S]
    si[SI_CARRY] = 0
    if si[SI_PROJ] == 1:
        si[SI_PROJ] = 0


@njit(**STAGE)
def store_state(m, S, O):
    """Row m of the output buffers = the current state."""
    copy_into(O.q[m], S.q)
    copy_into(O.qd[m], S.qd)
    copy_into(O.qdd[m], S.qdd)
    copy_into(O.lam[m], S.lam)


@njit(**STAGE)
def restore_state(S, W):
    """Back to the accepted state saved at the start of the trial step (work arrays 0 to 6 of W)."""
    copy_into(S.q, fview1(W, W_Q_S))
    copy_into(S.qd, fview1(W, W_QD_S))
    copy_into(S.qdd, fview1(W, W_QDD_S))
    copy_into(S.lam, fview1(W, W_LAM_S))
    copy_into(S.a, fview1(W, W_A_S))
    copy_into(S.pqdd, fview1(W, W_PQDD_S))
    copy_into(S.plam, fview1(W, W_PLAM_S))
