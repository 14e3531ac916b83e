"""Penalty (compliant) contact: spheres (or points) on planes and on spheres.

Types: :class:`PenaltySphereOnPlane` (planar body, line fixed in space),
:class:`SpatialPenaltySphereOnPlane` (spatial body, plane fixed in space),
:class:`SpatialPenaltySpherePair` (spheres on two spatial bodies),
:class:`SpatialPenaltySphereOnBodyPlane` (sphere on spatial body b, plane fixed to spatial body a).

A force element (role ``"force"``, docs/kernels.md): it runs in femb's compiled engine at
fixed or adaptive steps, planar and spatial, with the exact Jacobians ∂f/∂x (along
x ∘ exp(εw) on spatial nodes) and ∂f/∂v in the iteration matrix, so that stiff contacts
stay implicit. The nonsmooth scheme of ``femb.contact`` (docs/contact.md) enforces
g_N ≥ 0 exactly; this one lets the bodies overlap by δ = −g_N > 0 on purpose (soft
contact).

Geometry (the conventions of :mod:`femb.elements.contact`): sphere centre C = r + R s (s in
body axes, R the body's rotation), plane through p with unit normal n (to the free side),
gap g_N = n·(C − p) − R_s, penetration δ = −g_N, contact point c = C − R_s n, its velocity
v_c = ṙ + ω × (c − r), normal rate δ̇ = −n·v_c, slip velocity v_T = v_c − (n·v_c) n.

Normal force: Hunt & Crossley (1975), Hertz stiffness with a damping term proportional to
the elastic force,

    f_N = max(0, k δⁿ (1 + α δ̇))  for δ > 0, else 0;  n = 3/2 (Hertz) by default.

It is zero and C¹ at δ = 0 (n ≥ 1), never pulls (the damping part is clamped so that
f_N ≥ 0: Hunt & Crossley's model otherwise sticks the bodies during separation) and dissipates
only through α. For a central impact of a mass on the element the restitution coefficient is
a function of α v⁻ alone (v⁻ the approach speed; scale δ by (m v⁻²/k)^{1/(n+1)} and time by
that length over v⁻): :func:`hunt_crossley_damping` solves that one-degree-of-freedom impact for
the α that gives the requested e at the approach speed ``v_ref``. At other speeds the restitution
is e(α v⁻), lower for faster impacts; for e → 1 it tends to Hunt & Crossley's first-order relation
α = 3(1 − e)/(2 v⁻).

Friction: regularized Coulomb, f_T = −μ f_N v_T / √(|v_T|² + ε_v²), a viscous law below the
slip speed ε_v (``eps_v``, m/s) and Coulomb's law above it; a "sticking" contact creeps at a
speed ≈ ε_v |f_T|/(μ f_N) < ε_v.

The force F = f_N n + f_T acts on the body at the contact point c: generalized force
(F, (c − r) × F) (planar: the z-moment; spatial: Rᵀ((c − r) × F) in body axes). The elastic
potential V = k δⁿ⁺¹/(n + 1) is the ``"energy"`` role (``work = "potential"``): the damping
and friction forces, f(q, v) − f(q, 0), are counted as dissipated by ``Result.energy()``.

References
----------
K. H. Hunt, F. R. E. Crossley, Coefficient of restitution interpreted as damping in vibroimpact,
J. Appl. Mech. 42 (1975) 440–445.
K. L. Johnson, Contact Mechanics, Cambridge University Press, 1985, §4.2 (Hertz), §11.4 (impact).
P. Flores, M. Machado, M. T. Silva, J. M. Martins, On the continuous contact force models for soft
materials in multibody dynamics, Multibody Syst. Dyn. 25 (2011) 357–375 (the family of such laws).
"""
from __future__ import annotations

import functools
import math

import numpy as np

from femb.base.jit import kernel
from femb.base.rotations import quat_to_matrix_t
from femb.errors import ModelError
from femb.system.element import Element

from ._spatial import I9, add3, cross3, dot3, mm, mtm, mtv, mv, neg9, outer_minus, scale3, sub3

#: columns of P: s (3), R_s, p (3), n (3), k, n_exp, α, μ, ε_v
NPAR = 15
Z9 = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


# ---------------------------------------------------------------------------
# 3 × 3 helpers (row-major 9-tuples, no allocation)
# ---------------------------------------------------------------------------
@kernel
def skew(a):
    """ã with ã b = a × b."""
    return (0.0, -a[2], a[1], a[2], 0.0, -a[0], -a[1], a[0], 0.0)


@kernel
def outer_lin(u, g, c, Q, V):
    """u gᵀ − c Q V (3 × 3)."""
    QV = mm(Q, V)
    return (u[0] * g[0] - c * QV[0], u[0] * g[1] - c * QV[1], u[0] * g[2] - c * QV[2],
            u[1] * g[0] - c * QV[3], u[1] * g[1] - c * QV[4], u[1] * g[2] - c * QV[5],
            u[2] * g[0] - c * QV[6], u[2] * g[1] - c * QV[7], u[2] * g[2] - c * QV[8])


@kernel
def add9(A, B):
    return (A[0] + B[0], A[1] + B[1], A[2] + B[2], A[3] + B[3], A[4] + B[4], A[5] + B[5],
            A[6] + B[6], A[7] + B[7], A[8] + B[8])


@kernel
def lin3(s, a, t, b):
    """s a + t b (3-vectors)."""
    return (s * a[0] + t * b[0], s * a[1] + t * b[1], s * a[2] + t * b[2])


@kernel
def sub9(A, B):
    return (A[0] - B[0], A[1] - B[1], A[2] - B[2], A[3] - B[3], A[4] - B[4], A[5] - B[5],
            A[6] - B[6], A[7] - B[7], A[8] - B[8])


@kernel
def put_block(out, e, i0, j0, M):
    """out[e, i0:i0+3, j0:j0+3] = M."""
    for i in range(3):
        for j in range(3):
            out[e, i0 + i, j0 + j] = M[3 * i + j]


# ---------------------------------------------------------------------------
# the contact law
# ---------------------------------------------------------------------------
@kernel
def hunt_crossley(delta, delta_d, k, nexp, alpha):
    """Normal force f_N = max(0, k δⁿ (1 + α δ̇)) (δ > 0; else 0) and its partial derivatives.

    Returns
    -------
    (f_N, ∂f_N/∂δ, ∂f_N/∂δ̇) : floats (N, N/m, N s/m); zeros where f_N = 0.
    """
    if not delta > 0.0:
        return 0.0, 0.0, 0.0
    damp = 1.0 + alpha * delta_d
    if not damp > 0.0:
        return 0.0, 0.0, 0.0
    dn1 = delta ** (nexp - 1.0)
    sig = k * dn1 * delta
    return sig * damp, nexp * k * dn1 * damp, sig * alpha


@kernel
def sphere_plane_law(P, e, r, a, om, rd):
    """Gap, force and slip of one sphere on its plane, world axes.

    Parameters
    ----------
    P : (nel, 15) parameters; e : element
    r, a, om, rd : 3-tuples: node position, lever R s of the sphere centre, angular velocity ω,
        node velocity ṙ (space axes).

    Returns
    -------
    g, δ̇, f_N, dfd = ∂f_N/∂δ, dfv = ∂f_N/∂δ̇, F (3), v_T (3), d = c − r (3), u = F/f_N (3),
    ρ = √(|v_T|² + ε_v²)
    """
    Rs = P[e, 3]
    n = (P[e, 7], P[e, 8], P[e, 9])
    g = n[0] * (r[0] + a[0] - P[e, 4]) + n[1] * (r[1] + a[1] - P[e, 5]) + n[2] * (r[2] + a[2] - P[e, 6]) - Rs
    d = sub3(a, scale3(Rs, n))
    vc = add3(rd, cross3(om, d))
    vn = dot3(n, vc)
    fN, dfd, dfv = hunt_crossley(-g, -vn, P[e, 10], P[e, 11], P[e, 12])
    vT = sub3(vc, scale3(vn, n))
    eps = P[e, 14]
    rho = math.sqrt(dot3(vT, vT) + eps * eps)
    mr = P[e, 13] / rho
    u = (n[0] - mr * vT[0], n[1] - mr * vT[1], n[2] - mr * vT[2])
    return g, -vn, fN, dfd, dfv, scale3(fN, u), vT, d, u, rho


