"""What a picture of a mechanism shows: bodies, joints, ground, floor, paths.

Spatial and planar mechanisms are drawn by the same parts; a planar one (bodies
without frames in the plane z = 0) is seen straight onto its plane, without a
floor, each body's flat outline on a layer of its own.

A frame written by :func:`femb.io.frames.model_blocks` carries, next to its
geometry, field data naming what each element type is (``glyph.<type>``),
the bodies (``body.<name>``), their named points (``point.<body>.<point>``)
and gravity, and, per joint, its axis and the bodies it links (point data
``joint_axis``, ``joint_pin_a``, ``joint_pin_b``, cell data ``body_a``,
``body_b``). This module turns such a frame into a list of drawable
:class:`Item` records (plain numpy and pyvista meshes) and fits a camera to
them; :mod:`femb.io.render` draws the items. Nothing here opens a window, so
the content of a picture can be checked without rendering it
(:func:`picture_scene`).

Drawing rules:

* a body is drawn in its own colour (legend: its name); a body whose drawing
  is the box of its mass and inertia (no shape, no named points) and that
  holds two or more joint points is drawn as a bar joining its joint points
  (through its centre of mass when that lies off their line); a body smaller
  than :data:`MIN_BODY` joint sizes is enlarged about its centre;
* joints are dark glyphs sized from the whole motion (``size`` below):
  revolute a short cylinder along its axis, spherical a ball, prismatic and
  cylindrical a rail along the axis over the whole travel (with a sleeve),
  universal a cross of its two pins, fixed a cube, distance a thin rod;
  spring–dampers are coils, torsion springs and bushings rings;
* the ground: a base block at each joint to the ground (on the side away from
  the body it holds), dark cubes at named ground points, and, when gravity
  acts, a faint floor normal to it under the whole motion;
* a beam (an element type of kind ``beam``: an element class with
  ``glyph = "beam"``, whose geometry gives its centre line as line cells) is
  drawn as a tube along its line cells (radius from point data ``radius``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .vtk import OutputError

#: body colours (tab10 without its grey), cycled
BODY_COLOURS = (
    (31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40), (148, 103, 189),
    (140, 86, 75), (227, 119, 194), (188, 189, 34), (23, 190, 207),
)
JOINT_COLOUR = (45, 45, 55)
GROUND_COLOUR = (105, 95, 85)
FLOOR_COLOUR = (215, 215, 210)
SPRING_COLOUR = (90, 90, 90)
#: joint glyph size as a fraction of the largest extent of the motion
JOINT_SIZE = 0.035
#: smallest drawn body, in joint sizes
MIN_BODY = 1.8

KINDS = {1: "body", 2: "body_frame", 3: "point_mass", 10: "revolute", 11: "spherical", 12: "prismatic",
         13: "cylindrical", 14: "universal", 15: "fixed", 16: "distance", 17: "motor", 18: "actuator", 20: "spring", 21: "bushing",
         22: "torsion", 30: "load", 40: "ground", 50: "beam", 60: "contact"}
JOINT_KINDS = ("revolute", "spherical", "prismatic", "cylindrical", "universal", "fixed", "distance", "motor",
               "actuator")
DRIVE_COLOUR = (200, 30, 30)
LOAD_COLOUR = (200, 30, 30)
#: closed contacts: the contact point and the contact force on the body
CONTACT_COLOUR = (230, 150, 0)

VIEWS = ("3d", "iso", "front", "side", "top", "plane", "xy", "xz", "yz")
#: (azimuth, elevation) in degrees of the gravity-aware views (see :func:`view_direction`)
VIEW_ANGLES = {"3d": (-45.0, 26.33), "iso": (-45.0, 35.26), "front": (-90.0, 0.0), "side": (0.0, 0.0),
               "top": (-90.0, 90.0)}


# ---------------------------------------------------------------------------
# reading a frame
# ---------------------------------------------------------------------------
def _field(mesh):
    fd = mesh.field_data
    return {k: np.asarray(fd[k]) for k in fd.keys()}


def is_mechanism(mesh):
    """Whether a frame carries the scene description of :func:`femb.io.frames.scene_field_data`."""
    return any(k.startswith("glyph.") for k in mesh.field_data.keys())


@dataclass
class Joint:
    kind: str
    type_name: str
    index: int                 # among the joints of its type
    pa: np.ndarray
    pb: np.ndarray
    axis: np.ndarray
    pin_a: np.ndarray
    pin_b: np.ndarray
    body_a: int
    body_b: int


@dataclass
class Frame:
    """The parts of one frame of a mechanism."""

    time: float
    bodies: dict               # body number -> dict(points, cells (pyvista mesh), look)
    names: dict                # body number -> name
    centres: dict              # body number -> (position (3,), rotation (3, 3))
    joints: list
    springs: list              # (kind, a (3,), b (3,))
    ground_points: np.ndarray
    gravity: np.ndarray | None
    points: dict               # (body, point) -> body-axes coordinates
    loads: list = field(default_factory=list)      # ("force" or "torque", point (3,), vector (3,))
    beams: list = field(default_factory=list)      # (type name, pyvista mesh of its line cells)
    planar: bool = False       # bodies without frames (planar types): the mechanism of a plane
    contacts: list = field(default_factory=list)   # (point (3,), force on the body (3,), normal (3,)): closed ones


def read_frame(mesh, time=0.0):
    """Split a frame mesh (pyvista) into a :class:`Frame`."""
    fd = _field(mesh)
    types = {int(v[0]): k[len("element_type."):] for k, v in fd.items() if k.startswith("element_type.")}
    glyphs = {k[len("glyph."):]: KINDS.get(int(v[0])) for k, v in fd.items() if k.startswith("glyph.")}
    names = {int(v[0]): k[len("body."):] for k, v in fd.items() if k.startswith("body.")}
    known = sorted(names.values(), key=len, reverse=True)
    points = {}
    for k, v in fd.items():
        if k.startswith("point."):
            rest = k[len("point."):]
            for b in known:
                if rest.startswith(b + "."):
                    points[(b, rest[len(b) + 1:])] = np.asarray(v, dtype=float).reshape(3)
                    break
    g = fd.get("gravity")
    g = None if g is None else np.asarray(g, dtype=float).reshape(-1)[:3]
    if mesh.n_cells == 0:
        return Frame(time, {}, names, {}, [], [], np.zeros((0, 3)), g, points)
    c = _Cells(mesh)
    by_kind = {}
    for tid, tname in types.items():
        kind = glyphs.get(tname)
        cells = np.nonzero(c.et == tid)[0]
        if cells.size:
            by_kind.setdefault(kind, []).append((tname, cells))
    bodies, centres = _frame_bodies(c, by_kind)
    joints, springs = _frame_connectors(c, by_kind)
    ground = []
    for tname, cells in by_kind.get("ground", []):
        ground.extend(c.P[c.first_point(cells)])
    ground = np.array(ground, dtype=float).reshape(-1, 3)
    beams = []
    for tname, cells in by_kind.get("beam", []):
        lines = cells[c.ctype[cells] == 3]
        if lines.size:
            beams.append((tname, mesh.extract_cells(lines)))
    planar = bool(bodies) and "body_frame" not in by_kind
    return Frame(time, bodies, names, centres, joints, springs, ground, g, points, _frame_loads(c, by_kind), beams,
                 planar, _frame_contacts(c, by_kind))


class _Cells:
    """The cells of a frame mesh as arrays: types, connectivity, offsets, points, cell and point data."""

    def __init__(self, mesh):
        self.mesh = mesh
        self.et = np.asarray(mesh.cell_data["element_type"]).astype(int)
        self.ctype = np.asarray(mesh.celltypes)
        self.conn = np.asarray(mesh.cell_connectivity)
        self.off = np.asarray(mesh.cell_offsets if hasattr(type(mesh), "cell_offsets") else mesh.offset)
        self.P = np.asarray(mesh.points, dtype=float)
        self.cd, self.pd = mesh.cell_data, mesh.point_data

    def first_point(self, cells):
        return self.conn[self.off[cells]]


def _frame_bodies(c, by_kind):
    """{body id: its picture} and {body id: (centre (3,), axes (3, 3))} of a frame."""
    bodies, centres = {}, {}
    cd, P = c.cd, c.P
    for tname, cells in by_kind.get("body", []):
        bid = np.asarray(cd["body"])[cells].astype(int) if "body" in cd else np.zeros(cells.size, int)
        look = np.asarray(cd["body_look"])[cells].astype(int) if "body_look" in cd else np.zeros(cells.size, int)
        for b in np.unique(bid):
            sel = cells[bid == b]
            bodies[int(b)] = {"mesh": c.mesh.extract_cells(sel), "look": int(look[bid == b][0]), "type": tname}
    for tname, cells in by_kind.get("point_mass", []):
        bid = np.asarray(cd["body"])[cells].astype(int)
        for cell, b in zip(cells, bid):
            bodies[int(b)] = {"mesh": None, "look": 0, "type": tname, "point": P[c.first_point(cell)]}
            centres[int(b)] = (P[c.first_point(cell)], np.eye(3))
    for tname, cells in by_kind.get("body_frame", []):
        bid = np.asarray(cd["body"])[cells].astype(int)
        ids = c.first_point(cells)
        E = np.stack([np.asarray(c.pd[f"e{k}"], dtype=float)[ids] for k in (1, 2, 3)], axis=2)
        E = E / np.maximum(np.linalg.norm(E, axis=1, keepdims=True), 1e-300)
        for j, b in enumerate(bid):
            centres[int(b)] = (P[ids[j]], E[j])
    return bodies, centres


def _frame_connectors(c, by_kind):
    """The joints and the springs (spring, bushing, torsion) of a frame."""
    joints, springs = [], []
    conn, off, P, cd, pd = c.conn, c.off, c.P, c.cd, c.pd
    zero3 = np.zeros(3)
    for kind in JOINT_KINDS + ("spring", "bushing", "torsion"):
        for tname, cells in by_kind.get(kind, []):
            verts = cells[c.ctype[cells] == 1]
            lines = cells[c.ctype[cells] == 3]
            if kind == "spring":
                # one line per spring, or a chain of lines (a planar spring's zigzag): its two ends
                prev = None
                for cell in lines:
                    a, b = conn[off[cell]:off[cell] + 2]
                    if prev is not None and a == prev:
                        springs[-1] = ("spring", springs[-1][1], P[b])
                    else:
                        springs.append(("spring", P[a], P[b]))
                    prev = b
                continue
            ids = c.first_point(verts)
            ends = [P[conn[off[cell] + 1]] for cell in lines]
            for j, (cell, i) in enumerate(zip(verts, ids)):
                def vec(name):
                    return np.asarray(pd[name], dtype=float)[i] if name in pd else zero3.copy()
                ba = int(np.asarray(cd["body_a"])[cell]) if "body_a" in cd else -1
                bb = int(np.asarray(cd["body_b"])[cell]) if "body_b" in cd else -1
                pb = vec("joint_pb") if "joint_pb" in pd else (ends[j] if j < len(ends) else P[i])
                if kind in ("bushing", "torsion"):
                    springs.append((kind, P[i], vec("joint_axis")))
                    continue
                joints.append(Joint(kind, tname, j, P[i].copy(), pb.copy(), vec("joint_axis"),
                                    vec("joint_pin_a"), vec("joint_pin_b"), ba, bb))
    return joints, springs


def _frame_loads(c, by_kind):
    """[("force" or "torque", point (3,), vector (3,))]: the applied loads of a frame."""
    loads, P, pd = [], c.P, c.pd
    for tname, cells in by_kind.get("load", []):
        ids = c.first_point(cells)
        for what in ("force", "torque"):
            src = "load" if what == "force" and "force" not in pd else what    # planar: "load" (N)
            if src in pd:
                V = np.asarray(pd[src], dtype=float)[ids]
                if V.ndim == 1:                     # a planar torque: T about z (N m)
                    V = np.column_stack((np.zeros((V.size, 2)), V))
                keep = np.linalg.norm(V, axis=1) > 0.0
                loads += [(what, P[i], v) for i, v in zip(ids[keep], V[keep])]
    return loads


def _frame_contacts(c, by_kind):
    """[(point (3,), force (3,), normal (3,))]: the closed contacts of a frame.

    Closed: state stick or slip (contact results, penalty contacts), or, where the state is not
    known (−1), a gap ≤ 0.
    """
    out, P, pd = [], c.P, c.pd
    if "contact_state" not in pd:
        return out
    for tname, cells in by_kind.get("contact", []):
        ids = c.first_point(cells)
        st = np.asarray(pd["contact_state"], dtype=float)[ids]
        gap = np.asarray(pd["gap"], dtype=float)[ids]
        F = np.asarray(pd["contact_force"], dtype=float)[ids]
        n = np.asarray(pd["contact_normal"], dtype=float)[ids]
        closed = (st > 0.0) | ((st < 0.0) & (gap <= 0.0))
        out += [(P[i], F[j], n[j]) for j, i in enumerate(ids) if closed[j]]
    return out


# ---------------------------------------------------------------------------
# the whole motion
# ---------------------------------------------------------------------------
def up_vector(gravity):
    """The picture's up direction: against gravity, else +z."""
    if gravity is not None:
        n = float(np.linalg.norm(gravity))
        if n > 0.0:
            return -np.asarray(gravity, dtype=float) / n
    return np.array([0.0, 0.0, 1.0])


