"""Write spatial_engine_reference.json: the heavy top (index 3 and index 2) after 300 steps with the per-kind
generated engine (femb before the one compiled engine, commit 1e00ae6), for
tests/test_compiled_loop.py. Run from a checkout of that commit:

    PYTHONPATH=<that checkout> python tests/data/make_spatial_engine_reference.py OUT.json
"""
import importlib.util
import json
import sys
from pathlib import Path

import numpy as np

import femb

root = Path(femb.__file__).resolve().parent.parent
for name, folder in (("femb.elements", "elements"), ("femb.benchmarks", "benchmarks")):
    spec = importlib.util.spec_from_file_location(name, root / folder / "__init__.py",
                                                  submodule_search_locations=[str(root / folder)])
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)

from femb.benchmarks import registry  # noqa: E402

out = {"commit": "1e00ae6"}
for scene, h, n, form in (("heavy_top", 2e-3, 300, "index3"), ("heavy_top", 2e-3, 300, "index2")):
    mech = registry.load(scene).module.build()
    model = mech.compile() if hasattr(mech, "compile") else mech
    r = femb.simulate(model, t_end=n * h, h=h, rho_inf=0.7, formulation=form)
    out[f"{scene}_{form}"] = {"h": h, "n": n, "q": r.q[-1].tolist(), "qd": r.qd[-1].tolist(),
                              "lam": r.lam[-1].tolist(),
                              "newton": np.asarray(r.newton_iterations).tolist()}
Path(sys.argv[1]).write_text(json.dumps(out))
