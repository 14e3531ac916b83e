"""Analytic derivatives of the SE(3) operators of the beam (elements/spatial_beam.py):
dsfun against central differences of sfun, dtinv_se3 / dtinvt_se3 against central
differences of tinv_se3 / tinvt_se3, on both sides of the series switch φ² = 0.01."""
import numpy as np
import pytest

from femb.elements import spatial_beam as sb


@pytest.mark.parametrize("x", [1e-6, 0.005, 0.0098, 0.02, 0.3, 2.0, 9.0])
def test_dsfun_matches_differences(x):
    h = min(1e-3, x / 4)        # closed forms cancel at small φ: a step large against their round-off
    fd = (np.array(sb.sfun(x + h)) - np.array(sb.sfun(x - h))) / (2 * h)
    an = np.array(sb.dsfun(x))
    assert np.abs(an - fd).max() <= 1e-6 * np.abs(fd).max()


@pytest.mark.parametrize("scale", [1e-3, 0.05, 0.8, 2.5])
@pytest.mark.parametrize("transpose", [False, True])
def test_tangent_operator_derivatives(scale, transpose):
    rng = np.random.default_rng(3)
    U, W = rng.standard_normal(3), scale * rng.standard_normal(3)
    aU, aW = tuple(rng.standard_normal(3)), tuple(rng.standard_normal(3))
    f = sb.tinvt_se3 if transpose else sb.tinv_se3
    df = sb.dtinvt_se3 if transpose else sb.dtinv_se3

    def ev(U_, W_):
        r = f(tuple(U_), tuple(W_), sb.sfun(float(W_ @ W_)), aU, aW)
        return np.concatenate(r)

    for k in range(6):
        d = np.zeros(6)
        d[k] = 1.0
        h = 1e-6
        fd = (ev(U + h * d[:3], W + h * d[3:]) - ev(U - h * d[:3], W - h * d[3:])) / (2 * h)
        an = np.concatenate(df(tuple(U), tuple(W), sb.sfun(float(W @ W)), sb.dsfun(float(W @ W)), aU, aW,
                               tuple(d[:3]), tuple(d[3:])))
        assert np.abs(an - fd).max() <= 1e-7 * max(1.0, np.abs(fd).max())
