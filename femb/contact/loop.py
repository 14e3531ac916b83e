"""The time loop of :func:`femb.contact.simulate` compiled: many steps in one numba call.

For models on the dense, compiled path of :class:`femb.contact.step.NonsmoothStep` (constant mass
matrix, at most ``DENSE_MAX_UNKNOWNS`` unknowns, no time functions, no equations removed as
redundant) :func:`run_steps` does what the Python loop of :mod:`femb.contact.simulate` does per
step (``_step``, ``_split_at_impact``, ``_free_flight``, ``_accept``, ``_Recorder``), with the
same algorithm: the step's semismooth Newton iteration (:func:`femb.contact.core.newton_loop`,
called as it is), the impact location of docs/contact.md §1.1, item 2 (free flight to just before the
impact, the impact in a substep of ≤ 3d, the rest), the state advance (eqs. (71), (96), (114) of
Capobianco, Harsch, Eugster & Leine, IJNME 122 (2021)), the contact work, the impact events and
every stored output, written into preallocated arrays.

A (sub)step's solve is the Python one's: semismooth Newton, the prox fixed point of eqs. (144)–(146)
when it fails, Newton again from there. A substep without a solution abandons the innermost split
in progress, which takes its unsplit step (as ``_step`` catches a StepFailure). The call returns to
Python only when a step's own solve finds no solution (the Python loop then takes that step from
the same state and raises its ContactError with the diagnosis), when the event or substep arrays are
full (Python enlarges them and the step is taken again), or at the end.

The substeps of one step are a stack of tasks (h_k, depth_k) run in order from the current state,
which is the order of the recursion of the Python loop: a task either accepts its step, or pushes
the rest of its step after a free flight, or its two substeps around an imminent impact.

Packs (tuples) keep the argument lists short:

* ``P`` (3, L): rows of states; row 0 the current state, 1 a step's solution, 2 a free flight's.
  A row holds, at the offsets ``F`` (index constants ``_T`` … ``_ITS`` below): t, q, u, u̇, ā, λ_N,
  λ_F, λ̄_N, λ̄_F, ġ_N, γ_F, x (eq. (126)), g_N, g̈_N, r_N, r_F (prox parameters at q), P_N, P_F, the
  index sets A–E, the (sub)step's contact work (normal, friction) and Newton iterations, and the sums
  of P_N, Λ_N, P_F, Λ_F over the substeps of the step in progress (what :func:`store` stores);
* ``ctx`` = (F, mdl, lay, fixed_law, work, cst, M⁻¹, scratch): what
  :meth:`NonsmoothStep._dense_setup` built, and ``cst`` = (tol, m_ref, α_m, α_f, β, γ, max_iter,
  freeze_after, h_fixed, vel_tol, gap_tol, locate, max_fixed_point, slip law on P, h_acc);
* ``rec`` = (out, ev_f, ev_u, its, cnt, wsum): the stored steps ``out`` = (t, q, u, u̇, λ_g, g_N, ġ_N,
  λ_N, Λ_N, P_N, state, γ_F, λ_F, Λ_F, P_F, work) (rows = steps), the events (t, step, contact,
  ġ_N⁻, ġ_N⁺, Λ_N, P_N) and (u⁻, u⁺), the Newton iterations per accepted (sub)step, the counters
  (events, substeps) and the contact work so far.
"""
from __future__ import annotations

import math

import numpy as np

from femb.base.jit import borrowed, kernel
from femb.engine.link import call
from femb.contact.batches import evaluate_batches
from femb.contact.core import _direction, _evaluate, fp_stalled, kinematics, newton_loop, prox_parameters, residual
from femb.contact.result import OPEN, SLIP, STICK

#: the fields of a state row, in order (their offsets are ``F[i]:F[i + 1]``)
FIELDS = ("t", "q", "u", "ud", "abar", "lam_N", "lam_F", "lbar_N", "lbar_F", "gNd", "gFd", "x", "gN", "gNdd",
          "rN", "rF", "PN", "PF", "sets", "work", "its", "sum_PN", "sum_LN", "sum_PF", "sum_LF")
(_T, _Q, _U, _UD, _AB, _LN, _LF, _LBN, _LBF, _GND, _GFD, _X, _GN, _GNDD, _RN, _RF, _PN, _PF, _SETS, _WORK,
 _ITS, _SPN, _SLN, _SPF, _SLF) = range(25)
#: splits in progress at most (simulate._step splits up to depth 40)
_MAX_SPLITS = 48
#: (sub)steps done; no solution found (the Python loop takes the step); arrays full
DONE, PYTHON, FULL = 0, 1, 2


