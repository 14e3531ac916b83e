"""The run-time data of a model for the one compiled engine (:mod:`femb.engine`).

:class:`Compiled` holds, computed once per model, what the engine needs besides
the state: the arrays of every element batch (parameters, index arrays, scatter
targets, work arrays) as one pack ``G``, the model constants as a pack ``C``,
among them the *batch table* (role of each batch, where its arrays start in ``G``
and the addresses of its compiled kernels, :func:`femb.system.kernels.compiled_kernel`),
the sparsity of the iteration matrix and its bandwidth-reducing ordering.
Nothing here generates or compiles code: the engine is compiled once per
installation and each element type's kernels once.
"""
from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import reverse_cuthill_mckee

from femb.base.jit import pack
from femb.engine import layout as _S
from femb.errors import ModelError, ParameterError

#: largest system stored densely (its LU skips zeros); larger ones always use the band storage
DENSE_MAX = 400
#: systems up to this size are always stored densely
DENSE_SMALL = 128
#: the arrays of each batch, in the order they are packed into G: defined beside their numbers
#: in femb/engine/layout.py (F_*, K_*)
FORCE_FIELDS = _S.FORCE_FIELDS
CONSTRAINT_FIELDS = _S.CONSTRAINT_FIELDS
VELOCITY_FIELDS = _S.VELOCITY_FIELDS
#: the model constants packed into C, by name: ``C_FIELDS`` of femb/engine/layout.py


# --------------------------------------------------------------------------
# per-model run-time data
# --------------------------------------------------------------------------
def _i64(a):
    return np.ascontiguousarray(a, dtype=np.int64)


def _f64(a):
    return np.ascontiguousarray(a, dtype=np.float64)


