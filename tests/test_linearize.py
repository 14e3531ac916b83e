"""femb.analysis.linearize: the Whipple bicycle from the 3-D model, closed forms, finite differences, errors."""
import numpy as np
import pytest

from femb import Mechanism
from femb.analysis import linearize as fl
from femb.benchmarks.accuracy import linearize_scenes as sc
from femb.benchmarks.references import whipple_linear as ref
from femb.benchmarks.scenes.spatial import whipple_bicycle as wb
from femb.elements import RigidBody, Slider, SpringDamper
from femb.errors import ParameterError


def _match(got, want):
    """Largest distance between the two sets of eigenvalues (each matched to its nearest)."""
    got, want = np.asarray(got), np.asarray(want)
    assert got.shape == want.shape
    return max(max(np.min(np.abs(got - w)) for w in want), max(np.min(np.abs(want - g)) for g in got))


def _sorted(ev):
    ev = np.asarray(ev)
    return ev[np.lexsort((ev.imag, ev.real))]


# ---------------------------------------------------------------- the Whipple bicycle
@pytest.mark.parametrize("v", [0.0, 5.0, 10.0])
def test_whipple_eigenvalues_table2(v):
    got = wb.eigenvalues(v)
    want = _sorted(wb.TABLE2[v])
    assert np.max(np.abs(got - want)) < 1e-9


def test_whipple_weave_and_capsize_speeds():
    assert abs(wb.weave_speed() - wb.TABLE2["weave_speed"]) < 1e-8
    assert abs(wb.capsize_speed() - wb.TABLE2["capsize_speed"]) < 1e-8


@pytest.mark.parametrize("v", [0.0, 0.7, 3.0, 4.3, 6.0, 8.5, 10.0])
def test_whipple_state_matrix_equals_canonical_equations(v):
    """The whole (A, B) in (φ, δ, φ̇, δ̇), not only the eigenvalues: B = [0; M⁻¹] for (T_φ, T_δ)."""
    lin = wb.linearized(v)
    assert lin.state_names == ["lean", "steer", "lean_d", "steer_d"]
    np.testing.assert_allclose(lin.A, ref.state_matrix(v), rtol=0, atol=1e-9 * max(1.0, v * v))
    M = ref.canonical_matrices()[0]
    np.testing.assert_allclose(lin.B, np.vstack((np.zeros((2, 2)), np.linalg.inv(M))), rtol=0, atol=1e-10)
    np.testing.assert_allclose(lin.C, np.hstack((np.eye(2), np.zeros((2, 2)))), atol=1e-12)


def _other_bicycle(seed):
    rng = np.random.default_rng(seed)
    p = dict(ref.BENCHMARK)
    for k in ("w", "c", "lam", "rR", "mR", "xB", "zB", "mB", "xH", "zH", "mH", "rF", "mF"):
        p[k] = p[k] * (1.0 + 0.25 * rng.uniform(-1.0, 1.0))
    # each body's inertia tensor scaled as a whole: it stays physical (triangle inequalities)
    for body, keys in (("R", ("IRxx", "IRyy")), ("B", ("IBxx", "IByy", "IBzz", "IBxz")),
                       ("H", ("IHxx", "IHyy", "IHzz", "IHxz")), ("F", ("IFxx", "IFyy"))):
        s = 1.0 + 0.4 * rng.uniform(-1.0, 1.0)
        for k in keys:
            p[k] = p[k] * s
    return p


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_other_bicycles_equal_canonical_equations(seed):
    p = _other_bicycle(seed)
    for v in (1.0, 4.0, 7.5):
        got = wb.eigenvalues(v, p)
        want = ref.eigenvalues(v, p)
        assert np.max(np.abs(got - want)) < 1e-9, (p, v)
        np.testing.assert_allclose(wb.linearized(v, p).A, ref.state_matrix(v, p), rtol=0, atol=1e-9 * (1 + v * v))


