"""The sparse path's Newton solve by the triangular (unit) rows of J first (femb.contact.step._solve_unit_rows):
the rows of contacts that are open and stay open give their unknowns at once, and the LU is of the rest
(docs/contact.md §7, "Sphere pairs")."""
import itertools

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from femb.benchmarks.scenes.contact import contact_spheres
from femb.contact import simulate
from femb.contact import step as contact_step
from femb.elements.contact import SpatialSpherePair


def _system(n_rest, n_unit, seed=0):
    """A sparse J whose last rows are unit rows after two rounds (the first: one entry on the diagonal;
    the second: the diagonal and a column of the first), the rest coupled to everything."""
    rng = np.random.default_rng(seed)
    n = n_rest + 2 * n_unit
    J = sp.lil_matrix((n, n))
    for i in range(n_rest):
        J[i, i] = 4.0 + rng.random()
        for j in rng.choice(n, 5, replace=False):
            J[i, j] += rng.standard_normal()
    for k in range(n_unit):
        a, b = n_rest + k, n_rest + n_unit + k
        J[a, a] = 1.0 + rng.random()
        J[b, b] = 2.0 + rng.random()
        J[b, a] = rng.standard_normal()
        J[b, n_rest + (k + 1) % n_unit] = 0.0          # a stored zero: not a coupling
    return J.tocsc(), rng.standard_normal(n)


def test_unit_rows_first_give_the_solution_of_the_whole_system():
    J, b = _system(60, 100)
    y = contact_step._solve_unit_rows(J, b)
    assert y is not None
    np.testing.assert_allclose(y, spla.spsolve(J, b), rtol=0, atol=1e-12 * np.abs(y).max())


def test_too_few_unit_rows_leave_the_whole_system_to_the_caller():
    J, b = _system(400, 40)          # 80 of 480 rows: under a quarter
    assert contact_step._solve_unit_rows(J, b) is None
    J, b = _system(20, 20)           # 40 rows: under UNIT_ROWS_MIN
    assert contact_step._solve_unit_rows(J, b) is None


def _pile(n):
    """n spheres rolling on the floor with every pair declared (most of them far apart)."""
    mech = contact_spheres.build(n=n)
    for i, j in itertools.combinations(range(n), 2):
        mech.add(SpatialSpherePair(f"p{i}_{j}", f"s{i}", f"s{j}", radius_a=0.05, radius_b=0.05, mu=0.3))
    return mech.compile()


def test_a_pile_with_every_pair_declared_runs_as_with_the_whole_lu(monkeypatch):
    """(Without the broad phase, which leaves the far pairs out of the steps: tests/test_contact_broadphase.py.)"""
    model = _pile(12)
    calls = []
    solve = contact_step._solve_unit_rows

    def spy(J, b, passes=8):
        y = solve(J, b, passes)
        calls.append(y is not None)
        return y
    monkeypatch.setattr(contact_step, "_solve_unit_rows", spy)
    fast = simulate(model, 0.01, 1e-3, broad_phase=False)
    assert calls and all(calls)                       # every Newton step took the unit rows first
    monkeypatch.setattr(contact_step, "UNIT_ROWS_MIN", 10 ** 9)
    whole = simulate(model, 0.01, 1e-3, broad_phase=False)
    np.testing.assert_allclose(fast.q, whole.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(fast.contact["lam_N"], whole.contact["lam_N"], rtol=0,
                               atol=1e-9 * np.abs(whole.contact["lam_N"]).max())
    np.testing.assert_array_equal(fast.newton_iterations, whole.newton_iterations)


@pytest.mark.parametrize("passes", [1, 8])
def test_friction_rows_need_a_second_round(passes):
    """An open contact's friction rows depend on its normal force (the disc's radius): known in the second
    round only; one round leaves them, and their contact's coupling, to the LU."""
    J, b = _system(10, 200)
    y = contact_step._solve_unit_rows(J, b, passes)
    np.testing.assert_allclose(y, spla.spsolve(J, b), rtol=0, atol=1e-12 * np.abs(y).max())
