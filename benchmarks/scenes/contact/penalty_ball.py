"""Ball dropped on a compliant floor (penalty contact: Hertz stiffness, Hunt–Crossley damping), compiled engine.

A ball (m = 1 kg, R = 0.1 m, θ = (2/5) m R²) is released at rest with its centre at 1 m (0.9 m
fall) above the floor y = 0, :class:`femb.elements.PenaltySphereOnPlane` with f_N = k δ^{3/2}
(1 + α δ̇), k = 1e7 N/m^{3/2}, and α set so that an impact at the first impact speed
v⁻ = √(2 g 0.9) = 4.20214 m/s rebounds with e = 0.5.

Closed forms (``python -m femb.benchmarks.scenes.contact.penalty_ball`` prints the table of
docs/contact.md):

* the contact opens at t₁ = √(2·0.9/g) = 0.428353 s (free fall; the scheme integrates a constant
  acceleration exactly);
* undamped (e = 1), the contact lasts t_c = 2 (5/4)^{2/5} (2/5) B(2/5, 1/2) (m²/(k² v⁻))^{1/5}
  = 3.21807 (m²/(k² v⁻))^{1/5} (Hertz impact, Johnson, Contact Mechanics, §11.4, eq. (11.24) with
  k = (4/3) E* √R) and the ball leaves at v⁻;
* the ball thrown at v⁻ onto the floor without gravity rebounds with the speed ratio e (v_ref =
  v⁻); with gravity acting during the contact the ratio differs slightly (table).
"""
from __future__ import annotations

import math

import numpy as np

from femb import Mechanism
from femb.elements import Gravity, PenaltySphereOnPlane, RigidBody

PARAMS = {"mass": 1.0, "radius": 0.1, "y0": 1.0, "g": 9.81, "stiffness": 1e7, "restitution": 0.5,
          "v_ref": math.sqrt(2 * 9.81 * 0.9), "mu": 0.0}
DEFAULTS = {"t_end": 1.0, "h": 1e-4, "rho_inf": 0.9}
PARAMETERS = {
    "mass": ("ball mass", "kg"),
    "radius": ("ball radius", "m"),
    "y0": ("initial centre height (released at rest)", "m"),
    "g": ("gravity along -y", "m/s^2"),
    "stiffness": ("Hertz stiffness k of f_N = k delta^(3/2) (1 + alpha delta_d)", "N/m^1.5"),
    "restitution": ("coefficient of restitution of a central impact at v_ref (sets alpha)", "-"),
    "v_ref": ("approach speed at which the restitution holds", "m/s"),
    "mu": ("friction coefficient", "-"),
    "v0": ("initial vertical velocity", "m/s"),
}
OUTPUTS = {
    "y": ("centre height", "m"),
    "y_d": ("vertical velocity", "m/s"),
    "gN": ("gap (negative: penetration)", "m"),
    "lambda_N": ("normal contact force", "N"),
}
CONVERGENCE = {"t_end": 0.6, "h": [4e-4, 2e-4, 1e-4, 5e-5], "q": ["y"], "lambda": ["lambda_N"]}
T_IMPACT = math.sqrt(2 * 0.9 / 9.81)          # 0.428353 s


def build(mass=PARAMS["mass"], radius=PARAMS["radius"], y0=PARAMS["y0"], g=PARAMS["g"],
          stiffness=PARAMS["stiffness"], restitution=PARAMS["restitution"], v_ref=PARAMS["v_ref"], mu=PARAMS["mu"],
          v0=0.0):
    """The ball: body ``ball``, penalty contact ``floor`` on y = 0, ``gravity``."""
    mech = Mechanism("penalty_ball")
    mech.add(RigidBody("ball", mass, 0.4 * mass * radius * radius, position=(0.0, y0), velocity=(0.0, v0),
                       shape={"type": "disc", "radius": radius}))
    mech.add(Gravity((0.0, -g)))
    mech.add(PenaltySphereOnPlane("floor", "ball", radius, stiffness, restitution=restitution, v_ref=v_ref, mu=mu))
    return mech


