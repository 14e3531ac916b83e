"""Rotations for spatial nodes: unit quaternions and the Lie group SO(3), compiled.

Conventions (Brüls & Cardona 2010; femb's ``docs/spatial.md``):

* a quaternion is ``p = (p0, p1, p2, p3)``, scalar first; the rotation matrix of a
  unit quaternion is R(p) = (p0² − p⃗·p⃗) I + 2 p⃗p⃗ᵀ + 2 p0 p⃗~ and maps body to
  space components;
* ``a~`` is the skew matrix of a (a~ b = a × b);
* rotations are perturbed on the right, R ← R exp(δθ~), δθ in body axes;
* exp(θ) = I + s1 θ~ + s2 θ~², and the tangent operator T(θ) is defined by
  exp(θ + δ) = exp(θ) exp((T(θ) δ)~) + O(δ²):
  T(θ) = I − s2 θ~ + s3 θ~², T⁻¹(θ) = I + ½ θ~ + s4 θ~² (singular at |θ| = 2π),
  with s1 = sin φ/φ, s2 = (1 − cos φ)/φ², s3 = (φ − sin φ)/φ³,
  s4 = (1 − (φ/2) cot(φ/2))/φ², φ = |θ|, each by its Taylor series for φ < 0.1.

Every function is a numba kernel (:func:`femb.base.jit.kernel`) working on float64
arrays. The scalar functions, :func:`quat_to_matrix_t` (a tuple) and the
functions named ``*_into`` (they write into a given output array) allocate
nothing and may be called from element kernels and the time loop; the others
return new arrays (``allocates=True``) and serve Python-side code only.

References
----------
O. Brüls, A. Cardona, On the use of Lie group time integrators in multibody
dynamics, J. Comput. Nonlinear Dynam. 5(3):031002, 2010 (exponential map and
tangent operator of SO(3), eqs. for T and T⁻¹).
O. Brüls, A. Cardona, M. Arnold, Lie group generalized-α time integration of
constrained flexible multibody systems, Mech. Mach. Theory 48:121–137, 2012.
M. Géradin, A. Cardona, Flexible Multibody Dynamics, Wiley, 2001, Ch. 4
(quaternions / Euler parameters, Rodrigues' formula).
"""
from __future__ import annotations

import math

import numpy as np

from femb.base.jit import kernel

#: below this angle φ the coefficient functions use their Taylor series
SERIES_SWITCH = 0.1


# ---------------------------------------------------------------------------
# scalar coefficient functions of the SO(3) exponential
# ---------------------------------------------------------------------------
@kernel
def s1(phi):
    """sin φ / φ."""
    if phi < SERIES_SWITCH:
        p2 = phi * phi
        return 1.0 - p2 / 6.0 * (1.0 - p2 / 20.0 * (1.0 - p2 / 42.0 * (1.0 - p2 / 72.0)))
    return math.sin(phi) / phi


@kernel
def s2(phi):
    """(1 − cos φ) / φ²."""
    if phi < SERIES_SWITCH:
        p2 = phi * phi
        return 0.5 - p2 / 24.0 * (1.0 - p2 / 30.0 * (1.0 - p2 / 56.0 * (1.0 - p2 / 90.0)))
    return (1.0 - math.cos(phi)) / (phi * phi)


@kernel
def s3(phi):
    """(φ − sin φ) / φ³."""
    if phi < SERIES_SWITCH:
        p2 = phi * phi
        return 1.0 / 6.0 - p2 / 120.0 * (1.0 - p2 / 42.0 * (1.0 - p2 / 72.0))
    return (phi - math.sin(phi)) / (phi * phi * phi)


@kernel
def s4(phi):
    """(1 − (φ/2) cot(φ/2)) / φ² (singular at φ = 2π)."""
    if phi < SERIES_SWITCH:
        p2 = phi * phi
        return 1.0 / 12.0 + p2 / 720.0 + p2 * p2 / 30240.0 + p2 * p2 * p2 / 1209600.0
    h = 0.5 * phi
    return (1.0 - h * math.cos(h) / math.sin(h)) / (phi * phi)


