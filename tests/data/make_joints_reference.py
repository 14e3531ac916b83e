"""Record reference values of the joint and body kernels from the numpy implementation.

The numpy kernels (classmethods ``constraint_all``, ``constraint_rates``, ``mass``) were
replaced by compiled kernels; ``tests/test_kernels_joints.py`` checks that the compiled
kernels reproduce the values recorded here. The numpy code is taken from git commit
d1a00cd (the last commit before the compiled kernels), so this script needs a git
checkout of femb:

    python tests/data/make_joints_reference.py      # writes tests/data/joints_reference.json
"""
from __future__ import annotations

import json
import subprocess
import sys
import types
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
COMMIT = "d1a00cd"
SEEDS = (11, 12)

sys.path.insert(0, str(HERE.parent))
from joints_scenario import BODY_TYPES, JOINT_TYPES, build, states  # noqa: E402


def old_module(path, name):
    """The module ``path`` as of COMMIT, loaded as femb.elements.<name>."""
    src = subprocess.run(["git", "show", f"{COMMIT}:{path}"], cwd=ROOT, check=True,
                         capture_output=True, text=True).stdout
    mod = types.ModuleType(f"femb.elements.{name}")
    mod.__package__ = "femb.elements"
    exec(compile(src, f"{COMMIT}:{path}", "exec"), mod.__dict__)
    return mod


def main():
    joints = old_module("elements/joints.py", "_old_joints")
    bodies = old_module("elements/bodies.py", "_old_bodies")
    els = build(joints, bodies)
    out = {"commit": COMMIT, "cases": []}
    for name in JOINT_TYPES:
        cls = getattr(joints, name)
        p = cls.pack(els[name])
        for seed in SEEDS:
            t, xe, ve, le = states(len(els[name]), seed)
            le = le[:, :cls.n_constraints]
            Phi, B, H = cls.constraint_all(p, t, xe, le, True)
            if H is None:
                H = np.zeros((xe.shape[0], 6, 6))
            Phi_t, gam = cls.constraint_rates(p, t, xe, ve)
            out["cases"].append({"type": name, "seed": seed, "Phi": Phi.tolist(), "B": B.tolist(),
                                 "H": H.tolist(), "Phi_t": Phi_t.tolist(), "gam": gam.tolist()})
    for name in BODY_TYPES:
        cls = getattr(bodies, name)
        p = cls.pack(els[name])
        t, xe, ve, le = states(len(els[name]), SEEDS[0], ndx=3)
        out["cases"].append({"type": name, "seed": SEEDS[0], "M": cls.mass(p, xe).tolist()})
    (HERE / "joints_reference.json").write_text(json.dumps(out, indent=None) + "\n")


if __name__ == "__main__":
    main()
