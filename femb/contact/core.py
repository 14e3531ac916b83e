"""The compiled inner iteration of the nonsmooth step for small (dense) systems.

One semismooth Newton iteration of :class:`femb.contact.step.NonsmoothStep` needs, once the
model's quantities are evaluated (:class:`femb.contact.dense.DenseModel`): the contact
velocities and accelerations, the index sets, the residual R of eq. (127) of Capobianco, Harsch,
Eugster & Leine (IJNME 122, 2021) with its row weights, and — when R is not yet small — its
Jacobian and the Newton increment. These are the functions here, compiled with numba: they
compute, entry by entry, what ``NonsmoothStep.evaluate``, ``index_sets``, ``smooth_rows``,
``friction_rows``, ``scale``, ``jacobian`` and ``newton_increment`` compute with numpy (see their
docstrings and docs/contact.md §1 for the equations; the module docstring of
:mod:`femb.contact.step` for the unknowns' order).

Packs (tuples of arrays) keep the argument lists short:

* ``o`` (12,) int: the offsets of the 11 blocks of x = (u̇, U, Q, κ_g, Λ_g, λ_g, κ_N, Λ_N, λ_N, Λ_F, λ_F);
* ``mq`` = (M, K1, C1, Φ_q, W_N, W_F), 2-D; ``mv`` = (f, Φ, Φ_t, γ, g_N, ζ_N, ζ_F), 1-D
  (:class:`femb.contact.dense.DenseModel`);
* ``kin`` = (u, P_N, κ̂_N, P_F, ġ_N⁻, γ_F⁻) of the iterate and the step's start;
* ``law`` = (r_N, r_F, μ, e_N, e_F per tangent row, force weights w) and ``lay`` = (owner of each
  tangent row, fptr, fidx: the tangent rows of contact i are fidx[fptr[i]:fptr[i + 1]]);
* ``par`` = (h, tol, c_q, c_u, m_ref, frozen, slip law on P): the last nonzero puts the slip law (138b)
  on the whole percussions P_F, P_N (the paper's), zero on their impulsive parts Λ_F, Λ_N (femb's,
  docs/contact.md §1.1 item 5);
* ``der`` = (ġ_N, ξ_N, g̈_N, γ_F, ξ_F, γ̇_F), written by :func:`residual`;
* ``sets`` (5, nN) int8: the index sets A, B, C, D, E (written unless frozen).
"""
from __future__ import annotations

import numpy as np

from femb.base.jit import kernel
from femb.base.rotations import quat_exp_into, quat_mul_into
from femb.contact.batches import evaluate_batches

#: The start guess (the previous step's unknowns) is the step's solution without a Newton update only
#: if it solves the step to this fraction of the tolerance; an iterate after an update, to the
#: tolerance. Taken at the tolerance, a guess keeps a leftover percussion of a contact that has
#: opened (within tol of its row) step after step: a constant spurious force of order tol m/h²
#: (docs/contact.md §1.1, item 7; measured there).
GUESS_TOL = 1e-6
#: the shortest damped Newton step (a fraction of the full one; :func:`damp_step`)
MIN_DAMPING = 1.0 / 64.0
#: The prox fixed point halves its parameters r (for the rest of the step's fixed point) when its change
#: has not reached a new least value for FP_STALL iterations, at most FP_HALVINGS times. r = 1/(W M⁻¹ Wᵀ)_ii
#: (Studer 2009) converges for contacts that do not share a body; several contacts on one body (the four
#: corners of a box on a plate) couple their rows, the Jacobi-type iteration then needs r below
#: 2/λ_max(diag(r) W M⁻¹ Wᵀ)·r and oscillates without settling (docs/contact.md §1.1, item 12).
FP_STALL = 20
FP_HALVINGS = 4


@kernel
def fp_stalled(err, track):
    """The stall rule of the prox fixed points (the step's in both loops and the start's): ``track`` (3,) =
    (least change so far, iterations since it, halvings of r so far), updated with this iteration's change
    ``err``. True when r is to be halved now (FP_STALL iterations without a new least change, at most
    FP_HALVINGS times); ``2 ** track[2]`` restores r."""
    if err < track[0]:
        track[0] = err
        track[1] = 0.0
        return False
    track[1] += 1.0
    if track[1] >= FP_STALL and track[2] < FP_HALVINGS:
        track[0] = err
        track[1] = 0.0
        track[2] += 1.0
        return True
    return False


@kernel(allocates=True)
def _direction(v):
    """(v/|v|, (I − v̂v̂ᵀ)/|v|), and (v, I) for v = 0 (femb.contact.prox.direction)."""
    p = v.size
    nv = np.sqrt(np.sum(v * v))
    D = np.eye(p)
    if nv == 0.0:
        return v.copy(), D
    vh = v / nv
    for a in range(p):
        for b in range(p):
            D[a, b] = (D[a, b] - vh[a] * vh[b]) / nv
    return vh, D


@kernel(allocates=True)
def _gemv(A, v, y, alpha, trans):
    """y += alpha A v (``trans``: alpha Aᵀ v), by loops: BLAS calls on the few-row matrices of a contact step
    cost more in call and temporary-array overhead than the products themselves."""
    if trans:
        for i in range(A.shape[0]):
            c = alpha * v[i]
            if c != 0.0:
                for j in range(A.shape[1]):
                    y[j] += c * A[i, j]
    else:
        for i in range(A.shape[0]):
            acc = 0.0
            for j in range(A.shape[1]):
                acc += A[i, j] * v[j]
            y[i] += alpha * acc


