"""Consistent initial values, the start of flexible models, and the analysis of redundant constraints.

:func:`consistent_initial_state` projects a user's initial state onto the
constraints at position, velocity and acceleration level (method.md §5) and
says what it did: every body it moved by more than a tolerance is reported in
a warning, and a move above ``max_initial_move`` is an error naming the joints
that were furthest from closed.

Flexible models (elements with mass and stiffness, :func:`deformable_groups`)
are started with the weight M + (h²/10) K of their elements' stiffness
(:class:`StartWeights`; docs/stepsize.md §2, "Flexible models"): velocities with
the least strain rate the joints allow (:func:`project_velocity`), positions that
carry the deformation of the quasi-static motion (:func:`settle`), and the jerk of
the start (:func:`start_jerk`). :func:`residual_floor` is the round-off floor of
their internal forces for the residual Newton test, and :func:`newton_hint` the
hint of a Newton failure in the first steps.

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

from femb.errors import user_stacklevel
from femb.system import assembly, kernels
from femb.system.model import Model, State
from femb.errors import (NEWTON_HINT, NEWTON_HINT_START, SINGULAR_HINT, SINGULAR_HINT_DIVERGED, SINGULAR_HINT_INDEPENDENT, SINGULAR_HINT_STEP,
                         InitializationError,
                         InitialMoveWarning, InitialVelocityWarning, ModelError,  # noqa: F401 (re-exported)
                         RedundantConstraintWarning)

#: systems with at most this many unknowns are solved with dense LU
DENSE_LIMIT = 200

#: relative tolerance of the numerical rank of the scaled Φ_q (|R_kk| ≤ RANK_TOL |R_00| is zero)
RANK_TOL = 1e-10

#: default limit of an initial move, as a fraction of the model's length scale (see consistent_initial_state)
MAX_INITIAL_MOVE = 0.01

#: c_K / h² of StartWeights (a mode of frequency ω weighs 1 + START_STIFFNESS (hω)²)
START_STIFFNESS = 0.1

#: step of the difference in StartWeights.curvature: the fastest body turns by this angle (rad)
CURVATURE_STEP = 1e-3

#: the consistent start needs h ω ≤ this for the fastest motion its jerk shows (start_is_resolved)
START_RESOLUTION = 1.0

#: Newton failures up to this step get the start's hint (newton_hint)
START_STEPS = 5

#: proximal sweeps of the settled positions of flexible models (settle)
SETTLE_SWEEPS = 3

#: a mode with h ω ≥ START_UNRESOLVED counts as not resolved by h (project_velocity)
START_UNRESOLVED = 3.0

#: strain rate that the velocity projection leaves in modes with h ω ≥ START_UNRESOLVED
SWEEP_TOL = 1e-3

#: proximal sweeps of the velocity projection of flexible models (project_velocity): each
#: multiplies a mode's strain rate by x = 1/(1 + c_K ω²) ≤ 1/(1 + START_STIFFNESS START_UNRESOLVED²)
SWEEPS = 1 + math.ceil(math.log(SWEEP_TOL) / -math.log1p(START_STIFFNESS * START_UNRESOLVED ** 2))

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
def _factor_augmented(A, B):
    """A solver of [[A, Bᵀ], [B, 0]] [x; y] = [top; bottom]: a function (top, bottom) → (x, y), or
    None if the matrix is singular (one factorization serves every right-hand side)."""
    K = sp.bmat([[A, B.T], [B, None]], format="csc") if B.shape[0] else sp.csc_matrix(A)
    n = A.shape[0]
    if K.shape[0] <= DENSE_LIMIT:
        lu, piv, info = sla.lapack.dgetrf(K.toarray())
        d = np.abs(np.diag(lu))
        if info > 0 or not np.all(np.isfinite(d)) or d.min() <= 1e-13 * d.max():
            return None

        def solve(top, bottom):
            x = sla.lu_solve((lu, piv), np.concatenate((top, bottom)))
            return x[:n], x[n:]
        return solve
    import scipy.sparse.linalg as spla
    try:
        lu = spla.splu(K)
    except RuntimeError:
        return None
    d = np.abs(lu.U.diagonal())
    if not np.all(np.isfinite(d)) or d.min() <= 1e-13 * d.max():
        return None

    def solve(top, bottom):
        x = lu.solve(np.concatenate((top, bottom)))
        return x[:n], x[n:]
    return solve


def _solve_augmented(A, B, rhs_top, rhs_bottom, what):
    """Solve [[A, Bᵀ], [B, 0]] [x; y] = [rhs_top; rhs_bottom]; None if singular."""
    solve = _factor_augmented(A, B)
    return None if solve is None else solve(rhs_top, rhs_bottom)


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


def _project_positions(model, t, q0, rows, labels, tol, max_iter):
    """Step 1 of :func:`consistent_initial_state`: q = argmin ‖q − q0‖ subject to Φ(q, t) = 0 on the equations
    ``rows`` (Gauss–Newton, ‖Φ‖∞ ≤ tol), or an InitializationError naming the largest residual's joint."""
    I = sp.identity(model.nq, format="csr")
    q = q0.copy()
    for k in range(max_iter + 1):
        Phi = assembly.constraint_vector(model, t, q)
        err = np.abs(Phi).max()
        if not np.isfinite(err):
            raise InitializationError("initial positions give non-finite constraint values")
        if err <= tol:
            return q
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
    return q


