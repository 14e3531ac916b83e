"""Linearization of a constrained multibody model: (A, B, C, D), damped modes, steady motions.

About a reference — a static equilibrium, a given state, or a *steady motion* (a relative
equilibrium: a bicycle at constant speed, a rotor at constant spin) — small motions

    q = q₀(t) ∘ exp(δq),   v = v₀(t) + δv,   λ = λ₀ + δλ,   μ = μ₀ + δμ

(right perturbations on rotation nodes, δθ in body axes, as the time loop) obey

    δq̇ = δv + E δq,
    M δv̇ + (C_t − M Ṫ) δv + K_t δq + Φ_qᵀ δλ + Aᵀ δμ = F u,
    Φ_q δq = 0,     W δv + Z δq = 0,

with K_t = ∂(−f + Φ_qᵀλ₀ + Aᵀμ₀)/∂q (geometric, load and constraint-force terms),
C_t = −∂f/∂v (damping and gyroscopic terms), W = [Φ_q; A] the velocity-level constraints
(holonomic and non-holonomic) and Z = ∂(W v₀ + a)/∂q their change with the configuration at
fixed v. E is the kinematic term of the Lie group (−Ω₀ × δθ on a rotation) corrected for the
co-moving frame of a steady motion (below); M is constant (femb's bodies and beams).

**Elimination of the constraints** (Géradin & Cardona 2001, Ch. 10; the null-space method of
Laulusa & Bauchau, J. Comput. Nonlinear Dyn. 3 (2008) 011004): δq = N_q y with Φ_q N_q = 0,
δv = N_v w + P δq with W N_v = 0 and P = −W⁺Z (the particular velocity that keeps W δv + Z δq = 0).
Projecting the dynamics on N_v (which removes δλ and δμ) gives the minimal first-order system
s = (y, w), ṡ = A s + B u, of dimension (number of free coordinates) + (number of free velocities);
with non-holonomic constraints the second is smaller than the first (Neimark & Fufaev 1972, Ch. III).

**Steady motions** (relative equilibria; Marsden & Ratiu 1999, Sect. 4.6): q₀(t) = g_L(t) q₀(0) g_R(t)
with a world rotation g_L = exp(t ω_L) (ω_L = 0 for a straight motion) and, on each body, the rest
of its rotation, g_R = exp(t ω_R), ω_R = Ω₀ − Rᵀω_L (a wheel's spin). The perturbations measured in
the co-moving frame, δr' = g_Lᵀ δr and δθ' = g_R δθ (and the same for δṙ, δΩ), obey equations with
constant coefficients when the model is invariant under these actions (axisymmetric wheels rolling on
a plane, a symmetric rotor): A = A(0) + Ṫ(0), Ṫ = diag(ω_R ×, −ω_L ×). The coordinates along which the
steady motion drifts (position, heading, wheel angles) are then **eliminated by symmetry**: each
given symmetry (:func:`translation`, :func:`rotation`, :func:`spin`) is a direction ξ of the state
space; their span S is invariant under A (checked), and the reduced system is A restricted to the
complement of S, its block of the block-triangular form [Q_S, Q_W]ᵀ A [Q_S, Q_W] — the eigenvalues
of the steady motion proper, without the zero eigenvalues of the drift, none of them filtered.

**Drive inputs** (:func:`drive`): the prescribed value u of a driven constraint enters through
a particular solution of its linearized row, δq = N_q y + G_q u, δv = N_v w + P δq + P_u u + G_v u̇,
M-orthogonal at velocity level (N_vᵀ M G_v = 0) so that ü drops out of the reduced dynamics; the
input is (u, u̇), u̇ or ü (docs/linearize.md §4).

**Large models** (:func:`linearize_sparse`): coordinate-partitioned sparse null-space bases (Wehage & Haug,
J. Mech. Des. 104 (1982) 247–255), the sparse descriptor pair E ẋ = A_e x + B_e u and A = E⁻¹A_e as a
LinearOperator; modes by shift-invert (docs/linearize.md §5).

References: Arnold & Brüls, Multibody Syst. Dyn. 18 (2007) 185–202 (sign conventions, K_t, C_t);
Meijaard, Papadopoulos, Ruina & Schwab, Proc. R. Soc. A 463 (2007) 1955–1982 (the Whipple bicycle).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from femb.errors import ModelError, ParameterError, SingularMatrixError
from femb.system import assembly
from femb.system.initial import refuse_contacts
from femb.system import kernels as _kernels
from femb.system.model import State


# --------------------------------------------------------------------------
# the node table: what each free velocity entry is
# --------------------------------------------------------------------------
def _nodes(model):
    seen, out = set(), []
    for g in model.groups:
        for e in g.elements:
            for nd in e.nodes():
                if nd.name not in seen:
                    seen.add(nd.name)
                    out.append(nd)
    return out


def _quat(model, name, q):
    return model.node_coordinates(name, q)[3:7]


def _rot(p):
    p = np.asarray(p, dtype=float) / np.linalg.norm(p)
    w, x, y, z = p
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _skew(a):
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


class _Table:
    """Per node: velocity indices of its translations and of its rotation (None), its kind."""

    def __init__(self, model, q):
        self.items = []
        for nd in _nodes(model):
            vidx = model.node_vindex[nd.name]
            tr = [int(vidx[c]) for c in nd.translational]
            blocks = tuple(getattr(nd, "rotation_blocks", ()))
            if blocks:
                vs = blocks[0][1]
                rot = [int(i) for i in vidx[vs:vs + 3]]
                R = _rot(_quat(model, nd.name, q))
            elif getattr(nd, "kind", "") == "planar":
                rot, R = [int(vidx[2])], None
            else:
                rot, R = [], None
            self.items.append((nd, tr, rot, R))

    def blocks(self, nq):
        for nd, tr, rot, R in self.items:
            yield nd, [i for i in tr], rot, R, all(i < nq for i in tr), bool(rot) and all(i < nq for i in rot)


_TABLES = {}


def _table(model, q):
    """The node table at q (the last few kept: a sweep asks for the same one many times)."""
    key = (id(model), np.asarray(q, dtype=float).tobytes())
    tab = _TABLES.get(key)
    if tab is None or tab[0] is not model:
        if len(_TABLES) > 8:
            _TABLES.clear()
        tab = _TABLES[key] = (model, _Table(model, q))
    return tab[1]


def _kinematics(model, q, v, omega_L, steady):
    """(E, Ṫ): the kinematic term of δq̇ = δv + E δq and the co-moving frame's Ṫ, each (nq, nq)."""
    nq = model.nq
    E = np.zeros((nq, nq))
    Td = np.zeros((nq, nq))
    wL = np.zeros(3) if omega_L is None else np.asarray(omega_L, dtype=float)
    for nd, tr, rot, R, tr_free, rot_free in _table(model, q).blocks(nq):
        if len(rot) == 3 and rot_free:
            Om = v[rot]
            wR = Om - R.T @ wL if steady else np.zeros(3)
            E[np.ix_(rot, rot)] += -_skew(Om) + _skew(wR)
            Td[np.ix_(rot, rot)] += _skew(wR)
        if steady and tr and tr_free and np.any(wL != 0.0):
            S = -_skew(wL)[:len(tr), :len(tr)]
            if len(tr) == 2 and np.any(wL[:2] != 0.0):
                raise ParameterError("a planar model's steady rotation must be about z")
            E[np.ix_(tr, tr)] += S
            Td[np.ix_(tr, tr)] += S
    return E, Td


# --------------------------------------------------------------------------
# symmetries of a steady motion: directions of the state space (δq, δv)
# --------------------------------------------------------------------------
@dataclass
class Symmetry:
    """A one-parameter symmetry of the model: ``kind`` 'translation', 'rotation', 'spin' or 'direction'
    (made by :func:`translation`, :func:`rotation`, :func:`spin`, :func:`direction`)."""
    kind: str
    vector: np.ndarray
    point: np.ndarray = None
    body: str = None
    name: str = ""

    def direction(self, model, q, v):
        """ξ = (δq, δv), each (nq,), the symmetry's generator at (q, v)."""
        nq = model.nq
        if self.kind == "direction":
            return np.array(self.vector[0], dtype=float), np.array(self.vector[1], dtype=float)
        dq, dv = np.zeros(nq), np.zeros(nq)
        k = self.vector
        if self.kind == "spin" and self.body not in model.node_vindex:
            raise ModelError(f"symmetry {self.name}: model '{model.name}' has no body named '{self.body}'")
        for nd, tr, rot, R, tr_free, rot_free in _table(model, q).blocks(nq):
            if self.kind == "spin" and nd.name != self.body:
                continue
            r = model.node_coordinates(nd.name, q)[:len(tr)] if tr else None
            rd = model.node_velocities(nd.name, v)[:len(tr)] if tr else None
            if self.kind == "translation":
                vals, vvals, rv, rvv = k[:len(tr)], np.zeros(len(tr)), None, None
            elif self.kind == "rotation":
                r3 = np.zeros(3)
                r3[:len(tr)] = r - self.point[:len(tr)]
                rd3 = np.zeros(3)
                rd3[:len(tr)] = rd
                vals, vvals = np.cross(k, r3)[:len(tr)], np.cross(k, rd3)[:len(tr)]
                rv = (R.T @ k) if R is not None else (np.array([k[2]]) if rot else None)
                rvv = np.zeros(len(rot)) if rot else None
            else:
                vals = vvals = None
                Om = model.node_velocities(nd.name, v)[3:6] if R is not None else None
                rv = k if R is not None else np.array([k[2]])
                rvv = np.cross(Om, k) if R is not None else np.zeros(1)
            for idx, val, vval in ((tr, vals, vvals), (rot, rv, rvv)):
                if val is None:
                    continue
                for i, a, b in zip(idx, val, vval):
                    if i < nq:          # fixed coordinates (the ground) stay: whether the constraints
                        dq[i] += a      # to them allow the motion is checked on the constraints
                        dv[i] += b
        return dq, dv


