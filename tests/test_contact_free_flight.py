"""Free flights among resting contacts (docs/contact.md §1.1, item 10).

* a sphere at rest on the floor stays closed while another bounces beside it: no impact booked for it
  (before: its round-off ġ_N > 0 counted as leaving, every free flight closed it again, was halved eight
  times and abandoned, and its re-closure was booked as an impact at ġ_N⁻ = −g × 1e-7 s);
* ten spheres dropped from random heights: every sphere's bounces follow Newton's law, each approach
  speed e_N times the one before, down to 1e-4 m/s, although the spheres' impacts and their ends of
  cascade fall into the same steps (before: a slow approach's free flight ended within the Newton
  tolerance of the floor and closed it, was halved, and the halvings used up the splits of the step, so
  another sphere's impact was taken at the step's end: approach ratios of 0.488 instead of 0.5);
* both time loops take the same decisions on these and on the clearance slider–crank's cascades.
"""
import numpy as np
import pytest

from femb import Mechanism
from femb.benchmarks.scenes.contact import contact_slider_crank
from femb.contact import simulate
from femb.elements import SpatialGravity, SpatialRigidBody
from femb.elements.contact import SpatialSphereOnPlane

R, E_N = 0.05, 0.5


def _spheres(heights, seed=2):
    """Spheres of radius R at the given heights above the floor (e_N = 0.5, μ = 0.2), random slips and spins."""
    rng = np.random.default_rng(seed)
    m = Mechanism("drop")
    m.add(SpatialGravity((0.0, 0.0, -9.81)))
    th = 0.4 * R * R
    for i, z in enumerate(heights):
        m.add(SpatialRigidBody(f"s{i}", 1.0, (th,) * 3, position=(0.15 * (i % 6), 0.15 * (i // 6), R + z),
                               velocity=(rng.uniform(-0.1, 0.1), 0.0, 0.0), omega=(0.0, rng.uniform(-3, 3), 0.0)))
        m.add(SpatialSphereOnPlane(f"c{i}", f"s{i}", radius=R, e_N=E_N, mu=0.2))
    return m.compile()


def _approach_speeds(res, name):
    return np.array([-float(np.ravel(e["v_before"])[0]) for e in res.events if e["contact"] == name])


def test_a_sphere_at_rest_books_no_impact_while_another_bounces():
    """One sphere lands, bounces and comes to rest (t∞ ≈ 0.19 s) while the other still bounces (to 0.5 s)."""
    res = simulate(_spheres([0.02, 0.1]), 0.6, 2e-3)
    assert res.success
    for name in ("c0", "c1"):
        v = _approach_speeds(res, name)
        assert v.size >= 8 and np.all(v > 1e-6), name
        fast = v[1:] > 1e-4
        np.testing.assert_allclose(v[1:][fast] / v[:-1][fast], E_N, rtol=1e-3, err_msg=name)
    rest = res.t > 0.25                                  # the first sphere at rest on the floor
    assert np.abs(res.q[rest, 2] - R).max() < 1e-12
    assert np.abs(res.qd[rest, 2]).max() < 1e-9
    assert res.contact["gN"].min() >= -1e-10 * res.model.length_scale


@pytest.mark.parametrize("compiled", [True, False])
def test_ten_spheres_bounce_by_newtons_law_while_the_others_land(compiled):
    heights = np.random.default_rng(2).uniform(0.05, 0.15, 10)
    res = simulate(_spheres(heights), 0.6, 2e-3, compiled=compiled)
    assert res.success
    for i in range(10):
        v = _approach_speeds(res, f"c{i}")
        fast = v[1:] > 1e-4
        ratio = v[1:][fast] / v[:-1][fast]
        assert ratio.size >= 8
        np.testing.assert_allclose(ratio, E_N, rtol=1e-3, err_msg=f"c{i}")
    assert not any(abs(float(np.ravel(e["v_before"])[0])) < 1e-6 for e in res.events)
    assert res.contact["gN"].min() >= -1e-10 * res.model.length_scale


def test_both_loops_take_the_same_cascade_decisions():
    """The clearance slider–crank over 0.0105 s at h = 2e-4 s (h shortened to 0.0105/53): a cascade of
    impacts of the upper corners ends with one touching the guide at g_N of round-off, either side of 0,
    while approaching; the loops took the impact in a substep (a root at 5e-15 s) or at the step's end
    (no root) and parted by 1.7e-7 m. Now such a contact closes at τ = 0 in both."""
    model = contact_slider_crank.build().compile()
    a = simulate(model, 0.0105, 2e-4, compiled=True)
    b = simulate(model, 0.0105, 2e-4, compiled=False)
    assert np.abs(a.q - b.q).max() < 1e-12
    assert len(a.events) >= 10
    assert [(e["contact"], e["step"]) for e in a.events] == [(e["contact"], e["step"]) for e in b.events]