@kernel
def sphere_plane_jacobian(P, e, a, d, om, fN, dfd, dfv, vT, u, rho):
    """∂F/∂(δr, δφ, ṙ, ω) of :func:`sphere_plane_law` (δφ a rotation increment in space axes).

    With P_n = I − n nᵀ, Q = P_n − v_T v_Tᵀ/ρ², c_T = μ f_N/ρ, V_φ = ∂v_c/∂φ = d̃ ω̃ − ω̃ ã and
    u = n − μ v_T/ρ (F = f_N u):

    * F_r = u ⊗ (−dfd n),
    * F_φ = u ⊗ (−dfd (a × n) − dfv V_φᵀ n) − c_T Q V_φ,
    * F_v = u ⊗ (−dfv n) − c_T Q,
    * F_ω = u ⊗ (−dfv (a × n)) + c_T Q d̃.

    Returns the four 9-tuples.
    """
    n = (P[e, 7], P[e, 8], P[e, 9])
    cT = P[e, 13] * fN / rho
    r2 = 1.0 / (rho * rho)
    Q = (1.0 - n[0] * n[0] - r2 * vT[0] * vT[0], -n[0] * n[1] - r2 * vT[0] * vT[1], -n[0] * n[2] - r2 * vT[0] * vT[2],
         -n[1] * n[0] - r2 * vT[1] * vT[0], 1.0 - n[1] * n[1] - r2 * vT[1] * vT[1], -n[1] * n[2] - r2 * vT[1] * vT[2],
         -n[2] * n[0] - r2 * vT[2] * vT[0], -n[2] * n[1] - r2 * vT[2] * vT[1], 1.0 - n[2] * n[2] - r2 * vT[2] * vT[2])
    dt = skew(d)
    wt = skew(om)
    Vphi = sub9(mm(dt, wt), mm(wt, skew(a)))
    an = cross3(a, n)
    Vn = mtv(Vphi, n)
    Z = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    Fr = outer_lin(u, scale3(-dfd, n), 0.0, Z, Z)
    Fphi = outer_lin(u, (-dfd * an[0] - dfv * Vn[0], -dfd * an[1] - dfv * Vn[1], -dfd * an[2] - dfv * Vn[2]),
                     cT, Q, Vphi)
    I9 = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    Fv = outer_lin(u, scale3(-dfv, n), cT, Q, I9)
    Fw = outer_lin(u, scale3(-dfv, an), -cT, Q, dt)
    return Fr, Fphi, Fv, Fw


@kernel
def moment_jacobian(a, d, F, Fr, Fphi, Fv, Fw):
    """∂m/∂(δr, δφ, ṙ, ω) of m = d × F, d = a − R_s n (δd = δφ × a): d̃ F_r, F̃ ã + d̃ F_φ, d̃ F_v, d̃ F_ω."""
    dt = skew(d)
    return mm(dt, Fr), add9(mm(skew(F), skew(a)), mm(dt, Fphi)), mm(dt, Fv), mm(dt, Fw)


# ---------------------------------------------------------------------------
# kernels: planar (x, y, θ) and spatial (r, quaternion | ṙ, Ω) nodes
# ---------------------------------------------------------------------------
@kernel
def _planar_frame(P, xe, ve, e):
    c, s = math.cos(xe[e, 2]), math.sin(xe[e, 2])
    r = (xe[e, 0], xe[e, 1], 0.0)
    a = (c * P[e, 0] - s * P[e, 1], s * P[e, 0] + c * P[e, 1], 0.0)
    return r, a, (0.0, 0.0, ve[e, 2]), (ve[e, 0], ve[e, 1], 0.0)


@kernel
def planar_penalty_force(P, t, tf, xe, ve, jac, fe, fq, fv):
    """Penalty sphere (disc) on a line, planar node (x, y, θ): f = (F_x, F_y, ((c − r) × F)_z).

    P = (s (3, z = 0), R_s, p (3), n (3), k, n, α, μ, ε_v); Jacobians: the x, y and z-rotation
    rows and columns of :func:`sphere_plane_jacobian` and :func:`moment_jacobian`.
    """
    for e in range(xe.shape[0]):
        r, a, om, rd = _planar_frame(P, xe, ve, e)
        g, gd, fN, dfd, dfv, F, vT, d, u, rho = sphere_plane_law(P, e, r, a, om, rd)
        if fN == 0.0:
            continue
        fe[e, 0] = F[0]
        fe[e, 1] = F[1]
        fe[e, 2] = d[0] * F[1] - d[1] * F[0]
        if not jac:
            continue
        Fr, Fphi, Fv, Fw = sphere_plane_jacobian(P, e, a, d, om, fN, dfd, dfv, vT, u, rho)
        mr, mphi, mvv, mw = moment_jacobian(a, d, F, Fr, Fphi, Fv, Fw)
        for i in range(2):
            for j in range(2):
                fq[e, i, j] = Fr[3 * i + j]
                fv[e, i, j] = Fv[3 * i + j]
            fq[e, i, 2] = Fphi[3 * i + 2]
            fv[e, i, 2] = Fw[3 * i + 2]
            fq[e, 2, i] = mr[6 + i]
            fv[e, 2, i] = mvv[6 + i]
        fq[e, 2, 2] = mphi[8]
        fv[e, 2, 2] = mw[8]


@kernel
def _spatial_frame(P, xe, ve, e):
    Rm = quat_to_matrix_t(xe[e, 3], xe[e, 4], xe[e, 5], xe[e, 6])
    r = (xe[e, 0], xe[e, 1], xe[e, 2])
    a = mv(Rm, (P[e, 0], P[e, 1], P[e, 2]))
    om = mv(Rm, (ve[e, 3], ve[e, 4], ve[e, 5]))
    return Rm, r, a, om, (ve[e, 0], ve[e, 1], ve[e, 2])


@kernel
def spatial_penalty_force(P, t, tf, xe, ve, jac, fe, fq, fv):
    """Penalty sphere on a plane, spatial frame node: f = (F, Rᵀ((c − r) × F)).

    Along R ← R exp(δθ̃) (δφ = R δθ) and ω = RΩ:
    f_q = [[F_r, F_φ R], [Rᵀ m_r, (Rᵀm)~ + Rᵀ m_φ R]], f_v = [[F_v, F_ω R], [Rᵀ m_v, Rᵀ m_ω R]]
    with m = (c − r) × F and the blocks of :func:`sphere_plane_jacobian`, :func:`moment_jacobian`.
    P as :func:`planar_penalty_force`.
    """
    for e in range(xe.shape[0]):
        Rm, r, a, om, rd = _spatial_frame(P, xe, ve, e)
        g, gd, fN, dfd, dfv, F, vT, d, u, rho = sphere_plane_law(P, e, r, a, om, rd)
        if fN == 0.0:
            continue
        m = cross3(d, F)
        mb = mtv(Rm, m)
        for i in range(3):
            fe[e, i] = F[i]
            fe[e, 3 + i] = mb[i]
        if not jac:
            continue
        Fr, Fphi, Fv, Fw = sphere_plane_jacobian(P, e, a, d, om, fN, dfd, dfv, vT, u, rho)
        mr, mphi, mvv, mw = moment_jacobian(a, d, F, Fr, Fphi, Fv, Fw)
        put_block(fq, e, 0, 0, Fr)
        put_block(fq, e, 0, 3, mm(Fphi, Rm))
        put_block(fq, e, 3, 0, mtm(Rm, mr))
        put_block(fq, e, 3, 3, add9(skew(mb), mm(mtm(Rm, mphi), Rm)))
        put_block(fv, e, 0, 0, Fv)
        put_block(fv, e, 0, 3, mm(Fw, Rm))
        put_block(fv, e, 3, 0, mtm(Rm, mvv))
        put_block(fv, e, 3, 3, mm(mtm(Rm, mw), Rm))