def offsets(nqx, n, nc_x, k, l):
    """The offsets F (26,) of the fields of a state row for nqx configuration entries, n velocities,
    nc_x unknowns x, k normal and l tangent rows."""
    sizes = (1, nqx, n, n, n, k, l, k, l, k, l, nc_x, k, k, k, l, k, l, 5 * k, 2, 2, k, k, l, l)
    return np.concatenate(([0], np.cumsum(sizes))).astype(np.int64)


@kernel(allocates=True)
def first_root(a, b, c, lo, hi, closed):
    """The smallest real root r of a r² + b r + c = 0 with lo < r < hi (lo ≤ r ≤ hi if ``closed``); NaN if none.

    The roots by the cancellation-free form r₁ = q/a, r₂ = c/q, q = −(b + sign(b)√(b² − 4ac))/2
    (Press et al., Numerical Recipes, §5.6); a linear equation when a = 0.
    """
    r1 = np.nan
    r2 = np.nan
    if a != 0.0:
        if c == 0.0:
            r1, r2 = 0.0, -b / a
        else:
            disc = b * b - 4.0 * a * c
            if disc >= 0.0:
                qq = -0.5 * (b + math.copysign(math.sqrt(disc), b))
                r1, r2 = qq / a, c / qq
    elif b != 0.0:
        r1 = -c / b
    best = np.nan
    for r in (r1, r2):
        inside = (lo <= r <= hi) if closed else (lo < r < hi)
        if inside and not r >= best:
            best = r
    return best


@kernel(allocates=True)
def _field(row, F, i):
    return row[F[i]:F[i + 1]]


@kernel(allocates=True)
def _newton(P, si, x, h, zf, ctx, on_P):
    """The compiled semismooth Newton iteration (femb.contact.core.newton_loop) of a (sub)step of size h from
    row si, from and into x; with contact unknowns held at zf when zf is not empty (the fixed point's inner
    problem, eq. (145)); the slip law on P_F, P_N when ``on_P`` is 1 (NonsmoothStep.slip_on_P). Returns (converged, iterations); the work arrays hold the last iterate's values."""
    F, mdl, lay, fixed_law, work, cst, Minv, scr = ctx
    s = P[si]
    st = (_field(s, F, _Q), _field(s, F, _U), _field(s, F, _UD), _field(s, F, _AB), _field(s, F, _LN),
          _field(s, F, _LF), _field(s, F, _LBN), _field(s, F, _LBF))
    law = (_field(s, F, _RN), _field(s, F, _RF), fixed_law[0], fixed_law[1], fixed_law[2], fixed_law[3])
    am, af, beta, gamma = cst[2], cst[3], cst[4], cst[5]
    c = (1.0 - af) / (1.0 - am)
    par = np.array([h, cst[0], h * h * beta * c, h * gamma * c, cst[1], 0.0, am, af, beta, gamma, s[F[_T]] + h,
                    cst[6], cst[7], 1.0 if zf.size else 0.0, on_P, cst[14]])
    wk = work + ((_field(s, F, _GND), _field(s, F, _GFD)), zf)
    status, it, err = call(newton_loop, x, mdl, st, law, lay, par, wk)
    return status == 0, it


@kernel(allocates=True)
def _solve(P, si, ri, h, ctx):
    """One (sub)step of size h from row ``si`` into row ``ri`` (NonsmoothStep.solve): semismooth Newton, the
    prox fixed point if it fails, Newton again from where the fixed point got to; the three again with the
    slip law on P if all fail. Returns True when one of them converged (False: the Python loop takes the
    step and raises its StepFailure)."""
    F, work, cst, Minv = ctx[0], ctx[4], ctx[5], ctx[6]
    s, r = P[si], P[ri]
    x = _field(r, F, _X)
    ok = False
    it = 0
    method = 0.0
    for k in range(1 if cst[13] != 0.0 else 2):     # femb's slip law first, then the paper's (once if it is set)
        on_P = cst[13] if k == 0 else 1.0
        x[:] = _field(s, F, _X)
        ok, it1 = _newton(P, si, x, h, ctx[7][0], ctx, on_P)
        it += it1
        method = 2.0 * k                # newton (0), fixed point (1), the second pass on P (2)
        if ok:
            break
        x[:] = _field(s, F, _X)
        ok, it1 = call(_fixed_point, P, si, x, h, ctx, on_P)
        it += it1
        method = 2.0 if k == 1 else 1.0
        if not ok and np.all(np.isfinite(x)):
            ok, it1 = _newton(P, si, x, h, ctx[7][0], ctx, on_P)
            it += it1
        if ok:
            break
    if not ok:
        return False
    _store_solution(s, r, F, work, s[F[_T]] + h, it)
    r[F[_ITS] + 1] = method
    prox_parameters(work[5][4], work[5][5], Minv, _field(r, F, _RN), _field(r, F, _RF))
    return True


