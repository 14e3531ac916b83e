"""Planar pendulum (hinge to ground, gravity) against its exact elliptic-function solution."""
import math

import numpy as np
import pytest
from scipy.special import ellipj, ellipk

import femb
from femb.elements import Gravity, Hinge, RigidBody

L, M, G = 1.0, 2.0, 9.81


def build(psi0):
    """Uniform bar pivoted at one end; psi = angle from the downward vertical."""
    mech = femb.Mechanism("pendulum")
    phi = psi0 - math.pi / 2          # body x axis from the pivot to the free end
    c = 0.5 * L * np.array([math.cos(phi), math.sin(phi)])
    bar = mech.add(RigidBody("bar", M, M * L * L / 12, c, phi, points={"O": (-L / 2, 0.0)}))
    mech.add(Hinge("pivot", "ground", bar, point_b="O"))
    mech.add(Gravity((0.0, -G)))
    return mech


def exact(t, psi0):
    """ψ(t) = 2 arcsin(k sn(K − ω0 t | k²)), k = sin(ψ0/2), ω0² = 3g/(2L)."""
    k = math.sin(psi0 / 2)
    w0 = math.sqrt(1.5 * G / L)
    K = ellipk(k * k)
    sn, _, _, _ = ellipj(K - w0 * t, k * k)
    return 2 * np.arcsin(k * sn), 4 * K / w0


def angle_error(h, psi0=2.0):
    _, T = exact(0.0, psi0)
    r = femb.simulate(build(psi0).compile(), T, h, rho_inf=0.8)
    psi = r.body("bar")[:, 2] + math.pi / 2
    return np.abs(psi - exact(r.t, psi0)[0]).max(), r


def test_pendulum_matches_elliptic_solution_to_second_order():
    e1, r = angle_error(2e-3)
    e2, _ = angle_error(1e-3)
    assert e1 < 2e-3
    order = math.log(e1 / e2, 2)
    assert order > 1.9, (e1, e2, order)
    # after one period the pendulum is back at its start (exact period 4K/ω0)
    assert r.body("bar")[-1, 2] + math.pi / 2 == pytest.approx(2.0, abs=5e-4)


def test_pivot_reaction_equals_newton_euler():
    """Pivot force from the bar's Newton–Euler equation on the exact motion."""
    psi0 = 1.0
    _, T = exact(0.0, psi0)
    r = femb.simulate(build(psi0).compile(), T / 2, 1e-3, rho_inf=0.8)
    psi = r.body("bar")[:, 2] + math.pi / 2
    w = r.body("bar", "qd")[:, 2]
    a = -1.5 * G / L * np.sin(psi)
    # centre of mass r_c = (L/2)(sin ψ, −cos ψ); m r̈_c = R + m g
    acc = 0.5 * L * np.stack((np.cos(psi) * a - np.sin(psi) * w ** 2, np.sin(psi) * a + np.cos(psi) * w ** 2), 1)
    R = M * acc - M * np.array([0.0, -G])
    np.testing.assert_allclose(r.reaction("pivot"), R, atol=2e-3 * M * G)
