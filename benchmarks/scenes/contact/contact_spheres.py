"""Many spheres sliding to rolling on the floor (persistent unilateral contact with Coulomb friction).

``n`` spatial spheres (m = 1 kg, R = 0.05 m, θ = (2/5) m R²) on a square grid of pitch 0.15 m (``pitch``) rest on
the floor z = 0 (:class:`femb.elements.contact.SpatialSphereOnPlane`, μ = 0.3, e_N = 0), each with a
random horizontal velocity (|v_x|, |v_y| ≤ 0.05 m/s) and spin (|ω_i| ≤ 1 rad/s), seed 1, so that every
contact slips and then sticks: the nonsmooth counterpart of
:mod:`femb.benchmarks.scenes.contact.penalty_spheres` (run by :func:`femb.contact.simulate`; the
spheres do not touch each other).

Reference (closed form, as for one sphere in :mod:`contact_sphere3d`): a sphere slipping on a plane
with Coulomb friction keeps the direction of its contact-point velocity v_c = v + ω × (−R e_z), whose
size falls at the rate (7/2) μ g (the spin about the normal does not enter), so it rolls from
t_r = |v_c(0)| / (3.5 μ g) with the centre velocity (5/7)(v_x + (2/5) R ω_y, v_y − (2/5) R ω_x).

With ``lift`` > 0 the spheres start that high above the floor at rest and fall freely while
``lift`` > g t_end²/2 (the same model with its contacts open: the reference of the cost benchmark
``python -m femb.benchmarks.cost.contact_spheres``).

Checks (``python -m femb.benchmarks.scenes.contact.contact_spheres`` or ``femb bench contact
contact_spheres``): every sphere's switch to rolling within the step that holds its t_r, its rolling
velocity against the closed form, the total normal force n m g, no penetration.
"""
from __future__ import annotations

import math

import numpy as np

from femb import Mechanism
from femb.elements import SpatialGravity, SpatialRigidBody
from femb.elements.contact import SpatialSphereOnPlane

PARAMS = {"n": 200, "mass": 1.0, "radius": 0.05, "g": 9.81, "mu": 0.3, "lift": 0.0, "seed": 1, "pitch": 0.15}
DEFAULTS = {"t_end": 0.03, "h": 1e-3, "rho_inf": 0.8}
PARAMETERS = {
    "n": ("number of spheres", "-"),
    "mass": ("mass of each sphere", "kg"),
    "radius": ("sphere radius", "m"),
    "g": ("gravity along -z", "m/s^2"),
    "mu": ("friction coefficient", "-"),
    "lift": ("initial height of the spheres above the floor (0: resting on it)", "m"),
    "seed": ("seed of the random initial velocities and spins", "-"),
    "pitch": ("distance between neighbouring spheres' centres on the grid", "m"),
}
OUTPUTS = {
    "z_mean": ("mean centre height", "m"),
    "lambda_N": ("total normal force", "N"),
    "slip_max": ("largest slip speed", "m/s"),
}


