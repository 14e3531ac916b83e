"""Spatial mechanisms in the compiled time loop (Lie-group generalized-α on R³ × SO(3)).

Every check is against an independent reference of ``benchmarks/references``
(quaternion ODE or relative coordinates integrated with scipy), never femb
itself: orders of convergence in positions, rotations, angular velocities and
reactions, invariants, quaternion norm, closed loops and redundant joints.
"""
import warnings

import numpy as np
import pytest

import femb
from femb.errors import ModelError
from femb.solve.solver import GeneralizedAlphaSolver

from femb.benchmarks.scenes.spatial import bricard, heavy_top, spatial_double_pendulum, spatial_slider_crank

TOP_OUT = ["x_cm", "y_cm", "z_cm", "rotation", "omega_x", "omega_z", "lambda_x", "lambda_y", "lambda_z"]


@pytest.fixture(scope="module")
def top():
    return heavy_top.build().compile()


def _order(hs, errs):
    return float(np.polyfit(np.log(hs), np.log(errs), 1)[0])


def test_numbering_of_a_frame_node(top):
    assert (top.nx, top.nq, top.nc) == (7, 6, 3)
    assert top.lie and top.rot_blocks.tolist() == [[3, 3]]
    r = femb.simulate(top, 0.01, 2.0 ** -10, rho_inf=0.9)
    assert r.q.shape[1] == 7 and r.qd.shape[1] == 6
    assert r.body("top").shape == (r.t.size, 7)
    assert r.body("top", "qd").shape == (r.t.size, 6)


def test_heavy_top_second_order_at_t1(top):
    """x_cm, the rotation (angle of R_refᵀR), Ω and λ at t = 1 s converge with order 2 (docs/spatial.md §7.1).

    The protocol's coarsest step 2⁻⁸ (and 2⁻⁹ for Ω_z) is not yet asymptotic; the
    fit uses 2⁻¹⁰ … 2⁻¹³."""
    hs = [2.0 ** -k for k in range(10, 14)]
    ref = heavy_top.reference(np.array([1.0]))
    errs = {k: [] for k in TOP_OUT}
    for h in hs:
        r = femb.simulate(top, 1.0, h, rho_inf=0.9)
        out = heavy_top.outputs(r)
        out["rotation"] = [heavy_top.rotation_error(r.body("top")[-1, 3:7], ref)]
        for k in TOP_OUT:
            errs[k].append(abs(out[k][-1] - (0.0 if k == "rotation" else np.atleast_1d(ref[k])[-1])))
    for k in TOP_OUT:
        assert _order(hs, errs[k]) >= 1.9, (k, errs[k])
    # the finest step is close to the reference (24 full turns about the body axis by then)
    assert errs["x_cm"][-1] < 1e-4 and errs["lambda_z"][-1] < 1.0


def test_heavy_top_reactions_second_order_from_the_first_steps(top):
    """λ after 4 steps: order 2 with the consistent (perturbed) start, order 1 with the seed's a0 = v̇0."""
    hs = [2.0 ** -k for k in range(9, 13)]
    orders = {}
    for start in ("consistent", "seed"):
        errs = []
        for h in hs:
            r = femb.simulate(top, 4 * h, h, rho_inf=0.9, start=start)
            ref = heavy_top.reference(np.array([r.t[-1]]))
            out = heavy_top.outputs(r)
            errs.append(max(abs(out[k][-1] - np.atleast_1d(ref[k])[-1]) for k in ("lambda_x", "lambda_y", "lambda_z")))
        orders[start] = _order(hs, errs)
    assert orders["consistent"] >= 1.9, orders
    assert orders["seed"] < 1.5, orders


def test_heavy_top_invariants(top):
    """Ω_y ≡ 150 to Newton's accuracy; unit quaternions to round-off; E and L_z drift shrink as h²."""
    drift = []
    for h in (2.0 ** -10, 2.0 ** -11):
        r = femb.simulate(top, 1.0, h, rho_inf=0.9)
        out = heavy_top.outputs(r)
        assert np.abs(out["omega_y"] - 150.0).max() < 1e-9
        p = r.body("top")[:, 3:7]
        assert np.abs(np.linalg.norm(p, axis=1) - 1.0).max() < 1e-14
        drift.append((np.ptp(out["energy"]), np.ptp(out["L_z"])))
    (e1, l1), (e2, l2) = drift
    assert e1 / e2 > 3.0 and l1 / l2 > 3.0, drift


