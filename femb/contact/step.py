"""One step of the nonsmooth generalized-α method (Capobianco, Harsch, Eugster & Leine 2021).

Equation numbers refer to G. Capobianco, J. Harsch, S. R. Eugster, R. I. Leine, "A nonsmooth
generalized-α method for mechanical systems with frictional contact", Int. J. Numer. Methods
Eng. 122 (2021) 6497–6526, doi:10.1002/nme.6801 (the paper's numbering as carried by the
authors' implementation). Notation: u̇ the true accelerations, ā the auxiliary (α-weighted)
accelerations, U the velocity jump, Q the position correction; λ forces, Λ percussions,
κ position-correction multipliers; g bilateral (femb's Φ, sign M u̇ = f − Φ_qᵀλ), N normal, F
friction (contact forces act as +W_Nᵀλ_N + W_Fᵀλ_F).

Unknowns of a step (eq. (126)), x = (u̇, U, Q, κ_g, Λ_g, λ_g, κ_N, Λ_N, λ_N, Λ_F, λ_F), and
the residual R = (R_s, R_c) of eq. (127)::

    M u̇ − f + Φ_qᵀλ_g − W_Nᵀλ_N − W_Fᵀλ_F = 0
    M U + Φ_qᵀΛ_g − W_NᵀΛ_N − W_FᵀΛ_F = 0
    M Q + Φ_qᵀκ_g − W_Nᵀκ_N − (h/2) W_FᵀΛ_F = 0
    Φ = 0,   Φ_q u + Φ_t = 0,   Φ_q u̇ + γ = 0                 (index-3 exactness at all levels,
                                                             Brüls, Acary & Cardona 2014)
    contact rows, eqs. (129), (132), (135), (138), (142), on the index sets (130)–(141),
    with the slip row (138b) on the impulsive parts, Λ_F = −μΛ_N ξ_F/‖ξ_F‖ (docs/contact.md §1.1)

with the kinematics (71), (73), (125): ā_{n+1} from (1 − α_m)ā_{n+1} + α_m ā_n =
(1 − α_f)u̇_{n+1} + α_f u̇_n, u_{n+1} = u_n + h((1 − γ)ā_n + γā_{n+1}) + U,
q_{n+1} = q_n ∘ exp(h u_n + h²((1/2 − β)ā_n + βā_{n+1}) + Q); the auxiliary contact forces
λ̄ (96), (114), the percussions P = Λ + h((1 − γ)λ̄_n + γλ̄_{n+1}) (95), (113) and
κ̂_N = κ_N + h²((1/2 − β)λ̄_N,n + βλ̄_N,n+1) (102).

The step is solved by a semismooth Newton method on this active-set form (index sets
updated from the current iterate at every iteration, eqs. (130), (133), (136), (139),
(141)); when it does not converge, by the prox fixed point of eqs. (144)–(146) (Newton on
R_s for fixed contact unknowns, then the proximal update of the contact unknowns).
"""
from __future__ import annotations

import sys
import threading
import time
import warnings
import weakref
from dataclasses import dataclass

import numba
import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.sparse import csgraph

from femb.base.jit import cache_writable, compile_lock, is_cached, jit_disabled
from femb.contact import assemble, core
from femb.contact.dense import DenseModel
from femb.contact.prox import direction, prox_disc, prox_nonnegative
from femb.system import assembly, kernels


def diag_W_Minv_Wt(W, lu, comp):
    """diag(W M⁻¹ Wᵀ) of a sparse W at a cost linear in the model's size.

    M⁻¹ couples no two connected components of the graph of M, so rows of W whose components are
    disjoint share one right-hand side: w_iᵀ M⁻¹ Σ_j w_j = w_iᵀ M⁻¹ w_i when no other row of the sum
    touches a component of w_i. The rows are coloured greedily (a row takes the first colour that none
    of its components has used yet) and M is solved once per colour: as many solves as the most
    contact rows on one component (three for a sphere on a plane), not one per row.

    Parameters
    ----------
    W : scipy.sparse matrix, shape (k, n)
    lu : scipy.sparse.linalg.SuperLU
        Factors of M (n, n).
    comp : ndarray of int, shape (n,)
        The component of each velocity in the graph of M.

    Returns
    -------
    ndarray, shape (k,)
    """
    W = sp.csr_matrix(W)
    k = W.shape[0]
    rows = np.repeat(np.arange(k), np.diff(W.indptr))
    cn = comp[W.indices]
    next_free = np.zeros(int(comp.max()) + 1, dtype=np.int64)
    colour = np.zeros(k, dtype=np.int64)
    for i in range(k):
        cs = cn[W.indptr[i]:W.indptr[i + 1]]
        if cs.size:
            c = int(next_free[cs].max())
            colour[i] = c
            next_free[cs] = c + 1
    ncol = int(colour.max()) + 1 if k else 0
    B = sp.csr_matrix((np.ones(k), (colour, np.arange(k))), shape=(ncol, k)) @ W
    Z = lu.solve(np.ascontiguousarray(B.toarray().T))
    if Z.ndim == 1:
        Z = Z[:, None]
    return np.bincount(rows, W.data * Z[W.indices, colour[rows]], minlength=k)


class _BlockPattern:
    """The structure, built once, of a sparse matrix with one block per contact i in the rows of its
    friction directions ``idx``: idx × idx (``square``; ∂R/∂γ blocks, nF × nF, row by row) or idx ×
    column i (∂R/∂λ_N, nF × nN). ``start[i]``: where contact i's values begin in the values' array
    (what :func:`femb.contact.core.friction_blocks` writes); ``rows``, ``cols``: every value's place."""

    def __init__(self, friction, shape, square):
        self.shape = shape
        self.start = np.zeros(len(friction), dtype=np.int64)
        rows, cols, off = [np.zeros(0, dtype=np.int64)], [np.zeros(0, dtype=np.int64)], 0
        for i, idx in enumerate(friction):
            self.start[i] = off
            if idx.size:
                idx = np.asarray(idx, dtype=np.int64)
                rows.append(np.repeat(idx, idx.size) if square else idx)
                cols.append(np.tile(idx, idx.size) if square else np.full(idx.size, i, dtype=np.int64))
                off += rows[-1].size
        self.rows, self.cols = np.concatenate(rows), np.concatenate(cols)

    def tocsr(self, data):
        """The sparse matrix of the values ``data``."""
        return sp.csr_matrix((data, (self.rows, self.cols)), shape=self.shape)

    def toarray(self, data):
        """The dense matrix of the values ``data``."""
        out = np.zeros(self.shape)
        out[self.rows, self.cols] = data
        return out


@dataclass
class StepState:
    """What a step needs from the previous one (all arrays owned)."""

    t: float
    q: np.ndarray
    u: np.ndarray
    ud: np.ndarray          # u̇_n (true accelerations)
    abar: np.ndarray        # ā_n
    lam_N: np.ndarray
    lam_F: np.ndarray
    lbar_N: np.ndarray      # λ̄_N,n
    lbar_F: np.ndarray
    gNd: np.ndarray         # ġ_N(q_n, u_n), for Newton's impact law
    gFd: np.ndarray         # γ_F(q_n, u_n)
    x: np.ndarray = None    # the previous step's unknowns (initial guess)
    gN: np.ndarray = None   # g_N(q_n) and g̈_N(q_n, u_n, u̇_n): locate impacts inside a step
    gNdd: np.ndarray = None
    #: per normal contact, whether its gFd, gNdd were computed (None: all); the broad phase
    #: (femb/contact/broadphase.py) leaves them out for the pairs it left out of the step that ended here
    fresh: np.ndarray = None


#: dense linear algebra (and the compiled iteration, femb/contact/core.py) up to this many unknowns
DENSE_MAX_UNKNOWNS = 600
#: largest system solved by the compiled LU (femb/contact/core.py: increment); larger dense systems use LAPACK
DENSE_COMPILED_LU = 200


def _owned(a):
    """a as a writable, C-contiguous float64 array (the types the compiled iteration was compiled for)."""
    if a.dtype == np.float64 and a.flags.c_contiguous and a.flags.writeable:
        return a
    return np.array(a, dtype=np.float64)