def _initial(n, seed, lift, pitch=PARAMS["pitch"]):
    """Grid positions (n, 2), velocities (n, 3) and spins (n, 3) of :func:`build`."""
    rng = np.random.default_rng(int(seed))
    side = int(math.ceil(math.sqrt(n)))
    xy = np.array([(pitch * (i % side), pitch * (i // side)) for i in range(n)])
    v, w = np.zeros((n, 3)), np.zeros((n, 3))
    if lift <= 0:
        for i in range(n):
            v[i, :2] = rng.uniform(-0.05, 0.05, 2)
            w[i] = rng.uniform(-1.0, 1.0, 3)
    return xy, v, w


def build(n=PARAMS["n"], mass=PARAMS["mass"], radius=PARAMS["radius"], g=PARAMS["g"], mu=PARAMS["mu"],
          lift=PARAMS["lift"], seed=PARAMS["seed"], pitch=PARAMS["pitch"]):
    """``n`` spheres ``s0`` … with floor contacts ``c0`` … and gravity."""
    n = int(n)
    if n < 1:
        raise ValueError(f"contact_spheres: n must be a positive integer, got {n!r}")
    if not 2.0 * radius <= float(pitch) < float("inf"):
        raise ValueError(f"contact_spheres: pitch must be at least the diameter 2 radius = {2.0 * radius:g} m, "
                         f"got {pitch!r}")
    xy, v, w = _initial(n, seed, lift, float(pitch))
    theta = 0.4 * mass * radius * radius
    mech = Mechanism("contact_spheres")
    mech.add(SpatialGravity((0.0, 0.0, -g)))
    for i in range(n):
        mech.add(SpatialRigidBody(f"s{i}", mass, (theta,) * 3, position=(xy[i, 0], xy[i, 1], radius + lift),
                                  velocity=tuple(v[i]), omega=tuple(w[i]), shape={"type": "sphere", "radius": radius}))
        mech.add(SpatialSphereOnPlane(f"c{i}", f"s{i}", radius=radius, mu=mu))
    return mech


def reference(n=PARAMS["n"], radius=PARAMS["radius"], g=PARAMS["g"], mu=PARAMS["mu"], seed=PARAMS["seed"]):
    """Each sphere's rolling start t_r (n,) and rolling centre velocity (n, 2) (closed form)."""
    _, v, w = _initial(int(n), seed, 0.0)
    vc = v + np.cross(w, (0.0, 0.0, -radius))
    t_r = np.linalg.norm(vc[:, :2], axis=1) / (3.5 * mu * g)
    v_roll = 5.0 / 7.0 * np.column_stack((v[:, 0] + 0.4 * radius * w[:, 1], v[:, 1] - 0.4 * radius * w[:, 0]))
    return {"t_roll": t_r, "v_roll": v_roll}


def _n(result):
    return sum(1 for k in result.model.bodies if k.startswith("s") and k[1:].isdigit())


def outputs(result):
    """Mean height, total normal force and the largest slip speed (dict of arrays (nt,))."""
    n = _n(result)
    z = np.mean([result.series(f"s{i}.z")[0] for i in range(n)], axis=0)
    fN = np.sum([result.series(f"c{i}.lambda_N")[0] for i in range(n)], axis=0)
    slip = np.max([result.series(f"c{i}.slip")[0] for i in range(n)], axis=0)
    return {"z_mean": z, "lambda_N": fN, "slip_max": slip}


def table(n=PARAMS["n"], h=DEFAULTS["h"], t_end=DEFAULTS["t_end"], rho_inf=DEFAULTS["rho_inf"]):
    """The checks of the module docstring (dict)."""
    from femb.contact import simulate

    res = simulate(build(n=n).compile(), t_end, h, rho_inf=rho_inf)
    ref = reference(n=n)
    late, dv = 0, 0.0
    for i in range(n):
        st = np.array(res.contact_state(f"c{i}"))
        k = np.nonzero(st == "stick")[0]
        t_stick = float(res.t[k[0]]) if k.size else math.inf
        late += not (t_stick - h - 1e-12 <= ref["t_roll"][i] <= t_stick + 1e-12)
        v_end = np.array([res.series(f"s{i}.x_d")[0][-1], res.series(f"s{i}.y_d")[0][-1]])
        dv = max(dv, float(np.abs(v_end - ref["v_roll"][i]).max()))
    out = outputs(res)
    return {"spheres": n, "steps": res.t.size - 1, "ms per step": res.wall_time / (res.t.size - 1) * 1e3,
            "Newton iterations per step": float(np.mean(res.newton_iterations)),
            "latest t_roll": float(ref["t_roll"].max()),
            "spheres not sticking in the step holding t_roll": late,
            "max |v end − v_roll| (m/s)": dv,
            "total λ_N / (n m g) − 1 at the end": float(out["lambda_N"][-1] / (n * PARAMS["mass"] * PARAMS["g"]) - 1),
            "min g_N / L": float(res.contact["gN"].min() / res.model.length_scale)}


def main():
    for key, v in table().items():
        print(f"contact_spheres  {key:50s} {v}")


if __name__ == "__main__":
    main()
