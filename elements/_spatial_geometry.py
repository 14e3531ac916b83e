"""Output geometry of spatial elements (plain numpy, not performance critical).

Helpers shared by the ``geometry`` class methods of the spatial bodies, joints
and forces: drawing shapes in body axes (box, cylinder, sphere, or the convex
hull of a body's named points), rotation matrices of many frame nodes at once,
and the reduction of a generalized force on a frame node to a force and a
moment about a point.

Conventions (``docs/spatial.md``): x = (r, p) with p a unit quaternion, scalar
first, R(p) body → space; v = (ṙ, Ω) with Ω in body axes. A generalized force
on a node, (f_r, f_θ), has f_r in space axes and f_θ a moment about the node in
body axes.
"""
from __future__ import annotations

import math

import numpy as np

from femb.errors import ModelError

#: shape types of spatial bodies (``SpatialBody.shape["type"]``)
SHAPE_TYPES = ("box", "cylinder", "sphere", "hull")
#: segments around a cylinder, meridians and parallels of a sphere
N_AROUND = 24
N_SPHERE = (16, 9)


# ---------------------------------------------------------------------------
# shapes
# ---------------------------------------------------------------------------
def _positive(owner, what, value):
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ModelError(f"{owner}: shape {what} must be a number, got {value!r}") from None
    if not (v > 0.0 and math.isfinite(v)):
        raise ModelError(f"{owner}: shape {what} must be positive and finite, got {value!r}")
    return v


def check_shape(owner, shape):
    """A validated copy of a spatial drawing shape, or None.

    Parameters
    ----------
    owner : str
        Name used in error messages (e.g. ``"body 'crank'"``).
    shape : dict or None
        ``{"type": "box", "size": (a, b, c)}`` (edges along body x, y, z, m);
        ``{"type": "cylinder", "radius": r, "length": l, "axis": (3,)}``
        (centred on the node, ``axis`` in body axes, default body x);
        ``{"type": "sphere", "radius": r}``; ``{"type": "hull"}`` or None: the
        convex hull of the named points and the node.

    Returns
    -------
    dict or None
        With floats and, for a cylinder, a unit ``axis`` (3,).

    Raises
    ------
    ModelError
        Unknown type, missing or non-positive sizes.
    """
    if shape is None:
        return None
    if not isinstance(shape, dict):
        raise ModelError(f"{owner}: shape must be a dict such as {{'type': 'box', 'size': (a, b, c)}}, "
                         f"got {shape!r}")
    typ = shape.get("type")
    if typ not in SHAPE_TYPES:
        raise ModelError(f"{owner}: unknown spatial shape type {typ!r} (expected one of "
                         f"{', '.join(SHAPE_TYPES)})")
    out = {"type": typ}
    try:
        if typ == "box":
            size = np.asarray(shape["size"], dtype=float).reshape(-1)
            if size.size != 3:
                raise ModelError(f"{owner}: box size must be three edge lengths (a, b, c), got "
                                 f"{shape['size']!r}")
            out["size"] = np.array([_positive(owner, "size", s) for s in size])
        elif typ == "cylinder":
            out["radius"] = _positive(owner, "radius", shape["radius"])
            out["length"] = _positive(owner, "length", shape["length"])
            ax = np.asarray(shape.get("axis", (1.0, 0.0, 0.0)), dtype=float).reshape(-1)
            n = np.linalg.norm(ax) if ax.size == 3 else 0.0
            if not (n > 0.0 and math.isfinite(n)):
                raise ModelError(f"{owner}: cylinder axis must be a non-zero 3-vector, got "
                                 f"{shape.get('axis')!r}")
            out["axis"] = ax / n
        elif typ == "sphere":
            out["radius"] = _positive(owner, "radius", shape["radius"])
    except KeyError as exc:
        raise ModelError(f"{owner}: {typ} shape needs {exc.args[0]!r}") from None
    except (TypeError, ValueError) as exc:
        if isinstance(exc, ModelError):
            raise
        raise ModelError(f"{owner}: invalid {typ} shape {shape!r} ({exc})") from None
    return out


def _orthonormal(a):
    """Two unit vectors completing the unit vector a to a right-handed basis."""
    k = int(np.argmin(np.abs(a)))
    h = np.zeros(3)
    h[k] = 1.0
    e1 = np.cross(a, h)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(a, e1)


def box_points(size, axes=None):
    """The 8 corners (8, 3) of a box with edges ``size`` along the columns of ``axes`` (default I)."""
    a, b, c = 0.5 * np.asarray(size, dtype=float)
    corners = np.array([[x, y, z] for x in (-a, a) for y in (-b, b) for z in (-c, c)])
    return corners if axes is None else corners @ np.asarray(axes).T


