"""Velocity-level (non-holonomic) constraints in the compiled time loop.

A rolling disc (coin) and the Chaplygin sleigh (knife edge) against independent references
(minimal-velocity ODEs integrated by scipy at rtol 1e-12, femb.benchmarks.references.rolling_disc_ode),
a planar wheel rolling down an incline against its closed form, steady circular rolling of the
coin, the velocity residual at every step, energy, reactions as outputs, adaptive steps.
"""
import warnings

import numpy as np
import pytest

import femb
from femb import Mechanism
from femb.base.rotations import expm
from femb.benchmarks.references.rolling_disc_ode import ChaplyginSleigh, RollingDisc as DiscReference, quat_matrix
from femb.elements import Gravity, RigidBody
from femb.elements.rolling import KnifeEdge, PlanarWheel, RollingDisc
from femb.elements.spatial_bodies import SpatialRigidBody
from femb.elements.spatial_forces import SpatialGravity
from femb.system import assembly

RHO, MASS = 0.5, 1.0
Z = np.array([0.0, 0.0, 1.0])


def _order(hs, errs):
    return float(np.polyfit(np.log(hs), np.log(errs), 1)[0])


def _coin(R0, omega_space):
    """A thin disc (ρ = 0.5 m, 1 kg) on the plane z = 0, its axis R0 e_y, touching the plane and
    rolling with the angular velocity ω (space axes): its centre moves with ω × ρd."""
    a = R0 @ np.array([0.0, 1.0, 0.0])
    c = Z @ a
    d = (Z - c * a) / np.sqrt(1.0 - c * c)
    velocity = RHO * np.cross(omega_space, d)
    m = Mechanism("coin")
    m.add(SpatialRigidBody("disc", MASS, (MASS * RHO ** 2 / 4, MASS * RHO ** 2 / 2, MASS * RHO ** 2 / 4),
                           position=RHO * d, rotation=R0, omega=tuple(R0.T @ np.asarray(omega_space, float)),
                           velocity=tuple(velocity)))
    m.add(RollingDisc("roll", "disc", RHO, (0.0, 1.0, 0.0)))
    m.add(SpatialGravity())
    return m.compile()


@pytest.fixture(scope="module")
def coin():
    R0 = expm(np.array([0.3, 0.0, 0.0]))
    return _coin(R0, R0 @ np.array([0.0, 6.0, 0.5]))


def _max_velocity_residual(model, res):
    return max(np.abs(assembly.velocity_constraints(model, res.t[k], res.q[k], res.qd[k])[0]).max()
               for k in range(res.t.size))


def _disc_reference(res, T):
    """The reference from femb's consistent initial state (quaternion, ω in space axes, contact point)."""
    q0, qd0 = res.q[0], res.qd[0]
    R0 = quat_matrix(q0[3:7])
    w0 = R0 @ qd0[3:6]
    ref = DiscReference(MASS, RHO)
    _, d0, _ = ref.geometry(R0, w0)
    return ref.solve(q0[3:7], w0, q0[0:3] - RHO * d0, [0.0, T])


def test_coin_converges_at_second_order_in_positions_rotations_and_reactions(coin):
    T = 1.0
    errs = []
    hs = [4e-3, 2e-3, 1e-3]
    ref = None
    for h in hs:
        res = femb.simulate(coin, T, h=h)
        ref = ref or _disc_reference(res, T)
        F = ref["F"][-1]                       # contact force on the disc: −(λ n + μ₁ t₁ + μ₂ t₂)
        lam = res.lam[-1]
        errs.append((np.abs(res.q[-1, 0:3] - ref["G"][-1]).max(),
                     np.abs(quat_matrix(res.q[-1, 3:7]) - quat_matrix(ref["p"][-1])).max(),
                     max(abs(-lam[0] - F[2]), abs(-lam[1] - F[0]), abs(-lam[2] - F[1]))))
    errs = np.array(errs)
    for j, what in enumerate(("centre", "rotation", "reactions")):
        assert _order(hs, errs[:, j]) >= 1.9, (what, errs[:, j])
    assert errs[-1].max() < 1e-4