def test_whipple_drift_is_eliminated_by_symmetry_not_by_value():
    """Without the symmetries the linearization keeps the drift: 10 states, 6 of them zero modes."""
    model = wb.model_for()
    full = fl.linearize(model, (model.q0, wb.velocities(model, 5.0)), about="steady")
    assert full.A.shape == (10, 10)
    ev = _sorted(np.linalg.eigvals(full.A))
    lateral = wb.eigenvalues(5.0)
    for e in lateral:                        # the four of the reduced model are among them
        assert np.min(np.abs(ev - e)) < 1e-8
    assert wb.linearized(5.0).A.shape == (4, 4)


def test_a_false_symmetry_is_refused():
    model = wb.model_for()
    st = (model.q0, wb.velocities(model, 5.0))
    with pytest.raises(ParameterError, match="symmetr"):
        fl.linearize(model, st, symmetries=[fl.translation((0.0, 0.0, 1.0), "z")])
    with pytest.raises(ParameterError, match="not a steady motion"):
        fl.linearize(model, st, about="steady", omega=(0.0, 0.0, 0.3))


# ---------------------------------------------------------------- closed forms
@pytest.mark.parametrize("m,k,d", [(2.0, 4000.0, 8.0), (1.0, 4000.0, 8.0), (0.5, 30.0, 0.2), (3.0, 100.0, 50.0)])
def test_mass_spring_damper(m, k, d):
    mech = Mechanism("msd")
    mech.add(RigidBody("mass", m, 0.1, position=(1.0, 0.0)))
    mech.add(Slider("s", "ground", "mass", axis=(1.0, 0.0)))
    mech.add(SpringDamper("k", "ground", "mass", k, d, point_a=(0.0, 0.0), length=1.0))
    model = mech.compile()
    x = fl.coordinate(model, "mass.x")
    lin = fl.linearize(model, states=[x, fl.coordinate(model, "mass.x", rate=True)])
    w0, z = np.sqrt(k / m), d / (2.0 * np.sqrt(k * m))
    ev = _sorted(lin.eig().eigenvalues)
    want = _sorted(w0 * (-z + np.array([1, -1]) * np.sqrt(complex(z * z - 1.0))))
    assert np.max(np.abs(ev - want)) < 1e-10 * w0
    modes = lin.eig()
    if z < 1:
        np.testing.assert_allclose(modes.damping_ratio, z, atol=1e-12)
        np.testing.assert_allclose(modes.natural_frequency, w0, rtol=1e-12)
    np.testing.assert_allclose(lin.A, [[0, 1], [-k / m, -d / m]], atol=1e-10 * k / m)


def _top(m=15.0, Ix=0.234375, I3=0.46875, l=1.0, spin_rate=40.0, g=9.81):
    return sc.sleeping_top(spin_rate, "fixed", m, Ix, I3, l, g)[0]


@pytest.mark.parametrize("spin_rate", [0.0, 10.0, 22.0, 40.0, 150.0])
def test_sleeping_top_gyroscopic_split(spin_rate):
    """I₁ s² − i I₃ ω s − m g l = 0 for u = φ_x + i φ_y (and its conjugate), I₁ about the pivot."""
    m, Ix, I3, l, g = 15.0, 0.234375, 0.46875, 1.0, 9.81
    lin = _top(m, Ix, I3, l, spin_rate, g)
    I1 = Ix + m * l * l
    disc = np.sqrt(complex(4.0 * I1 * m * g * l - (I3 * spin_rate) ** 2))
    r = np.array([(1j * I3 * spin_rate + disc) / (2 * I1), (1j * I3 * spin_rate - disc) / (2 * I1)])
    want = _sorted(np.concatenate((r, r.conj())))
    assert lin.A.shape == (4, 4)
    assert _match(lin.eig().eigenvalues, want) < 1e-10 * max(1.0, np.abs(want).max())


def _coin(omega, m=1.3, r=0.4, g=9.81):
    lin, _ = sc.rolling_coin(omega, m, r, g)
    A, C = m * r * r / 4.0, m * r * r / 2.0
    return lin, (m, r, g, A, C)


