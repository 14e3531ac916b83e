"""Glocker's woodpecker toy: a limit cycle with impacts and friction, built from femb's rigid bodies and contacts.

A sleeve (Glocker's M, "Muffe": m_M = 3e-4 kg, J_M = 5e-9 kg m²) slides down a vertical pole of
radius r_0 = 2.5e-3 m through a hole of radius r_M = 3.1e-3 m and height 2 h_M = 11.6e-3 m. A woodpecker
(S, "Specht": m_S = 4.5e-3 kg, J_S = 7e-7 kg m² about its centre of gravity) hangs on a hinge at
l_M = 1e-2 m from the sleeve's centre, its centre of gravity l_G = 1.5e-2 m further out, its beak
at (−l_S, h_S) = (−2.01e-2, 2e-2) m from its centre of gravity; a rotational spring c_φ = 5.6e-3 N m/rad
acts between the two. The woodpecker swings, tilts the sleeve until its edges jam on the pole
(sticking), swings back, frees the sleeve, which slides down, and hits the pole with its beak: a
periodic motion, the toy walking down the pole. Parameters of C. Glocker, *Set-Valued Force Laws*,
Springer (2001), also in R. I. Leine, C. Glocker, D. H. van Campen, "Nonlinear dynamics and modeling
of various wooden toys with impact and friction", J. Vib. Control 9 (2003) 25–78, and R. I. Leine,
H. Nijmeijer, *Dynamics and Bifurcations of Non-smooth Mechanical Systems*, Springer (2004), §9.2.

femb's model (exact rigid-body kinematics; the published model is its small-angle linearization in
the minimal coordinates y, φ_M, φ_S):

* bodies ``sleeve`` (node at the hole's centre) and ``woodpecker`` (node at its centre of gravity);
* ``axis``: a :class:`~femb.elements.PointOnLine` holding the sleeve's centre on the pole's axis x = 0
  (Glocker's model has no horizontal sleeve motion);
* ``hinge``: a :class:`~femb.elements.Hinge` sleeve–woodpecker, ``spring`` a
  :class:`~femb.elements.RotationalSpringDamper` c_φ (φ_S − φ_M), unstretched at φ_S = φ_M;
* contacts against the pole's surface x = r_0 (normal +x, friction μ = 0.3 along the pole), each a
  :class:`~femb.elements.contact.SphereOnPlane` of radius 0: ``beak`` (e_N = 0.5), ``sleeve_low`` at
  the sleeve's lower edge (r_M, −h_M) and ``sleeve_up`` at its upper edge (r_M, h_M) on the woodpecker's
  side (e_N = 0): Glocker's contacts 1, 2, 3. With the sleeve held on the axis, the diagonally opposite
  edge's reaction is carried by ``axis``.

The published state on the limit cycle (y = 0, φ_M = −0.1036, φ_S = −0.2788, ẏ = −0.3411 m/s,
φ̇_M = 0, φ̇_S = −7.4583 rad/s) is the linear model's; with exact kinematics φ_M = −0.1036 puts the
sleeve's lower edge 1.6e-5 m inside the pole, so the run starts with the sleeve on its contact angle
(φ_M = −0.100900 rad) and the other values as published. The independent check is
``benchmarks/references/woodpecker_minimal.py`` (minimal coordinates, Moreau time stepping, the
linear model and the exact one); ``python -m femb.benchmarks.scenes.contact.contact_woodpecker``
prints the limit-cycle figures of docs/contact.md §5.
"""
from __future__ import annotations

import math

import numpy as np

from femb import Mechanism
from femb.benchmarks.references import woodpecker_minimal as reference
from femb.elements import Gravity, Hinge, PointOnLine, RigidBody, RotationalSpringDamper
from femb.elements.contact import SphereOnPlane

