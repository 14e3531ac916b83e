"""Bauchau's flexible four-bar: three SE(3) beams, a hinge tilted by 5°, crank driven at 0.6 rad/s.

The four-bar mechanism of the benchmark set of Bauchau et al. (2016): ground pivots
A = (0, 0, 0) and D = (0.24, 0, 0) m, link 1 (A → B = (0, 0.12, 0)), link 2 (B → C =
(0.24, 0.12, 0)) and link 3 (C → D), a parallelogram. Revolute joints about z at A, B and D;
the hinge at C is tilted by 5° about link 2's axis, (0, −sin 5°, cos 5°): a rigid linkage would
lock, the flexible one moves by bending and twisting its links out of the plane. The angle of
link 1 at A is prescribed, θ = −0.6 t rad from t = 0 (an impulsive start: at t0 only the
driven beam node turns; femb starts such steps with the seed's start, ``settings["start_used"]``).
Twice per turn (t ≈ 2.62 s and 7.85 s) the parallelogram folds flat: a singular position
where small differences of the model show most.

Sections (mb_sef_py's example, the benchmark's data): links 1 and 2 EA = 52.99 MN,
GA = 16.88 MN, GJ = 733.5 N m², EI = 1131 N m², ρA = 1.997 kg/m, ρJ = (85.2, 42.6, 42.6)
× 10⁻⁶ kg m; link 3 EA = 13.25 MN, GA = 4.22 MN, GJ = 45.84 N m², EI = 70.66 N m²,
ρA = 0.4992 kg/m, ρJ = (5.324, 2.662, 2.662) × 10⁻⁶ kg m; no gravity.

Not in the registry's :data:`~femb.study.registry.SCENES`: its impulsive start sets the
links' undamped stiff modes ringing, which adaptive steps resolve (steps of 2–4 µs, about
80 000 steps per 0.5 s), so the benchmark suite's adaptive series would take minutes and
gigabytes; ``femb run benchmarks/scenes/beams/bauchau_fourbar.py`` runs it as a scene file, and
``python -m femb.benchmarks.scenes.beams.bauchau_fourbar`` compares it with the reference.

Reference: the results published with mb_sef_py's example (V. Sonneville's code of the
same SE(3) element, consistent SE(3) mass, 8 elements per link, h = 4 ms, ρ∞ = 0;
:mod:`femb.benchmarks.references.mb_sef_fourbar`): the crooked hinge's point on link 2.

References
----------
O. A. Bauchau, P. Betsch, A. Cardona, J. Gerstmayr, B. Jonker, P. Masarati, V. Sonneville,
Validation of flexible multibody dynamics beam formulations using benchmark problems,
Multibody Syst. Dyn. 37:29–48, 2016.
V. Sonneville, mb_sef_py, github.com/vspsonn/mb_sef_py, examples/beam_fourbar (commit ed99143).
"""
from __future__ import annotations

import argparse
import math

import numpy as np

from femb import Mechanism
from femb.base.functions import Linear
from femb.elements.spatial_beam import SpatialSection, spatial_beam
from femb.elements.spatial_joints import DrivenRevoluteAngle, RevoluteJoint

DATA = dict(A=(0.0, 0.0, 0.0), B=(0.0, 0.12, 0.0), C=(0.24, 0.12, 0.0), D=(0.24, 0.0, 0.0),
            omega=-0.6, defect_deg=5.0,
            link12=dict(EA=52.99e6, GA=16.88e6, GJ=733.5, EI=1131.0, rhoA=1.997, rhoJ=42.6e-6),
            link3=dict(EA=13.25e6, GA=4.22e6, GJ=45.84, EI=70.66, rhoA=0.4992, rhoJ=2.662e-6))

#: Run settings (scene protocol of :mod:`femb.study.registry`): the reference's.
DEFAULTS = {"t_end": 12.0, "h": 4e-3, "rho_inf": 0.0}

PARAMETERS = {
    "n_elements": ("SE(3) beam elements per link", "-"),
    "defect_deg": ("tilt of the hinge at C about link 2's axis", "deg"),
}

OUTPUTS = {
    "hinge_x": ("x of link 2's end at the crooked hinge C", "m"),
    "hinge_y": ("y of link 2's end at C", "m"),
    "hinge_z": ("z of link 2's end at C (out of plane)", "m"),
    "T_drive": ("driving torque on link 1 about z", "N m"),
    "R_C_z": ("z force of link 2 on link 3 at C", "N"),
}

#: the in-plane kinematics is smooth; the start is impulsive (its O(h) transient in λ is
#: damped by ρ∞ = 0 within a few steps)
CONVERGENCE = {"t_end": 1.0, "h": [4e-3, 2e-3, 1e-3, 5e-4], "q": ["hinge_x", "hinge_y", "hinge_z"],
               "lambda": ["T_drive", "R_C_z"]}


def section(p):
    """A link's :class:`SpatialSection` from its entry of :data:`DATA` (ρJ₁ = 2ρJ₂)."""
    return SpatialSection.from_properties(p["EA"], p["GA"], p["GA"], p["GJ"], p["EI"], p["EI"], rhoA=p["rhoA"],
                                          rhoJ=(2.0 * p["rhoJ"], p["rhoJ"], p["rhoJ"]))


