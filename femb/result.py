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

    def position(self, body, point=(0.0, 0.0)):
        """Inertial position of a body point over time, shape (nt, 2) (same as :meth:`point`)."""
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

    def rotation(self, body):
        """Unit quaternion p = (p0, p1, p2, p3) (body to space) of a spatial body over time, shape (nt, 4)."""
        self._require_spatial(body, "rotation")
        return self.body(body)[:, 3:7].copy()

    def rotation_matrix(self, body):
        """Rotation matrix R (body to space) of a spatial body over time, shape (nt, 3, 3)."""
        from femb.rotations import quat_to_matrix
        return np.array([quat_to_matrix.py_func(np.ascontiguousarray(p)) for p in self.rotation(body)])

    def angular_velocity(self, body, frame="body"):
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

    def point(self, body, point=(0.0, 0.0)):
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

    def point_velocity(self, body, point=(0.0, 0.0)):
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

    def point_acceleration(self, body, point=(0.0, 0.0)):
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

    def reaction(self, name):
        """Lagrange multipliers of a joint over time, shape (nt, nc_element).

        For a :class:`~femb.elements.Hinge` these are the force components the
        joint exerts on its body ``b`` (and minus that on body ``a``). See
        :meth:`reaction_at` for the force *and moment* at a point.

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

            from femb.initial import RedundantConstraintWarning
            eqs = ", ".join(eq for el, eq in removed if el == name)
            warnings.warn(f"joint '{name}': equation(s) {eqs} were removed as redundant (λ = 0 there); its "
                          "reaction is one admissible distribution among the dependent joints, not unique",
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

    def reaction_at(self, joint, point=None, on="b"):
        """Force and moment a joint exerts on one of its bodies, about a point, over time.

        Computed from the generalized constraint force −Φ_qᵀλ of the joint's
        own equations on the body's coordinates (x, y, θ): the force (F_x,
        F_y) and the moment about the body's node, moved to the point P by
        M_P = M_node + (r_node − r_P) × F. The force and moment on the other
        body are the opposite (about the same inertial point), since a joint's
        equations depend only on the relative position of its bodies.

        Parameters
        ----------
        joint : str
            A joint or driven constraint.
        point : str or (x, y), optional
            Point of body ``on`` (name or body-frame coordinates) about which
            the moment is taken; default: the joint's point on that body (its
            node for joints without one).
        on : {"b", "a"}
            The body the reaction acts on.

        Returns
        -------
        ndarray, shape (nt, 3)
            F_x, F_y (N) in the inertial frame and M_z (N·m, counter-clockwise);
            for a spatial joint shape (nt, 6): F_x, F_y, F_z (N) and M_x, M_y,
            M_z (N·m) in space axes, the moment about the point.
        """
        from femb import assembly

        idx = self._joint(joint)
        if on not in ("a", "b"):
            raise ModelError(f"reaction_at: on must be 'a' or 'b', got {on!r}")
        e = self._element(joint)
        m = self.model
        body = e.b if on == "b" else e.a
        other = e.a if on == "b" else e.b
        if getattr(getattr(body, "node", None), "rotation_blocks", ()):
            return self._reaction_at_spatial(e, idx, body, other, point, on)
        if point is None:
            s = getattr(e, "sb" if on == "b" else "sa", None)
            s = np.zeros(2) if s is None else np.asarray(s, dtype=float)
        else:
            s = body.local(point)
        free_idx = m.node_index[body.node.name]
        sign = 1.0
        src = body
        if not np.any(free_idx < m.nq):          # body fixed (ground): from the other body, opposite
            src, sign = other, -1.0
        sidx = m.node_index[src.node.name]
        out = np.zeros((self.t.size, 3))
        P = self._point_series(body.name, s)
        for k, (t, q, lam) in enumerate(zip(self.t, self.q, self.lam)):
            B = assembly.constraint_jacobian(m, t, q).tocsr()[idx]
            g = -(B.T @ lam[idx])
            gen = np.array([g[i] if i < m.nq else 0.0 for i in sidx])
            xs = m.node_coordinates(src.node.name, q)
            F = gen[:2]
            Mn = gen[2] if gen.size > 2 else 0.0
            d = xs[:2] - P[k]
            out[k, :2] = sign * F
            out[k, 2] = sign * (Mn + d[0] * F[1] - d[1] * F[0])
        return out

    def _frame_series(self, node):
        """(r (nt, 3), R (nt, 3, 3)) of a spatial node, fixed ones included."""
        from femb.rotations import quat_to_matrix
        x = self.model.node_coordinates(node.name, self.q)
        R = np.array([quat_to_matrix.py_func(np.ascontiguousarray(p)) for p in x[:, 3:7]])
        return x[:, 0:3], R

    def _reaction_at_spatial(self, e, idx, body, other, point, on):
        """:meth:`reaction_at` for spatial joints: (nt, 6) = force (N) and moment (N·m), space axes."""
        from femb import assembly

        m = self.model
        if point is None:
            s = np.asarray(getattr(e, "Xb" if on == "b" else "Xa", np.zeros(3)), dtype=float)
        else:
            s = np.asarray(body.local(point), dtype=float)
        sign, src = 1.0, body
        if not np.any(m.node_vindex[body.node.name] < m.nq):     # fixed body: from the other, opposite
            sign, src = -1.0, other
        r_b, R_b = self._frame_series(body.node)
        P = r_b + R_b @ s
        r_s, R_s = self._frame_series(src.node)
        vidx = m.node_vindex[src.node.name]
        out = np.zeros((self.t.size, 6))
        for k, (t, q, lam) in enumerate(zip(self.t, self.q, self.lam)):
            B = assembly.constraint_jacobian(m, t, q).tocsr()[idx]
            g = -(B.T @ lam[idx])
            gen = np.array([g[i] if i < m.nq else 0.0 for i in vidx])
            F = gen[0:3]
            M_node = R_s[k] @ gen[3:6]            # the rotation entries are body-axes moments
            out[k, 0:3] = sign * F
            out[k, 3:6] = sign * (M_node + np.cross(r_s[k] - P[k], F))
        return out

    def write_vtk(self, directory, every=1, basename="frame"):
        """Write the stored steps as a ParaView time series (``.pvd`` + ``.vtu``); returns the ``.pvd`` path."""
        from femb.io.frames import write_vtk

        return write_vtk(self, directory, every=every, basename=basename)

    def nearest(self, time):
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

    def at(self, time):
        """The state at ``time``, interpolated between the stored steps.

        q uses cubic Hermite interpolation with the stored q̇ (its error is of
        order Δt⁴ q⁽⁴⁾ for stored steps Δt apart), q̇ cubic Hermite with q̈;
        q̈ and λ are linear. At a stored time the stored values are returned
        exactly.

        Returns
        -------
        femb.model.State

        Raises
        ------
        ModelError
            If ``time`` is outside [t_0, t_end] of the stored steps.
        """
        from femb.model import State

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
    def energy(self):
        """Energies and their balance at every stored step (dict of (nt,) arrays, J); see :mod:`femb.energy`."""
        from femb.energy import energies

        return energies(self)

    def energy_balance(self):
        """Largest |energy balance| relative to the run's energy scale (see :func:`femb.energy.energy_balance`)."""
        from femb.energy import energy_balance

        return energy_balance(self)

    # ------------------------------------------------------------------ named outputs
    def outputs(self):
        """Names of the outputs :meth:`series` knows for this model (coordinates, velocities, multipliers)."""
        m = self.model
        names = []
        for lab in m.coord_labels:
            names += [lab, lab + "_d", lab + "_dd"]
        from femb.initial import constraint_labels
        names += [f"{el}.{eq}" for el, eq in constraint_labels(m)]
        names += [f"energy.{k}" for k in ("kinetic", "gravitational", "elastic", "work_loads",
                                          "work_drives", "dissipated", "total", "balance")]
        return names

    def series(self, name):
        """One named output over time: (values of shape (nt,), unit).

        Names
        -----
        ``"<body>.x"``, ``".y"``, ``".theta"``
            A coordinate (m, rad); append ``_d`` / ``_dd`` for its velocity /
            acceleration (``"bar.theta_d"``).
        ``"<body>.<point>.x"`` / ``".y"`` (and ``_d``, ``_dd``)
            A named point of a body (:meth:`point`, :meth:`point_velocity`,
            :meth:`point_acceleration`).
        ``"<joint>.<equation>"``
            A multiplier (``"pivot.x"``; equation names as in
            ``constraint_names`` of the joint type; unit from its
            ``constraint_units`` when the type declares them, e.g. N·m for the
            lock rows of spatial joints, else ``"λ"``).
        ``"<joint>.Fx"``, ``".Fy"``, ``".M"``
            Reaction force and moment on body b at the joint's point (:meth:`reaction_at`).
        ``"energy.<kind>"``
            An energy of :meth:`energy` (J).
        """
        m = self.model
        if not isinstance(name, str):
            raise ModelError(f"output names are strings, got {name!r}")
        if name.startswith("energy."):
            kind = name[len("energy."):]
            e = self.energy()
            if kind not in e:
                raise ModelError(f"unknown energy '{kind}' (known: {sorted(e)})")
            return e[kind], "J"
        # longest known name that prefixes the output name
        known = sorted(set(m.node_index) | set(m.lam_index) | set(m.bodies), key=len, reverse=True)
        owner = next((k for k in known if name.startswith(k + ".")), None)
        if owner is None:
            raise ModelError(f"output '{name}': no body, node or joint of that name (see Result.outputs())")
        rest = name[len(owner) + 1:]
        base, deriv = rest, 0
        for suffix, d in (("_dd", 2), ("_d", 1)):
            if rest.endswith(suffix):
                base, deriv = rest[:-len(suffix)], d
                break
        if owner in m.node_index:
            node_coords = None
            body = m.bodies.get(owner)
            coord_names = getattr(getattr(body, "node", None), "coord_names", ("x", "y", "theta"))
            if base in coord_names:
                node_coords = self.body(owner, ("q", "qd", "qdd")[deriv])
                i = list(coord_names).index(base)
                unit = ("rad" if base == "theta" else "m") + ("", "/s", "/s²")[deriv]
                return node_coords[:, i], unit
            if body is not None and "." in base:
                pt, comp = base.rsplit(".", 1)
                if pt in body.points and comp in ("x", "y"):
                    f = (self.point, self.point_velocity, self.point_acceleration)[deriv]
                    return f(owner, pt)[:, "xy".index(comp)], ("m", "m/s", "m/s²")[deriv]
        if owner in m.lam_index and deriv == 0:
            idx = m.lam_index[owner]
            if idx.size:
                from femb.initial import constraint_labels
                labels = constraint_labels(m)
                for i in idx:
                    if labels[i][1] == base:
                        return self.lam[:, i].copy(), _multiplier_unit(m, i)
                if base in ("Fx", "Fy", "M"):
                    r = self.reaction_at(owner)
                    return r[:, ("Fx", "Fy", "M").index(base)], ("N", "N", "N·m")[("Fx", "Fy", "M").index(base)]
        raise ModelError(f"output '{name}': '{owner}' has no output '{rest}' (see Result.outputs())")

    def to_pandas(self, outputs=None):
        """The outputs as a ``pandas.DataFrame`` indexed by time (column names as in :meth:`series`).

        Parameters
        ----------
        outputs : list of str, optional
            Output names; default: every coordinate, velocity and multiplier.

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
        data = {n: self.series(n)[0] for n in outputs}
        df = pd.DataFrame(data, index=pd.Index(np.asarray(self.t), name="t"))
        df.attrs["units"] = {n: self.series(n)[1] for n in outputs} if len(outputs) < 64 else {}
        return df

    def plot(self, outputs, file=None, *, title=None):
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
        from matplotlib.figure import Figure

        if isinstance(outputs, str):
            outputs = [outputs]
        outputs = list(outputs)
        if not outputs:
            raise ModelError("Result.plot: give at least one output name")
        series = [(n, *self.series(n)) for n in outputs]
        fig = Figure(figsize=(7.0, 1.9 * len(series) + 0.6), layout="constrained")
        axes = fig.subplots(len(series), 1, sharex=True, squeeze=False)[:, 0]
        xlabel = "load factor" if hasattr(self, "load_factor") else "t (s)"
        for ax, (n, v, unit) in zip(axes, series):
            ax.plot(self.t, v)
            ax.set_ylabel(f"{n} ({unit})")
            ax.grid(True, alpha=0.3)
        axes[-1].set_xlabel(xlabel)
        fig.suptitle(title or f"{self.model.name}")
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


def _multiplier_unit(model, i):
    """Unit of multiplier i: the joint type's ``constraint_units`` entry, or ``"λ"`` when it declares none."""
    for g in model.constraint_groups:
        units = tuple(getattr(g.cls, "constraint_units", ()) or ())
        for row in g.lam:
            for k, j in enumerate(row):
                if int(j) == i:
                    return units[k] if k < len(units) else "λ"
    return "λ"
