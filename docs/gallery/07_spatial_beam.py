"""A spinning arm with a flexible blade
=====================================

A spatial rigid arm turns on a revolute joint about the vertical axis and
carries a thin steel blade welded to its tip: eight geometrically exact
SE(3) beam elements (Sonneville, Cardona & Brüls 2014) meshed by
:func:`~femb.elements.spatial_beam.spatial_beam`. The mechanism starts
spinning as one rigid body (:func:`femb.set_rigid_velocity`) under gravity:
the blade sags and vibrates about its sagged shape while it turns. The example
prints the tip's sag and the bending moment at the blade's root, and pictures
the motion.
"""
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import femb
from femb.elements import RevoluteJoint, SpatialGravity, SpatialRigidBody
from femb.elements.spatial_beam import SpatialSection, spatial_beam
from femb.elements.spatial_bodies import rod_inertia
from femb.io.render import render_strip

mech = femb.Mechanism("arm_and_blade")
arm = mech.add(SpatialRigidBody("arm", 2.0, rod_inertia(2.0, 0.4, 0.03), position=(0.2, 0.0, 0.0),
                                points={"O": (-0.2, 0.0, 0.0), "tip": (0.2, 0.0, 0.0)},
                                shape={"type": "box", "size": (0.4, 0.05, 0.05)}))
mech.add(RevoluteJoint("hub", "ground", arm, at=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0)))
steel = SpatialSection.rectangle(E=2.1e11, G=8.1e10, width=0.02, height=0.005, density=7850.0)
blade = spatial_beam(mech, "blade", steel, [(0.4, 0.0, 0.0), (1.0, 0.0, 0.0)], 8, start=arm)
mech.add(SpatialGravity((0.0, 0.0, -9.81)))
femb.set_rigid_velocity(mech, omega=(0.0, 0.0, 4.0))          # 4 rad/s about z, as one rigid body

result = femb.simulate(mech.compile(), t_end=1.0, h=1e-3, rho_inf=0.8)
tip = result.position(blade.nodes[-1].name)
series = result.beam("blade")
print(f"tip height: min {tip[:, 2].min() * 1e3:.2f} mm, at t = 1 s {tip[-1, 2] * 1e3:.2f} mm")
print(f"root bending moment M2 at t = 1 s: {series.forces[-1, 0, 4]:.4f} N m")

# %%
# The tip's height and the motion
tmp = Path(tempfile.mkdtemp())
pvd = result.write_vtk(tmp / "vtk", every=50)
render_strip(pvd, tmp / "blade.png", n=4, window_size=(1000, 300))
fig, axes = plt.subplots(2, 1, figsize=(9, 6), gridspec_kw={"height_ratios": [1, 1.2]})
axes[0].imshow(plt.imread(tmp / "blade.png"))
axes[0].set_axis_off()
axes[1].plot(result.t, tip[:, 2] * 1e3, lw=2)
axes[1].set_xlabel("t [s]")
axes[1].set_ylabel("tip height [mm]")
plt.tight_layout()
plt.show()
