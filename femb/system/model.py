"""The frozen model compiled from a mechanism, and the state.

The model holds everything that does not change during a simulation: the
coordinate numbering, the element batches with their packed parameters and
coordinate index arrays, the sparsity bookkeeping, and the constant parts
(mass matrix, constant forces). The state (t, q, q̇, q̈, λ) is separate.

Coordinates: every node coordinate is either free (an entry of q, index
0..nq-1) or fixed (a constant). Elements see the *extended* vector
``q_ext = [q, q_fixed]`` through their index arrays ``dofs`` (values ≥ nq are
fixed coordinates); contributions to fixed coordinates are dropped once, at
compile time.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from femb.errors import ModelError
from femb.system import kernels as _kernels


@dataclass
class State:
    """A state of the model.

    Attributes
    ----------
    t : float
    q, qd, qdd : ndarray, shape (nq,)
        Coordinates, velocities, accelerations.
    lam : ndarray, shape (nc,) or (nc + nn,)
        Lagrange multipliers; on models with velocity-level (non-holonomic) constraints, the
        states of a run (and of the consistent start) hold [λ; μ], μ of the nn velocity rows.
    """

    t: float
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    lam: np.ndarray

    def copy(self):
        return State(self.t, self.q.copy(), self.qd.copy(), self.qdd.copy(), self.lam.copy())


@dataclass
class Group:
    """One batch of elements of a type with equal layout (compiled)."""

    cls: type
    key: object
    elements: list
    names: list
    params: dict
    dofs: np.ndarray          # (nel, nd) indices into the extended velocities [q̇, 0] (tangent entries)
    traits: dict
    lam: np.ndarray           # (nel, nc) indices into λ
    P: np.ndarray = None       # (nel, npar) kernel parameters (params["P"])
    tf_index: np.ndarray = None  # (nel, ntf) rows of the model's time-function table
    xdofs: np.ndarray = None  # (nel, ndx) indices into q_ext = [q, q_fixed] (≡ dofs without rotations)
    time_functions: list = None  # per element, its TimeFunctions
    nn_sel: np.ndarray = None  # flat indices of free-free entries of (nel, nd, nd)
    nn_rows: np.ndarray = None
    nn_cols: np.ndarray = None
    cq_sel: np.ndarray = None  # flat indices of entries of (nel, nc, nd) on free columns
    cq_rows: np.ndarray = None  # constraint index
    cq_cols: np.ndarray = None  # coordinate index
    mu: np.ndarray = None      # (nel, nn) indices into μ, the multipliers of velocity constraints
    cN: np.ndarray = None      # (nel, n_contacts) indices of the batch's gaps among the model's (contact batches)
    cF: np.ndarray = None      # (nel, n_friction) indices of its tangent directions

    @property
    def n_contact_rows(self):
        """Normal and tangent rows per element of a contact batch (0 for other batches)."""
        return int(self.traits.get("n_contacts", 0)) + int(self.traits.get("n_friction", 0))

    @property
    def nel(self):
        return self.dofs.shape[0]

    @property
    def nd(self):
        return self.dofs.shape[1]

    @property
    def nc(self):
        return self.lam.shape[1]

    @property
    def nn(self):
        """Velocity-level (non-holonomic) constraints per element (0 without)."""
        return 0 if self.mu is None else self.mu.shape[1]

    @property
    def ndv(self):
        return self.dofs.shape[1]

    @property
    def name(self):
        return self.cls.__name__


class Model:
    """A compiled, frozen mechanism (create with :meth:`Mechanism.compile`).

    Attributes
    ----------
    name : str
    nq, nc, nfix : int
        Free velocities (= free coordinates without rotation nodes), constraints,
        fixed coordinates.
    nx, nfix_v : int
        Free configuration entries (a free frame node has 7: position and unit
        quaternion, for 6 velocities) and fixed velocity entries.
    lie : bool
        The model has rotation nodes (x ≠ v): the time loop composes
        q ∘ exp(Δ) (:meth:`compose`) and uses the tangent operator.
    q0 : ndarray, shape (nx,)
    qd0 : ndarray, shape (nq,)
        Initial coordinates and velocities as given (not yet consistent).
    q_fixed : ndarray, shape (nfix,)
    groups : list of Group
    mass_groups, force_groups, constraint_groups : list of Group
        The batches that contribute mass, (non-constant) forces, constraints.
    constant_mass : bool
        True when M does not depend on q (then ``M_const`` holds it).
    M_const : scipy.sparse.csr_matrix, shape (nq, nq), or None
    f_const : ndarray, shape (nq,)
        Constant forces (constant loads and, with constant mass, gravity).
    needs_C : bool
        Some force depends on q̇ (C_t is assembled).
    nn : int
        Number of velocity-level (non-holonomic) constraints A(q, t) v + a(q, t) = 0
        (multipliers μ, numbered per element in ``mu_index``); 0 for most models.
    velocity_constraint_groups : list of Group
        The batches with velocity constraints.
    rheonomic : bool
        Some constraint depends explicitly on t.
    length_scale : float
        Characteristic length (m) for the constraint tolerance.
    force_weight : ndarray, shape (nq,)
        1 for translational coordinates, 1/length_scale for rotations: turns
        the moment rows of a force residual into forces for the Newton test.
    """

    def __init__(self, **kw):
        self.__dict__.update(kw)
        self._frozen = True

    def __setattr__(self, key, value):
        if getattr(self, "_frozen", False):
            raise AttributeError(f"femb models are frozen: cannot set '{key}'")
        object.__setattr__(self, key, value)

    # ------------------------------------------------------------ helpers
    def ext(self, q):
        """Extended coordinates [q, q_fixed], shape (nq + nfix,)."""
        return np.concatenate((q, self.q_fixed))

    def ext_velocity(self, qd):
        """Extended velocities [q̇, 0], shape (nq + nfix_v,)."""
        return np.concatenate((qd, np.zeros(self.nfix_v)))

    def compose(self, q, d):
        """q ∘ exp(d): additive entries q + d, each free rotation p ⊗ exp(d_θ) (renormalised).

        Parameters
        ----------
        q : ndarray, shape (nx,)
            Configuration (quaternions stored in it for frame nodes).
        d : ndarray, shape (nq,)
            Increment in the tangent (velocity) numbering; rotation parts in body axes.

        Returns
        -------
        ndarray, shape (nx,)
        """
        from femb.base import rotations as rt
        q = np.array(q, dtype=float)
        d = np.asarray(d, dtype=float)
        if not self.lie:
            return q + d
        add = self.xmap >= 0
        q[self.xmap[add]] += d[add]
        for xs, vs in self.rot_blocks:
            # the plain-Python versions of the compiled group operations (no compilation on import)
            p = rt.quat_mul.py_func(q[xs:xs + 4], rt.quat_exp.py_func(np.ascontiguousarray(d[vs:vs + 3])))
            q[xs:xs + 4] = p / np.linalg.norm(p)
        return q

    def require_vector_space(self, what):
        """Raise :class:`ModelError` if the model has rotation nodes (``what`` is not available for them)."""
        if self.lie:
            raise ModelError(f"model '{self.name}' has spatial rotation nodes (quaternions): {what} is not "
                             "available for such models yet (see docs/spatial.md, 'Time loop')")

    def magnitude(self, q):
        """Magnitude of q per velocity entry (nq,): abs(x) of additive entries, 0 on rotations (judged by atol)."""
        q = np.asarray(q, dtype=float)
        if not self.lie:
            return np.abs(q)
        return np.where(self.xmap >= 0, np.abs(q[np.maximum(self.xmap, 0)]), 0.0)

    def bracket(self, v, w):
        """Lie bracket [v, w] (nq,): Ω_v × Ω_w on each free rotation, 0 elsewhere."""
        out = np.zeros(self.nq)
        for _, vs in self.rot_blocks:
            out[vs:vs + 3] = np.cross(v[vs:vs + 3], w[vs:vs + 3])
        return out

    def difference(self, q1, q0):
        """The increment d (nq,) with q1 = q0 ∘ exp(d): q1 − q0 on additive entries, log(p0⁻¹ ⊗ p1) on rotations."""
        from femb.base import rotations as rt
        q1 = np.asarray(q1, dtype=float)
        q0 = np.asarray(q0, dtype=float)
        if not self.lie:
            return q1 - q0
        d = np.zeros(self.nq)
        add = self.xmap >= 0
        d[add] = q1[self.xmap[add]] - q0[self.xmap[add]]
        for xs, vs in self.rot_blocks:
            d[vs:vs + 3] = rt.quat_log.py_func(rt.quat_mul.py_func(rt.quat_conj.py_func(q0[xs:xs + 4]),
                                                                  q1[xs:xs + 4]))
        return d

    def initial_state(self, t0=0.0):
        """The state as given by the user (not projected onto the constraints)."""
        return State(float(t0), self.q0.copy(), self.qd0.copy(), np.zeros(self.nq), np.zeros(self.nc))

    def node_coordinates(self, name, q):
        """Coordinates of node ``name`` (fixed ones included) for q of shape (..., nq)."""
        try:
            idx = self.node_index[name]
        except KeyError:
            raise ModelError(f"model '{self.name}' has no node/body named '{name}'") from None
        q = np.asarray(q)
        out = np.empty(q.shape[:-1] + (idx.size,))
        for k, i in enumerate(idx):
            out[..., k] = q[..., i] if i < self.nx else self.q_fixed[i - self.nx]
        return out

    def node_velocities(self, name, qd):
        """Velocities of node ``name`` (fixed ones as 0) for q̇ of shape (..., nq)."""
        try:
            idx = self.node_vindex[name]
        except KeyError:
            raise ModelError(f"model '{self.name}' has no node/body named '{name}'") from None
        qd = np.asarray(qd)
        out = np.zeros(qd.shape[:-1] + (idx.size,))
        for k, i in enumerate(idx):
            if i < self.nq:
                out[..., k] = qd[..., i]
        return out

    def mu_indices(self, name):
        """Indices into μ (the multipliers of velocity constraints) of element ``name`` (empty if none)."""
        if name not in self.element_types:
            raise ModelError(f"model '{self.name}' has no element named '{name}'")
        return self.mu_index.get(name, np.zeros(0, dtype=np.int64))

    def lam_indices(self, name):
        """Indices into λ of element ``name`` (empty for elements without constraints)."""
        try:
            return self.lam_index[name]
        except KeyError:
            raise ModelError(f"model '{self.name}' has no element named '{name}'") from None

    def describe(self):
        """A short text summary of the model."""
        lines = [f"model '{self.name}': nq = {self.nq}, nc = {self.nc}, fixed = {self.nfix}, "
                 f"constant mass: {self.constant_mass}, damping matrix: {self.needs_C}, "
                 f"rheonomic: {self.rheonomic}"]
        for g in self.groups:
            lines.append(f"  {g.name:24s} x{g.nel:<6d} nd={g.nd} nc={g.nc} {g.key}")
        return "\n".join(lines)

    def _summary(self):
        """(title, rows) for :meth:`__repr__` and :meth:`_repr_html_`."""
        from femb.base.summary import short_list

        batches = {}
        for g in self.groups:
            batches[g.name] = batches.get(g.name, 0) + g.nel
        rows = [("coordinates", f"nq = {self.nq} free velocities, nx = {self.nx} configuration entries, "
                                f"{self.nfix} fixed"),
                ("constraints", f"nc = {self.nc}"),
                ("elements", short_list(f"{n} {k}" for k, n in batches.items())),
                ("nodes", short_list(self.node_names)),
                ("kind", ("spatial (Lie group)" if self.lie else "planar") + ", mass "
                 + ("constant" if self.constant_mass else "configuration-dependent")
                 + (", rheonomic" if self.rheonomic else ""))]
        return f"femb Model '{self.name}'", rows

    def __repr__(self):
        from femb.base.summary import text

        return text(*self._summary())

    def _repr_html_(self):
        from femb.base.summary import html

        return html(*self._summary())


# --------------------------------------------------------------------------
def _group_key(e):
    k = e.group_key()
    return (type(e), k)


def _spatial_element(e):
    """True for elements that attach to spatial (frame-node) bodies: element types with a true
    class attribute ``spatial`` (the spatial bodies, joints, loads and beams of
    ``femb.elements.spatial_*`` set it on their base classes; a user's spatial type sets it too)."""
    return bool(getattr(type(e), "spatial", False))


def _is_body(obj):
    """True for bodies (what joints attach to: types with a true class attribute ``is_body``, as
    every body of ``femb.elements``; a body owns a node)."""
    return bool(getattr(type(obj), "is_body", False))


def compile_model(mech, *, length_scale=None):
    """Compile a :class:`~femb.system.mechanism.Mechanism` (see :meth:`Mechanism.compile`).

    The stages, in order: resolve and validate the elements (:func:`_resolve_elements`),
    number the coordinates (:func:`_number_coordinates`), batch the elements by type
    (:func:`_build_groups`), compile their kernels (:func:`_compile_kernels`), the constant
    mass and forces (:func:`_constant_terms`) and the length scale (:func:`_length_scale`).
    """
    elements = mech.elements
    gravity, others = _resolve_elements(mech)
    num = _number_coordinates(mech, others)
    groups, counts = _build_groups(others, num)
    for e in gravity:
        counts["lam_index"][e.name] = np.zeros(0, dtype=np.int64)
    mass_groups = [g for g in groups if g.traits["has_mass"]]
    const_force_groups = [g for g in groups if g.traits["has_force"] and g.traits["constant_force"]]
    force_groups = [g for g in groups if g.traits["has_force"] and not g.traits["constant_force"]]
    constraint_groups = [g for g in groups if g.nc > 0]
    if not mass_groups:
        raise ModelError(f"mechanism '{mech.name}' has no mass (add a RigidBody, PointMass or beam)")
    for g in mass_groups:
        if not g.traits["constant_mass"]:
            raise ModelError(f"{g.name}: a configuration-dependent mass matrix is not supported by the "
                             "compiled time loop (every femb element has constant mass)")
    qx0 = np.concatenate((num.q0, num.q_fixed))
    qdx0 = np.concatenate((num.qd0, np.zeros(num.nfix_v)))
    _compile_kernels(groups, qx0, qdx0)
    g_hat, M_const, f_const = _constant_terms(num, gravity, mass_groups, const_force_groups, qx0, qdx0)
    length_scale = _length_scale(mech, others, num.nodes, length_scale)
    w_ext = np.full(num.next_, 1.0 / length_scale)
    for nd in num.nodes:
        w_ext[num.node_vindex[nd.name][list(nd.translational)]] = 1.0
    model = Model(
        name=mech.name, nq=num.nq, nx=num.nx, nc=counts["nc"], nfix=num.nfix, nfix_v=num.nfix_v, q0=num.q0,
        qd0=num.qd0, q_fixed=num.q_fixed, node_index=num.node_index, node_vindex=num.node_vindex,
        node_names=[nd.name for nd in num.nodes], coord_labels=num.labels, velocity_labels=num.vlabels,
        lie=num.lie, xmap=num.xmap, rot_blocks=np.array(num.rot_blocks, dtype=np.int64).reshape(-1, 2),
        groups=groups, mass_groups=mass_groups, force_groups=force_groups,
        const_force_groups=const_force_groups, constraint_groups=constraint_groups,
        contact_groups=[g for g in groups if g.cN.shape[1] > 0], n_contacts=counts["n_N"],
        n_friction=counts["n_F"], constant_mass=all(g.traits["constant_mass"] for g in mass_groups), M_const=M_const, f_const=f_const[:num.nq].copy(),
        g_hat=g_hat, gravity=None if not gravity else gravity[0].g.copy(),
        needs_C=any(g.traits["force_depends_on_qd"] for g in force_groups),
        rheonomic=any(g.traits["rheonomic"] for g in constraint_groups),
        lam_index=counts["lam_index"], length_scale=length_scale, nn=counts["nn"],
        velocity_constraint_groups=[g for g in groups if g.nn > 0], mu_index=counts["mu_index"],
        time_function_table=_time_function_table(counts["tf_all"]),
        force_weight=w_ext[:num.nq].copy(), force_weight_ext=w_ext,
        bodies={e.name: e for e in [mech.ground] + others if _is_body(e)},
        element_types={e.name: type(e).__name__ for e in elements},
    )
    for arr in (num.q0, num.qd0, num.q_fixed):
        arr.flags.writeable = False
    return model


def _body_lookup(mech, owner, members):
    """The function ``lookup(ref, role)`` that ``owner.resolve`` calls: a name or body → the body."""
    def lookup(ref, role):
        if isinstance(ref, str):
            if ref not in mech:
                raise ModelError(f"{type(owner).__name__} '{owner.name}': {role} refers to '{ref}', "
                                 f"which is not in mechanism '{mech.name}'")
            ref = mech[ref]
        if not _is_body(ref):
            raise ModelError(f"{type(owner).__name__} '{owner.name}': {role} must be a body, got {ref!r}")
        if id(ref) not in members:
            raise ModelError(f"{type(owner).__name__} '{owner.name}': {role} refers to body "
                             f"'{ref.name}', which was not added to mechanism '{mech.name}'")
        if not _spatial_element(owner) and getattr(getattr(ref, "node", None), "rotation_blocks", ()):
            raise ModelError(
                f"{type(owner).__name__} '{owner.name}': {role} = '{ref.name}' is a spatial body "
                f"({type(ref).__name__}); {type(owner).__name__} is a planar element (it acts on x, y, θ) "
                "and cannot be attached to a spatial body: planar and spatial elements cannot be joined. "
                "Use the spatial element types (SphericalJoint, RevoluteJoint, PointSpringDamper, "
                "SpatialForce, SpatialTorque, ...; docs/spatial.md)")
        return ref
    return lookup


def _resolve_elements(mech):
    """Resolve every element's references and validate it: (gravity elements, the others)."""
    elements = mech.elements
    members = set(id(e) for e in elements) | {id(mech.ground)}
    gravity = [e for e in elements if getattr(type(e), "gravity_field", False)]
    if len(gravity) > 1:
        raise ModelError(f"mechanism '{mech.name}' has {len(gravity)} Gravity elements; give one")
    others = [e for e in elements if not getattr(type(e), "gravity_field", False)]
    for e in others:
        e.resolve(_body_lookup(mech, e, members))
        e.validate()
    return gravity, others


@dataclass
class _Numbering:
    """The coordinate numbering of a model (built by :func:`_number_coordinates`).

    Configuration entries x (nx per node; a frame node stores a quaternion) and velocity /
    tangent entries v (nv per node) are numbered apart: free ones first, fixed ones after.
    Nodes without rotations (planar) have x ≡ v, and both numberings agree on them when the
    model has no rotation nodes.
    """

    nodes: list
    nx: int
    nfix: int
    nq: int
    nfix_v: int
    q0: np.ndarray
    qd0: np.ndarray
    q_fixed: np.ndarray
    xmap: np.ndarray                            # x index of each additive free v entry, −1 for rotations
    node_index: dict = None
    node_vindex: dict = None
    labels: list = None
    vlabels: list = None
    rot_blocks: list = None                     # (x start of the quaternion, v start of its rotation vector)

    @property
    def next_(self):
        return self.nq + self.nfix_v

    @property
    def lie(self):
        return bool(self.rot_blocks) or self.nx != self.nq


def _nx(nd):
    return int(getattr(nd, "nx", nd.ncoord))


def _fixed_v(nd):
    return np.asarray(getattr(nd, "fixed_v", nd.fixed), dtype=bool)


def _number_coordinates(mech, others):
    """The nodes of the elements (ground first, each once) and their coordinate numbering."""
    nodes, seen = [mech.ground.node], {id(mech.ground.node)}
    for e in others:
        for nd in e.nodes():
            if id(nd) not in seen:
                seen.add(id(nd))
                nodes.append(nd)
    names = set()
    for nd in nodes:
        if nd.name in names:
            raise ModelError(f"duplicate node name '{nd.name}'")
        names.add(nd.name)
    nx = sum(int((~nd.fixed).sum()) for nd in nodes)
    nq = sum(int((~_fixed_v(nd)).sum()) for nd in nodes)
    num = _Numbering(nodes=nodes, nx=nx, nfix=sum(int(nd.fixed.sum()) for nd in nodes), nq=nq,
                     nfix_v=sum(int(_fixed_v(nd).sum()) for nd in nodes), q0=np.empty(nx), qd0=np.empty(nq),
                     q_fixed=np.empty(0), xmap=np.full(nq, -1, dtype=np.int64), node_index={}, node_vindex={},
                     labels=[], vlabels=[], rot_blocks=[])
    num.q_fixed = np.empty(num.nfix)
    counters = [0, 0, 0, 0]                    # free x, fixed x, free v, fixed v numbered so far
    for nd in nodes:
        idx, vidx = _number_node(num, nd, counters)
        _additive_map(num, nd, idx, vidx)
        num.node_index[nd.name] = idx
        num.node_vindex[nd.name] = vidx
    if nq == 0:
        raise ModelError(f"mechanism '{mech.name}' has no free coordinates (add a body)")
    return num


def _number_node(num, nd, counters):
    """The x and v indices of one node (free ones counted on, fixed ones after all free ones)."""
    fx, fv = nd.fixed, _fixed_v(nd)
    idx = np.empty(_nx(nd), dtype=np.int64)
    for c in range(idx.size):
        if fx[c]:
            idx[c] = num.nx + counters[1]
            num.q_fixed[counters[1]] = nd.q0[c]
            counters[1] += 1
        else:
            idx[c] = counters[0]
            num.q0[counters[0]] = nd.q0[c]
            num.labels.append(f"{nd.name}.{nd.coord_names[c]}")
            counters[0] += 1
    vidx = np.empty(fv.size, dtype=np.int64)
    vnames = getattr(nd, "velocity_names", nd.coord_names)
    for c in range(fv.size):
        if fv[c]:
            vidx[c] = num.nq + counters[3]
            counters[3] += 1
        else:
            vidx[c] = counters[2]
            num.qd0[counters[2]] = nd.qd0[c]
            num.vlabels.append(f"{nd.name}.{vnames[c]}")
            counters[2] += 1
    return idx, vidx


def _additive_map(num, nd, idx, vidx):
    """Rotation blocks and the x index of each additive v entry of one node (``num.xmap``)."""
    fx, fv = nd.fixed, _fixed_v(nd)
    blocks = tuple(getattr(nd, "rotation_blocks", ()))
    in_rot = np.zeros(fv.size, dtype=bool)
    for xs, vs in blocks:
        in_rot[vs:vs + 3] = True
        if not fv[vs]:
            num.rot_blocks.append((int(idx[xs]), int(vidx[vs])))
    # additive entries: the i-th non-rotation x entry goes with the i-th non-rotation v entry
    xs_add = [c for c in range(idx.size) if not any(b[0] <= c < b[0] + 4 for b in blocks)]
    vs_add = [c for c in range(fv.size) if not in_rot[c]]
    if len(xs_add) != len(vs_add):
        raise ModelError(f"node '{nd.name}': {len(xs_add)} additive coordinates but {len(vs_add)} "
                         "additive velocities")
    for cx, cv in zip(xs_add, vs_add):
        if fx[cx] != fv[cv]:
            raise ModelError(f"node '{nd.name}': coordinate {nd.coord_names[cx]} and its velocity must "
                             "be both free or both fixed")
        if not fv[cv]:
            num.xmap[vidx[cv]] = idx[cx]


def _build_groups(others, num):
    """One :class:`Group` per batch of elements (:func:`_group_key`), with its multipliers, contact
    rows and time functions numbered: (groups, counts) with counts the dict of ``nc``, ``nn``,
    ``n_N``, ``n_F``, ``lam_index``, ``mu_index`` and ``tf_all`` (every time function, in order)."""
    batches = {}
    for e in others:
        batches.setdefault(_group_key(e), []).append(e)
    counts = {"nc": 0, "nn": 0, "n_N": 0, "n_F": 0, "lam_index": {}, "mu_index": {}, "tf_all": []}
    groups = []
    for (cls, key), els in batches.items():
        dofs = np.array([np.concatenate([num.node_vindex[n.name] for n in e.nodes()]) for e in els],
                        dtype=np.int64).reshape(len(els), -1)
        xdofs = (np.array([np.concatenate([num.node_index[n.name] for n in e.nodes()]) for e in els],
                          dtype=np.int64).reshape(len(els), -1) if num.lie else dofs)
        tr = cls.traits(els)
        lam = _number_rows(counts, "nc", els, int(tr["n_constraints"]), counts["lam_index"])
        nvc = int(tr.get("n_velocity_constraints", 0) or 0)
        mu = _number_rows(counts, "nn", els, nvc, counts["mu_index"] if nvc else None)
        cN = _number_rows(counts, "n_N", els, int(tr.get("n_contacts", 0)), None)
        cF = _number_rows(counts, "n_F", els, int(tr.get("n_friction", 0)), None)
        params = cls.pack(els)
        if not isinstance(params, dict):
            raise ModelError(f"{cls.__name__}.pack must return a dict, got {type(params).__name__}")
        if "P" not in params and not _kernel_roles(tr):
            params = dict(params, P=np.zeros((len(els), 1)))   # a batch without kernels (nodes)
        _check_kernels(cls, tr, params, len(els))
        fns, tf_index = _time_functions(cls, els, counts["tf_all"])
        g = Group(cls=cls, key=key, elements=els, names=[e.name for e in els],
                  params=params, dofs=dofs, xdofs=xdofs, traits=tr, lam=lam,
                  P=np.ascontiguousarray(params["P"], dtype=np.float64), tf_index=tf_index,
                  time_functions=fns, mu=mu if nvc else None, cN=cN, cF=cF)
        _index_group(g, num.nq)
        groups.append(g)
    return groups, counts


def _number_rows(counts, key, els, per_element, index):
    """Rows ``counts[key] + 0, 1, ...``, ``per_element`` per element (shape (len(els), per_element));
    counts on ``counts[key]``; each element's rows into ``index`` (by name) unless it is None."""
    rows = (counts[key] + np.arange(len(els) * per_element)).reshape(len(els), per_element)
    counts[key] += len(els) * per_element
    if index is not None:
        for e, row in zip(els, rows):
            index[e.name] = row.copy()
    return rows


def _time_functions(cls, els, tf_all):
    """The time functions of a batch and their indices in ``tf_all`` (appended to)."""
    fns = [list(cls.time_functions(e)) for e in els]
    ntf = {len(f) for f in fns}
    if len(ntf) != 1:
        raise ModelError(f"{cls.__name__}: elements of one batch must have the same number of time "
                         f"functions (split them with group_key), got {sorted(ntf)}")
    tf_index = np.empty((len(els), ntf.pop()), dtype=np.int64)
    for e, row in enumerate(fns):
        for k, fn in enumerate(row):
            tf_index[e, k] = len(tf_all)
            tf_all.append(fn)
    return fns, tf_index


def _compile_kernels(groups, qx0, qdx0):
    """Every kernel of every batch, compiled once per element type for its role's signature (or
    loaded from the disk cache): a kernel that breaks its contract is refused here, naming its
    element type, and nothing compiles later, unannounced. Element types that are not femb's own
    run their kernels once, bounds-checked, on this model's shapes (an out-of-bounds write is a
    ModelError here, not a crash later)."""
    for g in groups:
        for role, fn in (getattr(g.cls, "kernels", None) or {}).items():
            if role in ("mass", "force", "constraint", "rates", "contact") or (role == "velocity_constraint" and g.nn):
                _kernels.compiled_kernel(g.cls.__name__, role, fn)
    _kernels.announce_compiled()
    for g in groups:
        if not _kernels.is_builtin(g.cls) or _kernels.debug_mode():
            _kernels.contract_check(g, qx0[g.xdofs], qdx0[g.dofs])


def _constant_terms(num, gravity, mass_groups, const_force_groups, qx0, qdx0):
    """The gravity direction field ĝ (or None), the constant mass matrix M (nq, nq) and the
    constant forces (next,): gravity M ĝ and the constant-force elements at t = 0."""
    next_ = num.next_
    g_hat = None
    if gravity:
        g_hat = np.zeros(next_)
        for nd in num.nodes:
            idx = num.node_vindex[nd.name]
            for c, comp in zip(nd.translational, gravity[0].g):
                g_hat[idx[c]] = comp
    f_const = np.zeros(next_)
    rows, cols, vals = [], [], []
    for g in mass_groups:
        Me = _kernels.mass(g, qx0[g.xdofs])
        rows.append(g.nn_rows)
        cols.append(g.nn_cols)
        vals.append(Me.reshape(-1)[g.nn_sel])
        if g_hat is not None:
            fe = np.einsum("eij,ej->ei", Me, g_hat[g.dofs])
            f_const += np.bincount(g.dofs.ravel(), fe.ravel(), minlength=next_)
    M_const = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                            shape=(num.nq, num.nq))
    M_const.sum_duplicates()
    for g in const_force_groups:
        fe, _, _ = _kernels.force(g, 0.0, qx0[g.xdofs], qdx0[g.dofs], False)
        f_const += np.bincount(g.dofs.ravel(), fe.ravel(), minlength=next_)
    return g_hat, M_const, f_const