@kernel
def _hertz_potential(P, e, g):
    """V = k δⁿ⁺¹/(n + 1) for δ = −g > 0, else 0."""
    if not g < 0.0:
        return 0.0
    n1 = P[e, 11] + 1.0
    return P[e, 10] * (-g) ** n1 / n1


@kernel
def planar_penalty_energy(P, t, tf, xe, Ve):
    """Elastic potential of :func:`planar_penalty_force` (its force at v = 0 is −∂V/∂q)."""
    for e in range(xe.shape[0]):
        c, s = math.cos(xe[e, 2]), math.sin(xe[e, 2])
        g = (P[e, 7] * (xe[e, 0] + c * P[e, 0] - s * P[e, 1] - P[e, 4])
             + P[e, 8] * (xe[e, 1] + s * P[e, 0] + c * P[e, 1] - P[e, 5]) - P[e, 3])
        Ve[e] = _hertz_potential(P, e, g)


@kernel
def spatial_penalty_energy(P, t, tf, xe, Ve):
    """Elastic potential of :func:`spatial_penalty_force`."""
    for e in range(xe.shape[0]):
        Rm = quat_to_matrix_t(xe[e, 3], xe[e, 4], xe[e, 5], xe[e, 6])
        a = mv(Rm, (P[e, 0], P[e, 1], P[e, 2]))
        g = (P[e, 7] * (xe[e, 0] + a[0] - P[e, 4]) + P[e, 8] * (xe[e, 1] + a[1] - P[e, 5])
             + P[e, 9] * (xe[e, 2] + a[2] - P[e, 6]) - P[e, 3])
        Ve[e] = _hertz_potential(P, e, g)


@kernel
def penalty_state(P, xe, ve, spatial, out):
    """Outputs of a batch at one state: out[e] = (g_N, ġ_N, f_N, F_T (3), v_T (3)), space axes.

    ``spatial``: 1.0 for frame nodes (x = (r, quaternion)), 0.0 for planar nodes.
    """
    for e in range(xe.shape[0]):
        if spatial > 0.0:
            Rm, r, a, om, rd = _spatial_frame(P, xe, ve, e)
        else:
            r, a, om, rd = _planar_frame(P, xe, ve, e)
        g, gd, fN, dfd, dfv, F, vT, d, u, rho = sphere_plane_law(P, e, r, a, om, rd)
        out[e, 0] = g
        out[e, 1] = -gd
        out[e, 2] = fN
        for i in range(3):
            out[e, 3 + i] = F[i] - fN * P[e, 7 + i]
            out[e, 6 + i] = vT[i]


# ---------------------------------------------------------------------------
# contacts between two spatial bodies a and b (tuples, no allocation)
# ---------------------------------------------------------------------------
@kernel
def lin9(s, A, t, B):
    """s A + t B (3 × 3)."""
    return (s * A[0] + t * B[0], s * A[1] + t * B[1], s * A[2] + t * B[2], s * A[3] + t * B[3],
            s * A[4] + t * B[4], s * A[5] + t * B[5], s * A[6] + t * B[6], s * A[7] + t * B[7],
            s * A[8] + t * B[8])


@kernel
def pick9(j, A0, A1, A2, A3):
    """Column block j of a 3 × 12 matrix [A0, A1, A2, A3] (9-tuples)."""
    if j == 0:
        return A0
    if j == 1:
        return A1
    if j == 2:
        return A2
    return A3


@kernel
def _rows3(ve, e, o):
    return (ve[e, o], ve[e, o + 1], ve[e, o + 2])


@kernel
def _frames2(xe, ve, e):
    """R_a, R_b (9-tuples) and ω_a = R_a Ω_a, ω_b = R_b Ω_b of xe = (r_a, p_a, r_b, p_b), ve = (ṙ_a, Ω_a, ṙ_b, Ω_b)."""
    Ra = quat_to_matrix_t(xe[e, 3], xe[e, 4], xe[e, 5], xe[e, 6])
    Rb = quat_to_matrix_t(xe[e, 10], xe[e, 11], xe[e, 12], xe[e, 13])
    return Ra, Rb, mv(Ra, _rows3(ve, e, 3)), mv(Rb, _rows3(ve, e, 9))


@kernel
def two_body_law(P, e, c0, g, n, v):
    """The law of the module docstring for gap g, normal n and velocity v (b's point at c against a's).

    P[e, c0:c0 + 5] = (k, n, α, μ, ε_v). Returns (f_N, ∂f_N/∂δ, ∂f_N/∂δ̇, c_T = μ f_N/ρ, ρ) and
    (F, v_T, u) (3-tuples, F = f_N u, u = n − μ v_T/ρ).
    """
    vn = dot3(n, v)
    fN, dfd, dfv = hunt_crossley(-g, -vn, P[e, c0], P[e, c0 + 1], P[e, c0 + 2])
    vT = sub3(v, scale3(vn, n))
    eps = P[e, c0 + 4]
    rho = math.sqrt(dot3(vT, vT) + eps * eps)
    mr = P[e, c0 + 3] / rho
    u = (n[0] - mr * vT[0], n[1] - mr * vT[1], n[2] - mr * vT[2])
    return (fN, dfd, dfv, mr * fN, rho), (scale3(fN, u), vT, u)


@kernel
def two_body_block(j, Dn, Dc, Dg, geo, law, vecs):
    """Column block j of the world-axes Jacobians (3 × 12) of F, m_a = −d_a × F and m_b = d_b × F for a
    contact between bodies a and b, along y = (δr_a, δφ_a, δr_b, δφ_b) (δφ rotation increments in space
    axes) and along (ṙ_a, ω_a, ṙ_b, ω_b).

    Dn, Dc (9-tuples), Dg (3-tuple): block j of ∂n/∂y, ∂c/∂y, ∂g/∂y; geo = (n, v, d_a, d_b, ω_a, ω_b),
    d_k = c − r_k; law, vecs from :func:`two_body_law`. With ∂d_a/∂y = Dc − [I, 0, 0, 0],
    ∂d_b/∂y = Dc − [0, 0, I, 0], V_y = ∂v/∂y = ω̃_b ∂d_b/∂y − ω̃_a ∂d_a/∂y + [0, −d̃_a ω̃_a, 0, d̃_b ω̃_b]
    (δω = δφ × ω), V_v = [−I, d̃_a, I, −d̃_b], P_n = I − n nᵀ, K = I − v_T v_Tᵀ/ρ²:

    * F_y = u (−dfd Dg − dfv (Dnᵀv + V_yᵀn))ᵀ + f_N Dn − c_T K (P_n V_y − (n·v I + n vᵀ) Dn),
    * F_v = u (−dfv V_vᵀn)ᵀ − c_T K P_n V_v,
    * m_a,y = F̃ ∂d_a/∂y − d̃_a F_y, m_a,v = −d̃_a F_v, m_b,y = −F̃ ∂d_b/∂y + d̃_b F_y, m_b,v = d̃_b F_v.

    Returns the six 3 × 3 blocks (F_y, F_v, m_a,y, m_a,v, m_b,y, m_b,v).
    """
    n, v, da, db, wa, wb = geo
    fN, dfd, dfv, cT, rho = law
    F, vT, u = vecs
    Dda = sub9(Dc, I9) if j == 0 else Dc
    Ddb = sub9(Dc, I9) if j == 2 else Dc
    Swa, Swb = skew(wa), skew(wb)
    dta, dtb = skew(da), skew(db)
    Vy = sub9(mm(Swb, Ddb), mm(Swa, Dda))
    if j == 1:
        Vy = sub9(Vy, mm(dta, Swa))
    elif j == 3:
        Vy = add9(Vy, mm(dtb, Swb))
    Vv = pick9(j, neg9(I9), dta, I9, neg9(dtb))
    vn = dot3(n, v)
    gy = lin3(-dfd, Dg, -dfv, add3(mtv(Dn, v), mtv(Vy, n)))
    gv = scale3(-dfv, mtv(Vv, n))
    Pn = neg9(outer_minus(n, n, 1.0, I9))
    K = lin9(1.0, I9, -1.0 / (rho * rho), outer_minus(vT, vT, 0.0, I9))
    dvTy = sub9(mm(Pn, Vy), mm(outer_minus(n, v, -vn, I9), Dn))
    Fy = add9(outer_lin(u, gy, cT, K, dvTy), lin9(fN, Dn, 0.0, Dn))
    Fv = outer_lin(u, gv, cT, mm(K, Pn), Vv)
    SF = skew(F)
    may = sub9(mm(SF, Dda), mm(dta, Fy))
    mby = sub9(mm(dtb, Fy), mm(SF, Ddb))
    return Fy, Fv, may, neg9(mm(dta, Fv)), mby, mm(dtb, Fv)


