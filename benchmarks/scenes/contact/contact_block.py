"""A block sliding, then sticking, on an inclined plane (two corner contacts with Coulomb friction).

A rigid block (width w, height b, mass m) lies with its two bottom corners on a plane inclined
by φ (plane through the origin, normal n = (sin φ, cos φ), downhill direction d = (cos φ, −sin φ)),
released with speed v₀ downhill. While it slides (both corners closed, slipping along +d):

    s(t) = s₀ + v₀ t + ½ a t²,   a = g (sin φ − μ cos φ),   N₁ + N₂ = m g cos φ,
    F₁ + F₂ = −μ m g cos φ,      N_front − N_back = (b/w) μ m g cos φ   (moments about the centre)

(front = the downhill corner). With μ > tan φ, a < 0: the block stops at t_s = v₀/|a| and sticks
(F₁ + F₂ = −m g sin φ, s = s₀ + v₀²/(2|a|)). Both are Coulomb's law on a rigid body; e.g.
F. Pfeiffer, C. Glocker, Multibody Dynamics with Unilateral Contacts, Wiley 1996, Ch. 7.

With ``spring > 0`` a spring from the block's centre to the fixed point ``anchor`` (off the
plane) pulls it, so the normal force varies smoothly: the persistent-contact case of the
convergence study (a converged femb run is its reference).

Run ``python -m femb.benchmarks.scenes.contact.contact_block`` for the validation table of docs/contact.md.
"""
from __future__ import annotations

import math

import numpy as np

from femb import Mechanism
from femb.elements import Gravity, RigidBody, SpringDamper
from femb.elements.contact import block_corners

PARAMS = {"mass": 1.0, "width": 0.2, "height": 0.1, "phi": 0.3, "mu": 0.2, "v0": 1.0, "g": 9.81,
          "spring": 0.0, "anchor": (1.0, -0.6),
          "spring_length": 0.6}
DEFAULTS = {"t_end": 1.0, "h": 1e-2, "rho_inf": 0.8}
PARAMETERS = {
    "mass": ("block mass", "kg"), "width": ("block width (along the plane)", "m"),
    "height": ("block height", "m"), "phi": ("inclination of the plane", "rad"),
    "mu": ("friction coefficient", "-"), "v0": ("initial speed downhill", "m/s"),
    "g": ("gravity along -y", "m/s^2"), "spring": ("stiffness of the spring to the anchor (0: none)", "N/m"),
    "anchor": ("fixed end of the spring", "m"), "spring_length": ("unstretched length of the spring", "m"),
}
OUTPUTS = {
    "s": ("position of the centre along the plane (downhill)", "m"),
    "s_d": ("velocity along the plane", "m/s"),
    "N": ("total normal contact force", "N"),
    "F": ("total friction force (along downhill)", "N"),
    "N_front_minus_back": ("normal force of the downhill corner minus the uphill one", "N"),
}


def _frame(phi):
    n = np.array([math.sin(phi), math.cos(phi)])
    d = np.array([math.cos(phi), -math.sin(phi)])
    return n, d


def build(mass=PARAMS["mass"], width=PARAMS["width"], height=PARAMS["height"], phi=PARAMS["phi"],
          mu=PARAMS["mu"], v0=PARAMS["v0"], g=PARAMS["g"], spring=PARAMS["spring"], anchor=PARAMS["anchor"],
          spring_length=PARAMS["spring_length"]):
    """The block ``block`` on corners ``corner.c0`` … ``corner.c3`` (c0 uphill, c1 downhill on the plane)."""
    n, d = _frame(phi)
    J = mass * (width ** 2 + height ** 2) / 12.0
    mech = Mechanism("contact_block")
    mech.add(RigidBody("block", mass, J, position=tuple(0.5 * height * n), angle=-phi, velocity=tuple(v0 * d),
                       shape={"type": "box", "size": (width, height)}))
    mech.add(Gravity((0.0, -g)))
    for c in block_corners("corner", "block", width, height, mu=mu, normal=tuple(n)):
        mech.add(c)
    if spring > 0.0:
        mech.add(SpringDamper("spring", "ground", "block", spring, length=spring_length, point_a=tuple(anchor)))
    return mech


