"""Stage: linear algebra: the LU factorizations and solves of the iteration matrix.

The Newton step (:mod:`femb.engine.newton`) and the error estimate (:mod:`femb.engine.control`)
solve S_t x = r (docs/method.md eq. 7, scaled by eq. 8) through :func:`factor` and :func:`solve`:
a band LU with partial pivoting after a bandwidth-reducing permutation (LAPACK's ``dgbtf2``
storage, transposed), or a dense LU that skips zeros for small systems (``ip[IP_DENSE]``).

References
----------
E. Anderson et al., LAPACK Users' Guide, 3rd ed., SIAM 1999 (band LU with partial pivoting, ``dgbtf2``).
"""

from numba import njit

from femb.base.jit import engine
from femb.engine.layout import (SEPARATE, ENTRY, INNER, IP_DENSE, IP_KL, IP_KU, IP_N)
from femb.engine.link import call


@engine(**ENTRY)
def band_lu(ABf, N, kl, ku, env, ipiv, rel_tol):
    """LU with partial pivoting of a band matrix in place (LAPACK ``dgbtf2`` logic, variable band).

    ``ABf`` is the flat storage of ``AB (N, 2 kl + ku + 1)``. ``env`` (3, N)
    bounds the work per column j from the matrix's structure, computed once
    per model (:mod:`femb.solve.codegen`): rows j+1 … env[0, j] can hold nonzeros
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


@engine(**SEPARATE)
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


@engine(**SEPARATE)
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
    st = call(dense_lu, Af, N, ipiv, rel_tol)
    if st == 0:
        call(dense_solve, Af, N, ipiv, b)
    return st


@njit(**INNER)
def factor(Af, ip, env, ipiv, rel_tol):
    """Factorize the iteration matrix in its storage (dense or band, fixed per model)."""
    if ip[IP_DENSE] != 0:
        return call(dense_lu, Af, ip[IP_N], ipiv, rel_tol)
    return call(band_lu, Af, ip[IP_N], ip[IP_KL], ip[IP_KU], env, ipiv, rel_tol)


@njit(**INNER)
def solve(Af, ip, env, ipiv, b):
    """Solve with the factors of :func:`factor`, in place on ``b`` (permuted order)."""
    if ip[IP_DENSE] != 0:
        call(dense_solve, Af, ip[IP_N], ipiv, b)
    else:
        call(band_solve, Af, ip[IP_N], ip[IP_KL], ip[IP_KU], env, ipiv, b)


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