@kernel
def put_column(out, e, j, Ra, Rb, J, Ja, Jb):
    """Column block j of a two-body Jacobian along R_k ← R_k exp(δθ̃_k): rows (−J, R_aᵀ J_a, J, R_bᵀ J_b),
    each times R_a (j = 1) or R_b (j = 3) on the right."""
    if j == 1:
        J, Ja, Jb = mm(J, Ra), mm(Ja, Ra), mm(Jb, Ra)
    elif j == 3:
        J, Ja, Jb = mm(J, Rb), mm(Ja, Rb), mm(Jb, Rb)
    c = 3 * j
    put_block(out, e, 0, c, neg9(J))
    put_block(out, e, 3, c, mtm(Ra, Ja))
    put_block(out, e, 6, c, J)
    put_block(out, e, 9, c, mtm(Rb, Jb))


@kernel
def put_forces(fe, fq, e, jac, Ra, Rb, da, db, F):
    """fe[e] = (−F, R_aᵀ m_a, F, R_bᵀ m_b), m_a = −d_a × F, m_b = d_b × F; with ``jac``, adds (R_kᵀ m_k)~ to
    fq[e] at (θ_k, θ_k) (the derivative of R_kᵀ along R_k exp(δθ̃_k))."""
    mab = mtv(Ra, cross3(F, da))
    mbb = mtv(Rb, cross3(db, F))
    for i in range(3):
        fe[e, i] = -F[i]
        fe[e, 3 + i] = mab[i]
        fe[e, 6 + i] = F[i]
        fe[e, 9 + i] = mbb[i]
    if jac:
        Sa, Sb = skew(mab), skew(mbb)
        for i in range(3):
            for k in range(3):
                fq[e, 3 + i, 3 + k] += Sa[3 * i + k]
                fq[e, 9 + i, 9 + k] += Sb[3 * i + k]


@kernel
def put_state(out, e, g, n, v, law, vecs):
    """out[e] = (g_N, ġ_N = n·v, f_N, F_T = F − f_N n (3), v_T (3))."""
    fN = law[0]
    F, vT = vecs[0], vecs[1]
    out[e, 0] = g
    out[e, 1] = dot3(n, v)
    out[e, 2] = fN
    for i in range(3):
        out[e, 3 + i] = F[i] - fN * n[i]
        out[e, 6 + i] = vT[i]


# ---------------------------------------------------------------------------
# spatial sphere–sphere between two bodies
# ---------------------------------------------------------------------------
@kernel
def sphere_pair_law(P, xe, ve, e):
    """Geometry, force and slip of one sphere pair, space axes.

    P = (s_a (3), s_b (3), R_a, R_b, w, k, n, α, μ, ε_v), w = R_a/(R_a + R_b); xe = (r_a, p_a, r_b, p_b).
    Returns (R_a, R_b), (a_a, a_b) (the levers R_k s_k), e = C_b − C_a, L = |e|, g,
    geo = (n, v, d_a, d_b, ω_a, ω_b) (d_k = c − r_k, c = C_a + w e) and law, vecs of :func:`two_body_law`.
    """
    Ra, Rb, wa, wb = _frames2(xe, ve, e)
    aa = mv(Ra, (P[e, 0], P[e, 1], P[e, 2]))
    ab = mv(Rb, (P[e, 3], P[e, 4], P[e, 5]))
    ev = sub3(add3(_rows3(xe, e, 7), ab), add3(_rows3(xe, e, 0), aa))
    L = math.sqrt(dot3(ev, ev))
    n = scale3(1.0 / L, ev)
    w = P[e, 8]
    da = add3(aa, scale3(w, ev))
    db = sub3(ab, scale3(1.0 - w, ev))
    v = sub3(add3(_rows3(ve, e, 6), cross3(wb, db)), add3(_rows3(ve, e, 0), cross3(wa, da)))
    g = L - P[e, 6] - P[e, 7]
    law, vecs = two_body_law(P, e, 9, g, n, v)
    return (Ra, Rb), (aa, ab), L, g, (n, v, da, db, wa, wb), law, vecs


@kernel
def sphere_pair_force(P, t, tf, xe, ve, jac, fe, fq, fv):
    """Penalty contact of a sphere on spatial body a with a sphere on spatial body b.

    f = (−F, −R_aᵀ(d_a × F), F, R_bᵀ(d_b × F)): F on b and −F on a at the contact point
    c = C_a + w e, d_k = c − r_k. Geometry derivatives (E = ∂e/∂y = [−I, ã_a, I, −ã_b]):
    ∂n/∂y = P_n E/L, ∂g/∂y = Eᵀn, ∂c/∂y = [I, −ã_a, 0, 0] + w E; then :func:`two_body_block` per column
    block, along R_k ← R_k exp(δθ̃_k) (δφ_k = R_k δθ_k, ω_k = R_k Ω_k) by :func:`put_column`, :func:`put_forces`.
    """
    for e in range(xe.shape[0]):
        (Ra, Rb), (aa, ab), L, g, geo, law, vecs = sphere_pair_law(P, xe, ve, e)
        if law[0] == 0.0:
            continue
        n = geo[0]
        if jac:
            w = P[e, 8]
            PnL = lin9(1.0 / L, I9, -1.0 / L, outer_minus(n, n, 0.0, I9))
            Sa, Sb = skew(aa), skew(ab)
            for j in range(4):
                E = pick9(j, neg9(I9), Sa, I9, neg9(Sb))
                C0 = pick9(j, I9, neg9(Sa), Z9, Z9)
                Fy, Fv, may, mav, mby, mbv = two_body_block(j, mm(PnL, E), lin9(1.0, C0, w, E), mtv(E, n),
                                                            geo, law, vecs)
                put_column(fq, e, j, Ra, Rb, Fy, may, mby)
                put_column(fv, e, j, Ra, Rb, Fv, mav, mbv)
        put_forces(fe, fq, e, jac, Ra, Rb, geo[2], geo[3], vecs[0])