@kernel(allocates=True)
def _derived(x, o, mq, mv, kin, law, lay, der):
    """ġ_N = W_N u, ξ_N = ġ_N + e_N min(ġ_N⁻, 0), g̈_N = W_N u̇ + ζ_N, γ_F = W_F u, ξ_F = γ_F + e_F γ_F⁻
    (at impacts, ġ_N⁻ < 0), γ̇_F = W_F u̇ + ζ_F."""
    WN, WF = mq[4], mq[5]
    zN, zF = mv[5], mv[6]
    u, gNd_m, gFd_m = kin[0], kin[4], kin[5]
    e_N, e_F, owner = law[3], law[4], lay[0]
    ud = x[o[0]:o[1]]
    gNd, xiN, gNdd, gF, xiF, gFdd = der
    gNd[:] = 0.0
    _gemv(WN, u, gNd, 1.0, False)
    gNdd[:] = zN
    _gemv(WN, ud, gNdd, 1.0, False)
    for i in range(gNd.size):
        xiN[i] = gNd[i] + e_N[i] * min(gNd_m[i], 0.0)
    gF[:] = 0.0
    _gemv(WF, u, gF, 1.0, False)
    gFdd[:] = zF
    _gemv(WF, ud, gFdd, 1.0, False)
    for j in range(gF.size):
        xiF[j] = gF[j] + (e_F[j] * gFd_m[j] if gNd_m[owner[j]] < 0.0 else 0.0)


@kernel(allocates=True)
def _index_sets(x, o, mv, kin, law, lay, par, der, sets):
    """A, B, C, D, E (eqs. (130), (133), (136), (139), (141)), the Newton tolerance as slack."""
    gN = mv[4]
    PN, kNh, PF = kin[1], kin[2], kin[3]
    rN, rF, mu = law[0], law[1], law[2]
    fptr, fidx = lay[1], lay[2]
    h, tol = par[0], par[1]
    gNd, xiN, gNdd, gF, xiF, gFdd = der
    lN, lF = x[o[8]:o[9]], x[o[10]:o[11]]
    for i in range(gN.size):
        A = gN[i] - kNh[i] / rN[i] <= tol
        B = A and h * (xiN[i] - PN[i] / rN[i]) <= tol
        C = B and h * h * (gNdd[i] - lN[i] / rN[i]) <= tol
        D = False
        E = False
        if A and fptr[i + 1] > fptr[i]:
            s1 = 0.0
            s2 = 0.0
            for p in range(fptr[i], fptr[i + 1]):
                j = fidx[p]
                s1 += (rF[j] * xiF[j] - PF[j]) ** 2
                s2 += (rF[j] * gFdd[j] - lF[j]) ** 2
            D = np.sqrt(s1) <= mu[i] * PN[i]
            E = D and np.sqrt(s2) <= mu[i] * lN[i]
        sets[0, i], sets[1, i], sets[2, i], sets[3, i], sets[4, i] = A, B, C, D, E


@kernel(allocates=True)
def _smooth_rows(x, o, mq, mv, kin, par, R):
    """R_s of eq. (127): the three dynamic rows and Φ, Φ_q u + Φ_t, Φ_q u̇ + γ."""
    M, B, WN, WF = mq[0], mq[3], mq[4], mq[5]
    f, Phi, Phi_t, gam = mv[0], mv[1], mv[2], mv[3]
    u, h = kin[0], par[0]
    ud, U, Q = x[o[0]:o[1]], x[o[1]:o[2]], x[o[2]:o[3]]
    kg, Lg, lg = x[o[3]:o[4]], x[o[4]:o[5]], x[o[5]:o[6]]
    kN, LN, lN, LF, lF = x[o[6]:o[7]], x[o[7]:o[8]], x[o[8]:o[9]], x[o[9]:o[10]], x[o[10]:o[11]]
    for r, y, lam_g, lam_N, lam_F, fF in ((0, ud, lg, lN, lF, 1.0), (1, U, Lg, LN, LF, 1.0),
                                          (2, Q, kg, kN, LF, 0.5 * h)):
        Rr = R[o[r]:o[r + 1]]
        Rr[:] = 0.0
        _gemv(M, y, Rr, 1.0, False)
        if r == 0:
            Rr -= f
        _gemv(B, lam_g, Rr, 1.0, True)
        _gemv(WN, lam_N, Rr, -1.0, True)
        _gemv(WF, lam_F, Rr, -fF, True)
    R[o[3]:o[4]] = Phi
    R[o[4]:o[5]] = Phi_t
    _gemv(B, u, R[o[4]:o[5]], 1.0, False)
    R[o[5]:o[6]] = gam
    _gemv(B, ud, R[o[5]:o[6]], 1.0, False)