@kernel(allocates=True)
def _fixed_point(P, si, x, h, ctx, on_P):
    """The prox fixed point of eqs. (144)–(146) (NonsmoothStep.fixed_point) from and into x. Returns
    (converged, iterations); on convergence the work arrays hold the model and residual at x."""
    F, work, cst = ctx[0], ctx[4], ctx[5]
    o = work[0]
    s = P[si]
    k, l = o[7] - o[6], o[11] - o[10]
    m_ref, tol = cst[1], cst[0]
    ha = max(h, cst[14])                       # the acceleration rows as in core._scale
    ha2 = ha * ha
    sc = np.concatenate((np.full(k, 1.0 / m_ref), np.full(k, h / m_ref), np.full(k, ha2 / m_ref),
                         np.full(l, h / m_ref), np.full(l, ha2 / m_ref)))
    z = x[o[6]:].copy()
    z1 = np.zeros(z.size)
    rN, rF = _field(s, F, _RN), _field(s, F, _RF)
    track = np.array([np.inf, 0.0, 0.0])          # core.fp_stalled: smaller r for the rest of this step
    ok, its, exhausted = False, int(cst[12]), True
    for it in range(1, int(cst[12]) + 1):
        x[o[6]:] = z
        ok, _ = _newton(P, si, x, h, z, ctx, on_P)
        if not ok:
            its, exhausted = it, False
            break
        call(_prox_update, P, si, x, h, ctx, z1, on_P)
        err = 0.0
        for a in range(z.size):
            err = max(err, abs(z1[a] - z[a]) * sc[a])
        z[:] = z1
        if err <= tol:
            x[o[6]:] = z
            call(_evaluate_at, P, si, x, h, ctx, on_P)
            ok, its, exhausted = True, it, False
            break
        if fp_stalled(err, track):
            rN *= 0.5
            rF *= 0.5
    if exhausted:                                # no convergence in cst[12] iterations
        ok = False
        x[o[6]:] = z
    scale = 2.0 ** track[2]                      # r as it was (halving is exact)
    rN *= scale
    rF *= scale
    return ok, its


@kernel(allocates=True)
def _evaluate_at(P, si, x, h, ctx, on_P):
    """Kinematics, model and residual (index sets from the iterate) at x (NonsmoothStep._dense_evaluate)."""
    F, mdl, lay, fixed_law, work, cst = ctx[0], ctx[1], ctx[2], ctx[3], ctx[4], ctx[5]
    o, cmp, kout, out, dq, mq, mv, sets = work[0], work[1], work[2], work[3], work[4], work[5], work[6], work[9]
    s = P[si]
    st = (_field(s, F, _Q), _field(s, F, _U), _field(s, F, _UD), _field(s, F, _AB), _field(s, F, _LN),
          _field(s, F, _LF), _field(s, F, _LBN), _field(s, F, _LBF))
    am, af, beta, gamma = cst[2], cst[3], cst[4], cst[5]
    c = (1.0 - af) / (1.0 - am)
    kinematics(x, o, st, np.array([h, am, af, beta, gamma]), cmp, kout)
    _evaluate(x, o, mdl, s[F[_T]] + h, kout, dq)
    law = (_field(s, F, _RN), _field(s, F, _RF), fixed_law[0], fixed_law[1], fixed_law[2], fixed_law[3])
    kin = (kout[1], kout[5], kout[6], kout[7], _field(s, F, _GND), _field(s, F, _GFD))
    rp = np.array([h, cst[0], h * h * beta * c, h * gamma * c, cst[1], 0.0, on_P, cst[14]])
    residual(x, o, mq, mv, kin, law, lay, rp, sets, out)