def _fmt(v):
    return "(" + ", ".join(f"{float(x):g}" for x in v) + ")"


def _unit(what, v):
    try:
        a = np.asarray(v, dtype=float).reshape(3)
    except (TypeError, ValueError):
        raise ParameterError(f"{what} must be a 3-vector, got {v!r}") from None
    n = float(np.linalg.norm(a))
    if not (np.isfinite(n) and n > 0.0):
        raise ParameterError(f"{what} must be a finite non-zero 3-vector, got {v!r}")
    return a / n


def translation(direction, name=None):
    """The model is invariant under a translation along ``direction`` (space axes)."""
    d = _unit("translation: direction", direction)
    return Symmetry("translation", d, name=name or f"translation along {_fmt(d)}")


def rotation(axis, point=(0.0, 0.0, 0.0), name=None):
    """The model is invariant under a rotation of everything about ``axis`` through ``point`` (space axes)."""
    a = _unit("rotation: axis", axis)
    return Symmetry("rotation", a, point=np.asarray(point, dtype=float).reshape(3),
                    name=name or f"rotation about {_fmt(a)}")


def spin(body, axis, name=None):
    """The model is invariant under a rotation of ``body`` about its own ``axis`` (body axes): a wheel."""
    a = _unit("spin: axis", axis)
    return Symmetry("spin", a, body=str(body), name=name or f"spin of {body}")


def direction(dq, dv, name="direction"):
    """An explicit invariant direction (δq, δv) (each (nq,)) to eliminate with the symmetries.

    For a family of steady motions, the change of the reference along the family (e.g. the
    velocities per unit forward speed of a vehicle): the linearization maps it into the drift of
    the symmetries (it is checked), so it carries a zero eigenvalue that is eliminated with them.
    """
    return Symmetry("direction", (np.asarray(dq, dtype=float), np.asarray(dv, dtype=float)), name=name)


# --------------------------------------------------------------------------
# inputs and outputs: linear functionals of (δq, δv) and generalized forces
# --------------------------------------------------------------------------
@dataclass
class Output:
    """y = cq·δq + cv·δv (+ its rate, from the linear model, when ``rate``); or, with ``nu`` ≥ 0,
    the change of the multiplier ν[nu] of ν = (λ, μ) (a reaction, :func:`reaction`)."""
    name: str
    unit: str
    cq: np.ndarray
    cv: np.ndarray
    rate: bool = False
    nu: int = -1


@dataclass
class Input:
    """u enters as the generalized force F u (F: (nq,))."""
    name: str
    unit: str
    F: np.ndarray


def _body_rot_index(model, body, q):
    for nd, tr, rot, R, tf, rf in _table(model, q).blocks(model.nq):
        if nd.name == body:
            return tr, rot, R
    raise ModelError(f"model '{model.name}' has no node/body named '{body}'")


def _axis_row(model, q, axis, plus, minus=None):
    """(nq,) row axis·(R_plus δθ_plus − R_minus δθ_minus) in the model's rotation coordinates: the
    small rotation about the space-axes ``axis`` of body ``plus`` relative to ``minus`` (None: ground),
    and, transposed, where a torque about ``axis`` on ``plus`` (reaction on ``minus``) enters f."""
    ax = np.asarray(axis, dtype=float).reshape(3)
    ax = ax / np.linalg.norm(ax)
    row = np.zeros(model.nq)
    for b, sgn in ((plus, 1.0), (minus, -1.0)):
        if b is None:
            continue
        _, rot, R = _body_rot_index(model, b, q)
        vals = R.T @ ax if R is not None else np.array([ax[2]])
        for i, c in zip(rot, vals):
            if i < model.nq:
                row[i] += sgn * c
    return row


def angle(model, q, body, axis, relative_to=None, name=None, rate=False):
    """Small rotation of ``body`` about the space-axes ``axis`` (relative to ``relative_to``), rad.

    δφ = axis·(R_b δθ_b − R_a δθ_a); with ``rate`` its time derivative (rad/s).
    """
    cq = _axis_row(model, q, axis, body, relative_to)
    nm = name or (f"{body} angle" + (f" rel. {relative_to}" if relative_to else ""))
    return Output(nm + ("_d" if rate else ""), "rad/s" if rate else "rad", cq, np.zeros(model.nq), rate)


def reaction(model, element, row=0):
    """Output: the change of a joint's multiplier (a reaction) — λ of its constraint ``row`` (index or
    name in the type's ``constraint_names``), or μ of its velocity-constraint row (names in
    ``velocity_constraint_names``). Sign and units as the element's multipliers (docs/conventions.md)."""
    cls = None
    for g in model.groups:
        if element in g.names:
            cls = g.cls
    if cls is None:
        raise ModelError(f"model '{model.name}' has no element named '{element}'")
    lam, mu = model.lam_indices(element), model.mu_indices(element)
    names_l, names_m = tuple(cls.constraint_names), tuple(getattr(cls, "velocity_constraint_names", ()))
    if isinstance(row, str):
        if row in names_l:
            k, nu = row, int(lam[names_l.index(row)])
        elif row in names_m:
            k, nu = row, model.nc + int(mu[names_m.index(row)])
        else:
            raise ModelError(f"{cls.__name__} '{element}' has no constraint row '{row}' "
                             f"(known: {', '.join(names_l + names_m)})")
    else:
        r = int(row)
        if not 0 <= r < lam.size + mu.size:
            raise ModelError(f"{cls.__name__} '{element}' has {lam.size + mu.size} constraint rows, not row {row!r}")
        nu = int(lam[r]) if r < lam.size else model.nc + int(mu[r - lam.size])
        allnames = names_l + names_m
        k = allnames[r] if r < len(allnames) else str(r)
    units = tuple(getattr(cls, "constraint_units", ()))
    unit = units[names_l.index(k)] if k in names_l and len(units) == len(names_l) else ""
    z = np.zeros(model.nq)
    return Output(f"{element}.{k}", unit, z, z.copy(), False, nu)


def coordinate(model, label, rate=False):
    """A tangent coordinate by its velocity label (``model.velocity_labels``, e.g. 'cart.vx')."""
    try:
        i = list(model.velocity_labels).index(label)
    except ValueError:
        raise ModelError(f"model '{model.name}' has no free velocity labelled '{label}' "
                         f"(known: {', '.join(model.velocity_labels[:12])}…)") from None
    cq = np.zeros(model.nq)
    cq[i] = 1.0
    return Output(label + ("_d" if rate else ""), "", cq, np.zeros(model.nq), rate)


def torque(model, q, body, axis, reaction=None, name=None, unit="N m"):
    """Input: a torque on ``body`` about the space-axes ``axis`` (and its reaction on ``reaction``)."""
    F = _axis_row(model, q, axis, body, reaction)
    return Input(name or f"torque on {body}", unit, F)


def force(model, q, body, direction, point=(0.0, 0.0, 0.0), name=None, unit="N"):
    """Input: a force along the space-axes ``direction`` at a body point (body axes) of ``body``."""
    d = np.asarray(direction, dtype=float).reshape(-1)
    tr, rot, R = _body_rot_index(model, body, q)
    F = np.zeros(model.nq)
    for i, c in zip(tr, d[:len(tr)]):
        if i < model.nq:
            F[i] += c
    X = np.asarray(point, dtype=float).reshape(-1)
    if R is not None and np.any(X != 0.0):
        for i, c in zip(rot, np.cross(X, R.T @ d)):
            if i < model.nq:
                F[i] += c
    elif R is None and rot and np.any(X != 0.0):
        raise ParameterError("force: a point offset on a planar body is not supported; apply it at the node")
    return Input(name or f"force on {body}", unit, F)


# --------------------------------------------------------------------------
# drives as inputs: the prescribed value of a rheonomic constraint
# --------------------------------------------------------------------------
DRIVE_KINDS = ("position", "speed", "acceleration")


@dataclass
class Drive:
    """A driven (rheonomic) constraint Φ_d(q, u) = 0 whose prescribed value u is an input.

    ``kind`` says what enters the state space (docs/linearize.md §4):

    * ``"position"``: the inputs are u and u̇ (two columns, ``name`` and ``name_d``);
    * ``"speed"``: the input is u̇ (``name_d``); u joins the state (an integrator);
    * ``"acceleration"``: the input is ü (``name_dd``); u and u̇ join the state.

    Made by :func:`drive`.
    """
    name: str
    unit: str
    element: str
    kind: str = "position"


def drive(model, element, kind="position", name=None, unit=None):
    """Input: the prescribed value u(t) of the driven constraint ``element`` (its time function).

    The element must be rheonomic with one time function φ(t) (``DrivenAngle``,
    ``DrivenDisplacement``, ``DrivenRevoluteAngle``, ``DrivenPrismaticDisplacement``, or a user
    type), and the drive at rest at the reference (φ′ = φ″ = 0, checked by :func:`linearize`):
    its value is then an input δu = δφ about the held value.

    Parameters
    ----------
    model : Model
    element : str
        The driven constraint's name.
    kind : {"position", "speed", "acceleration"}
        The input signal (:class:`Drive`): (u, u̇), u̇ (u a state) or ü (u, u̇ states).
    name : str, optional
        Input name (default the element's); its rate and acceleration get ``_d``, ``_dd``.
    unit : str, optional
        Unit of u (default rad for a type whose name says Angle, m for Displacement).

    Returns
    -------
    Drive
    """
    if kind not in DRIVE_KINDS:
        raise ParameterError(f"drive '{element}': kind must be one of {', '.join(DRIVE_KINDS)}, got {kind!r}")
    g, _ = _element_group(model, element)
    if not g.cls.rheonomic or not g.time_functions or len(g.time_functions[0]) != 1:
        raise ModelError(f"drive: {g.cls.__name__} '{element}' is not a driven constraint with one time "
                         "function (a rheonomic constraint type such as DrivenAngle)")
    if unit is None:
        unit = "rad" if "Angle" in g.cls.__name__ else ("m" if "Displacement" in g.cls.__name__ else "")
    return Drive(name or element, unit, element, kind)


