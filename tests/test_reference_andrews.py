"""Checks of the Andrews squeezing-mechanism reference model.

The reference (``femb.benchmarks.references.andrews``) is the yardstick for
femb's Andrews benchmark (docs/benchmarks.md section 2).  Its closed-form
``M, f, g, G`` are checked against the body table of docs/benchmarks.md
(kinetic energy of the seven bodies, hinge closure, Newton-Euler moment
balances of every body with the multipliers as the forces at E) and its
solution against the published values of the IVP test set (Mazzia &
Magherini, problem ``andrews``, PSIDE at rtol = atol = 1e-14).
"""

import numpy as np
import pytest

from femb.benchmarks.references import andrews as an

P = an.PARAMS
PUB = an.PUBLISHED_T003


@pytest.fixture(scope="module")
def run():
    """Trajectory on [0, 0.03] with the default (reference) settings."""
    return an.solve(np.linspace(0.0, 0.03, 61))


def _random_state(seed):
    """Angles within 1 rad of Q0 (not consistent) and rates of order 100 rad/s."""
    rng = np.random.default_rng(seed)
    return an.Q0 + rng.uniform(-1.0, 1.0, 7), 100.0 * rng.normal(size=7)


def _cross(u, v):
    return u[0] * v[1] - u[1] * v[0]


# ----------------------------------------------------------------- initial values

def test_initial_values_are_consistent():
    np.testing.assert_allclose(an.constraints(an.Q0), 0.0, atol=1e-12)
    # spring length at t = 0 (docs/benchmarks.md section 2)
    assert an.spring_length(an.Q0) == pytest.approx(0.0526725161107, abs=1e-13)
    assert an.Y0.shape == (14,)
    np.testing.assert_array_equal(an.Y0[7:], 0.0)


def test_initial_accelerations_and_multipliers():
    qdd, lam = an.accelerations(an.Q0, an.QD0)
    # Hairer & Wanner VII.7 / IVP test set: beta'' = 14222.44..., Theta'' = -10666.83...
    assert qdd[0] == pytest.approx(14222.4439199541138705911625887, rel=1e-13)
    assert qdd[1] == pytest.approx(-10666.8329399655854029433719415, rel=1e-13)
    np.testing.assert_allclose(qdd[2:], 0.0, atol=1e-9)
    # IVP test set initial multipliers (98.566..., -6.1226..., 0, 0, 0, 0)
    np.testing.assert_allclose(lam, an.LAM0, rtol=1e-13, atol=1e-12)


# ------------------------------------------------ closed forms vs the body table

def _points(q):
    """World positions of the named points of every body, from body_frames."""
    fr = an.body_frames(q)
    out = {}
    for k, pts in an.hinge_points().items():
        x, y, phi = fr[k - 1]
        c, s = np.cos(phi), np.sin(phi)
        for name, r in pts.items():
            out[(k, name)] = np.array([x + c * r[0] - s * r[1], y + s * r[0] + c * r[1]])
    return out


@pytest.mark.parametrize("trial", range(3))
def test_constraints_are_hinge_closures_of_the_body_table(trial):
    q, _ = _random_state(trial)
    pt = _points(q)
    # ground hinges hold by construction of the walk
    np.testing.assert_allclose(pt[(1, "O")], 0.0, atol=1e-15)
    np.testing.assert_allclose(pt[(3, "B")], [P["xb"], P["yb"]], atol=1e-15)
    np.testing.assert_allclose(pt[(5, "A")], [P["xa"], P["ya"]], atol=1e-15)
    np.testing.assert_allclose(pt[(7, "A")], [P["xa"], P["ya"]], atol=1e-15)
    np.testing.assert_allclose(pt[(1, "P")], pt[(2, "P")], atol=1e-15)
    np.testing.assert_allclose(pt[(4, "F")], pt[(5, "F")], atol=1e-15)
    np.testing.assert_allclose(pt[(6, "G")], pt[(7, "G")], atol=1e-15)
    g_table = np.concatenate([pt[(2, "E")] - pt[(3, "E")], pt[(2, "E")] - pt[(4, "E")],
                              pt[(2, "E")] - pt[(6, "E")]])
    np.testing.assert_allclose(an.constraints(q), g_table, atol=1e-15)
    C = np.array([P["xc"], P["yc"]])
    assert an.spring_length(q) == pytest.approx(np.linalg.norm(pt[(3, "D")] - C), abs=1e-15)