def refuse_contacts(model, who):
    """A :class:`ModelError` where ``model`` has (nonsmooth) contact elements, which ``who`` (an analysis or
    the engine, by name) does not treat and would silently ignore. Penalty contact elements are force
    elements: they pass."""
    n = int(getattr(model, "n_contacts", 0) or 0)
    if n:
        raise ModelError(f"model '{model.name}' has contact elements ({n} contacts): {who} does not treat "
                         "unilateral contacts and would ignore them; integrate it with femb.contact.simulate "
                         "(docs/contact.md), or model the contacts as penalty elements "
                         "(femb.elements.penalty_contact), which it takes")


def consistent_initial_state(model: Model, state: State | None = None, *, t0: float = 0.0, phi_tol: float = 1e-12,
                             max_iter: int = 50, max_initial_move: float | None = None,
                             report_move: float = REPORT_MOVE, weights: "StartWeights | None" = None,
                             contacts: bool = False, accelerations: bool = True) -> State:
    """Project an initial state onto the constraints at all levels, and say so.

    1. positions: least change q = argmin ‖q − q_0‖ subject to Φ(q, t_0) = 0
       (Gauss–Newton);
    2. velocities: q̇ = argmin ‖q̇ − q̇_0‖ subject to Φ_q q̇ = −Φ_t;
    3. accelerations and multipliers from
       [[M, Φ_qᵀ], [Φ_q, 0]] [q̈; λ] = [f; −γ].

    With ``weights`` (a flexible model's :class:`StartWeights`, the solver's
    default), steps 2 and 3 use A = M + c_K K_el in place of the
    identity and of M: the velocity change is the A-weighted least change
    (A δ + Φ_qᵀ μ = 0), so that the deformable elements start with the least
    strain rate the joints allow (interior beam nodes move with the ends),
    and the accelerations and multipliers are those of :func:`start_accelerations`
    (a stiff beam starts as the rigid body it approximates, with that body's
    reactions).

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
    weights : StartWeights, optional
        The start of flexible models (:meth:`StartWeights.for_step`); None: identity and M.
    contacts : bool
        Accept a model with contact elements (only :func:`femb.contact.simulate` does: it
        treats the contacts itself); otherwise such a model is a ModelError, so that
        ``femb.simulate`` never integrates it silently without its contacts.
    accelerations : bool
        Step 3 (default True). False: positions and velocities only, ``qdd`` and ``lam`` zero
        (for a model without velocity constraints or start weights): the contact integrator
        solves the accelerations with the contact forces itself.
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
    ModelError
        The model has velocity-level (non-holonomic) constraints (rolling joints) and
        ``contacts`` (the contact integrator does not take them).

    Notes
    -----
    Velocity-level (non-holonomic) constraints Ψ = A(q, t) v + a(q, t) = 0 (``model.nn`` rows,
    multipliers μ): step 2 projects onto Φ_q q̇ = −Φ_t and A q̇ = −a together, step 3 solves
    [[M, Φ_qᵀ, Aᵀ], [Φ_q, 0, 0], [A, 0, 0]] [q̈; λ; μ] = [f; −γ; −(Ψ_q q̇ + Ψ_t)], and the
    state's ``lam`` holds [λ; μ] (nc + nn). With ``weights`` (deformable elements) the A rows
    join the Φ_q rows of :func:`project_velocity` and :func:`start_accelerations` (and so of
    :func:`settle`, whose deformation Δ keeps Φ_q Δ = 0 only: velocity constraints do not
    restrict positions).
    """
    nn = getattr(model, "nn", 0)
    if nn and contacts:
        names = sorted({g.cls.__name__ for g in model.velocity_constraint_groups})
        raise ModelError(f"model '{model.name}' has {nn} velocity-level (non-holonomic) constraints "
                         f"({', '.join(names)}): the contact integrator (femb.contact.simulate) does not take them; "
                         "femb.simulate does (without contacts)")
    if not contacts:
        refuse_contacts(model, "the compiled engine (femb.simulate)")
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
    if nc:
        q0 = st.q.copy()
        _zero_rows(assembly.constraint_jacobian(model, t, q0).tocsr()[rows], [labels[i] for i in rows])
        Phi0 = assembly.constraint_vector(model, t, q0)
        q = _project_positions(model, t, q0, rows, labels, tol, max_iter)
        _check_moves(model, q0, q, Phi0, labels, act, max_initial_move, report_move)
        st.q = q
        B = assembly.constraint_jacobian(model, t, st.q).tocsr()[rows]
        Phi_t, _ = assembly.constraint_rates(model, t, st.q, st.qd)
        if nn:
            pass                    # below, with the velocity constraints
        elif weights is None:
            sol = _solve_augmented(I, B, st.qd, -Phi_t[rows], "velocity projection")
            if sol is None:
                e = _redundancy_error(model, st.q, t, "cannot make the initial velocities consistent")
                raise e or InitializationError(f"velocity projection: singular constraint Jacobian; {SINGULAR_HINT}")
            qd = sol[0]
        else:
            qd = project_velocity(model, weights, t, st.q, st.qd, -Phi_t)
        if not nn:
            _check_velocity_changes(model, st.qd, qd, report_move)
            st.qd = qd
    if nn and weights is not None:
        Phi_t, _ = assembly.constraint_rates(model, t, st.q, st.qd)
        Psi, A, _ = assembly.velocity_constraints(model, t, st.q, st.qd)
        qd = project_velocity(model, weights, t, st.q, st.qd, np.concatenate((-Phi_t, A @ st.qd - Psi)))
        _check_velocity_changes(model, st.qd, qd, report_move)
        st.qd = qd
        st.q, st.qdd, st.lam = settle(model, weights, t, st.q, st.qd)
    elif nn:
        qd = _project_velocity_constraints(model, t, st.q, st.qd, rows)
        _check_velocity_changes(model, st.qd, qd, report_move)
        st.qd = qd
        st.qdd, st.lam = _velocity_constraint_accelerations(model, t, st.q, st.qd, rows)
    elif weights is not None:
        st.q, st.qdd, st.lam = settle(model, weights, t, st.q, st.qd)
    elif not accelerations:
        st.qdd, st.lam = np.zeros(model.nq), np.zeros(model.nc)
    else:
        st.qdd, st.lam = start_accelerations(model, None, t, st.q, st.qd)
    if not (np.all(np.isfinite(st.qdd)) and np.all(np.isfinite(st.lam))):
        raise InitializationError("initial accelerations are not finite")
    return st


