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

import weakref

import numpy as np

from femb.contact.batches import evaluate_batches, records_list
from femb.system import kernels


def _flat(rows, cols, ncols):
    return (np.asarray(rows, dtype=np.int64) * ncols + np.asarray(cols, dtype=np.int64)).ravel()


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


def _i(a):
    return np.ascontiguousarray(a, dtype=np.int64)


def _record(g, kind, nq):
    """The record ``(meta, bf, bi)`` of one batch (femb/contact/batches.py); ``kind`` 0 force, 1 constraint,
    2 contact. Returns (record, time_values_array or None when the batch has no time functions)."""
    cls = g.cls
    role = ("force", "constraint", "contact")[kind]
    addr = kernels.compiled_kernel(cls.__name__, role, cls.kernels[role])[1]
    addr2 = kernels.compiled_kernel(cls.__name__, "rates", cls.kernels["rates"])[1] if kind == 1 else 0
    nel, nd = g.dofs.shape
    free = g.dofs < nq
    z1 = np.zeros(0, dtype=np.int64)
    vec_sel = np.nonzero(free.ravel())[0]
    mat_sel, mat_idx = _entries(free, free, g.dofs, g.dofs, nq)
    ntf = max((len(row) for row in (g.time_functions or [[]])), default=0)
    tf = np.zeros((nel, ntf, 3))
    if kind == 0:
        rows, a, kN, cF = np.zeros((nel, 0)), 0, 0, np.zeros((nel, 0))
        A_sel = A_idx = F_sel = F_idx = zN_sel = zF_sel = z1
        V2, V3a, V2b, V2c = np.zeros((nel, nd)), np.zeros((nel, nd, nd)), np.zeros((1, 1)), np.zeros((1, 1))
        le = np.zeros((1, 1))
    elif kind == 1:
        rows, a, kN, cF = g.lam, g.nc, 0, np.zeros((nel, 0))
        A_sel, A_idx = _entries(np.ones((nel, a), bool), free, rows, g.dofs, nq)
        F_sel = F_idx = zN_sel = zF_sel = z1
        V2, V3a, V2b, V2c = np.zeros((nel, a)), np.zeros((nel, a, nd)), np.zeros((nel, a)), np.zeros((nel, a))
        le = np.zeros((nel, a))
    else:
        kN, cF = g.cN.shape[1], g.cF
        rows, a = g.cN, kN + cF.shape[1]
        both = np.concatenate((g.cN, cF), axis=1)
        normal = np.zeros((nel, a), bool)
        normal[:, :kN] = True
        A_sel, A_idx = _entries(normal, free, both, g.dofs, nq)
        F_sel, F_idx = _entries(~normal, free, both, g.dofs, nq)
        zN_sel, zF_sel = np.nonzero(normal.ravel())[0], np.nonzero(~normal.ravel())[0]
        V2, V3a, V2b, V2c = np.zeros((nel, kN)), np.zeros((nel, a, nd)), np.zeros((nel, a)), np.zeros((1, 1))
        le = np.zeros((nel, a))
    damped = int(kind == 0 and bool(g.traits.get("force_depends_on_qd", True)))
    meta = np.array([kind, addr, addr2, damped, kN], dtype=np.int64)
    f = np.ascontiguousarray
    bf = (f(g.P, dtype=float), tf, np.zeros(g.xdofs.shape), np.zeros((nel, nd)), le, V2, V3a, V2b,
          np.zeros((nel, nd, nd)), V2c)
    bi = (_i(g.xdofs), _i(g.dofs), _i(rows), _i(vec_sel), _i(g.dofs.ravel()[vec_sel]), mat_sel, mat_idx,
          _i(A_sel), _i(A_idx), _i(F_sel), _i(F_idx), _i(zN_sel), _i(zF_sel), _i(cF))
    return (meta, bf, bi), (tf if ntf else None)


