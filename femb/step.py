"""The time step: Newton iteration and time loop of the generalized-α scheme, compiled.

This file is the whole time step in one place. It is not imported as a module:
:mod:`femb.codegen` appends its text to the module it generates for each
combination of element types, after the model-kind specific functions
``evaluate(...)`` (residual and iteration matrix of one iterate) and
``kkt_evaluate(...)`` (the matrix [[M, Bᵀ], [B, 0]] and right-hand side
[f; −γ] of the constrained accelerations). numba compiles the result once per
model kind and caches it on disk (:mod:`femb.jit`).

The iteration matrix is stored and factorized as a band matrix after a
bandwidth-reducing symmetric permutation (computed once per model by
:mod:`femb.codegen`): ``AB[j, d + i − j]`` holds entry (i, j) of the permuted
matrix, ``d = kl + ku``, leaving room for the fill of partial pivoting (LAPACK's
``gbtrf`` storage, transposed).

References
----------
M. Arnold, O. Brüls, Multibody Syst. Dyn. 18 (2007) 185–202, Algorithm 1.
C. L. Bottasso, D. Dopico, L. Trainelli, Multibody Syst. Dyn. 19 (2008) 3–20 (scaling).
E. Anderson et al., LAPACK Users' Guide, 3rd ed., SIAM 1999 (band LU with partial pivoting, ``dgbtf2``).
"""

# ---- status codes returned to Python (femb/solver.py raises femb's errors) -------------
ST_CHUNK = 0          # requested number of steps done
ST_DONE = 1           # t_end reached
ST_NEED_TF = 2        # Python time functions must be evaluated at info[0]
ST_NONFINITE = -1
ST_MAXITER = -2
ST_DIVERGED_SINGULAR = -3
ST_SINGULAR = -4

# ---- indices of the integer parameters ip[...] ------------------------------------------
IP_NV, IP_NC, IP_NFIX, IP_N, IP_KL, IP_KU = 0, 1, 2, 3, 4, 5
IP_MAXIT, IP_MINIT, IP_FULL, IP_PRED, IP_NSTEPS, IP_STRIDE, IP_STORE, IP_PYTF = 6, 7, 8, 9, 10, 11, 12, 13
# ---- indices of the float parameters fp[...] ---------------------------------------------
FP_H, FP_T0, FP_AM, FP_AF, FP_BETA, FP_GAMMA, FP_RTOL, FP_ATOL = 0, 1, 2, 3, 4, 5, 6, 7
FP_PHITOL, FP_L, FP_XTOL, FP_SCALED, FP_SINGTOL, FP_TEND, FP_FCONST = 8, 9, 10, 11, 12, 13, 14
# ---- indices of the run state si[...] (int) and sf[...] (float) ---------------------------
SI_STEP, SI_HASPREV, SI_LUVALID, SI_STORED = 0, 1, 2, 3
SF_FREF, SF_TFTIME = 0, 1
# ---- statistics counters ------------------------------------------------------------------
NS_STEPS, NS_EVAL, NS_FACT, NS_SOLVE, NS_ROUNDOFF = 0, 1, 2, 3, 4


@njit(cache=True, **OPTIONS)
def band_lu(ABf, N, kl, ku, ipiv, rel_tol):
    """LU with partial pivoting of a band matrix in place (LAPACK ``dgbtf2`` logic).

    ``ABf`` is the flat storage of ``AB (N, 2 kl + ku + 1)``. Returns 0, or 1 if a
    pivot is zero, non-finite, or below ``rel_tol`` times the largest pivot
    (singular for the purpose of the Newton iteration).
    """
    d = kl + ku
    AB = ABf.reshape((N, 2 * kl + ku + 1))
    ju = 0
    pmax = 0.0
    pmin = 1e308
    for j in range(N):
        km = min(kl, N - 1 - j)
        p = j
        amax = abs(AB[j, d])
        for i in range(j + 1, j + km + 1):
            v = abs(AB[j, d + i - j])
            if v > amax:
                amax = v
                p = i
        ipiv[j] = p
        if not (amax > 0.0) or amax > 1e300:
            return 1
        ju = max(ju, min(p + ku, N - 1))
        if p != j:
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
        for i in range(j + 1, j + km + 1):
            AB[j, d + i - j] *= inv
        for c in range(j + 1, ju + 1):
            a = AB[c, d + j - c]
            if a != 0.0:
                off = d - c
                for i in range(j + 1, j + km + 1):
                    AB[c, off + i] -= AB[j, d + i - j] * a
    if pmin <= rel_tol * pmax:
        return 1
    return 0