def _velocity_rows(model, t, q, qd, rows):
    """The velocity-level rows of a model with velocity constraints: [Φ_q; A] (active rows),
    [Φ_t; a] with a = Ψ − A q̇, and (γ, Ψ_q q̇ + Ψ_t) with B q̈ = −γ, A q̈ = −(Ψ_q q̇ + Ψ_t)."""
    B = assembly.constraint_jacobian(model, t, q).tocsr()[rows]
    Phi_t, gam = assembly.constraint_rates(model, t, q, qd)
    Psi, A, Psi_t = assembly.velocity_constraints(model, t, q, qd)
    Dq, _ = assembly.velocity_constraint_jacobians(model, t, q, qd, np.zeros(model.nn))
    BA = sp.vstack((B, A)).tocsr()
    return BA, np.concatenate((Phi_t[rows], Psi - A @ qd)), np.concatenate((gam[rows], Dq @ qd + Psi_t))


def _start_rows(model, t, q, qd):
    """The velocity-level rows of the start: (J, idx, gam) with J = [Φ_q; A] (active holonomic rows,
    then the ``model.nn`` velocity-constraint rows), idx their places in [λ; μ] (nc + nn), and
    J q̈ = −gam the acceleration-level rows (γ; Ψ_q q̇ + Ψ_t)."""
    rows = np.nonzero(active_mask(model))[0]
    if getattr(model, "nn", 0):
        J, _, gam = _velocity_rows(model, t, q, qd, rows)
        return J, np.concatenate((rows, model.nc + np.arange(model.nn))), gam
    B = assembly.constraint_jacobian(model, t, q).tocsr()[rows]
    _, gam = assembly.constraint_rates(model, t, q, qd)
    return B, rows, gam[rows]


def _project_velocity_constraints(model, t, q, qd, rows):
    """Least-change velocities with Φ_q q̇ + Φ_t = 0 and A q̇ + a = 0 (one linear projection: both
    are linear in q̇)."""
    BA, rate, _ = _velocity_rows(model, t, q, qd, rows)
    sol = _solve_augmented(sp.identity(model.nq, format="csr"), BA, qd, -rate, "velocity projection")
    if sol is None:
        raise InitializationError("velocity projection: the rows [Φ_q; A] of the holonomic and velocity-level "
                                  f"(non-holonomic) constraints are rank-deficient at t = {t:.6g} s; {SINGULAR_HINT}")
    return sol[0]


def _velocity_constraint_accelerations(model, t, q, qd, rows):
    """(q̈, [λ; μ]) of [[M, Φ_qᵀ, Aᵀ], [Φ_q, 0, 0], [A, 0, 0]] [q̈; λ; μ] = [f; −γ; −(Ψ_q q̇ + Ψ_t)]
    (Gauss's principle with the velocity-level rows differentiated once)."""
    BA, _, gam = _velocity_rows(model, t, q, qd, rows)
    f = assembly.force_vector(model, t, q, qd)
    sol = _solve_augmented(assembly.mass_matrix(model, q), BA, f, -gam, "initial accelerations")
    if sol is None:
        raise InitializationError(f"initial accelerations: the matrix [[M, Φ_qᵀ, Aᵀ], [Φ_q, 0, 0], [A, 0, 0]] is "
                                  f"singular at t = {t:.6g} s; {SINGULAR_HINT}")
    lam = np.zeros(model.nc + model.nn)
    lam[rows] = sol[1][:rows.size]
    lam[model.nc:] = sol[1][rows.size:]
    return sol[0], lam


# --------------------------------------------------------------------------
# the start of flexible models (stepsize.md §2, "Flexible models")
# --------------------------------------------------------------------------
def deformable_groups(model, t, q, qd):
    """Element batches that carry mass and an internal stiffness (beams, not rigid bodies).

    A batch counts when its element type has both mass and forces (``has_mass``,
    ``has_force``) and its force Jacobian ∂f/∂q is not zero at (t, q, q̇): the
    forces of rigid bodies (gyroscopic moments) depend on q̇ only.

    Returns
    -------
    list of Group
    """
    qx, qdx = assembly._ext(model, q, qd)
    out = []
    for g in model.force_groups:
        if not (g.traits.get("has_mass") and g.traits.get("has_force")):
            continue
        _, fq, _ = kernels.force(g, t, qx[g.xdofs], qdx[g.dofs], True)
        if np.any(fq != 0.0):
            out.append(g)
    return out


