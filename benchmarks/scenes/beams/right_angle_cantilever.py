"""Right-angle cantilever under an elbow load pulse (Simo & Vu-Quoc 1988), spatial SE(3) beams.

Two straight members (0, 0, 0) → (10, 0, 0) → (10, 10, 0) with a rigid elbow (one shared
frame node), clamped at the origin; EA = GA = 1e6, GJ = EI = 1e3, ρA = 1, ρJ = diag(20, 10, 10)
(section axes: 1 along the member). Out-of-plane elbow force F_z = 50 t on [0, 1],
50 (2 − t) on [1, 2], then 0; 30 s of free large-amplitude flexural–torsional vibration.
Data: ``docs/beams.md``, "Validation (spatial)" (Simo & Vu-Quoc 1988; Brüls, Cardona & Arnold 2012,
Ex. 7.2; vspsonn/mb_sef_py:examples/beam_rightangle, 10 elements per member, ρ∞ = 0.95).
Published references are plots only: the scene reports the tip and elbow displacements; the
convergence study (:func:`study`, ``--study``) measures the order over the whole 30 s in h and
under mesh refinement, and compares the peaks with :data:`MB_SEF_PEAKS`, the results that
vspsonn/mb_sef_py publishes with its example (examples/beam_rightangle/beam_rightangle.h5 at
commit ed99143: the same SE(3) element by the formulation's author, 10 elements per member,
h = 0.01, ρ∞ = 0.95, with its configuration-dependent consistent mass where femb lumps the
rotary inertia).

References
----------
J. C. Simo, L. Vu-Quoc, On the dynamics in space of rods undergoing large motions — a
geometrically exact approach, Comput. Methods Appl. Mech. Eng. 66:125–161, 1988.
O. Brüls, A. Cardona, M. Arnold, Lie group generalized-α time integration of constrained
flexible multibody systems, Mech. Mach. Theory 48:121–137, 2012.
"""
from __future__ import annotations

import argparse

import numpy as np

from femb import Mechanism
from femb.base.functions import TimeFunction
from femb.elements.spatial_beam import SpatialSection, spatial_beam
from femb.elements.spatial_forces import SpatialForce

DATA = dict(L=10.0, EA=1e6, GA=1e6, GJ=1e3, EI=1e3, rhoA=1.0, rhoJ=(20.0, 10.0, 10.0), F=50.0, t_end=30.0)

#: Run settings (scene protocol of :mod:`femb.study.registry`).
DEFAULTS = {"t_end": DATA["t_end"], "h": 0.1, "rho_inf": 0.95}

PARAMETERS = {
    "n_elements": ("elements per member", "-"),
    "mass": ("beam translational mass, 'consistent', 'lumped' or 'averaged'", "-"),
    "damping": ("stiffness-proportional damping beta of the beam", "s"),
}

OUTPUTS = {
    "tip_x": ("free tip x", "m"), "tip_y": ("free tip y", "m"), "tip_z": ("free tip z (out of plane)", "m"),
    "elbow_z": ("elbow z (out of plane)", "m"),
    "root_Fz": ("z force of the ground on the beam root", "N"),
}

#: Local extrema (time s, value m) of the out-of-plane displacements in the results published
#: with vspsonn/mb_sef_py (examples/beam_rightangle/beam_rightangle.h5, commit ed99143,
#: stored every 0.03 s; 10 elements per member, h = 0.01, ρ∞ = 0.95).
MB_SEF_PEAKS = {"tip_z": [(7.41, 8.248), (15.87, -9.760), (26.16, 7.213)],
                "elbow_z": [(3.09, 5.511), (10.83, -4.072), (20.94, -3.322), (25.23, 6.091)]}

CONVERGENCE = {"t_end": 4.0, "h": [0.1, 0.05, 0.025, 0.0125], "q": ["tip_z", "elbow_z", "tip_x"],
               "lambda": ["root_Fz"]}


def load_pulse(F=DATA["F"]):
    """The hat F(t): 0 → F at t = 1 → 0 at t = 2 (a TimeFunction; kinks at 0, 1 and 2)."""
    def f(t):
        return F * t if t <= 1.0 else (F * (2.0 - t) if t <= 2.0 else 0.0)

    def df(t):
        return F if t < 1.0 else (-F if t < 2.0 else 0.0)

    return TimeFunction(f, df, lambda t: 0.0, name="hat")


def build(n_elements=10, *, mass="consistent", damping=0.0):
    """The scene: beam ``beam`` with nodes ``beam.n0`` (welded to the ground by ``beam.start``) …
    ``beam.n{2n}`` (free tip); the elbow is ``beam.n{n}``, loaded by ``load``."""
    D = DATA
    sec = SpatialSection.from_properties(D["EA"], D["GA"], D["GA"], D["GJ"], D["EI"], D["EI"],
                                         rhoA=D["rhoA"], rhoJ=D["rhoJ"], damping=damping)
    mech = Mechanism("right_angle_cantilever")
    n = int(n_elements)
    # the clamp is a weld to the ground (FixedJoint "beam.start"), so its reactions are outputs
    b = spatial_beam(mech, "beam", sec, [(0, 0, 0), (D["L"], 0, 0), (D["L"], D["L"], 0)], n,
                     start=mech.ground, mass=mass)
    mech.add(SpatialForce("load", b.nodes[n], (0.0, 0.0, 1.0), function=load_pulse()))
    return mech


