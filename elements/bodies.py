"""Bodies: rigid bodies, point masses and the ground (planar).

A rigid body owns a :class:`~femb.nodes.PlanarNode` at its centre of mass,
(x, y, θ) in the inertial frame, so its mass matrix is the constant
diag(m, m, J) (Géradin & Cardona 2001, Ch. 5). A point mass owns a planar node
whose θ is fixed. The ground owns a fully fixed node at the origin.
"""
from __future__ import annotations

import math

import numpy as np

from femb.element import Element
from femb.errors import ModelError
from femb.nodes import PlanarNode

from ._planar import rot


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

    def global_point(self, spec, q=None):
        """Inertial coordinates of a body point for coordinates q (x, y, θ) (default: initial)."""
        x, y, th = self.node.q0 if q is None else q
        s = self.local(spec)
        return np.array([x, y]) + rot(np.array([th]), s[None])[0]


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
    """

    has_mass = True
    constant_mass = True

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
        return {"m": np.array([e.m for e in elements]), "J": np.array([e.J for e in elements])}

    @classmethod
    def mass(cls, p, qe):
        n = p["m"].shape[0]
        Me = np.zeros((n, 3, 3))
        Me[:, 0, 0] = p["m"]
        Me[:, 1, 1] = p["m"]
        Me[:, 2, 2] = p["J"]
        return Me


class PointMass(Body, Element):
    """A point mass: a planar node with (x, y) free and θ fixed.

    Parameters
    ----------
    name : str
    mass : float > 0
    position, velocity : (x, y)
    points : dict, optional
        Named points (offsets do not rotate: θ is fixed at 0).
    """

    has_mass = True
    constant_mass = True

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
        return {"m": np.array([e.m for e in elements])}

    @classmethod
    def mass(cls, p, qe):
        n = p["m"].shape[0]
        Me = np.zeros((n, 3, 3))
        Me[:, 0, 0] = p["m"]
        Me[:, 1, 1] = p["m"]
        return Me