def _element_group(model, element):
    for g in model.groups:
        if element in g.names:
            return g, g.names.index(element)
    raise ModelError(f"model '{model.name}' has no element named '{element}'")


def _check_drives_at_rest(model, t):
    """Rheonomic constraints are linearized with their time functions held: φ′ = φ″ = 0 at t."""
    for g in model.constraint_groups:
        if not g.cls.rheonomic or not g.time_functions or not len(g.time_functions[0]):
            continue
        tf = _kernels.time_values(g, t)
        moving = np.nonzero(np.abs(tf[:, :, 1:]).max(axis=(1, 2)) > 0.0)[0]
        if moving.size:
            e = int(moving[0])
            raise ParameterError(f"linearize: the driven constraint {g.cls.__name__} '{g.names[e]}' moves at "
                                 f"t = {t:g} (φ′ = {tf[e, 0, 1]:g}, φ″ = {tf[e, 0, 2]:g}); only drives at "
                                 "rest (holding their value) are linearized")


def _drive_terms(model, t, q, v, drives):
    """Per drive j: its constraint row r_j, Φ_u (the row's ∂Φ/∂u) and b_j = ∂(Φ_q)_r/∂u (nq,).

    Read from the element's own ``rates`` kernel with the time function's rate set to 1 and its
    second derivative to 0: then Φ_t = Φ_u and γ(v) = (Φ_q v)_q v + 2 b·v + Φ_uu, so that
    (γ(e_k) − γ(−e_k))/4 = b_k exactly (the quadratic terms cancel).

    Returns
    -------
    rows : ndarray (nd,) int; Phi_u : ndarray (nd,); b : ndarray (nd, nq)
    """
    nd = len(drives)
    rows, Phi_u, b = np.zeros(nd, dtype=np.int64), np.zeros(nd), np.zeros((nd, model.nq))
    qx, qdx = model.ext(np.asarray(q, dtype=float)), model.ext_velocity(np.asarray(v, dtype=float))
    for j, d in enumerate(drives):
        g, e = _element_group(model, d.element)
        fn = _kernels.compiled_kernel(g.cls.__name__, "rates", g.cls.kernels["rates"])[0]
        tf = _kernels.time_values(g, t)[e:e + 1].copy()
        tf[:, :, 1], tf[:, :, 2] = 1.0, 0.0
        xe = np.ascontiguousarray(qx[g.xdofs[e:e + 1]])
        ve0 = np.ascontiguousarray(qdx[g.dofs[e:e + 1]])

        def rates(ve):
            Pt, gam = np.zeros((1, g.nc)), np.zeros((1, g.nc))
            fn(g.P[e:e + 1], float(t), tf, xe, ve, Pt, gam)
            return Pt[0], gam[0]

        Pt = rates(np.zeros_like(ve0))[0]
        live = np.nonzero(np.abs(Pt) > 1e-12 * max(1.0, np.abs(Pt).max()))[0]
        if live.size != 1:
            raise ModelError(f"drive: {g.cls.__name__} '{d.element}' has {live.size} rows that depend on its "
                             "time function; one is needed")
        r = int(live[0])
        rows[j], Phi_u[j] = int(g.lam[e, r]), Pt[r]
        for k, i in enumerate(g.dofs[e]):
            if i < model.nq:
                ek = np.zeros_like(ve0)
                ek[0, k] = 1.0
                b[j, i] += (rates(ek)[1][r] - rates(-ek)[1][r]) / 4.0
    return rows, Phi_u, b


# --------------------------------------------------------------------------
# the reference: multipliers and accelerations of a state
# --------------------------------------------------------------------------
class _Blocks:
    """The constraint blocks at (t, q, v), assembled once: Φ, Φ_q, Φ_t, γ; Ψ, A, Ψ_t, Ψ_q."""

    def __init__(self, model, t, q, v):
        self.Phi = assembly.constraint_vector(model, t, q)
        self.B = assembly.constraint_jacobian(model, t, q)
        self.Phi_t, self.gam = assembly.constraint_rates(model, t, q, v)
        self.Psi, self.A, self.Psi_t = assembly.velocity_constraints(model, t, q, v)
        self.Dq = (assembly.velocity_constraint_jacobians(model, t, q, v, np.zeros(model.nn))[0] if model.nn
                   else sp.csr_matrix((0, model.nq)))


def reference(model, t, q, v, blocks=None, f_extra=None):
    """Accelerations v̇ and multipliers (λ, μ) of the state (t, q, v).

    Solves [[M, Wᵀ], [W, 0]] [v̇; ν] = [f; −γ] with W = [Φ_q; A], ν = (λ, μ) and γ the
    velocity-independent rest of the time derivative of W v + (Φ_t; a): γ_Φ of the constraint
    kernels' rates and Ψ_q v + Ψ_t of the velocity constraints.

    Returns
    -------
    vd : ndarray (nq,), lam : ndarray (nc,), mu : ndarray (nn,)

    ``f_extra`` (nq,) is added to the applied forces (e.g. inputs).
    """
    q = np.asarray(q, dtype=float)
    v = np.asarray(v, dtype=float)
    b_ = _Blocks(model, t, q, v) if blocks is None else blocks
    M = assembly.mass_matrix(model, q)
    f = assembly.force_vector(model, t, q, v)
    if f_extra is not None:
        f = f + np.asarray(f_extra, dtype=float)
    nq, nc = model.nq, model.nc
    if nc + model.nn:
        W = sp.vstack((b_.B, b_.A)).tocsc()
        S = sp.bmat([[M, W.T], [W, None]], format="csc")
        b = np.concatenate((f, -b_.gam, -(b_.Dq @ v) - b_.Psi_t))
    else:
        S, b = M.tocsc(), f
    try:
        x = spla.spsolve(S, b) if S.shape[0] > 2000 else np.linalg.solve(S.toarray(), b)
    except (np.linalg.LinAlgError, RuntimeError):
        x = np.full(b.shape, np.nan)
    if not np.all(np.isfinite(x)):
        raise SingularMatrixError(f"model '{model.name}': the constraints are dependent or a coordinate "
                                  "carries no mass: the accelerations and multipliers of the reference "
                                  "state are not unique")
    return x[:nq], x[nq:nq + nc], x[nq + nc:]


def _check_admissible(model, v, b_, tol):
    L = model.length_scale
    vs = max(1.0, float(np.max(np.abs(v), initial=0.0)))
    for what, r, s in (("Φ", b_.Phi, L), ("Φ_q v + Φ_t", b_.B @ v + b_.Phi_t, vs), ("A v + a", b_.Psi, vs)):
        if r.size and np.max(np.abs(r)) > tol * s:
            i = int(np.argmax(np.abs(r)))
            raise ParameterError(f"linearize: the reference state violates the constraints ({what}: "
                                 f"|residual| = {abs(r[i]):.3g} at row {i}); give a consistent state "
                                 "(femb.consistent_initial_state, femb.analysis.static.solve_static)")


def _check_steady(model, q, v, vd, omega_L, about, tol):
    """The reference accelerations are those of the equilibrium or the steady motion."""
    want = np.zeros(model.nq)
    if about == "steady":
        wL = np.zeros(3) if omega_L is None else np.asarray(omega_L, dtype=float)
        for nd, tr, rot, R, tf, rf in _table(model, q).blocks(model.nq):
            if len(rot) == 3 and rf:
                Om = v[rot]
                want[rot] = np.cross(R.T @ wL, Om - R.T @ wL)
            if tr and tf:
                want[tr] = np.cross(wL, np.pad(v[tr], (0, 3 - len(tr))))[:len(tr)]
    scale = max(1.0, float(np.max(np.abs(v), initial=0.0)) ** 2 / max(model.length_scale, 1e-300))
    err = float(np.max(np.abs(vd - want), initial=0.0))
    if err > tol * scale:
        i = int(np.argmax(np.abs(vd - want)))
        lab = model.velocity_labels[i] if i < len(model.velocity_labels) else str(i)
        what = "an equilibrium" if about == "equilibrium" else "a steady motion"
        raise ParameterError(f"linearize: the reference state of model '{model.name}' is not {what}: the "
                             f"acceleration of {lab} is {vd[i]:.6g}, not {want[i]:.6g} (use about='state' to "
                             "linearize about a passing state)")