@kernel(allocates=True)
def _contact_rows(x, o, mv, kin, law, lay, par, der, sets, R):
    """The normal rows (129), (132), (135) and the friction rows (138), (142) on the index sets (the slip
    row (138b) on Λ_F, Λ_N, or on P_F, P_N with ``par[6]``)."""
    gN = mv[4]
    PN, kNh, PF = kin[1], kin[2], kin[3]
    mu, fptr, fidx = law[2], lay[1], lay[2]
    gNd, xiN, gNdd, gF, xiF, gFdd = der
    LN, lN, LF, lF = x[o[7]:o[8]], x[o[8]:o[9]], x[o[9]:o[10]], x[o[10]:o[11]]
    k = gN.size
    for i in range(k):
        R[o[6] + i] = gN[i] if sets[0, i] else kNh[i]
        R[o[7] + i] = xiN[i] if sets[1, i] else PN[i]
        R[o[8] + i] = gNdd[i] if sets[2, i] else lN[i]
    R[o[9]:o[10]] = PF
    R[o[10]:o[11]] = lF
    for i in range(k):
        if fptr[i + 1] == fptr[i] or not sets[0, i]:
            continue
        idx = fidx[fptr[i]:fptr[i + 1]]
        if sets[3, i]:
            for j in idx:
                R[o[9] + j] = xiF[j]
            if sets[4, i]:
                for j in idx:
                    R[o[10] + j] = gFdd[j]
            else:
                v, _ = _direction(gFdd[idx])
                for a in range(idx.size):
                    R[o[10] + idx[a]] = lF[idx[a]] + mu[i] * lN[i] * v[a]
        else:
            v, _ = _direction(xiF[idx])
            w, _ = _direction(gF[idx])
            on_P = par[6] != 0.0
            for a in range(idx.size):
                if on_P:
                    R[o[9] + idx[a]] = PF[idx[a]] + mu[i] * PN[i] * v[a]
                else:
                    R[o[9] + idx[a]] = LF[idx[a]] + mu[i] * LN[i] * v[a]
                R[o[10] + idx[a]] = lF[idx[a]] + mu[i] * lN[i] * w[a]


@kernel(allocates=True)
def _scale(o, law, lay, par, sets, S):
    """Row weights that turn every row of R into a length (NonsmoothStep.scale); the acceleration-level rows
    with max(h, h_acc)² (``par[7]``, NonsmoothStep.h_acc: 0 in fixed-step runs, the first step in adaptive
    ones, whose error estimate needs u̇ solved on short steps too; docs/contact.md §1.2)."""
    h, m = par[0], par[4]
    ha = max(h, par[7])
    ha2 = ha * ha
    w, fptr, fidx = law[5], lay[1], lay[2]
    n = o[1] - o[0]
    for a in range(n):
        S[o[0] + a] = ha2 * w[a] / m
        S[o[1] + a] = h * w[a] / m
        S[o[2] + a] = w[a] / m
    S[o[3]:o[4]] = 1.0
    S[o[4]:o[5]] = h
    S[o[5]:o[6]] = ha2
    k = o[7] - o[6]
    for i in range(k):
        S[o[6] + i] = 1.0 if sets[0, i] else 1.0 / m
        S[o[7] + i] = h if sets[1, i] else h / m
        S[o[8] + i] = ha2 if sets[2, i] else ha2 / m
    S[o[9]:o[10]] = h / m
    S[o[10]:o[11]] = ha2 / m
    for i in range(k):
        for p in range(fptr[i], fptr[i + 1]):
            j = fidx[p]
            if sets[3, i]:
                S[o[9] + j] = h
            if sets[4, i]:
                S[o[10] + j] = ha2


@kernel(allocates=True)
def residual(x, o, mq, mv, kin, law, lay, par, sets, out):
    """Contact velocities, index sets (unless ``par[5]``, frozen), residual R and row weights S.

    ``out`` = (R, S, ġ_N, ξ_N, g̈_N, γ_F, ξ_F, γ̇_F). Returns max |S R| (0 for an empty system).
    """
    R, S = out[0], out[1]
    der = (out[2], out[3], out[4], out[5], out[6], out[7])
    _derived(x, o, mq, mv, kin, law, lay, der)
    if par[5] == 0.0:
        _index_sets(x, o, mv, kin, law, lay, par, der, sets)
    _smooth_rows(x, o, mq, mv, kin, par, R)
    _contact_rows(x, o, mv, kin, law, lay, par, der, sets, R)
    _scale(o, law, lay, par, sets, S)
    err = 0.0
    for a in range(R.size):
        e = abs(S[a] * R[a])
        if not e <= err:            # NaN propagates
            err = e
    if _undefined_gap(mv):          # no solution here, even where that contact is open
        err = np.nan
    return err


@kernel(allocates=True)
def _undefined_gap(mv):
    """Whether a gap g_N (``mv[4]``) is not a number: a contact kernel could not define its geometry at
    this iterate (e.g. a sphere pair whose centres coincide, femb.elements.contact.SpatialSpherePair)."""
    gN = mv[4]
    for i in range(gN.size):
        if not np.isfinite(gN[i]):
            return True
    return False


@kernel(allocates=True)
def _put(J, r0, c0, blk, fac):
    for a in range(blk.shape[0]):
        for b in range(blk.shape[1]):
            J[r0 + a, c0 + b] += fac * blk[a, b]


@kernel(allocates=True)
def _put_t(J, r0, c0, blk, fac):
    for a in range(blk.shape[1]):
        for b in range(blk.shape[0]):
            J[r0 + a, c0 + b] += fac * blk[b, a]


@kernel(allocates=True)
def _smooth_jacobian(o, mq, par, J):
    """Rows 0–5 of ∂R/∂x (NonsmoothStep.jacobian)."""
    M, K1, C1, B, WN, WF = mq
    h, cq, cu = par[0], par[2], par[3]
    _put(J, o[0], o[0], M, 1.0)
    _put(J, o[0], o[0], K1, cq)
    _put(J, o[0], o[0], C1, cu)
    _put(J, o[0], o[1], C1, 1.0)
    _put(J, o[0], o[2], K1, 1.0)
    _put_t(J, o[0], o[5], B, 1.0)
    _put_t(J, o[0], o[8], WN, -1.0)
    _put_t(J, o[0], o[10], WF, -1.0)
    _put(J, o[1], o[1], M, 1.0)
    _put_t(J, o[1], o[4], B, 1.0)
    _put_t(J, o[1], o[7], WN, -1.0)
    _put_t(J, o[1], o[9], WF, -1.0)
    _put(J, o[2], o[2], M, 1.0)
    _put_t(J, o[2], o[3], B, 1.0)
    _put_t(J, o[2], o[6], WN, -1.0)
    _put_t(J, o[2], o[9], WF, -0.5 * h)
    _put(J, o[3], o[0], B, cq)
    _put(J, o[3], o[2], B, 1.0)
    _put(J, o[4], o[0], B, cu)
    _put(J, o[4], o[1], B, 1.0)
    _put(J, o[5], o[0], B, 1.0)


