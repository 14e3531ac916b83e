"""Planar geometrically exact beams (Reissner / Simo–Vu-Quoc) in absolute coordinates.

A beam node carries the same absolute coordinates (x, y, θ) as the node of a
rigid body: the position of the section's centroid and the rotation of the
cross-section in the inertial frame (Géradin & Cardona 2001, Ch. 7). Beams,
rigid bodies, hinges, sliders and drivers therefore connect freely: a beam
node is a :class:`~femb.elements.bodies.Body` (a massless :class:`BeamNode`,
or the node of an existing rigid body), and every joint of the library
accepts it.

Kinematics and strains (Reissner 1972; Simo & Vu-Quoc 1986, Part I, eqs.
(2.6)–(2.8) restricted to the plane)::

    x(s), θ(s)                  centroid and section rotation
    Γ = R(θ)ᵀ x' − Γ₀           material axial (Γ₁) and shear (Γ₂) strain
    κ = θ' − κ₀                 bending strain (curvature change)
    N = EA Γ₁,  V = GA Γ₂,  M = EI κ      (plus η-proportional rates, below)

with ``'`` = d/ds along the reference arc length and Γ₀, κ₀ the strains of
the reference configuration, which is stress free (straight or curved).

Discretization: two-node elements, linear interpolation of x and θ, and
**one-point (reduced) Gauss integration** of all strain energy terms. Why
this choice (against selective integration or higher-order/mixed
interpolation):

* no shear locking: with one point, the Kirchhoff constraint Γ₂ = 0 is
  imposed once per element instead of pointwise, the classic cure for the
  linear Timoshenko element (Hughes, Taylor & Kanoknukulchai 1977; Simo &
  Vu-Quoc 1986 use exactly this reduced integration);
* no membrane locking of curved beams: the axial strain is sampled at the
  same single point (Stolarski & Belytschko 1982, Noor & Peters 1981);
* no spurious zero-energy (hourglass) modes: the element has 6 coordinates,
  3 rigid-body motions and exactly 3 independent strains (Γ₁, Γ₂, κ at the
  midpoint), so its stiffness has full rank 3;
* the bending strain κ = (θ_B − θ_A)/L is constant on the element, so the
  single point integrates it exactly, and the discrete equations have an
  exact constant-curvature solution: under a tip moment M = 2π EI/L a
  cantilever rolls into a closed regular polygon whose tip is at the root
  to round-off, for any number n ≥ 2 of elements (tests/test_beam_static.py);
* every quantity is a small closed form, cheap to vectorize over elements.

With one point at ξ = 0 (the element midpoint, reference length L)::

    x' = (x_B − x_A)/L,  θ_m = (θ_A + θ_B)/2,  g = R(θ_m)ᵀ x',  Γ = g − Γ₀,
    κ = (θ_B − θ_A)/L − κ₀,
    f_int = L Bᵀ σ,  B = ∂(Γ₁, Γ₂, κ)/∂q_e,  σ = (N, V, M)

giving, with n = R(θ_m)(N, V) the spatial force resultant,
f_int = [−n, L/2 (g₂N − g₁V) − M, n, L/2 (g₂N − g₁V) + M]. The tangent
stiffness is K = L Bᵀ D B + K_σ with the geometric part
K_σ[x_A, θ_*] = −J n/2, K_σ[x_B, θ_*] = J n/2, K_σ[θ_*, θ_*] = −L/4 (N g₁ + V g₂)
(J the rotation by +90°), all derived in the docstring of
:func:`beam_force` (the compiled force kernel).

Material damping is stiffness proportional (Kelvin–Voigt on the material
strain rates, objective): σ = D (ε + η ε̇), which adds C = L η Bᵀ D B to the
damping tangent and a (non-symmetric) term to the stiffness tangent.

Inertia: the node sits at the section centroid, so the kinetic energy
T = ½∫(ρA ‖ẋ‖² + ρI θ̇²) ds has a constant mass matrix in these absolute
coordinates (Simo & Vu-Quoc 1986, Part I, Sect. 3; no gyroscopic term in
the plane). Consistent (linear shape functions, exact integration) or lumped.

References
----------
E. Reissner, On one-dimensional finite-strain beam theory: the plane problem,
Z. angew. Math. Phys. 23 (1972) 795–804.

J. C. Simo, L. Vu-Quoc, On the dynamics of flexible beams under large overall
motions—the plane case, Parts I & II, J. Appl. Mech. 53 (1986) 849–863.

M. Géradin, A. Cardona, Flexible Multibody Dynamics: A Finite Element
Approach, Wiley, 2001, Ch. 7 (beams in absolute nodal coordinates).

T. J. R. Hughes, R. L. Taylor, W. Kanoknukulchai, A simple and efficient
finite element for plate bending, Int. J. Numer. Meth. Eng. 11 (1977)
1529–1543 (reduced integration against shear locking).

H. Stolarski, T. Belytschko, Membrane locking and reduced integration for
curved elements, J. Appl. Mech. 49 (1982) 172–176.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from femb.base.geometry import GeometryBlock
from femb.base.jit import kernel
from femb.errors import ModelError
from femb.system.element import Element
from femb.system.nodes import PlanarNode

from ._meshing import check_model_size, element_count
from ._planar import rot
from .bodies import Body, _check_scalar, _point
from .forces import write_pair_blocks
from .joints import Hinge, PairElement, hinge_rates

__all__ = ["Section", "BeamNode", "ReissnerBeam", "Clamp", "BeamMesh", "add_beam",
           "beam_resultants", "beam_strain_energy"]


# ---------------------------------------------------------------------------
# section data
# ---------------------------------------------------------------------------
def _section_numbers(owner, E, G, density, shear_factor, damping):
    """E, G, shear factor > 0, density and damping ≥ 0, each a finite number (ModelError naming it)."""
    return (_check_scalar(owner, "E", E, positive=True), _check_scalar(owner, "G", G, positive=True),
            _check_scalar(owner, "density", density, nonneg=True),
            _check_scalar(owner, "shear_factor", shear_factor, positive=True),
            _check_scalar(owner, "damping", damping, nonneg=True))


@dataclass(frozen=True)
class Section:
    """Cross-section data of a planar beam.

    Parameters
    ----------
    EA : float > 0
        Axial stiffness (N).
    GA : float > 0
        Effective shear stiffness k G A, shear factor k included (N).
    EI : float > 0
        Bending stiffness (N m²).
    rhoA : float ≥ 0
        Mass per unit length (kg/m).
    rhoI : float ≥ 0
        Rotational inertia of the section per unit length (kg m).
    damping : float ≥ 0
        Stiffness-proportional material damping coefficient η (s): the
        stress resultants are D (ε + η ε̇).
    """

    EA: float
    GA: float
    EI: float
    rhoA: float
    rhoI: float
    damping: float = 0.0

    def __post_init__(self):
        for k in ("EA", "GA", "EI"):
            object.__setattr__(self, k, _check_scalar("Section", k, getattr(self, k), positive=True))
        for k in ("rhoA", "rhoI", "damping"):
            object.__setattr__(self, k, _check_scalar("Section", k, getattr(self, k), nonneg=True))

    @classmethod
    def rectangle(cls, E, G, width, height, density, shear_factor=5.0 / 6.0, damping=0.0):
        """Solid rectangle ``width`` × ``height`` (height in the plane of bending)."""
        E, G, density, shear_factor, damping = _section_numbers("Section.rectangle", E, G, density, shear_factor,
                                                                damping)
        width = _check_scalar("Section.rectangle", "width", width, positive=True)
        height = _check_scalar("Section.rectangle", "height", height, positive=True)
        A = width * height
        I = width * height ** 3 / 12.0
        return cls(E * A, shear_factor * G * A, E * I, density * A, density * I, damping)

    @classmethod
    def circle(cls, E, G, diameter, density, shear_factor=0.9, damping=0.0):
        """Solid circle of ``diameter`` (shear factor 0.9 ≈ 6(1+ν)/(7+6ν) for ν = 0.3)."""
        E, G, density, shear_factor, damping = _section_numbers("Section.circle", E, G, density, shear_factor, damping)
        diameter = _check_scalar("Section.circle", "diameter", diameter, positive=True)
        A = math.pi * diameter ** 2 / 4.0
        I = math.pi * diameter ** 4 / 64.0
        return cls(E * A, shear_factor * G * A, E * I, density * A, density * I, damping)


# ---------------------------------------------------------------------------
# nodes
# ---------------------------------------------------------------------------
class BeamNode(Body, Element):
    """A massless body owning one beam node (x, y, θ).

    It contributes no equations; it exists so that joints, loads and named
    output (``result.body(name)``, ``result.position(name, point)``) work on
    beam nodes exactly as on rigid bodies. Mass comes from the beam elements.

    Parameters
    ----------
    name : str
    position : (x, y)
    angle : float
        Section rotation θ (rad), normally the tangent angle.
    velocity : (vx, vy), omega : float
    fixed : sequence of 3 bool, optional
        Coordinates held fixed (e.g. ``(True, True, True)`` clamps to the ground
        without a constraint).
    points : dict, optional
        Named points in the section frame.
    """

    def __init__(self, name, position, angle=0.0, velocity=(0.0, 0.0), omega=0.0, fixed=None,
                 points=None):
        Element.__init__(self, name)
        owner = f"BeamNode '{name}'"
        pos = _point(owner, "position", position)
        vel = _point(owner, "velocity", velocity)
        th = _check_scalar(owner, "angle", angle)
        om = _check_scalar(owner, "omega", omega)
        Body.__init__(self, name, PlanarNode(name, (pos[0], pos[1], th), (vel[0], vel[1], om), fixed),
                      points)

    def nodes(self):
        return [self.node]


# ---------------------------------------------------------------------------
# the element: compiled kernels
# ---------------------------------------------------------------------------
# Packed parameters of a ReissnerBeam batch, P (nel, 13): the columns below.
_L, _INVL, _G01, _G02, _K0, _EA, _GA, _EI, _ETA, _RHOA, _RHOI, _MDIAG, _MOFF = range(13)


@kernel
def _midpoint(P, xe, e):
    """Midpoint kinematics of element e: (c, s) of θ_m, g = R(θ_m)ᵀ x′, κ (strain, κ₀ removed)."""
    inv = P[e, _INVL]
    d1 = (xe[e, 3] - xe[e, 0]) * inv
    d2 = (xe[e, 4] - xe[e, 1]) * inv
    th = 0.5 * (xe[e, 2] + xe[e, 5])
    c, s = math.cos(th), math.sin(th)
    g1 = c * d1 + s * d2
    g2 = c * d2 - s * d1
    kap = (xe[e, 5] - xe[e, 2]) * inv - P[e, _K0]
    return c, s, g1, g2, kap


@kernel
def beam_energy(P, t, tf, xe, Ve):
    """Strain energy V = ½ L (EA Γ₁² + GA Γ₂² + EI κ²) of each element (one-point rule, the
    potential of the elastic part of :func:`beam_force`); P and xe as there."""
    for e in range(xe.shape[0]):
        c, s, g1, g2, kap = _midpoint(P, xe, e)
        G1 = g1 - P[e, _G01]
        G2 = g2 - P[e, _G02]
        Ve[e] = 0.5 * P[e, _L] * (P[e, _EA] * G1 * G1 + P[e, _GA] * G2 * G2 + P[e, _EI] * kap * kap)


@kernel
def _midpoint_rates(P, ve, e, c, s):
    """u = R(θ_m)ᵀ ẋ′ (u₁, u₂), θ̇_m and κ̇ of element e; Γ̇ = u − θ̇_m J g = (u₁ + θ̇_m g₂, u₂ − θ̇_m g₁)."""
    inv = P[e, _INVL]
    dd1 = (ve[e, 3] - ve[e, 0]) * inv
    dd2 = (ve[e, 4] - ve[e, 1]) * inv
    om = 0.5 * (ve[e, 2] + ve[e, 5])
    u1 = c * dd1 + s * dd2
    u2 = c * dd2 - s * dd1
    return u1, u2, om, (ve[e, 5] - ve[e, 2]) * inv


@kernel
def _btdb(L, inv, c, s, g1, g2, D0, D1, D2):
    """The distinct entries of L Bᵀ diag(D0, D1, D2) B of one element (6 × 6, symmetric).

    With B = [−Rᵀ/L, t, Rᵀ/L, t′] (rows Γ₁, Γ₂, κ; t = (g₂/2, −g₁/2, −1/L),
    t′ = (g₂/2, −g₁/2, 1/L)) the matrix has the blocks [x_A, x_A] = [x_B, x_B] =
    −[x_A, x_B] = R D̄ Rᵀ/L = a (D̄ = diag(D0, D1)), [x_A, θ_*] = −[x_B, θ_*] = −R w with
    w = D̄ (g₂/2, −g₁/2), and [θ_A, θ_A] = [θ_B, θ_B] = q + r, [θ_A, θ_B] = q − r with
    q = L (D0 g₂² + D1 g₁²)/4, r = D2/L.

    Returns a11, a12, a22, (R w)₁, (R w)₂, q, r.
    """
    cc, ss, cs = c * c, s * s, c * s
    a11 = (cc * D0 + ss * D1) * inv
    a12 = cs * (D0 - D1) * inv
    a22 = (ss * D0 + cc * D1) * inv
    w1 = 0.5 * D0 * g2
    w2 = -0.5 * D1 * g1
    q = 0.25 * L * (D0 * g2 * g2 + D1 * g1 * g1)
    return a11, a12, a22, c * w1 - s * w2, s * w1 + c * w2, q, D2 * inv


@kernel
def beam_mass(P, xe, Me):
    """Constant mass matrices of two-node beams (consistent or lumped).

    Consistent: ∫ Nᵢ Nⱼ ds = L/6 [[2, 1], [1, 2]] for each of x, y (× ρA) and θ (× ρI);
    lumped: L/2 on the diagonal. P[:, m_diag], P[:, m_off] hold 1/3, 1/6 or 1/2, 0.
    """
    for e in range(P.shape[0]):
        L = P[e, _L]
        md = P[e, _MDIAG]
        mo = P[e, _MOFF]
        for k in range(3):
            m = (P[e, _RHOI] if k == 2 else P[e, _RHOA]) * L
            Me[e, k, k] = m * md
            Me[e, 3 + k, 3 + k] = m * md
            Me[e, k, 3 + k] = m * mo
            Me[e, 3 + k, k] = m * mo


@kernel
def beam_force(P, t, tf, xe, ve, jac, fe, fq, fv):
    """f = −f_int with f_q = −K_t and f_q̇ = −C_t of two-node Reissner beams (one-point rule).

    Derivation (midpoint quantities; J = [[0, −1], [1, 0]], ∂Rᵀ/∂θ = −J Rᵀ; Simo & Vu-Quoc
    1986, Part I, Sect. 4, specialised to a linear element):

    * δΓ = Rᵀ δx′ − J g δθ_m, δκ = δθ′, so the rows of B are
      ∂Γ₁/∂(x_A, θ_A, x_B, θ_B) = (−(c, s)/L, g₂/2, (c, s)/L, g₂/2),
      ∂Γ₂/∂(…) = ((s, −c)/L, −g₁/2, (−s, c)/L, −g₁/2),
      ∂κ/∂(…) = (0, 0, −1/L, 0, 0, 1/L);
    * σ = (N, V, M) = D ε (+ η D ε̇), n = R(θ_m)(N, V);
      f = −L Bᵀσ = [n, M − m, −n, −M − m] with m = L/2 (g₂N − g₁V);
    * K_t = L BᵀDB + K_σ, K_σ from Σσᵢ ∂²εᵢ: ∂²(sᵀΓ)/∂x′∂θ_m = J n, ∂²(sᵀΓ)/∂θ_m² = −sᵀg
      (s = (N, V)), i.e. K_σ[x_A, θ_*] = −J n/2, K_σ[x_B, θ_*] = J n/2,
      K_σ[θ_*, θ_*] = −L/4 (N g₁ + V g₂);
    * damping (η ≠ 0): ε̇ = B q̇, C_t = L η BᵀDB, and ∂ε̇/∂q = E with
      ∂Γ̇/∂x_A = θ̇_m J Rᵀ/L = −∂Γ̇/∂x_B, ∂Γ̇/∂θ_* = ½(−J Rᵀẋ′ − θ̇_m g), adding L Bᵀ η D E
      (not symmetric) to K_t.

    P columns: L, 1/L, Γ₀ (2), κ₀, EA, GA, EI, η, ρA, ρI, m_diag, m_off.
    """
    for e in range(xe.shape[0]):
        L = P[e, _L]
        inv = P[e, _INVL]
        EA = P[e, _EA]
        GA = P[e, _GA]
        EI = P[e, _EI]
        eta = P[e, _ETA]
        c, s, g1, g2, kap = _midpoint(P, xe, e)
        N = EA * (g1 - P[e, _G01])
        V = GA * (g2 - P[e, _G02])
        M = EI * kap
        damped = eta != 0.0
        u1 = u2 = om = 0.0
        if damped:
            u1, u2, om, kd = _midpoint_rates(P, ve, e, c, s)
            N += (eta * EA) * (u1 + om * g2)
            V += (eta * GA) * (u2 - om * g1)
            M += (eta * EI) * kd
        n1 = c * N - s * V
        n2 = s * N + c * V
        mom = 0.5 * L * (g2 * N - g1 * V)
        fe[e, 0] = n1
        fe[e, 1] = n2
        fe[e, 2] = M - mom
        fe[e, 3] = -n1
        fe[e, 4] = -n2
        fe[e, 5] = -M - mom
        if not jac:
            continue
        # −(L BᵀDB + K_σ), symmetric: −K_σ adds J n/2 to [x_A, θ_*] and L/4 (N g₁ + V g₂) to [θ_*, θ_*]
        a11, a12, a22, r1, r2, q, rk = _btdb(L, inv, c, s, g1, g2, EA, GA, EI)
        p1 = r1 - 0.5 * n2
        p2 = r2 + 0.5 * n1
        m1, m2 = p1, p2
        Q11, Q12, Q21, Q22 = -a11, -a12, -a12, -a22
        tt = 0.25 * L * (N * g1 + V * g2)
        d = tt - (q + rk)
        o = tt - (q - rk)
        if damped:
            # −L Bᵀ η D E: −A on [x_A, x_A], −b on [x_A, θ_*], −r on [θ_*, x_A], −L w·e_t on [θ_*, θ_*]
            Da = eta * EA
            Db = eta * GA
            oi = om * inv
            A11 = oi * (c * s) * (Da - Db)           # A = θ̇_m/L · R D̄η J Rᵀ
            Q11 += A11
            Q12 -= oi * (c * c * Da + s * s * Db)
            Q21 += oi * (s * s * Da + c * c * Db)
            Q22 -= A11
            et1 = 0.5 * (u2 - om * g1)               # ∂Γ̇/∂θ_* = e_t
            et2 = 0.5 * (-u1 - om * g2)
            p1 += c * Da * et1 - s * Db * et2        # b = R D̄η e_t
            p2 += s * Da * et1 + c * Db * et2
            w1 = 0.5 * Da * g2
            w2 = -0.5 * Db * g1
            m1 -= om * (w1 * s + w2 * c)             # r = θ̇_m wηᵀ J Rᵀ
            m2 -= om * (w2 * s - w1 * c)
            tw = L * (w1 * et1 + w2 * et2)
            d -= tw
            o -= tw
            # f_q̇ = −C_t = −L Bᵀ η D B
            b11, b12, b22, br1, br2, bq, brk = _btdb(L, inv, c, s, g1, g2, Da, Db, eta * EI)
            write_pair_blocks(fv, e, -b11, -b12, -b12, -b22, br1, br2, br1, br2, br1, br2, br1, br2,
                              -(bq + brk), -(bq - brk), -(bq - brk), -(bq + brk))
        # both rotations enter through θ_m (same columns p, same rows m) except for bending (d, o)
        write_pair_blocks(fq, e, Q11, Q12, Q21, Q22, p1, p2, p1, p2, m1, m2, m1, m2, d, o, o, d)


@kernel
def beam_strains(P, xe, ve, rates, eps, epsd):
    """Material strains ε = (Γ₁, Γ₂, κ) of beams into ``eps (nel, 3)``; with ``rates`` also ε̇ into ``epsd``.

    For output (resultants, strain energy); the same midpoint kinematics as :func:`beam_force`.
    """
    for e in range(xe.shape[0]):
        c, s, g1, g2, kap = _midpoint(P, xe, e)
        eps[e, 0] = g1 - P[e, _G01]
        eps[e, 1] = g2 - P[e, _G02]
        eps[e, 2] = kap
        if rates:
            u1, u2, om, kd = _midpoint_rates(P, ve, e, c, s)
            epsd[e, 0] = u1 + om * g2
            epsd[e, 1] = u2 - om * g1
            epsd[e, 2] = kd


class ReissnerBeam(PairElement):
    """Two-node geometrically exact planar beam element (one-point integration).

    The element connects the nodes of bodies ``a`` and ``b`` (normally
    :class:`BeamNode` objects made by :func:`add_beam`; any body works, its
    node then is the beam node). Its reference configuration (length L,
    strains Γ₀ and κ₀) is taken from the two nodes' initial coordinates and is
    stress free. See the module docstring for the formulation.

    Parameters
    ----------
    name : str
    a, b : Body or str
    section : Section
    mass : {"consistent", "lumped"}
        Consistent mass (linear shape functions) or row-sum lumped.

    Notes
    -----
    Kernels: :func:`beam_mass`, :func:`beam_force`. Packed parameters
    ``P (nel, 13)`` = (L, 1/L, Γ₀ (2), κ₀, EA, GA, EI, η, ρA, ρI, m_diag, m_off);
    the dict also holds ``L``, ``invL``, ``gamma0``, ``kappa0``, ``D`` = (EA, GA, EI),
    ``eta``, ``damped`` for output. Lagrange multipliers: none. Batches are split
    by damping (zero or not), so undamped beams need no damping matrix.
    """
    glyph = "beam"  # how pictures draw it (femb.io.frames)

    has_mass = True
    constant_mass = True
    has_force = True
    force_depends_on_qd = True
    work = "potential"
    kernels = {"mass": beam_mass, "force": beam_force, "energy": beam_energy}

    def __init__(self, name, a, b, section, mass="consistent"):
        super().__init__(name, a, b)
        if not isinstance(section, Section):
            raise ModelError(f"ReissnerBeam '{name}': section must be a Section, got {section!r}")
        if mass not in ("consistent", "lumped"):
            raise ModelError(f"ReissnerBeam '{name}': mass must be 'consistent' or 'lumped', got {mass!r}")
        self.section = section
        self.mass_type = mass

    def group_key(self):
        return ("ReissnerBeam", self.section.damping != 0.0)

    @classmethod
    def traits(cls, elements):
        tr = super().traits(elements)
        tr["force_depends_on_qd"] = any(e.section.damping != 0.0 for e in elements)
        return tr

    def validate(self):
        qa, qb = self.a.node.q0, self.b.node.q0
        dx = qb[:2] - qa[:2]
        L = float(np.hypot(dx[0], dx[1]))
        if not L > 0.0:
            raise ModelError(f"ReissnerBeam '{self.name}': its nodes '{self.a.node.name}' and "
                             f"'{self.b.node.name}' coincide (zero length)")
        th = 0.5 * (qa[2] + qb[2])
        c, s = math.cos(th), math.sin(th)
        d = dx / L
        self.L0 = L
        self.gamma0 = np.array([c * d[0] + s * d[1], c * d[1] - s * d[0]])
        self.kappa0 = float(qb[2] - qa[2]) / L
        if self.gamma0[0] <= 0.5:
            raise ModelError(
                f"ReissnerBeam '{self.name}': the section angles ({qa[2]:.4g}, {qb[2]:.4g} rad) are far "
                f"from the direction of the element ({math.atan2(dx[1], dx[0]):.4g} rad); give the nodes "
                "the tangent angle of the beam axis")

    @classmethod
    def pack(cls, elements):
        n = len(elements)
        sec = [e.section for e in elements]
        lumped = np.array([e.mass_type == "lumped" for e in elements], dtype=bool)
        P = np.empty((n, 13))
        P[:, _L] = [e.L0 for e in elements]
        P[:, _INVL] = 1.0 / P[:, _L]
        P[:, _G01:_G02 + 1] = np.array([e.gamma0 for e in elements], dtype=float).reshape(n, 2)
        P[:, _K0] = [e.kappa0 for e in elements]
        P[:, _EA] = [s.EA for s in sec]
        P[:, _GA] = [s.GA for s in sec]
        P[:, _EI] = [s.EI for s in sec]
        P[:, _ETA] = [s.damping for s in sec]
        P[:, _RHOA] = [s.rhoA for s in sec]
        P[:, _RHOI] = [s.rhoI for s in sec]
        P[:, _MDIAG] = np.where(lumped, 0.5, 1.0 / 3.0)
        P[:, _MOFF] = np.where(lumped, 0.0, 1.0 / 6.0)
        return {"P": P, "L": P[:, _L].copy(), "invL": P[:, _INVL].copy(),
                "gamma0": P[:, _G01:_G02 + 1].copy(), "kappa0": P[:, _K0].copy(),
                "D": P[:, _EA:_EI + 1].copy(), "eta": P[:, _ETA].copy(),
                "damped": bool(np.any(P[:, _ETA] != 0.0)),
                "rhoA": P[:, _RHOA].copy(), "rhoI": P[:, _RHOI].copy()}

    # ------------------------------------------------------------------ strains (output)
    @classmethod
    def _strains(cls, p, qe, qde=None):
        qe = np.ascontiguousarray(qe, dtype=np.float64)
        eps = np.zeros((qe.shape[0], 3))
        epsd = np.zeros((qe.shape[0], 3))
        rates = qde is not None
        ve = np.ascontiguousarray(qde, dtype=np.float64) if rates else qe
        beam_strains(p["P"], qe, ve, rates, eps, epsd)
        return eps, (epsd if rates else None)

    @classmethod
    def strains(cls, p, qe):
        """Material strains (Γ₁, Γ₂, κ) at the integration point, shape (nel, 3)."""
        return cls._strains(p, qe)[0]

    @classmethod
    def strain_rates(cls, p, qe, qde):
        """(Γ̇₁, Γ̇₂, κ̇), shape (nel, 3): Γ̇ = Rᵀẋ' − θ̇_m J Rᵀx'."""
        return cls._strains(p, qe, qde)[1]

    @classmethod
    def resultants(cls, p, qe, qde=None):
        """Stress resultants (N, V, M) in the section frame, shape (nel, 3).

        Elastic part D ε plus, for damped sections and given velocities, η D ε̇.
        """
        damped = qde is not None and p["damped"]
        eps, epsd = cls._strains(p, qe, qde if damped else None)
        sig = eps * p["D"]
        if damped:
            sig += (p["eta"][:, None] * p["D"]) * epsd
        return sig

    @classmethod
    def strain_energy(cls, p, qe):
        """Elastic energy ½ L (EA Γ₁² + GA Γ₂² + EI κ²) per element, shape (nel,)."""
        eps = cls.strains(p, qe)
        return 0.5 * p["L"] * np.einsum("ek,ek->e", eps * p["D"], eps)

    # ------------------------------------------------------------------ output
    @classmethod
    def geometry(cls, p, t, qe, qde, lame, names):
        """Line cells through the two nodes of every element, with section forces.

        Cell data (one value per element, at its integration point):
        ``axial_force`` N, ``shear_force`` V (N), ``bending_moment`` M (N m),
        in the section frame; elastic plus viscous parts.
        """
        n = qe.shape[0]
        pts = np.zeros((2 * n, 3))
        pts[0::2, :2] = qe[:, 0:2]
        pts[1::2, :2] = qe[:, 3:5]
        sig = cls.resultants(p, qe, qde)
        conn = np.arange(2 * n).reshape(n, 2)
        return [GeometryBlock(cls.__name__, pts, [("line", conn)],
                              cell_data={"axial_force": [sig[:, 0]], "shear_force": [sig[:, 1]],
                                         "bending_moment": [sig[:, 2]]})]


# ---------------------------------------------------------------------------
# clamp (rigid connection)
# ---------------------------------------------------------------------------
@kernel
def clamp_constraint(P, t, tf, xe, le, jac, Phi, B, H):
    """Φ = [r_a + d_a − r_b − d_b; θ_b − θ_a − θ₀], d = R(θ) s; P = (s_a, s_b, θ₀).

    Φ_q = [[I, J d_a, −I, −J d_b], [0, −1, 0, 1]]; ∂(Φ_qᵀλ)/∂q has only the
    [θ_a, θ_a] = −λ·d_a and [θ_b, θ_b] = λ·d_b entries (λ = the first two multipliers).
    """
    for e in range(xe.shape[0]):
        ca, sa = math.cos(xe[e, 2]), math.sin(xe[e, 2])
        cb, sb = math.cos(xe[e, 5]), math.sin(xe[e, 5])
        dax = ca * P[e, 0] - sa * P[e, 1]
        day = sa * P[e, 0] + ca * P[e, 1]
        dbx = cb * P[e, 2] - sb * P[e, 3]
        dby = sb * P[e, 2] + cb * P[e, 3]
        Phi[e, 0] = xe[e, 0] - xe[e, 3] + (dax - dbx)
        Phi[e, 1] = xe[e, 1] - xe[e, 4] + (day - dby)
        Phi[e, 2] = xe[e, 5] - xe[e, 2] - P[e, 4]
        B[e, 0, 0] = 1.0
        B[e, 1, 1] = 1.0
        B[e, 0, 3] = -1.0
        B[e, 1, 4] = -1.0
        B[e, 2, 2] = -1.0
        B[e, 2, 5] = 1.0
        B[e, 0, 2] = -day
        B[e, 1, 2] = dax
        B[e, 0, 5] = dby
        B[e, 1, 5] = -dbx
        if jac:
            H[e, 2, 2] = -(le[e, 0] * dax + le[e, 1] * day)
            H[e, 5, 5] = le[e, 0] * dbx + le[e, 1] * dby


@kernel
def clamp_rates(P, t, tf, xe, ve, Phi_t, gam):
    """Φ_t = 0; γ = (−d_a θ̇_a² + d_b θ̇_b², 0): the hinge's two rows (same P = (s_a, s_b, …)), and 0."""
    hinge_rates(P, t, tf, xe, ve, Phi_t, gam)


