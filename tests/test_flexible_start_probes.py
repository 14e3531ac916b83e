"""Driven flexible closed loops started from rest as users start rigid ones (femb/system/initial.py,
docs/stepsize.md §2 "Flexible models"), on loops the start was not tuned on: an R–S–U–R linkage
with a skew rocker axis and a steel beam coupler, and a planar slider-crank with a flexible rod;
the driver at full speed from t = 0, the beams undeformed under gravity, the user's default
options (index 3, ρ∞ = 0.7).

Each runs at h = 1 ms and 0.5 ms with material damping 0, 1e-4 and 1e-3 s, every output the
result lists is finite, and with a stiff beam (E, G × 10⁴) the t = 0 drive reaction is the rigid
coupler's.
"""
import numpy as np
import pytest

import femb
from femb.benchmarks.accuracy.flexible_start import skew_rsur, slider_crank


LOOPS = {"skew_rsur": (skew_rsur, "drive.Mz"), "slider_crank": (slider_crank, "drive.M")}


def _all_finite(r):
    bad = [nm for nm in r.outputs() if not np.all(np.isfinite(r.series(nm)[0]))]
    assert bad == [], bad


@pytest.mark.parametrize("loop", sorted(LOOPS))
@pytest.mark.parametrize("h", [1e-3, 5e-4])
@pytest.mark.parametrize("damping", [0.0, 1e-4, 1e-3])
def test_driven_flexible_loop_runs_from_rest_on_the_defaults(loop, h, damping):
    build, _ = LOOPS[loop]
    r = femb.simulate(build(damping=damping).compile(), 0.05, h)
    assert r.steps == round(0.05 / h)
    _all_finite(r)
    # heavy damping fell back to the seed's start (its O(h) transient in λ): the damped modes
    # kept the strain rates of the mass-weighted start and their jerk was not resolved by h
    assert r.settings["start_used"] == "consistent"


@pytest.mark.parametrize("loop", sorted(LOOPS))
@pytest.mark.parametrize("damping", [0.0, 1e-4, 1e-3])
def test_stiff_beam_t0_reaction_is_the_rigid_couplers(loop, damping):
    # measured: skew R-S-U-R 1.1e-4, 1.1e-4, 1.0e-4 (−0.134422, −0.134422, −0.134421 N m against
    # −0.134407; before the multipliers at the settled positions 1.1, 1.1, 1.0 %); slider-crank
    # to 1e-6; over the first 10 steps 0.7, 0.9, 2.7 % and 0.03, 0.04, 0.13 %
    build, key = LOOPS[loop]
    rigid = femb.simulate(build(rigid=True).compile(), 0.01, 1e-3).series(key)[0]
    flex = femb.simulate(build(stiffness=1e4, damping=damping).compile(), 0.01, 1e-3).series(key)[0]
    assert abs(flex[0] - rigid[0]) < 0.05 * abs(rigid[0]), (flex[0], rigid[0])
    assert np.abs(flex - rigid).max() < 0.05 * np.abs(rigid).max()


@pytest.mark.parametrize("h", [1e-3, 5e-4, 2.5e-4])
def test_stiff_beam_t0_reaction_does_not_drift_as_h_falls(h):
    # the start's multipliers were taken at the positions before settling, whose strain
    # accelerations are O(x), x = 1/(1 + c_K ω²) ∝ 1/h²: 1.1 %, 4.2 %, 15 % off the rigid coupler's
    # at h = 1, 0.5, 0.25 ms (E × 10⁴). Measured now 1.1e-4, 1.7e-3, 2.2e-2
    rigid = femb.simulate(skew_rsur(rigid=True).compile(), 2 * h, h).series("drive.Mz")[0][0]
    flex = femb.simulate(skew_rsur(stiffness=1e4).compile(), 2 * h, h).series("drive.Mz")[0][0]
    assert abs(flex - rigid) < {1e-3: 1e-3, 5e-4: 5e-3, 2.5e-4: 0.04}[h] * abs(rigid), (flex, rigid)


def test_stiff_heavily_damped_beam_starts():
    # E × 10⁴ with η = 1e-3 s at h = 0.25 ms: the damped weight M + c_K (K + Cᵀ M_l⁻¹ C) is numerically singular
    # (η² ω⁴ c_K ≫ 1); the start raised InitializationError ("velocity projection: singular
    # matrix") instead of keeping the start without the damping term
    r = femb.simulate(skew_rsur(stiffness=1e4, damping=1e-3).compile(), 5e-3, 2.5e-4)
    assert r.steps == 20
    _all_finite(r)