@pytest.mark.parametrize("omega", [0.0, 2.0, 2.85, 3.0, 8.0, 20.0])
def test_rolling_coin_upright_stability(omega):
    """(A + m r²) φ̈ + [(C + m r²) C ω²/A − m g r] φ = 0 and A ψ̈ + C ω φ̇ = 0 (Neimark & Fufaev 1972)."""
    lin, (m, r, g, A, C) = _coin(omega)
    assert lin.A.shape == (3, 3)
    s2 = -((C + m * r * r) * C * omega ** 2 / A - m * g * r) / (A + m * r * r)
    s = np.sqrt(complex(s2))
    want = _sorted([s, -s, 0.0])
    assert _match(lin.eig().eigenvalues, want) < 1e-10 * max(1.0, abs(s))


def test_rolling_coin_stability_bound():
    """The critical spin ω² = m g r A / (C (C + m r²)) = g/(3r) (thin uniform disc), found from the
    linearization alone: the lean mode's s² (a coefficient of det(sI − A) = s³ − s² s) changes sign."""
    from scipy.optimize import brentq
    m, r, g = 1.3, 0.4, 9.81
    crit = np.sqrt(g / (3.0 * r))

    def s2(w):
        return -np.real(np.poly(_coin(w, m, r, g)[0].A)[2])

    wc = brentq(s2, 0.5 * crit, 2.0 * crit, xtol=1e-14)
    assert abs(wc - crit) < 1e-10 * crit
    assert np.max(_coin(0.99 * crit)[0].eig().eigenvalues.real) > 0.01          # unstable below
    assert np.max(np.abs(_coin(1.01 * crit)[0].eig().eigenvalues.real)) < 1e-9  # a centre above


# ---------------------------------------------------------------- the cart–pendulum
cart_pendulum = sc.cart_pendulum
_cart_linear = sc.cart_pendulum_linear


def test_cart_pendulum_closed_form():
    mc, m, l, J, g = 1.5, 0.5, 0.6, 0.02, 9.81
    model = cart_pendulum(mc, m, l, J, g).compile()
    lin = _cart_linear(model)
    # θ measured counter-clockwise; upright θ = π/2; a small tilt ϑ = θ − π/2 moves the CoM by −l ϑ in x
    Mm = np.array([[mc + m, -m * l], [-m * l, J + m * l * l]])
    Km = np.array([[0.0, 0.0], [0.0, -m * g * l]])
    Mi = np.linalg.inv(Mm)
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-Mi @ Km, np.zeros((2, 2))]])
    np.testing.assert_allclose(lin.A, A, rtol=0, atol=1e-10)
    np.testing.assert_allclose(lin.B[:, 0], np.concatenate(([0, 0], Mi[:, 0])), rtol=0, atol=1e-12)


def test_linearization_matches_finite_differences_of_the_nonlinear_model():
    """A and B against central differences of femb's own accelerations about equilibria: the
    cart–pendulum upright (holonomic constraints) and with a spring holding the pole tilted
    (constraint forces and geometric stiffness), the bicycle at rest (rolling constraints)."""
    tilted = cart_pendulum(theta0=1.2)
    tilted.add(SpringDamper("hold", "ground", "pole", 200.0, 1.5, point_a=(1.0, 0.3)))
    tilted_model = tilted.compile()
    import warnings
    from femb.analysis.static import solve_static
    with warnings.catch_warnings():          # the tilted pole is an unstable equilibrium: linearizable all the same
        warnings.simplefilter("ignore", UserWarning)
        eq = solve_static(tilted_model)
    for model, st in ((cart_pendulum().compile(), None), (tilted_model, (eq.q[-1], np.zeros(tilted_model.nq))),
                      (wb.model_for(), None)):
        q0 = model.q0 if st is None else st[0]
        inputs = [fl.force(model, q0, model.node_names[1], (1.0, 0.0, 0.0)[:2 if not model.lie else 3], name="u")]
        lin = fl.linearize(model, st, about="equilibrium", inputs=inputs)
        X = lin.basis
        nq = model.nq
        Xp = np.linalg.pinv(X)
        h = 1e-6
        Afd = np.zeros_like(lin.A)

        def rate(s, u=0.0):
            q = model.compose(q0, X[:nq] @ s)
            v = X[nq:] @ s
            vd = fl.reference(model, 0.0, q, v, f_extra=u * inputs[0].F)[0]
            return Xp @ np.concatenate((v, vd))

        for i in range(lin.n):
            e = np.zeros(lin.n)
            e[i] = h
            Afd[:, i] = (rate(e) - rate(-e)) / (2 * h)
        Bfd = (rate(np.zeros(lin.n), h) - rate(np.zeros(lin.n), -h)) / (2 * h)
        scale = np.abs(lin.A).max()
        assert np.abs(Afd - lin.A).max() < 1e-6 * scale
        assert np.abs(Bfd - lin.B[:, 0]).max() < 1e-6 * np.abs(lin.B).max()


