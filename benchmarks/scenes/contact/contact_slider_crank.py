"""Slider–crank with a translational clearance joint (Flores, Leine & Glocker 2010): hinges and contacts together.

A crank (l₁ = 0.153 m) hinged to the ground drives a connecting rod (l₂ = 0.306 m) hinged to the
centre of a slider (2a × 2b = 0.1 × 0.05 m) that moves between two guides with a clearance
c = 1 mm on each side: four corner contacts (the slider's top corners against the upper guide
y = b + c, its bottom corners against the lower guide y = −(b + c)), e_N = 0.4, μ = 0.01
(Table 1 of P. Flores, R. Leine, C. Glocker, "Modeling and analysis of planar rigid multibody
systems with translational clearance joints based on the non-smooth dynamics approach",
Multibody Syst. Dyn. 23 (2010) 165–190). Masses and inertias as in that table (crank 0.038 kg,
7.4e-5 kg m²; rod 0.038 kg, 5.9e-4 kg m²; slider 0.076 kg, 2.7e-6 kg m²), gravity 9.81 m/s²
along −y; the crank is not driven: it starts at angle 0 with ω₁ = 150 rad/s (ω₂ = −75 rad/s
follows from the hinges, the slider at rest).

The bilateral hinges are kept at index-3 exactness while the slider bounces between the guides.
The reference is femb itself at a smaller step (no closed form); docs/contact.md reports
penetration, hinge residuals and the agreement between step sizes.
"""
from __future__ import annotations

import numpy as np

from femb import Mechanism
from femb.elements import Gravity, Hinge, RigidBody
from femb.elements.contact import SphereOnPlane

PARAMS = {"l1": 0.153, "l2": 0.306, "a": 0.05, "b": 0.025, "c": 0.001, "e_N": 0.4, "mu": 0.01, "omega1": 150.0,
          "g": 9.81}
MASSES = {"crank": (0.038, 7.4e-5), "rod": (0.038, 5.9e-4), "slider": (0.076, 2.7e-6)}
DEFAULTS = {"t_end": 0.2, "h": 1e-4, "rho_inf": 0.8}
PARAMETERS = {"l1": ("crank length", "m"), "l2": ("rod length", "m"), "a": ("slider half-length", "m"),
              "b": ("slider half-height", "m"), "c": ("clearance on each side", "m"),
              "e_N": ("normal restitution", "-"), "mu": ("friction coefficient", "-"),
              "omega1": ("initial crank angular velocity", "rad/s"), "g": ("gravity along -y", "m/s^2")}
OUTPUTS = {"crank_angle": ("crank angle", "rad"), "slider_x": ("slider position", "m"),
           "slider_y": ("slider centre height in the clearance", "m"), "slider_theta": ("slider tilt", "rad")}


def build(l1=PARAMS["l1"], l2=PARAMS["l2"], a=PARAMS["a"], b=PARAMS["b"], c=PARAMS["c"], e_N=PARAMS["e_N"],
          mu=PARAMS["mu"], omega1=PARAMS["omega1"], g=PARAMS["g"]):
    """Bodies ``crank``, ``rod``, ``slider``; hinges ``O``, ``A``, ``B``; contacts ``upper.0/1``, ``lower.0/1``."""
    (m1, J1), (m2, J2), (m3, J3) = MASSES["crank"], MASSES["rod"], MASSES["slider"]
    mech = Mechanism("contact_slider_crank")
    mech.add(RigidBody("crank", m1, J1, position=(0.5 * l1, 0.0), velocity=(0.0, 0.5 * l1 * omega1), omega=omega1))
    w2 = -omega1 * l1 / l2
    mech.add(RigidBody("rod", m2, J2, position=(l1 + 0.5 * l2, 0.0), velocity=(0.0, l1 * omega1 + 0.5 * l2 * w2),
                       omega=w2))
    mech.add(RigidBody("slider", m3, J3, position=(l1 + l2, 0.0), shape={"type": "box", "size": (2 * a, 2 * b)}))
    mech.add(Gravity((0.0, -g)))
    mech.add(Hinge("O", "ground", "crank", at=(0.0, 0.0)))
    mech.add(Hinge("A", "crank", "rod", at=(l1, 0.0)))
    mech.add(Hinge("B", "rod", "slider", at=(l1 + l2, 0.0)))
    for k, x in enumerate((-a, a)):
        mech.add(SphereOnPlane(f"upper.{k}", "slider", 0.0, point=(x, b), plane_point=(0.0, b + c), normal=(0.0, -1.0),
                               e_N=e_N, mu=mu))
        mech.add(SphereOnPlane(f"lower.{k}", "slider", 0.0, point=(x, -b), plane_point=(0.0, -b - c),
                               normal=(0.0, 1.0), e_N=e_N, mu=mu))
    return mech


def outputs(result):
    return {"crank_angle": result.series("crank.theta")[0], "slider_x": result.series("slider.x")[0],
            "slider_y": result.series("slider.y")[0], "slider_theta": result.series("slider.theta")[0]}


def table(t_end=0.02, hs=(2e-4, 1e-4), rho_inf=DEFAULTS["rho_inf"]):
    """Penetration, hinge residuals, impacts and the agreement of two step sizes (dict)."""
    from femb.contact import simulate
    from femb.system import assembly
    model = build().compile()
    rows = {}
    runs = []
    for h in hs:
        res = simulate(model, t_end, h, rho_inf=rho_inf)
        phi = max(float(np.abs(assembly.constraint_vector(model, t, q)).max()) for t, q in zip(res.t, res.q))
        runs.append(outputs(res))
        rows[f"h = {h:g}"] = {"impacts": len(res.events), "min g_N / L": float(res.contact["gN"].min() / model.length_scale),
                              "max |Phi| (m)": phi, "crank angle end": float(runs[-1]["crank_angle"][-1]),
                              "slider y end (m)": float(runs[-1]["slider_y"][-1]), "wall (s)": res.wall_time}
    rows["|Δ crank angle end|"] = abs(runs[0]["crank_angle"][-1] - runs[1]["crank_angle"][-1])
    return rows


def main():
    for k, v in table().items():
        print(f"slider_crank  {k:24s} {v}")


if __name__ == "__main__":
    main()
