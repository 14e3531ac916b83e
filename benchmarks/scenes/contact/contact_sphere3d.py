"""A spatial sphere sliding on a plane until it rolls (Lie-group frame node, two friction directions).

A homogeneous sphere (m, R, θ = (2/5) m R²) touches the floor z = 0 with centre velocity v₀ and
angular velocity ω₀ (both horizontal, space axes = body axes at t = 0). Sliding friction μ m g
acts against the slip velocity v_c = v + ω × (−R e_z), whose direction stays fixed while it
shrinks at the rate (1 + mR²/θ) μ g = (7/2) μ g; the sphere rolls from t_r = |v_c(0)|/((7/2) μ g)
on, with the velocity fixed by the angular momentum about the contact point (conserved: every
contact force passes through it):

    v_x = (5/7)(v₀ₓ + (2/5) R ω₀ᵧ),   v_y = (5/7)(v₀ᵧ − (2/5) R ω₀ₓ)

(e.g. E. J. Routh, Dynamics of a System of Rigid Bodies, Advanced Part, 1905, §240–243).

Run ``python -m femb.benchmarks.scenes.contact.contact_sphere3d`` for the validation table of docs/contact.md.
"""
from __future__ import annotations

import numpy as np

from femb import Mechanism
from femb.elements import SpatialGravity, SpatialRigidBody
from femb.elements.contact import SpatialSphereOnPlane

PARAMS = {"mass": 1.0, "radius": 0.1, "mu": 0.3, "g": 9.81, "v0": (1.0, 0.5, 0.0), "omega0": (3.0, -8.0, 2.0)}
DEFAULTS = {"t_end": 0.6, "h": 2e-3, "rho_inf": 0.8}
PARAMETERS = {"mass": ("sphere mass", "kg"), "radius": ("sphere radius", "m"), "mu": ("friction coefficient", "-"),
              "g": ("gravity along -z", "m/s^2"), "v0": ("initial centre velocity", "m/s"),
              "omega0": ("initial angular velocity (body = space axes at t = 0)", "rad/s")}
OUTPUTS = {"vx": ("centre velocity x", "m/s"), "vy": ("centre velocity y", "m/s"), "z": ("centre height", "m"),
           "slip": ("slip speed", "m/s")}


def build(mass=PARAMS["mass"], radius=PARAMS["radius"], mu=PARAMS["mu"], g=PARAMS["g"], v0=PARAMS["v0"],
          omega0=PARAMS["omega0"]):
    """Body ``sphere`` on contact ``floor`` (SpatialSphereOnPlane on z = 0), ``gravity``."""
    th = 0.4 * mass * radius * radius
    mech = Mechanism("contact_sphere3d")
    mech.add(SpatialRigidBody("sphere", mass, (th, th, th), position=(0.0, 0.0, radius), velocity=v0,
                              omega=omega0, shape={"type": "sphere", "radius": radius}))
    mech.add(SpatialGravity((0.0, 0.0, -g)))
    mech.add(SpatialSphereOnPlane("floor", "sphere", radius=radius, mu=mu))
    return mech


def reference(mass=PARAMS["mass"], radius=PARAMS["radius"], mu=PARAMS["mu"], g=PARAMS["g"], v0=PARAMS["v0"],
              omega0=PARAMS["omega0"]):
    """Rolling start time and rolling velocity (closed form)."""
    v0, w0 = np.asarray(v0, dtype=float), np.asarray(omega0, dtype=float)
    vc = v0 + np.cross(w0, (0.0, 0.0, -radius))
    t_r = np.linalg.norm(vc[:2]) / (3.5 * mu * g)
    v = np.array([5.0 / 7.0 * (v0[0] + 0.4 * radius * w0[1]), 5.0 / 7.0 * (v0[1] - 0.4 * radius * w0[0])])
    return {"t_roll": t_r, "v_roll": v}


def outputs(result):
    return {"vx": result.series("sphere.x_d")[0], "vy": result.series("sphere.y_d")[0],
            "z": result.series("sphere.z")[0], "slip": result.series("floor.slip")[0]}


def table(h=DEFAULTS["h"], t_end=DEFAULTS["t_end"], rho_inf=DEFAULTS["rho_inf"]):
    from femb.contact import simulate
    res = simulate(build().compile(), t_end, h, rho_inf=rho_inf)
    ref = reference()
    st = np.array(res.contact_state("floor"))
    k = np.nonzero(st == "stick")[0]
    t_stick = float(res.t[k[0]]) if k.size else float("nan")
    return {"t_roll exact": ref["t_roll"], "first stick step end": t_stick,
            "stick step contains t_roll": bool(t_stick - h <= ref["t_roll"] <= t_stick + 1e-12),
            "v_roll exact": ref["v_roll"].tolist(), "v end": res.qd[-1, :2].tolist(),
            "max |v end - exact|": float(np.abs(res.qd[-1, :2] - ref["v_roll"]).max()),
            "max |z - R|": float(np.abs(res.q[:, 2] - PARAMS["radius"]).max()),
            "slip at end": float(outputs(res)["slip"][-1]),
            "min g_N / L": float(res.contact["gN"].min() / res.model.length_scale)}


def main():
    for key, v in table().items():
        print(f"sphere3d  {key:28s} {v}")


if __name__ == "__main__":
    main()
