"""Compiled building blocks of spatial joints and forces between two frame nodes.

Element layout (``docs/kernels.md``): ``x = (r_a, p_a, r_b, p_b)`` (14),
``v = (ṙ_a, Ω_a, ṙ_b, Ω_b)`` (12); tangent columns (δr_a, δθ_a, δr_b, δθ_b) at
0, 3, 6, 9. Joint parameters ``P`` start with the joint frame on both bodies:
``X_a`` (3), ``Ē_a`` (9, rows ē_a1, ē_a2, ē_a3 in body a axes), ``X_b`` (3),
``Ē_b`` (9); element-specific parameters follow from column 24.

Everything here allocates nothing (the kernels run in the time loop without
reference counting): 3-vectors are tuples of three floats, 3×3 matrices
row-major 9-tuples, and a 12-vector on the element's tangent space a tuple of
four 3-vectors (δr_a, δθ_a, δr_b, δθ_b blocks); numba keeps them in registers.

Each primitive (:func:`point_hess`, :func:`dot1`, :func:`dot2`,
:func:`distance`) returns its value Φ and gradient g = ∂Φ/∂(δr, δθ) (a row of
B), *adds* ``c`` times its Hessian H = ∂g/∂(δr, δθ) (right perturbation
R ← R exp(δθ~)) to a 12 × 12 array when ``add`` is true, and returns vᵀH for a
given 12-vector v (the convective term vᵀHv of γ, and the damping part of a
measure force's Jacobian). Formulas: ``docs/spatial.md`` §4 (dot-1, dot-2,
point, distance primitives; Géradin & Cardona 2001, Ch. 5; Brüls, Cardona &
Arnold 2012, Sect. 6), each checked against finite differences along
x ∘ exp(εw) in ``tests/test_spatial_kernels.py``.
"""
from __future__ import annotations

from femb.base.jit import kernel
from femb.base.rotations import quat_to_matrix_t

XA, EA, XB, EB, NPAR_FRAME = 0, 3, 12, 15, 24
Z3 = (0.0, 0.0, 0.0)
Z12 = (Z3, Z3, Z3, Z3)
I9 = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)


# ---------------------------------------------------------------------------
# 3-vectors and 3×3 matrices as tuples
# ---------------------------------------------------------------------------
@kernel
def vec3(a, o):
    """(a[o], a[o+1], a[o+2])."""
    return (a[o], a[o + 1], a[o + 2])


@kernel
def vec12(a):
    """A 12-vector (array) as four 3-vectors."""
    return ((a[0], a[1], a[2]), (a[3], a[4], a[5]), (a[6], a[7], a[8]), (a[9], a[10], a[11]))


