"""The spatial reference models conserve what they must and match the published values."""
import numpy as np

from femb.benchmarks.references import bricard, heavy_top, spatial_double_pendulum, spatial_slider_crank
from femb.benchmarks.references.kane import RigidSystem, cos, matmul, sin


def test_heavy_top_published_initial_values_and_invariants():
    P = heavy_top.PUBLISHED
    o = heavy_top.outputs_at([1.0, 0.0, 0.0, 0.0], heavy_top.OMEGA0)
    np.testing.assert_allclose([o["omega_dot_x"], o["omega_dot_y"], o["omega_dot_z"]], P["Omega_dot0"], atol=5e-6)
    np.testing.assert_allclose([o["lambda_x"], o["lambda_y"], o["lambda_z"]], P["lambda0"], atol=5e-6)
    assert abs(o["energy"] - P["energy"]) < 1e-9
    assert abs(o["L_z"] - P["L_z"]) < 1e-12
    t, out = heavy_top.solve(1.0, t_eval=np.linspace(0, 1, 11))
    np.testing.assert_allclose(out["omega_y"], 150.0, rtol=0, atol=1e-9)
    np.testing.assert_allclose(out["energy"], P["energy"], rtol=1e-12)
    np.testing.assert_allclose(out["L_z"], P["L_z"], rtol=1e-10)
    q = np.stack([out[f"p{k}"] for k in range(4)], axis=1)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-12)
    # the centre of mass stays at distance 1 from the fixed point
    np.testing.assert_allclose(np.sqrt(out["x_cm"] ** 2 + out["y_cm"] ** 2 + out["z_cm"] ** 2), 1.0, atol=1e-12)


def test_heavy_top_quaternion_ode_agrees_with_kane_in_cardan_angles():
    """Two independent formulations: quaternion/Euler equations vs. Kane's equations in
    Cardan angles R = Rz(a) Rx(b) Ry(c) (far from gimbal lock over 0.1 s)."""
    X = heavy_top.X

    def kin(q):
        a, b, c = q
        Rz = np.array([[cos(a), -sin(a), 0.0], [sin(a), cos(a), 0.0], [0.0, 0.0, 1.0]], dtype=object)
        Rx = np.array([[1.0, 0.0, 0.0], [0.0, cos(b), -sin(b)], [0.0, sin(b), cos(b)]], dtype=object)
        Ry = np.array([[cos(c), 0.0, sin(c)], [0.0, 1.0, 0.0], [-sin(c), 0.0, cos(c)]], dtype=object)
        R = matmul(Rz, matmul(Rx, Ry))
        return [(matmul(R, X), R)]

    sys_ = RigidSystem(kin, [heavy_top.M], [heavy_top.J_C], heavy_top.G)
    from scipy.integrate import solve_ivp
    W0 = heavy_top.OMEGA0
    y0 = [0.0, 0.0, 0.0, W0[2], W0[0], W0[1]]          # ω = ȧ z + ḃ x + ċ y at R = I
    T = 0.1
    sol = solve_ivp(sys_.rhs, (0, T), y0, method="DOP853", rtol=1e-12, atol=1e-12)
    s = sys_.state(sol.y[:3, -1], sol.y[3:, -1])
    _, ref = heavy_top.solve(T, t_eval=[T])
    np.testing.assert_allclose(s["c"][0], [ref["x_cm"][0], ref["y_cm"][0], ref["z_cm"][0]], atol=1e-9)
    Omega = s["R"][0].T @ s["omega"][0]
    np.testing.assert_allclose(Omega, [ref["omega_x"][0], ref["omega_y"][0], ref["omega_z"][0]], atol=1e-7)


def test_double_pendulum_reference_conserves_energy():
    t, out = spatial_double_pendulum.solve(1.0, t_eval=np.linspace(0, 1, 6))
    np.testing.assert_allclose(out["energy"], out["energy"][0], rtol=0, atol=1e-9)
    assert np.ptp(out["theta1"]) > 0.3 and np.ptp(out["theta2"]) > 0.3      # it really moves
    v1, w1, v2, w2 = spatial_double_pendulum.initial_velocities()
    np.testing.assert_allclose([out["omega2_x"][0], out["omega2_y"][0], out["omega2_z"][0]], w2, atol=1e-14)


def test_slider_crank_reference_matches_published_initial_velocities_and_conserves_energy():
    sys_ = spatial_slider_crank.system()
    o = spatial_slider_crank.outputs_at(sys_, np.array([0.0]), np.array([6.0]))
    P = spatial_slider_crank.PUBLISHED_V0
    np.testing.assert_allclose([o["rod_vx"], o["rod_vy"], o["rod_vz"]], P["rod_v"], atol=1e-14)
    np.testing.assert_allclose([o["rod_omega_x"], o["rod_omega_y"], o["rod_omega_z"]], P["rod_omega"], atol=1e-14)
    assert abs(o["slider_v"] - P["slider_v"][0]) < 1e-14
    assert abs(o["slider_x"] - 0.2) < 1e-15
    t, out = spatial_slider_crank.solve(0.5, t_eval=np.linspace(0, 0.5, 6))
    np.testing.assert_allclose(out["energy"], out["energy"][0], rtol=0, atol=1e-10)
    assert out["theta"][-1] > 2.0


def test_bricard_reference_conserves_energy_and_keeps_its_redundant_closure():
    t, out = bricard.solve(0.6, t_eval=np.linspace(0, 0.6, 4), rtol=1e-11, atol=1e-11)
    np.testing.assert_allclose(out["energy"], -5 * 9.81 * 0.6, rtol=0, atol=1e-8)   # from rest: E = V0
    assert np.all(out["closure"] < 1e-9)
    assert np.all(out["closure_rank"] == 4)          # 5 closure rows, one redundant
    assert abs(out["P3_x"][-1] - 1.0) > 0.1          # it falls from rest