@kernel(allocates=True)
def _normal_jacobian(o, mq, par, sets, J):
    """Rows of the normal contact laws (129), (132), (135) on the sets A, B, C."""
    WN = mq[4]
    cq, cu = par[2], par[3]
    n = o[1] - o[0]
    for i in range(o[7] - o[6]):
        r6, r7, r8 = o[6] + i, o[7] + i, o[8] + i
        if sets[0, i]:
            for a in range(n):
                J[r6, o[0] + a] = cq * WN[i, a]
                J[r6, o[2] + a] = WN[i, a]
        else:
            J[r6, o[6] + i] = 1.0
            J[r6, o[8] + i] = cq
        if sets[1, i]:
            for a in range(n):
                J[r7, o[0] + a] = cu * WN[i, a]
                J[r7, o[1] + a] = WN[i, a]
        else:
            J[r7, o[7] + i] = 1.0
            J[r7, o[8] + i] = cu
        if sets[2, i]:
            for a in range(n):
                J[r8, o[0] + a] = WN[i, a]
        else:
            J[r8, o[8] + i] = 1.0


@kernel(allocates=True)
def _friction_jacobian(x, o, mq, kin, law, lay, par, der, sets, J):
    """Rows of the friction laws (138), (142) (NonsmoothStep.friction_rows' derivative blocks)."""
    WF = mq[5]
    PN = kin[1]
    mu, fptr, fidx = law[2], lay[1], lay[2]
    cu = par[3]
    gNd, xiN, gNdd, gF, xiF, gFdd = der
    LN, lN = x[o[7]:o[8]], x[o[8]:o[9]]
    n = o[1] - o[0]
    for j in range(o[10] - o[9]):                  # open or frictionless: P_F = 0, λ_F = 0
        J[o[9] + j, o[9] + j] = 1.0
        J[o[9] + j, o[10] + j] = cu
        J[o[10] + j, o[10] + j] = 1.0
    for i in range(o[7] - o[6]):
        if fptr[i + 1] == fptr[i] or not sets[0, i]:
            continue
        idx = fidx[fptr[i]:fptr[i + 1]]
        p = idx.size
        if sets[3, i]:                             # stick at percussion level (138a)
            for a in range(p):
                r9 = o[9] + idx[a]
                J[r9, o[9] + idx[a]] = 0.0
                J[r9, o[10] + idx[a]] = 0.0
                for c in range(n):
                    J[r9, o[0] + c] = cu * WF[idx[a], c]
                    J[r9, o[1] + c] = WF[idx[a], c]
            if sets[4, i]:                         # (142a)
                for a in range(p):
                    r10 = o[10] + idx[a]
                    J[r10, o[10] + idx[a]] = 0.0
                    for c in range(n):
                        J[r10, o[0] + c] = WF[idx[a], c]
            else:                                  # (142b)
                v, dv = _direction(gFdd[idx])
                _slip_block(J, o[10] + idx, o[0], mu[i] * lN[i] * dv, WF[idx], 1.0)
                for a in range(p):
                    J[o[10] + idx[a], o[8] + i] = mu[i] * v[a]
        else:                                      # slip (138b) on Λ (or on P: par[6]), (142c)
            on_P = par[6] != 0.0
            Ns = PN[i] if on_P else LN[i]
            v, dv = _direction(xiF[idx])
            _slip_block(J, o[9] + idx, o[0], mu[i] * Ns * dv, WF[idx], cu)
            _slip_block(J, o[9] + idx, o[1], mu[i] * Ns * dv, WF[idx], 1.0)
            w, dw = _direction(gF[idx])
            _slip_block(J, o[10] + idx, o[0], mu[i] * lN[i] * dw, WF[idx], cu)
            _slip_block(J, o[10] + idx, o[1], mu[i] * lN[i] * dw, WF[idx], 1.0)
            for a in range(p):
                J[o[9] + idx[a], o[7] + i] = mu[i] * v[a]
                if on_P:                           # P_N, P_F hold cu λ_N, cu λ_F
                    J[o[9] + idx[a], o[8] + i] = cu * mu[i] * v[a]
                else:
                    J[o[9] + idx[a], o[10] + idx[a]] = 0.0
                J[o[10] + idx[a], o[8] + i] = mu[i] * w[a]