class Compiled:
    """The compiled functions of a model's kind and the model's run-time data.

    Attributes
    ----------
    mod : module
        The engine, :mod:`femb.engine` (``evaluate``, ``rates``, ``run``, ...).
    G : tuple (F, I, L)
        The arrays of every batch (parameters, index arrays, scatter targets, work
        arrays; :data:`FORCE_FIELDS`, :data:`CONSTRAINT_FIELDS`) as one pack
        (:func:`femb.base.jit.pack`); ``Gv`` the same arrays as numpy views.
    C : tuple (F, I, L)
        Model constants (mass matrix, permutation, weights, ...; their kinds in
        ``C_FIELDS`` of femb/engine/layout.py, their meaning where ``femb/engine/`` reads them) as
        one pack; ``Cv[k]`` constant k as a numpy view.
    N, kl, ku, ldab : int
        Unknowns nq + nc + nn (nq + 2 nc with the index-2 layout) and the band of the
        permuted iteration matrix. The nn velocity-constraint (non-holonomic) rows and their
        multipliers μ follow the nc holonomic ones: the engine's multiplier vector is [λ; μ].
    layout : {"index3", "index2"}
        "index2" adds nc rows and columns for the stabilized index-2 step
        (``newton_step`` in femb/engine/newton.py, index 2): the velocity constraint rows
        (B in the q̇ columns) and the unknowns η, coupled to the Φ rows by
        B(q) B(q_n)ᵀ. Its ``evaluate`` puts the identity on the η block, so
        that the constrained-acceleration solves of the index-3 layout work
        unchanged on it. The index-3 layout is the one of every index-3 run.
    """

    def __init__(self, model, ordering="rcm", layout="index3"):
        t0 = time.perf_counter()
        self.model = model
        self.layout = layout
        ggl = layout == "index2"
        nv, nc, nn = model.nq, model.nc, getattr(model, "nn", 0)
        if ggl and nn:
            raise ParameterError(f"formulation='index2': model '{model.name}' has {nn} velocity-level "
                                 "(non-holonomic) constraints, which the stabilized index-2 step does not take; "
                                 "use formulation='index3' (its velocity rows hold them exactly at every step)")
        self.N = N = nv + 2 * nc if ggl else nv + nc + nn
        active = np.ones(nc, dtype=np.int8) if getattr(model, "active_constraints", None) is None \
            else np.asarray(model.active_constraints, dtype=np.int8)
        # the engine's multipliers are [λ; μ]: velocity-constraint rows are always active
        active = np.concatenate((active, np.ones(nn, dtype=np.int8)))
        Mc = model.M_const.tocsr()
        Mc.sort_indices()
        flat = _index2_entries(model, active) if ggl else None
        rows, cols = _pattern(model, Mc, active, flat, N)
        perm, iperm = self._order(rows, cols, ordering)
        target = self._storage(iperm)
        _check_parameters(model)
        self.G, self.Gv = pack(_batch_arrays(model, target, active))
        index2 = _index2_targets(target, flat, active, nv, nc)
        C = _constants(model, Mc, perm, iperm, active, index2, target)
        C.update(env=self.env, gglw=np.zeros((4, nc if ggl else 0)), batches=self.batch_table(model),
                 lamz=np.zeros(nc + nn))
        #: the constants as one pack (F, I, L) for the compiled code, and as numpy views (Cv[k]),
        #: in the order of C_FIELDS (femb/engine/layout.py), by name
        self.C, self.Cv = pack(_S.named_arrays(_S.C_FIELDS, C, "C"))
        self.tfv = self.Cv[_S.C_TFV]
        self.python_tf = model.time_function_table["python"]
        from femb import engine
        from femb.base.jit import cache_writable
        if engine.ensure_engine() and cache_writable():
            # compiled now: the built-in element types' kernels follow in the background
            from femb.solve.cache import start_background_build
            start_background_build()
        #: the engine (femb/engine/): entry points ``run``, ``evaluate``, ``rates``, ...
        self.mod = engine
        self.setup_time = time.perf_counter() - t0

    def _order(self, rows, cols, ordering):
        """The bandwidth-reducing ordering of the iteration matrix and its storage kind.

        Sets ``kl``, ``ku`` (band), ``env`` (:func:`_envelope`), ``dense`` and ``ordering``.

        Returns
        -------
        perm, iperm : ndarray (N,) int64
            Unknown ``perm[k]`` is row k of the ordered matrix; ``iperm`` the inverse.
        """
        N, nv = self.N, self.model.nq
        pat = sp.csr_matrix((np.ones(rows.size), (rows, cols)), shape=(N, N))
        perm = _band_ordering(pat, nv) if ordering == "rcm" else np.arange(N, dtype=np.int64)
        iperm = np.empty(N, dtype=np.int64)
        iperm[perm] = np.arange(N)
        pr, pc = iperm[rows], iperm[cols]
        if ordering == "rcm":
            self.kl = kl = int(max(0, (pr - pc).max()))
            self.ku = ku = int(max(0, (pc - pr).max()))
        else:
            self.kl = kl = self.ku = ku = N - 1
        self.ordering = ordering
        # storage: band (LAPACK gbtrf layout, transposed) when the band is narrow, else a dense
        # row-major array whose LU skips zeros (small mechanisms with closed loops)
        self.env = _envelope(pr, pc, N, kl, ku)
        band_flops = int(((self.env[0] - np.arange(N)) * (self.env[1] - np.arange(N))).sum())
        # small systems: the zero-skipping dense LU (measured faster on Andrews' 41 unknowns than
        # the band LU, whose band the closed loops make wide); up to DENSE_MAX when the band's
        # work exceeds that of the dense scans
        self.dense = bool(ordering != "rcm" or N <= DENSE_SMALL
                          or (N <= DENSE_MAX and band_flops > 4 * N * N))
        if self.dense and ordering == "rcm":
            # the zero-skipping LU's fill follows reverse Cuthill–McKee of the whole matrix best
            perm = np.asarray(reverse_cuthill_mckee((pat + pat.T).tocsr(), symmetric_mode=True), dtype=np.int64)
            iperm = np.empty(N, dtype=np.int64)
            iperm[perm] = np.arange(N)
        return perm, iperm

    def _storage(self, iperm):
        """Sizes of the matrix storage and its pivots (``ldab``, ``storage_size``, ``piv_size``);
        returns the map of matrix entries to storage positions (:class:`_Targets`)."""
        N = self.N
        if self.dense:
            self.ldab = N
            self.storage_size = N * N
            # pivots and the nonzero pattern of the factors (femb/engine/linalg.py, dense_lu)
            self.piv_size = 3 * N + 2 * N * N
        else:
            self.ldab = 2 * self.kl + self.ku + 1
            self.storage_size = N * self.ldab
            self.piv_size = 2 * N
        return _Targets(iperm, N, self.dense, self.kl + self.ku, self.ldab)

    @staticmethod
    def batch_table(model):
        """(nbatch, NB) int64: per batch its role, first array in G, q̇ flag and kernel addresses
        (columns ``B_*`` of :mod:`femb.engine.layout`)."""
        from femb.system.kernels import compiled_kernel
        nF = len(model.force_groups)
        nK = len(model.constraint_groups)
        vgroups = list(getattr(model, "velocity_constraint_groups", ()))
        table = np.zeros((nF + nK + len(vgroups), _S.NB), dtype=np.int64)
        for gi, g in enumerate(model.force_groups):
            row = table[gi]
            row[_S.B_ROLE] = _S.ROLE_FORCE
            row[_S.B_BASE] = len(FORCE_FIELDS) * gi
            row[_S.B_HASC] = int(bool(g.traits["force_depends_on_qd"]))
            row[_S.B_KERNEL] = compiled_kernel(g.cls.__name__, "force", g.cls.kernels["force"])[1]
        for gi, g in enumerate(model.constraint_groups):
            row = table[nF + gi]
            row[_S.B_ROLE] = _S.ROLE_CONSTRAINT
            row[_S.B_BASE] = len(FORCE_FIELDS) * nF + len(CONSTRAINT_FIELDS) * gi
            row[_S.B_KERNEL] = compiled_kernel(g.cls.__name__, "constraint", g.cls.kernels["constraint"])[1]
            row[_S.B_RATES] = compiled_kernel(g.cls.__name__, "rates", g.cls.kernels["rates"])[1]
        base = len(FORCE_FIELDS) * nF + len(CONSTRAINT_FIELDS) * nK
        for gi, g in enumerate(vgroups):
            row = table[nF + nK + gi]
            row[_S.B_ROLE] = _S.ROLE_VELOCITY
            row[_S.B_BASE] = base + len(VELOCITY_FIELDS) * gi
            row[_S.B_KERNEL] = compiled_kernel(g.cls.__name__, "velocity_constraint",
                                               g.cls.kernels["velocity_constraint"])[1]
        return table


