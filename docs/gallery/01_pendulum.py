"""A pendulum in a few lines
=========================

The example of the README: a bar on a hinge to the ground, under gravity. It
is integrated at fixed steps and with local error control, the hinge's
reaction and the bar's angle are read by name (every output has a unit), and
the energy balance is checked: nothing dissipates, so the total energy stays
constant up to the integration error.
"""
import matplotlib.pyplot as plt
import numpy as np

import femb
from femb.elements import Gravity, Hinge, RigidBody

mech = femb.Mechanism("pendulum")
bar = mech.add(RigidBody("bar", mass=1.0, inertia=1 / 12, position=(0.5, 0.0),
                         points={"O": (-0.5, 0.0)}, shape={"type": "bar", "width": 0.04}))
mech.add(Hinge("pivot", "ground", bar, point_b="O"))   # Φ = r_ground − r_bar(O)
mech.add(Gravity((0.0, -9.81)))

model = mech.compile()
result = femb.simulate(model, t_end=2.0, h=1e-3, rho_inf=0.7)          # fixed steps
adaptive = femb.simulate(model, t_end=2.0, rtol=1e-6, atol=1e-8)       # local error control
print(result)
print(f"adaptive: {adaptive.steps} steps, h from {adaptive.h_steps.min():.2e} to "
      f"{adaptive.h_steps.max():.2e} s, {adaptive.n_rejected} rejected")
print("x, y, theta of the bar at t = 2 s:", result.body("bar")[-1])
print(f"relative energy error: {result.energy_balance():.1e}")

# %%
# Named outputs, with their units, as a figure
theta, unit_theta = result.series("bar.theta")
fy, unit_fy = result.series("pivot.Fy")
fig, axes = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
axes[0].plot(result.t, theta, lw=2, label="h = 1e-3 s")
axes[0].plot(adaptive.t, adaptive.series("bar.theta")[0], "k.", ms=3, label="rtol = 1e-6")
axes[0].set_ylabel(f"bar.theta [{unit_theta}]")
axes[0].legend()
axes[1].plot(result.t, fy, lw=2, color="C1")
axes[1].set_ylabel(f"pivot.Fy [{unit_fy}]")
axes[1].set_xlabel("t [s]")
fig.suptitle("A pendulum released from the horizontal")
plt.show()