@kernel(allocates=True)
def friction_blocks(z, ev, mu, lay, sets, on_P, out):
    """The friction rows (138), (142) and the values of their derivative blocks, contact by contact, for
    the Python step (:meth:`femb.contact.step.NonsmoothStep.friction_rows`, which assembles them into its
    sparse or dense Jacobian; the compiled iteration writes the same rows by :func:`_contact_rows` and
    :func:`_friction_jacobian`).

    ``z`` = (Λ_N, λ_N, Λ_F, λ_F); ``ev`` = (P_N, P_F, ξ_F, γ_F, γ̇_F); ``mu`` (nN,); ``lay`` = (fptr, fidx,
    sq, col): the tangent rows of contact i are fidx[fptr[i]:fptr[i + 1]] (p of them), its p × p blocks
    start at sq[i] of the square blocks' values (row by row) and its p × 1 columns at col[i];
    ``sets`` (5, nN) int8 (A, B, C, D, E); ``on_P`` the slip law on P_F, P_N (1) or on Λ_F, Λ_N (0).
    ``out`` = (R9, R10, Dxi, Dgd, Dg, Dpn, Dln, Dpf, Dlf, Dsm), all written: R9 = P_F, R10 = λ_F, the
    blocks 0, Dpf = Dlf = Dsm = 1 where a contact is open or frictionless.
    """
    LN, lN, LF, lF = z
    PN, PF, xiF, gF, gFdd = ev
    fptr, fidx, sq, col = lay
    R9, R10, Dxi, Dgd, Dg, Dpn, Dln, Dpf, Dlf, Dsm = out
    R9[:] = PF
    R10[:] = lF
    for D in (Dxi, Dgd, Dg, Dpn, Dln):
        D[:] = 0.0
    Dpf[:] = 1.0
    Dlf[:] = 1.0
    Dsm[:] = 1.0
    for i in range(fptr.size - 1):
        if fptr[i + 1] == fptr[i] or not sets[0, i]:
            continue                                   # (138c), (142d): P_F = 0, λ_F = 0
        idx = fidx[fptr[i]:fptr[i + 1]]
        p, s0, c0 = idx.size, sq[i], col[i]
        if sets[3, i]:
            for a in range(p):                         # (138a): stick at percussion level
                R9[idx[a]] = xiF[idx[a]]
                Dxi[s0 + a * p + a] = 1.0
                Dpf[idx[a]] = 0.0
            if sets[4, i]:                             # (142a): stick at acceleration level
                for a in range(p):
                    R10[idx[a]] = gFdd[idx[a]]
                    Dgd[s0 + a * p + a] = 1.0
                    Dlf[idx[a]] = 0.0
            else:                                      # (142b): slip at acceleration level
                v, dv = _direction(gFdd[idx])
                for a in range(p):
                    R10[idx[a]] = lF[idx[a]] + mu[i] * lN[i] * v[a]
                    Dln[c0 + a] = mu[i] * v[a]
                    for b in range(p):
                        Dgd[s0 + a * p + b] = mu[i] * lN[i] * dv[a, b]
        else:                                          # (138b), (142c): slip
            v, dv = _direction(xiF[idx])
            Ns = PN[i] if on_P != 0.0 else LN[i]
            w, dw = _direction(gF[idx])
            for a in range(p):
                j = idx[a]
                R9[j] = (PF[j] if on_P != 0.0 else LF[j]) + mu[i] * Ns * v[a]
                if on_P == 0.0:
                    Dsm[j] = 0.0
                Dpn[c0 + a] = mu[i] * v[a]
                R10[j] = lF[j] + mu[i] * lN[i] * w[a]
                Dln[c0 + a] = mu[i] * w[a]
                for b in range(p):
                    Dxi[s0 + a * p + b] = mu[i] * Ns * dv[a, b]
                    Dg[s0 + a * p + b] = mu[i] * lN[i] * dw[a, b]


@kernel(allocates=True)
def _slip_block(J, rows, c0, D, W, fac):
    """J[rows, c0:c0 + n] += fac D W."""
    DW = D @ W
    for a in range(rows.size):
        for c in range(W.shape[1]):
            J[rows[a], c0 + c] += fac * DW[a, c]


@kernel(allocates=True)
def jacobian(x, o, mq, kin, law, lay, par, sets, der, J):
    """∂R/∂x at the iterate (NonsmoothStep.jacobian), dense, into J (nx, nx)."""
    J[:, :] = 0.0
    _smooth_jacobian(o, mq, par, J)
    _normal_jacobian(o, mq, par, sets, J)
    _friction_jacobian(x, o, mq, kin, law, lay, par, der, sets, J)


@kernel(allocates=True)
def minimum_norm_step(J, R, x, dx, w):
    """The Newton increment dx for a rank-deficient J (NonsmoothStep.newton_increment): the least-squares
    solution of J dx = −R with the singular values below 1e-11 of the largest dropped (the minimum-norm
    increment), and then, where ``w`` (nx,) is given (non-empty), the new iterate y = x + dx moved within
    J's null space to the point of least Σ w_a y_a² (y − N c with (NᵀWN) c = NᵀW y, N the null basis;
    where these normal equations are singular to machine precision, the weights spread over more than
    about 1e16 (friction weights of contacts that carry almost nothing: a box landing on an edge), c is
    the least-squares solution of W^½ N c = W^½ y by SVD instead).

    The null space holds the unknowns that the laws leave undetermined (two sticking contacts on one body,
    of which only the sum of the friction forces is fixed; redundant constraints' multipliers). The
    minimum-norm increment alone keeps whatever split the iterate held, and a split locked in that way
    (opposite axial friction at the two ends of a shaft in a bushing) made a later step that starts to slip
    unsolvable. With the weights of :func:`null_weights` (1 / (μ_i times contact i's normal force or
    impulse) on its friction unknowns) the undetermined friction forces are shared in proportion to their
    cones, so that the contacts of one body reach their cones together (docs/contact.md §1.1, item 3).
    """
    U, s, Vt = np.linalg.svd(J)
    n = s.size
    cut = 1e-11 * s[0] if n > 0 else 0.0
    dx[:] = 0.0
    nul = 0
    for k in range(n):
        if s[k] > cut:
            c = 0.0
            for a in range(R.size):
                c -= U[a, k] * R[a]
            c /= s[k]
            for b in range(dx.size):
                dx[b] += c * Vt[k, b]
        else:
            nul += 1
    if w.size == 0 or nul == 0:
        return
    N = np.empty((dx.size, nul))
    j = 0
    for k in range(n):
        if not s[k] > cut:
            N[:, j] = Vt[k]
            j += 1
    WN = N * w.reshape(-1, 1)
    try:
        c = np.linalg.solve(N.T @ WN, WN.T @ (x + dx))
    except Exception:               # singular to machine precision: weights over ~1e16 apart
        sw = np.sqrt(w)
        c = np.linalg.lstsq(N * sw.reshape(-1, 1), sw * (x + dx), 1e-13)[0]
    dx -= N @ c


