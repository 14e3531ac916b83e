"""Force elements: springs and dampers, applied loads, gravity (planar).

Each element type writes its equations once, as compiled kernels (``@kernel``,
see docs/kernels.md): :func:`spring_damper_force`, :func:`rotational_spring_force`,
:func:`torque_force`, :func:`point_force`. Loads read their time functions from
``tf[e, k, 0/1/2]`` = (f, f′, f″) at the kernel's time. Gravity has no kernel: the
model assembles it as M ĝ.

References
----------
M. Géradin, A. Cardona, Flexible Multibody Dynamics, Wiley, 2001, Ch. 9.
"""
from __future__ import annotations

import math

import numpy as np

from femb.base.functions import Constant, as_time_function, evaluate
from femb.base.geometry import GeometryBlock
from femb.base.jit import kernel
from femb.errors import ModelError
from femb.system.element import Element

from .bodies import _check_scalar, _point
from .joints import PairElement
from ._planar import perp, rot


class _DampedBatches:
    """Instances with and without damping (``self.c``) form separate batches, so
    the model assembles no C_t for the undamped ones."""

    def group_key(self):
        return (type(self).__name__, self.c != 0.0)

    @classmethod
    def traits(cls, elements):
        tr = super().traits(elements)
        tr["force_depends_on_qd"] = any(e.c != 0.0 for e in elements)
        return tr


# ---------------------------------------------------------------------------
# SpringDamper
# ---------------------------------------------------------------------------
@kernel
def write_pair_blocks(out, e, X11, X12, X21, X22, pa1, pa2, pb1, pb2, ma1, ma2, mb1, mb2, taa, tab, tba, tbb):
    """Write the 6 × 6 Jacobian of a two-node planar element that depends on r_b − r_a into ``out[e]``.

    Rows and columns (r_a, θ_a, r_b, θ_b); X is 2 × 2, p_a, p_b, m_a, m_b are 2-vectors::

        [[ X,    p_a,  −X,    p_b ],
         [ m_aᵀ, t_aa, −m_aᵀ, t_ab],
         [−X,   −p_a,   X,   −p_b ],
         [ m_bᵀ, t_ba, −m_bᵀ, t_bb]]

    (a function of r_b − r_a has opposite derivatives with respect to r_a and r_b, and so have
    forces that act with opposite signs on the two nodes).
    """
    out[e, 0, 0] = X11
    out[e, 0, 1] = X12
    out[e, 0, 2] = pa1
    out[e, 0, 3] = -X11
    out[e, 0, 4] = -X12
    out[e, 0, 5] = pb1
    out[e, 1, 0] = X21
    out[e, 1, 1] = X22
    out[e, 1, 2] = pa2
    out[e, 1, 3] = -X21
    out[e, 1, 4] = -X22
    out[e, 1, 5] = pb2
    out[e, 2, 0] = ma1
    out[e, 2, 1] = ma2
    out[e, 2, 2] = taa
    out[e, 2, 3] = -ma1
    out[e, 2, 4] = -ma2
    out[e, 2, 5] = tab
    out[e, 3, 0] = -X11
    out[e, 3, 1] = -X12
    out[e, 3, 2] = -pa1
    out[e, 3, 3] = X11
    out[e, 3, 4] = X12
    out[e, 3, 5] = -pb1
    out[e, 4, 0] = -X21
    out[e, 4, 1] = -X22
    out[e, 4, 2] = -pa2
    out[e, 4, 3] = X21
    out[e, 4, 4] = X22
    out[e, 4, 5] = -pb2
    out[e, 5, 0] = mb1
    out[e, 5, 1] = mb2
    out[e, 5, 2] = tba
    out[e, 5, 3] = -mb1
    out[e, 5, 4] = -mb2
    out[e, 5, 5] = tbb


