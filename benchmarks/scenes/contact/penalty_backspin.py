"""Ball with backspin dropped on a compliant floor with friction: it slides, then rolls back at −10/7 m/s.

The ball of ``penalty_ball`` (m = 1 kg, R = 0.1 m, θ = (2/5) m R², dropped from centre height 1 m)
spins backwards at ω₀ = 50 rad/s (counter-clockwise, planar; about −y, spatial) and lands on the
floor with Hertz stiffness k = 1e7 N/m^{3/2}, restitution e = 0.05 at the impact speed and
regularized Coulomb friction μ = 0.2, ε_v = 1e-2 m/s (:class:`femb.elements.PenaltySphereOnPlane`,
:class:`femb.elements.SpatialPenaltySphereOnPlane`).

Closed form: friction acts at the contact point and the normal force passes through it, so the
angular momentum about the contact point, θω − m R ẋ (planar), is conserved through the impact,
the sliding and the flights; rolling (ẋ = −R ω) then has ẋ = −(2/7) R ω₀ = −10/7 m/s. The rigid
nonsmooth case (e_N = 0, docs/contact.md §5) slides from the impact at 0.428353 s until
0.72812 s; here the impact is compliant and e > 0 (a plastic impact is not reachable with
Hunt–Crossley damping), so the ball hops by a fraction of a millimetre, and the slip falls below
ε_v at 0.728 s (table in docs/contact.md). The regularized friction then lets the slip decay
exponentially instead of stopping it at once: the rolling speed reaches −10/7 up to the slip
left, times θ/(θ + m R²).

``python -m femb.benchmarks.scenes.contact.penalty_backspin`` prints the table of docs/contact.md.
"""
from __future__ import annotations

import math

import numpy as np

from femb import Mechanism
from femb.elements import (Gravity, PenaltySphereOnPlane, RigidBody, SpatialPenaltySphereOnPlane,
                           SpatialRigidBody)
from femb.elements.spatial_forces import SpatialGravity

PARAMS = {"mass": 1.0, "radius": 0.1, "y0": 1.0, "g": 9.81, "stiffness": 1e7, "restitution": 0.05,
          "mu": 0.2, "eps_v": 1e-2, "omega0": 50.0}
DEFAULTS = {"t_end": 1.5, "h": 1e-3, "rho_inf": 0.9}
PARAMETERS = {
    "mass": ("ball mass", "kg"),
    "radius": ("ball radius", "m"),
    "y0": ("initial centre height (released at rest)", "m"),
    "g": ("gravity along -y", "m/s^2"),
    "stiffness": ("Hertz stiffness k of f_N = k delta^(3/2) (1 + alpha delta_d)", "N/m^1.5"),
    "restitution": ("coefficient of restitution at the impact speed sqrt(2 g (y0 - R))", "-"),
    "mu": ("friction coefficient", "-"),
    "eps_v": ("friction regularization speed", "m/s"),
    "omega0": ("initial backspin (counter-clockwise)", "rad/s"),
    "spatial": ("1: the same ball as a spatial body on the floor z = 0", "-"),
}
OUTPUTS = {
    "x_d": ("horizontal velocity", "m/s"),
    "omega": ("angular velocity", "rad/s"),
    "y": ("centre height", "m"),
    "lambda_N": ("normal contact force", "N"),
    "lambda_F": ("friction force along +x", "N"),
    "gamma_F": ("slip velocity of the contact point along +x", "m/s"),
}
CONVERGENCE = {"t_end": 1.0, "h": [2e-3, 1e-3, 5e-4, 2.5e-4], "q": ["y"], "v": ["x_d", "omega"],
               "lambda": ["lambda_N"]}
ROLLING_SPEED = -10.0 / 7.0


