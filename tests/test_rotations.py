"""femb.base.rotations: quaternions, exp/log of SO(3), tangent operator (compiled)."""
import math

import numpy as np
import pytest

from femb.base import rotations as rt


def _rand_rot(rng, scale=1.0):
    return scale * rng.standard_normal(3)


def test_series_and_closed_forms_agree_at_the_switch():
    phi = rt.SERIES_SWITCH
    for f, exact in ((rt.s1, lambda p: math.sin(p) / p),
                     (rt.s2, lambda p: (1 - math.cos(p)) / p**2),
                     (rt.s4, lambda p: (1 - 0.5 * p / math.tan(0.5 * p)) / p**2),
                     (rt.s7, lambda p: math.sin(0.5 * p) / p)):
        assert abs(f(phi * (1 - 1e-12)) - exact(phi)) < 1e-14
    # s3 in closed form loses digits near 0; compare with a high-order series
    p = phi
    ser = 1/6 - p**2/120 + p**4/5040 - p**6/362880 + p**8/39916800
    assert abs(rt.s3(p * (1 + 1e-12)) - ser) < 1e-13
    assert rt.s1(0.0) == 1.0 and rt.s2(0.0) == 0.5 and rt.s4(0.0) == 1 / 12


@pytest.mark.parametrize("trial", range(5))
def test_exp_is_orthogonal_and_matches_quaternion(trial):
    rng = np.random.default_rng(trial)
    for scale in (1e-9, 1e-3, 0.09, 0.11, 1.0, 3.0, 20.0):
        th = _rand_rot(rng, scale)
        R = rt.expm(th)
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-14)
        assert abs(np.linalg.det(R) - 1) < 1e-14
        np.testing.assert_allclose(rt.quat_to_matrix(rt.quat_exp(th)), R, atol=1e-14)
        # the axis is invariant, skew part consistent with the angle
        np.testing.assert_allclose(R @ th, th, atol=1e-14 * max(1, scale))


def test_exp_log_round_trip_through_many_turns():
    rng = np.random.default_rng(7)
    for k in range(200):
        axis = rng.standard_normal(3)
        axis /= np.linalg.norm(axis)
        ang = rng.uniform(-60 * math.pi, 60 * math.pi)          # up to 30 full turns
        th = ang * axis
        R = rt.expm(th)
        lg = rt.logm(R)
        assert np.linalg.norm(lg) <= math.pi + 1e-12
        np.testing.assert_allclose(rt.expm(lg), R, atol=1e-13)
        # reduced angle equals the input angle modulo 2π along ±axis
        red = math.remainder(ang, 2 * math.pi)
        np.testing.assert_allclose(lg, red * axis, atol=1e-11) if abs(abs(red) - math.pi) > 1e-6 else None
        np.testing.assert_allclose(rt.quat_log(rt.quat_exp(th)), lg, atol=1e-11)
    # small and near-π angles
    for ang in (0.0, 1e-12, 1e-6, 1e-4, 0.3, math.pi - 1e-9, math.pi):
        th = ang * np.array([0.6, 0.0, 0.8])
        np.testing.assert_allclose(rt.expm(rt.logm(rt.expm(th))), rt.expm(th), atol=1e-14)
        if ang < math.pi - 1e-6:
            np.testing.assert_allclose(rt.logm(rt.expm(th)), th, atol=1e-14)


def test_quaternion_product_matches_matrices_and_norm_is_kept():
    rng = np.random.default_rng(3)
    p = rt.quat_exp(rng.standard_normal(3))
    x = np.concatenate((rng.standard_normal(3), p))
    for k in range(100000):
        x = rt.frame_compose(x, 0.7 * rng.standard_normal(6))
    assert abs(np.linalg.norm(x[3:]) - 1) < 4e-16
    a, b = rt.quat_exp(rng.standard_normal(3)), rt.quat_exp(rng.standard_normal(3))
    np.testing.assert_allclose(rt.quat_to_matrix(rt.quat_mul(a, b)),
                               rt.quat_to_matrix(a) @ rt.quat_to_matrix(b), atol=1e-14)
    np.testing.assert_allclose(rt.quat_mul(a, rt.quat_conj(a)), [1, 0, 0, 0], atol=1e-15)
    R = rt.quat_to_matrix(a)
    q = rt.matrix_to_quat(R)
    np.testing.assert_allclose(q, a if a[0] >= 0 else -a, atol=1e-14)
    for th in (np.array([math.pi, 0, 0]), np.array([0, 3.1, 0]), np.array([0, 0, -3.0])):
        np.testing.assert_allclose(rt.quat_to_matrix(rt.matrix_to_quat(rt.expm(th))), rt.expm(th), atol=1e-14)


@pytest.mark.parametrize("scale", [1e-3, 0.05, 0.5, 2.0, 5.0])
def test_tangent_operator_against_finite_differences(scale):
    rng = np.random.default_rng(int(scale * 1000))
    for trial in range(4):
        th = scale * rng.standard_normal(3)
        T = rt.tangent(th)
        E = rt.expm(th)
        eps = 1e-6
        J = np.zeros((3, 3))
        for j in range(3):
            d = np.zeros(3)
            d[j] = eps
            W = E.T @ (rt.expm(th + d) - rt.expm(th - d)) / (2 * eps)   # = (T e_j)~
            J[:, j] = rt.vee(W)
        np.testing.assert_allclose(T, J, atol=2e-9)
        # identities: T(−θ) = Tᵀ = exp(θ) T(θ), T θ = θ, T⁻¹ T = I
        np.testing.assert_allclose(rt.tangent(-th), T.T, atol=1e-15)
        np.testing.assert_allclose(E @ T, T.T, atol=1e-14)
        np.testing.assert_allclose(T @ th, th, atol=1e-14 * max(1, scale))
        np.testing.assert_allclose(rt.tangent_inv(th) @ T, np.eye(3), atol=1e-12)


def test_frame_group_operations():
    rng = np.random.default_rng(5)
    x = np.concatenate((rng.standard_normal(3), rt.quat_exp(rng.standard_normal(3))))
    d = rng.standard_normal(6)
    y = rt.frame_compose(x, d)
    np.testing.assert_allclose(y[:3], x[:3] + d[:3])
    np.testing.assert_allclose(rt.quat_to_matrix(y[3:]), rt.quat_to_matrix(x[3:]) @ rt.expm(d[3:]), atol=1e-14)
    T = rt.frame_tangent(d)
    np.testing.assert_allclose(T[:3, :3], np.eye(3))
    np.testing.assert_allclose(T[3:, 3:], rt.tangent(d[3:]))
    v, w = rng.standard_normal(6), rng.standard_normal(6)
    np.testing.assert_allclose(rt.frame_bracket(v, w)[3:], np.cross(v[3:], w[3:]))
    np.testing.assert_allclose(rt.skew(v[:3]) @ w[:3], np.cross(v[:3], w[:3]))
