"""Spatial bodies: frame nodes on R³ × SO(3), rigid bodies, point masses, the ground.

A :class:`FrameNode` stores the configuration x = (r, p) — the inertial position r
(3) and a unit quaternion p = (p0, p1, p2, p3), scalar first (4) — and the
velocity v = (ṙ, Ω) — ṙ in space axes (3), Ω the angular velocity in *body* axes
(3), Ṙ = R Ω~. Rotations are perturbed on the right, R ← R exp(δθ~), so every
kernel Jacobian is taken with respect to the tangent increments (δr, δθ)
(Brüls & Cardona 2010; ``docs/spatial.md``).

A :class:`SpatialRigidBody` owns a frame node at its centre of mass: its mass
matrix is the constant diag(m I₃, J) (J about the centre of mass in body axes)
and its only velocity-dependent force is the gyroscopic moment −Ω × JΩ
(Géradin & Cardona 2001, Ch. 8). A :class:`SpatialPointMass` owns a frame node
whose rotation is fixed (3 free coordinates). The ground of a mechanism is seen
by spatial elements through :func:`spatial_ground`: a fully fixed frame node at
the origin with the identity rotation.

References
----------
O. Brüls, A. Cardona, On the use of Lie group time integrators in multibody
dynamics, J. Comput. Nonlinear Dynam. 5(3):031002, 2010.
M. Géradin, A. Cardona, Flexible Multibody Dynamics, Wiley, 2001.
"""
from __future__ import annotations

import numpy as np

from femb.base import rotations as rt
from femb.base.geometry import GeometryBlock
from femb.base.jit import kernel
from femb.errors import ModelError
from femb.system.element import Element
from femb.system.nodes import Node

from . import _spatial_geometry as sg
from .bodies import Body, Ground, _check_scalar


def vector3(owner, what, value):
    """A finite 3-vector (ndarray) or a ModelError naming ``owner`` and ``what``."""
    try:
        v = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ModelError(f"{owner}: {what} must be three numbers, got {value!r}") from None
    if v.size != 3 or not np.all(np.isfinite(v)):
        raise ModelError(f"{owner}: {what} must be three finite numbers, got {value!r}")
    return v


def unit3(owner, what, value):
    """A unit 3-vector from a non-zero finite 3-vector."""
    v = vector3(owner, what, value)
    n = np.linalg.norm(v)
    if n == 0.0:
        raise ModelError(f"{owner}: {what} must be a non-zero vector, got {value!r}")
    return v / n


#: largest |‖p‖ − 1| of a quaternion given as input (rounding of printed values); beyond it, an error
QUATERNION_NORM_TOL = 1e-6


def rotation_input(owner, what, value):
    """A unit quaternion (4,) from a quaternion (4 numbers) or a 3×3 rotation matrix.

    A quaternion must have unit norm to within ``QUATERNION_NORM_TOL`` (then it is
    normalised to round-off); any other is refused: a quaternion of another
    length is most often a different input (an axis, a rotation vector, a
    typo), and normalising it would silently run another initial rotation.

    Raises
    ------
    ModelError
        Naming ``owner`` and ``what``: not finite, wrong shape, zero or
        non-unit quaternion, or a matrix that is not a rotation.
    """
    if value is None:
        return np.array([1.0, 0.0, 0.0, 0.0])
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{owner}: {what} must be a quaternion (4 numbers) or a 3×3 rotation "
                         f"matrix, got {value!r}") from None
    if not np.all(np.isfinite(a)):
        raise ModelError(f"{owner}: {what} must be finite, got {value!r}")
    if a.shape == (4,):
        n = np.linalg.norm(a)
        if n == 0.0:
            raise ModelError(f"{owner}: {what}: the zero quaternion is not a rotation")
        if abs(n - 1.0) > QUATERNION_NORM_TOL:
            raise ModelError(f"{owner}: {what} {a.tolist()} is not a unit quaternion (norm {n:.6g}): give the unit "
                             "quaternion (p0, p1, p2, p3), scalar first, e.g. p / |p| if this is the intended "
                             "direction, or a 3×3 rotation matrix")
        return a / n
    if a.shape == (3, 3):
        if not (np.allclose(a @ a.T, np.eye(3), atol=1e-9) and np.linalg.det(a) > 0):
            raise ModelError(f"{owner}: {what} is not a rotation matrix (RRᵀ ≠ I or det R ≠ 1)")
        return rt.matrix_to_quat(np.ascontiguousarray(a))
    raise ModelError(f"{owner}: {what} must be a quaternion (4 numbers) or a 3×3 rotation matrix, "
                     f"got shape {a.shape}")


