"""The spin-up beam built in 3-D (benchmarks/scenes/beams/spin_up_3d.py) converges to the planar scene's limit.

Both models are second order in the mesh; their difference at t = 2 s falls at order 2
(measured 2.00, 2.00 for n = 4 → 8 → 16), and the motion stays in the x–y plane.
"""
import numpy as np

import femb
from femb.study import registry


def test_difference_to_the_planar_scene_falls_at_order_two_and_stays_in_plane():
    sc = registry.load("spin_up_3d")
    c = sc.module.mesh_comparison((4, 8, 16), t_end=2.0, h=1e-3)
    assert np.all(np.abs(c["orders"] - 2.0) < 0.1), c["orders"]
    assert c["diff"][-1] < 1e-6 * abs(c["tip_2d"][-1])
    assert np.all(c["out_of_plane"] == 0.0)


def test_registered_scene_outputs_and_reactions():
    sc = registry.load("spin_up_3d")
    r2 = femb.simulate(registry.load("spin_up").model(n_elements=4), 1.0, 5e-3, rho_inf=0.7)
    r3 = femb.simulate(sc.model(n_elements=4), 1.0, 5e-3, rho_inf=0.7)
    o2, o3 = registry.load("spin_up").outputs(r2), sc.outputs(r3)
    # the hub torque and the root moment of the two models agree to the mesh difference
    for k in ("root_moment", "hub_torque"):
        scale = np.abs(o2[k]).max()
        assert np.abs(o3[k] - o2[k]).max() < 1e-3 * scale, k
    assert np.all(o3["out_of_plane"] == 0.0)