@njit(cache=True, **OPTIONS)
def band_solve(ABf, N, kl, ku, ipiv, b):
    """Solve with the factors of :func:`band_lu`, in place on ``b`` (permuted order)."""
    d = kl + ku
    AB = ABf.reshape((N, 2 * kl + ku + 1))
    for j in range(N):
        p = ipiv[j]
        if p != j:
            tmp = b[j]
            b[j] = b[p]
            b[p] = tmp
        bj = b[j]
        if bj != 0.0:
            for i in range(j + 1, min(N - 1, j + kl) + 1):
                b[i] -= AB[j, d + i - j] * bj
    for j in range(N - 1, -1, -1):
        b[j] /= AB[j, d]
        bj = b[j]
        if bj != 0.0:
            for i in range(max(0, j - d), j):
                b[i] -= AB[j, d + i - j] * bj


@njit(cache=True, **OPTIONS)
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


@njit(cache=True, **OPTIONS)
def newton_step(G, C, ip, fp, si, sf, stats, q, qd, qdd, lam, a, pqdd, plam, t1, h,
                AB, ipiv, r, Phi, rhs, x, info):
    """One step of Algorithm 1 (Arnold & Brüls 2007) from t1 − h to t1, in place.

    On success the arrays q, qd, qdd, lam, a hold the new step and the number of
    Newton iterations is returned (≥ 0). A negative return is a status code;
    ``info`` then holds (t1, ‖r_q‖, ‖Φ‖, iteration, index of the largest |Φ_i|,
    tolerance of r_q, tolerance of Φ).
    """
    nv = ip[IP_NV]
    nc = ip[IP_NC]
    N = ip[IP_N]
    kl = ip[IP_KL]
    ku = ip[IP_KU]
    am = fp[FP_AM]
    af = fp[FP_AF]
    beta = fp[FP_BETA]
    gamma = fp[FP_GAMMA]
    bp = (1.0 - am) / (h * h * beta * (1.0 - af))
    gp = gamma / (h * beta)
    c = beta * h * h if fp[FP_SCALED] != 0.0 else 1.0
    ka = (1.0 - af) / (1.0 - am)
    perm = C[1]
    iperm = C[2]
    w = C[3]
    full = ip[IP_FULL] != 0
    tol_phi = fp[FP_PHITOL] * fp[FP_L]
    rtol = fp[FP_RTOL]
    atol = fp[FP_ATOL]
    L = fp[FP_L]
    # predictor and (3)-(5) of Algorithm 1 for that guess of (q̈_{n+1}, λ_{n+1})
    pred = ip[IP_PRED]
    for i in range(nv):
        a_base = (af * qdd[i] - am * a[i]) / (1.0 - am)
        if pred == 0:
            g = 0.0
            a_pred = a_base
        else:
            if pred == 2 and si[SI_HASPREV] != 0:
                g = 2.0 * qdd[i] - pqdd[i]
            else:
                g = qdd[i]
            a_pred = a_base + ka * g
        pqdd[i] = qdd[i]
        # x[:nv] keeps a_base until the step is accepted (eq. (3) needs it)
        x[i] = a_base
        qd_new = qd[i] + (h * (1.0 - gamma)) * a[i] + (h * gamma) * a_pred
        q[i] = q[i] + h * qd[i] + (h * h * (0.5 - beta)) * a[i] + (h * h * beta) * a_pred
        qd[i] = qd_new
        qdd[i] = g
    for j in range(nc):
        if pred == 0:
            g = 0.0
        elif pred == 2 and si[SI_HASPREV] != 0:
            g = 2.0 * lam[j] - plam[j]
        else:
            g = lam[j]
        plam[j] = lam[j]
        lam[j] = g
    F_ref = sf[SF_FREF]
    prev_norm = -1.0
    k = 0
    maxit = ip[IP_MAXIT]
    F = F_ref
    while True:
        need_jac = (full and k == 0) or si[SI_LUVALID] == 0
        scale = evaluate(G, C, t1, q, qd, qdd, lam, need_jac, c * bp, c * gp, c, AB, r, Phi)
        stats[NS_EVAL] += 1
        F = scale if scale > F_ref else F_ref
        err_f = 0.0
        for i in range(nv):
            v = abs(r[i] * w[i])
            if not (v <= err_f):
                err_f = v if v == v else math.inf
        err_phi = 0.0
        iphi = -1
        for j in range(nc):
            v = abs(Phi[j])
            if not (v <= err_phi):
                err_phi = v if v == v else math.inf
                iphi = j
        info[0] = t1
        info[1] = err_f
        info[2] = err_phi
        info[3] = k
        info[4] = iphi
        info[5] = rtol * F + atol
        info[6] = tol_phi
        if not (math.isfinite(err_f) and math.isfinite(err_phi)):
            return ST_NONFINITE
        if k >= ip[IP_MINIT] and err_f <= rtol * F + atol and err_phi <= tol_phi:
            break
        if k == maxit:
            return ST_MAXITER
        factor = need_jac
        if full and not need_jac:
            scale = evaluate(G, C, t1, q, qd, qdd, lam, True, c * bp, c * gp, c, AB, r, Phi)
            stats[NS_EVAL] += 1
            factor = True
        if (not full) and prev_norm >= 0.0 and si[SI_LUVALID] != 0 and not factor:
            cur = max(err_f / max(F, 1e-300), err_phi / max(tol_phi, 1e-300))
            if cur > 0.25 * prev_norm:
                scale = evaluate(G, C, t1, q, qd, qdd, lam, True, c * bp, c * gp, c, AB, r, Phi)
                stats[NS_EVAL] += 1
                factor = True
        if factor:
            if band_lu(AB, N, kl, ku, ipiv, fp[FP_SINGTOL]) != 0:
                si[SI_LUVALID] = 0
                return ST_DIVERGED_SINGULAR if k > 0 else ST_SINGULAR
            si[SI_LUVALID] = 1
            stats[NS_FACT] += 1
        if not full:
            prev_norm = max(err_f / max(F, 1e-300), err_phi / max(tol_phi, 1e-300))
        for i in range(nv):
            rhs[iperm[i]] = -c * r[i]
        for j in range(nc):
            rhs[iperm[nv + j]] = -Phi[j]
        band_solve(AB, N, kl, ku, ipiv, rhs)
        stats[NS_SOLVE] += 1
        dqmax = 0.0
        qmax = 0.0
        inv_c = 1.0 / c
        for i in range(nv):
            dq = rhs[iperm[i]]
            q[i] += dq
            qd[i] += gp * dq
            qdd[i] += bp * dq
            if abs(dq) > dqmax:
                dqmax = abs(dq)
            if abs(q[i]) > qmax:
                qmax = abs(q[i])
        for j in range(nc):
            lam[j] += rhs[iperm[nv + j]] * inv_c
        k += 1
        # round-off floor: a correction at the level of the coordinates' own round-off
        # cannot improve the iterate (stiff elements nearly at rest)
        if (err_phi <= tol_phi and err_f <= 1e4 * (rtol * F + atol)
                and dqmax <= fp[FP_XTOL] * (qmax + L)):
            stats[NS_ROUNDOFF] += 1
            break
    for i in range(nv):
        a[i] = x[i] + ka * qdd[i]
    if F > F_ref:
        sf[SF_FREF] = F
    si[SI_HASPREV] = 1
    return k


