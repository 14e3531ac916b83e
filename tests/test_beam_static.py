"""Static validation of the Reissner beam with the static solver (femb.analysis.static).

References beside each test: Timoshenko beam theory for small loads, the
exact constant-curvature solution for a tip moment, the elastica solved
independently with scipy's ``solve_bvp``, and Castigliano's theorem for a
curved (quarter-ring) cantilever.
"""
import math

import numpy as np
import pytest
from scipy.integrate import solve_bvp

from femb import Mechanism
from femb.analysis.static import solve_static
from femb.elements import Force, Gravity, Section, Torque, add_beam


def cantilever(n, *, EI=1.0, EA=1e7, GA=1e7, L=1.0, P=0.0, M=0.0, rhoA=1.0, gravity=None):
    """Cantilever along x clamped to the ground at the origin, tip loads P (downwards) and M."""
    m = Mechanism("cantilever")
    b = add_beam(m, "b", Section(EA, GA, EI, rhoA, 1e-3), m.ground, (L, 0.0), n)
    if P:
        m.add(Force("P", b.nodes[-1], (0.0, -P)))
    if M:
        m.add(Torque("M", b.nodes[-1], M))
    if gravity is not None:
        m.add(Gravity((0.0, -gravity)))
    return m.compile(), b


def _tip(res, b):
    return res.body(b.node_names[-1])[-1]


def _order(ns, errs):
    return -np.polyfit(np.log(ns), np.log(np.abs(errs)), 1)[0]


def test_small_tip_load_matches_timoshenko_and_converges():
    """δ = PL³/3EI + PL/GA (Timoshenko); one-point elements give δ_n = δ − PL³/(12 EI n²)."""
    EI, GA, L, P = 1.0, 10.0, 1.0, 1e-5
    exact = P * L ** 3 / (3 * EI) + P * L / GA
    ns = np.array([2, 4, 8, 16])
    errs = []
    for n in ns:
        model, b = cantilever(n, EI=EI, GA=GA, P=P)
        res = solve_static(model, load_steps=1)
        d = -_tip(res, b)[1]
        errs.append(d / exact - 1.0)
        assert d == pytest.approx(exact - P * L ** 3 / (12 * EI * n ** 2), rel=1e-6)
    assert _order(ns, errs) == pytest.approx(2.0, abs=0.02)
    assert abs(errs[-1]) < 1e-3


@pytest.mark.parametrize("slenderness", [10.0, 1e3, 1e5])
def test_no_shear_locking(slenderness):
    """Thin and thick beams alike: 4 elements within 2 % of Timoshenko for any L/h."""
    L, h, E, G = 1.0, 1.0 / slenderness, 1.0, 0.4
    sec = Section.rectangle(E, G, 1.0, h, 1.0)
    P = 1e-6 * sec.EI
    model, b = cantilever(4, EI=sec.EI, EA=sec.EA, GA=sec.GA, P=P)
    d = -_tip(solve_static(model, load_steps=1), b)[1]
    exact = P * L ** 3 / (3 * sec.EI) + P * L / sec.GA
    assert abs(d / exact - 1.0) < 0.02


def test_curved_cantilever_no_membrane_locking():
    """Quarter ring, R/h = 1000, tip load F: δ = (π/4) F (R³/EI + R/EA + R/GA) (Castigliano)."""
    R, h = 1.0, 1e-3
    sec = Section.rectangle(1.0, 0.4, 1.0, h, 1.0)
    F = 1e-6 * sec.EI / R ** 2
    exact = math.pi / 4 * F * (R ** 3 / sec.EI + R / sec.EA + R / sec.GA)
    ns = np.array([4, 8, 16])
    errs = []
    for n in ns:
        m = Mechanism("ring")
        b = add_beam(m, "b", sec, (R, 0.0), (0.0, R), n, sweep=math.pi / 2, start_joint="clamp")
        m.add(Force("F", b.nodes[-1], (0.0, -F)))
        res = solve_static(m.compile(), load_steps=1)
        errs.append(-(_tip(res, b)[1] - R) / exact - 1.0)
    assert abs(errs[0]) < 0.05          # a locking element would be stiffer by orders of magnitude
    assert abs(errs[-1]) < 4e-3
    assert _order(ns, errs) == pytest.approx(2.0, abs=0.1)


