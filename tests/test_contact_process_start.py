"""A new process runs a contact scene from the disk cache without compiling anything.

The contact step's code is compiled once per installation; a later process only loads it. It used to
compile numba's typed-list methods for the batch records in every process (forming the list and
indexing it from Python: 1.5 s and 2.6 s before the first step; this test failed then). The check
counts numba's compiler passes (event ``numba:run_pass``, broadcast only when a function is
compiled, not when it is loaded from the cache) in a second process.
"""
import subprocess
import sys

SCRIPT = """
import sys
from numba.core import event
import femb
from femb.benchmarks.scenes.contact import contact_ball
from femb.contact import simulate

model = contact_ball.build().compile()
with event.install_recorder("numba:run_pass") as rec:
    res = simulate(model, 0.5, 2e-3)
passes = sum(1 for _, ev in rec.buffer if ev.is_start)
print(passes, len(res.t))
"""


def _run():
    out = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, timeout=900)
    assert out.returncode == 0, out.stderr[-3000:]
    passes, steps = (int(v) for v in out.stdout.split())
    return passes, steps


def test_a_second_process_runs_the_ball_without_compiling():
    _, steps = _run()                # fills the cache where it is empty (the contact step: about a minute)
    assert steps == 251
    passes, steps = _run()
    assert steps == 251
    assert passes == 0