@kernel(allocates=True)
def _prox_update(P, si, x, h, ctx, z1, on_P):
    """The proximal update z ↦ p(y, z) of eq. (146), eqs. (128)–(140) in turn (NonsmoothStep.prox_update),
    into z1 = (κ_N, Λ_N, λ_N, Λ_F, λ_F)."""
    F, lay, fixed_law, work, cst = ctx[0], ctx[2], ctx[3], ctx[4], ctx[5]
    o, kout, out, mv = work[0], work[2], work[3], work[6]
    s = P[si]
    call(_evaluate_at, P, si, x, h, ctx, on_P)
    rN, gN, kNh, PN0, xiN, gNdd = _field(s, F, _RN), mv[4], kout[6], kout[5], out[3], out[4]
    k, l = rN.size, o[11] - o[10]
    kN, LN, lN, LF, lF = z1[:k], z1[k:2 * k], z1[2 * k:3 * k], z1[3 * k:3 * k + l], z1[3 * k + l:]
    A = np.zeros(k, dtype=np.bool_)
    PN = np.zeros(k)
    for i in range(k):
        kN[i] = max(kNh[i] - rN[i] * gN[i], 0.0)                                   # (128)
        A[i] = rN[i] * gN[i] - kNh[i] <= 0.0
        PN[i] = max(PN0[i] - rN[i] * xiN[i], 0.0) if A[i] else 0.0                  # (131)
        B = A[i] and rN[i] * xiN[i] - PN0[i] <= 0.0
        lN[i] = max(x[o[8] + i] - rN[i] * gNdd[i], 0.0) if B else 0.0              # (134)
    slip = _prox_friction(s, x, ctx, (A, PN, lN), LF, lF)
    am, af, b, g = cst[2], cst[3], cst[4], cst[5]
    lN0, lbN0 = _field(s, F, _LN), _field(s, F, _LBN)
    for i in range(k):
        lbN = (af * lN0[i] + (1 - af) * lN[i] - am * lbN0[i]) / (1 - am)
        LN[i] = PN[i] - h * ((1 - g) * lbN0[i] + g * lbN)                          # (95)
        kN[i] = kN[i] - h * h * ((0.5 - b) * lbN0[i] + b * lbN)                    # (102)
    lF0, lbF0 = _field(s, F, _LF), _field(s, F, _LBF)
    for j in range(l):
        lbF = (af * lF0[j] + (1 - af) * lF[j] - am * lbF0[j]) / (1 - am)
        LF[j] = LF[j] - h * ((1 - g) * lbF0[j] + g * lbF)                          # (113), LF held P_F
    mu, fptr, fidx, xiF = fixed_law[0], lay[1], lay[2], out[6]
    for i in range(k):                                   # slip: Λ_F from Λ_N (friction_rows)
        if fptr[i + 1] > fptr[i] and slip[i] and on_P == 0.0:
            idx = fidx[fptr[i]:fptr[i + 1]]
            v, _ = _direction(xiF[idx])
            for a in range(idx.size):
                LF[idx[a]] = -mu[i] * LN[i] * v[a]


@kernel(allocates=True)
def _prox_friction(s, x, ctx, normal, PF, lF):
    """P_F (137) and λ_F (139), (140) per contact into PF, lF; returns which contacts slip (140b)."""
    F, lay, fixed_law, work = ctx[0], ctx[2], ctx[3], ctx[4]
    o, kout, out = work[0], work[2], work[3]
    A, PN, lN = normal
    mu, fptr, fidx = fixed_law[0], lay[1], lay[2]
    rF, PF0, xiF, gF, gFdd = _field(s, F, _RF), kout[7], out[6], out[5], out[7]
    PF[:] = 0.0
    lF[:] = 0.0
    slip = np.zeros(A.size, dtype=np.bool_)
    for i in range(A.size):
        if fptr[i + 1] == fptr[i] or not A[i]:
            continue
        idx = fidx[fptr[i]:fptr[i + 1]]
        arg = PF0[idx] - rF[idx] * xiF[idx]
        _prox_disc_into(arg, mu[i] * PN[i], PF, idx)
        if np.sqrt(np.sum(arg * arg)) <= mu[i] * PN[i]:
            lj = np.empty(idx.size)
            for a in range(idx.size):
                lj[a] = x[o[10] + idx[a]] - rF[idx[a]] * gFdd[idx[a]]
            _prox_disc_into(lj, mu[i] * lN[i], lF, idx)
        else:
            v, _ = _direction(gF[idx])
            for a in range(idx.size):
                lF[idx[a]] = -mu[i] * lN[i] * v[a]
            slip[i] = True
    return slip


@kernel(allocates=True)
def _prox_disc_into(v, radius, out, idx):
    """out[idx] = prox of v onto the disc of the radius (femb.contact.prox.prox_disc)."""
    nv = np.sqrt(np.sum(v * v))
    f = 1.0 if nv <= radius else radius / nv
    for a in range(idx.size):
        out[idx[a]] = f * v[a] if f != 1.0 else v[a]


@kernel(allocates=True)
def _store_solution(s, r, F, work, t1, it):
    """Row r from the converged iterate in the work arrays (NonsmoothStep._dense_result, _advance) and the
    contact work ½(ġ_N,n + ġ_N,n+1)·P_N, ½(γ_F,n + γ_F,n+1)·P_F of the (sub)step (simulate._accept)."""
    o, kout, out, mv, sets = work[0], work[2], work[3], work[6], work[9]
    x = _field(r, F, _X)
    r[F[_T]] = t1
    for i, a in ((_Q, 0), (_U, 1), (_AB, 2), (_LBN, 3), (_LBF, 4), (_PN, 5), (_PF, 7)):
        _field(r, F, i)[:] = kout[a]
    _field(r, F, _UD)[:] = x[o[0]:o[1]]
    _field(r, F, _LN)[:] = x[o[8]:o[9]]
    _field(r, F, _LF)[:] = x[o[10]:o[11]]
    _field(r, F, _GND)[:] = out[2]
    _field(r, F, _GFD)[:] = out[5]
    _field(r, F, _GNDD)[:] = out[4]
    _field(r, F, _GN)[:] = mv[4]
    k = sets.shape[1]
    for j in range(5):
        for i in range(k):
            r[F[_SETS] + j * k + i] = sets[j, i]
    for j, (v0, v1, p) in enumerate(((_field(s, F, _GND), out[2], kout[5]), (_field(s, F, _GFD), out[5], kout[7]))):
        w = 0.0                                    # ½(v_n + v_{n+1})·p, v = ġ_N or γ_F with W at each end
        for i in range(p.size):
            w += 0.5 * (v0[i] + v1[i]) * p[i]
        r[F[_WORK] + j] = w
    r[F[_ITS]] = it