@njit(cache=True, **OPTIONS)
def run_fixed(G, C, ip, fp, si, sf, stats, q, qd, qdd, lam, a, pqdd, plam, tfv,
              AB, ipiv, r, Phi, rhs, x, info, n_chunk, out_t, out_q, out_qd, out_qdd, out_lam, iters):
    """Advance up to ``n_chunk`` fixed steps, storing every ``stride``-th state.

    Returns a status code (ST_*); ``si[SI_STORED]`` counts the states written into
    the output buffers during this call.
    """
    n_steps = ip[IP_NSTEPS]
    stride = ip[IP_STRIDE]
    store = ip[IP_STORE] != 0
    h = fp[FP_H]
    t0 = fp[FP_T0]
    tf_kind = C[8]
    tf_off = C[9]
    tf_coef = C[10]
    si[SI_STORED] = 0
    done = 0
    while done < n_chunk:
        n = si[SI_STEP] + 1
        if n > n_steps:
            return ST_DONE
        t1 = t0 + n * h
        if ip[IP_PYTF] != 0:
            if sf[SF_TFTIME] != t1:
                info[0] = t1
                return ST_NEED_TF
        eval_time_functions(t1, tf_kind, tf_off, tf_coef, tfv)
        k = newton_step(G, C, ip, fp, si, sf, stats, q, qd, qdd, lam, a, pqdd, plam, t1, h,
                        AB, ipiv, r, Phi, rhs, x, info)
        if k < 0:
            return k
        iters[n - 1] = k
        si[SI_STEP] = n
        stats[NS_STEPS] += 1
        done += 1
        if (store and n % stride == 0) or n == n_steps:
            m = si[SI_STORED]
            out_t[m] = fp[FP_TEND] if n == n_steps else t1
            out_q[m, :] = q
            out_qd[m, :] = qd
            out_qdd[m, :] = qdd
            out_lam[m, :] = lam
            si[SI_STORED] = m + 1
    if si[SI_STEP] >= n_steps:
        return ST_DONE
    return ST_CHUNK


