"""Rigid multibody equations in generalized coordinates for the spatial references.

Independent of femb's engine (plain numpy/scipy): a reference model gives its
kinematics q ↦ (centre of mass c_k, rotation R_k) of every body as ordinary
formulas; derivatives are exact to round-off through **hyper-dual numbers**
(Fike & Alonso 2011): evaluating the formulas at q + ε1 e_j + ε2 u (ε1² = ε2² = 0)
gives ∂c/∂q_j in the ε1 part and ∂²c/∂q_j∂q·u = d/dt (∂c/∂q_j) in the ε1ε2 part.

With the Jacobians c_k = J_c,k u, ω_k = J_ω,k u (ω in space axes,
J_ω,k e_j = vee(∂R_k/∂q_j R_kᵀ)), the equations of motion are Kane's (projected
Newton–Euler):

    M u̇ = Q − h,   M = Σ m J_cᵀJ_c + J_ωᵀ I J_ω,   I = R J Rᵀ,
    h = Σ m J_cᵀ J̇_c u + J_ωᵀ (I J̇_ω u + ω × I ω),   Q = Σ m J_cᵀ g,

and, with closure constraints Φ(q) = 0 (possibly redundant),
[M Gᵀ; G 0][u̇; μ] = [Q − h; −Ġu] solved in the least-squares sense (u̇ is
unique; μ is not when G is rank deficient).

References
----------
R. A. Fike, J. J. Alonso, The development of hyper-dual numbers for exact
second-derivative calculations, AIAA 2011-886, 2011.
T. R. Kane, D. A. Levinson, Dynamics: Theory and Applications, McGraw-Hill, 1985.
"""
from __future__ import annotations

import math

import numpy as np


class HD:
    """Hyper-dual number a + b ε1 + c ε2 + d ε1ε2 (ε1² = ε2² = 0, ε1ε2 ≠ 0)."""

    __slots__ = ("a", "b", "c", "d")

    def __init__(self, a, b=0.0, c=0.0, d=0.0):
        self.a, self.b, self.c, self.d = float(a), float(b), float(c), float(d)

    @staticmethod
    def lift(x):
        return x if isinstance(x, HD) else HD(x)

    def __add__(self, o):
        if isinstance(o, HD):
            return HD(self.a + o.a, self.b + o.b, self.c + o.c, self.d + o.d)
        return HD(self.a + o, self.b, self.c, self.d)

    __radd__ = __add__

    def __neg__(self):
        return HD(-self.a, -self.b, -self.c, -self.d)

    def __sub__(self, o):
        return self + (-o)

    def __rsub__(self, o):
        return (-self) + o

    def __mul__(self, o):
        if isinstance(o, HD):
            return HD(self.a * o.a, self.a * o.b + self.b * o.a, self.a * o.c + self.c * o.a,
                      self.a * o.d + self.b * o.c + self.c * o.b + self.d * o.a)
        return HD(self.a * o, self.b * o, self.c * o, self.d * o)

    __rmul__ = __mul__

    def _f(self, f0, f1, f2):
        return HD(f0, f1 * self.b, f1 * self.c, f1 * self.d + f2 * self.b * self.c)

    def inv(self):
        x = self.a
        return self._f(1.0 / x, -1.0 / (x * x), 2.0 / (x * x * x))

    def __truediv__(self, o):
        return self * (o.inv() if isinstance(o, HD) else 1.0 / o)

    def __rtruediv__(self, o):
        return self.inv() * o

    def __pow__(self, n):
        x = self.a
        return self._f(x ** n, n * x ** (n - 1), n * (n - 1) * x ** (n - 2))

    def sqrt(self):
        s = math.sqrt(self.a)
        return self._f(s, 0.5 / s, -0.25 / (s * self.a))

    def sin(self):
        return self._f(math.sin(self.a), math.cos(self.a), -math.sin(self.a))

    def cos(self):
        return self._f(math.cos(self.a), -math.sin(self.a), -math.cos(self.a))

    def arccos(self):
        x = self.a
        r = 1.0 - x * x
        return self._f(math.acos(x), -1.0 / math.sqrt(r), -x / (r * math.sqrt(r)))

    def __repr__(self):
        return f"HD({self.a}, {self.b}, {self.c}, {self.d})"


