"""The twisted-brick chain (Exudyn's perf3DRigidBodies) on a short chain: model, invariants, Exudyn.

Checks on n = 5 bricks, a few hundred steps of h = 1e-3 s:

* the model: sizes, the data of the Exudyn file (mass, inertia, joint points on
  the brick ends), Φ = 0 at t0;
* the joints hold, checked from the bodies' positions and rotations without
  femb's constraint kernels: each joint point is the same material point of
  both bricks and the joint axis the same line in both;
* energy: without numerical damping (index-2 form at ρ∞ = 1) the energy of the
  conservative chain stays constant to the discretization error and its
  change falls with h (second order);
* Exudyn (when installed): the same model with Exudyn's generalized-α at the
  same h and ρ∞ gives the same brick positions well within femb's own
  discretization error (femb at h against h/2).

No timings are asserted.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest

import femb
from femb.benchmarks import peers
from femb.benchmarks.scenes.spatial import rigid_chain_3d as C
from femb.benchmarks.scenes.spatial.spatial_common import rotation_matrices
from femb.study import registry
from femb.system.assembly import constraint_vector

N = 5


@pytest.fixture(scope="module")
def model():
    return C.build(n=N).compile()


@pytest.fixture(scope="module")
def run(model):
    return femb.simulate(model, 0.3, 1e-3, rho_inf=0.8)


def test_registered_and_protocol():
    scene = registry.load("rigid_chain_3d")
    assert scene.defaults == {"t_end": 1.0, "h": 1e-3, "rho_inf": 0.8}
    assert scene.parameters()["n"] == 400
    missing, extra = scene.undocumented()
    assert not missing and not extra


def test_model_data(model):
    assert model.nq == 6 * N and model.nc == 5 * N
    m, J = C.brick_inertia()
    assert m == pytest.approx(4.0)                      # 1000 kg/m³ × 0.4 × 0.1 × 0.1 m³
    assert J == pytest.approx((m / 12 * 0.02, m / 12 * 0.17, m / 12 * 0.17))
    R, centre, joint, axis = C.chain_geometry(N)
    # each brick runs from its joint to the next one along its body x axis
    for i in range(N):
        assert np.allclose(centre[i] - R[i] @ [0.2, 0.0, 0.0], joint[i], atol=1e-14)
        assert np.allclose(R[i].T @ R[i], np.eye(3), atol=1e-14)
        if i + 1 < N:
            assert np.allclose(centre[i] + R[i] @ [0.2, 0.0, 0.0], joint[i + 1], atol=1e-14)
            # consecutive bricks differ by R_x(δ) R_z(2δ)
            d = C.PARAMS["twist"]
            assert np.allclose(R[i].T @ R[i + 1], C._rx(d) @ C._rz(2 * d), atol=1e-14)
    assert np.allclose(axis, R[:, :, 2])
    q0 = femb.simulate(model, 1e-3, 1e-3, rho_inf=0.8).q[0]
    assert np.max(np.abs(constraint_vector(model, 0.0, q0))) < 1e-13


def test_joints_hold_geometrically(model, run):
    """Joint points and axes of neighbouring bricks coincide over the run (from x and R only)."""
    assert run.success and run.steps == 300
    R0, _, joint0, axis0 = C.chain_geometry(N)
    half = np.array([0.5 * C.PARAMS["length"], 0.0, 0.0])
    x = [run.body(f"brick{i}") for i in range(N)]
    R = [rotation_matrices(xi) for xi in x]
    # J0: the start of brick0 stays at the origin, its axis stays the space z axis
    start0 = x[0][:, :3] - np.einsum("nij,j->ni", R[0], half)
    assert np.max(np.abs(start0)) < 1e-10
    assert np.max(np.abs(R[0][:, :, 2] - axis0[0])) < 1e-10
    moved = 0.0
    for i in range(1, N):
        end_prev = x[i - 1][:, :3] + np.einsum("nij,j->ni", R[i - 1], half)
        start = x[i][:, :3] - np.einsum("nij,j->ni", R[i], half)
        assert np.max(np.linalg.norm(end_prev - start, axis=1)) < 1e-10
        # the axis of J_i: body z of brick i, and fixed in brick i-1 as A_{i-1}ᵀ A_i e_z
        in_prev = R0[i - 1].T @ axis0[i]
        axis_prev = np.einsum("nij,j->ni", R[i - 1], in_prev)
        assert np.max(np.linalg.norm(axis_prev - R[i][:, :, 2], axis=1)) < 1e-10
        moved = max(moved, float(np.max(np.linalg.norm(start - joint0[i], axis=1))))
    assert moved > 0.05                      # the chain moved (by far more than the checks' scale)
    assert np.max(C.outputs(run)["phi_max"]) < 1e-10


def _energy_change(model, h, t_end=0.3):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = femb.simulate(model, t_end, h, rho_inf=1.0, formulation="index2")
    E = C.outputs(r)["energy"]
    return float(np.max(np.abs(E - E[0]))), r


def test_energy_conserved_without_damping(model):
    """Index-2 form at ρ∞ = 1: energy constant to O(h²) while the chain gains kinetic energy."""
    dE1, r1 = _energy_change(model, 2e-3)
    dE2, _ = _energy_change(model, 1e-3)
    v = np.concatenate([r1.body(f"brick{i}", "qd")[-1, :3] for i in range(N)])
    kinetic_scale = 0.5 * C.brick_inertia()[0] * float(v @ v)       # translational part at t_end
    assert kinetic_scale > 0.5                                         # J (1.17 J): the chain moved
    assert dE2 < 1e-4 * kinetic_scale
    assert dE1 / dE2 > 3.0                                             # order ≈ 2 (4× for h/2)


@pytest.mark.skipif(not peers.status()["exudyn"]["installed"], reason="Exudyn not installed")
def test_agrees_with_exudyn(model, run):
    """Same model, same scheme and h: positions agree far below femb's own h-versus-h/2 difference."""
    times = np.array([0.1, 0.2, 0.3])
    bricks = C.sample_bricks(N)
    ex = C.exudyn_solve(N, 0.3, 1e-3, 0.8, record=bricks)
    assert ex["ok"], ex["message"]
    half = femb.simulate(model, 0.3, 5e-4, rho_inf=0.8)
    f1, f2 = C.femb_positions(run, bricks, times), C.femb_positions(half, bricks, times)
    for k in bricks:
        arr = ex["positions"][k]
        rows = [int(np.argmin(np.abs(arr[:, 0] - t))) for t in times]
        assert np.allclose(arr[rows, 0], times, atol=1e-9)
        diff = np.linalg.norm(f1[k] - arr[rows, 1:4], axis=1)
        disc = np.linalg.norm(f1[k] - f2[k], axis=1)
        assert np.all(disc > 0)
        assert np.max(diff) < 0.1 * np.max(disc), (k, diff, disc)


