"""The spatial scenes build, start on their constraints and carry consistent velocities.

They cannot run before the Lie-group time loop exists; these checks use the
joints' compiled kernels directly (femb.benchmarks.spatial_common).
"""
import numpy as np
import pytest

from femb.benchmarks import bricard, heavy_top, spatial_double_pendulum, spatial_slider_crank
from femb.benchmarks.spatial_common import initial_constraints, redundancy

SCENES = {"heavy_top": (heavy_top, 6, 3, 3), "spatial_slider_crank": (spatial_slider_crank, 18, 17, 17),
          "bricard": (bricard, 30, 30, 29), "spatial_double_pendulum": (spatial_double_pendulum, 12, 10, 10)}


@pytest.mark.parametrize("name", sorted(SCENES))
def test_scene_starts_on_its_constraints(name):
    mod, nv, nc, rank = SCENES[name]
    assert set(mod.DEFAULTS) >= {"t_end", "h", "rho_inf"}
    chk = initial_constraints(mod.build())
    assert chk["nv"] == nv and chk["B"].shape == (nc, nv)
    np.testing.assert_allclose(chk["Phi"], 0.0, atol=1e-15)
    np.testing.assert_allclose(chk["velocity_residual"], 0.0, atol=1e-13)
    r, dependent, gap = redundancy(chk["B"])
    assert r == rank, (name, r, dependent)
    if name == "bricard":
        assert len(dependent) == 1 and gap < 1e-12


def test_slider_crank_initial_velocities_are_the_published_ones():
    mech = spatial_slider_crank.build()
    rod, slider = mech["rod"], mech["slider"]
    np.testing.assert_allclose(rod.node.qd0[:3], (0.12, -0.24, 0.0), atol=1e-15)
    np.testing.assert_allclose(rod.node.rotation0 @ rod.node.qd0[3:], (1.92, -0.96, 0.48), atol=1e-14)
    np.testing.assert_allclose(slider.node.qd0[:3], (0.24, 0.0, 0.0), atol=1e-15)


def test_heavy_top_initial_state():
    top = heavy_top.build()["top"]
    np.testing.assert_allclose(top.node.qd0, (4.61538, 0, 0, 0, 150, -4.61538), atol=1e-15)
    np.testing.assert_allclose(top.node.q0, (0, 1, 0, 1, 0, 0, 0))