@kernel(allocates=True)
def _free_gNdd(s, ctx, gdd):
    """g̈_N at the state row s without the forces of the contacts open or moving there (g_N > gap_tol or
    abs(ġ_N) > vel_tol), the others' λ_N, λ_F at t_n kept, bilateral constraints kept (simulate._free_gNdd):
    M u̇ + Φ_qᵀλ = f + W_Nᵀλ_N + W_Fᵀλ_F, Φ_q u̇ = −γ, then g̈_N = W_N u̇ + ζ_N."""
    F, mdl, lay, fixed_law, work, cst, Minv, scr = ctx
    recs, qx, ux, f0, removed = mdl
    o, mq, mv, dq = work[0], work[5], work[6], work[4]
    q, u, x = _field(s, F, _Q), _field(s, F, _U), _field(s, F, _X)
    qx[:q.size] = q
    ux[:u.size] = u
    mult = (x[o[5]:o[6]], x[o[8]:o[9]], x[o[10]:o[11]])
    evaluate_batches(recs, s[F[_T]], qx, ux, mult, False, dq, f0, removed)
    M, B, WN, WF = mq[0], mq[3], mq[4], mq[5]
    n, m = M.shape[0], B.shape[0]
    lN, lF = _field(s, F, _LN).copy(), _field(s, F, _LF).copy()
    gap_tol, vel_tol = cst[10], cst[9]
    fptr, fidx = lay[1], lay[2]
    for i in range(lN.size):
        if s[F[_GN] + i] > gap_tol or abs(s[F[_GND] + i]) > vel_tol:
            lN[i] = 0.0
            for a in range(fptr[i], fptr[i + 1]):
                lF[fidx[a]] = 0.0
    K = np.zeros((n + m, n + m))
    K[:n, :n] = M
    K[n:, :n] = B
    K[:n, n:] = B.T
    rhs = np.concatenate((mv[0] + WN.T @ lN + WF.T @ lF, -mv[3]))
    ud = np.linalg.solve(K, rhs)[:n]
    gdd[:] = WN @ ud + mv[5]


@kernel(allocates=True)
def _impact_time(P, si, ri, H, ctx):
    """Earliest τ ∈ [0, H) at which an open contact closes in the (sub)step from row si solved into row ri
    (simulate._impact_time); NaN if none."""
    F, cst = ctx[0], ctx[5]
    gap_tol, vel_tol = cst[10], cst[9]
    s, r = P[si], P[ri]
    k = F[_GN + 1] - F[_GN]
    gdd = _field(s, F, _GNDD)
    loaded, cand = False, False
    for i in range(k):
        if s[F[_GN] + i] > gap_tol or abs(s[F[_GND] + i]) > vel_tol:
            cand = cand or r[F[_SETS] + i] != 0.0
            loaded = loaded or s[F[_LN] + i] != 0.0
    if cand and loaded:     # an open or moving contact carries a force at t_n: g̈ without those forces
        gdd = ctx[7][1]
        _free_gNdd(s, ctx, gdd)
    best = np.nan
    d = 1e-4 * cst[8]
    for i in range(k):
        g, gd = s[F[_GN] + i], s[F[_GND] + i]
        if not (r[F[_SETS] + i] != 0.0 and (g > gap_tol or abs(gd) > vel_tol)):
            continue
        tau = first_root(0.5 * gdd[i], gd, g, 0.0, H, False)
        v = gd + gdd[i] * tau                      # ġ_N at the impact
        if np.isnan(tau) and g <= gap_tol and gd < -vel_tol:     # touching and approaching, g ≤ 0: now
            tau, v = 0.0, gd
        if np.isnan(tau) and g - r[F[_GN] + i] > 0.0:
            tau = H * g / (g - r[F[_GN] + i])
            v = (r[F[_GN] + i] - g) / H
        if not np.isnan(tau):
            tau = max(tau - margin(v, d, cst[0]) + 1e-3 * d, 0.0)
        if not np.isnan(tau) and not tau >= best:
            best = tau
    return best


