"""femb.analysis.linearize: drive positions, speeds and accelerations as inputs (driven constraints)."""
import numpy as np
import pytest

from femb import Mechanism
from femb.analysis import linearize as fl
from femb.base.functions import TimeFunction
from femb.elements import DrivenAngle, Gravity, Hinge, RigidBody, Slider, SpringDamper
from femb.errors import ModelError, ParameterError


class Held(TimeFunction):
    """A drive value set from outside (u, u̇, ü): the nonlinear model at any drive state."""

    def __init__(self):
        self.U = np.zeros(3)
        super().__init__(lambda t: self.U[0], lambda t: self.U[1], lambda t: self.U[2], "held")


def _driven_cart(theta=1.2):
    """A cart on a spring–damper, a pole hinged on it at the angle θ, the relative angle driven."""
    u = Held()
    mech = Mechanism("driven_cart")
    mech.add(RigidBody("cart", 1.5, 0.1, position=(0.0, 0.0)))
    mech.add(Slider("rail", "ground", "cart", axis=(1.0, 0.0)))
    mech.add(SpringDamper("k", "ground", "cart", 80.0, 1.2, point_a=(-1.0, 0.0), length=1.0))
    mech.add(RigidBody("pole", 0.5, 0.02, position=(0.6 * np.cos(theta), 0.6 * np.sin(theta)), angle=theta))
    mech.add(Hinge("pin", "cart", "pole", at=(0.0, 0.0)))
    mech.add(DrivenAngle("motor", "cart", "pole", u))
    mech.add(Gravity((0.0, -9.81)))
    return mech.compile(), u


def _drive_signal(lin, z, w):
    """(u, u̇, ü) of the drive from the state and the inputs (by their names)."""
    sig = dict(zip(lin.state_names, z)) | dict(zip(lin.input_names, w))
    return np.array([sig.get("motor", 0.0), sig.get("motor_d", 0.0), sig.get("motor_dd", 0.0)])


def _fd(model, u, lin, h=1e-6):
    """Central differences of ż and of the outputs (the drive's torque, the pole angle) in z and w."""
    Xz, Xv = lin.basis, lin.input_basis
    Xp = np.linalg.pinv(Xz)
    nu = fl.reaction(model, "motor", 0).nu
    i_pole = list(model.velocity_labels).index("pole.theta")

    def f(z, w):
        u.U[:] = _drive_signal(lin, z, w)
        dq, dv = np.split(Xz @ z + Xv @ w, 2)
        q = model.compose(model.q0, dq)
        vd, lam, mu = fl.reference(model, 0.0, q, dv)
        wd = np.zeros_like(w)                        # d/dt of the direct inputs: u̇ of a position drive
        names = list(lin.input_names)
        if "motor" in names and "motor_d" in names:
            wd[names.index("motor")] = u.U[1]
        zd = Xp @ (np.concatenate((dv, vd)) - Xv @ wd)
        return zd, np.array([lam[nu], dq[i_pole]])

    n, m = lin.A.shape[0], lin.B.shape[1]
    z0, w0 = np.zeros(n), np.zeros(m)
    A = np.array([(f(z0 + h * e, w0)[0] - f(z0 - h * e, w0)[0]) / (2 * h) for e in np.eye(n)]).T
    B = np.array([(f(z0, w0 + h * e)[0] - f(z0, w0 - h * e)[0]) / (2 * h) for e in np.eye(m)]).T
    C = np.array([(f(z0 + h * e, w0)[1] - f(z0 - h * e, w0)[1]) / (2 * h) for e in np.eye(n)]).T
    D = np.array([(f(z0, w0 + h * e)[1] - f(z0, w0 - h * e)[1]) / (2 * h) for e in np.eye(m)]).T
    u.U[:] = 0.0
    return A, B, C, D


def _close(got, want, rel=1e-6):
    scale = max(np.abs(want).max(initial=0.0), 1.0)
    assert np.abs(got - want).max(initial=0.0) < rel * scale, (got, want)


def test_drive_acceleration_input_matches_finite_differences():
    """kind='acceleration': states (cart x, ẋ, drive u, u̇), input ü; A, B and the C, D rows of the drive
    torque (a reaction: it feels ü) and of the pole angle against central differences of femb's own
    nonlinear accelerations and multipliers with the drive set to (u, u̇, ü)."""
    model, u = _driven_cart()
    outs = [fl.reaction(model, "motor", 0), fl.Output("pole angle", "rad", *_pole_rows(model))]
    lin = fl.linearize(model, inputs=[fl.drive(model, "motor", kind="acceleration")], outputs=outs)
    assert lin.state_names[-2:] == ["motor", "motor_d"] and lin.input_names == ["motor_dd"]
    assert lin.A.shape == (4, 4) and lin.input_units == ["rad/s²"]
    A, B, C, D = _fd(model, u, lin)
    _close(lin.A, A)
    _close(lin.B, B)
    _close(lin.C, C)
    _close(lin.D, D)
    assert abs(lin.D[0, 0]) > 1e-3                    # the motor torque feels ü directly
    np.testing.assert_allclose(lin.C[1], [0, 0, 1, 0], atol=1e-12)     # the pole angle is the drive's


def _pole_rows(model):
    cq = np.zeros(model.nq)
    cq[list(model.velocity_labels).index("pole.theta")] = 1.0
    return cq, np.zeros(model.nq)


