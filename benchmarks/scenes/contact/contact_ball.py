"""Bouncing ball and ball with backspin on a rigid floor (nonsmooth generalized-α, femb.contact).

A ball (m = 1 kg, R = 0.1 m, θ = (2/5) m R²) is dropped from centre height 1 m (0.9 m fall)
onto the floor y = 0 (Capobianco, Harsch, Eugster & Leine, IJNME 122 (2021), §10.1).

* ``e_N = 0.5, mu = 0`` (bouncing): the impacts come at t₁ = √(2·0.9/g) = 0.428353 s and
  t_{k+1} = t_k + 2 e_N^k t₁ ..., they accumulate at t∞ = t₁(1 + e_N)/(1 − e_N) = 1.285059 s,
  the energy after k impacts is e_N^{2k} E₀, and the ball is at rest after t∞.
* ``e_N = 0, mu = 0.2, omega0 = 50`` (backspin): the impact at t₁ leaves the ball sliding with
  ẋ⁺ = −μ v⁻ = −0.84043 m/s and ω⁺ = ω₀ − (5/2) μ v⁻/R = 28.989 rad/s; sliding friction μ m g
  brings the slip velocity ẋ + R ω to zero after 0.29977 s, at t = 0.72812 s, and the ball rolls
  on at ẋ = −(2/7) R ω₀ = −10/7 m/s (angular momentum about the contact point is conserved
  through impact and sliding). With ``omega0 = 10`` the impact itself stops the slip (it needs
  a friction percussion of (2/7) R ω₀ m = 0.286 ≤ μ Λ_N = 0.840): ẋ⁺ = −2/7 m/s.

Run ``python -m femb.benchmarks.scenes.contact.contact_ball`` for the validation table of docs/contact.md.
These scenes need :func:`femb.contact.simulate` (the compiled engine does not treat contacts
yet); they are not in ``femb list``.
"""
from __future__ import annotations

import math

import numpy as np

from femb import Mechanism
from femb.elements import Gravity, RigidBody
from femb.elements.contact import SphereOnPlane

PARAMS = {"mass": 1.0, "radius": 0.1, "y0": 1.0, "g": 9.81, "e_N": 0.5, "mu": 0.0, "omega0": 0.0}
DEFAULTS = {"t_end": 1.5, "h": 2e-3, "rho_inf": 0.8}
PARAMETERS = {
    "mass": ("ball mass", "kg"),
    "radius": ("ball radius", "m"),
    "y0": ("initial centre height (released at rest)", "m"),
    "g": ("gravity along -y", "m/s^2"),
    "e_N": ("normal restitution", "-"),
    "mu": ("friction coefficient", "-"),
    "omega0": ("initial angular velocity (counter-clockwise; > 0 is backspin for motion along +x)", "rad/s"),
}
OUTPUTS = {
    "y": ("centre height", "m"),
    "y_d": ("vertical velocity", "m/s"),
    "x_d": ("horizontal velocity", "m/s"),
    "omega": ("angular velocity", "rad/s"),
    "gN": ("gap", "m"),
    "lambda_N": ("normal contact force", "N"),
}


def build(mass=PARAMS["mass"], radius=PARAMS["radius"], y0=PARAMS["y0"], g=PARAMS["g"], e_N=PARAMS["e_N"],
          mu=PARAMS["mu"], omega0=PARAMS["omega0"]):
    """The ball: body ``ball`` (a disc), contact ``floor`` (SphereOnPlane on y = 0), ``gravity``."""
    mech = Mechanism("contact_ball")
    mech.add(RigidBody("ball", mass, 0.4 * mass * radius * radius, position=(0.0, y0), omega=omega0,
                       shape={"type": "disc", "radius": radius}))
    mech.add(Gravity((0.0, -g)))
    mech.add(SphereOnPlane("floor", "ball", radius=radius, e_N=e_N, mu=mu))
    return mech


def outputs(result):
    out = {"y": result.series("ball.y")[0], "y_d": result.series("ball.y_d")[0],
           "x_d": result.series("ball.x_d")[0], "omega": result.series("ball.theta_d")[0],
           "gN": result.series("floor.gN")[0], "lambda_N": result.series("floor.lambda_N")[0]}
    return out


def impact_times(k, y0=PARAMS["y0"], radius=PARAMS["radius"], g=PARAMS["g"], e_N=PARAMS["e_N"]):
    """The first k impact times of the bouncing ball (exact), shape (k,)."""
    t1 = math.sqrt(2.0 * (y0 - radius) / g)
    out = [t1]
    for j in range(1, k):
        out.append(out[-1] + 2.0 * e_N ** j * t1)
    return np.array(out)


def accumulation_time(y0=PARAMS["y0"], radius=PARAMS["radius"], g=PARAMS["g"], e_N=PARAMS["e_N"]):
    """t∞ = t₁(1 + e_N)/(1 − e_N)."""
    return math.sqrt(2.0 * (y0 - radius) / g) * (1.0 + e_N) / (1.0 - e_N)


