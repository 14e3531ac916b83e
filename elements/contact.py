"""Unilateral contact elements: gaps g_N ≥ 0, their force directions and curvature terms.

Each type provides the compiled kernel of the ``"contact"`` role (docs/contact.md, §3)::

    contact(P, t, tf, xe, ve, le, jac, gN, W, zeta, H)

for a batch of ``nel`` contact elements with ``k`` = ``n_contacts`` gaps and ``l`` =
``n_friction`` tangent directions each (``r = k + l`` rows):

* ``gN (nel, k)``: the gap g_N(q) (m), positive when open;
* ``W (nel, r, ndv)``: rows W_N = ∂g_N/∂v (so ġ_N = W_N v) and W_F, the tangent (slip)
  velocities γ_F = W_F v of the contact point of the second body relative to the first;
  in the model's velocity coordinates (spatial frame nodes: ṙ in space axes, Ω in body axes);
* ``zeta (nel, r)``: the curvature terms, g̈_N = W_N v̇ + ζ_N and γ̇_F = W_F v̇ + ζ_F;
* ``H (nel, ndv, ndv)`` (with ``jac``): ∂(Wᵀ le)/∂x along x ∘ exp(δ), ``le = (λ_N, λ_F)``.

A contact force λ_N ≥ 0 acts on the coordinates as +W_Nᵀ λ_N (it pushes the bodies apart)
and friction as +W_Fᵀ λ_F, against the sign convention of bilateral joints (−Φ_qᵀ λ): the
contact laws of docs/contact.md are written for this sign (Glocker 2001; Capobianco, Harsch,
Eugster & Leine 2021, eq. (127)).

Every kernel is checked against finite differences of its own outputs
(``femb.contact.check_contact_kernels``, ``tests/test_contact_kernels.py``).

References
----------
C. Glocker, Set-Valued Force Laws, Springer, 2001 (gap functions, W_N, W_F, the impact laws).
F. Pfeiffer, C. Glocker, Multibody Dynamics with Unilateral Contacts, Wiley, 1996.
"""
from __future__ import annotations

import math

import numpy as np

from femb.base.geometry import GeometryBlock
from femb.base.jit import kernel
from femb.base.rotations import quat_to_matrix_t
from femb.errors import ModelError
from femb.system.element import Element

from ._spatial import cross3, dot3, mtv, mv


