"""Functions of time with their first two derivatives.

Loads and rheonomic (driven) constraints take a :class:`TimeFunction`; the
derivatives enter Φ_t and Φ_tt in the consistent initialization and keep the
driven constraints exact in the solver.
"""
from __future__ import annotations

import math

import numpy as np

from femb.errors import ModelError


class TimeFunction:
    """f(t) with f'(t) and f''(t).

    Parameters
    ----------
    f, df, ddf : callable float -> float
        The function and its first and second derivatives.
    name : str, optional
    """

    def __init__(self, f, df, ddf, name="function"):
        for what, g in (("f", f), ("df", df), ("ddf", ddf)):
            if not callable(g):
                raise ModelError(f"time function '{name}': {what} must be callable, got {g!r}")
        self.f, self.df, self.ddf, self.name = f, df, ddf, name

    def __call__(self, t):
        return self.f(t)

    def compiled(self):
        """(kind, coefficients) for evaluation inside compiled code, or None (Python)."""
        return None

    def __repr__(self):
        return f"TimeFunction({self.name})"


class Constant(TimeFunction):
    """f(t) = c."""

    def __init__(self, c):
        c = float(c)
        self.c = c
        super().__init__(lambda t: c, lambda t: 0.0, lambda t: 0.0, f"constant {c}")

    def compiled(self):
        return 1, [self.c]


class Polynomial(TimeFunction):
    """f(t) = Σ c_k t^k (coefficients from the constant term up)."""

    def __init__(self, coefficients):
        c = np.asarray(coefficients, dtype=float)
        if c.ndim != 1 or c.size == 0 or not np.all(np.isfinite(c)):
            raise ModelError(f"Polynomial: coefficients must be finite numbers, got {coefficients!r}")
        p = np.polynomial.Polynomial(c)
        dp, ddp = p.deriv(1), p.deriv(2)
        self.coefficients = c.copy()
        super().__init__(lambda t: float(p(t)), lambda t: float(dp(t)), lambda t: float(ddp(t)),
                         f"polynomial {c.tolist()}")

    def compiled(self):
        return 1, list(self.coefficients)


def Linear(rate, offset=0.0):
    """f(t) = offset + rate t."""
    return Polynomial([offset, rate])


class Harmonic(TimeFunction):
    """f(t) = offset + amplitude sin(omega t + phase)."""

    def __init__(self, amplitude, omega, phase=0.0, offset=0.0):
        A, w, ph, o = map(float, (amplitude, omega, phase, offset))
        self.coefficients = (A, w, ph, o)
        super().__init__(lambda t: o + A * math.sin(w * t + ph),
                         lambda t: A * w * math.cos(w * t + ph),
                         lambda t: -A * w * w * math.sin(w * t + ph),
                         f"harmonic A={A} w={w}")

    def compiled(self):
        return 2, list(self.coefficients)


def as_time_function(value, owner, what):
    """Accept a number (constant), a TimeFunction, or a (f, df, ddf) triple."""
    if isinstance(value, TimeFunction):
        return value
    if isinstance(value, (tuple, list)) and len(value) == 3 and all(callable(g) for g in value):
        return TimeFunction(*value, name=f"{owner} {what}")
    if callable(value):
        raise ModelError(
            f"{owner}: {what} is a bare callable; give a TimeFunction or a (f, df, ddf) triple "
            "so that its derivatives are known")
    try:
        c = float(value)
    except (TypeError, ValueError):
        raise ModelError(f"{owner}: {what} must be a number or a TimeFunction, got {value!r}") from None
    if not math.isfinite(c):
        raise ModelError(f"{owner}: {what} must be finite, got {value!r}")
    return Constant(c)


def evaluate(functions, t, order=0):
    """Evaluate a list of TimeFunctions at t: derivative ``order`` 0, 1 or 2 -> (n,)."""
    if order == 0:
        return np.array([fn.f(t) for fn in functions], dtype=float)
    if order == 1:
        return np.array([fn.df(t) for fn in functions], dtype=float)
    return np.array([fn.ddf(t) for fn in functions], dtype=float)
