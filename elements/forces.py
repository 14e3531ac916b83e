"""Force elements: springs and dampers, applied loads, gravity (planar).

References
----------
M. Géradin, A. Cardona, Flexible Multibody Dynamics, Wiley, 2001, Ch. 9.
"""
from __future__ import annotations

import numpy as np

from femb.element import Element
from femb.errors import ModelError
from femb.functions import Constant, as_time_function, evaluate
from femb.geometry import GeometryBlock

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
    """

    has_force = True

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
        sa = np.array([e.sa for e in elements])
        sb = np.array([e.sb for e in elements])
        G0 = np.zeros((len(elements), 2, 6))   # constant part of ∂D/∂q
        G0[:, 0, 0] = G0[:, 1, 1] = -1.0
        G0[:, 0, 3] = G0[:, 1, 4] = 1.0
        return {"sa": sa, "sb": sb, "s_c": np.stack((sa[:, 0] + 1j * sa[:, 1], sb[:, 0] + 1j * sb[:, 1]), axis=1),
                "k": np.array([e.k for e in elements]), "c": np.array([e.c for e in elements]),
                "l0": np.array([e.l0 for e in elements]), "G0": G0,
                "damped": any(e.c != 0.0 for e in elements)}

    @classmethod
    def _kin(cls, p, qe):
        """Attachment offsets d_a, d_b, separation D = r_b − r_a, length l, direction e, ∂l/∂q."""
        d = (np.exp(1j * qe[:, 2::3]) * p["s_c"]).view(np.float64)   # [d_a, d_b] in one product
        da = d[:, 0:2]
        db = d[:, 2:4]
        D = qe[:, 3:5] - qe[:, 0:2]
        D += db
        D -= da
        l = np.hypot(D[:, 0], D[:, 1])
        if l.min() <= 0.0:
            raise FloatingPointError("SpringDamper: zero length (the two points coincide)")
        e = D / l[:, None]
        ge = np.empty((qe.shape[0], 6))            # ∂l/∂q = Gᵀe, G = ∂D/∂q = [−I, −J d_a, I, J d_b]
        ge[:, 3:5] = e
        ge[:, 0:2] = -e
        ge[:, 2] = da[:, 1] * e[:, 0] - da[:, 0] * e[:, 1]
        ge[:, 5] = db[:, 0] * e[:, 1] - db[:, 1] * e[:, 0]
        return da, db, D, l, e, ge

    @classmethod
    def _G(cls, p, da, db):
        G = p["G0"].copy()
        G[:, 0, 2] = da[:, 1]
        G[:, 1, 2] = -da[:, 0]
        G[:, 0, 5] = -db[:, 1]
        G[:, 1, 5] = db[:, 0]
        return G

    @classmethod
    def force(cls, p, t, qe, qde, jac):
        da, db, D, l, e, ge = cls._kin(p, qe)
        N = p["k"] * (l - p["l0"])
        damped = p["damped"]
        if damped:
            N = N + p["c"] * np.einsum("ij,ij->i", ge, qde)
        f = ge * (-N)[:, None]
        if not jac:
            return f, None, None
        # f_q = −ge ⊗ ∂N/∂q − N ∂(Gᵀe)/∂q, ∂(Gᵀe)/∂q = (GᵀG − ge geᵀ)/l + Σ e_i ∂G_i/∂q
        G = cls._G(p, da, db)
        Nl = N / l
        gg = ge[:, :, None] * ge[:, None, :]
        f_q = np.einsum("iak,iam->ikm", G, G)
        f_q *= -Nl[:, None, None]
        f_q -= (p["k"] - Nl)[:, None, None] * gg
        # Σ e_i ∂G_i/∂q: [θa,θa] = e·d_a, [θb,θb] = −e·d_b
        f_q[:, 2, 2] -= N * (e * da).sum(1)
        f_q[:, 5, 5] += N * (e * db).sum(1)
        f_qd = None
        if damped:
            # ∂l̇/∂q = (G q̇)ᵀ ∂e/∂q + eᵀ ∂(G q̇)/∂q, contributing −c ge ⊗ ∂l̇/∂q
            Gv = np.einsum("iak,ik->ia", G, qde)
            dldot = (np.einsum("ia,iak->ik", Gv, G) - (Gv * e).sum(1)[:, None] * ge) / l[:, None]
            dldot[:, 2] += qde[:, 2] * (e * da).sum(1)
            dldot[:, 5] -= qde[:, 5] * (e * db).sum(1)
            f_q -= p["c"][:, None, None] * ge[:, :, None] * dldot[:, None, :]
            f_qd = -p["c"][:, None, None] * gg
        return f, f_q, f_qd

    @classmethod
    def geometry(cls, p, t, qe, qde, lame, names, n_zig=12):
        da, db, D, l, e, ge = cls._kin(p, qe)
        ra = qe[:, 0:2] + da
        n = qe.shape[0]
        N = p["k"] * (l - p["l0"]) + p["c"] * np.einsum("ij,ij->i", ge, qde)
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
    """

    has_force = True

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
        return {"k": np.array([e.k for e in elements]), "c": np.array([e.c for e in elements]),
                "phi0": np.array([e.phi0 for e in elements]),
                "damped": any(e.c != 0.0 for e in elements)}

    @classmethod
    def force(cls, p, t, qe, qde, jac):
        n = qe.shape[0]
        Mz = p["k"] * (qe[:, 5] - qe[:, 2] - p["phi0"]) + p["c"] * (qde[:, 5] - qde[:, 2])
        f = np.zeros((n, 6))
        f[:, 2] = Mz
        f[:, 5] = -Mz
        if not jac:
            return f, None, None
        g = np.zeros(6)
        g[2], g[5] = -1.0, 1.0
        gg = np.outer(g, g)
        f_q = -p["k"][:, None, None] * gg[None]
        f_qd = -p["c"][:, None, None] * gg[None] if p["damped"] else None
        return f, f_q, f_qd


