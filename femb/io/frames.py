"""From model and state to output frames: the glue between elements and VTK files.

Elements describe their look as :class:`femb.base.geometry.GeometryBlock` records
(one call per element type); this module collects them for a state and streams
them through :class:`femb.io.vtk.TimeSeriesWriter`.
"""
from __future__ import annotations

import weakref

import numpy as np

from femb.base.geometry import GeometryBlock

#: What the renderer draws for an element type (field data ``glyph.<type name>``):
#: a number per kind. Element classes set a ``glyph`` attribute to be drawn as one
#: of these kinds: one name (for the blocks named after the type) or, for types
#: with several blocks, a dict {suffix: kind} (the block named type name + suffix).
GLYPHS = {"body": 1, "body_frame": 2, "point_mass": 3, "revolute": 10, "spherical": 11,
          "prismatic": 12, "cylindrical": 13, "universal": 14, "fixed": 15, "distance": 16,
          "motor": 17, "actuator": 18,
          "spring": 20, "bushing": 21, "torsion": 22, "load": 30, "ground": 40, "beam": 50, "contact": 60}

#: Kinds of the blocks this module makes itself (the ground's named points).
_OWN_KINDS = {"SpatialGround": "ground", "Ground": "ground"}

#: kinds of planar pair elements that the renderer draws as joints at their points
_PLANAR_JOINTS = ("revolute", "prismatic", "motor", "actuator", "torsion", "fixed")

#: How a body is drawn (cell data ``body_look``): its given shape, the hull of its
#: named points, or (neither given) the box with its mass and inertia.
LOOK_SHAPE, LOOK_HULL, LOOK_INERTIA = 0, 1, 2

_SCENES: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def glyphs(cls):
    """{block name: kind} that an element type declares with its ``glyph`` attribute (see :data:`GLYPHS`)."""
    gl = getattr(cls, "glyph", None)
    if isinstance(gl, dict):
        return {cls.__name__ + str(k): v for k, v in gl.items() if v in GLYPHS}
    return {cls.__name__: gl} if gl in GLYPHS else {}


class _Scene:
    """What the renderer needs to know about a model beyond its geometry (computed once)."""

    def __init__(self, model):
        self.kinds = dict(_OWN_KINDS)  # block name -> kind, from the glyph attributes of the types
        self.body_index = {}          # body name -> 1, 2, ... (0: the ground)
        for name in model.bodies:
            if name != "ground":
                self.body_index[name] = len(self.body_index) + 1
        self.body_look = {}
        self.points = {}              # (body, point) -> body-axes coordinates
        self.pairs = set()            # ids of groups of spatial pair elements
        self.hinges = {}              # {body a, body b} -> (x entries (6,), s_a (2,)) of a planar hinge
        for g in model.groups:
            self.kinds.update(glyphs(g.cls))
            if getattr(g.cls, "frame_pair", False):
                self.pairs.add(id(g))
            elif glyphs(g.cls).get(g.cls.__name__) == "revolute" and _is_planar_pair(g) and "sa" in g.params:
                for k, e in enumerate(g.elements):
                    key = frozenset((getattr(e.a, "name", e.a), getattr(e.b, "name", e.b)))
                    self.hinges.setdefault(key, (np.asarray(g.xdofs[k]), np.asarray(g.params["sa"][k], float)))
            for e in g.elements:
                if (getattr(type(e), "spatial", False) and model.bodies.get(e.name) is e
                        and e.name in self.body_index):
                    pts = getattr(e, "points", {}) or {}
                    shape = getattr(e, "shape", None)
                    typ = (shape or {}).get("type", "hull")
                    self.body_look[e.name] = (LOOK_SHAPE if typ != "hull" else
                                              LOOK_HULL if pts else LOOK_INERTIA)
                    for k, v in pts.items():
                        self.points[(e.name, k)] = np.asarray(v, dtype=float)
        g = getattr(model, "gravity", None)
        self.gravity = None
        if g is not None:
            g = np.asarray(g, dtype=float).reshape(-1)
            self.gravity = np.concatenate((g, np.zeros(3 - g.size))) if g.size < 3 else g[:3]

    def body(self, ref):
        name = getattr(ref, "name", ref)
        return self.body_index.get(name, 0)

    def hinge_point(self, a, b, qx):
        """Where a planar hinge joins bodies a and b at the configuration qx (2,), or None."""
        h = self.hinges.get(frozenset((getattr(a, "name", a), getattr(b, "name", b))))
        if h is None:
            return None
        from femb.elements._planar import rot

        x = np.asarray(qx[h[0]], dtype=float)
        return x[0:2] + rot(np.array([x[2]]), h[1][None])[0]

    def field_data(self, blocks):
        fd = {}
        for b in blocks:
            kind = self.kinds.get(b.name)
            if kind is not None:
                fd[f"glyph.{b.name}"] = np.array([GLYPHS[kind]], dtype=np.int32)
        for name, k in self.body_index.items():
            fd[f"body.{name}"] = np.array([k], dtype=np.int32)
        for (body, pt), X in self.points.items():
            fd[f"point.{body}.{pt}"] = X.copy()
        if self.gravity is not None:
            fd["gravity"] = self.gravity.copy()
        return fd