# --------------------------------------------------------------------------
# the linear model
# --------------------------------------------------------------------------
@dataclass
class LinearModel:
    """ẋ = A x + B u, y = C x + D u about an operating point (x = 0, u = 0 at the reference).

    Attributes
    ----------
    A : ndarray (n, n); B : ndarray (n, m); C : ndarray (p, n); D : ndarray (p, m)
    state_names, state_units, input_names, input_units, output_names, output_units : list of str
    operating_point : dict
        ``t``, ``q`` (nx,), ``v`` (nq,), ``vd`` (nq,) accelerations, ``lam`` (nc,), ``mu`` (nn,).
    descriptor : dict
        The second-order blocks before elimination (each (nq, nq) unless said): ``M``, ``C``
        (C_t − M Ṫ), ``K`` (K_t with the constraint-force terms), ``E`` (kinematic term),
        ``Phi_q`` (nc, nq), ``W`` (nc + nn, nq) velocity-level constraints, ``Z`` (nc + nn, nq),
        ``F`` (nq, m) generalized forces of the inputs.
    basis : ndarray (2 nq, n)
        (δq, δv) = basis @ x + input_basis @ u: the state in the model's tangent coordinates.
    symmetries : list of str
        The symmetries eliminated.
    input_basis : ndarray (2 nq, m)
        The part of (δq, δv) set by the inputs directly (drive positions and speeds; zero columns
        for forces).
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    state_names: list
    state_units: list
    input_names: list
    input_units: list
    output_names: list
    output_units: list
    operating_point: dict
    descriptor: dict
    basis: np.ndarray
    model: object = None
    symmetries: list = field(default_factory=list)
    input_basis: np.ndarray = None

    @property
    def n(self):
        return self.A.shape[0]

    @property
    def sparse(self):
        """True for the large-model form: ``A`` a LinearOperator, the descriptor pair in ``descriptor``."""
        return isinstance(self.A, spla.LinearOperator)

    def dense_A(self):
        """A as a dense array (of a sparse model: E⁻¹ A_e column by column, refused above
        :data:`DENSE_STATES_MAX` states)."""
        if not self.sparse:
            return self.A
        _refuse_dense(self.n, "dense_A")
        return self.A.matmat(np.eye(self.n))

    def to_scipy(self):
        """``scipy.signal.StateSpace(A, B, C, D)`` (dense; a sparse model up to :data:`DENSE_STATES_MAX` states)."""
        from scipy.signal import StateSpace
        return StateSpace(self.dense_A(), self._B(), self._C(), self._D())

    def to_control(self):
        """python-control's ``StateSpace`` with named states, inputs and outputs (the ``control`` extra)."""
        try:
            import control
        except ImportError:
            raise ModelError("to_control needs python-control: pip install 'femb[control]'") from None
        def ok(names):      # python-control refuses '.' in signal names: node.coordinate → node_coordinate
            return [str(n).replace(".", "_") for n in names] or None

        return control.ss(self.dense_A(), self._B(), self._C(), self._D(), states=ok(self.state_names),
                          inputs=ok(self.input_names), outputs=ok(self.output_names))

    def _B(self):
        return self.B if self.B.shape[1] else np.zeros((self.n, 1))

    def _C(self):
        return self.C if self.C.shape[0] else np.zeros((1, self.n))

    def _D(self):
        return np.zeros((self._C().shape[0], self._B().shape[1])) if not self.D.size else self.D

    def eig(self, n_modes=None, sigma=0.0, tol=1e-12):
        """Damped modes of A (:class:`DampedModes`): all of them (dense form; ``n_modes``, ``sigma`` and
        ``tol`` are then not used), or of a sparse model the ``n_modes`` eigenvalues nearest ``sigma``
        (shift-invert on the descriptor pair, :func:`_sparse_eig`; ARPACK's relative tolerance ``tol``)."""
        if self.sparse:
            if n_modes is None:
                raise ParameterError(f"eig: a sparse linear model ({self.n} states) needs n_modes (the number of "
                                     "eigenvalues nearest sigma)")
            return _sparse_eig(self, int(n_modes), float(sigma), tol)
        lam, X = sla.eig(self.A)
        order = np.lexsort((-lam.imag, lam.real))
        return DampedModes(lam[order], X[:, order], self.basis @ X[:, order], self.model, self.operating_point)


@dataclass
class DampedModes:
    """Eigenvalues s = −ζω₀ ± iω₀√(1 − ζ²) and mode shapes of a linear model.

    Attributes
    ----------
    eigenvalues : ndarray (k,) complex
    vectors : ndarray (n, k) complex, in the linear model's state
    shapes : ndarray (2 nq, k) complex, (δq, δv) in the model's tangent coordinates
    """

    eigenvalues: np.ndarray
    vectors: np.ndarray
    shapes: np.ndarray
    model: object = None
    operating_point: dict = None

    @property
    def natural_frequency(self):
        """ω₀ = |s| (rad/s)."""
        return np.abs(self.eigenvalues)

    @property
    def damped_frequency(self):
        """abs(Im s) / 2π (Hz)."""
        return np.abs(self.eigenvalues.imag) / (2.0 * np.pi)

    @property
    def damping_ratio(self):
        """ζ = −Re s / |s| (1 for a real stable root, negative when unstable; NaN for s = 0)."""
        w = np.abs(self.eigenvalues)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(w > 0, -self.eigenvalues.real / w, np.nan)

    def write_vtk(self, path, k, frames=16, scale=None):
        """Mode ``k`` animated over one period as a VTK series (``femb.io.vtk``), ``frames`` files."""
        return write_mode_vtk(self, path, k, frames=frames, scale=scale)


def write_mode_vtk(modes, directory, k, frames=16, scale=None, basename="mode"):
    """Write mode ``k`` of :class:`DampedModes` as a VTK time series for ParaView.

    Frame j shows q₀ ∘ exp(Re(a φ_q e^{2πij/frames})) with the mode's configuration part φ_q, scaled
    so that its largest translation is ``scale`` (default 10 % of the model's length scale; or its
    largest rotation 0.2 rad when it has no translation). Returns the ``.pvd`` path.
    """
    from femb.io.frames import model_blocks, scene_field_data
    from femb.io.vtk import TimeSeriesWriter

    m = modes.model
    op = modes.operating_point
    nq = m.nq
    phi = modes.shapes[:nq, int(k)]
    add = np.asarray(m.xmap) >= 0 if m.lie else np.ones(nq, dtype=bool)
    big_t = float(np.max(np.abs(phi[add]), initial=0.0))
    big = big_t if big_t > 0 else float(np.max(np.abs(phi), initial=0.0))
    if big == 0.0:
        raise ParameterError(f"mode {k} has no configuration part to draw")
    want = (0.1 * m.length_scale if big_t > 0 else 0.2) if scale is None else float(scale)
    a = want / big
    z = np.zeros(nq)
    with TimeSeriesWriter(directory, basename=f"{basename}{int(k)}") as w:
        for j in range(int(frames)):
            ph = 2.0 * np.pi * j / int(frames)
            q = m.compose(op["q"], a * np.real(phi * np.exp(1j * ph)))
            blocks = model_blocks(m, ph, q, z, np.zeros(m.nc))
            w.write(ph, blocks, field_data=scene_field_data(m, blocks))
    return w.path


def _state_of(model, state, t):
    if state is None:
        return float(t or 0.0), np.array(model.q0, dtype=float), np.zeros(model.nq)
    if isinstance(state, tuple):
        q, v = state
        return float(t or 0.0), np.asarray(q, dtype=float), np.asarray(v, dtype=float)
    if np.ndim(getattr(state, "t", 0.0)) == 1 and hasattr(state, "qd"):       # a Result: its step nearest t
        k = len(state.t) - 1 if t is None else int(np.argmin(np.abs(np.asarray(state.t) - float(t))))
        return float(state.t[k]), np.asarray(state.q[k], dtype=float), np.asarray(state.qd[k], dtype=float)
    st = getattr(state, "state", state)
    return float(st.t if t is None else t), np.asarray(st.q, dtype=float), np.asarray(st.qd, dtype=float)


def _drive_particular(M, Phi_q, W, drv):
    """Particular solutions of the linearized drive rows (docs/linearize.md §4).

    Φ_q G_q = −e_d Φ_u (least norm) for positions; for velocities the M-orthogonal
    Y = M⁻¹Wᵀ(W M⁻¹ Wᵀ)⁻¹ e_d, G_v = −Y Φ_u and P_u = −Y (b·v₀), so that N_vᵀ M G_v = 0 and
    the drive's acceleration ü does not enter the reduced dynamics.
    """
    nq, nd = M.shape[0], len(drv["rows"])
    Ed = np.zeros((W.shape[0], nd))
    Ed[drv["rows"], np.arange(nd)] = 1.0
    Gq = np.linalg.lstsq(Phi_q, -Ed[:Phi_q.shape[0]] * drv["Phi_u"], rcond=None)[0]
    try:
        MiW = np.linalg.solve(M, W.T)
        Y = MiW @ np.linalg.solve(W @ MiW, Ed)
    except np.linalg.LinAlgError:
        raise SingularMatrixError("linearize: drive inputs need a nonsingular M and independent constraints") from None
    return Gq, -Y * drv["Phi_u"], -Y * drv["bv"]