# ---- gather / scatter helpers called by the generated evaluate() ---------------------------
@njit(cache=True, **OPTIONS)
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


@njit(cache=True, **OPTIONS)
def gather_lam(lam, lamidx, le):
    for e in range(lamidx.shape[0]):
        for j in range(lamidx.shape[1]):
            le[e, j] = lam[lamidx[e, j]]


@njit(cache=True, **OPTIONS)
def gather_tf(tfv, tfi, tf):
    for e in range(tfi.shape[0]):
        for k in range(tfi.shape[1]):
            i = tfi[e, k]
            tf[e, k, 0] = tfv[i, 0]
            tf[e, k, 1] = tfv[i, 1]
            tf[e, k, 2] = tfv[i, 2]


@njit(cache=True, **OPTIONS)
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


@njit(cache=True, **OPTIONS)
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


@njit(cache=True, **OPTIONS)
def scatter_matrix(Ke, tgt, ABf, factor):
    """ABf[tgt[e, i, j]] += factor · Ke[e, i, j] (targets < 0 are fixed coordinates)."""
    for e in range(Ke.shape[0]):
        for i in range(Ke.shape[1]):
            for j in range(Ke.shape[2]):
                t = tgt[e, i, j]
                if t >= 0:
                    ABf[t] += factor * Ke[e, i, j]


@njit(cache=True, **OPTIONS)
def scatter_B(Be, tB, tBt, ABf):
    for e in range(Be.shape[0]):
        for j in range(Be.shape[1]):
            for i in range(Be.shape[2]):
                t = tB[e, j, i]
                if t >= 0:
                    v = Be[e, j, i]
                    ABf[t] += v
                    ABf[tBt[e, j, i]] += v


@njit(cache=True, **OPTIONS)
def mass_residual(C, qdd, r, ABf, jac, cM):
    """r = M q̈ − f_const (constant M in CSR), M into the matrix; returns the force scale."""
    Mp = C[0]
    w = C[3]
    fconst = C[6]
    Mi = C[7]
    Mx = C[11]
    tM = C[12]
    scale = C[14][0]
    for i in range(r.shape[0]):
        s = 0.0
        for k in range(Mp[i], Mp[i + 1]):
            s += Mx[k] * qdd[Mi[k]]
        v = abs(s * w[i])
        if v > scale:
            scale = v
        r[i] = s - fconst[i]
    if jac:
        ABf[:] = 0.0
        for k in range(tM.shape[0]):
            ABf[tM[k]] += cM * Mx[k]
        tI = C[16]
        for k in range(tI.shape[0]):
            ABf[tI[k]] = 1.0
    return scale
