"""Output channels: named outputs written to CSV or Parquet during a run (femb.io.OutputChannels)."""
import json

import numpy as np
import pytest

import femb
from femb.elements import Gravity, Hinge, RigidBody
from femb.errors import OutputError
from femb.io import OutputChannels

NAMES = ["bar.theta", "bar.theta_d", "pivot.Fy", "pivot.lambda_1"]


@pytest.fixture(scope="module")
def model():
    m = femb.Mechanism("pendulum")
    bar = m.add(RigidBody("bar", 2.0, 2.0 / 12, position=(0.5, 0.0), points={"O": (-0.5, 0.0)}))
    m.add(Hinge("pivot", "ground", bar, point_b="O"), Gravity((0.0, -9.81)))
    return m.compile()


def _names(model):
    r = femb.simulate(model, 0.01, 1e-3)
    return [n for n in NAMES if n in r.outputs()]


def test_csv_every_step_equals_the_stored_series(model, tmp_path):
    names = _names(model)
    ref = femb.simulate(model, 0.5, 1e-3)
    path = tmp_path / "ch.csv"
    with OutputChannels(model, path, names, every=10, flush_rows=7) as ch:
        res = femb.simulate(model, 0.5, 1e-3, store=False, observer=ch)
    assert res.t.size == 2                                   # nothing kept in memory
    header = path.read_text().splitlines()[0].split(",")
    assert header[0] == "t [s]" and header[1] == "bar.theta [rad]" and "pivot.Fy [N]" in header
    data = np.loadtxt(path, delimiter=",", skiprows=1)
    assert data.shape == (51, 1 + len(names)) and ch.n_rows == 51
    np.testing.assert_array_equal(data[:, 0], ref.t[::10])
    for k, n in enumerate(names):
        np.testing.assert_array_equal(data[:, 1 + k], ref.series(n)[0][::10])   # exact: repr round-trips


def test_parquet_at_a_rate_interpolates(model, tmp_path):
    pq = pytest.importorskip("pyarrow.parquet")
    path = tmp_path / "ch.parquet"
    with OutputChannels(model, path, ["bar.theta", "pivot.Fy"], dt=0.025, flush_rows=5) as ch:
        femb.simulate(model, 0.5, rtol=1e-6, store=False, observer=ch)
    table = pq.read_table(path)
    assert table.column_names == ["t", "bar.theta", "pivot.Fy"]
    assert json.loads(table.schema.metadata[b"units"]) == {"t": "s", "bar.theta": "rad", "pivot.Fy": "N"}
    t = table.column("t").to_numpy()
    np.testing.assert_allclose(t, 0.025 * np.arange(21), rtol=0, atol=1e-12)
    ref = femb.simulate(model, 0.5, rtol=1e-6, t_eval=t)           # the same interpolation, stored
    np.testing.assert_allclose(table.column("bar.theta").to_numpy(), ref.series("bar.theta")[0], atol=1e-12)


def test_bad_channels_say_what_is_wrong(model, tmp_path):
    with pytest.raises(OutputError, match="unknown output"):
        OutputChannels(model, tmp_path / "a.csv", ["bar.nothing"])
    with pytest.raises(OutputError, match="energies"):
        OutputChannels(model, tmp_path / "a.csv", ["energy.total"])
    with pytest.raises(OutputError, match=".csv or .parquet"):
        OutputChannels(model, tmp_path / "a.txt", ["bar.theta"])
    with pytest.raises(OutputError, match="does not exist"):
        OutputChannels(model, tmp_path / "no" / "a.csv", ["bar.theta"])
    with pytest.raises(OutputError, match="every must be"):
        OutputChannels(model, tmp_path / "a.csv", ["bar.theta"], every=0)
    with pytest.raises(OutputError, match="dt must be"):
        OutputChannels(model, tmp_path / "a.csv", ["bar.theta"], dt=-1.0)