class FrameNode(Node):
    """A spatial frame node on R³ × SO(3): x = (r, p) (7), v = (ṙ, Ω) (6).

    Parameters
    ----------
    name : str
    position : (3,)
        Initial position r (m).
    rotation : (4,) quaternion or (3, 3) matrix, optional
        Initial rotation (body to space); default identity.
    velocity : (3,), optional
        Initial ṙ (space axes).
    omega : (3,), optional
        Initial angular velocity in *body* axes.
    fixed_translation : (3,) bool, optional
        Translations held at their initial value.
    fixed_rotation : bool, optional
        The rotation is held (the quaternion is a fixed coordinate block and
        Ω ≡ 0); a rotation is either entirely free or entirely fixed.

    Attributes
    ----------
    q0 : ndarray (7,)     initial x
    qd0 : ndarray (6,)    initial v
    fixed : ndarray (7,) bool    fixed entries of x
    fixed_v : ndarray (6,) bool  fixed entries of v
    kind : ``"frame"``
        Class attributes from here on: what the model compiler and the time loop need.
    coord_names : 7 names of the configuration entries x.
    velocity_names : 6 names of the velocity / tangent entries v.
    nx, nv : 7, 6.
    translational : (0, 1, 2)
        Indices (in x and in v alike) of the translations along the inertial
        axes (gravity acts on them).
    rotation_blocks : ((3, 3),)
        For each rotation of the node: (start in x of its unit quaternion, 4
        entries; start in v of its body-axes rotation vector, 3 entries). The
        update is p ← p ⊗ quat(exp(δθ)) (renormalised), the tangent operator
        T(δθ) of :mod:`femb.base.rotations` multiplies these columns.
    compose, tangent, bracket :
        The group operations as compiled functions: ``compose(x, d)`` (7,),
        ``tangent(d)`` (6, 6), ``bracket(v, w)`` (6,)
        (:func:`femb.base.rotations.frame_compose`, ``frame_tangent``, ``frame_bracket``).
    """

    kind = "frame"
    coord_names = ("x", "y", "z", "p0", "p1", "p2", "p3")
    velocity_names = ("vx", "vy", "vz", "Omega_x", "Omega_y", "Omega_z")
    nx = 7
    nv = 6
    translational = (0, 1, 2)
    rotation_blocks = ((3, 3),)
    compose = staticmethod(rt.frame_compose)
    tangent = staticmethod(rt.frame_tangent)
    bracket = staticmethod(rt.frame_bracket)

    def __init__(self, name, position=(0.0, 0.0, 0.0), rotation=None, velocity=(0.0, 0.0, 0.0),
                 omega=(0.0, 0.0, 0.0), fixed_translation=(False, False, False), fixed_rotation=False):
        owner = f"node '{name}'"
        self.name = str(name)
        r = vector3(owner, "position", position)
        p = rotation_input(owner, "rotation", rotation)
        self.q0 = np.concatenate((r, p))
        self.qd0 = np.concatenate((vector3(owner, "velocity", velocity), vector3(owner, "omega", omega)))
        ft = np.asarray(fixed_translation, dtype=bool).reshape(-1)
        if ft.size != 3:
            raise ModelError(f"{owner}: fixed_translation must be three booleans, got {fixed_translation!r}")
        fr = bool(fixed_rotation)
        self.fixed = np.concatenate((ft, np.full(4, fr)))
        self.fixed_v = np.concatenate((ft, np.full(3, fr)))
        if np.any(self.qd0[self.fixed_v] != 0.0):
            raise ModelError(f"{owner}: a fixed coordinate cannot have a non-zero velocity")

    @property
    def ncoord(self):
        return self.nx

    @property
    def rotation0(self):
        """Initial rotation matrix, shape (3, 3)."""
        return rt.quat_to_matrix(self.q0[3:7])


