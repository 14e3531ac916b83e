"""Painlevé's rod: a sliding rod whose Coulomb friction admits no consistent contact force.

A uniform rod (mass m = 1 kg, length 2l = 1 m, J = m l²/3 about its centre) leans at θ = 1 rad
with its lower tip on the floor, sliding with ẋ = −1 m/s (the tip moves away from the side the
rod leans over), μ = 5/3, e_N = 0. With the slip direction fixed, the tip's normal acceleration
is g̈_N = b + a λ_N with the free part b = −g and

    a = 1/m + (l²/J) cos θ (cos θ − μ sin θ) = (1 + 3 cos θ (cos θ − μ sin θ))/m,

which is negative for μ > 4/3 near θ = 1 rad (a = −0.398 here): no λ_N ≥ 0 satisfies
0 ≤ λ_N ⊥ g̈_N ≥ 0 (Painlevé 1895; Génot & Brogliato, Eur. J. Mech. A/Solids 18 (1999)
653–677). femb.contact.simulate stops with a :class:`femb.errors.ContactError` naming the
time, the step, the contact and this reason; with μ = 0.3 (a > 0) the rod slides and falls
normally.

Run ``python -m femb.benchmarks.scenes.contact.contact_painleve`` to see the diagnosis.
"""
from __future__ import annotations

import math

from femb import Mechanism
from femb.elements import Gravity, RigidBody
from femb.elements.contact import SphereOnPlane

PARAMS = {"mass": 1.0, "half_length": 0.5, "theta": 1.0, "mu": 5.0 / 3.0, "v0": -1.0, "g": 9.81, "gap": 0.0}
DEFAULTS = {"t_end": 0.5, "h": 1e-3, "rho_inf": 0.8}
PARAMETERS = {
    "mass": ("rod mass", "kg"), "half_length": ("half of the rod's length, l", "m"),
    "theta": ("angle of the rod to the floor", "rad"), "mu": ("friction coefficient", "-"),
    "v0": ("initial horizontal velocity", "m/s"), "g": ("gravity along -y", "m/s^2"),
    "gap": ("initial height of the tip above the floor", "m"),
}
OUTPUTS = {"theta": ("angle of the rod", "rad"), "gN": ("height of the tip", "m")}


def build(mass=PARAMS["mass"], half_length=PARAMS["half_length"], theta=PARAMS["theta"], mu=PARAMS["mu"],
          v0=PARAMS["v0"], g=PARAMS["g"], gap=PARAMS["gap"]):
    """Body ``rod`` (point ``tip`` at its lower end), contact ``tip`` on the floor, ``gravity``."""
    l = half_length
    mech = Mechanism("contact_painleve")
    mech.add(RigidBody("rod", mass, mass * l * l / 3.0, position=(l * math.cos(theta), gap + l * math.sin(theta)),
                       angle=theta, velocity=(v0, 0.0), points={"tip": (-l, 0.0)}))
    mech.add(Gravity((0.0, -g)))
    mech.add(SphereOnPlane("tip", "rod", 0.0, point="tip", mu=mu))
    return mech


def outputs(result):
    return {"theta": result.series("rod.theta")[0], "gN": result.series("tip.gN")[0]}


def normal_response(mass=PARAMS["mass"], half_length=PARAMS["half_length"], theta=PARAMS["theta"], mu=PARAMS["mu"]):
    """a = (1 + 3 cos θ (cos θ − μ sin θ))/m (closed form, slip towards −x)."""
    c, s = math.cos(theta), math.sin(theta)
    return (1.0 + 3.0 * c * (c - mu * s)) / mass


def main():
    from femb.contact import simulate
    from femb.errors import ContactError
    print(f"closed form a = {normal_response():.4f}")
    for mu, gap in ((5.0 / 3.0, 0.0), (5.0 / 3.0, 1e-3), (0.3, 0.0)):
        try:
            res = simulate(build(mu=mu, gap=gap).compile(), *[DEFAULTS[k] for k in ("t_end", "h")])
            print(f"mu = {mu:.4g}, gap = {gap:g}: ran to t = {res.t[-1]:g} s, states {sorted(set(res.contact_state('tip')))}")
        except ContactError as e:
            print(f"mu = {mu:.4g}, gap = {gap:g}: ContactError at t = {e.t:g} s, step {e.step}, contact {e.contact!r}:\n  {e}")


if __name__ == "__main__":
    main()
