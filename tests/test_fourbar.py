"""Second-order convergence in q and λ on a closed-loop four-bar with gravity.

The reference is an independent model written here by hand (absolute
coordinates, the index-1 DAE [M Φ_qᵀ; Φ_q 0][q̈; λ] = [f; −γ] integrated by
scipy's DOP853 at rtol = atol = 1e-12); it shares no code with femb.
"""
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import femb
from femb.elements import Gravity, Hinge, RigidBody

L1, L2, L3, L4 = 0.4, 1.0, 0.8, 0.9
MS = (1.0, 2.0, 1.5)
G = 9.81
TH1, W1 = math.radians(70.0), 2.0


def geometry():
    """Consistent angles and rates for crank angle TH1 and rate W1 (circle intersection)."""
    A = L1 * np.array([math.cos(TH1), math.sin(TH1)])
    C = np.array([L4, 0.0])
    d = np.linalg.norm(C - A)
    a = (L2 ** 2 - L3 ** 2 + d ** 2) / (2 * d)
    hgt = math.sqrt(L2 ** 2 - a ** 2)
    u = (C - A) / d
    B = A + a * u + hgt * np.array([-u[1], u[0]])
    th2 = math.atan2(*(B - A)[::-1])
    th3 = math.atan2(*(B - C)[::-1])
    # velocities: L1 W1 J e1 + L2 w2 J e2 = L3 w3 J e3
    e = lambda th: np.array([-math.sin(th), math.cos(th)])
    w2, w3 = np.linalg.solve(np.column_stack((L2 * e(th2), -L3 * e(th3))), -L1 * W1 * e(TH1))
    return (TH1, th2, th3), (W1, w2, w3)


def centre_velocities(th, w):
    """Centre velocities of the three bars for consistent angles th and rates w."""
    n = lambda k: np.array([-math.sin(th[k]), math.cos(th[k])])
    vA = L1 * w[0] * n(0)
    return [0.5 * vA, vA + 0.5 * L2 * w[1] * n(1), 0.5 * L3 * w[2] * n(2)]


def build():
    (t1, t2, t3), (w1, w2, w3) = geometry()
    vc = centre_velocities((t1, t2, t3), (w1, w2, w3))
    mech = femb.Mechanism("fourbar")
    mech.ground.add_point("C", (L4, 0.0))
    bars = []
    for k, (Lk, th, w, base) in enumerate(((L1, t1, w1, np.zeros(2)),
                                          (L2, t2, w2, L1 * np.array([math.cos(t1), math.sin(t1)])),
                                          (L3, t3, w3, np.array([L4, 0.0])))):
        e = np.array([math.cos(th), math.sin(th)])
        c = base + 0.5 * Lk * e
        v = vc[k]
        bars.append(mech.add(RigidBody(f"bar{k + 1}", MS[k], MS[k] * Lk ** 2 / 12, c, th,
                                       omega=w, velocity=v, points={"s": (-Lk / 2, 0), "e": (Lk / 2, 0)})))
    mech.add(Hinge("O", "ground", bars[0], point_b="s"))
    mech.add(Hinge("A", bars[0], bars[1], point_a="e", point_b="s"))
    mech.add(Hinge("B", bars[1], bars[2], point_a="e", point_b="e"))
    mech.add(Hinge("C", "ground", bars[2], point_a="C", point_b="s"))
    mech.add(Gravity((0.0, -G)))
    return mech


# ------------------------------------------------------------------ reference
def _pt(q, k, s):
    x, y, th = q[3 * k:3 * k + 3]
    return np.array([x + math.cos(th) * s, y + math.sin(th) * s])


def ref_constraints(q):
    O, C = np.zeros(2), np.array([L4, 0.0])
    return np.concatenate((O - _pt(q, 0, -L1 / 2), _pt(q, 0, L1 / 2) - _pt(q, 1, -L2 / 2),
                           _pt(q, 1, L2 / 2) - _pt(q, 2, L3 / 2), C - _pt(q, 2, -L3 / 2)))


def ref_jac_gamma(q, v):
    B = np.zeros((8, 9))
    gam = np.zeros(8)

    def term(row, k, s, sign):
        th = q[3 * k + 2]
        B[row:row + 2, 3 * k:3 * k + 2] += sign * np.eye(2)
        B[row:row + 2, 3 * k + 2] += sign * s * np.array([-math.sin(th), math.cos(th)])
        gam[row:row + 2] += -sign * s * np.array([math.cos(th), math.sin(th)]) * v[3 * k + 2] ** 2

    term(0, 0, -L1 / 2, -1)
    term(2, 0, L1 / 2, 1)
    term(2, 1, -L2 / 2, -1)
    term(4, 1, L2 / 2, 1)
    term(4, 2, L3 / 2, -1)
    term(6, 2, -L3 / 2, -1)
    return B, gam


