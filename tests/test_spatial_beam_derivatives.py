"""Analytic derivatives of the SE(3) operators of the beam (elements/spatial_beam.py):
dsfun against central differences of sfun, and the 3 × 3 block forms of the derivatives of
T_SE3⁻¹ a (_e_blocks) and T_SE3⁻ᵀ a (_g_blocks) against central differences of tinv_se3 /
tinvt_se3, on both sides of the series switch φ² = 0.01."""
import numpy as np
import pytest

from femb.elements import spatial_beam as sb


@pytest.mark.parametrize("x", [1e-6, 0.005, 0.0098, 0.02, 0.3, 2.0, 9.0])
def test_dsfun_matches_differences(x):
    h = min(1e-3, x / 4)        # closed forms cancel at small φ: a step large against their round-off
    fd = (np.array(sb.sfun(x + h)) - np.array(sb.sfun(x - h))) / (2 * h)
    an = np.array(sb.dsfun(x))
    assert np.abs(an - fd).max() <= 1e-6 * np.abs(fd).max()


I9 = sb.I9


def _blocks(U, W, aU, aW, transpose):
    """The 6 × 6 derivative along d = (U, Ω) from the kernel's block forms (side B, identity rotations)."""
    x = float(W @ W)
    s, ds = sb.sfun(x), sb.dsfun(x)
    U, W = tuple(U), tuple(W)
    M, N = sb._tinv_mat(W, s[2]), sb._tuw_mat(U, W, s)
    buf = np.zeros(sb.NSCRATCH)
    if not transpose:
        sb._e_blocks(U, W, s, ds, M, N, (aU, aW), buf, True)
        return buf[144:180].reshape(6, 6).T            # E[m, k] at 144 + 6k + m
    tr = lambda A: (A[0], A[3], A[6], A[1], A[4], A[7], A[2], A[5], A[8])   # noqa: E731
    b = np.array(tr(M)) .reshape(3, 3) @ np.array(aU)
    r = np.array(aW) - np.array(tr(N)).reshape(3, 3) @ b
    Da = sb._dtinvt_pair(W, s[2], ds[2], aU)[0]
    sb._g_blocks(U, W, s, ds, M, N, tuple(b), tuple(r), Da, I9, I9, True, buf, 6)
    return buf[72 + 36:72 + 72].reshape(6, 6)          # rows 6 … 11 of Z, 6 columns


@pytest.mark.parametrize("scale", [1e-3, 0.05, 0.8, 2.5])
@pytest.mark.parametrize("transpose", [False, True])
def test_tangent_operator_derivatives(scale, transpose):
    rng = np.random.default_rng(3)
    U, W = rng.standard_normal(3), scale * rng.standard_normal(3)
    aU, aW = tuple(rng.standard_normal(3)), tuple(rng.standard_normal(3))
    f = sb.tinvt_se3 if transpose else sb.tinv_se3

    def ev(U_, W_):
        r = f(tuple(U_), tuple(W_), sb.sfun(float(W_ @ W_)), aU, aW)
        return np.concatenate(r)

    an = _blocks(U, W, aU, aW, transpose)
    for k in range(6):
        d = np.zeros(6)
        d[k] = 1.0
        h = 1e-6
        fd = (ev(U + h * d[:3], W + h * d[3:]) - ev(U - h * d[:3], W - h * d[3:])) / (2 * h)
        assert np.abs(an[:, k] - fd).max() <= 1e-7 * max(1.0, np.abs(fd).max()), (k, an[:, k], fd)
