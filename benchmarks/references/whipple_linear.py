"""The canonical linearized Whipple bicycle: M q̈ + v C₁ q̇ + (g K₀ + v² K₂) q = f, q = (φ, δ).

An independent reference for the bicycle built from femb's spatial bodies and rolling discs
(:mod:`femb.benchmarks.scenes.spatial.whipple_bicycle`): the closed-form coefficient matrices of Meijaard,
Papadopoulos, Ruina & Schwab, "Linearized dynamics equations for the balance and steer of a
bicycle: a benchmark and review", Proc. R. Soc. A 463 (2007) 1955–1982, Appendix A
(eqs. A1–A27), written from the paper for any parameter set. Coordinates as in the paper:
x forward, y to the right, z down, origin at the rear contact point; lean φ about x, steer δ
about the steer axis (downward), λ the steer-axis tilt from the vertical.
"""
from __future__ import annotations

import numpy as np

#: Table 1 of Meijaard et al. (2007): the benchmark bicycle
BENCHMARK = dict(w=1.02, c=0.08, lam=np.pi / 10.0, g=9.81,
                 rR=0.3, mR=2.0, IRxx=0.0603, IRyy=0.12,
                 xB=0.3, zB=-0.9, mB=85.0, IBxx=9.2, IByy=11.0, IBzz=2.8, IBxz=2.4,
                 xH=0.9, zH=-0.7, mH=4.0, IHxx=0.05892, IHyy=0.06, IHzz=0.00708, IHxz=-0.00756,
                 rF=0.35, mF=3.0, IFxx=0.1405, IFyy=0.28)


def canonical_matrices(p=None):
    """(M, C₁, K₀, K₂), each (2, 2), from the parameters ``p`` (keys of :data:`BENCHMARK`)."""
    p = dict(BENCHMARK if p is None else p)
    w, c, lam = p["w"], p["c"], p["lam"]
    rR, mR, rF, mF = p["rR"], p["mR"], p["rF"], p["mF"]
    xB, zB, mB, xH, zH, mH = p["xB"], p["zB"], p["mB"], p["xH"], p["zH"], p["mH"]
    sl, cl = np.sin(lam), np.cos(lam)
    mT = mR + mB + mH + mF                                                       # (A1)
    xT = (xB * mB + xH * mH + w * mF) / mT                                       # (A2)
    zT = (-rR * mR + zB * mB + zH * mH - rF * mF) / mT                           # (A3)
    ITxx = (p["IRxx"] + p["IBxx"] + p["IHxx"] + p["IFxx"] + mR * rR ** 2 + mB * zB ** 2
            + mH * zH ** 2 + mF * rF ** 2)                                       # (A4)
    ITxz = p["IBxz"] + p["IHxz"] - mB * xB * zB - mH * xH * zH + mF * w * rF     # (A5)
    IRzz, IFzz = p["IRxx"], p["IFxx"]                                            # (A6)
    ITzz = IRzz + p["IBzz"] + p["IHzz"] + IFzz + mB * xB ** 2 + mH * xH ** 2 + mF * w ** 2   # (A7)
    mA = mH + mF                                                                 # (A8)
    xA = (xH * mH + w * mF) / mA                                                 # (A9)
    zA = (zH * mH - rF * mF) / mA
    IAxx = p["IHxx"] + p["IFxx"] + mH * (zH - zA) ** 2 + mF * (rF + zA) ** 2     # (A10)
    IAxz = p["IHxz"] - mH * (xH - xA) * (zH - zA) + mF * (w - xA) * (rF + zA)
    IAzz = p["IHzz"] + IFzz + mH * (xH - xA) ** 2 + mF * (w - xA) ** 2
    uA = (xA - w - c) * cl - zA * sl                                             # (A11)
    IAll = mA * uA ** 2 + IAxx * sl ** 2 + 2.0 * IAxz * sl * cl + IAzz * cl ** 2  # (A12)
    IAlx = -mA * uA * zA + IAxx * sl + IAxz * cl
    IAlz = mA * uA * xA + IAxz * sl + IAzz * cl
    mu = c / w * cl                                                              # (A13)
    SR, SF = p["IRyy"] / rR, p["IFyy"] / rF                                      # (A14)
    ST = SR + SF
    SA = mA * uA + mu * mT * xT                                                  # (A15)
    M = np.array([[ITxx, IAlx + mu * ITxz],
                  [IAlx + mu * ITxz, IAll + 2.0 * mu * IAlz + mu ** 2 * ITzz]])  # (A16)
    K0 = np.array([[mT * zT, -SA], [-SA, -SA * sl]])                             # (A17)
    K2 = np.array([[0.0, (ST - mT * zT) / w * cl],
                   [0.0, (SA + SF * sl) / w * cl]])                              # (A18)
    C1 = np.array([[0.0, mu * ST + SF * cl + ITxz / w * cl - mu * mT * zT],
                   [-(mu * ST + SF * cl), IAlz / w * cl + mu * (SA + ITzz / w * cl)]])   # (A19)
    return M, C1, K0, K2


def state_matrix(v, p=None):
    """A (4, 4) of x = (φ, δ, φ̇, δ̇) at forward speed ``v`` (m/s)."""
    p = dict(BENCHMARK if p is None else p)
    M, C1, K0, K2 = canonical_matrices(p)
    Mi = np.linalg.inv(M)
    return np.block([[np.zeros((2, 2)), np.eye(2)],
                     [-Mi @ (p["g"] * K0 + v * v * K2), -Mi @ (v * C1)]])


def eigenvalues(v, p=None):
    """The four eigenvalues at speed ``v``, sorted by real part."""
    ev = np.linalg.eigvals(state_matrix(v, p))
    return ev[np.lexsort((ev.imag, ev.real))]
