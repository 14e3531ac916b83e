"""Solver paths: no constraints, damping, sparse vs dense, rheonomic drivers, storage."""
import math

import numpy as np
import pytest

import femb
from femb.benchmarks.scenes.planar import andrews
from femb.elements import (DrivenAngle, DrivenDisplacement, Gravity, Hinge, PointMass, PointOnLine,
                           RigidBody, Slider, SpringDamper)
from femb.base.functions import Harmonic, Linear

K, MASS = 40.0, 0.5


def oscillator(c=0.0):
    m = femb.Mechanism("osc")
    m.ground.add_point("anchor", (0.0, 0.0))
    p = m.add(PointMass("p", MASS, (1.1, 0.0)))
    m.add(SpringDamper("s", "ground", p, K, c, length=1.0, point_a="anchor"))
    return m


def test_unconstrained_oscillator_second_order():
    w = math.sqrt(K / MASS)
    model = oscillator().compile()
    assert model.nc == 0 and not model.needs_C
    errs = []
    for h in (4e-3, 2e-3, 1e-3):
        r = femb.simulate(model, 2.0, h, rho_inf=0.9)
        x = r.body("p")[:, 0] - 1.0
        errs.append(np.abs(x - 0.1 * np.cos(w * r.t)).max())
    assert errs[-1] < 1e-4
    assert math.log(errs[0] / errs[2], 4) > 1.9


def test_damped_oscillator_uses_damping_matrix():
    c = 2.0
    model = oscillator(c).compile()
    assert model.needs_C
    w0 = math.sqrt(K / MASS)
    z = c / (2 * math.sqrt(K * MASS))
    wd = w0 * math.sqrt(1 - z * z)
    r = femb.simulate(model, 1.5, 5e-4, rho_inf=0.8)
    x = r.body("p")[:, 0] - 1.0
    exact = 0.1 * np.exp(-z * w0 * r.t) * (np.cos(wd * r.t) + z * w0 / wd * np.sin(wd * r.t))
    assert np.abs(x - exact).max() < 2e-5
    # full Newton with the exact C_t converges in few iterations
    assert r.newton_iterations.max() <= 3


def test_sparse_and_dense_paths_agree():
    model = andrews.build().compile()
    rd = femb.simulate(model, 0.003, 3e-5, linear_solver="dense")
    rs = femb.simulate(model, 0.003, 3e-5, linear_solver="sparse")
    # "sparse" is the compiled band LU after a bandwidth-reducing ordering, "dense" the full-band LU
    assert rd.settings["linear_solver"] == "dense" and rs.settings["linear_solver"] == "band"
    np.testing.assert_allclose(rs.q, rd.q, atol=1e-11)
    np.testing.assert_allclose(rs.lam, rd.lam, rtol=1e-7, atol=1e-6)


def test_scaling_on_and_off_give_the_same_motion():
    model = andrews.build().compile()
    a = femb.simulate(model, 0.003, 3e-5, scaling=True)
    b = femb.simulate(model, 0.003, 3e-5, scaling=False)
    np.testing.assert_allclose(a.q, b.q, atol=1e-10)
    np.testing.assert_allclose(a.lam, b.lam, rtol=1e-6, atol=1e-6)


def crank(driver):
    L, m = 0.4, 1.5
    mech = femb.Mechanism("crank")
    c = mech.add(RigidBody("crank", m, m * L * L / 12, (L / 2, 0.0), 0.0, points={"O": (-L / 2, 0.0)}))
    mech.add(Hinge("pivot", "ground", c, point_b="O"))
    mech.add(DrivenAngle("motor", "ground", c, driver))
    mech.add(Gravity((0.0, -9.81)))
    return mech, L, m