def _reduce(M, K, Ct, E, Phi_q, W, Z, F, tol, drv=None):
    """The null-space reduction: (Ā, B̄, X) with (δq, δv) = X s, s = (y, w).

    With drive inputs (``drv``: rows, Phi_u, bv, Fu) also ``(B0, B1, Xu)``: ṡ = Ā s + B̄ f + B0 u
    + B1 u̇ and (δq, δv) = X s + Xu (u, u̇); else those are empty.
    """
    nq = M.shape[0]
    Nq = sla.null_space(Phi_q) if Phi_q.shape[0] else np.eye(nq)
    Nv = sla.null_space(W) if W.shape[0] else np.eye(nq)
    P = -np.linalg.lstsq(W, Z, rcond=None)[0] if W.shape[0] else np.zeros((nq, nq))
    m, p = Nq.shape[1], Nv.shape[1]
    if p == 0:
        raise ModelError("linearize: the constraints leave no velocity free")
    nd = 0 if drv is None else len(drv["rows"])
    Gq, Gv, Pu = _drive_particular(M, Phi_q, W, drv) if nd else (np.zeros((nq, 0)),) * 3
    PN, PG = P @ Nq, P @ Gq + Pu
    Ayy = Nq.T @ ((P + E) @ Nq)
    Ayw = Nq.T @ Nv
    # the kinematic relation must stay on the constraint manifold (exact for equilibria, steady motions)
    if Phi_q.shape[0]:
        drift = np.abs(Phi_q @ np.hstack(((P + E) @ Nq, Nv, (P + E) @ Gq + Pu))).max(initial=0.0)
        if drift > tol * max(1.0, np.abs(P).max(initial=0.0) + np.abs(E).max(initial=0.0)) * 1e2:
            raise ParameterError(f"linearize: the reference is not a steady motion of the given kind (the "
                                 f"linearized kinematics leave the constraint manifold by {drift:.3g}); "
                                 "give omega (the steady rotation) or use about='state'")
    Mr = Nv.T @ M @ Nv
    G = Nv.T @ M @ PN
    B0y, B1y = Nq.T @ ((P + E) @ Gq + Pu), Nq.T @ Gv
    try:
        Awy = np.linalg.solve(Mr, Nv.T @ (-K @ Nq - Ct @ PN) - G @ Ayy)
        Aww = np.linalg.solve(Mr, -Nv.T @ Ct @ Nv - G @ Ayw)
        Bw = np.linalg.solve(Mr, Nv.T @ F)
        B0w = np.linalg.solve(Mr, -G @ B0y - Nv.T @ (Ct @ PG + K @ Gq - (drv["Fu"] if nd else 0.0)))
        B1w = np.linalg.solve(Mr, -G @ B1y - Nv.T @ (M @ PG + Ct @ Gv))
    except np.linalg.LinAlgError:
        raise SingularMatrixError("linearize: the reduced mass matrix is singular (a free velocity carries no "
                                  "mass)") from None
    Abar = np.block([[Ayy, Ayw], [Awy, Aww]])
    Bbar = np.vstack((np.zeros((m, F.shape[1])), Bw))
    X = np.block([[Nq, np.zeros((nq, p))], [PN, Nv]])
    Xu = np.block([[Gq, np.zeros((nq, nd))], [PG, Gv]])
    return Abar, Bbar, X, (Nq, Nv, P), (np.vstack((B0y, B0w)), np.vstack((B1y, B1w)), Xu)


def _quotient(model, q, v, Abar, X, bases, symmetries, tol):
    """Eliminate the symmetry directions: the orthonormal complement Q_W of their invariant span
    (A, B, X on it: Q_Wᵀ A Q_W, Q_Wᵀ B, X Q_W)."""
    Nq, Nv, P = bases
    cols = []
    for sym in symmetries:
        dq, dv = sym.direction(model, q, v)
        y = Nq.T @ dq
        w = Nv.T @ (dv - P @ (Nq @ y))
        s = np.concatenate((y, w))
        res = np.abs(X @ s - np.concatenate((dq, dv))).max(initial=0.0)
        size = max(np.abs(dq).max(initial=0.0), np.abs(dv).max(initial=0.0))
        if size == 0.0 or res > 1e-7 * size:
            raise ParameterError(f"linearize: {sym.name} is not a symmetry of model '{model.name}' at the "
                                 f"reference: it breaks the constraints (residual {res:.3g})")
        cols.append(s)
    QS = sla.orth(np.array(cols).T)
    if QS.shape[1] != len(cols):
        raise ParameterError("linearize: the given symmetries are not independent")
    QW = sla.null_space(QS.T)
    leak = np.abs(QW.T @ Abar @ QS).max(initial=0.0)
    if leak > tol * max(1.0, np.abs(Abar).max()):
        raise ParameterError(f"linearize: the given symmetries are not symmetries of the linearized model "
                             f"(their span is not invariant: leak {leak:.3g}); check the model's symmetry "
                             "(e.g. axisymmetric wheels) and the steady motion (omega)")
    return QW


def _second_order(model, t, q, v, omega, about):
    """The blocks of the linearized equations before elimination (dense): M, K, C (with −MṪ), E,
    Φ_q, W, Z and the operating point (checked as ``about`` says)."""
    b_ = _Blocks(model, t, q, v)
    _check_admissible(model, v, b_, 1e-8)
    vd, lam, mu = reference(model, t, q, v, b_)
    if about != "state":
        _check_steady(model, q, v, vd, omega, about, 1e-8)
    elif (model.nc + model.nn) and np.max(np.abs(vd), initial=0.0) > 1e-8 * max(1.0, np.abs(v).max(initial=0.0)):
        import warnings
        from femb.errors import ParameterWarning
        warnings.warn(f"linearize: model '{model.name}' accelerates at the reference (|v̇| = "
                      f"{np.abs(vd).max():.3g}) and has constraints: about='state' freezes the constraint "
                      "basis at this instant, so the matrices describe the motion only approximately "
                      "(exact about equilibria and steady motions; docs/linearize.md)", ParameterWarning,
                      stacklevel=3)
    st = State(t, q, v, vd, lam)
    M = assembly.mass_matrix(model, q).toarray()
    K = assembly.tangent_stiffness(model, st).toarray()
    Ct = assembly.tangent_damping(model, st).toarray()
    Phi_q = b_.B.toarray()
    ZB = (assembly.constraint_velocity_jacobian(model, t, q, v).toarray() if np.any(v)
          else np.zeros((model.nc, model.nq)))
    if model.nn:
        ZA, HA = assembly.velocity_constraint_jacobians(model, t, q, v, mu)
        K = K + HA.toarray()
        ZA = ZA.toarray()
    else:
        ZA = np.zeros((0, model.nq))
    W = np.vstack((Phi_q, b_.A.toarray()))
    Z = np.vstack((ZB, ZA))
    E, Td = _kinematics(model, q, v, omega, about == "steady")
    Ct = Ct - M @ Td
    return M, K, Ct, E, Phi_q, W, Z, {"t": t, "q": q, "v": v, "vd": vd, "lam": lam, "mu": mu}


def linearize(model, state=None, *, about="auto", omega=None, symmetries=(), inputs=(), outputs=(),
              states=None, t=None, tol=1e-8):
    """Linearize ``model`` about an equilibrium, a steady motion or a state: a :class:`LinearModel`.

    Parameters
    ----------
    model : Model
    state : State, StaticResult, Result, (q, v) tuple, optional
        The reference (default: the initial coordinates at rest); of a Result, its stored step
        nearest ``t`` (default the last). Multipliers and accelerations are computed from it
        (:func:`reference`).
    about : {"auto", "equilibrium", "steady", "state"}
        "equilibrium": v = 0 and v̇ = 0 checked; "steady": a relative equilibrium with world
        rotation ``omega`` (default 0: straight motion), its accelerations checked, linearized in
        the co-moving frame (module docstring); "state": linearized as it passes (no check; the
        matrices describe only the instant); "auto": "equilibrium" if v = 0, else "steady".
    omega : (3,), optional
        ω_L of a steady motion (rad/s, space axes).
    symmetries : sequence of Symmetry
        Directions eliminated (:func:`translation`, :func:`rotation`, :func:`spin`).
    inputs : sequence of Input or Drive
        Generalized forces (:func:`torque`, :func:`force`) and drive values (:func:`drive`:
        position, speed or acceleration of a driven constraint; docs/linearize.md §4).
    outputs : sequence of Output
        (:func:`angle`, :func:`coordinate`, :func:`reaction`).
    states : sequence of Output, optional
        Express the state in these (as many as states, independent): named states.
    t : float, optional
    tol : float
        Relative tolerance of the checks.

    Returns
    -------
    LinearModel
        Dense; for a model with more than :data:`SPARSE_ABOVE` free velocities, when the request
        fits it (an equilibrium, force inputs, no symmetries, named states or reactions), the sparse
        form of :func:`linearize_sparse`.
    """
    refuse_contacts(model, 'linearization (linearize)')
    t, q, v = _state_of(model, state, t)
    if q.shape != (model.nx,) or v.shape != (model.nq,):
        raise ParameterError(f"linearize: the state does not fit model '{model.name}' (q: {model.nx}, v: {model.nq})")
    if about == "auto":
        about = "equilibrium" if not np.any(v) else "steady"
    if about not in ("equilibrium", "steady", "state"):
        raise ParameterError(f"linearize: about must be 'auto', 'equilibrium', 'steady' or 'state', got {about!r}")
    for u in inputs:
        if not isinstance(u, (Input, Drive)):
            raise ParameterError(f"linearize: inputs must be Input or Drive objects (force, torque, drive), got {u!r}")
    if getattr(model, "rheonomic", False):
        _check_drives_at_rest(model, t)
    if model.nq > SPARSE_ABOVE:
        why = _dense_only(symmetries, states, inputs, outputs, v)
        if why is None:
            return _linearize_sparse(model, t, q, v, list(inputs), list(outputs), tol)
        if 2 * model.nq > DENSE_STATES_MAX:
            raise ParameterError(f"linearize: model '{model.name}' is large ({model.nq} free velocities); the "
                                 f"sparse form does not take {why}, and the dense form would need "
                                 f"{8.0 * (2 * model.nq) ** 2 / 1e9:.3g} GB per matrix")
    forces = [u for u in inputs if isinstance(u, Input)]
    drives = [u for u in inputs if isinstance(u, Drive)]
    M, K, Ct, E, Phi_q, W, Z, op = _second_order(model, t, q, v, omega, about)
    F = np.array([u.F for u in forces]).T if forces else np.zeros((model.nq, 0))
    drv = None
    if drives:
        rows, Phi_u, b = _drive_terms(model, t, q, v, drives)
        drv = {"rows": rows, "Phi_u": Phi_u, "bv": b @ v, "Fu": -b.T * op["lam"][rows]}
    Abar, Bbar, X, bases, (B0, B1, Xu) = _reduce(M, K, Ct, E, Phi_q, W, Z, F, tol, drv)
    if symmetries:
        QW = _quotient(model, q, v, Abar, X, bases, list(symmetries), tol)
        Abar, Bbar, B0, B1, X = QW.T @ Abar @ QW, QW.T @ Bbar, QW.T @ B0, QW.T @ B1, X @ QW
    lin = _Lin(Abar, Bbar, B0, B1, X, Xu)
    lay = _Layout(inputs, Abar.shape[0])
    Az, Bz = lay.system(lin)
    R = _multiplier_maps(M, K, Ct, E, W, Z, F, drv) if any(o.nu >= 0 for o in outputs) else None
    Cm, Dm = lay.outputs(outputs, lin, R)
    Xz, Xv = lay.state_map(lin)
    names, units = [f"x{i}" for i in range(Abar.shape[0])] + lay.znames, [""] * Abar.shape[0] + lay.zunits
    if states is not None:
        T, Dt = lay.outputs(states, lin, None)
        n = Az.shape[0]
        if T.shape != (n, n) or np.linalg.matrix_rank(T) < n:
            raise ParameterError(f"linearize: {len(states)} states given for a state of dimension {n}, or "
                                 "they are dependent")
        if np.abs(Dt).max(initial=0.0) > 1e-12 * max(1.0, np.abs(T).max()):
            raise ParameterError("linearize: a named state depends directly on a drive input; give the drive "
                                 "kind='acceleration' (its position and speed become states)")
        Ti = np.linalg.inv(T)
        Az, Bz, Cm, Xz = T @ Az @ Ti, T @ Bz, Cm @ Ti, Xz @ Ti
        names, units = [s.name for s in states], [s.unit for s in states]
    desc = {"M": M, "C": Ct, "K": K, "E": E, "Phi_q": Phi_q, "W": W, "Z": Z, "F": F}
    if drv is not None:
        desc.update(drive_rows=drv["rows"], Phi_u=drv["Phi_u"], F_u=drv["Fu"], drive_basis=Xu)
    return LinearModel(Az, Bz, Cm, Dm, names, units, lay.names, lay.units, [o.name for o in outputs],
                       [o.unit for o in outputs], op, desc, Xz, model, [s.name for s in symmetries], Xv)


