"""The slider–crank benchmark built from femb elements (seed paper, Sect. 5.1).

The yardstick is the independent minimal-coordinate model
(``femb.benchmarks.references.slider_crank_minimal``: Lagrange's equations in
(θ, x4), solve_ivp at rtol = atol = 1e-12), never femb itself. Data:
docs/benchmarks.md §1.
"""
import math

import numpy as np
import pytest

import femb
from femb.benchmarks.accuracy.convergence import convergence_study, run
from femb.benchmarks.scenes.planar import slider_crank as sc


def test_scene_is_built_from_elements():
    model = sc.build().compile()
    # 2 rigid bodies (x, y, θ) + 2 point masses (x, y): 10 coordinates; 3 hinges (2 each)
    # + 2 point-on-line joints (1 each): 8 constraints (seed Sect. 5.1 also has 10 and 8)
    assert (model.nq, model.nc) == (10, 8)
    assert {"pivot", "crank_rod", "rod_slider", "guide_slider", "guide_mass"} <= set(model.lam_index)
    assert model.element_types["spring"] == "SpringDamper"
    assert model.element_types["torque"] == "Torque"


def test_initial_state_and_acceleration():
    res, out = run("slider_crank", t_end=5e-3, h=5e-3, store=True)
    x3_0 = math.sqrt(0.6 ** 2 - 0.3 ** 2)   # docs/benchmarks.md §1: x3 = sqrt(l2² − l1²)
    assert out["theta"][0] == pytest.approx(math.pi / 2, abs=1e-14)
    assert out["x3"][0] == pytest.approx(x3_0, abs=1e-14)
    assert out["x4"][0] == pytest.approx(x3_0 + 0.2, abs=1e-14)   # spring undeformed at t = 0
    # crank vertical, rod translating: θ̈(0) = T / (l1² (m1/3 + m2 + m3)) (virtual power, bars uniform)
    th_dd0 = 1.0 / (0.3 ** 2 * (0.36 / 3 + 0.15 + 0.1))
    assert res.body("crank", "qdd")[0, 2] == pytest.approx(th_dd0, rel=1e-10)


@pytest.fixture(scope="module")
def study():
    return convergence_study("slider_crank", h=[2e-3, 1e-3, 5e-4, 2.5e-4], rho_inf=0.7)


def test_second_order_in_theta_and_pivot_reaction(study):
    # seed, Sect. 5.1 / Fig. 3: second order in the coordinates and the multipliers (ρ∞ = 0.7)
    assert study["q_names"] == ["theta"]
    assert study["lambda_names"] == ["R_pivot_x", "R_pivot_y"]
    assert study["order_q"] >= 1.9
    assert study["order_lambda"] >= 1.9
    assert "solve_ivp" in study["reference"]
    assert all(e < 1e-2 for e in study["error_q"])


@pytest.fixture(scope="module")
def fine():
    res, out = run("slider_crank", h=1e-4, store=True, stride=100)
    return res, out, sc.reference(res.t)


def test_final_angle_matches_minimal_coordinates(fine):
    res, out, ref = fine
    assert res.t[-1] == pytest.approx(1.0)
    # θ(1) = 7.4146249855 rad from the minimal-coordinate reference (its docstring)
    assert ref["theta"][-1] == pytest.approx(7.4146249855, abs=1e-9)
    assert abs(out["theta"][-1] - ref["theta"][-1]) < 1e-3


def test_trajectory_and_pivot_reaction_follow_the_reference(fine):
    res, out, ref = fine
    assert np.abs(out["theta"] - ref["theta"]).max() < 1e-4
    assert np.abs(out["x4"] - ref["x4"]).max() < 1e-5
    # hinge "pivot" has the ground as body a: λ is the force of the ground on the crank,
    # the reference's R_pivot (Newton–Euler on the free bodies)
    scale = np.abs(np.stack([ref["R_pivot_x"], ref["R_pivot_y"]])).max()
    for name in ("R_pivot_x", "R_pivot_y"):
        assert np.abs(out[name] - ref[name]).max() < 1e-3 * scale


def test_build_parameters_reach_the_model():
    # torque doubled: the crank turns faster than with the published data
    _, base = run("slider_crank", t_end=0.2, h=1e-3)
    _, fast = run("slider_crank", t_end=0.2, h=1e-3, params={"T": 2.0})
    assert fast["theta"][-1] > base["theta"][-1] + 0.05
    with pytest.raises(ValueError):
        sc.build(l1=0.7, l2=0.6)
    assert isinstance(sc.build(), femb.Mechanism)
