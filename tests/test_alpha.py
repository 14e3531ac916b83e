"""Generalized-α parameters: identities, conditions, spectral radius (method.md §3)."""
import warnings

import numpy as np
import pytest

from femb import GeneralizedAlpha, ParameterError, ParameterWarning


@pytest.mark.parametrize("rho", [0.0, 0.5, 0.7, 0.9, 1.0])
def test_chung_hulbert_identities(rho):
    p = GeneralizedAlpha.from_rho_inf(rho)
    # Chung & Hulbert (1993), eq. (9) of method.md
    assert p.alpha_m == pytest.approx((2 * rho - 1) / (rho + 1), abs=1e-15)
    assert p.alpha_f == pytest.approx(rho / (rho + 1), abs=1e-15)
    assert p.gamma == pytest.approx(0.5 + p.alpha_f - p.alpha_m, abs=1e-15)
    assert p.beta == pytest.approx(0.25 * (p.gamma + 0.5) ** 2, abs=1e-15)
    c = p.conditions()
    assert c["second_order"] and c["zero_stable"]
    # strictly stable at infinity for rho < 1 only
    assert c["stable_at_infinity"] == (rho < 1.0)


@pytest.mark.parametrize("rho", [0.0, 0.5, 0.7, 0.9, 1.0])
def test_spectral_radius_at_infinity_equals_rho(rho):
    p = GeneralizedAlpha.from_rho_inf(rho)
    # the eigenvalue at infinity is triple, so convergence in omega*h is slow
    assert p.spectral_radius(1e12) == pytest.approx(rho, abs=1e-5)
    # and the scheme is accurate at low frequency
    assert p.spectral_radius(1e-3) == pytest.approx(1.0, abs=1e-6)


@pytest.mark.parametrize("rho", [0.0, 0.5, 0.7, 0.9, 1.0])
def test_unconditionally_stable(rho):
    p = GeneralizedAlpha.from_rho_inf(rho)
    for wh in np.logspace(-2, 6, 40):
        assert p.spectral_radius(wh) <= 1.0 + 1e-9


@pytest.mark.parametrize("rho", [-0.1, 1.5, float("nan"), "a"])
def test_rho_out_of_range(rho):
    with pytest.raises(ParameterError, match="rho_inf"):
        GeneralizedAlpha.from_rho_inf(rho)


def test_direct_values_warn_when_conditions_fail():
    # Newmark trapezoidal rule: second order, but not strictly stable at infinity
    with pytest.warns(ParameterWarning, match="not strictly stable"):
        GeneralizedAlpha.from_values(0.0, 0.0, 0.25, 0.5)
    # first-order gamma
    with pytest.warns(ParameterWarning, match="first order"):
        GeneralizedAlpha.from_values(0.0, 0.2, 0.4, 0.6)
    # alpha_m > 1/2: not zero-stable (and, with alpha_f < alpha_m, not stable at infinity)
    with pytest.warns(ParameterWarning) as rec:
        GeneralizedAlpha.from_values(0.6, 0.55, 0.3, 0.45)
    msgs = " | ".join(str(w.message) for w in rec)
    assert "zero-stable" in msgs and "not strictly stable" in msgs
    # a valid HHT set gives no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        a = 0.1
        GeneralizedAlpha.from_values(0.0, a, 0.25 * (1 + a) ** 2, 0.5 + a)


def test_direct_values_errors():
    with pytest.raises(ParameterError, match="alpha_f"):
        GeneralizedAlpha.from_values(0.0, 1.0, 0.25, 0.5)
    with pytest.raises(ParameterError, match="beta"):
        GeneralizedAlpha.from_values(0.0, 0.1, 0.0, 0.6)
    with pytest.raises(ParameterError, match="gamma"):
        GeneralizedAlpha.from_values(0.0, 0.1, 0.3, float("inf"))


def test_newton_factors():
    p = GeneralizedAlpha.from_rho_inf(0.7)
    h = 1e-3
    bp, gp = p.newton_factors(h)
    assert bp == pytest.approx((1 - p.alpha_m) / (h * h * p.beta * (1 - p.alpha_f)))
    assert gp == pytest.approx(p.gamma / (h * p.beta))
