"""The static solver (femb.analysis.static): load stepping, constraints, cut-backs, errors."""
import math

import numpy as np
import pytest
from scipy.optimize import brentq

import femb
from femb import Mechanism
from femb.elements import (Force, Gravity, Hinge, RigidBody, RotationalSpringDamper, Section,
                           add_beam)
from femb.analysis.static import equilibrium_residual, solve_static
from femb.errors import ConvergenceError, ParameterError, SingularMatrixError

M_BAR, L_BAR, K_SPRING, G = 2.0, 0.8, 10.0, 9.81


def spring_pendulum():
    """A bar hinged at its left end, horizontal at rest, held by a torsional spring, under gravity."""
    m = Mechanism("spring_pendulum")
    bar = m.add(RigidBody("bar", M_BAR, M_BAR * L_BAR ** 2 / 12, position=(L_BAR / 2, 0.0),
                          points={"O": (-L_BAR / 2, 0.0)}))
    m.add(Hinge("pivot", "ground", bar, point_b="O"))
    m.add(RotationalSpringDamper("spring", "ground", bar, K_SPRING))
    m.add(Gravity((0.0, -G)))
    return m.compile()


def test_spring_pendulum_equilibrium_and_reaction():
    """k θ + m g (L/2) cos θ = 0, hinge reaction = weight."""
    model = spring_pendulum()
    res = solve_static(model, load_steps=5)
    theta = brentq(lambda th: K_SPRING * th + M_BAR * G * L_BAR / 2 * math.cos(th), -math.pi / 2, 0.0)
    assert res.body("bar")[-1, 2] == pytest.approx(theta, abs=1e-12)
    np.testing.assert_allclose(res.reaction("pivot")[-1], [0.0, M_BAR * G], atol=1e-10)
    np.testing.assert_allclose(res.load_factor, np.linspace(0.0, 1.0, 6))
    # every stored step is an equilibrium at its own load factor
    for mu, q, lam in zip(res.t, res.q, res.lam):
        r, Phi = equilibrium_residual(model, q, lam, mu)
        assert np.abs(r).max() < 1e-9 and np.abs(Phi).max() < 1e-12
        th = brentq(lambda th: K_SPRING * th + mu * M_BAR * G * L_BAR / 2 * math.cos(th), -math.pi / 2, 0.0)
        assert model.node_coordinates("bar", q)[2] == pytest.approx(th, abs=1e-12)
    assert res.success and res.state.t == 0.0


def test_static_state_starts_a_dynamic_run_at_rest():
    model = spring_pendulum()
    # equilibrium to round-off: the dynamic run's first Newton correction removes any
    # leftover Φ, and Φ/(βh²) would show in λ (1e-13 m here gives ~4e-8 N)
    st = solve_static(model, load_steps=2, phi_tol=1e-16).state
    run = femb.simulate(model, 0.2, 1e-2, state=st)
    assert np.abs(run.q - st.q).max() < 1e-10
    assert np.abs(run.lam - st.lam).max() < 1e-8


def test_load_factors_and_follower_load():
    """Explicit load levels; a follower (body-frame) force gives a non-symmetric K_t."""
    m = Mechanism("follower")
    b = add_beam(m, "b", Section(1e4, 1e4, 1.0, 1.0, 1e-3), m.ground, (1.0, 0.0), 8)
    m.add(Force("F", b.nodes[-1], (0.0, -1.0), frame="body"))
    model = m.compile()
    res = solve_static(model, load_factors=[0.5, 1.0, 2.0])
    # explicit levels: exactly those, no zero-load solve first
    np.testing.assert_allclose(res.load_factor, [0.5, 1.0, 2.0])
    assert res.strategy == "load steps" and [p["mu"] for p in res.path] == [0.5, 1.0, 2.0]
    for mu, q, lam in zip(res.t, res.q, res.lam):
        r, Phi = equilibrium_residual(model, q, lam, mu)
        assert np.abs(r).max() < 1e-9
    # a follower tip force stays perpendicular to the tip section: the tip turns further than
    # under the dead load of the same size
    dead = Mechanism("dead")
    bd = add_beam(dead, "b", Section(1e4, 1e4, 1.0, 1.0, 1e-3), dead.ground, (1.0, 0.0), 8)
    dead.add(Force("F", bd.nodes[-1], (0.0, -2.0)))
    rd = solve_static(dead.compile(), load_steps=2)
    assert res.body("b.n8")[-1, 2] < rd.body("b.n8")[-1, 2] < 0.0


def test_cut_back_when_a_load_step_is_too_large():
    """The elastica at PL²/EI = 10 in one step with 6 Newton iterations (8 suffice): the step is bisected."""
    m = Mechanism("elastica")
    b = add_beam(m, "b", Section(1e6, 1e6, 1.0, 1.0, 1e-3), m.ground, (1.0, 0.0), 10)
    m.add(Force("P", b.nodes[-1], (0.0, -10.0)))
    model = m.compile()
    res = solve_static(model, load_steps=1, max_iter=6)
    assert len(res.t) > 2 and res.t[-1] == 1.0
    assert np.all(np.diff(res.t) > 0)
    ref = solve_static(model, load_steps=10)
    np.testing.assert_allclose(res.q[-1], ref.q[-1], atol=1e-10)