@dataclass
class _Lin:
    """ṡ = A s + Bf f + B0 u + B1 u̇, (δq, δv) = X s + Xu (u, u̇): the reduced model before the
    inputs are arranged (Xu (2nq, 2nd): the columns of u, then of u̇)."""
    A: np.ndarray
    Bf: np.ndarray
    B0: np.ndarray
    B1: np.ndarray
    X: np.ndarray
    Xu: np.ndarray


class _Layout:
    """Where forces and drive values go.

    Inputs v in the user's order: a force its column; a position drive u and u̇, a speed drive u̇,
    an acceleration drive ü. State z = (s, then per drive: u for speed and acceleration drives,
    u̇ for acceleration drives). u = Uz z + Uv v, u̇ = Dz z + Dv v, ü = Az z + Av v, f = Tf v; the
    drives without ü as a signal (position, speed) are flagged in ``no_udd``.
    """

    def __init__(self, inputs, n):
        drives = [u for u in inputs if isinstance(u, Drive)]
        nd, nf = len(drives), sum(isinstance(u, Input) for u in inputs)
        kinds = [d.kind for d in drives]
        self.n = n
        self.nz = n + sum({"position": 0, "speed": 1, "acceleration": 2}[k] for k in kinds)
        self.nv = nf + sum(2 if k == "position" else 1 for k in kinds)
        self.Tf = np.zeros((nf, self.nv))
        self.Uz, self.Dz, self.Az = (np.zeros((nd, self.nz)) for _ in range(3))
        self.Uv, self.Dv, self.Av = (np.zeros((nd, self.nv)) for _ in range(3))
        self.no_udd = [k != "acceleration" for k in kinds]
        self.zrows = []                 # (z index, drive j, "u" or "ud")
        self.names, self.units, self.znames, self.zunits = [], [], [], []
        col, fi, j = 0, 0, 0
        for u in inputs:
            if isinstance(u, Input):
                self.Tf[fi, col] = 1.0
                self.names.append(u.name)
                self.units.append(u.unit)
                fi, col = fi + 1, col + 1
            else:
                col = self._drive(u, j, col)
                j += 1

    def _signal(self, name, unit, col=None):
        """Name an input column (``col`` given) or the next added state."""
        if col is not None:
            self.names.append(name)
            self.units.append(unit)
        else:
            self.znames.append(name)
            self.zunits.append(unit)

    def _drive(self, d, j, col):
        """Place drive ``j``; returns the next input column."""
        zi = self.n + len(self.zrows)
        rate, acc = (d.name + "_d", d.unit + "/s"), (d.name + "_dd", d.unit + "/s²")
        if d.kind == "position":
            self.Uv[j, col], self.Dv[j, col + 1] = 1.0, 1.0
            self._signal(d.name, d.unit, col)
            self._signal(*rate, col + 1)
            return col + 2
        self.Uz[j, zi] = 1.0
        self.zrows.append((zi, j, "u"))
        self._signal(d.name, d.unit)
        if d.kind == "speed":
            self.Dv[j, col] = 1.0
            self._signal(*rate, col)
        else:
            self.Dz[j, zi + 1] = 1.0
            self.zrows.append((zi + 1, j, "ud"))
            self._signal(*rate)
            self.Av[j, col] = 1.0
            self._signal(*acc, col)
        return col + 1

    def system(self, lin):
        """(A_z (nz, nz), B_z (nz, nv)) of ż = A_z z + B_z v."""
        n = self.n
        Az = np.zeros((self.nz, self.nz))
        Bz = np.zeros((self.nz, self.nv))
        Az[:n, :n] = lin.A
        Az[:n] += lin.B0 @ self.Uz + lin.B1 @ self.Dz
        Bz[:n] = lin.Bf @ self.Tf + lin.B0 @ self.Uv + lin.B1 @ self.Dv
        for zi, j, what in self.zrows:          # d/dt u = u̇, d/dt u̇ = ü
            Az[zi], Bz[zi] = (self.Dz[j], self.Dv[j]) if what == "u" else (self.Az[j], self.Av[j])
        return Az, Bz

    def state_map(self, lin):
        """(δq, δv) = X_z z + X_v v: (X_z (2nq, nz), X_v (2nq, nv))."""
        Xz = np.hstack((lin.X, np.zeros((lin.X.shape[0], self.nz - self.n))))
        nd = self.Uz.shape[0]
        Xz += lin.Xu[:, :nd] @ self.Uz + lin.Xu[:, nd:] @ self.Dz
        return Xz, lin.Xu[:, :nd] @ self.Uv + lin.Xu[:, nd:] @ self.Dv

    def outputs(self, outputs, lin, R):
        """(C (p, nz), D (p, nv)) of the outputs."""
        C, D = np.zeros((len(outputs), self.nz)), np.zeros((len(outputs), self.nv))
        for i, o in enumerate(outputs):
            c, df, d0, d1, d2 = _raw_row(o, lin, R)
            for j, flag in enumerate(self.no_udd):
                if flag and abs(d2[j]) > 1e-12 * max(1.0, np.abs(c).max(initial=0.0)):
                    raise ParameterError(f"linearize: output {o.name} depends on the acceleration of a drive; "
                                         "give that drive kind='acceleration'")
            C[i, :self.n] = c
            C[i] += d0 @ self.Uz + d1 @ self.Dz + d2 @ self.Az
            D[i] = df @ self.Tf + d0 @ self.Uv + d1 @ self.Dv + d2 @ self.Av
        return C, D


def _raw_row(o, lin, R):
    """One output as y = c s + df f + d0 u + d1 u̇ + d2 ü."""
    nd = lin.B0.shape[1]
    if o.nu >= 0:
        if o.rate:
            raise ParameterError(f"linearize: output {o.name}: the rate of a reaction is not available")
        Rx, Ru, R0, R1, R2 = R
        r = Rx[o.nu]
        return r @ lin.X, Ru[o.nu], r @ lin.Xu[:, :nd] + R0[o.nu], r @ lin.Xu[:, nd:] + R1[o.nu], R2[o.nu]
    cx = np.concatenate((o.cq, o.cv))
    c = cx @ lin.X
    cu = cx @ lin.Xu
    if not o.rate:
        return c, np.zeros(lin.Bf.shape[1]), cu[:nd], cu[nd:], np.zeros(nd)
    return c @ lin.A, c @ lin.Bf, c @ lin.B0, c @ lin.B1 + cu[:nd], cu[nd:]


def _multiplier_maps(M, K, Ct, E, W, Z, F, drv=None):
    """δν = Rx (δq, δv) + Ru f + R0 u + R1 u̇ + R2 ü from M δv̇ = F f + F_u u − K δq − Ct δv − Wᵀ δν
    and d/dt (W δv + Z δq + e_d (b·v₀) u + e_d Φ_u u̇) = 0."""
    try:
        MiW = np.linalg.solve(M, W.T)
        G = np.linalg.inv(W @ MiW)
    except np.linalg.LinAlgError:
        raise SingularMatrixError("linearize: reactions need a nonsingular M and independent constraints") from None
    WMi = MiW.T
    Rq = G @ (-WMi @ K + Z @ E)
    Rv = G @ (-WMi @ Ct + Z)
    nd = 0 if drv is None else len(drv["rows"])
    R0, R1, R2 = np.zeros((W.shape[0], nd)), np.zeros((W.shape[0], nd)), np.zeros((W.shape[0], nd))
    if nd:
        Ed = np.zeros((W.shape[0], nd))
        Ed[drv["rows"], np.arange(nd)] = 1.0
        R0, R1, R2 = G @ (WMi @ drv["Fu"]), G @ Ed * drv["bv"], G @ Ed * drv["Phi_u"]
    return np.hstack((Rq, Rv)), G @ (WMi @ F), R0, R1, R2


