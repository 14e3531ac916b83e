"""Andrews' squeezing mechanism
============================

The seed paper's benchmark (Arnold & Brüls 2007; Hairer & Wanner, *Solving
Ordinary Differential Equations II*): seven rigid bodies, one degree of
freedom, a motor torque and a stiff spring, loaded from the scene registry
(``femb run andrews``). The seven angles are compared with the scene's
independent reference (minimal coordinates, integrated by scipy), and the
mechanism is pictured at four instants.
"""
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import femb
from femb.io.render import render_strip
from femb.study import registry

scene = registry.load("andrews")
model = scene.model()
result = femb.simulate(model, t_end=0.03, h=1e-4, rho_inf=0.7)
out = scene.outputs(result)
ref = scene.reference(result.t)
print(f"{result.steps} steps, {int(result.newton_iterations.sum())} Newton iterations")
for name in sorted(out):
    if name in ref:
        print(f"max |{name} - reference| = {np.max(np.abs(out[name] - ref[name])):.2e}")

# %%
# Four instants of the motion, each body in its colour
tmp = Path(tempfile.mkdtemp())
pvd = result.write_vtk(tmp / "vtk", every=10)
render_strip(pvd, tmp / "andrews.png", n=4, window_size=(1000, 330))
fig, ax = plt.subplots(figsize=(10, 3.3))
ax.imshow(plt.imread(tmp / "andrews.png"))
ax.set_axis_off()
plt.show()