def horizontal_basis(up):
    """Two unit vectors (h1, h2) completing ``up`` to a right-handed frame (h1 from x, else y)."""
    for a in (np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])):
        h1 = a - (a @ up) * up
        if np.linalg.norm(h1) > 1e-6:
            h1 /= np.linalg.norm(h1)
            return h1, np.cross(up, h1)
    raise OutputError("cannot build a horizontal basis")     # pragma: no cover


def parse_view(view):
    """A view name or ``"azimuth,elevation"`` (degrees) -> (name, (az, el) or None).

    Raises
    ------
    OutputError
        Unknown name or bad angles.
    """
    if view is None:
        return None, None
    if not isinstance(view, str):
        raise OutputError(f"view={view!r}: expected a name ({', '.join(VIEWS)}) or 'azimuth,elevation'")
    v = view.strip().lower()
    if v in VIEWS:
        return v, VIEW_ANGLES.get(v)
    parts = v.split(",")
    if len(parts) == 2:
        try:
            az, el = (float(p) for p in parts)
        except ValueError:
            az = el = math.nan
        if math.isfinite(az) and math.isfinite(el) and -90.0 <= el <= 90.0:
            return "custom", (az, el)
        raise OutputError(f"view={view!r}: azimuth,elevation must be numbers in degrees, "
                          "elevation in [-90, 90] (e.g. --view 30,20)")
    raise OutputError(f"view={view!r}: expected one of {', '.join(VIEWS)} or 'azimuth,elevation' in degrees")


