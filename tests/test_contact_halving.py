"""A step without a solution is taken as two halves (docs/contact.md §1.1, item 9).

The clearance slider–crank at its default step h = 1e-4 s: at t = 0.0397 s both upper corners of the
slider reach the guide within 2e-10 m of each other, with equal friction rows. The whole step found no
solution (Newton, the prox fixed point, Newton again, the same with the slip law on P) and the run
stopped with a ContactError there (`femb run contact_slider_crank` failed); its two halves have one,
on both time loops.
"""
import numpy as np
import pytest

from femb.benchmarks.scenes.contact import contact_slider_crank
from femb.contact import simulate


@pytest.mark.parametrize("compiled", [True, False])
def test_slider_crank_passes_the_step_without_a_solution(compiled):
    m = contact_slider_crank.build().compile()
    r = simulate(m, 0.0405, 1e-4, rho_inf=0.8, compiled=compiled)
    assert r.success and r.t[-1] == pytest.approx(0.0405)
    k = int(np.argmin(np.abs(r.t - 0.0398)))
    assert r.contact["gN"].min() >= -1e-10 * m.length_scale
    st = np.array([r.contact_state(n) for n in ("upper.0", "upper.1")])
    assert (st[:, k - 1:k + 3] != "open").any()          # the corners hit the guide in that step
    assert len(r.events) > 0
