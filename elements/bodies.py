"""Bodies: rigid bodies, point masses and the ground (planar).

A rigid body owns a :class:`~femb.system.nodes.PlanarNode` at its centre of mass,
(x, y, θ) in the inertial frame, so its mass matrix is the constant
diag(m, m, J) (Géradin & Cardona 2001, Ch. 5). A point mass owns a planar node
whose θ is fixed. The ground owns a fully fixed node at the origin.

Mass kernels (compiled, ``docs/kernels.md``): ``mass(P, xe, Me)`` writes the
element mass matrices ``Me (nel, 3, 3)`` on (x, y, θ) from ``P (nel, npar)``;
``xe (nel, 3)`` is not read (the mass is constant). The ground has no kernels.
"""
from __future__ import annotations

import math

import numpy as np

from femb.base.geometry import GeometryBlock
from femb.base.jit import kernel
from femb.errors import ModelError
from femb.system.element import Element
from femb.system.nodes import PlanarNode

from ._planar import perp, rot


def _check_scalar(owner, what, value, *, positive=False, nonneg=False):
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ModelError(f"{owner}: {what} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise ModelError(f"{owner}: {what} must be finite, got {value!r}")
    if positive and not v > 0.0:
        raise ModelError(f"{owner}: {what} must be positive, got {value!r}")
    if nonneg and v < 0.0:
        raise ModelError(f"{owner}: {what} must not be negative, got {value!r}")
    return v


def _point(owner, what, value):
    try:
        v = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ModelError(f"{owner}: {what} must be two numbers, got {value!r}") from None
    if v.size != 2 or not np.all(np.isfinite(v)):
        raise ModelError(f"{owner}: {what} must be two finite numbers, got {value!r}")
    return v


class Body:
    """Anything joints can attach to: owns a planar node and named points.

    Attributes
    ----------
    node : PlanarNode
    points : dict of str to ndarray (2,)
        Named points in the body frame (relative to the node).
    shape : dict or None
        Optional drawing shape for output: ``{"type": "bar", "width": w}``,
        ``{"type": "box", "size": (a, b)}``, ``{"type": "disc", "radius": r}``,
        ``{"type": "polygon", "points": [...]}`` or ``{"type": "mesh", "file": path}``.
    """

    #: a body: joints attach to it, it owns a node (femb.system.model reads this trait)
    is_body = True

    def __init__(self, name, node, points=None, shape=None):
        self.node = node
        self.points = {}
        for k, v in (points or {}).items():
            self.points[str(k)] = _point(f"body '{name}'", f"point '{k}'", v)
        self.shape = shape

    def local(self, spec, role="point"):
        """Body-frame coordinates of ``spec`` (a point name or an (x, y) pair)."""
        if isinstance(spec, str):
            try:
                return self.points[spec]
            except KeyError:
                raise ModelError(
                    f"body '{self.name}' has no point named '{spec}' "
                    f"(known: {sorted(self.points) or 'none'})") from None
        return _point(f"body '{self.name}'", role, spec)

    def local_from_global(self, xy):
        """Body-frame coordinates of an inertial point in the initial configuration."""
        x, y, th = self.node.q0
        d = _point(f"body '{self.name}'", "global point", xy) - np.array([x, y])
        c, s = math.cos(th), math.sin(th)
        return np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]])

    def outline(self):
        """Drawing outline in the body frame, shape (k, 2), k ≥ 3 (a closed polygon).

        From ``shape`` when given (bar, box, disc, polygon), else the convex hull
        of the named points and the node, widened into a thin bar when they are
        collinear.
        """
        sh = self.shape or {}
        typ = sh.get("type")
        if typ == "box":
            a, b = (0.5 * float(v) for v in sh["size"])
            return np.array([(-a, -b), (a, -b), (a, b), (-a, b)])
        if typ == "disc":
            r = float(sh["radius"])
            ang = np.linspace(0.0, 2 * math.pi, 24, endpoint=False)
            return np.column_stack((r * np.cos(ang), r * np.sin(ang)))
        if typ == "polygon":
            return np.asarray(sh["points"], dtype=float).reshape(-1, 2)
        pts = np.array([(0.0, 0.0)] + [tuple(v) for v in self.points.values()])
        width = float(sh.get("width", 0.0)) if typ == "bar" else 0.0
        return _hull_or_bar(pts, width)

    def global_point(self, spec, q=None):
        """Inertial coordinates of a body point for coordinates q (x, y, θ) (default: initial)."""
        x, y, th = self.node.q0 if q is None else q
        s = self.local(spec)
        return np.array([x, y]) + rot(np.array([th]), s[None])[0]


