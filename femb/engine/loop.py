"""Stage: the time loop: chunks of accepted steps, fixed or adaptive.

:func:`run` advances up to a requested number of accepted steps: the Newton step
(:func:`femb.engine.newton.newton_step`), the error estimate and the step-size control
(:mod:`femb.engine.control`), rejection and retry, and the storage of every ``ip[IP_STRIDE]``-th
state into the caller's buffers. It returns a status code (``ST_*``); Python raises femb's errors.
"""

from numba import njit

from femb.jit import (engine, fview1, iview1)
from femb.engine.layout import (C_TFCOEF, C_TFKIND, C_TFOFF, C_XMAP, ENTRY, FP_CQ, FP_CV, FP_EPUS, FP_H,
    FP_HMAX, FP_HMIN, FP_KEXP, FP_T0, FP_TEND, FP_WARN, INNER, IP_CHECK, IP_GGL, IP_MODE, IP_NC, IP_NSTEPS,
    IP_NV, IP_PYTF, IP_STORE, IP_STRIDE, KKT_EST_Q, KKT_EST_QV, NS_STEPS, SF_ERRMAX, SF_ERRMAX_T, SF_FREF,
    SF_FREF_S, SF_HNEXT, SF_HPREV, SF_T, SF_TFTIME, SF_WARN_ERR, SF_WARN_T, SI_CARRY, SI_HASPREV,
    SI_HASPREV_S, SI_HAVEJ, SI_LASTFAIL, SI_LUFRESH, SI_NFAIL, SI_NOGROW, SI_PROJ, SI_REJECTED, SI_RMODE,
    SI_SAVED, SI_STEP, SI_STORED, ST_CHUNK, ST_DONE, ST_HMIN, ST_KKT_SINGULAR, ST_NEED_TF, W_ATOLV, W_A_S,
    W_EQ, W_EV, W_JN, W_JNEW, W_KB, W_KBACC, W_KPIV, W_KPIVACC, W_LAM_S, W_PLAM_S, W_PQDD_S, W_QDD_S, W_QD_S,
    W_QPP, W_QPP_NEW, W_Q_S, W_WQ)
from femb.engine.linalg import copy_into
from femb.engine.evaluate import eval_time_functions
from femb.engine.newton import newton_step
from femb.engine.control import (error_norm, kkt_accelerations, newton_weights, resynchronise, step_factor)


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