class _BodyLoad(Element):
    """A load on one body."""

    has_force = True

    def __init__(self, name, body):
        super().__init__(name)
        self.body = body

    def resolve(self, lookup):
        self.body = lookup(self.body, "body")

    def nodes(self):
        return [self.body.node]


class Torque(_BodyLoad):
    """Applied torque T(t) on a body (positive counter-clockwise).

    Parameters
    ----------
    name : str
    body : Body or str
    torque : float, TimeFunction or (f, df, ddf)
    """

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
    def pack(cls, elements):
        return {"fn": [e.fn for e in elements]}

    @classmethod
    def force(cls, p, t, qe, qde, jac):
        f = np.zeros((qe.shape[0], 3))
        f[:, 2] = evaluate(p["fn"], t, 0)
        return f, (np.zeros((qe.shape[0], 3, 3)) if jac else None), None

    @classmethod
    def geometry(cls, p, t, qe, qde, lame, names):
        T = evaluate(p["fn"], t, 0)
        return _load_geometry("Torque", qe[:, 0:2], np.zeros((qe.shape[0], 2)), {"torque": T})


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
    """

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
    def pack(cls, elements):
        return {"fx": [e.fns[0] for e in elements], "fy": [e.fns[1] for e in elements],
                "s": np.array([e.s for e in elements]),
                "body_frame": np.array([e.frame == "body" for e in elements])}

    @classmethod
    def force(cls, p, t, qe, qde, jac):
        n = qe.shape[0]
        Fb = np.stack((evaluate(p["fx"], t, 0), evaluate(p["fy"], t, 0)), axis=1)
        th = qe[:, 2]
        bf = p["body_frame"]
        F = np.where(bf[:, None], rot(th, Fb), Fb)
        d = rot(th, p["s"])
        f = np.zeros((n, 3))
        f[:, 0:2] = F
        f[:, 2] = np.einsum("ij,ij->i", perp(d), F)
        if not jac:
            return f, None, None
        f_q = np.zeros((n, 3, 3))
        # ∂F/∂θ = J F for follower forces
        JF = perp(F)
        f_q[:, 0:2, 2] = np.where(bf[:, None], JF, 0.0)
        # ∂((J d)·F)/∂θ = (J J d)·F + (J d)·∂F/∂θ = −d·F + bf (J d)·(J F)
        f_q[:, 2, 2] = -np.einsum("ij,ij->i", d, F) + np.where(bf, np.einsum("ij,ij->i", d, F), 0.0)
        return f, f_q, None

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

    def __init__(self, g=(0.0, -9.81), name="gravity"):
        super().__init__(name)
        self.g = _point(f"Gravity '{name}'", "g", g)