# --------------------------------------------------------------------------
# large models: sparse null-space bases, a descriptor pair, A as a LinearOperator
# --------------------------------------------------------------------------
#: Free velocities above which :func:`linearize` builds the sparse form (when the request fits it).
SPARSE_ABOVE = 2000
#: States up to which a sparse model may be made dense (``to_scipy``, ``to_control``, ``dense_A``).
DENSE_STATES_MAX = 5000
#: Constraint rows up to which the sparse basis picks its dependent coordinates by a dense pivoted QR.
SPARSE_CONSTRAINTS_MAX = 5000


def _refuse_dense(n, what):
    if n > DENSE_STATES_MAX:
        gb = 8.0 * n * n / 1e9
        raise ParameterError(f"{what}: the linear model has {n} states; a dense A would take {gb:.3g} GB "
                             f"(limit {DENSE_STATES_MAX} states). Use lin.A (a LinearOperator), lin.B, lin.C, "
                             "lin.D and the sparse descriptor pair lin.descriptor['E'], ['A'], or lin.eig(n_modes)")


def sparse_null_space(W, tol=1e-10):
    """A sparse basis N of the null space of W by coordinate partitioning (Wehage & Haug, J. Mech.
    Des. 104 (1982) 247–255).

    The dependent coordinates d are r columns of W chosen by a pivoted QR of the columns that
    the constraints touch (dense, r × those columns); every other coordinate is independent, and
    N = [−W_d⁻¹ W_i; I] (rows permuted back): sparse, as W_i is non-zero only on the touched columns.

    Parameters
    ----------
    W : sparse (r, n), full row rank

    Returns
    -------
    N : csc (n, n − r); ind : ndarray (n − r,) the independent coordinates (N[ind] = I)
    """
    W = sp.csc_matrix(W)
    r, n = W.shape
    if r == 0:
        return sp.identity(n, format="csc"), np.arange(n)
    if r > SPARSE_CONSTRAINTS_MAX:
        raise ParameterError(f"linearize: {r} constraint rows; the sparse basis handles up to "
                             f"{SPARSE_CONSTRAINTS_MAX} (its pivoting is dense in the rows)")
    J = np.unique(W.nonzero()[1])
    _, R, piv = sla.qr(W[:, J].toarray(), mode="economic", pivoting=True)
    d = np.abs(np.diag(R))
    if d.size < r or d[r - 1] <= tol * d[0]:
        raise SingularMatrixError(f"linearize: the {r} constraint rows are dependent (rank < {r})")
    dep = J[piv[:r]]
    ind = np.setdiff1d(np.arange(n), dep)
    Wi = W[:, ind]
    k = np.nonzero(np.diff(Wi.indptr))[0]               # independent coordinates the constraints touch
    Dn = -np.linalg.solve(W[:, dep].toarray(), Wi[:, k].toarray())
    rows = np.concatenate((ind, np.repeat(dep, k.size)))
    cols = np.concatenate((np.arange(ind.size), np.tile(k, r)))
    N = sp.csc_matrix((np.concatenate((np.ones(ind.size), Dn.ravel())), (rows, cols)), shape=(n, ind.size))
    N.eliminate_zeros()
    return N, ind


def _dense_only(symmetries, states, inputs, outputs, v):
    """What of a request needs the dense form (None: the sparse form takes it)."""
    if np.any(v):
        return "a reference in motion (the sparse form is about equilibria)"
    for cond, why in ((symmetries, "symmetries"), (states is not None, "named states"),
                      (any(isinstance(u, Drive) for u in inputs), "drive inputs"),
                      (any(o.nu >= 0 for o in outputs), "reaction outputs")):
        if cond:
            return why
    return None


def linearize_sparse(model, state=None, *, inputs=(), outputs=(), t=None, tol=1e-8):
    """The large-model form of :func:`linearize` about an equilibrium (docs/linearize.md §5).

    Sparse coordinate-partitioned null-space bases (:func:`sparse_null_space`), ``A`` a
    ``scipy.sparse.linalg.LinearOperator`` (E⁻¹A_e of the sparse descriptor pair in
    ``descriptor["E"]``, ``["A"]``, ``["B"]``), B, C, D dense (n × m, p × n), ``basis`` sparse.
    :func:`linearize` returns it by itself above :data:`SPARSE_ABOVE` free velocities.

    Parameters
    ----------
    model : Model
    state : as in :func:`linearize`; an equilibrium (v = 0)
    inputs : sequence of Input
        Generalized forces (no drives).
    outputs : sequence of Output
        Coordinates and angles, and their rates (no reactions).
    t : float, optional
    tol : float

    Returns
    -------
    LinearModel
        ``sparse`` True.
    """
    refuse_contacts(model, 'linearization (linearize_sparse)')
    t, q, v = _state_of(model, state, t)
    if q.shape != (model.nx,) or v.shape != (model.nq,):
        raise ParameterError(f"linearize: the state does not fit model '{model.name}' (q: {model.nx}, v: {model.nq})")
    why = _dense_only((), None, inputs, outputs, v)
    if why is not None:
        raise ParameterError(f"linearize_sparse: model '{model.name}': the sparse form does not take {why}; "
                             "use linearize (the dense form)")
    for u in inputs:
        if not isinstance(u, Input):
            raise ParameterError(f"linearize_sparse: inputs must be Input objects (force, torque), got {u!r}")
    if getattr(model, "rheonomic", False):
        _check_drives_at_rest(model, t)
    return _linearize_sparse(model, t, q, v, list(inputs), list(outputs), tol)


def _linearize_sparse(model, t, q, v, inputs, outputs, tol):
    """The sparse form about an equilibrium (docs/linearize.md §5): E ẋ = A_e x + B_e u with
    E = diag(I, N_vᵀ M N_v), A_e = [[0, L_q N_v], [−N_vᵀ K N_q, −N_vᵀ C N_v]], B_e = [0; N_vᵀ F];
    ``A`` = E⁻¹A_e as a LinearOperator (one sparse LU of the reduced mass)."""
    b_ = _Blocks(model, t, q, v)
    _check_admissible(model, v, b_, 1e-8)
    vd, lam, mu = reference(model, t, q, v, b_)
    _check_steady(model, q, v, vd, None, "equilibrium", 1e-8)
    st = State(t, q, v, vd, lam)
    M = assembly.mass_matrix(model, q).tocsr()
    K = assembly.tangent_stiffness(model, st)
    C = assembly.tangent_damping(model, st)
    if model.nn:
        ZA, HA = assembly.velocity_constraint_jacobians(model, t, q, v, mu)
        K = K + HA
        if ZA.nnz and np.abs(ZA.data).max() > 0.0:
            raise ParameterError("linearize: the sparse form needs velocity constraints without a(q, t)")
    Phi_q = b_.B.tocsr()
    W = sp.vstack((Phi_q, b_.A)).tocsr()
    Nq, ind_q = sparse_null_space(Phi_q)
    Nv, _ = sparse_null_space(W) if model.nn else (Nq, ind_q)
    m, p = Nq.shape[1], Nv.shape[1]
    Mr = (Nv.T @ M @ Nv).tocsc()
    Kr, Cr = (Nv.T @ K @ Nq).tocsr(), (Nv.T @ C @ Nv).tocsr()
    Ayw = Nv[ind_q].tocsr()
    try:
        lu = spla.splu(Mr, permc_spec="MMD_AT_PLUS_A")
    except RuntimeError:
        raise SingularMatrixError("linearize: the reduced mass matrix is singular (a free velocity carries no "
                                  "mass)") from None
    F = np.array([u.F for u in inputs]).T if inputs else np.zeros((model.nq, 0))
    Be = np.vstack((np.zeros((m, F.shape[1])), Nv.T @ F))
    B = np.vstack((np.zeros((m, F.shape[1])), lu.solve(Be[m:]) if F.shape[1] else Be[m:]))

    def matvec(x):
        x = np.asarray(x).ravel()
        xy, xw = x[:m], x[m:]
        rhs = -(Kr @ xy) - Cr @ xw
        w = lu.solve(rhs) if not np.iscomplexobj(rhs) else lu.solve(rhs.real) + 1j * lu.solve(rhs.imag)
        return np.concatenate((Ayw @ xw, w))

    n = m + p
    A = spla.LinearOperator((n, n), matvec=matvec, dtype=float)
    E = sp.block_diag((sp.identity(m), Mr), format="csc")
    Ae = sp.bmat([[None, Ayw], [-Kr, -Cr]], format="csc") if m else sp.bmat([[-Cr]], format="csc")
    X = sp.block_diag((Nq, Nv), format="csr")
    Cm, Dm = _sparse_outputs(outputs, X, Ae, B, lu, m)
    op = {"t": t, "q": q, "v": v, "vd": vd, "lam": lam, "mu": mu}
    desc = {"M": M, "C": C, "K": K, "Phi_q": Phi_q, "W": W, "F": F, "E": E, "A": Ae, "B": Be,
            "Nq": Nq, "Nv": Nv, "lu_Mr": lu, "identity_kinematics": p == m and not model.nn}
    return LinearModel(A, B, Cm, Dm, [f"x{i}" for i in range(n)], [""] * n, [u.name for u in inputs],
                       [u.unit for u in inputs], [o.name for o in outputs], [o.unit for o in outputs], op, desc,
                       X, model, [], np.zeros((2 * model.nq, F.shape[1])))


