"""Static equilibrium with load stepping: Newton on the constrained equilibrium equations.

With q̇ = q̈ = 0 the equations of motion (method.md eq. 1–2) reduce to

    r(q, λ; μ) = −f_int(q) − μ f_ext(q) + Φ_q(q, t)ᵀ λ = 0,     Φ(q, t) = 0,

where the force vector f of the model is split into *applied loads* f_ext,
scaled by the load factor μ, and the rest f_int (elastic and spring forces of
beams, springs, ...), which is not. Each load level is solved by Newton's
method on

    [ K_t(μ)  Φ_qᵀ ] [Δq]     [r]
    [ Φ_q     0    ] [Δλ] = − [Φ],    K_t(μ) = −∂f_int/∂q − μ ∂f_ext/∂q + ∂(Φ_qᵀλ)/∂q,

the iteration matrix of the dynamic solver (method.md eq. 7) without its mass
and damping terms, assembled by the same functions
(:func:`femb.assembly.tangent_stiffness`, :func:`~femb.assembly.constraint_jacobian`,
…). Load steps go from μ = 0 to 1; a load step whose Newton iteration fails is
bisected (cut back) until it converges or the step falls below a minimum, and
the following increments double again up to the requested ones. Each Newton
solve starts from the multipliers that best balance the current loads
(least squares), so that the constraint (geometric) stiffness of the new load
level is present from the first iteration.

Applied loads are, by default, the constant forces of the model (constant
torques and gravity) and every :class:`~femb.elements.Force` and
:class:`~femb.elements.Torque`; rheonomic constraints are frozen at the time ``t``.

References
----------
M. A. Crisfield, Non-linear Finite Element Analysis of Solids and
Structures, Vol. 1, Wiley, 1991, Ch. 9 (incremental–iterative solution).

M. Géradin, A. Cardona, Flexible Multibody Dynamics, Wiley, 2001, Ch. 10
(static equilibrium of constrained flexible systems).
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

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
    """Converged load steps of :func:`solve_static` (a :class:`~femb.result.Result`).

    ``t`` holds the **load factors** μ of the stored steps (also available as
    :attr:`load_factor`); ``qd`` and ``qdd`` are zero; ``newton_iterations``
    counts the iterations of every stored step. Named access (``body``,
    ``position``, ``reaction``) works as for a simulation.
    """

    time: float = 0.0

    @property
    def load_factor(self):
        return self.t

    @property
    def state(self):
        """The last converged equilibrium as a :class:`~femb.model.State` (at time ``time``)."""
        return State(self.time, self.q[-1].copy(), np.zeros(self.q.shape[1]), np.zeros(self.q.shape[1]),
                     self.lam[-1].copy())


def _load_groups(model, load_types):
    if load_types is None:
        from femb.elements import Force, Torque
        load_types = (Force, Torque)
    load_types = tuple(load_types)
    return [g for g in model.force_groups if issubclass(g.cls, load_types)]


def _external(model, groups, t, q, jac):
    """Applied loads f_ext(q) (nq,) and, when ``jac``, ∂f_ext/∂q (csr)."""
    nq, next_ = model.nq, model.nq + model.nfix
    qx = model.ext(q)
    qdx = np.zeros(next_)
    f = model.f_const.copy()
    rows, cols, vals = [], [], []
    for g in groups:
        fe, fq, _ = kernels.force(g, t, qx[g.dofs], qdx[g.dofs], jac)
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


def equilibrium_residual(model, q, lam, mu=1.0, t=0.0, load_types=None):
    """(r, Φ) of the static equations at load factor ``mu`` (shapes (nq,), (nc,))."""
    q = np.asarray(q, dtype=float)
    groups = _load_groups(model, load_types)
    f = assembly.force_vector(model, t, q, np.zeros(model.nq))
    fe, _ = _external(model, groups, t, q, False)
    r = -(f - (1.0 - mu) * fe) + assembly.constraint_force(model, t, q, lam)
    return r, assembly.constraint_vector(model, t, q)


def solve_static(model, *, load_steps=10, load_factors=None, t=0.0, state=None, load_types=None,
                 rtol=1e-10, atol=0.0, phi_tol=1e-12, xtol=1e-12, max_iter=30, min_step=1e-4,
                 predictor="secant", observer=None):
    """Static equilibrium under increasing applied loads (Newton with load stepping).

    Parameters
    ----------
    model : Model
    load_steps : int
        Equal load increments from μ = 0 to μ = 1 (ignored when
        ``load_factors`` is given).
    load_factors : sequence of float, optional
        The load levels μ to reach, in order (e.g. ``[0.5, 1.0]``).
    t : float
        Time at which loads and (frozen) rheonomic constraints are evaluated.
    state : State, optional
        Starting configuration (default: the model's initial coordinates,
        λ = 0). The solver first equilibrates at μ = 0 from it.
    load_types : tuple of element classes, optional
        Force element types scaled by μ (default ``(Force, Torque)``); the
        model's constant forces (constant torques, gravity) are always scaled.
    rtol, atol : float
        Force test ‖r‖∞ ≤ rtol · F + atol, with F the largest of ‖f_int‖∞,
        ‖μ f_ext‖∞ and ‖Φ_qᵀλ‖∞ at the iterate (N).
    phi_tol : float
        Constraint test ‖Φ‖∞ ≤ phi_tol · model.length_scale.
    xtol : float
        Also accept an iterate when the last Newton correction was below
        xtol · model.length_scale (in every coordinate, rotations in rad) and
        the constraint test holds: the force residual of very stiff sections
        (large EA) under tiny loads can stall at round-off above rtol · F.
    max_iter : int
        Newton iterations per load step before the step is cut back.
    min_step : float
        Smallest load increment tried before giving up.
    predictor : {"secant", "previous"}
        Start each step from a linear extrapolation of the last two converged
        steps, or from the last one.
    observer : callable(mu, q, lam, iterations), optional
        Called after each converged step.

    Returns
    -------
    StaticResult
        One stored step per converged load level (μ = 0 first), including the
        intermediate levels of cut-back steps.

    Raises
    ------
    ConvergenceError
        When a load increment below ``min_step`` still does not converge.
    SingularMatrixError
        When the stiffness matrix of the constrained system is singular (a
        mechanism with an unloaded degree of freedom without stiffness).
    """
    if load_factors is None:
        n = int(load_steps)
        if n < 1:
            raise ParameterError(f"load_steps must be at least 1, got {load_steps!r}")
        targets = [k / n for k in range(1, n + 1)]
    else:
        targets = [float(x) for x in np.atleast_1d(load_factors)]
        if not all(math.isfinite(x) for x in targets):
            raise ParameterError(f"load_factors must be finite, got {load_factors!r}")
    if predictor not in ("secant", "previous"):
        raise ParameterError(f"predictor must be 'secant' or 'previous', got {predictor!r}")
    nq, nc = model.nq, model.nc
    groups = _load_groups(model, load_types)
    tol_phi = phi_tol * model.length_scale
    zero = np.zeros(nq)
    st = state.copy() if state is not None else model.initial_state(t)
    q = np.asarray(st.q, dtype=float).copy()
    lam = np.asarray(st.lam, dtype=float).copy() if st.lam.size == nc else np.zeros(nc)

    def newton(mu, q, lam):
        if nc:
            lam = _multiplier_guess(q, mu, lam)
        last = None
        for k in range(max_iter + 1):
            f = assembly.force_vector(model, t, q, zero)
            fe, Fe_q = _external(model, groups, t, q, True)
            f_int = f - fe
            cf = assembly.constraint_force(model, t, q, lam)
            r = -(f_int + mu * fe) + cf
            Phi = assembly.constraint_vector(model, t, q)
            F = max(np.abs(f_int).max(initial=0.0), abs(mu) * np.abs(fe).max(initial=0.0),
                    np.abs(cf).max(initial=0.0))
            err_r = np.abs(r).max(initial=0.0)
            err_phi = np.abs(Phi).max(initial=0.0)
            if not (math.isfinite(err_r) and math.isfinite(err_phi)):
                return None, k, "non-finite residual"
            if err_r <= rtol * F + atol and err_phi <= tol_phi:
                return (q, lam), k, None
            if last is not None and last <= xtol * model.length_scale and err_phi <= tol_phi:
                return (q, lam), k, None          # increment at the round-off level
            if k == max_iter:
                return None, k, f"‖r‖∞ = {err_r:.3e} N, ‖Φ‖∞ = {err_phi:.3e} m after {k} iterations"
            K = assembly.tangent_stiffness(model, State(t, q, zero, zero, lam))
            K = K + (1.0 - mu) * Fe_q
            B = assembly.constraint_jacobian(model, t, q)
            x = _solve(K, B, -np.concatenate((r, Phi)))
            if x is None:
                raise SingularMatrixError(
                    f"singular static stiffness matrix at load factor {mu:.6g}: the constrained system "
                    "has a motion without stiffness (a free body or an unloaded mechanism degree of "
                    "freedom), or redundant constraints; statics is undefined there",
                    residuals={"r_q": err_r, "Phi": err_phi})
            q = q + x[:nq]
            lam = lam + x[nq:]
            last = np.abs(x[:nq]).max(initial=0.0)
        return None, max_iter, "no convergence"

    def _multiplier_guess(q, mu, lam):
        """λ minimizing ‖−f + Φ_qᵀλ‖ at q: the reactions to the current loads.

        Starts Newton with the constraint (geometric) stiffness ∂(Φ_qᵀλ)/∂q
        of the new load level, without which a mechanism held only by its
        loads (a hanging pendulum) has a singular tangent.
        """
        f = assembly.force_vector(model, t, q, zero)
        if mu != 1.0:
            f = f - (1.0 - mu) * _external(model, groups, t, q, False)[0]
        B = assembly.constraint_jacobian(model, t, q).tocsc()
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                guess = spla.spsolve((B @ B.T).tocsc(), B @ f)
        except Exception:          # redundant constraints: keep the given λ
            return lam
        return guess if np.all(np.isfinite(guess)) else lam

    mus, Q, L, its = [], [], [], []
    sol, k, why = newton(0.0, q, lam)
    if sol is None:
        raise ConvergenceError(f"static equilibrium at zero load not found: {why}", t=t, step=0)
    q, lam = sol
    mus.append(0.0), Q.append(q.copy()), L.append(lam.copy()), its.append(k)
    if observer is not None:
        observer(0.0, q, lam, k)
    mu = 0.0
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
                    q_pred = Q[-1] + s * (Q[-1] - Q[-2])
                    l_pred = L[-1] + s * (L[-1] - L[-2])
                else:
                    q_pred, l_pred = q, lam
                sol, k, why = newton(trial, q_pred.copy(), l_pred.copy())
                if sol is None and q_pred is not q:
                    sol, k, why = newton(trial, q.copy(), lam.copy())
                if sol is not None:
                    break
                if abs(dmu) <= min_step:
                    raise ConvergenceError(
                        f"static Newton failed at load factor {trial:.6g} with increment {dmu:.3g} "
                        f"(last converged {mu:.6g}): {why}", t=t, step=len(mus))
                dmu *= 0.5
                step = dmu
            q, lam = sol
            mu = trial if abs(trial - target) > 1e-15 else target
            mus.append(mu), Q.append(q.copy()), L.append(lam.copy()), its.append(k)
            if observer is not None:
                observer(mu, q, lam, k)
    Qa = np.array(Q)
    return StaticResult(model=model, t=np.array(mus), q=Qa, qd=np.zeros_like(Qa), qdd=np.zeros_like(Qa),
                        lam=np.array(L).reshape(len(mus), nc), newton_iterations=np.array(its, dtype=np.int32),
                        status="success", message=f"reached load factor {mu:.6g} in {len(mus) - 1} steps",
                        settings={"t": t, "rtol": rtol, "atol": atol, "phi_tol": phi_tol, "xtol": xtol,
                                  "max_iter": max_iter, "min_step": min_step, "predictor": predictor},
                        time=float(t))