def build(mass=PARAMS["mass"], radius=PARAMS["radius"], y0=PARAMS["y0"], g=PARAMS["g"],
          stiffness=PARAMS["stiffness"], restitution=PARAMS["restitution"], mu=PARAMS["mu"],
          eps_v=PARAMS["eps_v"], omega0=PARAMS["omega0"], spatial=False):
    """The ball (body ``ball``), the floor contact ``floor`` and gravity; ``spatial``: the same on a
    spatial body (rotation about −y for the backspin, the floor z = 0)."""
    v_ref = math.sqrt(2.0 * g * (y0 - radius)) if y0 > radius and g > 0 else 1.0
    law = dict(restitution=restitution, v_ref=v_ref, mu=mu, eps_v=eps_v)
    theta = 0.4 * mass * radius * radius
    mech = Mechanism("penalty_backspin")
    if spatial:
        mech.add(SpatialRigidBody("ball", mass, (theta,) * 3, position=(0.0, 0.0, y0), omega=(0.0, -omega0, 0.0),
                                  shape={"type": "sphere", "radius": radius}))
        mech.add(SpatialGravity((0.0, 0.0, -g)))
        mech.add(SpatialPenaltySphereOnPlane("floor", "ball", radius, stiffness, tangent=(1.0, 0.0, 0.0), **law))
    else:
        mech.add(RigidBody("ball", mass, theta, position=(0.0, y0), omega=omega0,
                           shape={"type": "disc", "radius": radius}))
        mech.add(Gravity((0.0, -g)))
        mech.add(PenaltySphereOnPlane("floor", "ball", radius, stiffness, **law))
    return mech


def outputs(result):
    """Velocities, height and contact forces (dict of arrays (nt,)); spatial: z as the height, −ω_y as
    the (backspin-positive) angular velocity, the components along t₁ = +x."""
    if "ball.theta" in result.outputs():
        w, y, sfx = result.series("ball.theta_d")[0], result.series("ball.y")[0], ""
    else:
        w, y, sfx = -result.series("ball.omega_y")[0], result.series("ball.z")[0], "1"
    return {"x_d": result.series("ball.x_d")[0], "omega": w, "y": y,
            "lambda_N": result.series("floor.lambda_N")[0], "lambda_F": result.series("floor.lambda_F" + sfx)[0],
            "gamma_F": result.series("floor.gamma_F" + sfx)[0]}


def run(spatial=False, t_end=1.5, h=1e-3, rtol=None, **params):
    """Simulate and summarize: rolling speed at the end, its error, the slip left, when the slip
    first falls below ε_v for good (the regularized 'switch to rolling'), steps."""
    import femb

    kw = dict(h=h) if rtol is None else dict(rtol=rtol, atol=1e-8)
    res = femb.simulate(build(spatial=spatial, **params).compile(), t_end=t_end, rho_inf=DEFAULTS["rho_inf"], **kw)
    xd = res.series("ball.x_d")[0]
    slip = res.series("floor.slip")[0]
    state = res.series("floor.state")[0]
    eps_v = params.get("eps_v", PARAMS["eps_v"])
    closed = state > 0
    first = int(np.argmax(closed))
    sliding = np.nonzero(closed & (slip >= eps_v))[0]
    t_roll = float(res.t[sliding[-1] + 1]) if sliding.size and sliding[-1] + 1 < res.t.size else math.nan
    return {"rolling speed": float(xd[-1]), "rolling speed error": float(xd[-1] - ROLLING_SPEED),
            "slip at the end": float(slip[-1]), "first contact": float(res.t[first]),
            "slip < eps_v from": t_roll, "steps": int(res.t.size - 1), "result": res}


def main():
    for spatial in (False, True):
        for kw in (dict(h=1e-3), dict(h=5e-4), dict(rtol=1e-5)):
            out = run(spatial=spatial, **kw)
            tag = ("spatial" if spatial else "planar") + ", " + ", ".join(f"{k} = {v:g}" for k, v in kw.items())
            print(f"| {tag} | {out['rolling speed']:.9f} m/s | {out['rolling speed error']:.2e} m/s | "
                  f"{out['slip at the end']:.2e} m/s | {out['slip < eps_v from']:.4f} s | {out['steps']} |")


if __name__ == "__main__":
    main()