class _Targets:
    """Position of entry (r, c) of the iteration matrix (original numbering) in its storage: the
    dense row-major array or the band (LAPACK gbtrf layout, transposed; ``d`` = kl + ku)."""

    def __init__(self, iperm, N, dense, d, ldab):
        self.iperm, self.N, self.dense, self.d, self.ldab = iperm, N, dense, d, ldab

    def __call__(self, r_, c_):
        r_ = np.asarray(r_, dtype=np.int64)
        c_ = np.asarray(c_, dtype=np.int64)
        iperm = self.iperm
        if self.dense:
            return iperm[r_] * self.N + iperm[c_]
        return iperm[c_] * self.ldab + self.d + iperm[r_] - iperm[c_]


def _index2_entries(model, active):
    """The index-2 layout's flat element blocks of B (batch, element, row, column).

    Returns
    -------
    (fl_c, fl_d, valid, k1, k2)
        Constraint and coordinate of each flat entry (−1 when fixed or inactive), the valid
        entries, and the pairs of entries in the same column (the products of B(q) B(q_n)ᵀ).
    """
    nv = model.nq
    fl_c, fl_d = [], []
    for g in model.constraint_groups:
        nel, nd = g.dofs.shape
        cc = np.broadcast_to(g.lam[:, :, None], (nel, g.nc, nd)).reshape(-1)
        dd = np.broadcast_to(g.dofs[:, None, :], (nel, g.nc, nd)).reshape(-1)
        ok = (dd < nv) & (active[cc] != 0)
        fl_c.append(np.where(ok, cc, -1))
        fl_d.append(np.where(ok, dd, -1))
    fl_c = np.concatenate(fl_c).astype(np.int64) if fl_c else np.zeros(0, dtype=np.int64)
    fl_d = np.concatenate(fl_d).astype(np.int64) if fl_d else np.zeros(0, dtype=np.int64)
    valid = np.nonzero(fl_c >= 0)[0]
    order = valid[np.argsort(fl_d[valid], kind="stable")]
    dsort = fl_d[order]
    starts = np.flatnonzero(np.r_[True, dsort[1:] != dsort[:-1]]) if order.size else np.zeros(0, int)
    ends = np.r_[starts[1:], order.size]
    k1, k2 = [], []
    for a_, b_ in zip(starts, ends):
        ks = order[a_:b_]
        k1.append(np.repeat(ks, ks.size))
        k2.append(np.tile(ks, ks.size))
    k1 = np.concatenate(k1).astype(np.int64) if k1 else np.zeros(0, dtype=np.int64)
    k2 = np.concatenate(k2).astype(np.int64) if k2 else np.zeros(0, dtype=np.int64)
    return fl_c, fl_d, valid, k1, k2


