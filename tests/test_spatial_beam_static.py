"""Static equilibrium of spatial beam models (femb.analysis.static.solve_static on rotation nodes).

References: the exact circle of pure bending (Simo & Vu-Quoc 1986, Part II, roll-up);
the 45° bend of Bathe & Bolourchi (1979) with the tip values of docs/beams.md, "Validation (spatial)" (byuflowlab/GXBeam.jl:test/examples/curved.jl, 16 elements, J = 1/6, k = 1; Simo &
Vu-Quoc 1986 tip positions at F = 300, 450, 600); Timoshenko's cantilever deflection
PL³/(3EI) + PL/(kGA).
"""
import math

import numpy as np
import pytest

from femb import Mechanism
from femb.analysis.static import solve_static
from femb.elements.spatial_beam import SpatialSection, spatial_beam
from femb.elements.spatial_forces import SpatialForce, SpatialTorque


@pytest.mark.parametrize("n", [3, 4, 7, 10])
def test_rollup_tip_on_the_exact_circle(n):
    """End moment 2πEI/L rolls a cantilever into a full circle; the tip is on the exact arc at every level."""
    L, EI = 10.0, 100.0
    m = Mechanism("rollup")
    sec = SpatialSection.from_properties(1e4, 1e4, 1e4, 1e2, EI, EI, rhoA=1.0, rhoJ=(1e-3, 1e-3, 1e-3))
    b = spatial_beam(m, "b", sec, [(0, 0, 0), (L, 0, 0)], n, start="clamp")
    Mz = 2.0 * math.pi * EI / L
    m.add(SpatialTorque("M", b.nodes[-1], (0.0, 0.0, Mz)))
    model = m.compile()
    res = solve_static(model, load_steps=max(4, 2 * n))
    assert res.t[-1] == 1.0
    for k, mu in enumerate(res.t):
        if mu == 0.0:
            continue
        kap = mu * Mz / EI
        X = b.positions(model, res.q[k])
        for j, s in enumerate(b.arc_length):                 # every node on the circle
            exact = np.array([math.sin(kap * s) / kap, (1.0 - math.cos(kap * s)) / kap, 0.0])
            assert np.abs(X[j] - exact).max() <= 1e-9 * L


def _bend(n, loads):
    E = 1e7
    G = E / 2.0                                                     # ν = 0
    sec = SpatialSection.from_properties(E, G, G, G / 6.0, E / 12.0, E / 12.0, rhoA=1.0,
                                         rhoJ=(1 / 6, 1 / 12, 1 / 12))     # A = 1, I = 1/12, J = 1/6, k = 1
    R = 100.0

    def path(s):
        a = s * math.pi / 4.0
        return np.array([R - R * math.cos(a), R * math.sin(a), 0.0])

    def frames(s):
        a = s * math.pi / 4.0
        return np.column_stack(((math.sin(a), math.cos(a), 0.0), (-math.cos(a), math.sin(a), 0.0), (0.0, 0.0, 1.0)))

    m = Mechanism("bend45")
    b = spatial_beam(m, "b", sec, path, n, frames=frames, start="clamp")
    m.add(SpatialForce("F", b.nodes[-1], (0.0, 0.0, 600.0)))
    model = m.compile()
    res = solve_static(model, load_factors=loads)
    return {round(600 * mu): b.positions(model, q)[-1] for mu, q in zip(res.t, res.q)}


def test_45_degree_bend_against_gxbeam():
    tips = _bend(16, [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.75, 0.9, 1.0])
    u = tips[600] - np.array([100 - 100 / math.sqrt(2), 100 / math.sqrt(2), 0.0])
    ref = np.array([-13.577, -23.545, 53.458])
    assert np.linalg.norm(u - ref) <= 1e-3 * np.linalg.norm(ref)          # measured 4.6e-4


def test_45_degree_bend_against_simo_vu_quoc():
    tips = _bend(8, [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.75, 0.9, 1.0])
    for F, ref in ((300, (22.33, 58.84, 40.08)), (450, (18.62, 52.32, 48.39)), (600, (15.79, 47.23, 53.37))):
        ref = np.array(ref)
        assert np.linalg.norm(tips[F] - ref) <= 2e-3 * np.linalg.norm(ref)   # 4 published digits


