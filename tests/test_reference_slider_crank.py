"""Checks of the minimal-coordinate slider-crank reference model.

The reference (``femb.benchmarks.references.slider_crank_minimal``) is the
yardstick for femb's slider-crank benchmark (docs/benchmarks.md section 1),
so it is checked here against facts that do not depend on its own equations
of motion: energy conservation, closed-form kinematics, a hand-computed
initial acceleration, and the Newton-Euler balance of every free body with
accelerations obtained by finite differences of the computed velocities.
"""

import math

import numpy as np
import pytest

from femb.benchmarks.references import slider_crank_minimal as sc

T_CHECK = np.array([0.1, 0.37, 0.62, 0.91])  # times of the Newton-Euler checks
H_FD = 1e-4  # finite-difference step [s] of the fourth-order central difference


@pytest.fixture(scope="module")
def sol():
    return sc.solve(np.linspace(0.0, 1.0, 401))


def _fd_solution(**overrides):
    """Solution at T_CHECK, T_CHECK -/+ H_FD, T_CHECK -/+ 2 H_FD (one integration)."""
    t = np.sort(np.concatenate([T_CHECK + j * H_FD for j in (-2, -1, 0, 1, 2)]))
    s = sc.solve(t, **overrides)
    idx = np.searchsorted(t, T_CHECK)
    return s, idx


def _fd(s, name, idx):
    """Fourth-order central difference of s[name] at indices idx."""
    v = s[name]
    return (8 * (v[idx + 1] - v[idx - 1]) - (v[idx + 2] - v[idx - 2])) / (12 * H_FD)


def test_energy_is_conserved(sol):
    e = sc.energy(sol)
    p = sol["params"]
    scale = np.max(np.abs(p["T"] * (sol["theta"] - p["theta0"])))  # work of T
    assert scale > 1.0  # the crank really turns (about 5.8 J of work in 1 s)
    assert np.ptp(e) / scale < 1e-9


def test_initial_state_matches_closed_form(sol):
    p = sol["params"]
    x3_0 = math.sqrt(0.6**2 - 0.3**2)  # docs/benchmarks.md section 1
    assert sol["t"][0] == 0.0
    assert sol["theta"][0] == pytest.approx(math.pi / 2, abs=1e-15)
    assert sol["x3"][0] == pytest.approx(x3_0, abs=1e-15)
    assert sol["x4"][0] == pytest.approx(x3_0 + 0.2, abs=1e-15)
    for name in ("theta_d", "x3_d", "x4_d", "x1_d", "y1_d", "x2_d", "y2_d", "phi2_d"):
        assert sol[name][0] == 0.0
    # at theta = pi/2 the rod translates instantaneously (phi2' = 0), so the
    # virtual power gives theta_dd = T / (l1^2 (m1/3 + m2 + m3)); spring unstretched
    th_dd0 = p["T"] / (p["l1"] ** 2 * (p["m1"] / 3 + p["m2"] + p["m3"]))
    assert sol["theta_dd"][0] == pytest.approx(th_dd0, rel=1e-13)
    assert sol["x4_dd"][0] == pytest.approx(0.0, abs=1e-12)  # round-off of x3 + L0


def test_kinematic_closure_along_the_motion(sol):
    p = sol["params"]
    l1, l2 = p["l1"], p["l2"]
    tip = np.column_stack([l1 * np.cos(sol["theta"]), l1 * np.sin(sol["theta"])])
    slider = np.column_stack([sol["x3"], np.zeros_like(sol["x3"])])
    np.testing.assert_allclose(np.linalg.norm(slider - tip, axis=1), l2, rtol=1e-14)
    # rod centre at mid-span, rod angle along tip -> slider
    np.testing.assert_allclose(sol["x2"], 0.5 * (tip[:, 0] + slider[:, 0]), atol=1e-15)
    np.testing.assert_allclose(sol["y2"], 0.5 * tip[:, 1], atol=1e-15)
    d = slider - tip
    ang = np.arctan2(d[:, 1], d[:, 0])
    np.testing.assert_allclose(sol["phi2"], ang, atol=1e-14)
    np.testing.assert_allclose(sol["x1"], 0.5 * tip[:, 0], atol=1e-15)


def test_kinematic_derivatives_by_finite_differences():
    p = sc.params()
    th = np.linspace(0.0, 2 * np.pi, 17)
    h = 1e-6
    k0, km, kp = (sc.kinematics(th + dh, p) for dh in (0.0, -h, h))
    for name in ("x1", "y1", "x2", "y2", "phi2", "x3"):
        np.testing.assert_allclose(k0[name + "_p"], (kp[name] - km[name]) / (2 * h),
                                   atol=1e-8)
        np.testing.assert_allclose(k0[name + "_pp"], (kp[name + "_p"] - km[name + "_p"]) / (2 * h),
                                   atol=1e-8)


