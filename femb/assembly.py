"""Assembly: pure functions from (model, state) to global M, f, Φ, Φ_q, K_t, C_t, S_t.

Two layers share the same element kernels and index arrays:

* documented functions for users (returning ``scipy.sparse`` matrices and
  numpy vectors), to write one's own integrator, linearize, or check;
* :class:`Assembler`, the solver's hot path, which fills the iteration matrix
  into a storage whose sparsity was compiled once (a dense array for small
  systems, the data array of a fixed CSC structure for large ones), with one
  ``np.bincount`` per evaluation and no sorting.

Equations (Arnold & Brüls 2007): M q̈ = f − Φ_qᵀ λ, Φ = 0;
K_t = ∂(M q̈ − f + Φ_qᵀλ)/∂q, C_t = −∂f/∂q̇ (method.md eq. 7).
For a configuration-dependent mass matrix the term ∂(M q̈)/∂q is omitted from
K_t (a modified Newton method that converges to the same solution).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp


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


def mass_matrix(model, q=None):
    """Global mass matrix M(q), ``scipy.sparse.csr_matrix`` of shape (nq, nq)."""
    if model.constant_mass:
        return model.M_const.copy()
    qx, _ = _ext(model, q)
    return _coo(model.mass_groups, "nn", [g.cls.mass(g.params, qx[g.dofs]) for g in model.mass_groups],
                (model.nq, model.nq))


def force_vector(model, t, q, qd):
    """Global applied/internal force vector f(q, q̇, t), shape (nq,).

    Includes constant loads and gravity.
    """
    qx, qdx = _ext(model, q, qd)
    f = model.f_const.copy()
    f += _scatter(model, model.force_groups,
                  [g.cls.force(g.params, t, qx[g.dofs], qdx[g.dofs], False)[0] for g in model.force_groups])
    if model.g_hat is not None and not model.constant_mass:
        f += _scatter(model, model.mass_groups,
                      [np.einsum("eij,ej->ei", g.cls.mass(g.params, qx[g.dofs]), model.g_hat[g.dofs])
                       for g in model.mass_groups])
    return f


def force_jacobians(model, t, q, qd):
    """(∂f/∂q, ∂f/∂q̇) as csr matrices of shape (nq, nq)."""
    qx, qdx = _ext(model, q, qd)
    fq, fqd = [], []
    for g in model.force_groups:
        _, a, b = g.cls.force(g.params, t, qx[g.dofs], qdx[g.dofs], True)
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
        P, _ = g.cls.constraint(g.params, t, qx[g.dofs])
        Phi[g.lam.ravel()] = P.ravel()
    Phi[_removed(model)] = 0.0
    return Phi


def constraint_jacobian(model, t, q):
    """Φ_q(q, t), csr matrix of shape (nc, nq); zero rows for equations removed as redundant."""
    qx, _ = _ext(model, q)
    B = _coo(model.constraint_groups, "cq",
             [g.cls.constraint(g.params, t, qx[g.dofs])[1] for g in model.constraint_groups],
             (model.nc, model.nq))
    rem = _removed(model)
    if rem.size:
        keep = np.ones(model.nc)
        keep[rem] = 0.0
        B = (sp.diags(keep) @ B).tocsr()
        B.eliminate_zeros()
    return B


def constraint_rates(model, t, q, qd):
    """(Φ_t, γ) with Φ_q q̈ = −γ, γ = (Φ_q q̇)_q q̇ + 2Φ_qt q̇ + Φ_tt; each shape (nc,) (0 on removed equations)."""
    qx, qdx = _ext(model, q, qd)
    Phi_t = np.zeros(model.nc)
    gam = np.zeros(model.nc)
    for g in model.constraint_groups:
        a, b = g.cls.constraint_rates(g.params, t, qx[g.dofs], qdx[g.dofs])
        Phi_t[g.lam.ravel()] = a.ravel()
        gam[g.lam.ravel()] = b.ravel()
    rem = _removed(model)
    Phi_t[rem] = 0.0
    gam[rem] = 0.0
    return Phi_t, gam


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
        H.append(g.cls.constraint_hessian(g.params, state.t, qx[g.dofs], state.lam[g.lam]))
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
# the solver's hot path
# --------------------------------------------------------------------------
class Assembler:
    """Residual and iteration matrix with sparsity compiled once.

    Parameters
    ----------
    model : Model
    dense : bool
        Fill a dense (N, N) array (small systems, LAPACK LU) or the data array
        of a fixed CSC structure (large systems, SuperLU).

    Notes
    -----
    ``evaluate`` returns the residual and, when asked, the matrix
    [[cM M + cC C_t + cK K_t, Φ_qᵀ], [Φ_q, 0]]; with cM = c β', cC = c γ',
    cK = c and c = βh² (scaled) or 1 (unscaled) this is S_t of method.md.
    """

    def __init__(self, model, dense):
        self.model = model
        self.dense = bool(dense)
        nq, nc = model.nq, model.nc
        self.N = N = nq + nc
        self.next = nq + model.nfix
        R, C = [], []   # all structural entries, in evaluation order

        def add(rows, cols):
            R.append(np.asarray(rows, dtype=np.int64))
            C.append(np.asarray(cols, dtype=np.int64))
            return len(R) - 1

        slots = {}
        if model.constant_mass:
            Mc = model.M_const.tocoo()
            self.M_vals = Mc.data.copy()
            slots["M"] = add(Mc.row, Mc.col)
            self.M_dense = model.M_const.toarray() if nq <= 400 else None
        else:
            for g in model.mass_groups:
                slots[("M", id(g))] = add(g.nn_rows, g.nn_cols)
        for g in model.force_groups:
            slots[("K", id(g))] = add(g.nn_rows, g.nn_cols)
            if g.traits["force_depends_on_qd"]:
                slots[("C", id(g))] = add(g.nn_rows, g.nn_cols)
        for g in model.constraint_groups:
            slots[("B", id(g))] = add(nq + g.cq_rows, g.cq_cols)
            slots[("Bt", id(g))] = add(g.cq_cols, nq + g.cq_rows)
            slots[("H", id(g))] = add(g.nn_rows, g.nn_cols)
        allR = np.concatenate(R) if R else np.zeros(0, np.int64)
        allC = np.concatenate(C) if C else np.zeros(0, np.int64)
        if self.dense:
            key = allC * N + allR     # column-major: the reshaped array's transpose is Fortran-ordered
            self.size = N * N
            tg = key
        else:
            key = allC * N + allR          # column-major order = CSC order
            ukey, inv = np.unique(key, return_inverse=True)
            self.size = ukey.size
            self.indices = (ukey % N).astype(np.int32)
            cols = ukey // N
            self.indptr = np.searchsorted(cols, np.arange(N + 1)).astype(np.int32)
            tg = inv
        bounds = np.cumsum([0] + [r.size for r in R])
        tgt = {k: tg[bounds[i]:bounds[i + 1]] for k, i in slots.items()}
        # Evaluation plans: per batch, the kernel and every index array it needs.
        # The matrix values are produced in a fixed order, so the scatter targets
        # are concatenated once here and the hot loop only concatenates values.
        order = []
        self.fplan = []
        for g in model.force_groups:
            has_c = g.traits["force_depends_on_qd"]
            self.fplan.append((g.cls.force, g.params, g.dofs, g.nn_sel, has_c, g.nn_sel.size))
            order.append(tgt[("K", id(g))])
            if has_c:
                order.append(tgt[("C", id(g))])
        self.cplan = []
        for g in model.constraint_groups:
            rows = g.lam.ravel()
            sl = slice(int(rows[0]), int(rows[-1]) + 1)
            self.cplan.append((g.cls.constraint_all, g.params, g.dofs, sl, g.lam.shape, g.cq_sel,
                               g.nn_sel, g.nn_sel.size))
            order += [tgt[("B", id(g))], tgt[("Bt", id(g))], tgt[("H", id(g))]]
        if model.constant_mass:
            order.append(tgt["M"])
        else:
            for g in model.mass_groups:
                order.append(tgt[("M", id(g))])
        self.tg_all = np.concatenate(order) if order else np.zeros(0, np.int64)
        idx = [g.dofs.ravel() for g in model.force_groups] + [g.dofs.ravel() for g in model.constraint_groups]
        self.w_idx = np.concatenate(idx) if idx else np.zeros(0, np.int64)
        self.weight = model.force_weight                  # moments → forces (1/L on rotation rows)
        self.w_weight = model.force_weight_ext[self.w_idx]
        self.f_const_max = float(np.abs(model.f_const * self.weight).max(initial=0.0))
        # equations removed as redundant (compile(redundant="eliminate")): Φ_i = 0, λ_i = 0
        self.removed = _removed(model)
        self.keep = None
        if self.removed.size:
            self.keep = np.ones(N)
            self.keep[nq + self.removed] = 0.0

    def mass_times(self, qx, qdd):
        """M q̈."""
        m = self.model
        if m.constant_mass:
            return self.M_dense @ qdd if self.M_dense is not None else m.M_const @ qdd
        out = np.zeros(self.next)
        qe = np.zeros(self.next)
        qe[:m.nq] = qdd
        for g in m.mass_groups:
            Me = g.cls.mass(g.params, qx[g.dofs])
            out += np.bincount(g.dofs.ravel(), np.einsum("eij,ej->ei", Me, qe[g.dofs]).ravel(), minlength=self.next)
        return out[:m.nq]

    def evaluate(self, t, qx, qdx, qdd, lam, jac=False, cM=0.0, cC=0.0, cK=0.0):
        """Residual blocks and (optionally) the iteration matrix.

        Parameters
        ----------
        t : float
        qx, qdx : ndarray, shape (nq + nfix,)
            Extended coordinates and velocities.
        qdd : ndarray, shape (nq,)
        lam : ndarray, shape (nc,)
        jac : bool
            Also assemble the matrix.
        cM, cC, cK : float
            Factors of M, C_t, K_t in the top-left block.

        Returns
        -------
        r_q : ndarray (nq,)
            M q̈ − f + Φ_qᵀλ.
        Phi : ndarray (nc,)
        scale : float
            The force scale of the residual: the largest of ‖M q̈‖∞, ‖f_const‖∞
            and every element's force and constraint-force entry, with moment
            rows divided by the length scale (``model.force_weight``).
        S : ndarray (N, N), scipy.sparse.csc_matrix or None
        """
        m = self.model
        nq = m.nq
        Mqdd = self.mass_times(qx, qdd)
        vals = []
        w = []                      # element force vectors: −f_e and (Φ_qᵀλ)_e, scattered at once
        for kernel, p, dofs, sel, has_c, nsel in self.fplan:
            fe, fq, fqd = kernel(p, t, qx[dofs], qdx[dofs], jac)
            w.append(fe.ravel())
            if jac:
                vals.append((-cK) * fq.reshape(-1)[sel])
                if has_c:
                    vals.append((-cC) * fqd.reshape(-1)[sel] if fqd is not None else np.zeros(nsel))
        nf = len(w)
        Phi = np.empty(m.nc)
        for kernel, p, dofs, sl, shape, cq_sel, nn_sel, nsel in self.cplan:
            le = lam[sl].reshape(shape)
            P, Pq, H = kernel(p, t, qx[dofs], le, jac)
            Phi[sl] = P.ravel()
            w.append(np.einsum("ecd,ec->ed", Pq, le).ravel())
            if jac:
                b = Pq.reshape(-1)[cq_sel]
                vals.append(b)
                vals.append(b)
                vals.append(cK * H.reshape(-1)[nn_sel] if H is not None else np.zeros(nsel))
        if self.keep is not None:
            Phi[self.removed] = 0.0
        r_q = Mqdd - m.f_const
        scale = max(np.abs(Mqdd * self.weight).max(), self.f_const_max)
        if w:
            if nf:
                w[:nf] = [-x for x in w[:nf]]
            wv = np.concatenate(w)
            r_q += np.bincount(self.w_idx, wv, minlength=self.next)[:nq]
            scale = max(scale, np.abs(wv * self.w_weight).max())
        if m.g_hat is not None and not m.constant_mass:
            for g in m.mass_groups:
                Me = g.cls.mass(g.params, qx[g.dofs])
                fg = np.bincount(g.dofs.ravel(), np.einsum("eij,ej->ei", Me, m.g_hat[g.dofs]).ravel(),
                                 minlength=self.next)[:nq]
                r_q -= fg
                scale = max(scale, np.abs(fg * self.weight).max())
        if not jac:
            return r_q, Phi, scale, None
        if m.constant_mass:
            vals.append(cM * self.M_vals)
        else:
            for g in m.mass_groups:
                Me = g.cls.mass(g.params, qx[g.dofs])
                vals.append(cM * Me.reshape(-1)[g.nn_sel])
        data = np.bincount(self.tg_all, np.concatenate(vals), minlength=self.size)
        if self.dense:
            S = data.reshape(self.N, self.N).T     # Fortran-ordered view, no copy for LAPACK
        else:
            S = sp.csc_matrix((data, self.indices, self.indptr), shape=(self.N, self.N))
        if self.keep is not None:                  # removed equations: the trivial λ_i = 0
            if self.dense:
                S *= self.keep[:, None]
                S *= self.keep[None, :]
                S[nq + self.removed, nq + self.removed] = 1.0
            else:
                S = (sp.diags(self.keep) @ S @ sp.diags(self.keep) + sp.diags(1.0 - self.keep)).tocsc()
        return r_q, Phi, scale, S