def test_errors():
    model = spring_pendulum()
    with pytest.raises(ParameterError):
        solve_static(model, load_steps=0)
    with pytest.raises(ParameterError):
        solve_static(model, predictor="cubic")
    with pytest.raises(ConvergenceError, match="load factor"):
        solve_static(model, load_steps=1, max_iter=1, min_step=0.5)
    # a free body under a load has no static equilibrium
    m = Mechanism("free")
    body = m.add(RigidBody("b", 1.0, 1.0))
    m.add(Force("F", body, (1.0, 0.0)))
    with pytest.raises(SingularMatrixError, match="singular"):
        solve_static(m.compile())


# ---------------------------------------------------------------------------
# systems held only by gravity and springs (singular at zero load)
# ---------------------------------------------------------------------------
def hanging_chain(n, m=1.5, k=200.0, g=G):
    """n point masses in a vertical line, each hanging from the one above by a spring of rest length 1."""
    from femb.elements import PointMass, SpringDamper
    mech = Mechanism(f"chain{n}")
    prev = mech.ground
    for i in range(n):
        p = mech.add(PointMass(f"m{i}", m, position=(0.0, -(i + 1.0))))
        mech.add(SpringDamper(f"s{i}", prev, p, k))
        prev = p
    mech.add(Gravity((0.0, -g)))
    return mech.compile()


def test_one_mass_hanging_from_one_spring():
    """y = −(l0 + m g / k); zero load is singular (no lateral stiffness), full load is not."""
    m, k = 1.5, 200.0
    model = hanging_chain(1, m, k)
    res = solve_static(model)
    assert res.strategy == "direct" and res.load_factor.tolist() == [1.0]
    np.testing.assert_allclose(res.body("m0")[-1, :2], [0.0, -(1.0 + m * G / k)], atol=1e-14)
    assert res.path[0]["converged"] and res.path[0]["residuals"][-1][0] < 1e-10
    # no zero-load solve: the first (and only) Newton solve is at full load, from the given start,
    # and its first matrix is singular (a slack spring has no lateral stiffness): a regularized step
    assert [(p["mu"], p["start"]) for p in res.path] == [(1.0, "given")] and res.path[0]["damped"] >= 1


def test_hanging_chain_of_masses_and_springs():
    """Spring j (from the top) carries (n − j) m g: y_i = −Σ_{j≤i} (1 + (n − j) m g / k)."""
    n, m, k = 6, 1.5, 200.0
    res = solve_static(hanging_chain(n, m, k))
    y = -np.cumsum([1.0 + (n - j) * m * G / k for j in range(n)])
    got = np.array([res.body(f"m{i}")[-1] for i in range(n)])
    np.testing.assert_allclose(got[:, 1], y, atol=1e-12)
    np.testing.assert_allclose(got[:, 0], 0.0, atol=1e-14)
    assert res.strategy == "direct" and "direct" in res.describe_path()


def test_pendulum_with_rounded_input():
    """A bar given at −30° with its centre rounded to 2e-5 m: it hangs straight down, reaction = weight."""
    L, mass, th, rnd = 1.0, 2.0, -math.pi / 6, 2e-5
    c = np.round(np.array([math.cos(th), math.sin(th)]) * L / 2 / rnd) * rnd
    assert 0 < np.abs(c - np.array([math.cos(th), math.sin(th)]) * L / 2).max() <= rnd
    mech = Mechanism("pendulum")
    bar = mech.add(RigidBody("bar", mass, mass * L ** 2 / 12, position=c, angle=th, points={"O": (-L / 2, 0.0)}))
    mech.add(Hinge("pivot", "ground", bar, point_b="O"))
    mech.add(Gravity((0.0, -G)))
    res = solve_static(mech.compile())
    np.testing.assert_allclose(res.body("bar")[-1], [0.0, -L / 2, -math.pi / 2], atol=1e-12)
    np.testing.assert_allclose(res.reaction("pivot")[-1], [0.0, mass * G], atol=1e-10)
    assert res.path[-1]["stability"] > 0.0


def test_direct_failure_falls_back_to_continuation():
    """The elastica at PL²/EI = 10 with 6 Newton iterations (8 suffice): direct fails, load stepping gets there."""
    m = Mechanism("elastica")
    b = add_beam(m, "b", Section(1e6, 1e6, 1.0, 1.0, 1e-3), m.ground, (1.0, 0.0), 10)
    m.add(Force("P", b.nodes[-1], (0.0, -10.0)))
    model = m.compile()
    res = solve_static(model, max_iter=6)
    assert res.strategy == "continuation"
    assert not res.path[0]["converged"] and res.path[0]["mu"] == 1.0
    assert res.load_factor[-1] == 1.0
    ref = solve_static(model, load_steps=10)
    np.testing.assert_allclose(res.q[-1], ref.q[-1], atol=1e-10)
    # with enough iterations the direct solve reaches the same equilibrium in one go
    direct = solve_static(model)
    assert direct.strategy == "direct" and len(direct.path) == 1
    np.testing.assert_allclose(direct.q[-1], ref.q[-1], atol=1e-9)