def test_jacobian_and_bias_by_finite_differences():
    q, qd = _random_state(10)
    h = 1e-6
    G_fd = np.column_stack([(an.constraints(q + h * ei) - an.constraints(q - h * ei)) / (2 * h)
                            for ei in np.eye(7)])
    np.testing.assert_allclose(an.constraint_jacobian(q), G_fd, atol=1e-10)
    # g_qq(q', q') = d/ds [G(q + s q') q'] at s = 0
    s = 1e-8
    bias_fd = (an.constraint_jacobian(q + s * qd) @ qd
               - an.constraint_jacobian(q - s * qd) @ qd) / (2 * s)
    np.testing.assert_allclose(an.constraint_bias(q, qd), bias_fd, rtol=1e-6, atol=1e-6)


def _body_jacobians(q, h=1e-6):
    """d(x_k, y_k, phi_k)/dq by central differences, shape (7, 3, 7)."""
    cols = [(an.body_frames(q + h * ei) - an.body_frames(q - h * ei)) / (2 * h) for ei in np.eye(7)]
    return np.stack(cols, axis=-1)


@pytest.mark.parametrize("trial", range(3))
def test_mass_matrix_is_the_kinetic_energy_of_the_seven_bodies(trial):
    q, _ = _random_state(20 + trial)
    J = _body_jacobians(q)
    M = np.zeros((7, 7))
    for k in range(7):
        m, i = P[f"m{k + 1}"], P[f"i{k + 1}"]
        M += m * J[k, :2].T @ J[k, :2] + i * np.outer(J[k, 2], J[k, 2])
    np.testing.assert_allclose(an.mass_matrix(q), M, rtol=1e-8, atol=1e-14)
    Mq = an.mass_matrix(q)
    np.testing.assert_array_equal(Mq, Mq.T)
    assert np.all(np.linalg.eigvalsh(Mq) > 0)


def test_forces_follow_from_lagrange():
    q, qd = _random_state(30)
    h = 1e-6
    # quadratic velocity terms: -(M' q' - 1/2 grad(q'^T M q'))
    Mdot = (an.mass_matrix(q + h * qd) - an.mass_matrix(q - h * qd)) / (2 * h)
    grad_T = np.array([(qd @ an.mass_matrix(q + h * ei) @ qd - qd @ an.mass_matrix(q - h * ei) @ qd)
                       / (4 * h) for ei in np.eye(7)])
    f_quad = -(Mdot @ qd - grad_T)
    # applied: torque mom on beta, spring -dV/dgamma
    V = lambda qq: 0.5 * P["c0"] * (an.spring_length(qq) - P["l0"]) ** 2  # noqa: E731
    f_app = np.array([-(V(q + h * ei) - V(q - h * ei)) / (2 * h) for ei in np.eye(7)])
    f_app[0] += P["mom"]
    f = an.forces(q, qd)
    scale = np.max(np.abs(f))
    np.testing.assert_allclose(f, f_quad + f_app, atol=1e-7 * scale)


# ---------------------------------------------- multipliers as reactions at E

def _centre_accelerations(q, qd, qdd):
    """Centre accelerations and angular accelerations of the bodies, (7, 3).

    Fourth-order second difference of body_frames along the path
    q(s) = q + s q' + s^2/2 q'', whose second s-derivative at s = 0 is the
    true acceleration J q'' + (dJ/dt) q'.
    """
    s = 1e-3 / max(np.max(np.abs(qd)), np.max(np.abs(qdd)) ** 0.5)
    c = {j: an.body_frames(q + j * s * qd + 0.5 * (j * s) ** 2 * qdd) for j in (-2, -1, 0, 1, 2)}
    return (16 * (c[1] + c[-1]) - (c[2] + c[-2]) - 30 * c[0]) / (12 * s**2)


