"""The bouncing-ball comparison against Exudyn (benchmarks/cost/contact_peer.py) at tiny size."""
import builtins
import importlib.util

import numpy as np
import pytest

from femb.benchmarks.cost import contact_peer as cp
from femb.benchmarks.scenes.contact import contact_ball

HAVE_EXUDYN = importlib.util.find_spec("exudyn") is not None


def test_exact_height_matches_impacts():
    tk = contact_ball.impact_times(3)
    r = contact_ball.PARAMS["radius"]
    assert np.allclose(cp.exact_height(tk), r, atol=1e-12)
    assert cp.exact_height(0.0) == pytest.approx(contact_ball.PARAMS["y0"])
    apex = tk[0] + 0.5 * (tk[1] - tk[0])                  # apex of the first bounce: (e v1)^2 / 2g above R
    v1 = contact_ball.PARAMS["g"] * tk[0]
    assert cp.exact_height(apex) == pytest.approx(r + (0.5 * v1) ** 2 / (2 * contact_ball.PARAMS["g"]), rel=1e-12)


def test_closing_times_interpolates():
    t = np.linspace(0.0, 1.0, 11)
    gap = np.array([1, 1, -1, -1, 1, 1, 1, -3, 1, 1, 1], dtype=float)
    assert np.allclose(cp.closing_times(t, gap), [0.15, 0.625])


def test_femb_rows_tiny():
    rows = cp.measure(repeats=1, steps={"femb nonsmooth": (1e-2,), "femb penalty": (2e-4,)})
    (c1, h1, w1, et1, ey1), (c2, h2, w2, et2, ey2) = rows
    assert w1 > 0 and w2 > 0
    assert et1 < 1e-5 and ey1 < 1e-5                       # rigid contact, impacts located
    assert 1e-3 < et2 < 0.2                                 # compliant model: a finite model error
    lines = cp.report(rows)
    assert any("femb nonsmooth" in ln for ln in lines)


def test_missing_exudyn_is_reported(monkeypatch):
    real_import = builtins.__import__

    def no_exudyn(name, *args, **kwargs):
        if name == "exudyn" or name.startswith("exudyn."):
            raise ImportError("No module named 'exudyn'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_exudyn)
    assert cp.exudyn_version() is None
    rows = cp.measure(repeats=1, steps={"Exudyn": (1e-4,)})
    assert rows == [("Exudyn", 1e-4, None, None, None)]
    text = "\n".join(cp.report(rows))
    assert "not installed" in text


@pytest.mark.skipif(not HAVE_EXUDYN, reason="Exudyn not installed")
def test_exudyn_row_tiny():
    (code, h, wall, e_t, e_y), = cp.measure(repeats=1, steps={"Exudyn": (4e-4,)})
    assert code == "Exudyn" and wall > 0
    assert e_t < 0.01 and e_y < 0.005   # same ball, same Hertz law and restitution; measured 5.7e-3 s, 2.6e-3 m
