"""NUMBA_DISABLE_JIT=1 (kernels, engine and contact loop as plain Python, for debugging a kernel):
femb imports and simulates, and gives the compiled code's trajectories.

The engine's stage declarations read ``disp.py_func``, which a plain function does not have:
``import femb.engine`` (and with it ``femb.contact``) stopped with an AttributeError under
NUMBA_DISABLE_JIT=1 until femb.engine.link read the function itself there (this test failed then).
"""
import json
import os
import subprocess
import sys

import numpy as np

SCRIPT = """
import json
import femb
from femb.benchmarks.scenes.contact import contact_ball, contact_slider_crank
from femb.benchmarks.scenes.planar import andrews
from femb.contact import simulate

out = {}
out["andrews"] = femb.simulate(andrews.build().compile(), 1e-3, 1e-4).q[-1].tolist()
out["ball"] = simulate(contact_ball.build().compile(), 0.5, 1e-2).q[-1].tolist()
out["slider_crank"] = simulate(contact_slider_crank.build().compile(), 0.002, 1e-4).q[-1].tolist()
print(json.dumps(out))
"""


def _run(plain):
    env = dict(os.environ)
    env.pop("NUMBA_DISABLE_JIT", None)
    if plain:
        env["NUMBA_DISABLE_JIT"] = "1"
    out = subprocess.run([sys.executable, "-c", SCRIPT], env=env, capture_output=True, text=True, timeout=900)
    assert out.returncode == 0, out.stderr[-3000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_plain_python_runs_the_engine_and_the_contact_loop_as_compiled():
    plain, compiled = _run(True), _run(False)
    assert set(plain) == {"andrews", "ball", "slider_crank"}
    for name in plain:
        np.testing.assert_allclose(plain[name], compiled[name], rtol=0, atol=1e-10, err_msg=name)