@dataclass
class StartWeights:
    """The weight A = M + c_K (K_el + C_elᵀ M_l⁻¹ C_el) of a flexible model's start.

    K_el = −∂f/∂q and C_el = −∂f/∂q̇ of the deformable batches at zero velocity
    (:func:`deformable_groups`; at zero velocity C_el is the material damping
    alone, without gyroscopic terms), M_l the lumped (diagonal) mass, c_K =
    :data:`START_STIFFNESS` h² for the step h. A mode of frequency ω whose
    damping takes its velocity off at the rate d (d = η ω² for a section with
    stiffness-proportional damping η) weighs about 1 + c_K (ω² + d²) times its
    kinetic energy: modes with h ω ≳ 3 (fewer than about two steps per period,
    which the scheme damps towards ρ∞ rather than follows) and modes whose
    damping settles them within a step (h d ≳ 3) are started quasi-statically;
    modes the step resolves keep the start of Gauss's principle up to
    O((hω)², (hd)²). (The Newton matrix of the first step divided by β′ has
    c_K = 1/β′ ≈ 0.26 h² at ρ∞ = 0.8; that weight changed the start of modes at
    h ω ≈ 1.6 enough to lower the step-halving order of the damped flexible
    slider-crank from above 1.2 to 1.14; 0.025 h² left the undamped flexible
    four-bar failing Newton at h = 1 ms. The damping enters squared, and only
    where the start without it is not resolved by h (:func:`flexible_start`):
    a weight √c_K C_el, that of a backward-Euler step, changed the start of the
    resolved damped modes at first order in h, and even squared it lowered the
    step-halving order of the damped flexible slider-crank, whose start is
    resolved without it, from 1.27 to 1.19. Without it a coupler with
    η = 10⁻³ s kept the strain rates of the mass-weighted start in its
    overdamped modes, whose damping forces made the start's jerk one that h
    does not resolve, and the solver fell
    back to the seed's start.) :meth:`curvature` supplies the rates of the forces
    along a rigid motion, so that its centripetal accelerations are not taken
    for strain or strain rate.

    Attributes
    ----------
    groups : list of Group
    c_K : float
        In s².
    damped : bool
        Whether C_el enters (:func:`flexible_start` sets it only where the start
        without it is not resolved by h).
    """

    groups: list
    c_K: float
    damped: bool = False

    @classmethod
    def for_step(cls, model, state, h):
        """The weights for the step h (None if the model has no deformable element)."""
        groups = deformable_groups(model, state.t, state.q, state.qd)
        if not groups:
            return None
        return cls(groups, START_STIFFNESS * float(h) ** 2)

    def _jacobians(self, model, t, q, qd):
        """(∂f/∂q, ∂f/∂q̇) of the deformable batches at (t, q, q̇), csr (nq, nq) each (∂f/∂q̇ None
        when no batch's force depends on q̇)."""
        qx, qdx = assembly._ext(model, q, qd)
        parts = [kernels.force(g, t, qx[g.xdofs], qdx[g.dofs], True) for g in self.groups]
        shape = (model.nq, model.nq)
        fq = assembly._coo(self.groups, "nn", [p[1] for p in parts], shape)
        damped = [(g, p[2]) for g, p in zip(self.groups, parts) if p[2] is not None]
        fv = assembly._coo([g for g, _ in damped], "nn", [v for _, v in damped], shape) if damped else None
        return fq, fv

    def stiffness(self, model, t, q, qd):
        """∂f_el/∂q = −K_el of the deformable batches at (t, q) and zero velocity, csr (nq, nq).

        At zero velocity: the q-derivatives of damping forces (which are proportional to
        the velocity, and do not vanish on rigid motions in space axes) are not stiffness.
        """
        return self._jacobians(model, t, q, np.zeros_like(qd))[0]

    def _damping(self, model, t, q, qd):
        """(C_el, 1/diag(M)): C_el = −∂f/∂q̇ of the deformable batches at zero velocity (csr, or None
        without material damping) and the inverse lumped mass (nq,) (0 on massless coordinates)."""
        fv = self._jacobians(model, t, q, np.zeros_like(qd))[1] if self.damped else None
        if fv is None or fv.nnz == 0 or not np.any(fv.data != 0.0):
            return None, None
        m = assembly.mass_matrix(model, q).diagonal()
        return (-fv).tocsr(), np.where(m > 0.0, 1.0 / np.where(m > 0.0, m, 1.0), 0.0)

    def matrix(self, model, t, q, qd, damping=True):
        """A = M + c_K (K_el + C_elᵀ M_l⁻¹ C_el) at (t, q), csr (nq, nq); M + c_K K_el if not
        ``damped`` or ``damping=False``."""
        fq = self._jacobians(model, t, q, np.zeros_like(qd))[0]
        A = assembly.mass_matrix(model, q) - self.c_K * fq
        C, m_inv = self._damping(model, t, q, qd) if damping else (None, None)
        if C is not None:
            A = A + self.c_K * (C.T @ sp.diags(m_inv) @ C)
        return A.tocsr()

    def curvature(self, model, t, q, qd):
        """c_K (f̈_el + C_elᵀ M_l⁻¹ ḟ_d) at q̈ = 0, shape (nq,).

        f̈_el: c_K d/ds [∂f_el/∂q (q ∘ s q̇) q̇] at s = 0, the second derivative of the
        deformable elements' forces at zero velocity along the motion q ∘ s q̇ (on a
        Lie group the right-trivialized tangent of that path is q̇, so that
        f̈_el = f_el,q q̈ + this term exactly), by a five-point central difference
        of ∂f_el/∂q q̇ over steps s that turn or move the fastest body by
        :data:`CURVATURE_STEP` of the length scale: the c_K-weighted terms are large
        (c_K K_el q̈ ≈ 5·10⁵ N on the four-bar with E × 10⁶) and cancel to the reactions'
        size, so the difference must be accurate to about 10⁻⁸ (the truncation error of
        the five-point rule, (10⁻³)⁴, and its round-off, ε/10⁻³, both are). ḟ_d: the
        rate of the velocity-dependent forces at q̈ = 0, (∂f/∂q (q, q̇) − ∂f/∂q (q, 0)) q̇
        (exact; on a rigid motion C_el q̈ = ḟ_d). With them, the accelerations of a rigid motion leave the strains and
        strain rates unchanged: the centripetal accelerations of a turning beam are
        not taken for strain.
        """
        L = model.length_scale
        speed = float(np.abs(qd).max(initial=0.0)) * max(L, 1.0)
        if speed == 0.0:
            return np.zeros(model.nq)
        ds = CURVATURE_STEP * L / speed

        def g(k):
            return self.stiffness(model, t, model.compose(q, k * ds * qd), qd) @ qd

        out = self.c_K * (8.0 * (g(1) - g(-1)) - (g(2) - g(-2))) / (12.0 * ds)
        C, m_inv = self._damping(model, t, q, qd)
        if C is not None:
            fq = self._jacobians(model, t, q, qd)[0]
            out += self.c_K * (C.T @ (m_inv * ((fq - self.stiffness(model, t, q, qd)) @ qd)))
        return out


