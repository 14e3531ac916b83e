"""Small scenes with closed-form linearizations: mass–spring–damper, sleeping top, rolling coin,
cart–pendulum, Chaplygin sleigh (each built from femb elements, linearized by :mod:`femb.analysis.linearize`).

``python -m femb.benchmarks.accuracy.linearize_scenes`` prints each scene's largest eigenvalue error against
its closed form (docs/linearize.md, §6). Closed forms: damped oscillator s = ω₀(−ζ ± i√(1 − ζ²));
sleeping top I₁s² − iI₃ωs − mgl = 0 (I₁ about the pivot; Goldstein, Classical Mechanics, §5.7);
upright rolling disc (A + mr²)φ̈ + [(C + mr²)Cω²/A − mgr]φ = 0 with A ψ̈ + Cωφ̇ = 0 (Neimark &
Fufaev 1972, Ch. V), stable for ω² > mgrA/(C(C + mr²)) = g/(3r) for a thin uniform disc;
cart–pendulum M q̈ + K q = B F; Chaplygin sleigh (J + ma²)ω̇ = −mauω (Neimark & Fufaev 1972, Ch. V).
"""
from __future__ import annotations

import numpy as np

from femb import Mechanism
from femb.analysis import linearize as fl
from femb.elements import Hinge, RigidBody, Slider, SpringDamper
from femb.elements.forces import Gravity
from femb.elements.rolling import KnifeEdge, RollingDisc
from femb.elements.spatial_bodies import SpatialRigidBody
from femb.elements.spatial_forces import SpatialGravity
from femb.elements.spatial_joints import SphericalJoint

TOP = dict(m=15.0, Ix=0.234375, I3=0.46875, l=1.0, g=9.81)


def mass_spring(m=2.0, k=4000.0, d=8.0):
    """A mass on a slider with a spring–damper: LinearModel of (x, ẋ), and its closed form eigenvalues."""
    mech = Mechanism("msd")
    mech.add(RigidBody("mass", m, 0.1, position=(1.0, 0.0)))
    mech.add(Slider("s", "ground", "mass", axis=(1.0, 0.0)))
    mech.add(SpringDamper("k", "ground", "mass", k, d, point_a=(0.0, 0.0), length=1.0))
    model = mech.compile()
    x = fl.coordinate(model, "mass.x")
    lin = fl.linearize(model, states=[x, fl.coordinate(model, "mass.x", rate=True)])
    w0, z = np.sqrt(k / m), d / (2.0 * np.sqrt(k * m))
    return lin, w0 * (-z + np.array([1, -1]) * np.sqrt(complex(z * z - 1.0)))


def sleeping_top(spin_rate=40.0, frame="fixed", m=TOP["m"], Ix=TOP["Ix"], I3=TOP["I3"], l=TOP["l"], g=TOP["g"]):
    """A symmetric top spinning upright on a spherical joint, linearized as a steady motion.

    ``frame="fixed"``: the spin is the body's own rotation (ω_R), perturbations in a non-turning
    frame; ``"turning"``: the spin as a world rotation ω_L = ω e_z, perturbations in the frame turning
    with the top (every eigenvalue shifted by −iω, conjugates by +iω). Eliminated: the spin angle (or
    the rotation about z) and the spin rate (the family of steady motions). Returns (LinearModel, closed form).
    """
    mech = Mechanism("sleeping_top")
    mech.add(SpatialRigidBody("top", m, (Ix, Ix, I3), position=(0.0, 0.0, l), omega=(0.0, 0.0, spin_rate)))
    mech.add(SphericalJoint("pivot", "ground", "top", at=(0.0, 0.0, 0.0)))
    mech.add(SpatialGravity((0.0, 0.0, -g)))
    model = mech.compile()
    dv = np.zeros(model.nq)
    dv[model.node_vindex["top"][5]] = 1.0
    rate = fl.direction(np.zeros(model.nq), dv, "spin rate")
    if frame == "fixed":
        lin = fl.linearize(model, (model.q0, model.qd0), about="steady",
                           symmetries=[fl.spin("top", (0.0, 0.0, 1.0)), rate])
    else:
        lin = fl.linearize(model, (model.q0, model.qd0), about="steady", omega=(0.0, 0.0, spin_rate),
                           symmetries=[fl.rotation((0.0, 0.0, 1.0)), rate])
    I1 = Ix + m * l * l
    disc = np.sqrt(complex(4.0 * I1 * m * g * l - (I3 * spin_rate) ** 2))
    r = np.array([(1j * I3 * spin_rate + disc) / (2 * I1), (1j * I3 * spin_rate - disc) / (2 * I1)])
    if frame != "fixed":
        r = r - 1j * spin_rate
    return lin, np.concatenate((r, r.conj()))


