"""References integrated once per process (femb.benchmarks.references.dense): the values at any
later output times are those of a fresh integration, and timed (peer) runs never use the cache."""
import numpy as np
import pytest

from femb.benchmarks.references import andrews, dense, planar_chain
from femb.benchmarks.references import slider_crank_minimal as scm
from femb.benchmarks.scenes.planar import bead_attractor, force_pulse


@pytest.fixture(autouse=True)
def _empty():
    dense.clear()
    yield
    dense.clear()


def _irregular(t_end, n, seed=0):
    return np.sort(np.random.default_rng(seed).uniform(0.0, t_end, n))


def test_andrews_from_the_cache_equals_a_fresh_integration():
    t_long, t = np.linspace(0.0, 0.03, 26), _irregular(0.02, 200)
    andrews.solve(t_long, cache=True)                   # fills the cache to 0.03 s
    n_kept = len(dense._SOLUTIONS)
    got = andrews.solve(t, cache=True)
    assert len(dense._SOLUTIONS) == n_kept == 1          # evaluated, not integrated again
    want = andrews.solve(t)
    for k in ("angles", "rates", "lam"):
        scale = np.abs(want[k]).max()
        assert np.abs(got[k] - want[k]).max() < 1e-10 * scale, k
    assert len(dense._SOLUTIONS) == 1                    # the uncached (timed) call kept nothing


def test_a_later_time_integrates_again_and_other_data_are_other_entries():
    scm.solve(np.array([0.1, 0.2]), cache=True)
    scm.solve(np.array([0.5]), cache=True)              # beyond the kept end: integrated again, replaced
    assert len(dense._SOLUTIONS) == 1 and next(iter(dense._SOLUTIONS.values()))[0] == 0.5
    scm.solve(np.array([0.5]), cache=True, k=2.0 * scm.PARAMS["k"])
    scm.solve(np.array([0.5]), cache=True, rtol=1e-10, atol=1e-10)
    assert len(dense._SOLUTIONS) == 3
    a = scm.solve(np.array([0.3, 0.5]), cache=True, k=2.0 * scm.PARAMS["k"])
    b = scm.solve(np.array([0.3, 0.5]), k=2.0 * scm.PARAMS["k"])
    assert np.abs(a["theta"] - b["theta"]).max() < 1e-10


@pytest.mark.parametrize("scene", [bead_attractor, force_pulse])
def test_chain_references_with_loads_and_a_fine_window(scene):
    """The force pulse splits its run at the pulse (a capped step there): the pieces are kept too."""
    t_end = 1.0
    scene.reference(np.linspace(0.0, t_end, 11))
    t = _irregular(t_end, 150, seed=1)
    got = scene.reference(t)
    dense.clear()
    want = scene.reference(t)                           # integrated to t[-1] only
    for k, v in want.items():
        if k != "description":
            assert np.abs(np.asarray(got[k]) - v).max() <= 1e-9 * max(1.0, np.abs(v).max()), k


def test_the_key_tells_chains_apart():
    ch1 = planar_chain.Chain([1.0], [0.0], [1.0], [1.0])
    ch2 = planar_chain.Chain([1.0], [0.0], [2.0], [2.0])
    t = np.array([0.0, 0.5, 1.0])
    a = planar_chain.solve(ch1, t, [0.3], [0.0], key="same")
    b = planar_chain.solve(ch2, t, [0.3], [0.0], key="same")
    assert len(dense._SOLUTIONS) == 2 and not np.allclose(a["phi"], b["phi"])
    assert a["phi"][0, 0] == b["phi"][0, 0] == 0.3


def test_bad_times_are_refused():
    with pytest.raises(ValueError, match="increasing"):
        andrews.solve(np.array([0.02, 0.01]), cache=True)
    with pytest.raises(ValueError, match="increasing"):
        andrews.solve(np.array([-0.01, 0.01]))