class Clamp(PairElement):
    """Rigid connection: point P_a of body a coincides with P_b of body b, no relative rotation.

    Φ = [r_a(P_a) − r_b(P_b); θ_b − θ_a − θ₀] (3 equations; θ₀ the initial
    relative angle). λ = (F_x, F_y, T): (F_x, F_y) is the force the clamp
    exerts on body b at P_b, in inertial components (N), and −F on body a at
    P_a; T is a torque (N m) with the sign flipped: the clamp applies the
    moment −T to body b about P_b and +T to body a about P_a. A cantilever
    bar of mass m and length L clamped at its left end under gravity has
    λ = (0, m g, −m g L/2) (see ``docs/conventions.md``).

    Parameters
    ----------
    name : str
    a, b : Body or str
    at, point_a, point_b : see :class:`~femb.elements.Hinge`.

    Notes
    -----
    Kernels: :func:`clamp_constraint`, :func:`clamp_rates`; ``P = (s_a, s_b, θ₀)``.
    """
    glyph = "fixed"  # how pictures draw it (femb.io.frames)

    n_constraints = 3
    constraint_names = ("x", "y", "moment")
    kernels = {"constraint": clamp_constraint, "rates": clamp_rates}

    def __init__(self, name, a, b, at=None, point_a=None, point_b=None):
        super().__init__(name, a, b)
        self._spec = (at, point_a, point_b)

    def validate(self):
        self.sa, self.sb = self._points(*self._spec)
        if self.a.node.fixed[2] and self.b.node.fixed[2]:
            raise ModelError(f"Clamp '{self.name}': neither '{self.a.name}' nor '{self.b.name}' can "
                             "rotate, so the rotation lock is redundant; use a Hinge")
        self.phi0 = float(self.b.node.q0[2] - self.a.node.q0[2])

    @classmethod
    def pack(cls, elements):
        sa = np.array([e.sa for e in elements], dtype=float).reshape(-1, 2)
        sb = np.array([e.sb for e in elements], dtype=float).reshape(-1, 2)
        phi0 = np.array([e.phi0 for e in elements], dtype=float)
        return {"P": np.ascontiguousarray(np.column_stack((sa, sb, phi0))), "sa": sa, "sb": sb,
                "phi0": phi0}

    @classmethod
    def geometry(cls, p, t, qe, qde, lame, names):
        n = qe.shape[0]
        pts = np.zeros((n, 3))
        pts[:, :2] = qe[:, 0:2] + rot(qe[:, 2], p["sa"])
        F = np.zeros((n, 3))
        F[:, :2] = lame[:, :2]
        return [GeometryBlock(cls.__name__, pts, [("vertex", np.arange(n)[:, None])],
                              point_data={"reaction": F,
                                          "reaction_magnitude": np.linalg.norm(lame[:, :2], axis=1),
                                          "reaction_torque": lame[:, 2].copy()})]


