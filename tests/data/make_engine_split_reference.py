"""Write engine_split_reference.npz: trajectories of the engine before its split into femb/engine/
(commit 3a193aa, one file femb/step.py), for tests/test_engine_reference.py: Andrews (1000 fixed
steps of 3e-5 s with the defaults and with the seed's settings; its Newton iterations), the heavy
top at h = 1e-3 s with index 3 and index 2, and the spin-up beam (8 spatial beam elements).
Run with that commit's femb installed:

    python tests/data/make_engine_split_reference.py tests/data/engine_split_reference.npz
"""
import sys

import numpy as np

import femb
from femb.benchmarks import andrews, heavy_top, spin_up_3d

out = {}
m = andrews.build().compile()
r = femb.simulate(m, 1000 * 3e-5, 3e-5)
out.update(andrews_q=r.q[::100], andrews_lam=r.lam[-1], andrews_it=r.newton_iterations.astype(np.int8))
r = femb.simulate(m, 1000 * 3e-5, 3e-5, newton_test="residual", start="seed", check_every=0)
out.update(andrews_seed_q=r.q[-1], andrews_seed_it=r.newton_iterations.astype(np.int8))
top = heavy_top.build().compile()
for form in ("index3", "index2"):
    r = femb.simulate(top, 0.2, 1e-3, formulation=form)
    out.update({f"top_{form}_q": r.q[::20], f"top_{form}_lam": r.lam[-1],
                f"top_{form}_it": r.newton_iterations.astype(np.int8)})
beam = spin_up_3d.build(8).compile()
r = femb.simulate(beam, 0.1, 1e-3)
out.update(beam_q=r.q[-1], beam_lam=r.lam[-1], beam_it=r.newton_iterations.astype(np.int8))
np.savez_compressed(sys.argv[1], **out)