def test_state_space_exports():
    model = cart_pendulum().compile()
    lin = _cart_linear(model)
    ss = lin.to_scipy()
    np.testing.assert_allclose(ss.A, lin.A)
    control = pytest.importorskip("control")
    sys = lin.to_control()
    assert isinstance(sys, control.StateSpace)
    assert list(sys.state_labels) == [n.replace(".", "_") for n in lin.state_names]
    assert list(sys.input_labels) == ["F"]


# ---------------------------------------------------------------- large models, mode shapes
def test_sparse_damped_modes_of_a_beam_match_dense_and_proportional_damping():
    from femb.analysis.modal import modal_analysis
    from femb.benchmarks.cost.linearize_large import BETA, build
    model = build(30, length=1.0).compile()
    sparse = fl.damped_modes(model, n_modes=12)
    dense = fl.linearize(model).eig()
    s = sparse.eigenvalues
    d = dense.eigenvalues[np.argsort(np.abs(dense.eigenvalues))][:12]
    assert _match(s, d) < 1e-9 * np.abs(s).max()
    w = modal_analysis(model, n_modes=6).omega              # undamped; ζ = βω/2 (C = βK at rest)
    z = BETA * w / 2.0
    want = np.concatenate((w * (-z + 1j * np.sqrt(1 - z * z)), w * (-z - 1j * np.sqrt(1 - z * z))))
    assert _match(s, want) < 1e-8 * np.abs(s).max()
    up = s[s.imag > 0]
    np.testing.assert_allclose(sparse.damping_ratio[s.imag > 0], BETA * np.abs(up) / 2.0, rtol=1e-5)


def test_mode_shapes_to_vtk(tmp_path):
    lin = _top(spin_rate=40.0)
    modes = lin.eig()
    path = modes.write_vtk(tmp_path / "top", 0, frames=4)
    assert path.exists() and path.suffix == ".pvd"
    assert len(list((tmp_path / "top").glob("*.vt*"))) >= 4
    bike = wb.linearized(5.0).eig()
    assert bike.write_vtk(tmp_path / "bike", 1, frames=3).exists()


@pytest.mark.parametrize("spin_rate", [10.0, 40.0])
def test_sleeping_top_in_a_rotating_frame(spin_rate):
    """The same motion as a world rotation ω_L = ω e_z (ω_R = 0): the perturbations are then measured in
    the frame turning with the top, so every eigenvalue s of the fixed frame appears as s ∓ iω."""
    lin, want = sc.sleeping_top(spin_rate, "turning")
    assert _match(lin.eig().eigenvalues, want) < 1e-10 * max(1.0, np.abs(want).max())
    fixed = _top(spin_rate=spin_rate).eig().eigenvalues
    np.testing.assert_allclose(np.sort(lin.eig().eigenvalues.real), np.sort(fixed.real), atol=1e-10)