def _pattern(model, Mc, active, flat, N):
    """Rows and columns of the structural nonzeros of the iteration matrix (original numbering):
    M, the element blocks, B and Bᵀ, the inactive constraints' diagonal, the index-2 rows and
    columns (``flat`` from :func:`_index2_entries`, or None) and the whole diagonal."""
    nv, nc = model.nq, model.nc
    Mcoo = Mc.tocoo()
    R, Cc = [Mcoo.row], [Mcoo.col]
    for g in model.force_groups + model.constraint_groups:
        R.append(g.nn_rows)
        Cc.append(g.nn_cols)
    for g in model.constraint_groups:
        R += [nv + g.cq_rows, g.cq_cols]
        Cc += [g.cq_cols, nv + g.cq_rows]
    for g in getattr(model, "velocity_constraint_groups", ()):
        rr, cc = _velocity_rows(g, nc, nv)
        R += [nv + rr, cc, g.nn_rows]
        Cc += [cc, nv + rr, g.nn_cols]
    inactive = np.nonzero(active == 0)[0]
    R.append(nv + inactive)
    Cc.append(nv + inactive)
    if flat is not None:
        fl_c, fl_d, valid, k1, k2 = flat
        # velocity rows: B in the q̇ columns; Φ rows, η columns: B(q) B(q_n)ᵀ
        R += [nv + nc + fl_c[valid], nv + fl_c[k1]]
        Cc += [fl_d[valid], nv + nc + fl_c[k2]]
    R.append(np.arange(N))       # the diagonal, so that every unknown is in the graph
    Cc.append(np.arange(N))
    return np.concatenate(R).astype(np.int64), np.concatenate(Cc).astype(np.int64)


def _velocity_rows(g, nc, nv):
    """Row (in the multipliers [λ; μ]) and free column of each entry of a velocity-constraint batch's A."""
    nel, nd = g.dofs.shape
    R = np.broadcast_to(nc + g.mu[:, :, None], (nel, g.nn, nd)).reshape(-1)
    C = np.broadcast_to(g.dofs[:, None, :], (nel, g.nn, nd)).reshape(-1)
    ok = C < nv
    return R[ok], C[ok]