def _hull_or_bar(pts, width=0.0):
    """Convex hull (counter-clockwise) of 2D points, or a thin bar around collinear ones."""
    pts = np.unique(np.round(pts, 15), axis=0)
    span = np.ptp(pts, axis=0).max() if len(pts) > 1 else 0.0
    if len(pts) >= 3:
        c = pts.mean(0)
        d = pts - c
        # collinear test: smallest singular value of the centred points
        sv = np.linalg.svd(d, compute_uv=False)
        if sv[-1] > 1e-9 * max(sv[0], 1e-300) and width == 0.0:
            return _graham(pts)
    if span == 0.0:
        r = 0.01 if width == 0.0 else 0.5 * width
        ang = np.linspace(0.0, 2 * math.pi, 12, endpoint=False)
        return pts[0] + np.column_stack((r * np.cos(ang), r * np.sin(ang)))
    # a bar along the principal direction through the extreme points
    c = pts.mean(0)
    u = np.linalg.svd(pts - c)[2][0]
    s = (pts - c) @ u
    p0, p1 = c + s.min() * u, c + s.max() * u
    w = 0.5 * (width if width > 0.0 else 0.06 * (s.max() - s.min()))
    n = np.array([-u[1], u[0]]) * w
    return np.array([p0 - n, p1 - n, p1 + n, p0 + n])


def _graham(pts):
    """Convex hull by Andrew's monotone chain (counter-clockwise, no repeated end)."""
    P = sorted(map(tuple, pts))

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower, upper = [], []
    for p in P:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    for p in reversed(P):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return np.array(lower[:-1] + upper[:-1])


def _body_geometry(name, p, qe, qde):
    """Outline polygons of all bodies of a batch: one vectorized transform."""
    own = p["outline_owner"]
    th = qe[own, 2]
    d = rot(th, p["outline_local"])
    pts = np.zeros((own.size, 3))
    pts[:, :2] = qe[own, 0:2] + d
    vel = np.zeros((own.size, 3))
    vel[:, :2] = qde[own, 0:2] + perp(d) * qde[own, 2:3]
    cells = [("polygon", conn) for conn in p["outline_cells"]]
    ids = [p["body_id"][cb] for cb in p["outline_cell_body"]]
    return [GeometryBlock(name, pts, cells, point_data={"velocity": vel},
                          cell_data={"body_id": ids})]


def _pack_outlines(elements):
    loc, owner, by_count = [], [], {}
    start = 0
    for k, e in enumerate(elements):
        o = e.outline()
        loc.append(o)
        owner.append(np.full(len(o), k))
        by_count.setdefault(len(o), []).append((k, np.arange(start, start + len(o))))
        start += len(o)
    cells = [np.array([c for _, c in v]) for v in by_count.values()]
    cell_body = [np.array([k for k, _ in v]) for v in by_count.values()]
    return {"outline_local": np.concatenate(loc), "outline_owner": np.concatenate(owner),
            "outline_cells": cells, "outline_cell_body": cell_body}


@kernel
def rigid_body_mass(P, xe, Me):
    """M_e = diag(m, m, J) on (x, y, θ) of the centre of mass; P = (m, J)."""
    for e in range(xe.shape[0]):
        Me[e, 0, 0] = P[e, 0]
        Me[e, 1, 1] = P[e, 0]
        Me[e, 2, 2] = P[e, 1]


@kernel
def point_mass_mass(P, xe, Me):
    """M_e = diag(m, m, 0) on (x, y, θ) (θ is fixed); P = (m,)."""
    for e in range(xe.shape[0]):
        Me[e, 0, 0] = P[e, 0]
        Me[e, 1, 1] = P[e, 0]


class Ground(Body):
    """The fixed inertial frame; joints to it use its named points.

    Parameters
    ----------
    name : str
    points : dict of str to (x, y), optional
    """

    def __init__(self, name="ground", points=None):
        self.name = name
        super().__init__(name, PlanarNode(name, (0.0, 0.0, 0.0), fixed=(True, True, True)), points)

    def add_point(self, name, xy):
        """Add a named ground point; returns its name."""
        self.points[str(name)] = _point(f"ground '{self.name}'", f"point '{name}'", xy)
        return name


