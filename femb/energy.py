"""Energies of a simulation and their balance.

For every stored step of a :class:`~femb.result.Result`:

=================  ============================================================
``kinetic``        T = ½ q̇ᵀ M(q) q̇ (:func:`femb.assembly.mass_matrix`)
``gravitational``  V_g = −Σ m gᵀ r_G over rigid bodies and point masses
                   (planar and spatial)
                   (r_G the node = centre of mass) and −Σ ρA L₀ gᵀ (r_a + r_b)/2
                   over beam elements (the potential of the gravity loads
                   M ĝ of their consistent or lumped mass)
``elastic``        ½ k (l − l₀)² of springs, ½ k (θ_b − θ_a − θ₀)² of
                   rotational springs, the strain energy of beams
                   (:func:`femb.elements.beam_strain_energy`); spatial:
                   ½ k (ℓ − ℓ₀)² of point springs, ½ Σ K Δ² + ½ Σ K_r ψ² of
                   bushings, ½ k θ² of rotational springs
                   (:func:`spatial_pair_energy`)
``work_loads``     ∫ P dt of applied forces and torques, P = F·v_P + T ω
                   (spatial: F·v_P + M·ω, space axes)
``work_drives``    ∫ λᵀ Φ_t dt, the work of driven (rheonomic) constraints
                   (the power of the constraint forces −Φ_qᵀλ is
                   −λᵀ Φ_q q̇ = λᵀ Φ_t)
``dissipated``     ∫ −(f(q, q̇) − f(q, 0))·q̇ dt, the energy taken out by
                   dampers and damped beam sections
``balance``        T + V_g + V_el − (T + V_g + V_el)(t₀) − W_loads − W_drives
                   + D: zero for the exact motion; for a simulation, the
                   numerical dissipation of the scheme (ρ∞ < 1) plus the
                   error of the trapezoidal rule used for the integrals
=================  ============================================================

The integrals use the trapezoidal rule over the *stored* steps: store every
step (``stride=1``) for a sharp balance.

The element-specific formulas read the attributes of the element instances
(stiffness, rest length, attachment points, masses, sections, load functions).
"""
from __future__ import annotations

import numpy as np

from femb import assembly
from femb.errors import ModelError
from femb.functions import evaluate

KINDS = ("kinetic", "gravitational", "elastic", "work_loads", "work_drives", "dissipated", "total", "balance")


def _elements(model):
    """Every element instance of the model (each once), in batch order."""
    seen, out = set(), []
    for g in model.groups:
        for e in g.elements:
            if id(e) not in seen:
                seen.add(id(e))
                out.append(e)
    return out


def _rot(th, s):
    """R(θ) s for θ of shape (nt,) and s of shape (2,) -> (nt, 2)."""
    c, sn = np.cos(th), np.sin(th)
    return np.stack((c * s[0] - sn * s[1], sn * s[0] + c * s[1]), axis=-1)


class _Kin:
    """Node coordinates and velocities over the stored steps (fixed ones included)."""

    def __init__(self, result):
        self.model = result.model
        self.q, self.qd = result.q, result.qd

    def node(self, node):
        """x (nt, nx_node) and v (nt, nv_node) of a node: (x, y, θ) planar, (r, p) and (ṙ, Ω) spatial."""
        m = self.model
        return m.node_coordinates(node.name, self.q), m.node_velocities(node.name, self.qd)

    def point(self, body, s):
        """Position and velocity of a body-frame point s over time, each (nt, 2)."""
        x, v = self.node(body.node)
        d = _rot(x[:, 2], s)
        return x[:, :2] + d, v[:, :2] + v[:, 2:3] * np.stack((-d[:, 1], d[:, 0]), axis=-1)

    def frame(self, node):
        """r (nt, 3), R (nt, 3, 3), ṙ (nt, 3) and Ω (nt, 3, body axes) of a spatial frame node."""
        from femb.elements._spatial_geometry import rotation_matrices
        x, v = self.node(node)
        return x[:, 0:3], rotation_matrices(x[:, 3:7]), v[:, 0:3], v[:, 3:6]


def _spatial(node):
    return bool(getattr(node, "rotation_blocks", ()))


def _pair(kin, e):
    """R_a, R_b (nt, 3, 3) and the joint points p_a, p_b (nt, 3) of a spatial pair element."""
    ra, Ra, _, _ = kin.frame(e.a.node)
    rb, Rb, _, _ = kin.frame(e.b.node)
    return Ra, Rb, ra + Ra @ e.Xa, rb + Rb @ e.Xb