def _sparse_outputs(outputs, X, Ae, B, lu, m):
    """Rows c X of the outputs; of a rate output (c X) E⁻¹ A_e and D = (c X) B (E symmetric)."""
    Cm = np.zeros((len(outputs), X.shape[1]))
    Dm = np.zeros((len(outputs), B.shape[1]))
    for i, o in enumerate(outputs):
        r = X.T @ np.concatenate((o.cq, o.cv))
        if o.rate:
            y = np.concatenate((r[:m], lu.solve(r[m:])))
            Cm[i] = Ae.T @ y
            Dm[i] = r @ B
        else:
            Cm[i] = r
    return Cm, Dm


def _sparse_eig(lin, k, sigma, tol):
    """The ``k`` eigenvalues nearest ``sigma`` of E ẋ = A_e x by ARPACK in shift-invert mode.

    (A_e − σE)⁻¹E is applied by one sparse LU: of the reduced K + σC + σ²M (size of y) when the
    kinematics are ẏ = w (holonomic constraints), else of A_e − σE.
    """
    d = lin.descriptor
    E, Ae = d["E"], d["A"]
    n = lin.n
    if not 1 <= k < n - 1:
        raise ParameterError(f"eig: n_modes must be between 1 and {n - 2}, got {k}")
    s = sigma
    try:
        if d["identity_kinematics"]:
            m = n // 2
            Mr, Kr, Cr = E[m:, m:], -Ae[m:, :m], -Ae[m:, m:]
            lu = spla.splu((Kr + s * Cr + s * s * Mr).tocsc(), permc_spec="MMD_AT_PLUS_A")
            CsM = (Cr + s * Mr).tocsr()

            def solve(b):
                by, bw = b[:m], b[m:]
                rhs = -(Mr @ bw) - CsM @ by
                xy = _lu_solve(lu, rhs)
                return np.concatenate((xy, by + s * xy))
        else:
            lu = spla.splu((Ae - s * E).tocsc())

            def solve(b):
                return _lu_solve(lu, E @ b)
    except RuntimeError as err:
        raise SingularMatrixError(f"eig: the shifted matrix is singular at sigma = {s:g} ({err}); a model with "
                                  "rigid-body modes needs a shift away from 0") from None
    Op = spla.LinearOperator((n, n), matvec=solve, dtype=float)
    v0 = np.random.default_rng(0).standard_normal(n)
    theta, V = spla.eigs(Op, k=k, which="LM", tol=tol, v0=v0, ncv=min(n, max(2 * k + 1, k + 40)))
    lam = s + 1.0 / theta
    order = np.lexsort((-lam.imag, np.abs(lam)))
    return DampedModes(lam[order], V[:, order], lin.basis @ V[:, order], lin.model, lin.operating_point)


def _lu_solve(lu, b):
    return lu.solve(b) if not np.iscomplexobj(b) else lu.solve(b.real) + 1j * lu.solve(b.imag)


# --------------------------------------------------------------------------
# damped modes of large models: the descriptor pencil, sparse shift-invert
# --------------------------------------------------------------------------
def damped_modes(model, state=None, n_modes=20, *, sigma=0.0, t=None, tol=1e-12, ncv=None):
    """The ``n_modes`` damped modes nearest ``sigma`` of a model at an equilibrium, for large models.

    No null-space basis: the constrained pencil in x = (δq, δv, δλ, δμ),

        [[0, I, 0, 0], [−K, −C, −Φ_qᵀ, −Aᵀ], [Φ_q, 0, 0, 0], [0, A, 0, 0]] x = s diag(I, M, 0, 0) x,

    has the eigenvalues of the minimal system as its finite ones; the constraint directions are
    infinite eigenvalues, which shift-invert about ``sigma`` never reaches. Each solve of
    (𝒜 − σℰ) x = ℰ b is one solve with the sparse, factorized (once) matrix
    [[K + σC + σ²M, Φ_qᵀ, Aᵀσ], [Φ_q, 0, 0], [σA, 0, 0]] (δv = σ δq + b_q eliminated);
    ARPACK (``scipy.sparse.linalg.eigs``) iterates on it. Complex pairs count as two modes.

    Parameters
    ----------
    model : Model
    state : State, StaticResult or (q, v), optional
        An equilibrium (default the initial coordinates at rest).
    n_modes : int
        Number of eigenvalues (a conjugate pair counts two).
    sigma : float
        Real shift (1/s); 0 finds the slowest modes (needs K nonsingular on the constraints).
    tol : float
        ARPACK's relative tolerance of the shifted-inverted eigenvalues 1/(s − σ).
    ncv : int, optional
        ARPACK's number of Lanczos (Arnoldi) vectors (default max(2 n_modes + 1, n_modes + 40)).

    Returns
    -------
    DampedModes
        ``shapes`` (2 nq, k): (δq, δv) of each mode; ``vectors`` the same.
    """
    refuse_contacts(model, 'damped modes (damped_modes)')
    t, q, v = _state_of(model, state, t)
    if np.any(v):
        raise ParameterError("damped_modes: the reference must be an equilibrium (v = 0); use linearize(...).eig()")
    b_ = _Blocks(model, t, q, v)
    _check_admissible(model, v, b_, 1e-8)
    vd, lam, mu = reference(model, t, q, v, b_)
    _check_steady(model, q, v, vd, None, "equilibrium", 1e-8)
    st = State(t, q, v, vd, lam)
    nq, nc, nn = model.nq, model.nc, model.nn
    M = assembly.mass_matrix(model, q).tocsc()
    K = assembly.tangent_stiffness(model, st)
    if nn:
        K = K + assembly.velocity_constraint_jacobians(model, t, q, v, mu)[1]
    C = assembly.tangent_damping(model, st)
    s = float(sigma)
    Kc = (K + s * C + s * s * M).tocsc()
    Bq, An = b_.B.tocsc(), b_.A.tocsc()
    S = sp.bmat([[Kc, Bq.T, s * An.T if nn else None], [Bq, None, None],
                 [s * An if nn else None, None, None]], format="csc") if (nc + nn) else Kc
    if nn and s == 0.0:
        raise ParameterError("damped_modes: with velocity constraints give a non-zero sigma")
    try:
        lu = spla.splu(S, permc_spec="MMD_AT_PLUS_A")
    except RuntimeError as err:
        raise SingularMatrixError(f"damped_modes: the shifted matrix is singular at sigma = {s:g} ({err}); "
                                  "a model with rigid-body modes needs a shift away from 0") from None
    CsM = (C + s * M).tocsr()
    Ms = M.tocsr()

    def op(b):
        bq, bv = b[:nq], b[nq:]
        rhs = np.zeros(S.shape[0], dtype=np.result_type(b.dtype, float))
        rhs[:nq] = -(Ms @ bv) - CsM @ bq
        if nn:
            rhs[nq + nc:] = -(An @ bq)
        x = lu.solve(rhs) if not np.iscomplexobj(rhs) else lu.solve(rhs.real) + 1j * lu.solve(rhs.imag)
        dq = x[:nq]
        return np.concatenate((dq, s * dq + bq))

    n2 = 2 * nq
    Op = spla.LinearOperator((n2, n2), matvec=op, dtype=float)
    k = int(n_modes)
    if not 1 <= k < n2 - 1:
        raise ParameterError(f"damped_modes: n_modes must be between 1 and {n2 - 2}, got {n_modes!r}")
    v0 = np.random.default_rng(0).standard_normal(n2)
    ncv = min(n2, max(2 * k + 1, k + 40) if ncv is None else int(ncv))
    theta, X = spla.eigs(Op, k=k, which="LM", tol=tol, v0=v0, ncv=ncv)
    lam_s = s + 1.0 / theta
    order = np.lexsort((-lam_s.imag, np.abs(lam_s)))
    op_ = {"t": t, "q": q, "v": v, "vd": vd, "lam": lam, "mu": mu}
    return DampedModes(lam_s[order], X[:, order], X[:, order], model, op_)


# --------------------------------------------------------------------------
# eigenvalues against a parameter
# --------------------------------------------------------------------------
def eigenvalue_sweep(linear_model, values):
    """Eigenvalues of ``linear_model(p)`` (a function returning a :class:`LinearModel`) for each p.

    Returns
    -------
    values : ndarray (k,); eigenvalues : ndarray (k, n) complex, each row sorted by real part
    """
    values = np.asarray(values, dtype=float)
    rows = []
    for p in values:
        ev = np.linalg.eigvals(linear_model(p).A)
        rows.append(ev[np.lexsort((ev.imag, ev.real))])
    return values, np.array(rows)


def campbell_plot(values, eigenvalues, path, *, xlabel="parameter", title=None, ylim=None):
    """Real parts (dots) and |imaginary parts| (open circles) of the eigenvalues against the
    parameter, saved to ``path`` (matplotlib, no display)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    ax.plot(values, np.asarray(eigenvalues).real, "k.", ms=3)
    ax.plot(values, np.abs(np.asarray(eigenvalues).imag), "o", mfc="none", color="tab:blue", ms=3)
    ax.axhline(0.0, color="0.6", lw=0.8)
    if ylim is not None:
        ax.set_ylim(*ylim)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("Re λ (dots), |Im λ| (circles)  [1/s]")
    if title:
        ax.set_title(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
