"""The heavy top
=============

The heavy top of Brüls & Cardona (2010) as written in the README: a
:class:`~femb.elements.spatial_bodies.SpatialRigidBody` on a ball joint to
the ground, spinning fast under gravity. The example integrates one second
on the Lie group R³ × SO(3), prints the height of the centre of mass, the
spin about the symmetry axis and the energy (constant: nothing dissipates),
and renders the top with the path of its centre of mass — precession and
nutation — and a strip of instants.
"""
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import femb
from femb.elements.spatial_bodies import SpatialRigidBody
from femb.elements.spatial_forces import SpatialGravity
from femb.elements.spatial_joints import SphericalJoint
from femb.io.render import render_png, render_strip

X, W = np.array([0.0, 1.0, 0.0]), np.array([0.0, 150.0, -4.61538])   # CoM from the pivot; Ω in body axes
J = np.array([0.234375, 0.46875, 0.234375])
m, g = 15.0, np.array([0.0, 0.0, -9.81])
mech = femb.Mechanism("top")
disc = {"type": "cylinder", "radius": 0.5, "length": 0.12, "axis": (0.0, 1.0, 0.0)}   # for the picture
top = mech.add(SpatialRigidBody("top", m, J, position=X, velocity=np.cross(W, X), omega=W,
                                points={"O": -X}, shape=disc))
mech.add(SphericalJoint("support", "ground", top, point_b="O"), SpatialGravity(g))
r = femb.simulate(mech.compile(), 1.0, 2.0 ** -11, rho_inf=0.9)

x, v = r.body("top"), r.body("top", "qd")
energy = 0.5 * m * np.sum(v[:, :3] ** 2, axis=1) + 0.5 * np.sum(J * v[:, 3:] ** 2, axis=1) - m * x[:, :3] @ g
print(f"{'t [s]':>6} {'CoM height [m]':>15} {'spin [rad/s]':>13} {'energy [J]':>12}")
for i in np.linspace(0, r.t.size - 1, 6).astype(int):
    print(f"{r.t[i]:6.3f} {x[i, 2]:15.5f} {v[i, 4]:13.4f} {energy[i]:12.5f}")
print(f"energy drift {np.ptp(energy) / abs(energy[0]):.1e} (relative); "
      f"support force at t = 0: {np.round(r.reaction_at('support')[0, :3], 3)} N")

out = Path(tempfile.mkdtemp())
pvd = r.write_vtk(out / "vtk", every=32)
render_png(pvd, out / "heavy_top.png", window_size=(800, 560), trace=["top"])
render_strip(pvd, out / "heavy_top_strip.png", n=4, window_size=(4 * 280 + 150, 300), trace=["top"])

for png in ("heavy_top.png", "heavy_top_strip.png"):
    fig, ax = plt.subplots(figsize=(8, 5.6) if png == "heavy_top.png" else (10, 2.4))
    ax.imshow(plt.imread(out / png))
    ax.set_axis_off()
plt.show()
