"""A flexible beam pinned at one end swings down under gravity onto a rigid stop (contact at a beam node).

A straight spatial beam (femb's SE(3) beam, :func:`femb.elements.spatial_beam.spatial_beam`) of
length L and square section (side a, E, G, density ρ) lies along +x, pinned at the origin by a
:class:`~femb.elements.spatial_joints.RevoluteJoint` about the y axis, and is released at rest under
gravity −g e_z. A sphere of radius r at its tip node (:class:`SpatialSphereOnPlane` on the beam's
last frame node; the contact accepts any spatial frame node) hits the rigid stop, the plane
z = −L sin α* − r, when the beam has turned by α* (default 30°); e_N = 0, μ = 0 by default.

**Rigid-rod limit.** A rigid rod of the same mass and rotary inertia turns about the pin with
J α̈ = m g (L/2) cos α, J = ρ A L³/3 + ρ I_y L (the sections' rotary inertia about the pin
axis), so that α̇² = c sin α with c = m g L / J, and reaches α* at

    t* = ∫₀^{α*} dα / √(c sin α) = ∫₀^{√α*} 2u du / √(c sin u²)

(energy conservation; the substitution α = u² removes the integrable singularity at α = 0;
:func:`rigid_impact_time` evaluates it by scipy's quad). A stiff beam reaches the stop at t*
as its stiffness grows; a flexible one later (it sags while it accelerates).

Checks (:func:`table`): no penetration at any step, the first impact time against t*, the
energy taken out by the impacts (``energy.contact_normal``) and the balance, the pin's
constraint residual over all steps.

Run ``python -m femb.benchmarks.scenes.contact.contact_beam_stop`` for the validation table of
docs/contact.md.
"""
from __future__ import annotations

import math

import numpy as np

from femb import Mechanism
from femb.elements import SpatialGravity
from femb.elements.contact import SpatialSphereOnPlane
from femb.elements.spatial_beam import SpatialSection, spatial_beam
from femb.elements.spatial_joints import RevoluteJoint

PARAMS = {"length": 1.0, "side": 0.02, "E": 2.1e10, "nu": 0.3, "density": 7800.0, "n_elements": 4,
          "radius": 0.01, "alpha_stop": math.pi / 6.0, "e_N": 0.0, "mu": 0.0, "g": 9.81}
DEFAULTS = {"t_end": 0.4, "h": 1e-3, "rho_inf": 0.8}
PARAMETERS = {"length": ("beam length", "m"), "side": ("side of the square section", "m"),
              "E": ("Young's modulus", "Pa"), "nu": ("Poisson's ratio (G = E / (2 (1 + nu)))", "-"),
              "density": ("mass density", "kg/m^3"), "n_elements": ("beam elements", "-"),
              "radius": ("radius of the contact sphere at the tip node", "m"),
              "alpha_stop": ("angle of the rigid rod when its tip sphere touches the stop", "rad"),
              "e_N": ("normal restitution", "-"), "mu": ("friction coefficient", "-"),
              "g": ("gravity along -z", "m/s^2")}
OUTPUTS = {"tip_z": ("height of the tip node", "m"), "gap": ("gap of the tip sphere to the stop", "m"),
           "lambda_N": ("normal contact force at the stop", "N"),
           "energy_lost": ("energy taken out by the impacts, cumulative", "J")}


def build(length=PARAMS["length"], side=PARAMS["side"], E=PARAMS["E"], nu=PARAMS["nu"], density=PARAMS["density"],
          n_elements=PARAMS["n_elements"], radius=PARAMS["radius"], alpha_stop=PARAMS["alpha_stop"],
          e_N=PARAMS["e_N"], mu=PARAMS["mu"], g=PARAMS["g"]):
    """Beam ``beam`` (nodes ``beam.n0`` … ``beam.n{n}``), hinge ``pin``, contact ``stop`` at the tip, ``gravity``."""
    n = int(n_elements)
    sec = SpatialSection.rectangle(E, E / (2.0 * (1.0 + nu)), side, side, density=density)
    mech = Mechanism("contact_beam_stop")
    spatial_beam(mech, "beam", sec, [(0.0, 0.0, 0.0), (length, 0.0, 0.0)], n)
    mech.add(RevoluteJoint("pin", "ground", "beam.n0", at=(0.0, 0.0, 0.0), axis=(0.0, 1.0, 0.0)))
    mech.add(SpatialGravity((0.0, 0.0, -g)))
    z_stop = -length * math.sin(alpha_stop) - radius
    mech.add(SpatialSphereOnPlane("stop", f"beam.n{n}", radius=radius, plane_point=(0.0, 0.0, z_stop), e_N=e_N,
                                  mu=mu))
    return mech


def rigid_impact_time(length=PARAMS["length"], side=PARAMS["side"], density=PARAMS["density"],
                      alpha_stop=PARAMS["alpha_stop"], g=PARAMS["g"]):
    """t* of the rigid rod released horizontal (module docstring), by scipy's quad."""
    from scipy.integrate import quad

    A, Iy = side * side, side ** 4 / 12.0
    m = density * A * length
    J = density * A * length ** 3 / 3.0 + density * Iy * length
    c = m * g * length / J
    val, _ = quad(lambda u: 2.0 * u / math.sqrt(c * math.sin(u * u)) if u > 0.0 else 2.0 / math.sqrt(c),
                  0.0, math.sqrt(alpha_stop), epsabs=1e-14, epsrel=1e-13)
    return val


def outputs(result):
    n = max(int(label.split(".")[1][1:]) for label in result.model.coord_labels if label.startswith("beam.n"))
    return {"tip_z": result.series(f"beam.n{n}.z")[0], "gap": result.series("stop.gN")[0],
            "lambda_N": result.series("stop.lambda_N")[0], "energy_lost": result.energy()["contact_normal"]}


def pin_residual(result):
    """max |Φ| of the bilateral constraints (the pin) over all stored steps (m)."""
    from femb.system import assembly

    return max(float(np.max(np.abs(assembly.constraint_vector(result.model, t, q)), initial=0.0))
               for t, q in zip(result.t, result.q))


def run(E=PARAMS["E"], t_end=DEFAULTS["t_end"], h=DEFAULTS["h"], rho_inf=DEFAULTS["rho_inf"], **params):
    """Simulate and collect the checks of the validation table."""
    from femb.contact import simulate

    res = simulate(build(E=E, **params).compile(), t_end, h, rho_inf=rho_inf)
    en = res.energy()
    t_first = res.events[0]["t"] if res.events else float("nan")
    k = int(np.searchsorted(res.t, t_first)) - 1            # last stored step before the first impact
    return res, {"first impact": t_first, "impacts": len(res.events),
                 "min g_N / L": float(res.contact["gN"].min() / res.model.length_scale),
                 "max |Phi| pin": pin_residual(res),
                 "energy lost in impacts": float(en["contact_normal"][-1]),
                 "balance before the first impact": float(en["balance"][k]),
                 "balance at t_end": float(en["balance"][-1]),
                 "E_total(0)": float(en["total"][0])}


def table(Es=(2.1e9, 2.1e10), h=DEFAULTS["h"], t_end=DEFAULTS["t_end"]):
    t_star = rigid_impact_time()
    out = {"rigid rod t*": t_star}
    for E in Es:
        _, row = run(E=E, t_end=t_end, h=h)
        row["first impact - t*"] = row["first impact"] - t_star
        out[f"E = {E:g}"] = row
    return out


def main():
    for key, v in table().items():
        print(f"beam_stop  {key:20s} {v}")


if __name__ == "__main__":
    main()
