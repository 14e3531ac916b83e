"""Figures of the start of flexible models (femb/system/initial.py, docs/engine.md "Consistent initial values").

The four-bar with a beam coupler (:mod:`femb.benchmarks.scenes.beams.flexible_fourbar_3d`,
8 elements, driver at full speed from t = 0, ρ∞ = 0.8), against the same mechanism with a
rigid coupler run with the same h:

* ``t0``: |T_drive(0) − rigid| / |rigid| with E × 10⁴ at h = 1, 0.5, 0.25 ms;
* ``ringing``: the largest |T_drive − rigid| over the first 100 steps with E × 10⁶ at h = 1 ms (N m);
* ``aluminium``: the largest |T_drive| over 0.1 s of the aluminium coupler (E × 1) at h = 1 ms,
  and the rigid coupler's (N m).

    python -m femb.benchmarks.accuracy.flexible_start

About 15 s on a 2-core machine.
"""
from __future__ import annotations

import numpy as np


def _drive(h, t_end, **params):
    import femb
    from femb.study import registry

    scene = registry.load("flexible_fourbar_3d").module
    model = scene.build(8, ramp="constant", **params).compile()
    return scene.outputs(femb.simulate(model, t_end, h, rho_inf=0.8))["T_drive"]


def figures():
    """The figures of the module docstring (dict)."""
    out = {"t0": []}
    for h in (1e-3, 5e-4, 2.5e-4):
        rigid, flex = _drive(h, 2 * h, rigid=True)[0], _drive(h, 2 * h, stiffness=1e4)[0]
        out["t0"].append((h, rigid, flex, abs(flex - rigid) / abs(rigid)))
    rigid = _drive(1e-3, 0.1, rigid=True)
    out["ringing"] = float(np.abs(_drive(1e-3, 0.1, stiffness=1e6) - rigid).max())
    out["aluminium"] = (float(np.abs(_drive(1e-3, 0.1)).max()), float(np.abs(rigid).max()))
    return out


def main():
    f = figures()
    for h, rigid, flex, rel in f["t0"]:
        print(f"t0 reaction, E x 1e4, h = {h:g} s: rigid {rigid:.6g} N m, beam {flex:.6g} N m, relative {rel:.3g}")
    print(f"ringing, E x 1e6, h = 1 ms, first 100 steps: {f['ringing']:.3g} N m")
    print(f"aluminium at full speed, h = 1 ms: max |T_drive| {f['aluminium'][0]:.3g} N m (rigid {f['aluminium'][1]:.3g})")


if __name__ == "__main__":
    main()
