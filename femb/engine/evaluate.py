"""Stage: evaluate: gather, kernels, scatter.

For every batch of the model's batch table (``C_BATCHES``, :mod:`femb.engine.layout`) gather the
element coordinates from q, q̇ (and λ), call the batch's compiled kernels through their addresses
(:func:`femb.base.jit.call_force`, :func:`femb.base.jit.call_constraint`, :func:`femb.base.jit.call_rates`) and
scatter the results into the residual r_q = M q̈ − f + Φ_qᵀλ, r_λ = Φ (docs/method.md eqs. 1–2) and,
with ``jac``, the iteration matrix S_t = [[M β' + C_t γ' + K_t, Φ_qᵀ], [Φ_q, 0]] (eq. 7).
Jacobians with respect to rotations are taken in the tangent space (docs/spatial.md).

References
----------
M. Arnold, O. Brüls, Multibody Syst. Dyn. 18 (2007) 185–202 (Algorithm 1: the residual and S_t).
"""

import math

from numba import njit

from femb.base.jit import (
    call_constraint, call_force, call_rates, call_velocity_constraint, engine, fview1, fview2, fview3, iview1, iview2, iview3)
from femb.engine.layout import (SEPARATE, B_BASE, B_HASC, B_KERNEL, B_RATES, B_ROLE, C_ACTIVE, C_BATCHES, C_FCONST,
    C_LAMZ, C_LIE, C_MI, C_MP, C_MX, C_QFIX, C_SCALE0, C_TFV, C_TI, C_TM, C_TN, C_W, C_WEXT, ENTRY, F_DOFS, F_FE,
    F_FQ, F_FV, F_P, F_TBLK, F_TF, F_TFI, F_TNN, F_VE, F_XDOFS, F_XE, INNER, K_BE, K_DOFS, K_GM, K_HE,
    K_LAMIDX, K_LE, K_P, K_PHE, K_PT, K_TB, K_TBLK, K_TBT, K_TF, K_TFI, K_TNN, K_VE, K_XDOFS, K_XE,
    ROLE_CONSTRAINT, ROLE_FORCE, ROLE_VELOCITY, V_DQ)
from femb.engine.link import call
from femb.engine.linalg import zero1, zero2, zero3


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


