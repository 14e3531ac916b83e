"""The start of femb.contact.simulate on a model whose dependent constraint equations were removed
(Mechanism.compile(redundant="eliminate")): it used to stop with SciPy's bare "Factor is exactly singular"."""
import numpy as np

from femb.benchmarks.scenes.contact import contact_ball
from femb.contact import simulate
from femb.elements import Hinge


def _pendulum(hinges):
    """The bouncing ball hung from a ground point 0.71 m away by ``hinges`` identical hinges: it swings
    down onto the floor (one impact at 0.498 s)."""
    m = contact_ball.build()
    ball = [e for e in m.elements if type(e).__name__ == "RigidBody"][0]
    m.ground.add_point("P", (0.5, 0.5))
    for i in range(hinges):
        m.add(Hinge(f"h{i}", "ground", ball, point_a="P", point_b=(0.5, -0.5)))
    return m


def test_a_duplicated_hinge_eliminated_runs_as_the_single_hinge():
    one = simulate(_pendulum(1).compile(), 0.8, 1e-3)
    two = simulate(_pendulum(2).compile(redundant="eliminate"), 0.8, 1e-3)
    assert len(one.events) == len(two.events) == 1
    assert abs(two.events[0]["t"] - one.events[0]["t"]) < 1e-12
    np.testing.assert_allclose(two.q, one.q, rtol=0, atol=1e-12)
    # the kept hinge carries the single hinge's reaction, the removed equations none
    scale = np.abs(one.lam).max()
    np.testing.assert_allclose(two.lam[:, :2], one.lam, rtol=0, atol=1e-12 * scale)
    assert np.abs(two.lam[:, 2:]).max() <= 1e-12 * scale