# ---------------------------------------------------------------------------
# meshing helper
# ---------------------------------------------------------------------------
@dataclass
class BeamMesh:
    """What :func:`add_beam` added to a mechanism.

    Attributes
    ----------
    name : str
    nodes : list of Body
        The n + 1 node bodies from start to end (:class:`BeamNode`, or the
        connected body itself for a ``"shared"`` end).
    elements : list of ReissnerBeam
    joints : dict
        ``{"start": element or None, "end": element or None}``.
    section : Section
    arc_length : ndarray, shape (n + 1,)
        Reference arc-length coordinate of the nodes (m).
    """

    name: str
    nodes: list
    elements: list
    joints: dict
    section: Section
    arc_length: np.ndarray = field(repr=False)

    @property
    def node_names(self):
        return [b.node.name for b in self.nodes]

    @property
    def length(self):
        """Reference length (sum of the element lengths)."""
        return float(self.arc_length[-1])

    def coordinates(self, model, q):
        """Node coordinates (x, y, θ) for q of shape (..., nq): shape (..., n + 1, 3)."""
        return np.stack([model.node_coordinates(nm, q) for nm in self.node_names], axis=-2)

    def point_at(self, model, q, s):
        """Centreline point at reference arc length ``s`` (linear interpolation), shape (..., 2)."""
        X = self.coordinates(model, q)
        k = int(np.clip(np.searchsorted(self.arc_length, s, side="right") - 1, 0, len(self.elements) - 1))
        xi = (s - self.arc_length[k]) / (self.arc_length[k + 1] - self.arc_length[k])
        return (1.0 - xi) * X[..., k, :2] + xi * X[..., k + 1, :2]


