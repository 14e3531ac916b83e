"""Nodes: the owners of coordinates.

A node carries a few absolute coordinates in the inertial frame (Géradin &
Cardona 2001). Elements refer to nodes; only the compiler gives coordinates
global indices. Each coordinate of a node is either *free* (an unknown of the
model, an entry of q) or *fixed* (a known constant, stored apart). Elements see
all coordinates of their nodes, free or fixed, so one kernel serves a joint to
another body and a joint to the ground alike.

References
----------
M. Géradin, A. Cardona, Flexible Multibody Dynamics: A Finite Element
Approach, Wiley, 2001.
"""
from __future__ import annotations

import numpy as np

from femb.errors import ModelError


def _finite_vector(value, n, what):
    try:
        v = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ModelError(f"{what} must be {n} numbers, got {value!r}") from None
    if v.size != n:
        raise ModelError(f"{what} must have {n} components, got {v.size}")
    if not np.all(np.isfinite(v)):
        raise ModelError(f"{what} must be finite, got {v.tolist()}")
    return v


class Node:
    """Base class of nodes.

    Attributes
    ----------
    kind : str
        Node family name (``"planar"``).
    coord_names : tuple of str
        Names of the coordinates, in order.
    translational : tuple of int
        Indices of the coordinates that are translations along the inertial
        axes (gravity acts on them).

    Parameters
    ----------
    name : str
        Unique name (usually the name of the body owning the node).
    q0, qd0 : array_like, shape (ncoord,)
        Initial coordinates and velocities.
    fixed : array_like of bool, shape (ncoord,), optional
        Coordinates held at their initial value (not unknowns of the model).
    """

    kind = "node"
    coord_names: tuple = ()
    translational: tuple = ()

    def __init__(self, name, q0, qd0=None, fixed=None):
        n = len(self.coord_names)
        self.name = str(name)
        self.q0 = _finite_vector(q0, n, f"node '{name}': initial coordinates")
        self.qd0 = (np.zeros(n) if qd0 is None
                    else _finite_vector(qd0, n, f"node '{name}': initial velocities"))
        self.fixed = (np.zeros(n, bool) if fixed is None
                      else np.asarray(fixed, dtype=bool).reshape(n).copy())
        if np.any(self.qd0[self.fixed] != 0.0):
            raise ModelError(f"node '{name}': a fixed coordinate cannot have a non-zero velocity")

    @property
    def ncoord(self):
        return len(self.coord_names)

    def __repr__(self):
        return f"{type(self).__name__}({self.name!r})"


class PlanarNode(Node):
    """Planar node with absolute coordinates (x, y, theta).

    ``theta`` is the rotation of the node's frame about z; a body point with
    body-frame coordinates s sits at ``(x, y) + R(theta) s``.
    """

    kind = "planar"
    coord_names = ("x", "y", "theta")
    translational = (0, 1)
