"""Result.beam: centre line, section frames, resultants and strains of a meshed spatial beam."""
import math

import numpy as np
import pytest

import femb
from femb import Mechanism
from femb.analysis.static import solve_static
from femb.elements.spatial_beam import SpatialSection, spatial_beam
from femb.elements.spatial_forces import SpatialForce, SpatialTorque
from femb.errors import ModelError


def test_rollup_circle_strains_forces_and_frames():
    L, EI, n = 10.0, 100.0, 6
    m = Mechanism("rollup")
    sec = SpatialSection.from_properties(1e4, 1e4, 1e4, 1e2, EI, EI)
    spatial_beam(m, "b", sec, [(0, 0, 0), (L, 0, 0)], n, start="clamp")
    M = 2.0 * math.pi * EI / L
    m.add(SpatialTorque("M", "b.n6", (0.0, 0.0, M)))
    res = solve_static(m.compile(), load_steps=12)
    bs = res.beam("b")
    nt = len(res.t)
    assert bs.centre_line.shape == (nt, n + 1, 3) and bs.frames.shape == (nt, n + 1, 3, 3)
    assert bs.forces.shape == (nt, n, 6) and bs.strains.shape == (nt, n, 6)
    assert bs.nodes == [f"b.n{k}" for k in range(n + 1)]
    for k, mu in enumerate(res.t):
        kap = mu * M / EI
        exp = np.zeros(6)
        exp[5] = kap
        assert np.abs(bs.strains[k] - exp).max() < 1e-9
        assert np.abs(bs.force("M3")[k] - mu * M).max() < 1e-9 * M
        assert np.abs(bs.forces[k, :, :5]).max() < 1e-9 * M
        for j, s in enumerate(bs.arc_length):        # e1 is the circle's tangent, e3 stays z
            assert np.allclose(bs.frames[k, j, :, 0], (math.cos(kap * s), math.sin(kap * s), 0.0), atol=1e-9)
            assert np.allclose(bs.frames[k, j, :, 2], (0.0, 0.0, 1.0), atol=1e-9)
    assert np.allclose(bs.kappa[..., 2], bs.strains[..., 5])


def test_cantilever_resultant_signs():
    """Tip force F e_z and F e_x (linear range): Q3 = F, M2 = −F (L − s_mid), N = F (tension)."""
    L, F = 2.0, 1e-3
    m = Mechanism("cant")
    sec = SpatialSection.from_properties(1e8, 1e8, 1e8, 1e6, 1e6, 1e6)
    b = spatial_beam(m, "c", sec, [(0, 0, 0), (L, 0, 0)], 4, start="clamp")
    m.add(SpatialForce("F", b.nodes[-1], (F, 0.0, F)))
    res = solve_static(m.compile())
    bs = res.beam("c")
    smid = 0.5 * (bs.arc_length[:-1] + bs.arc_length[1:])
    assert np.allclose(bs.force("N")[-1], F, rtol=1e-5)
    assert np.allclose(bs.force("Q3")[-1], F, rtol=1e-5)
    assert np.allclose(bs.force("M2")[-1], -F * (L - smid), rtol=1e-5)
    assert np.abs(bs.force("Q2")[-1]).max() < 1e-9 and np.abs(bs.force("M3")[-1]).max() < 1e-9


def test_dynamic_beam_and_unknown_name():
    from femb.study import registry
    r = femb.simulate(registry.load("spin_up_3d").model(n_elements=4), 0.2, 0.01)
    bs = r.beam("beam")
    assert bs.centre_line.shape == (len(r.t), 5, 3)
    assert np.abs(bs.centre_line[..., 2]).max() == 0.0
    assert np.allclose(bs.centre_line[:, -1], r.body("beam.n4")[:, 0:3])
    with pytest.raises(ModelError):
        r.beam("nope")