@kernel
def sphere_pair_energy(P, t, tf, xe, Ve):
    """Elastic potential k δⁿ⁺¹/(n + 1) of :func:`sphere_pair_force`, δ = R_a + R_b − |C_b − C_a|."""
    for e in range(xe.shape[0]):
        Ra = quat_to_matrix_t(xe[e, 3], xe[e, 4], xe[e, 5], xe[e, 6])
        Rb = quat_to_matrix_t(xe[e, 10], xe[e, 11], xe[e, 12], xe[e, 13])
        aa = mv(Ra, (P[e, 0], P[e, 1], P[e, 2]))
        ab = mv(Rb, (P[e, 3], P[e, 4], P[e, 5]))
        ev = (xe[e, 7] + ab[0] - xe[e, 0] - aa[0], xe[e, 8] + ab[1] - xe[e, 1] - aa[1],
              xe[e, 9] + ab[2] - xe[e, 2] - aa[2])
        g = math.sqrt(dot3(ev, ev)) - P[e, 6] - P[e, 7]
        Ve[e] = 0.0 if not g < 0.0 else P[e, 9] * (-g) ** (P[e, 10] + 1.0) / (P[e, 10] + 1.0)


@kernel
def sphere_pair_state(P, xe, ve, out):
    """out[e] = (g_N, ġ_N, f_N, F_T (3), v_T (3)) of each pair, space axes (F_T on b, v_T of b against a)."""
    for e in range(xe.shape[0]):
        R, lev, L, g, geo, law, vecs = sphere_pair_law(P, xe, ve, e)
        put_state(out, e, g, geo[0], geo[1], law, vecs)


# ---------------------------------------------------------------------------
# spatial sphere on a plane fixed to another body
# ---------------------------------------------------------------------------
@kernel
def body_plane_law(P, xe, ve, e):
    """Geometry, force and slip of a sphere on body b against a plane fixed to body a, space axes.

    P = (p̄ (3), n̄ (3) in a's axes, s_b (3), R_s, k, n, α, μ, ε_v); xe = (r_a, p_a, r_b, p_b).
    Plane point P = r_a + R_a p̄, normal n = R_a n̄, centre C = r_b + R_b s_b, g = n·(C − P) − R_s,
    contact point c = C − R_s n. Returns (R_a, R_b), (p = R_a p̄, a_b = R_b s_b), C − P, g,
    geo = (n, v, d_a, d_b, ω_a, ω_b) (d_k = c − r_k; v: b's point at c against a's) and law, vecs of
    :func:`two_body_law`.
    """
    Ra, Rb, wa, wb = _frames2(xe, ve, e)
    pw = mv(Ra, (P[e, 0], P[e, 1], P[e, 2]))
    n = mv(Ra, (P[e, 3], P[e, 4], P[e, 5]))
    ab = mv(Rb, (P[e, 6], P[e, 7], P[e, 8]))
    rb = _rows3(xe, e, 7)
    CP = sub3(add3(rb, ab), add3(_rows3(xe, e, 0), pw))
    g = dot3(n, CP) - P[e, 9]
    db = sub3(ab, scale3(P[e, 9], n))
    da = sub3(add3(rb, db), _rows3(xe, e, 0))
    v = sub3(add3(_rows3(ve, e, 6), cross3(wb, db)), add3(_rows3(ve, e, 0), cross3(wa, da)))
    law, vecs = two_body_law(P, e, 10, g, n, v)
    return (Ra, Rb), (pw, ab), CP, g, (n, v, da, db, wa, wb), law, vecs


@kernel
def body_plane_force(P, t, tf, xe, ve, jac, fe, fq, fv):
    """Penalty sphere (on body b) against a plane fixed to body a: F on b at c, −F on a at c.

    Derivatives of the geometry of :func:`body_plane_law` (δn = δφ_a × n, δC = δr_b − ã_b δφ_b,
    δP = δr_a − p̃ δφ_a): Dn = [0, −ñ, 0, 0], D(C − P) = [−I, p̃, I, −ã_b], Dg = Dnᵀ(C − P) + D(C − P)ᵀn,
    Dc = [0, 0, I, −ã_b] − R_s Dn; then :func:`two_body_block` per column block, :func:`put_column`,
    :func:`put_forces`.
    """
    for e in range(xe.shape[0]):
        (Ra, Rb), (pw, ab), CP, g, geo, law, vecs = body_plane_law(P, xe, ve, e)
        if law[0] == 0.0:
            continue
        if jac:
            n = geo[0]
            Sn, Sb = skew(n), skew(ab)
            for j in range(4):
                Dn = pick9(j, Z9, neg9(Sn), Z9, Z9)
                DCP = pick9(j, neg9(I9), skew(pw), I9, neg9(Sb))
                Dc = lin9(1.0, pick9(j, Z9, Z9, I9, neg9(Sb)), -P[e, 9], Dn)
                Fy, Fv, may, mav, mby, mbv = two_body_block(j, Dn, Dc, add3(mtv(Dn, CP), mtv(DCP, n)),
                                                            geo, law, vecs)
                put_column(fq, e, j, Ra, Rb, Fy, may, mby)
                put_column(fv, e, j, Ra, Rb, Fv, mav, mbv)
        put_forces(fe, fq, e, jac, Ra, Rb, geo[2], geo[3], vecs[0])


@kernel
def body_plane_energy(P, t, tf, xe, Ve):
    """Elastic potential k δⁿ⁺¹/(n + 1) of :func:`body_plane_force`, δ = R_s − n·(C − P)."""
    for e in range(xe.shape[0]):
        Ra = quat_to_matrix_t(xe[e, 3], xe[e, 4], xe[e, 5], xe[e, 6])
        Rb = quat_to_matrix_t(xe[e, 10], xe[e, 11], xe[e, 12], xe[e, 13])
        pw = mv(Ra, (P[e, 0], P[e, 1], P[e, 2]))
        n = mv(Ra, (P[e, 3], P[e, 4], P[e, 5]))
        ab = mv(Rb, (P[e, 6], P[e, 7], P[e, 8]))
        CP = (xe[e, 7] + ab[0] - xe[e, 0] - pw[0], xe[e, 8] + ab[1] - xe[e, 1] - pw[1],
              xe[e, 9] + ab[2] - xe[e, 2] - pw[2])
        Ve[e] = _body_plane_potential(P, e, dot3(n, CP) - P[e, 9])


@kernel
def _body_plane_potential(P, e, g):
    if not g < 0.0:
        return 0.0
    n1 = P[e, 11] + 1.0
    return P[e, 10] * (-g) ** n1 / n1


@kernel
def body_plane_state(P, xe, ve, out):
    """out[e] = (g_N, ġ_N, f_N, F_T (3), v_T (3)), space axes (F_T on b, v_T of b against a)."""
    for e in range(xe.shape[0]):
        R, lev, CP, g, geo, law, vecs = body_plane_law(P, xe, ve, e)
        put_state(out, e, g, geo[0], geo[1], law, vecs)


# ---------------------------------------------------------------------------
# Hunt–Crossley damping for a given restitution
# ---------------------------------------------------------------------------
@functools.lru_cache(maxsize=64)
def restitution_of(c, exponent=1.5):
    """Restitution e of a central Hunt–Crossley impact as a function of c = α v⁻.

    Solves the impact in the scaled variables of the module docstring,
    x″ = −xⁿ max(0, 1 + c x′), x(0) = 0, x′(0) = 1, until x returns to 0; e = −x′ there.
    """
    from scipy.integrate import solve_ivp

    def rhs(_, y):
        x = max(y[0], 0.0)
        return (y[1], -x ** exponent * max(0.0, 1.0 + c * y[1]))

    def back(_, y):
        return y[0]

    back.terminal, back.direction = True, -1.0
    sol = solve_ivp(rhs, (0.0, 100.0), (0.0, 1.0), method="DOP853", rtol=1e-11, atol=1e-13, events=back)
    if not sol.t_events[0].size:
        raise ModelError(f"Hunt–Crossley restitution for α v = {c:g}: the impact did not end (internal error)")
    return float(-sol.y_events[0][0][1])


