"""Newton's cradle: simultaneous impacts by the generalized Newton law, and impacts in sequence
(docs/contact.md §3)."""
import numpy as np
import pytest

from femb import Mechanism
from femb.contact import simulate
from femb.elements import SpatialRigidBody
from femb.elements.contact import SpatialSpherePair

R = 0.05


def _cradle(gap, e_N=1.0, k=5):
    mech = Mechanism("cradle")
    th = 0.4 * R * R
    for i in range(k):
        x = (2 * R + gap) * i if gap > 0 else 2 * R * i - (0.01 if i == 0 else 0.0)
        mech.add(SpatialRigidBody(f"b{i}", 1.0, (th,) * 3, position=(x, 0.0, 0.0),
                                  velocity=(1.0 if i == 0 else 0.0, 0.0, 0.0)))
    for i in range(k - 1):
        mech.add(SpatialSpherePair(f"p{i}", f"b{i}", f"b{i + 1}", R, R, e_N=e_N))
    return mech.compile()


@pytest.mark.parametrize("e_N", [1.0, 0.5])
def test_touching_spheres_take_one_simultaneous_impact(e_N):
    r = simulate(_cradle(0.0, e_N), 0.1, 1e-3)
    v = r.qd[-1][0::6]
    # generalized Newton law on the chain: the four at rest move together after the impact
    v1 = (1.0 - 4.0 * e_N) / 5.0
    v2 = (1.0 + e_N) / 5.0
    np.testing.assert_allclose(v, [v1, v2, v2, v2, v2], rtol=0, atol=1e-12)
    assert v.sum() == pytest.approx(1.0, abs=1e-12)
    if e_N == 1.0:
        assert 0.5 * (v ** 2).sum() == pytest.approx(0.5, abs=1e-12)


@pytest.mark.parametrize("h", [1e-3, 1e-2])
def test_spheres_with_gaps_pass_the_impulse_on(h):
    r = simulate(_cradle(1e-3), 0.1, h)
    np.testing.assert_allclose(r.qd[-1][0::6], [0.0, 0.0, 0.0, 0.0, 1.0], rtol=0, atol=1e-12)
    times = [e["t"] for e in r.events]
    assert [e["contact"] for e in r.events] == ["p0", "p1", "p2", "p3"]
    np.testing.assert_allclose(times, [1e-3, 2e-3, 3e-3, 4e-3], rtol=0, atol=2e-6)
    assert r.contact["gN"].min() >= -1e-10 * r.model.length_scale