def rolling_coin(omega, m=1.3, r=0.4, g=9.81):
    """A thin uniform disc rolling upright and straight with spin ω: LinearModel of 3 states, closed form."""
    mech = Mechanism("coin")
    A, C = m * r * r / 4.0, m * r * r / 2.0
    mech.add(SpatialRigidBody("coin", m, (A, C, A), position=(0.0, 0.0, r), velocity=(r * omega, 0.0, 0.0),
                              omega=(0.0, omega, 0.0)))
    mech.add(RollingDisc("contact", "coin", r, (0.0, 1.0, 0.0)))
    mech.add(SpatialGravity((0.0, 0.0, -g)))
    model = mech.compile()
    dv = np.zeros(model.nq)
    idx = model.node_vindex["coin"]
    dv[idx[0]], dv[idx[4]] = r, 1.0
    syms = [fl.translation((1, 0, 0)), fl.translation((0, 1, 0)), fl.rotation((0, 0, 1)),
            fl.spin("coin", (0, 1, 0)), fl.direction(np.zeros(model.nq), dv, "spin rate")]
    lin = fl.linearize(model, (model.q0, model.qd0), about="steady", symmetries=syms)
    s = np.sqrt(complex(-((C + m * r * r) * C * omega ** 2 / A - m * g * r) / (A + m * r * r)))
    return lin, np.array([s, -s, 0.0])


def cart_pendulum(mc=1.5, m=0.5, l=0.6, J=0.02, g=9.81, theta0=np.pi / 2):
    """A cart on a rail with a pole hinged on it (pole angle θ counter-clockwise, upright at π/2)."""
    mech = Mechanism("cart_pendulum")
    mech.add(RigidBody("cart", mc, 0.1, position=(0.0, 0.0)))
    mech.add(Slider("rail", "ground", "cart", axis=(1.0, 0.0)))
    mech.add(RigidBody("pole", m, J, position=(l * np.cos(theta0), l * np.sin(theta0)), angle=theta0))
    mech.add(Hinge("pin", "cart", "pole", at=(0.0, 0.0)))
    mech.add(Gravity((0.0, -g)))
    return mech


def cart_pendulum_linear(model):
    """LinearModel of (x, θ, ẋ, θ̇) with the cart force F as input and (x, θ) as outputs."""
    states = [fl.coordinate(model, "cart.x"), fl.coordinate(model, "pole.theta"),
              fl.coordinate(model, "cart.x", rate=True), fl.coordinate(model, "pole.theta", rate=True)]
    return fl.linearize(model, states=states, inputs=[fl.force(model, model.q0, "cart", (1.0, 0.0), name="F")],
                        outputs=states[:2])


def cart_pendulum_closed_form(mc=1.5, m=0.5, l=0.6, J=0.02, g=9.81):
    """(A, B) of the upright cart–pendulum in (x, θ, ẋ, θ̇)."""
    Mm = np.array([[mc + m, -m * l], [-m * l, J + m * l * l]])
    Km = np.array([[0.0, 0.0], [0.0, -m * g * l]])
    Mi = np.linalg.inv(Mm)
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-Mi @ Km, np.zeros((2, 2))]])
    return A, np.concatenate(([0.0, 0.0], Mi[:, 0]))[:, None]


def sleigh(u=2.0, a=0.3, m=2.5, J=0.3):
    """A Chaplygin sleigh sliding straight at speed u, blade a behind the centre of mass: (LinearModel, −mau/(J + ma²))."""
    mech = Mechanism("sleigh")
    mech.add(RigidBody("sled", m, J, velocity=(u, 0.0)))
    mech.add(KnifeEdge("blade", "sled", 0.0, (-a, 0.0)))
    model = mech.compile()
    dv = np.zeros(model.nq)
    dv[model.node_vindex["sled"][0]] = 1.0
    syms = [fl.translation((1, 0, 0)), fl.translation((0, 1, 0)), fl.rotation((0, 0, 1)),
            fl.direction(np.zeros(model.nq), dv, "speed")]
    lin = fl.linearize(model, (model.q0, model.qd0), about="steady", symmetries=syms)
    return lin, np.array([-m * a * u / (J + m * a * a)])


def match(got, want):
    """Largest distance between two sets of eigenvalues, each matched to its nearest."""
    got, want = np.asarray(got), np.asarray(want)
    return max(max(np.min(np.abs(got - w)) for w in want), max(np.min(np.abs(want - g)) for g in got))


def main():
    rows = [("mass–spring–damper k = 4000, d = 8", *mass_spring())]
    rows += [(f"sleeping top ω = {w:g} rad/s", *sleeping_top(w)) for w in (10.0, 40.0)]
    rows += [(f"sleeping top ω = {w:g}, turning frame", *sleeping_top(w, "turning")) for w in (10.0, 40.0)]
    rows += [(f"rolling coin ω = {w:g} rad/s", *rolling_coin(w)) for w in (2.0, 8.0)]
    rows += [("Chaplygin sleigh u = 2, a = 0.3", *sleigh())]
    print(f"{'scene':44s} {'states':>6s} {'max |Δλ|':>10s}")
    for name, lin, want in rows:
        print(f"{name:44s} {lin.n:6d} {match(lin.eig().eigenvalues, want):10.1e}")
    model = cart_pendulum().compile()
    lin = cart_pendulum_linear(model)
    A, B = cart_pendulum_closed_form()
    print(f"{'cart–pendulum: max |ΔA|, |ΔB|':44s} {lin.n:6d} {np.abs(lin.A - A).max():10.1e} "
          f"{np.abs(lin.B - B).max():.1e}")


if __name__ == "__main__":
    main()
