"""Spin-up of a flexible beam (Simo & Vu-Quoc 1986) built in 3-D from SE(3) spatial beams.

The planar scene :mod:`femb.benchmarks.scenes.beams.spin_up` rebuilt with spatial elements: a hub
(:class:`SpatialRigidBody`) on a :class:`RevoluteJoint` about z at the origin, its angle
prescribed by a :class:`DrivenRevoluteAngle` with the same smooth spin-up profile
θ(t) (ω_s = 6 rad/s, T_s = 15 s); the beam, L = 10 m along x, is welded to the hub
(:class:`FixedJoint` ``beam.start``) and meshed with :class:`SpatialBeam` elements.
Section data of the planar scene (EA = 2.8e7 N, GA = 1e7 N, EI = 1.4e4 N m², ρA = 1.2 kg/m,
ρI = 6e-4 kg m) in both bending planes; section axis 3 is z, so the in-plane bending
stiffness is EI₃ and the in-plane rotary inertia ρJ₃₃ = ρI. The out-of-plane data
(GJ = EI, ρJ₁₁ = 2ρI) do not enter: the motion stays in the x–y plane.

Both femb models converge to the same continuum limit; the difference of their tip and
mid-span deflections falls as the mesh is refined (:func:`mesh_comparison`), and the
out-of-plane coordinates stay zero.

References
----------
J. C. Simo, L. Vu-Quoc, On the dynamics of flexible beams under large overall
motions—the plane case: Part II, J. Appl. Mech. 53 (1986) 855–863.
"""
from __future__ import annotations

import argparse

import numpy as np

from femb import Mechanism
from femb.elements.spatial_beam import SpatialSection, spatial_beam
from femb.elements.spatial_bodies import SpatialRigidBody
from femb.elements.spatial_joints import DrivenRevoluteAngle, RevoluteJoint

from femb.benchmarks.scenes.beams import spin_up as planar

DATA = planar.DATA

DEFAULTS = dict(planar.DEFAULTS)

PARAMETERS = {
    "n_elements": ("beam elements", "-"),
    "omega_s": ("final hub angular velocity", "rad/s"),
    "T_s": ("spin-up time (smooth ramp of the hub rate)", "s"),
    "damping": ("stiffness-proportional material damping beta of the beam", "s"),
    "mass": ("beam translational mass, 'consistent', 'lumped' or 'averaged'", "-"),
}

OUTPUTS = {
    "tip_deflection": ("transverse tip displacement in the hub frame", "m"),
    "tip_axial": ("axial tip displacement in the hub frame", "m"),
    "mid_deflection": ("transverse mid-span displacement in the hub frame", "m"),
    "out_of_plane": ("largest |z| of any beam node", "m"),
    "root_moment": ("z torque of the hub on the beam root (counter-clockwise positive)", "N m"),
    "hub_torque": ("torque the driver applies to the hub", "N m"),
}

CONVERGENCE = dict(planar.CONVERGENCE)


def build(n_elements=10, *, omega_s=DATA["omega_s"], T_s=DATA["T_s"], damping=0.0, mass="consistent"):
    """The 3-D spin-up scene.

    Returns
    -------
    Mechanism
        Hub ``hub`` (revolute ``pivot`` to the ground about z, driver ``drive``), beam
        nodes ``beam.n0`` … ``beam.n{n}`` welded to the hub by ``beam.start``.
    """
    D = DATA
    m = Mechanism("spin_up_3d")
    hub = m.add(SpatialRigidBody("hub", 1.0, (0.1, 0.1, 0.1)))
    m.add(RevoluteJoint("pivot", m.ground, hub, at=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0)))
    m.add(DrivenRevoluteAngle("drive", m.ground, hub, planar.spin_profile(omega_s, T_s), at=(0.0, 0.0, 0.0),
                              axis=(0.0, 0.0, 1.0)))
    rI = D["rhoI"]
    sec = SpatialSection.from_properties(D["EA"], D["GA"], D["GA"], D["EI"], D["EI"], D["EI"],
                                         rhoA=D["rhoA"], rhoJ=(2.0 * rI, rI, rI), damping=damping)
    spatial_beam(m, "beam", sec, [(0.0, 0.0, 0.0), (D["L"], 0.0, 0.0)], int(n_elements), start=hub, mass=mass)
    return m


def _beam_nodes(model):
    return sorted((nm for nm in model.node_index if nm.startswith("beam.n")), key=lambda s: int(s[6:]))


def hub_frame(result, name):
    """(axial, transverse) displacement of node ``name`` in the rotating hub frame, (nt, 2)."""
    m = result.model
    x = m.node_coordinates(name, result.q)
    hub = m.node_coordinates("hub", result.q)
    th = 2.0 * np.arctan2(hub[:, 6], hub[:, 3])          # rotation about z (the revolute holds x, y)
    X0 = m.node_coordinates(name, m.q0[None, :])[0, 0:3]
    c, s = np.cos(th), np.sin(th)
    dx, dy = x[:, 0] - hub[:, 0], x[:, 1] - hub[:, 1]
    return np.column_stack((c * dx + s * dy - X0[0], -s * dx + c * dy - X0[1]))


