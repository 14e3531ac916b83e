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
:mod:`femb.assembly` (:func:`~femb.assembly.force_vector`,
:func:`~femb.assembly.tangent_stiffness`, :func:`~femb.assembly.constraint_jacobian`, …).

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

The route taken is reported in :attr:`StaticResult.path`.

Applied loads are, by default, the constant forces of the model (constant
torques and gravity) and every :class:`~femb.elements.Force` and
:class:`~femb.elements.Torque`; rheonomic constraints are frozen at the time ``t``.

References
----------
M. A. Crisfield, Non-linear Finite Element Analysis of Solids and
Structures, Vol. 1, Wiley, 1991, Ch. 9 (incremental–iterative solution).

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
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from femb import assembly, kernels
from femb.errors import ConvergenceError, ParameterError, SingularMatrixError
from femb.model import State
from femb.result import Result

#: saddle-point systems with at most this many unknowns are solved with dense LU
DENSE_LIMIT = 400


@dataclass
class StaticResult(Result):
    """Converged load levels of :func:`solve_static` (a :class:`~femb.result.Result`).

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
        attempt failed, load stepping found it) or ``"load steps"`` (asked for).
    path : list of dict
        Every Newton solve attempted, in order, converged or not: ``mu`` (load
        factor), ``start`` (``"given"``, ``"previous"`` or ``"secant"``),
        ``newton`` (``"full steps"``, or ``"globalized"`` for the retry with
        line search / Levenberg–Marquardt after full steps failed),
        ``converged`` (bool), ``iterations``, ``residuals`` (list of
        (‖r‖∞ in N with moments / L, ‖Φ‖∞ in m) per iterate), ``damped``
        (iterations that needed a shortened or regularized step) and
        ``reason`` (why it failed, or ""); the direct attempt also has
        ``stability`` (see :func:`stability`).
    """

    time: float = 0.0
    strategy: str = "direct"
    path: list = field(default_factory=list)

    @property
    def load_factor(self):
        return self.t

    @property
    def state(self):
        """The last converged equilibrium as a :class:`~femb.model.State` (at time ``time``)."""
        nv = self.model.nq          # velocities: nq (rotation nodes store 7 coordinates, move with 6)
        return State(self.time, self.q[-1].copy(), np.zeros(nv), np.zeros(nv), self.lam[-1].copy())

    def describe_path(self):
        """The route to the equilibrium as text, one line per Newton solve."""
        lines = [f"static solution ({self.strategy}):"]
        for p in self.path:
            r, phi = p["residuals"][-1] if p["residuals"] else (float("nan"), float("nan"))
            lines.append(f"  mu = {p['mu']:<10.6g} from {p['start']:<8s} {p['newton']:<10s} {'converged' if p['converged'] else 'FAILED':9s} "
                         f"in {p['iterations']:2d} iterations ({p['damped']} damped), "
                         f"|r| = {r:.3e} N, |Phi| = {phi:.3e} m" + (f"  [{p['reason']}]" if p["reason"] else ""))
        return "\n".join(lines)


def _load_groups(model, load_types):
    if load_types is None:
        from femb.elements import Force, Torque
        from femb.elements.spatial_forces import SpatialForce, SpatialTorque
        load_types = (Force, Torque, SpatialForce, SpatialTorque)
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


def _solve(K, B, rhs):
    """Solve [[K, Bᵀ], [B, 0]] x = rhs; None when the matrix is singular.

    The matrix is first equilibrated symmetrically, D A D with D = 1/√(row max),
    so that stiff and soft coordinates, forces and constraint rows are
    compared on one scale; a pivot below 1e-15 of the largest (a few machine
    epsilons, the level of exact singularity after cancellation) or a
    non-finite solution is taken as singular. Legitimately ill-conditioned
    structures (EA L²/EI up to 1e12) pass.
    """
    nc = B.shape[0]
    A = sp.bmat([[K, B.T], [B, None]], format="csc") if nc else sp.csc_matrix(K)
    N = A.shape[0]
    rmax = np.asarray(abs(A).max(axis=1).todense()).ravel()
    if np.any(rmax == 0.0) or not np.all(np.isfinite(rmax)):
        return None
    D = sp.diags(1.0 / np.sqrt(rmax))
    As = (D @ A @ D).tocsc()
    b = D @ rhs
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
    x = D @ y
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


