"""Linearizing the Whipple bicycle
===============================

The benchmark bicycle of Meijaard, Papadopoulos, Ruina & Schwab (2007),
built as a 3-D multibody model (four bodies, two rolling wheels: non-holonomic
constraints) and linearized by :func:`femb.analysis.linearize.linearize` about its
steady straight-ahead motion at each forward speed. The eigenvalues of the
lateral dynamics against speed show the weave and capsize modes; between the
two critical speeds the uncontrolled bicycle is stable. The published
values: weave speed 4.292 m/s, capsize speed 6.024 m/s.
"""
import matplotlib.pyplot as plt
import numpy as np

from femb.benchmarks.scenes.spatial import whipple_bicycle as wb

lin = wb.linearized(5.0)
print(lin)
print(f"weave speed   {wb.weave_speed():.4f} m/s")
print(f"capsize speed {wb.capsize_speed():.4f} m/s")

speeds = np.linspace(0.0, 10.0, 41)
ev = np.array([wb.eigenvalues(v) for v in speeds])

fig, ax = plt.subplots(figsize=(7, 4.5))
ax.plot(speeds, ev.real, "k.", ms=5)
ax.plot(speeds, np.abs(ev.imag), ".", color="C0", ms=4)
ax.axhline(0.0, color="grey", lw=0.8)
ax.set_ylim(-10, 10)
ax.set_xlabel("forward speed v [m/s]")
ax.set_ylabel("eigenvalues: real (black), |imaginary| (blue) [1/s]")
ax.set_title("Whipple bicycle from femb's 3-D model")
plt.show()