def view_direction(angles, up):
    """Direction from the scene towards the camera, and the picture's up vector.

    Azimuth is measured in the horizontal plane (normal to ``up``) from h1 (the
    x axis made horizontal) towards h2 = up × h1; elevation above that plane.
    ``(-45, 26)`` with z up is the direction (1, −1, 0.7) of the default view.
    """
    az, el = (math.radians(a) for a in angles)
    h1, h2 = horizontal_basis(up)
    d = math.cos(el) * (math.cos(az) * h1 + math.sin(az) * h2) + math.sin(el) * up
    if abs(math.cos(el)) < 1e-6:            # looking along up: the picture's up is h2 rotated by az
        pic_up = -(math.cos(az) * h1 + math.sin(az) * h2) * np.sign(math.sin(el))
    else:
        pic_up = up - (up @ d) * d
    return d / np.linalg.norm(d), pic_up / np.linalg.norm(pic_up)


def fit_points(points, direction, up, aspect, view_angle=30.0, *, right=0.0, top=0.0, margin=1.08):
    """A perspective camera that shows every point, looking along −direction.

    Returns
    -------
    focal, position, up : ndarray, shape (3,)
    """
    pts = np.asarray(points, dtype=float).reshape(-1, 3)
    d = np.asarray(direction, dtype=float)
    up = np.asarray(up, dtype=float)
    rgt = np.cross(up, d)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    size = float(np.max(hi - lo)) or 1.0
    # centre the picture on the middle of the points' spread across and up the view
    u, v, w = pts @ rgt, pts @ up, pts @ d
    centre = (0.5 * (u.min() + u.max())) * rgt + (0.5 * (v.min() + v.max())) * up + (0.5 * (w.min() + w.max())) * d
    half = math.tan(math.radians(view_angle) / 2.0)
    tx = half * aspect * (1.0 - right) / margin
    ty = half * (1.0 - top) / margin
    c = pts - centre
    need = c @ d + np.maximum(np.abs(c @ rgt) / tx, np.abs(c @ up) / ty)
    dist = max(float(need.max()), 1e-6 * size)
    return centre, centre + dist * d, up