def outputs(result):
    """Height, vertical velocity, gap and normal force (dict of arrays (nt,))."""
    return {"y": result.series("ball.y")[0], "y_d": result.series("ball.y_d")[0],
            "gN": result.series("floor.gN")[0], "lambda_N": result.series("floor.lambda_N")[0]}


def hertz_contact_time(m, k, v):
    """Duration (s) of an undamped Hertz impact of a mass m at speed v, f = k δ^{3/2} (Johnson §11.4)."""
    return 3.2180654597 * (m * m / (k * k * v)) ** 0.2


def first_contact(result):
    """(closing time, opening time, ġ at closing, ġ at opening) of the first contact, interpolated
    linearly in the gap between the stored steps."""
    g, gd, t = result.series("floor.gN")[0], result.series("floor.gN_d")[0], result.t
    i0 = int(np.argmax(g < 0.0))
    i1 = i0 + int(np.argmax(g[i0:] >= 0.0))
    if i0 == 0 or i1 == i0:
        raise RuntimeError("penalty_ball: no complete contact in the run")

    def cross(i):
        s = g[i - 1] / (g[i - 1] - g[i])
        return t[i - 1] + s * (t[i] - t[i - 1]), gd[i - 1] + s * (gd[i] - gd[i - 1])
    (ta, va), (tb, vb) = cross(i0), cross(i1)
    return ta, tb, va, vb


def table(h=1e-4, adaptive_rtol=1e-6):
    """Rows of the validation table (list of (figure, femb, reference)).

    The drop (gravity on) gives the impact time; the same ball thrown at v⁻ onto the floor
    without gravity (``g = 0``, ``v0 = −v⁻``) isolates the contact law: its duration against
    Hertz's closed form (e = 1) and its rebound ratio against e.
    """
    import femb

    rows = []
    v = PARAMS["v_ref"]
    r, gap0 = PARAMS["radius"], 1e-3
    for label, kw in ((f"h = {h:g}", dict(h=h)), (f"adaptive rtol = {adaptive_rtol:g}",
                                                  dict(rtol=adaptive_rtol, atol=1e-9))):
        for e in (1.0, 0.5):
            res = femb.simulate(build(restitution=e).compile(), t_end=0.6, rho_inf=DEFAULTS["rho_inf"], **kw)
            ta, tb, va, vb = first_contact(res)
            rows.append((f"{label}, e = {e:g}, drop: contact closes", f"{ta:.7f} s", f"{T_IMPACT:.7f} s"))
            rows.append((f"{label}, e = {e:g}, drop: rebound ratio", f"{-vb / va:.5f}",
                         f"{e:g} (gravity acts during the contact)"))
            res = femb.simulate(build(restitution=e, g=0.0, y0=r + gap0, v0=-v).compile(), t_end=0.012,
                                rho_inf=DEFAULTS["rho_inf"], **kw)
            ta, tb, va, vb = first_contact(res)
            ref_tc = f"{hertz_contact_time(1.0, PARAMS['stiffness'], v):.5e} s (Hertz)" if e == 1.0 else "-"
            rows.append((f"{label}, e = {e:g}, thrown at v-, g = 0: contact duration", f"{tb - ta:.5e} s", ref_tc))
            rows.append((f"{label}, e = {e:g}, thrown at v-, g = 0: rebound ratio", f"{-vb / va:.5f}", f"{e:g}"))
            rows.append((f"{label}, e = {e:g}, thrown at v-, g = 0: steps in contact, max penetration",
                         f"{int(np.sum(res.series('floor.gN')[0] < 0))}, {-res.series('floor.gN')[0].min():.4e} m",
                         f"{(5 * v * v / (4 * PARAMS['stiffness'])) ** 0.4:.4e} m (Hertz, e = 1)" if e == 1.0 else "-"))
    return rows


def main():
    for fig, val, ref in table():
        print(f"| {fig} | {val} | {ref} |")


if __name__ == "__main__":
    main()
