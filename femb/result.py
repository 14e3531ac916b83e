"""Simulation results: plain arrays plus named access."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from femb.errors import ModelError


@dataclass
class Result:
    """Stored steps of a simulation.

    Attributes
    ----------
    model : Model
    t : ndarray, shape (nt,)
    q, qd, qdd : ndarray, shape (nt, nq)
    lam : ndarray, shape (nt, nc)
    newton_iterations : ndarray of int, shape (nsteps,)
        Newton iterations of every step taken (not only the stored ones).
    status : str
        ``"success"`` or ``"failed"``.
    message : str
    wall_time : float
        Seconds spent in the time loop (initialization excluded).
    init_time : float
        Seconds spent computing consistent initial values.
    stats : dict
        Counters: ``steps``, ``evaluations``, ``factorizations``, ``solves``.
    settings : dict
        h, parameters, tolerances, scaling, linear solver.
    """

    model: object
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    lam: np.ndarray
    newton_iterations: np.ndarray
    status: str = "success"
    message: str = ""
    wall_time: float = 0.0
    init_time: float = 0.0
    stats: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)

    @property
    def success(self):
        return self.status == "success"

    @property
    def steps(self):
        """Number of steps taken."""
        return int(self.newton_iterations.size)

    def body(self, name, what="q"):
        """Coordinates of a body or node over time, fixed ones included.

        Parameters
        ----------
        name : str
        what : {"q", "qd", "qdd"}

        Returns
        -------
        ndarray, shape (nt, ncoord) — (x, y, θ) for planar nodes.
        """
        arr = {"q": self.q, "qd": self.qd, "qdd": self.qdd}.get(what)
        if arr is None:
            raise ModelError(f"what must be 'q', 'qd' or 'qdd', got {what!r}")
        if what == "q":
            return self.model.node_coordinates(name, arr)
        idx = self._node(name)
        out = np.zeros((arr.shape[0], idx.size))
        free = idx < self.model.nq
        out[:, free] = arr[:, idx[free]]
        return out

    def _node(self, name):
        try:
            return self.model.node_index[name]
        except KeyError:
            raise ModelError(f"no body/node named '{name}' (known: {sorted(self.model.node_index)})") from None

    def position(self, body, point=(0.0, 0.0)):
        """Inertial position of a body point over time, shape (nt, 2)."""
        b = self.model.bodies.get(body)
        if b is None:
            raise ModelError(f"no body named '{body}'")
        s = b.local(point)
        qb = self.body(body)
        c, sn = np.cos(qb[:, 2]), np.sin(qb[:, 2])
        return np.stack((qb[:, 0] + c * s[0] - sn * s[1], qb[:, 1] + sn * s[0] + c * s[1]), axis=1)

    def reaction(self, name):
        """Lagrange multipliers of a joint over time, shape (nt, nc_element).

        For a :class:`~femb.elements.Hinge` these are the force components the
        joint exerts on its body ``b`` (and minus that on body ``a``).
        """
        idx = self.model.lam_indices(name)
        return self.lam[:, idx]

    def write_vtk(self, directory, every=1, basename="frame"):
        """Write the stored steps as a ParaView time series (``.pvd`` + ``.vtu``); returns the ``.pvd`` path."""
        from femb.io.frames import write_vtk

        return write_vtk(self, directory, every=every, basename=basename)

    def at(self, time):
        """Index of the stored step nearest to ``time``."""
        return int(np.argmin(np.abs(self.t - time)))