@dataclass
class Motion:
    """What is known of the whole motion: bounds, glyph size, rails, paths, floor."""

    lo: np.ndarray
    hi: np.ndarray
    size: float
    gravity: np.ndarray | None
    rails: dict                 # (type, index) -> (smin, smax) travel of p_b along the axis from p_a
    key: np.ndarray             # points of the whole motion that must be in view
    traces: dict                # label -> (times (nt,), points (nt, 3), body)
    names: dict
    ground_side: dict = field(default_factory=dict)   # (type, index) -> +1 body above its ground joint, -1 below
    planar: bool = False        # everything lies in the plane z = 0 (a planar mechanism)

    @property
    def joint_size(self):
        return JOINT_SIZE * self.size

    @property
    def up(self):
        up = up_vector(self.gravity)
        if self.planar and abs(up[2]) > 0.9:        # a planar mechanism without in-plane gravity: y up
            return np.array([0.0, 1.0, 0.0])
        return up


def trace_position(frame, body, point):
    """Where a named point (or the body's node when ``point`` is None) of ``body`` is in a frame."""
    num = {v: k for k, v in frame.names.items()}.get(body)
    if num is None or num not in frame.centres:
        return None
    r, R = frame.centres[num]
    if point is None:
        return r.copy()
    return r + R @ frame.points[(body, point)]


def parse_traces(traces, frame):
    """``["body", "body:point", ...]`` -> list of (label, body, point or None), checked against a frame."""
    out = []
    for spec in traces or ():
        if not isinstance(spec, str) or not spec.strip():
            raise OutputError(f"trace={spec!r}: expected 'body' or 'body:point'")
        body, _, point = spec.strip().partition(":")
        point = point or None
        bodies = sorted(v for k, v in frame.names.items() if k in frame.centres)
        if body not in bodies:
            raise OutputError(f"trace={spec!r}: no body {body!r} with a frame in this series "
                              f"(bodies: {', '.join(bodies) or 'none'})")
        if point is not None and point not in ("com", "node") and (body, point) not in frame.points:
            pts = sorted(p for b, p in frame.points if b == body)
            raise OutputError(f"trace={spec!r}: body {body!r} has no point {point!r} "
                              f"(points: {', '.join(pts + ['com']) })")
        if point in ("com", "node"):
            point = None
        out.append((spec.strip(), body, point))
    return out


def scan_motion(frames, traces=()):
    """A :class:`Motion` from the frames (each a :class:`Frame`) of the whole series."""
    keys, rails, paths, side = [], {}, {}, {}
    specs = parse_traces(traces, frames[0]) if traces else []
    up = up_vector(frames[0].gravity)
    for fr in frames:
        for b in fr.bodies.values():
            if b.get("mesh") is not None and b["mesh"].n_points:
                keys.append(np.asarray(b["mesh"].points))
            elif "point" in b:
                keys.append(b["point"][None])
        for j in fr.joints:
            keys.append(np.vstack((j.pa, j.pb)))
            if 0 in (j.body_a, j.body_b):
                held = j.body_b if j.body_a == 0 else j.body_a
                c = fr.centres.get(held, (None, None))[0]
                if c is None:                   # a planar body (no frame): the middle of its drawing
                    m = fr.bodies.get(held, {}).get("mesh")
                    c = np.asarray(m.points, dtype=float).mean(axis=0) if m is not None and m.n_points else j.pb
                side[(j.type_name, j.index)] = side.get((j.type_name, j.index), 0.0) + float((c - j.pa) @ up)
            if j.kind in ("prismatic", "cylindrical"):
                s = float((j.pb - j.pa) @ j.axis)
                lo, hi = rails.get((j.type_name, j.index), (0.0, 0.0))
                rails[(j.type_name, j.index)] = (min(lo, s), max(hi, s))
        for _, a, b in fr.springs:
            keys.append(np.vstack((a,)))
        for _, m in fr.beams:
            keys.append(np.asarray(m.points, dtype=float))
        if len(fr.ground_points):
            keys.append(fr.ground_points)
        for label, body, point in specs:
            p = trace_position(fr, body, point)
            if p is not None:
                paths.setdefault(label, ([], [], body))
                paths[label][0].append(fr.time)
                paths[label][1].append(p)
                keys.append(p[None])
    key = np.vstack(keys) if keys else np.zeros((1, 3))
    lo, hi = key.min(axis=0), key.max(axis=0)
    size = float(np.max(hi - lo)) or 1.0
    traces_out = {k: (np.array(t), np.array(p), b) for k, (t, p, b) in paths.items()}
    # thin the key points: bounding extremes in many directions are enough to frame
    if len(key) > 4000:
        key = np.unique(np.round(key / (1e-3 * size)), axis=0) * (1e-3 * size)
    planar = bool(hi[2] - lo[2] <= 1e-9 * size) and frames[0].planar and (
        frames[0].gravity is None or abs(float(frames[0].gravity[2])) == 0.0)
    return Motion(lo, hi, size, frames[0].gravity, rails, key, traces_out, dict(frames[0].names),
                  {k: (-1.0 if v < 0.0 else 1.0) for k, v in side.items()}, planar)