@kernel
def spring_damper_force(P, t, tf, xe, ve, jac, fe, fq, fv):
    """Force of linear spring–dampers; P = (s_a, s_b, k, c, l_0), xe = (r_a, θ_a, r_b, θ_b).

    With d_a = R(θ_a) s_a, d_b = R(θ_b) s_b, D = r_b + d_b − r_a − d_a, l = |D|, e = D/l and
    G = ∂D/∂q = [−I, g_a, I, g_b], g_a = −J d_a, g_b = J d_b (J the rotation by +90°):

    * ∂l/∂q = Gᵀe = (−e, g_a·e, e, g_b·e) (``ge``), l̇ = e·(G q̇);
      tension N = k (l − l_0) + c l̇, f = −N Gᵀe;
    * f_q = −(N/l) GᵀG − ge ⊗ w + N (−e·d_a at [θ_a, θ_a], e·d_b at [θ_b, θ_b]) with
      w = (k − N/l) ge + c ∂l̇/∂q, ∂l̇/∂q = (Gᵀ(G q̇) − l̇ ge)/l + (θ̇_a e·d_a at θ_a, −θ̇_b e·d_b at θ_b);
    * f_q̇ = −c ge geᵀ (damped elements only: c ≠ 0).

    Coinciding points (l = 0, no direction) give NaN forces.
    """
    for e in range(xe.shape[0]):
        k = P[e, 4]
        c = P[e, 5]
        ca, sa = math.cos(xe[e, 2]), math.sin(xe[e, 2])
        cb, sb = math.cos(xe[e, 5]), math.sin(xe[e, 5])
        dax = ca * P[e, 0] - sa * P[e, 1]
        day = sa * P[e, 0] + ca * P[e, 1]
        dbx = cb * P[e, 2] - sb * P[e, 3]
        dby = sb * P[e, 2] + cb * P[e, 3]
        Dx = xe[e, 3] - xe[e, 0] + dbx - dax
        Dy = xe[e, 4] - xe[e, 1] + dby - day
        l = math.hypot(Dx, Dy)
        if not l > 0.0:
            for j in range(6):
                fe[e, j] = math.nan
                if jac:
                    for m in range(6):
                        fq[e, j, m] = math.nan
            continue
        ex = Dx / l
        ey = Dy / l
        gax, gay = day, -dax                 # g_a = −J d_a
        gbx, gby = -dby, dbx                 # g_b = J d_b
        gae = gax * ex + gay * ey
        gbe = gbx * ex + gby * ey
        N = k * (l - P[e, 6])
        if c != 0.0:
            Gvx = ve[e, 3] - ve[e, 0] + gax * ve[e, 2] + gbx * ve[e, 5]
            Gvy = ve[e, 4] - ve[e, 1] + gay * ve[e, 2] + gby * ve[e, 5]
            ldot = Gvx * ex + Gvy * ey
            N += c * ldot
        fe[e, 0] = N * ex
        fe[e, 1] = N * ey
        fe[e, 2] = -N * gae
        fe[e, 3] = -N * ex
        fe[e, 4] = -N * ey
        fe[e, 5] = -N * gbe
        if not jac:
            continue
        Nl = N / l
        kN = k - Nl
        eda = ex * dax + ey * day
        edb = ex * dbx + ey * dby
        wx = kN * ex
        wy = kN * ey
        wa = kN * gae
        wb = kN * gbe
        if c != 0.0:
            cl = c / l
            wx += cl * (Gvx - ldot * ex)
            wy += cl * (Gvy - ldot * ey)
            wa += cl * (gax * Gvx + gay * Gvy - ldot * gae) + c * ve[e, 2] * eda
            wb += cl * (gbx * Gvx + gby * Gvy - ldot * gbe) - c * ve[e, 5] * edb
            write_pair_blocks(fv, e, -c * ex * ex, -c * ex * ey, -c * ey * ex, -c * ey * ey,
                              c * gae * ex, c * gae * ey, c * gbe * ex, c * gbe * ey,
                              c * gae * ex, c * gae * ey, c * gbe * ex, c * gbe * ey,
                              -c * gae * gae, -c * gae * gbe, -c * gbe * gae, -c * gbe * gbe)
        gab = gax * gbx + gay * gby
        write_pair_blocks(fq, e, -Nl - ex * wx, -ex * wy, -ey * wx, -Nl - ey * wy,
                          Nl * gax + ex * wa, Nl * gay + ey * wa, Nl * gbx + ex * wb, Nl * gby + ey * wb,
                          Nl * gax + gae * wx, Nl * gay + gae * wy, Nl * gbx + gbe * wx, Nl * gby + gbe * wy,
                          -Nl * (gax * gax + gay * gay) - gae * wa - N * eda, -Nl * gab - gae * wb,
                          -Nl * gab - gbe * wa, -Nl * (gbx * gbx + gby * gby) - gbe * wb + N * edb)