def _part(x, k):
    return getattr(x, "abcd"[k]) if isinstance(x, HD) else (float(x) if k == 0 else 0.0)


def part(arr, k):
    """Part k (0 value, 1 ε1, 2 ε2, 3 ε1ε2) of an array of HD (or floats) as float array."""
    arr = np.asarray(arr, dtype=object)
    return np.vectorize(lambda x: _part(x, k), otypes=[float])(arr)


def sin(x):
    return x.sin() if isinstance(x, HD) else math.sin(x)


def cos(x):
    return x.cos() if isinstance(x, HD) else math.cos(x)


def sqrt(x):
    return x.sqrt() if isinstance(x, HD) else math.sqrt(x)


def arccos(x):
    return x.arccos() if isinstance(x, HD) else math.acos(x)


def atan2(y, x):
    """atan2 with hyper-dual arguments (exact first and second derivatives)."""
    if not isinstance(y, HD) and not isinstance(x, HD):
        return math.atan2(y, x)
    y, x = HD.lift(y), HD.lift(x)
    X, Y = x.a, y.a
    r2 = X * X + Y * Y
    ty, tx = X / r2, -Y / r2
    tyy, txx, txy = -2 * X * Y / r2 ** 2, 2 * X * Y / r2 ** 2, (Y * Y - X * X) / r2 ** 2
    return HD(math.atan2(Y, X), ty * y.b + tx * x.b, ty * y.c + tx * x.c,
              ty * y.d + tx * x.d + tyy * y.b * y.c + txy * (y.b * x.c + x.b * y.c) + txx * x.b * x.c)


def cross(a, b):
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]],
                    dtype=object)


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def normalize(a):
    return a / sqrt(dot(a, a))


def rodrigues(axis, angle):
    """exp(angle axis~) for a unit axis (floats) and a (hyper-dual) angle, object (3, 3)."""
    n = np.asarray(axis, dtype=float)
    K = np.array([[0, -n[2], n[1]], [n[2], 0, -n[0]], [-n[1], n[0], 0]], dtype=float)
    K2 = K @ K
    s, c = sin(angle), cos(angle)
    R = np.empty((3, 3), dtype=object)
    for i in range(3):
        for j in range(3):
            R[i, j] = (1.0 if i == j else 0.0) + s * K[i, j] + (1 - c) * K2[i, j]
    return R


def matmul(A, B):
    A = np.asarray(A, dtype=object)
    B = np.asarray(B, dtype=object)
    return A.dot(B)


def vee(S):
    return np.array([0.5 * (S[2, 1] - S[1, 2]), 0.5 * (S[0, 2] - S[2, 0]), 0.5 * (S[1, 0] - S[0, 1])])