def test_sleigh_converges_at_second_order_in_q_and_the_reaction():
    mass, J, b = 2.0, 0.3, -0.4
    th0, u0, w0 = 0.2, 1.0, 0.8
    e = np.array([np.cos(th0), np.sin(th0)])
    l_ = np.array([-np.sin(th0), np.cos(th0)])
    m = Mechanism("sleigh")
    m.add(RigidBody("s", mass, J, angle=th0, velocity=tuple(u0 * e - b * w0 * l_), omega=w0))
    m.add(KnifeEdge("k", "s", 0.0, (b, 0.0)))
    model = m.compile()
    T = 2.0
    ref = ChaplyginSleigh(mass, J, b).solve(0.0, 0.0, th0, u0, w0, [0.0, T])
    hs = [8e-3, 4e-3, 2e-3]
    errs = []
    for h in hs:
        res = femb.simulate(model, T, h=h)
        assert _max_velocity_residual(model, res) < 1e-14
        errs.append((np.abs(res.q[-1] - ref["q"][-1]).max(), np.abs(res.qd[-1] - ref["qd"][-1]).max(),
                     abs(-res.lam[-1, 0] - ref["F"][-1])))
    errs = np.array(errs)
    for j in range(3):
        assert _order(hs, errs[:, j]) >= 1.9, errs[:, j]
    assert errs[-1].max() < 1e-6
    # the reaction is an output by its name, in N
    vals, unit = res.series("k.lateral")
    assert unit == "N" and np.array_equal(vals, res.lam[:, 0]) and "k.lateral" in res.outputs()


def test_velocity_residual_is_at_round_off_every_step(coin):
    res = femb.simulate(coin, 1.0, h=2e-3)
    speed = np.abs(res.qd).max()
    assert _max_velocity_residual(coin, res) <= 1e-13 * speed
    # μ are outputs: the tangential reactions of the disc, and Result.mu
    t1, unit = res.series("roll.t1")
    assert unit == "N" and np.array_equal(t1, res.mu[:, 0]) and res.mu.shape == (res.t.size, 2)
    assert {"roll.normal", "roll.t1", "roll.t2"} <= set(res.outputs())


def test_planar_wheel_rolls_down_an_incline_as_in_closed_form():
    alpha, rho, mass, J, g = 0.3, 0.4, 2.0, 0.1, 9.81
    n = np.array([-np.sin(alpha), np.cos(alpha)])
    m = Mechanism("wheel")
    m.add(RigidBody("w", mass, J, position=tuple(rho * n)))
    m.add(PlanarWheel("roll", "w", rho, normal=tuple(n)))
    m.add(Gravity((0.0, -g)))
    model = m.compile()
    res = femb.simulate(model, 1.0, h=1e-2)
    acc = g * np.sin(alpha) / (1.0 + J / (mass * rho ** 2))     # down the slope, −t direction
    t_dir = np.array([n[1], -n[0]])
    s = (res.q[:, 0:2] - rho * n) @ t_dir
    assert np.allclose(s, -0.5 * acc * res.t ** 2, rtol=0, atol=1e-10)
    assert np.allclose(res.qd[:, 2], acc * res.t / rho, rtol=0, atol=1e-10)
    assert np.allclose(-res.lam[:, 0], mass * g * np.cos(alpha), rtol=1e-10)          # normal force
    # friction up the slope (+t): m g sin α J/(J + m ρ²)
    assert np.allclose(-res.lam[:, 1], mass * g * np.sin(alpha) * J / (J + mass * rho ** 2), rtol=1e-9)