@functools.lru_cache(maxsize=64)
def hunt_crossley_damping(restitution, v_ref, exponent=1.5):
    """α (s/m) such that a central impact at approach speed ``v_ref`` rebounds with ``restitution``.

    Parameters
    ----------
    restitution : float in (0, 1]
    v_ref : float > 0
        Approach speed (m/s) at which e is exact.
    exponent : float ≥ 1

    Returns
    -------
    float
        α = c/v_ref with e(c) = restitution (:func:`restitution_of`, solved by bisection on c);
        0 for e = 1.
    """
    from scipy.optimize import brentq

    if restitution >= 1.0:
        return 0.0
    hi = 1.0
    while restitution_of(hi, exponent) > restitution:
        hi *= 4.0
        if hi > 1e9:
            raise ModelError(f"restitution {restitution:g} is too small for the Hunt–Crossley law")
    c = brentq(lambda x: restitution_of(x, exponent) - restitution, 0.0, hi, xtol=1e-12, rtol=1e-12)
    return c / v_ref


# ---------------------------------------------------------------------------
# element types
# ---------------------------------------------------------------------------
def _resolve_two_bodies(el, owner, lookup):
    """Resolve ``el.a`` and ``el.b`` to two different spatial bodies (ModelError naming ``owner``)."""
    for role in ("a", "b"):
        body = lookup(getattr(el, role), role)
        if getattr(body, "node", None) is None or not getattr(body.node, "rotation_blocks", ()):
            raise ModelError(f"{owner}: {role} must be a spatial body, got {getattr(body, 'name', body)!r}")
        setattr(el, role, body)
    if el.a is el.b:
        raise ModelError(f"{owner}: bodies a and b are the same ('{el.a.name}')")


