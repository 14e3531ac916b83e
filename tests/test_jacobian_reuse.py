"""The iteration matrix carried over steps (femb/engine/layout.py, ``carry_rule``): when it applies, that it
converges to the same tolerance as one fresh matrix per step, and that it is refreshed."""
import numpy as np
import pytest

import femb
import femb.engine as S
from femb.benchmarks.cost.spatial_beam_scaling import build as rod
from femb.benchmarks.scenes.planar import andrews
from femb.benchmarks.scenes.spatial import rigid_chain_3d
from femb.engine import layout


@pytest.fixture
def per_step(monkeypatch):
    """Make every model factorize once per step (the rule's size threshold out of reach)."""
    def use():
        monkeypatch.setattr(layout, "NEWTON_CARRY_MIN_N", 10 ** 12)     # read by carry_rule
    return use


def test_rule():
    """Band systems of ≥ NEWTON_CARRY_MIN_N unknowns with the correction rule, index 3 only."""
    n = S.NEWTON_CARRY_MIN_N
    assert S.carry_rule(n, False, True, False) == 1
    assert S.carry_rule(n - 1, False, True, False) == 0
    assert S.carry_rule(n, True, True, False) == 0            # dense storage
    assert S.carry_rule(n, False, False, False) == 0          # residual rule
    assert S.carry_rule(n, False, True, True) == 0            # index 2


def test_small_models_keep_one_matrix_per_step():
    """Andrews (41 unknowns): one factorization per step, as before (tests/test_compiled_loop.py
    compares its trajectory and Newton counts bit for bit)."""
    r = femb.simulate(andrews.build().compile(), 3e-3, 3e-5, rho_inf=0.7, linear_solver="band")
    assert r.settings["newton_matrix"] == "per step"
    assert r.stats["factorizations"] >= r.stats["steps"]


def _same_accuracy(model, t_end, h, rho_inf, per_step):
    """Runs with the carried matrix, with a fresh one per step and (per step) with h/4: the
    carried run's error against the h/4 run is the per-step run's to 1 %, and the two runs
    differ by less than 1 % of that error (q and q̇ at t_end). Returns the carried run."""
    r = femb.simulate(model, t_end, h, rho_inf=rho_inf)
    assert r.settings["newton_matrix"] == "carried"
    per_step()
    ref = femb.simulate(model, t_end, h, rho_inf=rho_inf)
    assert ref.settings["newton_matrix"] == "per step"
    assert ref.stats["factorizations"] >= ref.stats["steps"]
    fine = femb.simulate(model, t_end, h / 4, rho_inf=rho_inf)
    for a in ("q", "qd"):
        x, x_ref, x_fine = getattr(r, a)[-1], getattr(ref, a)[-1], getattr(fine, a)[-1]
        err, err_ref = np.abs(x - x_fine).max(), np.abs(x_ref - x_fine).max()
        assert err_ref > 0.0
        assert abs(err / err_ref - 1.0) <= 0.01, (a, err, err_ref)
        assert np.abs(x - x_ref).max() <= 1e-2 * err_ref, (a, np.abs(x - x_ref).max(), err_ref)
    return r


def test_beam_carries_its_matrix_with_the_same_accuracy(per_step):
    """A 200-element cantilever (1200 unknowns): a handful of factorizations in 100 steps, at most
    three corrections per step, and the accuracy of one fresh matrix per step."""
    r = _same_accuracy(rod(200).compile(), 100 * 1e-4, 1e-4, 0.7, per_step)
    assert r.stats["factorizations"] <= 5
    assert r.newton_iterations.max() <= 3


def test_chain_refreshes_a_slowly_contracting_matrix(per_step):
    """A chain of 100 bricks on spherical joints (1100 unknowns): the carried matrix contracts more
    slowly than a fresh one (its carried rate passes NEWTON_CARRY_ETA), so it is refreshed every
    few steps; the accuracy is that of a fresh matrix per step."""
    r = _same_accuracy(rigid_chain_3d.build(n=100).compile(), 0.1, 1e-3, 0.8, per_step)
    assert 1 < r.stats["factorizations"] <= r.stats["steps"] // 2           # measured 31 in 100 steps


def test_adaptive_steps_carry_it_while_h_stays(per_step):
    """Adaptive steps limited by h_max (the chain of 100 bricks): the matrix is carried while h stays
    the same (after a step with a carried matrix, a change of h re-synchronises the normal velocity
    with a KKT factorization at the accepted state), and the run agrees with the per-step one well
    within rtol."""
    model = rigid_chain_3d.build(n=100).compile()
    r = femb.simulate(model, 0.05, rtol=1e-4, h_max=1e-3)
    assert r.settings["newton_matrix"] == "carried"
    assert r.stats["factorizations"] < r.stats["steps"]
    per_step()
    ref = femb.simulate(model, 0.05, rtol=1e-4, h_max=1e-3)
    assert ref.stats["factorizations"] >= ref.stats["steps"]
    assert np.abs(r.q[-1] - ref.q[-1]).max() <= 1e-5 * np.abs(ref.q[-1] - ref.q[0]).max()