@dataclass
class StartEngine:
    """The compiled pieces the start uses, as functions the solver supplies.

    Attributes
    ----------
    qpp : callable (t, q, q̇) → ndarray (nq,)
        Constrained accelerations q̈ᵖᵖ (the KKT solve of the engine).
    jacobian_times : callable (t, q, v) → ndarray (nc,)
        Φ_q v.
    rates : callable (t, q, q̇) → ndarray (nc,)
        Φ_t, with the time functions at t.
    project : callable (t, q, q̇, target) → None
        Corrects q̇ in place so that Φ_q q̇ = target (M-orthogonal, the factorization
        of [[M, Φ_qᵀ], [Φ_q, 0]] at the initial state).
    """

    qpp: object
    jacobian_times: object
    rates: object
    project: object


def jerk(model, weights, engine, st, dl):
    """The jerk j₀ at the start (stepsize.md §2): a central difference of the constrained
    accelerations along the motion, at t ± δ from (q ∘ (±δ q̇ + ½δ² q̈), q̇ ± δ q̈); for a
    flexible model those of :func:`start_accelerations` (:func:`start_jerk`).

    Parameters
    ----------
    model : Model
    weights : StartWeights or None
    engine : StartEngine
    st : State
        The consistent initial state.
    dl : float
        δ (s).

    Returns
    -------
    ndarray, shape (nq,)
    """
    t0, q0, v0, a0 = st.t, st.q, st.qd, st.qdd
    if weights is not None:
        return start_jerk(model, weights, t0, q0, v0, a0, dl)
    cmp = model.compose
    ap = engine.qpp(t0 + dl, cmp(q0, dl * v0 + 0.5 * dl * dl * a0), v0 + dl * a0)
    am = engine.qpp(t0 - dl, cmp(q0, -dl * v0 + 0.5 * dl * dl * a0), v0 - dl * a0)
    return (ap - am) / (2.0 * dl)


def consistent_start(model, weights, engine, st, j0, h0, alpha, Cq, index3):
    """The consistent start of the generalized-α scheme (stepsize.md §2): a₀ and the normal velocity.

    a₀ = q̈₀ + (α_m − α_f) h₀ j₀; with the index-3 form and constraints, q̇₀ is corrected
    in place so that Φ_q q̇₀ = −Φ_t + h₀² C_q Φ_q j₀ (velocity-constraint rows: A q̇₀ = −a) (+ h₀²/12 Φ_q [q̇₀, q̈₀] on Lie groups,
    Arnold, Cardona & Brüls 2016): M-orthogonally by ``engine.project``, or for a flexible
    model with the sweeps of :func:`project_velocity`. The index-2 form keeps
    Φ_q q̇ + Φ_t = 0 exactly: only a₀ is set.

    A flexible model's q̇₀ first gains h₀² C_q j₀ itself, and the sweeps then meet the
    target from there. The strains of elements whose modes h does not resolve are held by
    the scheme as the joints are, at position level, so their strain rates carry the same
    defect h² C_q G j (G the strains' Jacobian; G j ≠ 0 on a rigid motion, as Φ_q j is).
    A kinematically driven loop (no free motion) has Φ_q square: its rigid version's
    correction is exactly h₀² C_q j₀. Projected alone, the correction was met with no strain
    rate, and the four-bar with a coupler of E × 10⁶ rang (period 2h) with 1.4·10⁻³ N m
    (0.34 % of the drive's moment) against the rigid coupler's start over its first 100
    steps; now 4.3·10⁻⁶ N m. In free or resolved motions the term adds O(h²) to q̇₀, within
    the scheme's error.

    Parameters
    ----------
    model : Model
    weights : StartWeights or None
    engine : StartEngine
    st : State
        The consistent initial state; ``st.qd`` is corrected in place.
    j0 : ndarray, shape (nq,)
    h0 : float
        The first step.
    alpha : GeneralizedAlpha
    Cq : float
        Local error constant C_q (:func:`femb.solve.solver.error_constants`).
    index3 : bool

    Returns
    -------
    ndarray, shape (nq,)
        a₀.
    """
    d = alpha.alpha_m - alpha.alpha_f
    a0 = st.qdd + d * h0 * j0
    if (model.nc or getattr(model, "nn", 0)) and index3:
        t0 = float(st.t)
        Pt = engine.rates(t0, st.q, st.qd)
        target = -Pt + h0 * h0 * Cq * engine.jacobian_times(t0, st.q, j0)
        if model.lie:
            Bb = engine.jacobian_times(t0, st.q, model.bracket(st.qd, st.qdd))
            target = target + (h0 * h0 / 12.0) * Bb
        if getattr(model, "nn", 0):
            # velocity-constraint rows (after the nc holonomic ones): the step keeps A q̇ + a = 0 exactly
            target[model.nc:] = -Pt[model.nc:]
        if weights is not None:
            st.qd[:] += h0 * h0 * Cq * j0
            st.qd[:] = project_velocity(model, weights, t0, st.q, st.qd, target)
        else:
            engine.project(t0, st.q, st.qd, target)
    return a0


