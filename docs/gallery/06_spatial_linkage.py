"""A driven spatial linkage (RSSR)
===============================

A crank turning about the vertical axis drives, through a coupler with a
ball joint at each end, a rocker hinged about a horizontal axis: the
spatial four-bar RSSR (revolute–spherical–spherical–revolute). A
:class:`~femb.elements.spatial_joints.DrivenRevoluteAngle` turns the crank
at one turn per second (steps land on every quarter turn); the bodies have no drawing shape, so each is drawn
as a bar through its joint points. The example prints the rocker's swing and
the motor torque (−λ of the drive), checks that the motor's power is the
rate of change of the linkage's energy, and renders small multiples of one
turn with the path of the coupler's middle.
"""
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import femb
from femb.base.functions import Linear
from femb.elements.spatial_bodies import SpatialRigidBody, rod_inertia
from femb.elements.spatial_forces import SpatialGravity
from femb.elements.spatial_joints import DrivenRevoluteAngle, RevoluteJoint, SphericalJoint
from femb.io.render import render_png, render_strip

W = 2.0 * np.pi                                          # one turn per second
g = np.array([0.0, 0.0, -9.81])
A, B = np.array([0.0, 0.0, 0.0]), np.array([0.08, 0.0, 0.0])         # crank: A (axle) to B
D = np.array([0.3, 0.0, 0.35])                                       # rocker axle, along x
C = D + 0.2 * np.array([0.0, -np.cos(-0.3), -np.sin(-0.3)])         # rocker tip


def rod(name, mass, P, Q):
    """A slender rod from P to Q (body x along it), at rest, with named end points."""
    L = float(np.linalg.norm(Q - P))
    x = (Q - P) / L
    y = np.cross([0.0, 0.0, 1.0], x) if abs(x[2]) < 0.9 else np.cross([0.0, 1.0, 0.0], x)
    y /= np.linalg.norm(y)
    R = np.column_stack((x, y, np.cross(x, y)))
    return SpatialRigidBody(name, mass, rod_inertia(mass, L, 0.01), position=(P + Q) / 2, rotation=R,
                            points={"P": (-L / 2, 0, 0), "Q": (L / 2, 0, 0), "mid": (0, 0, 0)})


mech = femb.Mechanism("rssr")
crank, coupler, rocker = (mech.add(rod("crank", 0.2, A, B)), mech.add(rod("coupler", 0.5, B, C)),
                          mech.add(rod("rocker", 0.3, D, C)))
mech.add(RevoluteJoint("axle", "ground", crank, at=A, axis=(0.0, 0.0, 1.0)),
         DrivenRevoluteAngle("motor", "ground", crank, Linear(W), at=A, axis=(0.0, 0.0, 1.0)),
         SphericalJoint("B", crank, coupler, at=B),
         SphericalJoint("C", coupler, rocker, at=C),
         RevoluteJoint("pivot", "ground", rocker, at=D, axis=(1.0, 0.0, 0.0)),
         SpatialGravity(g))

result = femb.simulate(mech.compile(), t_end=1.0, h=1e-3, rho_inf=0.9)         # one turn
torque = -result.reaction("motor")[:, 0]                 # moment of the motor on the crank about z (N m)
tip = result.point("rocker", "Q")
phi = np.degrees(np.arctan2(D[2] - tip[:, 2], D[1] - tip[:, 1]))     # rocker angle about x, from -y
energy = np.zeros(result.t.size)
for b in (crank, coupler, rocker):
    x, v = result.body(b.name), result.body(b.name, "qd")
    energy += 0.5 * b.m * np.sum(v[:, :3] ** 2, axis=1) + 0.5 * np.einsum("ni,ij,nj->n", v[:, 3:], b.J, v[:, 3:]) \
        - b.m * x[:, :3] @ g
power = torque * W
dEdt = np.gradient(energy, result.t)
print(f"{'t [s]':>6} {'rocker [deg]':>13} {'motor torque [N m]':>19}")
for i in np.linspace(0, result.t.size - 1, 9).astype(int):
    print(f"{result.t[i]:6.3f} {phi[i]:13.2f} {torque[i]:19.5f}")
inner = slice(2, -2)
print(f"rocker swings {np.ptp(phi):.1f} deg; max |power - dE/dt| = "
      f"{np.max(np.abs(power[inner] - dEdt[inner])):.1e} W (power up to {np.max(np.abs(power)):.3f} W)")

out = Path(tempfile.mkdtemp())
pvd = result.write_vtk(out / "vtk", every=20)
render_png(pvd, out / "rssr.png", time=0.4, window_size=(800, 560), trace=["coupler:mid"])
render_strip(pvd, out / "rssr_strip.png", n=5, window_size=(5 * 260 + 170, 280), trace=["coupler:mid"])

for png in ("rssr.png", "rssr_strip.png"):
    fig, ax = plt.subplots(figsize=(8, 5.6) if png == "rssr.png" else (10, 2.0))
    ax.imshow(plt.imread(out / png))
    ax.set_axis_off()
plt.show()
