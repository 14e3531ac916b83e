"""Consistent initial values and the analysis of redundant constraints.

:func:`consistent_initial_state` projects a user's initial state onto the
constraints at position, velocity and acceleration level (method.md §5) and
says what it did: every body it moved by more than a tolerance is reported in
a warning, and a move above ``max_initial_move`` is an error naming the joints
that were furthest from closed.

:func:`redundancy` finds dependent constraint equations with a rank-revealing
QR factorization (column pivoting) of the scaled Φ_qᵀ and names them;
:meth:`femb.Mechanism.compile` uses it for ``redundant="eliminate"``, which
records a mask ``model.active_constraints``: an eliminated equation keeps its
index in λ and is treated as λ_i = 0 with its rows of Φ and Φ_q dropped.

References
----------
G. H. Golub, C. F. Van Loan, Matrix Computations, 4th ed., Johns Hopkins,
2013, §5.4.2 (QR with column pivoting, numerical rank).

J. García de Jalón, E. Bayo, Kinematic and Dynamic Simulation of Multibody
Systems, Springer, 1994, §3.5 and §5.5 (redundant constraints; their
reactions are not unique).
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from femb import assembly
from femb.errors import (SINGULAR_HINT, SINGULAR_HINT_DIVERGED, SINGULAR_HINT_INDEPENDENT, SINGULAR_HINT_STEP,
                         InitializationError,
                         InitialMoveWarning, InitialVelocityWarning, ModelError,  # noqa: F401 (re-exported)
                         RedundantConstraintWarning)

#: systems with at most this many unknowns are solved with dense LU
DENSE_LIMIT = 200

#: relative tolerance of the numerical rank of the scaled Φ_q (|R_kk| ≤ RANK_TOL |R_00| is zero)
RANK_TOL = 1e-10

#: default limit of an initial move, as a fraction of the model's length scale (see consistent_initial_state)
MAX_INITIAL_MOVE = 0.01

#: bodies moved by more than this fraction of the length scale (or this many rad) are reported
REPORT_MOVE = 1e-6


# --------------------------------------------------------------------------
# naming
# --------------------------------------------------------------------------
def constraint_labels(model):
    """(element name, equation name) of every constraint equation, a list of length nc."""
    labels = [None] * model.nc
    for g in model.constraint_groups:
        eq = tuple(getattr(g.cls, "constraint_names", ()) or ())
        for name, row in zip(g.names, g.lam):
            for k, i in enumerate(row):
                labels[int(i)] = (name, eq[k] if k < len(eq) else str(k))
    for i, lab in enumerate(labels):
        if lab is None:
            labels[i] = ("?", str(i))
    return labels


def _kind(model, name):
    return model.element_types.get(name, "element").lower()


def _describe(model, pairs):
    """'hinge 'h2' equations x, y' for a list of (element, equation), grouped by element."""
    by = {}
    for el, eq in pairs:
        by.setdefault(el, []).append(eq)
    parts = []
    for el, eqs in by.items():
        word = "equation" if len(eqs) == 1 else "equations"
        parts.append(f"{_kind(model, el)} '{el}' {word} {', '.join(eqs)}")
    return " and ".join(parts)


def active_mask(model):
    """``model.active_constraints`` or all True (shape (nc,))."""
    act = getattr(model, "active_constraints", None)
    return np.ones(model.nc, dtype=bool) if act is None else np.asarray(act, dtype=bool)


# --------------------------------------------------------------------------
# redundancy
# --------------------------------------------------------------------------
@dataclass
class Redundancy:
    """Result of :func:`redundancy`.

    Attributes
    ----------
    rank : int
        Numerical rank of Φ_q (active rows).
    dependent : list of int
        Indices into λ of equations that depend on the others (the ones
        ``redundant="eliminate"`` removes).
    groups : list of (int, list of int)
        For each dependent equation, the independent equations it is a
        combination of.
    labels : list of (str, str)
        (element, equation) of every constraint (length nc).
    """

    rank: int
    dependent: list = field(default_factory=list)
    groups: list = field(default_factory=list)
    labels: list = field(default_factory=list)

    def message(self, model):
        """A sentence per dependent equation, naming the joints involved."""
        lines = []
        by_el = {}
        for j, basis in self.groups:
            el = self.labels[j][0]
            d = by_el.setdefault(el, ([], []))
            d[0].append(self.labels[j])
            for i in basis:
                if self.labels[i] not in d[1]:
                    d[1].append(self.labels[i])
        for el, (dep, basis) in by_el.items():
            lines.append(f"{_describe(model, dep)} {'is' if len(dep) == 1 else 'are'} dependent on "
                         f"{_describe(model, basis) if basis else 'nothing (a zero row)'}")
        return "; ".join(lines)


def redundancy(model, q=None, t=0.0, rank_tol=RANK_TOL):
    """Dependent constraint equations at a configuration (rank-revealing QR).

    Φ_q (active rows only) is scaled to be dimensionless, A = R Φ_q W, with W
    dividing rotation columns by the length scale L (Φ_q entries of a
    rotation are lengths) and R making every row's largest entry 1; then
    Aᵀ = Q R P (scipy.linalg.qr with column pivoting, Golub & Van Loan §5.4.2).
    Equations whose pivot |R_kk| ≤ rank_tol |R_00| are dependent; the first
    ``rank`` pivoted columns are kept. A dependent equation's combination of
    kept ones is R_11⁻¹ R_12.

    Parameters
    ----------
    model : Model
    q : ndarray, shape (nq,), optional
        Configuration (default: the initial coordinates as given).
    t : float
    rank_tol : float

    Returns
    -------
    Redundancy
    """
    labels = constraint_labels(model)
    if model.nc == 0:
        return Redundancy(0, [], [], labels)
    q = model.q0 if q is None else np.asarray(q, dtype=float)
    act = np.nonzero(active_mask(model))[0]
    B = assembly.constraint_jacobian(model, t, q).toarray()[act]
    A = B * model.force_weight[None, :]
    rmax = np.abs(A).max(axis=1)
    zero = rmax == 0.0
    A[~zero] /= rmax[~zero, None]
    _, R, piv = sla.qr(A.T, mode="economic", pivoting=True)
    d = np.abs(np.diag(R))
    top = d[0] if d.size else 0.0
    rank = int(np.sum(d > rank_tol * top)) if top > 0 else 0
    dep_local = piv[rank:]
    groups = []
    if dep_local.size:
        R11, R12 = R[:rank, :rank], R[:rank, rank:]
        C = sla.solve_triangular(R11, R12) if rank else np.zeros((0, dep_local.size))
        for k, j in enumerate(dep_local):
            c = np.abs(C[:, k]) if rank else np.zeros(0)
            basis = sorted(int(act[piv[i]]) for i in np.nonzero(c > 1e-8 * max(c.max(initial=0.0), 1e-300))[0])
            groups.append((int(act[j]), basis))
    groups.sort()
    return Redundancy(rank, [g[0] for g in groups], groups, labels)


def eliminate_redundant(model, t=0.0):
    """Mask and names of the equations ``redundant="eliminate"`` removes (at the initial configuration).

    Returns
    -------
    active : ndarray of bool, shape (nc,)
    removed : list of (str, str)
        (element name, equation name) of the removed equations.
    analysis : Redundancy
    """
    an = redundancy(model, t=t)
    active = np.ones(model.nc, dtype=bool)
    active[an.dependent] = False
    return active, [an.labels[j] for j in an.dependent], an


def singular_hint(model, q, t=0.0, diverged=False):
    """The hint that fits a singular iteration matrix at configuration ``q``.

    After a diverging Newton iteration: the step size. Otherwise a rank test
    of Φ_q (:func:`redundancy`): dependent equations are named (redundant
    joints or a singular position). With independent constraints, the matrix
    [[M, Φ_qᵀ], [Φ_q, 0]] decides: regular, the singular iteration matrix comes
    from its h-dependent terms and the hint names the step size first;
    singular, a coordinate has neither mass nor a constraint.

    Returns
    -------
    str
    """
    if diverged:
        return SINGULAR_HINT_DIVERGED
    try:
        an = redundancy(model, q, t)
    except Exception:                      # the hint must never hide the error it explains
        return SINGULAR_HINT
    if an.dependent:
        return (f"hint: redundant constraints or a singular (dead-centre) position: {an.message(model)}; "
                "remove the dependent joints or compile with redundant=\"eliminate\"")
    try:
        rows = np.nonzero(active_mask(model))[0]
        M = assembly.mass_matrix(model, q)
        B = assembly.constraint_jacobian(model, t, q).tocsr()[rows]
        regular = _solve_augmented(M, B, np.zeros(model.nq), np.zeros(rows.size), "hint") is not None
    except Exception:                      # the hint must never hide the error it explains
        return SINGULAR_HINT_INDEPENDENT
    return SINGULAR_HINT_STEP if regular else SINGULAR_HINT_INDEPENDENT


# --------------------------------------------------------------------------
# linear solves
# --------------------------------------------------------------------------
def _solve_augmented(A, B, rhs_top, rhs_bottom, what):
    """Solve [[A, Bᵀ], [B, 0]] [x; y] = [rhs_top; rhs_bottom]; None if singular."""
    K = sp.bmat([[A, B.T], [B, None]], format="csc") if B.shape[0] else sp.csc_matrix(A)
    rhs = np.concatenate((rhs_top, rhs_bottom))
    n = A.shape[0]
    if K.shape[0] <= DENSE_LIMIT:
        lu, piv, info = sla.lapack.dgetrf(K.toarray())
        d = np.abs(np.diag(lu))
        if info > 0 or not np.all(np.isfinite(d)) or d.min() <= 1e-13 * d.max():
            return None
        x = sla.lu_solve((lu, piv), rhs)
    else:
        import scipy.sparse.linalg as spla
        try:
            lu = spla.splu(K)
        except RuntimeError:
            return None
        d = np.abs(lu.U.diagonal())
        if not np.all(np.isfinite(d)) or d.min() <= 1e-13 * d.max():
            return None
        x = lu.solve(rhs)
    return x[:n], x[n:]


def _zero_rows(B, labels):
    absmax = np.zeros(B.shape[0])
    Bc = B.tocoo()
    np.maximum.at(absmax, Bc.row, np.abs(Bc.data))
    bad = np.nonzero(absmax == 0.0)[0]
    if bad.size:
        el, eq = labels[bad[0]]
        raise InitializationError(
            f"constraint equation '{eq}' of element '{el}' does not depend on any free "
            "coordinate (it acts only on fixed coordinates): remove it or free a coordinate")


def _redundancy_error(model, q, t, why):
    an = redundancy(model, q, t)
    if an.dependent:
        return InitializationError(
            f"{why}: redundant constraints at the initial configuration: {an.message(model)}. "
            "Remove the dependent joints (or use a joint that removes fewer motions), or compile "
            "with Mechanism.compile(redundant=\"eliminate\") to drop the dependent equations "
            "(their joints' reactions are then not unique); if the joints are not structurally "
            "redundant, the mechanism is in a singular (dead-centre) position")
    return None


# --------------------------------------------------------------------------
# consistent initial values (method.md §5)
# --------------------------------------------------------------------------
def body_moves(model, q_from, q_to):
    """Displacement and rotation of every body between two configurations.

    Returns
    -------
    list of (str, float, float)
        (body name, distance moved in m, angle turned in rad), for bodies with
        free coordinates, in the order of ``model.bodies``.
    """
    out = []
    for name, body in model.bodies.items():
        node = getattr(body, "node", None)
        if node is None or node.name not in model.node_index:
            continue
        idx = model.node_index[node.name]
        a = model.node_coordinates(node.name, q_from)
        b = model.node_coordinates(node.name, q_to)
        tr = list(node.translational)
        if not np.any(idx < model.nq):
            continue
        dist = float(np.linalg.norm(b[tr] - a[tr])) if tr else 0.0
        rot = [c for c in range(len(idx)) if c not in tr]
        if getattr(node, "rotation_blocks", ()):
            # angle between two unit quaternions: 2 acos |p_a · p_b|
            ang = max(2.0 * math.acos(min(1.0, abs(float(np.dot(a[xs:xs + 4], b[xs:xs + 4])))))
                      for xs, _ in node.rotation_blocks)
        else:
            ang = float(np.abs(b[rot] - a[rot]).max()) if rot else 0.0
        out.append((name, dist, ang))
    return out


def consistent_initial_state(model, state=None, *, t0=0.0, phi_tol=1e-12, max_iter=50,
                             max_initial_move=None, report_move=REPORT_MOVE, contacts=False):
    """Project an initial state onto the constraints at all levels, and say so.

    1. positions: least change q = argmin ‖q − q_0‖ subject to Φ(q, t_0) = 0
       (Gauss–Newton);
    2. velocities: q̇ = argmin ‖q̇ − q̇_0‖ subject to Φ_q q̇ = −Φ_t;
    3. accelerations and multipliers from
       [[M, Φ_qᵀ], [Φ_q, 0]] [q̈; λ] = [f; −γ].

    Equations removed by ``Mechanism.compile(redundant="eliminate")``
    (``model.active_constraints``) are left out and get λ_i = 0.

    Parameters
    ----------
    model : Model
    state : State, optional
        Starting guess (default: the model's initial state).
    t0 : float
    phi_tol : float
        Relative tolerance: ‖Φ‖∞ ≤ phi_tol × model.length_scale.
    max_iter : int
    max_initial_move : float, optional
        Largest move of a body (m; a rotation counts as angle × length scale)
        accepted from the given to the consistent positions. Default:
        ``model.max_initial_move`` if the model has one (set by
        ``Mechanism.compile(max_initial_move=...)``), else 1 % of the model's
        length scale: rounding of the input (µm) passes, a joint placed at a
        wrong point (a visible fraction of the mechanism) does not.
        ``float("inf")`` disables the check.
    contacts : bool
        Accept a model with contact elements (only :func:`femb.contact.simulate` does: it
        treats the contacts itself); otherwise such a model is a ModelError, so that
        ``femb.simulate`` never integrates it silently without its contacts.
    report_move : float
        Bodies moved by more than ``report_move`` × length scale (or turned by
        more than ``report_move`` rad) are listed in an
        :class:`InitialMoveWarning`. Velocities: when a velocity that was given
        (a body with a non-zero initial velocity) is changed by the projection
        by more than ``report_move`` times the run's velocity scale (the largest
        ‖v‖ and L‖ω‖ of the given and the consistent velocities), every body
        whose velocity changed is listed in an
        :class:`~femb.errors.InitialVelocityWarning` (a subclass of
        :class:`InitialMoveWarning`). Bodies given no velocity that a driver or
        a moving neighbour sets in motion are not a surprise and do not warn
        alone.

    Returns
    -------
    State

    Raises
    ------
    InitializationError
        If the positions cannot be projected (names the constraint with the
        largest residual), a body would move more than ``max_initial_move``
        (names the joints with the largest initial residual), constraint
        equations are dependent (names them, and what they depend on), or a
        matrix is singular.
    """
    if getattr(model, "n_contacts", 0) and not contacts:
        raise ModelError(f"model '{model.name}' has contact elements ({model.n_contacts} contacts): the compiled "
                         "engine (femb.simulate) does not treat contacts yet and would ignore them; integrate it "
                         "with femb.contact.simulate (docs/contact.md)")
    st = (state or model.initial_state(t0)).copy()
    t = st.t
    nq, nc = model.nq, model.nc
    L = model.length_scale
    I = sp.identity(nq, format="csr")
    labels = constraint_labels(model)
    act = active_mask(model)
    rows = np.nonzero(act)[0]
    tol = phi_tol * L
    if max_initial_move is None:
        max_initial_move = getattr(model, "max_initial_move", None)
    if max_initial_move is None:
        max_initial_move = MAX_INITIAL_MOVE * L
    max_initial_move = float(max_initial_move)
    if not max_initial_move > 0.0:
        raise ModelError(f"max_initial_move must be a positive length (m), got {max_initial_move!r}")
    B = sp.csr_matrix((0, nq))
    gam = np.zeros(0)
    if nc:
        q0 = st.q.copy()
        q = st.q.copy()
        B0 = assembly.constraint_jacobian(model, t, q).tocsr()[rows]
        _zero_rows(B0, [labels[i] for i in rows])
        Phi0 = assembly.constraint_vector(model, t, q)
        for k in range(max_iter + 1):
            Phi = assembly.constraint_vector(model, t, q)
            err = np.abs(Phi).max()
            if not np.isfinite(err):
                raise InitializationError("initial positions give non-finite constraint values")
            if err <= tol:
                break
            if k == max_iter:
                i = int(np.argmax(np.abs(Phi)))
                raise InitializationError(
                    f"cannot project the initial configuration onto the constraints: ‖Φ‖ = {err:.3e} "
                    f"after {max_iter} Gauss–Newton iterations; largest residual in {_describe(model, [labels[i]])} "
                    f"({Phi[i]:.3e}). The joints cannot all be closed from these positions: "
                    "check the bodies' positions and the joints' points")
            Bk = assembly.constraint_jacobian(model, t, q).tocsr()[rows]
            sol = _solve_augmented(I, Bk, model.difference(q0, q), -Phi[rows], "position projection")
            if sol is None:
                i = int(np.argmax(np.abs(Phi)))
                why = (f"cannot project the initial configuration onto the constraints: ‖Φ‖ = {err:.3e} "
                       f"(largest residual in {_describe(model, [labels[i]])}, {Phi[i]:.3e}) and the constraint "
                       f"Jacobian is rank-deficient at Gauss–Newton iteration {k}")
                e = _redundancy_error(model, q, t, why)
                raise e or InitializationError(f"{why}; {SINGULAR_HINT}")
            q = model.compose(q, sol[0])
        _check_moves(model, q0, q, Phi0, labels, act, max_initial_move, report_move)
        st.q = q
        B = assembly.constraint_jacobian(model, t, st.q).tocsr()[rows]
        Phi_t, _ = assembly.constraint_rates(model, t, st.q, st.qd)
        sol = _solve_augmented(I, B, st.qd, -Phi_t[rows], "velocity projection")
        if sol is None:
            e = _redundancy_error(model, st.q, t, "cannot make the initial velocities consistent")
            raise e or InitializationError(f"velocity projection: singular constraint Jacobian; {SINGULAR_HINT}")
        _check_velocity_changes(model, st.qd, sol[0], report_move)
        st.qd = sol[0]
        _, gam = assembly.constraint_rates(model, t, st.q, st.qd)
        gam = gam[rows]
    M = assembly.mass_matrix(model, st.q)
    f = assembly.force_vector(model, t, st.q, st.qd)
    sol = _solve_augmented(M, B, f, -gam, "initial accelerations")
    if sol is None:
        raise InitializationError(f"initial accelerations: the matrix [[M, Φ_qᵀ], [Φ_q, 0]] is singular; "
                                  f"{SINGULAR_HINT}")
    st.qdd = sol[0]
    st.lam = np.zeros(nc)
    st.lam[rows] = sol[1]
    if not (np.all(np.isfinite(st.qdd)) and np.all(np.isfinite(st.lam))):
        raise InitializationError("initial accelerations are not finite")
    return st


def _check_moves(model, q0, q, Phi0, labels, act, limit, report_move):
    L = model.length_scale
    moves = body_moves(model, q0, q)
    big = [(n, d, a) for n, d, a in moves if d > report_move * L or a > report_move]
    if not big:
        return
    worst = max(max(d, a * L) for _, d, a in big)
    listing = ", ".join(f"'{n}' by {d:.3g} m and {a:.3g} rad" for n, d, a in big)
    res = np.where(act, np.abs(Phi0), 0.0)
    order = np.argsort(-res)
    top = [labels[i] for i in order[:4] if res[i] > 0.5 * res[order[0]] and res[i] > 0.0]
    joints = _describe(model, top)
    if worst > limit:
        raise InitializationError(
            f"the initial configuration is {worst:.3g} m away from closing the constraints (limit "
            f"max_initial_move = {limit:.3g} m): the largest initial residual is in {joints} "
            f"({res[order[0]]:.3g}); the projection would move {listing}. Check the bodies' positions and "
            "the joints' points, or raise max_initial_move (Mechanism.compile(max_initial_move=...))")
    warnings.warn(f"model '{model.name}': the initial positions were moved onto the constraints: {listing} "
                  f"(largest initial residual in {joints}, {res[order[0]]:.3g})",
                  InitialMoveWarning, stacklevel=4)


def body_velocity_changes(model, qd_from, qd_to):
    """Change of every body's velocity between two velocity vectors.

    Returns
    -------
    list of (str, float, float, bool, float)
        (body name, change of the translational velocity in m/s, change of
        the angular velocity in rad/s, whether the body had a non-zero
        velocity in ``qd_from``, the body's velocity scale max(‖v‖, L‖ω‖) over
        both vectors in m/s), for bodies with free velocities, in the order of
        ``model.bodies``.
    """
    L = model.length_scale
    out = []
    for name, body in model.bodies.items():
        node = getattr(body, "node", None)
        if node is None or node.name not in model.node_vindex:
            continue
        vidx = model.node_vindex[node.name]
        if not np.any(vidx < model.nq):
            continue
        a = model.node_velocities(node.name, qd_from)
        b = model.node_velocities(node.name, qd_to)
        tr = list(node.translational)
        rot = [c for c in range(vidx.size) if c not in tr]
        dv = float(np.linalg.norm(b[tr] - a[tr])) if tr else 0.0
        dw = float(np.linalg.norm(b[rot] - a[rot])) if rot else 0.0
        scale = max(float(np.linalg.norm(v[tr])) if tr else 0.0 for v in (a, b))
        scale = max(scale, max(L * float(np.linalg.norm(v[rot])) if rot else 0.0 for v in (a, b)))
        out.append((name, dv, dw, bool(np.any(a != 0.0)), scale))
    return out


def _check_velocity_changes(model, qd0, qd, report_move):
    changes = body_velocity_changes(model, qd0, qd)
    if not changes:
        return
    L = model.length_scale
    V = max(s for *_, s in changes)
    if V == 0.0:
        return
    tol = report_move * V
    changed = [(n, dv, dw, given) for n, dv, dw, given, _ in changes if max(dv, L * dw) > tol]
    if not any(given for *_, given in changed):
        return
    listing = ", ".join(f"'{n}' by {dv:.3g} m/s and {dw:.3g} rad/s" + ("" if given else " (given none)")
                        for n, dv, dw, given in changed)
    warnings.warn(f"model '{model.name}': the initial velocities were changed to satisfy the constraints "
                  f"(B q̇ + Φ_t = 0; least change): {listing}. Give consistent initial velocities to keep "
                  "them as given", InitialVelocityWarning, stacklevel=4)