@kernel
def s7(phi):
    """sin(φ/2) / φ: the quaternion of exp(θ) is (cos(φ/2), s7 θ)."""
    if phi < SERIES_SWITCH:
        p2 = phi * phi
        return 0.5 - p2 / 48.0 + p2 * p2 / 3840.0 - p2 * p2 * p2 / 645120.0
    return math.sin(0.5 * phi) / phi


# ---------------------------------------------------------------------------
# small linear algebra
# ---------------------------------------------------------------------------
@kernel
def skew_into(a, S):
    """S = a~ (3×3), so that S b = a × b."""
    S[0, 0] = 0.0
    S[0, 1] = -a[2]
    S[0, 2] = a[1]
    S[1, 0] = a[2]
    S[1, 1] = 0.0
    S[1, 2] = -a[0]
    S[2, 0] = -a[1]
    S[2, 1] = a[0]
    S[2, 2] = 0.0


@kernel(allocates=True)
def skew(a):
    """The skew matrix a~ of a 3-vector, shape (3, 3)."""
    S = np.empty((3, 3))
    skew_into(a, S)
    return S


@kernel(allocates=True)
def vee(S):
    """The axial vector of the skew part of S: vee(a~) = a, shape (3,)."""
    return np.array([0.5 * (S[2, 1] - S[1, 2]), 0.5 * (S[0, 2] - S[2, 0]), 0.5 * (S[1, 0] - S[0, 1])])


# ---------------------------------------------------------------------------
# quaternions
# ---------------------------------------------------------------------------
@kernel
def quat_mul_into(a, b, out):
    """out = a ⊗ b = (a0b0 − a⃗·b⃗, a0b⃗ + b0a⃗ + a⃗ × b⃗); ``out`` must not alias a or b."""
    out[0] = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3]
    out[1] = a[0] * b[1] + b[0] * a[1] + a[2] * b[3] - a[3] * b[2]
    out[2] = a[0] * b[2] + b[0] * a[2] + a[3] * b[1] - a[1] * b[3]
    out[3] = a[0] * b[3] + b[0] * a[3] + a[1] * b[2] - a[2] * b[1]


@kernel(allocates=True)
def quat_mul(a, b):
    """Quaternion product a ⊗ b (R(a ⊗ b) = R(a) R(b)), shape (4,)."""
    out = np.empty(4)
    quat_mul_into(a, b, out)
    return out


@kernel(allocates=True)
def quat_conj(a):
    """Conjugate (p0, −p⃗): the inverse rotation of a unit quaternion, shape (4,)."""
    return np.array([a[0], -a[1], -a[2], -a[3]])


@kernel
def quat_normalize_into(p):
    """Scale p to unit norm in place."""
    n = math.sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2] + p[3] * p[3])
    for i in range(4):
        p[i] /= n


@kernel
def quat_to_matrix_t(p0, p1, p2, p3):
    """R(p) of a unit quaternion (no normalisation) as a row-major 9-tuple (no array)."""
    d = p0 * p0 - (p1 * p1 + p2 * p2 + p3 * p3)
    return (d + 2.0 * p1 * p1, 2.0 * (p1 * p2 - p0 * p3), 2.0 * (p1 * p3 + p0 * p2),
            2.0 * (p1 * p2 + p0 * p3), d + 2.0 * p2 * p2, 2.0 * (p2 * p3 - p0 * p1),
            2.0 * (p1 * p3 - p0 * p2), 2.0 * (p2 * p3 + p0 * p1), d + 2.0 * p3 * p3)


@kernel
def quat_to_matrix_into(p, R):
    """R = R(p) for a unit quaternion p (no normalisation)."""
    T = quat_to_matrix_t(p[0], p[1], p[2], p[3])
    for i in range(3):
        for j in range(3):
            R[i, j] = T[3 * i + j]


@kernel(allocates=True)
def quat_to_matrix(p):
    """Rotation matrix of a unit quaternion, shape (3, 3)."""
    R = np.empty((3, 3))
    quat_to_matrix_into(p, R)
    return R