def test_driven_angle_follows_its_function_and_gives_inverse_dynamics():
    A, W = 0.8, 3.0
    mech, L, m = crank(Harmonic(A, W))
    model = mech.compile()
    assert model.rheonomic
    r = femb.simulate(model, 1.0, 1e-3, rho_inf=0.7)
    th = r.body("crank")[:, 2]
    np.testing.assert_allclose(th, A * np.sin(W * r.t), atol=1e-11)
    # consistent initial velocity from Φ_t: ω(0) = A W
    assert r.body("crank", "qd")[0, 2] == pytest.approx(A * W, abs=1e-12)
    # inverse dynamics about the pivot: I_O θ̈ = τ_motor − m g (L/2) cos θ; the joint applies −λ to body b
    I_O = m * L * L / 3
    thdd = -A * W * W * np.sin(W * r.t)
    tau = I_O * thdd + m * 9.81 * L / 2 * np.cos(th)
    np.testing.assert_allclose(-r.reaction("motor")[:, 0], tau, atol=5e-3 * np.abs(tau).max())


def test_driven_displacement_on_a_slider():
    mech = femb.Mechanism("ram")
    ram = mech.add(RigidBody("ram", 2.0, 0.1, (0.0, 0.0)))
    mech.add(Slider("guide", "ground", ram, axis=(1.0, 1.0)))
    mech.add(DrivenDisplacement("actuator", "ground", ram, Linear(0.5), axis=(1.0, 1.0)))
    mech.add(Gravity((0.0, -9.81)))
    r = femb.simulate(mech.compile(), 0.5, 1e-3)
    pos = r.body("ram")
    s = 0.5 * r.t / math.sqrt(2)
    np.testing.assert_allclose(pos[:, 0], s, atol=1e-12)
    np.testing.assert_allclose(pos[:, 1], s, atol=1e-12)
    # constant speed: the actuator holds the gravity component along the axis, λ = −m g_axis·(−1)
    np.testing.assert_allclose(r.reaction("actuator")[:, 0], -2.0 * 9.81 / math.sqrt(2), rtol=1e-8)


def test_stride_store_and_observer():
    model = oscillator().compile()
    seen = []
    r = femb.simulate(model, 0.1, 1e-3, stride=30, observer=lambda s, k: seen.append((k, s.t)))
    assert r.steps == 100
    np.testing.assert_allclose(r.t, [0.0, 0.03, 0.06, 0.09, 0.1], atol=1e-12)
    assert [k for k, _ in seen] == list(range(101))
    r2 = femb.simulate(model, 0.1, 1e-3, store=False)
    assert r2.t.size == 2 and r2.q.shape == (2, model.nq)
    np.testing.assert_allclose(r2.q[-1], r.q[-1], atol=0)
    assert r.t[-1] == 0.1


def test_t_end_not_a_multiple_of_h_lands_exactly():
    model = oscillator().compile()
    r = femb.simulate(model, 0.1005, 1e-3)
    # 100.5 steps of h: 101 equal steps, each shorter than h (never stretched)
    assert r.t[-1] == 0.1005 and r.steps == 101
    assert r.settings["h"] == pytest.approx(0.1005 / 101) and r.settings["h"] < 1e-3


def test_point_on_line_reaction_is_the_normal_force():
    """A point mass resting on an inclined line under gravity: N = m g cos α."""
    a = math.radians(30.0)
    mech = femb.Mechanism("incline")
    p = mech.add(PointMass("p", 3.0, (0.0, 0.0)))
    mech.add(PointOnLine("rail", "ground", p, axis=(math.cos(a), math.sin(a))))
    mech.add(Gravity((0.0, -9.81)))
    r = femb.simulate(mech.compile(), 0.2, 1e-3)
    # slides down with g sin α along the rail
    s = -(r.body("p")[:, 0] * math.cos(a) + r.body("p")[:, 1] * math.sin(a))
    np.testing.assert_allclose(s, 0.5 * 9.81 * math.sin(a) * r.t ** 2, atol=1e-10)
    # the joint pushes the point with −λ n, n = R(0) J u: |λ| = m g cos α
    np.testing.assert_allclose(np.abs(r.reaction("rail")[:, 0]), 3.0 * 9.81 * math.cos(a), rtol=1e-9)
