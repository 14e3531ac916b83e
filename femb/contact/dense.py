"""A model's quantities for the contact step, evaluated into preallocated dense arrays.

:class:`DenseModel` is built once per model and step size class (small models, the dense path of
:class:`femb.contact.step.NonsmoothStep`): it keeps, per batch, the compiled kernel, the arrays
the kernel writes and the flat indices where its entries go in the global dense arrays, so that an
evaluation is one kernel call per batch and one scatter per output, with no sparse matrix built.
It computes what :mod:`femb.system.assembly` and :func:`femb.contact.assemble.evaluate` compute
(the same kernels, the same sums), in dense form:

* M (nq, nq) (constant, or assembled at q), f (nq,) with constant loads and gravity;
* K1 = −∂f/∂q + ∂(Φ_qᵀλ_g)/∂q − ∂(W_Nᵀλ_N + W_Fᵀλ_F)/∂q and C1 = −∂f/∂q̇ (nq, nq);
* Φ, Φ_t, γ (nc,), Φ_q (nc, nq), zero on equations removed as redundant;
* g_N, ζ_N (nN,), ζ_F (nF,), W_N (nN, nq), W_F (nF, nq).
"""
from __future__ import annotations

import numpy as np

from femb.base.jit import kernel
from femb.system import kernels


def _flat(rows, cols, ncols):
    return (np.asarray(rows, dtype=np.int64) * ncols + np.asarray(cols, dtype=np.int64)).ravel()


@kernel
def _add_at(flat, idx, vals, sel, sign):
    """flat[idx[a]] += sign vals[sel[a]] (unbuffered: repeated indices add up)."""
    for a in range(idx.size):
        flat[idx[a]] += sign * vals[sel[a]]


@kernel
def _put_at(flat, idx, vals, sel):
    """flat[idx[a]] = vals[sel[a]]."""
    for a in range(idx.size):
        flat[idx[a]] = vals[sel[a]]


def _entries(free_rows, free_cols, rows, cols, ncols):
    """(sel, idx): the flat positions in a kernel's (nel, a, b) output of the entries whose row and column
    are kept (``free_rows``, ``free_cols`` (nel, a), (nel, b) bool) and their flat global positions."""
    nel, a = rows.shape
    b = cols.shape[1]
    mask = (free_rows[:, :, None] & free_cols[:, None, :]).ravel()
    sel = np.nonzero(mask)[0].astype(np.int64)
    R = np.broadcast_to(rows[:, :, None], (nel, a, b)).ravel()[sel]
    C = np.broadcast_to(cols[:, None, :], (nel, a, b)).ravel()[sel]
    return sel, _flat(R, C, ncols)


class _Batch:
    """One batch's kernel, its preallocated outputs and the global positions of its entries."""

    def __init__(self, g, role, nq):
        self.g, self.role = g, role
        self.fn = kernels.compiled_kernel(g.cls.__name__, role, g.cls.kernels[role])[0]
        nel, nd = g.dofs.shape
        self.P, self.xdofs, self.dofs = g.P, g.xdofs, g.dofs
        self.static_tf = not any(len(row) for row in (g.time_functions or [[]]))
        self.tf = np.zeros((nel, 0, 3))
        self.xe = np.zeros(g.xdofs.shape)
        self.ve = np.zeros(g.dofs.shape)
        free = g.dofs < nq
        self.vec_sel = np.nonzero(free.ravel())[0].astype(np.int64)   # entries of (nel, nd) on free dofs
        self.vec_idx = g.dofs.ravel()[self.vec_sel].astype(np.int64)
        self.mat_sel, self.mat_idx = _entries(free, free, g.dofs, g.dofs, nq)
        self.Mat = np.zeros((nel, nd, nd))                            # fq / Me / H
        self.Mat2 = np.zeros((nel, nd, nd))                           # fv
        self.Vec = np.zeros((nel, nd))                                # fe

    def time_values(self, t):
        return self.tf if self.static_tf else kernels.time_values(self.g, t)

    def gather(self, qx, ux=None):
        np.take(qx, self.xdofs, out=self.xe)
        if ux is not None:
            np.take(ux, self.dofs, out=self.ve)