@kernel
def margin(v, d, tol):
    """How long before an impact at the speed v the free flight ends (simulate._impact_time): 1e-3 d, or
    the time in which the gap closes by 2 tol where that is longer (a slow approach: a free flight that
    ends with its gap within the Newton tolerance closes the contact, eq. (130)), at most d/2."""
    if v == 0.0:
        return 0.5 * d
    return min(max(1e-3 * d, 2.0 * tol / abs(v)), 0.5 * d)


@kernel(allocates=True)
def _free_flight(P, tau, ctx):
    """A step of size ≤ tau from row 0 into row 2 after which the contacts open at row 0 are still open,
    halved up to 8 times (simulate._free_flight). Returns (converged, its size or NaN)."""
    F, cst = ctx[0], ctx[5]
    gap_tol, vel_tol = cst[10], cst[9]
    s, r = P[0], P[2]
    k = F[_GN + 1] - F[_GN]
    for _ in range(8):
        if not call(_solve, P, 0, 2, tau, ctx):
            return False, np.nan
        closes = False
        for i in range(k):
            was_open = s[F[_GN] + i] > gap_tol or s[F[_GND] + i] > vel_tol
            closes = closes or (was_open and r[F[_SETS] + i] != 0.0)
        if not closes:
            return True, tau
        tau *= 0.5
    return True, np.nan


@kernel(allocates=True)
def _accept(P, ri, n, ctx, rec):
    """Book the (sub)step solved into row ri from row 0 (simulate._accept): iterations, contact work,
    impacts; row 0 becomes its solution. Returns False when the event or substep arrays are full."""
    F, cst = ctx[0], ctx[5]
    vel_tol = cst[9]
    ev_f, ev_u, its, cnt, wsum = rec[1], rec[2], rec[3], rec[4], rec[5]
    s, r = P[0], P[ri]
    if cnt[1] >= its.size:
        return False
    its[cnt[1]] = int(r[F[_ITS]])
    cnt[1] += 1
    cnt[2] += int(r[F[_ITS] + 1] == 1.0)        # fixed point (1), slip law on P (2)
    cnt[3] += int(r[F[_ITS] + 1] == 2.0)
    wsum[0] += r[F[_WORK]]
    wsum[1] += r[F[_WORK] + 1]
    k = F[_GN + 1] - F[_GN]
    o = ctx[4][0]
    for i in range(k):
        A, B, C = r[F[_SETS] + i], r[F[_SETS] + k + i], r[F[_SETS] + 2 * k + i]
        closed = A != 0.0 and (B != 0.0 or C != 0.0)
        if not (s[F[_GND] + i] < -vel_tol and r[F[_GND] + i] - s[F[_GND] + i] > vel_tol and closed
                and r[F[_PN] + i] > 0.0):
            continue
        if cnt[0] >= ev_f.shape[0]:
            return False
        dt = r[F[_T]] - s[F[_T]]
        tau = first_root(0.5 * s[F[_GNDD] + i], s[F[_GND] + i], max(s[F[_GN] + i], 0.0), 0.0, dt, True)
        e = cnt[0]
        ev_f[e, 0] = r[F[_T]] if np.isnan(tau) else s[F[_T]] + tau
        ev_f[e, 1], ev_f[e, 2] = n, i
        ev_f[e, 3], ev_f[e, 4] = s[F[_GND] + i], r[F[_GND] + i]
        ev_f[e, 5], ev_f[e, 6] = r[F[_X] + o[7] + i], r[F[_PN] + i]
        ev_u[e, 0, :] = _field(s, F, _U)
        ev_u[e, 1, :] = _field(r, F, _U)
        cnt[0] += 1
    x = _field(r, F, _X)
    for i, a, j in ((_SPN, _PN, -1), (_SLN, -1, 7), (_SPF, _PF, -1), (_SLF, -1, 9)):
        dst, prev = _field(r, F, i), _field(s, F, i)     # the step's sums of the (sub)steps' impulses
        add = _field(r, F, a) if a >= 0 else x[o[j]:o[j + 1]]
        for p in range(dst.size):
            dst[p] = prev[p] + add[p]
    P[0, :] = P[ri]
    return True


@kernel(allocates=True)
def _task(P, h, depth, ctx, stack):
    """One task of a step (simulate._step): solve from row 0 over h; accept (returns 0), or push the rest
    after a free flight (1, row 2 to accept) or the two substeps around an imminent impact (2).
    Returns -1 when its solve found no solution (a free flight without one: the unsplit step, 0).
    ``stack`` = (hs, depths, top (1,))."""
    cst = ctx[5]
    if not call(_solve, P, 0, 1, h, ctx):
        return -1
    d = 1e-4 * cst[8]
    tau = np.nan
    if cst[11] != 0.0 and depth < 40 and h > 3 * d:
        tau = call(_impact_time, P, 0, 1, h, ctx)
    if np.isnan(tau):
        return 0
    hs, ds, top = stack
    if tau > 2 * d:
        ok, h1 = call(_free_flight, P, tau - 1e-3 * d, ctx)
        if not ok:                      # no solution in the free flight: the unsplit step (simulate._step)
            return 0
        if not np.isnan(h1):
            hs[top[0]], ds[top[0]] = h - h1, depth + 1
            top[0] += 1
            return 1
    first = min(tau + d, 0.5 * h)
    hs[top[0]], ds[top[0]] = h - first, depth + 1
    hs[top[0] + 1], ds[top[0] + 1] = first, depth + 1
    top[0] += 2
    return 2


