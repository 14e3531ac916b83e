# Run with femb installed from commit d1a00cd (the numpy engine); writes andrews_numpy_d1a00cd.json.
"""Reference: Andrews' mechanism, 1000 steps of h = 3e-5 s, rho_inf = 0.7, with femb's
numpy engine of commit d1a00cd (the last before the compiled loop)."""
import json, femb, numpy as np
from femb.benchmarks import andrews
model = andrews.build().compile()
r = femb.simulate(model, 0.03, 3e-5, rho_inf=0.7)
out = {"source": "femb commit d1a00cd (numpy engine), femb.simulate(andrews.build().compile(), 0.03, 3e-5, rho_inf=0.7)",
       "q_1000": r.q[-1].tolist(), "qd_1000": r.qd[-1].tolist(), "lam_1000": r.lam[-1].tolist(),
       "newton_iterations": r.newton_iterations.tolist(), "q_500": r.q[500].tolist()}
json.dump(out, open(__import__("os").path.join(__import__("os").path.dirname(__file__), "andrews_numpy_d1a00cd.json"), "w"), indent=0)
print(r.stats, r.newton_iterations.sum())