def _scene(model):
    try:
        sc = _SCENES.get(model)
    except TypeError:               # not weakly referable: compute each time
        return _Scene(model)
    if sc is None:
        sc = _Scene(model)
        _SCENES[model] = sc
    return sc


def _annotate(scene, g, blocks, qx):
    """Add body numbers, joint axes and the bodies a joint links to the blocks of group g."""
    names = list(g.names)
    kind = glyphs(g.cls).get(g.cls.__name__)
    if kind in ("body", "point_mass"):
        index = np.array([scene.body(n) for n in names], dtype=np.int32)
        look = np.array([scene.body_look.get(n, LOOK_SHAPE) for n in names], dtype=np.int32)
        for b in blocks:
            ids = b.cell_data.get("body_id")
            if ids is None and kind == "point_mass" and [c for c, _ in b.cells] == ["vertex"] \
                    and len(b.points) == len(names):          # one vertex per point mass, in order
                ids = [np.arange(len(names))]
            if ids is None:
                continue
            b.cell_data["body"] = [index[np.asarray(i, dtype=np.int64)] for i in ids]
            b.cell_data["body_look"] = [look[np.asarray(i, dtype=np.int64)] for i in ids]
        return
    if kind in _PLANAR_JOINTS and id(g) not in scene.pairs and _is_planar_pair(g):
        _planar_joint(scene, g, kind, blocks, qx)
        return
    if id(g) not in scene.pairs or not blocks:
        return
    from femb.elements._spatial_geometry import rotation_matrices

    p = g.params
    qe = np.asarray(qx[g.xdofs], dtype=float)
    Ra = rotation_matrices(qe[:, 3:7])
    Rb = rotation_matrices(qe[:, 10:14])
    n = qe.shape[0]
    ba = np.array([scene.body(e.a) for e in g.elements], dtype=np.int32)
    bb = np.array([scene.body(e.b) for e in g.elements], dtype=np.int32)
    for b in blocks:
        if len(b.points) != n or [c for c, _ in b.cells] != ["vertex"]:
            continue
        if "Ea" in p and "Eb" in p:
            b.point_data["joint_axis"] = np.einsum("nij,nj->ni", Ra, p["Ea"][:, 2])
            b.point_data["joint_pin_a"] = np.einsum("nij,nj->ni", Ra, p["Ea"][:, 1])
            b.point_data["joint_pin_b"] = np.einsum("nij,nj->ni", Rb, p["Eb"][:, 0])
        b.cell_data["body_a"] = [ba.copy()]
        b.cell_data["body_b"] = [bb.copy()]


def _is_planar_pair(g):
    """A group of planar elements between two bodies (x, y, θ each: 6 configuration entries)."""
    return not getattr(g.cls, "spatial", False) and bool(g.elements) and \
        all(hasattr(e, "a") and hasattr(e, "b") for e in g.elements) and np.shape(g.xdofs)[1:] == (6,)