@kernel
def spring_damper_energy(P, t, tf, xe, Ve):
    """Potential of linear springs, V = ½ k (l − l_0)² (the conservative part of
    :func:`spring_damper_force`: f(q, 0) = −∂V/∂q); P and xe as there."""
    for e in range(xe.shape[0]):
        ca, sa = math.cos(xe[e, 2]), math.sin(xe[e, 2])
        cb, sb = math.cos(xe[e, 5]), math.sin(xe[e, 5])
        Dx = xe[e, 3] - xe[e, 0] + cb * P[e, 2] - sb * P[e, 3] - (ca * P[e, 0] - sa * P[e, 1])
        Dy = xe[e, 4] - xe[e, 1] + sb * P[e, 2] + cb * P[e, 3] - (sa * P[e, 0] + ca * P[e, 1])
        dl = math.hypot(Dx, Dy) - P[e, 6]
        Ve[e] = 0.5 * P[e, 4] * dl * dl


class SpringDamper(_DampedBatches, PairElement):
    """Linear spring–damper between point P_a of body a and P_b of body b.

    Tension N = k (l − l_0) + c l̇ along the line of the points; the force on
    P_b is −N e and on P_a is +N e, e = (r_b − r_a)/l.

    Parameters
    ----------
    name : str
    a, b : Body or str
    stiffness : float ≥ 0
    damping : float ≥ 0, optional
    length : float ≥ 0, optional
        Unstretched length l_0 (default: the initial distance).
    point_a, point_b : str or (x, y)
        The attachment points (default: the nodes).

    Notes
    -----
    Kernel: :func:`spring_damper_force`; ``P = (s_a, s_b, k, c, l_0)``.
    """
    glyph = "spring"  # how pictures draw it (femb.io.frames)

    has_force = True
    work = "potential"
    kernels = {"force": spring_damper_force, "energy": spring_damper_energy}

    def __init__(self, name, a, b, stiffness, damping=0.0, length=None, point_a=None, point_b=None):
        super().__init__(name, a, b)
        owner = f"SpringDamper '{name}'"
        self.k = _check_scalar(owner, "stiffness", stiffness, nonneg=True)
        self.c = _check_scalar(owner, "damping", damping, nonneg=True)
        self.l0 = None if length is None else _check_scalar(owner, "length", length, nonneg=True)
        self._spec = (point_a, point_b)

    def validate(self):
        self.sa, self.sb = self._points(None, *self._spec)
        l_init = float(np.linalg.norm(self.b.global_point(self.sb) - self.a.global_point(self.sa)))
        if self.l0 is None:
            self.l0 = l_init
        if l_init == 0.0:
            raise ModelError(f"SpringDamper '{self.name}': its two points coincide initially (zero length has no direction)")

    @classmethod
    def pack(cls, elements):
        sa = np.array([e.sa for e in elements], dtype=float).reshape(-1, 2)
        sb = np.array([e.sb for e in elements], dtype=float).reshape(-1, 2)
        k = np.array([e.k for e in elements], dtype=float)
        c = np.array([e.c for e in elements], dtype=float)
        l0 = np.array([e.l0 for e in elements], dtype=float)
        P = np.ascontiguousarray(np.column_stack((sa, sb, k, c, l0)))
        return {"P": P, "sa": sa, "sb": sb, "k": k, "c": c, "l0": l0}

    @classmethod
    def geometry(cls, p, t, qe, qde, lame, names, n_zig=12):
        qe = np.ascontiguousarray(qe, dtype=float)
        qde = np.ascontiguousarray(qde, dtype=float)
        n = qe.shape[0]
        ra = qe[:, 0:2] + rot(qe[:, 2], p["sa"])
        D = qe[:, 3:5] + rot(qe[:, 5], p["sb"]) - ra
        l = np.hypot(D[:, 0], D[:, 1])
        e = D / np.where(l > 0.0, l, np.nan)[:, None]
        fe = np.zeros((n, 6))
        spring_damper_force(p["P"], float(t), np.zeros((n, 0, 3)), qe, qde, False, fe,
                            np.zeros((n, 6, 6)), np.zeros((n, 6, 6)))
        N = -np.einsum("ij,ij->i", fe[:, 3:5], e)       # the force on P_b is −N e
        m = n_zig + 2
        s = np.linspace(0.0, 1.0, m)
        amp = np.zeros(m)
        amp[1:-1:2] = 1.0
        amp[2:-1:2] = -1.0
        amp[1], amp[-2] = 0.0, 0.0
        width = 0.08 * p["l0"] + 1e-12
        pts = np.zeros((n, m, 3))
        pts[:, :, :2] = (ra[:, None, :] + s[None, :, None] * D[:, None, :]
                         + (amp[None, :, None] * width[:, None, None]) * perp(e)[:, None, :])
        conn = np.arange(n * m).reshape(n, m)
        lines = np.stack((conn[:, :-1], conn[:, 1:]), axis=-1).reshape(-1, 2)
        rep = m - 1
        return [GeometryBlock("SpringDamper", pts.reshape(-1, 3), [("line", lines)],
                              cell_data={"force": [np.repeat(N, rep)],
                                         "elongation": [np.repeat(l - p["l0"], rep)]})]


