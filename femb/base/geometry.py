"""Plain geometry records that elements return for output.

Elements describe what they look like as plain numpy data; only the output
layer (:mod:`femb.io`) turns these records into files or pictures, so elements
never import meshio or pyvista.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class GeometryBlock:
    """Geometry of all elements of one type at one instant.

    Attributes
    ----------
    name : str
        Element type name (e.g. ``"RigidBody"``), written as field data.
    points : ndarray, shape (k, 3)
        Point coordinates in the inertial frame (planar scenes use z = 0).
    cells : list of (str, ndarray)
        Cell blocks, each a meshio cell type name (``"vertex"``, ``"line"``,
        ``"polygon"``, ``"triangle"``, ...) and a connectivity array of shape
        (ncell, nverts) indexing ``points`` of this block.
    point_data : dict of str to ndarray
        Per-point arrays of shape (k,) or (k, c).
    cell_data : dict of str to list of ndarray
        Per-cell arrays, one array per cell block, each (ncell,) or (ncell, c).
    """

    name: str
    points: np.ndarray
    cells: list = field(default_factory=list)
    point_data: dict = field(default_factory=dict)
    cell_data: dict = field(default_factory=dict)
