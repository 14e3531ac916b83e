"""Regenerate tests/data/kernels_forces_reference.json from the numpy kernels of commit 97c7148.

Before the element kernels of elements/forces.py and elements/beam.py became compiled
functions, they were numpy classmethods (``force``, ``mass``, ``constraint_all``,
``constraint_rates``). This script loads those two files as they were at commit 97c7148
(``git show 97c7148:elements/forces.py``), evaluates the old kernels on the batches of
tests/kernel_scene.py at random states, and stores inputs and outputs, so that
tests/test_kernels_forces.py can check that the compiled kernels give the same numbers.

Run from the repository root (needs the git history): python tests/data/make_kernels_forces_reference.py
"""
import importlib.util
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests"))
import kernel_scene  # noqa: E402

COMMIT = "97c7148"


def old_module(path, name):
    src = subprocess.run(["git", "show", f"{COMMIT}:{path}"], cwd=ROOT, check=True, capture_output=True,
                         text=True).stdout
    tmp = Path(tempfile.mkdtemp()) / f"{name}.py"
    tmp.write_text(src)
    spec = importlib.util.spec_from_file_location(f"femb.elements.{name}", tmp)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


def main():
    old = {"forces": old_module("elements/forces.py", "_old_forces"),
           "beam": old_module("elements/beam.py", "_old_beam")}
    _, elements = kernel_scene.build()
    out = {"commit": COMMIT, "batches": {}}
    rng = np.random.default_rng(20261123)
    for label, g in kernel_scene.batches(elements).items():
        cls = getattr(old[g.cls.__module__.rsplit(".", 1)[-1]], g.cls.__name__)
        p = cls.pack(g.els)
        cases = []
        for _ in range(2):
            t, xe, ve, le = kernel_scene.random_state(g, rng)
            case = {"t": t, "xe": xe.tolist(), "ve": ve.tolist(), "le": le.tolist()}
            if g.traits["has_mass"]:
                case["Me"] = cls.mass(p, xe).tolist()
            if g.traits["has_force"]:
                f, fq, fv = cls.force(p, t, xe, ve, True)
                case["fe"], case["fq"] = f.tolist(), fq.tolist()
                case["fv"] = (np.zeros_like(fq) if fv is None else fv).tolist()
            if g.nc:
                Phi, B, H = cls.constraint_all(p, t, xe, le, True)
                Phi_t, gam = cls.constraint_rates(p, t, xe, ve)
                case.update(Phi=Phi.tolist(), B=B.tolist(), H=H.tolist(), Phi_t=Phi_t.tolist(),
                            gam=gam.tolist())
            cases.append(case)
        out["batches"][label] = cases
    dest = Path(__file__).with_name("kernels_forces_reference.json")
    dest.write_text(json.dumps(out, separators=(",", ":")))
    print(f"wrote {dest} ({dest.stat().st_size} bytes): {', '.join(out['batches'])}")


if __name__ == "__main__":
    main()