class RigidSystem:
    """Bodies in generalized coordinates; see the module docstring.

    Parameters
    ----------
    kinematics : callable q (object array of HD, (n,)) -> list of (c (3,), R (3, 3))
        Centre of mass and rotation (body to space) of every body.
    masses : sequence of float
    inertias : sequence of (3, 3)
        Inertia tensors about the centres of mass, body axes.
    g : (3,)
        Gravity.
    closure : callable q -> (m,) object array, optional
        Constraints Φ(q) = 0 (redundant rows allowed).
    """

    def __init__(self, kinematics, masses, inertias, g, closure=None):
        self.kin = kinematics
        self.m = [float(m) for m in masses]
        self.J = [np.asarray(J, dtype=float) for J in inertias]
        self.g = np.asarray(g, dtype=float)
        self.closure = closure

    def _eval(self, q, u):
        n = q.size
        cols = []
        for j in range(n):
            qq = np.array([HD(q[i], 1.0 if i == j else 0.0, u[i], 0.0) for i in range(n)], dtype=object)
            cols.append((self.kin(qq), self.closure(qq) if self.closure else None))
        return cols

    def state(self, q, u):
        """Body quantities at (q, u): dict with c, R, cd, omega, Jc, Jw, Jc_dot_u, Jw_dot_u, M, h, Q."""
        q = np.asarray(q, dtype=float)
        u = np.asarray(u, dtype=float)
        n = q.size
        cols = self._eval(q, u)
        nb = len(cols[0][0])
        out = {"c": [], "R": [], "cd": [], "omega": [], "Jc": [], "Jw": [], "acc_c": [], "acc_w": []}
        M = np.zeros((n, n))
        h = np.zeros(n)
        Q = np.zeros(n)
        for k in range(nb):
            c = part(cols[0][0][k][0], 0)
            R = part(cols[0][0][k][1], 0)
            Rd = part(cols[0][0][k][1], 2)
            cd = part(cols[0][0][k][0], 2)
            Jc = np.column_stack([part(cols[j][0][k][0], 1) for j in range(n)])
            Jcd_u = sum(part(cols[j][0][k][0], 3) * u[j] for j in range(n))
            Rj = [part(cols[j][0][k][1], 1) for j in range(n)]
            Rjd = [part(cols[j][0][k][1], 3) for j in range(n)]
            Jw = np.column_stack([_vee(Rj[j] @ R.T) for j in range(n)])
            Jwd_u = sum(_vee(Rjd[j] @ R.T + Rj[j] @ Rd.T) * u[j] for j in range(n))
            w = _vee(Rd @ R.T)
            I = R @ self.J[k] @ R.T
            M += self.m[k] * Jc.T @ Jc + Jw.T @ I @ Jw
            h += self.m[k] * Jc.T @ Jcd_u + Jw.T @ (I @ Jwd_u + np.cross(w, I @ w))
            Q += self.m[k] * Jc.T @ self.g
            for key, val in (("c", c), ("R", R), ("cd", cd), ("omega", w), ("Jc", Jc), ("Jw", Jw),
                             ("acc_c", Jcd_u), ("acc_w", Jwd_u)):
                out[key].append(val)
        out.update(M=M, h=h, Q=Q)
        if self.closure is not None:
            G = np.column_stack([part(cols[j][1], 1) for j in range(n)])
            Gd_u = sum(part(cols[j][1], 3) * u[j] for j in range(n))
            out.update(Phi=part(cols[0][1], 0), G=G, Gd_u=Gd_u)
        return out

    def accelerations(self, q, u):
        """u̇ and the body quantities at (q, u)."""
        s = self.state(q, u)
        rhs = s["Q"] - s["h"]
        if self.closure is None:
            ud = np.linalg.solve(s["M"], rhs)
        else:
            n, m = s["M"].shape[0], s["G"].shape[0]
            K = np.block([[s["M"], s["G"].T], [s["G"], np.zeros((m, m))]])
            sol = np.linalg.lstsq(K, np.concatenate((rhs, -s["Gd_u"])), rcond=1e-12)[0]
            ud = sol[:n]
        return ud, s

    def rhs(self, t, y):
        n = y.size // 2
        ud, _ = self.accelerations(y[:n], y[n:])
        return np.concatenate((y[n:], ud))

    def energy(self, q, u):
        """Kinetic plus gravitational potential energy."""
        s = self.state(q, u)
        T = 0.5 * u @ s["M"] @ u
        V = -sum(self.m[k] * self.g @ s["c"][k] for k in range(len(self.m)))
        return T + V


def _vee(S):
    return np.array([0.5 * (S[2, 1] - S[1, 2]), 0.5 * (S[0, 2] - S[2, 0]), 0.5 * (S[1, 0] - S[0, 1])])