# ---------------------------------------------------------------------------
# drawable items
# ---------------------------------------------------------------------------
@dataclass
class Item:
    """One drawn thing: what it is, its label, its mesh and how it looks."""

    kind: str                   # "body", "link", "joint:<kind>", "ground", "floor", "spring", "trace", ...
    label: str
    mesh: object                # pyvista DataSet
    colour: tuple
    opacity: float = 1.0
    edges: object = None        # feature edges drawn in black (pyvista PolyData)
    line_width: float = 0.0

    @property
    def points(self):
        return np.asarray(self.mesh.points, dtype=float)


def body_colour(num):
    return BODY_COLOURS[(int(num) - 1) % len(BODY_COLOURS)]


def _shade(colour, frac):
    """Blend a colour towards white: frac 1 keeps it, 0 gives white."""
    return tuple(int(round(255 - frac * (255 - c))) for c in colour)


def _merge(pv, meshes):
    meshes = [m for m in meshes if m is not None and m.n_points]
    if not meshes:
        return None
    out = meshes[0].copy()
    for m in meshes[1:]:
        out = out.merge(m, merge_points=False) if hasattr(out, "merge") else out + m
    return out


def _tube(pv, a, b, radius, n=16):
    a, b = np.asarray(a, float), np.asarray(b, float)
    L = float(np.linalg.norm(b - a))
    if L <= 1e-12:
        return pv.Sphere(radius=radius, center=a)
    return pv.Cylinder(center=0.5 * (a + b), direction=b - a, radius=radius, height=L, resolution=n,
                       capping=True)


def _unit(v, fallback=(0.0, 0.0, 1.0)):
    v = np.asarray(v, dtype=float)
    n = float(np.linalg.norm(v))
    return v / n if n > 1e-12 else np.asarray(fallback, dtype=float)


def _attachments(frame):
    """Body number -> list of points where joints and springs hold it."""
    out = {}
    for j in frame.joints:
        if j.body_a > 0:
            out.setdefault(j.body_a, []).append(j.pa)
        if j.body_b > 0:
            out.setdefault(j.body_b, []).append(j.pb)
    return out


def _distinct(points, tol):
    out = []
    for p in points:
        if all(np.linalg.norm(p - q) > tol for q in out):
            out.append(p)
    return out


def _surface(mesh):
    """The cells of an unstructured grid as PolyData."""
    try:
        return mesh.extract_surface(algorithm="dataset_surface")
    except TypeError:                          # older pyvista
        return mesh.extract_surface()


def body_items(pv, frame, motion, shade=1.0):
    s = motion.joint_size
    att = _attachments(frame)
    items = []
    for num in sorted(frame.bodies):
        b = frame.bodies[num]
        name = frame.names.get(num, f"body {num}")
        colour = _shade(body_colour(num), shade)
        if b.get("mesh") is None:                      # a point mass: a ball
            ball = pv.Sphere(radius=0.6 * MIN_BODY * s, center=b["point"])
            items.append(Item("body", name, ball, colour))
            continue
        surf = _surface(b["mesh"])
        if motion.planar:               # flat outlines in one plane: each body on its own layer, no z-fighting
            surf = surf.copy()
            surf.points = np.asarray(surf.points, dtype=float) + np.array([0.0, 0.0, 0.04 * s * num])
        pts = np.asarray(surf.points, dtype=float)
        anchors = _distinct(att.get(num, []), 0.5 * s)
        if b["look"] == 2 and len(anchors) >= 2:
            # a body with no drawing of its own: a bar through its joint points
            r = 0.35 * s
            c = frame.centres.get(num, (pts.mean(axis=0), None))[0]
            parts = []
            if len(anchors) == 2:
                a, e = anchors
                t = np.clip((c - a) @ (e - a) / max((e - a) @ (e - a), 1e-300), 0.0, 1.0)
                if np.linalg.norm(a + t * (e - a) - c) < 0.5 * s:
                    parts.append(_tube(pv, a, e, r))
                    anchors = []
            for a in anchors:
                parts.append(_tube(pv, c, a, r))
            if anchors:
                parts.append(pv.Sphere(radius=r, center=c))
            items.append(Item("body", name, _merge(pv, parts), colour))
            continue
        ext = float(np.max(pts.max(axis=0) - pts.min(axis=0))) if len(pts) else 0.0
        if ext < MIN_BODY * s and len(pts):
            centre = 0.5 * (pts.max(axis=0) + pts.min(axis=0))
            k = MIN_BODY * s / max(ext, 1e-12 * motion.size)
            if ext <= 1e-12 * motion.size:
                surf = pv.Cube(center=centre, x_length=MIN_BODY * s, y_length=MIN_BODY * s, z_length=MIN_BODY * s)
            else:
                surf = surf.copy()
                surf.points = centre + k * (pts - centre)
        if surf.n_cells and surf.GetMaxCellSize() <= 2:        # lines only (collinear points): a bar
            lines = surf.tube(radius=0.35 * s, n_sides=16, capping=True) if surf.n_points > 1 else surf
            items.append(Item("body", name, lines, colour))
            continue
        stems = []
        if num in frame.centres and len(pts):
            c = frame.centres[num][0]
            blo, bhi = pts.min(axis=0) - 0.5 * s, pts.max(axis=0) + 0.5 * s
            for a in anchors:
                if np.any(a < blo) or np.any(a > bhi):         # held outside its drawing: a stem
                    stems.append(_tube(pv, c, a, 0.3 * s))
        if stems:
            items.append(Item("body", name, _merge(pv, stems), colour))
        edges = surf.extract_feature_edges(boundary_edges=True, feature_edges=True, manifold_edges=False,
                                           non_manifold_edges=False, feature_angle=35.0)
        items.append(Item("body", name, surf, colour, edges=edges if edges.n_points else None))
    return items