def residual_floor(model, state):
    """The round-off floor of the force residual of a model with deformable elements (N).

    An element's internal forces are its stiffness times strains computed from
    positions of size L (the model's length scale): their round-off is about
    ε K L, far above ε times the forces themselves when a stiff element carries
    small loads (a beam's axial force ε EA L/l_e). The floor is
    ε max_i w_i Σ_j |K_el,ij| s_j, with K_el the deformable batches' stiffness at
    zero velocity, w the residual's weights (moments divided by L) and s_j = L
    for translations, 1 rad for rotations; 0 without deformable elements. The
    residual Newton test accepts a residual at this floor (a tighter tolerance,
    ``newton_rtol=1e-13`` relative to the loads, cannot be met: 1.6e-8 N against
    1.5e-12 N on the four-bar with a 32-element coupler).

    Returns
    -------
    float
    """
    groups = deformable_groups(model, state.t, state.q, state.qd)
    if not groups:
        return 0.0
    K = StartWeights(groups, 1.0).stiffness(model, state.t, state.q, state.qd)
    w = np.asarray(model.force_weight, dtype=float)
    s = model.length_scale * w
    rows = np.asarray(abs(K).multiply(s[None, :]).sum(axis=1)).ravel() * w
    return float(np.finfo(float).eps * rows.max(initial=0.0))


def newton_hint(step, flexible, started):
    """The hint of a Newton failure at ``step`` of a run.

    Parameters
    ----------
    step : int
    flexible : bool
        The model has deformable elements (:func:`deformable_groups`).
    started : bool
        The run used the start of flexible models (consistent initial values with
        :class:`StartWeights`, and ``start="consistent"``).

    Returns
    -------
    str
        :data:`~femb.errors.NEWTON_HINT_START` in the first :data:`START_STEPS`
        steps of a flexible model that was not started so, else "try a smaller h"
        (with adaptive steps named in the first steps).
    """
    if step <= START_STEPS and flexible and not started:
        return NEWTON_HINT_START
    if step <= START_STEPS:
        return NEWTON_HINT + " (or adaptive steps, simulate(..., rtol=...), which resolve the start and then grow)"
    return NEWTON_HINT


def start_weights(model, state, t0, h, t_end):
    """The :class:`StartWeights` the solver starts a model with (None for models without
    deformable elements, which keep the identity and M).

    The step of the weights is the fixed step ``h``, else (adaptive steps) the given first step,
    else 10⁻³ (t_end − t₀).
    """
    st = state if state is not None else model.initial_state(t0)
    if h is None:
        if t_end is None or not math.isfinite(t_end) or not t_end > st.t:
            return None
        h = 1e-3 * (t_end - st.t)
    w = StartWeights.for_step(model, st, h)
    if w is None:
        return w
    # a step so large that the stiffness swamps the mass numerically: the usual start, and the
    # solver's own diagnosis of the step (its iteration matrix is then singular too)
    rows = np.nonzero(active_mask(model))[0]
    B = assembly.constraint_jacobian(model, st.t, st.q).tocsr()[rows]
    return w if _factor_augmented(w.matrix(model, st.t, st.q, st.qd), B) is not None else None


def start_is_resolved(h, v0, j0):
    """Whether the step h resolves the motion that the initial jerk j₀ shows (fixed steps).

    The consistent start a₀ = q̈₀ + (α_m − α_f) h j₀ (Arnold & Brüls 2007, stepsize.md §2) is the
    leading term of an expansion in h: it needs h ω ≪ 1 for the motions present at t₀. For an
    oscillation of frequency ω, j₀ ≈ −ω² q̇₀, so ω ≈ √(‖j₀‖/‖q̇₀‖) estimates the fastest one the start
    sets going. A start at rest (q̇₀ = 0) counts as resolved: its jerk comes from drivers and loads.

    Parameters
    ----------
    h : float
    v0, j0 : (nq,) ndarray
        Initial velocities and the jerk (central differences of the constrained accelerations).

    Returns
    -------
    bool
        ``h · ω ≤ START_RESOLUTION``.
    """
    nv = float(np.linalg.norm(v0))
    nj = float(np.linalg.norm(j0))
    if nv == 0.0 or nj == 0.0:
        return math.isfinite(nj)
    return h * math.sqrt(nj / nv) <= START_RESOLUTION


def flexible_start(model, state, t0, h, t_end, adaptive, **options):
    """The start weights and the consistent initial state the solver begins with.

    :func:`start_weights` and :func:`consistent_initial_state` (``options`` passed on).
    With fixed steps, a model whose deformable elements are damped and whose start
    is not resolved by h (:func:`start_is_resolved` of :func:`start_jerk`: overdamped
    modes that the mass-weighted start leaves straining) is started again with the
    damping in the weights (:class:`StartWeights`, ``damped``), which starts those
    modes quasi-statically; where that does not resolve it either, the first start
    stays (and the solver uses the seed's start).

    Returns
    -------
    weights : StartWeights or None
    state : State
    """
    w = start_weights(model, state, t0, h, t_end)
    st = consistent_initial_state(model, state, t0=t0, weights=w, **options)
    if w is None or adaptive or w.damped:
        return w, st
    wd = StartWeights(w.groups, w.c_K, damped=True)
    if wd._damping(model, st.t, st.q, st.qd)[0] is None:
        return w, st
    dl = min(1e-4, 1e-2 * h)
    if start_is_resolved(h, st.qd, start_jerk(model, w, st.t, st.q, st.qd, st.qdd, dl)):
        return w, st
    rows = np.nonzero(active_mask(model))[0]
    B = assembly.constraint_jacobian(model, st.t, st.q).tocsr()[rows]
    if _factor_augmented(wd.matrix(model, st.t, st.q, st.qd), B) is None:
        # the damping term swamps the mass numerically (η² ω⁴ c_K ≫ 1: a stiff, heavily damped
        # beam): the start without it, as for a step too large in start_weights
        return w, st
    sd = consistent_initial_state(model, state, t0=t0, weights=wd, **options)
    if start_is_resolved(h, sd.qd, start_jerk(model, wd, sd.t, sd.q, sd.qd, sd.qdd, dl)):
        return wd, sd
    return w, st