def backspin_reference(mass=PARAMS["mass"], radius=PARAMS["radius"], y0=PARAMS["y0"], g=PARAMS["g"], mu=0.2,
                       omega0=50.0):
    """Impact time, velocities after the impact, rolling start time and rolling speed (e_N = 0)."""
    theta = 0.4 * mass * radius ** 2
    t1 = math.sqrt(2.0 * (y0 - radius) / g)
    v = g * t1                                  # approach speed
    LN = mass * v                               # plastic normal percussion
    slip0 = radius * omega0                     # slip velocity ẋ + Rω before the impact
    stick_needs = slip0 / (1.0 / mass + radius ** 2 / theta)
    if stick_needs <= mu * LN:                  # the impact stops the slip
        LF = -stick_needs
        xd = LF / mass
        return {"t_impact": t1, "xd_after": xd, "omega_after": omega0 + radius * LF / theta,
                "t_roll": t1, "xd_roll": xd}
    LF = -mu * LN
    xd, om = LF / mass, omega0 + radius * LF / theta
    slip = xd + radius * om
    rate = mu * g * (1.0 + mass * radius ** 2 / theta)
    dt = slip / rate
    return {"t_impact": t1, "xd_after": xd, "omega_after": om, "t_roll": t1 + dt,
            "xd_roll": xd - mu * g * dt}


def bouncing_table(h=DEFAULTS["h"], rho_inf=DEFAULTS["rho_inf"], t_end=DEFAULTS["t_end"], e_N=0.5):
    """Validation figures of the bouncing ball (dict)."""
    from femb.contact import simulate
    res = simulate(build(e_N=e_N).compile(), t_end, h, rho_inf=rho_inf)
    ev = res.events
    ex = impact_times(len(ev), e_N=e_N)
    t_ev = np.array([e["t"] for e in ev])
    E0 = PARAMS["mass"] * PARAMS["g"] * (PARAMS["y0"] - PARAMS["radius"])
    Ek = np.array([0.5 * PARAMS["mass"] * e["v_after"] ** 2 for e in ev])
    ratio = Ek / (E0 * e_N ** (2 * np.arange(1, len(ev) + 1)))
    ratio = ratio[:10]      # later bounces carry less than e^20 E0: gravity over the 1e-4 h impact substep shows
    t_inf = accumulation_time(e_N=e_N)
    last = t_ev[-1]
    after = res.t > last + h
    return {"impacts": len(ev), "max |t_k - t_k,exact|": float(np.max(np.abs(t_ev - ex))),
            "t1": float(t_ev[0]), "t_inf (last impact)": float(last), "t_inf error": float(last - t_inf),
            "max |E_k/(e^2k E0) - 1|, k <= 10": float(np.max(np.abs(ratio - 1.0))),
            "min g_N / L": float(res.contact["gN"].min() / res.model.length_scale),
            "max |v| after t_inf": float(np.abs(res.qd[after]).max()),
            "max g_N after t_inf": float(res.contact["gN"][after].max()),
            "states after t_inf": sorted(set(res.contact_state("floor")[int(np.argmax(after)):])),
            "wall time (s)": res.wall_time}


def backspin_table(omega0=50.0, h=DEFAULTS["h"], rho_inf=DEFAULTS["rho_inf"], t_end=1.1):
    """Validation figures of the ball with backspin (dict)."""
    from femb.contact import simulate
    res = simulate(build(e_N=0.0, mu=0.2, omega0=omega0).compile(), t_end, h, rho_inf=rho_inf)
    ref = backspin_reference(omega0=omega0)
    st = np.array(res.contact_state("floor"))
    after = res.t > ref["t_impact"]
    stick = np.nonzero(after & (st == "stick"))[0]
    t_stick = float(res.t[stick[0]]) if stick.size else float("nan")
    slip_after = np.nonzero(after & (st == "slip"))[0]
    return {"omega0": omega0, "impact t": float(res.events[0]["t"]), "impact t exact": ref["t_impact"],
            "xd after impact": float(res.events[0]["u_after"][0]), "xd after exact": ref["xd_after"],
            "first stick step end": t_stick, "t_roll exact": ref["t_roll"],
            "stick step contains t_roll": bool(t_stick - h <= ref["t_roll"] <= t_stick + 1e-12),
            "xd end": float(res.qd[-1, 0]), "xd roll exact": ref["xd_roll"],
            "|xd end - exact|": float(abs(res.qd[-1, 0] - ref["xd_roll"])),
            "slip steps after stick": int(np.sum(slip_after > (stick[0] if stick.size else 0))),
            "min g_N / L": float(res.contact["gN"].min() / res.model.length_scale)}


def main():
    for k, v in bouncing_table().items():
        print(f"bouncing  {k:32s} {v}")
    for om in (50.0, 10.0):
        for k, v in backspin_table(om).items():
            print(f"backspin  {k:32s} {v}")


if __name__ == "__main__":
    main()