def _ground_base(pv, p, down, s):
    """A base block under (along ``down`` from) a point fixed to the ground, and its post."""
    h1, h2 = horizontal_basis(-down)
    c = p + 1.8 * s * down
    plate = pv.Cube(center=(0.0, 0.0, 0.0), x_length=2.6 * s, y_length=2.6 * s, z_length=0.5 * s)
    M = np.column_stack((h1, h2, -down))
    plate.points = c + np.asarray(plate.points) @ M.T
    return [plate, _tube(pv, p, c, 0.25 * s, 12)]


def joint_items(pv, frame, motion, shade=1.0):
    s = motion.joint_size
    up = motion.up
    colour = _shade(JOINT_COLOUR, shade)
    gcol = _shade(GROUND_COLOUR, shade)
    items, ground = [], []
    for j in frame.joints:
        ax = _unit(j.axis)
        parts = []
        if j.kind == "revolute":
            parts.append(_tube(pv, j.pa - 1.2 * s * ax, j.pa + 1.2 * s * ax, 0.55 * s, 24))
        elif j.kind == "spherical":
            parts.append(pv.Sphere(radius=0.75 * s, center=j.pa, theta_resolution=24, phi_resolution=16))
        elif j.kind in ("prismatic", "cylindrical"):
            lo, hi = motion.rails.get((j.type_name, j.index), (0.0, 0.0))
            rail = _tube(pv, j.pa + (lo - 2.0 * s) * ax, j.pa + (hi + 2.0 * s) * ax, 0.22 * s, 12)
            (ground if 0 in (j.body_a,) else parts).append(rail)
            if j.kind == "prismatic":
                e1 = _unit(j.pin_a, horizontal_basis(ax)[0])
                sleeve = pv.Cube(center=(0, 0, 0), x_length=1.1 * s, y_length=1.1 * s, z_length=1.6 * s)
                M = np.column_stack((e1, np.cross(ax, e1), ax))
                sleeve.points = j.pb + np.asarray(sleeve.points) @ M.T
                parts.append(sleeve)
            else:
                parts.append(pv.Cylinder(center=j.pb, direction=ax, radius=0.6 * s, height=1.4 * s, resolution=24))
        elif j.kind == "universal":
            a, b = _unit(j.pin_a, (1, 0, 0)), _unit(j.pin_b, (0, 1, 0))
            parts += [_tube(pv, j.pa - 1.1 * s * a, j.pa + 1.1 * s * a, 0.28 * s),
                      _tube(pv, j.pb - 1.1 * s * b, j.pb + 1.1 * s * b, 0.28 * s),
                      pv.Sphere(radius=0.42 * s, center=j.pa)]
        elif j.kind == "fixed":
            parts.append(pv.Cube(center=j.pa, x_length=1.1 * s, y_length=1.1 * s, z_length=1.1 * s))
        elif j.kind == "motor":                      # a driven angle: a red ring about the axis
            parts.append(pv.Disc(center=j.pa, inner=0.75 * s, outer=1.05 * s, normal=ax, c_res=32))
            items.append(Item("joint:motor", j.type_name, _merge(pv, parts), _shade(DRIVE_COLOUR, shade)))
            continue
        elif j.kind == "actuator":                   # a driven displacement: a red arrow along the axis
            side = _unit(j.pin_a, horizontal_basis(ax)[0])          # beside the guide, where it shows
            parts.append(pv.Arrow(start=j.pb - 1.5 * s * ax + 2.2 * s * side, direction=ax, scale=3.0 * s,
                                  tip_length=0.35, tip_radius=0.12, shaft_radius=0.04))
            items.append(Item("joint:actuator", j.type_name, _merge(pv, parts), _shade(DRIVE_COLOUR, shade)))
            continue
        elif j.kind == "distance":
            parts += [_tube(pv, j.pa, j.pb, 0.18 * s), pv.Sphere(radius=0.4 * s, center=j.pa),
                      pv.Sphere(radius=0.4 * s, center=j.pb)]
        items.append(Item(f"joint:{j.kind}", j.type_name, _merge(pv, parts), colour))
        if 0 in (j.body_a, j.body_b) and j.kind not in ("motor", "actuator"):
            # the base on the side away from the body it holds, over the whole motion
            down = up.copy() if motion.ground_side.get((j.type_name, j.index), 1.0) < 0.0 else -up
            if j.kind in ("prismatic", "cylindrical"):
                # a rail stands on posts at both ends; one along gravity stands on its lower end
                lo, hi = motion.rails.get((j.type_name, j.index), (0.0, 0.0))
                ends = (j.pa + (lo - 2.0 * s) * ax, j.pa + (hi + 2.0 * s) * ax)
                if abs(ax @ up) > 0.7:
                    low = min(ends, key=lambda e: float(e @ up))
                    ground += _ground_base(pv, low - 0.2 * s * up, -up, s)
                else:
                    for e in ends:
                        ground += _ground_base(pv, e, -up, s)
            else:
                ground += _ground_base(pv, j.pa - (1.2 * s * ax if abs(ax @ up) > 0.7 else 0.0), down, s)
    for p in frame.ground_points:
        ground.append(pv.Cube(center=p, x_length=0.9 * s, y_length=0.9 * s, z_length=0.9 * s))
    if ground:
        items.append(Item("ground", "ground", _merge(pv, ground), gcol))
    return items