def test_stepping_solver_equals_simulate(top):
    h = 2.0 ** -9
    r = femb.simulate(top, 20 * h, h, rho_inf=0.9)
    s = GeneralizedAlphaSolver(top, h, rho_inf=0.9, t_end=20 * h)
    for _ in range(20):
        s.step()
    assert np.array_equal(s.state.q, r.q[-1]) and np.array_equal(s.state.lam, r.lam[-1])


def test_heavy_top_adaptive_steps(top):
    ref = heavy_top.reference(np.array([1.0]))
    errs = []
    for rtol in (1e-4, 1e-5):
        r = femb.simulate(top, 1.0, rtol=rtol, atol=rtol, rho_inf=0.9)
        assert r.t[-1] == 1.0
        out = heavy_top.outputs(r)
        errs.append(abs(out["x_cm"][-1] - ref["x_cm"][-1]))
    assert errs[1] < errs[0] < 5e-3


def test_spatial_double_pendulum_orders():
    """Skew revolute axes: positions, body angular velocities and joint forces, order 2."""
    m = spatial_double_pendulum.build().compile()
    hs = [4e-3, 2e-3, 1e-3, 5e-4]
    keys = ["x2_x", "x2_z", "Omega2_x", "Omega2_z", "F1_x", "F1_y", "F2_x"]
    errs = {k: [] for k in keys}
    for h in hs:
        r = femb.simulate(m, 0.5, h, rho_inf=0.9)
        out = spatial_double_pendulum.outputs(r)
        ref = spatial_double_pendulum.reference(r.t[-1:])
        for k in keys:
            errs[k].append(abs(out[k][-1] - np.atleast_1d(ref[k])[-1]))
    for k in keys:
        assert _order(hs, errs[k]) >= 1.9, (k, errs[k])


def test_spatial_slider_crank_closed_loop_order():
    """A closed loop of revolute, spherical, universal and prismatic joints (IFToMM data)."""
    m = spatial_slider_crank.build().compile()
    hs = [1e-3, 5e-4, 2.5e-4]
    keys = ["theta", "theta_d", "slider_x", "rod_omega_x", "rod_omega_z"]
    errs = {k: [] for k in keys}
    for h in hs:
        r = femb.simulate(m, 0.2, h, rho_inf=0.9)
        out = spatial_slider_crank.outputs(r)
        ref = spatial_slider_crank.reference(r.t[-1:])
        for k in keys:
            errs[k].append(abs(out[k][-1] - np.atleast_1d(ref[k])[-1]))
    for k in keys:
        assert _order(hs, errs[k]) >= 1.9, (k, errs[k])


def test_bricard_runs_with_its_redundant_equation_removed():
    m = bricard.build().compile(redundant="eliminate")      # asked for: no warning (tests/test_initial.py)
    assert m.removed_constraints == [("J6", "lock_2")]
    r = femb.simulate(m, 1.0, 1e-3, rho_inf=0.9)
    out = bricard.outputs(r)
    ref = bricard.reference(r.t[-1:])
    for k in ("P3_x", "P3_y", "P3_z"):
        assert abs(out[k][-1] - np.atleast_1d(ref[k])[-1]) < 1e-5
    assert np.ptp(out["energy"]) < 1e-6 * max(1.0, np.abs(out["energy"]).max())


def test_output_between_steps_on_the_group(top):
    """t_eval with adaptive steps: q interpolated on SO(3) (unit quaternions), fourth-order accurate."""
    t_eval = np.linspace(0.0, 0.5, 41)
    r = femb.simulate(top, 0.5, rtol=1e-7, atol=1e-7, rho_inf=0.9, t_eval=t_eval)
    assert np.array_equal(r.t, t_eval)
    p = r.body("top")[:, 3:7]
    assert np.abs(np.linalg.norm(p, axis=1) - 1.0).max() < 1e-14
    ref = heavy_top.reference(t_eval)
    out = heavy_top.outputs(r)
    # the interpolation error stays at the level of the steps' own error
    full = femb.simulate(top, 0.5, rtol=1e-7, atol=1e-7, rho_inf=0.9)
    step_err = np.abs(heavy_top.outputs(full)["x_cm"] - heavy_top.reference(full.t)["x_cm"]).max()
    assert np.abs(out["x_cm"] - ref["x_cm"]).max() < 2.0 * step_err + 1e-9