class SpatialBody(Body):
    """Anything spatial joints attach to: owns a :class:`FrameNode`, named points and axes.

    Attributes
    ----------
    node : FrameNode
    points : dict of str to ndarray (3,)
        Named points in body axes, relative to the node.
    axes : dict of str to ndarray (3,)
        Named unit vectors in body axes.
    shape : dict or None
        Drawing shape for output (``{"type": "box", "size": (a, b, c)}``,
        ``{"type": "cylinder", "radius": r, "length": l, "axis": (3,)}`` (axis in
        body axes, default body x), ``{"type": "sphere", "radius": r}``; None or
        ``{"type": "hull"}``: the convex hull of the named points and the node),
        unused by the kernels; checked by
        :func:`~femb.elements._spatial_geometry.check_shape`.
    """

    #: acts on spatial frame nodes (femb.system.model refuses planar elements on them)
    spatial = True

    def _init_body(self, name, node, points=None, axes=None, shape=None):
        self.node = node
        owner = f"body '{name}'"
        self.points = {str(k): vector3(owner, f"point '{k}'", v) for k, v in (points or {}).items()}
        self.axes = {str(k): unit3(owner, f"axis '{k}'", v) for k, v in (axes or {}).items()}
        self.shape = sg.check_shape(f"{type(self).__name__} '{name}'", shape)

    # body-frame quantities from names or inertial values at t0
    def local(self, spec, role="point"):
        """Body-axes coordinates (relative to the node) of a point name or a 3-vector."""
        if isinstance(spec, str):
            try:
                return self.points[spec]
            except KeyError:
                raise ModelError(f"body '{self.name}' has no point named '{spec}' "
                                 f"(known: {sorted(self.points) or 'none'})") from None
        return vector3(f"body '{self.name}'", role, spec)

    def local_from_global(self, xyz):
        """Body-axes coordinates of an inertial point in the initial configuration."""
        d = vector3(f"body '{self.name}'", "global point", xyz) - self.node.q0[:3]
        return self.node.rotation0.T @ d

    def axis_global(self, spec, role="axis"):
        """Inertial direction at t0 of a named body axis or of an inertial 3-vector (unit)."""
        if isinstance(spec, str):
            try:
                return self.node.rotation0 @ self.axes[spec]
            except KeyError:
                raise ModelError(f"body '{self.name}' has no axis named '{spec}' "
                                 f"(known: {sorted(self.axes) or 'none'})") from None
        return unit3(f"body '{self.name}'", role, spec)

    def global_point(self, spec, x=None):
        """Inertial coordinates of a body point for node coordinates x (7,) (default: initial)."""
        x = self.node.q0 if x is None else np.asarray(x, dtype=float)
        return x[:3] + rt.quat_to_matrix(np.ascontiguousarray(x[3:7])) @ self.local(spec)

    def outline(self):  # planar drawing does not apply
        raise ModelError(f"body '{self.name}' is spatial: it has no planar outline")


