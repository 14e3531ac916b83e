"""Compiled building blocks of spatial joints and forces between two frame nodes.

Element layout (``docs/kernels.md``): ``x = (r_a, p_a, r_b, p_b)`` (14),
``v = (ṙ_a, Ω_a, ṙ_b, Ω_b)`` (12); tangent columns (δr_a, δθ_a, δr_b, δθ_b) at
0, 3, 6, 9. Joint parameters ``P`` start with the joint frame on both bodies:
``X_a`` (3), ``Ē_a`` (9, rows ē_a1, ē_a2, ē_a3 in body a axes), ``X_b`` (3),
``Ē_b`` (9); element-specific parameters follow from column 24.

Each primitive writes one or three rows of Φ and B (assignment) and *adds*
λ-weighted blocks to H = ∂(Bᵀλ)/∂(δr, δθ) (right perturbation R ← R exp(δθ~));
the caller zeroes B and H. Formulas: ``docs/spatial.md`` §4 (dot-1, dot-2,
point, distance primitives; Géradin & Cardona 2001, Ch. 5; Brüls, Cardona &
Arnold 2012, Sect. 6), each checked against finite differences along
x ∘ exp(εw) in ``tests/test_spatial_kernels.py``.

Workspace: kernels allocate ``W = np.empty((NW, 3, 3))`` and
``V = np.empty((NV, 3))`` once per call and pass them down; primitives use the
slots documented at :func:`frames`.
"""
from __future__ import annotations

import math

import numpy as np

from femb import rotations as rt
from femb.jit import kernel

XA, EA, XB, EB, NPAR_FRAME = 0, 3, 12, 15, 24
NW, NV = 12, 16
# slots of the workspace
W_RA, W_RB, W_M, W_N, W_T1, W_T2, W_I = 0, 1, 2, 3, 4, 5, 6
V_RA, V_RB, V_PA, V_PB, V_D, V_U, V_W, V_C, V_S, V_T = 0, 1, 2, 3, 4, 5, 6, 7, 8, 9


@kernel(allocates=True)
def frames(P, x, W, V):
    """Rotations, arms and points of the two frames.

    W[0] = R_a, W[1] = R_b, W[6] = I; V[0] = r_a = R_a X_a, V[1] = r_b = R_b X_b,
    V[2] = p_a = x_a + r_a, V[3] = p_b, V[4] = d = p_b − p_a.
    """
    rt.quat_to_matrix_into(x[3:7], W[W_RA])
    rt.quat_to_matrix_into(x[10:14], W[W_RB])
    for i in range(3):
        for j in range(3):
            W[W_I, i, j] = 1.0 if i == j else 0.0
    for i in range(3):
        ra = 0.0
        rb = 0.0
        for j in range(3):
            ra += W[W_RA, i, j] * P[XA + j]
            rb += W[W_RB, i, j] * P[XB + j]
        V[V_RA, i] = ra
        V[V_RB, i] = rb
        V[V_PA, i] = x[i] + ra
        V[V_PB, i] = x[7 + i] + rb
        V[V_D, i] = V[V_PB, i] - V[V_PA, i]


@kernel(allocates=True)
def rot_vec(R, a, out):
    """out = R a."""
    for i in range(3):
        out[i] = R[i, 0] * a[0] + R[i, 1] * a[1] + R[i, 2] * a[2]


@kernel(allocates=True)
def rotT_vec(R, a, out):
    """out = Rᵀ a."""
    for i in range(3):
        out[i] = R[0, i] * a[0] + R[1, i] * a[1] + R[2, i] * a[2]


@kernel(allocates=True)
def cross_into(a, b, out):
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


