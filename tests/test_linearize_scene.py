"""The Whipple bicycle as a registered scene: femb list, femb run, its protocol tables."""
import importlib
import json

import pytest

from femb.console import cli
from femb.study import registry


def test_bicycle_is_registered_and_described(capsys):
    assert "whipple_bicycle" in registry.names()
    mod = importlib.import_module(registry.scene_module("whipple_bicycle"))
    scene = registry.load("whipple_bicycle")
    assert scene.undocumented() == ([], [])
    for table in (mod.PARAMETERS, mod.OUTPUTS):
        for key, (meaning, unit) in table.items():
            assert meaning.strip() and unit.strip(), key
    assert cli.main(["list", "whipple_bicycle"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("whipple_bicycle: The Whipple bicycle")
    assert "v=4.6" in out and "roll_rate=0.5" in out and "[m/s]" in out and "t_end=5.0" in out
    assert "N_front" in out
    assert cli.main(["list"]) == 0
    assert "whipple_bicycle:" in capsys.readouterr().out


def test_bicycle_runs_from_the_command_line(capsys):
    """A short run at 3 m/s: every output at t_end; upright start, so the lean is the lean rate × t to
    first order, and the normal forces carry the weight (m_T g = 921.24 N)."""
    assert cli.main(["run", "whipple_bicycle", "--t-end", "0.02", "--h", "5e-3", "--set", "v=3",
                     "--set", "roll_rate=0.1", "--json", "-"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["steps"] == 4 and data["params"]["v"]["value"] == 3
    out = data["outputs"]
    assert set(out) == {"lean", "steer", "speed", "N_rear", "N_front"}
    assert out["lean"] == pytest.approx(0.1 * 0.02, rel=0.05)
    assert out["speed"] == pytest.approx(3.0, rel=1e-3)
    assert out["N_rear"] + out["N_front"] == pytest.approx(94.0 * 9.81, rel=0.02)
