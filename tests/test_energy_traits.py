"""Energies and momenta from the element contract (femb.results.energy).

* every built-in type's ``"energy"`` kernel is the potential of its force: −dV/ds along
  x ∘ exp(s w) equals f(q, 0)·w (central differences, planar and spatial);
* spatial beams: the strain energy of a statically loaded cantilever equals ½ F δ (linear) and the
  work of the load along the load path (large deflection), and Σ ½ L εᵀCε of the documented
  strains; a free spinning beam keeps its energy balance ≤ 1e-3 at h = 2 ms and its linear and
  angular momentum, which start at the hand-computed values of a rigid rod; a beam falling under
  gravity has V_g = −m gᵀr_c and p(t) = p0 + m g t; structural damping appears as dissipated energy;
* planar beams: the elastic energy is the beams' strain energy; momenta of planar bodies by hand;
* a user's element type with an ``"energy"`` kernel is in ``energy()``; one without is listed in
  ``not_counted`` with a warning naming it;
* the core (femb/) never imports a concrete element class.
"""
import ast
import inspect
import pathlib

import numpy as np
import pytest

import femb
from femb.results import energy as fe
from femb.system import kernels
from femb.system.element import Element
from femb.elements import (Bushing, PointSpringDamper, RigidBody, RotationalSpringDamper, Section,
                           SpatialForce, SpatialRigidBody, SpatialRotationalSpringDamper, SpringDamper, add_beam,
                           beam_strain_energy)
from femb.analysis.static import solve_static
from femb.base.jit import kernel
from femb.elements.spatial_beam import SpatialBeam, SpatialSection, spatial_beam
from femb.elements.spatial_forces import SpatialGravity
from femb.system.kernels import ContractWarning

ROOT = pathlib.Path(__file__).resolve().parents[1]


# ---------------------------------------------------------------- models
def planar_springs_and_beam():
    m = femb.Mechanism("planar_energy")
    a = m.add(RigidBody("a", 2.0, 0.1, position=(0.3, -0.2), angle=0.3, points={"P": (0.1, 0.05)}))
    m.add(SpringDamper("s", "ground", a, 50.0, damping=0.3, length=0.2, point_b="P"))
    m.add(RotationalSpringDamper("r", "ground", a, 4.0, damping=0.1, angle=0.1))
    add_beam(m, "b", Section(EA=1e4, GA=5e3, EI=20.0, rhoA=0.5, rhoI=1e-3), (0.0, 0.5), (1.0, 0.7), 3,
             sweep=0.4)
    return m


def spatial_springs_and_beam():
    m = femb.Mechanism("spatial_energy")
    b = m.add(SpatialRigidBody("b", 1.0, (0.01, 0.02, 0.03), position=(0.4, 0.1, -0.3)))
    c = m.add(SpatialRigidBody("c", 1.0, (0.01, 0.02, 0.03), position=(0.2, 0.3, -0.5)))
    m.add(PointSpringDamper("ps", "ground", b, stiffness=30.0, length=0.3, damping=0.2))
    m.add(Bushing("bu", b, c, stiffness=(100.0, 200.0, 300.0), rotational_stiffness=(5.0, 6.0, 7.0),
                  at=(0.3, 0.2, -0.4)))
    m.add(SpatialRotationalSpringDamper("rs", b, c, stiffness=3.0, at=(0.3, 0.2, -0.4), axis=(0.0, 1.0, 1.0)))
    sec = SpatialSection.rectangle(E=2e8, G=8e7, width=0.02, height=0.01, density=1000.0)
    spatial_beam(m, "arm", sec, lambda s: (0.5 * np.cos(s), 0.5 * np.sin(s), 0.2 * s), 3)
    return m