# ---------------------------------------------------------------------------
# parameters common to every contact: e_N, e_F, μ
# ---------------------------------------------------------------------------
def _scalar(owner, what, value, lo=None, hi=None):
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ModelError(f"{owner}: {what} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise ModelError(f"{owner}: {what} must be finite, got {value!r}")
    if lo is not None and v < lo or hi is not None and v > hi:
        rng = f"[{lo:g}, {hi:g}]" if hi is not None else f"≥ {lo:g}"
        raise ModelError(f"{owner}: {what} must be in {rng}, got {v:g}")
    return v


def _vector(owner, what, value, n):
    try:
        v = np.array(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ModelError(f"{owner}: {what} must be {n} numbers, got {value!r}") from None
    if v.size != n or not np.all(np.isfinite(v)):
        raise ModelError(f"{owner}: {what} must be {n} finite numbers, got {value!r}")
    return v


def _unit(owner, what, value, n):
    v = _vector(owner, what, value, n)
    L = float(np.linalg.norm(v))
    if L < 1e-12:
        raise ModelError(f"{owner}: {what} must be a non-zero vector, got {value!r}")
    return v / L


class ContactElement(Element):
    """Base of the contact types: the impact and friction parameters of one contact.

    Parameters
    ----------
    name : str
    e_N : float in [0, 1]
        Newton's normal restitution coefficient (0: plastic, 1: elastic impact).
    mu : float ≥ 0
        Coulomb friction coefficient (0: frictionless).
    e_F : float in [0, 1]
        Tangential restitution (0: the slip velocity after an impact that sticks is zero).
    """

    n_contacts = 1
    glyph = "contact"  # how pictures draw it (femb.io.frames)

    def __init__(self, name, e_N=0.0, mu=0.0, e_F=0.0):
        super().__init__(name)
        owner = f"{type(self).__name__} '{name}'"
        self.e_N = _scalar(owner, "e_N (normal restitution)", e_N, 0.0, 1.0)
        self.mu = _scalar(owner, "mu (friction coefficient)", mu, 0.0)
        self.e_F = _scalar(owner, "e_F (tangential restitution)", e_F, 0.0, 1.0)

    @classmethod
    def contact_frames(cls, P, qe):
        """Contact points, normals, tangents and gaps of a batch at one state (for output).

        Parameters
        ----------
        P : ndarray, shape (nel, npar)
            The batch's packed parameters.
        qe : ndarray, shape (nel, ndx)
            Coordinates of each element's nodes.

        Returns
        -------
        c : ndarray (nel, 3)
            Contact point (m), where the surfaces touch when the contact is closed: on a plane,
            the sphere's point nearest the plane (c = C − R_s n); on a disc pair, pin in hole or
            sphere pair, the first disc's (the hole's, the first sphere's) surface point towards the
            second centre.
        n : ndarray (nel, 3)
            Unit direction in which the normal force λ_N pushes the body (on pairs: body b).
        T : ndarray (nel, l, 3)
            Direction of each friction force λ_F on that body.
        gN : ndarray (nel,)
            Gap (m), negative when the surfaces overlap.

        None (this base class): the type is not drawn in VTK and pictures; a user's contact type
        overrides this to be drawn.
        """
        return None

    @classmethod
    def sphere_pairs(cls, P, qe, ve):
        """The broad phase's view of a pair type (docs/contact.md §7, "Broad phase"): each element's two
        spheres, whose gap is g_N = abs(c_b − c_a) − R_a − R_b (types with one normal contact per element).

        Parameters
        ----------
        P : ndarray, shape (nel, npar)
        qe : ndarray, shape (nel, ndx)
        ve : ndarray, shape (nel, ndv)
            Coordinates and velocities of each element's nodes.

        Returns
        -------
        (c_a, c_b, v_a, v_b, R_a, R_b) or None
            Centres (nel, 3) (m), their velocities (nel, 3) (m/s) and radii (nel,) (m). None (this base
            class): the type is not a pair of spheres, and the sparse path evaluates it at every
            iteration. A type that returns them promises that its gap is exactly this (the broad phase
            reports it for the pairs it leaves out of a step).
        """
        return None

    @classmethod
    def geometry_problems(cls, P, qe):
        """Elements of a batch whose gap or directions are undefined, or nearly so, at one state.

        Parameters
        ----------
        P : ndarray, shape (nel, npar)
        qe : ndarray, shape (nel, ndx)

        Returns
        -------
        list of (int, str)
            (index in the batch, why); empty for this base class (a type whose geometry is defined
            everywhere). :func:`femb.contact.simulate.diagnose` reports them when a step fails.
        """
        return []

    @classmethod
    def geometry(cls, p, t, qe, qde, lame, names):
        """One vertex per contact at its contact point (see :func:`contact_block`).

        ``lame`` (nel, 2 + l), when the caller knows the contact forces (a contact result):
        state (0 open, 1 stick, 2 slip), λ_N and the friction forces λ_F; (nel, 0) otherwise
        (forces 0, state −1: not known).
        """
        frames = cls.contact_frames(p["P"], np.asarray(qe, dtype=float))
        if frames is None:          # a user's contact type that does not describe its points: not drawn
            return []
        c, n, T, gN = frames
        lame = np.asarray(lame, dtype=float)
        if lame.shape[1] >= 2:
            state = lame[:, 0]
            F = lame[:, 1:2] * n + np.einsum("ek,ekj->ej", lame[:, 2:2 + T.shape[1]], T)
        else:
            state, F = np.full(len(gN), -1.0), np.zeros_like(n)
        return contact_block(cls.__name__, c, n, F, gN, state)


def contact_block(name, points, normals, forces, gaps, states):
    """The contacts of a batch as output geometry (VTK, pictures).

    Parameters
    ----------
    name : str
        The element type's name.
    points, normals, forces : ndarray, shape (nel, 3)
        Contact point (m), unit normal along which the normal force pushes the (second) body,
        and the whole contact force on it (N: normal plus friction).
    gaps : ndarray, shape (nel,)
        g_N (m).
    states : ndarray, shape (nel,)
        0 open, 1 stick, 2 slip; −1 when not known.

    Returns
    -------
    list of GeometryBlock
        One block of vertices with point data ``contact_normal``, ``contact_force`` (N),
        ``gap`` (m) and ``contact_state``.
    """
    n = len(gaps)
    return [GeometryBlock(name, np.asarray(points, dtype=float).reshape(n, 3), [("vertex", np.arange(n)[:, None])],
                          point_data={"contact_normal": np.asarray(normals, dtype=float).reshape(n, 3),
                                      "contact_force": np.asarray(forces, dtype=float).reshape(n, 3),
                                      "gap": np.asarray(gaps, dtype=float).reshape(n),
                                      "contact_state": np.asarray(states, dtype=float).reshape(n)})]


def _planar_points(qe, s, col=0):
    """(r + R(θ)s (n, 3) with z = 0) of planar nodes whose (x, y, θ) start at column ``col`` of qe."""
    th = qe[:, col + 2]
    c, sn = np.cos(th), np.sin(th)
    out = np.zeros((qe.shape[0], 3))
    out[:, 0] = qe[:, col] + c * s[:, 0] - sn * s[:, 1]
    out[:, 1] = qe[:, col + 1] + sn * s[:, 0] + c * s[:, 1]
    return out


def _planar3(v):
    out = np.zeros((v.shape[0], 3))
    out[:, :2] = v
    return out


def _spatial_points(qe, s, col=0):
    """(r + R(p)s (n, 3), R (n, 3, 3)) of spatial nodes whose (r, p) start at column ``col`` of qe."""
    from ._spatial_geometry import rotation_matrices

    R = rotation_matrices(qe[:, col + 3:col + 7])
    return qe[:, col:col + 3] + np.einsum("eij,ej->ei", R, s), R


def _body(owner, lookup, ref, role):
    b = lookup(ref, role)
    if getattr(b, "node", None) is None:
        raise ModelError(f"{owner}: {role} must be a body with a node, got {ref!r}")
    return b


def _points(owner, n, **points):
    """Check the points given as vectors (n,); names of a body's points are resolved later (``_local``)."""
    for what, pt in points.items():
        if not isinstance(pt, str):
            _vector(owner, what, pt, n)


def _two_bodies(owner, refs, roles, find):
    """The two bodies of a pair contact by ``find(ref, role)``; ModelError naming ``owner`` if they are one."""
    a, b = find(refs[0], roles[0]), find(refs[1], roles[1])
    if a is b:
        raise ModelError(f"{owner}: {roles[0]} and {roles[1]} are the same body ('{a.name}')")
    return a, b


# ---------------------------------------------------------------------------
# planar: a point or disc of a body on a plane fixed in space
# ---------------------------------------------------------------------------
@kernel
def sphere_plane_contact(P, t, tf, xe, ve, le, jac, gN, W, zeta, H):
    """Disc (radius R, centre s on the body) on the fixed line through p with unit normal n.

    g = n·(r + R(θ)s − p) − R; W_N = (n, n·Jd); W_F = (t, R − n·d) with t = (n_y, −n_x),
    d = R(θ)s, Jd = (−d_y, d_x); ζ_N = −ω² n·d, ζ_F = −ω² n·Jd;
    H_θθ = −λ_N n·d − λ_F n·Jd.  P = (s_x, s_y, R, p_x, p_y, n_x, n_y).
    """
    for e in range(xe.shape[0]):
        c, s = math.cos(xe[e, 2]), math.sin(xe[e, 2])
        dx = c * P[e, 0] - s * P[e, 1]
        dy = s * P[e, 0] + c * P[e, 1]
        nx, ny = P[e, 5], P[e, 6]
        R = P[e, 2]
        nd = nx * dx + ny * dy
        nJd = -nx * dy + ny * dx
        gN[e, 0] = nx * (xe[e, 0] + dx - P[e, 3]) + ny * (xe[e, 1] + dy - P[e, 4]) - R
        W[e, 0, 0] = nx
        W[e, 0, 1] = ny
        W[e, 0, 2] = nJd
        W[e, 1, 0] = ny
        W[e, 1, 1] = -nx
        W[e, 1, 2] = R - nd
        w2 = ve[e, 2] * ve[e, 2]
        zeta[e, 0] = -w2 * nd
        zeta[e, 1] = -w2 * nJd
        if jac:
            H[e, 2, 2] = -le[e, 0] * nd - le[e, 1] * nJd


class SphereOnPlane(ContactElement):
    """A point or disc of a planar body on a plane (a line) fixed in space, with Coulomb friction.

    g_N = n·(r_C − p) − R ≥ 0 for the disc centre r_C = r + R(θ) s; the tangent
    t = (n_y, −n_x) is n turned clockwise (on a floor with n = (0, 1): t = +x). The slip
    velocity γ_F = t·(velocity of the contact point r_C − R n). With ``radius = 0`` it is a
    corner or edge point (rocking blocks: one element per corner, :func:`block_corners`).

    Parameters
    ----------
    name : str
    body : body or name
        A planar body (RigidBody, PointMass, ...).
    radius : float ≥ 0
    point : (2,) or name
        Disc centre in the body frame.
    plane_point, normal : (2,)
        A point of the plane and its normal (pointing to the free side; normalised).
    e_N, mu, e_F : see :class:`ContactElement`.
    """

    n_friction = 1
    kernels = {"contact": sphere_plane_contact}

    def __init__(self, name, body, radius=0.0, point=(0.0, 0.0), plane_point=(0.0, 0.0), normal=(0.0, 1.0),
                 e_N=0.0, mu=0.0, e_F=0.0):
        super().__init__(name, e_N, mu, e_F)
        owner = f"SphereOnPlane '{name}'"
        self.body = body
        self._point = point
        self.radius = _scalar(owner, "radius", radius, 0.0)
        self.p = _vector(owner, "plane_point", plane_point, 2)
        self.n = _unit(owner, "normal", normal, 2)

    def resolve(self, lookup):
        owner = f"SphereOnPlane '{self.name}'"
        self.body = _body(owner, lookup, self.body, "body")
        self.s = np.asarray(self.body.local(self._point, "point"), dtype=float)

    def nodes(self):
        return [self.body.node]

    @classmethod
    def pack(cls, elements):
        P = np.array([[*e.s, e.radius, *e.p, *e.n] for e in elements], dtype=float)
        return {"P": np.ascontiguousarray(P)}

    @classmethod
    def contact_frames(cls, P, qe):
        C = _planar_points(qe, P[:, 0:2])
        n = _planar3(P[:, 5:7])
        gN = np.einsum("ej,ej->e", n, C - _planar3(P[:, 3:5])) - P[:, 2]
        T = _planar3(np.column_stack((P[:, 6], -P[:, 5])))[:, None, :]
        return C - P[:, 2:3] * n, n, T, gN


def block_corners(name, body, width, height, e_N=0.0, mu=0.0, e_F=0.0, plane_point=(0.0, 0.0),
                  normal=(0.0, 1.0)):
    """The four corner contacts of a planar rectangular block centred on its node.

    Returns
    -------
    list of SphereOnPlane
        Named ``<name>.c0`` … ``<name>.c3`` at the corners (−w/2, −h/2), (w/2, −h/2),
        (w/2, h/2), (−w/2, h/2) of the body frame.
    """
    owner = f"block_corners '{name}'"
    a = 0.5 * _scalar(owner, "width", width, 0.0)
    b = 0.5 * _scalar(owner, "height", height, 0.0)
    pts = ((-a, -b), (a, -b), (a, b), (-a, b))
    return [SphereOnPlane(f"{name}.c{k}", body, 0.0, p, plane_point, normal, e_N, mu, e_F)
            for k, p in enumerate(pts)]


# ---------------------------------------------------------------------------
# planar: two discs (outside each other) or a pin in a hole (revolute clearance)
# ---------------------------------------------------------------------------
@kernel
def disc_pair_contact(P, t, tf, xe, ve, le, jac, gN, W, zeta, H):
    """Disc on body b against a disc (sN = +1) or a hole (sN = −1) on body a.

    e = c_b − c_a (c = r + R(θ)s), L = |e|, n = e/L, t = (n_y, −n_x), E = ∂e/∂v =
    [−I, −Jd_a, I, Jd_b]; g = sN L + c0; W_N = sN nᵀE; W_F = tᵀE + (0, 0, ca, 0, 0, cb);
    ζ_N = sN((t·ė)²/L + n·ë_c), ζ_F = −(n·ė)(t·ė)/L + t·ë_c with ë_c = ω_a² d_a − ω_b² d_b;
    H = (sN λ_N EᵀttᵀE − λ_F EᵀntᵀE)/L + the θθ terms of ∂E/∂θ.
    P = (s_a(2), s_b(2), sN, c0, ca, cb).
    """
    for e in range(xe.shape[0]):
        ca_, sa_ = math.cos(xe[e, 2]), math.sin(xe[e, 2])
        cb_, sb_ = math.cos(xe[e, 5]), math.sin(xe[e, 5])
        dax = ca_ * P[e, 0] - sa_ * P[e, 1]
        day = sa_ * P[e, 0] + ca_ * P[e, 1]
        dbx = cb_ * P[e, 2] - sb_ * P[e, 3]
        dby = sb_ * P[e, 2] + cb_ * P[e, 3]
        ex = xe[e, 3] + dbx - xe[e, 0] - dax
        ey = xe[e, 4] + dby - xe[e, 1] - day
        L = math.sqrt(ex * ex + ey * ey)
        nx, ny = ex / L, ey / L
        tx, ty = ny, -nx
        sN = P[e, 4]
        gN[e, 0] = sN * L + P[e, 5]
        # E = ∂e/∂v, columns (vx_a, vy_a, ω_a, vx_b, vy_b, ω_b), rows x and y
        nE = (-nx, -ny, nx * day - ny * dax, nx, ny, -nx * dby + ny * dbx)
        tE = (-tx, -ty, tx * day - ty * dax, tx, ty, -tx * dby + ty * dbx)
        for j in range(6):
            W[e, 0, j] = sN * nE[j]
            W[e, 1, j] = tE[j]
        W[e, 1, 2] += P[e, 6]
        W[e, 1, 5] += P[e, 7]
        edx = ve[e, 3] - ve[e, 5] * dby - ve[e, 0] + ve[e, 2] * day
        edy = ve[e, 4] + ve[e, 5] * dbx - ve[e, 1] - ve[e, 2] * dax
        wa2 = ve[e, 2] * ve[e, 2]
        wb2 = ve[e, 5] * ve[e, 5]
        ecx = wa2 * dax - wb2 * dbx
        ecy = wa2 * day - wb2 * dby
        ne = nx * edx + ny * edy
        te = tx * edx + ty * edy
        zeta[e, 0] = sN * (te * te / L + nx * ecx + ny * ecy)
        zeta[e, 1] = -ne * te / L + tx * ecx + ty * ecy
        if jac:
            lN, lF = le[e, 0], le[e, 1]
            for i in range(6):
                for j in range(6):
                    H[e, i, j] = (sN * lN * tE[i] - lF * nE[i]) * tE[j] / L
            # ∂E/∂θ: the columns of ω_a, (d_ay, −d_ax), and of ω_b, (−d_by, d_bx), turn with their bodies
            ux = sN * lN * nx + lF * tx
            uy = sN * lN * ny + lF * ty
            H[e, 2, 2] += ux * dax + uy * day
            H[e, 5, 5] -= ux * dbx + uy * dby


class _DiscPair(ContactElement):
    n_friction = 1
    kernels = {"contact": disc_pair_contact}

    def __init__(self, name, a, b, point_a, point_b, e_N, mu, e_F):
        super().__init__(name, e_N, mu, e_F)
        self.a, self.b = a, b
        self._pa, self._pb = point_a, point_b

    def resolve(self, lookup):
        owner = f"{type(self).__name__} '{self.name}'"
        self.a, self.b = _two_bodies(owner, (self.a, self.b), ("a", "b"), lambda r, w: _body(owner, lookup, r, w))
        self.sa = _local(owner, self.a, self._pa, "point_a")
        self.sb = _local(owner, self.b, self._pb, "point_b")

    def nodes(self):
        return [self.a.node, self.b.node]

    @classmethod
    def pack(cls, elements):
        P = np.array([[*e.sa, *e.sb, *e._law()] for e in elements], dtype=float)
        return {"P": np.ascontiguousarray(P)}

    @classmethod
    def contact_frames(cls, P, qe):
        ca, cb = _planar_points(qe, P[:, 0:2]), _planar_points(qe, P[:, 2:4], col=3)
        e = cb - ca
        L = np.linalg.norm(e, axis=1)
        u = e / np.where(L > 0.0, L, 1.0)[:, None]
        sN = P[:, 4:5]
        T = np.column_stack((u[:, 1], -u[:, 0], np.zeros(len(L))))[:, None, :]
        return ca + P[:, 6:7] * u, sN * u, T, P[:, 4] * L + P[:, 5]


class DiscOnDisc(_DiscPair):
    """Two discs (planar spheres) outside each other, with Coulomb friction.

    g_N = |c_b − c_a| − R_a − R_b, normal n from c_a to c_b, tangent t = (n_y, −n_x);
    γ_F is the slip velocity of b's contact point relative to a's along t.

    Parameters
    ----------
    name : str
    a, b : body or name
    radius_a, radius_b : float ≥ 0
    point_a, point_b : (2,) or name
        Disc centres in the body frames.
    e_N, mu, e_F : see :class:`ContactElement`.
    """

    def __init__(self, name, a, b, radius_a, radius_b, point_a=(0.0, 0.0), point_b=(0.0, 0.0),
                 e_N=0.0, mu=0.0, e_F=0.0):
        super().__init__(name, a, b, point_a, point_b, e_N, mu, e_F)
        owner = f"DiscOnDisc '{name}'"
        self.Ra = _scalar(owner, "radius_a", radius_a, 0.0)
        self.Rb = _scalar(owner, "radius_b", radius_b, 0.0)

    def _law(self):
        return (1.0, -(self.Ra + self.Rb), self.Ra, self.Rb)

    @classmethod
    def sphere_pairs(cls, P, qe, ve):
        """The discs as spheres in the plane z = 0 (:meth:`ContactElement.sphere_pairs`): c = r + R(θ)s,
        v = ṙ + ω e_z × R(θ)s, radii R_a = ca, R_b = cb of the packed law."""
        out = []
        for col, s in ((0, P[:, 0:2]), (3, P[:, 2:4])):
            c = _planar_points(qe, s, col)
            w = ve[:, col + 2]
            v = np.zeros_like(c)
            v[:, 0] = ve[:, col] - w * (c[:, 1] - qe[:, col + 1])
            v[:, 1] = ve[:, col + 1] + w * (c[:, 0] - qe[:, col])
            out.append((c, v))
        return out[0][0], out[1][0], out[0][1], out[1][1], P[:, 6].copy(), P[:, 7].copy()


class PinInHole(_DiscPair):
    """A pin (radius R_p on body b) in a hole (radius R_h > R_p on body a): a revolute joint with clearance.

    g_N = (R_h − R_p) − |c_b − c_a| ≥ 0 (the clearance joint of Flores, Ambrósio, Claro &
    Lankarani, Kinematics and Dynamics of Multibody Systems with Imperfect Joints, Springer
    2008, Ch. 4); n points from the hole's centre to the pin's; friction acts on the slip of
    the pin's surface against the hole's.

    Parameters
    ----------
    name : str
    a : body or name
        The body with the hole (bushing).
    b : body or name
        The body with the pin (journal).
    hole_radius, pin_radius : float, hole_radius > pin_radius ≥ 0
    point_a, point_b : (2,) or name
        Hole and pin centres in the body frames.
    e_N, mu, e_F : see :class:`ContactElement`.
    """

    def __init__(self, name, a, b, hole_radius, pin_radius, point_a=(0.0, 0.0), point_b=(0.0, 0.0),
                 e_N=0.0, mu=0.0, e_F=0.0):
        super().__init__(name, a, b, point_a, point_b, e_N, mu, e_F)
        owner = f"PinInHole '{name}'"
        self.Rh = _scalar(owner, "hole_radius", hole_radius, 0.0)
        self.Rp = _scalar(owner, "pin_radius", pin_radius, 0.0)
        if not self.Rh > self.Rp:
            raise ModelError(f"{owner}: hole_radius ({self.Rh:g}) must exceed pin_radius ({self.Rp:g})")

    def _law(self):
        return (-1.0, self.Rh - self.Rp, self.Rh, -self.Rp)


# ---------------------------------------------------------------------------
# planar: a disc of one body on a line fixed to another body
# ---------------------------------------------------------------------------
@kernel
def _planar_row(W, e, k, w, aa, ab):
    """Row k for the unit direction w: W = (−w, −aa × w, w, ab × w) (x × w = x_x w_y − x_y w_x), the
    velocity along w of b's material point at arm ab relative to a's at arm aa."""
    W[e, k, 0] = -w[0]
    W[e, k, 1] = -w[1]
    W[e, k, 2] = -(aa[0] * w[1] - aa[1] * w[0])
    W[e, k, 3] = w[0]
    W[e, k, 4] = w[1]
    W[e, k, 5] = ab[0] * w[1] - ab[1] * w[0]


@kernel
def _planar_body_plane_hessian(H, e, F, lN, R, aa, ab, db):
    """H = ∂(Wᵀλ)/∂x of :func:`sphere_body_plane_contact`: Wᵀλ = (−F, −aa × F, F, ab × F) with
    F = λ_N n + λ_F t = R(θ_a)F̄ (∂F/∂θ_a = JF), ∂aa/∂(r_a, θ_a, r_b, θ_b) = (−I, −R Jn, I, J d_b),
    ∂ab/∂θ_a = −R Jn, ∂ab/∂θ_b = J d_b; with (Jx) × y = −x·y and x × Jy = x·y."""
    aF = aa[0] * F[0] + aa[1] * F[1]
    bF = ab[0] * F[0] + ab[1] * F[1]
    dF = db[0] * F[0] + db[1] * F[1]
    H[e, 0, 2] = F[1]
    H[e, 1, 2] = -F[0]
    H[e, 3, 2] = -F[1]
    H[e, 4, 2] = F[0]
    H[e, 2, 0] = F[1]
    H[e, 2, 1] = -F[0]
    H[e, 2, 3] = -F[1]
    H[e, 2, 4] = F[0]
    H[e, 2, 2] = -(R * lN + aF)
    H[e, 2, 5] = dF
    H[e, 5, 2] = R * lN + bF
    H[e, 5, 5] = -dF


@kernel
def sphere_body_plane_contact(P, t, tf, xe, ve, le, jac, gN, W, zeta, H):
    """Disc (radius R, centre s on body b) on the line through p̄ with unit normal n̄ fixed to body a.

    Nodes (a, b) = (plane body, disc body). n = R(θ_a)n̄, t = (n_y, −n_x), plane point
    P = r_a + R(θ_a)p̄, centre C = r_b + d_b, d_b = R(θ_b)s; g = n·(C − P) − R. Contact point
    c = C − R n, arms aa = c − r_a, ab = c − r_b = d_b − R n. Rows w ∈ (n, t): W = (−w, −aa × w,
    w, ab × w), w·V with V = ṙ_b − ṙ_a + ω_b J ab − ω_a J aa the velocity of b's material point
    at c relative to a's (J the turn by +90°); W_N = ∂g/∂q (the ω_a terms of ṅ = ω_a Jn and
    Ṗ combine into −ω_a n·J aa). ζ = ω_a (Jw)·V + w·V̇ with ẇ = ω_a Jw and
    V̇ = (ω_a ω_b − ω_b²) d_b + R ω_a(ω_b − ω_a) n − ω_a J(ṙ_b − ṙ_a);
    H by :func:`_planar_body_plane_hessian`. P = (p̄(2), n̄(2), s(2), R).
    """
    for e in range(xe.shape[0]):
        ca, sa = math.cos(xe[e, 2]), math.sin(xe[e, 2])
        cb, sb = math.cos(xe[e, 5]), math.sin(xe[e, 5])
        n = (ca * P[e, 2] - sa * P[e, 3], sa * P[e, 2] + ca * P[e, 3])
        tt = (n[1], -n[0])
        px, py = ca * P[e, 0] - sa * P[e, 1], sa * P[e, 0] + ca * P[e, 1]
        db = (cb * P[e, 4] - sb * P[e, 5], sb * P[e, 4] + cb * P[e, 5])
        R = P[e, 6]
        cax, cay = xe[e, 3] + db[0] - xe[e, 0], xe[e, 4] + db[1] - xe[e, 1]      # C − r_a
        gN[e, 0] = n[0] * (cax - px) + n[1] * (cay - py) - R
        aa = (cax - R * n[0], cay - R * n[1])
        ab = (db[0] - R * n[0], db[1] - R * n[1])
        wa, wb = ve[e, 2], ve[e, 5]
        rdx, rdy = ve[e, 3] - ve[e, 0], ve[e, 4] - ve[e, 1]
        Vx = rdx - wb * ab[1] + wa * aa[1]
        Vy = rdy + wb * ab[0] - wa * aa[0]
        c1, c2 = wa * wb - wb * wb, R * wa * (wb - wa)
        Vdx = c1 * db[0] + c2 * n[0] + wa * rdy
        Vdy = c1 * db[1] + c2 * n[1] - wa * rdx
        _planar_row(W, e, 0, n, aa, ab)
        _planar_row(W, e, 1, tt, aa, ab)
        zeta[e, 0] = wa * (-n[1] * Vx + n[0] * Vy) + n[0] * Vdx + n[1] * Vdy
        zeta[e, 1] = wa * (-tt[1] * Vx + tt[0] * Vy) + tt[0] * Vdx + tt[1] * Vdy
        if jac:
            lN, lF = le[e, 0], le[e, 1]
            F = (lN * n[0] + lF * tt[0], lN * n[1] + lF * tt[1])
            _planar_body_plane_hessian(H, e, F, lN, R, aa, ab, db)


class SphereOnBodyPlane(ContactElement):
    """A point or disc of a planar body on a line fixed to another planar body, with Coulomb friction.

    The line passes through p̄ with unit normal n̄, both in ``plane_body``'s frame: in space
    P = r_a + R(θ_a)p̄, n = R(θ_a)n̄ (a = plane_body). The disc's centre is C = r_b + R(θ_b)s
    (b = body); g_N = n·(C − P) − R, tangent t = (n_y, −n_x) (turns with a). The normal force λ_N n
    and the friction force λ_F t act on ``body`` at the contact point c = C − R n, their opposites on
    ``plane_body`` at the same point; γ_F = t·(velocity of b's material point at c − velocity of a's
    material point at c). With a's node fixed (``plane_body="ground"``, as the pair types allow) it is
    :class:`SphereOnPlane`. The line is unbounded: keep the disc over the part of a you mean.

    Parameters
    ----------
    name : str
    body : body or name
        The planar body that carries the disc (radius 0: a corner point).
    plane_body : body or name
        The planar body that carries the line (or ``"ground"``); not ``body``.
    radius : float ≥ 0
    point : (2,) or name
        Disc centre in ``body``'s frame.
    plane_point : (2,) or name
        A point of the line in ``plane_body``'s frame.
    normal : (2,)
        The line's normal in ``plane_body``'s frame (to the free side; normalised).
    e_N, mu, e_F : see :class:`ContactElement`.

    Notes
    -----
    Nodes (plane_body, body): the sphere's body is the second body b of a pair (docs/contact.md §2).
    Kernel :func:`sphere_body_plane_contact`; ``P = (p̄, n̄, s, R)``.
    """

    n_friction = 1
    kernels = {"contact": sphere_body_plane_contact}

    def __init__(self, name, body, plane_body, radius=0.0, point=(0.0, 0.0), plane_point=(0.0, 0.0),
                 normal=(0.0, 1.0), e_N=0.0, mu=0.0, e_F=0.0):
        super().__init__(name, e_N, mu, e_F)
        owner = f"SphereOnBodyPlane '{name}'"
        self.body, self.plane_body = body, plane_body
        self.radius = _scalar(owner, "radius", radius, 0.0)
        self.nbar = _unit(owner, "normal", normal, 2)
        _points(owner, 2, point=point, plane_point=plane_point)
        self._point, self._plane_point = point, plane_point

    def resolve(self, lookup):
        owner = f"SphereOnBodyPlane '{self.name}'"
        self.body, self.plane_body = _two_bodies(owner, (self.body, self.plane_body), ("body", "plane_body"),
                                                 lambda r, w: _body(owner, lookup, r, w))
        self.s = _local(owner, self.body, self._point, "point")
        self.pbar = _local(owner, self.plane_body, self._plane_point, "plane_point")

    def nodes(self):
        return [self.plane_body.node, self.body.node]

    @classmethod
    def pack(cls, elements):
        P = np.array([[*e.pbar, *e.nbar, *e.s, e.radius] for e in elements], dtype=float)
        return {"P": np.ascontiguousarray(P.reshape(-1, 7))}

    @classmethod
    def contact_frames(cls, P, qe):
        """Contact point c = C − R n (the disc's point nearest the line), n, t, g_N."""
        Pl = _planar_points(qe, P[:, 0:2])
        ang = qe[:, 2]
        n = _planar3(np.column_stack((np.cos(ang) * P[:, 2] - np.sin(ang) * P[:, 3],
                                      np.sin(ang) * P[:, 2] + np.cos(ang) * P[:, 3])))
        C = _planar_points(qe, P[:, 4:6], col=3)
        gN = np.einsum("ej,ej->e", n, C - Pl) - P[:, 6]
        T = np.column_stack((n[:, 1], -n[:, 0], np.zeros(len(gN))))[:, None, :]
        return C - P[:, 6:7] * n, n, T, gN


def _local(owner, body, spec, what):
    """Body-frame coordinates of a point name or vector of ``body``; ModelError naming ``owner``."""
    try:
        return np.asarray(body.local(spec, what), dtype=float)
    except ModelError as err:
        raise ModelError(f"{owner}: {what}: {err}") from None


# ---------------------------------------------------------------------------
# spatial: a point or sphere of a spatial body on a plane fixed in space
# ---------------------------------------------------------------------------
@kernel
def _row(W, Z, H, e, k, lk, jac, w, m, s, Rm, Om):
    """Row k for a direction w fixed in space and m = R_s n × w: W = (w, s × Rᵀw − Rᵀm),
    ζ = −(Ω × s)·(Ω × Rᵀw), H_θθ += λ (s̃ w̃' − m̃') with w' = Rᵀw, m' = Rᵀm."""
    wp = mtv(Rm, w)
    mp = mtv(Rm, m)
    rot = cross3(s, wp)
    for i in range(3):
        W[e, k, i] = w[i]
        W[e, k, 3 + i] = rot[i] - mp[i]
    Z[e, k] = -dot3(cross3(Om, s), cross3(Om, wp))
    if jac:
        # (s̃ w̃')_ij = w'_i s_j − (s·w') δ_ij ;  −(m̃')_ij
        sw = dot3(s, wp)
        H[e, 3, 3] += lk * (wp[0] * s[0] - sw)
        H[e, 3, 4] += lk * (wp[0] * s[1] + mp[2])
        H[e, 3, 5] += lk * (wp[0] * s[2] - mp[1])
        H[e, 4, 3] += lk * (wp[1] * s[0] - mp[2])
        H[e, 4, 4] += lk * (wp[1] * s[1] - sw)
        H[e, 4, 5] += lk * (wp[1] * s[2] + mp[0])
        H[e, 5, 3] += lk * (wp[2] * s[0] + mp[1])
        H[e, 5, 4] += lk * (wp[2] * s[1] - mp[0])
        H[e, 5, 5] += lk * (wp[2] * s[2] - sw)


@kernel
def spatial_sphere_plane_contact(P, t, tf, xe, ve, le, jac, gN, W, zeta, H):
    """Sphere (radius R_s, centre s in body axes) on the fixed plane through p with unit normal n.

    g = n·(r + R(p)s − p) − R_s; rows w ∈ (n, t₁, t₂): W = (w, s × Rᵀw − Rᵀm_w) with
    m_w = R_s n × w (m_n = 0): the velocity of the contact point r + Rs − R_s n along w;
    ζ = −(Ω × s)·(Ω × Rᵀw). P = (s(3), R_s, p(3), n(3), t₁(3), t₂(3)).
    """
    for e in range(xe.shape[0]):
        Rm = quat_to_matrix_t(xe[e, 3], xe[e, 4], xe[e, 5], xe[e, 6])
        s = (P[e, 0], P[e, 1], P[e, 2])
        Rs = P[e, 3]
        n = (P[e, 7], P[e, 8], P[e, 9])
        t1 = (P[e, 10], P[e, 11], P[e, 12])
        t2 = (P[e, 13], P[e, 14], P[e, 15])
        Om = (ve[e, 3], ve[e, 4], ve[e, 5])
        d0 = Rm[0] * s[0] + Rm[1] * s[1] + Rm[2] * s[2]
        d1 = Rm[3] * s[0] + Rm[4] * s[1] + Rm[5] * s[2]
        d2 = Rm[6] * s[0] + Rm[7] * s[1] + Rm[8] * s[2]
        gN[e, 0] = (n[0] * (xe[e, 0] + d0 - P[e, 4]) + n[1] * (xe[e, 1] + d1 - P[e, 5])
                    + n[2] * (xe[e, 2] + d2 - P[e, 6]) - Rs)
        c1 = cross3(n, t1)
        c2 = cross3(n, t2)
        _row(W, zeta, H, e, 0, le[e, 0], jac, n, (0.0, 0.0, 0.0), s, Rm, Om)
        _row(W, zeta, H, e, 1, le[e, 1], jac, t1, (Rs * c1[0], Rs * c1[1], Rs * c1[2]), s, Rm, Om)
        _row(W, zeta, H, e, 2, le[e, 2], jac, t2, (Rs * c2[0], Rs * c2[1], Rs * c2[2]), s, Rm, Om)


def tangents(n):
    """Two unit tangents (t₁, t₂) of a unit normal n, with (t₁, t₂, n) right-handed."""
    k = int(np.argmin(np.abs(n)))
    e = np.zeros(3)
    e[k] = 1.0
    t1 = np.cross(e, n)
    t1 /= np.linalg.norm(t1)
    return t1, np.cross(n, t1)


def plane_tangents(owner, n, tangent=None):
    """The tangents (t₁, t₂) of the plane with unit normal n: :func:`tangents` when ``tangent`` is None,
    else t₁ the given direction projected on the plane (ModelError naming ``owner`` when it is parallel
    to n), t₂ = n × t₁."""
    if tangent is None:
        return tangents(n)
    t1 = _vector(owner, "tangent", tangent, 3)
    t1 = t1 - (t1 @ n) * n
    if np.linalg.norm(t1) < 1e-9:
        raise ModelError(f"{owner}: tangent must not be parallel to the normal, got {tangent!r}")
    t1 = t1 / np.linalg.norm(t1)
    return t1, np.cross(n, t1)


class SpatialSphereOnPlane(ContactElement):
    """A point or sphere of a spatial body on a plane fixed in space, with isotropic Coulomb friction.

    g_N = n·(r + R s − p) − R_s; two tangents (t₁, t₂, n right-handed; from
    :func:`tangents` unless ``tangent`` is given) span the friction cone; γ_F = (t₁, t₂)·(the
    velocity of the contact point r + R s − R_s n).

    Parameters
    ----------
    name : str
    body : spatial body or name
    radius : float ≥ 0
    point : (3,) or name
        Sphere centre in body axes.
    plane_point, normal : (3,)
    tangent : (3,), optional
        t₁ (its part orthogonal to n).
    e_N, mu, e_F : see :class:`ContactElement`.
    """

    spatial = True
    n_friction = 2
    kernels = {"contact": spatial_sphere_plane_contact}

    def __init__(self, name, body, radius=0.0, point=(0.0, 0.0, 0.0), plane_point=(0.0, 0.0, 0.0),
                 normal=(0.0, 0.0, 1.0), tangent=None, e_N=0.0, mu=0.0, e_F=0.0):
        super().__init__(name, e_N, mu, e_F)
        owner = f"SpatialSphereOnPlane '{name}'"
        self.body = body
        self._point = point
        self.radius = _scalar(owner, "radius", radius, 0.0)
        self.p = _vector(owner, "plane_point", plane_point, 3)
        self.n = _unit(owner, "normal", normal, 3)
        self.t1, self.t2 = plane_tangents(owner, self.n, tangent)

    def resolve(self, lookup):
        owner = f"SpatialSphereOnPlane '{self.name}'"
        self.body = _body(owner, lookup, self.body, "body")
        if not getattr(self.body.node, "rotation_blocks", ()):
            raise ModelError(f"{owner}: body '{self.body.name}' is planar; use SphereOnPlane")
        self.s = np.asarray(self.body.local(self._point, "point"), dtype=float)

    def nodes(self):
        return [self.body.node]

    @classmethod
    def pack(cls, elements):
        P = np.array([[*e.s, e.radius, *e.p, *e.n, *e.t1, *e.t2] for e in elements], dtype=float)
        return {"P": np.ascontiguousarray(P)}

    @classmethod
    def contact_frames(cls, P, qe):
        C, _ = _spatial_points(qe, P[:, 0:3])
        n = P[:, 7:10]
        gN = np.einsum("ej,ej->e", n, C - P[:, 4:7]) - P[:, 3]
        return C - P[:, 3:4] * n, n, np.stack((P[:, 10:13], P[:, 13:16]), axis=1), gN


# ---------------------------------------------------------------------------
# spatial: two spheres on two spatial bodies (frame nodes), outside each other
# ---------------------------------------------------------------------------
#: below these the pair's geometry is undefined (the kernel writes NaN, femb.contact.simulate stops with a
#: ContactError that names the pair): centre distance |d| ≤ PAIR_MIN_DISTANCE (R_a + R_b) (no normal), or
#: 1 + n·p ≤ PAIR_MIN_POLE (the normal turned to the opposite of its initial direction p: no tangents)
PAIR_MIN_DISTANCE = 1e-12
PAIR_MIN_POLE = 1e-6
#: an open pair whose gap exceeds PAIR_CHART_GAP (R_a + R_b) and whose normal has turned by more than 120°
#: from its initial direction p (n·p < −1/2) takes its tangents from the opposite chart, (f₁, −f₂, −p): the
#: smallest rotation from −p to n. An open pair carries no friction force, so which chart it uses changes
#: no force; a pair that closes is back within PAIR_CHART_GAP first, where it uses (f₁, f₂, p)
PAIR_CHART_GAP = 1e-2


@kernel
def pair_tangent(n, f, p):
    """t = f − (n·f)/(1 + n·p) (n + p): the image of f (a unit vector ⊥ p) under the smallest rotation
    that takes p to n (so |t| = 1, t ⊥ n, and (t₁, t₂, n) is right-handed when (f₁, f₂, p) is)."""
    b = dot3(n, f) / (1.0 + dot3(n, p))
    return (f[0] - b * (n[0] + p[0]), f[1] - b * (n[1] + p[1]), f[2] - b * (n[2] + p[2]))


@kernel
def pair_tangent_d(n, f, p, dn):
    """δt of :func:`pair_tangent` along δn, with c = n·p:
    δt = −((δn·f)/(1+c) − (n·f)(δn·p)/(1+c)²)(n + p) − (n·f)/(1+c) δn."""
    c1 = 1.0 / (1.0 + dot3(n, p))
    b = dot3(n, f) * c1
    a = (dot3(dn, f) - b * dot3(dn, p)) * c1
    return (-a * (n[0] + p[0]) - b * dn[0], -a * (n[1] + p[1]) - b * dn[1], -a * (n[2] + p[2]) - b * dn[2])


@kernel
def _pair_row(W, zeta, e, k, w, wd, aa, ab, Ra, Rb, V, Vq):
    """Row k for the unit direction w(q) (rate ẇ = wd along v): γ = w·V with V the velocity of b's point at
    arm ab relative to a's at arm aa; W = (−w, −R_aᵀ(aa × w), w, R_bᵀ(ab × w)), ζ = ẇ·V + w·V̇|_v."""
    ma = mtv(Ra, cross3(aa, w))
    mb = mtv(Rb, cross3(ab, w))
    for i in range(3):
        W[e, k, i] = -w[i]
        W[e, k, 3 + i] = -ma[i]
        W[e, k, 6 + i] = w[i]
        W[e, k, 9 + i] = mb[i]
    zeta[e, k] = dot3(wd, V) + dot3(w, Vq)


@kernel
def _pair_undefined(gN, W, zeta, H, e, jac):
    """NaN in every output of element e: its geometry is undefined (see PAIR_MIN_DISTANCE)."""
    nan = math.nan
    gN[e, 0] = nan
    for k in range(W.shape[1]):
        zeta[e, k] = nan
        for j in range(W.shape[2]):
            W[e, k, j] = nan
    if jac:
        for i in range(H.shape[1]):
            for j in range(H.shape[2]):
                H[e, i, j] = nan


@kernel
def two_body_h_column(H, e, j, base, d):
    """Column j of H = ∂(Wᵀλ)/∂x for a contact between spatial bodies a and b, whose generalized force
    is Wᵀλ = (−F, −R_aᵀ(aa × F), F, R_bᵀ(ab × F)) in (r_a, Ω_a, r_b, Ω_b) (F the contact force on b at its
    arms aa, ab from the nodes). ``base`` = (R_a, R_b, F, aa, ab, R_aᵀ(aa × F), R_bᵀ(ab × F)) at the
    state; ``d`` = (δθ_a, δθ_b, δF, δaa, δab) along the column's direction. With δ(Rᵀy) = (Rᵀy) × δθ + Rᵀδy:
    H[:, j] = (−δF, −((R_aᵀ(aa × F)) × δθ_a + R_aᵀ(δaa × F + aa × δF)), δF, (…)_b)."""
    Ra, Rb, F, aa, ab, ya, yb = base
    tha, thb, dF, daa, dab = d
    ca = cross3(ya, tha)
    cb = cross3(yb, thb)
    ea = mtv(Ra, cross3(daa, F))
    fa = mtv(Ra, cross3(aa, dF))
    eb = mtv(Rb, cross3(dab, F))
    fb = mtv(Rb, cross3(ab, dF))
    for r in range(3):
        H[e, r, j] = -dF[r]
        H[e, 3 + r, j] = -(ca[r] + ea[r] + fa[r])
        H[e, 6 + r, j] = dF[r]
        H[e, 9 + r, j] = cb[r] + eb[r] + fb[r]


@kernel
def _pair_hessian(H, e, lam, geo, rot):
    """H = ∂(Wᵀλ)/∂x of one pair, column by column along the 12 tangent directions (δr_a, δθ_a, δr_b,
    δθ_b).

    Wᵀλ is the generalized force of F = λ_N n + λ₁t₁ + λ₂t₂ on b at arm ab and −F on a at arm aa:
    (−F, −R_aᵀ(aa × F), F, R_bᵀ(ab × F)). Along δx: δd = δr_b − δr_a + R_b(δθ_b × s_b)
    − R_a(δθ_a × s_a), δn = (δd − (n·δd)n)/L, δF = λ_N δn + Σ λ_k δt_k,
    δaa = R_a(δθ_a × s_a) + R_a' δn,
    δab = R_b(δθ_b × s_b) − R_b' δn, δ(Rᵀy) = (Rᵀy) × δθ + Rᵀδy (R ← R exp(δθ~)).
    ``geo`` = (n, t₁, t₂, aa, ab, s_a, s_b, f₁, f₂, p), ``rot`` = (R_a, R_b, L, radius_a, radius_b).
    """
    n, t1, t2, aa, ab, sa, sb, f1, f2, p = geo
    Ra, Rb, L, rA, rB = rot
    lN, l1, l2 = lam
    F = (lN * n[0] + l1 * t1[0] + l2 * t2[0], lN * n[1] + l1 * t1[1] + l2 * t2[1],
         lN * n[2] + l1 * t1[2] + l2 * t2[2])
    ya = mtv(Ra, cross3(aa, F))
    yb = mtv(Rb, cross3(ab, F))
    z3 = (0.0, 0.0, 0.0)
    for j in range(12):
        blk, i = j // 3, j % 3
        u = (1.0 if i == 0 else 0.0, 1.0 if i == 1 else 0.0, 1.0 if i == 2 else 0.0)
        tha, thb = z3, z3
        if blk == 0:
            dd = (-u[0], -u[1], -u[2])
        elif blk == 1:
            tha = u
            dd = mv(Ra, cross3(sa, u))
        elif blk == 2:
            dd = u
        else:
            thb = u
            dd = mv(Rb, cross3(u, sb))
        nd = dot3(n, dd)
        dn = ((dd[0] - nd * n[0]) / L, (dd[1] - nd * n[1]) / L, (dd[2] - nd * n[2]) / L)
        d1 = pair_tangent_d(n, f1, p, dn)
        d2 = pair_tangent_d(n, f2, p, dn)
        dF = (lN * dn[0] + l1 * d1[0] + l2 * d2[0], lN * dn[1] + l1 * d1[1] + l2 * d2[1],
              lN * dn[2] + l1 * d1[2] + l2 * d2[2])
        ra = mv(Ra, cross3(tha, sa))
        rb = mv(Rb, cross3(thb, sb))
        daa = (ra[0] + rA * dn[0], ra[1] + rA * dn[1], ra[2] + rA * dn[2])
        dab = (rb[0] - rB * dn[0], rb[1] - rB * dn[1], rb[2] - rB * dn[2])
        two_body_h_column(H, e, j, (Ra, Rb, F, aa, ab, ya, yb), (tha, thb, dF, daa, dab))


@kernel
def sphere_pair_contact(P, t, tf, xe, ve, le, jac, gN, W, zeta, H):
    """Sphere (radius R_a', centre s_a on body a) against a sphere (R_b', s_b on body b), outside each other.

    c_k = r_k + R_k s_k, d = c_b − c_a, L = |d|, n = d/L, g = L − R_a' − R_b'; tangents
    t_k = f_k − (n·f_k)/(1 + n·p)(n + p) (:func:`pair_tangent`; (f₁, f₂, p) fixed, p the initial
    normal). Arms from the nodes to the contact points: aa = R_a s_a + R_a' n (a's surface point
    towards b), ab = R_b s_b − R_b' n. Rows w ∈ (n, t₁, t₂): W = (−w, −R_aᵀ(aa × w), w, R_bᵀ(ab × w)),
    the velocity V = ṙ_b − ṙ_a + ω_b × ab − ω_a × aa of b's surface point relative to a's along w
    (ω = RΩ); ζ = ẇ·V + w·(ω_b × (ω_b × R_b s_b − R_b' ṅ) − ω_a × (ω_a × R_a s_a + R_a' ṅ)) with
    ṅ = (ḋ − (n·ḋ)n)/L (ω is constant along x ∘ exp(εv)); H by :func:`_pair_hessian`.
    An open pair with g > PAIR_CHART_GAP (R_a' + R_b') and n·p < −1/2 uses (f₁, −f₂, −p) instead
    (:func:`pair_charts`). Where L ≤ PAIR_MIN_DISTANCE (R_a' + R_b') or 1 + n·p ≤ PAIR_MIN_POLE (p of
    the chart in use) every output is NaN.
    P = (s_a(3), s_b(3), R_a', R_b', f₁(3), f₂(3), p(3)).
    """
    for e in range(xe.shape[0]):
        Ra = quat_to_matrix_t(xe[e, 3], xe[e, 4], xe[e, 5], xe[e, 6])
        Rb = quat_to_matrix_t(xe[e, 10], xe[e, 11], xe[e, 12], xe[e, 13])
        sa = (P[e, 0], P[e, 1], P[e, 2])
        sb = (P[e, 3], P[e, 4], P[e, 5])
        rA, rB = P[e, 6], P[e, 7]
        f1 = (P[e, 8], P[e, 9], P[e, 10])
        f2 = (P[e, 11], P[e, 12], P[e, 13])
        p = (P[e, 14], P[e, 15], P[e, 16])
        da = mv(Ra, sa)
        db = mv(Rb, sb)
        d = (xe[e, 7] + db[0] - xe[e, 0] - da[0], xe[e, 8] + db[1] - xe[e, 1] - da[1],
             xe[e, 9] + db[2] - xe[e, 2] - da[2])
        L = math.sqrt(dot3(d, d))
        if not L > PAIR_MIN_DISTANCE * (rA + rB):
            _pair_undefined(gN, W, zeta, H, e, jac)
            continue
        n = (d[0] / L, d[1] / L, d[2] / L)
        if L - rA - rB > PAIR_CHART_GAP * (rA + rB) and dot3(n, p) < -0.5:   # open and far round: the other chart
            f2 = (-f2[0], -f2[1], -f2[2])
            p = (-p[0], -p[1], -p[2])
        if not 1.0 + dot3(n, p) > PAIR_MIN_POLE:
            _pair_undefined(gN, W, zeta, H, e, jac)
            continue
        gN[e, 0] = L - rA - rB
        t1 = pair_tangent(n, f1, p)
        t2 = pair_tangent(n, f2, p)
        aa = (da[0] + rA * n[0], da[1] + rA * n[1], da[2] + rA * n[2])
        ab = (db[0] - rB * n[0], db[1] - rB * n[1], db[2] - rB * n[2])
        wa = mv(Ra, (ve[e, 3], ve[e, 4], ve[e, 5]))
        wb = mv(Rb, (ve[e, 9], ve[e, 10], ve[e, 11]))
        va = cross3(wa, aa)
        vb = cross3(wb, ab)
        V = (ve[e, 6] - ve[e, 0] + vb[0] - va[0], ve[e, 7] - ve[e, 1] + vb[1] - va[1],
             ve[e, 8] - ve[e, 2] + vb[2] - va[2])
        ca = cross3(wa, da)
        cb = cross3(wb, db)
        dd = (ve[e, 6] - ve[e, 0] + cb[0] - ca[0], ve[e, 7] - ve[e, 1] + cb[1] - ca[1],
              ve[e, 8] - ve[e, 2] + cb[2] - ca[2])
        nd = dot3(n, dd)
        ndot = ((dd[0] - nd * n[0]) / L, (dd[1] - nd * n[1]) / L, (dd[2] - nd * n[2]) / L)
        qa = cross3(wa, (ca[0] + rA * ndot[0], ca[1] + rA * ndot[1], ca[2] + rA * ndot[2]))
        qb = cross3(wb, (cb[0] - rB * ndot[0], cb[1] - rB * ndot[1], cb[2] - rB * ndot[2]))
        Vq = (qb[0] - qa[0], qb[1] - qa[1], qb[2] - qa[2])
        _pair_row(W, zeta, e, 0, n, ndot, aa, ab, Ra, Rb, V, Vq)
        _pair_row(W, zeta, e, 1, t1, pair_tangent_d(n, f1, p, ndot), aa, ab, Ra, Rb, V, Vq)
        _pair_row(W, zeta, e, 2, t2, pair_tangent_d(n, f2, p, ndot), aa, ab, Ra, Rb, V, Vq)
        if jac:
            _pair_hessian(H, e, (le[e, 0], le[e, 1], le[e, 2]), (n, t1, t2, aa, ab, sa, sb, f1, f2, p),
                          (Ra, Rb, L, rA, rB))


def pair_charts(n, gN, radii, f1, f2, p):
    """The chart (f₁, f₂, p) each pair of a batch takes its tangents from (as :func:`sphere_pair_contact`):
    (f₁, −f₂, −p) where the pair is open by more than PAIR_CHART_GAP (R_a + R_b) and n·p < −1/2, else
    (f₁, f₂, p). ``n`` (nel, 3) unit normals, ``gN`` (nel,) gaps, ``radii`` (nel,) R_a + R_b."""
    other = (gN > PAIR_CHART_GAP * radii) & (np.einsum("ej,ej->e", n, p) < -0.5)
    sign = np.where(other, -1.0, 1.0)[:, None]
    return f1, sign * f2, sign * p


def pair_tangents(n, f1, f2, p):
    """Numpy twin of :func:`pair_tangent` for a batch: t₁, t₂ (nel, 3) of unit normals n (nel, 3)."""
    s = n + p
    c1 = 1.0 / (1.0 + np.einsum("ej,ej->e", n, p))
    t1 = f1 - (np.einsum("ej,ej->e", n, f1) * c1)[:, None] * s
    t2 = f2 - (np.einsum("ej,ej->e", n, f2) * c1)[:, None] * s
    return t1, t2


def _spatial_body(owner, lookup, ref, role, planar="DiscOnDisc"):
    """A spatial body (the mechanism's ground: its fixed spatial twin) for ``role``; ModelError naming owner
    (and ``planar``, the type to use in the plane)."""
    from .bodies import Ground
    from .spatial_bodies import SpatialGround, spatial_ground

    if isinstance(ref, SpatialGround):
        return ref
    b = lookup(ref, role)
    if isinstance(b, Ground):
        return spatial_ground(b)
    if getattr(b, "node", None) is None or not getattr(b.node, "rotation_blocks", ()):
        raise ModelError(f"{owner}: {role} = '{getattr(b, 'name', b)}' is a planar body; the pair needs spatial "
                         f"bodies (use {planar} in the plane)")
    return b


class SpatialSpherePair(ContactElement):
    """Two spheres on two spatial bodies, outside each other, with isotropic Coulomb friction.

    Centres c_a = r_a + R_a s_a, c_b = r_b + R_b s_b, d = c_b − c_a; gap g_N = |d| − R_a' − R_b'
    (R_a', R_b' the radii), normal n = d/|d| from a to b (the force λ_N n acts on b, −λ_N n on a);
    the gap, W_N and W_F of Glocker (Set-Valued Force Laws, Springer 2001, Ch. 7–8; the spatial
    form of Pfeiffer & Glocker 1996, Ch. 4). Friction acts on the slip
    γ_F,k = t_k·(velocity of b's surface point c_b − R_b' n − velocity of a's point c_a + R_a' n).

    The tangents turn with n: t_k = f_k − (n·f_k)/(1 + n·p)(n + p), the images of two fixed
    directions f₁, f₂ under the smallest rotation taking p to n, where p is the normal in the initial
    configuration and (f₁, f₂, p) are right-handed (:func:`tangents`); so (t₁, t₂, n) is right-handed
    and smooth in q everywhere except at n = −p, where no tangent basis is defined (a pair whose line
    of centres turns by 180° from its initial direction stops the run with a ContactError; the kernel
    writes NaN there, never a wrong number). Either body may be the mechanism's ground (``"ground"``:
    a sphere fixed in space).

    Parameters
    ----------
    name : str
    a, b : spatial body, name, or ``"ground"``
    radius_a, radius_b : float ≥ 0, radius_a + radius_b > 0
    point_a, point_b : (3,) or name
        Sphere centres in body axes.
    e_N, mu, e_F : see :class:`ContactElement`.
    """

    spatial = True
    n_friction = 2
    kernels = {"contact": sphere_pair_contact}

    def __init__(self, name, a, b, radius_a, radius_b, point_a=(0.0, 0.0, 0.0), point_b=(0.0, 0.0, 0.0),
                 e_N=0.0, mu=0.0, e_F=0.0):
        super().__init__(name, e_N, mu, e_F)
        owner = f"SpatialSpherePair '{name}'"
        self.a, self.b = a, b
        self.Ra = _scalar(owner, "radius_a", radius_a, 0.0)
        self.Rb = _scalar(owner, "radius_b", radius_b, 0.0)
        if not self.Ra + self.Rb > 0.0:
            raise ModelError(f"{owner}: radius_a + radius_b must be positive (two points never touch), "
                             f"got {self.Ra:g} and {self.Rb:g}")
        _points(owner, 3, point_a=point_a, point_b=point_b)
        self._pa, self._pb = point_a, point_b

    def resolve(self, lookup):
        owner = f"SpatialSpherePair '{self.name}'"
        self.a, self.b = _two_bodies(owner, (self.a, self.b), ("a", "b"),
                                     lambda r, w: _spatial_body(owner, lookup, r, w))
        self.sa = _local(owner, self.a, self._pa, "point_a")
        self.sb = _local(owner, self.b, self._pb, "point_b")

    def validate(self):
        owner = f"SpatialSpherePair '{self.name}'"
        d = self.b.global_point(self.sb) - self.a.global_point(self.sa)
        L = float(np.linalg.norm(d))
        if not L > PAIR_MIN_DISTANCE * (self.Ra + self.Rb):
            raise ModelError(f"{owner}: the sphere centres (point_a on '{self.a.name}', point_b on "
                             f"'{self.b.name}') coincide initially: no normal direction")
        self.p = d / L
        self.f1, self.f2 = tangents(self.p)

    def nodes(self):
        return [self.a.node, self.b.node]

    @classmethod
    def pack(cls, elements):
        P = np.array([[*e.sa, *e.sb, e.Ra, e.Rb, *e.f1, *e.f2, *e.p] for e in elements], dtype=float)
        return {"P": np.ascontiguousarray(P.reshape(-1, 17))}

    @classmethod
    def sphere_pairs(cls, P, qe, ve):
        """The two spheres (:meth:`ContactElement.sphere_pairs`): c = r + R s, v = ṙ + ω × R s (ω = R Ω);
        the rotations formed only for the spheres off their body's node (s ≠ 0)."""
        out = []
        for x, v, s in ((0, 0, P[:, 0:3]), (7, 6, P[:, 3:6])):
            c, w = qe[:, x:x + 3].copy(), ve[:, v:v + 3].copy()
            off = np.nonzero(np.any(s != 0.0, axis=1))[0]
            if off.size:
                c_off, R = _spatial_points(qe[off], s[off], col=x)
                c[off] = c_off
                w[off] += np.cross(np.einsum("eij,ej->ei", R, ve[off, v + 3:v + 6]), c_off - qe[off, x:x + 3])
            out.append((c, w))
        return out[0][0], out[1][0], out[0][1], out[1][1], P[:, 6].copy(), P[:, 7].copy()

    @classmethod
    def contact_frames(cls, P, qe):
        """Contact point c = c_a + R_a' n (a's surface point towards b), n, (t₁, t₂), g_N."""
        ca, _ = _spatial_points(qe, P[:, 0:3])
        cb, _ = _spatial_points(qe, P[:, 3:6], col=7)
        d = cb - ca
        L = np.linalg.norm(d, axis=1)
        n = d / np.where(L > 0.0, L, 1.0)[:, None]
        gN = L - P[:, 6] - P[:, 7]
        t1, t2 = pair_tangents(n, *pair_charts(n, gN, P[:, 6] + P[:, 7], P[:, 8:11], P[:, 11:14], P[:, 14:17]))
        return ca + P[:, 6:7] * n, n, np.stack((t1, t2), axis=1), gN

    @classmethod
    def geometry_problems(cls, P, qe):
        """Pairs whose geometry is undefined or close to it at one state (docs/contact.md §2)."""
        ca, _ = _spatial_points(qe, P[:, 0:3])
        cb, _ = _spatial_points(qe, P[:, 3:6], col=7)
        d = cb - ca
        L = np.linalg.norm(d, axis=1)
        n = d / np.where(L > 0.0, L, 1.0)[:, None]
        _, _, p = pair_charts(n, L - P[:, 6] - P[:, 7], P[:, 6] + P[:, 7], P[:, 8:11], P[:, 11:14], P[:, 14:17])
        out = []
        for e in range(len(L)):
            R = P[e, 6] + P[e, 7]
            if not L[e] > 1e-3 * R:
                out.append((e, f"the sphere centres are {L[e]:.3g} m apart (radii sum {R:.4g} m): "
                               "the normal is not defined where they coincide"))
            elif not 1.0 + n[e] @ p[e] > 1e-3:
                out.append((e, f"the normal n = {np.round(n[e], 6).tolist()} has turned to (nearly) the "
                               f"opposite of its initial direction {np.round(P[e, 14:17], 6).tolist()} with the "
                               f"spheres {L[e] - R:.3g} m apart (within {PAIR_CHART_GAP:g} (R_a + R_b) of "
                               "touching), where the pair's tangent basis is singular"))
        return out


# ---------------------------------------------------------------------------
# spatial: a sphere of one spatial body on a plane fixed to another
# ---------------------------------------------------------------------------
@kernel
def _body_plane_hessian(H, e, geo, rot):
    """H = ∂(Wᵀλ)/∂x of :func:`spatial_sphere_body_plane_contact`, column by column along the 12 tangent
    directions (δr_a, δθ_a, δr_b, δθ_b).

    Wᵀλ = (−F, −R_aᵀ(aa × F), F, R_bᵀ(ab × F)), F = λ_N n + λ₁t₁ + λ₂t₂ = R_a F̄. Along δx:
    δF = (R_a δθ_a) × F, δn = (R_a δθ_a) × n, δd_b = (R_b δθ_b) × d_b (d_b = R_b s),
    δab = δd_b − R_s δn, δaa = δr_b − δr_a + δab, δ(Rᵀy) = (Rᵀy) × δθ + Rᵀδy (R ← R exp(δθ~)).
    ``geo`` = (n, F, aa, ab, d_b), ``rot`` = (R_a, R_b, R_s).
    """
    n, F, aa, ab, db = geo
    Ra, Rb, rs = rot
    ya = mtv(Ra, cross3(aa, F))
    yb = mtv(Rb, cross3(ab, F))
    z3 = (0.0, 0.0, 0.0)
    for j in range(12):
        blk, i = j // 3, j % 3
        u = (1.0 if i == 0 else 0.0, 1.0 if i == 1 else 0.0, 1.0 if i == 2 else 0.0)
        tha, thb, dF, dab, dr = z3, z3, z3, z3, z3
        if blk == 0:
            dr = (-u[0], -u[1], -u[2])
        elif blk == 1:
            tha = u
            ga = mv(Ra, u)
            dF = cross3(ga, F)
            dn = cross3(ga, n)
            dab = (-rs * dn[0], -rs * dn[1], -rs * dn[2])
        elif blk == 2:
            dr = u
        else:
            thb = u
            dab = cross3(mv(Rb, u), db)
        daa = (dr[0] + dab[0], dr[1] + dab[1], dr[2] + dab[2])
        two_body_h_column(H, e, j, (Ra, Rb, F, aa, ab, ya, yb), (tha, thb, dF, daa, dab))


@kernel
def spatial_sphere_body_plane_contact(P, t, tf, xe, ve, le, jac, gN, W, zeta, H):
    """Sphere (radius R_s, centre s on body b) on the plane through p̄ with unit normal n̄ fixed to body a.

    Nodes (a, b) = (plane body, sphere body). n = R_a n̄, t_k = R_a t̄_k (body-fixed tangents, defined
    everywhere), plane point P = r_a + R_a p̄, centre C = r_b + d_b, d_b = R_b s; g = n·(C − P) − R_s.
    Contact point c = C − R_s n, arms aa = c − r_a, ab = c − r_b = d_b − R_s n. Rows w ∈ (n, t₁, t₂) by
    :func:`_pair_row`: W = (−w, −R_aᵀ(aa × w), w, R_bᵀ(ab × w)), w·V with
    V = ṙ_b − ṙ_a + ω_b × ab − ω_a × aa (ω = RΩ) the velocity of b's material point at c relative to
    a's; W_N = ∂g/∂q (the ω_a terms of ṅ = ω_a × n and Ṗ combine into −ω_a·(aa × n)). ζ = ẇ·V + w·V̇
    with ẇ = ω_a × w, V̇ = ω_b × ȧb − ω_a × ȧa, ȧb = ω_b × d_b − R_s ω_a × n, ȧa = ṙ_b − ṙ_a + ȧb (ω is
    constant along x ∘ exp(εv)); H by :func:`_body_plane_hessian`.
    P = (p̄(3), n̄(3), t̄₁(3), t̄₂(3), s(3), R_s).
    """
    for e in range(xe.shape[0]):
        Ra = quat_to_matrix_t(xe[e, 3], xe[e, 4], xe[e, 5], xe[e, 6])
        Rb = quat_to_matrix_t(xe[e, 10], xe[e, 11], xe[e, 12], xe[e, 13])
        pw = mv(Ra, (P[e, 0], P[e, 1], P[e, 2]))
        n = mv(Ra, (P[e, 3], P[e, 4], P[e, 5]))
        t1 = mv(Ra, (P[e, 6], P[e, 7], P[e, 8]))
        t2 = mv(Ra, (P[e, 9], P[e, 10], P[e, 11]))
        db = mv(Rb, (P[e, 12], P[e, 13], P[e, 14]))
        rs = P[e, 15]
        ca = (xe[e, 7] + db[0] - xe[e, 0], xe[e, 8] + db[1] - xe[e, 1], xe[e, 9] + db[2] - xe[e, 2])   # C − r_a
        gN[e, 0] = n[0] * (ca[0] - pw[0]) + n[1] * (ca[1] - pw[1]) + n[2] * (ca[2] - pw[2]) - rs
        aa = (ca[0] - rs * n[0], ca[1] - rs * n[1], ca[2] - rs * n[2])
        ab = (db[0] - rs * n[0], db[1] - rs * n[1], db[2] - rs * n[2])
        wa = mv(Ra, (ve[e, 3], ve[e, 4], ve[e, 5]))
        wb = mv(Rb, (ve[e, 9], ve[e, 10], ve[e, 11]))
        rd = (ve[e, 6] - ve[e, 0], ve[e, 7] - ve[e, 1], ve[e, 8] - ve[e, 2])
        va = cross3(wa, aa)
        vb = cross3(wb, ab)
        V = (rd[0] + vb[0] - va[0], rd[1] + vb[1] - va[1], rd[2] + vb[2] - va[2])
        ndot = cross3(wa, n)
        wd = cross3(wb, db)
        abd = (wd[0] - rs * ndot[0], wd[1] - rs * ndot[1], wd[2] - rs * ndot[2])
        qa = cross3(wa, (rd[0] + abd[0], rd[1] + abd[1], rd[2] + abd[2]))
        qb = cross3(wb, abd)
        Vq = (qb[0] - qa[0], qb[1] - qa[1], qb[2] - qa[2])
        _pair_row(W, zeta, e, 0, n, ndot, aa, ab, Ra, Rb, V, Vq)
        _pair_row(W, zeta, e, 1, t1, cross3(wa, t1), aa, ab, Ra, Rb, V, Vq)
        _pair_row(W, zeta, e, 2, t2, cross3(wa, t2), aa, ab, Ra, Rb, V, Vq)
        if jac:
            lN, l1, l2 = le[e, 0], le[e, 1], le[e, 2]
            F = (lN * n[0] + l1 * t1[0] + l2 * t2[0], lN * n[1] + l1 * t1[1] + l2 * t2[1],
                 lN * n[2] + l1 * t1[2] + l2 * t2[2])
            _body_plane_hessian(H, e, (n, F, aa, ab, db), (Ra, Rb, rs))


class SpatialSphereOnBodyPlane(ContactElement):
    """A point or sphere of a spatial body on a plane fixed to another spatial body, with isotropic Coulomb
    friction.

    The plane passes through p̄ with unit normal n̄, both in ``plane_body``'s axes: in space
    P = r_a + R_a p̄, n = R_a n̄ (a = plane_body). The sphere's centre is C = r_b + R_b s (b = body);
    g_N = n·(C − P) − R_s. The tangents t_k = R_a t̄_k are fixed in a (t̄₁ = ``tangent`` projected on the
    plane, or chosen from n̄ by :func:`tangents`; t̄₂ = n̄ × t̄₁, so (t₁, t₂, n) is right-handed): defined
    at every state. The normal force λ_N n and the friction forces λ_k t_k act on ``body`` at the contact
    point c = C − R_s n, their opposites on ``plane_body`` at the same point (its moment about a's node
    is (c − r_a) × F); γ_F,k = t_k·(velocity of b's material point at c − velocity of a's material point
    at c). With ``plane_body="ground"`` (its fixed twin, as :class:`SpatialSpherePair` allows) it is
    :class:`SpatialSphereOnPlane`. The plane is unbounded: keep the sphere over the part of a you mean.
    The geometry of :class:`~femb.elements.penalty_contact.SpatialPenaltySphereOnBodyPlane`.

    Parameters
    ----------
    name : str
    body : spatial body or name
        The body that carries the sphere.
    plane_body : spatial body or name
        The body that carries the plane (or ``"ground"``); not ``body``.
    radius : float ≥ 0
    point : (3,) or name
        Sphere centre in ``body``'s axes.
    plane_point : (3,) or name
        A point of the plane in ``plane_body``'s axes.
    normal : (3,)
        The plane's normal in ``plane_body``'s axes (to the free side; normalised).
    tangent : (3,), optional
        t̄₁ in ``plane_body``'s axes (its part orthogonal to n̄).
    e_N, mu, e_F : see :class:`ContactElement`.

    Notes
    -----
    Nodes (plane_body, body): the sphere's body is the second body b of a pair (docs/contact.md §2).
    Kernel :func:`spatial_sphere_body_plane_contact`; ``P = (p̄, n̄, t̄₁, t̄₂, s, R_s)``.
    """

    spatial = True
    n_friction = 2
    kernels = {"contact": spatial_sphere_body_plane_contact}

    def __init__(self, name, body, plane_body, radius=0.0, point=(0.0, 0.0, 0.0), plane_point=(0.0, 0.0, 0.0),
                 normal=(0.0, 0.0, 1.0), tangent=None, e_N=0.0, mu=0.0, e_F=0.0):
        super().__init__(name, e_N, mu, e_F)
        owner = f"SpatialSphereOnBodyPlane '{name}'"
        self.body, self.plane_body = body, plane_body
        self.radius = _scalar(owner, "radius", radius, 0.0)
        self.nbar = _unit(owner, "normal", normal, 3)
        self.t1bar, self.t2bar = plane_tangents(owner, self.nbar, tangent)
        _points(owner, 3, point=point, plane_point=plane_point)
        self._point, self._plane_point = point, plane_point

    def resolve(self, lookup):
        owner = f"SpatialSphereOnBodyPlane '{self.name}'"
        self.body, self.plane_body = _two_bodies(owner, (self.body, self.plane_body), ("body", "plane_body"),
                                                 lambda r, w: _spatial_body(owner, lookup, r, w, "SphereOnBodyPlane"))
        self.s = _local(owner, self.body, self._point, "point")
        self.pbar = _local(owner, self.plane_body, self._plane_point, "plane_point")

    def nodes(self):
        return [self.plane_body.node, self.body.node]

    @classmethod
    def pack(cls, elements):
        P = np.array([[*e.pbar, *e.nbar, *e.t1bar, *e.t2bar, *e.s, e.radius] for e in elements], dtype=float)
        return {"P": np.ascontiguousarray(P.reshape(-1, 16))}

    @classmethod
    def contact_frames(cls, P, qe):
        """Contact point c = C − R_s n (the sphere's point nearest the plane), n = R_a n̄, (t₁, t₂), g_N."""
        Pl, Ra = _spatial_points(qe, P[:, 0:3])
        n, t1, t2 = (np.einsum("eij,ej->ei", Ra, P[:, k:k + 3]) for k in (3, 6, 9))
        C, _ = _spatial_points(qe, P[:, 12:15], col=7)
        gN = np.einsum("ej,ej->e", n, C - Pl) - P[:, 15]
        return C - P[:, 15:16] * n, n, np.stack((t1, t2), axis=1), gN


# ---------------------------------------------------------------------------
# spatial: pin in a bushing (a revolute joint with clearance in space)
# ---------------------------------------------------------------------------
from ._spatial import add3, scale3, sub3  # noqa: E402  (this section's own imports: kept apart for merges)

#: below this offset of the pin point from the bushing axis, |d⊥| ≤ PIN_MIN_OFFSET (R_h − R_p), the normal
#: d⊥/|d⊥| is not defined: the gap is exact (the whole clearance, the contact is open) and the rows use the
#: direction f fixed in the bushing instead (SpatialPinInBushing, docstring)
PIN_MIN_OFFSET = 1e-9


@kernel
def _pin_geometry(xe, P, e):
    """(R_a, R_b, R_a s, R_b c, e, d, z, L, n, regular) of element e of a pin–bushing batch: d the pin point
    relative to the axis point, z = e·d, L = |d − z e|, n = (d − z e)/L where L > PIN_MIN_OFFSET (R_h − R_p),
    else R_b f (``regular`` False)."""
    Ra = quat_to_matrix_t(xe[e, 3], xe[e, 4], xe[e, 5], xe[e, 6])
    Rb = quat_to_matrix_t(xe[e, 10], xe[e, 11], xe[e, 12], xe[e, 13])
    da = mv(Ra, (P[e, 0], P[e, 1], P[e, 2]))
    db = mv(Rb, (P[e, 3], P[e, 4], P[e, 5]))
    ax = mv(Rb, (P[e, 6], P[e, 7], P[e, 8]))
    d = (xe[e, 0] + da[0] - xe[e, 7] - db[0], xe[e, 1] + da[1] - xe[e, 8] - db[1],
         xe[e, 2] + da[2] - xe[e, 9] - db[2])
    z = dot3(ax, d)
    dp = (d[0] - z * ax[0], d[1] - z * ax[1], d[2] - z * ax[2])
    L = math.sqrt(dot3(dp, dp))
    regular = L > PIN_MIN_OFFSET * (P[e, 12] - P[e, 13])
    if regular:
        n = (dp[0] / L, dp[1] / L, dp[2] / L)
    else:
        n = mv(Rb, (P[e, 9], P[e, 10], P[e, 11]))
    return Ra, Rb, da, db, ax, d, z, L, n, regular


@kernel
def _pin_normal_d(n, ax, d, z, dd, de, L, regular, dnf):
    """δn of the pin–bushing normal for δd, δe: (δd⊥ − (n·δd⊥)n)/L with
    δd⊥ = δd − (δe·d + e·δd) e − z δe (regular), else ``dnf`` (the variation of the bushing-fixed R_b f);
    returns (δn, δz)."""
    dz = dot3(de, d) + dot3(ax, dd)
    if not regular:
        return dnf, dz
    dp = (dd[0] - dz * ax[0] - z * de[0], dd[1] - dz * ax[1] - z * de[1], dd[2] - dz * ax[2] - z * de[2])
    nd = dot3(n, dp)
    return ((dp[0] - nd * n[0]) / L, (dp[1] - nd * n[1]) / L, (dp[2] - nd * n[2]) / L), dz


@kernel
def _pin_hessian(H, e, lam, geo, rot):
    """H = ∂(Wᵀλ)/∂x of one pin–bushing contact, column by column along (δr_a, δθ_a, δr_b, δθ_b).

    Wᵀλ = (−F, −R_aᵀ(aa × F), F, R_bᵀ(ab × F)) with F = λ_N n + λ₁ e + λ₂ e × n. Along δx:
    δd = δr_a + R_a(δθ_a × s) − δr_b − R_b(δθ_b × c), δe = R_b(δθ_b × e_b), δz = δe·d + e·δd, δn by
    :func:`_pin_normal_d`, δF = λ_N δn + λ₁ δe + λ₂ (δe × n + e × δn), δaa = R_a(δθ_a × s) + R_p δn,
    δab = R_b(δθ_b × c) + δz e + z δe + R_h δn, δ(Rᵀy) = (Rᵀy) × δθ + Rᵀδy.
    ``geo`` = (n, e, e × n, aa, ab, d, z, s, c, e_b, f), ``rot`` = (R_a, R_b, L, R_h, R_p, regular).
    """
    n, ax, t2, aa, ab, d, z, s, c, eb, f = geo
    Ra, Rb, L, rH, rP, regular = rot
    lN, l1, l2 = lam
    F = (lN * n[0] + l1 * ax[0] + l2 * t2[0], lN * n[1] + l1 * ax[1] + l2 * t2[1],
         lN * n[2] + l1 * ax[2] + l2 * t2[2])
    ya = mtv(Ra, cross3(aa, F))
    yb = mtv(Rb, cross3(ab, F))
    z3 = (0.0, 0.0, 0.0)
    for j in range(12):
        blk, i = j // 3, j % 3
        u = (1.0 if i == 0 else 0.0, 1.0 if i == 1 else 0.0, 1.0 if i == 2 else 0.0)
        tha, thb, dra, drb = z3, z3, z3, z3
        if blk == 0:
            dra = u
        elif blk == 1:
            tha = u
        elif blk == 2:
            drb = u
        else:
            thb = u
        dda = mv(Ra, cross3(tha, s))
        ddb = mv(Rb, cross3(thb, c))
        de = mv(Rb, cross3(thb, eb))
        dd = sub3(add3(dra, dda), add3(drb, ddb))
        dn, dz = _pin_normal_d(n, ax, d, z, dd, de, L, regular, mv(Rb, cross3(thb, f)))
        dt2 = add3(cross3(de, n), cross3(ax, dn))
        dF = (lN * dn[0] + l1 * de[0] + l2 * dt2[0], lN * dn[1] + l1 * de[1] + l2 * dt2[1],
              lN * dn[2] + l1 * de[2] + l2 * dt2[2])
        daa = add3(dda, scale3(rP, dn))
        dab = (ddb[0] + dz * ax[0] + z * de[0] + rH * dn[0], ddb[1] + dz * ax[1] + z * de[1] + rH * dn[1],
               ddb[2] + dz * ax[2] + z * de[2] + rH * dn[2])
        two_body_h_column(H, e, j, (Ra, Rb, F, aa, ab, ya, yb), (tha, thb, dF, daa, dab))


@kernel
def pin_bushing_contact(P, t, tf, xe, ve, le, jac, gN, W, zeta, H):
    """Pin point s on body a (the pin, radius R_p) in the cylindrical hole of body b (the bushing, radius R_h,
    axis through c along the unit e_b, both in b's axes).

    d = r_a + R_a s − r_b − R_b c, e = R_b e_b, z = e·d, d⊥ = d − z e, L = |d⊥|, n = d⊥/L (from the axis to
    the pin point; λ_N n acts on the bushing, −λ_N n on the pin); g = (R_h − R_p) − L. Tangents t₁ = e
    (axial), t₂ = e × n (circumferential). Arms from the nodes to the contact points: aa = R_a s + R_p n
    (the pin's surface point towards the wall), ab = R_b c + z e + R_h n (the hole's surface point there).
    Rows w ∈ (n, t₁, t₂): W = (−w, −R_aᵀ(aa × w), w, R_bᵀ(ab × w)), the velocity
    V = ṙ_b + ω_b × ab − ṙ_a − ω_a × aa of the bushing's point relative to the pin's along w (ω = RΩ);
    W_N v = −n·ḋ + z n·ė = ġ_N. ζ = ẇ·V + w·(ω_b × ȧb − ω_a × ȧa) (ω is constant along x ∘ exp(εv)),
    ȧa = ω_a × R_a s + R_p ṅ, ȧb = ω_b × R_b c + ż e + z ė + R_h ṅ, ė = ω_b × e, ż = ė·d + e·ḋ,
    ṅ = (ḋ⊥ − (n·ḋ⊥)n)/L with ḋ⊥ = ḋ − ż e − z ė, ṫ₂ = ė × n + e × ṅ; H by :func:`_pin_hessian`.
    Where L ≤ PIN_MIN_OFFSET (R_h − R_p) (the pin point on the axis, no normal) g is still exact (the whole
    clearance: open) and the rows are those of the bushing-fixed direction n = R_b f (ṅ = ω_b × n).
    P = (s(3), c(3), e_b(3), f(3), R_h, R_p, e_pin(3)); e_pin (the pin's axis in a's axes) is for output.
    """
    for e in range(xe.shape[0]):
        Ra, Rb, da, db, ax, d, z, L, n, regular = _pin_geometry(xe, P, e)
        rH, rP = P[e, 12], P[e, 13]
        gN[e, 0] = rH - rP - L
        t2 = cross3(ax, n)
        aa = add3(da, scale3(rP, n))
        ab = (db[0] + z * ax[0] + rH * n[0], db[1] + z * ax[1] + rH * n[1], db[2] + z * ax[2] + rH * n[2])
        wa = mv(Ra, (ve[e, 3], ve[e, 4], ve[e, 5]))
        wb = mv(Rb, (ve[e, 9], ve[e, 10], ve[e, 11]))
        ra = (ve[e, 0], ve[e, 1], ve[e, 2])
        rb = (ve[e, 6], ve[e, 7], ve[e, 8])
        V = sub3(add3(rb, cross3(wb, ab)), add3(ra, cross3(wa, aa)))
        ca = cross3(wa, da)
        cb = cross3(wb, db)
        dd = sub3(add3(ra, ca), add3(rb, cb))
        edot = cross3(wb, ax)
        ndot, zd = _pin_normal_d(n, ax, d, z, dd, edot, L, regular, cross3(wb, n))
        aad = add3(ca, scale3(rP, ndot))
        abd = (cb[0] + zd * ax[0] + z * edot[0] + rH * ndot[0], cb[1] + zd * ax[1] + z * edot[1] + rH * ndot[1],
               cb[2] + zd * ax[2] + z * edot[2] + rH * ndot[2])
        Vq = sub3(cross3(wb, abd), cross3(wa, aad))
        _pair_row(W, zeta, e, 0, n, ndot, aa, ab, Ra, Rb, V, Vq)
        _pair_row(W, zeta, e, 1, ax, edot, aa, ab, Ra, Rb, V, Vq)
        _pair_row(W, zeta, e, 2, t2, add3(cross3(edot, n), cross3(ax, ndot)), aa, ab, Ra, Rb, V, Vq)
        if jac:
            geo = (n, ax, t2, aa, ab, d, z, (P[e, 0], P[e, 1], P[e, 2]), (P[e, 3], P[e, 4], P[e, 5]),
                   (P[e, 6], P[e, 7], P[e, 8]), (P[e, 9], P[e, 10], P[e, 11]))
            _pin_hessian(H, e, (le[e, 0], le[e, 1], le[e, 2]), geo, (Ra, Rb, L, rH, rP, regular))


def _pin_frames(P, qe):
    """Numpy twin of :func:`_pin_geometry` for a batch: dict of the axis e, the normal n (R_b f where the pin
    point is on the axis), L = |d⊥|, z, the axis point x = r_b + R_b c, the pin's axis R_a e_pin and g_N."""
    p, Ra = _spatial_points(qe, P[:, 0:3])
    x, Rb = _spatial_points(qe, P[:, 3:6], col=7)
    ax = np.einsum("eij,ej->ei", Rb, P[:, 6:9])
    d = p - x
    z = np.einsum("ej,ej->e", ax, d)
    dp = d - z[:, None] * ax
    L = np.linalg.norm(dp, axis=1)
    regular = L > PIN_MIN_OFFSET * (P[:, 12] - P[:, 13])
    n = np.where(regular[:, None], dp / np.where(regular, L, 1.0)[:, None], np.einsum("eij,ej->ei", Rb, P[:, 9:12]))
    return {"e": ax, "n": n, "L": L, "z": z, "x": x, "pin_axis": np.einsum("eij,ej->ei", Ra, P[:, 14:17]),
            "gN": P[:, 12] - P[:, 13] - L}


def _pin_spatial_body(owner, lookup, ref, role):
    """A spatial body (the mechanism's ground: its fixed spatial twin) for ``role``; ModelError naming owner."""
    from .bodies import Ground
    from .spatial_bodies import SpatialGround, spatial_ground

    if isinstance(ref, SpatialGround):
        return ref
    b = lookup(ref, role)
    if isinstance(b, Ground):
        return spatial_ground(b)
    if getattr(b, "node", None) is None or not getattr(b.node, "rotation_blocks", ()):
        raise ModelError(f"{owner}: {role} = '{getattr(b, 'name', b)}' is a planar body; the pin and the bushing "
                         "must be spatial bodies (use PinInHole in the plane)")
    return b


def _pin_axis_spec(owner, what, spec):
    """An axis given as a name (checked at resolve) or a non-zero 3-vector (normalised here)."""
    return spec if isinstance(spec, str) else _unit(owner, what, spec, 3)


def _pin_body_axis(owner, body, spec, what):
    if not isinstance(spec, str):
        return np.asarray(spec, dtype=float)
    try:
        return np.asarray(body.axes[spec], dtype=float)
    except (KeyError, AttributeError):
        raise ModelError(f"{owner}: {what}: body '{body.name}' has no axis named '{spec}' "
                         f"(known: {sorted(getattr(body, 'axes', {})) or 'none'})") from None


class SpatialPinInBushing(ContactElement):
    """A point of a pin's axis in the cylindrical hole of a bushing: one contact of a revolute joint with
    clearance in space (use :func:`pin_bushing` for the joint: two of them, at the bushing's ends).

    Geometry. Body b (the bushing) has a cylindrical hole of radius R_h whose axis passes through c along
    the unit vector e_b (both in b's axes); body a (the pin, or shaft) is a cylinder of radius R_p < R_h,
    and s (in a's axes) is a point of its axis. With c_b = r_b + R_b c, e = R_b e_b and
    d = (r_a + R_a s) − c_b, the radial offset of the pin point from the hole's axis is d⊥ = d − (e·d) e and

        g_N = (R_h − R_p) − |d⊥|,   n = d⊥/|d⊥|  (from the hole's axis towards the pin point).

    The normal force λ_N n acts on the bushing (b) and −λ_N n on the pin (a), which it pushes back
    towards the axis: as on every pair, n is the direction in which λ_N pushes body b
    (:meth:`ContactElement.contact_frames`; :class:`PinInHole` is the planar case, with its pin on b). The
    tangents follow the bodies, t₁ = e (axial) and t₂ = e × n (circumferential), defined wherever n is
    (t₁ × t₂ = −n: (t₁, t₂, −n) is right-handed, −n the direction that pushes the pin); the slip
    γ_F,k = t_k·(V_b − V_a) is the velocity of the hole's surface point c_b + (e·d) e + R_h n (a material
    point of b) relative to the pin's surface point r_a + R_a s + R_p n (of a), and the friction force
    λ_F,k t_k acts on b, −λ_F,k t_k on a. In a plane normal to the axis (e = +z) γ_F,2 is
    :class:`PinInHole`'s slip, t·ė − R_p ω_pin + R_h ω_hole. The gap and rows are Glocker's (Set-Valued
    Force Laws, Springer 2001, Ch. 7–8; Pfeiffer & Glocker, Multibody Dynamics with Unilateral Contacts,
    Wiley 1996, Ch. 4) for the revolute clearance joint (Flores, Ambrósio, Claro & Lankarani, Kinematics
    and Dynamics of Multibody Systems with Imperfect Joints, Springer 2008, Ch. 4, planar; the spatial
    joint: the same authors, Proc. IMechE Part K 220 (2006) 257–271).

    Assumptions (the model, not the exact contact of two cylinders):

    * the hole is an infinite cylinder and the contact is checked at the pin point s, fixed in the pin:
      a pin that slides along the axis by Δ carries its check point with it (the bushing's end is not
      tracked), so with a tilt β its gap is that of a station Δ away from the bushing's end, off by about
      Δ tan β;
    * a pin tilted by β against the hole's axis meets the hole along an ellipse (semi-axes R_p and
      R_p/cos β in the plane normal to e), not a circle: the gap is too large by R_p (1/cos β − 1)
      ≈ R_p β²/2. It matters when that nears the clearance, β ≈ √(2 (R_h − R_p)/R_p); inside a bushing of
      length ℓ the tilt is at most about 2 (R_h − R_p)/ℓ, where the error is 2 R_p (R_h − R_p)²/ℓ² (a
      fraction 2 R_p (R_h − R_p)/ℓ² of the clearance). :meth:`geometry_problems` reports a tilt whose
      error exceeds a tenth of the clearance.

    Where the pin point is on the hole's axis (|d⊥| ≤ PIN_MIN_OFFSET (R_h − R_p)) the normal is not
    defined. The gap is then exact, the whole clearance R_h − R_p (open), and the rows use the direction
    n = R_b f fixed in the bushing (f ⊥ e_b, :func:`tangents`): a supergradient of the gap there (g_N ≤
    (R_h − R_p) − n·d⊥), never NaN, so a concentric start is allowed; :meth:`geometry_problems` names it.

    Parameters
    ----------
    name : str
    pin : spatial body, name, or ``"ground"``
        Body a, the pin (a fixed axle: ``"ground"``).
    bushing : spatial body, name, or ``"ground"``
        Body b, with the hole (a bushing fixed in space: ``"ground"``).
    hole_radius, pin_radius : float, hole_radius > pin_radius ≥ 0
    centre : (3,) or name
        A point of the hole's axis c, in the bushing's axes.
    axis : (3,) or name
        The hole's axis e_b in the bushing's axes (normalised; a name: one of the bushing's named axes).
    pin_point : (3,) or name
        The point s of the pin's axis where the gap is checked, in the pin's axes.
    offset : float
        Moves c along e_b and s along the pin's axis by this (m): the contact's station along the joint
        (:func:`pin_bushing` uses ±length/2).
    pin_axis : (3,), optional
        The pin's axis in its own axes (for ``offset`` and the tilt report); default: the hole's axis in
        the initial configuration, R_a0ᵀ R_b0 e_b.
    e_N, mu, e_F : see :class:`ContactElement`.
    """

    spatial = True
    n_friction = 2
    kernels = {"contact": pin_bushing_contact}

    def __init__(self, name, pin, bushing, hole_radius, pin_radius, centre=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0),
                 pin_point=(0.0, 0.0, 0.0), offset=0.0, pin_axis=None, e_N=0.0, mu=0.0, e_F=0.0):
        super().__init__(name, e_N, mu, e_F)
        owner = f"SpatialPinInBushing '{name}'"
        self.a, self.b = pin, bushing
        self.Rh = _scalar(owner, "hole_radius", hole_radius, 0.0)
        self.Rp = _scalar(owner, "pin_radius", pin_radius, 0.0)
        if not self.Rh > self.Rp:
            raise ModelError(f"{owner}: hole_radius ({self.Rh:g}) must exceed pin_radius ({self.Rp:g})")
        _points(owner, 3, centre=centre, pin_point=pin_point)
        self._centre, self._pin_point = centre, pin_point
        self._axis = _pin_axis_spec(owner, "axis", axis)
        self._pin_axis = None if pin_axis is None else _unit(owner, "pin_axis", pin_axis, 3)
        self.offset = _scalar(owner, "offset", offset)

    def resolve(self, lookup):
        owner = f"SpatialPinInBushing '{self.name}'"
        self.a, self.b = _two_bodies(owner, (self.a, self.b), ("pin", "bushing"),
                                     lambda r, w: _pin_spatial_body(owner, lookup, r, w))
        self.s0 = _local(owner, self.a, self._pin_point, "pin_point")
        self.c0 = _local(owner, self.b, self._centre, "centre")
        eb = _pin_body_axis(owner, self.b, self._axis, "axis")
        self.eb = eb / np.linalg.norm(eb)

    def validate(self):
        Ra0, Rb0 = self.a.node.rotation0, self.b.node.rotation0
        self.e_pin = Ra0.T @ (Rb0 @ self.eb) if self._pin_axis is None else self._pin_axis
        self.c = self.c0 + self.offset * self.eb
        self.s = self.s0 + self.offset * self.e_pin
        self.f = tangents(self.eb)[0]

    def nodes(self):
        return [self.a.node, self.b.node]

    @classmethod
    def pack(cls, elements):
        P = np.array([[*e.s, *e.c, *e.eb, *e.f, e.Rh, e.Rp, *e.e_pin] for e in elements], dtype=float)
        return {"P": np.ascontiguousarray(P.reshape(-1, 17))}

    @classmethod
    def contact_frames(cls, P, qe):
        """Contact point: the hole's surface point c_b + (e·d) e + R_h n at the pin point's station; n (the
        direction λ_N pushes the bushing), (t₁, t₂) = (e, e × n), g_N."""
        f = _pin_frames(P, qe)
        n, ax = f["n"], f["e"]
        c = f["x"] + f["z"][:, None] * ax + P[:, 12:13] * n
        return c, n, np.stack((ax, np.cross(ax, n)), axis=1), f["gN"]

    @classmethod
    def geometry_problems(cls, P, qe):
        """Contacts whose pin point is (nearly) on the hole's axis (no normal; open), or whose pin is tilted
        so far that the pin-point model's gap error R_p (1/cos β − 1) exceeds a tenth of the clearance."""
        f = _pin_frames(P, qe)
        clear = P[:, 12] - P[:, 13]
        out = []
        for e in range(len(clear)):
            cosb = abs(float(f["e"][e] @ f["pin_axis"][e]))
            if not f["L"][e] > 1e-6 * clear[e]:
                out.append((e, f"the pin point is {f['L'][e]:.3g} m from the bushing's axis (clearance "
                               f"{clear[e]:.4g} m): the normal is not defined there (the contact is open; "
                               "its rows use a direction fixed in the bushing)"))
            elif P[e, 13] * (1.0 / max(cosb, 1e-300) - 1.0) > 0.1 * clear[e]:
                out.append((e, f"the pin is tilted by {math.degrees(math.acos(min(cosb, 1.0))):.3g}° against "
                               f"the bushing's axis: the pin-point model's gap error R_p (1/cos β − 1) "
                               f"exceeds a tenth of the clearance {clear[e]:.4g} m"))
        return out


def pin_bushing(name, pin_body, bushing_body, hole_radius, pin_radius, length, centre=(0.0, 0.0, 0.0),
                axis=(0.0, 0.0, 1.0), pin_point=(0.0, 0.0, 0.0), pin_axis=None, e_N=0.0, mu=0.0, e_F=0.0):
    """A revolute joint with clearance in space: two :class:`SpatialPinInBushing` at the bushing's ends.

    Parameters
    ----------
    name : str
    pin_body, bushing_body : spatial body, name, or ``"ground"``
    hole_radius, pin_radius : float, hole_radius > pin_radius ≥ 0
    length : float > 0
        The bushing's length ℓ: the contacts sit at ±ℓ/2 along the axis from ``centre`` (on the bushing)
        and from ``pin_point`` (on the pin).
    centre, axis : (3,) or name
        The bushing's middle and its axis, in the bushing's axes.
    pin_point : (3,) or name
        The pin's point that sits at ``centre`` when the joint is centred, in the pin's axes.
    pin_axis, e_N, mu, e_F : see :class:`SpatialPinInBushing`.

    Returns
    -------
    list of SpatialPinInBushing
        ``<name>.end0`` at −ℓ/2 and ``<name>.end1`` at +ℓ/2.
    """
    owner = f"pin_bushing '{name}'"
    ell = _scalar(owner, "length", length, 0.0)
    if not ell > 0.0:
        raise ModelError(f"{owner}: length must be positive, got {length!r}")
    return [SpatialPinInBushing(f"{name}.end{k}", pin_body, bushing_body, hole_radius, pin_radius, centre, axis,
                                pin_point, offset=o, pin_axis=pin_axis, e_N=e_N, mu=mu, e_F=e_F)
            for k, o in enumerate((-0.5 * ell, 0.5 * ell))]