class DenseModel:
    """Dense evaluation of a model's M, f, Jacobians, constraints and contact operators (see the
    module docstring).

    Parameters
    ----------
    model : Model
        A compiled model (with or without contact batches).
    """

    def __init__(self, model):
        # a weak reference: femb.contact.step keeps one DenseModel per model in a WeakKeyDictionary, whose
        # entry a strong reference from the value would keep alive (and the model with it) for good
        self.model = weakref.proxy(model)
        n, m = model.nq, model.nc
        self.n, self.m = n, m
        self.k, self.l = int(getattr(model, "n_contacts", 0)), int(getattr(model, "n_friction", 0))
        self.mass = [] if model.constant_mass else list(model.mass_groups)
        self.mass_fn = [kernels.compiled_kernel(g.cls.__name__, "mass", g.cls.kernels["mass"])[0] for g in self.mass]
        self.mass_idx = [_entries(g.dofs < n, g.dofs < n, g.dofs, g.dofs, n) for g in self.mass]
        act = getattr(model, "active_constraints", None)
        self.removed = _i(np.zeros(0) if act is None else np.nonzero(~np.asarray(act, bool))[0])
        self.M = model.M_const.toarray() if model.constant_mass else np.zeros((n, n))
        self.f, self.K1, self.C1 = np.zeros(n), np.zeros((n, n)), np.zeros((n, n))
        self.f0 = np.array(model.f_const[:n], dtype=float)
        self.Phi, self.Phi_t, self.gam, self.B = np.zeros(m), np.zeros(m), np.zeros(m), np.zeros((m, n))
        k, l = self.k, self.l
        self.gN, self.zN, self.zF = np.zeros(k), np.zeros(k), np.zeros(l)
        self.WN, self.WF = np.zeros((k, n)), np.zeros((l, n))
        self.dq = tuple(a.reshape(-1) for a in (self.f, self.K1, self.C1, self.Phi, self.Phi_t, self.gam, self.B,
                                                self.gN, self.zN, self.zF, self.WN, self.WF))
        self._records()
        self.qx = np.concatenate((np.zeros(model.nx), model.q_fixed))
        self.ux = np.zeros(n + model.nfix_v)

    def _records(self):
        """The typed list of batch records (femb/contact/batches.py) and the batches with time functions."""
        model, n = self.model, self.n
        recs, self.timed = [], []
        for kind, groups in ((0, model.force_groups), (1, model.constraint_groups),
                             (2, getattr(model, "contact_groups", []))):
            for g in groups:
                rec, tf = _record(g, kind, n)
                recs.append(rec)
                if tf is not None:
                    self.timed.append((g, tf))
        self.recs = records_list(recs) if recs else None

    def time_values(self, t):
        """Refresh the time-function values (f, f', f'') of the batches that have them, at t."""
        for g, tf in self.timed:
            tf[...] = kernels.time_values(g, t)

    # ------------------------------------------------------------------ evaluation
    def evaluate(self, t, q, u, lam_g, lam_N, lam_F, jac=True):
        """Fill the arrays (attributes) at (t, q, u) with the multipliers given (for the curvature
        terms of K1). Without ``jac`` K1 and C1 are left as they are."""
        nx = q.size
        self.qx[:nx] = q
        self.ux[:self.n] = u
        f0 = self._mass(self.qx) if self.mass else self.f0
        self.time_values(t)
        if self.recs is not None:
            evaluate_batches(self.recs, float(t), self.qx, self.ux, (lam_g, lam_N, lam_F), bool(jac), self.dq,
                             f0, self.removed)
        else:
            self.f[:] = f0
            if jac:
                self.K1.fill(0.0)
                self.C1.fill(0.0)

    def _mass(self, qx):
        """M(q) and the constant forces with gravity M ĝ (configuration-dependent mass only)."""
        model = self.model
        self.M.fill(0.0)
        f0 = self.f0.copy()
        for g, fn, (sel, idx) in zip(self.mass, self.mass_fn, self.mass_idx):
            Me = np.zeros((g.nel, g.nd, g.nd))
            fn(g.P, np.ascontiguousarray(qx[g.xdofs]), Me)
            np.add.at(self.M.reshape(-1), idx, Me.reshape(-1)[sel])
            if model.g_hat is not None:
                fe = np.einsum("eij,ej->ei", Me, model.g_hat[g.dofs]).reshape(-1)
                sel_v = np.nonzero((g.dofs < self.n).ravel())[0]
                np.add.at(f0, g.dofs.ravel()[sel_v], fe[sel_v])
        return f0