def _index2_targets(target, flat, active, nv, nc):
    """Storage positions of the index-2 layout (empty arrays for index 3) and of the diagonal
    entries set to 1 (inactive constraints; the η block).

    Returns
    -------
    dict
        fl (nB, 3): constraint, coordinate and velocity-row target of each flat entry of B;
        pairs (np, 3): entry, entry and target of each product of B(q) B(q_n)ᵀ; teta: the η
        diagonal of active constraints (−1 otherwise); ti: the unit diagonal; bw (3, nB) work.
    """
    inactive = np.nonzero(active == 0)[0]
    if flat is None:
        z = np.zeros(0, dtype=np.int64)
        return dict(fl=np.zeros((0, 3), dtype=np.int64), pairs=np.zeros((0, 3), dtype=np.int64), teta=z,
                    ti=_i64(target(nv + inactive, nv + inactive)), bw=np.zeros((3, 0)))
    fl_c, fl_d, valid, k1, k2 = flat
    tG = np.full(fl_c.size, -1, dtype=np.int64)
    tG[valid] = target(nv + nc + fl_c[valid], fl_d[valid])
    pairs = np.stack((k1, k2, target(nv + fl_c[k1], nv + nc + fl_c[k2])), axis=1).astype(np.int64)
    eta_diag = target(nv + nc + np.arange(nc), nv + nc + np.arange(nc))
    return dict(fl=np.ascontiguousarray(np.stack((fl_c, fl_d, tG), axis=1).astype(np.int64)), pairs=pairs,
                teta=_i64(np.where(active != 0, eta_diag, -1)),
                ti=_i64(np.concatenate((target(nv + inactive, nv + inactive), eta_diag))),
                bw=np.zeros((3, fl_c.size)))


def _check_parameters(model):
    """Every batch's parameter array P is (elements, parameters)."""
    for g in model.force_groups + model.constraint_groups + list(getattr(model, "velocity_constraint_groups", ())):
        if g.P.ndim != 2:
            raise ModelError(f"{g.name}: its parameter array P must have shape (elements, parameters), "
                             f"got shape {g.P.shape}")


def _nn_targets(g, target, nv):
    """Storage position of each entry of the batch's element matrices (−1: a fixed coordinate)."""
    dofs = g.dofs
    nel, nd = dofs.shape
    Rr = np.broadcast_to(dofs[:, :, None], (nel, nd, nd))
    Cr = np.broadcast_to(dofs[:, None, :], (nel, nd, nd))
    t = np.full((nel, nd, nd), -1, dtype=np.int64)
    ok = (Rr < nv) & (Cr < nv)
    t[ok] = target(Rr[ok], Cr[ok])
    return t


def _tangent_blocks(g, block_of):
    """Rotation blocks: T(Δθ) of each free rotation multiplies the element columns of its rotation
    vector in the Newton matrix (tblk[e, k] = (first column in the element, block))."""
    rows = [[(i, block_of[int(d)]) for i, d in enumerate(e) if int(d) in block_of] for e in g.dofs]
    k = max([len(r_) for r_ in rows] + [0])
    out = np.full((len(rows), k, 2), -1, dtype=np.int64)
    for e, r_ in enumerate(rows):
        for j, pair in enumerate(r_):
            out[e, j] = pair
    return out


def _xdofs_of(g):
    return _i64(g.xdofs if getattr(g, "xdofs", None) is not None else g.dofs)


