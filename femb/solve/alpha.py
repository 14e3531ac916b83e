"""Generalized-α method parameters (α_m, α_f, β, γ) and their conditions.

References
----------
J. Chung, G. M. Hulbert, A time integration algorithm for structural dynamics
with improved numerical dissipation: the generalized-α method, J. Appl. Mech.
60 (1993) 371–375.

M. Arnold, O. Brüls, Convergence of the generalized-α scheme for constrained
mechanical systems, Multibody Syst. Dyn. 18 (2007) 185–202.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from femb.errors import ParameterError, ParameterWarning


@dataclass(frozen=True)
class GeneralizedAlpha:
    """The four parameters of the generalized-α scheme.

    Attributes
    ----------
    alpha_m, alpha_f, beta, gamma : float
        Method parameters in the convention of Arnold & Brüls (2007), eq. (3):
        (1 − α_m) a_{n+1} + α_m a_n = (1 − α_f) q̈_{n+1} + α_f q̈_n.
    rho_inf : float or None
        Spectral radius at infinity when built by :meth:`from_rho_inf`.
    """

    alpha_m: float
    alpha_f: float
    beta: float
    gamma: float
    rho_inf: float | None = None

    @classmethod
    def from_rho_inf(cls, rho_inf=0.7):
        """Chung & Hulbert (1993) parameters for a spectral radius at infinity.

        α_m = (2ρ∞ − 1)/(ρ∞ + 1), α_f = ρ∞/(ρ∞ + 1), γ = 1/2 + α_f − α_m,
        β = (γ + 1/2)²/4 (method.md eq. 9).

        Parameters
        ----------
        rho_inf : float in [0, 1]
        """
        try:
            r = float(rho_inf)
        except (TypeError, ValueError):
            raise ParameterError(f"rho_inf must be a number in [0, 1], got {rho_inf!r}") from None
        if not (0.0 <= r <= 1.0) or not math.isfinite(r):
            raise ParameterError(f"rho_inf must lie in [0, 1], got {rho_inf!r}")
        am = (2.0 * r - 1.0) / (r + 1.0)
        af = r / (r + 1.0)
        g = 0.5 + af - am
        b = 0.25 * (g + 0.5) ** 2
        return cls(am, af, b, g, r)

    @classmethod
    def from_values(cls, alpha_m, alpha_f, beta, gamma, *, warn=True):
        """Parameters given directly (Newmark: α_m = α_f = 0; HHT: α_m = 0; WBZ: α_f = 0).

        Raises :class:`ParameterError` for non-finite values or α_f = 1 or
        α_m = 1 (the scheme is undefined), and warns
        (:class:`ParameterWarning`) for each violated condition of
        :meth:`conditions`.
        """
        vals = {"alpha_m": alpha_m, "alpha_f": alpha_f, "beta": beta, "gamma": gamma}
        for k, v in vals.items():
            try:
                vals[k] = float(v)
            except (TypeError, ValueError):
                raise ParameterError(f"{k} must be a number, got {v!r}") from None
            if not math.isfinite(vals[k]):
                raise ParameterError(f"{k} must be finite, got {v!r}")
        if vals["alpha_m"] == 1.0 or vals["alpha_f"] == 1.0:
            raise ParameterError("alpha_m and alpha_f must differ from 1 (division by 1 - alpha)")
        if vals["beta"] <= 0.0:
            raise ParameterError(f"beta must be positive for the implicit scheme, got {vals['beta']}")
        p = cls(**vals)
        if warn:
            p.check(warn=True)
        return p

    def conditions(self):
        """The order and stability conditions of method.md §3.

        Returns
        -------
        dict of str to bool
            ``second_order``: γ = 1/2 + α_f − α_m;
            ``zero_stable``: α_m ≤ 1/2;
            ``stable_at_infinity``: α_m < α_f < 1/2 and β > (1/2 + α_f − α_m)/2
            (strict stability at infinity, needed for convergence of λ).
        """
        am, af, b, g = self.alpha_m, self.alpha_f, self.beta, self.gamma
        tol = 1e-14
        return {
            "second_order": abs(g - (0.5 + af - am)) <= tol,
            "zero_stable": am <= 0.5 + tol,
            "stable_at_infinity": (am < af < 0.5) and (b > 0.5 * (0.5 + af - am)),
        }

    def check(self, warn=True):
        """Warn (ParameterWarning) for each violated condition; return the failing names."""
        failed = [k for k, ok in self.conditions().items() if not ok]
        if warn:
            for k in failed:
                msg = {
                    "second_order": "gamma != 1/2 + alpha_f - alpha_m: the scheme is only first order",
                    "zero_stable": "alpha_m > 1/2: the scheme is not zero-stable",
                    "stable_at_infinity": (
                        "not strictly stable at infinity (need alpha_m < alpha_f < 1/2 and "
                        "beta > (1/2 + alpha_f - alpha_m)/2): Lagrange multipliers may oscillate "
                        "and need not converge (Arnold & Brüls 2007, Sect. 4)"),
                }[k]
                warnings.warn(f"generalized-alpha {self.as_tuple()}: {msg}", ParameterWarning, stacklevel=3)
        return failed

    def as_tuple(self):
        return (self.alpha_m, self.alpha_f, self.beta, self.gamma)

    def newton_factors(self, h):
        """β' = (1 − α_m)/(h² β (1 − α_f)) and γ' = γ/(h β) (method.md eq. 6)."""
        bp = (1.0 - self.alpha_m) / (h * h * self.beta * (1.0 - self.alpha_f))
        gp = self.gamma / (h * self.beta)
        return bp, gp

    def amplification_matrix(self, omega_h, xi=0.0):
        """Amplification matrix of the scheme on q̈ + 2ξω q̇ + ω² q = 0.

        With the state X_n = (q_n, h q̇_n, h² q̈_n, h² a_n), the returned
        matrix A gives X_{n+1} = A X_n; its spectral radius tends to ρ∞ as
        ωh → ∞ (slowly: the eigenvalue there is triple, so the error decays
        like (ωh)^(-2/3)).

        Parameters
        ----------
        omega_h : float
            ω h (may be large, e.g. 1e8, for the limit).
        xi : float
            Damping ratio.
        """
        am, af, b, g = self.as_tuple()
        w2 = omega_h ** 2
        c = 2.0 * xi * omega_h
        # unknowns at n+1: u = (q, v, A, a) with v = h q̇, A = h² q̈, a = h² a
        # equations:
        # q1 - b a1 = q0 + v0 + (1/2 - b) a0
        # v1 - g a1 = v0 + (1 - g) a0
        # (1-am) a1 - (1-af) A1 = af A0 - am a0
        # A1 + c v1 + w2 q1 = 0
        L = np.array([
            [1.0, 0.0, 0.0, -b],
            [0.0, 1.0, 0.0, -g],
            [0.0, 0.0, -(1.0 - af), 1.0 - am],
            [w2, c, 1.0, 0.0],
        ])
        R = np.array([
            [1.0, 1.0, 0.0, 0.5 - b],
            [0.0, 1.0, 0.0, 1.0 - g],
            [0.0, 0.0, af, -am],
            [0.0, 0.0, 0.0, 0.0],
        ])
        return np.linalg.solve(L, R)

    def spectral_radius(self, omega_h, xi=0.0):
        """Largest eigenvalue modulus of :meth:`amplification_matrix`."""
        return float(np.max(np.abs(np.linalg.eigvals(self.amplification_matrix(omega_h, xi)))))