def build(n_elements=8, *, defect_deg=DATA["defect_deg"]):
    """The mechanism: beams ``link1``, ``link2``, ``link3`` (nodes ``link1.n0`` … ``link1.n{n}``, …),
    joints ``A``, ``drive``, ``B``, ``C``, ``D``."""
    D = DATA
    A, B, C, Dp = (np.array(D[k]) for k in ("A", "B", "C", "D"))
    z = np.array([0.0, 0.0, 1.0])
    d = math.radians(float(defect_deg))
    m = Mechanism("bauchau_fourbar")
    n = int(n_elements)
    l1 = spatial_beam(m, "link1", section(D["link12"]), [A, B], n)
    l2 = spatial_beam(m, "link2", section(D["link12"]), [B, C], n)
    l3 = spatial_beam(m, "link3", section(D["link3"]), [C, Dp], n)
    m.add(RevoluteJoint("A", m.ground, l1.nodes[0], at=A, axis=z))
    m.add(DrivenRevoluteAngle("drive", m.ground, l1.nodes[0], Linear(D["omega"]), at=A, axis=z))
    m.add(RevoluteJoint("B", l1.nodes[-1], l2.nodes[0], at=B, axis=z))
    m.add(RevoluteJoint("C", l2.nodes[-1], l3.nodes[0], at=C, axis=np.array([0.0, -math.sin(d), math.cos(d)])))
    m.add(RevoluteJoint("D", l3.nodes[-1], m.ground, at=Dp, axis=z))
    return m


def _hinge(model):
    return max((nm for nm in model.node_index if nm.startswith("link2.n")), key=lambda s: int(s[7:]))


def outputs(result):
    """Named outputs over the stored steps, each (nt,) (:data:`OUTPUTS`).

    ``T_drive`` = −λ of ``drive`` (the driver's moment on link 1 is −λ e_z); ``R_C_z``: λ[2] of
    the hinge ``C`` (force on its body b, link 3, space axes).
    """
    x = result.model.node_coordinates(_hinge(result.model), result.q)
    return {"hinge_x": x[:, 0], "hinge_y": x[:, 1], "hinge_z": x[:, 2],
            "T_drive": -result.reaction("drive")[:, 0], "R_C_z": result.reaction("C")[:, 2]}


def reference(t, **params):
    """mb_sef_py's published hinge position at the times t (linear interpolation of its samples
    every 0.04 s); NaN for other outputs and for a defect other than 5°."""
    from femb.benchmarks.references.mb_sef_fourbar import HINGE
    t = np.atleast_1d(np.asarray(t, dtype=float))
    ok = float(params.get("defect_deg", DATA["defect_deg"])) == DATA["defect_deg"]
    out = {}
    for i, k in enumerate(("hinge_x", "hinge_y", "hinge_z")):
        v = np.interp(t, HINGE[:, 0], HINGE[:, i + 1], left=np.nan, right=np.nan)
        out[k] = v if ok else np.full_like(t, np.nan)
    out["description"] = ("mb_sef_py (V. Sonneville), examples/beam_fourbar/beam_fourbar.h5: the same SE(3) "
                          "element with consistent SE(3) mass, 8 elements per link, h = 4 ms, rho_inf = 0")
    return out


def comparison(n_elements=8, h=DEFAULTS["h"]):
    """femb against the reference at its samples, away from and near the folded positions.

    Returns
    -------
    dict
        ``smooth`` (3,) and ``fold`` (3,): max |femb − mb_sef_py| of x, y, z over the samples farther
        than 0.2 s from the folded positions t = (π/2 + kπ)/0.6 and over the rest; ``z_max``: max |z|
        of the reference; ``start_used``.
    """
    import femb
    from femb.benchmarks.references.mb_sef_fourbar import HINGE
    r = femb.simulate(build(n_elements).compile(), DEFAULTS["t_end"], h, rho_inf=DEFAULTS["rho_inf"])
    o = outputs(r)
    t = HINGE[:, 0]
    x = np.stack([np.interp(t, r.t, o[k]) for k in ("hinge_x", "hinge_y", "hinge_z")], axis=1)
    d = np.abs(x - HINGE[:, 1:])
    folds = (0.5 * math.pi + math.pi * np.arange(4)) / abs(DATA["omega"])
    near = np.min(np.abs(t[:, None] - folds[None, :]), axis=1) < 0.2
    return {"smooth": d[~near].max(axis=0), "fold": d[near].max(axis=0), "z_max": np.abs(HINGE[:, 3]).max(),
            "start_used": r.settings["start_used"]}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="*", default=[8, 16])
    ap.add_argument("--h", type=float, nargs="*", default=[4e-3, 1e-3])
    a = ap.parse_args(argv)
    print("max |femb - mb_sef_py| of the hinge position (x, y, z) in m; away from / within 0.2 s of the folded "
          "positions (t = 2.62, 7.85 s)")
    for n in a.n:
        for h in a.h:
            c = comparison(n, h)
            print(f"  {n:3d} el./link, h = {h:g}: smooth ({c['smooth'][0]:.1e}, {c['smooth'][1]:.1e}, "
                  f"{c['smooth'][2]:.1e}), fold ({c['fold'][0]:.1e}, {c['fold'][1]:.1e}, {c['fold'][2]:.1e}); "
                  f"reference max |z| = {c['z_max']:.2e}; start: {c['start_used']}")


if __name__ == "__main__":
    main()