def _fingerprint(a):
    """What numba's type of ``a`` depends on, for nested tuples and typed lists of arrays (cheap to form)."""
    if isinstance(a, np.ndarray):
        return (a.ndim, a.dtype.char, a.flags.c_contiguous, a.flags.writeable)
    if isinstance(a, tuple):
        return tuple(_fingerprint(b) for b in a)
    if isinstance(a, numba.typed.List):
        return numba.typeof(a)      # the list's type, held by the list (indexing it from Python would compile)
    return type(a).__name__


_ENTRIES = {}
_DENSE = weakref.WeakKeyDictionary()


def _dense_model(model):
    """The :class:`DenseModel` of ``model`` for this thread: built once (its batch records take tens of
    milliseconds to form), reused by the next run of the same model in the same thread (a run uses
    its work arrays only while it runs; results are copied out of them)."""
    per_thread = _DENSE.setdefault(model, {})
    key = threading.get_ident()
    if key not in per_thread:
        per_thread[key] = DenseModel(model)
    return per_thread[key]


def _entry_point(disp, args, plan=None, announce=True):
    """The compiled function of ``disp`` for the types of ``args``, callable without the dispatcher's type
    resolution (which hashes the nested tuple types anew at every call: milliseconds here); kept per
    process and argument structure. ``disp`` itself under NUMBA_DISABLE_JIT. ``plan(sig)``, if given,
    gives the units to compile in parallel, their costs and the groups kept together
    (:func:`femb.contact.loop.build_plan`). ``announce=False``: a small function, compiled in seconds without
    a word on stderr (the sparse path's helpers)."""
    if jit_disabled():
        return disp
    key = (disp.__name__, _fingerprint(args))
    if key not in _ENTRIES:
        sig = tuple(numba.typeof(a) for a in args)
        _ENTRIES[key] = _compile_announced(disp, sig, plan) if announce else disp.compile(sig)
    return _ENTRIES[key]


def _compile_announced(disp, sig, plan=None):
    """``disp.compile(sig)``, said on stderr with the time it took when it is not in the cache (the contact
    step and its time loop compile once per installation: their argument types do not depend on the
    element types, whose kernels they call through their addresses; about two minutes of CPU on a small
    machine), under a lock so that processes that need it at once compile it once. With
    ``stages``, ``disp`` and its stages are first compiled at once in worker processes into the cache
    (:func:`femb.engine.parallel.compile_in_workers`), and loaded from there."""
    if is_cached(disp, sig):
        return disp.compile(sig)
    with compile_lock(f"contact.{disp.__name__}"):
        if is_cached(disp, sig):                    # compiled by another process while this one waited
            return disp.compile(sig)
        print(f"femb: compiling the contact step ({disp.__name__}), once per installation; "
              "about 80 s on 2 cores", file=sys.stderr, flush=True)
        t0 = time.perf_counter()
        if plan is not None:
            from femb.engine.parallel import compile_in_workers
            units, cost, together = plan(sig)
            compile_in_workers(units, cost=cost, together=together)
        fn = disp.compile(sig)
        kept = "cached for later runs" if cache_writable() else "in memory for this run only"
        print(f"femb: contact step compiled in {time.perf_counter() - t0:.1f} s, {kept}", file=sys.stderr,
              flush=True)
        return fn


class StepFailure(Exception):
    """Neither the semismooth Newton method nor the fixed point found the step's solution."""

    def __init__(self, message, x=None, sets=None):
        super().__init__(message)
        self.x = x
        self.sets = sets


def _bilateral_H(model, t, q, lam):
    """∂(Φ_qᵀλ)/∂q (csr)."""
    if not model.constraint_groups:
        return sp.csr_matrix((model.nq, model.nq))
    qx = model.ext(q)
    blocks = [kernels.constraint(g, t, qx[g.xdofs], lam[g.lam], jac=True)[2] for g in model.constraint_groups]
    return assembly._coo(model.constraint_groups, "nn", blocks, (model.nq, model.nq))


def _equilibrate(J, dense):
    """(D_r J D_c, D_r, D_c) with D_r, D_c diagonal (as vectors): rows, then columns, scaled to a largest
    entry of 1 (empty rows or columns keep 1)."""
    if dense:
        r = np.max(np.abs(J), axis=1)
        r = np.where(r > 0.0, 1.0 / np.where(r > 0.0, r, 1.0), 1.0)
        Jr = r[:, None] * J
        c = np.max(np.abs(Jr), axis=0)
        c = np.where(c > 0.0, 1.0 / np.where(c > 0.0, c, 1.0), 1.0)
        return Jr * c[None, :], r, c
    J = J.tocsc()                      # on its arrays: rows J.indices, columns by J.indptr
    J.sum_duplicates()
    r = np.zeros(J.shape[0])
    np.maximum.at(r, J.indices, np.abs(J.data))
    r = np.where(r > 0.0, 1.0 / np.where(r > 0.0, r, 1.0), 1.0)
    data = J.data * r[J.indices]
    counts = np.diff(J.indptr)
    c = np.zeros(J.shape[1])
    full = counts > 0
    if data.size:
        c[full] = np.maximum.reduceat(np.abs(data), J.indptr[:-1][full])
    c = np.where(c > 0.0, 1.0 / np.where(c > 0.0, c, 1.0), 1.0)
    data = data * np.repeat(c, counts)
    return sp.csc_matrix((data, J.indices.copy(), J.indptr.copy()), shape=J.shape), r, c


#: the sparse path solves the unit rows of J apart (:func:`_solve_unit_rows`) when at least this many
#: rows, and a quarter of them, are unit rows
UNIT_ROWS_MIN = 64


def _solve_unit_rows(Js, b, passes=8):
    """The solution y of Js y = b by its triangular rows first, or None where that does not pay.

    A unit row has one nonzero entry among the unknowns not yet known, on the diagonal: the rows of a
    contact that is open and stays open (its normal unknowns are zero whatever the others; its friction
    unknowns follow once its normal force is known), such as the far pairs of a pile of spheres that
    declares every pair. Such rows give their unknowns at once, y_i = (b_i − Σ_known J_ij y_j) / J_ii,
    in up to ``passes`` rounds, and the rest is the smaller system Js[K, K] y_K = b_K − Js[K, U] y_U: the
    same solution (block elimination of a block-triangular J). Returns None (the caller factors the
    whole J) when fewer than :data:`UNIT_ROWS_MIN` rows, or fewer than a quarter of them, are known that
    way, or when the smaller system is singular (``_regular`` decides on the whole J there)."""
    Jc = Js.tocsc()                                       # (J comes in CSC: no copy)
    n = Jc.shape[0]
    rows = Jc.indices
    cols = np.repeat(np.arange(n), np.diff(Jc.indptr))
    nzero = Jc.data != 0.0
    diag = Jc.diagonal()
    known = np.zeros(n, dtype=bool)
    y = np.zeros(n)
    for _ in range(passes):
        live = nzero & ~known[cols]                       # nonzeros among the unknowns not yet known
        counts = np.bincount(rows[live], minlength=n)
        new = np.nonzero(~known & (counts == 1) & (diag != 0.0))[0]
        if not new.size:
            break
        y[new] = (b[new] - (Jc @ y)[new]) / diag[new]    # y is zero where not known (and at new)
        known[new] = True
    nu = int(known.sum())
    if nu < UNIT_ROWS_MIN or 4 * nu < n:
        return None
    keep = np.nonzero(~known)[0]
    if keep.size:
        U = np.nonzero(known)[0]
        A = Jc[:, keep][keep, :].tocsc()
        A.eliminate_zeros()                 # the zeros J's fixed pattern stores would steer the ordering
        rhs = b[keep] - Jc[:, U][keep, :] @ y[U]
        lu = spla.splu(A, permc_spec="MMD_AT_PLUS_A")
        d = np.concatenate((np.abs(lu.U.diagonal()), np.abs(diag[U])))
        if not d.min() > 1e-11 * d.max():
            return None
        y[keep] = lu.solve(rhs)
    return y