def outputs(result):
    """Named outputs over the stored steps, each (nt,) (see :data:`OUTPUTS`).

    ``root_moment`` is −λ[5] of the weld ``beam.start`` (the weld acts on the beam root
    with the moment −λ[5] u3, u3 = z); ``hub_torque`` is −λ of ``drive`` (the driver acts on
    the hub with −λ e_z).
    """
    names = _beam_nodes(result.model)
    tip = hub_frame(result, names[-1])
    mid = hub_frame(result, names[(len(names) - 1) // 2])
    z = np.stack([result.model.node_coordinates(nm, result.q)[:, 2] for nm in names], axis=1)
    return {"tip_deflection": tip[:, 1], "tip_axial": tip[:, 0], "mid_deflection": mid[:, 1],
            "out_of_plane": np.abs(z).max(axis=1),
            "root_moment": -result.reaction("beam.start")[:, 5],
            "hub_torque": -result.reaction("drive")[:, 0]}


def planar_outputs(result):
    """Tip and mid-span deflections of the planar scene (the comparison quantities), each (nt,)."""
    out = planar.outputs(result)
    m = result.model
    names = sorted((nm for nm in m.node_index if nm.startswith("beam.n")), key=lambda s: int(s[6:]))
    mid = result.body(names[(len(names) - 1) // 2])
    hub = result.body("hub")
    c, s = np.cos(hub[:, 2]), np.sin(hub[:, 2])
    X0 = m.node_coordinates(names[(len(names) - 1) // 2], m.q0[None, :])[0]
    dx, dy = mid[:, 0] - hub[:, 0], mid[:, 1] - hub[:, 1]
    out["mid_deflection"] = -s * dx + c * dy - X0[1]
    return out


def mesh_comparison(ns=(4, 8, 16, 32), t_end=2.0, h=1e-3, rho_inf=0.7):
    """Tip and mid-span deflections of the 3-D and the planar scene at t_end per mesh.

    Returns
    -------
    dict
        ``n`` (k,); ``tip_3d``, ``tip_2d``, ``mid_3d``, ``mid_2d`` (k,) at t_end; ``diff``
        (k,) max(|tip_3d − tip_2d|, |mid_3d − mid_2d|); ``orders`` (k − 1,)
        log₂(diff_i / diff_{i+1}); ``out_of_plane`` (k,) the largest |z| of a node over the run.
    """
    import femb

    rows = {k: [] for k in ("tip_3d", "tip_2d", "mid_3d", "mid_2d", "out_of_plane")}
    for n in ns:
        r3 = femb.simulate(build(n).compile(), t_end, h, rho_inf=rho_inf)
        r2 = femb.simulate(planar.build(n).compile(), t_end, h, rho_inf=rho_inf)
        o3, o2 = outputs(r3), planar_outputs(r2)
        rows["tip_3d"].append(o3["tip_deflection"][-1])
        rows["tip_2d"].append(o2["tip_deflection"][-1])
        rows["mid_3d"].append(o3["mid_deflection"][-1])
        rows["mid_2d"].append(o2["mid_deflection"][-1])
        rows["out_of_plane"].append(o3["out_of_plane"].max())
    out = {k: np.array(v) for k, v in rows.items()}
    out["n"] = list(ns)
    out["diff"] = np.maximum(np.abs(out["tip_3d"] - out["tip_2d"]), np.abs(out["mid_3d"] - out["mid_2d"]))
    out["orders"] = np.log2(out["diff"][:-1] / out["diff"][1:])
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="*", default=[4, 8, 16, 32])
    ap.add_argument("--t-end", type=float, default=2.0)
    ap.add_argument("--h", type=float, default=1e-3)
    a = ap.parse_args(argv)
    c = mesh_comparison(a.n, a.t_end, a.h)
    print(f"spin-up in 3-D against the planar scene, t = {a.t_end:g} s, h = {a.h:g} s")
    print("  n    tip 3-D      tip planar   mid 3-D      mid planar   |diff|      order  max|z|")
    for i, n in enumerate(c["n"]):
        o = f"{c['orders'][i - 1]:.2f}" if i else ""
        print(f"  {n:3d}  {c['tip_3d'][i]: .6e} {c['tip_2d'][i]: .6e} {c['mid_3d'][i]: .6e} "
              f"{c['mid_2d'][i]: .6e} {c['diff'][i]:.3e}  {o:>5s}  {c['out_of_plane'][i]:.1e}")


if __name__ == "__main__":
    main()