def _end_spec(mech, spec, what):
    """Parse an end: a point (x, y), a body (or its name), or (body, point)."""
    def body_of(ref):
        if isinstance(ref, Body):
            return ref
        if isinstance(ref, str):
            b = mech[ref]
            if not isinstance(b, Body):
                raise ModelError(f"add_beam: {what} '{ref}' is not a body")
            return b
        return None

    b = body_of(spec)
    if b is not None:
        return b, np.asarray(b.node.q0[:2], dtype=float).copy()
    if isinstance(spec, (tuple, list)) and len(spec) == 2:
        b = body_of(spec[0])
        if b is not None:
            return b, b.global_point(spec[1])
    return None, _point("add_beam", what, spec)


def _node_velocities(owner, velocities, xy, th):
    """(n + 1, 3) initial (vx, vy, ω) of the nodes from ``add_beam``'s ``velocities``."""
    n1 = len(xy)
    if velocities is None:
        return np.zeros((n1, 3))
    if callable(velocities):
        try:
            v = velocities(xy.copy(), th.copy())
        except Exception as e:
            raise ModelError(f"{owner}: velocities(xy, theta) raised {type(e).__name__}: {e}") from e
    else:
        v = velocities
    try:
        V = np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{owner}: velocities must be ({n1}, 3) numbers (vx, vy, ω) per node, got {v!r}") from None
    if V.size == 3 * n1:
        V = V.reshape(n1, 3)
    if V.shape != (n1, 3) or not np.all(np.isfinite(V)):
        raise ModelError(f"{owner}: velocities must be ({n1}, 3) finite numbers (vx, vy, ω) per node, got "
                         f"shape {V.shape}" + ("" if V.shape != (n1, 3) else " with entries that are not finite"))
    return V


