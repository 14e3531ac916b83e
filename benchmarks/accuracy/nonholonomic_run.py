"""Velocity-level (non-holonomic) constraints in the time loop: convergence against independent references.

``python -m femb.benchmarks.accuracy.nonholonomic_run`` prints the table of docs/linearize.md §8:
the rolling coin and the Chaplygin sleigh against the references of
:mod:`femb.benchmarks.references.rolling_disc_ode` (scipy at rtol 1e-12), fitted orders in q and in
the reactions, the velocity residual max |A q̇ + a| over every stored step, steady circular
rolling and the energy of the ideal rolling coin. The same scenes and settings as
``tests/test_nonholonomic_run.py``.
"""
from __future__ import annotations

import warnings

import numpy as np

import femb
from femb import Mechanism
from femb.base.rotations import expm
from femb.benchmarks.references.rolling_disc_ode import ChaplyginSleigh, RollingDisc as DiscReference, quat_matrix
from femb.elements import RigidBody
from femb.elements.rolling import KnifeEdge, RollingDisc
from femb.elements.spatial_bodies import SpatialRigidBody
from femb.elements.spatial_forces import SpatialGravity
from femb.system.assembly import velocity_constraints

RHO, MASS = 0.5, 1.0
Z = np.array([0.0, 0.0, 1.0])


def coin(R0=None, omega_space=None):
    """The thin coin (ρ = 0.5 m, 1 kg) on z = 0, axis R0 e_y, rolling with ω (space axes)."""
    R0 = expm(np.array([0.3, 0.0, 0.0])) if R0 is None else R0
    w = R0 @ np.array([0.0, 6.0, 0.5]) if omega_space is None else np.asarray(omega_space, float)
    a = R0 @ np.array([0.0, 1.0, 0.0])
    d = (Z - (Z @ a) * a) / np.sqrt(1.0 - (Z @ a) ** 2)
    m = Mechanism("coin")
    m.add(SpatialRigidBody("disc", MASS, (MASS * RHO ** 2 / 4, MASS * RHO ** 2 / 2, MASS * RHO ** 2 / 4),
                           position=RHO * d, rotation=R0, omega=tuple(R0.T @ w), velocity=tuple(RHO * np.cross(w, d))))
    m.add(RollingDisc("roll", "disc", RHO, (0.0, 1.0, 0.0)))
    m.add(SpatialGravity())
    return m.compile()


def residual(model, res):
    """max |A q̇ + a| over the stored steps."""
    return max(float(np.abs(velocity_constraints(model, t, q, qd)[0]).max())
               for t, q, qd in zip(res.t, res.q, res.qd))


def _order(hs, e):
    return float(np.polyfit(np.log(hs), np.log(e), 1)[0])


def coin_convergence(hs=(4e-3, 2e-3, 1e-3, 5e-4), T=1.0):
    """Errors of the centre, the rotation matrix and [λ; μ] at T against the reference; orders."""
    model = coin()
    errs, ref, psi = [], None, 0.0
    for h in hs:
        res = femb.simulate(model, T, h=h)
        if ref is None:
            R0 = quat_matrix(res.q[0, 3:7])
            w0 = R0 @ res.qd[0, 3:6]
            dr = DiscReference(MASS, RHO)
            d0 = dr.geometry(R0, w0)[1]
            ref = dr.solve(res.q[0, 3:7], w0, res.q[0, 0:3] - RHO * d0, [0.0, T])
        F, lam = ref["F"][-1], res.lam[-1]
        errs.append((np.abs(res.q[-1, 0:3] - ref["G"][-1]).max(),
                     np.abs(quat_matrix(res.q[-1, 3:7]) - quat_matrix(ref["p"][-1])).max(),
                     max(abs(-lam[0] - F[2]), abs(-lam[1] - F[0]), abs(-lam[2] - F[1]))))
        psi = max(psi, residual(model, res))
    errs = np.array(errs)
    return errs, [_order(hs, errs[:, j]) for j in range(3)], psi