def _energy_gradient_error(model, seed=0):
    """Largest relative error of −dV/ds against f(q, 0)·w over the batches with an energy kernel."""
    rng = np.random.default_rng(seed)
    q = model.compose(model.q0, 0.05 * rng.standard_normal(model.nq))
    worst, n = 0.0, 0
    for g in model.groups:
        if "energy" not in (g.cls.kernels or {}):
            continue
        n += 1
        w = rng.standard_normal(model.nq)
        wx = np.concatenate((w, np.zeros(model.nfix_v)))

        def V(s):
            qx = model.ext(model.compose(q, s * w))
            return kernels.energy(g, 0.0, qx[g.xdofs]).sum()

        eps = 1e-6
        dV = (V(eps) - V(-eps)) / (2 * eps)
        qx = model.ext(q)
        f0, _, _ = kernels.force(g, 0.0, qx[g.xdofs], np.zeros((g.nel, g.ndv)), jac=False)
        fw = np.einsum("ei,ei->", f0, wx[g.dofs])
        worst = max(worst, abs(dV + fw) / max(abs(fw), 1e-12))
    return worst, n


@pytest.mark.parametrize("build", [planar_springs_and_beam, spatial_springs_and_beam])
def test_energy_kernels_are_the_potentials_of_the_forces(build):
    err, n = _energy_gradient_error(build().compile())
    assert n >= 3
    assert err < 1e-6


def test_planar_elastic_energy_is_the_beam_and_spring_energy():
    model = planar_springs_and_beam().compile()
    r = femb.simulate(model, 0.05, 1e-3, rho_inf=0.9)
    parts = fe.elastic_energy(r, by_element=True)
    beams = sum(v for k, v in parts.items() if k.startswith("b."))
    np.testing.assert_allclose(beams, [beam_strain_energy(model, q) for q in r.q], rtol=1e-12, atol=1e-15)
    assert set(parts) == {"s", "r", "b.e0", "b.e1", "b.e2"}
    np.testing.assert_allclose(r.energy()["elastic"], sum(parts.values()), rtol=1e-12)


# ---------------------------------------------------------------- spatial beam, static
def _cantilever(F):
    m = femb.Mechanism("cantilever")
    sec = SpatialSection.circle(E=2e9, G=8e8, diameter=0.02)
    mesh = spatial_beam(m, "c", sec, [(0, 0, 0), (1, 0, 0)], 8, start="clamp")
    m.add(SpatialForce("tip", mesh.nodes[-1], (0.0, 0.3 * F, F)))
    return m.compile(), mesh, sec


def test_spatial_beam_strain_energy_is_half_the_load_work_when_linear():
    F = 0.05
    model, mesh, sec = _cantilever(F)
    res = solve_static(model)
    V = fe.elastic_energy(res)[-1]
    u = mesh.positions(model, res.q)[-1, -1] - mesh.positions(model, model.q0[None])[0, -1]
    W = 0.5 * np.dot((0.0, 0.3 * F, F), u)
    assert V > 0.0
    assert abs(V - W) < 1e-4 * W
    # Σ ½ L εᵀCε from the documented strains (SpatialBeam.strains, numpy)
    g = [g for g in model.groups if g.cls is SpatialBeam][0]
    eps = SpatialBeam.strains(g.params, model.ext(res.q[-1])[g.xdofs])
    ref = 0.5 * np.sum(g.params["L"] * np.einsum("ei,ij,ej->e", eps, sec.C, eps))
    np.testing.assert_allclose(V, ref, rtol=1e-12)


def test_spatial_beam_strain_energy_is_the_work_of_the_load_at_large_deflection():
    F = 60.0
    model, mesh, _ = _cantilever(F)
    res = solve_static(model, load_factors=np.linspace(0.0, 1.0, 81)[1:])
    tip = mesh.positions(model, res.q)[:, -1] - mesh.positions(model, model.q0[None])[0, -1]
    mu = res.t
    assert np.linalg.norm(tip[-1]) > 0.3                         # a large deflection
    Fv = np.array((0.0, 0.3 * F, F))
    # W = ∫ μ F·du (trapezoid over the load path from the unloaded state)
    mus = np.concatenate(([0.0], mu))
    us = np.concatenate((np.zeros((1, 3)), tip))
    W = np.sum(0.5 * (mus[1:] + mus[:-1]) * ((us[1:] - us[:-1]) @ Fv))
    V = fe.elastic_energy(res)[-1]
    assert abs(V - W) < 1e-3 * W