@kernel
def quat_exp_into(theta, out):
    """out = quaternion of exp(θ) = (cos(φ/2), s7(φ) θ)."""
    phi = math.sqrt(theta[0] * theta[0] + theta[1] * theta[1] + theta[2] * theta[2])
    c = s7(phi)
    out[0] = math.cos(0.5 * phi)
    out[1] = c * theta[0]
    out[2] = c * theta[1]
    out[3] = c * theta[2]


@kernel(allocates=True)
def quat_exp(theta):
    """Unit quaternion of the rotation exp(θ), shape (4,)."""
    out = np.empty(4)
    quat_exp_into(theta, out)
    return out


@kernel
def quat_log3(p):
    """Rotation vector θ with exp(θ) = R(p), |θ| ≤ π, as a tuple of three floats (no allocation).

    The sign of p is flipped to p0 ≥ 0 first (p and −p are one rotation);
    θ = 2 atan2(|p⃗|, p0) p⃗/|p⃗|, by its series for |p⃗| < 1e-4.
    """
    n = math.sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2] + p[3] * p[3])
    sg = 1.0 if p[0] >= 0.0 else -1.0
    p0 = sg * p[0] / n
    v0, v1, v2 = sg * p[1] / n, sg * p[2] / n, sg * p[3] / n
    s = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    if s < 1e-4:
        c = (2.0 / p0) * (1.0 - s * s / (3.0 * p0 * p0))
    else:
        c = 2.0 * math.atan2(s, p0) / s
    return (c * v0, c * v1, c * v2)


@kernel(allocates=True)
def quat_log(p):
    """Rotation vector θ with exp(θ) = R(p), |θ| ≤ π, shape (3,) (:func:`quat_log3`)."""
    t = quat_log3(p)
    return np.array([t[0], t[1], t[2]])


@kernel(allocates=True)
def matrix_to_quat(R):
    """Unit quaternion (p0 ≥ 0) of a rotation matrix (Shepperd's method), shape (4,)."""
    tr = R[0, 0] + R[1, 1] + R[2, 2]
    p = np.empty(4)
    k = 0
    big = tr
    for i in range(3):
        if R[i, i] > big:
            big = R[i, i]
            k = i + 1
    if k == 0:
        p[0] = 0.5 * math.sqrt(1.0 + tr)
        f = 0.25 / p[0]
        p[1] = (R[2, 1] - R[1, 2]) * f
        p[2] = (R[0, 2] - R[2, 0]) * f
        p[3] = (R[1, 0] - R[0, 1]) * f
    else:
        i = k - 1
        j = (i + 1) % 3
        m = (i + 2) % 3
        pi = 0.5 * math.sqrt(1.0 + R[i, i] - R[j, j] - R[m, m])
        f = 0.25 / pi
        p[1 + i] = pi
        p[0] = (R[m, j] - R[j, m]) * f
        p[1 + j] = (R[j, i] + R[i, j]) * f
        p[1 + m] = (R[m, i] + R[i, m]) * f
    if p[0] < 0.0:
        for i in range(4):
            p[i] = -p[i]
    return p


# ---------------------------------------------------------------------------
# SO(3): exponential, logarithm, tangent operator
# ---------------------------------------------------------------------------
@kernel
def expm_into(theta, R):
    """R = exp(θ~) = I + s1 θ~ + s2 θ~² (Rodrigues)."""
    phi = math.sqrt(theta[0] * theta[0] + theta[1] * theta[1] + theta[2] * theta[2])
    a, b = s1(phi), s2(phi)
    x, y, z = theta[0], theta[1], theta[2]
    R[0, 0] = 1.0 - b * (y * y + z * z)
    R[1, 1] = 1.0 - b * (x * x + z * z)
    R[2, 2] = 1.0 - b * (x * x + y * y)
    R[0, 1] = -a * z + b * x * y
    R[1, 0] = a * z + b * x * y
    R[0, 2] = a * y + b * x * z
    R[2, 0] = -a * y + b * x * z
    R[1, 2] = -a * x + b * y * z
    R[2, 1] = a * x + b * y * z


@kernel(allocates=True)
def expm(theta):
    """Rotation matrix exp(θ~), shape (3, 3)."""
    R = np.empty((3, 3))
    expm_into(theta, R)
    return R