def outputs(result, phi=PARAMS["phi"]):
    n, d = _frame(phi)
    x, y = result.series("block.x")[0], result.series("block.y")[0]
    xd, yd = result.series("block.x_d")[0], result.series("block.y_d")[0]
    lN = [result.series(f"corner.c{k}.lambda_N")[0] for k in range(4)]
    lF = [result.series(f"corner.c{k}.lambda_F")[0] for k in range(4)]
    return {"s": d[0] * x + d[1] * y, "s_d": d[0] * xd + d[1] * yd, "N": sum(lN), "F": sum(lF),
            "N_front_minus_back": lN[1] - lN[0]}


def reference(t, mass=PARAMS["mass"], width=PARAMS["width"], height=PARAMS["height"], phi=PARAMS["phi"],
              mu=PARAMS["mu"], v0=PARAMS["v0"], g=PARAMS["g"]):
    """Analytic sliding, then sticking (no spring)."""
    t = np.asarray(t, dtype=float)
    a = g * (math.sin(phi) - mu * math.cos(phi))
    N = mass * g * math.cos(phi)
    ts = v0 / -a if a < 0.0 else np.inf
    tt = np.minimum(t, ts)
    s = v0 * tt + 0.5 * a * tt * tt
    sd = np.where(t < ts, v0 + a * t, 0.0)
    F = np.where(t < ts, -mu * N, -mass * g * math.sin(phi))
    return {"s": s, "s_d": sd, "N": np.full_like(t, N), "F": F, "N_front_minus_back": -(height / width) * F,
            "t_stop": ts, "description": "Coulomb sliding then sticking of a rigid block (closed form)"}


def table(mu=PARAMS["mu"], h=DEFAULTS["h"], t_end=DEFAULTS["t_end"], rho_inf=DEFAULTS["rho_inf"]):
    """Largest deviations from the closed form (dict)."""
    from femb.contact import simulate
    res = simulate(build(mu=mu).compile(), t_end, h, rho_inf=rho_inf)
    out = outputs(res)
    ref = reference(res.t, mu=mu)
    row = {"mu": mu, "t_stop exact": ref["t_stop"]}
    k = res.t > 0.0
    if np.isfinite(ref["t_stop"]):
        k &= np.abs(res.t - ref["t_stop"]) > h          # the step of the transition is first order
    for name in ("s", "s_d", "N", "F", "N_front_minus_back"):
        row[f"max |{name} - exact|"] = float(np.max(np.abs(out[name][k] - ref[name][k])))
    row["min g_N / L"] = float(res.contact["gN"].min() / res.model.length_scale)
    row["fixed-point steps"] = res.stats["fixed_point_steps"]
    return row


def order_study(hs=(2e-2, 1e-2, 5e-3, 2.5e-3), t_end=0.4, spring=20.0, mu=0.1, v0=0.3):
    """Persistent sliding contact pulled by a spring: errors of s and N at t_end against a run at
    h/8 of the finest step, and the fitted orders (dict)."""
    from femb.contact import simulate
    model = build(spring=spring, mu=mu, v0=v0).compile()
    ref = simulate(model, t_end, hs[-1] / 8)
    r = outputs(ref)
    es, eN = [], []
    for h in hs:
        out = outputs(simulate(model, t_end, h))
        es.append(abs(out["s"][-1] - r["s"][-1]))
        eN.append(abs(out["N"][-1] - r["N"][-1]))
    return {"h": list(hs), "error s": es, "error N": eN,
            "order s": float(np.polyfit(np.log(hs), np.log(es), 1)[0]),
            "order N": float(np.polyfit(np.log(hs), np.log(eN), 1)[0]),
            "always sliding": bool(np.all(ref.contact["state"][1:, :2] == 2))}


def main():
    for mu in (0.2, 0.5):
        for k, v in table(mu).items():
            print(f"block  {k:32s} {v}")
    for k, v in order_study().items():
        print(f"block order  {k:16s} {v}")


if __name__ == "__main__":
    main()