def _planar_joint(scene, g, kind, blocks, qx):
    """What the renderer needs of a planar joint, drive or torsion spring between bodies a and b.

    Its points P_a = r_a + R(θ_a) s_a (vertex cells) carry ``joint_axis`` (z, or the
    line's direction for sliders and driven displacements), ``joint_pb`` (P_b) and the
    bodies ``body_a`` / ``body_b``. A type that draws nothing of its own (a driven angle,
    a torsion spring) gets a block of its own there: at the hinge that joins the same
    two bodies when there is one, else at P_a.
    """
    from femb.elements._planar import perp, rot

    n = len(g.elements)
    qe = np.asarray(qx[g.xdofs], dtype=float)
    p = g.params
    zero = np.zeros((n, 2))
    sa = np.asarray(p.get("sa", zero), dtype=float).reshape(n, 2)
    sb = np.asarray(p.get("sb", zero), dtype=float).reshape(n, 2)
    Pa = qe[:, 0:2] + rot(qe[:, 2], sa)
    Pb = qe[:, 3:5] + rot(qe[:, 5], sb)
    if not blocks and kind in ("motor", "torsion"):
        for k, e in enumerate(g.elements):
            at = scene.hinge_point(e.a, e.b, qx)
            if at is not None:
                Pa[k] = Pb[k] = at
    axis = np.zeros((n, 3))
    if kind in ("prismatic", "actuator") and "u" in p:
        axis[:, :2] = rot(qe[:, 2], np.asarray(p["u"], dtype=float).reshape(n, 2))
    else:
        axis[:, 2] = 1.0
    pin = np.zeros((n, 3))                  # a direction normal to the axis (sleeves, arrows beside)
    if kind in ("prismatic", "actuator"):
        pin[:, :2] = perp(axis[:, :2])
    else:
        pin[:, 0] = 1.0
    ba = np.array([scene.body(e.a) for e in g.elements], dtype=np.int32)
    bb = np.array([scene.body(e.b) for e in g.elements], dtype=np.int32)
    pa3, pb3 = np.zeros((n, 3)), np.zeros((n, 3))
    pa3[:, :2], pb3[:, :2] = Pa, Pb
    data = {"joint_axis": axis, "joint_pin_a": pin, "joint_pb": pb3}
    own = [b for b in blocks if b.name == g.cls.__name__]
    if not own:
        blocks.append(GeometryBlock(g.cls.__name__, pa3, [("vertex", np.arange(n)[:, None])],
                                    point_data=data, cell_data={"body_a": [ba], "body_b": [bb]}))
        return
    b = own[0]
    kinds = [c for c, _ in b.cells]
    if kinds == ["vertex"] and len(b.points) == n:        # a hinge: its vertices are the P_a
        b.point_data.update(data)
        b.cell_data.update(body_a=[ba], body_b=[bb])
        return
    # a line joint: its drawing (lines) stays for ParaView; vertices at P_a are added
    m = len(b.points)
    b.points = np.vstack((np.asarray(b.points, dtype=float), pa3))
    for name, a in list(b.point_data.items()):
        a = np.asarray(a)
        b.point_data[name] = np.concatenate((a, np.zeros((n,) + a.shape[1:], a.dtype)))
    for name, a in data.items():
        b.point_data[name] = np.concatenate((np.zeros((m, 3)), a))
    b.cells = list(b.cells) + [("vertex", m + np.arange(n)[:, None])]
    for name, arrays in list(b.cell_data.items()):
        last = np.asarray(arrays[-1])
        b.cell_data[name] = list(arrays) + [np.zeros((n,) + last.shape[1:], last.dtype)]
    minus = [np.full(len(c), -1, dtype=np.int32) for _, c in b.cells[:-1]]
    b.cell_data["body_a"] = minus + [ba]
    b.cell_data["body_b"] = [x.copy() for x in minus] + [bb]


def model_blocks(model, t, q, qd, lam, contact=None):
    """Geometry of every element of ``model`` at one state.

    Parameters
    ----------
    model : Model
    t : float
    q, qd : ndarray, shape (nq,)
    lam : ndarray, shape (nc,)
    contact : (state (nN,), lam_N (nN,), lam_F (nF,)), optional
        The contact states and forces of a contact result at this state (see
        :meth:`femb.contact.result.ContactResult.contact_at`); the contact elements then draw their
        forces.

    Returns
    -------
    list of GeometryBlock
        One or more blocks per element type, plus the ground's named points
        (and those of its spatial twin, :func:`~femb.elements.spatial_bodies.spatial_ground`).
    """
    qx = model.ext(np.asarray(q, dtype=float))
    qdx = model.ext_velocity(np.asarray(qd, dtype=float))
    lam = np.asarray(lam, dtype=float)
    blocks = []
    ground = model.bodies.get("ground")
    if ground is not None and ground.points:
        pts = np.zeros((len(ground.points), 3))
        pts[:, :2] = np.array(list(ground.points.values()))
        blocks.append(GeometryBlock("Ground", pts, [("vertex", np.arange(len(pts))[:, None])]))
    twin = getattr(ground, "_spatial_twin", None)       # the ground as seen by spatial elements
    if twin is not None and twin.points:
        pts = np.array(list(twin.points.values()), dtype=float).reshape(-1, 3)
        blocks.append(GeometryBlock("SpatialGround", pts, [("vertex", np.arange(len(pts))[:, None])]))
    scene = _scene(model)
    for g in model.groups:
        le = lam[g.lam] if g.nc else np.zeros((g.nel, 0))
        if contact is not None and g.cN.shape[1] == 1:
            st, lN, lF = (np.asarray(a, dtype=float) for a in contact)
            le = np.column_stack((st[g.cN[:, 0]], lN[g.cN[:, 0]], lF[g.cF].reshape(g.nel, -1)))
        out = list(g.cls.geometry(g.params, t, qx[g.xdofs], qdx[g.dofs], le, g.names))
        _annotate(scene, g, out, qx)
        blocks.extend(out)
    return blocks


