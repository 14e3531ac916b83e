"""Many spheres resting on a compliant floor with friction (persistent penalty contact), compiled engine.

``n`` spatial spheres (m = 1 kg, R = 0.05 m, θ = (2/5) m R²) on a square grid of pitch 0.15 m sit
on the floor z = 0 at the static Hertz penetration δ₀ = (m g/k)^{2/3}, each with a small random
horizontal velocity (|v| ≤ 0.05 m/s) and spin (|ω| ≤ 1 rad/s, seed 1), so that friction acts and
the contacts go from slip to stick (:class:`femb.elements.SpatialPenaltySphereOnPlane`: k = 1e6
N/m^{3/2}, e = 0.5 at 1 m/s, μ = 0.3, ε_v = 1e-2 m/s). The spheres do not touch each other (no
sphere–sphere contact yet): one force batch of ``n`` elements, one node each.

With ``lift`` > 0 the spheres start that high above the floor at rest and fall freely for the whole
run when ``lift`` ≫ g t_end²/2 (the same model with its contacts open: the cost benchmark's reference,
``python -m femb.benchmarks.cost.penalty_spheres``).

Checks (``python -m femb.benchmarks.scenes.contact.penalty_spheres``): the total normal force tends
to n m g, the penetration to δ₀, every slip to zero (the spheres end up rolling; the spin about
the normal stays: the law has no spinning friction).
"""
from __future__ import annotations

import math

import numpy as np

from femb import Mechanism
from femb.elements import SpatialPenaltySphereOnPlane, SpatialRigidBody
from femb.elements.spatial_forces import SpatialGravity

PARAMS = {"n": 200, "mass": 1.0, "radius": 0.05, "g": 9.81, "stiffness": 1e6, "restitution": 0.5,
          "mu": 0.3, "eps_v": 1e-2, "lift": 0.0, "seed": 1}
DEFAULTS = {"t_end": 0.2, "h": 1e-3, "rho_inf": 0.8}
PARAMETERS = {
    "n": ("number of spheres", "-"),
    "mass": ("mass of each sphere", "kg"),
    "radius": ("sphere radius", "m"),
    "g": ("gravity along -z", "m/s^2"),
    "stiffness": ("Hertz stiffness k of f_N = k delta^(3/2) (1 + alpha delta_d)", "N/m^1.5"),
    "restitution": ("coefficient of restitution at 1 m/s", "-"),
    "mu": ("friction coefficient", "-"),
    "eps_v": ("friction regularization speed", "m/s"),
    "lift": ("initial height of the spheres above the floor (0: resting at the static penetration)", "m"),
    "seed": ("seed of the random initial velocities and spins", "-"),
}
OUTPUTS = {
    "z_mean": ("mean centre height", "m"),
    "lambda_N": ("total normal force", "N"),
    "slip_max": ("largest slip speed", "m/s"),
}
CONVERGENCE = {"t_end": 0.1, "h": [2e-3, 1e-3, 5e-4, 2.5e-4], "q": ["z_mean"], "lambda": ["lambda_N"]}


def build(n=PARAMS["n"], mass=PARAMS["mass"], radius=PARAMS["radius"], g=PARAMS["g"],
          stiffness=PARAMS["stiffness"], restitution=PARAMS["restitution"], mu=PARAMS["mu"],
          eps_v=PARAMS["eps_v"], lift=PARAMS["lift"], seed=PARAMS["seed"]):
    """``n`` spheres ``s0`` … with floor contacts ``c0`` … and gravity."""
    n = int(n)
    if n < 1:
        raise ValueError(f"penalty_spheres: n must be a positive integer, got {n!r}")
    rng = np.random.default_rng(int(seed))
    side = int(math.ceil(math.sqrt(n)))
    d0 = (mass * g / stiffness) ** (2.0 / 3.0) if g > 0 else 0.0
    z0 = radius - d0 + lift
    theta = 0.4 * mass * radius * radius
    mech = Mechanism("penalty_spheres")
    mech.add(SpatialGravity((0.0, 0.0, -g)))
    for i in range(n):
        x, y = 0.15 * (i % side), 0.15 * (i // side)
        v = (0.0, 0.0, 0.0) if lift > 0 else (*rng.uniform(-0.05, 0.05, 2), 0.0)
        w = (0.0, 0.0, 0.0) if lift > 0 else tuple(rng.uniform(-1.0, 1.0, 3))
        mech.add(SpatialRigidBody(f"s{i}", mass, (theta,) * 3, position=(x, y, z0), velocity=v, omega=w,
                                  shape={"type": "sphere", "radius": radius}))
        mech.add(SpatialPenaltySphereOnPlane(f"c{i}", f"s{i}", radius, stiffness, restitution=restitution,
                                             mu=mu, eps_v=eps_v))
    return mech


def outputs(result):
    """Mean height, total normal force and the largest slip speed (dict of arrays (nt,))."""
    names = sorted((k for k in result.model.bodies if k.startswith("s") and k[1:].isdigit()), key=lambda k: int(k[1:]))
    z = np.mean([result.series(f"{b}.z")[0] for b in names], axis=0)
    fN = np.sum([result.series(f"c{b[1:]}.lambda_N")[0] for b in names], axis=0)
    slip = np.max([result.series(f"c{b[1:]}.slip")[0] for b in names], axis=0)
    return {"z_mean": z, "lambda_N": fN, "slip_max": slip}


def main(n=200, t_end=1.0, h=1e-3):
    """Print the static checks of docs/contact.md for ``n`` spheres after ``t_end``."""
    import femb

    res = femb.simulate(build(n=n).compile(), t_end=t_end, h=h, rho_inf=DEFAULTS["rho_inf"])
    out = outputs(res)
    d0 = (PARAMS["mass"] * PARAMS["g"] / PARAMS["stiffness"]) ** (2 / 3)
    print(f"| total normal force at {t_end:g} s / (n m g) − 1 | {out['lambda_N'][-1] / (n * 9.81) - 1:.2e} | 0 |")
    print(f"| mean penetration at {t_end:g} s | {PARAMS['radius'] - out['z_mean'][-1]:.6e} m | {d0:.6e} m |")
    print(f"| largest slip speed at {t_end:g} s | {out['slip_max'][-1]:.2e} m/s | 0 |")


if __name__ == "__main__":
    main()
