"""Figures of the start of flexible models (femb/system/initial.py, docs/engine.md "Consistent initial values").

The four-bar with a beam coupler (:mod:`femb.benchmarks.scenes.beams.flexible_fourbar_3d`,
8 elements, driver at full speed from t = 0, ρ∞ = 0.8), against the same mechanism with a
rigid coupler run with the same h:

* ``t0``: |T_drive(0) − rigid| / |rigid| with E × 10⁴ at h = 1, 0.5, 0.25 ms;
* ``ringing``: the largest |T_drive − rigid| over the first 100 steps with E × 10⁶ at h = 1 ms (N m);
* ``aluminium``: the largest |T_drive| over 0.1 s of the aluminium coupler (E × 1) at h = 1 ms,
  and the rigid coupler's (N m).

and the same t = 0 figure for an R–S–U–R loop with a skew rocker axis and a steel coupler
(:func:`skew_rsur`), and the energy balance and dissipated energy of a planar slider-crank whose
rod has E × 10⁴ and material damping η = 10⁻³ s at h = 1 ms over 0.1 s (:func:`slider_crank`).
The two loops are those of ``tests/test_flexible_start_probes.py``.

    python -m femb.benchmarks.accuracy.flexible_start

About 25 s on a 2-core machine.
"""
from __future__ import annotations

import math

import numpy as np

from femb import Mechanism
from femb.base.functions import Linear
from femb.elements import DrivenAngle, Hinge, PointMass, PointOnLine, RigidBody, Section, add_beam
from femb.elements.spatial_beam import SpatialSection, spatial_beam
from femb.elements.spatial_bodies import SpatialRigidBody
from femb.elements.spatial_forces import SpatialGravity
from femb.elements.spatial_joints import DrivenRevoluteAngle, RevoluteJoint, SphericalJoint, UniversalJoint


def _rod(name, m, p0, p1, r=0.01):
    d = (p1 - p0) / np.linalg.norm(p1 - p0)
    L = np.linalg.norm(p1 - p0)
    J = m * (3 * r * r + L * L) / 12.0 * (np.eye(3) - np.outer(d, d)) + 0.5 * m * r * r * np.outer(d, d)
    return SpatialRigidBody(name, m, J, position=0.5 * (p0 + p1))


def skew_rsur(stiffness=1.0, damping=0.0, rigid=False, n=6, omega=4.0):
    """Crank about z at O, rocker about the skew axis (0, 0.4, 1)/|·| at D, steel coupler (d = 12 mm)
    with a spherical joint at B and a universal joint at C; gravity along −y."""
    O, B = np.zeros(3), np.array([0.0, 0.15, 0.0])
    aD = np.array([0.0, 0.4, 1.0]) / math.hypot(0.4, 1.0)
    D = np.array([0.7, 0.0, -0.1])
    u = np.array([-0.2, 0.9, -0.36])
    C = D + 0.45 * u / np.linalg.norm(u)
    C = C - ((C - D) @ aD) * aD                      # in the rocker's plane
    z = np.array([0.0, 0.0, 1.0])
    m = Mechanism("skew_rsur")
    crank, rocker = m.add(_rod("crank", 0.4, O, B)), m.add(_rod("rocker", 1.0, D, C))
    m.add(RevoluteJoint("O", m.ground, crank, at=O, axis=z))
    m.add(DrivenRevoluteAngle("drive", m.ground, crank, Linear(omega), at=O, axis=z))
    m.add(RevoluteJoint("D", m.ground, rocker, at=D, axis=aD))
    sec = SpatialSection.circle(2.1e11 * stiffness, 8.1e10 * stiffness, 0.012, density=7850.0, damping=damping)
    e1 = (C - B) / np.linalg.norm(C - B)
    pin = np.cross(e1, aD) / np.linalg.norm(np.cross(e1, aD))
    if rigid:
        L = float(np.linalg.norm(C - B))
        mass = sec.rhoA * L
        e2 = np.cross(aD, e1) / np.linalg.norm(np.cross(aD, e1))
        J = (sec.rhoJ[0, 0] * L, mass * L * L / 12 + sec.rhoJ[1, 1] * L, mass * L * L / 12 + sec.rhoJ[2, 2] * L)
        end_b = end_c = m.add(SpatialRigidBody("coupler", mass, J, position=0.5 * (B + C),
                                               rotation=np.column_stack((e1, e2, np.cross(e1, e2)))))
    else:
        beam = spatial_beam(m, "coupler", sec, [B, C], n)
        end_b, end_c = beam.nodes[0], beam.nodes[-1]
    m.add(SphericalJoint("B", crank, end_b, at=B))
    m.add(UniversalJoint("C", rocker, end_c, axis_a=aD, axis_b=pin, at=C))
    m.add(SpatialGravity((0.0, -9.81, 0.0)))
    return m


