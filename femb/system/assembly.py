"""Assembly: pure functions from (model, state) to global M, f, Φ, Φ_q, K_t, C_t, S_t.

These documented functions (returning ``scipy.sparse`` matrices and numpy
vectors) are for users who write their own integrator, linearize, or check, and
for static and modal analysis. They call the same compiled element kernels as
the time loop (through :mod:`femb.system.kernels`); the solver's hot path is the
compiled engine (``femb/engine/``, run-time data from :mod:`femb.solve.codegen`).

Equations (Arnold & Brüls 2007): M q̈ = f − Φ_qᵀ λ, Φ = 0;
K_t = ∂(M q̈ − f + Φ_qᵀλ)/∂q, C_t = −∂f/∂q̇ (method.md eq. 7).
For a configuration-dependent mass matrix the term ∂(M q̈)/∂q is omitted from
K_t (a modified Newton method that converges to the same solution).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from femb.system import kernels


# --------------------------------------------------------------------------
# user-level functions
# --------------------------------------------------------------------------
def _ext(model, q, qd=None):
    qx = model.ext(np.asarray(q, dtype=float))
    qdx = None if qd is None else model.ext_velocity(np.asarray(qd, dtype=float))
    return qx, qdx


def _coo(groups, attr, blocks, shape):
    rows, cols, vals = [], [], []
    for g, B in zip(groups, blocks):
        if B is None:
            continue
        sel = getattr(g, attr + "_sel")
        rows.append(getattr(g, attr + "_rows"))
        cols.append(getattr(g, attr + "_cols"))
        vals.append(B.reshape(-1)[sel])
    if not rows:
        return sp.csr_matrix(shape)
    A = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=shape)
    A.sum_duplicates()
    return A


def _scatter(model, groups, blocks):
    n = model.nq + model.nfix
    out = np.zeros(n)
    for g, B in zip(groups, blocks):
        out += np.bincount(g.dofs.ravel(), B.ravel(), minlength=n)
    return out[:model.nq]


def _masked(model, v):
    """Zero the entries of eliminated (redundant) constraints."""
    act = getattr(model, "active_constraints", None)
    if act is not None:
        v[~np.asarray(act, dtype=bool)] = 0.0
    return v


def _masked_rows(model, g, B):
    act = getattr(model, "active_constraints", None)
    if act is not None:
        B = B.copy()
        B[~np.asarray(act, dtype=bool)[g.lam]] = 0.0
    return B


def mass_matrix(model, q=None):
    """Global mass matrix M(q), ``scipy.sparse.csr_matrix`` of shape (nq, nq)."""
    if model.constant_mass:
        return model.M_const.copy()
    qx, _ = _ext(model, q)
    return _coo(model.mass_groups, "nn", [kernels.mass(g, qx[g.xdofs]) for g in model.mass_groups],
                (model.nq, model.nq))


def force_vector(model, t, q, qd):
    """Global applied/internal force vector f(q, q̇, t), shape (nq,).

    Includes constant loads and gravity.
    """
    qx, qdx = _ext(model, q, qd)
    f = model.f_const.copy()
    f += _scatter(model, model.force_groups,
                  [kernels.force(g, t, qx[g.xdofs], qdx[g.dofs], False)[0] for g in model.force_groups])
    if model.g_hat is not None and not model.constant_mass:
        f += _scatter(model, model.mass_groups,
                      [np.einsum("eij,ej->ei", kernels.mass(g, qx[g.xdofs]), model.g_hat[g.dofs])
                       for g in model.mass_groups])
    return f


def force_jacobians(model, t, q, qd):
    """(∂f/∂q, ∂f/∂q̇) as csr matrices of shape (nq, nq)."""
    qx, qdx = _ext(model, q, qd)
    fq, fqd = [], []
    for g in model.force_groups:
        _, a, b = kernels.force(g, t, qx[g.xdofs], qdx[g.dofs], True)
        fq.append(a)
        fqd.append(b)
    shape = (model.nq, model.nq)
    return _coo(model.force_groups, "nn", fq, shape), _coo(model.force_groups, "nn", fqd, shape)


def _removed(model):
    """Indices of equations removed by ``compile(redundant="eliminate")`` (empty if none)."""
    act = getattr(model, "active_constraints", None)
    return np.zeros(0, dtype=np.int64) if act is None else np.nonzero(~np.asarray(act, dtype=bool))[0]


def constraint_vector(model, t, q):
    """Φ(q, t), shape (nc,); 0 on equations removed as redundant (``model.active_constraints``)."""
    qx, _ = _ext(model, q)
    Phi = np.zeros(model.nc)
    for g in model.constraint_groups:
        P, _, _ = kernels.constraint(g, t, qx[g.xdofs], jac=False)
        Phi[g.lam.ravel()] = P.ravel()
    return _masked(model, Phi)


def constraint_jacobian(model, t, q):
    """Φ_q(q, t), csr matrix of shape (nc, nq); zero rows for equations removed as redundant."""
    qx, _ = _ext(model, q)
    return _coo(model.constraint_groups, "cq",
                [_masked_rows(model, g, kernels.constraint(g, t, qx[g.xdofs], jac=False)[1])
                 for g in model.constraint_groups],
                (model.nc, model.nq))


def constraint_rates(model, t, q, qd):
    """(Φ_t, γ) with Φ_q q̈ = −γ, γ = (Φ_q q̇)_q q̇ + 2Φ_qt q̇ + Φ_tt; each shape (nc,) (0 on removed equations)."""
    qx, qdx = _ext(model, q, qd)
    Phi_t = np.zeros(model.nc)
    gam = np.zeros(model.nc)
    for g in model.constraint_groups:
        a, b = kernels.rates(g, t, qx[g.xdofs], qdx[g.dofs])
        Phi_t[g.lam.ravel()] = a.ravel()
        gam[g.lam.ravel()] = b.ravel()
    return _masked(model, Phi_t), _masked(model, gam)


def constraint_force(model, t, q, lam):
    """Φ_qᵀ λ, shape (nq,)."""
    return constraint_jacobian(model, t, q).T @ np.asarray(lam, dtype=float)


def tangent_stiffness(model, state):
    """K_t = ∂(M q̈ − f + Φ_qᵀλ)/∂q at ``state`` (csr, (nq, nq)).

    ∂(M q̈)/∂q is omitted for configuration-dependent mass (zero for the
    constant mass matrices of planar rigid bodies and beams).
    """
    qx, qdx = _ext(model, state.q, state.qd)
    f_q, _ = force_jacobians(model, state.t, state.q, state.qd)
    H = []
    for g in model.constraint_groups:
        H.append(kernels.constraint(g, state.t, qx[g.xdofs], state.lam[g.lam], jac=True)[2])
    K = -f_q + _coo(model.constraint_groups, "nn", H, (model.nq, model.nq))
    return K.tocsr()


def tangent_damping(model, state):
    """C_t = −∂f/∂q̇ at ``state`` (csr, (nq, nq))."""
    _, f_qd = force_jacobians(model, state.t, state.q, state.qd)
    return (-f_qd).tocsr()


def residual(model, state):
    """(r_q, r_λ) = (M q̈ − f + Φ_qᵀλ, Φ) at ``state``."""
    r_q = (mass_matrix(model, state.q) @ state.qdd - force_vector(model, state.t, state.q, state.qd)
           + constraint_force(model, state.t, state.q, state.lam))
    return r_q, constraint_vector(model, state.t, state.q)


def iteration_matrix(model, state, h, alpha, scaled=True):
    """The Newton iteration matrix S_t (method.md eq. 7), optionally scaled (eq. 8).

    Parameters
    ----------
    model : Model
    state : State
    h : float
        Step size.
    alpha : GeneralizedAlpha
    scaled : bool
        If True return D_L S_t D_R with D_L = diag(βh² I, I), D_R = diag(I, I/(βh²))
        (Bottasso, Dopico & Trainelli 2006).

    Equations removed as redundant (``model.active_constraints``) have a zero
    row and column and a 1 on the diagonal (the equation λ_i = 0).

    Returns
    -------
    scipy.sparse.csc_matrix, shape (nq + nc, nq + nc)
    """
    bp, gp = alpha.newton_factors(h)
    c = alpha.beta * h * h if scaled else 1.0
    top = c * (bp * mass_matrix(model, state.q) + gp * tangent_damping(model, state)
               + tangent_stiffness(model, state))
    B = constraint_jacobian(model, state.t, state.q)
    S = sp.bmat([[top, B.T], [B, None]], format="csc")
    rem = _removed(model)
    if rem.size:            # a removed equation is the trivial λ_i = 0
        d = np.zeros(model.nq + model.nc)
        d[model.nq + rem] = 1.0
        S = (S + sp.diags(d)).tocsc()
    return S


# --------------------------------------------------------------------------
# velocity-level (non-holonomic) constraints A(q, t) v + a(q, t) = 0
# --------------------------------------------------------------------------
def _rows_coo(model, blocks, nrow):
    """Sum (nel, k, nd) blocks of the velocity-constraint batches into a csr matrix (nn, nq)."""
    rows, cols, vals = [], [], []
    for g, B in zip(model.velocity_constraint_groups, blocks):
        nel, k, nd = B.shape
        R = np.broadcast_to(g.mu[:, :, None], B.shape).reshape(-1)
        C = np.broadcast_to(g.dofs[:, None, :], B.shape).reshape(-1)
        sel = C < model.nq
        rows.append(R[sel])
        cols.append(C[sel])
        vals.append(B.reshape(-1)[sel])
    if not rows:
        return sp.csr_matrix((nrow, model.nq))
    A = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(nrow, model.nq))
    A.sum_duplicates()
    return A


def velocity_constraints(model, t, q, qd):
    """Velocity constraints Ψ = A(q, t) v + a(q, t), their matrix A and Ψ_t = ∂Ψ/∂t.

    Parameters
    ----------
    model : Model
    t : float
    q : ndarray, shape (nx,)
    qd : ndarray, shape (nq,)
        Velocities v (body-axes Ω on rotation nodes).

    Returns
    -------
    Psi : ndarray, shape (nn,)
    A : scipy.sparse.csr_matrix, shape (nn, nq)
    Psi_t : ndarray, shape (nn,)
    """
    qx, qdx = _ext(model, q, qd)
    Psi, Psi_t, As = np.zeros(model.nn), np.zeros(model.nn), []
    for g in model.velocity_constraint_groups:
        P, A, Pt, _, _ = kernels.velocity_constraint(g, t, qx[g.xdofs], qdx[g.dofs], jac=False)
        Psi[g.mu.ravel()] = P.ravel()
        Psi_t[g.mu.ravel()] = Pt.ravel()
        As.append(A)
    return Psi, _rows_coo(model, As, model.nn), Psi_t


def velocity_constraint_jacobians(model, t, q, qd, mu):
    """(Ψ_q, ∂(Aᵀμ)/∂q): ``Dq = ∂Ψ/∂q`` (csr (nn, nq)) and ``H`` (csr (nq, nq)).

    Both along the model's perturbation q ∘ exp(δq) at fixed v (docs/kernels.md).
    """
    qx, qdx = _ext(model, q, qd)
    mu = np.asarray(mu, dtype=float)
    Ds, Hs = [], []
    for g in model.velocity_constraint_groups:
        _, _, _, D, H = kernels.velocity_constraint(g, t, qx[g.xdofs], qdx[g.dofs], mu[g.mu], jac=True)
        Ds.append(D)
        Hs.append(H)
    return (_rows_coo(model, Ds, model.nn),
            _coo(model.velocity_constraint_groups, "nn", Hs, (model.nq, model.nq)).tocsr())


def constraint_velocity_jacobian(model, t, q, qd):
    """∂(Φ_q v)/∂q along q ∘ exp(δq) at fixed v, csr (nc, nq).

    Row i is vᵀ H(e_i) with H(λ) = ∂(Φ_qᵀλ)/∂q the constraint kernel's Jacobian (one
    kernel call per constraint row of an element). Used to linearize the velocity level
    Φ_q v + Φ_t = 0 of holonomic constraints about a moving state.
    """
    qx, qdx = _ext(model, q, qd)
    blocks = []
    for g in model.constraint_groups:
        xe, ve = qx[g.xdofs], qdx[g.dofs]
        D = np.zeros((g.nel, g.nc, g.nd))
        for i in range(g.nc):
            le = np.zeros((g.nel, g.nc))
            le[:, i] = 1.0
            H = kernels.constraint(g, t, xe, le, jac=True)[2]
            D[:, i, :] = np.einsum("ejk,ej->ek", H, ve)
        blocks.append(_masked_rows(model, g, D))
    return _coo(model.constraint_groups, "cq", blocks, (model.nc, model.nq))