class SpatialGround(SpatialBody):
    """The inertial frame as seen by spatial elements: a fully fixed frame node.

    Created by :func:`spatial_ground` for a mechanism's ground (one per
    mechanism, sharing its name); its node ``<ground>.frame`` sits at the
    origin with the identity rotation.
    """

    def __init__(self, name="ground", points=None):
        self.name = name
        self._init_body(name, FrameNode(f"{name}.frame", fixed_translation=(True, True, True),
                                        fixed_rotation=True), points)

    def add_point(self, name, xyz):
        """Add a named ground point (inertial coordinates); returns its name."""
        self.points[str(name)] = vector3(f"ground '{self.name}'", f"point '{name}'", xyz)
        return name


def spatial_ground(ground):
    """The spatial twin of a mechanism's ground (a :class:`Mechanism` or its ``ground``).

    Spatial elements given ``"ground"`` or ``mech.ground`` attach to this twin:
    a :class:`SpatialGround` with a fully fixed frame node, created on first use
    and stored on the ground, so all spatial elements of a mechanism share it.
    """
    g = getattr(ground, "ground", ground)
    if isinstance(g, SpatialGround):
        return g
    if not isinstance(g, Ground):
        raise ModelError(f"spatial_ground: expected a Mechanism or its ground, got {ground!r}")
    twin = getattr(g, "_spatial_twin", None)
    if twin is None:
        twin = SpatialGround(g.name)
        g._spatial_twin = twin
    return twin


# ---------------------------------------------------------------------------
# rigid body kernels
# ---------------------------------------------------------------------------
@kernel
def rigid_body_mass(P, xe, Me):
    """Me = diag(m I₃, J); P = (m, J row-major (9))."""
    for e in range(xe.shape[0]):
        for i in range(3):
            Me[e, i, i] = P[e, 0]
            for j in range(3):
                Me[e, 3 + i, 3 + j] = P[e, 1 + 3 * i + j]


@kernel
def rigid_body_force(P, t, tf, xe, ve, jac, fe, fq, fv):
    """Gyroscopic moment f_θ = −Ω × JΩ; fv(θ, Ω) = −(Ω~J − (JΩ)~); fq = 0."""
    for e in range(xe.shape[0]):
        w0, w1, w2 = ve[e, 3], ve[e, 4], ve[e, 5]
        h0 = P[e, 1] * w0 + P[e, 2] * w1 + P[e, 3] * w2
        h1 = P[e, 4] * w0 + P[e, 5] * w1 + P[e, 6] * w2
        h2 = P[e, 7] * w0 + P[e, 8] * w1 + P[e, 9] * w2
        fe[e, 3] = -(w1 * h2 - w2 * h1)
        fe[e, 4] = -(w2 * h0 - w0 * h2)
        fe[e, 5] = -(w0 * h1 - w1 * h0)
        if jac:
            # ∂(Ω × h)/∂Ω = Ω~J − h~
            for j in range(3):
                J0, J1, J2 = P[e, 1 + j], P[e, 4 + j], P[e, 7 + j]      # column j of J
                fv[e, 3, 3 + j] = -(w1 * J2 - w2 * J1)
                fv[e, 4, 3 + j] = -(w2 * J0 - w0 * J2)
                fv[e, 5, 3 + j] = -(w0 * J1 - w1 * J0)
            fv[e, 3, 4] += -h2
            fv[e, 3, 5] += h1
            fv[e, 4, 3] += h2
            fv[e, 4, 5] += -h0
            fv[e, 5, 3] += -h1
            fv[e, 5, 4] += h0


def inertia_tensor(owner, value):
    """A symmetric positive definite 3×3 inertia tensor from 3 principal values or a 3×3 matrix."""
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{owner}: inertia must be 3 numbers or a 3×3 matrix, got {value!r}") from None
    if a.shape == (3,):
        a = np.diag(a)
    if a.shape != (3, 3) or not np.all(np.isfinite(a)):
        raise ModelError(f"{owner}: inertia must be 3 finite numbers or a finite 3×3 matrix, got {value!r}")
    if not np.allclose(a, a.T, rtol=1e-12, atol=1e-14 * np.abs(a).max()):
        raise ModelError(f"{owner}: inertia tensor must be symmetric")
    ev = np.linalg.eigvalsh(a)
    if ev[0] <= 0.0:
        raise ModelError(f"{owner}: inertia tensor must be positive definite (eigenvalues {ev.tolist()})")
    # triangle inequality of principal moments (a physical body)
    if ev[2] > ev[0] + ev[1] + 1e-12 * ev[2]:
        raise ModelError(f"{owner}: principal moments {ev.tolist()} violate the triangle inequality "
                         "J3 ≤ J1 + J2 of a physical body")
    return 0.5 * (a + a.T)


