"""Dynamics of spatial beams with femb.simulate: the right-angle cantilever (Simo & Vu-Quoc 1988;
../shared/docs/spatial.md §7.5), benchmarks/right_angle_cantilever.py."""
import numpy as np
import pytest

import femb
from femb.benchmarks import registry
from femb.benchmarks import right_angle_cantilever as scene
from femb.elements.spatial_beam import SpatialBeam


@pytest.fixture(scope="module")
def model():
    return scene.build(10).compile()


def _energy(model, r):
    g = [g for g in model.groups if g.cls is SpatialBeam][0]
    E = []
    for q, v in zip(r.q, r.qd):
        qx = model.ext(q)
        E.append(0.5 * v @ (model.M_const @ v) + SpatialBeam.strain_energy(g.params, qx[g.xdofs]).sum())
    return np.array(E)


def test_registered_scene():
    s = registry.load("right_angle_cantilever")
    assert s.module is scene


def test_second_order_in_h(model):
    """Tip z, elbow z, tip x at t = 4 s: errors against h = 0.00625 fall by 4 per halving of h
    (measured 8.5e-3, 2.1e-3, 5.1e-4 m for h = 0.1, 0.05, 0.025)."""
    out = {}
    for h in (0.1, 0.05, 0.025, 0.00625):
        o = scene.outputs(femb.simulate(model, 4.0, h, rho_inf=0.95))
        out[h] = np.array([o["tip_z"][-1], o["elbow_z"][-1], o["tip_x"][-1]])
    err = [np.abs(out[h] - out[0.00625]).max() for h in (0.1, 0.05, 0.025)]
    assert err[0] < 1.5e-2
    orders = np.log2(np.array(err[:-1]) / np.array(err[1:]))
    assert np.all(orders > 1.8)


def test_energy_after_the_pulse(model):
    """Free vibration after t = 2 s: kinetic + strain energy varies by O(h²) (4.2e-4 at h = 0.05)."""
    r = femb.simulate(model, 30.0, 0.05, rho_inf=0.95)
    E = _energy(model, r)
    k = np.searchsorted(r.t, 2.0)
    assert (E[k:].max() - E[k:].min()) / E[k] < 1e-3
    o = scene.outputs(r)
    assert 5.0 < np.abs(o["tip_z"]).max() < 15.0 and np.all(np.isfinite(r.q))


def test_stiffness_proportional_damping_dissipates():
    model = scene.build(5, damping=0.02).compile()
    r = femb.simulate(model, 12.0, 0.05, rho_inf=0.95)
    E = _energy(model, r)
    k = np.searchsorted(r.t, 2.0)
    assert np.all(np.diff(E[k:]) <= 1e-9 * E[k])
    assert E[-1] < 0.9 * E[k]
