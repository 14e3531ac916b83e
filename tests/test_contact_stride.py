"""femb.contact.simulate(..., stride=k, store=False): the stored steps are the full run's rows 0, k, 2k, …
and the last, on every loop (compiled and Python, fixed and adaptive steps); events, iterations, the
contact work and the step sizes still cover every step (docs/contact.md §4)."""
import numpy as np
import pytest

from femb.benchmarks.scenes.contact import contact_ball, contact_block, contact_painleve
from femb.contact import compiled as compiled_loop
from femb.contact import simulate
from femb.errors import ContactError, ParameterError

KEYS = ("t", "q", "qd", "qdd", "lam")


def _rows(n, every):
    """The rows a run of n steps stores with stride ``every`` (0: store=False)."""
    keep = [0] + ([k for k in range(1, n + 1) if k % every == 0] if every else [])
    return keep if keep[-1] == n else keep + [n]


def _check(full, part, every):
    rows = _rows(full.t.size - 1, every)
    for key in KEYS:
        np.testing.assert_array_equal(getattr(part, key), getattr(full, key)[rows], err_msg=key)
    for key, v in full.contact.items():
        np.testing.assert_array_equal(part.contact[key], v[rows], err_msg=key)
    assert [(e["t"], e["step"], e["contact"], e["v_after"]) for e in part.events] == \
           [(e["t"], e["step"], e["contact"], e["v_after"]) for e in full.events]
    np.testing.assert_array_equal(part.newton_iterations, full.newton_iterations)
    assert part.stats == full.stats
    e_full, e_part = full.energy(), part.energy()
    for key in ("contact_normal", "contact_friction", "balance"):
        np.testing.assert_array_equal(e_part[key], e_full[key][rows], err_msg=key)


@pytest.mark.parametrize("compiled", [None, False])
def test_fixed_steps_stride_and_store(compiled):
    model = contact_ball.build(e_N=0.5).compile()
    full = simulate(model, 1.5, 2e-3, compiled=compiled)
    assert len(full.events) >= 3
    for every in (7, 1):
        _check(full, simulate(model, 1.5, 2e-3, compiled=compiled, stride=every), every)
    last = simulate(model, 1.5, 2e-3, compiled=compiled, store=False, stride=7)
    assert last.t.size == 2
    _check(full, last, 0)


def test_compiled_window_across_calls(monkeypatch):
    """A window of 5 rows: every call of the compiled loop writes at most 5 steps, the rows kept from each."""
    model = contact_ball.build(e_N=0.5).compile()
    full = simulate(model, 1.0, 2e-3)
    monkeypatch.setattr(compiled_loop, "WINDOW_ROWS", 5)
    for every in (1, 3, 13):
        _check(full, simulate(model, 1.0, 2e-3, stride=every), every)


@pytest.mark.parametrize("compiled", [None, False])
def test_adaptive_stride(compiled):
    model = contact_block.build(mu=0.5).compile()
    full = simulate(model, 1.0, 1e-3, rtol=1e-4, compiled=compiled)
    part = simulate(model, 1.0, 1e-3, rtol=1e-4, compiled=compiled, stride=4)
    _check(full, part, 4)
    np.testing.assert_array_equal(part.h_steps, full.h_steps)
    assert full.h_steps.size == full.t.size - 1 and part.n_rejected == full.n_rejected
    np.testing.assert_allclose(full.h_steps, np.diff(full.t), rtol=0, atol=1e-15)
    assert abs(full.h_steps.sum() - 1.0) < 1e-12


@pytest.mark.parametrize("compiled", [None, False])
def test_failed_run_keeps_the_last_step(compiled):
    """The μ = 5/3 rod dropped at 20 m/s with one fixed-point iteration allowed stops at step 15; the
    partial result ends with the last step taken, stride or not."""
    model = contact_painleve.build(mu=5.0 / 3.0, v0=-20.0, gap=1e-3).compile()
    got = []
    for every in (1, 4, 1000):
        with pytest.raises(ContactError) as err:
            simulate(model, 0.3, 1e-3, max_fixed_point=1, stride=every, compiled=compiled)
        got.append(err.value.result)
    full = got[0]
    assert full.t.size == 15
    for every, part in zip((4, 1000), got[1:]):
        _check(full, part, every)


@pytest.mark.parametrize("bad", [0, -3, 1.5, "2", None])
def test_bad_stride(bad):
    model = contact_ball.build(e_N=0.5).compile()
    with pytest.raises(ParameterError, match="stride"):
        simulate(model, 0.1, 1e-2, stride=bad)


def test_models_and_their_dense_work_arrays_are_freed():
    """The dense path's per-model work arrays (femb.contact.step._dense_model, a WeakKeyDictionary) do not
    keep the model alive: a sweep of many models in one process does not keep them all (until 2026-11-29
    every model used stayed in memory, with its arrays). Also the broad phase's subsets, a new one for
    each change of the contacts in a step."""
    import gc
    import itertools

    from femb.contact import step as contact_step
    from femb import Mechanism
    from femb.elements import SpatialRigidBody
    from femb.elements.contact import SpatialSpherePair

    gc.collect()
    before = len(contact_step._DENSE)
    for _ in range(3):
        model = contact_ball.build().compile()
        simulate(model, 0.01, 1e-3, compiled=False)
        simulate(model, 0.01, 1e-3)
    m = Mechanism("cradle")
    for i in range(12):              # 12 spheres, 66 pairs: the sparse path, with the broad phase
        m.add(SpatialRigidBody(f"s{i}", 1.0, (1e-3,) * 3, position=(0.101 * i, 0.0, 0.0),
                               velocity=(10.0 if i == 0 else 0.0, 0.0, 0.0)))
    for i, j in itertools.combinations(range(12), 2):
        m.add(SpatialSpherePair(f"p{i}_{j}", f"s{i}", f"s{j}", 0.05, 0.05, e_N=1.0))
    res = simulate(m.compile(), 0.01, 1e-3)
    assert res.stats["broad_phase"]["rebuilt"] >= 2
    del model, res
    gc.collect()
    assert len(contact_step._DENSE) == before