def _batch_arrays(model, target, active):
    """The arrays of every batch, forces, constraints, then velocity constraints, each in the order of
    :data:`FORCE_FIELDS` / :data:`CONSTRAINT_FIELDS` / :data:`VELOCITY_FIELDS` (the contents of the pack G)."""
    nv = model.nq
    rot = getattr(model, "rot_blocks", np.zeros((0, 2), dtype=np.int64))
    block_of = {int(vs): b for b, (_, vs) in enumerate(rot)}
    arrays = []
    for g in model.force_groups:
        nel, nd = g.dofs.shape
        ndx = _xdofs_of(g).shape[1]
        ntf = g.tf_index.shape[1]
        arrays += [g.P, _i64(g.dofs), _i64(g.tf_index), _nn_targets(g, target, nv),
                   np.zeros((nel, ndx)), np.zeros((nel, nd)), np.zeros((nel, ntf, 3)),
                   np.zeros((nel, nd)), np.zeros((nel, nd, nd)), np.zeros((nel, nd, nd)),
                   _xdofs_of(g), _tangent_blocks(g, block_of)]
    for g in model.constraint_groups:
        nel, nd = g.dofs.shape
        ndx = _xdofs_of(g).shape[1]
        ncg = g.nc
        ntf = g.tf_index.shape[1]
        tB = np.full((nel, ncg, nd), -1, dtype=np.int64)
        tBt = np.full((nel, ncg, nd), -1, dtype=np.int64)
        Rr = np.broadcast_to(g.lam[:, :, None], (nel, ncg, nd))
        Cr = np.broadcast_to(g.dofs[:, None, :], (nel, ncg, nd))
        ok = (Cr < nv) & (active[Rr] != 0)
        tB[ok] = target(nv + Rr[ok], Cr[ok])
        tBt[ok] = target(Cr[ok], nv + Rr[ok])
        arrays += [g.P, _i64(g.dofs), _i64(g.lam), _i64(g.tf_index), _nn_targets(g, target, nv), tB, tBt,
                   np.zeros((nel, ndx)), np.zeros((nel, nd)), np.zeros((nel, ncg)),
                   np.zeros((nel, ntf, 3)), np.zeros((nel, ncg)), np.zeros((nel, ncg, nd)),
                   np.zeros((nel, nd, nd)), np.zeros((nel, ncg)), np.zeros((nel, ncg)),
                   _xdofs_of(g), _tangent_blocks(g, block_of)]
    for g in getattr(model, "velocity_constraint_groups", ()):
        arrays += _velocity_arrays(g, target, model.nc, nv, block_of)
    return arrays


def _velocity_arrays(g, target, nc, nv, block_of):
    """The arrays of one velocity-constraint batch (:data:`VELOCITY_FIELDS`): those of a constraint
    batch with the rows nc + μ of the multipliers [λ; μ], and the work array of Ψ_q."""
    nel, nd = g.dofs.shape
    ndx = _xdofs_of(g).shape[1]
    nn = g.nn
    ntf = g.tf_index.shape[1]
    rows = nc + g.mu
    tB = np.full((nel, nn, nd), -1, dtype=np.int64)
    tBt = np.full((nel, nn, nd), -1, dtype=np.int64)
    Rr = np.broadcast_to(rows[:, :, None], (nel, nn, nd))
    Cr = np.broadcast_to(g.dofs[:, None, :], (nel, nn, nd))
    ok = Cr < nv
    tB[ok] = target(nv + Rr[ok], Cr[ok])
    tBt[ok] = target(Cr[ok], nv + Rr[ok])
    return [g.P, _i64(g.dofs), _i64(rows), _i64(g.tf_index), _nn_targets(g, target, nv), tB, tBt,
            np.zeros((nel, ndx)), np.zeros((nel, nd)), np.zeros((nel, nn)),
            np.zeros((nel, ntf, 3)), np.zeros((nel, nn)), np.zeros((nel, nn, nd)),
            np.zeros((nel, nd, nd)), np.zeros((nel, nn)), np.zeros((nel, nn)),
            _xdofs_of(g), _tangent_blocks(g, block_of), np.zeros((nel, nn, nd))]