class SpatialRigidBody(SpatialBody, Element):
    """A spatial rigid body; its frame node is the centre of mass.

    Parameters
    ----------
    name : str
    mass : float > 0
        Mass (kg).
    inertia : (3,) or (3, 3)
        Inertia tensor about the centre of mass in body axes (kg m²): principal
        values (diagonal) or the full symmetric matrix.
    position : (3,)
        Initial centre of mass (m).
    rotation : (4,) quaternion or (3, 3) matrix, optional
        Initial rotation, body to space (default identity).
    velocity : (3,), optional
        Initial centre-of-mass velocity (space axes).
    omega : (3,), optional
        Initial angular velocity in body axes. Give ``omega_space`` instead for
        space axes (Ω0 = R0ᵀ ω0).
    omega_space : (3,), optional
    points : dict of str to (3,), optional
        Named points in body axes, relative to the centre of mass.
    axes : dict of str to (3,), optional
        Named directions in body axes (normalised).
    shape : dict, optional
        Drawing shape (see :class:`SpatialBody`).
    inertia_at : str or (3,), optional
        The point (name or body-axes coordinates relative to the centre of
        mass) about which ``inertia`` is given; it is moved to the centre of
        mass by the parallel-axis theorem, J_C = J_P − m(|d|²I − ddᵀ).

    Notes
    -----
    Kernels: ``mass`` :func:`rigid_body_mass` (constant), ``force``
    :func:`rigid_body_force` (gyroscopic moment, depends on v). ``P = (m, J (9))``.
    """

    glyph = {"": "body", "Frame": "body_frame"}   # the drawing and the body frames (femb.io.frames)

    has_mass = True
    constant_mass = True
    has_force = True
    force_depends_on_qd = True
    work = "none"                     # the gyroscopic moment does no work (Ω·(Ω × JΩ) = 0)
    kernels = {"mass": rigid_body_mass, "force": rigid_body_force}

    def __init__(self, name, mass, inertia, position=(0.0, 0.0, 0.0), rotation=None,
                 velocity=(0.0, 0.0, 0.0), omega=None, omega_space=None, points=None, axes=None,
                 shape=None, inertia_at=None):
        Element.__init__(self, name)
        owner = f"SpatialRigidBody '{name}'"
        self.m = _check_scalar(owner, "mass", mass, positive=True)
        if inertia_at is None:
            self.J = inertia_tensor(owner, inertia)
        else:
            pts = {str(k): vector3(owner, f"point '{k}'", v) for k, v in (points or {}).items()}
            if isinstance(inertia_at, str):
                if inertia_at not in pts:
                    raise ModelError(f"{owner}: inertia_at names no point ('{inertia_at}'; known: {sorted(pts)})")
                d = pts[inertia_at]
            else:
                d = vector3(owner, "inertia_at", inertia_at)
            Jp = np.asarray(inertia, dtype=float)
            Jp = np.diag(Jp) if Jp.shape == (3,) else Jp
            self.J = inertia_tensor(owner, Jp - self.m * (d @ d * np.eye(3) - np.outer(d, d)))
        p = rotation_input(owner, "rotation", rotation)
        if omega is not None and omega_space is not None:
            raise ModelError(f"{owner}: give omega (body axes) or omega_space, not both")
        if omega_space is not None:
            om = rt.quat_to_matrix(p).T @ vector3(owner, "omega_space", omega_space)
        else:
            om = vector3(owner, "omega", (0.0, 0.0, 0.0) if omega is None else omega)
        node = FrameNode(name, position, p, velocity, om)
        self._init_body(name, node, points, axes, shape)

    def nodes(self):
        return [self.node]

    @classmethod
    def pack(cls, elements):
        """``P = (m, J (9))`` (nel, 10), plus masses, inertias and the drawing tables of :meth:`geometry`."""
        P = np.array([[e.m, *e.J.reshape(-1)] for e in elements], dtype=float)
        p = {"P": np.ascontiguousarray(P), "m": P[:, 0].copy(), "J": P[:, 1:].reshape(-1, 3, 3).copy(),
             "body_id": np.arange(len(elements))}
        p.update(_pack_outlines([sg.outline(e.shape, e.points, e.m, e.J) for e in elements]))
        return p

    @classmethod
    def geometry(cls, p, t, qe, qde, lame, names):
        """Surfaces of the bodies and a block of body frames.

        Parameters
        ----------
        p : dict
            From :meth:`pack`.
        t : float
        qe : ndarray, shape (nel, 7)
            (r, p) of each body.
        qde : ndarray, shape (nel, 6)
            (ṙ, Ω), Ω in body axes.
        lame : ndarray, shape (nel, 0)
        names : list of str

        Returns
        -------
        list of GeometryBlock
            ``SpatialRigidBody``: each body's drawing (triangles, or a polygon
            fan / segment for degenerate point sets) at r + R(p) X with point
            data ``velocity`` ṙ + R(Ω × X) (m/s, space axes) and cell data
            ``body_id`` and ``mass`` (kg). ``SpatialRigidBodyFrame``: one vertex
            per body at r with point data ``e1``, ``e2``, ``e3`` (the columns
            of R scaled to the body's size, m), ``omega`` (RΩ, rad/s, space
            axes) and ``velocity`` ṙ.
        """
        qe = np.asarray(qe, dtype=float)
        qde = np.asarray(qde, dtype=float)
        return [_outline_block(cls.__name__, p, qe, qde), _frame_block(cls.__name__ + "Frame", p, qe, qde)]