def test_reaction_outputs_match_finite_differences():
    """C and D rows of joint reactions against central differences of femb's multipliers (cart–pendulum)."""
    model = cart_pendulum().compile()
    q0 = model.q0
    inp = [fl.force(model, q0, "cart", (1.0, 0.0), name="F")]
    outs = [fl.reaction(model, "pin", 0), fl.reaction(model, "pin", "y"), fl.reaction(model, "rail", 1)]
    lin = fl.linearize(model, inputs=inp, outputs=outs)
    assert lin.output_names == ["pin.x", "pin.y", "rail.moment"]
    X, nq, h = lin.basis, model.nq, 1e-6
    nus = [o.nu for o in outs]

    def nu(s, u=0.0):
        q = model.compose(q0, X[:nq] @ s)
        _, lam, mu = fl.reference(model, 0.0, q, X[nq:] @ s, f_extra=u * inp[0].F)
        return np.concatenate((lam, mu))[nus]

    C = np.array([(nu(h * e) - nu(-h * e)) / (2 * h) for e in np.eye(lin.n)]).T
    D = (nu(np.zeros(lin.n), h) - nu(np.zeros(lin.n), -h)) / (2 * h)
    np.testing.assert_allclose(lin.C, C, rtol=0, atol=1e-6 * np.abs(C).max())
    np.testing.assert_allclose(lin.D[:, 0], D, rtol=0, atol=1e-6 * np.abs(D).max())
    with pytest.raises(Exception, match="no constraint row"):
        fl.reaction(model, "pin", "z")


def test_state_of_a_result():
    """A stored step of a run is a reference (here the cart–pendulum hanging at rest, an equilibrium)."""
    import femb
    model = cart_pendulum(theta0=-np.pi / 2).compile()
    res = femb.simulate(model, 0.05, h=0.01)
    lin = fl.linearize(model, res, t=0.05)
    assert lin.operating_point["t"] == pytest.approx(0.05)
    ev = lin.eig().eigenvalues
    assert np.max(ev.real) < 1e-8 and np.max(np.abs(ev.imag)) > 1.0      # the hanging pole swings


@pytest.mark.parametrize("u,a", [(2.0, 0.3), (-1.5, 0.3), (1.0, -0.2)])
def test_chaplygin_sleigh(u, a):
    """A knife edge a behind the centre of mass, sliding straight at speed u: (J + m a²) ω̇ = −m a u ω."""
    m, J = 2.5, 0.3
    lin, want = sc.sleigh(u, a, m, J)
    assert lin.A.shape == (1, 1)
    assert abs(lin.A[0, 0] - want[0]) < 1e-12
    assert abs(want[0] + m * a * u / (J + m * a * a)) == 0.0


def test_whipple_contact_forces_at_the_operating_point():
    """Straight running: the normal forces carry the weight as at rest, N_F = m_T g x_T / w; no traction."""
    p = ref.BENCHMARK
    lin = wb.linearized(5.0)
    model = lin.model
    lam, mu = lin.operating_point["lam"], lin.operating_point["mu"]
    mT = p["mR"] + p["mB"] + p["mH"] + p["mF"]
    xT = (p["xB"] * p["mB"] + p["xH"] * p["mH"] + p["w"] * p["mF"]) / mT
    NF = mT * p["g"] * xT / p["w"]
    assert -lam[model.lam_indices("front_contact")[0]] == pytest.approx(NF, rel=1e-12)
    assert -lam[model.lam_indices("rear_contact")[0]] == pytest.approx(mT * p["g"] - NF, rel=1e-12)
    assert np.max(np.abs(mu)) < 1e-9


def test_bad_linearize_input_is_named():
    from femb.errors import ModelError
    with pytest.raises(ParameterError, match="translation: direction"):
        fl.translation((0.0, 0.0, 0.0))
    with pytest.raises(ParameterError, match="spin: axis"):
        fl.spin("w", (np.nan, 0.0, 1.0))
    model = wb.model_for()
    st = (model.q0, wb.velocities(model, 5.0))
    with pytest.raises(ModelError, match="no body named 'wheel'"):
        fl.linearize(model, st, symmetries=[fl.spin("wheel", (0.0, 1.0, 0.0))])
    with pytest.raises(ParameterError, match="about must be"):
        fl.linearize(model, st, about="moving")
    with pytest.raises(ParameterError, match="does not fit"):
        fl.linearize(model, (model.q0[:5], st[1]))
    with pytest.raises(ParameterError, match="violates the constraints"):
        fl.linearize(model, (model.q0, st[1] + 0.1))
    with pytest.raises(ParameterError, match="states given"):
        fl.linearize(model, st, states=[fl.angle(model, model.q0, "rear_frame", (1.0, 0.0, 0.0))])