def _constants(model, Mc, perm, iperm, active, index2, target):
    """The model constants of the pack C by name (``C_FIELDS``; without ``env``, ``gglw`` and
    ``batches``, which the caller adds)."""
    nv = model.nq
    tf = model.time_function_table
    rot = getattr(model, "rot_blocks", np.zeros((0, 2), dtype=np.int64))
    Mcoo = Mc.tocoo()
    C = dict(mp=_i64(Mc.indptr), perm=perm, iperm=iperm, w=_f64(model.force_weight),
             wext=_f64(model.force_weight_ext), qfix=_f64(model.q_fixed), fconst=_f64(model.f_const),
             mi=_i64(Mc.indices), tfkind=_i64(tf["kind"]), tfoff=_i64(tf["off"]), tfcoef=_f64(tf["coef"]),
             mx=_f64(Mc.data), tm=_i64(target(Mcoo.row, Mcoo.col)),
             tfv=np.zeros((max(1, len(tf["kind"])), 3)),
             scale0=np.array([float(np.abs(model.f_const * model.force_weight).max(initial=0.0))]),
             active=active,
             # rotation nodes: T(Δθ) per free rotation (identity between steps), x index of each
             # additive v entry (−1 on rotations), (x start, v start) of each free rotation, the
             # quaternions at the start of the step, the step's increment Δ on rotation entries
             tn=np.tile(np.eye(3), (len(rot), 1, 1)), xmap=_i64(getattr(model, "xmap", np.arange(nv))),
             rot=_i64(rot).reshape(-1, 2), pn=np.zeros((len(rot), 4)), d=np.zeros(nv),
             lie=np.array([1 if getattr(model, "lie", False) else 0], dtype=np.int64))
    # index-2 layout (empty otherwise): per flat entry of B (constraint, coordinate, target in the
    # velocity rows), the products of B(q) B(q_n)ᵀ (entry, entry, target), the η diagonal of active
    # constraints, work: B(q_n), B(q) and B(q) T(D) flat
    C.update(index2)
    return C


def _envelope(pr, pc, N, kl, ku):
    """Per-column bounds of the band LU work, (3, N) int64 (see ``band_lu`` in femb/engine/linalg.py).

    env[0, j]: lowest row that can be nonzero below the diagonal of column j
    (cumulative over columns ≤ j, so partial pivoting stays inside); env[1, j]:
    last column the pivot row and the fill can reach (cumulative over the rows
    ≤ env[0, j]); env[2, j]: first row whose U part reaches column j.
    """
    maxrow = np.arange(N, dtype=np.int64)
    np.maximum.at(maxrow, pc, pr)
    low = np.maximum.accumulate(maxrow)
    lastcol = np.arange(N, dtype=np.int64)
    np.maximum.at(lastcol, pr, pc)
    cum = np.maximum.accumulate(lastcol)
    up = np.maximum(cum[low], np.arange(N))
    low = np.minimum(low, np.arange(N) + kl)
    up = np.minimum(up, np.minimum(np.arange(N) + kl + ku, N - 1))
    first = np.searchsorted(up, np.arange(N), side="left").astype(np.int64)
    return np.ascontiguousarray(np.stack((low, up, first)).astype(np.int64))


def _band_cost(pat, perm):
    """(kl, ku, N·kl·(kl + ku)) of the pattern under a symmetric permutation."""
    N = pat.shape[0]
    iperm = np.empty(N, dtype=np.int64)
    iperm[perm] = np.arange(N)
    coo = pat.tocoo()
    pr, pc = iperm[coo.row], iperm[coo.col]
    kl = int(max(0, (pr - pc).max()))
    ku = int(max(0, (pc - pr).max()))
    return kl, ku, N * kl * (kl + ku)


def _constraints_after_coordinates(pat, nv, coord_order):
    """Coordinates in ``coord_order``, each constraint row right after the last coordinate it touches."""
    N = pat.shape[0]
    pos = np.empty(nv, dtype=np.int64)
    pos[coord_order] = np.arange(nv)
    B = pat[nv:, :nv].tocsr()
    key = np.concatenate((2 * pos.astype(float), np.empty(N - nv)))
    for j in range(N - nv):
        cols = B.indices[B.indptr[j]:B.indptr[j + 1]]
        key[nv + j] = 2 * pos[cols].max() + 1 if cols.size else 2 * nv
    return np.argsort(key, kind="stable").astype(np.int64)