@kernel(allocates=True)
def logm(R):
    """Rotation vector θ, |θ| ≤ π, with exp(θ~) = R, shape (3,) (via the quaternion)."""
    return quat_log(matrix_to_quat(R))


@kernel
def _poly_into(theta, c1, c2, out):
    """out = I + c1 θ~ + c2 θ~²."""
    x, y, z = theta[0], theta[1], theta[2]
    out[0, 0] = 1.0 - c2 * (y * y + z * z)
    out[1, 1] = 1.0 - c2 * (x * x + z * z)
    out[2, 2] = 1.0 - c2 * (x * x + y * y)
    out[0, 1] = -c1 * z + c2 * x * y
    out[1, 0] = c1 * z + c2 * x * y
    out[0, 2] = c1 * y + c2 * x * z
    out[2, 0] = -c1 * y + c2 * x * z
    out[1, 2] = -c1 * x + c2 * y * z
    out[2, 1] = c1 * x + c2 * y * z


@kernel
def tangent_into(theta, T):
    """T = T(θ) = I − s2 θ~ + s3 θ~² (Brüls & Cardona 2010)."""
    phi = math.sqrt(theta[0] * theta[0] + theta[1] * theta[1] + theta[2] * theta[2])
    _poly_into(theta, -s2(phi), s3(phi), T)


@kernel(allocates=True)
def tangent(theta):
    """Tangent operator T(θ) of SO(3), shape (3, 3): exp(θ + δ) ≈ exp(θ) exp((T(θ)δ)~)."""
    T = np.empty((3, 3))
    tangent_into(theta, T)
    return T


@kernel
def tangent_inv_into(theta, Ti):
    """Ti = T⁻¹(θ) = I + ½ θ~ + s4 θ~² (singular at |θ| = 2π)."""
    phi = math.sqrt(theta[0] * theta[0] + theta[1] * theta[1] + theta[2] * theta[2])
    _poly_into(theta, 0.5, s4(phi), Ti)


@kernel(allocates=True)
def tangent_inv(theta):
    """Inverse tangent operator T⁻¹(θ), shape (3, 3)."""
    Ti = np.empty((3, 3))
    tangent_inv_into(theta, Ti)
    return Ti


# ---------------------------------------------------------------------------
# the group R³ × SO(3) of a frame node: x = (r, p), tangent (δr, δθ)
# ---------------------------------------------------------------------------
@kernel
def frame_compose_into(x, d, out):
    """out = x ∘ exp(d) on R³ × SO(3): (r + d_r, p ⊗ quat(exp(d_θ))), renormalised.

    x : (7,) = (r, p); d : (6,) = (δr in space axes, δθ in body axes); out : (7,).
    """
    t0, t1, t2 = d[3], d[4], d[5]
    phi = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
    c = s7(phi)
    e = (math.cos(0.5 * phi), c * t0, c * t1, c * t2)       # quaternion of exp(d_θ)
    for i in range(3):
        out[i] = x[i] + d[i]
    quat_mul_into(x[3:7], e, out[3:7])
    quat_normalize_into(out[3:7])


@kernel(allocates=True)
def frame_compose(x, d):
    """x ∘ exp(d) for a frame node, shape (7,) (see :func:`frame_compose_into`)."""
    out = np.empty(7)
    frame_compose_into(x, d, out)
    return out


@kernel(allocates=True)
def frame_tangent(d):
    """T(d) of R³ × SO(3): blockdiag(I₃, T(d_θ)), shape (6, 6)."""
    T = np.zeros((6, 6))
    for i in range(3):
        T[i, i] = 1.0
    tangent_into(d[3:6], T[3:6, 3:6])
    return T


@kernel(allocates=True)
def frame_bracket(v, w):
    """Lie bracket [v, w] of R³ × SO(3): (0, Ω_v × Ω_w), shape (6,)."""
    out = np.zeros(6)
    out[3] = v[4] * w[5] - v[5] * w[4]
    out[4] = v[5] * w[3] - v[3] * w[5]
    out[5] = v[3] * w[4] - v[4] * w[3]
    return out