class RigidBody(Body, Element):
    """A planar rigid body; its node is the centre of mass.

    Parameters
    ----------
    name : str
    mass : float > 0
    inertia : float > 0
        Moment of inertia about the centre of mass (kg m²).
    position : (x, y)
        Initial centre of mass.
    angle : float
        Initial orientation θ (rad).
    velocity : (vx, vy), omega : float
        Initial velocities (projected onto the constraints before the first step).
    points : dict, optional
        Named points in the body frame (relative to the centre of mass).
    shape : dict, optional
        Drawing shape for output (see :class:`Body`).

    Notes
    -----
    Kernel: :func:`rigid_body_mass`; ``P = (m, J)``.
    """
    glyph = "body"  # how pictures draw it (femb.io.frames)

    has_mass = True
    constant_mass = True
    kernels = {"mass": rigid_body_mass}

    def __init__(self, name, mass, inertia, position=(0.0, 0.0), angle=0.0,
                 velocity=(0.0, 0.0), omega=0.0, points=None, shape=None):
        Element.__init__(self, name)
        owner = f"RigidBody '{name}'"
        self.m = _check_scalar(owner, "mass", mass, positive=True)
        self.J = _check_scalar(owner, "inertia", inertia, positive=True)
        pos = _point(owner, "position", position)
        vel = _point(owner, "velocity", velocity)
        th = _check_scalar(owner, "angle", angle)
        om = _check_scalar(owner, "omega", omega)
        Body.__init__(self, name, PlanarNode(name, (pos[0], pos[1], th), (vel[0], vel[1], om)),
                      points, shape)

    def nodes(self):
        return [self.node]

    @classmethod
    def pack(cls, elements):
        """``P = (m, J)`` (nel, 2), plus masses, ids and outlines for :meth:`geometry`."""
        m = np.array([e.m for e in elements], dtype=float)
        J = np.array([e.J for e in elements], dtype=float)
        p = {"P": np.ascontiguousarray(np.column_stack((m, J))), "m": m, "J": J,
             "body_id": np.arange(len(elements))}
        p.update(_pack_outlines(elements))
        return p

    @classmethod
    def geometry(cls, p, t, qe, qde, lame, names):
        return _body_geometry(cls.__name__, p, qe, qde)


class PointMass(Body, Element):
    """A point mass: a planar node with (x, y) free and θ fixed.

    Parameters
    ----------
    name : str
    mass : float > 0
    position, velocity : (x, y)
    points : dict, optional
        Named points (offsets do not rotate: θ is fixed at 0).

    Notes
    -----
    Kernel: :func:`point_mass_mass`; ``P = (m,)``.
    """
    glyph = "point_mass"  # how pictures draw it (femb.io.frames)

    has_mass = True
    constant_mass = True
    kernels = {"mass": point_mass_mass}

    def __init__(self, name, mass, position=(0.0, 0.0), velocity=(0.0, 0.0), points=None, shape=None):
        Element.__init__(self, name)
        owner = f"PointMass '{name}'"
        self.m = _check_scalar(owner, "mass", mass, positive=True)
        pos = _point(owner, "position", position)
        vel = _point(owner, "velocity", velocity)
        Body.__init__(self, name, PlanarNode(name, (pos[0], pos[1], 0.0), (vel[0], vel[1], 0.0),
                                             fixed=(False, False, True)), points, shape)

    def nodes(self):
        return [self.node]

    @classmethod
    def pack(cls, elements):
        """``P = (m,)`` (nel, 1), plus the masses for :meth:`geometry`."""
        m = np.array([e.m for e in elements], dtype=float)
        return {"P": np.ascontiguousarray(m.reshape(-1, 1)), "m": m}

    @classmethod
    def geometry(cls, p, t, qe, qde, lame, names):
        n = qe.shape[0]
        pts = np.zeros((n, 3))
        pts[:, :2] = qe[:, 0:2]
        vel = np.zeros((n, 3))
        vel[:, :2] = qde[:, 0:2]
        return [GeometryBlock(cls.__name__, pts, [("vertex", np.arange(n)[:, None])],
                              point_data={"velocity": vel}, cell_data={"mass": [p["m"].copy()]})]