def test_tip_moment_rolls_the_cantilever_into_a_circle():
    """M = 2π EI/L: exact solution for one-point linear elements, tip back at the root."""
    n, L, EI = 10, 1.0, 1.0
    model, b = cantilever(n, EI=EI, M=2 * math.pi * EI / L)
    res = solve_static(model, load_steps=4)
    np.testing.assert_allclose(res.load_factor, [0.0, 0.25, 0.5, 0.75, 1.0])
    x, y, th = _tip(res, b)
    assert math.hypot(x, y) < 1e-6 * L
    assert th == pytest.approx(2 * math.pi, abs=1e-10)
    # the nodes form a regular polygon with sides L/n on a circle of radius L / (2 n sin(π/n))
    X = b.coordinates(model, res.q[-1])
    r = L / (2 * n * math.sin(math.pi / n))
    np.testing.assert_allclose(np.hypot(X[:, 0], X[:, 1] - r), r, atol=1e-10)
    np.testing.assert_allclose(np.hypot(*np.diff(X[:, :2], axis=0).T), L / n, rtol=1e-10)
    # at half the moment: a half circle of radius L / (2 n sin(π/2n)), tip diametrically opposite
    xh, yh, thh = b.coordinates(model, res.q[2])[-1]
    assert thh == pytest.approx(math.pi, abs=1e-10) and abs(xh) < 1e-10
    assert yh == pytest.approx(L / (n * math.sin(math.pi / (2 * n))), rel=1e-10)


def elastica(alphas):
    """Tip (x, y, θ) of the inextensible cantilever elastica under a tip dead load, L = EI = 1.

    EI θ'' = P cos θ, θ(0) = 0, θ'(L) = 0, x' = cos θ, y' = sin θ (load downwards),
    solved by scipy's solve_bvp with continuation in P L²/EI.
    """
    s = np.linspace(0.0, 1.0, 101)
    y = np.zeros((4, s.size))
    y[2] = s
    out, a0 = {}, 0.0
    for target in alphas:
        for a in np.linspace(a0, target, 4)[1:]:
            sol = solve_bvp(lambda s, y, a=a: np.vstack((y[1], a * np.cos(y[0]), np.cos(y[0]), np.sin(y[0]))),
                            lambda ya, yb: np.array([ya[0], yb[1], ya[2], ya[3]]), s, y, tol=1e-10,
                            max_nodes=100000)
            assert sol.success, sol.message
            s, y = sol.x, sol.y
        a0 = target
        out[target] = np.array([y[2, -1], y[3, -1], y[0, -1]])
    return out


def test_large_deflection_cantilever_matches_the_elastica():
    """PL²/EI ∈ {1, 3, 10}: tip position and rotation converge to the elastica as O(1/n²)."""
    ref = elastica([1.0, 3.0, 10.0])
    # published values of the elastica (Bisshopp & Drucker 1945): vertical tip deflection/L
    assert -ref[1.0][1] == pytest.approx(0.30172, abs=1e-5)
    assert -ref[10.0][1] == pytest.approx(0.81061, abs=1e-5)
    ns = np.array([8, 16, 32])
    for a in (1.0, 3.0, 10.0):
        errs = []
        for n in ns:
            model, b = cantilever(n, P=a)
            res = solve_static(model, load_steps=int(a))
            errs.append(np.abs(_tip(res, b) - ref[a]).max())
        assert errs[-1] < 5e-4, (a, errs)
        assert _order(ns, errs) == pytest.approx(2.0, abs=0.1), (a, errs)


def test_gravity_load_through_the_mass_matrix():
    """Uniform load q = ρA g: δ = qL⁴/8EI + qL²/2GA (Timoshenko), consistent loads from M ĝ."""
    EI, GA, rhoA, g = 1.0, 50.0, 1.0, 1e-5
    q = rhoA * g
    exact = q / (8 * EI) + q / (2 * GA)
    errs = []
    for n in (3, 8):
        model, b = cantilever(n, EI=EI, GA=GA, rhoA=rhoA, gravity=g)
        res = solve_static(model, load_steps=1)
        errs.append(-_tip(res, b)[1] / exact - 1.0)
        # the clamp carries the weight: force of the clamp on the beam = +ρA g L upwards
        np.testing.assert_allclose(res.reaction("b.start")[-1, :2], [0.0, q], atol=1e-12)
        # one-point elements with the consistent load M ĝ are nodally exact for a uniform load
        assert abs(errs[-1]) < 1e-9
