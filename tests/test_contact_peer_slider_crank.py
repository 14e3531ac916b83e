"""The clearance slider–crank against Exudyn (benchmarks/cost/contact_peer_slider_crank.py) at tiny size:
Exudyn's model is the same mechanism (without contacts it gives femb's crank angle), its contacts act."""
import importlib.util

import pytest

from femb.benchmarks.cost import contact_peer_slider_crank as pc
from femb.benchmarks.scenes.contact import contact_slider_crank as scene
from femb.contact import simulate

HAVE_EXUDYN = importlib.util.find_spec("exudyn") is not None


def test_report_tables():
    rows = [("femb nonsmooth", 1e-4, 1.0, 1.6136), ("Exudyn", 1e-4, 0.5, 1.6134), ("Exudyn", 5e-5, 0.4, 1.6131)]
    lines = pc.report(rows, [1.61335, 1.61333], tolerances=(1e-3, 1e-4))
    text = "\n".join(lines)
    assert "| femb nonsmooth | 0.0001 | 1.000 | 1.613600 | 2.7e-04 | 2.7e-04 |" in text
    assert "| 0.001 rad | 1.000 | 0.400 | 2.500 |" in text
    assert "| 0.0001 rad | not reached | 0.500 | - |" in text           # 7e-5 from the reference


@pytest.mark.skipif(not HAVE_EXUDYN, reason="Exudyn not installed")
def test_exudyn_model_is_the_same_mechanism():
    """Contacts far away (femb: clearance 0.5 m; Exudyn: no contact objects): the same crank angle."""
    h = 1e-4
    res = simulate(scene.build(c=0.5).compile(), pc.T_END, h)
    free_femb = float(res.series("crank.theta")[0][-1])
    _, free_exu = pc.exudyn_runner(h, contacts=False)()
    assert free_exu == pytest.approx(free_femb, abs=5e-4)
    _, with_contacts = pc.exudyn_runner(h)()
    assert abs(with_contacts - free_exu) > 0.03                      # the guides slow the crank (impacts)
    assert with_contacts == pytest.approx(1.61334, abs=1e-3)         # the rigid model's angle, §10
