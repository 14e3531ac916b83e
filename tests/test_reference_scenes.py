"""femb's step-size scenes at small fixed steps against their independent references.

Every scene is built from femb elements (the bead's attractor through the
public element contract) and compared over a short interval with its
minimal-coordinate reference (``femb.benchmarks.references``): the angles
converge with order 2 and agree to the measured level, the multipliers agree
to the measured level (their start-up error is first order today when the
motion starts with velocity; tests/test_stepsize.py holds the second-order
target for them).
"""
import math

import numpy as np
import pytest

import femb
from femb.study import registry

#: scene: (t_end, position outputs, multiplier outputs, bound on max position error at h = 1e-3,
#:         bound on max multiplier error at h = 1e-3 (N or N m)); bounds ≈ 1.5× the measured values
CASES = {
    "double_pendulum": (0.3, ["phi1", "phi2"], ["R_pivot_x", "R_pivot_y"], 1e-5, 0.2),
    "two_bar_pendulum": (0.5, ["phi1", "phi2"], ["R_pivot_x", "R_pivot_y"], 5e-6, 6e-4),
    "spring_pendulum": (0.5, ["phi1"], ["R_pivot_x", "R_pivot_y"], 1.1e-5, 6.5e-4),
    "force_pulse": (1.1, ["phi1"], ["R_pivot_x", "R_pivot_y"], 6e-5, 2.3e-2),
    "bead_attractor": (1.5, ["phi1"], ["R_pivot_x", "R_pivot_y"], 4e-5, 0.3),
    "fourbar_driven": (0.3, ["theta3_d"], ["T_drive", "R_O_x", "R_O_y"], 5e-6, 8e-2),
}


def _errors(name, h):
    scene = registry.load(name)
    t_end, qn, ln, _, _ = CASES[name]
    r = femb.simulate(scene.model(), t_end, h, rho_inf=scene.defaults["rho_inf"])
    out, ref = scene.outputs(r), scene.reference(r.t)
    eq = max(np.max(np.abs(out[k] - ref[k])) for k in qn)
    el = max(np.max(np.abs(out[k] - ref[k])) for k in ln)
    return eq, el


@pytest.mark.parametrize("name", sorted(CASES))
def test_scene_agrees_with_reference_with_second_order_positions(name):
    _, _, _, bound_q, bound_l = CASES[name]
    eq1, el1 = _errors(name, 2e-3)
    eq2, el2 = _errors(name, 1e-3)
    assert eq2 < bound_q, f"{name}: max position error {eq2:.3g} at h = 1e-3"
    assert el2 < bound_l, f"{name}: max multiplier error {el2:.3g} at h = 1e-3"
    assert math.log2(eq1 / eq2) > 1.8, f"{name}: position order {math.log2(eq1 / eq2):.2f}"


def test_references_describe_themselves():
    for name in CASES:
        ref = registry.load(name).reference(np.array([0.0, 0.1]))
        assert "femb.benchmarks.references." in ref["description"]


def test_initial_state_is_the_reference_state():
    """At t = 0 the femb model and the reference start from the same angles and rates."""
    for name in CASES:
        scene = registry.load(name)
        r = femb.simulate(scene.model(), 1e-3, 1e-3)
        out, ref = scene.outputs(r), scene.reference(np.array([0.0]))
        for k in CASES[name][1]:
            assert out[k][0] == pytest.approx(ref[k][0], abs=1e-12), (name, k)