def _length_scale(mech, others, nodes, length_scale):
    """The model's length scale: given, or the extent of the initial node positions and of the
    elements' attachment points (1 if both are zero).

    Residual weights: moments (rows of non-translational coordinates) are divided by it so the
    force-residual test mixes N with N, not N with N·m (unit-invariant Newton stopping)."""
    if length_scale is not None:
        length_scale = float(length_scale)
        if not (length_scale > 0.0 and np.isfinite(length_scale)):
            raise ModelError(f"length_scale must be a positive finite number, got {length_scale!r}")
        return length_scale
    pts = [np.pad(nd.q0[list(nd.translational)], (0, 3 - len(nd.translational)))
           for nd in nodes if len(nd.translational)]
    pts = np.array(pts) if pts else np.zeros((1, 3))
    L = float(np.max(np.ptp(pts, axis=0))) if len(pts) > 1 else 0.0
    for e in [mech.ground] + others:
        for s in getattr(e, "points", {}).values():
            L = max(L, float(np.linalg.norm(s)))
    return L if L > 0.0 else 1.0


def _index_group(g, nq):
    """Free-coordinate bookkeeping of a batch (done once)."""
    nel, nd = g.dofs.shape
    R = np.broadcast_to(g.dofs[:, :, None], (nel, nd, nd)).reshape(-1)
    C = np.broadcast_to(g.dofs[:, None, :], (nel, nd, nd)).reshape(-1)
    sel = np.nonzero((R < nq) & (C < nq))[0]
    g.nn_sel, g.nn_rows, g.nn_cols = sel, R[sel], C[sel]
    nc = g.lam.shape[1]
    if nc:
        R = np.broadcast_to(g.lam[:, :, None], (nel, nc, nd)).reshape(-1)
        C = np.broadcast_to(g.dofs[:, None, :], (nel, nc, nd)).reshape(-1)
        sel = np.nonzero(C < nq)[0]
        g.cq_sel, g.cq_rows, g.cq_cols = sel, R[sel], C[sel]