# ---------------------------------------------------------------- spatial beam, dynamics
RHO_J = (0.02, 0.01, 0.01)


def _free_beam(omega, v0=(0.0, 0.0, 0.0), bend=0.0, gravity=None, damping=0.0, n=8):
    """A free bar from (0, 0, 0) to (1, 0, 0), ρA = 1, soft (first bending frequency ≈ 22 rad/s),
    started in a rigid motion (v0, ω) plus a bending velocity bend·cos(πx) along z."""
    m = femb.Mechanism("free_beam")
    sec = SpatialSection.from_properties(EA=100.0, GA2=100.0, GA3=100.0, GJ=1.0, EI2=1.0, EI3=1.0, rhoA=1.0,
                                         rhoJ=RHO_J, damping=damping)
    mesh = spatial_beam(m, "bar", sec, [(0, 0, 0), (1, 0, 0)], n)
    omega = np.asarray(omega, float)
    for nd in mesh.nodes:
        x = nd.node.q0[:3]
        nd.node.qd0[:3] = np.asarray(v0) + np.cross(omega, x) + (0.0, 0.0, bend * np.cos(np.pi * x[0]))
        w = omega + (0.0, bend * np.pi * np.sin(np.pi * x[0]), 0.0)       # −∂v_z/∂x about y
        nd.node.qd0[3:] = nd.node.rotation0.T @ w
    if gravity is not None:
        m.add(SpatialGravity(gravity))
    return m, mesh, sec


