"""A step without a solution is taken as two halves (docs/contact.md §1.1, item 9).

The clearance slider–crank at its default step h = 1e-4 s: at t = 0.0397 s both upper corners of the
slider reach the guide within 2e-10 m of each other, with equal friction rows. The whole step found no
solution (Newton, the prox fixed point, Newton again, the same with the slip law on P) and the run
stopped with a ContactError there (`femb run contact_slider_crank` failed). Its two halves had one, on
both time loops. Since the fixed point halves its prox parameters when it stalls (§1.1, item 12) the
cascade of micro-impacts at 0.030 s takes another branch and the upper corners meet the guide inside a
step (0.039799 s); the run is checked through that impact on both loops, and the halving itself by a
solve made to fail on that step (the Python loop: the compiled one hands such a step to it).
"""
import numpy as np
import pytest

from femb.benchmarks.scenes.contact import contact_slider_crank
from femb.contact import simulate
from femb.contact import step as contact_step


@pytest.mark.parametrize("compiled", [True, False])
def test_slider_crank_runs_through_the_upper_impact_at_0_0398(compiled):
    m = contact_slider_crank.build().compile()
    r = simulate(m, 0.0405, 1e-4, rho_inf=0.8, compiled=compiled)
    assert r.success and r.t[-1] == pytest.approx(0.0405)
    assert r.contact["gN"].min() >= -1e-10 * m.length_scale
    late = sorted(e["contact"] for e in r.events if 0.0396 < e["t"] < 0.0400)
    assert late == ["upper.0", "upper.1"]                 # both upper corners hit the guide


def test_a_step_whose_solve_fails_is_taken_as_two_halves(monkeypatch):
    m = contact_slider_crank.build().compile()
    ref = simulate(m, 0.0405, 1e-4, rho_inf=0.8, compiled=False)
    solve = contact_step.NonsmoothStep.solve
    failed, after = [], []

    def failing_once(self, s):
        if failed and len(after) < 2:
            after.append((s.t, self.h))
        if not failed and abs(s.t - 0.0397) < 1e-9 and abs(self.h - 1e-4) < 1e-12:
            failed.append(s.t)
            raise contact_step.StepFailure("made to fail (test)")
        return solve(self, s)

    monkeypatch.setattr(contact_step.NonsmoothStep, "solve", failing_once)
    r = simulate(m, 0.0405, 1e-4, rho_inf=0.8, compiled=False)
    assert failed and r.success and r.t[-1] == pytest.approx(0.0405)
    (t1, h1), (t2, h2) = after                            # the next solves: the two halves
    assert (t1, h1) == (pytest.approx(0.0397), pytest.approx(5e-5))
    assert (t2, h2) == (pytest.approx(0.03975), pytest.approx(5e-5))
    assert r.t.size == ref.t.size                         # stored per step as before
    assert r.contact["gN"].min() >= -1e-10 * m.length_scale
    np.testing.assert_allclose(r.q[-1], ref.q[-1], rtol=0, atol=1e-3)