@kernel(allocates=True)
def dot3(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@kernel(allocates=True)
def skskw(a, b, M):
    """M = a~ b~ = b aᵀ − (a·b) I."""
    ab = a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    for i in range(3):
        for j in range(3):
            M[i, j] = b[i] * a[j]
        M[i, i] -= ab


@kernel(allocates=True)
def add_RtMR(H, i0, j0, R1, M, R2, s):
    """H[i0:i0+3, j0:j0+3] += s R1ᵀ M R2."""
    for i in range(3):
        for j in range(3):
            acc = 0.0
            for k in range(3):
                mk = 0.0
                for m in range(3):
                    mk += M[k, m] * R2[m, j]
                acc += R1[k, i] * mk
            H[i0 + i, j0 + j] += s * acc


@kernel(allocates=True)
def add_skew_block(H, i0, j0, a, R, s, left):
    """H block += s a~ R (left) or s Rᵀ a~ (not left)."""
    for i in range(3):
        for j in range(3):
            if left:
                v = (a[(i + 1) % 3] * R[(i + 2) % 3, j] - a[(i + 2) % 3] * R[(i + 1) % 3, j])
            else:
                # (Rᵀ a~)[i, j] = Σ_k R[k, i] a~[k, j];  a~[k, j] = −ε_kjm a_m
                v = 0.0
                for k in range(3):
                    akj = 0.0
                    if (j - k) % 3 == 1:
                        akj = -a[(k + 2) % 3]
                    elif (k - j) % 3 == 1:
                        akj = a[(j + 2) % 3]
                    v += R[k, i] * akj
            H[i0 + i, j0 + j] += s * v


# ---------------------------------------------------------------------------
# primitives
# ---------------------------------------------------------------------------
@kernel(allocates=True)
def prim_point(r, P, x, lam, jac, Phi, B, H, W, V):
    """Rows r..r+2: Φ = p_a − p_b, B = [I, −R_a X_a~, −I, R_b X_b~].

    H(θa, θa) = X_a~ (R_aᵀλ)~,  H(θb, θb) = −X_b~ (R_bᵀλ)~ (λ = Φ rows' multipliers).
    """
    Ra, Rb = W[W_RA], W[W_RB]
    for i in range(3):
        Phi[r + i] = V[V_PA, i] - V[V_PB, i]
        B[r + i, i] = 1.0
        B[r + i, 6 + i] = -1.0
    # −R_a X_a~ : column j = −R_a (e_j × X_a) ; R_a X_a~ e_j = R_a (X_a × e_j)
    for i in range(3):
        for j in range(3):
            sa = 0.0
            sb = 0.0
            for k in range(3):
                # (X~)[k, j]
                xa = 0.0
                xb = 0.0
                if (j - k) % 3 == 1:
                    xa = -P[XA + (k + 2) % 3]
                    xb = -P[XB + (k + 2) % 3]
                elif (k - j) % 3 == 1:
                    xa = P[XA + (j + 2) % 3]
                    xb = P[XB + (j + 2) % 3]
                sa += Ra[i, k] * xa
                sb += Rb[i, k] * xb
            B[r + i, 3 + j] = -sa
            B[r + i, 9 + j] = sb
    if jac:
        la = V[V_T]
        l = V[V_S]
        for i in range(3):
            l[i] = lam[r + i]
        M = W[W_M]
        rotT_vec(Ra, l, la)
        skskw(P[XA:XA + 3], la, M)
        for i in range(3):
            for j in range(3):
                H[3 + i, 3 + j] += M[i, j]
        rotT_vec(Rb, l, la)
        skskw(P[XB:XB + 3], la, M)
        for i in range(3):
            for j in range(3):
                H[9 + i, 9 + j] -= M[i, j]


@kernel(allocates=True)
def prim_dot1(r, abar, bbar, lam, jac, Phi, B, H, W, V):
    """Row r: Φ = u·w, u = R_a ā, w = R_b b̄; B = [0, cᵀR_a, 0, −cᵀR_b], c = u × w."""
    Ra, Rb = W[W_RA], W[W_RB]
    u, w, c, t = V[V_U], V[V_W], V[V_C], V[V_T]
    rot_vec(Ra, abar, u)
    rot_vec(Rb, bbar, w)
    cross_into(u, w, c)
    Phi[r] = dot3(u, w)
    rotT_vec(Ra, c, t)
    for i in range(3):
        B[r, 3 + i] = t[i]
    rotT_vec(Rb, c, t)
    for i in range(3):
        B[r, 9 + i] = -t[i]
    if jac:
        l = lam[r]
        M, N = W[W_M], W[W_N]
        skskw(u, w, M)
        skskw(w, u, N)
        add_RtMR(H, 3, 3, Ra, M, Ra, l)
        add_RtMR(H, 3, 9, Ra, M, Rb, -l)
        add_RtMR(H, 9, 3, Rb, N, Ra, -l)
        add_RtMR(H, 9, 9, Rb, N, Rb, l)


@kernel(allocates=True)
def prim_dot2(r, x, abar, offset, lam, jac, Phi, B, H, W, V):
    """Row r: Φ = u·d − offset, u = R_a ā, d = p_b − p_a.

    B = [−uᵀ, (u × s)ᵀR_a, uᵀ, −(u × r_b)ᵀR_b], s = p_b − x_a (force −λu at p_b on b).
    """
    Ra, Rb = W[W_RA], W[W_RB]
    u, s, c, t = V[V_U], V[V_S], V[V_C], V[V_T]
    rb, d = V[V_RB], V[V_D]
    rot_vec(Ra, abar, u)
    for i in range(3):
        s[i] = V[V_PB, i] - x[i]
    Phi[r] = dot3(u, d) - offset
    cross_into(u, s, c)
    rotT_vec(Ra, c, t)
    for i in range(3):
        B[r, i] = -u[i]
        B[r, 6 + i] = u[i]
        B[r, 3 + i] = t[i]
    cross_into(u, rb, c)
    rotT_vec(Rb, c, t)
    for i in range(3):
        B[r, 9 + i] = -t[i]
    if jac:
        l = lam[r]
        M = W[W_M]
        add_skew_block(H, 0, 3, u, Ra, l, True)
        add_skew_block(H, 6, 3, u, Ra, -l, True)
        add_skew_block(H, 3, 0, u, Ra, -l, False)
        add_skew_block(H, 3, 6, u, Ra, l, False)
        skskw(u, s, M)
        add_RtMR(H, 3, 3, Ra, M, Ra, l)
        skskw(u, rb, M)
        add_RtMR(H, 3, 9, Ra, M, Rb, -l)
        skskw(rb, u, M)
        add_RtMR(H, 9, 3, Rb, M, Ra, -l)
        add_RtMR(H, 9, 9, Rb, M, Rb, l)


@kernel(allocates=True)
def gmat(P, W, V, G):
    """G (3, 12) with δd = G δq: [−I, R_a X_a~, I, −R_b X_b~]."""
    Ra, Rb = W[W_RA], W[W_RB]
    for i in range(3):
        for j in range(12):
            G[i, j] = 0.0
        G[i, i] = -1.0
        G[i, 6 + i] = 1.0
    for i in range(3):
        for j in range(3):
            sa = 0.0
            sb = 0.0
            for k in range(3):
                xa = 0.0
                xb = 0.0
                if (j - k) % 3 == 1:
                    xa = -P[XA + (k + 2) % 3]
                    xb = -P[XB + (k + 2) % 3]
                elif (k - j) % 3 == 1:
                    xa = P[XA + (j + 2) % 3]
                    xb = P[XB + (j + 2) % 3]
                sa += Ra[i, k] * xa
                sb += Rb[i, k] * xb
            G[i, 3 + j] = sa
            G[i, 9 + j] = -sb


@kernel(allocates=True)
def add_arm_blocks(P, H, a, s, W, V):
    """H += s · blockdiag(0, −X_a~(R_aᵀa)~, 0, X_b~(R_bᵀa)~) (derivative of Gᵀa at fixed a)."""
    t, M = V[V_T], W[W_M]
    rotT_vec(W[W_RA], a, t)
    skskw(P[XA:XA + 3], t, M)
    for i in range(3):
        for j in range(3):
            H[3 + i, 3 + j] -= s * M[i, j]
    rotT_vec(W[W_RB], a, t)
    skskw(P[XB:XB + 3], t, M)
    for i in range(3):
        for j in range(3):
            H[9 + i, 9 + j] += s * M[i, j]


@kernel(allocates=True)
def prim_distance(r, P, L, lam, jac, Phi, B, H, W, V, G):
    """Row r: Φ = (d·d − L²)/(2L), B = dᵀG/L (λ = tension of the link).

    H = (λ/L)(GᵀG + blockdiag(0, −X_a~(R_aᵀd)~, 0, X_b~(R_bᵀd)~)).
    """
    d = V[V_D]
    Phi[r] = (dot3(d, d) - L * L) / (2.0 * L)
    gmat(P, W, V, G)
    for j in range(12):
        B[r, j] = (d[0] * G[0, j] + d[1] * G[1, j] + d[2] * G[2, j]) / L
    if jac:
        s = lam[r] / L
        for i in range(12):
            for j in range(12):
                H[i, j] += s * (G[0, i] * G[0, j] + G[1, i] * G[1, j] + G[2, i] * G[2, j])
        add_arm_blocks(P, H, d, s, W, V)


@kernel(allocates=True)
def quadratic_form(v, H):
    """vᵀ H v."""
    acc = 0.0
    n = v.shape[0]
    for i in range(n):
        vi = v[i]
        if vi != 0.0:
            for j in range(n):
                acc += vi * H[i, j] * v[j]
    return acc


@kernel(allocates=True)
def angle_about(P, abar1, abar2, bbar, W, V):
    """atan2(u2·w, u1·w) with u_k = R_a ā_k, w = R_b b̄."""
    u, w = V[V_U], V[V_W]
    rot_vec(W[W_RB], bbar, w)
    rot_vec(W[W_RA], abar1, u)
    c = dot3(u, w)
    rot_vec(W[W_RA], abar2, u)
    s = dot3(u, w)
    return math.atan2(s, c)


def workspace():
    """Python-side workspace (for tests): W (NW, 3, 3), V (NV, 3)."""
    return np.zeros((NW, 3, 3)), np.zeros((NV, 3))
