"""Linearized modes (femb.analysis.modal) of beams and constrained mechanisms.

References: Euler–Bernoulli cantilever frequencies β_k² √(EI/(ρA L⁴)),
β = 1.8751, 4.6941, 7.8548 (e.g. Géradin & Rixen, Mechanical Vibrations,
Sect. 3.7); pinned–pinned beam under tension T, ω_k² = ((kπ/L)⁴ EI + (kπ/L)² T)/ρA;
compound pendulum ω² = m g d / (J + m d²).
"""
import math

import numpy as np
import pytest

from femb import Mechanism
from femb.analysis.modal import modal_analysis
from femb.analysis.static import solve_static
from femb.elements import Force, Gravity, Hinge, PointOnLine, RigidBody, Section, add_beam
from femb.errors import SingularMatrixError
from femb.system import assembly

BETA = np.array([1.875104068711961, 4.694091132974175, 7.854757438237613])
# steel, 10 mm × 10 mm, L = 1 m: length/thickness = 100
SEC = Section.rectangle(2.1e11, 2.1e11 / 2.6, 0.01, 0.01, 7800.0)


def cantilever(n, mass="consistent", section=SEC):
    m = Mechanism("cantilever")
    add_beam(m, "b", section, m.ground, (1.0, 0.0), n, mass=mass)
    return m.compile()


def test_cantilever_frequencies_match_euler_bernoulli():
    """Within 1 % with 40 consistent-mass elements; the mesh error falls as O(1/n²)."""
    w_eb = BETA ** 2 * math.sqrt(SEC.EI / SEC.rhoA)
    w = {n: modal_analysis(cantilever(n), n_modes=3).omega for n in (10, 20, 40)}
    w[320] = modal_analysis(cantilever(320), n_modes=3, method="sparse").omega
    err_eb = w[40] / w_eb - 1.0
    assert np.all(np.abs(err_eb) < 0.01), err_eb
    # against the model's own converged value (320 elements; it differs from Euler–Bernoulli by
    # shear and rotary inertia, -0.008 %, -0.055 %, -0.13 %) the error falls by 4 per halving
    e = {n: w[n] / w[320] - 1.0 for n in (10, 20, 40)}
    assert np.all(e[10] > e[20]) and np.all(e[20] > e[40]) and np.all(e[40] > 0)
    ratio = e[20] / e[40]
    assert np.all((ratio > 3.7) & (ratio < 4.3)), ratio
    # lumped mass is within 1 % as well
    rl = modal_analysis(cantilever(40, "lumped"), n_modes=3)
    assert np.all(np.abs(rl.omega / w_eb - 1.0) < 0.01)


def test_modes_are_mass_orthonormal_and_satisfy_the_constraints():
    model = cantilever(12)
    r = modal_analysis(model, n_modes=5)
    M = assembly.mass_matrix(model).toarray()
    K = assembly.tangent_stiffness(model, r.state).toarray()
    B = assembly.constraint_jacobian(model, 0.0, model.q0).toarray()
    Phi = r.modes
    np.testing.assert_allclose(Phi @ M @ Phi.T, np.eye(5), atol=1e-10)
    np.testing.assert_allclose(Phi @ K @ Phi.T, np.diag(r.omega ** 2), rtol=0, atol=1e-8 * r.omega[-1] ** 2)
    assert np.abs(B @ Phi.T).max() < 1e-12
    np.testing.assert_allclose(r.frequency, r.omega / (2 * math.pi))
    tip = r.node_mode("b.n12", 0)
    assert tip.shape == (3,) and abs(tip[1]) > 10 * abs(tip[0])      # first mode: transverse
    assert np.all(r.node_mode("ground", 0) == 0.0)


def test_dense_and_sparse_methods_agree():
    model = cantilever(30)
    rd = modal_analysis(model, n_modes=4, method="dense")
    rs = modal_analysis(model, n_modes=4, method="sparse")
    np.testing.assert_allclose(rs.omega, rd.omega, rtol=1e-7)
    for a, b in zip(rd.modes, rs.modes):
        assert abs(abs(a @ b) / (np.linalg.norm(a) * np.linalg.norm(b)) - 1.0) < 1e-6


def test_tension_stiffens_a_pinned_beam():
    """Pinned–pinned beam, right end on a roller, pulled by T: ω² rises by (kπ/L)² T/ρA."""
    T, n = 2000.0, 40
    omegas = []
    for load in (0.0, T):
        m = Mechanism("string")
        b = add_beam(m, "b", SEC, (0.0, 0.0), (1.0, 0.0), n, start_joint="hinge")
        m.add(PointOnLine("roller", m.ground, b.nodes[-1], axis=(1.0, 0.0)))
        if load:
            m.add(Force("T", b.nodes[-1], (load, 0.0)))
        model = m.compile()
        st = solve_static(model, load_steps=1)
        r = modal_analysis(model, st, n_modes=3)
        assert r.asymmetry < 1e-12
        omegas.append(r.omega)
    k = np.arange(1, 4) * math.pi
    np.testing.assert_allclose(omegas[0], k ** 2 * math.sqrt(SEC.EI / SEC.rhoA), rtol=6e-3)
    np.testing.assert_allclose((omegas[1] ** 2 - omegas[0] ** 2) * SEC.rhoA / (k ** 2 * T), 1.0, rtol=3e-3)


def test_pendulum_mode_needs_the_constraint_stiffness():
    """A hanging compound pendulum: ω² = m g d/(J + m d²) from ∂(Φ_qᵀλ)/∂q at the static λ."""
    mass, J, d, g = 2.0, 0.1, 0.4, 9.81
    m = Mechanism("pendulum")
    bar = m.add(RigidBody("bar", mass, J, position=(0.0, -d), points={"O": (0.0, d)}))
    m.add(Hinge("pivot", "ground", bar, point_b="O"))
    m.add(Gravity((0.0, -g)))
    model = m.compile()
    st = solve_static(model, load_steps=1)
    r = modal_analysis(model, st, n_modes=1)
    assert r.omega[0] == pytest.approx(math.sqrt(mass * g * d / (J + mass * d ** 2)), rel=1e-12)
    # without the multipliers (unloaded reference) there is no restoring stiffness
    assert abs(modal_analysis(model, n_modes=1).omega[0]) < 1e-6
    # an inverted pendulum is unstable: negative ω² is reported as a negative ω
    m2 = Mechanism("inverted")
    bar2 = m2.add(RigidBody("bar", mass, J, position=(0.0, d), points={"O": (0.0, -d)}))
    m2.add(Hinge("pivot", "ground", bar2, point_b="O"))
    m2.add(Gravity((0.0, -g)))
    model2 = m2.compile()
    r2 = modal_analysis(model2, solve_static(model2, load_steps=1), n_modes=1)
    assert r2.omega[0] == pytest.approx(-math.sqrt(mass * g * d / (J + mass * d ** 2)), rel=1e-12)


def test_massless_rotation_is_reported():
    sec = Section(1.0, 1.0, 1.0, 1.0, 0.0)        # no rotary inertia
    with pytest.raises(SingularMatrixError, match="mass"):
        modal_analysis(cantilever(4, section=sec), n_modes=2, method="dense")