def start_accelerations(model, weights, t, q, qd, what="initial accelerations"):
    """Accelerations and multipliers of a start that does not ring: (q̈, λ) from
    [[A, Φ_qᵀ], [Φ_q, 0]] [q̈; λ] = [f; −γ].

    With A = M (``weights`` None) these are the constrained accelerations
    (Gauss's principle). With the weights of a flexible model (:class:`StartWeights`)
    the deformable elements' stiffness resists accelerations that strain them, as
    in the first implicit step, and f gains c_K f̈_el (:meth:`StartWeights.curvature`):
    a beam much stiffer than the step resolves (ω h ≫ 1) is accelerated as the
    rigid body it approximates, and λ is the quasi-static reaction (that of a rigid
    coupler in the stiff limit), while a mode that h resolves is changed by
    O((ωh)²). :func:`settle` uses them to find the deformation that the start
    needs; :func:`consistent_initial_state` reports those of M at the settled
    positions.

    Parameters
    ----------
    model : Model
    weights : StartWeights or None
    t : float
    q : ndarray, shape (nx,)
    qd : ndarray, shape (nq,)

    Returns
    -------
    qdd : ndarray, shape (nq,)
    lam : ndarray, shape (nc,)
        0 on equations removed as redundant.

    Raises
    ------
    InitializationError
        If the matrix is singular.
    """
    J, idx, gam = _start_rows(model, t, q, qd)
    f = assembly.force_vector(model, t, q, qd)
    if weights is None:
        A = assembly.mass_matrix(model, q)
    else:
        A = weights.matrix(model, t, q, qd)
        f = f + weights.curvature(model, t, q, qd)
    sol = _solve_augmented(A, J, f, -gam, what)
    if sol is None:
        raise InitializationError(f"{what}: the matrix [[M, Φ_qᵀ], [Φ_q, 0]] is singular at t = {t:.6g} s; "
                                  f"{SINGULAR_HINT}")
    lam = np.zeros(model.nc + getattr(model, "nn", 0))
    lam[idx] = sol[1]
    return sol[0], lam


def settle(model, weights, t, q, qd):
    """Positions that carry the deformation the start's motion needs, q ∘ Δ, the start's
    accelerations, and the multipliers at q ∘ Δ.

    The accelerations of :func:`start_accelerations` with ``weights`` follow the
    motion quasi-statically in the modes the step does not resolve; the
    deformable elements then carry the force −E/c_K, E = c_K (f − M q̈ − Φ_qᵀλ) (the force that
    accelerates a stiff beam as a rigid body, or holds it against gravity). The
    positions, as given, do not carry it (an undeformed beam released under
    gravity, one set turning by a driver): the first steps would ring with it in
    the stiff modes, decaying only by ρ∞ per step. Δ supplies it, f_el(q ∘ Δ) − f_el(q)
    ≈ −K_el Δ = −E/c_K in those modes, by proximal sweeps as in :func:`project_velocity`
    (:data:`SETTLE_SWEEPS` of them):

        A Δ_1 + Φ_qᵀ ν_1 = E,                Φ_q Δ_1 = 0,
        A Δ_k + Φ_qᵀ ν_k = E + M Δ_(k−1),    Φ_q Δ_k = 0.

    In a mode of frequency ω, with x = 1/(1 + c_K ω²) and r its acceleration by Gauss's
    principle at q (the load the elements do not carry yet), E = (1 − x) r and the acceleration
    left at q ∘ Δ is r (x + x³ − x⁴): a stiff mode is settled to O(x), a mode the step resolves
    is moved by O((c_K ω²)²), O(h⁴). Settling further (Δ = Δ_1 + 2XΔ_1, which leaves O(x²), or
    repeated passes) moved the resolved modes of the damped flexible slider-crank enough to
    lower its step-halving order from 1.30 to 1.26 and 1.19 and to flag a node rotation
    as not converging (order 0.97).

    The accelerations returned are those of :func:`start_accelerations` at the given
    positions (the quasi-static motion), the multipliers those at the settled positions, where
    the weighted strain accelerations are x times the remaining r x: a stiff beam's multipliers
    are a rigid coupler's to O(x²). (The accelerations at the settled positions too made
    the damped flexible slider-crank's fixed-step convergence check flag a node rotation, order
    0.99 against 1 at h = 0.1 ms.) The multipliers at the given positions (as before) left
    O(x) ∝ 1/h²: the skew R–S–U–R loop's t = 0 drive reaction was 1.1 %, 4.2 %
    and 15 % off the rigid coupler's at h = 1, 0.5, 0.25 ms with E × 10⁴ (now 1.1·10⁻⁴, 1.7·10⁻³,
    2.2·10⁻²). Gauss's principle at the settled positions would have to recover
    the elastic forces from strains of O(E/EA), which a stiff beam's positions carry to few
    digits (its rocker acceleration came out 0.25 % off with E × 10⁶ and 4 % with E × 10⁸);
    the weighted solve at q ∘ Δ is exact where those forces balance (E = 0) and damps their
    round-off by 1/(1 + c_K ω²).

    Returns
    -------
    q : ndarray, shape (nx,)
    qdd : ndarray, shape (nq,)
    lam : ndarray, shape (nc,)
    """
    qdd, lam = start_accelerations(model, weights, t, q, qd)
    J, idx, _ = _start_rows(model, t, q, qd)
    rows = np.nonzero(active_mask(model))[0]
    B = assembly.constraint_jacobian(model, t, q).tocsr()[rows]
    M = assembly.mass_matrix(model, q)
    E = weights.c_K * (assembly.force_vector(model, t, q, qd) - M @ qdd - J.T @ lam[idx])
    solve = _factor_augmented(weights.matrix(model, t, q, qd, damping=False), B)
    if solve is None:
        raise InitializationError(f"the start of the deformable elements: singular matrix [[A, Φ_qᵀ], [Φ_q, 0]]; "
                                  f"{SINGULAR_HINT}")
    z = np.zeros(rows.size)
    d = solve(E, z)[0]
    for _ in range(SETTLE_SWEEPS - 1):
        d = solve(E + M @ d, z)[0]
    qs = model.compose(q, d)
    lam = start_accelerations(model, weights, t, qs, qd)[1]
    return qs, qdd, lam