# ---------------------------------------------------------------------------
# RotationalSpringDamper
# ---------------------------------------------------------------------------
@kernel
def rotational_spring_force(P, t, tf, xe, ve, jac, fe, fq, fv):
    """Torsional spring–dampers; P = (k, c, θ_0).

    M = k (θ_b − θ_a − θ_0) + c (θ̇_b − θ̇_a); f_θa = M, f_θb = −M;
    f_q = −k g gᵀ and f_q̇ = −c g gᵀ (damped elements only) with g = ∂(θ_b − θ_a)/∂q.
    """
    for e in range(xe.shape[0]):
        k = P[e, 0]
        c = P[e, 1]
        Mz = k * (xe[e, 5] - xe[e, 2] - P[e, 2]) + c * (ve[e, 5] - ve[e, 2])
        fe[e, 2] = Mz
        fe[e, 5] = -Mz
        if jac:
            fq[e, 2, 2] = -k
            fq[e, 5, 5] = -k
            fq[e, 2, 5] = k
            fq[e, 5, 2] = k
            if c != 0.0:
                fv[e, 2, 2] = -c
                fv[e, 5, 5] = -c
                fv[e, 2, 5] = c
                fv[e, 5, 2] = c


@kernel
def rotational_spring_energy(P, t, tf, xe, Ve):
    """Potential of torsional springs, V = ½ k (θ_b − θ_a − θ_0)²; P = (k, c, θ_0)."""
    for e in range(xe.shape[0]):
        d = xe[e, 5] - xe[e, 2] - P[e, 2]
        Ve[e] = 0.5 * P[e, 0] * d * d