# ---- the model's element batches: residual, iteration matrix, rates, B -------------------
@engine(**ENTRY)
def evaluate(G, C, t, X, jac, coef, out):
    """Residual r = M q̈ − f + Bᵀλ, Φ, and (jac) the iteration matrix into ABf; returns the force scale.

    Batches run in the order of the batch table: forces first, then constraints.

    Parameters
    ----------
    G, C : pack
        The element batches and the model constants.
    t : float
    X : (ndarray, ndarray, ndarray, ndarray)
        The iterate (q (nx,), q̇ (nv,), q̈ (nv,), λ (nc,)).
    jac : bool
        Whether the iteration matrix is built.
    coef : (float, float, float)
        cM, cC, cK: the factors of M, C_t = −∂f/∂q̇ and K_t = −∂f/∂q + ∂(Bᵀλ)/∂q in the matrix
        (Newton: c β', c γ', c; Arnold & Brüls 2007, eq. 7 scaled by c as in eq. 8).
    out : (ndarray, ndarray, ndarray)
        ABf (the matrix's storage), r (nv,), Φ (nc,), written.

    Returns
    -------
    float
        The force scale max |f_i w_i| (the residual test's reference).
    """
    batches = iview2(C, C_BATCHES)
    scale = mass_residual(C, X[2], out[1], out[0], jac, coef[0])
    for b in range(batches.shape[0]):
        if batches[b, B_ROLE] == ROLE_FORCE:
            scale = force_batch(G, C, batches[b], t, X, jac, coef, out, scale)
        else:
            scale = constraint_batch(G, C, batches[b], t, X, jac, coef, out, scale)
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
def force_batch(G, C, row, t, X, jac, coef, out, scale):
    """One force batch: f_e and its Jacobians from the kernel, −f into r, −cK ∂f/∂q − cC ∂f/∂q̇ into ABf
    (the arguments of :func:`evaluate`; ``row`` the batch's row of the batch table)."""
    q, qd = X[0], X[1]
    cC, cK = coef[1], coef[2]
    ABf, r = out[0], out[1]
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
def constraint_batch(G, C, row, t, X, jac, coef, out, scale):
    """One constraint batch: Φ_e, B_e and H_e from the kernel; Φ, Bᵀλ into r, [B, Bᵀ, cK H] into ABf
    (the arguments of :func:`evaluate`; ``row`` the batch's row of the batch table).

    A velocity-constraint batch (``ROLE_VELOCITY``, Ψ = A v + a at (q, q̇)) takes the same path with
    its rows as those of the index-2 velocity level in Algorithm 1 (q̇ = q̇' + γ'Δq), scaled by
    1/γ': residual rows Ψ/γ', r += Aᵀμ, and with ``jac`` the rows A + Ψ_q T/γ' (∂Ψ/∂Δq = γ'A +
    Ψ_q T, T the tangent operator of rotation nodes), the columns Aᵀ and cK ∂(Aᵀμ)/∂q; γ' = cC/cK
    from ``coef`` (Newton: c γ' / c). With cC = 0 (the constrained accelerations of the error
    estimate, coef = (1, 0, 0)) the rows are A and the residual Ψ (:func:`kernel_blocks`).
    """
    q, qd, lam = X[0], X[1], X[3]
    cK = coef[2]
    ABf, r, Phi = out
    base = row[B_BASE]
    velocity = row[B_ROLE] == ROLE_VELOCITY
    s = call(kernel_blocks, G, C, row, t, q, qd, lam, jac, coef[1], cK)
    sd = s if coef[1] != 0.0 else 0.0          # the factor of Ψ_q in the velocity rows (1/γ', or none)
    lamidx = iview2(G, base + K_LAMIDX)
    Be = fview3(G, base + K_BE)
    He = fview3(G, base + K_HE)
    scale = scatter_constraint(fview2(G, base + K_PHE), Be, fview2(G, base + K_LE), iview2(G, base + K_DOFS),
                               lamidx, iview1(C, C_ACTIVE), Phi, r, fview1(C, C_WEXT), scale)
    if jac:
        tB = iview3(G, base + K_TB)
        tBt = iview3(G, base + K_TBT)
        lie = iview1(C, C_LIE)[0] != 0
        if lie:
            tblk = iview3(G, base + K_TBLK)
            Tn = fview3(C, C_TN)
            if velocity:
                # A + Ψ_q T/γ' in the rows (the kernel's Ψ_q in the batch's array V_DQ), Aᵀ in the columns
                Dq = fview3(G, base + V_DQ)
                apply_tangent(Dq, tblk, Tn, cK)
                scatter_matrix(Dq, tB, ABf, sd)
                scatter_B(Be, tB, tBt, ABf)
            else:
                scatter_B_tangent(Be, tblk, Tn, cK, tB, tBt, ABf)
            apply_tangent(He, tblk, Tn, cK)
        else:
            if velocity:
                scatter_matrix(fview3(G, base + V_DQ), tB, ABf, sd)
            scatter_B(Be, tB, tBt, ABf)
        scatter_matrix(He, iview3(G, base + K_TNN), ABf, cK)
    return scale


@engine(**SEPARATE)
def kernel_blocks(G, C, row, t, q, v, lam, jac, cC, cK):
    """Gather the batch's coordinates, velocities ``v`` and multipliers, run its constraint kernel (or
    velocity-constraint kernel: Ψ into Φ_e, A into B_e, Ψ_t into the batch's Pt, Ψ_q into V_DQ) at
    (t, q); the blocks stay in G.

    Returns the factor s of a velocity batch's rows (cK/cC = 1/γ', 1 when cC = 0; its Ψ is scaled
    by it), 1.0 for a constraint batch.
    """
    base = row[B_BASE]
    gather_batch(G, C, base, K_XDOFS, K_DOFS, K_XE, K_VE, q, v)
    le = fview2(G, base + K_LE)
    gather_lam(lam, iview2(G, base + K_LAMIDX), le)
    tf = fview3(G, base + K_TF)
    gather_tf(fview2(C, C_TFV), iview2(G, base + K_TFI), tf)
    Phe = fview2(G, base + K_PHE)
    Be = fview3(G, base + K_BE)
    He = fview3(G, base + K_HE)
    zero2(Phe)
    zero3(Be)
    if jac:
        zero3(He)
    if row[B_ROLE] != ROLE_VELOCITY:
        call_constraint(row[B_KERNEL], fview2(G, base + K_P), t, tf, fview2(G, base + K_XE), le, jac, Phe, Be, He)
        return 1.0
    Pt = fview2(G, base + K_PT)
    Dq = fview3(G, base + V_DQ)
    zero2(Pt)
    if jac:
        zero3(Dq)
    call_velocity_constraint(row[B_KERNEL], fview2(G, base + K_P), t, tf, fview2(G, base + K_XE),
                             fview2(G, base + K_VE), le, jac, Phe, Be, Pt, Dq, He)
    s = cK / cC if cC != 0.0 else 1.0
    for e in range(Phe.shape[0]):
        for j in range(Phe.shape[1]):
            Phe[e, j] *= s
    return s