def test_vtk_frames_at_fixed_dt_for_a_spatial_model(top, tmp_path):
    from femb.io.frames import VTKStream
    from femb.io.vtk import read_pvd
    with VTKStream(top, tmp_path / "vtk", dt=0.01) as vtk:
        femb.simulate(top, 0.05, rtol=1e-5, rho_inf=0.9, observer=vtk)
    times = [t for t, _ in read_pvd(vtk.path)]
    assert np.allclose(times, np.arange(6) * 0.01)


def test_planar_and_spatial_rotation_entries_apart():
    """A planar pendulum next to a spatial body: both integrate, each as if alone."""
    from femb.benchmarks.scenes.planar import pendulum
    mp = pendulum.build().compile()
    ref = femb.simulate(mp, 0.2, 1e-3, rho_inf=0.9)
    mech = pendulum.build()
    for e in heavy_top.build().elements:
        if e.name != "gravity":
            mech.add(e)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        both = mech.compile()
    r = femb.simulate(both, 0.2, 1e-3, rho_inf=0.9)
    name = [n for n in mp.node_index if n != "ground"][0]
    assert np.allclose(r.body(name)[-1], ref.body(name)[-1], rtol=0, atol=1e-12)


def test_result_access_of_a_spatial_body(top):
    """Rotation, angular velocity in both frames, body points and the support reaction of the heavy top."""
    h = 2.0 ** -10
    r = femb.simulate(top, 0.2, h, rho_inf=0.9)
    R = r.rotation_matrix("top")
    assert np.allclose(np.einsum("nij,nkj->nik", R, R), np.eye(3), atol=1e-14)
    W = r.angular_velocity("top")
    w = r.angular_velocity("top", frame="space")
    assert np.allclose(w, np.einsum("nij,nj->ni", R, W), atol=1e-12)
    # the fixed point O stays at the origin (index 3 holds positions exactly); its velocity vanishes
    # to the scheme's O(h²) (index 3 does not enforce the velocity constraint)
    assert np.abs(r.point("top", "O")).max() < 1e-12
    r2 = femb.simulate(top, 0.2, h / 2, rho_inf=0.9)
    vO, vO2 = np.abs(r.point_velocity("top", "O")).max(), np.abs(r2.point_velocity("top", "O")).max()
    assert vO2 < vO / 3.0, (vO, vO2)
    # point velocity and acceleration are the derivatives of the point position and velocity
    # (central differences of stored steps, second order)
    c = r.point("top", (0.1, 0.2, 0.3))
    v = r.point_velocity("top", (0.1, 0.2, 0.3))
    a = r.point_acceleration("top", (0.1, 0.2, 0.3))
    assert np.abs((c[2:] - c[:-2]) / (2 * h) - v[1:-1]).max() < 1e-2 * np.abs(v).max()
    assert np.abs((v[2:] - v[:-2]) / (2 * h) - a[1:-1]).max() < 1e-2 * np.abs(a).max()
    # the support acts on the top with the force λ (docs/spatial.md: Φ = p_ground − p_top) and no moment
    # about the support point
    F = r.reaction_at("support")
    assert F.shape == (r.t.size, 6)
    assert np.allclose(F[:, 0:3], r.reaction("support"), rtol=1e-12, atol=1e-9)
    assert np.abs(F[:, 3:6]).max() < 1e-9 * np.abs(F[:, 0:3]).max()
    with pytest.raises(ModelError, match="planar"):
        from femb.benchmarks.scenes.planar import pendulum
        femb.simulate(pendulum.build().compile(), 0.01, 1e-3).rotation(
            [n for n in pendulum.build().compile().bodies if n != "ground"][0])