def _coil(pv, a, b, radius, turns=8, n=24):
    a, b = np.asarray(a, float), np.asarray(b, float)
    d = b - a
    L = float(np.linalg.norm(d))
    if L <= 1e-12:
        return None
    ax = d / L
    e1, e2 = horizontal_basis(ax)
    t = np.linspace(0.0, 1.0, turns * n + 1)
    ramp = np.clip(np.minimum(t, 1.0 - t) / 0.08, 0.0, 1.0)       # straight ends
    ang = 2.0 * math.pi * turns * t
    pts = a + np.outer(t * L, ax) + radius * ramp[:, None] * (np.outer(np.cos(ang), e1) + np.outer(np.sin(ang), e2))
    return pv.lines_from_points(pts)


def spring_items(pv, frame, motion, shade=1.0):
    """Coils of spring–dampers; rings of torsion springs (about their axis) and bushings (thicker)."""
    s = motion.joint_size
    parts = {}
    for kind, a, b in frame.springs:
        if kind == "spring":
            m = _coil(pv, a, b, 0.5 * s)
        elif kind == "torsion":
            m = pv.Disc(center=a, inner=0.75 * s, outer=1.05 * s, normal=_unit(b), c_res=24)
        else:
            m = _tube(pv, a - 0.35 * s * _unit(b), a + 0.35 * s * _unit(b), 0.9 * s, 24)
        parts.setdefault(kind, []).append(m)
    out = []
    for kind, ms in parts.items():
        m = _merge(pv, ms)
        if m is not None:
            out.append(Item("spring", kind, m, _shade(SPRING_COLOUR, shade), line_width=3.0 if kind == "spring" else 0.0))
    return out


#: colour of beams (centre lines drawn as tubes)
BEAM_COLOUR = (70, 130, 140)


def beam_items(pv, frame, motion, shade=1.0):
    """Beams: their centre lines (line cells of an element type of kind ``beam``) as tubes.

    The tube's radius is the point data ``radius`` (m) when the frames carry
    it, else 0.3 joint sizes.
    """
    s = motion.joint_size
    items = []
    for tname, m in frame.beams:
        line = _surface(m)
        r = 0.3 * s
        if "radius" in m.point_data:
            rr = np.asarray(m.point_data["radius"], dtype=float)
            if rr.size and np.all(np.isfinite(rr)) and rr.max() > 0:
                r = float(rr.max())
        tube = line.tube(radius=r, n_sides=16, capping=True) if line.n_points > 1 else None
        if tube is not None:
            items.append(Item("beam", tname, tube, _shade(BEAM_COLOUR, shade)))
    return items


def load_items(pv, frame, motion, shade=1.0):
    """Arrows of applied forces (ending at their point) and torques (double head along the axis)."""
    s = motion.joint_size
    parts = []
    for what, p, v in frame.loads:
        d = _unit(v)
        if what == "force":
            parts.append(pv.Arrow(start=p - 3.0 * s * d, direction=d, scale=3.0 * s, tip_length=0.3,
                                  tip_radius=0.12, shaft_radius=0.04))
        else:
            parts += [pv.Arrow(start=p, direction=d, scale=3.0 * s, tip_length=0.3, tip_radius=0.12,
                               shaft_radius=0.04),
                      pv.Arrow(start=p + 1.8 * s * d, direction=d, scale=1.2 * s, tip_length=0.75,
                               tip_radius=0.3, shaft_radius=0.1)]
    m = _merge(pv, parts)
    return [] if m is None else [Item("load", "load", m, _shade(LOAD_COLOUR, shade))]


def contact_items(pv, frame, motion, shade=1.0):
    """Closed contacts: a flat marker at the contact point and the force on the body as an arrow
    ending there (length fixed, like the loads', along the force; along the normal when it is 0)."""
    s = motion.joint_size
    parts = []
    for p, F, n in frame.contacts:
        d = _unit(F, fallback=n)
        parts.append(pv.Disc(center=p, inner=0.0, outer=0.5 * s, normal=_unit(n), c_res=24))
        if float(np.linalg.norm(F)) > 0.0:
            parts.append(pv.Arrow(start=p - 3.0 * s * d, direction=d, scale=3.0 * s, tip_length=0.3,
                                  tip_radius=0.12, shaft_radius=0.04))
    m = _merge(pv, parts)
    return [] if m is None else [Item("contact", "contact", m, _shade(CONTACT_COLOUR, shade))]


