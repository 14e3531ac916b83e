"""A four-bar linkage driven by a motor
====================================

A crank turned at a constant rate by a :class:`~femb.elements.DrivenAngle`
drives a coupler and a rocker under gravity. The torque the motor delivers
to the crank is −λ of the driver (see the sign conventions); its power must
equal the rate of change of the mechanism's energy, which the example checks.
It also renders a few instants of the motion into one picture with
:func:`femb.io.render.render_strip`.
"""
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import femb
from femb.base.functions import Linear
from femb.elements import DrivenAngle, Gravity, Hinge, RigidBody
from femb.io.render import render_strip

W = 2.0                                            # crank speed, rad/s
g = 9.81
mech = femb.Mechanism("fourbar")
mech.ground.add_point("A", (0.0, 0.0))
mech.ground.add_point("D", (0.9, 0.0))
# crank-rocker (Grashof: 0.3 + 0.922 < 0.9 + 0.5): crank A-B vertical, rocker D-C vertical at t = 0
B, C = np.array([0.0, 0.3]), np.array([0.9, 0.5])
lc = float(np.linalg.norm(C - B))
bar = {"type": "bar", "width": 0.03}
crank = mech.add(RigidBody("crank", 0.3, 0.3 * 0.3**2 / 12, B / 2, np.pi / 2,
                           points={"A": (-0.15, 0.0), "B": (0.15, 0.0)}, shape=bar))
coupler = mech.add(RigidBody("coupler", 0.8, 0.8 * lc**2 / 12, (B + C) / 2, np.arctan2(*(C - B)[::-1]),
                             points={"B": (-lc / 2, 0.0), "C": (lc / 2, 0.0)}, shape=bar))
rocker = mech.add(RigidBody("rocker", 0.4, 0.4 * 0.5**2 / 12, (0.9, 0.25), np.pi / 2,
                            points={"D": (-0.25, 0.0), "C": (0.25, 0.0)}, shape=bar))
mech.add(Hinge("A", "ground", crank, point_a="A", point_b="A"),
         Hinge("B", crank, coupler, point_a="B", point_b="B"),
         Hinge("C", coupler, rocker, point_a="C", point_b="C"),
         Hinge("D", "ground", rocker, point_a="D", point_b="D"),
         DrivenAngle("motor", "ground", crank, Linear(W)),
         Gravity((0.0, -g)))

model = mech.compile()
result = femb.simulate(model, t_end=2 * np.pi / W, h=2e-3, rho_inf=0.9)   # one turn
torque = -result.reaction("motor")[:, 0]          # torque of the motor on the crank (N m)

# energy of the bodies: kinetic + gravitational
energy = np.zeros(result.t.size)
for b in (crank, coupler, rocker):
    q, v = result.body(b.name), result.body(b.name, "qd")
    energy += 0.5 * b.m * (v[:, 0]**2 + v[:, 1]**2) + 0.5 * b.J * v[:, 2]**2 + b.m * g * q[:, 1]
power = torque * result.body("crank", "qd")[:, 2]
dEdt = np.gradient(energy, result.t)
print(f"{'t [s]':>6} {'motor torque [N m]':>19} {'power [W]':>10} {'dE/dt [W]':>10}")
for i in np.linspace(0, result.t.size - 1, 7).astype(int):
    print(f"{result.t[i]:6.3f} {torque[i]:19.5f} {power[i]:10.5f} {dEdt[i]:10.5f}")
inner = slice(1, -1)                               # central differences only
print(f"max |power - dE/dt| = {np.max(np.abs(power[inner] - dEdt[inner])):.1e} W "
      f"(energy changes by {np.ptp(energy):.3f} J)")

out = Path(tempfile.mkdtemp())
pvd = result.write_vtk(out / "vtk", every=25)
render_strip(pvd, out / "fourbar.png", n=6, window_size=(800, 500))

fig, ax = plt.subplots(figsize=(8, 5))
ax.imshow(plt.imread(out / "fourbar.png"))
ax.set_axis_off()
plt.show()
