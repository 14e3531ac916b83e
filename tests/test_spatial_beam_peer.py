"""femb's spatial beam against Exudyn's ObjectBeamGeometricallyExact (benchmarks/cost/spatial_beam_peer.py).

Skipped when Exudyn is not installed. On the small model (n = 10 elements, the
first 10 ms after release under gravity, h = 1e-4 s, ρ∞ = 0.7):

* the two codes' tip trajectories agree within their discretization errors, in
  every Exudyn setting that the benchmark times (Euler-parameter nodes with three
  Newton settings, Lie-group nodes with the stalled residual accepted).
  Both are second-order approximations in time of the same semi-discrete
  beam (same SE(3) element, stiffness, translational mass and loads; only the
  rotary inertia is lumped in femb and consistent in Exudyn, and the rotation
  parameters differ), so at the same h their difference is bounded by the sum
  of their errors, each estimated from its own h → h/2 change as
  e(h) ≈ (4/3)|x(h) − x(h/2)| (Richardson, order 2);
* Exudyn's translational mass matrix is the consistent one that femb's
  ``mass="consistent"`` uses (the match the benchmark relies on);
* femb's cheaper Newton setting (modified Newton, residual test 1e-4) gives the
  same trajectory within the same bound;
* the timing function runs and reports its figures (no timings are asserted).
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from femb.benchmarks.cost import spatial_beam_peer as P

pytestmark = pytest.mark.skipif(P.exudyn_version() is None, reason="Exudyn not installed")


@pytest.fixture(scope="module")
def comparison():
    return P.compare(10, t_end=0.01)


def test_tip_agrees_within_discretization_error(comparison):
    c = comparison
    assert "error" not in c, c.get("error")
    assert c["tip_z"] < -5e-4                                   # the rod has bent (≈ −0.72 mm at 10 ms)
    # each code converges in h: its h → h/2 change is small against the deflection
    assert c["femb_h2"] < 1e-3 * abs(c["tip_z"])
    assert c["exudyn_h2"] < 1e-3 * abs(c["tip_z"])
    bound = 4.0 / 3.0 * (c["femb_h2"] + c["exudyn_h2"])
    assert c["femb_residual"] <= bound                          # femb's modified-Newton setting
    assert set(c["diff"]) == set(P.EXUDYN_SETTINGS)              # every timed Exudyn setting
    for key, d in c["diff"].items():
        assert d <= bound, (key, d, c["femb_h2"], c["exudyn_h2"])
        # pointwise in time as well: z of the tip at every step of h
        assert np.abs(c["femb"][:, 2] - c["exudyn"][key][:, 2]).max() <= bound


def test_exudyn_translational_mass_is_consistent():
    import exudyn as exu
    from exudyn.solver import ComputeLinearizedSystem

    n = 2
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        SC, mbs, tip, _ = P.exudyn_build(n)
        M = np.asarray(ComputeLinearizedSystem(mbs, exu.SimulationSettings())[0])
    rhoA = P.section_properties()[4]
    le = P.DATA["L"] / n
    # node 0: coordinates 0..6 (x, y, z, 4 Euler parameters), node 1: 7..13
    assert M[0, 0] == pytest.approx(rhoA * le / 3.0, rel=1e-12)
    assert M[0, 7] == pytest.approx(rhoA * le / 6.0, rel=1e-12)
    assert M[7, 7] == pytest.approx(2.0 * rhoA * le / 3.0, rel=1e-12)     # interior node: two elements


def test_measure_reports_both_codes():
    r = P.measure(10, runs=1, steps=20)
    assert r["steps"] == 20
    assert set(r["femb"]) == set(P.FEMB_SETTINGS)
    for f in r["femb"].values():
        assert f["ms"] > 0 and f["newton"] >= 1
    for key in P.EXUDYN_SETTINGS:
        e = r["exudyn"][key]
        assert "error" not in e, e
        assert e["ms"] > 0 and e["newton"] >= 1
        for k, f in r["femb"].items():
            assert e["ratio"][k] == pytest.approx(f["ms"] / e["ms"])
