"""Initial velocities from a rigid motion: :func:`set_rigid_velocity`.

Every point of a rigid motion moves with v(r) = v₀ + ω × (r − p): v₀ the velocity of the point p,
ω the angular velocity in space axes. Bodies and nodes store their initial velocities in their
own conventions (a planar node (ẋ, ẏ, θ̇); a spatial frame node ṙ in space axes and Ω = Rᵀω in
*node* axes, :class:`femb.elements.spatial_bodies.FrameNode`); this module fills them in from the
one field, so that a spinning free beam, a rigid body and the beam nodes welded to it start as
one rigid body (Géradin & Cardona, *Flexible Multibody Dynamics*, Wiley 2001, §4.2: the velocity
field of a rigid body; the body-axes angular velocity Ω = Rᵀω).
"""
from __future__ import annotations

import numpy as np

from femb.errors import ModelError

__all__ = ["set_rigid_velocity", "rigid_velocity_of_node"]


def _vector(what, value, n):
    try:
        v = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ModelError(f"set_rigid_velocity: {what} must be {n} numbers, got {value!r}") from None
    if v.size != n or not np.all(np.isfinite(v)):
        raise ModelError(f"set_rigid_velocity: {what} must be {n} finite numbers, got {value!r}")
    return v


def _nodes_of(items, out):
    """The nodes of ``items`` (a mechanism, bodies, nodes, meshes, or sequences of them), in order."""
    if hasattr(items, "kind") and hasattr(items, "qd0"):
        out.append(items)                                   # a node
    elif hasattr(items, "node") and hasattr(items.node, "qd0"):
        out.append(items.node)                              # a body (rigid, point mass, beam node)
    elif hasattr(items, "elements") and callable(getattr(items, "compile", None)):
        for e in items.elements:                            # a Mechanism: every body in it
            if hasattr(e, "node") and hasattr(e.node, "qd0"):
                out.append(e.node)
    elif hasattr(items, "nodes") and isinstance(getattr(items, "nodes"), list):
        for b in items.nodes:                               # a beam mesh
            _nodes_of(b, out)
    elif isinstance(items, (list, tuple)):
        for it in items:
            _nodes_of(it, out)
    else:
        raise ModelError(f"set_rigid_velocity: {items!r} is not a body, a node, a mesh or a mechanism")
    return out


def rigid_velocity_of_node(node, velocity, omega, about):
    """The initial velocities (``node.qd0`` layout) of ``node`` in the rigid motion (v₀, ω, p).

    Parameters
    ----------
    node : femb.system.nodes.PlanarNode or FrameNode
    velocity : (2,) or (3,)
        v₀, the velocity of the point ``about`` (space axes).
    omega : float or (3,)
        ω in space axes (planar: the rate about z).
    about : (2,) or (3,)
        The point p.

    Returns
    -------
    ndarray (3,) for a planar node (ẋ, ẏ, θ̇); (6,) for a frame node (ṙ, Ω = R₀ᵀ ω).
    """
    if node.kind == "planar":
        v0, w, p = _vector("velocity", velocity, 2), float(_vector("omega", omega, 1)[0]), _vector("about", about, 2)
        d = node.q0[:2] - p
        return np.array([v0[0] - w * d[1], v0[1] + w * d[0], w])
    if node.kind == "frame":
        v0, w, p = _vector("velocity", velocity, 3), _vector("omega", omega, 3), _vector("about", about, 3)
        r = node.q0[:3]
        return np.concatenate((v0 + np.cross(w, r - p), node.rotation0.T @ w))
    raise ModelError(f"set_rigid_velocity: node '{node.name}' of kind '{node.kind}' has no rigid-motion rule")


def set_rigid_velocity(items, velocity=None, omega=None, about=None):
    """Set the initial velocities of bodies and nodes to the rigid motion v(r) = v₀ + ω × (r − p).

    Works for rigid bodies, point masses, beam nodes (planar and spatial) and meshes: every
    node gets its velocity in its own convention (module docstring). Coordinates a node holds
    fixed must have zero velocity in the field.

    Parameters
    ----------
    items : Mechanism, body, node, BeamMesh, SpatialBeamMesh, or a sequence of them
        A mechanism means every body added to it so far.
    velocity : (2,) or (3,), optional
        v₀, the velocity of the point ``about`` in space axes (m/s); default zero.
    omega : float or (3,), optional
        Angular velocity in space axes (rad/s): a planar model's rate about z, or a 3-vector
        for spatial ones; default zero.
    about : (2,) or (3,), optional
        The point p (m); default the origin.

    Returns
    -------
    list of Node
        The nodes that were set.

    Raises
    ------
    ModelError
        Unknown items, items that hold no body or node, vectors of the wrong size or not
        finite, planar and spatial nodes mixed, or a non-zero velocity of a fixed coordinate (naming the node).
    """
    nodes = _nodes_of(items, [])
    if not nodes:
        raise ModelError(f"set_rigid_velocity: {items!r} holds no body or node to set")
    kinds = {n.kind for n in nodes}
    if len(kinds) > 1:
        raise ModelError(f"set_rigid_velocity: planar and spatial nodes in one call ({sorted(kinds)}); "
                         f"set each kind with its own call")
    spatial = kinds == {"frame"}
    dim = 3 if spatial else 2
    velocity = np.zeros(dim) if velocity is None else velocity
    omega = (np.zeros(3) if spatial else 0.0) if omega is None else omega
    about = np.zeros(dim) if about is None else about
    new = [rigid_velocity_of_node(n, velocity, omega, about) for n in nodes]
    for n, v in zip(nodes, new):
        fixed = np.asarray(getattr(n, "fixed_v", n.fixed), dtype=bool)
        if np.any(v[fixed] != 0.0):
            names = np.asarray(getattr(n, "velocity_names", n.coord_names))[fixed]
            raise ModelError(f"set_rigid_velocity: node '{n.name}' holds {', '.join(names)} fixed, "
                             f"and the motion would move them ({v[fixed].tolist()})")
    for n, v in zip(nodes, new):
        n.qd0 = v
    return nodes
