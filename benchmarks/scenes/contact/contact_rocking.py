"""Housner's rocking block: a rigid block rocking on its bottom corners, plastic impacts, no sliding.

A block of half-width b and half-height h (mass m, I_G = m R²/3 with R = √(b² + h²)) is tilted
by θ₀ about its bottom-right corner and released at rest. It rocks back; when its bottom-left
corner hits the floor (e_N = 0, friction high enough that nothing slides) it starts rocking about
that corner. Conservation of angular momentum about the new corner gives the ratio of the angular
velocities after and before the impact (G. W. Housner, "The behavior of inverted pendulum
structures during earthquakes", Bull. Seismol. Soc. Am. 53 (1963) 403–417, eq. (9)):

    ω⁺/ω⁻ = 1 − (3/2) sin² α,   α = atan(b/h),

the old corner lifting off (ġ_N ≥ 0 without percussion). Between impacts the block is an inverted
pendulum about its corner: θ̈ = −(3g/(4R)) sin(α − θ) (Housner, eq. (2)) for rocking about the right
corner with θ its tilt.

Run ``python -m femb.benchmarks.scenes.contact.contact_rocking`` for the validation table of docs/contact.md.
"""
from __future__ import annotations

import math

import numpy as np

from femb import Mechanism
from femb.elements import Gravity, RigidBody
from femb.elements.contact import block_corners

PARAMS = {"mass": 1.0, "half_width": 0.1, "half_height": 0.5, "theta0": 0.1, "mu": 2.0, "g": 9.81}
DEFAULTS = {"t_end": 1.5, "h": 2e-3, "rho_inf": 0.8}
PARAMETERS = {
    "mass": ("block mass", "kg"), "half_width": ("half-width b", "m"), "half_height": ("half-height h", "m"),
    "theta0": ("initial tilt about the bottom-right corner (released at rest)", "rad"),
    "mu": ("friction coefficient (high: no sliding)", "-"), "g": ("gravity along -y", "m/s^2"),
}
OUTPUTS = {"theta": ("angle of the block (counter-clockwise)", "rad"),
           "omega": ("angular velocity", "rad/s")}


def build(mass=PARAMS["mass"], half_width=PARAMS["half_width"], half_height=PARAMS["half_height"],
          theta0=PARAMS["theta0"], mu=PARAMS["mu"], g=PARAMS["g"]):
    """Body ``block`` on corners ``corner.c0`` (bottom left) … ``corner.c3``, tilted clockwise by θ₀ about c1."""
    b, h = half_width, half_height
    c, s = math.cos(-theta0), math.sin(-theta0)
    pivot = np.array([b, 0.0])
    com = pivot + np.array([c * (-b) - s * h, s * (-b) + c * h])
    mech = Mechanism("contact_rocking")
    mech.add(RigidBody("block", mass, mass * (b * b + h * h) / 3.0, position=tuple(com), angle=-theta0,
                       shape={"type": "box", "size": (2 * b, 2 * h)}))
    mech.add(Gravity((0.0, -g)))
    for corner in block_corners("corner", "block", 2 * b, 2 * h, mu=mu):
        mech.add(corner)
    return mech


def outputs(result):
    return {"theta": result.series("block.theta")[0], "omega": result.series("block.theta_d")[0]}


def housner_ratio(half_width=PARAMS["half_width"], half_height=PARAMS["half_height"]):
    """ω⁺/ω⁻ = 1 − (3/2) sin² α."""
    alpha = math.atan(half_width / half_height)
    return 1.0 - 1.5 * math.sin(alpha) ** 2


def first_impact_speed(theta0=PARAMS["theta0"], half_width=PARAMS["half_width"], half_height=PARAMS["half_height"],
                       g=PARAMS["g"]):
    """The speed ω⁻ (absolute value) at the first impact from energy conservation about the pivot: (4/3) m R² ω²/2 = m g R (cos(α − θ₀) − cos α)."""
    R = math.hypot(half_width, half_height)
    alpha = math.atan(half_width / half_height)
    return math.sqrt(1.5 * g / R * (math.cos(alpha - theta0) - math.cos(alpha)))


def table(h=DEFAULTS["h"], rho_inf=DEFAULTS["rho_inf"], t_end=DEFAULTS["t_end"]):
    """The impacts of the rocking block against Housner's ratio (dict)."""
    from femb.contact import simulate
    res = simulate(build().compile(), t_end, h, rho_inf=rho_inf)
    ev = [e for e in res.events if abs(e["u_before"][2]) > 1e-6]
    ratios = [e["u_after"][2] / e["u_before"][2] for e in ev]
    r = housner_ratio()
    return {"impacts": len(ev), "contacts hit": [e["contact"] for e in ev][:4],
            "omega- first (exact)": first_impact_speed(), "omega- first": abs(float(ev[0]["u_before"][2])),
            "Housner ratio": r, "ratios": [round(float(x), 10) for x in ratios[:4]],
            "max |ratio - Housner|": float(max(abs(x - r) for x in ratios)),
            "max slip speed (m/s)": float(np.abs(res.contact["gam_F"][res.contact["state"].repeat(1, axis=1) > 0]).max()
                                          if res.contact["gam_F"].size else 0.0),
            "min g_N / L": float(res.contact["gN"].min() / res.model.length_scale)}


def main():
    for k, v in table().items():
        print(f"rocking  {k:28s} {v}")


if __name__ == "__main__":
    main()