PARAMS = {"mu": 0.3, "e_N1": 0.5, "c_phi": 5.6e-3, "g": 9.81}
GEOMETRY = {k: reference.PARAMS[k] for k in ("m_M", "J_M", "m_S", "J_S", "r_0", "r_M", "h_M", "l_M", "l_G",
                                              "h_S", "l_S")}
DEFAULTS = {"t_end": 1.0, "h": 1e-4, "rho_inf": 0.8}
PARAMETERS = {"mu": ("friction coefficient of the three contacts", "-"),
              "e_N1": ("normal restitution of the beak (the sleeve's edges: 0)", "-"),
              "c_phi": ("rotational spring sleeve-woodpecker", "N m/rad"), "g": ("gravity along -y", "m/s^2")}
OUTPUTS = {"y": ("sleeve height", "m"), "y_d": ("sleeve velocity", "m/s"), "phi_M": ("sleeve angle", "rad"),
           "phi_S": ("woodpecker angle", "rad"), "phi_S_d": ("woodpecker angular velocity", "rad/s")}
#: The Poincaré section of the figures: φ_S decreasing through the published state's −0.2788 rad.
SECTION = reference.LIMIT_CYCLE_STATE["phi_S"]


def _rot(phi, v):
    c, s = math.cos(phi), math.sin(phi)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def build(mu=PARAMS["mu"], e_N1=PARAMS["e_N1"], c_phi=PARAMS["c_phi"], g=PARAMS["g"]):
    """Bodies ``sleeve``, ``woodpecker``; joints ``axis``, ``hinge``; ``spring``; contacts ``beak``,
    ``sleeve_low``, ``sleeve_up``; started on the published limit-cycle state (sleeve on its contact angle)."""
    p = GEOMETRY
    s = reference.LIMIT_CYCLE_STATE
    phi_M = -reference.sleeve_contact_angle() + 1e-12            # lower edge touching (gap 6e-15 m)
    phi_S, y_d, w_S = s["phi_S"], s["y_d"], s["phi_S_d"]
    hinge = _rot(phi_M, (p["l_M"], 0.0))
    arm = _rot(phi_S, (p["l_G"], 0.0))
    v_S = np.array([0.0, y_d]) + w_S * np.array([-arm[1], arm[0]])
    mech = Mechanism("contact_woodpecker")
    mech.add(RigidBody("sleeve", p["m_M"], p["J_M"], position=(0.0, s["y"]), angle=phi_M, velocity=(0.0, y_d),
                       shape={"type": "box", "size": (2 * p["r_M"], 2 * p["h_M"])}))
    mech.add(RigidBody("woodpecker", p["m_S"], p["J_S"], position=tuple(hinge + arm), angle=phi_S,
                       velocity=tuple(v_S), omega=w_S))
    mech.add(Gravity((0.0, -g)))
    mech.add(PointOnLine("axis", "ground", "sleeve", axis=(0.0, 1.0), at=(0.0, s["y"])))
    mech.add(Hinge("hinge", "sleeve", "woodpecker", at=tuple(hinge)))
    mech.add(RotationalSpringDamper("spring", "sleeve", "woodpecker", c_phi, angle=0.0))
    pole = {"plane_point": (p["r_0"], 0.0), "normal": (1.0, 0.0), "mu": mu}
    mech.add(SphereOnPlane("beak", "woodpecker", 0.0, point=(-p["l_S"], p["h_S"]), e_N=e_N1, **pole))
    mech.add(SphereOnPlane("sleeve_low", "sleeve", 0.0, point=(p["r_M"], -p["h_M"]), e_N=0.0, **pole))
    mech.add(SphereOnPlane("sleeve_up", "sleeve", 0.0, point=(p["r_M"], p["h_M"]), e_N=0.0, **pole))
    return mech


def outputs(result):
    return {"y": result.series("sleeve.y")[0], "y_d": result.series("sleeve.y_d")[0],
            "phi_M": result.series("sleeve.theta")[0], "phi_S": result.series("woodpecker.theta")[0],
            "phi_S_d": result.series("woodpecker.theta_d")[0]}