@kernel(allocates=True)
def null_weights(x, o, PN, law, lay, w):
    """The weights of :func:`minimum_norm_step`: 1 on every unknown but the friction ones; on contact i's
    friction percussions Λ_F and forces λ_F, 1 / (μ_i P_N,i) and 1 / (μ_i λ_N,i) (the cone's size at the
    iterate; at least 1e-9 of the largest, so that an unloaded contact takes almost none). Returns w."""
    w[:] = 1.0
    mu, fptr, fidx = law[2], lay[1], lay[2]
    k = o[8] - o[7]
    sP = 0.0
    sl = 0.0
    for i in range(k):
        sP = max(sP, mu[i] * abs(PN[i]))
        sl = max(sl, mu[i] * abs(x[o[8] + i]))
    for i in range(k):
        cP = max(mu[i] * PN[i], 1e-9 * sP)
        cl = max(mu[i] * x[o[8] + i], 1e-9 * sl)
        for p in range(fptr[i], fptr[i + 1]):
            j = fidx[p]
            if cP > 0.0:
                w[o[9] + j] = 1.0 / cP
            if cl > 0.0:
                w[o[10] + j] = 1.0 / cl
    return w


@kernel(allocates=True)
def increment(J, R, dx):
    """Solve J dx = −R on J equilibrated by rows and columns (LU, partial pivoting).

    Returns 0 (dx written), or 1 when the equilibrated pivots spread over more than 1e11 (J is
    treated as rank deficient: the caller takes the minimum-norm least-squares increment,
    NonsmoothStep.newton_increment).
    """
    N = R.size
    if N == 0:
        return 0
    A = J.copy()
    r = np.empty(N)
    c = np.zeros(N)
    piv = np.empty(N, dtype=np.int64)
    for a in range(N):                  # rows, then columns, each divided by its largest entry
        m = 0.0
        for b in range(N):
            m = max(m, abs(A[a, b]))
        r[a] = 1.0 / m if m > 0.0 else 1.0
        for b in range(N):
            A[a, b] *= r[a]
            c[b] = max(c[b], abs(A[a, b]))
    for b in range(N):
        c[b] = 1.0 / c[b] if c[b] > 0.0 else 1.0
    for a in range(N):
        for b in range(N):
            A[a, b] *= c[b]
    for k in range(N):                  # LU with partial pivoting; zero entries below the pivot skipped
        p = k
        amax = abs(A[k, k])
        for i in range(k + 1, N):
            if abs(A[i, k]) > amax:
                amax = abs(A[i, k])
                p = i
        piv[k] = p
        if p != k:
            for j in range(N):
                A[k, j], A[p, j] = A[p, j], A[k, j]
        if A[k, k] != 0.0:
            inv = 1.0 / A[k, k]
            for i in range(k + 1, N):
                if A[i, k] != 0.0:
                    A[i, k] *= inv
                    f = A[i, k]
                    for j in range(k + 1, N):
                        A[i, j] -= f * A[k, j]
    dmin = abs(A[0, 0])
    dmax = dmin
    for k in range(1, N):
        dmin = min(dmin, abs(A[k, k]))
        dmax = max(dmax, abs(A[k, k]))
    if not dmin > 1e-11 * dmax:
        return 1
    y = np.empty(N)
    for a in range(N):
        y[a] = -r[a] * R[a]
    for k in range(N):
        p = piv[k]
        if p != k:
            y[k], y[p] = y[p], y[k]
    for i in range(N):
        s = y[i]
        for j in range(i):
            s -= A[i, j] * y[j]
        y[i] = s
    for i in range(N - 1, -1, -1):
        s = y[i]
        for j in range(i + 1, N):
            s -= A[i, j] * y[j]
        y[i] = s / A[i, i]
    for a in range(N):
        dx[a] = c[a] * y[a]
    return 0