@pytest.mark.parametrize("slenderness", [10.0, 100.0, 1e3, 1e4])
def test_no_shear_locking(slenderness):
    """Cantilever tip deflection with 8 elements: within 0.5 % of Timoshenko at every slenderness.

    The constant-strain element's error is −1/(4N²) of the bending part (−0.39 % at N = 8),
    independent of the slenderness (no locking).
    """
    E, nu, L = 2.1e11, 0.3, 1.0
    G = E / (2 * (1 + nu))
    h = L / slenderness
    sec = SpatialSection.rectangle(E, G, h, h, 7850.0)
    EI, kGA = sec.C[4, 4], sec.C[2, 2]
    m = Mechanism("cantilever")
    b = spatial_beam(m, "b", sec, [(0, 0, 0), (L, 0, 0)], 8, start="clamp")
    P = 1e-6 * L * 3.0 * EI / L ** 3                                 # tip deflection 1e-6 L: linear range
    m.add(SpatialForce("F", b.nodes[-1], (0.0, 0.0, -P)))
    model = m.compile()
    res = solve_static(model)
    w = -b.positions(model, res.q[-1])[-1][2]
    exact = P * L ** 3 / (3 * EI) + P * L / kGA
    assert abs(w / exact - 1.0) < 5e-3
    bending = P * L ** 3 / (3 * EI) / exact
    assert abs(w / exact - 1.0 + bending / (4 * 64)) < 1e-5


@pytest.mark.parametrize("attach", ["shared", "welded"])
def test_cantilever_carrying_a_rigid_body_under_gravity(attach):
    """A rigid body at the tip (its own node as the beam end, or welded with its centre of mass
    e beyond the tip) and the beam's own weight: tip deflection of linear Timoshenko theory,
    w = W L³/3EI + W L/kGA + W e L²/2EI + q L⁴/8EI + q L²/2kGA (W = m g, q = ρA g)."""
    from femb.elements.spatial_bodies import SpatialRigidBody
    from femb.elements.spatial_forces import SpatialGravity
    E, G, L, g = 2.1e11, 8.1e10, 1.0, 9.81
    sec = SpatialSection.rectangle(E, G, 0.05, 0.05, 7850.0)
    EI, kGA, q = sec.C[4, 4], sec.C[2, 2], sec.rhoA * g
    mass, e = 50.0, (0.0 if attach == "shared" else 0.2)
    m = Mechanism("tipmass")
    body = m.add(SpatialRigidBody("tip", mass, (1.0, 1.0, 1.0), position=(L + e, 0.0, 0.0)))
    end = (body, "shared") if attach == "shared" else body
    b = spatial_beam(m, "b", sec, [(0, 0, 0), (L, 0, 0)], 32, start="clamp", end=end)
    m.add(SpatialGravity((0.0, 0.0, -g)))
    model = m.compile()
    res = solve_static(model)
    w = -b.positions(model, res.q[-1])[-1][2]
    W = mass * g
    exact = (W * L ** 3 / (3 * EI) + W * L / kGA + W * e * L ** 2 / (2 * EI)
             + q * L ** 4 / (8 * EI) + q * L ** 2 / (2 * kGA))
    assert abs(w / exact - 1.0) < 1e-3


def test_large_deflection_against_the_elastica():
    """Cantilever under a dead tip load P L²/EI = 3 (EA = GA = 1e7 EI/L²), in the x–y plane:
    tip (x, y, θ) against the elastica (0.745580, −0.603253, −0.986017) (docs/beams.md, Validation 3;
    Bisshopp & Drucker 1945), errors O(1/n²)."""
    from femb.base import rotations as rt
    L, EI = 1.0, 1.0
    ref = np.array([0.745580, -0.603253, -0.986017])
    errs = []
    for n in (8, 16, 32):
        sec = SpatialSection.from_properties(1e7, 1e7, 1e7, 1.0, EI, EI)
        m = Mechanism("elastica")
        b = spatial_beam(m, "b", sec, [(0, 0, 0), (L, 0, 0)], n, start="clamp")
        m.add(SpatialForce("P", b.nodes[-1], (0.0, -3.0 * EI / L ** 2, 0.0)))
        model = m.compile()
        res = solve_static(model, load_steps=3)
        x = b.positions(model, res.q[-1])[-1]
        th = rt.quat_log(np.ascontiguousarray(b.quaternions(model, res.q[-1])[-1]))[2]
        errs.append(np.abs(np.array([x[0], x[1], th]) - ref).max())
    assert errs[1] < 1e-3
    assert np.all(np.log2(np.array(errs[:-1]) / np.array(errs[1:])) > 1.9)


def test_load_unload_returns_to_the_start():
    """Path independence: load the 45° bend to F = 600 and back to 0 (8 elements)."""
    E = 1e7
    sec = SpatialSection.from_properties(E, E / 2, E / 2, E / 12, E / 12, E / 12)
    m = Mechanism("loadunload")
    R = 100.0
    b = spatial_beam(m, "b", sec, lambda s: np.array([R - R * math.cos(s * math.pi / 4), R * math.sin(s * math.pi / 4), 0.0]),
                     8, start="clamp")
    m.add(SpatialForce("F", b.nodes[-1], (0.0, 0.0, 600.0)))
    model = m.compile()
    res = solve_static(model, load_factors=[0.25, 0.5, 0.75, 1.0, 0.5, 0.0])
    assert np.abs(res.q[-1] - model.q0).max() < 1e-9 * R