@kernel
def point_mass_mass(P, xe, Me):
    """Me = diag(m I₃, 0); P = (m,)."""
    for e in range(xe.shape[0]):
        for i in range(3):
            Me[e, i, i] = P[e, 0]


class SpatialPointMass(SpatialBody, Element):
    """A spatial point mass: a frame node with its rotation fixed (3 free coordinates).

    Joints and forces see it as a frame with the identity rotation, so the
    same kernels serve; a rotation lock to a point mass is meaningless (a
    rotational constraint would remove nothing and make the model singular).

    Parameters
    ----------
    name : str
    mass : float > 0
    position, velocity : (3,)
    points : dict, optional
        Named offsets (they do not rotate).
    """

    glyph = "point_mass"

    has_mass = True
    constant_mass = True
    kernels = {"mass": point_mass_mass}

    def __init__(self, name, mass, position=(0.0, 0.0, 0.0), velocity=(0.0, 0.0, 0.0), points=None,
                 shape=None):
        Element.__init__(self, name)
        owner = f"SpatialPointMass '{name}'"
        self.m = _check_scalar(owner, "mass", mass, positive=True)
        node = FrameNode(name, position, None, velocity, fixed_rotation=True)
        self._init_body(name, node, points, None, shape)

    def nodes(self):
        return [self.node]

    @classmethod
    def pack(cls, elements):
        P = np.array([[e.m] for e in elements], dtype=float)
        return {"P": P, "m": P[:, 0].copy(), "body_id": np.arange(len(elements))}

    @classmethod
    def geometry(cls, p, t, qe, qde, lame, names):
        """One vertex per point mass at r (qe (nel, 7)) with point data ``velocity`` ṙ
        (qde (nel, 6), m/s) and cell data ``body_id`` and ``mass`` (kg)."""
        qe = np.asarray(qe, dtype=float)
        n = qe.shape[0]
        return [GeometryBlock(cls.__name__, qe[:, 0:3].copy(), [("vertex", sg.vertex_cells(n))],
                              point_data={"velocity": np.asarray(qde, dtype=float)[:, 0:3].copy()},
                              cell_data={"body_id": [p["body_id"].copy()], "mass": [p["m"].copy()]})]


