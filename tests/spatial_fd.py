"""Finite differences on R³ × SO(3) for the spatial kernel tests (x ⊕ δ = (r + δr, p ∘ exp(δθ)))."""
import numpy as np

from femb.base import rotations as rt


def random_quat(rng):
    return rt.quat_exp(rng.uniform(-3.0, 3.0) * _unit(rng))


def _unit(rng):
    v = rng.standard_normal(3)
    return v / np.linalg.norm(v)


def random_frame_state(rng, nnodes, nel):
    """xe (nel, 7 nnodes) with unit quaternions, ve (nel, 6 nnodes)."""
    xe = np.zeros((nel, 7 * nnodes))
    for e in range(nel):
        for k in range(nnodes):
            xe[e, 7 * k:7 * k + 3] = rng.standard_normal(3)
            xe[e, 7 * k + 3:7 * k + 7] = random_quat(rng)
    ve = rng.standard_normal((nel, 6 * nnodes))
    return xe, ve


def oplus(xe, d):
    """x ⊕ d per element: xe (nel, 7k), d (nel, 6k)."""
    out = xe.copy()
    nn = xe.shape[1] // 7
    for e in range(xe.shape[0]):
        for k in range(nn):
            out[e, 7 * k:7 * k + 7] = rt.frame_compose(np.ascontiguousarray(xe[e, 7 * k:7 * k + 7]),
                                                       np.ascontiguousarray(d[e, 6 * k:6 * k + 6]))
    return out


def tangent_jacobian(fun, xe, eps=1e-6):
    """d fun(x ⊕ δ)/dδ at δ = 0, central differences: fun maps (nel, 7k) -> (nel, ...)."""
    nel = xe.shape[0]
    ndv = 6 * (xe.shape[1] // 7)
    f0 = fun(xe)
    J = np.zeros(f0.shape + (ndv,))
    for j in range(ndv):
        d = np.zeros((nel, ndv))
        d[:, j] = eps
        J[..., j] = (fun(oplus(xe, d)) - fun(oplus(xe, -d))) / (2 * eps)
    return J


def random_rotation_rows(rng):
    """An orthonormal 3×3 matrix (rows)."""
    return rt.quat_to_matrix(random_quat(rng))