class DenseModel:
    """Dense evaluation of a model's M, f, Jacobians, constraints and contact operators (see the
    module docstring).

    Parameters
    ----------
    model : Model
        A compiled model (with or without contact batches).
    """

    def __init__(self, model):
        self.model = model
        n, m = model.nq, model.nc
        self.n, self.m = n, m
        self.k, self.l = int(getattr(model, "n_contacts", 0)), int(getattr(model, "n_friction", 0))
        self.mass = [_Batch(g, "mass", n) for g in model.mass_groups] if not model.constant_mass else []
        self.force = [_Batch(g, "force", n) for g in model.force_groups]
        self.cons = [_Batch(g, "constraint", n) for g in model.constraint_groups]
        self.rates = [_Batch(g, "rates", n) for g in model.constraint_groups]
        self.contact = [_Batch(g, "contact", n) for g in getattr(model, "contact_groups", [])]
        self._constraint_layout()
        self._contact_layout()
        act = getattr(model, "active_constraints", None)
        self.removed = np.zeros(0, dtype=np.int64) if act is None else np.nonzero(~np.asarray(act, bool))[0]
        self.M = model.M_const.toarray() if model.constant_mass else np.zeros((n, n))
        self.f, self.K1, self.C1 = np.zeros(n), np.zeros((n, n)), np.zeros((n, n))
        self.f0 = np.array(model.f_const[:n], dtype=float)
        self.Phi, self.Phi_t, self.gam, self.B = np.zeros(m), np.zeros(m), np.zeros(m), np.zeros((m, n))
        k, l = self.k, self.l
        self.gN, self.zN, self.zF = np.zeros(k), np.zeros(k), np.zeros(l)
        self.WN, self.WF = np.zeros((k, n)), np.zeros((l, n))

    def _constraint_layout(self):
        n = self.n
        for b, br in zip(self.cons, self.rates):
            g = b.g
            nel, nc, nd = g.nel, g.nc, g.nd
            b.lam = g.lam.ravel().astype(np.int64)
            b.all_sel = np.arange(nel * nc, dtype=np.int64)
            b.B_sel, b.B_idx = _entries(np.ones((nel, nc), bool), g.dofs < n, g.lam, g.dofs, n)
            b.le = np.zeros((nel, nc))
            b.Phi, b.Bk = np.zeros((nel, nc)), np.zeros((nel, nc, nd))
            br.Phi_t, br.gam = np.zeros((nel, nc)), np.zeros((nel, nc))

    def _contact_layout(self):
        n = self.n
        for b in self.contact:
            g = b.g
            nel, nd = g.dofs.shape
            kN, kF = g.cN.shape[1], g.cF.shape[1]
            r = kN + kF
            b.kN = kN
            rows = np.concatenate((g.cN, g.cF), axis=1).astype(np.int64)
            normal = np.zeros((nel, r), bool)
            normal[:, :kN] = True
            b.N_sel, b.N_idx = _entries(normal, g.dofs < n, rows, g.dofs, n)
            b.F_sel, b.F_idx = _entries(~normal, g.dofs < n, rows, g.dofs, n)
            b.zN_sel, b.zF_sel = np.nonzero(normal.ravel())[0], np.nonzero(~normal.ravel())[0]
            b.cN, b.cF = g.cN.ravel().astype(np.int64), g.cF.ravel().astype(np.int64)
            b.gN_sel = np.arange(nel * kN, dtype=np.int64)
            b.le = np.zeros((nel, r))
            b.G, b.W, b.Z = np.zeros((nel, kN)), np.zeros((nel, r, nd)), np.zeros((nel, r))

    # ------------------------------------------------------------------ evaluation
    def evaluate(self, t, q, u, lam_g, lam_N, lam_F, jac=True):
        """Fill the arrays (attributes) at (t, q, u) with the multipliers given (for the curvature
        terms of K1). Without ``jac`` only f, Φ, Φ_q, Φ_t, γ and the contact quantities."""
        model = self.model
        qx = np.concatenate((q, model.q_fixed))
        ux = np.concatenate((u, np.zeros(model.nfix_v)))
        t = float(t)
        jac = bool(jac)
        self.f[:] = self.f0
        if jac:
            self.K1.fill(0.0)
            self.C1.fill(0.0)
        self._mass(qx)
        self._forces(t, qx, ux, jac)
        self._constraints(t, qx, ux, lam_g, jac)
        self._contacts(t, qx, ux, lam_N, lam_F, jac)

    def _mass(self, qx):
        if not self.mass:
            return
        model = self.model
        self.M.fill(0.0)
        for b in self.mass:
            b.gather(qx)
            b.Mat.fill(0.0)
            b.fn(b.P, b.xe, b.Mat)
            _add_at(self.M.reshape(-1), b.mat_idx, b.Mat.reshape(-1), b.mat_sel, 1.0)
            if model.g_hat is not None:
                fe = np.einsum("eij,ej->ei", b.Mat, model.g_hat[b.dofs])
                _add_at(self.f, b.vec_idx, fe.reshape(-1), b.vec_sel, 1.0)

    def _forces(self, t, qx, ux, jac):
        for b in self.force:
            b.gather(qx, ux)
            for a in (b.Vec, b.Mat, b.Mat2):
                a.fill(0.0)
            b.fn(b.P, t, b.time_values(t), b.xe, b.ve, jac, b.Vec, b.Mat, b.Mat2)
            _add_at(self.f, b.vec_idx, b.Vec.reshape(-1), b.vec_sel, 1.0)
            if jac:
                _add_at(self.K1.reshape(-1), b.mat_idx, b.Mat.reshape(-1), b.mat_sel, -1.0)
                if b.g.traits.get("force_depends_on_qd", True):
                    _add_at(self.C1.reshape(-1), b.mat_idx, b.Mat2.reshape(-1), b.mat_sel, -1.0)

    def _constraints(self, t, qx, ux, lam_g, jac):
        if not self.cons:
            return
        self.B.fill(0.0)
        for b, br in zip(self.cons, self.rates):
            b.gather(qx, ux)
            if jac:
                np.take(lam_g, b.g.lam, out=b.le)
            else:
                b.le.fill(0.0)
            for a in (b.Phi, b.Bk, b.Mat, br.Phi_t, br.gam):
                a.fill(0.0)
            tf = b.time_values(t)
            b.fn(b.P, t, tf, b.xe, b.le, jac, b.Phi, b.Bk, b.Mat)
            _put_at(self.Phi, b.lam, b.Phi.reshape(-1), b.all_sel)
            _add_at(self.B.reshape(-1), b.B_idx, b.Bk.reshape(-1), b.B_sel, 1.0)
            if jac:
                _add_at(self.K1.reshape(-1), b.mat_idx, b.Mat.reshape(-1), b.mat_sel, 1.0)
            br.fn(b.P, t, tf, b.xe, b.ve, br.Phi_t, br.gam)
            _put_at(self.Phi_t, b.lam, br.Phi_t.reshape(-1), b.all_sel)
            _put_at(self.gam, b.lam, br.gam.reshape(-1), b.all_sel)
        if self.removed.size:
            for a in (self.Phi, self.Phi_t, self.gam, self.B):
                a[self.removed] = 0.0

    def _contacts(self, t, qx, ux, lam_N, lam_F, jac):
        if not self.contact:
            return
        self.WN.fill(0.0)
        self.WF.fill(0.0)
        for b in self.contact:
            b.gather(qx, ux)
            if jac:
                b.le[:, :b.kN] = lam_N[b.g.cN]
                b.le[:, b.kN:] = lam_F[b.g.cF]
            else:
                b.le.fill(0.0)
            for a in (b.G, b.W, b.Z, b.Mat):
                a.fill(0.0)
            b.fn(b.P, t, b.time_values(t), b.xe, b.ve, b.le, jac, b.G, b.W, b.Z, b.Mat)
            _put_at(self.gN, b.cN, b.G.reshape(-1), b.gN_sel)
            _put_at(self.zN, b.cN, b.Z.reshape(-1), b.zN_sel)
            _put_at(self.zF, b.cF, b.Z.reshape(-1), b.zF_sel)
            _add_at(self.WN.reshape(-1), b.N_idx, b.W.reshape(-1), b.N_sel, 1.0)
            _add_at(self.WF.reshape(-1), b.F_idx, b.W.reshape(-1), b.F_sel, 1.0)
            if jac:
                _add_at(self.K1.reshape(-1), b.mat_idx, b.Mat.reshape(-1), b.mat_sel, -1.0)