@njit(**INNER)
def constraint_blocks(G, C, row, t, q, v):
    """Run the batch's constraint kernel at (t, q) without Jacobian; its B_e blocks stay in G.
    The velocities gathered into the batch's ``ve`` are those of ``v`` (a velocity-constraint batch:
    its A, which does not depend on them, with zero multipliers)."""
    call(kernel_blocks, G, C, row, t, q, v, fview1(C, C_LAMZ), v.shape[0] < 0, 0.0, 0.0)


@engine(**ENTRY)
def rates(G, C, t, q, qd, Phi_t, gam):
    """Φ_t and γ (B q̈ = −γ) of all constraints at (t, q, q̇); velocity-constraint rows Ψ = A q̇ + a:
    Φ_t = a = Ψ − A q̇ (so that they read A q̇ + Φ_t = 0) and γ = Ψ_q q̇ + Ψ_t (A q̈ = −γ: dΨ/dt = 0)."""
    batches = iview2(C, C_BATCHES)
    active = iview1(C, C_ACTIVE)
    zero1(Phi_t)
    zero1(gam)
    for b in range(batches.shape[0]):
        if batches[b, B_ROLE] == ROLE_FORCE:
            continue
        base = batches[b, B_BASE]
        Pt = fview2(G, base + K_PT)
        gm = fview2(G, base + K_GM)
        if batches[b, B_ROLE] == ROLE_VELOCITY:
            call(kernel_blocks, G, C, batches[b], t, q, qd, fview1(C, C_LAMZ), qd.shape[0] >= 0, 0.0, 0.0)
            velocity_rates(fview2(G, base + K_PHE), fview3(G, base + K_BE), fview3(G, base + V_DQ),
                           fview2(G, base + K_VE), Pt, gm)
        else:
            gather_batch(G, C, base, K_XDOFS, K_DOFS, K_XE, K_VE, q, qd)
            tf = fview3(G, base + K_TF)
            gather_tf(fview2(C, C_TFV), iview2(G, base + K_TFI), tf)
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


@njit(**INNER)
def velocity_rates(Psi, Ae, Dq, ve, Pt, gm):
    """A velocity batch's Φ_t ← Ψ − A v and γ ← Ψ_q v + Ψ_t (Ψ_t in ``Pt`` on entry), per row."""
    for e in range(Psi.shape[0]):
        for j in range(Psi.shape[1]):
            av = 0.0
            dv = 0.0
            for i in range(ve.shape[1]):
                av += Ae[e, j, i] * ve[e, i]
                dv += Dq[e, j, i] * ve[e, i]
            gm[e, j] = dv + Pt[e, j]
            Pt[e, j] = Psi[e, j] - av


@engine(**ENTRY)
def jacobian_times(G, C, t, q, v, out):
    """out = B(q, t) v for all constraints (the velocity-constraint rows: A(q, t) v)."""
    batches = iview2(C, C_BATCHES)
    zero1(out)
    for b in range(batches.shape[0]):
        if batches[b, B_ROLE] == ROLE_FORCE:
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


@njit(**INNER)
def copy_blocks(Be, out, o):
    """out[o:] = Be (nel, nc_e, nd) in row-major order; returns the next offset."""
    for e in range(Be.shape[0]):
        for j in range(Be.shape[1]):
            for i in range(Be.shape[2]):
                out[o] = Be[e, j, i]
                o += 1
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
def scatter_constraint(Phe, Be, le, dofs, lamidx, active, Phi, r, wext, scale):
    """Φ rows and r += Bᵀλ per element (free coordinates: d < nv = len(r)); returns
    max(scale, |(Bᵀλ)_e · w|)."""
    nv = r.shape[0]
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
