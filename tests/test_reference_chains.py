"""Checks of the independent references of the step-size scenes (no femb involved).

The chain reference (``femb.benchmarks.references.planar_chain``) and the
driven four-bar (``femb.benchmarks.references.fourbar_driven``) are checked
against facts outside their own equations: energy conservation, momentum
balance with finite-difference accelerations, loop closure, and the power
balance of the driver.
"""
import math

import numpy as np
import pytest

from femb.benchmarks.references import fourbar_driven as fb
from femb.benchmarks.references.planar_chain import Chain, solve

G = 9.81


def _double():
    return Chain([1.0, 1.0], [1 / 12, 1 / 12], [1.0, 1.0], [0.5, 0.5], g=(0.0, -G))


def _energy(chain, sol, potential=None):
    m, J = chain.m, chain.J
    T = 0.5 * np.einsum("k,tkx,tkx->t", m, sol["v"], sol["v"]) + 0.5 * np.einsum("k,tk->t", J, sol["phid"] ** 2)
    V = -np.einsum("k,x,tkx->t", m, chain.g, sol["r"])
    if potential is not None:
        V = V + potential(sol)
    return T + V


def test_double_pendulum_conserves_energy_and_matches_hand_mass_matrix():
    chain = _double()
    sol = solve(chain, np.linspace(0.0, 3.0, 61), [-1.2, -1.6], [3.0, 0.0])
    E = _energy(chain, sol)
    assert np.ptp(E) < 1e-9 * np.max(np.abs(E))
    # two uniform bars (absolute angles): M = [[m l²/3 + m l², m l²/2 cos], [.., m l²/3]]
    phi = np.array([0.3, -0.4])
    d = phi[0] - phi[1]
    M = np.array([[1 / 3 + 1.0, 0.5 * math.cos(d)], [0.5 * math.cos(d), 1 / 3]])
    Q = np.array([-G * 1.5 * math.cos(phi[0]), -G * 0.5 * math.cos(phi[1])])
    # rates zero: no quadratic terms
    np.testing.assert_allclose(chain.accelerations(0.0, phi, np.zeros(2)), np.linalg.solve(M, Q), rtol=1e-14)


@pytest.mark.parametrize("case", ["double", "spring", "bead"])
def test_ground_reaction_is_the_momentum_balance(case):
    """R_0 = d/dt Σ m_k v_k − Σ F_k, with d/dt by a fourth-order difference of the velocities."""
    if case == "double":
        chain, phi0, phid0 = _double(), [-1.2, -1.6], [3.0, 0.0]
    elif case == "spring":
        chain = Chain([2.0], [2.0 * 0.64 / 12], [0.8], [0.4], g=(0.0, -G),
                      loads=lambda t, p, w: (np.zeros((1, 2)), -30.0 * p))
        phi0, phid0 = [0.0], [0.0]
    else:
        P = np.array([1.05, 0.0])

        def loads(t, p, w):
            D = np.array([math.cos(p[0]), math.sin(p[0])]) - P
            return (-D / np.linalg.norm(D) ** 3)[None, :], np.zeros(1)
        chain, phi0, phid0 = Chain([1.0], [1e-4], [1.0], [1.0], g=(0.0, 0.0), loads=loads), [math.pi], [2.0]
    h = 1e-4
    tc = np.array([0.4, 1.3])
    t = np.sort(np.concatenate([tc + j * h for j in (-2, -1, 0, 1, 2)]))
    sol = solve(chain, t, phi0, phid0)
    i = np.searchsorted(t, tc)
    p = np.einsum("k,tkx->tx", chain.m, sol["v"])
    dp = (8 * (p[i + 1] - p[i - 1]) - (p[i + 2] - p[i - 2])) / (12 * h)
    F = np.array([chain.external(t[j], sol["phi"][j], sol["phid"][j])[0].sum(axis=0) for j in i])
    np.testing.assert_allclose(sol["R"][i, 0], dp - F, atol=1e-6 * np.max(np.abs(sol["R"][i, 0])))


def test_bead_energy_with_the_attractor_potential():
    P = np.array([1.05, 0.0])

    def loads(t, p, w):
        D = np.array([math.cos(p[0]), math.sin(p[0])]) - P
        return (-D / np.linalg.norm(D) ** 3)[None, :], np.zeros(1)
    chain = Chain([1.0], [1e-4], [1.0], [1.0], g=(0.0, 0.0), loads=loads)
    sol = solve(chain, np.linspace(0.0, 10.0, 201), [math.pi], [2.0])
    E = _energy(chain, sol, lambda s: -1.0 / np.linalg.norm(s["r"][:, 0] - P, axis=1))
    assert np.ptp(E) < 1e-9 * np.max(np.abs(E))
    # slowest at the start (farthest from P), fast near P: ½(m + J)φ̇² = E + 1/0.05 there, φ̇ = 6.56 rad/s
    assert np.min(sol["phid"]) >= 2.0 - 1e-9 and np.max(sol["phid"]) > 4.0
    assert math.sqrt(2 * (E[0] + 1 / 0.05) / (1 + 1e-4)) == pytest.approx(6.559, abs=1e-3)


def test_fine_window_matches_a_plain_run():
    chain = _double()
    t = np.linspace(0.0, 1.0, 11)
    a = solve(chain, t, [-1.2, -1.6], [3.0, 0.0])
    b = solve(chain, t, [-1.2, -1.6], [3.0, 0.0], fine=(0.3, 0.55, 1e-3))
    np.testing.assert_allclose(a["phi"], b["phi"], atol=1e-10)
    np.testing.assert_allclose(a["R"], b["R"], atol=1e-8)


def test_fourbar_closes_and_its_rates_are_derivatives():
    p = fb.PARAMS
    h = 1e-5
    for t in (0.0, 0.37, 1.21):
        s, sm, sp = fb.state(t), fb.state(t - h), fb.state(t + h)
        th = s["theta"]
        e = lambda a: np.array([math.cos(a), math.sin(a)])  # noqa: E731
        gap = p["l1"] * e(th[0]) + p["l2"] * e(th[1]) - p["l3"] * e(th[2]) - np.array([p["l4"], 0.0])
        assert np.abs(gap).max() < 1e-14
        np.testing.assert_allclose(s["omega"], (sp["theta"] - sm["theta"]) / (2 * h), atol=1e-8)
        np.testing.assert_allclose(s["alpha"], (sp["omega"] - sm["omega"]) / (2 * h), atol=1e-6)


def test_fourbar_driving_power_equals_energy_rate():
    """τ ω = d(T + V)/dt: the driver is the only non-conservative force."""
    p = fb.PARAMS
    m = np.array([p["m1"], p["m2"], p["m3"]])
    J = m * np.array([p["l1"], p["l2"], p["l3"]]) ** 2 / 12

    def energy(t):
        h = 1e-6
        s, sp, sm = fb.state(t), fb.state(t + h), fb.state(t - h)
        v = (sp["centres"] - sm["centres"]) / (2 * h)
        return 0.5 * np.sum(m * np.sum(v * v, axis=1)) + 0.5 * np.sum(J * s["omega"] ** 2) \
            + p["g"] * np.sum(m * s["centres"][:, 1])

    for t in (0.1, 0.8, 1.7):
        h = 1e-4
        dE = (energy(t + h) - energy(t - h)) / (2 * h)
        s = fb.state(t)
        assert s["tau"] * p["omega"] == pytest.approx(dE, rel=1e-5, abs=1e-6)