def floor_item(pv, motion):
    """A faint floor normal to gravity under the whole motion (None without gravity or in a plane)."""
    if motion.gravity is None or not np.any(motion.gravity) or motion.planar:
        return None
    up = motion.up
    s = motion.joint_size
    h1, h2 = horizontal_basis(up)
    key = motion.key
    level = float((key @ up).min()) - 3.5 * s
    u, v = key @ h1, key @ h2
    pad = 0.12 * motion.size + 2.0 * s
    cu, cv = 0.5 * (u.min() + u.max()), 0.5 * (v.min() + v.max())
    su, sv = (u.max() - u.min()) + 2 * pad, (v.max() - v.min()) + 2 * pad
    centre = cu * h1 + cv * h2 + level * up
    plane = pv.Plane(center=centre, direction=up, i_size=su, j_size=sv, i_resolution=1, j_resolution=1)
    # orient the plane's edges along h1, h2
    corners = np.array([centre + a * 0.5 * su * h1 + b * 0.5 * sv * h2 for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))])
    plane = pv.PolyData(corners, faces=[4, 0, 1, 2, 3])
    # a faint grid
    raw = max(su, sv) / 8.0
    e = 10 ** math.floor(math.log10(raw))
    step = e * min((m for m in (1.0, 2.0, 5.0, 10.0) if m * e >= raw), default=10.0)
    lines = []
    for k in np.arange(math.ceil((cu - su / 2) / step), math.floor((cu + su / 2) / step) + 1):
        lines.append((k * step * h1 + (cv - sv / 2) * h2 + level * up, k * step * h1 + (cv + sv / 2) * h2 + level * up))
    for k in np.arange(math.ceil((cv - sv / 2) / step), math.floor((cv + sv / 2) / step) + 1):
        lines.append(((cu - su / 2) * h1 + k * step * h2 + level * up, (cu + su / 2) * h1 + k * step * h2 + level * up))
    grid = None
    if lines:
        pts = np.array([p for ab in lines for p in ab])
        cells = np.hstack([[2, 2 * i, 2 * i + 1] for i in range(len(lines))])
        grid = pv.PolyData(pts, lines=cells)
    return Item("floor", "floor", plane, FLOOR_COLOUR, opacity=0.55, edges=grid)


def trace_items(pv, frame, motion, upto=None):
    items = []
    s = motion.joint_size
    num = {v: k for k, v in motion.names.items()}
    for label, (t, pts, body) in motion.traces.items():
        if len(pts) < 2:
            continue
        colour = tuple(int(0.6 * c) for c in body_colour(num.get(body, 1)))
        line = pv.lines_from_points(pts)
        items.append(Item("trace", label, line, colour, line_width=2.5))
        if upto is not None:
            k = int(np.argmin(np.abs(t - upto)))
            items.append(Item("trace_point", label, pv.Sphere(radius=0.35 * s, center=pts[k]), colour))
    return items


def frame_items(pv, frame, motion, *, shade=1.0, floor=True, traces=True):
    """Every item of one frame: floor, ground, bodies, joints, springs, traces."""
    items = []
    if floor:
        f = floor_item(pv, motion)
        if f is not None:
            items.append(f)
    items += body_items(pv, frame, motion, shade)
    items += beam_items(pv, frame, motion, shade)
    items += joint_items(pv, frame, motion, shade)
    items += spring_items(pv, frame, motion, shade)
    items += load_items(pv, frame, motion, shade)
    items += contact_items(pv, frame, motion, shade)
    if traces:
        items += trace_items(pv, frame, motion, upto=frame.time)
    return [it for it in items if it.mesh is not None and it.mesh.n_points]


def framing_points(items, motion):
    """Points the camera must show: the motion's key points and every drawn item but the floor."""
    pts = [motion.key]
    for it in items:
        if it.kind != "floor":
            pts.append(it.points)
    return np.vstack(pts)


# ---------------------------------------------------------------------------
# a picture without drawing it
# ---------------------------------------------------------------------------
@dataclass
class Camera:
    focal: np.ndarray
    position: np.ndarray
    up: np.ndarray
    view_angle: float
    window_size: tuple
    window_center: tuple = (0.0, 0.0)

    def project(self, points):
        """Pixel coordinates (column, row from the top) of points, and their depth in front of the camera."""
        pts = np.asarray(points, dtype=float).reshape(-1, 3)
        w, h = self.window_size
        d = self.position - self.focal
        d = d / np.linalg.norm(d)
        up = self.up - (self.up @ d) * d
        up /= np.linalg.norm(up)
        rgt = np.cross(up, d)
        rel = pts - self.position
        depth = -(rel @ d)
        half = math.tan(math.radians(self.view_angle) / 2.0)
        y = (rel @ up) / (depth * half)              # -1 .. 1 over the height
        x = (rel @ rgt) / (depth * half * (w / h))
        x = x - self.window_center[0]           # VTK's window centre moves the view's centre there
        y = y - self.window_center[1]
        return np.column_stack((0.5 * (x + 1.0) * w, 0.5 * (1.0 - y) * h)), depth


@dataclass
class Picture:
    """The items of one picture of a mechanism and the camera that shows them."""

    time: float
    items: list
    camera: Camera
    motion: Motion

    def kinds(self):
        return sorted({it.kind for it in self.items})