@kernel(allocates=True)
def kinematics(x, o, st, par, cmp, out):
    """The iterate's kinematics (eqs. (71), (73), (125), (95), (96), (102), (113), (114); NonsmoothStep.kinematics).

    ``st`` = (q_n, u_n, u̇_n, ā_n, λ_N,n, λ_F,n, λ̄_N,n, λ̄_F,n); ``par`` = (h, α_m, α_f, β, γ);
    ``cmp`` = (xmap, rot): the configuration entry of each additive velocity (−1 for rotations) and
    the (x start, v start) pairs of the rotation nodes, flattened (Model.compose); ``out`` =
    (q, u, ā, λ̄_N, λ̄_F, P_N, κ̂_N, P_F, Δ) with Δ the increment q = q_n ∘ exp(Δ).
    """
    q0, u0, ud0, ab0, lN0, lF0, lbN0, lbF0 = st
    h, am, af, b, g = par[0], par[1], par[2], par[3], par[4]
    q, u, abar, lbN, lbF, PN, kNh, PF, d = out
    ud, U, Q = x[o[0]:o[1]], x[o[1]:o[2]], x[o[2]:o[3]]
    kN, LN, lN, LF, lF = x[o[6]:o[7]], x[o[7]:o[8]], x[o[8]:o[9]], x[o[9]:o[10]], x[o[10]:o[11]]
    for a in range(u.size):
        abar[a] = (af * ud0[a] + (1 - af) * ud[a] - am * ab0[a]) / (1 - am)
        u[a] = u0[a] + h * ((1 - g) * ab0[a] + g * abar[a]) + U[a]
        d[a] = h * u0[a] + h * h * ((0.5 - b) * ab0[a] + b * abar[a]) + Q[a]
    for i in range(lbN.size):
        lbN[i] = (af * lN0[i] + (1 - af) * lN[i] - am * lbN0[i]) / (1 - am)
        PN[i] = LN[i] + h * ((1 - g) * lbN0[i] + g * lbN[i])
        kNh[i] = kN[i] + h * h * ((0.5 - b) * lbN0[i] + b * lbN[i])
    for j in range(lbF.size):
        lbF[j] = (af * lF0[j] + (1 - af) * lF[j] - am * lbF0[j]) / (1 - am)
        PF[j] = LF[j] + h * ((1 - g) * lbF0[j] + g * lbF[j])
    _compose(q0, d, cmp[0], cmp[1], q)


@kernel(allocates=True)
def _compose(q0, d, xmap, rot, q):
    """q = q0 ∘ exp(d) (Model.compose): additive entries, each rotation p ⊗ exp(d_θ) renormalised."""
    q[:] = q0
    if rot.size == 0 and xmap.size == q.size:
        for a in range(d.size):
            q[xmap[a]] += d[a]
        return
    for a in range(d.size):
        if xmap[a] >= 0:
            q[xmap[a]] += d[a]
    e = np.empty(4)
    p = np.empty(4)
    for r in range(rot.size // 2):
        xs, vs = rot[2 * r], rot[2 * r + 1]
        quat_exp_into(d[vs:vs + 3], e)
        quat_mul_into(q0[xs:xs + 4], e, p)
        nrm = np.sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2] + p[3] * p[3])
        for c in range(4):
            q[xs + c] = p[c] / nrm


@kernel(allocates=True)
def _evaluate(x, o, mdl, t, kout, dq):
    """The model at the iterate's kinematics (femb/contact/batches.py)."""
    recs, qx, ux, f0, removed = mdl
    q, u = kout[0], kout[1]
    qx[:q.size] = q
    ux[:u.size] = u
    mult = (x[o[5]:o[6]], x[o[8]:o[9]], x[o[10]:o[11]])
    evaluate_batches(recs, t, qx, ux, mult, True, dq, f0, removed)


@kernel(allocates=True)
def newton_loop(x, mdl, st, law, lay, par, work):
    """The semismooth Newton iterations of one step (NonsmoothStep.newton_dense) in one call.

    ``x`` (nx,) the initial guess, overwritten by the last iterate; ``mdl`` = (batch records, q_ext, v_ext,
    f0, removed) (:class:`femb.contact.dense.DenseModel`); ``st`` the step's start (:func:`kinematics`);
    ``par`` = (h, tol, c_q, c_u, m_ref, 0, α_m, α_f, β, γ, t_{n+1}, max_iter, freeze_after, fixed, slip law
    on P, h_acc of :func:`_scale`); ``work`` =
    (o, cmp, kout, out, dq, mq, mv, J, dx, sets, (ġ_N⁻, γ_F⁻), z_fixed). With ``fixed`` the contact rows are
    z − z_fixed = 0 (Newton on R_s for fixed contact unknowns, the fixed point's inner problem). The index sets are held after
    ``freeze_after`` iterations; a result reached with held sets is a solution only if they are its
    own. Returns (0 converged or 1 not, iterations, error); the work arrays hold the last iterate's
    quantities.
    """
    o, cmp, kout, out, dq, mq, mv, J, dx, sets, sd, zf = work
    fixed = par[13] != 0.0
    kp = np.array([par[0], par[6], par[7], par[8], par[9]])
    rp = np.empty(8)
    rp[:6] = par[:6]
    rp[5] = 0.0
    rp[6] = par[14]
    rp[7] = par[15]
    t1, tol = par[10], par[1]
    max_iter, freeze_after = int(par[11]), int(par[12])
    kin = (kout[1], kout[5], kout[6], kout[7], sd[0], sd[1])
    R = out[0]
    x_prev = x.copy()                   # the last full Newton iterate, its error and index sets
    sets_prev = sets.copy()
    err_prev = np.inf
    theta = 1.0
    for it in range(1, max_iter + 1):
        kinematics(x, o, st, kp, cmp, kout)
        _evaluate(x, o, mdl, t1, kout, dq)
        err = residual(x, o, mq, mv, kin, law, lay, rp, sets, out)
        if fixed:
            err = _fixed_rows(x, o, zf, out, mv)
        if not np.isfinite(err):
            return 1, it, err
        if err <= (tol if it > 1 else GUESS_TOL * tol):
            if rp[5] != 0.0:            # converged with the sets held: a solution if they are its own
                rp[5] = 0.0
                err = residual(x, o, mq, mv, kin, law, lay, rp, sets, out)
                if fixed:
                    err = _fixed_rows(x, o, zf, out, mv)
            return (0 if err <= tol else 1), it, err
        if damp_step(err, err_prev, sets, sets_prev, theta, _worst_row(out[0], out[1]) >= o[9]):
            theta *= 0.5                # the same branch and no decrease: half the step (docs/contact.md §1.1, item 8)
            for a in range(x.size):
                x[a] = x_prev[a] + theta * dx[a]
            continue
        x_prev[:] = x
        sets_prev[:] = sets
        err_prev = err
        theta = 1.0
        if it >= freeze_after:
            rp[5] = 1.0
        jacobian(x, o, mq, kin, law, lay, rp, sets, out[2:], J)
        if fixed:
            for a in range(o[6], o[11]):
                J[a, :] = 0.0
                J[a, a] = 1.0
        if not np.all(np.isfinite(J)):
            return 1, it, err
        if increment(J, R, dx) != 0:
            minimum_norm_step(J, R, x, dx, null_weights(x, o, kout[5], law, lay, np.empty(x.size)))
        elif it > 1 and rp[5] == 0.0 and increment_size(dx, o, law[5], par) <= tol:
            return 0, it, err           # converged at the residual's round-off floor (increment_size)
        x += dx
    kinematics(x, o, st, kp, cmp, kout)
    _evaluate(x, o, mdl, t1, kout, dq)
    rp[5] = 0.0
    err = residual(x, o, mq, mv, kin, law, lay, rp, sets, out)
    if fixed:
        err = _fixed_rows(x, o, zf, out, mv)
    return (0 if err <= tol else 1), max_iter, err