class RotationalSpringDamper(_DampedBatches, PairElement):
    """Torsional spring–damper between the rotations of bodies a and b.

    Torque on b: −(k (θ_b − θ_a − θ_0) + c (θ̇_b − θ̇_a)), the opposite on a.

    Parameters
    ----------
    name : str
    a, b : Body or str
    stiffness : float ≥ 0
    damping : float ≥ 0
    angle : float, optional
        Unstretched relative angle θ_0 (default: the initial one).

    Notes
    -----
    Kernel: :func:`rotational_spring_force`; ``P = (k, c, θ_0)``.
    """
    glyph = "torsion"  # how pictures draw it (femb.io.frames)

    has_force = True
    work = "potential"
    kernels = {"force": rotational_spring_force, "energy": rotational_spring_energy}

    def __init__(self, name, a, b, stiffness, damping=0.0, angle=None):
        super().__init__(name, a, b)
        owner = f"RotationalSpringDamper '{name}'"
        self.k = _check_scalar(owner, "stiffness", stiffness, nonneg=True)
        self.c = _check_scalar(owner, "damping", damping, nonneg=True)
        self.phi0 = None if angle is None else _check_scalar(owner, "angle", angle)

    def validate(self):
        if self.phi0 is None:
            self.phi0 = float(self.b.node.q0[2] - self.a.node.q0[2])

    @classmethod
    def pack(cls, elements):
        k = np.array([e.k for e in elements], dtype=float)
        c = np.array([e.c for e in elements], dtype=float)
        phi0 = np.array([e.phi0 for e in elements], dtype=float)
        return {"P": np.ascontiguousarray(np.column_stack((k, c, phi0))), "k": k, "c": c, "phi0": phi0}


# ---------------------------------------------------------------------------
# loads
# ---------------------------------------------------------------------------
class _BodyLoad(Element):
    """A load on one body."""

    has_force = True
    work = "load"                    # an applied load: its work ∫ fe·ve dt (femb.results.energy)

    def __init__(self, name, body):
        super().__init__(name)
        self.body = body

    def resolve(self, lookup):
        self.body = lookup(self.body, "body")

    def nodes(self):
        return [self.body.node]


@kernel
def torque_force(P, t, tf, xe, ve, jac, fe, fq, fv):
    """Applied torques T(t) = tf[e, 0, 0] on θ; P unused (one dummy column); f_q = 0."""
    for e in range(xe.shape[0]):
        fe[e, 2] = tf[e, 0, 0]


class Torque(_BodyLoad):
    """Applied torque T(t) on a body (positive counter-clockwise).

    Parameters
    ----------
    name : str
    body : Body or str
    torque : float, TimeFunction or (f, df, ddf)

    Notes
    -----
    Kernel: :func:`torque_force`; one time function per element (T). Constant
    torques form their own batch, evaluated once (``constant_force``).
    """
    glyph = "load"  # how pictures draw it (femb.io.frames)

    kernels = {"force": torque_force}

    def __init__(self, name, body, torque):
        super().__init__(name, body)
        self.fn = as_time_function(torque, f"Torque '{name}'", "torque")

    def group_key(self):
        return ("Torque", isinstance(self.fn, Constant))

    @classmethod
    def traits(cls, elements):
        tr = super().traits(elements)
        tr["constant_force"] = all(isinstance(e.fn, Constant) for e in elements)
        return tr

    @classmethod
    def time_functions(cls, element):
        return [element.fn]

    @classmethod
    def pack(cls, elements):
        return {"P": np.zeros((len(elements), 1)), "fn": [e.fn for e in elements]}

    @classmethod
    def geometry(cls, p, t, qe, qde, lame, names):
        T = evaluate(p["fn"], t, 0)
        return _load_geometry("Torque", qe[:, 0:2], np.zeros((qe.shape[0], 2)), {"torque": T})


@kernel
def point_force(P, t, tf, xe, ve, jac, fe, fq, fv):
    """Applied forces at a body point; P = (s, body_frame), F_body/global = (tf[e,0,0], tf[e,1,0]).

    F = R(θ) F̄ for follower forces (body_frame = 1), else F̄; d = R(θ) s;
    f = (F, (J d)·F). f_q: ∂F/∂θ = J F (followers), ∂((J d)·F)/∂θ = −d·F for a
    fixed direction and 0 for a follower (its moment arm and direction turn together).
    """
    for e in range(xe.shape[0]):
        c, s = math.cos(xe[e, 2]), math.sin(xe[e, 2])
        Fx = tf[e, 0, 0]
        Fy = tf[e, 1, 0]
        follower = P[e, 2] != 0.0
        if follower:
            Fx, Fy = c * Fx - s * Fy, s * Fx + c * Fy
        dx = c * P[e, 0] - s * P[e, 1]
        dy = s * P[e, 0] + c * P[e, 1]
        fe[e, 0] = Fx
        fe[e, 1] = Fy
        fe[e, 2] = dx * Fy - dy * Fx
        if jac:
            if follower:
                fq[e, 0, 2] = -Fy
                fq[e, 1, 2] = Fx
            else:
                fq[e, 2, 2] = -(dx * Fx + dy * Fy)


