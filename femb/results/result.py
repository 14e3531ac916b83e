"""Simulation results: plain arrays plus named access."""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np
from numpy.typing import ArrayLike

from femb.base.summary import Animation
from femb.errors import ModelError
from femb.system.model import State


#: reaction components of a planar joint (:meth:`Result.series`): force (N) and moment (N·m) on body b
PLANAR_REACTIONS = ("Fx", "Fy", "M")
#: reaction components of a spatial joint: force (N) and moment (N·m) on body b, space axes
SPATIAL_REACTIONS = ("Fx", "Fy", "Fz", "Mx", "My", "Mz")


def _rot2(th, s):
    """R(θ) s for θ of shape (nt,) and s of shape (2,) -> (nt, 2)."""
    c, sn = np.cos(th), np.sin(th)
    return np.stack((c * s[0] - sn * s[1], sn * s[0] + c * s[1]), axis=-1)


#: :meth:`Result.plot` page, in inches: width, height of one panel (axes and the gap above it),
#: margins left (tick labels and y label), right, top (title), bottom (x tick labels and label)
_PLOT_INCHES = {"width": 7.0, "panel": 1.9, "left": 1.15, "right": 0.2, "top": 0.55, "bottom": 0.55,
                "gap": 0.3}


def _panel_figure(n):
    """A matplotlib Figure for ``n`` stacked panels with margins fixed in inches.

    Fixed margins instead of the constrained layout engine: the engine measures
    every axes' tick labels on a dry draw before the real one, which made a plot
    of all ~40 outputs of a spatial model take several times as long as drawing
    it (the margins here fit tick labels of up to about 8 characters, what the
    default tick formatter writes, with its offset text in the gap above a panel).
    """
    from matplotlib.figure import Figure

    s = _PLOT_INCHES
    height = s["panel"] * n + s["top"] + s["bottom"] - s["gap"]
    fig = Figure(figsize=(s["width"], height))
    axes_height = s["panel"] - s["gap"]
    fig.subplots_adjust(left=s["left"] / s["width"], right=1.0 - s["right"] / s["width"],
                        bottom=s["bottom"] / height, top=1.0 - s["top"] / height,
                        hspace=s["gap"] / axes_height)
    return fig