def spatial_pair_energy(kin, e):
    """Potential energy of a spatial spring element over time, shape (nt,) (J).

    :class:`~femb.elements.spatial_forces.PointSpringDamper`: ½ k (ℓ − ℓ0)²;
    :class:`~femb.elements.spatial_forces.Bushing`: ½ Σ K_k Δ_k² + ½ Σ K_r,k ψ_k²
    with Δ_k = u_k·(p_b − p_a) − Δ0_k and ψ = (u3·w2, u1·w3, u2·w1);
    :class:`~femb.elements.spatial_forces.RotationalSpringDamper`: ½ k θ², θ =
    atan2(ā2·w1, ā1·w1) measured from the unstretched angle θ0 — the
    potentials whose gradients are the elements' kernels' forces.
    """
    from femb.elements.spatial_forces import Bushing, PointSpringDamper, RotationalSpringDamper

    Ra, Rb, pa, pb = _pair(kin, e)
    if isinstance(e, PointSpringDamper):
        return 0.5 * e.k * (np.linalg.norm(pb - pa, axis=1) - e.L0) ** 2
    u = [Ra @ e.Ea[k] for k in range(3)]          # (nt, 3) each, space axes
    w = [Rb @ e.Eb[k] for k in range(3)]
    if isinstance(e, Bushing):
        d = pb - pa
        V = np.zeros(pa.shape[0])
        for k in range(3):
            V += 0.5 * e.K[k] * (np.einsum("ti,ti->t", u[k], d) - e.m0[k]) ** 2
        for k, (a, b) in enumerate(((2, 1), (0, 2), (1, 0))):
            V += 0.5 * e.K[3 + k] * np.einsum("ti,ti->t", u[a], w[b]) ** 2
        return V
    if isinstance(e, RotationalSpringDamper):
        c0, s0 = np.cos(e.angle0), np.sin(e.angle0)
        a1, a2 = c0 * u[0] + s0 * u[1], -s0 * u[0] + c0 * u[1]
        th = np.arctan2(np.einsum("ti,ti->t", a2, w[0]), np.einsum("ti,ti->t", a1, w[0]))
        return 0.5 * e.k * th ** 2
    return None


def _trapz(t, p):
    out = np.zeros_like(p)
    if p.size > 1:
        out[1:] = np.cumsum(0.5 * (p[1:] + p[:-1]) * np.diff(t))
    return out


def kinetic_energy(result):
    """T = ½ q̇ᵀ M q̇ at every stored step, shape (nt,) (J)."""
    m = result.model
    if m.constant_mass:
        M = m.M_const
        return 0.5 * np.einsum("ti,ti->t", result.qd, (M @ result.qd.T).T)
    return np.array([0.5 * qd @ (assembly.mass_matrix(m, q) @ qd) for q, qd in zip(result.q, result.qd)])


def gravitational_energy(result):
    """V_g = −Σ m gᵀ r_G (bodies, point masses, beam elements; planar and spatial), shape (nt,) (J).

    A planar :class:`~femb.elements.Gravity` acts on the x and y translations
    of spatial nodes, a :class:`~femb.elements.spatial_forces.SpatialGravity`
    with its x and y components on planar nodes (as the assembled force M ĝ).
    Zeros without gravity.
    """
    from femb.elements import PointMass, RigidBody
    from femb.elements.beam import ReissnerBeam
    from femb.elements.spatial_bodies import SpatialPointMass, SpatialRigidBody

    m = result.model
    nt = result.t.size
    V = np.zeros(nt)
    if m.gravity is None:
        return V
    g = np.asarray(m.gravity, dtype=float)
    g2, g3 = g[:2], np.pad(g, (0, 3 - g.size))[:3]
    kin = _Kin(result)
    for e in _elements(m):
        if isinstance(e, (RigidBody, PointMass)):
            x, _ = kin.node(e.node)
            V -= e.m * (x[:, :2] @ g2)
        elif isinstance(e, (SpatialRigidBody, SpatialPointMass)):
            x, _ = kin.node(e.node)
            V -= e.m * (x[:, 0:3] @ g3)
        elif isinstance(e, ReissnerBeam):
            xa, _ = kin.node(e.a.node)
            xb, _ = kin.node(e.b.node)
            V -= e.section.rhoA * e.L0 * (0.5 * (xa[:, :2] + xb[:, :2]) @ g2)
    return V


def elastic_energy(result, by_element=False):
    """Energy stored in springs, rotational springs, bushings and beams, shape (nt,) (J).

    Parameters
    ----------
    result : Result
    by_element : bool
        Return a dict ``{element name: (nt,) array}`` for springs and a
        ``"beams"`` entry for all beams together instead of the sum.
    """
    from femb.elements import RotationalSpringDamper, SpringDamper
    from femb.elements.beam import ReissnerBeam, beam_strain_energy
    from femb.elements.spatial_forces import Bushing, PointSpringDamper
    from femb.elements.spatial_forces import RotationalSpringDamper as SpatialRotationalSpringDamper

    m = result.model
    kin = _Kin(result)
    parts = {}
    has_beam = False
    for e in _elements(m):
        if isinstance(e, SpringDamper):
            pa, _ = kin.point(e.a, e.sa)
            pb, _ = kin.point(e.b, e.sb)
            l = np.linalg.norm(pb - pa, axis=1)
            parts[e.name] = 0.5 * e.k * (l - e.l0) ** 2
        elif isinstance(e, RotationalSpringDamper):
            xa, _ = kin.node(e.a.node)
            xb, _ = kin.node(e.b.node)
            parts[e.name] = 0.5 * e.k * (xb[:, 2] - xa[:, 2] - e.phi0) ** 2
        elif isinstance(e, (PointSpringDamper, Bushing, SpatialRotationalSpringDamper)):
            parts[e.name] = spatial_pair_energy(kin, e)
        elif isinstance(e, ReissnerBeam):
            has_beam = True
    if has_beam:
        parts["beams"] = np.array([beam_strain_energy(m, q) for q in result.q])
    if by_element:
        return parts
    total = np.zeros(result.t.size)
    for v in parts.values():
        total += v
    return total


