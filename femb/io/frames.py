"""From model and state to output frames: the glue between elements and VTK files.

Elements describe their look as :class:`femb.geometry.GeometryBlock` records
(one call per element type); this module collects them for a state and streams
them through :class:`femb.io.vtk.TimeSeriesWriter`.
"""
from __future__ import annotations

import numpy as np

from femb.geometry import GeometryBlock


def model_blocks(model, t, q, qd, lam):
    """Geometry of every element of ``model`` at one state.

    Parameters
    ----------
    model : Model
    t : float
    q, qd : ndarray, shape (nq,)
    lam : ndarray, shape (nc,)

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
    for g in model.groups:
        le = lam[g.lam] if g.nc else np.zeros((g.nel, 0))
        blocks.extend(g.cls.geometry(g.params, t, qx[g.xdofs], qdx[g.dofs], le, g.names))
    return blocks


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
        from femb.io.vtk import TimeSeriesWriter
        from femb.errors import OutputError

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
        from femb.interp import state_between
        if step == 0 or self._prev is None:
            self._t0 = state.t
            self._k = 0
            self.writer.write(state.t, model_blocks(self.model, state.t, state.q, state.qd, state.lam))
            self._k = 1
        else:
            s0 = self._prev
            while True:
                t = self._t0 + self._k * self.dt
                if t > state.t * (1 + 1e-12) + 1e-300:
                    break
                q, qd, _, lam = state_between(s0, state, min(t, state.t), self.model)
                self.writer.write(t, model_blocks(self.model, t, q, qd, lam))
                self._k += 1
        self._prev = state.copy() if hasattr(state, "copy") else state

    @property
    def path(self):
        """Path of the ``.pvd`` collection."""
        return self.writer.path

    def __call__(self, state, step):
        if self.dt is not None:
            self._frames_between(state, step)
        elif step % self.every == 0:
            self.writer.write(state.t, model_blocks(self.model, state.t, state.q, state.qd, state.lam))
        if self.observer is not None:
            self.observer(state, step)

    def close(self):
        self.writer.close()

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        self.close()
        return False


def write_vtk(result, directory, every=1, basename="frame"):
    """Write the stored steps of a :class:`~femb.result.Result` as a time series.

    Returns
    -------
    pathlib.Path
        The ``.pvd`` file.
    """
    from femb.io.vtk import TimeSeriesWriter

    m = result.model
    with TimeSeriesWriter(directory, basename=basename) as w:
        for k in range(0, result.t.size, int(every)):
            w.write(result.t[k], model_blocks(m, result.t[k], result.q[k], result.qd[k], result.lam[k]))
        if (result.t.size - 1) % int(every):
            k = result.t.size - 1
            w.write(result.t[k], model_blocks(m, result.t[k], result.q[k], result.qd[k], result.lam[k]))
    return w.path


def write_vtk_stream(model, directory, every=1, basename="frame", observer=None, dt=None):
    """A :class:`VTKStream` (the hook the command line uses for ``--vtk``)."""
    return VTKStream(model, directory, every=every, basename=basename, observer=observer, dt=dt)
