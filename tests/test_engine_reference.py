"""The engine split by stage (femb/engine/) and its named fields reproduce the engine of one file
(femb/step.py, commit 3a193aa) to round-off: Andrews with the defaults and the seed's settings and
its Newton iteration counts, the heavy top with index 3 and index 2, and a spatial beam scene
(data: tests/data/make_engine_split_reference.py)."""
from pathlib import Path

import numpy as np
import pytest

import femb
from femb.benchmarks.scenes.beams import spin_up_3d
from femb.benchmarks.scenes.planar import andrews
from femb.benchmarks.scenes.spatial import heavy_top

REF = np.load(Path(__file__).parent / "data" / "engine_split_reference.npz")
#: round-off of a different CPU or BLAS; on the machine the data were written on, the runs are bit-identical
RTOL = 1e-10


def close(a, ref):
    scale = max(float(np.abs(ref).max()), 1e-300)
    assert float(np.abs(np.asarray(a) - ref).max()) <= RTOL * scale


def test_andrews_1000_steps_and_newton_counts():
    m = andrews.build().compile()
    r = femb.simulate(m, 1000 * 3e-5, 3e-5)
    close(r.q[::100], REF["andrews_q"])
    close(r.lam[-1], REF["andrews_lam"])
    np.testing.assert_array_equal(r.newton_iterations, REF["andrews_it"])
    r = femb.simulate(m, 1000 * 3e-5, 3e-5, newton_test="residual", start="seed", check_every=0)
    close(r.q[-1], REF["andrews_seed_q"])
    np.testing.assert_array_equal(r.newton_iterations, REF["andrews_seed_it"])


@pytest.mark.parametrize("form", ["index3", "index2"])
def test_heavy_top(form):
    top = heavy_top.build().compile()
    r = femb.simulate(top, 0.2, 1e-3, formulation=form)
    close(r.q[::20], REF[f"top_{form}_q"])
    close(r.lam[-1], REF[f"top_{form}_lam"])
    np.testing.assert_array_equal(r.newton_iterations, REF[f"top_{form}_it"])


def test_spatial_beam_spin_up():
    beam = spin_up_3d.build(8).compile()
    r = femb.simulate(beam, 0.1, 1e-3)
    close(r.q[-1], REF["beam_q"])
    close(r.lam[-1], REF["beam_lam"])
    np.testing.assert_array_equal(r.newton_iterations, REF["beam_it"])