def cylinder_points(radius, length, axis):
    """Two rings of ``N_AROUND`` points (2 N_AROUND, 3), centred on the origin."""
    e1, e2 = _orthonormal(np.asarray(axis, dtype=float))
    ang = np.linspace(0.0, 2.0 * math.pi, N_AROUND, endpoint=False)
    ring = radius * (np.outer(np.cos(ang), e1) + np.outer(np.sin(ang), e2))
    h = 0.5 * length * np.asarray(axis, dtype=float)
    return np.vstack((ring - h, ring + h))


def sphere_points(radius):
    """A latitude–longitude point set on a sphere, poles included, shape (k, 3)."""
    nlon, nlat = N_SPHERE
    lat = np.linspace(0.0, math.pi, nlat)[1:-1]
    lon = np.linspace(0.0, 2.0 * math.pi, nlon, endpoint=False)
    la, lo = np.meshgrid(lat, lon, indexing="ij")
    pts = np.column_stack((np.sin(la).ravel() * np.cos(lo).ravel(),
                           np.sin(la).ravel() * np.sin(lo).ravel(), np.cos(la).ravel()))
    return radius * np.vstack(([0.0, 0.0, 1.0], pts, [0.0, 0.0, -1.0]))


def inertia_box(mass, J):
    """Edges (3,) and axes (3, 3) (columns) of the homogeneous box with mass ``mass`` and inertia J.

    From the principal moments J_i = m (b² + c²)/12 ...: a² = 6 (J_2 + J_3 − J_1)/m;
    edges are kept at least 5 % of the longest (a flat or slender body stays visible).
    """
    ev, V = np.linalg.eigh(np.asarray(J, dtype=float))
    a2 = 6.0 * (ev.sum() - 2.0 * ev) / float(mass)
    edges = np.sqrt(np.maximum(a2, 0.0))
    edges = np.maximum(edges, 0.05 * max(edges.max(), 1e-12))
    if np.linalg.det(V) < 0:
        V[:, 2] *= -1.0
    return edges, V


def surface(points):
    """A closed triangulated surface (or lower-dimensional stand-in) through a point set.

    Parameters
    ----------
    points : ndarray, shape (k, 3)

    Returns
    -------
    verts : ndarray, shape (m, 3)
        The vertices used (a subset of ``points`` or, for collinear points, the
        two extreme points).
    triangles : ndarray, shape (nt, 3)
        Outward-oriented triangles of the convex hull (points spanning 3-D),
        or a triangle fan of the planar hull (coplanar points); may be empty.
    lines : ndarray, shape (nl, 2)
        One segment between the extreme points of collinear points; else empty.
    None
        When the points do not span a line (a single point): the caller picks
        a stand-in.
    """
    pts = np.unique(np.round(np.asarray(points, dtype=float).reshape(-1, 3), 14), axis=0)
    none2 = np.zeros((0, 2), dtype=np.int64)
    none3 = np.zeros((0, 3), dtype=np.int64)
    if len(pts) < 2:
        return None
    c = pts.mean(axis=0)
    _, sv, Vt = np.linalg.svd(pts - c)
    tol = 1e-9 * sv[0]
    rank = int(np.sum(sv > tol))
    if rank == 0:
        return None
    if rank >= 3 and len(pts) >= 4:
        try:
            from scipy.spatial import ConvexHull
            hull = ConvexHull(pts)
        except Exception:           # Qhull failure (nearly flat sets): lower dimension below
            hull = None
        if hull is not None:
            keep = np.unique(hull.simplices)
            new = np.full(len(pts), -1, dtype=np.int64)
            new[keep] = np.arange(keep.size)
            tri = hull.simplices.astype(np.int64).copy()
            a, b, cc = pts[tri[:, 0]], pts[tri[:, 1]], pts[tri[:, 2]]
            flip = np.einsum("ij,ij->i", np.cross(b - a, cc - a), hull.equations[:, :3]) < 0.0
            tri[flip] = tri[flip][:, [0, 2, 1]]
            return pts[keep], new[tri], none2
        rank = 2
    if rank >= 2:
        uv = (pts - c) @ Vt[:2].T
        try:
            from scipy.spatial import ConvexHull
            ring = ConvexHull(uv).vertices          # counter-clockwise in (u, v)
        except Exception:
            ring = None
        if ring is not None and len(ring) >= 3:
            fan = np.column_stack((np.zeros(len(ring) - 2, dtype=np.int64),
                                   np.arange(1, len(ring) - 1), np.arange(2, len(ring))))
            return pts[ring], fan, none2
    # collinear: the segment between the extreme points
    s = (pts - c) @ Vt[0]
    ends = np.array([c + s.min() * Vt[0], c + s.max() * Vt[0]])
    return ends, none3, np.array([[0, 1]], dtype=np.int64)