class NonsmoothStep:
    """The residual, its Jacobian and the solvers of one step (see the module docstring).

    Parameters
    ----------
    model : Model
    h : float
    alpha : femb.GeneralizedAlpha
    lay : femb.contact.assemble.ContactLayout
    tol : float
        Newton tolerance on the residual in length units (rows scaled by h, h², 1/m as below).
    max_iter, max_fixed_point : int
    like : NonsmoothStep, optional
        A stepper of the same model whose mass matrix, its factors and its structure this one shares
        (the broad phase's steppers on subsets of the contacts, :mod:`femb.contact.broadphase`).
    """

    #: The slip law (138b) on the whole percussions P_F, P_N (the paper's) instead of their impulsive parts
    #: Λ_F, Λ_N (docs/contact.md §1.1 item 5). False: femb's law first, the paper's for a step that has no
    #: solution on it (:meth:`solve`); True: the paper's law on every step (tests compare the paths on it).
    slip_on_P = False
    #: the step size whose square weighs the acceleration-level rows of the Newton test when it exceeds h
    #: (0: h itself). Adaptive runs set it to their first step: on steps far shorter than that, h² would let
    #: Newton accept a stale u̇ and λ, which the error estimate reads (docs/contact.md §1.2)
    h_acc = 0.0

    def __init__(self, model, h, alpha, lay, tol, max_iter=40, max_fixed_point=400, like=None):
        self.model, self.h, self.lay = model, float(h), lay
        self.am, self.af, self.beta, self.gamma = alpha.alpha_m, alpha.alpha_f, alpha.beta, alpha.gamma
        self.tol, self.max_iter, self.max_fp = tol, max_iter, max_fixed_point
        #: semismooth Newton iterations before the index sets are held fixed
        self.freeze_after = max(2, max_iter // 2)
        self.h_fixed = float(h)
        n, m, k, l = model.nq, model.nc, lay.nN, lay.nF
        self.sizes = (n, n, n, m, m, m, k, k, k, l, l)
        self.offsets = np.concatenate(([0], np.cumsum(self.sizes)))
        self.nx = int(self.offsets[-1])
        self._slices = [slice(int(self.offsets[i]), int(self.offsets[i + 1])) for i in range(11)]
        self.set_h(h)
        self.owner = np.zeros(l, dtype=np.int64)
        for i, idx in enumerate(lay.friction):
            self.owner[idx] = i
        self.e_F = lay.e_F_rows
        if like is not None:
            self.M = like.M
        else:
            self.M = model.M_const.tocsc() if model.constant_mass else None
        #: dense linear algebra below this many unknowns (sparse overhead dominates small systems)
        self.dense = self.nx <= DENSE_MAX_UNKNOWNS
        self.Md = self.M.toarray() if (self.dense and self.M is not None) else None
        self.Minv = np.linalg.inv(self.Md) if self.Md is not None else None
        diagM = (self.M if self.M is not None else assembly.mass_matrix(model, model.q0)).diagonal()
        w = model.force_weight
        self.m_ref = float(np.mean(diagM[w == 1.0])) if np.any(w == 1.0) else float(np.mean(diagM))
        self._r_cache = None
        self._r_memo = []
        self._regular = False      # the last Newton increment came from a regular J (newton_increment)
        #: offsets and force weights as core.increment_size takes them (_converged_by_increment)
        self._inc_arrays = (np.asarray(self.offsets, dtype=np.int64),
                            np.ascontiguousarray(model.force_weight, dtype=float))
        self._M_lu = None          # the sparse path's factors of a constant M
        self._mass_comp = None     # the mass matrix's connected components (the sparse path's prox parameters)
        self._patterns = None      # the sparse path's friction derivative blocks (_BlockPattern)
        self._maps = None          # (xmap, rotation blocks) of a Lie-group model (_rotation_maps)
        self._M_coo = None         # the sparse path's constant mass matrix as COO (_sparse_jacobian)
        if like is not None:
            self._share_from(like)
        if self.dense:
            self._dense_setup()

    def _share_from(self, like):
        """Take ``like``'s factors of the constant mass matrix, its components and the rotation maps (the
        model's, the same for any subset of the contacts), forming them there first."""
        if self.M is not None:
            if like._M_lu is None:
                like._M_lu = spla.splu(like.M)
            if like._M_coo is None:
                like._M_coo = sp.coo_matrix(like.M)
            self._M_lu, self._M_coo = like._M_lu, like._M_coo
        self._mass_comp = like._mass_components(self.model.q0)
        self._maps = like._rotation_maps()

    def set_h(self, h):
        """Use step size h (impact steps are split at the impact, docs/contact.md §1.1, item 2)."""
        self.h = float(h)
        c = (1.0 - self.af) / (1.0 - self.am)
        self.c_u = self.h * self.gamma * c        # ∂u_{n+1}/∂u̇_{n+1}, ∂P/∂λ
        self.c_q = self.h * self.h * self.beta * c     # ∂Δq/∂u̇_{n+1}, ∂κ̂/∂λ

    # ------------------------------------------------------------------ the dense, compiled path
    def _dense_setup(self):
        """Work arrays of the compiled iteration (femb/contact/core.py) for small systems."""
        lay, k, l, nx = self.lay, self.lay.nN, self.lay.nF, self.nx
        self.dm = _dense_model(self.model)
        self._o = np.ascontiguousarray(self.offsets, dtype=np.int64)
        sizes = [idx.size for idx in lay.friction]
        fptr = np.concatenate(([0], np.cumsum(sizes))).astype(np.int64)
        fidx = np.concatenate([np.asarray(i, dtype=np.int64) for i in lay.friction] + [np.zeros(0, np.int64)])
        self._lay = (np.ascontiguousarray(self.owner, dtype=np.int64), fptr, np.ascontiguousarray(fidx))
        self._fixed_law = (np.ascontiguousarray(lay.mu, dtype=float), np.ascontiguousarray(lay.e_N, dtype=float),
                           np.ascontiguousarray(self.e_F, dtype=float),
                           np.ascontiguousarray(self.model.force_weight, dtype=float))
        self._sets = np.zeros((5, k), dtype=np.int8)
        self._loop = None
        #: the whole iteration compiled (constant mass: no mass matrix to evaluate from Python)
        self._loop_ok = not self.dm.mass and self.dm.recs is not None
        self._out = tuple(np.zeros(nx) for _ in range(2)) + tuple(np.zeros(k) for _ in range(3)) + \
            tuple(np.zeros(l) for _ in range(3))
        self._J = np.zeros((nx, nx))
        self._dx = np.zeros(nx)
        dm = self.dm
        self._mq = (dm.M, dm.K1, dm.C1, dm.B, dm.WN, dm.WF)
        self._mv = (dm.f, dm.Phi, dm.Phi_t, dm.gam, dm.gN, dm.zN, dm.zF)
        model, n = self.model, self.model.nq
        xmap = np.asarray(model.xmap, dtype=np.int64) if model.lie else np.arange(n, dtype=np.int64)
        self._cmp = (np.ascontiguousarray(xmap), self._rotation_maps()[1])
        self._kout = (np.zeros(model.nx),) + tuple(np.zeros(n) for _ in range(2)) + \
            tuple(np.zeros(a) for a in (k, l, k, k, l)) + (np.zeros(n),)
        self._work = (self._o, self._cmp, self._kout, self._out, dm.dq, self._mq, self._mv, self._J, self._dx,
                      self._sets)

    def _dense_kinematics(self, s, x):
        """:meth:`kinematics` compiled: a dict of views into work arrays (copied by :meth:`_dense_result`)."""
        par = np.array([self.h, self.am, self.af, self.beta, self.gamma])
        core.kinematics(x, self._o, self._st, par, self._cmp, self._kout)
        return dict(zip(("q", "u", "abar", "lbar_N", "lbar_F", "PN", "kN_hat", "PF"), self._kout))

    def _dense_residual(self, s, x, ev, frozen):
        """Evaluate the model at the iterate's kinematics ``ev`` and the compiled residual; returns the error."""
        o, dm = self.offsets, self.dm
        dm.evaluate(s.t + self.h, ev["q"], ev["u"], x[o[5]:o[6]], x[o[8]:o[9]], x[o[10]:o[11]])
        if frozen is not None:
            self._sets[:] = frozen
        par = np.array([self.h, self.tol, self.c_q, self.c_u, self.m_ref, 0.0 if frozen is None else 1.0,
                        float(self.slip_on_P), self.h_acc])
        self._par = par
        kin = (ev["u"], ev["PN"], ev["kN_hat"], ev["PF"], s.gNd, s.gFd)
        self._kin = kin
        return core.residual(x, self._o, self._mq, self._mv, kin, self._law, self._lay, par, self._sets, self._out)

    def _dense_result(self, ev):
        """The iterate's quantities (owned copies) that the time loop reads (a part of what :meth:`evaluate`
        gives), and its index sets."""
        dm, out = self.dm, self._out
        ev = {key: a.copy() for key, a in ev.items()}
        ev.update(gN=dm.gN.copy(), WN=dm.WN.copy(), WF=dm.WF.copy(), gNd=out[2].copy(), gNdd=out[4].copy(),
                  gF=out[5].copy())
        sets = tuple(self._sets[i].astype(bool) for i in range(5))
        return ev, sets

    def _dense_increment(self, x):
        """The Newton increment at the iterate of the last :meth:`_dense_residual` (None: no factorization);
        for a rank-deficient J :func:`femb.contact.core.minimum_norm_step` with the weights of
        :func:`femb.contact.core.null_weights`, as the compiled iteration."""
        J, R = self._J, self._out[0]
        core.jacobian(x, self._o, self._mq, self._kin, self._law, self._lay, self._par, self._sets, self._out[2:], J)
        if not np.all(np.isfinite(J)):
            return None
        if self.nx <= DENSE_COMPILED_LU:
            self._regular = core.increment(J, R, self._dx) == 0
            if self._regular:
                return self._dx.copy()
            xc = np.ascontiguousarray(x, dtype=float)
            w = core.null_weights(xc, self._o, self._kout[5], self._law, self._lay, np.empty(xc.size))
            core.minimum_norm_step(J, R, xc, self._dx, w)
            return self._dx.copy()
        return self.newton_increment(J, R)

    def _dense_evaluate(self, s, x):
        """:meth:`evaluate` on the dense path (views into work arrays; what :meth:`prox_update` reads)."""
        f = _owned
        self._st = (f(s.q), f(s.u), f(s.ud), f(s.abar), f(s.lam_N), f(s.lam_F), f(s.lbar_N), f(s.lbar_F))
        ev = self._dense_kinematics(s, x)
        self._dense_residual(s, x, ev, None)
        out = self._out
        ev.update(gN=self.dm.gN, xiN=out[3], gNdd=out[4], gF=out[5], xiF=out[6], gFdd=out[7])
        return ev

    def newton_dense(self, s, x0, max_iter=None, fixed_z=None):
        """:meth:`newton` without ``fixed_z`` on the compiled dense path (same iterates, same result): the
        whole iteration in one compiled call (constant mass), else one compiled residual and one
        Jacobian and increment per iteration around the mass matrix evaluated here."""
        x = x0.copy()
        frozen = None
        f = _owned
        self._st = (f(s.q), f(s.u), f(s.ud), f(s.abar), f(s.lam_N), f(s.lam_F), f(s.lbar_N), f(s.lbar_F))
        dm = self.dm
        if self._loop_ok:
            t1 = s.t + self.h
            dm.time_values(t1)
            par = np.array([self.h, self.tol, self.c_q, self.c_u, self.m_ref, 0.0, self.am, self.af, self.beta,
                            self.gamma, t1, max_iter or self.max_iter, self.freeze_after, fixed_z is not None,
                            float(self.slip_on_P), self.h_acc])
            zf = np.zeros(0) if fixed_z is None else _owned(fixed_z)
            work = self._work + ((f(s.gNd), f(s.gFd)), zf)
            mdl = (dm.recs, dm.qx, dm.ux, dm.f0, dm.removed)
            args = (x, mdl, self._st, self._law, self._lay, par, work)
            if self._loop is None:
                self._loop = _entry_point(core.newton_loop, args)
            status, it, err = self._loop(*args)
            ev = dict(zip(("q", "u", "abar", "lbar_N", "lbar_F", "PN", "kN_hat", "PF"), self._kout))
            return (x, *self._dense_result(ev), it, status == 0, err)
        for it in range(1, (max_iter or self.max_iter) + 1):
            ev = self._dense_kinematics(s, x)
            err = self._dense_residual(s, x, ev, frozen)
            if not np.isfinite(err):
                return (x, *self._dense_result(ev), it, False, err)
            if err <= (self.tol if it > 1 else core.GUESS_TOL * self.tol):
                if frozen is not None:       # converged with the sets held: a solution if they are its own
                    err = self._dense_residual(s, x, ev, None)
                return (x, *self._dense_result(ev), it, err <= self.tol, err)
            if it == self.freeze_after:
                frozen = self._sets.copy()
            dx = self._dense_increment(x)
            if dx is None:
                return (x, *self._dense_result(ev), it, False, err)
            if self._converged_by_increment(dx, it, frozen):
                return (x, *self._dense_result(ev), it, True, err)
            x = x + dx
        ev = self._dense_kinematics(s, x)
        err = self._dense_residual(s, x, ev, None)
        return (x, *self._dense_result(ev), self.max_iter, err <= self.tol, err)

    # ------------------------------------------------------------------ bookkeeping
    def split(self, x):
        """The 11 blocks of x (eq. (126))."""
        return [x[sl] for sl in self._slices]

    def kinematics(self, s, x):
        """q, u, ā, λ̄_N, λ̄_F, P_N, κ̂_N, P_F of the iterate x (eqs. (71), (73), (125), (95), (96), (102), (113), (114))."""
        h, am, af, b, g = self.h, self.am, self.af, self.beta, self.gamma
        ud, U, Q, _, _, _, kN, LN, lN, LF, lF = self.split(x)
        abar = (af * s.ud + (1 - af) * ud - am * s.abar) / (1 - am)
        u = s.u + h * ((1 - g) * s.abar + g * abar) + U
        q = self._compose(s.q, h * s.u + h * h * ((0.5 - b) * s.abar + b * abar) + Q)
        lbN = (af * s.lam_N + (1 - af) * lN - am * s.lbar_N) / (1 - am)
        lbF = (af * s.lam_F + (1 - af) * lF - am * s.lbar_F) / (1 - am)
        PN = LN + h * ((1 - g) * s.lbar_N + g * lbN)
        kN_hat = kN + h * h * ((0.5 - b) * s.lbar_N + b * lbN)
        PF = LF + h * ((1 - g) * s.lbar_F + g * lbF)
        return dict(q=q, u=u, abar=abar, lbar_N=lbN, lbar_F=lbF, PN=PN, kN_hat=kN_hat, PF=PF)

    def _compose(self, q, d):
        """q ∘ exp(d) (:meth:`femb.system.model.Model.compose`), on Lie-group models by the compiled iteration's
        :func:`femb.contact.core._compose` (one loop over the rotations instead of one Python call each)."""
        model = self.model
        if not model.lie:
            return model.compose(q, d)
        out = np.empty(np.asarray(q).size)
        args = (np.ascontiguousarray(q, dtype=float), np.ascontiguousarray(d, dtype=float), *self._rotation_maps(), out)
        _entry_point(core._compose, args, announce=False)(*args)
        return out

    def _rotation_maps(self):
        """(xmap, rotation blocks (xs, vs) flattened) of a Lie-group model for :func:`femb.contact.core._compose`,
        formed once."""
        if self._maps is None:
            model = self.model
            rot = np.asarray(model.rot_blocks, dtype=np.int64).ravel() if model.lie else np.zeros(0, np.int64)
            xmap = model.xmap if model.lie else np.arange(model.nq)
            self._maps = (np.ascontiguousarray(xmap, dtype=np.int64), np.ascontiguousarray(rot))
        return self._maps

    def prox_r(self, q, t):
        """Prox parameters r_i = 1/(W M⁻¹ Wᵀ)_ii per normal and tangent row (Studer 2009).

        W at (q, t) is taken from the last converged iterate when that is the state asked for (the
        start of a step is the end of the step before), else evaluated."""
        for q_, t_, rN, rF in self._r_memo:           # the same start again (a step retried shorter)
            if q_ is q and t_ == t:
                return rN, rF
        c = self._r_cache
        if c is not None and c[0] is q and c[1] == t:
            WN, WF = c[2], c[3]
        else:
            ev = assemble.evaluate(self.model, t, q, np.zeros(self.model.nq), dense=self.dense)
            WN, WF = ev["WN"], ev["WF"]
        if self.dense and self.Minv is not None:
            rN, rF = np.zeros(self.lay.nN), np.zeros(self.lay.nF)
            core.prox_parameters(_owned(WN), _owned(WF), self.Minv, rN, rF)
            self._r_memo = [(q, t, rN, rF)] + self._r_memo[:1]
            return rN, rF
        if WN.shape[0] + WF.shape[0] == 0:
            return np.zeros(0), np.zeros(0)
        if self.dense:
            Wd = np.vstack((WN, WF))
            M = assembly.mass_matrix(self.model, q).tocsc()
            G = np.einsum("ij,ji->i", Wd, spla.splu(M).solve(np.ascontiguousarray(Wd.T)))
        else:
            if self.M is None:
                lu = spla.splu(assembly.mass_matrix(self.model, q).tocsc())
            else:
                if self._M_lu is None:
                    self._M_lu = spla.splu(self.M)
                lu = self._M_lu
            G = diag_W_Minv_Wt(sp.vstack((WN, WF)).tocsr(), lu, self._mass_components(q))
        r = 1.0 / np.maximum(G, 1e-300)
        rN, rF = r[:self.lay.nN], r[self.lay.nN:]
        self._r_memo = [(q, t, rN, rF)] + self._r_memo[:1]
        return rN, rF

    def _mass_components(self, q):
        """The connected component of each velocity in the graph of the mass matrix (its sparsity is
        the model's, computed once)."""
        if self._mass_comp is None:
            M = self.M if self.M is not None else assembly.mass_matrix(self.model, q)
            self._mass_comp = csgraph.connected_components(sp.csr_matrix(M), directed=False)[1]
        return self._mass_comp

    # ------------------------------------------------------------------ residual and Jacobian
    def evaluate(self, s, x):
        """Model quantities at the iterate x: kinematics, M, f, constraint and contact operators."""
        model, t1 = self.model, s.t + self.h
        ev = self.kinematics(s, x)
        q, u = ev["q"], ev["u"]
        ud, U, Q, kg, Lg, lg, kN, LN, lN, LF, lF = self.split(x)
        if self.dense:
            ev["M"] = self.Md if self.Md is not None else assembly.mass_matrix(model, q).toarray()
        else:
            ev["M"] = self.M if self.M is not None else assembly.mass_matrix(model, q).tocsc()
        ev["f"] = assembly.force_vector(model, t1, q, u)
        ev["Phi"] = assembly.constraint_vector(model, t1, q)
        B = assembly.constraint_jacobian(model, t1, q)
        ev["B"] = B.toarray() if self.dense else B
        ev["Phi_t"], ev["gam"] = assembly.constraint_rates(model, t1, q, u)
        c = assemble.evaluate(model, t1, q, u, lN, lF, jac=True, dense=self.dense)
        ev.update(c)
        WN, WF = c["WN"], c["WF"]
        ev["gNd"] = WN @ u
        # Newton's impact law ξ_N = ġ_N⁺ + e_N ġ_N⁻, the restitution acting on an approaching ġ_N⁻ only
        # (a contact that closes while separating, ġ_N⁻ > 0, has no impact to restitute: ξ_N = ġ_N⁺)
        ev["xiN"] = ev["gNd"] + self.lay.e_N * np.minimum(s.gNd, 0.0)
        ev["gNdd"] = WN @ ud + c["zN"]
        ev["gF"] = WF @ u
        ev["xiF"] = ev["gF"] + self.e_F * s.gFd * (s.gNd < 0.0)[self.owner]   # ξ_F, at impacts only
        ev["gFdd"] = WF @ ud + c["zF"]
        return ev

    def index_sets(self, ev, x):
        """A, B, C (normal) and D, E (friction, per contact) of eqs. (130), (133), (136), (139), (141), by
        :func:`femb.contact.core._index_sets` (the compiled iteration's).

        r > 0, so r g − κ̂ ≤ 0 ⇔ g − κ̂/r ≤ 0; femb compares with the Newton tolerance instead of 0: where
        both sides of a complementarity vanish the set must not flip on round-off (in length units:
        g ≤ tol, h ξ ≤ tol, h² g̈ ≤ tol).
        """
        f = np.ascontiguousarray
        lay = self._friction_layout()
        k = self.lay.nN
        z = np.zeros(0)
        mv = (z, z, z, z, f(ev["gN"], dtype=float), z, z)
        kin = (z, f(ev["PN"]), f(ev["kN_hat"]), f(ev["PF"]), z, z)
        law = (f(self.rN, dtype=float), f(self.rF, dtype=float), f(self.lay.mu, dtype=float), z, z, z)
        der = (z, f(ev["xiN"]), f(ev["gNdd"]), z, f(ev["xiF"]), f(ev["gFdd"]))
        sets = np.zeros((5, k), dtype=np.int8)
        args = (f(x, dtype=float), self._o_sparse, mv, kin, law, lay[:3], np.array([self.h, self.tol]), der, sets)
        _entry_point(core._index_sets, args, announce=False)(*args)
        return tuple(sets[i].astype(bool) for i in range(5))

    def _friction_layout(self):
        """(owner, fptr, fidx, sq, col) of the friction rows (built once): the tangent rows of contact i are
        fidx[fptr[i]:fptr[i + 1]]; sq and col where its blocks begin in the values of
        :meth:`friction_rows`' patterns."""
        if self._patterns is None:
            fr = self.lay.friction
            self._patterns = (_BlockPattern(fr, (self.lay.nF, self.lay.nF), True),
                              _BlockPattern(fr, (self.lay.nF, self.lay.nN), False))
            sizes = [np.asarray(i).size for i in fr]
            fptr = np.concatenate(([0], np.cumsum(sizes))).astype(np.int64)
            fidx = np.concatenate([np.asarray(i, dtype=np.int64) for i in fr] + [np.zeros(0, np.int64)])
            self._flay = (np.ascontiguousarray(self.owner, dtype=np.int64), fptr, np.ascontiguousarray(fidx),
                          self._patterns[0].start, self._patterns[1].start)
            self._o_sparse = np.ascontiguousarray(self.offsets, dtype=np.int64)
        return self._flay

    def smooth_rows(self, ev, x):
        """R_s of eq. (127): three dynamic rows and the bilateral constraints at three levels."""
        ud, U, Q, kg, Lg, lg, kN, LN, lN, LF, lF = self.split(x)
        M, B, WN, WF = ev["M"], ev["B"], ev["WN"], ev["WF"]
        return [M @ ud - ev["f"] + B.T @ lg - WN.T @ lN - WF.T @ lF,
                M @ U + B.T @ Lg - WN.T @ LN - WF.T @ LF,
                M @ Q + B.T @ kg - WN.T @ kN - 0.5 * self.h * (WF.T @ LF),
                ev["Phi"], B @ ev["u"] + ev["Phi_t"], B @ ud + ev["gam"]]

    def friction_rows(self, ev, x, A, D, E):
        """R_c for friction, eqs. (138), (142), and the derivative blocks of the Jacobian.

        The slip row of (138) acts on Λ_F, Λ_N, not on P_F, P_N: the smooth share
        h((1 − γ)λ̄_F,n + γλ̄_F,n+1) of P_F follows (142c) with the slip direction of its own stage,
        so a persistent slip whose direction turns leaves no O(h²) percussion per step. With
        ``slip_on_P`` (a step without a solution on that law, :meth:`solve`) it acts on P_F, P_N, as
        in the paper.
        """
        f = np.ascontiguousarray
        nF = self.lay.nF
        lay = self._friction_layout()
        sq, col = self._patterns
        LN, lN, LF, lF = (f(a, dtype=float) for a in self.split(x)[7:11])
        sets = np.array((A, A, A, D, E), dtype=np.int8)
        R9, R10 = np.zeros(nF), np.zeros(nF)
        Dxi, Dgd, Dg = (np.zeros(sq.rows.size) for _ in range(3))
        Dpn, Dln = np.zeros(col.rows.size), np.zeros(col.rows.size)
        Dpf, Dlf, Dsm = np.ones(nF), np.ones(nF), np.ones(nF)
        args = ((LN, lN, LF, lF), tuple(f(ev[k], dtype=float) for k in ("PN", "PF", "xiF", "gF", "gFdd")),
                f(self.lay.mu, dtype=float), lay[1:], sets, float(self.slip_on_P),
                (R9, R10, Dxi, Dgd, Dg, Dpn, Dln, Dpf, Dlf, Dsm))
        _entry_point(core.friction_blocks, args, announce=False)(*args)
        mk = (lambda pat, d: pat.toarray(d)) if self.dense else (lambda pat, d: pat.tocsr(d))
        Dxi, Dgd, Dg = (mk(sq, d) for d in (Dxi, Dgd, Dg))
        Dpn, Dln = mk(col, Dpn), mk(col, Dln)
        return R9, R10, dict(Dxi=Dxi, Dgd=Dgd, Dg=Dg, Dpf=Dpf, Dlf=Dlf, Dpn=Dpn, Dln=Dln, Dsm=Dsm)

    def system(self, s, x, fixed_z=None, frozen=None):
        """Residual R (eq. (127)), its Jacobian (csc) and the index sets at the iterate x.

        With ``fixed_z`` (the contact unknowns, eq. (144)) the contact rows become z − fixed_z = 0:
        Newton on R_s for fixed contact unknowns, the inner problem of the fixed point (145).
        The Jacobian leaves out ∂(Φ_q u)/∂q, ∂γ/∂q, ∂ζ/∂q, ∂W u/∂q in the velocity rows and the
        curvature of W in the percussion and position-correction rows (a modified Newton method
        that converges to the same solution).
        """
        ev = self.evaluate(s, x)
        A, B_, C, D, E = self.index_sets(ev, x) if frozen is None else frozen
        rows = self.smooth_rows(ev, x)
        lN = self.split(x)[8]
        # normal contact rows (129), (132), (135)
        rows.append(np.where(A, ev["gN"], ev["kN_hat"]))
        rows.append(np.where(B_, ev["xiN"], ev["PN"]))
        rows.append(np.where(C, ev["gNdd"], lN))
        R9, R10, Fd = self.friction_rows(ev, x, A, D, E)
        rows += [R9, R10]
        if fixed_z is not None:
            rows[6:] = np.split(x[self.offsets[6]:] - fixed_z, np.cumsum(self.sizes[6:-1]))
        R = np.concatenate(rows)
        if not self.dense:
            return R, self._sparse_jacobian(s, ev, x, (A, B_, C), Fd, fixed_z is not None), ev, (A, B_, C, D, E)
        J = self.jacobian(s, ev, x, (A, B_, C), Fd)
        if fixed_z is not None:
            for i in range(6, 11):
                J[i] = [None] * 11
                J[i][i] = np.eye(self.sizes[i])
        return R, self._matrix(J), ev, (A, B_, C, D, E)

    def _sparse_jacobian(self, s, ev, x, normal_sets, Fd, fixed):
        """The Jacobian of :meth:`jacobian` on the sparse path (csc), its entries gathered block by block
        (row, column and value arrays of each term at its block's offsets) and summed once; with
        ``fixed`` the contact rows are those of z − z_fixed (identity)."""
        model, h, cu, cq, o = self.model, self.h, self.c_u, self.c_q, self.offsets
        A, B_, C = normal_sets
        lg = self.split(x)[5]
        fq, fu = assembly.force_jacobians(model, s.t + h, ev["q"], ev["u"])
        coo = {key: sp.coo_matrix(a) for key, a in (("fq", fq), ("fu", fu), ("B", ev["B"]), ("WN", ev["WN"]),
                                                   ("WF", ev["WF"]), ("H", ev["H"]),
                                                   ("Hg", _bilateral_H(model, s.t + h, ev["q"], lg)))}
        if self.M is None:
            coo["M"] = sp.coo_matrix(ev["M"])
        else:                                        # a constant mass matrix: converted once
            if self._M_coo is None:
                self._M_coo = sp.coo_matrix(self.M)
            coo["M"] = self._M_coo
        R, Cc, V = [], [], []

        def put(i, j, key, fac=1.0, T=False, rowscale=None):
            m = coo[key]
            r, c = (m.col, m.row) if T else (m.row, m.col)
            v = fac * m.data if rowscale is None else fac * rowscale[r] * m.data
            R.append(o[i] + r)
            Cc.append(o[j] + c)
            V.append(v)

        def diag(i, j, v):
            k = np.arange(v.size)
            R.append(o[i] + k)
            Cc.append(o[j] + k)
            V.append(np.asarray(v, dtype=float))

        # dynamics (0–2): M u̇ − f + Φ_qᵀλ − W_Nᵀλ_N − W_Fᵀλ_F and its impulse and position rows; K1 = −f_q +
        # ∂(Φ_qᵀλ)/∂q − H, C1 = −f_u
        put(0, 0, "M")
        for key, fac in (("fq", -1.0), ("Hg", 1.0), ("H", -1.0)):
            put(0, 0, key, cq * fac)
            put(0, 2, key, fac)
        put(0, 0, "fu", -cu)
        put(0, 1, "fu", -1.0)
        for i, (jb, jn, jf, ff) in enumerate(((5, 8, 10, 1.0), (4, 7, 9, 1.0), (3, 6, 9, 0.5 * h))):
            if i:
                put(i, i, "M")
            put(i, jb, "B", T=True)
            put(i, jn, "WN", -1.0, T=True)
            put(i, jf, "WF", -ff, T=True)
        # bilateral constraints at three levels (3–5)
        put(3, 0, "B", cq)
        put(3, 2, "B")
        put(4, 0, "B", cu)
        put(4, 1, "B")
        put(5, 0, "B")
        if fixed:
            for i in range(6, 11):
                diag(i, i, np.ones(self.sizes[i]))
        else:
            Af, Bf, Cf = A.astype(float), B_.astype(float), C.astype(float)
            put(6, 0, "WN", cq, rowscale=Af)
            put(6, 2, "WN", rowscale=Af)
            diag(6, 6, 1.0 - Af)
            diag(6, 8, cq * (1.0 - Af))
            put(7, 0, "WN", cu, rowscale=Bf)
            put(7, 1, "WN", rowscale=Bf)
            diag(7, 7, 1.0 - Bf)
            diag(7, 8, cu * (1.0 - Bf))
            put(8, 0, "WN", rowscale=Cf)
            diag(8, 8, 1.0 - Cf)
            WF = ev["WF"]
            for key in ("Dxi", "Dgd", "Dg"):
                coo[key + "W"] = sp.coo_matrix(Fd[key] @ WF)
            coo["Dpn"], coo["Dln"] = sp.coo_matrix(Fd["Dpn"]), sp.coo_matrix(Fd["Dln"])
            put(9, 0, "DxiW", cu)
            put(9, 1, "DxiW")
            put(9, 7, "Dpn")
            put(9, 8, "Dpn", cu, rowscale=Fd["Dsm"])
            diag(9, 9, Fd["Dpf"])
            diag(9, 10, cu * Fd["Dsm"] * Fd["Dpf"])
            put(10, 0, "DgdW")
            put(10, 0, "DgW", cu)
            put(10, 1, "DgW")
            put(10, 8, "Dln")
            diag(10, 10, Fd["Dlf"])
        return sp.csc_matrix((np.concatenate(V), (np.concatenate(R), np.concatenate(Cc))), shape=(self.nx, self.nx))


    def _matrix(self, J):
        """The block matrix J (11 × 11 blocks, None for zero) as a dense array (the dense path)."""
        o = self.offsets
        out = np.zeros((self.nx, self.nx))
        for i in range(11):
            for j in range(11):
                b = J[i][j]
                if b is not None and b.size:
                    out[o[i]:o[i + 1], o[j]:o[j + 1]] = b.toarray() if sp.issparse(b) else b
        return out

    def jacobian(self, s, ev, x, normal_sets, Fd):
        """The 11 × 11 blocks of ∂R/∂x (see :meth:`system`), dense (the Python dense path; the sparse path
        gathers the same terms in :meth:`_sparse_jacobian`)."""
        model, h, cu, cq = self.model, self.h, self.c_u, self.c_q
        A, B_, C = normal_sets
        lg = self.split(x)[5]
        M, Bc, WN, WF = ev["M"], ev["B"], ev["WN"], ev["WF"]
        fq, fu = assembly.force_jacobians(model, s.t + h, ev["q"], ev["u"])
        K1 = -fq + _bilateral_H(model, s.t + h, ev["q"], lg) - ev["H"]
        C1 = -fu
        M, Bc, WN, WF, K1, C1 = (a.toarray() if sp.issparse(a) else a for a in (M, Bc, WN, WF, K1, C1))
        dg = np.diag
        Af, Bf, Cf = A.astype(float), B_.astype(float), C.astype(float)
        Dxi, Dgd, Dg, Dpn, Dln = (Fd[k] for k in ("Dxi", "Dgd", "Dg", "Dpn", "Dln"))
        J = [[None] * 11 for _ in range(11)]
        J[0][0], J[0][1], J[0][2] = M + cq * K1 + cu * C1, C1, K1
        J[0][5], J[0][8], J[0][10] = Bc.T, -WN.T, -WF.T
        J[1][1], J[1][4], J[1][7], J[1][9] = M, Bc.T, -WN.T, -WF.T
        J[2][2], J[2][3], J[2][6], J[2][9] = M, Bc.T, -WN.T, -0.5 * h * WF.T
        J[3][0], J[3][2] = cq * Bc, Bc
        J[4][0], J[4][1] = cu * Bc, Bc
        J[5][0] = Bc
        J[6][0], J[6][2], J[6][6], J[6][8] = cq * (dg(Af) @ WN), dg(Af) @ WN, dg(1 - Af), cq * dg(1 - Af)
        J[7][0], J[7][1], J[7][7], J[7][8] = cu * (dg(Bf) @ WN), dg(Bf) @ WN, dg(1 - Bf), cu * dg(1 - Bf)
        J[8][0], J[8][8] = dg(Cf) @ WN, dg(1 - Cf)
        J[9][0], J[9][1], J[9][7], J[9][8] = cu * (Dxi @ WF), Dxi @ WF, Dpn, cu * (dg(Fd["Dsm"]) @ Dpn)
        J[9][9], J[9][10] = dg(Fd["Dpf"]), cu * dg(Fd["Dsm"] * Fd["Dpf"])
        J[10][0], J[10][1], J[10][8], J[10][10] = Dgd @ WF + cu * (Dg @ WF), Dg @ WF, Dln, dg(Fd["Dlf"])
        return J

    def scale(self, sets):
        """Row weights that turn every row of R into a length (for the Newton test); the acceleration rows
        with max(h, h_acc)² (core._scale)."""
        h, m = self.h, self.m_ref
        ha = max(h, self.h_acc)
        ha2 = ha * ha
        A, B_, C, D, E = sets
        w = self.model.force_weight
        Df = np.zeros(self.lay.nF, dtype=bool)
        Ef = np.zeros(self.lay.nF, dtype=bool)
        for i, idx in enumerate(self.lay.friction):
            Df[idx], Ef[idx] = D[i], E[i]
        n, mc = self.model.nq, self.model.nc
        return np.concatenate((ha2 * w / m, h * w / m, w / m, np.ones(mc), np.full(mc, h), np.full(mc, ha2),
                               np.where(A, 1.0, 1.0 / m), np.where(B_, h, h / m), np.where(C, ha2, ha2 / m),
                               np.where(Df, h, h / m), np.where(Ef, ha2, ha2 / m)))

    # ------------------------------------------------------------------ solvers
    def newton(self, s, x0, fixed_z=None, max_iter=None):
        """Semismooth Newton iterations on R(x) = 0 (index sets updated at every iterate).

        Returns
        -------
        (x, ev, sets, iterations, converged, error)
        """
        if self.dense and (fixed_z is None or self._loop_ok):
            return self.newton_dense(s, x0, max_iter, fixed_z)
        x = x0.copy()
        err = np.inf
        frozen = None
        x_prev, sets_prev, err_prev, theta, dx = x, None, np.inf, 1.0, None
        for it in range(1, (max_iter or self.max_iter) + 1):
            R, J, ev, sets = self.system(s, x, fixed_z, frozen)
            werr = np.abs(self.scale(sets) * R)
            err = float(np.max(werr)) if R.size else 0.0
            if not np.all(np.isfinite(ev["gN"])):     # a gap its kernel could not define (as core.residual)
                err = np.nan
            if not np.isfinite(err):
                return x, ev, sets, it, False, err
            if err <= (self.tol if it > 1 else core.GUESS_TOL * self.tol):   # core.GUESS_TOL: the start guess
                if frozen is None:
                    return x, ev, sets, it, True, err
                # converged with the index sets held: a solution if they are its own index sets
                R2, _, ev2, sets2 = self.system(s, x, fixed_z)
                err2 = float(np.max(np.abs(self.scale(sets2) * R2))) if R2.size else 0.0
                return x, ev2, sets2, it, err2 <= self.tol, err2
            worst = int(np.argmax(werr)) if R.size else 0
            if sets_prev is not None and core.damp_step(err, err_prev, np.array(sets, dtype=np.int8), sets_prev,
                                                        theta, worst >= self.offsets[9]):
                theta *= 0.5                  # the same branch and no decrease: half the step (core.damp_step)
                x = x_prev + theta * dx
                continue
            x_prev, sets_prev, err_prev, theta = x, np.array(sets, dtype=np.int8), err, 1.0
            if it >= self.freeze_after and frozen is None:   # the index sets keep switching: hold them
                frozen = sets
            dx = self.newton_increment(J, R)
            if dx is None:
                return x, ev, sets, it, False, err
            if self._converged_by_increment(dx, it, frozen):
                return x, ev, sets, it, True, err
            x = x + dx
        R, J, ev, sets = self.system(s, x, fixed_z)
        err = float(np.max(np.abs(self.scale(sets) * R))) if R.size else 0.0
        return x, ev, sets, self.max_iter, err <= self.tol, err

    def _converged_by_increment(self, dx, it, frozen):
        """Whether the iterate whose Newton increment is ``dx`` is converged although its residual is above
        the tolerance: a regular J's increment, as a length (:func:`femb.contact.core.increment_size`), within
        the tolerance, after the first iteration and with the index sets not held (as the compiled
        iteration, :func:`femb.contact.core.newton_loop`)."""
        if it <= 1 or frozen is not None or not self._regular:
            return False
        par = np.zeros(16)
        par[0], par[4], par[15] = self.h, self.m_ref, self.h_acc
        return core.increment_size(np.ascontiguousarray(dx, dtype=float), *self._inc_arrays, par) <= self.tol

    def newton_increment(self, J, R):
        """Solve J dx = −R; with a rank-deficient J (forces that the contact laws leave undetermined,
        e.g. the friction forces of two sticking corners of one block, of which only the sum is
        unique) the minimum-norm increment (SVD; LSQR on the sparse path), which keeps the undetermined
        parts where they are (the dense path's :meth:`_dense_increment` shares them out by
        :func:`femb.contact.core.minimum_norm_step`). None if J cannot be factored at all.

        The rank test is made on J equilibrated by rows and columns (each divided by its largest
        entry): a stiff beam's K_t beside small rotational masses and the constraint rows spreads
        J's pivots over more than 1e11 with J regular (a spatial beam, E = 2.1e9 Pa, 2 elements: 4e-14
        unscaled, 1.6e-4 equilibrated), which the least-squares path would truncate."""
        try:
            Js, r, c = _equilibrate(J, self.dense)
            if self.dense:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", sla.LinAlgWarning)
                    lu, piv = sla.lu_factor(Js, check_finite=False)
                d = np.abs(np.diag(lu))
                self._regular = d.min() > 1e-11 * d.max()
                if self._regular:
                    return c * sla.lu_solve((lu, piv), -r * R, check_finite=False)
                return np.linalg.lstsq(J, -R, rcond=1e-11)[0]
            y = _solve_unit_rows(Js, -r * R)
            if y is not None:
                self._regular = True
                return c * y
            # minimum degree on Jᵀ + J: as fast as COLAMD on beams and on spheres against the floor, ten times
            # faster where sphere pairs couple every body (docs/contact.md §7)
            Js.eliminate_zeros()            # the zeros of J's fixed pattern would steer the ordering: 100-element
            lu = spla.splu(Js, permc_spec="MMD_AT_PLUS_A")   # beam on the stop 50-53 -> 36-41 ms per step
            d = np.abs(lu.U.diagonal())
            self._regular = d.min() > 1e-11 * d.max()
            if self._regular:
                return c * lu.solve(-r * R)
            return spla.lsqr(J, -R, atol=1e-14, btol=1e-14)[0]
        except (RuntimeError, ValueError, np.linalg.LinAlgError):
            return None

    def prox_update(self, s, x):
        """The proximal update z ↦ p(y, z) of eq. (146), eqs. (128)–(140) in turn."""
        ev = self._dense_evaluate(s, x) if self.dense and self._loop_ok else self.evaluate(s, x)
        rN, rF, mu = self.rN, self.rF, self.lay.mu
        h, am, af, b, g = self.h, self.am, self.af, self.beta, self.gamma
        lN_j, lF_j = self.split(x)[8], self.split(x)[10]
        kN_hat = prox_nonnegative(ev["kN_hat"] - rN * ev["gN"])              # (128)
        A = rN * ev["gN"] - ev["kN_hat"] <= 0.0
        PN = np.where(A, prox_nonnegative(ev["PN"] - rN * ev["xiN"]), 0.0)     # (131)
        B_ = A & (rN * ev["xiN"] - ev["PN"] <= 0.0)
        lN = np.where(B_, prox_nonnegative(lN_j - rN * ev["gNdd"]), 0.0)      # (134)
        PF, lF = np.zeros(self.lay.nF), np.zeros(self.lay.nF)
        slip = np.zeros(self.lay.nF, dtype=bool)
        for i, idx in enumerate(self.lay.friction):
            if not idx.size or not A[i]:
                continue
            arg = ev["PF"][idx] - rF[idx] * ev["xiF"][idx]                    # (137)
            PF[idx] = prox_disc(arg, mu[i] * PN[i])
            if np.linalg.norm(arg) <= mu[i] * PN[i]:                          # (139), (140a)
                lF[idx] = prox_disc(lF_j[idx] - rF[idx] * ev["gFdd"][idx], mu[i] * lN[i])
            else:                                                             # (140b)
                v, _ = direction(ev["gF"][idx])
                lF[idx] = -mu[i] * lN[i] * v
                slip[idx] = True
        lbN = (af * s.lam_N + (1 - af) * lN - am * s.lbar_N) / (1 - am)
        lbF = (af * s.lam_F + (1 - af) * lF - am * s.lbar_F) / (1 - am)
        LN = PN - h * ((1 - g) * s.lbar_N + g * lbN)                          # (95)
        kN = kN_hat - h * h * ((0.5 - b) * s.lbar_N + b * lbN)                # (102)
        LF = PF - h * ((1 - g) * s.lbar_F + g * lbF)                          # (113)
        for i, idx in enumerate(self.lay.friction):                           # slip: Λ_F from Λ_N (friction_rows)
            if idx.size and slip[idx[0]] and not self.slip_on_P:
                v, _ = direction(ev["xiF"][idx])
                LF[idx] = -mu[i] * LN[i] * v
        return np.concatenate((kN, LN, lN, LF, lF))

    def fixed_point(self, s, x0):
        """The prox fixed point of eqs. (144)–(146); returns (x, ev, sets, iterations, converged, error).

        When the change has not reached a new least value for ``core.FP_STALL`` iterations, r is halved for
        the rest of this fixed point (at most ``core.FP_HALVINGS`` times; as the compiled
        :func:`femb.contact.loop._fixed_point`); the step's r is restored on return."""
        r0 = (self.rN, self.rF)
        try:
            return self._fixed_point(s, x0)
        finally:
            self._set_r(*r0)

    def _set_r(self, rN, rF):
        self.rN, self.rF = rN, rF
        if self.dense:
            self._law = (rN, rF) + self._fixed_law

    def _fixed_point(self, s, x0):
        o = self.offsets[6]
        x = x0.copy()
        z = x[o:].copy()
        err = np.inf
        track = np.array([np.inf, 0.0, 0.0])         # core.fp_stalled
        for it in range(1, self.max_fp + 1):
            x[o:] = z
            x, ev, sets, _, ok, _ = self.newton(s, x, fixed_z=z)
            if not ok:
                return x, ev, sets, it, False, np.inf
            z1 = self.prox_update(s, x)
            step = np.abs(z1 - z)
            ha = max(self.h, self.h_acc)           # the acceleration rows as in scale()
            ha2 = ha * ha
            scale = np.concatenate((np.full(self.lay.nN, 1.0 / self.m_ref), np.full(self.lay.nN, self.h / self.m_ref),
                                    np.full(self.lay.nN, ha2 / self.m_ref),
                                    np.full(self.lay.nF, self.h / self.m_ref),
                                    np.full(self.lay.nF, ha2 / self.m_ref)))
            err = float(np.max(step * scale)) if step.size else 0.0
            z = z1
            if err <= self.tol:
                x[o:] = z
                R, _, ev, sets = self.system(s, x)
                return x, ev, sets, it, True, err
            if core.fp_stalled(err, track):               # smaller r for the rest of the step
                self._set_r(0.5 * self.rN, 0.5 * self.rF)
        x[o:] = z
        R, _, ev, sets = self.system(s, x)
        return x, ev, sets, self.max_fp, False, err

    def _remember(self, s, ev):
        """Keep W of a step's solution for the prox parameters of the step that starts there."""
        self.remember_W(ev["q"], s.t + self.h, ev["WN"], ev["WF"])

    def remember_W(self, q, t, WN, WF):
        """W at (q, t) (dense arrays on the dense path) for :meth:`prox_r` at that state, instead of
        evaluating it again (the end of a step; the start of a run)."""
        self._r_cache = (q, t, WN, WF)

    def solve(self, s):
        """One step from s: semismooth Newton, the fixed point if Newton fails, Newton again from where
        the fixed point got to; if all fail, the same three with the slip law (138b) on the whole
        percussions (``slip_on_P``, the paper's law; docs/contact.md §1.1 item 5).

        Returns
        -------
        (x, ev, sets, info) with info = dict(method, iterations, error)

        Raises
        ------
        StepFailure
        """
        self.rN, self.rF = self.prox_r(s.q, s.t)
        if self.dense:
            self._law = (self.rN, self.rF) + self._fixed_law
        x0 = s.x if s.x is not None else np.zeros(self.nx)
        x, ev, sets, it, ok, err = self.newton(s, x0)
        if ok:
            self._remember(s, ev)
            return x, ev, sets, dict(method="newton", iterations=it, error=err)
        x1, ev1, sets1, it1, ok1, err1 = self.fixed_point(s, x0)
        if ok1:
            self._remember(s, ev1)
            return x1, ev1, sets1, dict(method="fixed_point", iterations=it + it1, error=err1)
        it2 = 0
        if np.all(np.isfinite(x1)):             # Newton again, from where the fixed point got to
            x2, ev2, sets2, it2, ok2, err2 = self.newton(s, x1)
            if ok2:
                self._remember(s, ev2)
                return x2, ev2, sets2, dict(method="fixed_point", iterations=it + it1 + it2, error=err2)
        why = (f"semismooth Newton: {it} iterations, residual {err:.3e}; prox fixed point: {it1} iterations, "
               f"last change {err1:.3e} (tolerance {self.tol:.1e})")
        if self.slip_on_P:                      # the paper's law already: nothing else to try
            raise StepFailure(why, x, sets)
        # The slip law on Λ with the stick test on P can have no solution where a sticking contact
        # starts to slip (docs/contact.md §1.1 item 5): the step again with (138b) on P, the paper's law.
        self.slip_on_P = True
        try:
            x3, ev3, sets3, it3, ok3, err3 = self.newton(s, x0)
            n3 = it3
            if not ok3:
                x3, ev3, sets3, it3, ok3, err3 = self.fixed_point(s, x0)
                n3 += it3
                if not ok3 and np.all(np.isfinite(x3)):
                    x3, ev3, sets3, it3, ok3, err3 = self.newton(s, x3)
                    n3 += it3
        finally:
            self.slip_on_P = False
        if ok3:
            self._remember(s, ev3)
            return x3, ev3, sets3, dict(method="slip_on_P", iterations=it + it1 + it2 + n3, error=err3)
        raise StepFailure(why + "; the same with the slip law on the whole percussions", x, sets)