@pytest.mark.parametrize("overrides", [{}, {"g": 9.81, "k": 5000.0, "m2": 0.3}],
                         ids=["benchmark", "gravity-stiffer"])
def test_reactions_satisfy_newton_euler(overrides):
    s, i = _fd_solution(**overrides)
    p = s["params"]
    m1, m2, m3, m4, g = p["m1"], p["m2"], p["m3"], p["m4"], p["g"]
    # accelerations independently, by differencing the velocities
    a1 = np.column_stack([_fd(s, "x1_d", i), _fd(s, "y1_d", i)])
    al1 = _fd(s, "phi1_d", i)
    a2 = np.column_stack([_fd(s, "x2_d", i), _fd(s, "y2_d", i)])
    al2 = _fd(s, "phi2_d", i)
    a3 = _fd(s, "x3_d", i)
    a4 = _fd(s, "x4_d", i)

    Rp, Rcr, Rrs = s["R_pivot"][i], s["R_crank_rod"][i], s["R_rod_slider"][i]
    Ns, N4, Fs = s["N_slider"][i], s["N_mass4"][i], s["spring_force"][i]
    th, x3 = s["theta"][i], s["x3"][i]
    tip = np.column_stack([p["l1"] * np.cos(th), p["l1"] * np.sin(th)])
    slider = np.column_stack([x3, np.zeros_like(x3)])
    c1 = np.column_stack([s["x1"][i], s["y1"][i]])
    c2 = np.column_stack([s["x2"][i], s["y2"][i]])
    grav = lambda m: np.column_stack([np.zeros_like(th), -m * g * np.ones_like(th)])  # noqa: E731

    def cross(u, v):
        return u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]

    # measured residuals: <= 3e-10 * force_scale (truncation of the difference
    # formula, ~H_FD**4); a wrong sign or a missing term gives O(1)
    force_scale = max(np.max(np.abs(Rp)), np.max(np.abs(Rcr)), np.max(np.abs(Fs)))
    tol_f = 1e-8 * force_scale
    tol_m = tol_f * p["l2"]
    # crank: pivot force, pin force from the rod (= -R_crank_rod), torque T
    np.testing.assert_allclose(m1 * a1, Rp - Rcr + grav(m1), atol=tol_f)
    np.testing.assert_allclose(p["J1"] * al1,
                               p["T"] + cross(-c1, Rp) + cross(tip - c1, -Rcr), atol=tol_m)
    # rod: R_crank_rod at the tip, -R_rod_slider at the slider
    np.testing.assert_allclose(m2 * a2, Rcr - Rrs + grav(m2), atol=tol_f)
    np.testing.assert_allclose(p["J2"] * al2,
                               cross(tip - c2, Rcr) + cross(slider - c2, -Rrs), atol=tol_m)
    # slider: rod, spring (along x) and guide (along y only)
    np.testing.assert_allclose(m3 * a3, Rrs[:, 0] + Fs, atol=tol_f)
    np.testing.assert_allclose(0.0, Rrs[:, 1] + Ns - m3 * g, atol=tol_f)
    # extra mass: spring reaction along x, guide along y
    np.testing.assert_allclose(m4 * a4, -Fs, atol=tol_f)
    np.testing.assert_allclose(N4, m4 * g, atol=1e-15)


def test_guide_forces_are_vertical_and_zero_without_gravity(sol):
    # the guide reactions are scalars (y components only): the whole x motion
    # of slider and mass 4 is explained by the rod and spring forces
    assert sol["N_slider"].shape == sol["t"].shape
    assert sol["N_mass4"].shape == sol["t"].shape
    np.testing.assert_array_equal(sol["N_mass4"], 0.0)
    # the guide force on the slider balances the rod's vertical push
    np.testing.assert_allclose(sol["N_slider"], -sol["R_rod_slider"][:, 1], atol=1e-12)
    assert np.max(np.abs(sol["N_slider"])) > 0.1


def test_overrides_and_stiff_radau_agree():
    t = np.linspace(0.0, 0.2, 5)
    a = sc.solve(t, k=1e5)
    b = sc.solve(t, k=1e5, method="Radau", rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(a["theta"], b["theta"], atol=1e-8)
    np.testing.assert_allclose(a["x4"], b["x4"], atol=1e-9)
    e = sc.energy(a)
    assert np.ptp(e) < 1e-9 * max(1.0, np.max(np.abs(e)))
    with pytest.raises(KeyError):
        sc.solve(t, not_a_parameter=1.0)