def _num(owner, what, value, lo=None, lo_open=False, hi=None):
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ModelError(f"{owner}: {what} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise ModelError(f"{owner}: {what} must be finite, got {value!r}")
    if lo is not None and (v < lo or (lo_open and v == lo)):
        raise ModelError(f"{owner}: {what} must be {'>' if lo_open else '≥'} {lo:g}, got {v:g}")
    if hi is not None and v > hi:
        raise ModelError(f"{owner}: {what} must be ≤ {hi:g}, got {v:g}")
    return v


def _vec(owner, what, value, dim, unit=False):
    from .contact import _vector

    v = _vector(owner, what, value, dim)
    if unit:
        L = float(np.linalg.norm(v))
        if L < 1e-12:
            raise ModelError(f"{owner}: {what} must be a non-zero vector, got {value!r}")
        v = v / L
    return v


class _PenaltyLaw(Element):
    """The contact law's parameters (checked) and the named outputs, shared by every penalty type.

    Subclasses set ``_state(P, xe, ve, out)`` (the compiled outputs kernel) through
    :meth:`_state_values` and name their tangent components in :meth:`_tangent_rows`.
    """

    has_force = True
    force_depends_on_qd = True
    work = "potential"
    #: column of ε_v in P
    _eps_col = 14
    #: suffixes of the tangent components of the outputs
    _tangent_suffixes = ("",)

    def _set_law(self, stiffness, restitution, v_ref, damping, mu, eps_v, exponent):
        owner = f"{type(self).__name__} '{self.name}'"
        self.k = _num(owner, "stiffness", stiffness, 0.0, lo_open=True)
        self.exponent = _num(owner, "exponent", exponent, 1.0)
        self.mu = _num(owner, "mu (friction coefficient)", mu, 0.0)
        self.eps_v = _num(owner, "eps_v (regularization speed, m/s)", eps_v, 0.0, lo_open=True)
        self.restitution = _num(owner, "restitution", restitution, 0.0, hi=1.0)
        self.v_ref = _num(owner, "v_ref (approach speed of the restitution, m/s)", v_ref, 0.0, lo_open=True)
        if damping is not None:
            if self.restitution != 1.0:
                raise ModelError(f"{owner}: give restitution (with v_ref) or damping, not both")
            self.alpha = _num(owner, "damping (Hunt–Crossley α, s/m)", damping, 0.0)
        else:
            if self.restitution == 0.0:
                raise ModelError(f"{owner}: restitution 0 (a plastic impact) is not reachable with the "
                                 "Hunt–Crossley law (α → ∞); give e > 0, or use femb.contact for e_N = 0")
            self.alpha = hunt_crossley_damping(self.restitution, self.v_ref, self.exponent)

    def _law_row(self):
        return [self.k, self.exponent, self.alpha, self.mu, self.eps_v]

    # ----------------------------------------------------------------- outputs
    @classmethod
    def output_units(cls):
        """Named outputs per element (``"<element>.<name>"`` in ``Result.series``) and their units."""
        tang = tuple((f"lambda_F{x}", "N") for x in cls._tangent_suffixes) + tuple(
            (f"gamma_F{x}", "m/s") for x in cls._tangent_suffixes)
        return (("gN", "m"), ("gN_d", "m/s"), ("lambda_N", "N")) + tang + (
            ("lambda_F_norm", "N"), ("slip", "m/s"), ("state", "1"))

    @classmethod
    def outputs(cls, params, qe, qde, rows):
        """Every named output of some elements of a batch at many states.

        Parameters
        ----------
        params : dict from :meth:`pack` (the whole batch)
        qe : ndarray (nt, ne, ndx); qde : ndarray (nt, ne, ndv)
            Coordinates and velocities of the elements ``rows`` (ne indices into the batch).

        Returns
        -------
        dict name → ndarray (nt, ne): gap g_N (m, negative = penetration), ġ_N (m/s), normal
        force λ_N = f_N (N), the friction force's components (N; planar along t = (n_y, −n_x),
        spatial on a plane along the element's t₁, t₂, sphere pairs along x, y, z, the force on b)
        and the slip velocity's (m/s), |f_T| (N), slip speed |v_T| (m/s), state (0 open: f_N = 0,
        1 stick: |v_T| < ε_v, 2 slip).
        """
        rows = np.asarray(rows, dtype=np.int64).reshape(-1)
        nt, nel = qe.shape[0], qe.shape[1]
        Pt = np.ascontiguousarray(np.tile(params["P"][rows], (nt, 1)))
        out = np.zeros((nt * nel, 9))
        cls._state_values(Pt, np.ascontiguousarray(qe.reshape(nt * nel, -1), dtype=float),
                          np.ascontiguousarray(qde.reshape(nt * nel, -1), dtype=float), out)
        FT, vT = out[:, 3:6], out[:, 6:9]
        res = {"gN": out[:, 0], "gN_d": out[:, 1], "lambda_N": out[:, 2]}
        for sfx, t in zip(cls._tangent_suffixes, cls._tangent_rows(params["T"][rows], nt)):
            res["lambda_F" + sfx] = np.einsum("ij,ij->i", FT, t)
            res["gamma_F" + sfx] = np.einsum("ij,ij->i", vT, t)
        slip = np.linalg.norm(vT, axis=1)
        res["lambda_F_norm"] = np.linalg.norm(FT, axis=1)
        res["slip"] = slip
        res["state"] = np.where(out[:, 2] > 0.0, np.where(slip < Pt[:, cls._eps_col], 1.0, 2.0), 0.0)
        return {k: v.reshape(nt, nel) for k, v in res.items()}

    @classmethod
    def _tangent_rows(cls, T, nt):
        T = np.tile(T, (nt, 1))
        return [T[:, 3 * k:3 * k + 3] for k in range(len(cls._tangent_suffixes))]

    glyph = "contact"  # how pictures draw it (femb.io.frames)

    @classmethod
    def geometry(cls, p, t, qe, qde, lame, names):
        """One vertex per contact at its contact point c, with its force on the (second) body.

        Point data (:func:`femb.elements.contact.contact_block`): ``contact_normal`` n,
        ``contact_force`` f_N n + f_T (N), ``gap`` g_N (m) and ``contact_state`` (0 open, 1 stick,
        2 slip), from the same compiled law as the forces and the outputs.
        """
        from .contact import contact_block

        qe, qde = np.asarray(qe, dtype=float), np.asarray(qde, dtype=float)
        nel = qe.shape[0]
        c, n, gN = cls.contact_frames(p["P"], qe)
        out = cls.outputs(p, qe[None], qde[None], np.arange(nel))
        F = out["lambda_N"][0][:, None] * n
        for sfx, tk in zip(cls._tangent_suffixes, cls._tangent_rows(p["T"], 1)):
            F = F + out["lambda_F" + sfx][0][:, None] * tk
        return contact_block(cls.__name__, c, n, F, gN, out["state"][0])


class _PenaltySphereOnPlane(_PenaltyLaw):
    """Shared parameters, validation and packing of the planar and spatial sphere-on-plane types."""

    dim = 2

    def __init__(self, name, body, radius, stiffness, point=None, plane_point=None, normal=None, *,
                 restitution=1.0, v_ref=1.0, damping=None, mu=0.0, eps_v=1e-2, exponent=1.5):
        super().__init__(name)
        owner = f"{type(self).__name__} '{name}'"
        dim = self.dim
        self.body = body
        self._point = point
        self.radius = _num(owner, "radius", radius, 0.0)
        self.p = _vec(owner, "plane_point", np.zeros(dim) if plane_point is None else plane_point, dim)
        default_n = (0.0, 1.0) if dim == 2 else (0.0, 0.0, 1.0)
        self.n = _vec(owner, "normal", default_n if normal is None else normal, dim, unit=True)
        self._set_law(stiffness, restitution, v_ref, damping, mu, eps_v, exponent)

    def nodes(self):
        return [self.body.node]

    @classmethod
    def pack(cls, elements):
        rows = []
        for e in elements:
            s3, p3, n3 = (np.zeros(3) for _ in range(3))
            s3[:cls.dim], p3[:cls.dim], n3[:cls.dim] = e.s, e.p, e.n
            rows.append([*s3, e.radius, *p3, *n3, *e._law_row()])
        P = np.ascontiguousarray(np.array(rows, dtype=float).reshape(-1, NPAR))
        return {"P": P, "T": cls._tangents(elements)}

    @classmethod
    def _state_values(cls, P, xe, ve, out):
        penalty_state(P, xe, ve, 1.0 if cls.dim == 3 else 0.0, out)

    @classmethod
    def contact_frames(cls, P, qe):
        """(contact point c = C − R_s n (nel, 3), normal n (nel, 3), gap g_N (nel,)) at one state."""
        from .contact import _planar_points, _spatial_points

        C = _planar_points(qe, P[:, 0:2]) if cls.dim == 2 else _spatial_points(qe, P[:, 0:3])[0]
        n = P[:, 7:10]
        gN = np.einsum("ej,ej->e", n, C - P[:, 4:7]) - P[:, 3]
        return C - P[:, 3:4] * n, n, gN

    @classmethod
    def _tangents(cls, elements):
        """(nel, 6): the tangents (t₁, t₂) of the outputs; planar: t = (n_y, −n_x), t₂ = 0."""
        T = np.zeros((len(elements), 6))
        for i, e in enumerate(elements):
            if cls.dim == 2:
                T[i, 0:2] = (e.n[1], -e.n[0])
            else:
                T[i] = np.concatenate((e.t1, e.t2))
        return T


class PenaltySphereOnPlane(_PenaltySphereOnPlane):
    """Compliant contact of a disc (or point) of a planar body with a line fixed in space.

    Hunt–Crossley normal force with Hertz stiffness and regularized Coulomb friction (module
    docstring); geometry and signs as :class:`femb.elements.contact.SphereOnPlane`.

    Parameters
    ----------
    name : str
    body : planar body or name
    radius : float ≥ 0
        Disc radius R_s (m); 0: a point.
    stiffness : float > 0
        k in f_N = k δⁿ (N/mⁿ); for two elastic spheres (Johnson §4.2) k = (4/3) E* √R*.
    point : (2,) or name, optional
        Disc centre in the body frame (default: the node).
    plane_point, normal : (2,), optional
        A point of the line and its normal to the free side (default: the x axis, n = (0, 1)).
    restitution : float in (0, 1]
        Coefficient of restitution of a central impact at approach speed ``v_ref`` (default 1:
        no damping); sets α by :func:`hunt_crossley_damping`.
    v_ref : float > 0
        The approach speed (m/s) at which ``restitution`` holds (default 1).
    damping : float ≥ 0, optional
        α (s/m) directly, instead of ``restitution``.
    mu : float ≥ 0
        Coulomb friction coefficient.
    eps_v : float > 0
        Regularization speed ε_v (m/s, default 1e-3): below it friction is viscous
        (f_T ≈ −μ f_N v_T/ε_v); "sticking" contacts creep at less than ε_v.
    exponent : float ≥ 1
        n (default 3/2, Hertz; 1: linear spring).
    """

    kernels = {"force": planar_penalty_force, "energy": planar_penalty_energy}
    dim = 2

    def resolve(self, lookup):
        owner = f"PenaltySphereOnPlane '{self.name}'"
        body = lookup(self.body, "body")
        if getattr(body, "node", None) is None or getattr(body.node, "rotation_blocks", ()):
            raise ModelError(f"{owner}: body must be a planar body, got {getattr(body, 'name', body)!r} "
                             "(use SpatialPenaltySphereOnPlane for spatial bodies)")
        self.body = body
        self.s = np.asarray(body.local((0.0, 0.0) if self._point is None else self._point, "point"), dtype=float)


class SpatialPenaltySphereOnPlane(_PenaltySphereOnPlane):
    """Compliant contact of a sphere (or point) of a spatial body with a plane fixed in space.

    As :class:`PenaltySphereOnPlane` with 3-vectors (``point`` in body axes; default plane z = 0,
    n = (0, 0, 1)); geometry and signs as :class:`femb.elements.contact.SpatialSphereOnPlane`.
    ``tangent`` (3,), optional: t₁ of the outputs ``lambda_F1``, ``gamma_F1`` (its part orthogonal
    to n; t₂ = n × t₁); default :func:`femb.elements.contact.tangents`. The force law is isotropic
    and does not depend on it.
    """

    kernels = {"force": spatial_penalty_force, "energy": spatial_penalty_energy}
    spatial = True
    dim = 3
    _tangent_suffixes = ("1", "2")

    def __init__(self, name, body, radius, stiffness, point=None, plane_point=None, normal=None, *,
                 tangent=None, **law):
        super().__init__(name, body, radius, stiffness, point, plane_point, normal, **law)
        from .contact import plane_tangents

        self.t1, self.t2 = plane_tangents(f"SpatialPenaltySphereOnPlane '{name}'", self.n, tangent)

    def resolve(self, lookup):
        owner = f"SpatialPenaltySphereOnPlane '{self.name}'"
        body = lookup(self.body, "body")
        if getattr(body, "node", None) is None or not getattr(body.node, "rotation_blocks", ()):
            raise ModelError(f"{owner}: body must be a spatial body, got {getattr(body, 'name', body)!r} "
                             "(use PenaltySphereOnPlane for planar bodies)")
        self.body = body
        self.s = np.asarray(body.local((0.0, 0.0, 0.0) if self._point is None else self._point, "point"),
                            dtype=float)


class SpatialPenaltySpherePair(_PenaltyLaw):
    """Compliant contact of a sphere on spatial body a with a sphere on spatial body b.

    Centres C_k = r_k + R_k s_k, e = C_b − C_a, normal n = e/|e| (from a to b), gap
    g_N = |e| − R_a − R_b (the convention of :class:`femb.elements.contact.DiscOnDisc`), contact
    point c = C_a + w e with w = R_a/(R_a + R_b) (the touching point when g_N = 0; on the line of
    centres, dividing the overlap in the ratio of the radii), slip v_T = the tangential part of
    the velocity of b's material point at c relative to a's. The law of the module docstring gives F,
    which acts on b at c, and −F on a at c (so the pair exerts no net force or moment).

    Parameters
    ----------
    name : str
    a, b : spatial body or name
    radius_a, radius_b : float ≥ 0
    stiffness : float > 0
        k in f_N = k δⁿ; for two elastic spheres (Johnson §4.2) k = (4/3) E* √R*,
        1/R* = 1/R_a + 1/R_b, 1/E* = (1 − ν_a²)/E_a + (1 − ν_b²)/E_b.
    point_a, point_b : (3,) or name, optional
        Sphere centres in body axes (default: the nodes).
    restitution, v_ref, damping, mu, eps_v, exponent : as :class:`PenaltySphereOnPlane`.

    Notes
    -----
    The outputs ``lambda_F_x`` … and ``gamma_F_x`` … are the friction force on b and the slip
    velocity in space axes.
    """

    kernels = {"force": sphere_pair_force, "energy": sphere_pair_energy}
    spatial = True
    _eps_col = 13
    _tangent_suffixes = ("_x", "_y", "_z")

    def __init__(self, name, a, b, radius_a, radius_b, stiffness, point_a=None, point_b=None, *,
                 restitution=1.0, v_ref=1.0, damping=None, mu=0.0, eps_v=1e-2, exponent=1.5):
        super().__init__(name)
        owner = f"SpatialPenaltySpherePair '{name}'"
        self.a, self.b = a, b
        self._points = (point_a, point_b)
        self.Ra = _num(owner, "radius_a", radius_a, 0.0)
        self.Rb = _num(owner, "radius_b", radius_b, 0.0)
        self._set_law(stiffness, restitution, v_ref, damping, mu, eps_v, exponent)

    def resolve(self, lookup):
        _resolve_two_bodies(self, f"SpatialPenaltySpherePair '{self.name}'", lookup)
        pa, pb = self._points
        self.sa = np.asarray(self.a.local((0.0, 0.0, 0.0) if pa is None else pa, "point_a"), dtype=float)
        self.sb = np.asarray(self.b.local((0.0, 0.0, 0.0) if pb is None else pb, "point_b"), dtype=float)

    def validate(self):
        Ca, Cb = self.a.global_point(self.sa), self.b.global_point(self.sb)
        if np.linalg.norm(Cb - Ca) == 0.0:
            raise ModelError(f"SpatialPenaltySpherePair '{self.name}': the sphere centres coincide initially "
                             "(no normal direction)")

    def nodes(self):
        return [self.a.node, self.b.node]

    @classmethod
    def pack(cls, elements):
        rows = []
        for e in elements:
            w = e.Ra / (e.Ra + e.Rb) if e.Ra + e.Rb > 0.0 else 0.5
            rows.append([*e.sa, *e.sb, e.Ra, e.Rb, w, *e._law_row()])
        P = np.ascontiguousarray(np.array(rows, dtype=float).reshape(-1, 14))
        return {"P": P, "T": np.tile(np.eye(3).reshape(1, 9), (len(elements), 1))}

    @classmethod
    def _state_values(cls, P, xe, ve, out):
        sphere_pair_state(P, xe, ve, out)

    @classmethod
    def contact_frames(cls, P, qe):
        """(contact point c = C_a + w e, normal n = e/|e| (on b), gap |e| − R_a − R_b) at one state."""
        from .contact import _spatial_points

        e = _spatial_points(qe, P[:, 3:6], col=7)[0] - _spatial_points(qe, P[:, 0:3])[0]
        L = np.linalg.norm(e, axis=1)
        n = e / np.where(L > 0.0, L, 1.0)[:, None]
        return _spatial_points(qe, P[:, 0:3])[0] + P[:, 8:9] * e, n, L - P[:, 6] - P[:, 7]


class SpatialPenaltySphereOnBodyPlane(_PenaltyLaw):
    """Compliant contact of a sphere on spatial body b with a plane fixed to spatial body a.

    Plane point P = r_a + R_a p̄ and normal n = R_a n̄ (p̄, n̄ in a's axes; n to the free side), sphere
    centre C = r_b + R_b s_b, gap g_N = n·(C − P) − R_s, contact point c = C − R_s n; the law of the
    module docstring gives F, which acts on b at c and −F on a at c. The plane is unbounded (no
    edges): keep the sphere over the part of a you mean.

    Parameters
    ----------
    name : str
    a : spatial body or name
        The body that carries the plane (a table, a moving platform).
    b : spatial body or name
        The body that carries the sphere.
    radius, stiffness : as :class:`PenaltySphereOnPlane`.
    plane_point, normal : (3,), optional
        In a's axes, or a point name of a (default: a's node and its z axis).
    point : (3,) or name, optional
        Sphere centre in b's axes (default: b's node).
    restitution, v_ref, damping, mu, eps_v, exponent : as :class:`PenaltySphereOnPlane`.

    Notes
    -----
    Outputs ``lambda_F_x`` … ``gamma_F_z``: the friction force on b and the slip velocity, space axes.
    """

    kernels = {"force": body_plane_force, "energy": body_plane_energy}
    spatial = True
    _tangent_suffixes = ("_x", "_y", "_z")

    def __init__(self, name, a, b, radius, stiffness, plane_point=None, normal=None, point=None, *,
                 restitution=1.0, v_ref=1.0, damping=None, mu=0.0, eps_v=1e-2, exponent=1.5):
        super().__init__(name)
        owner = f"SpatialPenaltySphereOnBodyPlane '{name}'"
        self.a, self.b = a, b
        self._spec = (plane_point, point)
        self.radius = _num(owner, "radius", radius, 0.0)
        self.nbar = _vec(owner, "normal", (0.0, 0.0, 1.0) if normal is None else normal, 3, unit=True)
        self._set_law(stiffness, restitution, v_ref, damping, mu, eps_v, exponent)

    def resolve(self, lookup):
        _resolve_two_bodies(self, f"SpatialPenaltySphereOnBodyPlane '{self.name}'", lookup)
        pp, pt = self._spec
        self.pbar = np.asarray(self.a.local((0.0, 0.0, 0.0) if pp is None else pp, "plane_point"), dtype=float)
        self.s = np.asarray(self.b.local((0.0, 0.0, 0.0) if pt is None else pt, "point"), dtype=float)

    def nodes(self):
        return [self.a.node, self.b.node]

    @classmethod
    def pack(cls, elements):
        rows = [[*e.pbar, *e.nbar, *e.s, e.radius, *e._law_row()] for e in elements]
        P = np.ascontiguousarray(np.array(rows, dtype=float).reshape(-1, 15))
        return {"P": P, "T": np.tile(np.eye(3).reshape(1, 9), (len(elements), 1))}

    @classmethod
    def _state_values(cls, P, xe, ve, out):
        body_plane_state(P, xe, ve, out)

    @classmethod
    def contact_frames(cls, P, qe):
        """(contact point c = C − R_s n, normal n = R_a n̄, gap n·(C − P) − R_s) at one state."""
        from .contact import _spatial_points

        Pl, Ra = _spatial_points(qe, P[:, 0:3])
        n = np.einsum("eij,ej->ei", Ra, P[:, 3:6])
        C = _spatial_points(qe, P[:, 6:9], col=7)[0]
        gN = np.einsum("ej,ej->e", n, C - Pl) - P[:, 9]
        return C - P[:, 9:10] * n, n, gN