MASS = np.diag(np.concatenate([[m, m, m * Lk ** 2 / 12] for m, Lk in zip(MS, (L1, L2, L3))]))
FORCE = np.concatenate([[0.0, -m * G, 0.0] for m in MS])


def ref_acc(q, v):
    B, gam = ref_jac_gamma(q, v)
    K = np.block([[MASS, B.T], [B, np.zeros((8, 8))]])
    sol = np.linalg.solve(K, np.concatenate((FORCE, -gam)))
    return sol[:9], sol[9:]


def reference(t_end):
    (t1, t2, t3), (w1, w2, w3) = geometry()
    q0, v0 = [], []
    for Lk, th, w, base in ((L1, t1, w1, np.zeros(2)), (L2, t2, w2, L1 * np.array([math.cos(t1), math.sin(t1)])),
                            (L3, t3, w3, np.array([L4, 0.0]))):
        e = np.array([math.cos(th), math.sin(th)])
        n = np.array([-math.sin(th), math.cos(th)])
        q0 += list(base + 0.5 * Lk * e) + [th]
        v0 += [0, 0, w]
    vc = centre_velocities((t1, t2, t3), (w1, w2, w3))
    v0[0:2], v0[3:5], v0[6:8] = vc
    y0 = np.concatenate((q0, v0))
    assert np.abs(ref_constraints(np.array(q0))).max() < 1e-12
    sol = solve_ivp(lambda t, y: np.concatenate((y[9:], ref_acc(y[:9], y[9:])[0])), (0, t_end), y0,
                    method="DOP853", rtol=1e-12, atol=1e-12)
    q, v = sol.y[:9, -1], sol.y[9:, -1]
    return q, v, ref_acc(q, v)[1]


T_END = 1.0


@pytest.fixture(scope="module")
def ref():
    return reference(T_END)


def test_reference_is_consistent(ref):
    q, v, lam = ref
    assert np.abs(ref_constraints(q)).max() < 1e-9


def test_second_order_in_q_and_lambda(ref):
    q_ref, v_ref, lam_ref = ref
    model = build().compile()
    hs = np.array([8e-3, 4e-3, 2e-3, 1e-3])
    eq, ev, el = [], [], []
    for h in hs:
        r = femb.simulate(model, T_END, h, rho_inf=0.7)
        q = np.concatenate([r.body(f"bar{k}")[-1] for k in (1, 2, 3)])
        v = np.concatenate([r.body(f"bar{k}", "qd")[-1] for k in (1, 2, 3)])
        lam = np.concatenate([r.reaction(n)[-1] for n in ("O", "A", "B", "C")])
        eq.append(np.abs(q - q_ref).max())
        ev.append(np.abs(v - v_ref).max())
        el.append(np.abs(lam - lam_ref).max() / np.abs(lam_ref).max())
    order_q = np.polyfit(np.log(hs), np.log(eq), 1)[0]
    order_v = np.polyfit(np.log(hs), np.log(ev), 1)[0]
    order_l = np.polyfit(np.log(hs), np.log(el), 1)[0]
    assert order_q >= 1.9, (eq, order_q)
    assert order_v >= 1.9, (ev, order_v)
    assert order_l >= 1.9, (el, order_l)
    assert eq[-1] < 1e-4


@pytest.mark.parametrize("scaling", [True, False])
def test_constraint_residual_at_tolerance_after_every_step(scaling):
    model = build().compile()
    tol = 1e-12 * model.length_scale
    worst = []

    def observer(state, step):
        worst.append(np.abs(femb.system.assembly.constraint_vector(model, state.t, state.q)).max())

    r = femb.simulate(model, 0.5, 2e-3, scaling=scaling, observer=observer)
    assert len(worst) == r.steps + 1
    assert max(worst) <= tol
    # and the equations of motion hold at every stored step
    for k in range(0, r.t.size, 25):
        st = femb.State(r.t[k], r.q[k], r.qd[k], r.qdd[k], r.lam[k])
        r_q, _ = femb.system.assembly.residual(model, st)
        assert np.abs(r_q).max() <= 1e-9 * np.abs(FORCE).max()