def scene_field_data(model, blocks):
    """Field data that tells a renderer what the geometry blocks of ``model`` are.

    Parameters
    ----------
    model : Model
    blocks : list of GeometryBlock
        From :func:`model_blocks`.

    Returns
    -------
    dict of str to ndarray
        ``glyph.<type name>``: the kind of each element type (:data:`GLYPHS`);
        ``body.<name>``: the number of each body (cell data ``body`` of its
        drawing, ``body_a`` / ``body_b`` of its joints; 0 is the ground);
        ``point.<body>.<point>``: named points in body axes (m), relative to
        the body's node; ``gravity`` (3,), m/s², when the model has gravity.
    """
    return _scene(model).field_data(blocks)


class VTKStream:
    """Stream frames to a ParaView time series while a simulation runs.

    Use as the ``observer`` of :func:`femb.simulate`, inside a ``with`` block so
    the ``.pvd`` is complete even when the run fails midway::

        with VTKStream(model, "out/andrews", every=10) as vtk:
            femb.simulate(model, 0.03, 1e-5, observer=vtk)

    Parameters
    ----------
    model : Model
    directory : str or Path
    every : int
        Write every ``every``-th step (step 0, the initial state, is written).
    basename : str
    observer : callable(state, step), optional
        Another observer to call after writing (e.g. a progress bar).
    dt : float, optional
        Write frames at t0 + k·dt instead, interpolated between the accepted
        steps (cubic Hermite in q and q̇): for adaptive steps, whose step times
        are not known in advance. ``every`` is then ignored.
    """

    def __init__(self, model, directory, every=1, basename="frame", observer=None, dt=None):
        from femb.errors import OutputError
        from femb.io.vtk import TimeSeriesWriter

        self.model = model
        self.every = int(every)
        if self.every < 1:
            raise OutputError(f"every must be a positive integer, got {every!r}")
        self.dt = None
        if dt is not None:
            self.dt = float(dt)
            if not (self.dt > 0.0 and np.isfinite(self.dt)):
                raise OutputError(f"dt must be a positive finite time, got {dt!r}")
            self.every = 1
        self._prev = None
        self._next_t = None
        self._t0 = None
        self._k = 0
        self.writer = TimeSeriesWriter(directory, basename=basename)
        self.observer = observer

    def _frames_between(self, state, step):
        from femb.base.interp import state_between
        if step == 0 or self._prev is None:
            self._t0 = state.t
            self._k = 0
            self._write(state.t, state.q, state.qd, state.lam)
            self._k = 1
        else:
            s0 = self._prev
            while True:
                t = self._t0 + self._k * self.dt
                if t > state.t * (1 + 1e-12) + 1e-300:
                    break
                q, qd, _, lam = state_between(s0, state, min(t, state.t), self.model)
                self._write(t, q, qd, lam)
                self._k += 1
        self._prev = state.copy() if hasattr(state, "copy") else state

    def _write(self, t, q, qd, lam):
        blocks = model_blocks(self.model, t, q, qd, lam)
        self.writer.write(t, blocks, field_data=scene_field_data(self.model, blocks))

    @property
    def path(self):
        """Path of the ``.pvd`` collection."""
        return self.writer.path

    def __call__(self, state, step):
        if self.dt is not None:
            self._frames_between(state, step)
        elif step % self.every == 0:
            self._write(state.t, state.q, state.qd, state.lam)
        if self.observer is not None:
            self.observer(state, step)

    def close(self):
        self.writer.close()

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        self.writer.__exit__(exc_type, exc, tb)      # no second error while one is in flight
        return False


def write_vtk(result, directory, every=1, basename="frame", steps=None):
    """Write the stored steps of a :class:`~femb.results.result.Result` as a time series.

    ``every``-th stored step and the last; or, with ``steps`` (indices of stored steps, increasing), those.

    Returns
    -------
    pathlib.Path
        The ``.pvd`` file.
    """
    from femb.io.vtk import TimeSeriesWriter

    m = result.model
    contact_at = getattr(result, "contact_at", None)        # a contact result: its forces and states
    with TimeSeriesWriter(directory, basename=basename) as w:
        def put(k):
            blocks = model_blocks(m, result.t[k], result.q[k], result.qd[k], result.lam[k],
                                  contact=None if contact_at is None else contact_at(k))
            w.write(result.t[k], blocks, field_data=scene_field_data(m, blocks))

        if steps is not None:
            for k in steps:
                put(int(k))
            return w.path
        for k in range(0, result.t.size, int(every)):
            put(k)
        if (result.t.size - 1) % int(every):
            put(result.t.size - 1)
    return w.path


def write_vtk_stream(model, directory, every=1, basename="frame", observer=None, dt=None):
    """A :class:`VTKStream` (the hook the command line uses for ``--vtk``)."""
    return VTKStream(model, directory, every=every, basename=basename, observer=observer, dt=dt)