def add_beam(mech, name, section, start, end, n_elements, *, sweep=0.0, start_joint=None,
             end_joint=None, mass="consistent", velocities=None):
    """Mesh a straight or circular beam into ``n_elements`` elements and add it to ``mech``.

    Parameters
    ----------
    mech : Mechanism
    name : str
        Prefix of the names: nodes ``{name}.n0`` … ``{name}.n{n}``, elements
        ``{name}.e0`` …, joints ``{name}.start`` and ``{name}.end``.
    section : Section
    start, end : (x, y), Body, str, or (Body or str, point)
        End points: an inertial point; a body (its node position); or a body
        with one of its points (a name or body-frame coordinates).
    n_elements : int ≥ 1
    sweep : float
        Angle (rad) through which the tangent turns from start to end:
        0 for a straight beam, otherwise a circular arc through both points
        (positive: counter-clockwise).
    start_joint, end_joint : {"clamp", "hinge", "shared", None}
        How the end connects to its body (to the ground when the end is a
        plain point): a :class:`Clamp` or a :class:`~femb.elements.Hinge` at
        the end point, or ``"shared"``: the beam's end node *is* the body's
        node (the body's node must lie at the end point; no constraint).
        Default: ``"clamp"`` when the end names a body, None (free) otherwise.
    mass : {"consistent", "lumped"}
    velocities : array_like (n + 1, 3) or callable, optional
        Initial (vx, vy, ω) of the nodes, or a function
        ``f(xy (n+1, 2), theta (n+1,)) -> (n+1, 3)``. Default: at rest.
        Ignored for shared nodes (they move with their body).

    Returns
    -------
    BeamMesh

    Notes
    -----
    Node angles are the tangent angles of the centreline; the elements'
    reference strains are computed from the nodes, so the initial shape is
    stress free. A free end needs no joint; a ground clamp or hinge can also
    be made by fixing the node's coordinates (``BeamNode(fixed=...)``), at the
    price of losing the reaction as a multiplier.
    """
    from femb.system.mechanism import Mechanism
    if not isinstance(name, str) or not name:
        raise ModelError(f"add_beam: name must be a non-empty string, got {name!r}")
    owner = f"add_beam '{name}'"
    if not isinstance(mech, Mechanism):
        raise ModelError(f"{owner}: mech must be a Mechanism, got {mech!r}")
    n = element_count(owner, "n_elements", n_elements)
    if not isinstance(section, Section):
        raise ModelError(f"{owner}: section must be a Section, got {type(section).__name__}")
    if mass not in ("consistent", "lumped"):
        raise ModelError(f"{owner}: mass must be 'consistent' or 'lumped', got {mass!r}")
    check_model_size(owner, n, "planar")
    b0, P0 = _end_spec(mech, start, "start")
    b1, P1 = _end_spec(mech, end, "end")
    chord = P1 - P0
    dist = float(np.hypot(*chord))
    if not dist > 0.0:
        raise ModelError(f"add_beam '{name}': start and end coincide")
    sweep = _check_scalar(owner, "sweep", sweep)
    if not (abs(sweep) < 2.0 * math.pi):
        raise ModelError(f"add_beam '{name}': |sweep| must be below 2π, got {sweep!r}")
    phi = math.atan2(chord[1], chord[0])
    k = np.arange(n + 1) / n
    if sweep == 0.0:
        xy = P0[None, :] + k[:, None] * chord[None, :]
        th = np.full(n + 1, phi)
        arc = k * dist
    else:
        R = dist / (2.0 * math.sin(0.5 * sweep))      # signed radius
        th0 = phi - 0.5 * sweep
        th = th0 + sweep * k
        xy = P0[None, :] + R * np.column_stack((np.sin(th) - math.sin(th0), math.cos(th0) - np.cos(th)))
        xy[-1] = P1
        arc = R * sweep * k
    V = _node_velocities(owner, velocities, xy, th)

    joints_kind = {}
    for which, b, kind in (("start", b0, start_joint), ("end", b1, end_joint)):
        if kind is None and b is not None:
            kind = "clamp"
        if kind not in (None, "clamp", "hinge", "shared"):
            raise ModelError(f"add_beam '{name}': {which}_joint must be 'clamp', 'hinge', 'shared' or None, "
                             f"got {kind!r}")
        if kind == "shared" and b is None:
            raise ModelError(f"add_beam '{name}': a shared {which} needs a body")
        joints_kind[which] = kind

    nodes = []
    for i in range(n + 1):
        shared = ((i == 0 and joints_kind["start"] == "shared") or
                  (i == n and joints_kind["end"] == "shared"))
        if shared:
            b = b0 if i == 0 else b1
            if np.hypot(*(b.node.q0[:2] - xy[i])) > 1e-9 * max(dist, 1.0):
                raise ModelError(f"add_beam '{name}': a shared end must lie at the node of body "
                                 f"'{b.name}' ({b.node.q0[:2].tolist()}), the end is at {xy[i].tolist()}")
            nodes.append(b)
        else:
            nodes.append(mech.add(BeamNode(f"{name}.n{i}", xy[i], th[i], V[i, :2], V[i, 2])))
    elements = [mech.add(ReissnerBeam(f"{name}.e{i}", nodes[i], nodes[i + 1], section, mass))
                for i in range(n)]
    joints = {"start": None, "end": None}
    for which, b, i in (("start", b0, 0), ("end", b1, n)):
        kind = joints_kind[which]
        if kind in ("clamp", "hinge"):
            other = b if b is not None else mech.ground
            cls = Clamp if kind == "clamp" else Hinge
            joints[which] = mech.add(cls(f"{name}.{which}", other, nodes[i], at=tuple(xy[i])))
    return BeamMesh(name, nodes, elements, joints, section, arc)


# ---------------------------------------------------------------------------
# post-processing
# ---------------------------------------------------------------------------
def _beam_groups(model):
    return [g for g in model.groups if issubclass(g.cls, ReissnerBeam)]


def beam_resultants(model, q, qd=None):
    """Section forces of every beam element: dict name -> (N, V, M) at its midpoint.

    Parameters
    ----------
    model : Model
    q : ndarray, shape (nq,)
    qd : ndarray, shape (nq,), optional
        Velocities (adds the viscous part for damped sections).
    """
    qx = model.ext(np.asarray(q, dtype=float))
    qdx = None if qd is None else model.ext_velocity(np.asarray(qd, dtype=float))
    out = {}
    for g in _beam_groups(model):
        sig = g.cls.resultants(g.params, qx[g.xdofs], None if qdx is None else qdx[g.dofs])
        out.update(zip(g.names, sig))
    return out


def beam_strain_energy(model, q):
    """Total elastic energy of all beams at q (J)."""
    qx = model.ext(np.asarray(q, dtype=float))
    return float(sum(g.cls.strain_energy(g.params, qx[g.xdofs]).sum() for g in _beam_groups(model)))
