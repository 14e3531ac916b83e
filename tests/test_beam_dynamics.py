"""Beams in the generalized-α solver: energy, convergence in h and in the mesh.

* energy of a free, spinning and vibrating beam: conserved to O(h²) with
  ρ∞ = 1 (no numerical dissipation), dissipated with ρ∞ < 1 and by material damping;
* second-order convergence in h of q and λ on the two flexible benchmark
  scenes (femb.benchmarks.scenes.beams.spin_up, femb.benchmarks.scenes.beams.flexible_slider_crank),
  errors against a run with a much smaller step (the scheme's own reference:
  the scenes have no closed-form solution);
* convergence of their tip/midspan deflection under mesh refinement.
"""
import warnings

import numpy as np
import pytest

import femb
from femb import Mechanism
from femb.benchmarks.scenes.beams import flexible_slider_crank, spin_up
from femb.elements import Section, add_beam, beam_strain_energy
from femb.errors import ParameterWarning
from femb.system import assembly


def free_beam(damping=0.0, n=4):
    """A free beam (no constraints) spinning at 2 rad/s about its centre with a bending velocity."""
    def vel(xy, th):
        v = np.zeros((xy.shape[0], 3))
        xc = xy - xy.mean(axis=0)
        v[:, 0] = -2.0 * xc[:, 1]
        v[:, 1] = 2.0 * xc[:, 0] + 0.5 * np.cos(np.pi * xy[:, 0])
        v[:, 2] = 2.0 - 0.5 * np.pi * np.sin(np.pi * xy[:, 0])
        return v

    m = Mechanism("free_beam")
    add_beam(m, "b", Section(100.0, 100.0, 1.0, 1.0, 0.01, damping), (0.0, 0.0), (1.0, 0.0), n,
             velocities=vel)
    return m.compile()


def energy(model, res):
    M = assembly.mass_matrix(model)
    return np.array([0.5 * v @ (M @ v) + beam_strain_energy(model, q) for q, v in zip(res.q, res.qd)])


def _run(model, h, rho_inf, t_end=2.0):
    # the seed's start (a_0 = q̈_0): from it the stored energy never rises above E(t0) under numerical
    # dissipation; the consistent start shifts a_0 by (α_m − α_f) h j_0, an O(h²) change of the first
    # step's energy, which the strict monotonicity test below would see
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ParameterWarning)     # ρ∞ = 1 warns about multipliers
        return femb.simulate(model, t_end, h, rho_inf=rho_inf, stride=10, start="seed")


def test_energy_conserved_to_second_order_with_rho_inf_1():
    model = free_beam()
    assert model.nc == 0
    hs = np.array([0.004, 0.002, 0.001])
    errs = []
    for h in hs:
        E = energy(model, _run(model, h, 1.0))
        errs.append(np.abs(E - E[0]).max() / E[0])
    order = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    assert 1.8 < order < 2.5, (errs, order)
    assert errs[-1] < 2e-6


def test_energy_dissipated_with_rho_inf_below_1_and_with_material_damping():
    model = free_beam()
    h = 0.002
    E1 = energy(model, _run(model, h, 1.0))
    E05 = energy(model, _run(model, h, 0.5))
    drift = np.abs(E1 - E1[0]).max()
    assert E05[-1] < E05[0] - 100 * drift                  # numerical dissipation ≫ O(h²) error
    assert E05.max() <= E05[0] * (1 + 1e-9)
    assert np.all(np.diff(E05[::10]) < 0)                 # decreasing over 0.2 s windows
    damped = free_beam(damping=1e-3)
    assert damped.needs_C
    Ed = energy(damped, _run(damped, h, 1.0))
    assert Ed[-1] < 0.999 * Ed[0]
    assert np.all(np.diff(Ed[::10]) < 0)


def test_spin_up_converges_to_second_order_in_h():
    c = spin_up.time_convergence(n_elements=4, t_end=1.0, hs=(0.04, 0.02, 0.01), h_ref=0.0025)
    assert 1.85 < c["order_q"] < 2.3, c
    assert 1.85 < c["order_lam"] < 2.3, c


def test_flexible_slider_crank_converges_to_second_order_in_h():
    """Errors at t = 10 ms, after the start transient of the damped axial and shear modes."""
    c = flexible_slider_crank.time_convergence(n_elements=4, t_end=0.01, hs=(8e-5, 4e-5, 2e-5), h_ref=5e-6)
    assert 1.85 < c["order_q"] < 2.3, c
    assert 1.85 < c["order_lam"] < 2.3, c


def test_tip_deflections_converge_with_the_mesh():
    s = spin_up.mesh_convergence(ns=(4, 8, 16), t_end=3.0, h=0.01)
    assert s["tip_deflection"][-1] == pytest.approx(-0.2172, abs=5e-4)
    assert 1.8 < s["orders"][-1] < 2.3, s
    f = flexible_slider_crank.mesh_convergence(ns=(4, 8, 16, 32), t_end=0.01, h=4e-5)
    assert np.all((f["orders"] > 1.8) & (f["orders"] < 2.4)), f


def test_scene_protocol():
    """build(n_elements), DEFAULTS, CONVERGENCE and outputs(result) -> arrays over the stored steps."""
    for scene in (spin_up, flexible_slider_crank):
        model = scene.build(n_elements=3).compile()
        assert sum(1 for nm in model.node_index if ".n" in nm) == 4
        assert set(scene.DEFAULTS) == {"t_end", "h", "rho_inf"}
        res = femb.simulate(model, 20 * scene.DEFAULTS["h"], scene.DEFAULTS["h"], **scene.newton_options(3))
        out = scene.outputs(res)
        for name in scene.CONVERGENCE["q"] + scene.CONVERGENCE["lambda"] + ["tip_deflection"]:
            assert out[name].shape == res.t.shape
        fin = scene.final_outputs(res)
        assert fin["tip_deflection"] == out["tip_deflection"][-1]
    # the spin-up hub follows the prescribed angle; the rigid state starts inside the spin-up
    model = spin_up.build(n_elements=2).compile()
    st = femb.consistent_initial_state(model, spin_up.rigid_state(model, 15.0))
    assert model.node_coordinates("hub", st.q)[2] == pytest.approx(spin_up.spin_profile().f(15.0))
    ix, iy, _ = model.node_index["beam.n2"]
    assert np.hypot(st.qd[ix], st.qd[iy]) == pytest.approx(6.0 * 10.0, rel=1e-12)     # ω_s L