@kernel
def add3(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@kernel
def sub3(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@kernel
def scale3(s, a):
    return (s * a[0], s * a[1], s * a[2])


@kernel
def dot3(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@kernel
def cross3(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@kernel
def mv(R, a):
    """R a."""
    return (R[0] * a[0] + R[1] * a[1] + R[2] * a[2],
            R[3] * a[0] + R[4] * a[1] + R[5] * a[2],
            R[6] * a[0] + R[7] * a[1] + R[8] * a[2])


@kernel
def mtv(R, a):
    """Rᵀ a."""
    return (R[0] * a[0] + R[3] * a[1] + R[6] * a[2],
            R[1] * a[0] + R[4] * a[1] + R[7] * a[2],
            R[2] * a[0] + R[5] * a[1] + R[8] * a[2])


@kernel
def mm(A, B):
    """A B."""
    return (A[0] * B[0] + A[1] * B[3] + A[2] * B[6], A[0] * B[1] + A[1] * B[4] + A[2] * B[7],
            A[0] * B[2] + A[1] * B[5] + A[2] * B[8],
            A[3] * B[0] + A[4] * B[3] + A[5] * B[6], A[3] * B[1] + A[4] * B[4] + A[5] * B[7],
            A[3] * B[2] + A[4] * B[5] + A[5] * B[8],
            A[6] * B[0] + A[7] * B[3] + A[8] * B[6], A[6] * B[1] + A[7] * B[4] + A[8] * B[7],
            A[6] * B[2] + A[7] * B[5] + A[8] * B[8])


@kernel
def mmt(A, B):
    """A Bᵀ."""
    return (A[0] * B[0] + A[1] * B[1] + A[2] * B[2], A[0] * B[3] + A[1] * B[4] + A[2] * B[5],
            A[0] * B[6] + A[1] * B[7] + A[2] * B[8],
            A[3] * B[0] + A[4] * B[1] + A[5] * B[2], A[3] * B[3] + A[4] * B[4] + A[5] * B[5],
            A[3] * B[6] + A[4] * B[7] + A[5] * B[8],
            A[6] * B[0] + A[7] * B[1] + A[8] * B[2], A[6] * B[3] + A[7] * B[4] + A[8] * B[5],
            A[6] * B[6] + A[7] * B[7] + A[8] * B[8])


@kernel
def mtm(A, B):
    """Aᵀ B."""
    return (A[0] * B[0] + A[3] * B[3] + A[6] * B[6], A[0] * B[1] + A[3] * B[4] + A[6] * B[7],
            A[0] * B[2] + A[3] * B[5] + A[6] * B[8],
            A[1] * B[0] + A[4] * B[3] + A[7] * B[6], A[1] * B[1] + A[4] * B[4] + A[7] * B[7],
            A[1] * B[2] + A[4] * B[5] + A[7] * B[8],
            A[2] * B[0] + A[5] * B[3] + A[8] * B[6], A[2] * B[1] + A[5] * B[4] + A[8] * B[7],
            A[2] * B[2] + A[5] * B[5] + A[8] * B[8])


@kernel
def tr9(M):
    """Mᵀ."""
    return (M[0], M[3], M[6], M[1], M[4], M[7], M[2], M[5], M[8])


@kernel
def neg9(M):
    return (-M[0], -M[1], -M[2], -M[3], -M[4], -M[5], -M[6], -M[7], -M[8])


@kernel
def skskw(a, b):
    """a~ b~ = b aᵀ − (a·b) I."""
    ab = a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    return (b[0] * a[0] - ab, b[0] * a[1], b[0] * a[2],
            b[1] * a[0], b[1] * a[1] - ab, b[1] * a[2],
            b[2] * a[0], b[2] * a[1], b[2] * a[2] - ab)


@kernel
def outer_minus(a, b, s, R):
    """a bᵀ − s R."""
    return (a[0] * b[0] - s * R[0], a[0] * b[1] - s * R[1], a[0] * b[2] - s * R[2],
            a[1] * b[0] - s * R[3], a[1] * b[1] - s * R[4], a[1] * b[2] - s * R[5],
            a[2] * b[0] - s * R[6], a[2] * b[1] - s * R[7], a[2] * b[2] - s * R[8])


@kernel
def rskew(R, a):
    """R a~ (row i = (row i of R) × a); with u = R a: u~ R = R a~."""
    r0 = cross3((R[0], R[1], R[2]), a)
    r1 = cross3((R[3], R[4], R[5]), a)
    r2 = cross3((R[6], R[7], R[8]), a)
    return (r0[0], r0[1], r0[2], r1[0], r1[1], r1[2], r2[0], r2[1], r2[2])


# ---------------------------------------------------------------------------
# 12-vectors (four 3-vectors) and additions to 12 × 12 arrays
# ---------------------------------------------------------------------------
@kernel
def dot12(a, b):
    return dot3(a[0], b[0]) + dot3(a[1], b[1]) + dot3(a[2], b[2]) + dot3(a[3], b[3])


@kernel
def lin12(s, a, t, b):
    """s a + t b."""
    return ((s * a[0][0] + t * b[0][0], s * a[0][1] + t * b[0][1], s * a[0][2] + t * b[0][2]),
            (s * a[1][0] + t * b[1][0], s * a[1][1] + t * b[1][1], s * a[1][2] + t * b[1][2]),
            (s * a[2][0] + t * b[2][0], s * a[2][1] + t * b[2][1], s * a[2][2] + t * b[2][2]),
            (s * a[3][0] + t * b[3][0], s * a[3][1] + t * b[3][1], s * a[3][2] + t * b[3][2]))


@kernel
def put_row(B, r, g):
    """B[r, :] = g."""
    for k in range(4):
        gk = g[k]
        for i in range(3):
            B[r, 3 * k + i] = gk[i]


@kernel
def axpy_row(f, s, g):
    """f += s g (f a 12-array)."""
    for k in range(4):
        gk = g[k]
        for i in range(3):
            f[3 * k + i] += s * gk[i]


@kernel
def add_outer12(H, s, a, b):
    """H += s a bᵀ (12 × 12)."""
    for k in range(4):
        ak = a[k]
        for m in range(4):
            bm = b[m]
            for i in range(3):
                sa = s * ak[i]
                for j in range(3):
                    H[3 * k + i, 3 * m + j] += sa * bm[j]


@kernel
def blk(H, add, i0, j0, c, M, vi):
    """H[i0:i0+3, j0:j0+3] += c M if ``add``; returns viᵀ M."""
    if add:
        for i in range(3):
            for j in range(3):
                H[i0 + i, j0 + j] += c * M[3 * i + j]
    return (vi[0] * M[0] + vi[1] * M[3] + vi[2] * M[6],
            vi[0] * M[1] + vi[1] * M[4] + vi[2] * M[7],
            vi[0] * M[2] + vi[1] * M[5] + vi[2] * M[8])


@kernel
def gtg(H, add, c, G0, G1, G2, G3, v):
    """H += c GᵀG if ``add``, G = [G0 G1 G2 G3] (3 × 12); returns vᵀGᵀG = Gᵀ(Gv)."""
    if add:
        for a in range(4):
            Ga = G0 if a == 0 else (G1 if a == 1 else (G2 if a == 2 else G3))
            for b in range(4):
                Gb = G0 if b == 0 else (G1 if b == 1 else (G2 if b == 2 else G3))
                M = mtm(Ga, Gb)
                for i in range(3):
                    for j in range(3):
                        H[3 * a + i, 3 * b + j] += c * M[3 * i + j]
    y = add3(add3(mv(G0, v[0]), mv(G1, v[1])), add3(mv(G2, v[2]), mv(G3, v[3])))
    return (mtv(G0, y), mtv(G1, y), mtv(G2, y), mtv(G3, y))


# ---------------------------------------------------------------------------
# the two frames of an element
# ---------------------------------------------------------------------------
@kernel
def frames(P, x):
    """Rotations, arms and points of the two frames of one element.

    Returns (R_a, R_b, R_ab = R_aᵀR_b, X_a, X_b, r_b = R_b X_b, p_a = x_a + R_a X_a,
    p_b, d = p_b − p_a, x_a): 9-tuples and 3-tuples.
    """
    Ra = quat_to_matrix_t(x[3], x[4], x[5], x[6])
    Rb = quat_to_matrix_t(x[10], x[11], x[12], x[13])
    Xa = vec3(P, XA)
    Xb = vec3(P, XB)
    xa = vec3(x, 0)
    pa = add3(xa, mv(Ra, Xa))
    rb = mv(Rb, Xb)
    pb = add3(vec3(x, 7), rb)
    return (Ra, Rb, mtm(Ra, Rb), Xa, Xb, rb, pa, pb, sub3(pb, pa), xa)


# ---------------------------------------------------------------------------
# primitives
# ---------------------------------------------------------------------------
@kernel
def point_rows(r, F, Phi, B):
    """Rows r..r+2: Φ = p_a − p_b, B = [I, −R_a X_a~, −I, R_b X_b~] (row i of R X~ = (row i of R) × X)."""
    Ra, Rb, Rab, Xa, Xb, rb, pa, pb, d, xa = F
    for i in range(3):
        Phi[r + i] = pa[i] - pb[i]
        B[r + i, i] = 1.0
        B[r + i, 6 + i] = -1.0
        ca = cross3(Xa, (Ra[3 * i], Ra[3 * i + 1], Ra[3 * i + 2]))
        cb = cross3((Rb[3 * i], Rb[3 * i + 1], Rb[3 * i + 2]), Xb)
        for j in range(3):
            B[r + i, 3 + j] = ca[j]
            B[r + i, 9 + j] = cb[j]


@kernel
def point_hess(F, l, H, add, c, v):
    """Hessian of λ·Φ of the point rows (λ = l, a 3-tuple): H(θa, θa) = X_a~(R_aᵀλ)~,
    H(θb, θb) = −X_b~(R_bᵀλ)~; adds c H if ``add``, returns vᵀH."""
    Ra, Rb, Rab, Xa, Xb, rb, pa, pb, d, xa = F
    ha = blk(H, add, 3, 3, c, skskw(Xa, mtv(Ra, l)), v[1])
    hb = blk(H, add, 9, 9, c, neg9(skskw(Xb, mtv(Rb, l))), v[3])
    return (Z3, ha, Z3, hb)


@kernel
def dot1(abar, bbar, F, H, add, c, v):
    """Φ = u·w, u = R_a ā, w = R_b b̄; g = [0, ā × w_a, 0, −u_b × b̄] (w_a = R_aᵀw, u_b = R_bᵀu).

    H(θa, θa) = ā~w_a~, H(θb, θb) = b̄~u_b~, H(θa, θb) = −(w_a u_bᵀ − Φ R_ab), H(θb, θa) its
    transpose. Returns (Φ, g, vᵀH); adds c H if ``add``.
    """
    Ra, Rb, Rab, Xa, Xb, rb, pa, pb, d, xa = F
    u = mv(Ra, abar)
    w = mv(Rb, bbar)
    wa = mtv(Ra, w)
    ub = mtv(Rb, u)
    phi = dot3(u, w)
    ct = cross3(ub, bbar)
    g = (Z3, cross3(abar, wa), Z3, (-ct[0], -ct[1], -ct[2]))
    Mab = neg9(outer_minus(wa, ub, phi, Rab))
    h_aa = blk(H, add, 3, 3, c, skskw(abar, wa), v[1])
    h_ab = blk(H, add, 3, 9, c, Mab, v[1])
    h_ba = blk(H, add, 9, 3, c, tr9(Mab), v[3])
    h_bb = blk(H, add, 9, 9, c, skskw(bbar, ub), v[3])
    return phi, g, (Z3, add3(h_aa, h_ba), Z3, add3(h_ab, h_bb))


@kernel
def dot2(abar, offset, F, H, add, c, v):
    """Φ = u·d − offset, u = R_a ā, d = p_b − p_a; g = [−u, ā × s_a, u, −u_b × X_b],
    s = p_b − x_a, s_a = R_aᵀs, u_b = R_bᵀu (force −λu at p_b on b).

    With K = R_a ā~ (= u~R_a): H(r_a, θa) = K, H(r_b, θa) = −K, H(θa, r_a) = Kᵀ,
    H(θa, r_b) = −Kᵀ, H(θa, θa) = ā~s_a~, H(θa, θb) = −(R_aᵀr_b u_bᵀ − (u·r_b) R_ab),
    H(θb, θa) its transpose, H(θb, θb) = X_b~u_b~. Returns (Φ, g, vᵀH); adds c H if ``add``.
    """
    Ra, Rb, Rab, Xa, Xb, rb, pa, pb, d, xa = F
    u = mv(Ra, abar)
    s = sub3(pb, xa)
    sa = mtv(Ra, s)
    ub = mtv(Rb, u)
    phi = dot3(u, d) - offset
    cb = cross3(ub, Xb)
    g = ((-u[0], -u[1], -u[2]), cross3(abar, sa), u, (-cb[0], -cb[1], -cb[2]))
    K = rskew(Ra, abar)
    Kt = tr9(K)
    Mab = neg9(outer_minus(mv(Rab, Xb), ub, dot3(u, rb), Rab))
    h_ra = blk(H, add, 0, 3, c, K, v[0])
    h_rb = blk(H, add, 6, 3, c, neg9(K), v[2])
    h_a0 = blk(H, add, 3, 0, c, Kt, v[1])
    h_a2 = blk(H, add, 3, 6, c, neg9(Kt), v[1])
    h_aa = blk(H, add, 3, 3, c, skskw(abar, sa), v[1])
    h_ab = blk(H, add, 3, 9, c, Mab, v[1])
    h_ba = blk(H, add, 9, 3, c, tr9(Mab), v[3])
    h_bb = blk(H, add, 9, 9, c, skskw(Xb, ub), v[3])
    return phi, g, (h_a0, add3(add3(h_ra, h_rb), add3(h_aa, h_ba)), h_a2, add3(h_ab, h_bb))


@kernel
def distance(L, F, H, add, c, v):
    """Φ = (d·d − L²)/(2L); g = dᵀG/L, G = [−I, R_a X_a~, I, −R_b X_b~] (δd = G δq);
    H = (GᵀG + blockdiag(0, −X_a~(R_aᵀd)~, 0, X_b~(R_bᵀd)~))/L. Returns (Φ, g, vᵀH);
    adds c H if ``add`` (λ = tension of the link)."""
    Ra, Rb, Rab, Xa, Xb, rb, pa, pb, d, xa = F
    phi = (dot3(d, d) - L * L) / (2.0 * L)
    da = mtv(Ra, d)
    db = mtv(Rb, d)
    il = 1.0 / L
    g = (scale3(-il, d), scale3(il, cross3(da, Xa)), scale3(il, d), scale3(-il, cross3(db, Xb)))
    A = rskew(Ra, Xa)
    Bm = neg9(rskew(Rb, Xb))
    hg = gtg(H, add, c * il, neg9(I9), A, I9, Bm, v)
    ha = blk(H, add, 3, 3, c * il, neg9(skskw(Xa, da)), v[1])
    hb = blk(H, add, 9, 9, c * il, skskw(Xb, db), v[3])
    return phi, g, (scale3(il, hg[0]), scale3(il, add3(hg[1], ha)), scale3(il, hg[2]),
                    scale3(il, add3(hg[3], hb)))