def limit_cycle(t, y, y_d, phi_S, phi_S_d, periods=2):
    """Figures of the last ``periods`` periods of a trajectory (dict).

    Section: φ_S decreasing through :data:`SECTION` (linear interpolation between stored steps).
    ``period`` the mean time between the last ``periods + 1`` crossings, ``period spread`` the largest
    deviation of one of them from it, ``descent speed`` −Δy/Δt between the first and last of them,
    ``phi_S min/max`` and ``omega_S min/max`` over those periods, ``y_d, omega_S at section`` the mean
    values at the crossings (the published state: −0.3411 m/s, −7.4583 rad/s).
    """
    t, y, y_d, ph, w = (np.asarray(a, float) for a in (t, y, y_d, phi_S, phi_S_d))
    k = np.where((ph[:-1] > SECTION) & (ph[1:] <= SECTION))[0]
    if k.size < periods + 1:
        raise ValueError(f"woodpecker: {k.size} crossings of the section, {periods + 1} needed (run longer)")
    k = k[-(periods + 1):]
    a = (ph[k] - SECTION) / (ph[k] - ph[k + 1])
    lerp = lambda z: z[k] + a * (z[k + 1] - z[k])                                       # noqa: E731
    tc, yc = lerp(t), lerp(y)
    dt = np.diff(tc)
    span = slice(k[0], k[-1] + 1)
    return {"period": float(dt.mean()), "period spread": float(np.abs(dt - dt.mean()).max()),
            "descent speed": float(-(yc[-1] - yc[0]) / (tc[-1] - tc[0])),
            "phi_S min": float(ph[span].min()), "phi_S max": float(ph[span].max()),
            "omega_S min": float(w[span].min()), "omega_S max": float(w[span].max()),
            "y_d at section": float(lerp(y_d).mean()), "omega_S at section": float(lerp(w).mean())}


def femb_run(t_end=DEFAULTS["t_end"], h=DEFAULTS["h"], rho_inf=DEFAULTS["rho_inf"]):
    """femb's run: (ContactResult, limit-cycle figures)."""
    from femb.contact import simulate
    res = simulate(build().compile(), t_end, h, rho_inf=rho_inf)
    o = outputs(res)
    return res, limit_cycle(res.t, o["y"], o["y_d"], o["phi_S"], o["phi_S_d"])


def reference_run(t_end=DEFAULTS["t_end"], h=1e-6, linear=False):
    """The minimal-coordinate reference (Moreau, step h): (dict of arrays, limit-cycle figures)."""
    r = reference.simulate(t_end, h=h, linear=linear, every=max(1, int(round(1e-5 / h))))
    return r, limit_cycle(r["t"], r["q"][:, 0], r["u"][:, 0], r["q"][:, 2], r["u"][:, 2])


def table(t_end=DEFAULTS["t_end"], hs=(2e-4, DEFAULTS["h"]), h_ref=1e-6):
    """femb against the exact and the linear minimal models (dict of dicts)."""
    rows = {}
    for h in hs:
        res, fig = femb_run(t_end, h)
        L = res.model.length_scale
        fig.update({"impacts": len(res.events), "min g_N / L": float(res.contact["gN"].min() / L),
                    "wall (s)": res.wall_time})
        rows[f"femb h = {h:g}"] = fig
    for linear in (False, True):
        r, f = reference_run(t_end, h_ref, linear)
        f["min g_N (m)"] = float(r["gN"].min())
        rows[f"Moreau h = {h_ref:g}, {'linear' if linear else 'exact'}"] = f
    return rows


def main():
    rows = table()
    keys = list(dict.fromkeys(k for r in rows.values() for k in r))
    print("woodpecker  " + " | ".join(rows))
    for k in keys:
        print(f"  {k:22s} " + " | ".join(f"{r[k]:.6g}" if k in r else "-" for r in rows.values()))


if __name__ == "__main__":
    main()