@dataclass
class Result:
    """Stored steps of a simulation.

    Attributes
    ----------
    model : Model
    t : ndarray, shape (nt,)
    q : ndarray, shape (nt, nx)
        Free configuration entries (nx = nq without spatial rotations; a free
        spatial frame node has 7: position and unit quaternion).
    qd, qdd : ndarray, shape (nt, nq)
        Velocities and accelerations (a spatial frame node: ṙ in space axes,
        Ω in body axes, and their derivatives).
    lam : ndarray, shape (nt, nc + nn)
        The multipliers: λ of the nc holonomic constraints, then μ of the nn velocity-level
        (non-holonomic) ones (:attr:`mu`; nn = 0 for most models).
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
    def mu(self):
        """Multipliers μ of the velocity-level (non-holonomic) constraints, shape (nt, nn)."""
        return self.lam[:, self.model.nc:]

    @property
    def steps(self):
        """Number of steps taken."""
        return int(self.newton_iterations.size)

    def body(self, name: str, what: str = "q") -> np.ndarray:
        """Coordinates of a body or node over time, fixed ones included.

        Parameters
        ----------
        name : str
        what : {"q", "qd", "qdd"}

        Returns
        -------
        ndarray, shape (nt, ncoord) — (x, y, θ) for planar nodes; for a spatial
        frame node (nt, 7) = (r, p) with "q" and (nt, 6) = (ṙ, Ω body axes) with
        "qd" / "qdd".
        """
        arr = {"q": self.q, "qd": self.qd, "qdd": self.qdd}.get(what)
        if arr is None:
            raise ModelError(f"what must be 'q', 'qd' or 'qdd', got {what!r}")
        if what == "q":
            return self.model.node_coordinates(name, arr)
        self._node(name)
        return self.model.node_velocities(name, arr)

    def _node(self, name):
        try:
            return self.model.node_index[name]
        except KeyError:
            raise ModelError(f"no body/node named '{name}' (known: {sorted(self.model.node_index)})") from None

    def position(self, body: str, point: str | ArrayLike = (0.0, 0.0)) -> np.ndarray:
        """Inertial position of a body point over time (same as :meth:`point`).

        Returns
        -------
        ndarray, shape (nt, 2) for planar bodies, (nt, 3) (space axes) for spatial ones
        """
        return self.point(body, point)

    def _body(self, body):
        b = self.model.bodies.get(body)
        if b is None:
            raise ModelError(f"no body named '{body}' (known: {sorted(self.model.bodies)})")
        return b

    def _spatial(self, body):
        """True for a body on a spatial frame node (quaternion rotation)."""
        return bool(getattr(getattr(self._body(body), "node", None), "rotation_blocks", ()))

    def _require_spatial(self, body, what):
        if not self._spatial(body):
            raise ModelError(f"{what}: body '{body}' is planar (its rotation is the angle θ, "
                             f"result.body('{body}')[:, 2])")

    def rotation(self, body: str) -> np.ndarray:
        """Unit quaternion p = (p0, p1, p2, p3) (body to space) of a spatial body over time, shape (nt, 4)."""
        self._require_spatial(body, "rotation")
        return self.body(body)[:, 3:7].copy()

    def rotation_matrix(self, body: str) -> np.ndarray:
        """Rotation matrix R (body to space) of a spatial body over time, shape (nt, 3, 3)."""
        from femb.base.rotations import quat_to_matrix
        return np.array([quat_to_matrix.py_func(np.ascontiguousarray(p)) for p in self.rotation(body)])

    def angular_velocity(self, body: str, frame: str = "body") -> np.ndarray:
        """Angular velocity of a spatial body over time, shape (nt, 3) (rad/s).

        Parameters
        ----------
        body : str
        frame : {"body", "space"}
            Components in body axes (Ω, the model's velocity entries) or in space
            axes (ω = R Ω).
        """
        self._require_spatial(body, "angular_velocity")
        if frame not in ("body", "space"):
            raise ModelError(f"angular_velocity: frame must be 'body' or 'space', got {frame!r}")
        W = self.body(body, "qd")[:, 3:6]
        if frame == "body":
            return W
        return np.einsum("nij,nj->ni", self.rotation_matrix(body), W)

    def _point_series(self, body, s):
        if self._spatial(body):
            R = self.rotation_matrix(body)
            return self.body(body)[:, 0:3] + R @ np.asarray(s, dtype=float)
        qb = self.body(body)
        c, sn = np.cos(qb[:, 2]), np.sin(qb[:, 2])
        return np.stack((qb[:, 0] + c * s[0] - sn * s[1], qb[:, 1] + sn * s[0] + c * s[1]), axis=1)

    def _local(self, body, point):
        b = self._body(body)
        if self._spatial(body) and point is not None and not isinstance(point, str) and np.size(point) == 2:
            point = (0.0, 0.0, 0.0) if not np.any(point) else point
        return b.local(point)

    def point(self, body: str, point: str | ArrayLike = (0.0, 0.0)) -> np.ndarray:
        """Inertial position r_P = r + R s of a body point over time (m).

        Parameters
        ----------
        body : str
        point : str or (x, y) or (x, y, z)
            A named point of the body or body-frame coordinates (default: the node).

        Returns
        -------
        ndarray, shape (nt, 2) for planar bodies, (nt, 3) for spatial ones
        """
        return self._point_series(body, self._local(body, point))

    def point_velocity(self, body: str, point: str | ArrayLike = (0.0, 0.0)) -> np.ndarray:
        """v_P = ṙ + θ̇ J R(θ) s (planar, (nt, 2)) or ṙ + R (Ω × s) (spatial, (nt, 3)) of a body point (m/s)."""
        s = self._local(body, point)
        if self._spatial(body):
            v = self.body(body, "qd")
            R = self.rotation_matrix(body)
            return v[:, 0:3] + np.einsum("nij,nj->ni", R, np.cross(v[:, 3:6], s))
        q, v = self.body(body), self.body(body, "qd")
        c, sn = np.cos(q[:, 2]), np.sin(q[:, 2])
        d = np.stack((c * s[0] - sn * s[1], sn * s[0] + c * s[1]), axis=1)
        return v[:, :2] + v[:, 2:3] * np.stack((-d[:, 1], d[:, 0]), axis=1)

    def point_acceleration(self, body: str, point: str | ArrayLike = (0.0, 0.0)) -> np.ndarray:
        """a_P = r̈ + θ̈ J R(θ) s − θ̇² R(θ) s (planar, (nt, 2)) or r̈ + R(Ω̇ × s + Ω × (Ω × s)) (spatial, (nt, 3)) (m/s²)."""
        s = self._local(body, point)
        if self._spatial(body):
            v, a = self.body(body, "qd"), self.body(body, "qdd")
            R = self.rotation_matrix(body)
            W = v[:, 3:6]
            loc = np.cross(a[:, 3:6], s) + np.cross(W, np.cross(W, s))
            return a[:, 0:3] + np.einsum("nij,nj->ni", R, loc)
        q, v, a = self.body(body), self.body(body, "qd"), self.body(body, "qdd")
        c, sn = np.cos(q[:, 2]), np.sin(q[:, 2])
        d = np.stack((c * s[0] - sn * s[1], sn * s[0] + c * s[1]), axis=1)
        return a[:, :2] + a[:, 2:3] * np.stack((-d[:, 1], d[:, 0]), axis=1) - (v[:, 2:3] ** 2) * d

    def beam(self, name):
        """A spatial beam meshed by :func:`~femb.elements.spatial_beam.spatial_beam` as ``name``.

        Returns
        -------
        BeamSeries
            Over the stored times (nt) of the beam's n elements: ``centre_line`` (nt, n + 1, 3)
            node positions; ``frames`` (nt, n + 1, 3, 3) section axes (columns e1 along the
            beam, e2, e3) in space; ``forces`` (nt, n, 6) = (N, Q2, Q3, T, M2, M3) and
            ``strains`` (nt, n, 6) = (Γ − Γ0, κ − κ0) per element in section axes (N > 0 in
            tension; the resultants act from the end side on the start side). See
            :class:`~femb.elements.spatial_beam.BeamSeries` for the conventions.
        """
        from femb.elements.spatial_beam import beam_series
        return beam_series(self, name)

    def reaction(self, name: str) -> np.ndarray:
        """Lagrange multipliers of a joint over time, shape (nt, nc_element).

        For a :class:`~femb.elements.Hinge` these are the force components the
        joint exerts on its body ``b`` (and minus that on body ``a``); for a
        :class:`~femb.elements.SphericalJoint` the force on b in space axes;
        other joints' multipliers are listed in docs/conventions.md and
        docs/spatial.md. See :meth:`reaction_at` for the force *and moment* at
        a point, whatever the joint's equations.

        Raises
        ------
        ModelError
            If ``name`` is a body or an element without constraints (springs,
            loads), or unknown.
        """
        idx = self._joint(name)
        removed = getattr(self.model, "removed_constraints", None) or []
        if any(el == name for el, _ in removed):
            import warnings

            from femb.system.initial import RedundantConstraintWarning
            eqs = ", ".join(eq for el, eq in removed if el == name)
            warnings.warn(f"joint '{name}': equation(s) {eqs} removed as redundant; its reaction is not unique",
                          RedundantConstraintWarning, stacklevel=2)
        return self.lam[:, idx]

    def _joint(self, name):
        m = self.model
        if name in getattr(m, "bodies", {}) and not len(m.lam_index.get(name, ())):
            raise ModelError(f"'{name}' is a body, not a joint: reactions belong to joints and constraints "
                             f"(known: {sorted(k for k, v in m.lam_index.items() if len(v))})")
        idx = m.lam_indices(name)
        if idx.size == 0:
            kind = getattr(m, "element_types", {}).get(name, "element")
            raise ModelError(f"{kind} '{name}' has no constraint equations, hence no reaction (reactions belong "
                             f"to joints: {sorted(k for k, v in m.lam_index.items() if len(v))})")
        return idx

    def _element(self, name):
        for g in self.model.constraint_groups:
            for e in g.elements:
                if e.name == name:
                    return e
        raise ModelError(f"no constraint element named '{name}'")

    def reaction_at(self, joint: str, point: str | ArrayLike | None = None, on: str = "b") -> np.ndarray:
        """Force and moment a joint exerts on one of its bodies, about a point, over time.

        Computed from the joint's own constraint kernel, evaluated once for all
        stored steps: the generalized constraint force −B_bᵀλ of the joint's
        equations on the coordinates of body ``on`` (B_b the columns of that
        body's node in the joint's Jacobian B = ∂Φ/∂q). Its force part is the
        force; its moment part (about the node) is moved to the point P by
        M_P = M_node + (r_node − r_P) × F. The force and moment on the other
        body are the opposite (about the same inertial point), since a joint's
        equations depend only on the relative position of its bodies. Nothing
        depends on which multiplier stands for what, so the result holds for
        any choice of a joint's equations.

        Parameters
        ----------
        joint : str
            A joint or driven constraint.
        point : str or (x, y) or (x, y, z), optional
            Point of body ``on`` (name or body-frame coordinates: (x, y) on a
            planar body, (x, y, z) in body axes on a spatial one) about which
            the moment is taken; default: the joint's point on that body (its
            node for joints without one).
        on : {"b", "a"}
            The body the reaction acts on.

        Returns
        -------
        ndarray
            Planar joint, shape (nt, 3): F_x, F_y (N) in the inertial frame and
            M_z (N·m, counter-clockwise). Spatial joint, shape (nt, 6): F_x,
            F_y, F_z (N) and M_x, M_y, M_z (N·m), all in space (inertial) axes,
            the moment about the point.
        """
        self._joint(joint)
        if on not in ("a", "b"):
            raise ModelError(f"reaction_at: on must be 'a' or 'b', got {on!r}")
        e = self._element(joint)
        body = getattr(e, on, None)
        node = getattr(body, "node", None)
        if node is None:
            raise ModelError(f"reaction_at: {type(e).__name__} '{joint}' has no body '{on}' with a node")
        spatial = bool(getattr(node, "rotation_blocks", ()))
        if point is None:
            s = getattr(e, ("Xb" if on == "b" else "Xa") if spatial else ("sb" if on == "b" else "sa"), None)
            s = np.zeros(3 if spatial else 2) if s is None else np.asarray(s, dtype=float)
        elif spatial:
            s = np.asarray(self._local(body.name, point) if body.name in self.model.bodies
                           else body.local(point), dtype=float)
        else:
            s = np.asarray(body.local(point), dtype=float)
        gen = self._constraint_force_on(e, node)
        x = self.model.node_coordinates(node.name, self.q)
        if spatial:
            from femb.elements._spatial_geometry import rotate, rotation_matrices
            R = rotation_matrices(x[:, 3:7])
            F = gen[:, 0:3]
            d = R @ s                             # r_P − r_node
            M = rotate(R, gen[:, 3:6]) - np.cross(d, F)
            return np.hstack((F, M))
        d = _rot2(x[:, 2], s)
        F = gen[:, 0:2]
        Mz = gen[:, 2] - (d[:, 0] * F[:, 1] - d[:, 1] * F[:, 0])
        return np.column_stack((F, Mz))

    def _constraint_force_on(self, e, node):
        """−B_nᵀλ of element ``e``'s equations on the velocity entries of ``node``, every stored step.

        Returns
        -------
        ndarray, shape (nt, nv)
            nv = 3 for a planar node ((F_x, F_y) in the inertial frame, M_z about
            the node), 6 for a spatial frame node ((F_x, F_y, F_z) in space axes,
            the moment about the node in *body* axes).
        """
        from femb.system import kernels

        m = self.model
        for g in m.constraint_groups:
            rows = [k for k, el in enumerate(g.elements) if el is e]
            if rows:
                break
        else:
            raise ModelError(f"no constraint element named '{e.name}'")
        k = rows[0]
        nt = self.t.size
        xdofs = g.xdofs[k]
        xe = np.empty((nt, xdofs.size))
        free = xdofs < m.nx
        xe[:, free] = self.q[:, xdofs[free]]
        xe[:, ~free] = m.q_fixed[xdofs[~free] - m.nx]
        le = np.ascontiguousarray(self.lam[:, g.lam[k]])
        fns = g.time_functions[k] if g.time_functions else []
        tf = np.zeros((nt, len(fns), 3))
        for j, fn in enumerate(fns):
            tf[:, j, 0] = [fn.f(t) for t in self.t]
            tf[:, j, 1] = [fn.df(t) for t in self.t]
            tf[:, j, 2] = [fn.ddf(t) for t in self.t]
        P = np.ascontiguousarray(np.broadcast_to(g.P[k], (nt, g.P.shape[1])))
        Phi = np.zeros((nt, g.nc))
        B = np.zeros((nt, g.nc, g.ndv))
        H = np.zeros((nt, g.ndv, g.ndv))       # kernels may index it per row even without jac
        kernels._kernel(g, "constraint")(P, float(self.t[0]) if nt else 0.0, tf,
                                         np.ascontiguousarray(xe), le, False, Phi, B, H)
        vidx = m.node_vindex[node.name]
        cols = [int(np.nonzero(g.dofs[k] == i)[0][0]) for i in vidx]
        return -np.einsum("tkc,tk->tc", B[:, :, cols], le)

    def write_vtk(self, directory: str | os.PathLike, every: int = 1, basename: str = "frame",
                  dt: float | None = None) -> Path:
        """Write the stored steps as a ParaView time series (``.pvd`` + ``.vtu``); returns the ``.pvd`` path.

        Every ``every``-th stored step and the last; with ``dt``, the stored step nearest each of
        t₀, t₀ + dt, t₀ + 2 dt, … and the last (for uneven steps: adaptive runs, impacts), each once."""
        from femb.io.frames import write_vtk

        if dt is None:
            return write_vtk(self, directory, every=every, basename=basename)
        try:
            ok = float(dt) > 0.0 and np.isfinite(float(dt))
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise ModelError(f"write_vtk: dt must be a positive number of seconds, got {dt!r}")
        dt = float(dt)
        t = np.asarray(self.t, dtype=float)
        if t.size == 0:
            raise ModelError("the result has no stored steps")
        marks = t[0] + dt * np.arange(int(np.floor((t[-1] - t[0]) / dt * (1.0 + 1e-12))) + 1)
        right = np.clip(np.searchsorted(t, marks), 1, max(t.size - 1, 1))
        left = right - 1
        near = np.where(np.abs(t[np.minimum(right, t.size - 1)] - marks) < np.abs(marks - t[left]), right, left)
        steps = np.unique(np.append(np.minimum(near, t.size - 1), t.size - 1))
        return write_vtk(self, directory, basename=basename, steps=steps)

    def nearest(self, time: float) -> int:
        """Index of the stored step nearest to ``time`` (ties go to the earlier step)."""
        self._check_time(time)
        return int(np.argmin(np.abs(self.t - time)))

    def _check_time(self, time):
        try:
            time = float(time)
        except (TypeError, ValueError):
            raise ModelError(f"time must be a number, got {time!r}") from None
        if self.t.size == 0:
            raise ModelError("the result has no stored steps")
        t0, t1 = float(self.t[0]), float(self.t[-1])
        eps = 1e-12 * max(1.0, abs(t0), abs(t1))
        if not (t0 - eps <= time <= t1 + eps):
            raise ModelError(f"time {time!r} is outside the stored interval [{t0:.6g}, {t1:.6g}]")
        return min(max(time, t0), t1)

    def at(self, time: float) -> State:
        """The state at ``time``, interpolated between the stored steps.

        q uses cubic Hermite interpolation with the stored q̇ (its error is of
        order Δt⁴ q⁽⁴⁾ for stored steps Δt apart), q̇ cubic Hermite with q̈;
        q̈ and λ are linear. At a stored time the stored values are returned
        exactly.

        Returns
        -------
        femb.system.model.State

        Raises
        ------
        ModelError
            If ``time`` is outside [t_0, t_end] of the stored steps.
        """
        from femb.system.model import State

        time = self._check_time(time)
        t = self.t
        k = int(np.searchsorted(t, time, side="right")) - 1
        k = min(max(k, 0), t.size - 1)
        if k == t.size - 1 or time == t[k]:
            return State(float(time), self.q[k].copy(), self.qd[k].copy(), self.qdd[k].copy(),
                         self.lam[k].copy())
        h = t[k + 1] - t[k]
        s = (time - t[k]) / h
        h00, h10, h01, h11 = 2 * s ** 3 - 3 * s ** 2 + 1, s ** 3 - 2 * s ** 2 + s, -2 * s ** 3 + 3 * s ** 2, s ** 3 - s ** 2
        q = h00 * self.q[k] + h10 * h * self.qd[k] + h01 * self.q[k + 1] + h11 * h * self.qd[k + 1]
        qd = h00 * self.qd[k] + h10 * h * self.qdd[k] + h01 * self.qd[k + 1] + h11 * h * self.qdd[k + 1]
        qdd = (1 - s) * self.qdd[k] + s * self.qdd[k + 1]
        lam = (1 - s) * self.lam[k] + s * self.lam[k + 1]
        return State(float(time), q, qd, qdd, lam)

    # ------------------------------------------------------------------ energies
    def energy(self) -> dict[str, np.ndarray]:
        """Energies and their balance at every stored step (dict of (nt,) arrays, J); see :mod:`femb.results.energy`.

        Computed once per result (the stored arrays are the run's); each call returns copies.
        """
        from femb.results.energy import energies

        key = (id(self.t), self.t.size)
        cache = self.__dict__.get("_energy_cache")
        if cache is None or cache[0] != key:
            cache = (key, energies(self))
            self.__dict__["_energy_cache"] = cache
        return {k: (v if isinstance(v, tuple) else np.array(v, copy=True)) for k, v in cache[1].items()}

    def energy_balance(self) -> float:
        """Largest |energy balance| relative to the run's energy scale (see :func:`femb.results.energy.energy_balance`)."""
        from femb.results.energy import balance_ratio

        return balance_ratio(self.energy())

    def momentum(self, about=None, of=None):
        """Linear and angular momentum at every stored step; see :func:`femb.results.energy.momentum`.

        Parameters
        ----------
        about : array_like, optional
            Point of the angular momentum, (3,) spatial / (2,) planar (m); default the origin.
        of : str or sequence of str, optional
            Bodies or beam elements by name (a meshed beam's name selects its elements);
            default the whole model.

        Returns
        -------
        p : ndarray, shape (nt, 3) spatial / (nt, 2) planar
            Linear momentum (kg m/s).
        H : ndarray, shape (nt, 3) spatial / (nt,) planar (about z)
            Angular momentum about ``about`` (kg m²/s).
        """
        from femb.results.energy import momentum

        return momentum(self, about=about, of=of)

    # ------------------------------------------------------------------ named outputs
    def _nodes(self):
        """Every node of the model by name ({name: node})."""
        m = self.model
        out = {}
        for b in m.bodies.values():
            nd = getattr(b, "node", None)
            if nd is not None:
                out[nd.name] = nd
        for g in m.groups:
            for e in g.elements:
                for nd in e.nodes():
                    out.setdefault(nd.name, nd)
        return out

    def _reaction_joints(self):
        """{joint name: its reaction names} of the constraint elements between two bodies."""
        out = {}
        for g in self.model.constraint_groups:
            for e in g.elements:
                nb = getattr(getattr(e, "b", None), "node", None)
                if nb is None or getattr(getattr(e, "a", None), "node", None) is None:
                    continue
                out[e.name] = SPATIAL_REACTIONS if getattr(nb, "rotation_blocks", ()) else PLANAR_REACTIONS
        return out

    def outputs(self) -> list[str]:
        """Names of the outputs :meth:`series` knows for this model.

        Per free node coordinate its value and, for planar nodes and the
        translations of spatial ones, ``_d`` and ``_dd`` (velocity,
        acceleration); per spatial rotation its quaternion components
        (``p0`` … ``p3``) and the angular velocity (``Omega_x`` … in body axes,
        ``omega_x`` … in space axes, each with ``_d``); every multiplier; the
        reaction of every joint between two bodies (``Fx``, ``Fy``, ``M``
        planar; ``Fx`` … ``Mz`` spatial); the energies.

        Returns
        -------
        list of str
        """
        m = self.model
        names = []
        nodes = self._nodes()
        for nname in m.node_names:
            idx = m.node_index[nname]
            nd = nodes.get(nname)
            cn = tuple(getattr(nd, "coord_names", ()))
            if len(cn) != idx.size:
                cn = tuple(str(c) for c in range(idx.size))
            blocks = tuple(getattr(nd, "rotation_blocks", ()))
            quat = {c for xs, _ in blocks for c in range(xs, xs + 4)}
            for c in range(idx.size):
                if idx[c] >= m.nx:
                    continue
                lab = f"{nname}.{cn[c]}"
                names += [lab] if c in quat else [lab, lab + "_d", lab + "_dd"]
            vidx = m.node_vindex[nname]
            for _, vs in blocks:
                if vidx[vs] < m.nq:
                    for kind in ("Omega", "omega"):
                        for comp in "xyz":
                            names += [f"{nname}.{kind}_{comp}", f"{nname}.{kind}_{comp}_d"]
        from femb.system.initial import constraint_labels
        names += [f"{el}.{eq}" for el, eq in constraint_labels(m)]
        names += [f"{el}.{eq}" for el, eq in _velocity_labels(m)]
        for el, comps in self._reaction_joints().items():
            names += [f"{el}.{c}" for c in comps]
        for el, (g, _) in self._output_elements().items():
            names += [f"{el}.{c}" for c, _ in g.cls.output_units()]
        names += [f"energy.{k}" for k in ("kinetic", "gravitational", "elastic", "work_loads",
                                          "work_drives", "dissipated", "total", "balance")]
        return names

    def _output_elements(self):
        """{element name: (batch, index in it)} of the element types that declare named outputs
        (an ``output_units()`` and an ``outputs(params, qe, qde, rows)`` classmethod, e.g. penalty contacts)."""
        return {name: (g, i) for g in self.model.groups if hasattr(g.cls, "output_units")
                for i, name in enumerate(g.names)}

    def _element_output_series(self, name, owner, base):
        """:meth:`series` of an element's declared output; None if ``owner`` declares none."""
        found = self._output_elements().get(owner)
        if found is None:
            return None
        g, i = found
        units = dict(g.cls.output_units())
        if base not in units:
            raise ModelError(f"output '{name}': '{owner}' has the outputs {', '.join(units)} (see Result.outputs())")
        m = self.model
        nt = self.t.size
        qx = np.concatenate((self.q, np.broadcast_to(m.q_fixed, (nt, m.q_fixed.size))), axis=1)
        vx = np.concatenate((self.qd, np.zeros((nt, m.nfix_v))), axis=1)
        vals = g.cls.outputs(g.params, qx[:, g.xdofs[i:i + 1]], vx[:, g.dofs[i:i + 1]], [i])
        return vals[base][:, 0].copy(), units[base]

    def series(self, name: str) -> tuple[np.ndarray, str]:
        """One named output over time: (values of shape (nt,), unit).

        Parameters
        ----------
        name : str
            An output name, as listed by :meth:`outputs`; the kinds are listed under Notes.

        Notes
        -----
        The output names:

        ``"<body>.x"``, ``".y"``, ``".theta"``
            A planar coordinate (m, rad); append ``_d`` / ``_dd`` for its
            velocity / acceleration (``"bar.theta_d"``).
        ``"<body>.x"``, ``".y"``, ``".z"`` (and ``_d``, ``_dd``)
            The position of a spatial body's node in space axes (m, m/s, m/s²).
        ``"<body>.p0"`` … ``".p3"``
            The unit quaternion of a spatial body (dimensionless, unit ``"1"``).
        ``"<body>.Omega_x"`` … ``".Omega_z"`` / ``"<body>.omega_x"`` … ``".omega_z"``
            Angular velocity of a spatial body in body axes (Ω) / space axes
            (ω = RΩ) (rad/s); ``_d``: the angular acceleration in the same axes
            (rad/s²).
        ``"<body>.<point>.x"`` / ``".y"`` (``".z"`` on spatial bodies; and ``_d``, ``_dd``)
            A named point of a body (:meth:`point`, :meth:`point_velocity`,
            :meth:`point_acceleration`), inertial axes.
        ``"<joint>.<equation>"``
            A multiplier (``"pivot.x"``; equation names as in
            ``constraint_names`` of the joint type; unit from its
            ``constraint_units`` when the type declares them, e.g. N·m for the
            lock rows of spatial joints, else ``"λ"``). Velocity-level
            (non-holonomic) constraints likewise (``"roll.t1"``: names from
            ``velocity_constraint_names``, units from ``velocity_constraint_units``
            when declared, else ``"μ"``).
        ``"<joint>.Fx"``, ``".Fy"``, ``".M"`` (planar joints)
            Reaction force (N) and moment (N·m, counter-clockwise) of the joint
            on its body b, about the joint's point on b (:meth:`reaction_at`).
        ``"<joint>.Fx"``, ``".Fy"``, ``".Fz"``, ``".Mx"``, ``".My"``, ``".Mz"`` (spatial joints)
            Reaction force (N) and moment (N·m) of the joint on its body b,
            space axes, the moment about the joint's point on b
            (:meth:`reaction_at`).
        ``"<element>.<output>"``
            A named output of an element type that declares them (``output_units()``
            and ``outputs()`` classmethods), e.g. ``"floor.lambda_N"`` of a penalty
            contact (docs/contact.md).
        ``"energy.<kind>"``
            An energy of :meth:`energy` (J).

        Returns
        -------
        values : ndarray, shape (nt,)
        unit : str

        Raises
        ------
        ModelError
            If the name is not an output of this model (see :meth:`outputs`).
        """
        m = self.model
        if not isinstance(name, str):
            raise ModelError(f"output names are strings, got {name!r}")
        if name.startswith("energy."):
            kind = name[len("energy."):]
            e = self.energy()
            if kind not in e or isinstance(e[kind], tuple):
                raise ModelError(f"unknown energy '{kind}' (known: {sorted(k for k in e if k != 'not_counted')})")
            return e[kind], "J"
        # longest known name that prefixes the output name
        mu_index = getattr(m, "mu_index", {})
        known = sorted(set(m.node_index) | set(m.lam_index) | set(mu_index) | set(m.bodies)
                       | set(self._output_elements()), key=len, reverse=True)
        owner = next((k for k in known if name.startswith(k + ".")), None)
        if owner is None:
            raise ModelError(f"output '{name}': no body, node or joint of that name (see Result.outputs())")
        rest = name[len(owner) + 1:]
        base, deriv = rest, 0
        for suffix, d in (("_dd", 2), ("_d", 1)):
            if rest.endswith(suffix):
                base, deriv = rest[:-len(suffix)], d
                break
        found = self._element_output_series(name, owner, rest)
        if owner in m.node_index and found is None:
            found = self._node_series(name, owner, base, deriv)
        if found is None and owner in m.lam_index and deriv == 0:
            found = self._multiplier_series(name, owner, base)
        if found is None and owner in mu_index and deriv == 0:
            labels = dict(((el, eq), i) for i, (el, eq) in enumerate(_velocity_labels(m)))
            i = labels.get((owner, base))
            if i is not None:
                found = self.lam[:, m.nc + i].copy(), _velocity_unit(m, owner, base)
        if found is not None:
            return found
        raise ModelError(f"output '{name}': '{owner}' has no output '{rest}' (see Result.outputs())")

    def _node_series(self, name, owner, base, deriv):
        """:meth:`series` of a node's coordinate, angular velocity or body point; None if not one."""
        m = self.model
        nd = self._nodes().get(owner)
        body = m.bodies.get(owner)
        coord_names = tuple(getattr(nd, "coord_names", ("x", "y", "theta")))
        blocks = tuple(getattr(nd, "rotation_blocks", ()))
        quat = {coord_names[c] for xs, _ in blocks for c in range(xs, xs + 4)}
        if base in quat:
            if deriv:
                raise ModelError(f"output '{name}': quaternion components have no stored derivatives; "
                                 f"read the angular velocity '{owner}.Omega_x' … or '{owner}.omega_x' …")
            i = coord_names.index(base)
            return m.node_coordinates(owner, self.q)[:, i], "1"
        if blocks and base[:-1] in ("Omega_", "omega_") and base[-1] in "xyz" and deriv < 2:
            xs, vs = blocks[0]
            arr = self.qd if deriv == 0 else self.qdd
            W = m.node_velocities(owner, arr)[:, vs:vs + 3]
            if base.startswith("omega"):
                from femb.elements._spatial_geometry import rotate, rotation_matrices
                W = rotate(rotation_matrices(m.node_coordinates(owner, self.q)[:, xs:xs + 4]), W)
            return W[:, "xyz".index(base[-1])].copy(), ("rad/s", "rad/s²")[deriv]
        if base in coord_names:
            i = coord_names.index(base)
            if deriv == 0:
                vals = m.node_coordinates(owner, self.q)[:, i]
            else:
                tr = list(getattr(nd, "translational", range(len(coord_names))))
                j = i if not blocks else getattr(nd, "translational")[tr.index(i)]
                vals = m.node_velocities(owner, (self.qd, self.qdd)[deriv - 1])[:, j]
            unit = ("rad" if base == "theta" else "m") + ("", "/s", "/s²")[deriv]
            return vals, unit
        if body is not None and "." in base:
            pt, comp = base.rsplit(".", 1)
            axes = "xyz" if blocks else "xy"
            if pt in body.points and comp in axes:
                f = (self.point, self.point_velocity, self.point_acceleration)[deriv]
                return f(owner, pt)[:, axes.index(comp)], ("m", "m/s", "m/s²")[deriv]
        return None

    def _multiplier_series(self, name, owner, base):
        """:meth:`series` of a joint's multiplier or reaction; None if not one."""
        m = self.model
        idx = m.lam_index[owner]
        if idx.size:
            from femb.system.initial import constraint_labels
            labels = constraint_labels(m)
            for i in idx:
                if labels[i][1] == base:
                    return self.lam[:, i].copy(), _multiplier_unit(m, i)
            comps = self._reaction_joints().get(owner, ())
            if base in comps:
                k = comps.index(base)
                return self.reaction_at(owner)[:, k].copy(), ("N·m" if base.startswith("M") else "N")
            if base in PLANAR_REACTIONS + SPATIAL_REACTIONS:
                raise ModelError(f"output '{name}': the reaction of '{owner}' has the components "
                                 f"{', '.join(comps) or 'none'} (see Result.outputs())")
        return None

    def to_pandas(self, outputs: Sequence[str] | None = None) -> Any:
        """The outputs as a ``pandas.DataFrame`` indexed by time (column names as in :meth:`series`).

        Parameters
        ----------
        outputs : list of str, optional
            Output names; default: every output of :meth:`outputs` except
            accelerations (``_dd``) and energies: coordinates, velocities,
            multipliers and joint reactions.

        Raises
        ------
        ModelError
            If pandas is not installed (``pip install femb[pandas]``) or a name is unknown.
        """
        try:
            import pandas as pd
        except ImportError:
            raise ModelError("Result.to_pandas needs pandas: pip install 'femb[pandas]'") from None
        if outputs is None:
            outputs = [n for n in self.outputs() if not n.endswith("_dd") and not n.startswith("energy.")]
        outputs = list(outputs)
        series = {n: self.series(n) for n in outputs}
        df = pd.DataFrame({n: v for n, (v, _) in series.items()}, index=pd.Index(np.asarray(self.t), name="t"))
        df.attrs["units"] = {n: u for n, (_, u) in series.items()}
        return df

    def plot(self, outputs: str | Sequence[str], file: str | os.PathLike | None = None, *,
             title: str | None = None) -> Any:
        """Plot named outputs against time, one panel per output (matplotlib).

        Parameters
        ----------
        outputs : str or list of str
            Names as in :meth:`series`.
        file : str or path, optional
            Save the figure there (format from the suffix, Agg backend; the
            figure is closed). Without it, the figure is returned open.
        title : str, optional

        Returns
        -------
        matplotlib.figure.Figure
        """
        if isinstance(outputs, str):
            outputs = [outputs]
        outputs = list(outputs)
        if not outputs:
            raise ModelError("Result.plot: give at least one output name")
        series = [(n, *self.series(n)) for n in outputs]
        fig = _panel_figure(len(series))
        axes = fig.subplots(len(series), 1, sharex=True, squeeze=False)[:, 0]
        xlabel = "load factor" if hasattr(self, "load_factor") else "t (s)"
        for ax, (n, v, unit) in zip(axes, series):
            ax.plot(self.t, v)
            ax.set_ylabel(f"{n} ({unit})")
            ax.grid(True, alpha=0.3)
        axes[-1].set_xlabel(xlabel)
        fig.suptitle(title or f"{self.model.name}", y=1.0 - 0.12 / fig.get_figheight())
        if file is not None:
            import os
            from matplotlib.backends.backend_agg import FigureCanvasAgg
            FigureCanvasAgg(fig)
            try:
                fig.savefig(os.fspath(file))
            except (OSError, ValueError) as err:
                from femb.errors import OutputError
                raise OutputError(f"Result.plot: cannot write '{file}': {err}") from err
        return fig

    # ------------------------------------------------------------ display (console and notebooks)
    def _summary(self):
        """(title, rows) for :meth:`__repr__` and :meth:`_repr_html_`."""
        from femb.base.summary import short_list, span

        st = self.settings or {}
        if st.get("adaptive"):
            how = (f"adaptive, rtol = {st.get('rtol'):.3g}, {getattr(self, 'n_rejected', 0)} rejected"
                   if st.get("rtol") is not None else "adaptive")
        elif st.get("h") is not None:
            how = f"fixed h = {st['h']:.6g} s"
        else:
            how = "given"
        outs = self.outputs()
        owners, n_out = list(dict.fromkeys(n.partition(".")[0] for n in outs)), len(outs)
        status = self.status + (f": {self.message}" if self.message and not self.success else "")
        rows = [("status", status), ("time", span(self.t)),
                ("steps", f"{self._steps_label(how)}, {self.wall_time:.3g} s wall"),
                ("arrays", f"q {tuple(self.q.shape)}, qd {tuple(self.qd.shape)}, lam {tuple(self.lam.shape)}"),
                ("outputs", f"{n_out} of " + short_list(owners, 6) + " (series(name), to_pandas(), plot())")]
        return f"femb Result of '{self.model.name}'", rows

    def _steps_label(self, how):
        """The summary's count of steps with how they were taken (``how``)."""
        return f"{self.steps} ({how})"

    def __repr__(self):
        from femb.base.summary import text

        return text(*self._summary())

    def _repr_html_(self):
        from femb.base.summary import html

        return html(*self._summary())

    def animate(self, frames: int = 60, *, size: tuple[int, int] = (480, 360), view: str | None = None,
                fps: float = 20.0) -> Animation:
        """The motion as an animated GIF, shown inline in a notebook (the pictures of ``femb render``).

        Writes the stored steps to a temporary VTK series and renders it off-screen
        (:func:`femb.io.render.render_animation`: bodies in their colours, legend, joints, ground).

        Parameters
        ----------
        frames : int
            At most this many pictures, evenly spaced over the stored steps.
        size : (int, int)
            Picture size in pixels.
        view : str, optional
            As for :func:`femb.io.render.render_png` (default: onto the plane for a planar
            mechanism, else the 3-D view).
        fps : float
            Pictures per second.

        Returns
        -------
        femb.base.summary.Animation
            ``_repr_html_`` for Jupyter, ``save(path)``, ``data`` (the GIF bytes).

        Raises
        ------
        OutputError
            No off-screen rendering here (:func:`femb.io.can_render`), or bad arguments.
        """
        import io
        import tempfile

        from PIL import Image

        from femb.errors import OutputError
        from femb.io.render import render_animation

        if not isinstance(frames, (int, np.integer)) or isinstance(frames, bool) or frames < 1:
            raise OutputError(f"Result.animate: frames must be a positive integer, got {frames!r}")
        every = max(1, len(self.t) // (4 * int(frames)))         # write no more frames than needed
        with tempfile.TemporaryDirectory(prefix="femb-animate-") as tmp:
            pvd = self.write_vtk(tmp, every=every)
            gif = render_animation(pvd, Path(tmp) / "motion.gif", fps=fps, max_frames=int(frames),
                                   window_size=tuple(size), view=view)
            data = gif.read_bytes()
        with Image.open(io.BytesIO(data)) as im:
            n = getattr(im, "n_frames", 1)
        return Animation(data, n)

    def view(self, *, port: int | None = None, open_browser: bool = True, view: str | None = None):
        """The motion in an interactive 3-D player in the browser (:func:`femb.io.view.view`).

        Writes the stored steps to a temporary VTK series (at most about 400 frames) and serves
        the player: rotate, zoom, a time slider, play/pause, the bodies, joints, ground and
        legend of the pictures. Needs the ``view`` extra (``pip install "femb[view]"``).

        Parameters
        ----------
        port : int, optional
            Port of the local server (default any free port).
        open_browser : bool, default True
            Outside a notebook: open the system's browser (else print the address).
        view : str, optional
            Initial camera, as for :func:`femb.io.render.render_png`.

        Returns
        -------
        None
            In a Jupyter notebook the player is shown inline; elsewhere the call serves until
            interrupted (Ctrl-C).
        """
        from femb.io.view import view as _view

        return _view(self, port=port, open_browser=open_browser, view=view)


def _velocity_labels(model):
    """(element, equation name) of each velocity-level (non-holonomic) constraint row, in μ order."""
    out = [None] * getattr(model, "nn", 0)
    for g in getattr(model, "velocity_constraint_groups", ()):
        names = tuple(getattr(g.cls, "velocity_constraint_names", ()) or ())
        for e, row in zip(g.names, g.mu):
            for k, j in enumerate(row):
                out[int(j)] = (e, names[k] if k < len(names) else f"mu{k}")
    return out


def _velocity_unit(model, element, equation):
    """Unit of a velocity-constraint multiplier: its type's ``velocity_constraint_units`` entry, else "μ"."""
    for g in getattr(model, "velocity_constraint_groups", ()):
        if element in g.names:
            names = tuple(getattr(g.cls, "velocity_constraint_names", ()) or ())
            units = tuple(getattr(g.cls, "velocity_constraint_units", ()) or ())
            k = names.index(equation) if equation in names else -1
            return units[k] if 0 <= k < len(units) else "μ"
    return "μ"


def _multiplier_unit(model, i):
    """Unit of multiplier i: the joint type's ``constraint_units`` entry, or ``"λ"`` when it declares none."""
    for g in model.constraint_groups:
        units = tuple(getattr(g.cls, "constraint_units", ()) or ())
        for row in g.lam:
            for k, j in enumerate(row):
                if int(j) == i:
                    return units[k] if k < len(units) else "λ"
    return "λ"