@pytest.mark.parametrize("kind", ["position", "speed"])
def test_drive_position_and_speed_inputs_match_finite_differences(kind):
    """kind='position': inputs (u, u̇), the state (x, ẋ); kind='speed': input u̇, u a state. The pole
    angle has the feed-through D = 1 from u (position); a reaction output needs ü and is refused."""
    model, u = _driven_cart(theta=0.9)
    outs = [fl.Output("pole angle", "rad", *_pole_rows(model))]
    lin = fl.linearize(model, inputs=[fl.force(model, model.q0, "cart", (1.0, 0.0), name="F"),
                                      fl.drive(model, "motor", kind=kind)], outputs=outs)
    want_in = ["F", "motor", "motor_d"] if kind == "position" else ["F", "motor_d"]
    assert lin.input_names == want_in
    A, B, _, _ = _fd(model, u, lin)
    _close(lin.A, A)
    _close(lin.B[:, 1:], B[:, 1:])
    Bf = fl.linearize(model, inputs=[fl.force(model, model.q0, "cart", (1.0, 0.0))]).B
    assert np.abs(lin.B[:2, 0]).max() > 0 and np.abs(Bf).max() > 0
    if kind == "position":
        np.testing.assert_allclose(lin.D, [[0.0, 1.0, 0.0]], atol=1e-12)
    else:
        np.testing.assert_allclose(lin.C[0], [0, 0, 1], atol=1e-12)
    with pytest.raises(ParameterError, match="acceleration of a drive"):
        fl.linearize(model, inputs=[fl.drive(model, "motor", kind=kind)], outputs=[fl.reaction(model, "motor", 0)])


def test_drive_input_errors_are_named():
    model, u = _driven_cart()
    with pytest.raises(ModelError, match="'pin' is not a driven constraint"):
        fl.drive(model, "pin")
    with pytest.raises(ModelError, match="no element named 'motr'"):
        fl.drive(model, "motr")
    with pytest.raises(ParameterError, match="kind must be"):
        fl.drive(model, "motor", kind="jerk")
    with pytest.raises(ParameterError, match="inputs must be"):
        fl.linearize(model, inputs=["motor"])
    u.U[1] = 0.5
    with pytest.raises(ParameterError, match="DrivenAngle 'motor' moves"):
        fl.linearize(model)
    u.U[1] = 0.0


# ---------------------------------------------------------------- the bicycle steered by its angle
@pytest.mark.parametrize("v", [0.0, 3.0, 5.0, 8.0])
def test_bicycle_with_steer_angle_input_equals_canonical_equations(v):
    """The 3-D Whipple bicycle with a DrivenRevoluteAngle on the steer axis, its acceleration δ̈ the input
    (kind='acceleration'): in (φ, δ, φ̇, δ̇) the lean row of Meijaard et al. (2007),
    M₀₀ φ̈ + M₀₁ δ̈ + v C₁[0]·(φ̇, δ̇) + (g K₀ + v² K₂)[0]·(φ, δ) = 0, and the drive's torque
    −λ = T_δ from the steer row, exactly (1e-9), with the drift eliminated by symmetry."""
    from femb.benchmarks.references import whipple_linear as ref
    from femb.benchmarks.scenes.spatial import whipple_bicycle as wb
    from femb.elements import DrivenRevoluteAngle
    p = ref.BENCHMARK
    mech = wb.build(0.0)
    mech.add(DrivenRevoluteAngle("steer_drive", "rear_frame", "front_frame", Held(), at=(p["w"] + p["c"], 0.0, 0.0),
                                 axis=wb.steer_axis()))
    model = mech.compile()
    q = model.q0
    phi = fl.angle(model, q, "rear_frame", (1.0, 0.0, 0.0), name="lean")
    delta = fl.angle(model, q, "front_frame", wb.steer_axis(), relative_to="rear_frame", name="steer")
    states = [phi, delta, fl.Output("lean_d", "rad/s", phi.cq, phi.cv, True),
              fl.Output("steer_d", "rad/s", delta.cq, delta.cv, True)]
    lin = fl.linearize(model, (q, wb.velocities(model, v)), about="steady", symmetries=wb.symmetries(model),
                       inputs=[fl.drive(model, "steer_drive", kind="acceleration")],
                       outputs=[fl.reaction(model, "steer_drive", 0)], states=states)
    M, C1, K0, K2 = ref.canonical_matrices()
    Kv, Cv = p["g"] * K0 + v * v * K2, v * C1
    lean = -np.concatenate((Kv[0], Cv[0])) / M[0, 0]
    A = np.array([[0, 0, 1, 0], [0, 0, 0, 1], lean, [0, 0, 0, 0]])
    B = np.array([0, 0, -M[0, 1] / M[0, 0], 1.0])
    np.testing.assert_allclose(lin.A, A, rtol=0, atol=1e-9 * max(1.0, v * v))
    np.testing.assert_allclose(lin.B[:, 0], B, rtol=0, atol=1e-10)
    T_C = M[1, 0] * lean + np.concatenate((Kv[1], Cv[1]))       # T_δ = M₁₀ φ̈ + M₁₁ δ̈ + ...
    T_D = M[1, 0] * B[2] + M[1, 1]
    np.testing.assert_allclose(-lin.C[0], T_C, rtol=0, atol=1e-9 * max(1.0, v * v))
    assert -lin.D[0, 0] == pytest.approx(T_D, abs=1e-10)
