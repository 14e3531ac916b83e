"""The seed paper's slider–crank, from the scene registry
======================================================

Loads the seed paper's slider–crank from the scene registry (the same scene
``femb run slider_crank`` runs), integrates it, and compares its named outputs
with the scene's independent reference (minimal coordinates, Lagrange's
equations, integrated by scipy).
"""
import matplotlib.pyplot as plt
import numpy as np

import femb
from femb.study import registry

scene = registry.load("slider_crank")
print(scene.description)
for name, (default, meaning, unit) in scene.parameter_info().items():
    print(f"  {name:7s} = {default!r:<20} [{unit}] {meaning}")

model = scene.model()                                   # build() and compile()
d = scene.defaults
result = femb.simulate(model, t_end=d["t_end"], h=1e-3, rho_inf=d["rho_inf"])
out = scene.outputs(result)
ref = scene.reference(result.t)

print(f"\n{result.steps} steps of h = 1e-3 s, {int(result.newton_iterations.sum())} Newton iterations")
print(f"{'t [s]':>6} {'theta [rad]':>12} {'x4 [m]':>10} {'R_pivot_y [N]':>14}")
for i in np.linspace(0, result.t.size - 1, 5).astype(int):
    print(f"{result.t[i]:6.2f} {out['theta'][i]:12.6f} {out['x4'][i]:10.6f} {out['R_pivot_y'][i]:14.6f}")
for name in ("theta", "x4", "R_pivot_y"):
    err = np.max(np.abs(out[name] - ref[name]))
    print(f"max |{name} - reference| = {err:.2e}")

fig, axes = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
for ax, name, unit in zip(axes, ("theta", "R_pivot_y"), ("rad", "N")):
    ax.plot(result.t, out[name], lw=2, label="femb")
    ax.plot(result.t, ref[name], "k--", lw=1, label="reference")
    ax.set_ylabel(f"{name} [{unit}]")
axes[0].legend()
axes[-1].set_xlabel("t [s]")
fig.suptitle("Slider–crank of Arnold & Brüls (2007): femb against the minimal-coordinate reference")
plt.show()