def test_measure_and_report_section():
    """The timing driver's record and the suite's section for it (structure only, no timing asserted)."""
    from femb.benchmarks.runners import suite

    sp = C.measure(n=3, t_end=0.01, runs=3, log=lambda m: None)
    assert sp["steps"] == 10 and len(sp["femb_runs"]) == 3 and sp["femb_ms"] > 0
    assert sp["femb_newton"] >= 1.0
    if peers.status()["exudyn"]["installed"]:
        assert set(sp["exudyn"]) == set(C.EXUDYN_SETTINGS)
        assert sp["ratio"] == pytest.approx(sp["femb_ms"] / sp["exudyn"]["tight"]["ms"])
    else:
        assert sp["ratio"] is None and sp["message"] == "Exudyn not installed"
    text = suite._spatial_section(sp)
    assert "| femb |" in text and ("| Exudyn |" in text)
    assert "femb" in suite._spatial_sentence(sp)


def test_reproduces_exudyn_published_result():
    """The full 400-brick run to 1 s reproduces Exudyn's logged perf3DRigidBodies result.

    Source: :data:`femb.benchmarks.scenes.spatial.rigid_chain_3d.EXUDYN_LOG` (Exudyn's performance log, 1.10.0):
    the last brick's displacement and xyz rotation angles, given there to 8 digits.
    """
    scene = registry.load("rigid_chain_3d")
    d = scene.defaults
    r = femb.simulate(scene.model(), d["t_end"], d["h"], rho_inf=d["rho_inf"], stride=1000)
    got = C.last_brick_measures(r)
    assert np.max(np.abs(got["u"] - np.array(C.EXUDYN_LOG["u"]))) < 1e-7
    assert np.max(np.abs(got["angles"] - np.array(C.EXUDYN_LOG["angles"]))) < 1e-7
    assert got["result"] == pytest.approx(C.EXUDYN_LOG["result"], abs=1e-7)


def test_rot_xyz_inverts_the_elementary_rotations():
    a = (0.3, -0.7, 2.5)
    R = C._rx(a[0]) @ np.array([[np.cos(a[1]), 0, np.sin(a[1])], [0, 1, 0], [-np.sin(a[1]), 0, np.cos(a[1])]]) \
        @ C._rz(a[2])
    assert np.allclose(C.rot_xyz(R), a, atol=1e-14)