@kernel(allocates=True)
def _one_step(P, h, n, ctx, rec, fr):
    """Step n of size h from row 0 (simulate._step, its substeps as a stack of tasks). Returns DONE,
    PYTHON or FULL; row 0 holds the state at its end (with its last (sub)step's solution).

    ``fr`` = (rows, counters, tops, count): a frame per split task in progress, with its start state and
    unsplit solution, the counters and the work sum at the split, and the task-stack position of its
    substeps. A substep without a solution abandons the innermost split in progress, which takes its
    unsplit step instead (the StepFailure handler of simulate._step); without a split in progress the
    Python loop takes the step."""
    SV, FC, FT, nf = fr
    cnt, wsum = rec[4], rec[5]
    hs, ds, top = np.zeros(128), np.zeros(128, dtype=np.int64), np.zeros(1, dtype=np.int64)
    hs[0], ds[0], top[0] = h, 0, 1
    nf[0] = 0
    while top[0] > 0:
        top[0] -= 1
        while nf[0] > 0 and FT[nf[0] - 1] > top[0]:         # splits whose substeps are all done
            nf[0] -= 1
        t0 = top[0]
        kind = call(_task, P, hs[t0], ds[t0], ctx, (hs, ds, top))
        ri = 2 if kind == 1 else 1
        if kind < 0:
            if nf[0] == 0:
                return PYTHON
            nf[0] -= 1
            f = nf[0]
            P[0, :] = SV[2 * f]
            P[1, :] = SV[2 * f + 1]
            cnt[0], cnt[1], cnt[2], cnt[3] = int(FC[f, 0]), int(FC[f, 1]), int(FC[f, 2]), int(FC[f, 5])
            wsum[0], wsum[1] = FC[f, 3], FC[f, 4]
            top[0] = FT[f]
        elif kind > 0:                                       # a split: its frame before anything is booked
            f = nf[0]
            SV[2 * f, :] = P[0]
            SV[2 * f + 1, :] = P[1]
            FC[f, 0], FC[f, 1], FC[f, 2], FC[f, 3], FC[f, 4] = cnt[0], cnt[1], cnt[2], wsum[0], wsum[1]
            FC[f, 5] = cnt[3]
            FT[f] = t0
            nf[0] += 1
            if kind == 2:                                    # two substeps pushed, nothing to accept yet
                continue
        if not _accept(P, ri, n, ctx, rec):
            return FULL
    return DONE


@kernel(allocates=True)
def store(P, n, ctx, rec):
    """Row n of the stored steps from row 0 (simulate._Recorder.store, simulate._states)."""
    F, lay, cst, o = ctx[0], ctx[2], ctx[5], ctx[4][0]
    t, q, u, ud, lam, gN, gNd, lN, LN, PN, state, gF, lF, LF, PF, work = rec[0]
    s = P[0]
    x = _field(s, F, _X)
    t[n] = s[F[_T]]
    q[n] = _field(s, F, _Q)
    u[n] = _field(s, F, _U)
    ud[n] = _field(s, F, _UD)
    lam[n] = x[o[5]:o[6]]
    gN[n] = _field(s, F, _GN)
    gNd[n] = _field(s, F, _GND)
    lN[n] = x[o[8]:o[9]]
    LN[n] = _field(s, F, _SLN)           # the impulses summed over the step's substeps
    PN[n] = _field(s, F, _SPN)
    gF[n] = _field(s, F, _GFD)
    lF[n] = x[o[10]:o[11]]
    LF[n] = _field(s, F, _SLF)
    PF[n] = _field(s, F, _SPF)
    work[n] = rec[5]
    k = gN.shape[1]
    fptr, fidx = lay[1], lay[2]
    for i in range(k):
        A, B, C = s[F[_SETS] + i], s[F[_SETS] + k + i], s[F[_SETS] + 2 * k + i]
        state[n, i] = OPEN
        if A != 0.0 and (B != 0.0 or C != 0.0):
            v = 0.0
            for p in range(fptr[i], fptr[i + 1]):
                v += s[F[_GFD] + fidx[p]] ** 2
            state[n, i] = SLIP if fptr[i + 1] > fptr[i] and np.sqrt(v) > cst[9] else STICK