@kernel
def increment_size(dx, o, w, par):
    """The Newton increment ``dx`` as a length (max over its entries): u̇, U, Q times max(h, h_acc)², h, 1
    (rotations times the length scale, 1/w); the multipliers κ, Λ, λ (bilateral, normal, friction) times
    1/m, h/m, max(h, h_acc)²/m, the weights :func:`_scale` gives their rows. ``par`` as in
    :func:`newton_loop` (h, m_ref and h_acc at 0, 4, 15).

    A regular J's increment is the distance of the iterate from the solution of the linearized equations;
    where it is below the tolerance the iterate is converged although its residual is not: the round-off
    of a stiff model's forces (a beam of 100 elements: internal forces whose rounding errors, scaled by
    h²/m of its small nodal masses, leave the dynamics rows at 2e-11 m with increments of 1e-15 m;
    the floor grows as the square of the number of elements) keeps the residual above 1e-12 L
    (docs/contact.md §1.1, item 11).
    """
    h, m = par[0], par[4]
    ha = max(h, par[15])
    ha2 = ha * ha
    n = o[1] - o[0]
    size = 0.0
    for a in range(n):
        size = max(size, abs(dx[o[0] + a]) * ha2 / w[a], abs(dx[o[1] + a]) * h / w[a], abs(dx[o[2] + a]) / w[a])
    for b, c in ((3, 1.0), (4, h), (5, ha2), (6, 1.0), (7, h), (8, ha2), (9, h), (10, ha2)):
        for a in range(o[b], o[b + 1]):
            size = max(size, abs(dx[a]) * c / m)
    return size


@kernel
def damp_step(err, err_prev, sets, sets_prev, theta, friction_worst):
    """Whether a Newton step is to be halved: it stayed on the branch it was computed on (the same
    index sets), did not decrease the error, whose largest row is a friction row (``friction_worst``),
    and it is still longer than ``MIN_DAMPING`` (then taken as it is).

    On one branch R is smooth except where a slip direction v = γ/‖γ‖ turns at γ → 0, and the Newton
    step dx of R + J dx = 0 decreases every component of R for a short enough step:
    R(x + θ dx) = (1 − θ) R(x) + O(θ²). A contact ending its slip within the step (its solution a
    slip speed of 1e-5 m/s) otherwise jumps across γ = 0 at every iterate, its friction row the
    largest (docs/contact.md §1.1, item 8). Steps whose error grows in the other rows are taken as
    they are: a flexible beam's early iterates do so on their way to quadratic convergence, and halving
    them tripled the iterations of its steps.
    """
    if not friction_worst or not err >= err_prev or theta <= MIN_DAMPING:
        return False
    for i in range(sets.shape[0]):
        for j in range(sets.shape[1]):
            if sets[i, j] != sets_prev[i, j]:
                return False
    return True


@kernel
def _worst_row(R, S):
    """The row of the largest |S R| (the weighted error)."""
    k, e = 0, -1.0
    for a in range(R.size):
        v = abs(S[a] * R[a])
        if v > e:
            k, e = a, v
    return k


@kernel(allocates=True)
def _fixed_rows(x, o, zf, out, mv):
    """The contact rows z − z_fixed = 0 of the fixed point's inner problem (eq. (145)); the new error
    (NaN where a gap is not defined, as in :func:`residual`)."""
    R, S = out[0], out[1]
    for a in range(zf.size):
        R[o[6] + a] = x[o[6] + a] - zf[a]
    err = 0.0
    for a in range(R.size):
        e = abs(S[a] * R[a])
        if not e <= err:
            err = e
    if _undefined_gap(mv):
        err = np.nan
    return err


@kernel(allocates=True)
def prox_parameters(WN, WF, Minv, rN, rF):
    """r_i = 1/(W M⁻¹ Wᵀ)_ii for the normal and tangent rows (NonsmoothStep.prox_r; Studer 2009, §3.4)."""
    n = Minv.shape[0]
    for W, r in ((WN, rN), (WF, rF)):
        for i in range(W.shape[0]):
            g = 0.0
            for a in range(n):
                if W[i, a] != 0.0:
                    acc = 0.0
                    for b in range(n):
                        acc += Minv[a, b] * W[i, b]
                    g += W[i, a] * acc
            r[i] = 1.0 / max(g, 1e-300)