class Force(_BodyLoad):
    """Applied force F(t) at a body point.

    Parameters
    ----------
    name : str
    body : Body or str
    force : (Fx, Fy) of numbers, or of TimeFunctions / (f, df, ddf) triples
    point : str or (x, y), optional
        Application point (default: the node).
    frame : {"global", "body"}
        Components in the inertial frame (default) or in the body frame
        (a follower force that turns with the body).

    Notes
    -----
    Kernel: :func:`point_force`; ``P = (s, body_frame)``; two time functions per
    element (F_x, F_y).
    """
    glyph = "load"  # how pictures draw it (femb.io.frames)

    kernels = {"force": point_force}

    def __init__(self, name, body, force, point=None, frame="global"):
        super().__init__(name, body)
        try:
            comps = list(force)
        except TypeError:
            raise ModelError(f"Force '{name}': force must have two components, got {force!r}") from None
        if len(comps) != 2:
            raise ModelError(f"Force '{name}': force must have two components, got {force!r}")
        self.fns = [as_time_function(c, f"Force '{name}'", f"force[{i}]") for i, c in enumerate(comps)]
        if frame not in ("global", "body"):
            raise ModelError(f"Force '{name}': frame must be 'global' or 'body', got {frame!r}")
        self.frame = frame
        self._point = point

    def validate(self):
        self.s = self.body.local((0.0, 0.0) if self._point is None else self._point, "point")

    @classmethod
    def time_functions(cls, element):
        return list(element.fns)

    @classmethod
    def pack(cls, elements):
        s = np.array([e.s for e in elements], dtype=float).reshape(-1, 2)
        body_frame = np.array([e.frame == "body" for e in elements])
        return {"P": np.ascontiguousarray(np.column_stack((s, body_frame.astype(float)))),
                "fx": [e.fns[0] for e in elements], "fy": [e.fns[1] for e in elements],
                "s": s, "body_frame": body_frame}

    @classmethod
    def geometry(cls, p, t, qe, qde, lame, names):
        Fb = np.stack((evaluate(p["fx"], t, 0), evaluate(p["fy"], t, 0)), axis=1)
        th = qe[:, 2]
        F = np.where(p["body_frame"][:, None], rot(th, Fb), Fb)
        return _load_geometry("Force", qe[:, 0:2] + rot(th, p["s"]), F)


def _load_geometry(name, pts2, vec2, extra=None):
    n = pts2.shape[0]
    pts = np.zeros((n, 3))
    pts[:, :2] = pts2
    vec = np.zeros((n, 3))
    vec[:, :2] = vec2
    pd = {"load": vec}
    if extra:
        pd.update(extra)
    return [GeometryBlock(name, pts, [("vertex", np.arange(n)[:, None])], point_data=pd)]


class Gravity(Element):
    """Uniform gravity acting on every mass of the mechanism.

    The generalized gravity force is M ĝ, where ĝ holds g at the translational
    coordinates of every node (exact for rigid bodies with their node at the
    centre of mass, and for consistent beam mass matrices). With a constant
    mass matrix it is assembled once.

    Parameters
    ----------
    g : (gx, gy)
        Acceleration of gravity (m/s²), e.g. (0, -9.81).
    name : str
    """

    #: a uniform field on every mass, assembled by the model as M ĝ (no kernels; femb.system.model reads this trait)
    gravity_field = True

    def __init__(self, g=(0.0, -9.81), name="gravity"):
        super().__init__(name)
        self.g = _point(f"Gravity '{name}'", "g", g)