def outline(shape, points, mass=None, J=None, fallback_size=0.05):
    """Drawing of one spatial body in body axes: (verts (m, 3), triangles (nt, 3), lines (nl, 2)).

    ``shape`` a validated shape (:func:`check_shape`) or None: box, cylinder and
    sphere are triangulated through their convex hull; None / ``"hull"`` uses
    the named ``points`` (dict or (k, 3)) and the node (origin). Degenerate
    point sets give a polygon (coplanar), a segment (collinear); a lone node
    gives the inertia-equivalent box (:func:`inertia_box`) when ``mass`` and
    ``J`` are known, else a cube of edge ``fallback_size``.
    """
    typ = (shape or {}).get("type", "hull")
    if typ == "box":
        cloud = box_points(shape["size"])
    elif typ == "cylinder":
        cloud = cylinder_points(shape["radius"], shape["length"], shape["axis"])
    elif typ == "sphere":
        cloud = sphere_points(shape["radius"])
    else:
        vals = list(points.values()) if isinstance(points, dict) else list(np.asarray(points).reshape(-1, 3))
        cloud = np.vstack([np.zeros(3)] + [np.asarray(v, dtype=float) for v in vals])
    out = surface(cloud)
    if out is None:
        if mass is not None and J is not None:
            edges, axes = inertia_box(mass, J)
            cloud = box_points(edges, axes)
        else:
            cloud = box_points((fallback_size,) * 3)
        out = surface(cloud)
    return out


# ---------------------------------------------------------------------------
# kinematics of many frames
# ---------------------------------------------------------------------------
def rotation_matrices(p):
    """R(p) for many quaternions: p (n, 4) scalar first (normalised here) -> (n, 3, 3)."""
    p = np.asarray(p, dtype=float).reshape(-1, 4)
    p = p / np.linalg.norm(p, axis=1)[:, None]
    p0, p1, p2, p3 = p.T
    R = np.empty((p.shape[0], 3, 3))
    R[:, 0, 0] = p0 * p0 + p1 * p1 - p2 * p2 - p3 * p3
    R[:, 1, 1] = p0 * p0 - p1 * p1 + p2 * p2 - p3 * p3
    R[:, 2, 2] = p0 * p0 - p1 * p1 - p2 * p2 + p3 * p3
    R[:, 0, 1] = 2.0 * (p1 * p2 - p0 * p3)
    R[:, 1, 0] = 2.0 * (p1 * p2 + p0 * p3)
    R[:, 0, 2] = 2.0 * (p1 * p3 + p0 * p2)
    R[:, 2, 0] = 2.0 * (p1 * p3 - p0 * p2)
    R[:, 1, 2] = 2.0 * (p2 * p3 - p0 * p1)
    R[:, 2, 1] = 2.0 * (p2 * p3 + p0 * p1)
    return R


def rotate(R, X):
    """R X row by row: R (n, 3, 3), X (n, 3) -> (n, 3)."""
    return np.einsum("nij,nj->ni", R, X)


def material_points(x, v, X):
    """Positions and velocities of body points.

    Parameters
    ----------
    x : ndarray, shape (n, 7)
        Node configurations (r, p) of the owners of the points.
    v : ndarray, shape (n, 6)
        Node velocities (ṙ, Ω), Ω in body axes.
    X : ndarray, shape (n, 3)
        Points in body axes relative to the node.

    Returns
    -------
    pos, vel : ndarray, shape (n, 3)
        r + R X and ṙ + R (Ω × X), space axes.
    """
    R = rotation_matrices(x[:, 3:7])
    return x[:, 0:3] + rotate(R, X), v[:, 0:3] + rotate(R, np.cross(v[:, 3:6], X))


def wrench_at(f, xb, Rb, point):
    """Force and moment about ``point`` (space axes) of generalized forces on frame nodes.

    Parameters
    ----------
    f : ndarray, shape (n, 6)
        (f_r, f_θ): force in space axes (N) and moment about the node in body
        axes (N m).
    xb : ndarray, shape (n, 3)
        Node positions.
    Rb : ndarray, shape (n, 3, 3)
        Node rotations.
    point : ndarray, shape (n, 3)
        Reduction points.

    Returns
    -------
    F, M : ndarray, shape (n, 3)
        F = f_r; M = R f_θ − (point − x_b) × F (the moment about ``point``).
    """
    F = f[:, 0:3].copy()
    M = rotate(Rb, f[:, 3:6]) - np.cross(point - xb, F)
    return F, M


def vertex_cells(n):
    """Connectivity of n vertex cells, shape (n, 1)."""
    return np.arange(n, dtype=np.int64)[:, None]


def time_function_table(functions, t, n):
    """(f, f', f'') at t of each element's time functions: shape (n, ntf, 3) (zeros when none)."""
    if not functions:
        return np.zeros((n, 0, 3))
    ntf = len(functions[0])
    tf = np.zeros((n, ntf, 3))
    for e, fns in enumerate(functions):
        for k, fn in enumerate(fns):
            tf[e, k] = (fn.f(t), fn.df(t), fn.ddf(t))
    return tf