def _nodes(model):
    names = sorted((nm for nm in model.node_index if nm.startswith("beam.n")), key=lambda s: int(s[6:]))
    return names[(len(names) - 1) // 2], names[-1]


def outputs(result):
    """Tip position (x, y, z), elbow z and the root's z reaction over the stored steps, each (nt,).

    ``root_Fz``: z component of the weld's force on the beam root (λ[0:3] of a FixedJoint is the
    force on its body b, space axes).
    """
    elbow, tip = _nodes(result.model)
    xt = result.body(tip)
    xe = result.body(elbow)
    return {"tip_x": xt[:, 0], "tip_y": xt[:, 1], "tip_z": xt[:, 2], "elbow_z": xe[:, 2],
            "root_Fz": result.reaction("beam.start")[:, 2]}


def _run(n, h, t_end=30.0):
    import femb
    r = femb.simulate(build(n).compile(), t_end, h, rho_inf=DEFAULTS["rho_inf"])
    o = outputs(r)
    return np.asarray(r.t), o["tip_z"], o["elbow_z"]


def _max_diff(a, b, ts):
    """max over ts of |tip z| and |elbow z| differences of two runs (t, tip_z, elbow_z)."""
    return max(np.abs(np.interp(ts, a[0], a[i]) - np.interp(ts, b[0], b[i])).max() for i in (1, 2))


def study(hs=(0.1, 0.05, 0.025, 0.0125, 0.00625), h_ref=0.1 / 64, ns=(5, 10, 20, 40, 80), n_ref=160,
          h_mesh=0.0025, t_end=30.0):
    """Convergence over the whole interval, in h (10 elements per member) and under mesh refinement.

    Errors are max over t = 0, 0.1, …, t_end of |tip z| and |elbow z| against a run at ``h_ref``
    (same mesh) or with ``n_ref`` elements per member (same ``h_mesh``); the peaks of the finest
    mesh are compared with :data:`MB_SEF_PEAKS`.

    Returns
    -------
    dict
        ``h``, ``err_h``, ``order_h``; ``n``, ``err_n``, ``order_n``; ``peaks``: per output a list of
        (t, mb_sef_py value, femb value) with femb's extremum within ±1 s of mb_sef_py's.
    """
    ts = np.linspace(0.0, t_end, int(round(t_end / 0.1)) + 1)
    ref = _run(10, h_ref, t_end)
    err_h = np.array([_max_diff(_run(10, h, t_end), ref, ts) for h in hs])
    ref = _run(n_ref, h_mesh, t_end)
    err_n = np.array([_max_diff(_run(n, h_mesh, t_end), ref, ts) for n in ns])
    peaks = {}
    for k, i in (("tip_z", 1), ("elbow_z", 2)):
        rows = []
        for tp, vp in MB_SEF_PEAKS[k]:
            w = np.abs(ref[0] - tp) <= 1.0
            v = ref[i][w]
            rows.append((tp, vp, float(v.max() if vp > 0 else v.min())))
        peaks[k] = rows
    return {"h": list(hs), "err_h": err_h, "order_h": np.log2(err_h[:-1] / err_h[1:]),
            "n": list(ns), "err_n": err_n, "order_n": np.log2(err_n[:-1] / err_n[1:]), "peaks": peaks}


def main(argv=None):
    import femb

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=10, help="elements per member")
    ap.add_argument("--h", type=float, default=DEFAULTS["h"])
    ap.add_argument("--t-end", type=float, default=DATA["t_end"])
    ap.add_argument("--rho-inf", type=float, default=DEFAULTS["rho_inf"])
    ap.add_argument("--study", action="store_true", help="orders in h and n over [0, 30] s, peaks")
    a = ap.parse_args(argv)
    if a.study:
        st = study()
        print("max over [0, 30] s of |tip z|, |elbow z| errors (m)")
        print("  h (10 el./member, against h = 0.1/64): " + ", ".join(
            f"{h:g}: {e:.2e}" for h, e in zip(st["h"], st["err_h"])) + "; orders "
            + ", ".join(f"{o:.2f}" for o in st["order_h"]))
        print("  elements per member (h = 2.5 ms, against 160): " + ", ".join(
            f"{n}: {e:.2e}" for n, e in zip(st["n"], st["err_n"])) + "; orders "
            + ", ".join(f"{o:.2f}" for o in st["order_n"]))
        print("  peaks, mb_sef_py (10 el., h = 0.01) against femb (160 el., h = 2.5 ms):")
        for k, rows in st["peaks"].items():
            for tp, vp, vf in rows:
                print(f"    {k:8s} t ≈ {tp:5.2f} s: {vp: .3f}  femb {vf: .3f}  ({100 * (vf / vp - 1):+.2f} %)")
        return
    r = femb.simulate(build(a.n).compile(), a.t_end, a.h, rho_inf=a.rho_inf)
    out = outputs(r)
    print(f"right-angle cantilever, n = {a.n} per member, h = {a.h:g} s, {r.wall_time:.2f} s wall")
    for k in range(0, len(r.t), max(1, len(r.t) // 30)):
        print(f"  t = {r.t[k]:6.2f}  tip z {out['tip_z'][k]: .4f}  elbow z {out['elbow_z'][k]: .4f}  "
              f"tip x {out['tip_x'][k]: .4f}")
    print(f"  max |tip z| = {np.abs(out['tip_z']).max():.4f} m, max |elbow z| = {np.abs(out['elbow_z']).max():.4f} m")


if __name__ == "__main__":
    main()