@pytest.mark.parametrize("t", [0.0, 0.012, 0.03])
def test_multipliers_are_the_forces_at_E_newton_euler(t):
    """lam_(2j-1,2j) = force of the rod on triangle 3 / body 4 / body 6 at E.

    Every body's moment balance (about a hinge point), with the spring and
    torque as applied loads, closes with these forces; this pins down the sign
    convention M q'' = f - G^T lam independently of M, f and G.
    """
    if t == 0.0:
        q, qd = an.Q0, an.QD0
        qdd, lam = an.accelerations(q, qd)
    else:
        s = an.solve([t])
        q, qd, qdd, lam = s["angles"][0], s["rates"][0], s["accelerations"][0], s["lam"][0]
    acc = _centre_accelerations(q, qd, qdd)
    fr = an.body_frames(q)
    pt = _points(q)
    F3, F4, F6 = lam[0:2], lam[2:4], lam[4:6]  # forces of the rod at E
    D, C = pt[(3, "D")], np.array([P["xc"], P["yc"]])
    L = np.linalg.norm(D - C)
    F_spring = -P["c0"] * (L - P["l0"]) * (D - C) / L  # on D

    def dH(k, about):
        """Rate of angular momentum of body k about the point `about`."""
        c, a = fr[k - 1, :2], acc[k - 1]
        return P[f"i{k}"] * a[2] + P[f"m{k}"] * _cross(c - about, a[:2])

    O, A, B = np.zeros(2), pt[(5, "A")], pt[(3, "B")]
    E = pt[(2, "E")]
    balances = [
        # crank + rod about O: torque, and the sum of the reactions on the rod at E
        (dH(1, O) + dH(2, O), P["mom"] + _cross(E - O, -(F3 + F4 + F6))),
        # rod about P
        (dH(2, pt[(2, "P")]), _cross(E - pt[(2, "P")], -(F3 + F4 + F6))),
        # triangle about B: spring at D, rod at E
        (dH(3, B), _cross(D - B, F_spring) + _cross(pt[(3, "E")] - B, F3)),
        # body 4 about F, bodies 4 + 5 about A
        (dH(4, pt[(4, "F")]), _cross(pt[(4, "E")] - pt[(4, "F")], F4)),
        (dH(4, A) + dH(5, A), _cross(pt[(4, "E")] - A, F4)),
        # body 6 about G, bodies 6 + 7 about A
        (dH(6, pt[(6, "G")]), _cross(pt[(6, "E")] - pt[(6, "G")], F6)),
        (dH(6, A) + dH(7, A), _cross(pt[(6, "E")] - A, F6)),
    ]
    lhs, rhs = np.array(balances).T
    # moment scale: the largest single term (|lam| * lever ~ 200 N * 0.03 m)
    scale = np.max(np.abs(lam)) * 0.03
    # measured residuals <= 3.3e-9 * scale (truncation and round-off of the
    # difference formula); a sign error in lam gives O(1) * scale
    np.testing.assert_allclose(lhs, rhs, atol=1e-7 * scale)


# --------------------------------------------------- published solution at t = 0.03

@pytest.fixture(scope="module")
def at_003():
    return an.solve([0.03])


def test_matches_published_angles(at_003):
    # published accuracy 3e-10 relative, |beta| = 15.8 rad -> 5e-9 rad;
    # measured: max 1.4e-9 rad (Theta), gamma 1.1e-11 rad
    np.testing.assert_allclose(at_003["angles"][0], PUB["angles"], rtol=0, atol=5e-9)


def test_matches_published_velocities(at_003):
    qd = at_003["rates"][0]
    # measured 1.3e-10 relative on beta', Theta'
    np.testing.assert_allclose(qd[:2], [PUB["beta_d"], PUB["Theta_d"]], rtol=5e-10)
    # published accuracy about 5e-8 relative; measured max 5.1e-8 (epsilon')
    np.testing.assert_allclose(qd, PUB["rates"], rtol=1e-7)


def test_matches_published_multipliers_and_accelerations(at_003):
    # published accuracy about 1e-6; measured max 1.26e-6 relative (lam6),
    # the others <= 3.7e-7; our own solution is converged to ~2e-11 relative
    np.testing.assert_allclose(at_003["lam"][0], PUB["lam"], rtol=2e-6)
    # measured max 1.3e-6 relative (epsilon'')
    np.testing.assert_allclose(at_003["accelerations"][0], PUB["accelerations"], rtol=3e-6)


def test_reference_is_converged_in_the_tolerance(at_003):
    tight = an.solve([0.03], rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(at_003["angles"], tight["angles"], atol=2e-12)
    np.testing.assert_allclose(at_003["lam"], tight["lam"], rtol=1e-9)


# ---------------------------------------------------------------- invariants

def test_energy_is_conserved(run):
    e = an.energy(run["angles"], run["rates"])
    work = P["mom"] * np.ptp(run["angles"][:, 0])  # ~0.52 J done by the torque
    assert work > 0.5
    assert np.ptp(e) < 1e-10 * work  # measured 2.6e-12 relative


def test_mirror_symmetry_and_constraint_drift(run):
    q, qd = run["angles"], run["rates"]
    np.testing.assert_allclose(q[:, 5], -q[:, 3], atol=1e-12)  # Omega = -Phi
    np.testing.assert_allclose(qd[:, 5], -qd[:, 3], atol=1e-9)
    g = np.array([an.constraints(qi) for qi in q])
    assert np.max(np.abs(g)) < 1e-12  # index-1 drift, measured ~1e-14 m
    gd = np.array([an.constraint_jacobian(qi) @ vi for qi, vi in zip(q, qd)])
    assert np.max(np.abs(gd)) < 1e-9  # measured ~4e-12 m/s