_ROLES = (("has_mass", "mass"), ("has_force", "force"))


def _kernel_roles(tr):
    need = [role for flag, role in _ROLES if tr[flag]]
    if int(tr["n_constraints"]):
        need += ["constraint", "rates"]
    if int(tr.get("n_velocity_constraints", 0) or 0):
        need += ["velocity_constraint"]
    if int(tr.get("n_contacts", 0)):
        need += ["contact"]
    return need


def _check_kernels(cls, tr, params, nel):
    """The batch provides the compiled kernels its metadata declares, and a parameter array."""
    ks = getattr(cls, "kernels", None) or {}
    need = _kernel_roles(tr)
    missing = [r for r in need if r not in ks]
    if missing:
        raise ModelError(f"{cls.__name__}: its metadata declares {', '.join(missing)} but "
                         f"{cls.__name__}.kernels has no such compiled kernel (see docs/kernels.md)")
    P = params.get("P") if isinstance(params, dict) else None
    if P is None or np.ndim(P) != 2 or np.shape(P)[0] != nel:
        raise ModelError(f"{cls.__name__}.pack must return a dict with 'P', a float array of shape "
                         f"(nel, npar) = ({nel}, ...), got {None if P is None else np.shape(P)}")


def _time_function_table(fns):
    """Compiled description of the model's time functions.

    kind 1: polynomial (coefficients from the constant term up), kind 2: harmonic
    (A, ω, φ, offset), kind 0: a Python function evaluated outside compiled code.
    """
    kind, off, coef = [], [0], []
    python = []
    for k, fn in enumerate(fns):
        spec = fn.compiled() if hasattr(fn, "compiled") else None
        if spec is None:
            kind.append(0)
            python.append((k, fn))
        else:
            kind.append(spec[0])
            coef.extend(float(c) for c in spec[1])
        off.append(len(coef))
    return {"kind": np.array(kind, dtype=np.int64), "off": np.array(off, dtype=np.int64),
            "coef": np.array(coef if coef else [0.0]), "python": python}
