"""An LQR gain from the linearization stabilizes the nonlinear femb model (a compiled user force kernel)."""
import numpy as np
import scipy.linalg as sla

import femb
from femb.base.jit import kernel
from femb.system.element import Element

from femb.benchmarks.accuracy.linearize_scenes import cart_pendulum
from femb.benchmarks.accuracy.linearize_scenes import cart_pendulum_linear as _cart_linear


@kernel
def feedback_force(P, t, tf, xe, ve, jac, fe, fq, fv):
    """u = −k·(x − x_ref, θ − θ_ref, ẋ, θ̇) on the cart's x; P = (k (4), x_ref, θ_ref)."""
    for e in range(xe.shape[0]):
        u = -(P[e, 0] * (xe[e, 0] - P[e, 4]) + P[e, 1] * (xe[e, 5] - P[e, 5])
              + P[e, 2] * ve[e, 0] + P[e, 3] * ve[e, 5])
        fe[e, 0] = u
        if jac:
            fq[e, 0, 0] = -P[e, 0]
            fq[e, 0, 5] = -P[e, 1]
            fv[e, 0, 0] = -P[e, 2]
            fv[e, 0, 5] = -P[e, 3]


class StateFeedback(Element):
    """A force on the cart from the state of cart and pole (x, θ, ẋ, θ̇)."""
    has_force = True
    force_depends_on_qd = True
    kernels = {"force": feedback_force}

    def __init__(self, name, cart, pole, gain, x_ref, theta_ref):
        super().__init__(name)
        self.cart, self.pole = cart, pole
        self.gain = np.asarray(gain, dtype=float).reshape(4)
        self.ref = (float(x_ref), float(theta_ref))

    def resolve(self, lookup):
        self.cart, self.pole = lookup(self.cart, "cart"), lookup(self.pole, "pole")

    def nodes(self):
        return [self.cart.node, self.pole.node]

    @classmethod
    def pack(cls, elements):
        return {"P": np.ascontiguousarray([[*e.gain, *e.ref] for e in elements], dtype=float)}


def _run(gain, tilt, t_end=4.0):
    mech = cart_pendulum(theta0=np.pi / 2 + tilt)
    if gain is not None:
        mech.add(StateFeedback("lqr", "cart", "pole", gain, 0.0, np.pi / 2))
    model = mech.compile()
    assert gain is None or femb.check_jacobians(model).ok
    res = femb.simulate(model, t_end, h=2e-3)
    th = np.array([model.node_coordinates("pole", q)[2] for q in res.q]) - np.pi / 2
    x = np.array([model.node_coordinates("cart", q)[0] for q in res.q])
    return res.t, x, th


def test_lqr_from_the_linearization_stabilizes_the_nonlinear_model():
    model = cart_pendulum().compile()
    lin = _cart_linear(model)                       # states (x, θ, ẋ, θ̇), input the cart force
    Q, R = np.diag([10.0, 100.0, 1.0, 1.0]), np.array([[0.1]])
    P = sla.solve_continuous_are(lin.A, lin.B, Q, R)
    K = np.linalg.solve(R, lin.B.T @ P)[0]
    assert np.all(np.linalg.eigvals(lin.A - np.outer(lin.B[:, 0], K)).real < 0)
    t, x, th = _run(K, 0.25, t_end=8.0)             # 14° off the top, a nonlinear start
    assert np.max(np.abs(th)) < 0.3                 # held up …
    assert abs(th[-1]) < 1e-3 and abs(x[-1]) < 1e-2  # … and brought back to the top, the cart home
    _, _, th_free = _run(None, 0.25, t_end=1.0)     # without the controller it falls
    assert np.max(np.abs(th_free)) > 1.0
