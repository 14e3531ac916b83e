"""The contact step's Newton test on stiff fine meshes: an iterate whose regular Newton increment is below
the tolerance is converged, though round-off keeps its residual above it (femb.contact.core.increment_size,
docs/contact.md §1.1, item 11)."""
import numpy as np
import pytest

from femb.benchmarks.scenes.contact import contact_beam_stop
from femb.contact import core, simulate


def test_a_fine_beam_converges_in_three_iterations_a_step():
    """The beam on the stop with 100 elements (the sparse path, 1840 unknowns) swinging freely: its
    residual's round-off floor is about 2e-11 m, above the tolerance 1e-12 m; before the increment test
    every step ran to 40 iterations, was halved and fell back to the fixed point (170 s for 10 steps)."""
    model = contact_beam_stop.build(n_elements=100).compile()
    res = simulate(model, 0.003, 1e-3)
    assert res.status == "success"
    assert res.stats["substeps"] == res.stats["steps"] == 3
    assert res.stats["fixed_point_steps"] == 0
    assert res.newton_iterations.max() <= 4
    assert np.all(np.isfinite(res.q))


def test_the_compiled_and_python_dense_loops_accept_the_same_iterates():
    """30 elements (the dense path; its floor is above the tolerance too): the compiled loop and the Python
    loop take the same iterations and give the same trajectory."""
    model = contact_beam_stop.build(n_elements=30).compile()
    a = simulate(model, 0.004, 1e-3)
    b = simulate(model, 0.004, 1e-3, compiled=False)
    assert a.newton_iterations.max() <= 4 and a.stats["fixed_point_steps"] == 0
    np.testing.assert_array_equal(a.newton_iterations, b.newton_iterations)
    np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-12)


@pytest.mark.parametrize("block, weight", [(0, 1e-6), (1, 1e-3), (2, 1.0), (3, 0.5), (4, 5e-4), (5, 5e-7),
                                           (6, 0.5), (7, 5e-4), (8, 5e-7), (9, 5e-4), (10, 5e-7)])
def test_increment_size_weighs_each_block_as_its_rows(block, weight):
    """One unit in one block of dx: u̇, U, Q times h², h, 1 (a rotation times the length scale 1/w = 2); the
    multipliers κ, Λ, λ of the joints and the contacts times 1/m, h/m, h²/m (h = 1e-3, m = 2)."""
    o = np.arange(0, 23, 2, dtype=np.int64)          # two unknowns per block
    w = np.array([1.0, 0.5])                         # a translation and a rotation (length scale 2)
    par = np.zeros(16)
    par[0], par[4] = 1e-3, 2.0
    for a in range(2):
        dx = np.zeros(22)
        dx[o[block] + a] = 1.0
        expected = weight / w[a] if block < 3 else weight
        assert core.increment_size(dx, o, w, par) == pytest.approx(expected, rel=1e-14)
