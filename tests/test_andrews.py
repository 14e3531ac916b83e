"""Andrews' squeezing mechanism built from femb elements (seed paper, Sect. 5.2).

Published values: IVP test set (Mazzia & Magherini, release 2.4, problem
``andrews``; PSIDE at rtol = atol = 1e-14), which carries the data and initial
values of Hairer & Wanner, Solving ODEs II, Sect. VII.7 (docs/benchmarks.md §2).
Intermediate times: the independent relative-coordinate model
``femb.benchmarks.references.andrews`` (solve_ivp, rtol = atol = 1e-12).
"""
import numpy as np
import pytest

from femb.benchmarks.accuracy.convergence import convergence_study, fit_order, run
from femb.benchmarks.scenes.planar import andrews as an

ANGLES = list(an.ANGLE_NAMES)
LAMS = list(an.LAMBDA_NAMES)


def test_model_size():
    model = an.build().compile()
    # 7 bodies × 3 absolute coordinates, 10 hinges × 2 constraints (docs/benchmarks.md §2)
    assert (model.nq, model.nc) == (21, 20)


def test_consistent_initial_values_match_published():
    res, out = run("andrews", t_end=1e-5, h=1e-5, store=True)
    for k, name in enumerate(ANGLES):
        assert out[name][0] == pytest.approx(an.ANGLES0[k], abs=1e-12)
    # β̈(0) = 14222.4439199541..., Θ̈(0) = −10666.8329399655... (Hairer & Wanner VII.7; IVP test set)
    assert out["beta_dd"][0] == pytest.approx(14222.4439199541138705911625887, rel=1e-9)
    assert out["Theta_dd"][0] == pytest.approx(-10666.8329399655854029433719415, rel=1e-9)
    # λ(0) = (98.5668703962..., −6.1226883442..., 0, 0, 0, 0) (IVP test set initial values):
    # the hinges E23, E24, E26 carry the published multipliers with their signs
    lam0 = [out[n][0] for n in LAMS]
    np.testing.assert_allclose(lam0, [98.5668703962410896057654982170, -6.12268834425566265503114393122,
                                      0, 0, 0, 0], rtol=1e-9, atol=1e-8)


@pytest.fixture(scope="module")
def study():
    return convergence_study("andrews", h=[1e-5, 5e-6, 2.5e-6, 1.25e-6], rho_inf=0.7)


def test_second_order_in_angles_and_multipliers(study):
    # seed, Sect. 5.2 / Fig. 9: second order in q and λ at ρ∞ = 0.7
    assert study["q_names"] == ANGLES and study["lambda_names"] == LAMS
    assert study["order_q"] >= 1.9
    assert study["order_lambda"] >= 1.9
    assert "published" in study["reference"]


def test_finest_run_matches_published_angles(study):
    # published angles at t = 0.03 (IVP test set, PSIDE rtol = atol = 1e-14): the study's
    # reference for the angles; absolute error of the finest run below 1e-4 rad
    assert study["error_q_abs"][-1] < 1e-4
    pub = an.published()
    angles = dict(zip(study["q_names"], study["q_final"][-1]))
    assert max(abs(angles[n] - pub[n]) for n in ANGLES) < 1e-4
    # the 15.8 rad the crank turns: β(0.03) = 15.81077119629904 (IVP test set)
    assert angles["beta"] == pytest.approx(15.81077119629904, abs=1e-4)
    # multipliers in the published order and sign convention (IVP test set, accurate to ~1e-6):
    # λ = 199.175333373191, −29.75531228015052, 23.06654119098399, 31.45271365475927,
    #     22.64249232082739, 11.61740700019673
    lam = np.array(study["lambda_final"][-1])
    published_lam = np.array([199.175333373191, -29.75531228015052, 23.06654119098399,
                              31.45271365475927, 22.64249232082739, 11.61740700019673])
    assert np.abs(lam - published_lam).max() < 1e-3 * np.abs(published_lam).max()


@pytest.fixture(scope="module")
def medium():
    res, out = run("andrews", h=1e-5, store=True, stride=100)
    return res, out, an.reference(res.t)


def test_trajectory_follows_relative_coordinate_reference(medium):
    res, out, ref = medium
    # error ≈ 1.2e-4 rad at h = 1e-5 (second order, 1.2e6 h²); along the whole run
    for name in ANGLES:
        assert np.abs(out[name] - ref[name]).max() < 3e-4, name
    scale = max(np.abs(ref[n]).max() for n in LAMS)
    for name in LAMS:
        assert np.abs(out[name] - ref[name]).max() < 5e-4 * scale, name


def test_point_P_acceleration_is_consistent_with_positions():
    res, out = run("andrews", t_end=0.006, h=1e-6, store=True, stride=1)
    h = res.t[1] - res.t[0]
    i = res.t.size // 2
    for x in ("xP", "yP"):
        fd = (out[x][i + 1] - 2 * out[x][i] + out[x][i - 1]) / h ** 2
        assert fd == pytest.approx(out[x + "_dd"][i], rel=1e-3, abs=1.0)


def test_mirror_chains_omega_equals_minus_phi():
    # the chains A–5–4 and A–7–6 are mirror images: Ω = −Φ for all t (docs/benchmarks.md §2).
    # Kinematic, so it holds to the Newton tolerance on Φ (1e-12 × length scale ≈ 7e-14 m
    # over links of 0.02 m): bound 1e-10 rad
    res, out = run("andrews", h=1e-4, store=True)
    assert np.abs(out["Omega"] + out["Phi"]).max() < 1e-10


def test_energy_balance_is_second_order():
    # T + V − mom·β is constant along exact solutions (docs/benchmarks.md §2)
    hs = [1e-4, 5e-5, 2.5e-5]
    drift = []
    for h in hs:
        res, out = run("andrews", h=h, store=True)
        E = an.energy(res)
        drift.append(np.abs(E - E[0]).max())
    work = 0.033 * np.abs(out["beta"] - out["beta"][0]).max()   # work of the torque, ≈ 0.52 J
    assert drift[-1] < 1e-3 * work
    assert fit_order(hs, drift) >= 1.9


def test_undamped_scheme_makes_multipliers_oscillate():
    # seed, Fig. 8: with ρ∞ = 1 the multipliers oscillate (not strictly stable at infinity)
    def roughness(rho):
        _, out = run("andrews", rho_inf=rho, store=True)
        lam = out["lambda_1"]
        return np.abs(np.diff(lam, 2)).sum()

    assert roughness(1.0) > 3 * roughness(0.7)


def test_outputs_names():
    res, out = run("andrews", t_end=3e-4, h=3e-4)
    expected = (ANGLES + [n + "_d" for n in ANGLES] + [n + "_dd" for n in ANGLES]
                + ["xP", "yP", "xP_dd", "yP_dd"] + LAMS)
    assert set(expected) <= set(out)
    assert all(np.shape(v) == (res.t.size,) for v in out.values())