@kernel(allocates=True)
def run_steps(P, h, n0, n1, ctx, rec):
    """Steps n0 … n1 of size h from row 0, each stored (:func:`store`). Returns (status, n): DONE and n1 + 1,
    or PYTHON / FULL and the step n not taken (the counters and the work sum as at its start)."""
    # the arguments are the caller's until the call returns: their arrays pass through the stages without
    # reference counts (femb.base.jit.borrowed)
    P, ctx, rec = borrowed(P), borrowed(ctx), borrowed(rec)
    cnt, wsum = rec[4], rec[5]
    fr = (np.zeros((2 * _MAX_SPLITS, P.shape[1])), np.zeros((_MAX_SPLITS, 6)), np.zeros(_MAX_SPLITS, dtype=np.int64),
          np.zeros(1, dtype=np.int64))
    for n in range(n0, n1 + 1):
        c0, c1, c2, c3, w0, w1 = cnt[0], cnt[1], cnt[2], cnt[3], wsum[0], wsum[1]
        save = P[0].copy()
        P[0, ctx[0][_SPN]:] = 0.0                   # the step's sums of its substeps' impulses (the last fields)
        status = call(_one_step, P, h, n, ctx, rec, fr)
        if status != DONE:
            cnt[0], cnt[1], cnt[2], cnt[3], wsum[0], wsum[1] = c0, c1, c2, c3, w0, w1
            P[0, :] = save
            return status, n
        call(store, P, n, ctx, rec)
    return DONE, n1 + 1


# ---- the stages called by symbol: their argument types from run_steps', their return types -------
def stage_signatures(sig):
    """``{stage: argument types}`` of the stages that :func:`run_steps` reaches by symbol
    (``femb.engine.link.call``), from run_steps' own argument types ``sig`` = (P, h, n0, n1, ctx,
    rec): what the engine's parallel build (:mod:`femb.engine.parallel`) compiles each on its own.
    ``tests/test_contact_loop.py`` checks them against the stages compiled in one process."""
    from numba import types as T
    P, f, i = sig[0], T.float64, T.int64
    ctx, rec = sig[4], sig[5]
    f1, i1, f2 = T.float64[::1], T.int64[::1], T.float64[:, ::1]
    mdl, lay, fixed_law, work = ctx.types[1], ctx.types[2], ctx.types[3], ctx.types[4]
    law = T.Tuple((f1, f1) + tuple(fixed_law.types[:4]))
    wk = T.Tuple(tuple(work.types) + (T.UniTuple(f1, 2), f1))
    return {
        _one_step: (P, f, i, ctx, rec, T.Tuple((f2, f2, i1, i1))),
        store: (P, i, ctx, rec),
        _task: (P, f, i, ctx, T.Tuple((f1, i1, i1))),
        _solve: (P, i, i, f, ctx),
        _impact_time: (P, i, i, f, ctx),
        _free_flight: (P, f, ctx),
        _fixed_point: (P, i, f1, f, ctx, f),
        _prox_update: (P, i, f1, f, ctx, f1, f),
        _evaluate_at: (P, i, f1, f, ctx, f),
        newton_loop: (f1, mdl, T.UniTuple(f1, 8), law, lay, f1, wk),
    }


#: CPU seconds that each stage took to compile in a build worker, with the units listed before it in
#: its worker (2-core test machine, numba 0.68, the ball's loop, 2026-11-28): for the split between
#: workers (femb.engine.parallel.split)
BUILD_COST = {"newton_loop": 45.6, "_evaluate_at": 34.4, "_impact_time": 29.5, "_solve": 12.3,
              "_prox_update": 8.9, "run_steps": 8.2, "_one_step": 8.2, "store": 6.1, "_fixed_point": 4.7,
              "_task": 2.4, "_free_flight": 2.4}
#: stages that share most of their code (the kinematics, the batches' evaluation, the residual: 35 s
#: of CPU compiled twice when apart): one worker compiles them
BUILD_TOGETHER = (("newton_loop", "_evaluate_at"),)


def build_plan(sig):
    """What the parallel build compiles for :func:`run_steps` with argument types ``sig``: the units
    ``{run_steps: sig, stage: argument types, ...}``, their costs and the groups kept together."""
    return {run_steps: tuple(sig), **stage_signatures(sig)}, BUILD_COST, BUILD_TOGETHER


def _declare_returns():
    """The return type of every stage called by symbol (femb.engine.link.declare)."""
    from numba import types as T
    from femb.engine.link import declare
    for disp, restype in ((_one_step, T.int64), (store, T.none), (_task, T.int64), (_solve, T.boolean),
                          (_impact_time, T.float64), (_free_flight, T.Tuple((T.boolean, T.float64))),
                          (_fixed_point, T.Tuple((T.boolean, T.int64))), (_prox_update, T.none),
                          (_evaluate_at, T.none), (newton_loop, T.Tuple((T.int64, T.int64, T.float64)))):
        declare(disp, restype)


_declare_returns()
