"""Static equilibrium: a globalized Newton method on the constrained equilibrium equations.

With q̇ = q̈ = 0 the equations of motion (method.md eq. 1–2) reduce to

    r(q, λ; μ) = −f_int(q) − μ f_ext(q) + Φ_q(q, t)ᵀ λ = 0,     Φ(q, t) = 0,

where the force vector f of the model is split into *applied loads* f_ext,
scaled by the load factor μ, and the rest f_int (elastic and spring forces of
beams, springs, ...), which is not. A load level is solved by Newton's method on

    [ K_t(μ)  Φ_qᵀ ] [Δq]     [r]
    [ Φ_q     0    ] [Δλ] = − [Φ],    K_t(μ) = −∂f_int/∂q − μ ∂f_ext/∂q + ∂(Φ_qᵀλ)/∂q,

the iteration matrix of the dynamic solver (method.md eq. 7) without its mass
and damping terms, assembled by the user-level functions of
:mod:`femb.system.assembly` (:func:`~femb.system.assembly.force_vector`,
:func:`~femb.system.assembly.tangent_stiffness`, :func:`~femb.system.assembly.constraint_jacobian`, …).

Strategy (default)
------------------
1. **Direct**: solve at full load (μ = 1) from the given configuration. The
   multipliers start at the least-squares reactions to the loads there, so the
   constraint (geometric) stiffness ∂(Φ_qᵀλ)/∂q is present from the first
   iteration. Newton first takes full steps (the fastest route when it
   converges: a residual-decrease test would reject the good full steps of
   stiff geometrically nonlinear beams), shortened only where they would move
   a coordinate by more than the length scale L (a rotation by more than
   1 rad); where K_t is singular it takes the least regularized step
   (K_t + ν K_d, below) within that radius. If full steps fail, the level
   is solved again from its start with Newton globalized by a backtracking line search on the merit
   function ½‖D R‖² (R = [r; Φ], D scales forces by the force scale and
   lengths by the length scale; the Newton direction is a descent direction of
   it for any such D), and, where the tangent is singular or the line search
   fails, by Levenberg–Marquardt steps (K_t + ν K_d) with a growing ν (the
   trust-region idea of Moré 1978; Nocedal & Wright 2006, Ch. 4 and 11). A
   configuration where a spring is slack or a pendulum carries no load yet has
   a singular tangent: such a step moves along the loads until the stiffness
   appears, where starting at zero load cannot move at all.
   An equilibrium reached this way is checked for stability
   (:func:`stability`); an unstable one sends the solver on to 2.
   A system with several *stable* equilibria (a slender beam under a large
   load can also hold a looped shape) may land on another one than gradual
   loading reaches: ask for ``load_steps`` to follow the loading path.
2. **Continuation** (only if the direct attempt fails, or when asked through
   ``load_steps`` / ``load_factors``): load stepping from μ = 0 with bisection
   of failed increments (Crisfield 1991, Ch. 9), each level solved as in 1.

3. **Arc length** (``method="arc_length"``): the load factor becomes an unknown
   and the path is followed in steps of prescribed length (pseudo-arc-length
   continuation with a bordered Newton corrector, Keller 1977, Riks 1979;
   adaptive step length as Crisfield 1981), through limit points and
   snap-backs where load stepping must fail (see :func:`solve_static`).

The route taken is reported in :attr:`StaticResult.path`.

Applied loads are, by default, the constant forces of the model (constant
torques and gravity) and every :class:`~femb.elements.Force` and
:class:`~femb.elements.Torque`; rheonomic constraints are frozen at the time ``t``.

References
----------
M. A. Crisfield, Non-linear Finite Element Analysis of Solids and
Structures, Vol. 1, Wiley, 1991, Ch. 9 (incremental–iterative solution).

M. A. Crisfield, A fast incremental/iterative solution procedure that handles
"snap-through", Computers & Structures 13 (1981) 55–62 (arc length, step-length
adaptation (I_d/I)^½).

E. Riks, An incremental approach to the solution of snapping and buckling
problems, Int. J. Solids Struct. 15 (1979) 529–551.

H. B. Keller, Numerical solution of bifurcation and nonlinear eigenvalue
problems, in: P. H. Rabinowitz (ed.), Applications of Bifurcation Theory,
Academic Press, 1977, 359–384 (pseudo-arc-length continuation, bordered system).

E. L. Allgower, K. Georg, Numerical Continuation Methods, Springer, 1990,
Ch. 2 (tangent orientation, predictor–corrector).

M. Géradin, A. Cardona, Flexible Multibody Dynamics, Wiley, 2001, Ch. 10
(static equilibrium of constrained flexible systems).

J. J. Moré, The Levenberg–Marquardt algorithm: implementation and theory,
Lecture Notes in Mathematics 630, Springer, 1978, 105–116.

J. Nocedal, S. J. Wright, Numerical Optimization, 2nd ed., Springer, 2006
(line search and trust-region globalization of Newton's method).
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field, fields, replace
from typing import Any, Callable, Sequence

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from femb.errors import ConvergenceError, ParameterError, PathJumpWarning, SingularMatrixError
from femb.results.result import Result
from femb.system import assembly, kernels
from femb.system.initial import refuse_contacts
from femb.system.model import Model, State

#: saddle-point systems with at most this many unknowns are solved with dense LU
DENSE_LIMIT = 400


@dataclass(repr=False)
class StaticResult(Result):
    """Converged load levels of :func:`solve_static` (a :class:`~femb.results.result.Result`).

    ``t`` holds the **load factors** μ of the stored equilibria (also available
    as :attr:`load_factor`); ``qd`` and ``qdd`` are zero; ``newton_iterations``
    counts the iterations of every stored level. Named access (``body``,
    ``position``, ``reaction``) works as for a simulation.

    Attributes
    ----------
    time : float
        Time at which loads and rheonomic constraints were evaluated.
    strategy : str
        ``"direct"`` (full load at once), ``"continuation"`` (the direct
        attempt failed, load stepping found it), ``"load steps"`` (asked for) or
        ``"arc length"`` (``method="arc_length"``).
    path : list of dict
        Every Newton solve attempted, in order, converged or not: ``mu`` (load
        factor), ``start`` (``"given"``, ``"previous"`` or ``"secant"``),
        ``newton`` (``"full steps"``, or ``"globalized"`` for the retry with
        line search / Levenberg–Marquardt after full steps failed),
        ``converged`` (bool), ``iterations``, ``residuals`` (list of
        (‖r‖∞ in N with moments / L, ‖Φ‖∞ in m) per iterate), ``damped``
        (iterations that needed a shortened or regularized step) and
        ``reason`` (why it failed, or ""); the direct attempt also has
        ``stability`` (see :func:`stability`). Arc-length steps have ``start``
        ``"tangent"``, ``newton`` ``"arc length"`` and ``arc_length`` (Δs); ``mu``
        is the load factor of their last iterate.
    arc : dict or None
        With ``method="arc_length"``, per stored state (nt,): ``"s"`` the path
        parameter (sum of the step lengths in the arc-length norm, 0 at the
        start) and ``"dmu_ds"`` the load-factor component t_μ of the unit tangent
        there (NaN where not computed); None otherwise.
    """

    time: float = 0.0
    strategy: str = "direct"
    path: list = field(default_factory=list)
    arc: dict = None

    @property
    def load_factor(self):
        return self.t

    @property
    def state(self):
        """The last converged equilibrium as a :class:`~femb.system.model.State` (at time ``time``)."""
        nv = self.model.nq          # velocities: nq (rotation nodes store 7 coordinates, move with 6)
        return State(self.time, self.q[-1].copy(), np.zeros(nv), np.zeros(nv), self.lam[-1].copy())

    def limit_points(self):
        """Indices k of the stored states where the load factor has a local extremum (int array).

        On a path followed by arc length (``strategy == "arc length"``): the stored
        points nearest the limit points, where μ turns from increasing to decreasing
        or back (μ_k − μ_{k−1} and μ_{k+1} − μ_k of opposite signs).
        """
        mu = np.asarray(self.t, dtype=float)
        if len(mu) < 3:
            return np.zeros(0, dtype=int)
        d = np.diff(mu)
        return np.nonzero(d[:-1] * d[1:] < 0.0)[0] + 1

    def limit_load_factors(self):
        """Load factors at the limit points of an arc-length path, refined between stored points (nl,).

        Where the tangent's t_μ = dμ/ds changes sign between stored points k and
        k + 1, μ(s) is interpolated by the cubic Hermite polynomial through
        (s, μ, dμ/ds) at both points and its extremum returned (error O(Δs⁴) for a
        smooth path). Needs ``arc`` (``method="arc_length"``); empty if the path
        has no limit point.
        """
        if self.arc is None:
            raise ParameterError("limit_load_factors needs a path followed by method='arc_length'")
        s, d, mu = np.asarray(self.arc["s"]), np.asarray(self.arc["dmu_ds"]), np.asarray(self.t, dtype=float)
        out = []
        for k in range(len(s) - 1):
            if not (np.isfinite(d[k]) and np.isfinite(d[k + 1]) and d[k] * d[k + 1] < 0.0):
                continue
            h = s[k + 1] - s[k]
            # μ(s_k + x h) = h00 μ_k + h10 h d_k + h01 μ_k+1 + h11 h d_k+1 (x in [0, 1]); μ' = 0 is quadratic in x
            a0, a1, b0, b1 = mu[k], mu[k + 1], h * d[k], h * d[k + 1]
            c2 = 3.0 * (2.0 * a0 + b0 - 2.0 * a1 + b1)          # coefficients of dμ/dx = c2 x² + c1 x + c0
            c1 = 2.0 * (-3.0 * a0 - 2.0 * b0 + 3.0 * a1 - b1)
            c0 = b0
            roots = np.roots([c2, c1, c0]) if abs(c2) > 0.0 else np.array([-c0 / c1])
            roots = [r.real for r in np.atleast_1d(roots) if abs(r.imag) < 1e-12 and -1e-9 <= r.real <= 1 + 1e-9]
            if not roots:
                continue
            x = roots[0]
            out.append((2 * x**3 - 3 * x**2 + 1) * a0 + (x**3 - 2 * x**2 + x) * b0
                       + (-2 * x**3 + 3 * x**2) * a1 + (x**3 - x**2) * b1)
        return np.array(out)

    def _summary(self):
        """(title, rows) for ``repr`` and ``_repr_html_`` (see :class:`~femb.results.result.Result`)."""
        from femb.base.summary import short_list

        mu = np.asarray(self.t, dtype=float)
        solves = len(self.path)
        failed = sum(1 for p in self.path if not p.get("converged"))
        outs = self.outputs()
        owners, n_out = list(dict.fromkeys(n.partition(".")[0] for n in outs)), len(outs)
        rows = [("status", self.status + (f": {self.message}" if self.message and not self.success else "")),
                ("strategy", f"{self.strategy}, {solves} Newton solve(s), {failed} failed (describe_path())"),
                ("load factors", (f"{mu[0]:.6g} … {mu[-1]:.6g} ({mu.size} equilibria stored)" if mu.size
                                  else "none stored")),
                ("time", f"loads evaluated at t = {self.time:.6g} s"),
                ("arrays", f"q {tuple(self.q.shape)}, lam {tuple(self.lam.shape)}"),
                ("outputs", f"{n_out} of " + short_list(owners, 6) + " (series(name))")]
        return f"femb StaticResult of '{self.model.name}'", rows

    def describe_path(self):
        """The route to the equilibrium as text, one line per Newton solve."""
        lines = [f"static solution ({self.strategy}):"]
        for p in self.path:
            r, phi = p["residuals"][-1] if p["residuals"] else (float("nan"), float("nan"))
            lines.append(f"  mu = {p['mu']:<10.6g} from {p['start']:<8s} {p['newton']:<10s} {'converged' if p['converged'] else 'FAILED':9s} "
                         f"in {p['iterations']:2d} iterations ({p['damped']} damped), "
                         f"|r| = {r:.3e} N, |Phi| = {phi:.3e} m"
                         + (f", arc length {p['arc_length']:.3g}" if "arc_length" in p else "")
                         + (f"  [{p['reason']}]" if p["reason"] else ""))
        return "\n".join(lines)


def _load_groups(model, load_types):
    """The batches of applied loads: by default those whose element type declares
    ``work = "load"`` (docs/kernels.md), else those of the given types."""
    if load_types is None:
        return [g for g in model.force_groups if getattr(g.cls, "work", None) == "load"]
    load_types = tuple(load_types)
    return [g for g in model.force_groups if issubclass(g.cls, load_types)]


def _external(model, groups, t, q, jac):
    """Applied loads f_ext(q) (nq,) and, when ``jac``, ∂f_ext/∂q (csr).

    The only place that evaluates element force kernels per type (to split
    the applied loads from the internal forces); needed for load stepping only.
    """
    nq, next_ = model.nq, model.nq + model.nfix
    qx = model.ext(q)
    qdx = np.zeros(next_)
    f = model.f_const.copy()
    rows, cols, vals = [], [], []
    for g in groups:
        fe, fq, _ = kernels.force(g, t, qx[g.xdofs], qdx[g.dofs], jac)
        f += np.bincount(g.dofs.ravel(), fe.ravel(), minlength=next_)[:nq]
        if jac:
            rows.append(g.nn_rows)
            cols.append(g.nn_cols)
            vals.append(fq.reshape(-1)[g.nn_sel])
    if model.g_hat is not None and not model.constant_mass:
        f += assembly.mass_matrix(model, q) @ model.g_hat[:nq]
    if not jac:
        return f, None
    if rows:
        Fq = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                           shape=(nq, nq))
    else:
        Fq = sp.csr_matrix((nq, nq))
    return f, Fq


def _saddle_csc(K, B, b=None, c=None, d=0.0):
    """[[K, Bᵀ], [B, 0]], bordered by the column b and the row [cᵀ, 0, d] when b is given, as one CSC matrix.

    Put together from the blocks' COO entries in one step (duplicates summed): scipy.sparse's
    block and diagonal products cost several times the LU at the sizes of beam models.

    Returns
    -------
    A : scipy.sparse.csc_matrix, shape (N, N)
        N = nq + nc (+ 1 with the border).
    cols : ndarray of int, shape (nnz,)
        The column of each stored entry of ``A`` (``A.indices`` holds the rows).
    """
    nq, nc = K.shape[0], B.shape[0]
    Kc, Bc = sp.coo_matrix(K), sp.coo_matrix(B)
    rows, cols, vals = [Kc.row, Bc.col, nq + Bc.row], [Kc.col, nq + Bc.row, Bc.col], [Kc.data, Bc.data, Bc.data]
    N = nq + nc
    if b is not None:
        N += 1
        b, c = np.asarray(b, dtype=float).ravel(), np.asarray(c, dtype=float).ravel()
        ib, ic = np.flatnonzero(b), np.flatnonzero(c)
        dv = [float(d)] if d != 0.0 else []
        rows += [ib, np.full(ic.size, N - 1), [N - 1] * len(dv)]
        cols += [np.full(ib.size, N - 1), ic, [N - 1] * len(dv)]
        vals += [b[ib], c[ic], dv]
    A = sp.csc_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(N, N))
    A.sum_duplicates()
    return A, np.repeat(np.arange(N), np.diff(A.indptr))


def _row_max(A, cols=None):
    """Largest |entry| of every row of a CSC matrix (of every column with ``cols``)."""
    out = np.zeros(A.shape[0])
    np.maximum.at(out, A.indices if cols is None else cols, np.abs(A.data))
    return out


def _solve(K, B, rhs):
    """Solve [[K, Bᵀ], [B, 0]] x = rhs; None when the matrix is singular.

    The matrix is first equilibrated symmetrically, D A D with D = 1/√(row max),
    so that stiff and soft coordinates, forces and constraint rows are
    compared on one scale; a pivot below 1e-15 of the largest (a few machine
    epsilons, the level of exact singularity after cancellation) or a
    non-finite solution is taken as singular. Legitimately ill-conditioned
    structures (EA L²/EI up to 1e12) pass.
    """
    A, cols = _saddle_csc(K, B)
    N = A.shape[0]
    rmax = _row_max(A)
    if np.any(rmax == 0.0) or not np.all(np.isfinite(rmax)):
        return None
    D = 1.0 / np.sqrt(rmax)
    As = sp.csc_matrix((D[A.indices] * A.data * D[cols], A.indices, A.indptr), shape=(N, N))
    b = D * rhs
    if N <= DENSE_LIMIT:
        lu, piv, info = sla.lapack.dgetrf(As.toarray())
        d = np.abs(np.diag(lu))
        if info > 0 or not np.all(np.isfinite(d)) or d.min() <= 1e-15 * d.max():
            return None
        y = sla.lu_solve((lu, piv), b)
    else:
        try:
            lu = spla.splu(As)
        except RuntimeError:
            return None
        d = np.abs(lu.U.diagonal())
        if not np.all(np.isfinite(d)) or d.min() <= 1e-15 * d.max():
            return None
        y = lu.solve(b)
    x = D * y
    return x if np.all(np.isfinite(x)) else None


def _solve_bordered(K, B, b, c, d, rhs):
    """Solve the bordered system [[K, Bᵀ, b], [B, 0, 0], [cᵀ, 0, d]] x = rhs; None when singular.

    The matrix of arc-length continuation: the saddle-point matrix of :func:`_solve`
    with one more unknown (the load factor) and one more equation (the arc-length
    condition). It is not symmetric, so it is equilibrated by rows and then by
    columns (each scaled by the inverse of its largest entry) before the LU
    factorization (sparse LU at every size; the blocks are put together and scaled as
    arrays of one COO/CSC matrix: scipy.sparse's block and diagonal products cost
    several times the LU at the beams' sizes); the singularity test is that of
    :func:`_solve` (a pivot below 1e-15 of the largest). At a limit point K is singular but this matrix is not
    (Keller 1977; Allgower & Georg 1990, Ch. 2).
    """
    A, cols = _saddle_csc(K, B, b, c, d)
    N = A.shape[0]
    rmax = _row_max(A)
    if np.any(rmax == 0.0) or not np.all(np.isfinite(rmax)):
        return None
    r_inv = 1.0 / rmax
    data = A.data * r_inv[A.indices]
    cmax = np.zeros(N)
    np.maximum.at(cmax, cols, np.abs(data))
    if np.any(cmax == 0.0):
        return None
    c_inv = 1.0 / cmax
    As = sp.csc_matrix((data * c_inv[cols], A.indices, A.indptr), shape=(N, N))
    bs = r_inv * rhs
    try:                                   # sparse LU at every size: the beams' matrices are banded
        lu = spla.splu(As)
    except RuntimeError:
        return None
    dg = np.abs(lu.U.diagonal())
    if not np.all(np.isfinite(dg)) or dg.min() <= 1e-15 * dg.max():
        return None
    x = c_inv * lu.solve(bs)
    return x if np.all(np.isfinite(x)) else None


def _active(model):
    act = getattr(model, "active_constraints", None)
    return np.ones(model.nc, dtype=bool) if act is None else np.asarray(act, dtype=bool)


def equilibrium_residual(model, q, lam, mu=1.0, t=0.0, load_types=None):
    """(r, Φ) of the static equations at load factor ``mu`` (shapes (nq,), (nc,))."""
    q = np.asarray(q, dtype=float)
    f = assembly.force_vector(model, t, q, np.zeros(model.nq))
    if mu != 1.0:
        fe, _ = _external(model, _load_groups(model, load_types), t, q, False)
        f = f - (1.0 - mu) * fe
    r = -f + assembly.constraint_force(model, t, q, lam)
    return r, assembly.constraint_vector(model, t, q)


class _Newton:
    """Globalized Newton for one load level (line search, then Levenberg–Marquardt)."""

    def __init__(self, model, t, groups, rtol, atol, tol_phi, xtol, max_iter):
        self.model, self.t, self.groups = model, t, groups
        self.rtol, self.atol, self.tol_phi, self.xtol, self.max_iter = rtol, atol, tol_phi, xtol, max_iter
        self.act = _active(model)
        self.nq = model.nq
        self.w = model.force_weight                       # moments → forces (1/L on rotation rows)
        self.zero = np.zeros(model.nq)

    # ---------------------------------------------------------------- pieces
    def residual(self, mu, q, lam):
        m, t = self.model, self.t
        f = assembly.force_vector(m, t, q, self.zero)
        fe = _external(m, self.groups, t, q, False)[0] if mu != 1.0 else None
        f_loaded = f if fe is None else f - (1.0 - mu) * fe
        cf = assembly.constraint_force(m, t, q, lam)
        r = -f_loaded + cf
        Phi = assembly.constraint_vector(m, t, q)[self.act]
        F = max(np.abs(f * self.w).max(initial=0.0), np.abs(cf * self.w).max(initial=0.0))
        if fe is not None:
            F = max(F, np.abs((f - fe) * self.w).max(initial=0.0), abs(mu) * np.abs(fe * self.w).max(initial=0.0))
        return r, Phi, F

    def matrix(self, mu, q, lam):
        m, t = self.model, self.t
        K = assembly.tangent_stiffness(m, State(t, q, self.zero, self.zero, lam))
        if mu != 1.0:
            K = K + (1.0 - mu) * _external(m, self.groups, t, q, True)[1]
        B = assembly.constraint_jacobian(m, t, q).tocsr()[np.nonzero(self.act)[0]]
        return K.tocsr(), B

    def multiplier_guess(self, mu, q, lam):
        """λ minimizing ‖−f + Φ_qᵀλ‖ at q: the reactions to the current loads.

        Starts Newton with the constraint (geometric) stiffness ∂(Φ_qᵀλ)/∂q
        of the load level, without which a mechanism held only by its loads
        (a hanging pendulum) has a singular tangent.
        """
        m, t = self.model, self.t
        if not m.nc:
            return lam
        f = assembly.force_vector(m, t, q, self.zero)
        if mu != 1.0:
            f = f - (1.0 - mu) * _external(m, self.groups, t, q, False)[0]
        B = assembly.constraint_jacobian(m, t, q).tocsr()[np.nonzero(self.act)[0]].tocsc()
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                guess = spla.spsolve((B @ B.T).tocsc(), B @ f)
        except Exception:          # dependent rows: keep the given λ
            return lam
        guess = np.atleast_1d(guess)
        if not np.all(np.isfinite(guess)):
            return lam
        out = np.zeros(m.nc)
        out[self.act] = guess
        return out

    # ---------------------------------------------------------------- solve
    def __call__(self, mu, q, lam, start):
        """Full Newton steps first; if that fails, again from the start with globalization.

        Returns ((q, λ) or None, list of record dicts, singular flag of the last matrix).
        """
        sol, rec, singular = self.run(mu, q, lam, start, False)
        if sol is not None:
            return sol, [rec], singular
        sol2, rec2, singular = self.run(mu, q, lam, start, True)
        return sol2, [rec, rec2], singular

    def run(self, mu, q, lam, start, globalize):
        """One Newton solve: full steps (regularized only where K_t is singular) or globalized."""
        L = self.model.length_scale
        q = q.copy()
        lam = self.multiplier_guess(mu, q, lam.copy())
        rec = {"mu": float(mu), "start": start, "converged": False, "iterations": 0, "residuals": [],
               "damped": 0, "reason": "", "newton": "globalized" if globalize else "full steps"}
        last = None
        F_ref = 0.0
        singular = False
        for k in range(self.max_iter + 1):
            r, Phi, F = self.residual(mu, q, lam)
            F_ref = max(F_ref, F)
            err_r = np.abs(r * self.w).max(initial=0.0)
            err_phi = np.abs(Phi).max(initial=0.0)
            rec["residuals"].append((float(err_r), float(err_phi)))
            rec["iterations"] = k
            if not (math.isfinite(err_r) and math.isfinite(err_phi)):
                rec["reason"] = "non-finite residual"
                return None, rec, singular
            if err_r <= self.rtol * F + self.atol and err_phi <= self.tol_phi:
                rec["converged"] = True
                return (q, lam), rec, False
            if last is not None and last <= self.xtol * L and err_phi <= self.tol_phi:
                rec["converged"] = True           # increment at the round-off level
                return (q, lam), rec, False
            if k == self.max_iter:
                rec["reason"] = f"|r| = {err_r:.3e} N, |Phi| = {err_phi:.3e} m after {k} iterations"
                return None, rec, singular
            # merit ½‖D R‖², D = diag(W / F_s, 1 / L)
            Fs = max(F_ref, self.atol, 1e-300)
            scale_r = self.w / Fs

            def merit(r_, P_):
                return 0.5 * (np.sum((r_ * scale_r) ** 2) + np.sum((P_ / L) ** 2))

            m0 = merit(r, Phi)
            K, B = self.matrix(mu, q, lam)
            rhs = -np.concatenate((r, Phi))
            x = _solve(K, B, rhs)
            singular = x is None
            if not globalize:
                step = self._limited(*self._split(x)) if x is not None else \
                    self._levenberg_marquardt(mu, q, lam, K, B, rhs, m0, None)
            else:
                step = self._line_search(mu, q, lam, x, m0, merit) if x is not None else None
            if step is None:
                step = self._levenberg_marquardt(mu, q, lam, K, B, rhs, m0, merit if globalize else None)
                if step is None:
                    rec["reason"] = ("singular tangent and no regularized step reduces the residual"
                                     if singular else "no step along the Newton or regularized direction "
                                     "reduces the residual")
                    return None, rec, singular
            dq, dlam, damped = step
            rec["damped"] += int(damped)
            q = self.model.compose(q, dq)          # q ∘ exp(Δq) on rotation nodes, q + Δq otherwise
            lam = lam + dlam
            last = np.abs(dq).max(initial=0.0)
        return None, rec, singular

    def _limited(self, dq, dl):
        """A full step, shortened to the trust radius: no coordinate moves more than L (rotations 1 rad)."""
        big = np.abs(dq / self.w).max(initial=0.0) / self.model.length_scale
        if big > 1.0:
            return dq / big, dl / big, True
        return dq, dl, False

    def _split(self, x):
        dl = np.zeros(self.model.nc)
        dl[self.act] = x[self.nq:]
        return x[:self.nq], dl

    def _line_search(self, mu, q, lam, x, m0, merit, min_alpha=2.0 ** -12):
        """Backtracking (Armijo, c = 1e-4) along the Newton direction; None if it fails."""
        dq, dl = self._split(x)
        alpha = 1.0
        while alpha >= min_alpha:
            r, Phi, _ = self.residual(mu, self.model.compose(q, alpha * dq), lam + alpha * dl)
            mt = merit(r, Phi)
            if np.isfinite(mt) and mt <= (1.0 - 2e-4 * alpha) * m0:
                return alpha * dq, alpha * dl, alpha < 1.0
            if m0 <= 1e-28:                       # already at round-off: take the full step
                return dq, dl, False
            alpha *= 0.5
        return None

    def _levenberg_marquardt(self, mu, q, lam, K, B, rhs, m0, merit):
        """Steps with K + ν K_d for growing ν; None if none reduces the merit.

        With ``merit`` None (full-step mode), the first solvable step that
        moves no coordinate by more than the length scale L (rotations: 1 rad)
        is returned: a trust radius, without which an almost singular K_t
        gives an enormous step.

        K_d = diag(1 for translations, L² for rotations) × κ, κ the largest
        diagonal stiffness in N/m (or the force scale over L if K is zero): a
        regularization in consistent units, small ν being a nearly full Newton
        step and large ν a short step along the (scaled) residual.
        """
        w = self.w
        kd = np.abs(K.diagonal()) * w * w
        kappa = kd.max(initial=0.0)
        if not kappa > 0.0:
            kappa = max(np.abs(rhs[:self.nq] * w).max(initial=0.0), 1e-300) / self.model.length_scale
        Kd = sp.diags(kappa / (w * w))
        nu = 1e-8
        while nu <= 1e8:
            x = _solve((K + nu * Kd).tocsr(), B, rhs)
            if x is not None:
                dq, dl = self._split(x)
                if merit is None:                 # full-step mode: the least regularized step within the
                    if np.abs(dq / w).max(initial=0.0) <= self.model.length_scale:   # trust radius L
                        return dq, dl, True
                    nu *= 10.0
                    continue
                r, Phi, _ = self.residual(mu, self.model.compose(q, dq), lam + dl)
                mt = merit(r, Phi)
                if np.isfinite(mt) and mt < m0:
                    return dq, dl, True
            nu *= 10.0
        return None


class _ArcLength:
    """Pseudo-arc-length continuation (bordered Newton) of the static equations.

    Unknowns (q, λ, μ). With the metric ⟨a, b⟩ = Σ s_i² a_i b_i + ψ² a_μ b_μ on
    (tangent increment, load factor) — s_i = 1/L on translations, 1 on rotations
    (rad) and other non-translational coordinates, L = model.length_scale; the
    multipliers are not in it — and t = (t_q, t_μ) the unit tangent of the path
    at the last equilibrium (q_n, μ_n), a step of length Δs solves

        r(q, λ, μ) = 0,  Φ(q) = 0,  ⟨t, (Δq, μ − μ_n)⟩ − Δs = 0,

    Δq the sum of the tangent increments of the step (the predictor Δs t_q and the
    corrections: q = q_n ∘ exp(predictor) ∘ exp(δq_1) ∘ …; on vector spaces
    Δq = q − q_n), by Newton's method on the bordered matrix

        [ K_t   Φ_qᵀ  −f_ext ] [δq]     [ r ]
        [ Φ_q   0      0     ] [δλ] = − [ Φ ]
        [ s²t_q 0      ψ²t_μ ] [δμ]     [ g ],

    regular at limit points where K_t is singular (the pseudo-arc-length method of
    Keller 1977; Riks 1979 constrains the step to the same normal plane). The
    tangent at a new equilibrium solves the same matrix with right side (0, 0, 1)
    and the previous tangent in the last row, so ⟨t_new, t_old⟩ > 0: the path keeps
    its direction through limit points (μ decreasing after a maximum) and snap-backs.
    """

    def __init__(self, model, newton, s2, psi2):
        self.model, self.newton, self.s2, self.psi2 = model, newton, s2, psi2
        self.nq = model.nq
        self.nact = int(np.count_nonzero(newton.act))

    def fext(self, q):
        n = self.newton
        return _external(self.model, n.groups, n.t, q, False)[0]

    def tangent(self, mu, q, lam, prev):
        """Unit tangent (t_q, t_λ, t_μ) at an equilibrium; ``prev`` the previous (t_q, t_μ) or None (dμ > 0)."""
        K, B = self.newton.matrix(mu, q, lam)
        fe = self.fext(q)
        if prev is None:
            c, d = np.zeros(self.nq), 1.0
        else:
            c, d = self.s2 * prev[0], self.psi2 * prev[1]
        rhs = np.zeros(self.nq + self.nact + 1)
        rhs[-1] = 1.0
        x = _solve_bordered(K, B, -fe, c, d, rhs)
        if x is None:
            return None
        v, nu = self.newton._split(x[:-1])
        tau = x[-1]
        return self.normalized(v, nu, tau)

    def norm(self, dq, dmu):
        return math.sqrt(float(np.sum(self.s2 * dq * dq)) + self.psi2 * dmu * dmu)

    def normalized(self, v, nu, tau):
        nrm = self.norm(v, tau)
        if not (nrm > 0.0 and math.isfinite(nrm)):
            return None
        return v / nrm, nu / nrm, tau / nrm

    def step(self, mu, q, lam, tan, ds, rec):
        """One arc-length step of length ``ds`` from the equilibrium (μ, q, λ) along ``tan``.

        Returns (μ, q, λ, Δq, Δμ) or None (``rec`` says why).
        """
        n, m = self.newton, self.model
        L = m.length_scale
        tq, tl, tmu = tan
        Dq, Dmu = ds * tq, ds * tmu
        qi, li, mui = m.compose(q, Dq), lam + ds * tl, mu + Dmu
        last = None
        for k in range(n.max_iter + 1):
            r, Phi, F = n.residual(mui, qi, li)
            g = float(np.sum(self.s2 * tq * Dq)) + self.psi2 * tmu * Dmu - ds
            err_r = np.abs(r * n.w).max(initial=0.0)
            err_phi = np.abs(Phi).max(initial=0.0)
            rec["residuals"].append((float(err_r), float(err_phi)))
            rec["iterations"] = k
            rec["mu"] = float(mui)
            if not (math.isfinite(err_r) and math.isfinite(err_phi) and math.isfinite(g)):
                rec["reason"] = "non-finite residual"
                return None
            arc_ok = abs(g) <= 1e-8 * ds
            if arc_ok and err_phi <= n.tol_phi and (err_r <= n.rtol * F + n.atol
                                                   or (last is not None and last <= n.xtol * L)):
                rec["converged"] = True
                return mui, qi, li, Dq, Dmu
            if k == n.max_iter:
                rec["reason"] = f"|r| = {err_r:.3e} N, |Phi| = {err_phi:.3e} m after {k} iterations"
                return None
            K, B = n.matrix(mui, qi, li)
            rhs = -np.concatenate((r, Phi, [g]))
            x = _solve_bordered(K, B, -self.fext(qi), self.s2 * tq, self.psi2 * tmu, rhs)
            if x is None:
                rec["reason"] = "singular bordered matrix (a bifurcation point, or no stiffness against a motion)"
                return None
            dq, dl = n._split(x[:-1])
            dmu = float(x[-1])
            qi = m.compose(qi, dq)
            li = li + dl
            mui = mui + dmu
            Dq = Dq + dq
            Dmu = Dmu + dmu
            last = np.abs(dq).max(initial=0.0)
            if self.norm(Dq, Dmu) > 3.0 * ds:
                rec["reason"] = (f"the corrector left the step (distance {self.norm(Dq, Dmu) / ds:.3g} arc "
                                 "lengths from the last equilibrium)")
                return None
        return None                                   # pragma: no cover


#: a secant-predicted load step whose Newton correction is this many times the predicted step
#: counts as a jump off the path (a smooth path: the correction is O(Δμ) smaller than the step)
JUMP_RATIO = 3.0


def _check_jump(model, q_prev, q_pred, q_new, mu_prev, mu_new):
    """Warn (:class:`PathJumpWarning`) when load stepping jumped: the converged state q_new is farther
    from the secant prediction q_pred than :data:`JUMP_RATIO` times the predicted step q_pred − q_prev
    (tangent vectors on the group, Euclidean norm; coordinates that did not move are left out)."""
    step = np.linalg.norm(model.difference(q_pred, q_prev))
    corr = np.linalg.norm(model.difference(q_new, q_pred))
    if corr > JUMP_RATIO * step and corr > 1e-9 * (model.length_scale + np.linalg.norm(q_prev)):
        warnings.warn(f"model '{model.name}': load stepping jumped between load factors {mu_prev:.6g} and "
                      f"{mu_new:.6g}: the converged state is {corr / max(step, 1e-300):.3g} predicted steps away "
                      "from the path's continuation (a limit point passed: snap-through). The states before "
                      "and after are not on one continuous path; solve_static(..., method=\"arc_length\") "
                      "follows it through the limit point", PathJumpWarning, stacklevel=4)


def stability(model, q, lam, t=0.0, max_size=1500):
    """Stability of an equilibrium: smallest eigenvalue of the reduced stiffness.

    Eigenvalues of Zᵀ ½(K_t + K_tᵀ) Z, with Z an orthonormal basis of the null
    space of the active rows of Φ_q (the admissible motions); positive
    definite means a strict local minimum of the potential energy for
    conservative loads (Géradin & Cardona 2001, Ch. 10). The sign test does
    not depend on units (Sylvester's law of inertia).

    Returns
    -------
    float or None
        The smallest eigenvalue divided by the largest magnitude (negative:
        unstable), or None when nq > ``max_size`` (not computed) or there is
        no admissible motion.
    """
    nq = model.nq
    if nq > max_size:
        return None
    z = np.zeros(nq)
    K = assembly.tangent_stiffness(model, State(t, np.asarray(q, float), z, z, np.asarray(lam, float))).toarray()
    act = _active(model)
    B = assembly.constraint_jacobian(model, t, q).toarray()[act]
    Z = sla.null_space(B) if B.shape[0] else np.eye(nq)
    if Z.shape[1] == 0:
        return None
    e = np.linalg.eigvalsh(Z.T @ (0.5 * (K + K.T)) @ Z)
    big = np.abs(e).max()
    return float(e.min() / big) if big > 0.0 else 0.0


_ARC_ONLY = ("arc_length", "arc_length_min", "arc_length_max", "load_weight", "max_steps", "max_limit_points")


@dataclass(frozen=True)
class StaticOptions:
    """The options of :func:`solve_static` (see there for each), validated by :meth:`create`.

    The fields hold the values as given (``settings`` of the result records them so);
    :func:`solve_static` accepts ``options=StaticOptions.create(...)``, keywords, or both
    (the keywords then change the given options).
    """

    load_steps: int | None = None
    load_factors: Sequence[float] | None = None
    t: float = 0.0
    load_types: tuple | None = None
    rtol: float = 1e-10
    atol: float = 0.0
    phi_tol: float = 1e-12
    xtol: float = 1e-12
    max_iter: int = 30
    min_step: float = 1e-4
    fallback_steps: int = 10
    predictor: str = "secant"
    method: str = "load_control"
    arc_length: float | None = None
    arc_length_min: float | None = None
    arc_length_max: float | None = None
    load_weight: float | None = None
    target_load_factor: float | None = 1.0
    max_steps: int | None = None
    max_limit_points: int | None = None
    desired_iterations: int = 6

    @classmethod
    def create(cls, options: StaticOptions | None = None, **changes: Any) -> StaticOptions:
        """Validated options: ``options`` (default: the defaults) with ``changes`` applied.

        Raises
        ------
        ParameterError
            An unknown option name, or a value out of its range (naming the option).
        """
        names = [f.name for f in fields(cls)]
        unknown = sorted(k for k in changes if k not in names)
        if unknown:
            raise ParameterError(f"solve_static: unknown option(s) {', '.join(unknown)}; the options are "
                                 f"{', '.join(names)}")
        if options is not None and not isinstance(options, StaticOptions):
            raise ParameterError(f"options must be a StaticOptions, got {type(options).__name__}")
        o = replace(options, **changes) if options is not None else cls(**changes)
        if o.method not in ("load_control", "arc_length"):
            raise ParameterError(f"method must be 'load_control' or 'arc_length', got {o.method!r}")
        if o.method == "arc_length":
            _check_arc_options(o)
        elif o.arc_given():
            raise ParameterError(f"{', '.join(o.arc_given())}: only for method='arc_length' (method is {o.method!r})")
        _check_load_control(o)
        return o

    def arc_given(self):
        """{name: value} of the arc-length-only options given (not None)."""
        return {k: getattr(self, k) for k in _ARC_ONLY if getattr(self, k) is not None}

    def targets(self):
        """The load levels μ of load control, in order (list of float)."""
        if self.load_factors is not None:
            return [float(x) for x in np.atleast_1d(self.load_factors)]
        if self.load_steps is not None:
            n = int(self.load_steps)
            return [k / n for k in range(1, n + 1)]
        return [1.0]

    def settings(self):
        """The ``settings`` dict of the result."""
        s = {k: getattr(self, k) for k in ("t", "rtol", "atol", "phi_tol", "xtol", "max_iter", "min_step",
                                            "predictor", "method")}
        if self.method == "arc_length":
            s.update({k: getattr(self, k) for k in _ARC_ONLY + ("target_load_factor", "desired_iterations")})
        return s


def _check_arc_options(o):
    """The options of ``method="arc_length"``."""
    if o.load_steps is not None or o.load_factors is not None:
        raise ParameterError("method='arc_length' chooses its own load factors: do not give load_steps "
                             "or load_factors")
    for k, v in o.arc_given().items():
        if k in ("max_steps", "max_limit_points"):
            if int(v) != v or int(v) < 1:
                raise ParameterError(f"{k} must be a positive integer, got {v!r}")
        elif k == "load_weight":
            if not (math.isfinite(float(v)) and float(v) >= 0.0):
                raise ParameterError(f"load_weight must be a finite number ≥ 0, got {v!r}")
        elif not (math.isfinite(float(v)) and float(v) > 0.0):
            raise ParameterError(f"{k} must be a positive finite number, got {v!r}")
    s, s_min, s_max = o.arc_length, o.arc_length_min, o.arc_length_max
    if s_min is not None and s_max is not None and s_min > s_max:
        raise ParameterError(f"arc_length_min ({s_min!r}) exceeds arc_length_max ({s_max!r})")
    if s is not None and ((s_min is not None and s < s_min) or (s_max is not None and s > s_max)):
        raise ParameterError(f"arc_length ({s!r}) is outside [arc_length_min, arc_length_max]")
    target = o.target_load_factor
    if target is not None and not math.isfinite(float(target)):
        raise ParameterError(f"target_load_factor must be a finite number or None, got {target!r}")
    if target is not None and float(target) == 0.0:
        raise ParameterError("target_load_factor must not be 0 (the path starts there); give None to "
                             "stop after max_steps")
    if int(o.desired_iterations) != o.desired_iterations or int(o.desired_iterations) < 1:
        raise ParameterError(f"desired_iterations must be a positive integer, got {o.desired_iterations!r}")


def _check_load_control(o):
    """load_steps, load_factors, fallback_steps and predictor."""
    if o.load_steps is not None and o.load_factors is not None:
        raise ParameterError("give either load_steps or load_factors, not both")
    if o.load_factors is not None:
        targets = o.targets()
        if not targets or not all(math.isfinite(x) for x in targets):
            raise ParameterError(f"load_factors must be finite numbers, got {o.load_factors!r}")
    elif o.load_steps is not None and int(o.load_steps) < 1:
        raise ParameterError(f"load_steps must be at least 1, got {o.load_steps!r}")
    if int(o.fallback_steps) < 1:
        raise ParameterError(f"fallback_steps must be at least 1, got {o.fallback_steps!r}")
    if o.predictor not in ("secant", "previous"):
        raise ParameterError(f"predictor must be 'secant' or 'previous', got {o.predictor!r}")


def solve_static(model: Model, *, state: State | None = None, observer: Callable[..., Any] | None = None,
                 options: StaticOptions | None = None, **kwargs: Any) -> StaticResult:
    """Static equilibrium: full load at once, load stepping, or arc-length continuation.

    ``method="load_control"`` (default): full load at once, load stepping when
    that fails or when asked (``load_steps``, ``load_factors``). It cannot pass a
    limit point (a maximum of the load along the path). ``method="arc_length"``
    follows the equilibrium path from μ = 0 with steps of prescribed length in
    (displacement, load factor) space, through limit points (snap-through) and
    snap-backs; see *Arc length* in the notes.

    Parameters
    ----------
    model : Model
    state : State, optional
        Starting configuration (default: the model's initial coordinates).
        Its multipliers are replaced by the least-squares reactions to the loads.
    observer : callable(mu, q, lam, iterations), optional
        Called after each converged level (each point of the path with arc length).
    options : StaticOptions, optional
        The options below at once (:meth:`StaticOptions.create`); keywords given as
        well change them. Every option is also a keyword of its own:
    load_steps : int, optional
        Ask for load stepping with this many equal increments from μ = 0 to 1.
        Default: none, solve at μ = 1 directly (see the module notes).
    load_factors : sequence of float, optional
        Ask for load stepping through these levels μ, in order (e.g.
        ``[0.5, 1.0, 2.0]``); the first is solved from the given configuration.
    t : float
        Time at which loads and (frozen) rheonomic constraints are evaluated.
    load_types : tuple of element classes, optional
        Force element types scaled by μ (default: the types that declare
        ``work = "load"``, e.g. Force, Torque, SpatialForce, SpatialTorque); the
        model's constant forces (constant torques, gravity) are always scaled.
    rtol, atol : float
        Force test ‖W r‖∞ ≤ rtol · F + atol, W dividing moment rows by the
        length scale L, F the largest of ‖W f_int‖∞, ‖W μ f_ext‖∞ and
        ‖W Φ_qᵀλ‖∞ at the iterate (N).
    phi_tol : float
        Constraint test ‖Φ‖∞ ≤ phi_tol · model.length_scale.
    xtol : float
        Also accept an iterate when the last Newton correction was below
        xtol · model.length_scale (in every coordinate, rotations in rad) and
        the constraint test holds: the force residual of very stiff sections
        (large EA) under tiny loads can stall at round-off above rtol · F.
    max_iter : int
        Newton iterations per load level before it counts as failed.
    min_step : float
        Smallest load increment tried before giving up.
    fallback_steps : int
        Initial number of increments of the continuation that follows a failed
        direct attempt (they are bisected further where needed).
    predictor : {"secant", "previous"}
        In load stepping, start each level from a linear extrapolation of the
        last two converged levels, or from the last one.
    method : {"load_control", "arc_length"}
        Load control (the load factor prescribed: direct solve or load stepping)
        or arc-length continuation (the load factor an unknown).
    arc_length : float, optional
        ``method="arc_length"`` only. Length Δs of the first step in the scaled
        norm ‖(Δq, Δμ)‖ = (Σ (s_i Δq_i)² + ψ² Δμ²)^½ (dimensionless): s_i = 1/L
        for translations, 1 for rotations (rad) and the other non-translational
        coordinates, L = ``model.length_scale`` (a rotation of 1 rad counts as a
        displacement by L, the convention of the Newton trust radius); Δq are the
        increments in tangent coordinates (rotations of frame nodes in body axes);
        the multipliers λ are not in the norm. Default: the length of the
        tangent step to the load factor ``0.05 · |target_load_factor|`` (0.05
        without a target).
    arc_length_min, arc_length_max : float, optional
        ``method="arc_length"`` only. Bounds of the adaptive arc length (default:
        ``arc_length / 1024`` and ``10 · arc_length``). A failed step is retried
        with half the arc length; below ``arc_length_min`` the continuation stops
        with :class:`~femb.errors.ConvergenceError`.
    load_weight : float, optional
        ``method="arc_length"`` only. ψ ≥ 0, the weight of the load factor in the
        norm (ψ = 0: the cylindrical arc length, displacements only; Crisfield
        1981). Default: the scaled norm of dq/dμ at the start, so that load and
        displacement contribute equally to the first step.
    target_load_factor : float or None
        ``method="arc_length"`` only. Stop when the path reaches this load factor
        (crossing it in either direction after the start; the last point is then
        solved at exactly this load factor); None: stop after ``max_steps``.
    max_steps : int, optional
        ``method="arc_length"`` only. Largest number of converged steps (default
        200); the continuation stops there.
    max_limit_points : int, optional
        ``method="arc_length"`` only. Also stop at the first stored point after
        the path has passed this many limit points (sign changes of dμ/ds, e.g. 1:
        just past the first maximum of the load).
    desired_iterations : int
        ``method="arc_length"`` only. Adaptive arc length: after a step that took
        I Newton iterations the next is Δs · (desired_iterations / I)^½, limited
        to [Δs/2, 2Δs] and the bounds above (Crisfield 1981).

    Returns
    -------
    StaticResult
        One stored step per converged level; ``path`` and ``strategy`` tell
        how it was reached (:meth:`StaticResult.describe_path` prints it).
        With arc length: every converged point of the path, the start (μ = 0)
        included, in order; ``load_factor`` (= ``t``) is then not monotonic
        (:meth:`StaticResult.limit_points` gives the indices of its extrema).

    Raises
    ------
    ConvergenceError
        When neither the direct attempt nor load stepping (down to an
        increment of ``min_step``) converges; ``err.path`` holds the attempts.
    SingularMatrixError
        When a Newton solve fails at a configuration whose constrained
        stiffness matrix is singular (a free body or a mechanism degree of
        freedom without stiffness against the loads, or a limit point: statics
        is undefined there, and neither load stepping nor cut-backs help);
        raised at once, ``err.path`` holds the attempts.
    ParameterError
        Bad parameters or an unknown option name (the message names it), or
        ``method="arc_length"`` on a model without applied loads.

    Notes
    -----
    **Arc length.** Pseudo-arc-length continuation with a bordered Newton
    corrector (Keller 1977; the normal-plane constraint of Riks 1979): a step of length Δs from the
    equilibrium (q_n, λ_n, μ_n) with unit tangent t = (t_q, t_μ) (in the norm
    above) starts at the predictor (q_n ∘ exp(Δs t_q), λ_n + Δs t_λ, μ_n + Δs t_μ)
    and corrects (q, λ, μ) by Newton's method on r = 0, Φ = 0 and
    ⟨t, (Δq, μ − μ_n)⟩ = Δs, the bordered matrix [[K_t, Φ_qᵀ, −f_ext],
    [Φ_q, 0, 0], [s² t_q, 0, ψ² t_μ]] (one LU per iteration). Chosen over
    Crisfield's quadratic (spherical/cylindrical) constraint because the bordered
    matrix stays regular at limit points, there is no root of a quadratic to
    select (nor complex roots to recover from), and constraints and multipliers
    enter as in the load-controlled solver. The tangent at each new
    equilibrium solves the same matrix with right side (0, 0, 1) and the
    previous tangent as last row: its direction continues the previous one
    (⟨t_new, t_old⟩ > 0), which turns the load factor down after a limit point.
    Corrector iterates farther than 3 Δs from the last equilibrium count as a
    failed step (against jumping to another branch).

    Examples
    --------
    >>> from femb import Mechanism
    >>> from femb.elements import PointMass, SpringDamper, Gravity
    >>> m = Mechanism("hanging")
    >>> p = m.add(PointMass("p", 1.0, position=(0.0, -1.0)))
    >>> _ = m.add(SpringDamper("s", "ground", p, 100.0), Gravity((0.0, -10.0)))
    >>> res = solve_static(m.compile())
    >>> round(float(res.body("p")[-1, 1]), 6), res.strategy
    (-1.1, 'direct')

    Arc length (the path from μ = 0 to the target load factor 1; a second spring
    gives the unloaded mass a lateral stiffness, without which the tangent at
    μ = 0 is singular):

    >>> _ = m.add(SpringDamper("h", "ground", p, 100.0, point_a=(1.0, -1.0)))   # holds x at μ = 0
    >>> res = solve_static(m.compile(), method="arc_length")
    >>> round(float(res.load_factor[-1]), 12), round(float(res.body("p")[-1, 1]), 4), res.strategy
    (1.0, -1.0999, 'arc length')
    """
    refuse_contacts(model, 'static analysis (solve_static)')
    o = StaticOptions.create(options, **kwargs)
    run = _StaticRun(model, o, state, observer)
    if o.method == "arc_length":
        return run.result("arc length", run.arc())
    if o.load_steps is None and o.load_factors is None:
        return run.result(run.direct(), "")
    run.stepping(o.targets(), run.q0, run.lam0, o.load_steps is not None)
    return run.result("load steps", "")


class _StaticRun:
    """One static solve: its Newton solver, the attempts (``path``) and the converged levels.

    The strategies of :func:`solve_static` are methods: :meth:`direct` (full load, load
    stepping as the fallback), :meth:`stepping` (load control through given levels) and
    :meth:`arc` (arc-length continuation).
    """

    def __init__(self, model, o, state, observer):
        self.model, self.o, self.observer = model, o, observer
        self.newton = _Newton(model, o.t, _load_groups(model, o.load_types), o.rtol, o.atol,
                              o.phi_tol * model.length_scale, o.xtol, int(o.max_iter))
        st = state.copy() if state is not None else model.initial_state(o.t)
        self.q0 = np.asarray(st.q, dtype=float).copy()
        self.lam0 = np.asarray(st.lam, dtype=float).copy() if st.lam.size == model.nc else np.zeros(model.nc)
        self.path = []
        self.mus, self.Q, self.L, self.its = [], [], [], []
        self.singular = False                 # the last Newton solve failed on a singular matrix
        self.S, self.T = [], []               # arc-length path parameter and dμ/ds per stored state

    def attempt(self, mu, q, lam, start):
        sol, recs, singular = self.newton(mu, q, lam, start)
        self.path.extend(recs)
        self.singular = singular
        return sol, recs[-1]

    def accept(self, mu, sol, rec):
        self.mus.append(mu), self.Q.append(sol[0].copy()), self.L.append(sol[1].copy())
        self.its.append(rec["iterations"])
        if self.observer is not None:
            self.observer(mu, sol[0], sol[1], rec["iterations"])

    def fail(self, msg, mu):
        """The error to raise: SingularMatrixError after a singular solve, else ConvergenceError."""
        model, t = self.model, self.o.t
        text = f"{msg}\n" + StaticResult.describe_path(
            StaticResult(model=model, t=np.zeros(0), q=np.zeros((0, model.nq)), qd=None, qdd=None, lam=None,
                         newton_iterations=np.zeros(0), path=self.path, strategy="failed"))
        if self.singular:
            err = SingularMatrixError(
                f"singular static stiffness matrix at load factor {mu:.6g}: the constrained system has a "
                "motion without stiffness (a free body or an unloaded mechanism degree of freedom), or "
                f"redundant constraints; statics is undefined there. {text}", t=t, step=len(self.mus))
        else:
            err = ConvergenceError(text, t=t, step=len(self.mus))
        err.path = self.path
        return err

    # ---- load control ------------------------------------------------------------------------
    def direct(self):
        """Full load from the given configuration; load stepping when that fails or is unstable.

        Returns the strategy ("direct" or "continuation")."""
        model, t = self.model, self.o.t
        sol, rec = self.attempt(1.0, self.q0, self.lam0, "given")
        if sol is None:
            if self.singular:
                raise self.fail(f"static Newton failed at full load from the given configuration on a singular "
                                f"stiffness matrix: {rec['reason']}", 1.0)
            self.stepping(self._fallback_levels(), self.q0, self.lam0, True)
            return "continuation"
        lam_min = stability(model, sol[0], sol[1], t)
        rec["stability"] = lam_min
        if lam_min is None or lam_min >= -1e-10:
            self.accept(1.0, sol, rec)
            return "direct"
        # an unstable equilibrium reached directly (e.g. an inverted pendulum from a start
        # near horizontal): prefer the one load stepping leads to, if that is stable
        rec["reason"] = "converged to an unstable equilibrium; trying load stepping"
        try:
            self.stepping(self._fallback_levels(), self.q0, self.lam0, True)
            lam_min = stability(model, self.Q[-1], self.L[-1], t)
            ok = lam_min is None or lam_min >= -1e-10
        except (ConvergenceError, SingularMatrixError):
            ok = False
        if ok:
            return "continuation"
        self.mus.clear(), self.Q.clear(), self.L.clear(), self.its.clear()
        self.accept(1.0, sol, rec)
        warnings.warn(f"model '{model.name}': the static equilibrium found is unstable (the reduced "
                      "stiffness has a negative eigenvalue); load stepping found no stable one", stacklevel=3)
        return "direct"

    def _fallback_levels(self):
        n = int(self.o.fallback_steps)
        return [k / n for k in range(1, n + 1)]

    def stepping(self, targets, q, lam, include_zero):
        """Load stepping from μ = 0 (the given configuration) through ``targets``."""
        mu = 0.0
        if include_zero:
            sol, rec = self.attempt(0.0, q, lam, "given")
            if sol is not None:
                self.accept(0.0, sol, rec)
                q, lam = sol
            else:
                rec["reason"] += " (zero load skipped: the stepping starts from the given configuration)"
        mus, Q, model = self.mus, self.Q, self.model
        for target in targets:
            step = None                        # increment that worked after a cut-back
            wall = None                        # the nearest load factor ahead where Newton failed
            while mu != target:
                dmu = target - mu
                if step is not None and abs(step) < abs(dmu):
                    dmu = math.copysign(2.0 * abs(step), dmu) if 2.0 * abs(step) < abs(dmu) else dmu
                if wall is not None and (mu + dmu - wall) * dmu > 0.0:
                    dmu = wall - mu                # after a cut-back: up to the level that failed, not past it
                trial, sol, rec, step, failed = self._increment(mu, dmu, q, lam, step)
                wall = failed if failed is not None else (None if trial == wall else wall)
                if len(mus) >= 2 and mus[-1] != mus[-2]:
                    # the secant continuation of the path, whichever start converged
                    s_ = (trial - mus[-1]) / (mus[-1] - mus[-2])
                    _check_jump(model, Q[-1], model.compose(Q[-1], s_ * model.difference(Q[-1], Q[-2])), sol[0],
                                mus[-1], trial)
                q, lam = sol
                mu = trial if abs(trial - target) > 1e-15 else target
                self.accept(mu, sol, rec)

    def _increment(self, mu, dmu, q, lam, step):
        """Solve at μ + dμ, halving dμ until Newton converges.

        Returns (μ + dμ, solution, record, step, the last load factor that failed or None)."""
        failed = None
        while True:
            trial = mu + dmu
            sol, rec = self._predicted(trial, q, lam)
            if sol is not None:
                return trial, sol, rec, step, failed
            failed = trial
            if self.singular:
                # a singular tangent where Newton stalls (no stiffness against the loads, or a
                # limit point): smaller increments do not remove it
                raise self.fail(f"static Newton failed at load factor {trial:.6g} (last converged {mu:.6g}) "
                                f"on a singular stiffness matrix: {rec['reason']}", trial)
            if abs(dmu) <= self.o.min_step:
                raise self.fail(f"static Newton failed at load factor {trial:.6g} with increment "
                                f"{dmu:.3g} (last converged {mu:.6g}): {rec['reason']}", trial)
            dmu *= 0.5
            step = dmu

    def _predicted(self, trial, q, lam):
        """Newton at load factor ``trial`` from the predictor (secant, else the last level)."""
        mus, Q, L, model = self.mus, self.Q, self.L, self.model
        if self.o.predictor == "secant" and len(mus) >= 2 and mus[-1] != mus[-2]:
            s = (trial - mus[-1]) / (mus[-1] - mus[-2])
            # Q[-1] ∘ exp(s log(Q[-2]⁻¹Q[-1])): the secant on the group (Q[-1] + s(Q[-1] − Q[-2])
            # on vector spaces)
            qs = model.compose(Q[-1], s * model.difference(Q[-1], Q[-2]))
            sol, rec = self.attempt(trial, qs, L[-1] + s * (L[-1] - L[-2]), "secant")
            if sol is None:
                sol, rec = self.attempt(trial, q, lam, "previous")
            return sol, rec
        return self.attempt(trial, q, lam, "previous" if mus else "given")

    # ---- arc length --------------------------------------------------------------------------
    def _arc_start(self):
        """Equilibrium at μ = 0, the scaled norm and the first tangent: (q, λ, _ArcLength, tangent)."""
        model = self.model
        sol, rec = self.attempt(0.0, self.q0, self.lam0, "given")
        if sol is None:
            raise self.fail(f"static Newton failed at zero load from the given configuration: {rec['reason']}", 0.0)
        self.accept(0.0, sol, rec)
        q, lam = sol
        s2 = 1.0 / (model.force_weight * model.length_scale) ** 2
        al = _ArcLength(model, self.newton, s2, 1.0)
        if not np.any(al.fext(q) != 0.0):
            raise ParameterError(f"model '{model.name}': method='arc_length' needs applied loads (the scaled "
                                 "loads f_ext are zero: no Force/Torque of load_types, no gravity)")
        raw = al.tangent(0.0, q, lam, None)              # with ψ = 1; only its displacement part is used
        if raw is None:
            self.singular = True
            raise self.fail("singular static stiffness matrix at zero load: no tangent to start the path", 0.0)
        vq = raw[0] / raw[2]                              # dq/dμ
        vnorm = math.sqrt(float(np.sum(s2 * vq * vq)))
        w = self.o.load_weight
        psi = float(w) if w is not None else (vnorm if vnorm > 0.0 else 1.0)
        al.psi2 = psi * psi
        tan = al.normalized(vq, raw[1] / raw[2], 1.0)
        if tan is None:
            raise self.fail("no tangent to start the path (zero load weight and no displacement under the loads)",
                            0.0)
        return q, lam, al, tan

    def _arc_bounds(self, target, tan):
        """The first arc length and its bounds (ds, ds_min, ds_max)."""
        o = self.o
        ds = float(o.arc_length) if o.arc_length is not None else \
            0.05 * (abs(target) if target is not None else 1.0) / tan[2]
        ds_min = float(o.arc_length_min) if o.arc_length_min is not None else ds / 1024.0
        ds_max = float(o.arc_length_max) if o.arc_length_max is not None else 10.0 * ds
        ds_min, ds_max = min(ds_min, ds_max), max(ds_min, ds_max)      # one bound given, beyond the other's default
        return min(max(ds, ds_min), ds_max), ds_min, ds_max

    def arc(self):
        """Arc-length continuation from μ = 0 (see the notes of solve_static); returns the stop reason."""
        o, S, T = self.o, self.S, self.T
        q, lam, al, tan = self._arc_start()
        mu = 0.0
        target = None if o.target_load_factor is None else float(o.target_load_factor)
        ds, ds_min, ds_max = self._arc_bounds(target, tan)
        nmax = int(o.max_steps) if o.max_steps is not None else 200
        steps = passed = 0
        S.append(0.0), T.append(float(tan[2]))
        while steps < nmax:
            rec = {"mu": float(mu), "start": "tangent", "newton": "arc length", "converged": False,
                   "iterations": 0, "residuals": [], "damped": 0, "reason": "", "arc_length": ds}
            out = al.step(mu, q, lam, tan, ds, rec)
            self.path.append(rec)
            if out is None:
                self.singular = rec["reason"].startswith("singular")
                if ds <= ds_min * (1.0 + 1e-12):
                    raise self.fail(f"arc-length step failed at load factor {rec['mu']:.6g} (last converged "
                                    f"{mu:.6g}) with the smallest arc length {ds:.3g}: {rec['reason']}", rec["mu"])
                ds = max(0.5 * ds, ds_min)
                continue
            mu1, q1, lam1, Dq, Dmu = out
            if target is not None and (mu - target) * (mu1 - target) < 0.0:
                return self._land(al, target, (mu, q, lam), out, rec)
            self.accept(mu1, (q1, lam1), rec)
            S.append(S[-1] + al.norm(Dq, Dmu))
            steps += 1
            new = al.tangent(mu1, q1, lam1, (tan[0], tan[2]))
            if new is None:                               # singular (a bifurcation): continue along the secant
                new = al.normalized(Dq, (lam1 - lam), Dmu)
                T.append(float("nan"))
            else:
                T.append(float(new[2]))
            if target is not None and mu1 == target:
                return f"reached the target load factor {target:.6g}"
            if math.isfinite(T[-1]) and T[-1] * tan[2] < 0.0:
                passed += 1
                if o.max_limit_points is not None and passed >= int(o.max_limit_points):
                    return f"passed {passed} limit point(s); stopped at load factor {mu1:.6g}"
            mu, q, lam, tan = mu1, q1, lam1, new
            grow = math.sqrt(int(o.desired_iterations) / max(rec["iterations"], 1))
            ds = min(max(ds * min(max(grow, 0.5), 2.0), ds_min), ds_max)
        return f"stopped after max_steps = {nmax} steps at load factor {mu:.6g}"

    def _land(self, al, target, last, out, rec):
        """The step crossed the target: the last point at exactly μ = target, from the interpolation."""
        mu, q, lam = last
        mu1, q1, lam1, Dq, Dmu = out
        frac = (target - mu) / (mu1 - mu)
        sol, rec2 = self.attempt(target, self.model.compose(q, frac * Dq), lam + frac * (lam1 - lam), "secant")
        if sol is not None:
            self.accept(target, sol, rec2)
            self.S.append(self.S[-1] + al.norm(self.model.difference(sol[0], q), target - mu))
            self.T.append(float("nan"))
            return f"reached the target load factor {target:.6g}"
        rec2["reason"] += " (landing on the target failed: the crossing point is kept)"
        self.accept(mu1, (q1, lam1), rec)
        self.S.append(self.S[-1] + al.norm(Dq, Dmu)), self.T.append(float("nan"))
        return f"crossed the target load factor {target:.6g} at {mu1:.6g}"

    # ---- the result --------------------------------------------------------------------------
    def result(self, strategy, stop):
        mus, o, n = self.mus, self.o, len(self.path)
        Qa = np.array(self.Q)
        arc = {"s": np.array(self.S), "dmu_ds": np.array(self.T)} if o.method == "arc_length" else None
        return StaticResult(model=self.model, t=np.array(mus), q=Qa, qd=np.zeros_like(Qa), qdd=np.zeros_like(Qa),
                            lam=np.array(self.L).reshape(len(mus), self.model.nc),
                            newton_iterations=np.array(self.its, dtype=np.int32), status="success",
                            message=(f"{stop} ({strategy}, {n} Newton solves)" if stop else
                                     f"reached load factor {mus[-1]:.6g} ({strategy}, {n} Newton solves)"),
                            settings=o.settings(), time=float(o.t), strategy=strategy, path=self.path, arc=arc)
