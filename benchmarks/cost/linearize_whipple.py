"""Whipple bicycle eigenvalues at 101 speeds as a whole process: imports, model, 101 linearizations.

Builds and compiles the 3-D bicycle of :mod:`femb.benchmarks.scenes.spatial.whipple_bicycle`
once and linearizes it at 101 speeds in [0, 10] m/s (each a steady motion, drift eliminated by
symmetry, four named states), then prints: the time of the study alone (wall, ``perf_counter``),
the CPU time of the whole process from its start (user + sys, ``resource.getrusage``: the
interpreter, the imports, the compile-cache loads and the study), its peak memory
(``ru_maxrss``) and the largest distance of the eigenvalues at 0, 5 and 10 m/s from Table 2 of
Meijaard et al. (2007). The wall time of the whole process is what ``/usr/bin/time -v`` reports
around it:

``/usr/bin/time -v python -m femb.benchmarks.cost.linearize_whipple``
"""
from __future__ import annotations

import resource
import time

import numpy as np


def main():
    t0 = time.perf_counter()
    from femb.benchmarks.scenes.spatial import whipple_bicycle as wb
    t1 = time.perf_counter()
    speeds, ev = wb.study()
    t2 = time.perf_counter()
    ru = resource.getrusage(resource.RUSAGE_SELF)
    worst = 0.0
    for v in (0.0, 5.0, 10.0):
        want = np.array(wb.TABLE2[v])
        want = want[np.lexsort((want.imag, want.real))]
        worst = max(worst, float(np.max(np.abs(ev[int(round(v * 10))] - want))))
    print(f"Whipple bicycle eigenvalues at {speeds.size} speeds (0-10 m/s)")
    print(f"imports: {t1 - t0:.2f} s; compile + 101 linearizations and eigenvalues: {t2 - t1:.2f} s (wall)")
    print(f"whole process CPU (user + sys): {ru.ru_utime + ru.ru_stime:.2f} s; "
          f"peak memory (ru_maxrss): {ru.ru_maxrss / 1024:.0f} MB")
    print(f"max |Δλ| vs Table 2 at 0, 5, 10 m/s: {worst:.1e}")
    return 0 if worst < 1e-9 else 1


if __name__ == "__main__":
    raise SystemExit(main())