def load_power(result):
    """Power of applied forces and torques, shape (nt,) (W).

    Planar: P = F·v_P + T θ̇. Spatial (:class:`~femb.elements.spatial_forces.SpatialForce`,
    :class:`~femb.elements.spatial_forces.SpatialTorque`): P = F·(ṙ + R(Ω × X)) and
    P = M·(RΩ), F and M in space axes (R F_b for follower loads).
    """
    from femb.elements import Force, Torque
    from femb.elements.spatial_forces import SpatialForce, SpatialTorque

    m = result.model
    kin = _Kin(result)
    t = result.t
    P = np.zeros(t.size)
    for e in _elements(m):
        if isinstance(e, Force):
            F = np.stack([np.array([evaluate([fn], tk, 0)[0] for tk in t]) for fn in e.fns], axis=1)
            x, _ = kin.node(e.body.node)
            if e.frame == "body":
                c, s = np.cos(x[:, 2]), np.sin(x[:, 2])
                F = np.stack((c * F[:, 0] - s * F[:, 1], s * F[:, 0] + c * F[:, 1]), axis=1)
            _, v = kin.point(e.body, e.s)
            P += np.einsum("ti,ti->t", F, v)
        elif isinstance(e, Torque):
            T = np.array([evaluate([e.fn], tk, 0)[0] for tk in t])
            _, v = kin.node(e.body.node)
            P += T * v[:, 2]
        elif isinstance(e, (SpatialForce, SpatialTorque)):
            s = np.array([e.fn.f(tk) for tk in t])
            _, R, rd, W = kin.frame(e.body.node)
            V = s[:, None] * (R @ e.value if e.follower else e.value)       # space axes
            if isinstance(e, SpatialTorque):
                P += np.einsum("ti,ti->t", V, np.einsum("tij,tj->ti", R, W))
            else:
                vP = rd + np.einsum("tij,tj->ti", R, np.cross(W, e.X))
                P += np.einsum("ti,ti->t", V, vP)
    return P


def drive_power(result):
    """Power of the constraint forces, λᵀ Φ_t (nonzero for driven constraints only), shape (nt,) (W)."""
    m = result.model
    if not m.nc or not m.rheonomic:
        return np.zeros(result.t.size)
    return np.array([lam @ assembly.constraint_rates(m, t, q, qd)[0]
                     for t, q, qd, lam in zip(result.t, result.q, result.qd, result.lam)])


def dissipation_power(result):
    """Power taken out by velocity-dependent forces, −(f(q, q̇) − f(q, 0))·q̇ ≥ 0, shape (nt,) (W)."""
    m = result.model
    if not m.needs_C:
        return np.zeros(result.t.size)
    z = np.zeros(m.nq)
    return np.array([-(assembly.force_vector(m, t, q, qd) - assembly.force_vector(m, t, q, z)) @ qd
                     for t, q, qd in zip(result.t, result.q, result.qd)])


def energies(result):
    """All energies and the balance at every stored step (see the module table).

    Returns
    -------
    dict of str to ndarray, shape (nt,)
        Keys: ``kinetic``, ``gravitational``, ``elastic``, ``work_loads``,
        ``work_drives``, ``dissipated``, ``total`` (T + V_g + V_el) and
        ``balance``, in J.
    """
    if result.qd is None or result.t.size == 0:
        raise ModelError("energies need a result with stored steps and velocities")
    t = result.t
    out = {"kinetic": kinetic_energy(result), "gravitational": gravitational_energy(result),
           "elastic": elastic_energy(result)}
    out["work_loads"] = _trapz(t, load_power(result))
    out["work_drives"] = _trapz(t, drive_power(result))
    out["dissipated"] = _trapz(t, dissipation_power(result))
    out["total"] = out["kinetic"] + out["gravitational"] + out["elastic"]
    out["balance"] = (out["total"] - out["total"][0] - out["work_loads"] - out["work_drives"]
                      + out["dissipated"])
    return out


def energy_balance(result):
    """Largest |balance| relative to the energy scale of the run.

    The scale is the largest of the ranges (max − min) of T, V_g, V_el and of
    the work and dissipation integrals; a relative balance error of order h²
    (ρ∞ = 1) or the numerical dissipation (ρ∞ < 1) is expected.

    Returns
    -------
    float
    """
    e = energies(result)
    scale = max(float(np.ptp(e[k])) for k in ("kinetic", "gravitational", "elastic", "work_loads",
                                              "work_drives", "dissipated"))
    err = float(np.abs(e["balance"]).max())
    return err / scale if scale > 0.0 else err
