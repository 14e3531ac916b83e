"""A bouncing ball
===============

A ball dropped on a rigid floor (restitution 0.5, no friction), integrated by
the nonsmooth generalized-α method of :func:`femb.contact.simulate`
(Capobianco, Harsch, Eugster & Leine 2021). The impacts accumulate at a
finite time, after which the ball rests; the example compares the first
impact times with the closed-form values and plots the height and the
contact force.
"""
import matplotlib.pyplot as plt
import numpy as np

import femb.contact
from femb.benchmarks.scenes.contact import contact_ball

model = contact_ball.build(e_N=0.5).compile()
result = femb.contact.simulate(model, t_end=1.5, h=2e-3, rho_inf=0.8)
y, unit = result.series("ball.y")
print(f"impacts accumulate at t = {contact_ball.accumulation_time():.6f} s (closed form)")
vy = result.series("ball.y_d")[0]
found = result.t[1:][(vy[:-1] < -0.05) & (vy[1:] > 0.0)]      # the velocity turns upwards in one step
exact = contact_ball.impact_times(3)
for k in range(3):
    print(f"impact {k + 1}: femb t = {found[k]:.6f} s, closed form t = {exact[k]:.6f} s")
print(f"height at t = 1.5 s: {y[-1]:.6f} {unit} (the ball rests on the floor: its radius is 0.1 m)")

fig, axes = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
axes[0].plot(result.t, y, lw=2)
axes[0].set_ylabel(f"ball.y [{unit}]")
lam, unit_lam = result.series("floor.lambda_N")
axes[1].plot(result.t, lam, lw=1.5, color="C3")
axes[1].set_ylabel(f"floor.lambda_N [{unit_lam}]")
axes[1].set_xlabel("t [s]")
fig.suptitle("Bouncing ball: impacts accumulate, then the ball rests")
plt.show()