def slider_crank(stiffness=1.0, damping=0.0, rigid=False, n=6, omega=30.0):
    """Crank 0.15 m (vertical at t0) driven at 30 rad/s, steel rod 0.4 m (d = 8 mm) hinged to it and
    to a slider on the x axis."""
    L1, L2 = 0.15, 0.4
    xs = math.sqrt(L2 ** 2 - L1 ** 2)
    m = Mechanism("flexible_rod_slider_crank")
    crank = m.add(RigidBody("crank", 0.3, 0.3 * L1 ** 2 / 12, position=(0.0, 0.5 * L1),
                            points={"A": (0.0, 0.5 * L1)}))
    slider = m.add(PointMass("slider", 0.2, position=(xs, 0.0)))
    m.add(Hinge("O", m.ground, crank, at=(0.0, 0.0)))
    m.add(DrivenAngle("drive", m.ground, crank, Linear(omega)))
    m.add(PointOnLine("guide", m.ground, slider, axis=(1.0, 0.0)))
    sec = Section.circle(2.0e11 * stiffness, 2.0e11 * stiffness / 2.6, 8e-3, 7850.0, damping=damping)
    if rigid:
        mass = sec.rhoA * L2
        rod = m.add(RigidBody("rod", mass, mass * L2 ** 2 / 12, position=(0.5 * xs, 0.5 * L1),
                              angle=math.atan2(-L1, xs)))
        m.add(Hinge("rod.start", crank, rod, at=(0.0, L1)))
        m.add(Hinge("rod.end", rod, slider, at=(xs, 0.0)))
    else:
        add_beam(m, "rod", sec, (crank, "A"), slider, n, start_joint="hinge", end_joint="hinge")
    return m


def _drive(h, t_end, **params):
    import femb
    from femb.study import registry

    scene = registry.load("flexible_fourbar_3d").module
    model = scene.build(8, ramp="constant", **params).compile()
    return scene.outputs(femb.simulate(model, t_end, h, rho_inf=0.8))["T_drive"]


def figures():
    """The figures of the module docstring (dict)."""
    import femb

    out = {"t0": [], "t0_skew": []}
    for h in (1e-3, 5e-4, 2.5e-4):
        rigid, flex = _drive(h, 2 * h, rigid=True)[0], _drive(h, 2 * h, stiffness=1e4)[0]
        out["t0"].append((h, rigid, flex, abs(flex - rigid) / abs(rigid)))
        rigid = femb.simulate(skew_rsur(rigid=True).compile(), 2 * h, h).series("drive.Mz")[0][0]
        flex = femb.simulate(skew_rsur(stiffness=1e4).compile(), 2 * h, h).series("drive.Mz")[0][0]
        out["t0_skew"].append((h, rigid, flex, abs(flex - rigid) / abs(rigid)))
    rigid = _drive(1e-3, 0.1, rigid=True)
    out["ringing"] = float(np.abs(_drive(1e-3, 0.1, stiffness=1e6) - rigid).max())
    out["aluminium"] = (float(np.abs(_drive(1e-3, 0.1)).max()), float(np.abs(rigid).max()))
    r = femb.simulate(slider_crank(stiffness=1e4, damping=1e-3).compile(), 0.1, 1e-3)
    out["damped_rod"] = (r.energy_balance(), float(r.energy()["dissipated"][-1]))
    return out


def main():
    f = figures()
    for key, name in (("t0", "four-bar"), ("t0_skew", "skew R-S-U-R")):
        for h, rigid, flex, rel in f[key]:
            print(f"t0 reaction, {name}, E x 1e4, h = {h:g} s: rigid {rigid:.6g} N m, beam {flex:.6g} N m, "
                  f"relative {rel:.3g}")
    print(f"ringing, four-bar E x 1e6, h = 1 ms, first 100 steps: {f['ringing']:.3g} N m")
    print(f"aluminium four-bar at full speed, h = 1 ms: max |T_drive| {f['aluminium'][0]:.3g} N m "
          f"(rigid {f['aluminium'][1]:.3g})")
    print(f"slider-crank rod E x 1e4, eta = 1e-3 s, h = 1 ms, 0.1 s: energy balance {f['damped_rod'][0]:.3g}, "
          f"dissipated {f['damped_rod'][1]:.3g} J")


if __name__ == "__main__":
    main()