def _band_ordering(pat, nv):
    """A bandwidth-reducing symmetric ordering of the iteration matrix, the best of three.

    Candidates: reverse Cuthill–McKee of the whole KKT pattern; the model's own
    coordinate numbering (nodes in the order they were added: chains such as
    beams are already banded) and reverse Cuthill–McKee of the coordinates'
    pattern (M, K and BᵀB), each with every constraint row placed right after
    the last coordinate it acts on. The one with the least band LU work wins.
    """
    sym = (pat + pat.T).tocsr()
    cands = [np.asarray(reverse_cuthill_mckee(sym, symmetric_mode=True), dtype=np.int64)]
    if pat.shape[0] > nv:
        Pq = (pat[:nv, :nv] + pat[:nv, nv:] @ pat[nv:, :nv]).tocsr()
        Pq = (Pq + Pq.T).tocsr()
        cands.append(_constraints_after_coordinates(pat, nv, np.arange(nv)))
        cands.append(_constraints_after_coordinates(
            pat, nv, np.asarray(reverse_cuthill_mckee(Pq, symmetric_mode=True), dtype=np.int64)))
    return min(cands, key=lambda p: _band_cost(pat, p)[2])


def compiled(model, ordering="rcm", layout="index3"):
    """The :class:`Compiled` data of a model (built once per model, ordering and layout, kept on it)."""
    store = model.__dict__.setdefault("_compiled", {})
    key = ordering if layout == "index3" else (ordering, layout)
    c = store.get(key)
    if c is None:
        c = Compiled(model, ordering, layout)
        store[key] = c
    return c


def evaluate_dense(model, state, h, alpha, scaled=True, ordering="rcm", formulation="index3"):
    """Residual, Φ, force scale and iteration matrix as the compiled loop computes them.

    For checks and debugging: runs the generated ``evaluate`` once and unpacks
    the band storage into a dense (N, N) array in the model's numbering.
    ``formulation="index2"``: the matrix of the stabilized index-2 step
    (``newton_step``, index 2), N = nq + 2 nc, with the state's q as both q_n and
    the iterate.

    Returns
    -------
    r_q : ndarray (nq,)
    Phi : ndarray (nc + nn,)
        Φ, then the velocity-constraint rows Ψ/γ' (``state.lam`` holds [λ; μ] for such models).
    scale : float
    S : ndarray (N, N)
    """
    cp = compiled(model, ordering, formulation)
    nv, N = model.nq, cp.N
    for k, fn in cp.python_tf:
        cp.tfv[k] = (fn.f(state.t), fn.df(state.t), fn.ddf(state.t))
    cp.mod.eval_time_functions(float(state.t), cp.Cv[_S.C_TFKIND], cp.Cv[_S.C_TFOFF], cp.Cv[_S.C_TFCOEF], cp.tfv)
    bp, gp = alpha.newton_factors(h)
    c = alpha.beta * h * h if scaled else 1.0
    AB = np.zeros(cp.storage_size)
    r = np.zeros(nv)
    Phi = np.zeros(model.nc + getattr(model, "nn", 0))
    cp.mod.lie_reset(cp.C)
    X = (_f64(state.q), _f64(state.qd), _f64(state.qdd), _f64(state.lam))
    scale = cp.mod.evaluate(cp.G, cp.C, float(state.t), X, True, (c * bp, c * gp, c), (AB, r, Phi))
    if formulation == "index2":
        Bw = cp.Cv[_S.C_BW]
        cp.mod.constraint_B(cp.G, cp.C, float(state.t), _f64(state.q), _f64(state.qd), Bw[0])
        cp.mod.copy_B(cp.G, cp.C, Bw[1])
        cp.mod.ggl_matrix(cp.C, AB, 1.0 if scaled else gp)
    perm = cp.Cv[_S.C_PERM]
    S = np.zeros((N, N))
    if cp.dense:
        S[np.ix_(perm, perm)] = AB.reshape(N, N)
        return r, Phi, scale, S
    A = AB.reshape(N, cp.ldab)
    d = cp.kl + cp.ku
    for jp in range(N):
        for ip_ in range(max(0, jp - cp.ku), min(N, jp + cp.kl + 1)):
            S[perm[ip_], perm[jp]] = A[jp, d + ip_ - jp]
    return r, Phi, scale, S