def solve_static(model, *, load_steps=None, load_factors=None, t=0.0, state=None, load_types=None,
                 rtol=1e-10, atol=0.0, phi_tol=1e-12, xtol=1e-12, max_iter=30, min_step=1e-4,
                 fallback_steps=10, predictor="secant", observer=None):
    """Static equilibrium: full load at once, load stepping when that fails or when asked.

    Parameters
    ----------
    model : Model
    load_steps : int, optional
        Ask for load stepping with this many equal increments from μ = 0 to 1.
        Default: none, solve at μ = 1 directly (see the module notes).
    load_factors : sequence of float, optional
        Ask for load stepping through these levels μ, in order (e.g.
        ``[0.5, 1.0, 2.0]``); the first is solved from the given configuration.
    t : float
        Time at which loads and (frozen) rheonomic constraints are evaluated.
    state : State, optional
        Starting configuration (default: the model's initial coordinates).
        Its multipliers are replaced by the least-squares reactions to the loads.
    load_types : tuple of element classes, optional
        Force element types scaled by μ (default ``(Force, Torque)``); the
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
    observer : callable(mu, q, lam, iterations), optional
        Called after each converged level.

    Returns
    -------
    StaticResult
        One stored step per converged level; ``path`` and ``strategy`` tell
        how it was reached (:meth:`StaticResult.describe_path` prints it).

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
    """
    asked = load_steps is not None or load_factors is not None
    if load_steps is not None and load_factors is not None:
        raise ParameterError("give either load_steps or load_factors, not both")
    if load_factors is not None:
        targets = [float(x) for x in np.atleast_1d(load_factors)]
        if not targets or not all(math.isfinite(x) for x in targets):
            raise ParameterError(f"load_factors must be finite numbers, got {load_factors!r}")
    elif load_steps is not None:
        n = int(load_steps)
        if n < 1:
            raise ParameterError(f"load_steps must be at least 1, got {load_steps!r}")
        targets = [k / n for k in range(1, n + 1)]
    else:
        targets = [1.0]
    if int(fallback_steps) < 1:
        raise ParameterError(f"fallback_steps must be at least 1, got {fallback_steps!r}")
    if predictor not in ("secant", "previous"):
        raise ParameterError(f"predictor must be 'secant' or 'previous', got {predictor!r}")
    nq, nc = model.nq, model.nc
    groups = _load_groups(model, load_types)
    newton = _Newton(model, t, groups, rtol, atol, phi_tol * model.length_scale, xtol, int(max_iter))
    st = state.copy() if state is not None else model.initial_state(t)
    q0 = np.asarray(st.q, dtype=float).copy()
    lam0 = np.asarray(st.lam, dtype=float).copy() if st.lam.size == nc else np.zeros(nc)
    path = []
    mus, Q, L, its = [], [], [], []
    last_singular = [False]

    def attempt(mu, q, lam, start):
        sol, recs, singular = newton(mu, q, lam, start)
        path.extend(recs)
        last_singular[0] = singular
        return sol, recs[-1]

    def accept(mu, sol, rec):
        mus.append(mu), Q.append(sol[0].copy()), L.append(sol[1].copy()), its.append(rec["iterations"])
        if observer is not None:
            observer(mu, sol[0], sol[1], rec["iterations"])

    def fail(msg, mu):
        text = f"{msg}\n" + StaticResult.describe_path(
            StaticResult(model=model, t=np.zeros(0), q=np.zeros((0, nq)), qd=None, qdd=None, lam=None,
                         newton_iterations=np.zeros(0), path=path, strategy="failed"))
        if last_singular[0]:
            err = SingularMatrixError(
                f"singular static stiffness matrix at load factor {mu:.6g}: the constrained system has a "
                "motion without stiffness (a free body or an unloaded mechanism degree of freedom), or "
                f"redundant constraints; statics is undefined there. {text}", t=t, step=len(mus))
        else:
            err = ConvergenceError(text, t=t, step=len(mus))
        err.path = path
        return err

    def stepping(targets, q, lam, include_zero):
        """Load stepping from μ = 0 (the given configuration) through ``targets``."""
        mu = 0.0
        if include_zero:
            sol, rec = attempt(0.0, q, lam, "given")
            if sol is not None:
                accept(0.0, sol, rec)
                q, lam = sol
            else:
                rec["reason"] += " (zero load skipped: the stepping starts from the given configuration)"
        for target in targets:
            step = None                        # increment that worked after a cut-back
            while mu != target:
                dmu = target - mu
                if step is not None and abs(step) < abs(dmu):
                    dmu = math.copysign(2.0 * abs(step), dmu) if 2.0 * abs(step) < abs(dmu) else dmu
                while True:
                    trial = mu + dmu
                    if predictor == "secant" and len(mus) >= 2 and mus[-1] != mus[-2]:
                        s = (trial - mus[-1]) / (mus[-1] - mus[-2])
                        # Q[-1] ∘ exp(s log(Q[-2]⁻¹Q[-1])): the secant on the group (Q[-1] + s(Q[-1] − Q[-2])
                        # on vector spaces)
                        qs = model.compose(Q[-1], s * model.difference(Q[-1], Q[-2]))
                        sol, rec = attempt(trial, qs, L[-1] + s * (L[-1] - L[-2]), "secant")
                        if sol is None:
                            sol, rec = attempt(trial, q, lam, "previous")
                    else:
                        sol, rec = attempt(trial, q, lam, "previous" if mus else "given")
                    if sol is not None:
                        break
                    if last_singular[0]:
                        # a singular tangent where Newton stalls (no stiffness against the loads, or a
                        # limit point): smaller increments do not remove it
                        raise fail(f"static Newton failed at load factor {trial:.6g} (last converged {mu:.6g}) "
                                   f"on a singular stiffness matrix: {rec['reason']}", trial)
                    if abs(dmu) <= min_step:
                        raise fail(f"static Newton failed at load factor {trial:.6g} with increment "
                                   f"{dmu:.3g} (last converged {mu:.6g}): {rec['reason']}", trial)
                    dmu *= 0.5
                    step = dmu
                q, lam = sol
                mu = trial if abs(trial - target) > 1e-15 else target
                accept(mu, sol, rec)

    if not asked:
        sol, rec = attempt(1.0, q0, lam0, "given")
        unstable = False
        if sol is not None:
            lam_min = stability(model, sol[0], sol[1], t)
            unstable = lam_min is not None and lam_min < -1e-10
            rec["stability"] = lam_min
        if sol is not None and not unstable:
            accept(1.0, sol, rec)
            strategy = "direct"
        elif sol is not None:
            # an unstable equilibrium reached directly (e.g. an inverted pendulum from a start
            # near horizontal): prefer the one load stepping leads to, if that is stable
            rec["reason"] = "converged to an unstable equilibrium; trying load stepping"
            direct = (sol, rec)
            try:
                n = int(fallback_steps)
                stepping([k / n for k in range(1, n + 1)], q0, lam0, True)
                lam_min = stability(model, Q[-1], L[-1], t)
                ok = lam_min is None or lam_min >= -1e-10
            except (ConvergenceError, SingularMatrixError):
                ok = False
            if ok:
                strategy = "continuation"
            else:
                mus.clear(), Q.clear(), L.clear(), its.clear()
                accept(1.0, *direct)
                strategy = "direct"
                warnings.warn(f"model '{model.name}': the static equilibrium found is unstable (the reduced "
                              "stiffness has a negative eigenvalue); load stepping found no stable one",
                              stacklevel=2)
        elif last_singular[0]:
            raise fail(f"static Newton failed at full load from the given configuration on a singular "
                       f"stiffness matrix: {rec['reason']}", 1.0)
        else:
            strategy = "continuation"
            n = int(fallback_steps)
            stepping([k / n for k in range(1, n + 1)], q0, lam0, True)
    else:
        strategy = "load steps"
        stepping(targets, q0, lam0, load_steps is not None)
    Qa = np.array(Q)
    return StaticResult(model=model, t=np.array(mus), q=Qa, qd=np.zeros_like(Qa), qdd=np.zeros_like(Qa),
                        lam=np.array(L).reshape(len(mus), nc), newton_iterations=np.array(its, dtype=np.int32),
                        status="success",
                        message=f"reached load factor {mus[-1]:.6g} ({strategy}, {len(path)} Newton solves)",
                        settings={"t": t, "rtol": rtol, "atol": atol, "phi_tol": phi_tol, "xtol": xtol,
                                  "max_iter": max_iter, "min_step": min_step, "predictor": predictor},
                        time=float(t), strategy=strategy, path=path)