def _pack_outlines(outlines):
    """Stack per-body drawings (verts, triangles, lines) into batch tables (global indices)."""
    local, owner, tri, tri_owner, lines, line_owner = [], [], [], [], [], []
    start = 0
    scale = np.empty(len(outlines))
    for k, (verts, t, ln) in enumerate(outlines):
        local.append(verts)
        owner.append(np.full(len(verts), k, dtype=np.int64))
        tri.append(t + start)
        tri_owner.append(np.full(len(t), k, dtype=np.int64))
        lines.append(ln + start)
        line_owner.append(np.full(len(ln), k, dtype=np.int64))
        start += len(verts)
        ext = float(np.max(np.linalg.norm(verts, axis=1))) if len(verts) else 0.0
        scale[k] = ext if ext > 0.0 else 0.1
    return {"outline_local": np.concatenate(local), "outline_owner": np.concatenate(owner),
            "outline_triangles": np.concatenate(tri).reshape(-1, 3),
            "outline_triangle_body": np.concatenate(tri_owner),
            "outline_lines": np.concatenate(lines).reshape(-1, 2),
            "outline_line_body": np.concatenate(line_owner), "frame_scale": scale}


def _outline_block(name, p, qe, qde):
    own = p["outline_owner"]
    pos, vel = sg.material_points(qe[own], qde[own], p["outline_local"])
    cells, ids, mass = [], [], []
    for kind, conn, body in (("triangle", p["outline_triangles"], p["outline_triangle_body"]),
                             ("line", p["outline_lines"], p["outline_line_body"])):
        if len(conn):
            cells.append((kind, conn))
            ids.append(p["body_id"][body])
            mass.append(p["m"][body])
    return GeometryBlock(name, pos, cells, point_data={"velocity": vel},
                         cell_data={"body_id": ids, "mass": mass})


def _frame_block(name, p, qe, qde):
    R = sg.rotation_matrices(qe[:, 3:7])
    s = p["frame_scale"][:, None]
    n = qe.shape[0]
    pd = {"e1": R[:, :, 0] * s, "e2": R[:, :, 1] * s, "e3": R[:, :, 2] * s,
          "omega": sg.rotate(R, qde[:, 3:6]), "velocity": qde[:, 0:3].copy()}
    return GeometryBlock(name, qe[:, 0:3].copy(), [("vertex", sg.vertex_cells(n))], point_data=pd,
                         cell_data={"body_id": [p["body_id"].copy()], "mass": [p["m"].copy()]})


def box_inertia(mass, a, b, c):
    """Principal inertia (about the centre) of a homogeneous cuboid with edges a, b, c along x, y, z."""
    m = float(mass)
    return np.array([m * (b * b + c * c), m * (a * a + c * c), m * (a * a + b * b)]) / 12.0


def rod_inertia(mass, length, radius=0.0):
    """Principal inertia of a homogeneous cylinder along body x (radius 0: a slender rod)."""
    m, L, r = float(mass), float(length), float(radius)
    it = m * (3 * r * r + L * L) / 12.0
    return np.array([0.5 * m * r * r, it, it])


__all__ = ["FrameNode", "SpatialBody", "SpatialGround", "spatial_ground", "SpatialRigidBody",
           "SpatialPointMass", "rigid_body_mass", "rigid_body_force", "point_mass_mass",
           "box_inertia", "rod_inertia"]