def start_jerk(model, weights, t, q, qd, qdd, dl):
    """The jerk j₀ at the start: a central difference of :func:`start_accelerations` along the
    motion, at t ± δ from (q ∘ (±δ q̇ + ½δ² q̈), q̇ ± δ q̈) (stepsize.md §2).

    Returns
    -------
    ndarray, shape (nq,)
    """
    cmp = model.compose
    ap, _ = start_accelerations(model, weights, t + dl, cmp(q, dl * qd + 0.5 * dl * dl * qdd), qd + dl * qdd,
                                "the jerk of the start")
    am, _ = start_accelerations(model, weights, t - dl, cmp(q, -dl * qd + 0.5 * dl * dl * qdd), qd - dl * qdd,
                                "the jerk of the start")
    return (ap - am) / (2.0 * dl)


def project_velocity(model, weights, t, q, qd, target, sweeps=None):
    """q̇ + δ with Φ_q (q̇ + δ) = target and the least strain rate in δ that the step allows.

    δ is the limit of ``sweeps`` proximal steps (:class:`StartWeights`, A = M + c_K K_el):

        A δ_1 + Φ_qᵀ μ_1 = 0,        Φ_q δ_1 = target − Φ_q q̇,
        A δ_k + Φ_qᵀ μ_k = M δ_(k−1), Φ_q δ_k = target − Φ_q q̇.

    Each sweep is a backward-Euler step of length √c_K of the structure with the
    joints' velocities held: it multiplies the part of δ in a mode of frequency ω
    by x = 1/(1 + c_K ω²). The first sweep is the A-weighted least change; the
    next ones remove what it leaves in the modes the step does not resolve (the
    axial modes of a stiff beam: c_K ω² ≫ 1), while a mode that the step resolves
    (c_K ω² ≪ 1) keeps the kinetic-energy-weighted change to O((ωh)²). A stiff
    beam is set moving as a rigid body; a given strain rate is kept (δ = 0 when
    the given q̇ satisfies the constraints).

    The number of sweeps, :data:`SWEEPS` (12), is the criterion: every mode with
    h ω ≥ :data:`START_UNRESOLVED` (3, fewer than about two steps per period) keeps at
    most :data:`SWEEP_TOL` (10⁻³) of the strain rate of the first sweep. Three sweeps
    left 7.5 % in the axial mode of the aluminium four-bar started at full speed at
    h = 1 ms (h ω ≈ 3.7, x = 0.42), whose drive then rang with 28 N m against the rigid
    coupler's 0.42 N m; six left 3 N m. A mode at h ω = 1 keeps 39 % of its deviation
    from the limit (O((hω)²) in general: x¹¹ ≈ 1 − 11 c_K ω²).

    Parameters
    ----------
    weights : StartWeights
    target : ndarray, shape (nc,) or (nc + nn,)
        Required Φ_q q̇ (0 on removed equations); with velocity-level constraints
        (``model.nn`` rows) also the required A q̇ (= −a): both are linear in q̇, and
        their rows are projected on together (Φ_q stands for [Φ_q; A] above).
    sweeps : int, optional
        Default :data:`SWEEPS`.

    Returns
    -------
    ndarray, shape (nq,)
    """
    B, rows, _ = _start_rows(model, t, q, qd)
    A = weights.matrix(model, t, q, qd)
    solve = _factor_augmented(A, B)
    if solve is None:
        e = _redundancy_error(model, q, t, "cannot make the initial velocities consistent")
        raise e or InitializationError(f"velocity projection: singular matrix [[A, Φ_qᵀ], [Φ_q, 0]]; {SINGULAR_HINT}")
    M = assembly.mass_matrix(model, q)
    sweeps = SWEEPS if sweeps is None else int(sweeps)
    r = target[rows] - B @ qd
    d = solve(np.zeros(model.nq), r)[0]
    for _ in range(sweeps - 1):
        d = solve(M @ d, r)[0]
    return qd + d


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
                  InitialMoveWarning, stacklevel=user_stacklevel())


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
                  "them as given", InitialVelocityWarning, stacklevel=user_stacklevel())