def test_steady_circular_rolling_stays_steady():
    ref = DiscReference(MASS, RHO)
    R0 = expm(np.array([0.3, 0.0, 0.0]))
    yaw = 2.0
    ws, resid = ref.steady_spin(R0, yaw)
    assert resid < 1e-12
    a, d, _ = ref.geometry(R0, Z)
    w = yaw * Z + ws * a
    model = _coin(R0, w)
    dev = []
    for h in (2e-3, 1e-3):
        res = femb.simulate(model, 3.0, h=h)
        axes = np.einsum("nij,j->ni", np.array([quat_matrix(p) for p in res.q[:, 3:7]]), [0.0, 1.0, 0.0])
        lean = np.abs(axes[:, 2] - a[2]).max()
        yaw_rate = np.abs(np.array([(quat_matrix(p) @ om)[2] for p, om in zip(res.q[:, 3:7], res.qd[:, 3:6])])
                          - w[2]).max()
        normal = np.ptp(res.lam[:, 0]) / abs(res.lam[0, 0])
        dev.append((lean, yaw_rate, normal))
    dev = np.array(dev)
    assert dev[0].max() < 3e-5            # the motion stays steady at the step's accuracy...
    assert np.all(dev[0] / dev[1] > 3.5)  # ... and closer to it at second order


def test_energy_of_the_ideal_rolling_disc_is_conserved_at_second_order(coin):
    hs = [4e-3, 2e-3, 1e-3]
    errs = []
    for h in hs:
        E = femb.simulate(coin, 2.0, h=h).energy()["total"]
        errs.append(np.abs(E - E[0]).max())
    assert _order(hs, errs) >= 1.9 and errs[-1] < 2e-6 * abs(E[0]), errs


def test_adaptive_steps_hold_the_velocity_constraints(coin):
    T = 1.0
    res = femb.simulate(coin, T, rtol=1e-6)
    ref = _disc_reference(res, T)
    assert res.success and res.stats["rejected"] <= 5
    assert np.abs(res.q[-1, 0:3] - ref["G"][-1]).max() < 1e-4
    assert _max_velocity_residual(coin, res) < 1e-12


def test_start_from_a_given_state_without_mu():
    m = Mechanism("skate")
    m.add(RigidBody("s", 1.0, 0.1, velocity=(1.0, 0.0), omega=0.5))
    m.add(KnifeEdge("k", "s", 0.0, (-0.3, 0.0)))
    model = m.compile()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = femb.simulate(model, 0.1, h=1e-3)
        again = femb.simulate(model, 0.1, h=1e-3, state=res.at(0.0), initialize=False)
    assert again.lam.shape == res.lam.shape and np.allclose(again.q, res.q, atol=1e-6)


@pytest.mark.parametrize("v, grows", [(4.6, False), (3.0, True)])
def test_whipple_bicycle_roll_perturbation_follows_the_weave_eigenvalue(v, grows):
    """The IFToMM uncontrolled-bicycle benchmark from the 3-D model: a lean-rate perturbation decays
    inside the self-stable range (4.292–6.024 m/s) and grows below it, at the rate of the weave
    eigenvalue of the linearization."""
    from femb.benchmarks.scenes.spatial import whipple_bicycle as wb
    ev = wb.eigenvalues(v)
    weave = ev[np.argmax(np.abs(ev.imag))]
    t, lean, _, res, psi = wb.roll_perturbation(v, roll_rate=1e-3, t_end=3.5, h=1e-3)
    sigma, omega, rms = wb.fit_lean(t, lean, ev)
    assert abs(sigma - weave.real) < 2e-3 and abs(omega - abs(weave.imag)) < 2e-3, (sigma, omega, weave)
    early, late = np.abs(lean[(t >= 0.5) & (t <= 1.5)]).max(), np.abs(lean[t >= 2.5]).max()
    assert (late > 5 * early) if grows else (late < 0.5 * early)
    assert psi < 1e-13


def test_contact_integrator_refuses_velocity_constraints():
    from femb.system.initial import consistent_initial_state
    m = Mechanism("skate")
    m.add(RigidBody("s", 1.0, 0.1))
    m.add(KnifeEdge("k", "s"))
    with pytest.raises(femb.errors.ModelError, match="contact integrator"):
        consistent_initial_state(m.compile(), contacts=True)
