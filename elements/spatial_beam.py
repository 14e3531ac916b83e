"""Spatial geometrically exact beam: the two-node SE(3) element on frame nodes.

Formulation (Sonneville, Cardona & Brüls 2014; ``docs/beams.md``, "Spatial beams").
Each end of an element carries a *section frame* H = (R R̄, x) ∈ SE(3): the
frame node's rotation R (body to space) times a constant offset rotation R̄
(node axes to section axes, fixed at t0), and the node position x (the
centroid). The element's deformation is the SE(3) relative motion of its two
section frames,

    d = log(H_A⁻¹ H_B) = (U, Θ),   ε = (d − d0)/L = (Γ − Γ0, κ − κ0)   (6,),

with d0 the same quantity in the reference configuration and L = |U0| its arc
length. The strain ε is constant along the element; the element represents
exactly every configuration of constant strain (helices, circles, straight
lines), is objective, path independent and free of shear locking.
The log of SE(3) is log(R, x) = (T⁻¹(−Θ) x, Θ), Θ = log R. With
T_SE3 the SE(3) tangent operator (spatial.md §1; exp(d + δ) = exp(d) exp(T(d)δ)),
the variation of d under right increments ξ of the section frames is

    δd = −T_SE3⁻¹(−d) ξ_A + T_SE3⁻¹(d) ξ_B,    ξ = (R_sᵀ δx, R̄ᵀ δθ),

where (δx, δθ) are femb's tangent increments of a frame node (right-perturbed
rotation) and R_s = R R̄. The strain energy V = ½ L εᵀ C ε gives the section
wrench σ = C (ε + β ε̇) (β: stiffness-proportional damping) and the nodal
forces h_A = −T_SE3⁻ᵀ(−d) σ, h_B = T_SE3⁻ᵀ(d) σ on the section frames, i.e.

    f_x = −R_s h_U,   f_θ = −R̄ h_Ω        (each node; M v̇ = f − Bᵀλ).

Tangent: with Q = ∂d/∂(δx, δθ) (6 × 12),

    ∂f/∂q = −Qᵀ (C/L)(Q + β(E Q + P V)) − Aᵀ G Q + blockdiag(R (R̄ h_U)~ at (x, θ)),

G = ∂(h_A, h_B)/∂d at fixed σ (12 × 6), E = ∂ḋ/∂d at fixed section velocities,
P V the change of the section velocities R_sᵀẋ under δθ. G and E are the
derivatives of the closed forms of T_SE3⁻ᵀ σ and T_SE3⁻¹ ξ̇ (spatial.md §1) along the
six directions of d, by the chain rule through their factored evaluation
(b_U = T⁻¹(−Ω) a_U, b_Ω = T⁻¹(−Ω)(a_Ω − T_UΩᵀ b_U), and the transposed order for
T_SE3⁻¹): T_UΩ is linear in U, so its U-derivative is one 3 × 3 matrix; along Ω the
coefficients s2 … s6 change with x = φ² through the closed-form derivatives
of :func:`dsfun` (s2' = (s1/2 − s2)/x, s3' = (s2 − 3s3)/(2x), s4', s5', s6' = (s5 − 5s6)/(2x);
series below x = 0.01). G and E are built by 3 × 3 blocks (:func:`_g_blocks`,
:func:`_e_blocks`): T⁻¹(Ω) and T_UΩ are formed once as matrices, and at −d (node A) they
are their transposes, so that Q, the derivatives of b_U, b_Ω and the rotations R_s, R̄ of
the rows are 3 × 3 products and rank-one sums. Exact (no difference step); checked against
finite differences of the force in tests/test_spatial_beam.py. ``fv = −(β/L) Qᵀ C Q`` plus
the gyroscopic part below.

Arithmetic: the kernels that form only the tangent compile with fused multiply–adds
(``TANGENT``); the forces keep plain IEEE arithmetic, so the residual, hence every
converged state, is the same whether or not a step forms a tangent, and the same as
before the tangent was so compiled (docs/beams.md, "Kernel cost").

Inertia: **consistent translational mass** for linear interpolation of the
centroid, ρA L/6 [2 1; 1 2] ⊗ I₃ in (ẋ_A, ẋ_B), and **lumped rotary inertia**
ρJ L/2 at each node (body axes of the node, J_n = R̄ ρJ R̄ᵀ L/2) with its
gyroscopic moment −Ω × J_n Ω in the force kernel, as for
:class:`SpatialRigidBody`. In femb's velocity coordinates (ẋ in space axes, Ω
in body axes) this mass matrix is **constant**, as the compiled time loop
requires (``femb/system/model.py`` refuses configuration-dependent masses); the
consistent rotary inertia of the SE(3) interpolation would depend on the
relative rotation of the two nodes. ``mass="lumped"`` gives ρA L/2 I₃ per
node; ``mass="averaged"`` their mean. Gravity (``SpatialGravity``, M ĝ) is then the work-equivalent load of
uniform distributed gravity ρA g.

Section frame conventions: section axis 1 is the beam axis (tangent), 2 and 3
the cross-section axes; the resultants σ = C ε = (N, V2, V3, T, M2, M3) are
the force and moment that the part of the element beyond a section (towards
node B) exerts on the part before it, in section axes (N > 0 tension).

References
----------
V. Sonneville, A. Cardona, O. Brüls, Geometrically exact beam finite element
formulated on the special Euclidean group SE(3), Comput. Methods Appl. Mech.
Eng. 268:451–474, 2014.
J. C. Simo, L. Vu-Quoc, A three-dimensional finite-strain rod model. Part II,
Comput. Methods Appl. Mech. Eng. 58:79–116, 1986.
G. R. Cowper, The shear coefficient in Timoshenko's beam theory, J. Appl.
Mech. 33:335–340, 1966 (shear factors).
W. C. Young, R. G. Budynas, Roark's Formulas for Stress and Strain, 7th ed.,
McGraw-Hill, 2002, Table 10.7 (torsion constant of a rectangle).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from femb.base import rotations as rt
from femb.base.geometry import GeometryBlock
from femb.base.jit import jit_disabled, kernel
from femb.errors import ModelError
from femb.system.element import Element

from . import _spatial as sp
from ._meshing import check_model_size, element_count
from .bodies import Body, _check_scalar
from .spatial_bodies import FrameNode, SpatialBody, rotation_input, vector3

#: options of the kernels that form the tangent only: fused multiply–adds (``contract``; no other
#: fast-math licence). The forces, hence the residual and the converged states, are computed by
#: the kernels without it, so they do not depend on whether a tangent was formed (docs/beams.md,
#: "Kernel cost").
TANGENT = dict(fastmath={"contract"})
# the 3 × 3 products of elements/_spatial.py compiled once more with TANGENT, for the tangent blocks
_mm = kernel(**TANGENT)(sp.mm.py_func)
_mmt = kernel(**TANGENT)(sp.mmt.py_func)
_mtm = kernel(**TANGENT)(sp.mtm.py_func)

# parameter layout of P (per element)
# (what the force kernel reads first, the 6 × 6 C last: a batch whose sections are all diagonal,
# the usual case, stores none, and the force kernel reads 43 numbers per element instead of 79)
D0, LEN, BETA, FLAGS, QA, QB, CD, JN, JNB, MD, MO, CM = 0, 6, 7, 8, 9, 13, 17, 23, 32, 41, 42, 43
NPAR_DIAG, NPAR = 43, 79
#: bits of P[FLAGS]: C diagonal (its diagonal at CD), both section offsets the identity, rotary inertia
F_DIAG, F_IDENT, F_ROTARY = 1, 2, 4


# ---------------------------------------------------------------------------
# SE(3) operators and their derivatives
# ---------------------------------------------------------------------------
@kernel
def sfun(phi2):
    """(s2, s3, s4, s5, s6) of spatial.md §1 from φ² (series below φ² = 0.01; analytic in φ²)."""
    x = phi2
    if abs(x) < 0.01:
        s2 = 1.0 / 2.0 - x / 24.0 + x * x / 720.0 - x * x * x / 40320.0 + x * x * x * x / 3628800.0
        s3 = 1.0 / 6.0 - x / 120.0 + x * x / 5040.0 - x * x * x / 362880.0 + x * x * x * x / 39916800.0
        s4 = 1.0 / 12.0 + x / 720.0 + x * x / 30240.0 + x * x * x / 1209600.0 + x * x * x * x / 47900160.0
        s5 = 1.0 / 12.0 - x / 180.0 + x * x / 6720.0 - x * x * x / 453600.0 + x * x * x * x / 47900160.0
        s6 = 1.0 / 60.0 - x / 1260.0 + x * x / 60480.0 - x * x * x / 4989600.0 + x * x * x * x / 622702080.0
        return s2, s3, s4, s5, s6
    phi = np.sqrt(x)
    return _s_closed(x, phi, np.sin(phi), np.cos(phi))


@kernel
def _s_closed(x, phi, sn, c):
    """(s2, …, s6) by their closed forms from x = φ², φ, sin φ, cos φ (:func:`sfun` above the series)."""
    s2 = (1.0 - c) / x
    s3 = (phi - sn) / (x * phi)
    s4 = (1.0 - 0.5 * phi * sn / (1.0 - c)) / x
    s5 = (2.0 - 2.0 * c - phi * sn) / (x * x)
    s6 = (phi * (2.0 + c) - 3.0 * sn) / (x * x * phi)
    return s2, s3, s4, s5, s6


@kernel
def _tinv3(W, s4, a):
    """T⁻¹(W) a = a + ½ W × a + s4 W × (W × a)."""
    wa = sp.cross3(W, a)
    wwa = sp.cross3(W, wa)
    return (a[0] + 0.5 * wa[0] + s4 * wwa[0], a[1] + 0.5 * wa[1] + s4 * wwa[1],
            a[2] + 0.5 * wa[2] + s4 * wwa[2])


@kernel
def _uw_terms(U, W, a):
    """(Ω·U, U × a, Ω × a, U × (Ω × a), Ω × (U × a), Ω × (Ω × a)): the terms of T_UΩ a and of its
    derivatives."""
    ua = sp.cross3(U, a)
    wa = sp.cross3(W, a)
    return sp.dot3(W, U), ua, wa, sp.cross3(U, wa), sp.cross3(W, ua), sp.cross3(W, wa)


@kernel
def _tuw(U, W, s, a, sgn):
    """T_UΩ a (sgn = 1) or T_UΩᵀ a (sgn = −1); s = sfun(|Ω|²)."""
    s2, s3, s4, s5, s6 = s
    wu, ua, wa, uwa, wua, wwa = _uw_terms(U, W, a)
    c1 = -sgn * s2
    c5 = sgn * s5 * wu
    c6 = -s6 * wu
    return (c1 * ua[0] + s3 * (uwa[0] + wua[0]) + c5 * wa[0] + c6 * wwa[0],
            c1 * ua[1] + s3 * (uwa[1] + wua[1]) + c5 * wa[1] + c6 * wwa[1],
            c1 * ua[2] + s3 * (uwa[2] + wua[2]) + c5 * wa[2] + c6 * wwa[2])


@kernel
def tinv_se3(U, W, s, aU, aW):
    """T_SE3⁻¹(d) a for d = (U, Ω), a = (aU, aW): returns (bU, bW) (3-tuples)."""
    bW = _tinv3(W, s[2], aW)
    t = _tuw(U, W, s, bW, 1.0)
    bU = _tinv3(W, s[2], sp.sub3(aU, t))
    return bU, bW


@kernel
def tinvt_se3(U, W, s, aU, aW):
    """T_SE3⁻ᵀ(d) a for d = (U, Ω), a = (aU, aW): returns (bU, bW)."""
    mW = sp.scale3(-1.0, W)
    bU = _tinv3(mW, s[2], aU)
    t = _tuw(U, W, s, bU, -1.0)
    bW = _tinv3(mW, s[2], sp.sub3(aW, t))
    return bU, bW


@kernel
def _neg3(a):
    return (-a[0], -a[1], -a[2])


@kernel(**TANGENT)
def dsfun(phi2):
    """Derivatives (s2', s3', s4', s5', s6') of :func:`sfun` with respect to x = φ².

    Closed forms (differentiating the definitions of spatial.md §1, s1 = sin φ/φ):
    s2' = (s1/2 − s2)/x, s3' = (s2 − 3 s3)/(2x),
    s4' = −[(sin φ − φ)/(4φ(1 − cos φ)) + s4]/x, s5' = (sin φ − φ cos φ)/(2φx²) − 2 s5/x,
    s6' = (s5 − 5 s6)/(2x); below x = 0.01 the term-by-term derivatives of the series of
    :func:`sfun`.
    """
    x = phi2
    if abs(x) < 0.01:
        d2 = -1.0 / 24.0 + 2.0 * x / 720.0 - 3.0 * x * x / 40320.0 + 4.0 * x * x * x / 3628800.0
        d3 = -1.0 / 120.0 + 2.0 * x / 5040.0 - 3.0 * x * x / 362880.0 + 4.0 * x * x * x / 39916800.0
        d4 = 1.0 / 720.0 + 2.0 * x / 30240.0 + 3.0 * x * x / 1209600.0 + 4.0 * x * x * x / 47900160.0
        d5 = -1.0 / 180.0 + 2.0 * x / 6720.0 - 3.0 * x * x / 453600.0 + 4.0 * x * x * x / 47900160.0
        d6 = -1.0 / 1260.0 + 2.0 * x / 60480.0 - 3.0 * x * x / 4989600.0 + 4.0 * x * x * x / 622702080.0
        return d2, d3, d4, d5, d6
    phi = np.sqrt(x)
    sn = np.sin(phi)
    c = np.cos(phi)
    return _ds_closed(x, phi, sn, c, _s_closed(x, phi, sn, c))


@kernel(**TANGENT)
def _ds_closed(x, phi, sn, c, s):
    """(s2', …, s6') by the closed forms of :func:`dsfun` (they serve the tangent only:
    reciprocals instead of eight divisions)."""
    s2, s3, s4, s5, s6 = s
    ix = 1.0 / x
    ip = 1.0 / phi
    d2 = (0.5 * sn * ip - s2) * ix
    d3 = 0.5 * (s2 - 3.0 * s3) * ix
    d4 = -(0.25 * (sn - phi) * ip / (1.0 - c) + s4) * ix
    d5 = (0.5 * (sn - phi * c) * ip * ix - 2.0 * s5) * ix
    d6 = 0.5 * (s5 - 5.0 * s6) * ix
    return d2, d3, d4, d5, d6


@kernel
def _sdfun(phi2):
    """(:func:`sfun`, :func:`dsfun`) of φ² together: one square root, sine and cosine for both."""
    x = phi2
    if abs(x) < 0.01:
        return sfun(x), dsfun(x)
    phi = np.sqrt(x)
    sn = np.sin(phi)
    c = np.cos(phi)
    sv = _s_closed(x, phi, sn, c)
    return sv, _ds_closed(x, phi, sn, c, sv)


# 3 × 3 matrices are row-major 9-tuples (products: elements/_spatial.py)
@kernel
def _tinv_mat(W, s4):
    """T⁻¹(Ω) = I + ½Ω~ + s4 Ω~² = I + ½Ω~ + s4(ΩΩᵀ − φ² I) (T⁻¹(−Ω) is its transpose)."""
    dg = 1.0 - s4 * sp.dot3(W, W)
    return (dg + s4 * W[0] * W[0], -0.5 * W[2] + s4 * W[0] * W[1], 0.5 * W[1] + s4 * W[0] * W[2],
            0.5 * W[2] + s4 * W[1] * W[0], dg + s4 * W[1] * W[1], -0.5 * W[0] + s4 * W[1] * W[2],
            -0.5 * W[1] + s4 * W[2] * W[0], 0.5 * W[0] + s4 * W[2] * W[1], dg + s4 * W[2] * W[2])


@kernel
def _rank3(a, b, c, d, e, f, g, kap):
    """a bᵀ + c dᵀ + e fᵀ + g~ + κ I (3-tuples a … g, scalar κ)."""
    return (a[0] * b[0] + c[0] * d[0] + e[0] * f[0] + kap, a[0] * b[1] + c[0] * d[1] + e[0] * f[1] - g[2],
            a[0] * b[2] + c[0] * d[2] + e[0] * f[2] + g[1],
            a[1] * b[0] + c[1] * d[0] + e[1] * f[0] + g[2], a[1] * b[1] + c[1] * d[1] + e[1] * f[1] + kap,
            a[1] * b[2] + c[1] * d[2] + e[1] * f[2] - g[0],
            a[2] * b[0] + c[2] * d[0] + e[2] * f[0] - g[1], a[2] * b[1] + c[2] * d[1] + e[2] * f[1] + g[0],
            a[2] * b[2] + c[2] * d[2] + e[2] * f[2] + kap)


@kernel(**TANGENT)
def _rank1s(a, b, g, kap):
    """a bᵀ + g~ + κ I."""
    return (a[0] * b[0] + kap, a[0] * b[1] - g[2], a[0] * b[2] + g[1],
            a[1] * b[0] + g[2], a[1] * b[1] + kap, a[1] * b[2] - g[0],
            a[2] * b[0] - g[1], a[2] * b[1] + g[0], a[2] * b[2] + kap)


@kernel(**TANGENT)
def _rank2s(a, b, c, d, g, kap):
    """a bᵀ + c dᵀ + g~ + κ I."""
    return (a[0] * b[0] + c[0] * d[0] + kap, a[0] * b[1] + c[0] * d[1] - g[2], a[0] * b[2] + c[0] * d[2] + g[1],
            a[1] * b[0] + c[1] * d[0] + g[2], a[1] * b[1] + c[1] * d[1] + kap, a[1] * b[2] + c[1] * d[2] - g[0],
            a[2] * b[0] + c[2] * d[0] - g[1], a[2] * b[1] + c[2] * d[1] + g[0], a[2] * b[2] + c[2] * d[2] + kap)


# :func:`_rank3` serves the forces (T_UΩ); its copy with TANGENT the tangent blocks
_rank3t = kernel(**TANGENT)(_rank3.py_func)


@kernel
def _tuw_mat(U, W, s):
    """T_UΩ of :func:`_tuw` as a matrix (T_UΩ at −d is its transpose).

    −s2 U~ + s3(U~Ω~ + Ω~U~) + s5(Ω·U)Ω~ − s6(Ω·U)Ω~² with a~b~ = b aᵀ − (a·b) I:
    s3(Ω Uᵀ + U Ωᵀ) − s6(Ω·U) Ω Ωᵀ + (−s2 U + s5(Ω·U)Ω)~ + (Ω·U)(s6 φ² − 2 s3) I.
    """
    s2, s3, s4, s5, s6 = s
    wu = sp.dot3(W, U)
    c6 = -s6 * wu
    g = (-s2 * U[0] + s5 * wu * W[0], -s2 * U[1] + s5 * wu * W[1], -s2 * U[2] + s5 * wu * W[2])
    return _rank3((s3 * W[0], s3 * W[1], s3 * W[2]), U, (s3 * U[0], s3 * U[1], s3 * U[2]), W,
                  (c6 * W[0], c6 * W[1], c6 * W[2]), W, g, wu * (s6 * sp.dot3(W, W) - 2.0 * s3))


@kernel(**TANGENT)
def _dtinv_mat(W, s4, ds4, a, sgn):
    """∂(T⁻¹(sgn Ω) a)/∂Ω (3 × 3) for T⁻¹(sgn Ω) a = a + ½ sgn Ω × a + s4 Ω × (Ω × a):
    −½ sgn a~ + s4((Ω·a) I + Ω aᵀ − 2 a Ωᵀ) + 2 s4' (Ω × (Ω × a)) Ωᵀ."""
    wwa = sp.cross3(W, sp.cross3(W, a))
    c = 2.0 * ds4
    s = 2.0 * s4
    h = -0.5 * sgn
    v = (c * wwa[0] - s * a[0], c * wwa[1] - s * a[1], c * wwa[2] - s * a[2])
    return _rank2s(v, W, (s4 * W[0], s4 * W[1], s4 * W[2]), a, (h * a[0], h * a[1], h * a[2]),
                   s4 * sp.dot3(W, a))


@kernel(**TANGENT)
def _dtuw_blocks(U, W, s, ds, b, sgn):
    """(D_U, D_Ω): the derivatives of T_UΩ b (sgn = 1) or T_UΩᵀ b (sgn = −1) at fixed b along U
    and along Ω (3 × 3 each). With σ = sgn, T b = −σ s2 U × b + s3(U × (Ω × b) + Ω × (U × b))
    + (Ω·U)(σ s5 Ω × b − s6 Ω × (Ω × b)) (:func:`_tuw`), T linear in U:

    D_U = (σ s2 b − s3 Ω × b)~ + s3(Ω·b) I + v Ωᵀ,  v = −s3 b + σ s5 Ω × b − s6 Ω × (Ω × b);
    D_Ω = v₁Ωᵀ + (v − s3 b)Uᵀ + (s3 U − s6(Ω·U)Ω) bᵀ + (−σ s5(Ω·U) b)~ + (s3 U·b − s6(Ω·U) Ω·b) I,
    v₁ = 2[−σ s2' U × b + s3'(U × (Ω × b) + Ω × (U × b)) + (Ω·U)(σ s5' Ω × b − s6' Ω × (Ω × b) + s6 b)]

    (s' = ds/dφ², :func:`dsfun`; a~b~ = b aᵀ − (a·b) I and (a × b)~ = b aᵀ − a bᵀ).
    """
    s2, s3, s4, s5, s6 = s
    d2, d3, d4, d5, d6 = ds
    wu, ub, wb, uwb, wub, wwb = _uw_terms(U, W, b)
    c5 = sgn * s5
    v = (-s3 * b[0] + c5 * wb[0] - s6 * wwb[0], -s3 * b[1] + c5 * wb[1] - s6 * wwb[1],
         -s3 * b[2] + c5 * wb[2] - s6 * wwb[2])
    gu = (sgn * s2 * b[0] - s3 * wb[0], sgn * s2 * b[1] - s3 * wb[1], sgn * s2 * b[2] - s3 * wb[2])
    DU = _rank1s(v, W, gu, s3 * sp.dot3(W, b))
    e2 = -sgn * d2
    e5 = sgn * d5
    v1 = (2.0 * (e2 * ub[0] + d3 * (uwb[0] + wub[0]) + wu * (e5 * wb[0] - d6 * wwb[0] + s6 * b[0])),
          2.0 * (e2 * ub[1] + d3 * (uwb[1] + wub[1]) + wu * (e5 * wb[1] - d6 * wwb[1] + s6 * b[1])),
          2.0 * (e2 * ub[2] + d3 * (uwb[2] + wub[2]) + wu * (e5 * wb[2] - d6 * wwb[2] + s6 * b[2])))
    c6 = -s6 * wu
    u1 = (v[0] - s3 * b[0], v[1] - s3 * b[1], v[2] - s3 * b[2])
    cU = (s3 * U[0] + c6 * W[0], s3 * U[1] + c6 * W[1], s3 * U[2] + c6 * W[2])
    g = (-c5 * wu * b[0], -c5 * wu * b[1], -c5 * wu * b[2])
    DW = _rank3t(v1, W, u1, U, cU, b, g, s3 * sp.dot3(U, b) + c6 * sp.dot3(W, b))
    return DU, DW


@kernel(**TANGENT)
def _dtinvt_pair(W, s4, ds4, a):
    """:func:`_dtinv_mat` (sgn = −1) at Ω and at −Ω (the same values): ½ a~ ± S with S, the part odd
    in Ω, formed once."""
    wwa = sp.cross3(W, sp.cross3(W, a))
    c = 2.0 * ds4
    s = 2.0 * s4
    v = (c * wwa[0] - s * a[0], c * wwa[1] - s * a[1], c * wwa[2] - s * a[2])
    sw = (s4 * W[0], s4 * W[1], s4 * W[2])
    k = s4 * sp.dot3(W, a)
    S = (v[0] * W[0] + sw[0] * a[0] + k, v[0] * W[1] + sw[0] * a[1], v[0] * W[2] + sw[0] * a[2],
         v[1] * W[0] + sw[1] * a[0], v[1] * W[1] + sw[1] * a[1] + k, v[1] * W[2] + sw[1] * a[2],
         v[2] * W[0] + sw[2] * a[0], v[2] * W[1] + sw[2] * a[1], v[2] * W[2] + sw[2] * a[2] + k)
    g = (0.5 * a[0], 0.5 * a[1], 0.5 * a[2])
    return ((S[0], S[1] - g[2], S[2] + g[1], S[3] + g[2], S[4], S[5] - g[0], S[6] - g[1], S[7] + g[0], S[8]),
            (-S[0], -S[1] - g[2], -S[2] + g[1], -S[3] + g[2], -S[4], -S[5] - g[0], -S[6] - g[1], -S[7] + g[0],
             -S[8]))


@kernel
def _put9(buf, o, st, A):
    """buf[o + st i + k] = A[3i + k] (i, k < 3): constant tuple indices (no spill of A to memory)."""
    buf[o] = A[0]
    buf[o + 1] = A[1]
    buf[o + 2] = A[2]
    buf[o + st] = A[3]
    buf[o + st + 1] = A[4]
    buf[o + st + 2] = A[5]
    buf[o + 2 * st] = A[6]
    buf[o + 2 * st + 1] = A[7]
    buf[o + 2 * st + 2] = A[8]


@kernel
def _add9(buf, o, st, A):
    """buf[o + st i + k] += A[3i + k] (i, k < 3)."""
    buf[o] += A[0]
    buf[o + 1] += A[1]
    buf[o + 2] += A[2]
    buf[o + st] += A[3]
    buf[o + st + 1] += A[4]
    buf[o + st + 2] += A[5]
    buf[o + 2 * st] += A[6]
    buf[o + 2 * st + 1] += A[7]
    buf[o + 2 * st + 2] += A[8]


@kernel(**TANGENT)
def _q_blocks(Mb, K, Rs, Rb, ident, buf, c0, sg):
    """Columns c0 … c0 + 5 of Q = ∂d/∂(δx, δθ) into buf (row k at 12k): one node's block.

    Node B (sg = 1): T_SE3⁻¹(d) applied to ξ = (R_sᵀ δx, R̄ᵀ δθ); node A (sg = −1):
    −T_SE3⁻¹(−d). With T_SE3⁻¹ = [T⁻¹, −T⁻¹T_UΩT⁻¹; 0, T⁻¹] (spatial.md §1), ``Mb`` = T⁻¹
    and N = T_UΩ at ±d (transposes of each other): the block is
    [sg Mb R_sᵀ, −sg K R̄ᵀ; 0, sg Mb R̄ᵀ] with ``K`` = Mb N Mb (at −d the transpose of
    its value at d; ``ident``: R̄ = I).
    """
    X = _mmt(Mb, Rs)
    if ident:
        Y = Mb
        P = K
    else:
        Y = _mmt(Mb, Rb)
        P = _mmt(K, Rb)
    if sg < 0.0:
        X = sp.neg9(X)
        Y = sp.neg9(Y)
    else:
        P = sp.neg9(P)
    _put9(buf, c0, 12, X)
    _put9(buf, 36 + c0, 12, (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    _put9(buf, c0 + 3, 12, P)
    _put9(buf, 36 + c0 + 3, 12, Y)


@kernel(**TANGENT)
def _g_blocks(Ub, Wb, s, ds, Mb, Nb, b, r, Da, Rx, Rt, ident, buf, r0):
    """Add Aᵀ ∂(T_SE3⁻ᵀ(d_b) a)/∂d_b (6 columns) to Z = buf[72:144] at rows r0 … r0 + 5, by 3 × 3 blocks.

    Side B: d_b = d; side A: d_b = −d (h_A = −T_SE3⁻ᵀ(−d)σ, whose derivative along δ is that
    of T_SE3⁻ᵀ(·)σ at −d along δ). ``Mb`` = T⁻¹(Ω_b), ``Nb`` = T_UΩ at d_b. Through
    :func:`tinvt_se3`: b_U = Mbᵀ a_U, t = Nbᵀ b_U, b_Ω = Mbᵀ r, r = a_Ω − t:

    * along U (b_U does not depend on U): ∂b_Ω/∂U = −Mbᵀ D_U;
    * along Ω: ∂b_U/∂Ω = D(a_U) and ∂b_Ω/∂Ω = D(r) − Mbᵀ(D_Ω + Nbᵀ D(a_U)),

    with D(a) = ∂(T⁻¹(−Ω) a)/∂Ω (:func:`_dtinv_mat`) and D_U, D_Ω the derivatives of Nbᵀ b_U
    (:func:`_dtuw_blocks`, sgn = −1).

    ``b`` = b_U, ``r`` and ``Da`` = D(a_U) come from the force evaluation (:func:`_dtinvt_pair`).
    Rows: R_x ∂b_U (r0 … r0 + 2; zero along U), R_t ∂b_Ω (r0 + 3 …); ``ident``: R_t = I.
    """
    DU, DW = _dtuw_blocks(Ub, Wb, s, ds, b, -1.0)
    Dr = _dtinv_mat(Wb, s[2], ds[2], r, -1.0)
    if ident:
        RM = sp.tr9(Mb)
    else:
        RM = _mmt(Rt, Mb)                    # R_t Mbᵀ
    X = _mm(Rx, Da)                          # rows x, columns Ω
    YU = _mm(RM, DU)                         # rows θ, columns U (with a minus sign)
    Ki = _mtm(Nb, Da)
    YW = _mm(RM, (DW[0] + Ki[0], DW[1] + Ki[1], DW[2] + Ki[2], DW[3] + Ki[3], DW[4] + Ki[4], DW[5] + Ki[5],
                  DW[6] + Ki[6], DW[7] + Ki[7], DW[8] + Ki[8]))
    if ident:
        RD = Dr
    else:
        RD = _mm(Rt, Dr)
    o = 72 + 6 * r0
    _add9(buf, o + 3, 6, X)
    _add9(buf, o + 18, 6, sp.neg9(YU))
    _add9(buf, o + 21, 6, (RD[0] - YW[0], RD[1] - YW[1], RD[2] - YW[2], RD[3] - YW[3], RD[4] - YW[4],
                           RD[5] - YW[5], RD[6] - YW[6], RD[7] - YW[7], RD[8] - YW[8]))


@kernel(**TANGENT)
def _e_blocks(Ub, Wb, s, ds, Mb, Nb, a, buf, first):
    """Add ∂(T_SE3⁻¹(d_b) a)/∂d_b (6 × 6) to E = buf[144:180] (column k at 144 + 6k), by 3 × 3
    blocks; ``first``: set E instead of adding.

    Side B: d_b = d, a = ξ̇_B; side A: d_b = −d, a = ξ̇_A (ḋ = −T_SE3⁻¹(−d) ξ̇_A + T_SE3⁻¹(d) ξ̇_B,
    whose derivative along δ is the sum of the two). ``Mb`` = T⁻¹(Ω_b), ``Nb`` = T_UΩ at d_b.
    Through :func:`tinv_se3`: b_Ω = Mb a_Ω, t = Nb b_Ω, r = a_U − t, b_U = Mb r:

    * ∂b_Ω/∂U = 0, ∂b_Ω/∂Ω = D⁺(a_Ω);
    * ∂b_U/∂U = −Mb D_U, ∂b_U/∂Ω = D⁺(r) − Mb(D_Ω + Nb D⁺(a_Ω)),

    with D⁺(a) = ∂(T⁻¹(Ω) a)/∂Ω (:func:`_dtinv_mat`) and D_U, D_Ω the derivatives of T_UΩ b_Ω
    (:func:`_dtuw_blocks`, sgn = 1): the derivation of :func:`_g_blocks` with T_UΩ in place of
    its transpose.
    """
    aU = a[0]
    aW = a[1]
    b = sp.mv(Mb, aW)
    r = sp.sub3(aU, sp.mv(Nb, b))
    DU, DW = _dtuw_blocks(Ub, Wb, s, ds, b, 1.0)
    Daw = _dtinv_mat(Wb, s[2], ds[2], aW, 1.0)
    Dr = _dtinv_mat(Wb, s[2], ds[2], r, 1.0)
    Ki = _mm(Nb, Daw)
    YU = _mm(Mb, DU)
    YW = _mm(Mb, (DW[0] + Ki[0], DW[1] + Ki[1], DW[2] + Ki[2], DW[3] + Ki[3], DW[4] + Ki[4], DW[5] + Ki[5],
                  DW[6] + Ki[6], DW[7] + Ki[7], DW[8] + Ki[8]))
    # E[m, k] at 144 + 6k + m: the U rows (m < 3) and Ω rows (m ≥ 3) of the U columns (k < 3) and
    # Ω columns (k ≥ 3)
    for i in range(3):
        for k in range(3):
            uu = -YU[3 * i + k]
            uw = Dr[3 * i + k] - YW[3 * i + k]
            ww = Daw[3 * i + k]
            if first:
                buf[144 + 6 * k + i] = uu
                buf[144 + 6 * (3 + k) + i] = uw
                buf[144 + 6 * k + 3 + i] = 0.0
                buf[144 + 6 * (3 + k) + 3 + i] = ww
            else:
                buf[144 + 6 * k + i] += uu
                buf[144 + 6 * (3 + k) + i] += uw
                buf[144 + 6 * (3 + k) + 3 + i] += ww


@kernel
def _qmul(a0, a1, a2, a3, b0, b1, b2, b3):
    """Quaternion product a ⊗ b (scalar first)."""
    return (a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
            a0 * b1 + b0 * a1 + a2 * b3 - a3 * b2,
            a0 * b2 + b0 * a2 + a3 * b1 - a1 * b3,
            a0 * b3 + b0 * a3 + a1 * b2 - a2 * b1)


@kernel
def section_frames(Pe, x):
    """Section frames of one element: (R_A, R_B (node), R_sA, R_sB (section), x_A, x_B, U, Θ).

    Section rotations R_s = R R̄ with R̄ from the offset quaternions in P; d = (U, Θ) =
    log(H_A⁻¹ H_B) with Θ = log(R_sAᵀ R_sB), U = T⁻¹(−Θ) R_sAᵀ (x_B − x_A).
    """
    RA, RB, RsA, RsB, xA, xB, U, Th, s, ds = _frames(Pe, x, False)
    return RA, RB, RsA, RsB, xA, xB, U, Th


@kernel
def _frames(Pe, x, with_ds):
    """:func:`section_frames` and s = :func:`sfun` (|Θ|²), with ``with_ds`` also ds = :func:`dsfun`
    (else zeros): the kernel evaluates the sine and cosine of |Θ| once."""
    qa = _qmul(x[3], x[4], x[5], x[6], Pe[QA], Pe[QA + 1], Pe[QA + 2], Pe[QA + 3])
    qb = _qmul(x[10], x[11], x[12], x[13], Pe[QB], Pe[QB + 1], Pe[QB + 2], Pe[QB + 3])
    na = 1.0 / math.sqrt(qa[0] * qa[0] + qa[1] * qa[1] + qa[2] * qa[2] + qa[3] * qa[3])
    nb = 1.0 / math.sqrt(qb[0] * qb[0] + qb[1] * qb[1] + qb[2] * qb[2] + qb[3] * qb[3])
    qa = (qa[0] * na, qa[1] * na, qa[2] * na, qa[3] * na)
    qb = (qb[0] * nb, qb[1] * nb, qb[2] * nb, qb[3] * nb)
    rel = _qmul(qa[0], -qa[1], -qa[2], -qa[3], qb[0], qb[1], qb[2], qb[3])
    Th = rt.quat_log3(rel)
    RA = rt.quat_to_matrix_t(x[3], x[4], x[5], x[6])
    RB = rt.quat_to_matrix_t(x[10], x[11], x[12], x[13])
    RsA = rt.quat_to_matrix_t(qa[0], qa[1], qa[2], qa[3])
    RsB = rt.quat_to_matrix_t(qb[0], qb[1], qb[2], qb[3])
    xA = sp.vec3(x, 0)
    xB = sp.vec3(x, 7)
    xab = sp.mtv(RsA, sp.sub3(xB, xA))
    if with_ds:
        s, ds = _sdfun(sp.dot3(Th, Th))
    else:
        s = sfun(sp.dot3(Th, Th))
        ds = (0.0, 0.0, 0.0, 0.0, 0.0)
    U = _tinv3(_neg3(Th), s[2], xab)
    return RA, RB, RsA, RsB, xA, xB, U, Th, s, ds


@kernel
def _c6(Pe, a):
    """C a (a a 6-tuple): the diagonal at P[CD:CD+6] (flag F_DIAG), else C row-major at P[CM:CM+36]."""
    if _flag(Pe, F_DIAG):
        return (Pe[CD] * a[0], Pe[CD + 1] * a[1], Pe[CD + 2] * a[2], Pe[CD + 3] * a[3], Pe[CD + 4] * a[4],
                Pe[CD + 5] * a[5])
    r0 = 0.0
    r1 = 0.0
    r2 = 0.0
    r3 = 0.0
    r4 = 0.0
    r5 = 0.0
    for j in range(6):
        aj = a[j]
        r0 += Pe[CM + j] * aj
        r1 += Pe[CM + 6 + j] * aj
        r2 += Pe[CM + 12 + j] * aj
        r3 += Pe[CM + 18 + j] * aj
        r4 += Pe[CM + 24 + j] * aj
        r5 += Pe[CM + 30 + j] * aj
    return (r0, r1, r2, r3, r4, r5)


@kernel
def _flag(Pe, bit):
    """Bit ``bit`` of P[FLAGS] is set."""
    return (int(Pe[FLAGS]) & bit) != 0


@kernel
def _ddot(U, W, s, sm, vA, vB):
    """ḋ = −T_SE3⁻¹(−d) ξ̇_A + T_SE3⁻¹(d) ξ̇_B (vA, vB pairs of 3-tuples; sm = sfun at −d, same)."""
    a = tinv_se3(_neg3(U), _neg3(W), sm, vA[0], vA[1])
    b = tinv_se3(U, W, s, vB[0], vB[1])
    return (b[0][0] - a[0][0], b[0][1] - a[0][1], b[0][2] - a[0][2],
            b[1][0] - a[1][0], b[1][1] - a[1][1], b[1][2] - a[1][2])


@kernel
def _damped_strain(eps, bL, dd):
    """ε + (β/L) ḋ (a force-path helper: compiled without ``TANGENT``)."""
    return (eps[0] + bL * dd[0], eps[1] + bL * dd[1], eps[2] + bL * dd[2],
            eps[3] + bL * dd[3], eps[4] + bL * dd[4], eps[5] + bL * dd[5])


@kernel
def _rbar(Pe, o):
    """R̄ (9-tuple) of the offset quaternion at P[o:o+4]."""
    return rt.quat_to_matrix_t(Pe[o], Pe[o + 1], Pe[o + 2], Pe[o + 3])


@kernel
def _gyro(Pe, o, w):
    """(J_n Ω, −Ω × J_n Ω) with J_n at P[o:o+9]."""
    h = (Pe[o] * w[0] + Pe[o + 1] * w[1] + Pe[o + 2] * w[2],
         Pe[o + 3] * w[0] + Pe[o + 4] * w[1] + Pe[o + 5] * w[2],
         Pe[o + 6] * w[0] + Pe[o + 7] * w[1] + Pe[o + 8] * w[2])
    return h, _neg3(sp.cross3(w, h))


@kernel(**TANGENT)
def _gyro_jac(Pe, oj, w, h, fv, o):
    """fv[o:o+3, o:o+3] += −(Ω~J − (JΩ)~), J at P[oj:oj+9]."""
    for j in range(3):
        Jc = (Pe[oj + j], Pe[oj + 3 + j], Pe[oj + 6 + j])
        c = sp.cross3(w, Jc)
        for i in range(3):
            fv[o + i, o + j] -= c[i]
    fv[o + 0, o + 1] += -h[2]
    fv[o + 0, o + 2] += h[1]
    fv[o + 1, o + 0] += h[2]
    fv[o + 1, o + 2] += -h[0]
    fv[o + 2, o + 0] += -h[1]
    fv[o + 2, o + 1] += h[0]


NSCRATCH = 252
#: the 3 × 3 identity (row-major), R̄ of the identity section offsets
I9 = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)


def _make_scratch():
    """Intrinsic ``_scratch()``: a float64 array of NSCRATCH entries on the stack of the calling
    kernel (an ``alloca`` in its entry block: no heap allocation, no reference count)."""
    from numba.core import cgutils, types
    from numba.extending import intrinsic
    from numba.np.arrayobj import make_array, populate_array

    @intrinsic
    def _scratch(typingctx):
        retty = types.Array(types.float64, 1, "C")

        def codegen(context, builder, sig, args):
            dt = context.get_data_type(types.float64)
            ptr = cgutils.alloca_once(builder, dt, size=context.get_constant(types.intp, NSCRATCH))
            itemsize = context.get_constant(types.intp, context.get_abi_sizeof(dt))
            out = make_array(retty)(context, builder)
            populate_array(out, data=ptr, shape=[context.get_constant(types.intp, NSCRATCH)],
                           strides=[itemsize], itemsize=itemsize, meminfo=None)
            return out._getvalue()

        return retty(), codegen

    return _scratch


_scratch = _make_scratch()
if jit_disabled():                          # plain Python (NUMBA_DISABLE_JIT=1)
    def _scratch():                         # noqa: F811
        return np.zeros(NSCRATCH)


@kernel(**TANGENT)
def _zq(buf, F, c, off):
    """F −= c Z X with Z (12 × 6) at buf[72:144] and X (6 × 12, row-major) at buf[off:off+72]
    (Q at 0, E Q + P V at 180).

    Each row of F is one loop over its columns (the Ω rows of Q hold zeros in the δx
    columns); its bound is read from F, so that the compiler keeps the loop and
    vectorizes it instead of unrolling it into scalar operations.
    """
    ncol = F.shape[1]
    for i in range(12):
        o = 72 + 6 * i
        z0 = c * buf[o]
        z1 = c * buf[o + 1]
        z2 = c * buf[o + 2]
        z3 = c * buf[o + 3]
        z4 = c * buf[o + 4]
        z5 = c * buf[o + 5]
        for j in range(ncol):
            F[i, j] -= (z0 * buf[off + j] + z1 * buf[off + 12 + j] + z2 * buf[off + 24 + j]
                        + z3 * buf[off + 36 + j] + z4 * buf[off + 48 + j] + z5 * buf[off + 60 + j])


@kernel(**TANGENT)
def _eq_pv(buf, xdA, xdB, RA, RB, ncol):
    """E Q + P V (6 × 12) into buf[180:252]: E (6 × 6) at buf[144:180] (column k at 144 + 6k),
    Q at buf[0:72]; P V adds to the δθ columns of each node the Q columns of its δx times
    ẋ × (column of R), the change of the section velocity R_sᵀẋ under δθ."""
    for m in range(6):
        e0 = buf[144 + m]
        e1 = buf[150 + m]
        e2 = buf[156 + m]
        e3 = buf[162 + m]
        e4 = buf[168 + m]
        e5 = buf[174 + m]
        o = 180 + 12 * m
        for j in range(ncol):
            buf[o + j] = (e0 * buf[j] + e1 * buf[12 + j] + e2 * buf[24 + j] + e3 * buf[36 + j]
                          + e4 * buf[48 + j] + e5 * buf[60 + j])
    for mm in range(3):
        ca = sp.cross3(xdA, (RA[mm], RA[3 + mm], RA[6 + mm]))
        cb = sp.cross3(xdB, (RB[mm], RB[3 + mm], RB[6 + mm]))
        for k in range(6):
            o = 12 * k
            buf[180 + o + 3 + mm] += buf[o] * ca[0] + buf[o + 1] * ca[1] + buf[o + 2] * ca[2]
            buf[180 + o + 9 + mm] += buf[o + 6] * cb[0] + buf[o + 7] * cb[1] + buf[o + 8] * cb[2]


@kernel
def spatial_beam_mass(P, xe, Me):
    """Constant mass: translational m_d I, m_o I (A–B), rotary J_n at each node (body axes)."""
    for e in range(xe.shape[0]):
        md = P[e, MD]
        mo = P[e, MO]
        for i in range(3):
            Me[e, i, i] = md
            Me[e, 6 + i, 6 + i] = md
            Me[e, i, 6 + i] = mo
            Me[e, 6 + i, i] = mo
            for j in range(3):
                Me[e, 3 + i, 3 + j] = P[e, JN + 3 * i + j]
                Me[e, 9 + i, 9 + j] = P[e, JNB + 3 * i + j]


@kernel
def spatial_beam_force(P, t, tf, xe, ve, jac, fe, fq, fv):
    """Elastic, damping and gyroscopic forces of the SE(3) beam (module docstring).

    P (nel, 43 or 79): d0 (6), L, β, flags (F_DIAG, F_IDENT, F_ROTARY), p̄_A (4), p̄_B (4), diag C (6),
    J_nA (9), J_nB (9), m_d, m_o and, only in a batch with a non-diagonal C, C (36, row-major).
    xe (nel, 14) = (x_A, p_A, x_B, p_B); ve (nel, 12) = (ẋ_A, Ω_A, ẋ_B, Ω_B).
    """
    for e in range(xe.shape[0]):
        Pe = P[e]
        x = xe[e]
        v = ve[e]
        RA, RB, RsA, RsB, xA, xB, U, W, s, ds = _frames(Pe, x, jac)
        L = Pe[LEN]
        iL = 1.0 / L
        beta = Pe[BETA]
        eps = ((U[0] - Pe[0]) * iL, (U[1] - Pe[1]) * iL, (U[2] - Pe[2]) * iL,
               (W[0] - Pe[3]) * iL, (W[1] - Pe[4]) * iL, (W[2] - Pe[5]) * iL)
        xdA = sp.vec3(v, 0)
        xdB = sp.vec3(v, 6)
        wA = sp.vec3(v, 3)
        wB = sp.vec3(v, 9)
        # R̄_A = R̄_B = I (node axes = section axes, as meshed by spatial_beam): the R̄ products skipped
        ident = _flag(Pe, F_IDENT)
        RbA = I9 if ident else _rbar(Pe, QA)
        RbB = I9 if ident else _rbar(Pe, QB)
        z3 = (0.0, 0.0, 0.0)
        vA = (z3, z3)
        vB = (z3, z3)
        if beta != 0.0:
            # section velocities and the strain rate only with damping
            if ident:
                vA = (sp.mtv(RsA, xdA), wA)
                vB = (sp.mtv(RsB, xdB), wB)
            else:
                vA = (sp.mtv(RsA, xdA), sp.mtv(RbA, wA))
                vB = (sp.mtv(RsB, xdB), sp.mtv(RbB, wB))
            eps = _damped_strain(eps, beta * iL, _ddot(U, W, s, s, vA, vB))
        sig = _c6(Pe, eps)
        # T⁻¹(Ω) and T_UΩ once as matrices, for the forces and the tangent: at −d they are
        # the transposes, so h_B = T_SE3⁻ᵀ(d)σ = (Mᵀσ_U, Mᵀ(σ_Ω − Nᵀ b_U)) and
        # h_A = −T_SE3⁻ᵀ(−d)σ = −(Mσ_U, M(σ_Ω − N b_U)) (:func:`tinvt_se3`)
        M = _tinv_mat(W, s[2])
        N = _tuw_mat(U, W, s)
        sU = (sig[0], sig[1], sig[2])
        sW = (sig[3], sig[4], sig[5])
        bUB = sp.mtv(M, sU)
        bUA = sp.mv(M, sU)
        rB = sp.sub3(sW, sp.mtv(N, bUB))
        rA = sp.sub3(sW, sp.mv(N, bUA))
        hB = (bUB, sp.mtv(M, rB))
        hA = (_neg3(bUA), _neg3(sp.mv(M, rA)))
        fxa = sp.mv(RsA, hA[0])
        fxb = sp.mv(RsB, hB[0])
        if ident:
            fta = hA[1]
            ftb = hB[1]
        else:
            fta = sp.mv(RbA, hA[1])
            ftb = sp.mv(RbB, hB[1])
        gA, mgA = _gyro(Pe, JN, wA)
        gB, mgB = _gyro(Pe, JNB, wB)
        for i in range(3):
            fe[e, i] = -fxa[i]
            fe[e, 3 + i] = -fta[i] + mgA[i]
            fe[e, 6 + i] = -fxb[i]
            fe[e, 9 + i] = -ftb[i] + mgB[i]
        if not jac:
            continue
        # Scratch on the stack (no heap arrays in kernels): Q = ∂d/∂(δx, δθ) (6 × 12, row k at
        # 12k), Z = Qᵀ C/L (12 × 6, row i at 72 + 6i), E = ∂ḋ/∂d (6 × 6, column k at 144 + 6k).
        Mt = sp.tr9(M)
        Nt = sp.tr9(N)
        buf = _scratch()
        MNM = _mm(M, _mm(N, M))
        _q_blocks(Mt, sp.tr9(MNM), RsA, RbA, ident, buf, 0, -1.0)
        _q_blocks(M, MNM, RsB, RbB, ident, buf, 6, 1.0)
        if _flag(Pe, F_DIAG):
            # the usual section (principal axes, shear centre at the centroid): C diagonal
            c0 = Pe[CD] * iL
            c1 = Pe[CD + 1] * iL
            c2 = Pe[CD + 2] * iL
            c3 = Pe[CD + 3] * iL
            c4 = Pe[CD + 4] * iL
            c5 = Pe[CD + 5] * iL
            for i in range(12):
                o = 72 + 6 * i
                buf[o] = c0 * buf[i]
                buf[o + 1] = c1 * buf[12 + i]
                buf[o + 2] = c2 * buf[24 + i]
                buf[o + 3] = c3 * buf[36 + i]
                buf[o + 4] = c4 * buf[48 + i]
                buf[o + 5] = c5 * buf[60 + i]
        else:
            for i in range(12):
                if i % 6 < 3:
                    # a δx column of Q has no Ω rows
                    cq = _c6(Pe, (buf[i], buf[12 + i], buf[24 + i], 0.0, 0.0, 0.0))
                else:
                    cq = _c6(Pe, (buf[i], buf[12 + i], buf[24 + i], buf[36 + i], buf[48 + i], buf[60 + i]))
                o = 72 + 6 * i
                buf[o] = cq[0] * iL
                buf[o + 1] = cq[1] * iL
                buf[o + 2] = cq[2] * iL
                buf[o + 3] = cq[3] * iL
                buf[o + 4] = cq[4] * iL
                buf[o + 5] = cq[5] * iL
        if beta != 0.0:
            # fv = −β Qᵀ(C/L)Q; fq −= β Qᵀ(C/L)(E Q + P V): E = ∂ḋ/∂d at fixed section
            # velocities (:func:`_e_blocks`), P V the change of R_sᵀẋ under δθ (columns θ_A, θ_B)
            _zq(buf, fv[e], beta, 0)
            _e_blocks(_neg3(U), _neg3(W), s, ds, Mt, Nt, vA, buf, True)
            _e_blocks(U, W, s, ds, M, N, vB, buf, False)
            _eq_pv(buf, xdA, xdB, RA, RB, fq.shape[2])
            _zq(buf, fq[e], beta, 180)
        # G (12 × 6) = ∂(h_A, h_B)/∂d at fixed σ (analytic, :func:`_g_blocks`); Z += Aᵀ G, then
        # fq −= Z Q = Qᵀ(C/L)Q + Aᵀ G Q
        DaB, DaA = _dtinvt_pair(W, s[2], ds[2], sU)
        _g_blocks(_neg3(U), _neg3(W), s, ds, Mt, Nt, bUA, rA, DaA, RsA, RbA, ident, buf, 0)
        _g_blocks(U, W, s, ds, M, N, bUB, rB, DaB, RsB, RbB, ident, buf, 6)
        _zq(buf, fq[e], 1.0, 0)
        # the rotation of the force directions: ∂(−R R̄ h_U)/∂δθ = R (R̄ h_U)~
        if ident:
            ma = sp.rskew(RA, hA[0])
            mb = sp.rskew(RB, hB[0])
        else:
            ma = sp.rskew(RA, sp.mv(RbA, hA[0]))
            mb = sp.rskew(RB, sp.mv(RbB, hB[0]))
        for i in range(3):
            for j in range(3):
                fq[e, i, 3 + j] += ma[3 * i + j]
                fq[e, 6 + i, 9 + j] += mb[3 * i + j]
        if _flag(Pe, F_ROTARY):     # fv is touched only by types that declare it
            V = fv[e]
            _gyro_jac(Pe, JN, wA, gA, V, 3)
            _gyro_jac(Pe, JNB, wB, gB, V, 9)


@kernel
def spatial_beam_energy(P, t, tf, xe, Ve):
    """Strain energy V = ½ L εᵀ C ε of each element, ε = (d − d0)/L (the strains of
    :func:`spatial_beam_force`, whose elastic part is −∂V/∂(δx, δθ)); P and xe as there."""
    for e in range(xe.shape[0]):
        Pe = P[e]
        RA, RB, RsA, RsB, xA, xB, U, W, s, ds = _frames(Pe, xe[e], False)
        iL = 1.0 / Pe[LEN]
        eps = ((U[0] - Pe[0]) * iL, (U[1] - Pe[1]) * iL, (U[2] - Pe[2]) * iL,
               (W[0] - Pe[3]) * iL, (W[1] - Pe[4]) * iL, (W[2] - Pe[5]) * iL)
        sig = _c6(Pe, eps)
        Ve[e] = 0.5 * Pe[LEN] * (eps[0] * sig[0] + eps[1] * sig[1] + eps[2] * sig[2]
                                 + eps[3] * sig[3] + eps[4] * sig[4] + eps[5] * sig[5])


def section_stiffness(P):
    """The section stiffnesses C (nel, 6, 6) of packed elements ``P`` (either layout)."""
    if P.shape[1] >= NPAR:
        return P[:, CM:CM + 36].reshape(-1, 6, 6).copy()
    C = np.zeros((len(P), 6, 6))
    C[:, np.arange(6), np.arange(6)] = P[:, CD:CD + 6]
    return C


# ---------------------------------------------------------------------------
# sections
# ---------------------------------------------------------------------------
def _cowper_nu(E, G):
    return E / (2.0 * G) - 1.0


def _material(owner, E, G, density, shear_factor, damping):
    """Checked material numbers: E, G > 0, density ≥ 0, shear factor > 0 or None, damping ≥ 0."""
    E = _check_scalar(owner, "E", E, positive=True)
    G = _check_scalar(owner, "G", G, positive=True)
    density = _check_scalar(owner, "density", density, nonneg=True)
    if shear_factor is not None:
        shear_factor = _check_scalar(owner, "shear_factor", shear_factor, positive=True)
    damping = _check_scalar(owner, "damping", damping, nonneg=True)
    return E, G, density, shear_factor, damping


_STIFFNESS_NAMES = ("EA", "GA2", "GA3", "GJ", "EI2", "EI3")


@dataclass
class SpatialSection:
    """Cross-section of a spatial beam: stiffness C (6 × 6) and inertia per unit length.

    Section axes: 1 along the beam, 2 and 3 in the cross-section. Strain
    ε = (Γ1 − 1, Γ2, Γ3, κ1, κ2, κ3) (extension, shears, twist, curvatures), resultants
    σ = C ε = (N, V2, V3, T, M2, M3).

    Parameters
    ----------
    C : (6, 6) array_like
        Symmetric positive definite section stiffness; diagonal
        (EA, k2 GA, k3 GA, GJ, EI2, EI3) for principal, shear-centre = centroid sections.
    rhoA : float
        Mass per unit length (kg/m).
    rhoJ : (3,) or (3, 3) array_like
        Mass moment of inertia per unit length in section axes (kg m); (ρ(I2 + I3), ρI2, ρI3)
        for a homogeneous section.
    damping : float, optional
        β (s): stiffness-proportional damping, σ = C (ε + β ε̇).
    """

    C: np.ndarray
    rhoA: float = 0.0
    rhoJ: np.ndarray = field(default_factory=lambda: np.zeros(3))
    damping: float = 0.0

    def __post_init__(self):
        try:
            C = np.asarray(self.C, dtype=float)
        except (TypeError, ValueError):
            raise ModelError(f"SpatialSection: C must be 6 numbers or a 6×6 matrix, got {self.C!r}") from None
        if C.shape == (6,):
            C = np.diag(C)
        if C.shape != (6, 6) or not np.all(np.isfinite(C)):
            raise ModelError(f"SpatialSection: C must be 6 numbers or a finite 6×6 matrix, got shape {C.shape}"
                             + ("" if C.shape != (6, 6) else f" with entries that are not finite: diagonal "
                                f"{dict(zip(_STIFFNESS_NAMES, np.diag(C).tolist()))}"))
        if not np.allclose(C, C.T, rtol=1e-12, atol=1e-14 * np.abs(C).max()):
            raise ModelError("SpatialSection: C must be symmetric (the strain energy is ½εᵀCε)")
        bad = [f"{k} = {v:.6g}" for k, v in zip(_STIFFNESS_NAMES, np.diag(C)) if not v > 0.0]
        if bad:
            raise ModelError(f"SpatialSection: the stiffnesses must be positive: {', '.join(bad)}")
        lam = np.linalg.eigvalsh(C)
        if lam[0] <= 0.0:
            raise ModelError(f"SpatialSection: C must be positive definite; its smallest eigenvalue is {lam[0]:.6g} "
                             f"(the couplings outweigh the diagonal {dict(zip(_STIFFNESS_NAMES, np.diag(C).tolist()))})")
        self.C = 0.5 * (C + C.T)
        self.rhoA = _check_scalar("SpatialSection", "rhoA", self.rhoA)
        if self.rhoA < 0.0:
            raise ModelError(f"SpatialSection: rhoA must be ≥ 0, got {self.rhoA}")
        try:
            J = np.asarray(self.rhoJ, dtype=float)
        except (TypeError, ValueError):
            raise ModelError(f"SpatialSection: rhoJ must be 3 numbers or a symmetric 3×3 matrix, got {self.rhoJ!r}") from None
        if J.shape == (3,):
            J = np.diag(J)
        if J.shape != (3, 3) or not np.all(np.isfinite(J)) or not np.allclose(J, J.T):
            raise ModelError("SpatialSection: rhoJ must be 3 numbers or a symmetric 3×3 matrix")
        if np.linalg.eigvalsh(J)[0] < 0.0:
            raise ModelError(f"SpatialSection: rhoJ must be positive semi-definite, got {J.tolist()}")
        self.rhoJ = J
        self.damping = _check_scalar("SpatialSection", "damping", self.damping)
        if self.damping < 0.0:
            raise ModelError(f"SpatialSection: damping must be ≥ 0, got {self.damping}")

    @classmethod
    def from_properties(cls, EA, GA2, GA3, GJ, EI2, EI3, rhoA=0.0, rhoJ=(0.0, 0.0, 0.0), damping=0.0):
        """Diagonal C = diag(EA, GA2, GA3, GJ, EI2, EI3) (shear stiffnesses include the shear factors)."""
        d = [_check_scalar("SpatialSection.from_properties", k, v, positive=True)
             for k, v in zip(_STIFFNESS_NAMES, (EA, GA2, GA3, GJ, EI2, EI3))]
        return cls(np.diag(d), rhoA, rhoJ, damping)

    @classmethod
    def rectangle(cls, E, G, width, height, density=0.0, shear_factor=5.0 / 6.0, damping=0.0):
        """Solid rectangle, ``width`` along section axis 2, ``height`` along axis 3.

        I2 = w h³/12 (bending about axis 2), I3 = h w³/12; shear factor k (default 5/6;
        Cowper 1966: 10(1+ν)/(12+11ν)) on both shears; St-Venant torsion constant
        J = a b³ (1/3 − 0.21 (b/a)(1 − b⁴/(12 a⁴))), a ≥ b the sides (Roark, Table 10.7,
        within 4 % for all ratios, exact as a/b → ∞).
        """
        own = "SpatialSection.rectangle"
        E, G, density, shear_factor, damping = _material(own, E, G, density, shear_factor, damping)
        w, h = (_check_scalar(own, "width", width, positive=True), _check_scalar(own, "height", height, positive=True))
        A = w * h
        I2 = w * h ** 3 / 12.0
        I3 = h * w ** 3 / 12.0
        a, b = max(w, h), min(w, h)
        J = a * b ** 3 * (1.0 / 3.0 - 0.21 * (b / a) * (1.0 - b ** 4 / (12.0 * a ** 4)))
        k = shear_factor
        return cls.from_properties(E * A, k * G * A, k * G * A, G * J, E * I2, E * I3,
                                   density * A, density * np.array([I2 + I3, I2, I3]), damping)

    @classmethod
    def circle(cls, E, G, diameter, density=0.0, shear_factor=None, damping=0.0):
        """Solid circle: I = π d⁴/64, J = π d⁴/32; shear factor default Cowper's 6(1+ν)/(7+6ν), ν = E/2G − 1."""
        E, G, density, shear_factor, damping = _material("SpatialSection.circle", E, G, density, shear_factor, damping)
        d = _check_scalar("SpatialSection.circle", "diameter", diameter, positive=True)
        A = math.pi * d * d / 4.0
        I = math.pi * d ** 4 / 64.0
        nu = _cowper_nu(E, G)
        k = 6.0 * (1.0 + nu) / (7.0 + 6.0 * nu) if shear_factor is None else shear_factor
        return cls.from_properties(E * A, k * G * A, k * G * A, G * 2.0 * I, E * I, E * I,
                                   density * A, density * np.array([2.0 * I, I, I]), damping)

    @classmethod
    def tube(cls, E, G, outer_diameter, inner_diameter, density=0.0, shear_factor=None, damping=0.0):
        """Circular tube: I = π(D⁴ − d⁴)/64, J = 2I; shear factor default Cowper's
        6(1+ν)(1+m²)²/((7+6ν)(1+m²)² + (20+12ν)m²), m = d/D."""
        own = "SpatialSection.tube"
        E, G, density, shear_factor, damping = _material(own, E, G, density, shear_factor, damping)
        Do = _check_scalar(own, "outer_diameter", outer_diameter, positive=True)
        Di = _check_scalar(own, "inner_diameter", inner_diameter, nonneg=True)
        if not 0.0 <= Di < Do:
            raise ModelError(f"SpatialSection.tube: need 0 ≤ inner < outer diameter, got {Di}, {Do}")
        A = math.pi * (Do * Do - Di * Di) / 4.0
        I = math.pi * (Do ** 4 - Di ** 4) / 64.0
        nu = _cowper_nu(E, G)
        m2 = (Di / Do) ** 2
        k = (6.0 * (1.0 + nu) * (1.0 + m2) ** 2 / ((7.0 + 6.0 * nu) * (1.0 + m2) ** 2 + (20.0 + 12.0 * nu) * m2)
             if shear_factor is None else shear_factor)
        return cls.from_properties(E * A, k * G * A, k * G * A, G * 2.0 * I, E * I, E * I,
                                   density * A, density * np.array([2.0 * I, I, I]), damping)


# ---------------------------------------------------------------------------
# nodes and the element
# ---------------------------------------------------------------------------
class SpatialBeamNode(SpatialBody, Element):
    """A frame node of a spatial beam (no mass of its own); joints attach to it as to a body.

    Parameters
    ----------
    name : str
    position : (3,)
    rotation : (4,) quaternion or (3, 3) matrix, optional
        Node axes (body to space) at t0; :func:`spatial_beam` makes them the section axes.
    velocity, omega : (3,), optional
        Initial ṙ (space axes) and Ω (node axes).
    fixed_translation, fixed_rotation : optional
        As :class:`FrameNode` (a clamp).
    """

    def __init__(self, name, position, rotation=None, velocity=(0.0, 0.0, 0.0), omega=(0.0, 0.0, 0.0),
                 fixed_translation=(False, False, False), fixed_rotation=False, points=None, axes=None):
        Element.__init__(self, name)
        node = FrameNode(name, position, rotation, velocity, omega, fixed_translation, fixed_rotation)
        self._init_body(name, node, points, axes, None)

    def nodes(self):
        return [self.node]


def _qmul_np(a, b):
    return np.array(_qmul.py_func(*a, *b))


def _se3_log_np(qa, xa, qb, xb):
    """d = log(H_A⁻¹ H_B) (6,) of section frames given by unit quaternions and positions."""
    rel = _qmul_np(np.array([qa[0], -qa[1], -qa[2], -qa[3]]), qb)
    Th = np.array(rt.quat_log3.py_func(rel))
    RsA = rt.quat_to_matrix(np.ascontiguousarray(qa))
    xab = RsA.T @ (np.asarray(xb) - np.asarray(xa))
    s = sfun.py_func(float(Th @ Th))
    U = np.array(_tinv3((-Th[0], -Th[1], -Th[2]), s[2], (xab[0], xab[1], xab[2])))
    return np.concatenate((U, Th))


class SpatialBeam(Element):
    """Two-node geometrically exact (Simo–Reissner) spatial beam, SE(3) formulation.

    See the module docstring for the formulation. The element's section axes at
    each end are the node's axes times a constant offset R̄ fixed at t0: by default
    (``frame=None``) the section frame at t0 has axis 1 along the chord x_B − x_A
    and axes 2, 3 from the nodes (the node's axis 2 projected normal to the chord),
    so a node may carry several elements in different directions (a rigid elbow)
    and may be any frame node (a rigid body's centre of mass, a beam node).

    Parameters
    ----------
    name : str
    a, b : SpatialBody or str
        The bodies whose frame nodes are the element's ends.
    section : SpatialSection
    mass : {"consistent", "lumped", "averaged"}
        Translational mass: consistent ρAL/6 [2 1; 1 2], lumped ρAL/2 [1 0; 0 1], or their
        average ρAL/12 [5 1; 1 5] (the most accurate bending frequencies with 20 elements,
        tests/test_spatial_beam_modal.py). Rotary inertia is always lumped.
    frame_a, frame_b : (3, 3) array_like, optional
        Section axes at t0 in space (columns e1, e2, e3) at each end; default: e1 along
        the chord, e2 the node's axis 2 made normal to e1 (or its axis 3 if parallel).
        For a curved reference give the exact tangent frames (the element then holds the
        circular/helical arc through them).
    """

    spatial = True                    # acts on frame nodes (femb.system.model: no planar element on them)
    glyph = "beam"                    # drawn as a tube along its centre line (femb.io.frames)
    has_mass = True
    constant_mass = True
    has_force = True
    force_depends_on_qd = True
    work = "potential"                # strain energy (kernels["energy"]); damping in "dissipated"
    kernels = {"mass": spatial_beam_mass, "force": spatial_beam_force, "energy": spatial_beam_energy}

    def __init__(self, name, a, b, section, mass="consistent", frame_a=None, frame_b=None):
        super().__init__(name)
        if not isinstance(section, SpatialSection):
            raise ModelError(f"SpatialBeam '{name}': section must be a SpatialSection, got {section!r}")
        if mass not in ("consistent", "lumped", "averaged"):
            raise ModelError(f"SpatialBeam '{name}': mass must be 'consistent', 'lumped' or 'averaged', "
                             f"got {mass!r}")
        self.a, self.b = a, b
        self.section = section
        self.mass_kind = mass
        self.frame_a = None if frame_a is None else np.asarray(frame_a, dtype=float)
        self.frame_b = None if frame_b is None else np.asarray(frame_b, dtype=float)

    def resolve(self, lookup):
        from .spatial_joints import _resolve_spatial
        self.a = _resolve_spatial(self, self.a, lookup, "a")
        self.b = _resolve_spatial(self, self.b, lookup, "b")
        if self.a is self.b:
            raise ModelError(f"SpatialBeam '{self.name}': ends a and b are the same body ('{self.a.name}')")

    def nodes(self):
        return [self.a.node, self.b.node]

    def _default_frame(self, node, chord):
        e1 = chord / np.linalg.norm(chord)
        R0 = node.rotation0
        for c in (R0[:, 1], R0[:, 2], R0[:, 0]):
            e2 = c - (c @ e1) * e1
            if np.linalg.norm(e2) > 1e-6:
                e2 /= np.linalg.norm(e2)
                return np.column_stack((e1, e2, np.cross(e1, e2)))
        raise ModelError(f"SpatialBeam '{self.name}': cannot build a section frame")  # pragma: no cover

    def validate(self):
        xa, xb = self.a.node.q0[:3], self.b.node.q0[:3]
        chord = xb - xa
        if np.linalg.norm(chord) == 0.0:
            raise ModelError(f"SpatialBeam '{self.name}': its two nodes coincide at t0 (zero length)")
        Fa = self.frame_a if self.frame_a is not None else self._default_frame(self.a.node, chord)
        Fb = self.frame_b if self.frame_b is not None else self._default_frame(self.b.node, chord)
        pa, pb = (rotation_input(f"SpatialBeam '{self.name}'", w, F) for w, F in (("frame_a", Fa), ("frame_b", Fb)))
        # offsets R̄ = Rᵀ R_s (node axes to section axes)
        self.qbar_a = _qmul_np(np.array([1, -1, -1, -1.0]) * self.a.node.q0[3:7], pa)
        self.qbar_b = _qmul_np(np.array([1, -1, -1, -1.0]) * self.b.node.q0[3:7], pb)
        self.qbar_a /= np.linalg.norm(self.qbar_a)
        self.qbar_b /= np.linalg.norm(self.qbar_b)
        self.d0 = _se3_log_np(pa, xa, pb, xb)
        self.L = float(np.linalg.norm(self.d0[:3]))
        if np.linalg.norm(self.d0[3:]) > 0.75 * math.pi:
            raise ModelError(f"SpatialBeam '{self.name}': the section frames at its ends differ by "
                             f"{np.linalg.norm(self.d0[3:]):.3g} rad at t0 (more than 3π/4): refine the mesh")

    @classmethod
    def pack(cls, elements):
        """``P`` (nel, 43) or, when some section's C is not diagonal, (nel, 79): the layout of
        :func:`spatial_beam_force`."""
        full = any(np.count_nonzero(e.section.C - np.diag(np.diag(e.section.C))) for e in elements)
        P = np.zeros((len(elements), NPAR if full else NPAR_DIAG))
        for k, e in enumerate(elements):
            s = e.section
            m = s.rhoA * e.L
            P[k, D0:D0 + 6] = e.d0
            P[k, LEN] = e.L
            diag = not np.count_nonzero(s.C - np.diag(np.diag(s.C)))
            P[k, CD:CD + 6] = np.diag(s.C)
            if full:
                P[k, CM:CM + 36] = s.C.reshape(-1)
            ident = all(np.array_equal(q, [1.0, 0.0, 0.0, 0.0]) for q in (e.qbar_a, e.qbar_b))
            P[k, FLAGS] = (F_DIAG if diag else 0) + (F_IDENT if ident else 0) + (F_ROTARY if np.any(s.rhoJ) else 0)
            if e.mass_kind == "consistent":
                P[k, MD], P[k, MO] = m / 3.0, m / 6.0
            elif e.mass_kind == "averaged":
                P[k, MD], P[k, MO] = 5.0 * m / 12.0, m / 12.0
            else:
                P[k, MD], P[k, MO] = m / 2.0, 0.0
            # rotary inertia at each node, in node axes: R̄ ρJ R̄ᵀ L/2 (each end its own offset)
            for o, qb in ((JN, e.qbar_a), (JNB, e.qbar_b)):
                Rb = rt.quat_to_matrix(np.ascontiguousarray(qb))
                P[k, o:o + 9] = (Rb @ s.rhoJ @ Rb.T * (0.5 * e.L)).reshape(-1)
            P[k, BETA] = s.damping
            P[k, QA:QA + 4] = e.qbar_a
            P[k, QB:QB + 4] = e.qbar_b
        return {"P": P, "L": P[:, LEN].copy()}

    @classmethod
    def traits(cls, elements):
        """``force_depends_on_qd`` only when some element has damping or rotary inertia (gyroscopic)."""
        t = super().traits(elements)
        t["force_depends_on_qd"] = any(e.section.damping != 0.0 or np.any(e.section.rhoJ != 0.0)
                                       for e in elements)
        return t

    # ---------------------------------------------------------------- output
    @classmethod
    def strains(cls, p, qe, qde=None):
        """Strains ε = (d − d0)/L (nel, 6) = (Γ1 − Γ1⁰, Γ2 − Γ2⁰, Γ3 − Γ3⁰, κ − κ⁰) in section axes.

        With ``qde`` (nel, 12) the strain rates ε̇ are returned too.
        """
        P = p["P"]
        qe = np.asarray(qe, dtype=float)
        eps = np.empty((len(P), 6))
        rate = np.empty((len(P), 6))
        for e in range(len(P)):
            # the compiled function (its helpers have no Python wrapper, so no .py_func here)
            RA, RB, RsA, RsB, xA, xB, U, W = section_frames(np.ascontiguousarray(P[e]),
                                                            np.ascontiguousarray(qe[e]))
            eps[e] = (np.array([*U, *W]) - P[e, D0:D0 + 6]) / P[e, LEN]
            if qde is not None:
                v = np.asarray(qde[e], dtype=float)
                s = sfun.py_func(float(np.dot(W, W)))
                RbA = rt.quat_to_matrix(np.ascontiguousarray(P[e, QA:QA + 4]))
                RbB = rt.quat_to_matrix(np.ascontiguousarray(P[e, QB:QB + 4]))
                vA = (tuple(np.reshape(RsA, (3, 3)).T @ v[0:3]), tuple(RbA.T @ v[3:6]))
                vB = (tuple(np.reshape(RsB, (3, 3)).T @ v[6:9]), tuple(RbB.T @ v[9:12]))
                rate[e] = np.array(_ddot(U, W, s, s, vA, vB)) / P[e, LEN]
        return eps if qde is None else (eps, rate)

    @classmethod
    def resultants(cls, p, qe, qde=None):
        """Section resultants σ = C(ε + βε̇) (nel, 6) = (N, V2, V3, T, M2, M3) in section axes."""
        P = p["P"]
        if qde is None:
            eps = cls.strains(p, qe)
        else:
            eps, rate = cls.strains(p, qe, qde)
            eps = eps + P[:, BETA:BETA + 1] * rate
        return np.einsum("eij,ej->ei", section_stiffness(P), eps)

    @classmethod
    def strain_energy(cls, p, qe):
        """½ L εᵀ C ε per element (nel,)."""
        P = p["P"]
        eps = cls.strains(p, qe)
        return 0.5 * P[:, LEN] * np.einsum("ei,eij,ej->e", eps, section_stiffness(P), eps)

    @classmethod
    def geometry(cls, p, t, qe, qde, lame, names):
        """The centre lines: one line per element through its two nodes.

        Cell data per element: the resultants ``N, V2, V3, T, M2, M3`` (section axes, the part
        towards B on the part towards A; :meth:`resultants`) and the strains ``Gamma1 …
        Gamma3, kappa1 … kappa3`` (ε = (d − d0)/L, :meth:`strains`). Point data at each end
        of each element: the section frame ``e1, e2, e3`` (unit vectors in space axes, e1 along
        the reference centre line).
        """
        qe = np.asarray(qe, dtype=float)
        n = qe.shape[0]
        pts = np.concatenate((qe[:, 0:3], qe[:, 7:10]))
        conn = np.column_stack((np.arange(n), n + np.arange(n))).astype(np.int64)
        sig = cls.resultants(p, qe)
        eps = cls.strains(p, qe)
        cd = {k: [sig[:, i].copy()] for i, k in enumerate(("N", "V2", "V3", "T", "M2", "M3"))}
        cd.update({k: [eps[:, i].copy()] for i, k in enumerate(("Gamma1", "Gamma2", "Gamma3",
                                                               "kappa1", "kappa2", "kappa3"))})
        frames = np.empty((2 * n, 3, 3))
        P = p["P"]
        for e in range(n):
            _, _, RsA, RsB, _, _, _, _ = section_frames(np.ascontiguousarray(P[e]), np.ascontiguousarray(qe[e]))
            frames[e] = np.reshape(RsA, (3, 3))
            frames[n + e] = np.reshape(RsB, (3, 3))
        pd = {f"e{k + 1}": np.ascontiguousarray(frames[:, :, k]) for k in range(3)}
        return [GeometryBlock(cls.__name__, pts, [("line", conn)], cell_data=cd, point_data=pd)]


# ---------------------------------------------------------------------------
# meshing
# ---------------------------------------------------------------------------
@dataclass
class SpatialBeamMesh:
    """What :func:`spatial_beam` added to a mechanism.

    Attributes
    ----------
    name : str
    nodes : list of SpatialBody
        The n + 1 node bodies from start to end (:class:`SpatialBeamNode`, or the body
        given as a ``"shared"`` end).
    elements : list of SpatialBeam
    joints : dict
        ``{"start": FixedJoint or None, "end": FixedJoint or None}``.
    section : SpatialSection
    arc_length : ndarray (n + 1,)
        Reference arc length of the nodes (sum of element lengths |U0|).
    """

    name: str
    nodes: list
    elements: list
    joints: dict
    section: Any
    arc_length: np.ndarray = field(repr=False)

    @property
    def node_names(self):
        return [b.node.name for b in self.nodes]

    @property
    def length(self):
        return float(self.arc_length[-1])

    def positions(self, model, q):
        """Node positions for q (..., nx): shape (..., n + 1, 3)."""
        return np.stack([model.node_coordinates(nm, q)[..., 0:3] for nm in self.node_names], axis=-2)

    def quaternions(self, model, q):
        """Node quaternions (..., n + 1, 4)."""
        return np.stack([model.node_coordinates(nm, q)[..., 3:7] for nm in self.node_names], axis=-2)


def _frame_from(t, normal, where="spatial_beam"):
    e1 = np.asarray(t, dtype=float)
    if not np.all(np.isfinite(e1)) or np.linalg.norm(e1) == 0.0:
        raise ModelError(f"{where}: the beam axis has no direction there (a segment of zero length, or a "
                         f"curve whose tangent is zero or not finite): {t!r}")
    e1 = e1 / np.linalg.norm(e1)
    if normal is None:
        normal = (0.0, 0.0, 1.0) if abs(e1[2]) < 0.9 else (0.0, 1.0, 0.0)
        # default: axis 2 horizontal-ish, axis 3 "up" where possible
        n = np.asarray(normal, dtype=float)
        e3 = n - (n @ e1) * e1
        e3 /= np.linalg.norm(e3)
        return np.column_stack((e1, np.cross(e3, e1), e3))
    n = np.asarray(normal, dtype=float)
    e2 = n - (n @ e1) * e1
    if np.linalg.norm(e2) < 1e-9 * np.linalg.norm(n):
        raise ModelError(f"{where}: normal {np.asarray(normal).tolist()} (the direction of section axis 2) "
                         f"is parallel to the beam axis {e1.tolist()}")
    e2 /= np.linalg.norm(e2)
    return np.column_stack((e1, e2, np.cross(e1, e2)))


#: largest angle (rad) between e1 of ``frames(s)`` and the centre line's tangent (central differences
#: of ``path``, step 1e-6: error about 1e-10 for curves of unit scale)
FRAME_TANGENT_TOL = 1e-6


def _call_path(owner, path, s):
    """``path(s)`` as three finite numbers, or a ModelError naming s."""
    try:
        x = path(s)
    except Exception as e:
        raise ModelError(f"{owner}: path({s:.6g}) raised {type(e).__name__}: {e}") from e
    try:
        v = np.asarray(x, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        v = None
    if v is None or v.size != 3:
        raise ModelError(f"{owner}: path(s) must return three coordinates (x, y, z); path({s:.6g}) "
                         f"returned {x!r}")
    if not np.all(np.isfinite(v)):
        raise ModelError(f"{owner}: path({s:.6g}) is not finite: {v.tolist()}")
    return v


def _user_frame(owner, frames, s, k, tangent):
    """``frames(s)`` checked: a rotation matrix whose first column is the unit tangent."""
    try:
        F = frames(s)
    except Exception as e:
        raise ModelError(f"{owner}: frames({s:.6g}) raised {type(e).__name__}: {e}") from e
    p = rotation_input(f"{owner}: frames({s:.6g}) at node {k}", "the section axes", F)
    R = rt.quat_to_matrix(p)
    t = tangent / np.linalg.norm(tangent)
    ang = math.atan2(np.linalg.norm(np.cross(R[:, 0], t)), float(R[:, 0] @ t))
    if ang > FRAME_TANGENT_TOL:
        raise ModelError(f"{owner}: frames({s:.6g}) at node {k} has its first axis e1 = "
                         f"{np.round(R[:, 0], 6).tolist()} at {math.degrees(ang):.4g}° ({ang:.3g} rad) from the "
                         f"centre line's tangent {np.round(t, 6).tolist()}; e1 must be the unit tangent of path "
                         f"(tolerance {FRAME_TANGENT_TOL:g} rad), e2 and e3 the cross-section axes")
    return R


def _curve_mesh(owner, path, n, frames, normal):
    """Nodes and section frames of a curve ``path(s)``, s ∈ [0, 1], at s = k/n."""
    s = np.linspace(0.0, 1.0, n + 1)
    X = np.array([_call_path(owner, path, si) for si in s])
    h = 1e-6
    T = [(_call_path(owner, path, si + h) - _call_path(owner, path, si - h)) / (2 * h) for si in s]
    F = []
    for k, (si, tk) in enumerate(zip(s, T)):
        where = f"{owner} at node {k} (s = {si:g})"
        if frames is None:
            F.append(_frame_from(tk, normal, where))
        else:
            _frame_from(tk, None, where)                      # a tangent there at all
            F.append(_user_frame(owner, frames, si, k, tk))
    return X, F[:-1], F[1:], F


def _polyline_mesh(owner, P, counts, normal):
    """Nodes and section frames of a polyline with ``counts[k]`` elements on segment k."""
    pts, fa, fb, node_frames = [P[0]], [], [], []
    for k in range(len(P) - 1):
        Fk = _frame_from(P[k + 1] - P[k], normal, f"{owner}, segment {k} from {P[k]} to {P[k + 1]}")
        if k == 0:
            node_frames.append(Fk)
        for j in range(1, counts[k] + 1):
            pts.append(P[k] + (P[k + 1] - P[k]) * j / counts[k])
            node_frames.append(Fk)
            fa.append(Fk)
            fb.append(Fk)
    return np.array(pts), fa, fb, node_frames


def _polyline_counts(owner, P, n_elements):
    nseg = len(P) - 1
    if np.ndim(n_elements) == 0:
        return [element_count(owner, "n_elements", n_elements)] * nseg
    counts = list(n_elements)
    if len(counts) != nseg:
        raise ModelError(f"{owner}: n_elements has {len(counts)} counts for {nseg} segments")
    return [element_count(owner, f"n_elements[{k}]", c) for k, c in enumerate(counts)]


def _check_end(mech, owner, which, spec):
    """An end specification: None, "clamp", a spatial body or its name, or (body, "shared")."""
    if spec is None or (isinstance(spec, str) and spec == "clamp"):
        return
    if isinstance(spec, tuple) and len(spec) == 2 and spec[1] == "shared":
        body = spec[0]
        if isinstance(body, str):
            if body not in mech:
                raise ModelError(f"{owner}: {which}: no body named '{body}'")
            body = mech[body]
        if not isinstance(body, SpatialBody):
            raise ModelError(f"{owner}: {which}: {spec[0]!r} is not a spatial body")
        return
    if isinstance(spec, str):
        if spec != "ground" and spec not in mech:
            raise ModelError(f"{owner}: {which}: no body named '{spec}' (and not 'clamp')")
        return
    if not isinstance(spec, Body):            # a spatial body or the ground (FixedJoint checks the rest)
        raise ModelError(f"{owner}: {which} must be None, 'clamp', a spatial body or its name, the ground, "
                         f"or (body, 'shared'), got {spec!r}")


def _mesher_inputs(mech, name, section, mass, normal, frames, path):
    """The checks of :func:`spatial_beam` that need no mesh; returns the owner string and ``normal``."""
    from femb.system.mechanism import Mechanism
    if not isinstance(name, str) or not name:
        raise ModelError(f"spatial_beam: name must be a non-empty string, got {name!r}")
    owner = f"spatial_beam '{name}'"
    if not isinstance(mech, Mechanism):
        raise ModelError(f"{owner}: mech must be a Mechanism, got {mech!r}")
    if not isinstance(section, SpatialSection):
        raise ModelError(f"{owner}: section must be a SpatialSection, got {type(section).__name__}")
    if mass not in ("consistent", "lumped", "averaged"):
        raise ModelError(f"{owner}: mass must be 'consistent', 'lumped' or 'averaged', got {mass!r}")
    if normal is not None:
        normal = vector3(owner, "normal", normal)
        if not np.linalg.norm(normal) > 0.0:
            raise ModelError(f"{owner}: normal (the direction of section axis 2) must not be zero, "
                             f"got {normal.tolist()}")
    if frames is not None and not callable(frames):
        raise ModelError(f"{owner}: frames must be a callable frames(s) -> (3, 3), got {frames!r}")
    if frames is not None and not callable(path):
        raise ModelError(f"{owner}: frames applies to a curve path(s); a polyline's section axes "
                         f"come from its segments and normal")
    return owner, normal


def _node_velocities(owner, pts, node_frames, velocity, omega, about):
    """Initial (ṙ, Ω) of the n + 1 nodes: a rigid field v₀ + ω × (r − p), or per-node values
    (space axes; Ω in node axes = section axes at t0)."""
    n1 = len(pts)

    def numbers(what, value):
        if value is None:
            return np.zeros((n1, 3))
        try:
            return np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise ModelError(f"{owner}: {what} must be three finite numbers or one row of three per node "
                             f"({n1}, 3), got {value!r}") from None

    V, W = numbers("velocity", velocity), numbers("omega", omega)
    for what, A in (("velocity", V), ("omega", W)):
        if A.shape not in ((3,), (n1, 3)) or not np.all(np.isfinite(A)):
            raise ModelError(f"{owner}: {what} must be three finite numbers or one row of three per node "
                             f"({n1}, 3), got shape {A.shape}")
    p = np.zeros(3) if about is None else vector3(owner, "about", about)
    if about is not None and (V.ndim == 2 or W.ndim == 2):
        raise ModelError(f"{owner}: about applies to a rigid field (velocity and omega of 3 numbers)")
    W = np.broadcast_to(W, (n1, 3))
    V = np.broadcast_to(V, (n1, 3)) + (np.cross(W, pts - p) if V.ndim == 1 else 0.0)
    Om = np.array([node_frames[k].T @ W[k] for k in range(n1)])
    return V, Om


def spatial_beam(mech, name, section, path, n_elements, *, normal=None, frames=None, start=None, end=None,
                 mass="consistent", velocity=None, omega=None, about=None):
    """Mesh a spatial beam along a line, a polyline or a curve and add it to ``mech``.

    Parameters
    ----------
    mech : Mechanism
    name : str
        Prefix: nodes ``{name}.n0`` …, elements ``{name}.e0`` …, joints ``{name}.start``,
        ``{name}.end``.
    section : SpatialSection
    path : (m, 3) array_like or callable
        A polyline through m ≥ 2 points (straight segments; a corner is a rigid elbow:
        one node, each segment's elements with their own section axes), or a curve
        ``path(s)`` → (3,), s ∈ [0, 1] (nodes at s = k/n).
    n_elements : int or sequence of int
        Elements in total (a curve), per segment (int: each segment of a polyline), or
        a list with one count per segment; whole numbers ≥ 1 (4.0 is 4; 2.7 is an error).
        A mesh whose model would not fit in the machine's memory is refused before
        anything is made.
    normal : (3,), optional
        Direction of section axis 2 (made normal to the axis); default: axis 3 towards +z
        (+y for beams along z).
    frames : callable, optional
        For a curve: ``frames(s)`` → (3, 3) section axes at s (columns e1 = unit tangent,
        e2, e3); default: the tangent by central differences of ``path`` (step 1e-6,
        error O(1e-12)) and ``normal``. A frame whose e1 is more than
        :data:`FRAME_TANGENT_TOL` from the tangent is refused (naming the node and the angle).
    start, end : None, "clamp", SpatialBody or name, or (body, "shared")
        Free end; clamped to the ground (the node's coordinates are fixed); welded to a
        body by a :class:`~femb.elements.spatial_joints.FixedJoint` at the node; or the
        body's own frame node is the end node (``"shared"``; its axes need not be the
        section axes).
    mass : {"consistent", "lumped", "averaged"}
    velocity, omega : (3,) or (n + 1, 3), optional
        Initial velocities of the nodes, space axes. Both (3,): the rigid motion
        ṙ = v₀ + ω × (r − p) of velocity v₀ at the point p = ``about`` and angular velocity ω
        (each node's Ω = R₀ᵀ ω in its node axes; :func:`femb.system.motion.set_rigid_velocity` sets any
        body to such a field). Rows per node: ṙ and ω of each node. Default: at rest. A
        ``"shared"`` end keeps its body's velocities; clamped nodes must be given zero.
    about : (3,), optional
        The point p of a rigid field; default the origin.

    Returns
    -------
    SpatialBeamMesh
    """
    from .spatial_joints import FixedJoint
    owner, normal = _mesher_inputs(mech, name, section, mass, normal, frames, path)
    if callable(path):
        n = element_count(owner, "n_elements", n_elements)
        check_model_size(owner, n, "spatial")
        pts, fa, fb, node_frames = _curve_mesh(owner, path, n, frames, normal)
    else:
        try:
            P = np.asarray(path, dtype=float)
        except (TypeError, ValueError):
            P = None
        if P is None or P.ndim != 2 or P.shape[1] != 3 or len(P) < 2 or not np.all(np.isfinite(P)):
            got = repr(path)[:80] if P is None else f"shape {P.shape}" + ("" if np.all(np.isfinite(P)) else ", not finite")
            raise ModelError(f"{owner}: path must be (m ≥ 2, 3) finite points or a callable path(s) -> (3,), "
                             f"got {got}")
        counts = _polyline_counts(owner, P, n_elements)
        check_model_size(owner, sum(counts), "spatial")
        pts, fa, fb, node_frames = _polyline_mesh(owner, P, counts, normal)
    for which, spec in (("start", start), ("end", end)):
        _check_end(mech, owner, which, spec)
    V, Om = _node_velocities(owner, pts, node_frames, velocity, omega, about)
    n = len(pts) - 1
    nodes = []
    joints = {"start": None, "end": None}
    for k in range(n + 1):
        spec = start if k == 0 else (end if k == n else None)
        if isinstance(spec, tuple):                        # (body, "shared"), checked above
            body = mech[spec[0]] if isinstance(spec[0], str) else spec[0]
            if np.linalg.norm(body.node.q0[:3] - pts[k]) > 1e-9 * max(1.0, np.abs(pts).max()):
                raise ModelError(f"{owner}: the shared body '{body.name}' has its node at "
                                 f"{body.node.q0[:3]}, not at the beam end {pts[k]}")
            nodes.append(body)
            continue
        clamp = isinstance(spec, str) and spec == "clamp"
        if clamp and (np.any(V[k] != 0.0) or np.any(Om[k] != 0.0)):
            raise ModelError(f"{owner}: the clamped {'start' if k == 0 else 'end'} node {k} cannot move: "
                             f"its initial velocity would be ṙ = {V[k].tolist()}, Ω = {Om[k].tolist()}")
        nd = SpatialBeamNode(f"{name}.n{k}", pts[k], node_frames[k], velocity=V[k], omega=Om[k],
                             fixed_translation=(clamp, clamp, clamp), fixed_rotation=clamp)
        mech.add(nd)
        nodes.append(nd)
        if spec is not None and not clamp:
            which = "start" if k == 0 else "end"
            joints[which] = mech.add(FixedJoint(f"{name}.{which}", spec, nd, at=pts[k]))
    elements = []
    for k in range(n):
        elements.append(mech.add(SpatialBeam(f"{name}.e{k}", nodes[k], nodes[k + 1], section, mass=mass,
                                             frame_a=fa[k], frame_b=fb[k])))
    arc = np.zeros(n + 1)
    for k, e in enumerate(elements):
        e.validate()
        arc[k + 1] = arc[k] + e.L
    return SpatialBeamMesh(name, nodes, elements, joints, section, arc)


# ---------------------------------------------------------------------------
# results along a meshed beam (Result.beam)
# ---------------------------------------------------------------------------
@dataclass
class BeamSeries:
    """A meshed spatial beam over the stored times of a result (:meth:`femb.results.result.Result.beam`).

    n elements ``{name}.e0`` … ``{name}.e{n-1}``, n + 1 nodes from the start to the end of the
    mesh, nt stored times. All vectors in space axes unless stated.

    Attributes
    ----------
    name : str
    t : ndarray (nt,)
    nodes : list of str
        The n + 1 frame nodes, start to end.
    elements : list of str
    arc_length : ndarray (n + 1,)
        Reference arc length of the nodes (sum of the element lengths |U0|).
    centre_line : ndarray (nt, n + 1, 3)
        Node (section centroid) positions.
    frames : ndarray (nt, n + 1, 3, 3)
        Section axes at each node, columns (e1, e2, e3): e1 the beam axis (tangent of the
        reference; with shear it is the section normal, not the tangent of the deformed
        line), e2, e3 the cross-section axes; R_node R̄ with the offset R̄ of the element
        that starts at the node (the last node: of the element that ends there).
    forces : ndarray (nt, n, 6)
        Section resultants per element (constant along an element), **section axes**:
        (N, Q2, Q3, T, M2, M3) = C (ε + β ε̇): N > 0 in tension, Q2, Q3 shear forces, T the
        torque, M2, M3 bending moments about e2, e3; the force and moment that the part of
        the beam towards the end node exerts on the part towards the start node (right-hand
        rule). In space axes: R_s (N, Q2, Q3) with R_s the element's section axes.
    strains : ndarray (nt, n, 6)
        (Γ − Γ0, κ − κ0) per element in section axes: axial strain, shear strains, twist and
        curvatures relative to the stress-free reference (1/m for κ).
    """

    name: str
    t: np.ndarray
    nodes: list
    elements: list
    arc_length: np.ndarray
    centre_line: np.ndarray
    frames: np.ndarray
    forces: np.ndarray
    strains: np.ndarray

    @property
    def gamma(self):
        """Translational strains Γ − Γ0 (nt, n, 3)."""
        return self.strains[..., 0:3]

    @property
    def kappa(self):
        """Curvature and twist κ − κ0 (nt, n, 3)."""
        return self.strains[..., 3:6]

    def force(self, which):
        """One resultant by name ("N", "Q2", "Q3", "T", "M2", "M3"): (nt, n)."""
        return self.forces[..., ("N", "Q2", "Q3", "T", "M2", "M3").index(which)]


def beam_series(result, name):
    """:class:`BeamSeries` of the beam meshed as ``name`` by :func:`spatial_beam` in ``result``."""
    model = result.model
    found = {}
    for g in model.groups:
        if not issubclass(g.cls, SpatialBeam):
            continue
        for i, e in enumerate(g.elements):
            pre, _, k = e.name.rpartition(".e")
            if pre == name and k.isdigit():
                found[int(k)] = (g, i, e)
    if not found:
        raise ModelError(f"no spatial beam named '{name}' (elements '{name}.e0', …) in model '{model.name}'")
    n = len(found)
    if sorted(found) != list(range(n)):
        raise ModelError(f"beam '{name}': elements are not numbered 0 … {n - 1}")
    els = [found[k] for k in range(n)]
    nodes = [els[0][2].a.node.name] + [e.b.node.name for _, _, e in els]
    nt = len(result.t)
    X = np.stack([model.node_coordinates(nm, result.q) for nm in nodes], axis=1)        # (nt, n+1, 7)
    Rbar = [_rbar_np(e.qbar_a) for _, _, e in els] + [_rbar_np(els[-1][2].qbar_b)]
    frames = np.empty((nt, n + 1, 3, 3))
    for j in range(n + 1):
        for k in range(nt):
            frames[k, j] = rt.quat_to_matrix(np.ascontiguousarray(X[k, j, 3:7])) @ Rbar[j]
    forces = np.empty((nt, n, 6))
    strains = np.empty((nt, n, 6))
    for g in {id(g): g for g, _, _ in els}.values():
        idx = [i for gg, i, _ in els if gg is g]
        pos = [k for k, (gg, _, _) in enumerate(els) if gg is g]
        p = {"P": g.P[idx]}
        for k in range(nt):
            qe = model.ext(result.q[k])[g.xdofs[idx]]
            qde = model.ext_velocity(result.qd[k])[g.dofs[idx]]
            eps, rate = SpatialBeam.strains(p, qe, qde)
            strains[k, pos] = eps
            forces[k, pos] = np.einsum("eij,ej->ei", section_stiffness(p["P"]), eps + p["P"][:, BETA:BETA + 1] * rate)
    arc = np.concatenate(([0.0], np.cumsum([e.L for _, _, e in els])))
    return BeamSeries(name, np.asarray(result.t).copy(), nodes, [e.name for _, _, e in els], arc,
                      X[..., 0:3].copy(), frames, forces, strains)


def _rbar_np(q):
    return rt.quat_to_matrix(np.ascontiguousarray(q, dtype=float))