def test_spatial_beam_kinetic_energy_and_momenta_by_hand():
    """A rigidly moving bar at t0: T, p and H of a rod (the consistent mass is exact for the linear
    velocity field of a rigid motion; rotary inertia ρJ per unit length, section axes = space axes)."""
    omega = np.array([0.0, 3.0, 12.0])
    v0 = np.array([0.1, 0.2, -0.1])
    mech, mesh, sec = _free_beam(omega, v0)
    # the given state as it is (the consistent start of flexible models adds the quasi-static
    # stretch of the spinning bar, docs/stepsize.md §2): the by-hand values are of the rigid motion
    r = femb.simulate(mech.compile(), 0.004, 2e-3, initialize=False)
    m, L = 1.0, 1.0
    c = np.array([L / 2, 0.0, 0.0])
    vc = v0 + np.cross(omega, c)
    I_c = m * L ** 2 / 12 * np.diag([0.0, 1.0, 1.0]) + L * np.diag(RHO_J)
    np.testing.assert_allclose(r.energy()["kinetic"][0], 0.5 * m * vc @ vc + 0.5 * omega @ I_c @ omega, rtol=1e-12)
    p, H = r.momentum()
    np.testing.assert_allclose(p[0], m * vc, rtol=1e-12)
    np.testing.assert_allclose(H[0], np.cross(c, m * vc) + I_c @ omega, rtol=1e-12)
    o = np.array([0.3, -0.2, 0.5])                    # about another point: H_o = H − o × p
    np.testing.assert_allclose(r.momentum(about=o)[1], H - np.cross(o, p), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(r.momentum(of="bar")[1], H, rtol=1e-12)
    np.testing.assert_allclose(r.momentum(of=["bar.e0", "bar.e1"])[0][0], m / 4 * (v0 + np.cross(omega, c / 4)),
                               rtol=1e-12)


@pytest.fixture(scope="module")
def spinning_bar():
    mech, _, _ = _free_beam((0.0, 0.5, 2.0), v0=(0.1, 0.0, 0.0), bend=0.5)
    return femb.simulate(mech.compile(), 2.0, 2e-3, rho_inf=0.9)


def test_free_spinning_spatial_beam_energy_balance(spinning_bar):
    """Spinning and bending (issue: the balance of a free spinning spatial beam ≤ 1e-3 at h = 2 ms)."""
    e = spinning_bar.energy()
    assert e["not_counted"] == ()
    assert np.ptp(e["elastic"]) > 5e-3                        # energy flows between T and V
    assert spinning_bar.energy_balance() <= 1e-3


def test_free_spinning_spatial_beam_conserves_momentum(spinning_bar):
    p, H = spinning_bar.momentum()
    assert np.abs(p - p[0]).max() <= 1e-12 * np.linalg.norm(p[0])   # linear in v: exact
    assert np.abs(H - H[0]).max() <= 1e-3 * np.linalg.norm(H[0])     # quadratic: to the scheme's accuracy


@pytest.mark.parametrize("n", [4, 8])
@pytest.mark.parametrize("bend", [0.0, 0.5])
@pytest.mark.parametrize("omega", [(0.0, 3.0, 12.0), (4.0, 3.0, 8.0), (6.0, -6.0, 0.0)])
def test_free_spinning_spatial_beam_balance_on_the_defaults(omega, bend, n):
    """The issue's probe on the options a user gets (ρ∞ = 0.7, index 3): spin about axes across the
    bar and with a torsional part, with and without bending, h = 2 ms. The spin stretches the bar
    and rings its axial mode (T and V_el exchange ≈ 2 J of the ≈ 26 J), so the balance tests the
    elastic and kinetic measures together; a rigid body of the bar's inertia in the same spin keeps
    T exactly (test below): the remaining error is the scheme's, O(h²)."""
    mech, _, _ = _free_beam(omega, bend=bend, n=n)
    r = femb.simulate(mech.compile(), 2.0, 2e-3)
    e = r.energy()
    assert e["not_counted"] == ()
    assert np.ptp(e["elastic"]) > 1e-2 * e["kinetic"].max()              # energy changes form
    ratio = r.energy_balance()
    assert ratio <= 1e-3
    E = e["total"]
    assert ratio == pytest.approx(np.abs(E - E[0]).max() / e["kinetic"].max(), rel=1e-12)


def test_free_spinning_spatial_beam_balance_is_second_order():
    mech, _, _ = _free_beam((0.0, 3.0, 12.0), bend=0.5, n=4)
    model = mech.compile()
    b = [femb.simulate(model, 1.0, h).energy_balance() for h in (2e-3, 1e-3)]
    assert 3.0 < b[0] / b[1] < 5.0


def test_balance_of_a_steady_tumbling_body_is_its_energy_error_not_one():
    """A free asymmetric body keeps T = const exactly; the scheme's drift of T is O(h²) and the
    balance is relative to T (a scale of ranges alone would read ≈ 1 here at every h)."""
    J = np.array([0.1, 0.2, 0.3])
    out = []
    for h in (2e-3, 1e-3):
        mech = femb.Mechanism("tumbling")
        mech.add(SpatialRigidBody("b", 2.0, J, velocity=(1.0, 0.5, -0.3), omega=(0.1, 5.0, 0.2)))
        r = femb.simulate(mech.compile(), 2.0, h)
        T = r.energy()["kinetic"]
        assert r.energy_balance() == pytest.approx(np.abs(T - T[0]).max() / T.max(), rel=1e-12)
        out.append(r.energy_balance())
    assert out[0] < 1e-4 and 3.0 < out[0] / out[1] < 5.0


def test_spatial_beam_falling_under_gravity():
    g = np.array([0.0, 0.0, -9.81])
    mech, mesh, _ = _free_beam((0.0, 0.0, 2.0), bend=0.5, gravity=g)
    model = mech.compile()
    r = femb.simulate(model, 0.5, 2e-3, rho_inf=0.9)
    e = r.energy()
    m = 1.0
    x = mesh.positions(model, r.q)                    # (nt, n + 1, 3), equal elements
    centroid = 0.5 * (x[:, 1:] + x[:, :-1]).mean(axis=1)
    np.testing.assert_allclose(e["gravitational"], -m * centroid @ g, rtol=1e-10, atol=1e-12)
    assert np.ptp(e["gravitational"]) > 1.0
    assert r.energy_balance() <= 1e-3
    p, _ = r.momentum()
    np.testing.assert_allclose(p, p[0] + m * np.outer(r.t, g), atol=1e-9)


def test_structural_damping_of_a_spatial_beam_is_dissipated_energy():
    mech, mesh, _ = _free_beam((0.0, 0.5, 2.0), bend=0.5, damping=5e-3)
    r = femb.simulate(mech.compile(), 2.0, 2e-3, rho_inf=0.9)
    e = r.energy()
    assert e["dissipated"][-1] > 0.2 * np.ptp(e["elastic"])
    assert np.all(np.diff(e["dissipated"]) >= -1e-15)
    assert r.energy_balance() <= 1e-3


# ---------------------------------------------------------------- momenta of bodies
def test_free_flying_spinning_body_conserves_momentum():
    """Torque-free asymmetric body (the tennis-racket axis): p and H constant, H by hand at t0."""
    J = np.array([0.1, 0.2, 0.3])
    mech = femb.Mechanism("free_body")
    mech.add(SpatialRigidBody("b", 2.0, J, position=(0.5, -0.2, 1.0), velocity=(1.0, 0.5, -0.3),
                              omega=(0.1, 5.0, 0.2)))
    r = femb.simulate(mech.compile(), 2.0, 1e-3, rho_inf=0.9)
    p, H = r.momentum()
    np.testing.assert_allclose(p[0], 2.0 * np.array([1.0, 0.5, -0.3]), rtol=1e-12)
    Hb = J * np.array([0.1, 5.0, 0.2])                  # body axes = space axes at t0
    np.testing.assert_allclose(H[0], np.cross((0.5, -0.2, 1.0), p[0]) + Hb, rtol=1e-12)
    assert np.abs(p - p[0]).max() <= 1e-12 * np.linalg.norm(p[0])
    assert np.abs(H - H[0]).max() <= 1e-6 * np.linalg.norm(H[0])
    p1, H1 = r.momentum(of="b")
    np.testing.assert_allclose(H1, H)


def test_momentum_arguments_that_name_nothing_are_errors():
    # before: about="x" a raw ValueError, of=3 a raw TypeError, of=[] zero momenta without a word
    mech = femb.Mechanism("one")
    mech.add(SpatialRigidBody("b", 1.0, (0.1, 0.2, 0.3), velocity=(1.0, 0.0, 0.0)))
    r = femb.simulate(mech.compile(), 0.01, 1e-3)
    with pytest.raises(femb.ModelError, match="about must be a finite point of 3 coordinates, got 'x'"):
        r.momentum(about="x")
    with pytest.raises(femb.ModelError, match="of must be a name or a sequence of names.*got 3"):
        r.momentum(of=3)
    for of in ([], "", ["b", ""]):
        with pytest.raises(femb.ModelError, match="of names nothing"):
            r.momentum(of=of)
    np.testing.assert_allclose(r.momentum(of=("b",))[0], r.momentum()[0])


def test_planar_momentum_by_hand_and_by_name():
    mech = femb.Mechanism("planar_free")
    mech.add(RigidBody("a", 2.0, 0.3, position=(1.0, 2.0), velocity=(0.5, -1.0), omega=3.0))
    mech.add(RigidBody("b", 1.0, 0.1, position=(-1.0, 0.0), velocity=(0.0, 2.0), omega=-1.0))
    r = femb.simulate(mech.compile(), 0.1, 1e-3)
    p, H = r.momentum()
    assert p.shape == (r.t.size, 2) and H.shape == (r.t.size,)
    np.testing.assert_allclose(p[0], (1.0, 0.0), atol=1e-14)
    Ha = 0.3 * 3.0 + (1.0 * (2.0 * -1.0) - 2.0 * (2.0 * 0.5))
    Hb = 0.1 * -1.0 + (-1.0 * 2.0 - 0.0)
    np.testing.assert_allclose(H[0], Ha + Hb, rtol=1e-12)
    np.testing.assert_allclose(r.momentum(of="a")[1][0], Ha, rtol=1e-12)
    np.testing.assert_allclose(r.momentum(about=(1.0, 2.0), of=["a"])[1][0], 0.9, rtol=1e-12)
    np.testing.assert_allclose(H, H[0], rtol=1e-12)
    with pytest.raises(femb.ModelError, match="'c' names no element"):
        r.momentum(of="c")
    with pytest.raises(femb.ModelError, match="about"):
        r.momentum(about=(1.0, 2.0, 3.0, 4.0))


def test_planar_beam_momentum_of_a_meshed_beam():
    mech = femb.Mechanism("pb")
    sec = Section(EA=1e4, GA=5e3, EI=20.0, rhoA=0.5, rhoI=1e-3)
    # rigid rotation ω = 0.5 about the origin: v = (−ω y, ω x), θ̇ = ω
    add_beam(mech, "b", sec, (0.0, 0.0), (2.0, 0.0), 4, velocities=[(0.0, 0.25 * k, 0.5) for k in range(5)])
    # the given rigid state as it is (the flexible start would add the quasi-static stretch)
    r = femb.simulate(mech.compile(), 0.2, 1e-3, initialize=False)
    p, H = r.momentum(of="b")
    m = 0.5 * 2.0
    np.testing.assert_allclose(p[0], (0.0, m * 1.0 * 0.5), rtol=1e-12, atol=1e-14)
    # ∫ ρA x² dx ω + ρI L ω (consistent mass exact for the linear field)
    np.testing.assert_allclose(H[0], (0.5 * 8.0 / 3.0 + 1e-3 * 2.0) * 0.5, rtol=1e-12)
    assert np.abs(H - H[0]).max() <= 1e-6 * abs(H[0])          # to the scheme's accuracy


# ---------------------------------------------------------------- user types
@kernel
def _anchor_force(P, t, tf, xe, ve, jac, fe, fq, fv):
    for e in range(xe.shape[0]):
        for i in range(3):
            fe[e, i] = -P[e, 0] * xe[e, i]
            if jac:
                fq[e, i, i] = -P[e, 0]


@kernel
def _anchor_energy(P, t, tf, xe, Ve):
    for e in range(xe.shape[0]):
        Ve[e] = 0.5 * P[e, 0] * (xe[e, 0] ** 2 + xe[e, 1] ** 2 + xe[e, 2] ** 2)


class Anchor(Element):
    """A user's spring from a spatial body's node to the origin, V = ½ k |r|²."""

    spatial = True
    has_force = True
    work = "potential"
    kernels = {"force": _anchor_force, "energy": _anchor_energy}

    def __init__(self, name, body, k):
        super().__init__(name)
        self.body, self.k = body, k

    def resolve(self, lookup):
        self.body = lookup(self.body, "body")

    def nodes(self):
        return [self.body.node]

    @classmethod
    def pack(cls, elements):
        return {"P": np.array([[e.k] for e in elements])}


class SilentAnchor(Anchor):
    """The same force without a declared potential."""

    work = None
    kernels = {"force": _anchor_force}


def _anchored(cls):
    mech = femb.Mechanism("anchored")
    b = mech.add(SpatialRigidBody("b", 1.0, (0.1, 0.1, 0.1), position=(0.3, 0.0, 0.0), velocity=(0.0, 1.0, 0.0)))
    mech.add(cls("anchor", b, 20.0))
    return femb.simulate(mech.compile(), 1.0, 1e-3, rho_inf=0.95)


def test_a_users_type_with_an_energy_kernel_is_counted():
    r = _anchored(Anchor)
    e = r.energy()
    x = r.series("b.x")[0] ** 2 + r.series("b.y")[0] ** 2 + r.series("b.z")[0] ** 2
    np.testing.assert_allclose(e["elastic"], 10.0 * x, rtol=1e-12)
    assert e["not_counted"] == ()
    assert r.energy_balance() < 1e-3


def test_a_users_type_without_an_energy_is_reported_not_counted():
    r = _anchored(SilentAnchor)
    with pytest.warns(ContractWarning, match="SilentAnchor"):
        e = r.energy()
    assert e["not_counted"] == ("SilentAnchor",)
    assert np.all(e["elastic"] == 0.0)


def test_an_unknown_work_declaration_is_a_named_error():
    class Misdeclared(SilentAnchor):
        work = "loads"

    r = _anchored(Misdeclared)
    with pytest.raises(femb.ModelError, match="Misdeclared: work = 'loads'"):
        r.energy()


# ---------------------------------------------------------------- no class switches in the core
def _element_classes():
    import femb.elements as E
    out = set()
    for mod in list(vars(E).values()) + [E]:
        if inspect.ismodule(mod) and mod.__name__.startswith("femb.elements"):
            for name, obj in vars(mod).items():
                if inspect.isclass(obj) and obj.__module__.startswith("femb.elements"):
                    out.add(name)
    return out


def test_the_core_never_names_an_element_class():
    """femb/ (not femb/elements) imports no class of the element library; the one exception is the
    ground every Mechanism starts with (femb/system/mechanism.py)."""
    classes = _element_classes()
    assert {"SpatialBeam", "RigidBody", "Gravity", "SpatialPairElement", "Body"} <= classes
    bad = []
    for path in sorted((ROOT / "femb").rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("femb.elements"):
                for a in node.names:
                    if a.name in classes and not (path.relative_to(ROOT).as_posix() == "femb/system/mechanism.py"
                                                  and a.name == "Ground"):
                        bad.append(f"{path.relative_to(ROOT)}:{node.lineno} {a.name}")
    assert not bad, bad


def test_the_bead_attractor_example_declares_its_potential():
    """benchmarks/scenes/planar/bead_attractor.py's PointAttractor (a type outside femb.elements): U = −μ/|x − P|."""
    from femb.benchmarks.scenes.planar import bead_attractor
    model = bead_attractor.build().compile()
    r = femb.simulate(model, 1.0, 1e-3, rho_inf=0.95)
    e = r.energy()
    d = np.hypot(r.series("bar1.x")[0] - 1.05, r.series("bar1.y")[0])
    np.testing.assert_allclose(e["elastic"], -1.0 / d, rtol=1e-12)
    assert e["not_counted"] == () and r.energy_balance() < 1e-3


def test_dissipation_of_a_stiff_damped_rod_follows_the_scheme():
    """A slider-crank whose rod has E × 10⁴ and material damping η = 1e-3 s, h = 1 ms (η ω² h ≫ 1):
    kinetic energy and the drive's work equal the undamped run's to 1e-4, yet the damping power of
    the stored velocities (their O(h²) strain rate) summed to 0.57 J and the balance read 0.124. The
    dissipated energy of damped beams is now their work deficit: measured balance 1.5e-4 (the
    undamped run's 1.5e-4), dissipated −8.2e-4 J (the scheme's own energy error in the rod), and
    the same figures fall with h (at h = 0.25 ms: balance 1.9e-5, dissipated −3.4e-6 J)."""
    from femb.benchmarks.accuracy.flexible_start import slider_crank

    runs = [femb.simulate(slider_crank(stiffness=1e4, damping=d).compile(), 0.1, 1e-3) for d in (0.0, 1e-3)]
    e0, e1 = (r.energy() for r in runs)
    np.testing.assert_allclose(e1["kinetic"], e0["kinetic"], rtol=1e-4, atol=1e-4 * e0["kinetic"].max())
    assert runs[1].energy_balance() < 2.0 * runs[0].energy_balance() + 1e-4
    assert abs(e1["dissipated"][-1]) < 1e-3 * e1["kinetic"].max()