def sleigh_convergence(hs=(8e-3, 4e-3, 2e-3, 1e-3), T=2.0, mass=2.0, J=0.3, b=-0.4, th0=0.2, u0=1.0, w0=0.8):
    """Errors of q, q̇ and the lateral force at T against the reference; orders."""
    e = np.array([np.cos(th0), np.sin(th0)])
    l_ = np.array([-np.sin(th0), np.cos(th0)])
    m = Mechanism("sleigh")
    m.add(RigidBody("s", mass, J, angle=th0, velocity=tuple(u0 * e - b * w0 * l_), omega=w0))
    m.add(KnifeEdge("k", "s", 0.0, (b, 0.0)))
    model = m.compile()
    ref = ChaplyginSleigh(mass, J, b).solve(0.0, 0.0, th0, u0, w0, [0.0, T])
    errs, psi = [], 0.0
    for h in hs:
        res = femb.simulate(model, T, h=h)
        errs.append((np.abs(res.q[-1] - ref["q"][-1]).max(), np.abs(res.qd[-1] - ref["qd"][-1]).max(),
                     abs(-res.lam[-1, 0] - ref["F"][-1])))
        psi = max(psi, residual(model, res))
    errs = np.array(errs)
    return errs, [_order(hs, errs[:, j]) for j in range(3)], psi


def steady_rolling(hs=(2e-3, 1e-3), lean=0.3, yaw=2.0, T=3.0):
    """Largest change of the lean (axis z-component), yaw rate and normal force over T, per h."""
    R0 = expm(np.array([lean, 0.0, 0.0]))
    dr = DiscReference(MASS, RHO)
    ws, _ = dr.steady_spin(R0, yaw)
    a = dr.geometry(R0, Z)[0]
    w = yaw * Z + ws * a
    model = coin(R0, w)
    out = []
    for h in hs:
        res = femb.simulate(model, T, h=h)
        Rs = [quat_matrix(p) for p in res.q[:, 3:7]]
        out.append((max(abs((R @ [0.0, 1.0, 0.0])[2] - a[2]) for R in Rs),
                    max(abs((R @ om)[2] - w[2]) for R, om in zip(Rs, res.qd[:, 3:6])),
                    float(np.ptp(res.lam[:, 0]) / abs(res.lam[0, 0]))))
    return np.array(out)


def energy(hs=(4e-3, 2e-3, 1e-3), T=2.0):
    """Largest drift of the total energy of the coin over T, per h, and its order."""
    model = coin()
    drift, E0 = [], 0.0
    for h in hs:
        E = femb.simulate(model, T, h=h).energy()["total"]
        drift.append(float(np.abs(E - E[0]).max()))
        E0 = float(E[0])
    return drift, _order(hs, drift), E0


def adaptive(rtols=(1e-4, 1e-6), T=1.0):
    """Adaptive steps on the coin: (rtol, steps, centre error at T, max |A q̇ + a|) per rtol."""
    model = coin()
    out = []
    for rtol in rtols:
        res = femb.simulate(model, T, rtol=rtol)
        R0 = quat_matrix(res.q[0, 3:7])
        w0 = R0 @ res.qd[0, 3:6]
        dr = DiscReference(MASS, RHO)
        ref = dr.solve(res.q[0, 3:7], w0, res.q[0, 0:3] - RHO * dr.geometry(R0, w0)[1], [0.0, T])
        out.append((rtol, res.steps, float(np.abs(res.q[-1, 0:3] - ref["G"][-1]).max()), residual(model, res)))
    return out


def main():
    warnings.simplefilter("ignore")
    errs, orders, psi = coin_convergence()
    print("coin, t = 1 s, h = 4, 2, 1, 0.5 ms: errors (centre, rotation, reactions)")
    print(np.array2string(errs, precision=3), "orders", np.round(orders, 4), f"max |A q̇ + a| {psi:.1e} m/s")
    errs, orders, psi = sleigh_convergence()
    print("sleigh, t = 2 s, h = 8, 4, 2, 1 ms: errors (q, q̇, lateral force)")
    print(np.array2string(errs, precision=3), "orders", np.round(orders, 4), f"max |A q̇ + a| {psi:.1e} m/s")
    print("steady rolling, h = 2, 1 ms: (lean, yaw rate, normal force rel.)\n",
          np.array2string(steady_rolling(), precision=3))
    for rtol, n, err, psi in adaptive():
        print(f"coin, adaptive rtol = {rtol:g}: {n} steps, centre error {err:.2e} m, max |A q̇ + a| {psi:.1e} m/s")
    drift, order, E0 = energy()
    print(f"energy of the coin ({E0:.3f} J), h = 4, 2, 1 ms: drift {np.round(drift, 9)}, order {order:.3f}")


if __name__ == "__main__":
    main()
