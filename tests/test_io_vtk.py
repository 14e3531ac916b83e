"""Output round trip: write VTK frames, read them back with meshio, compare."""
import os
import subprocess
import sys
import xml.etree.ElementTree as ET

import meshio
import numpy as np
import pytest

from femb.base.geometry import GeometryBlock
from femb.io import vtk as fvtk
from femb.io.vtk import (
    OutputError,
    TimeSeriesWriter,
    merge_blocks,
    pvd_time,
    read_frame,
    read_pvd,
    write_vtu,
)

NFRAMES = 20


def scene(t):
    """A small moving mechanism: polygons of 3, 4 and 5 vertices, lines, vertices."""
    c, s = np.cos(t), np.sin(t)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    tri = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    quad = np.array([[2, 0, 0], [3, 0, 0], [3, 1, 0], [2, 1, 0]], float)
    pent = np.array([[5 + np.cos(a), np.sin(a), 0] for a in np.linspace(0, 2 * np.pi, 6)[:-1]])
    body_pts = np.vstack([tri, quad, pent]) @ rot.T + [0.1 * t, 0.0, 0.0]
    bodies = GeometryBlock(
        name="RigidBody",
        points=body_pts,
        # ragged: the quad sits between the triangle and the pentagon, and a
        # second triangle comes last, so splitting by count reorders cells
        cells=[("polygon", [[0, 1, 2], [3, 4, 5, 6], [7, 8, 9, 10, 11], [0, 2, 3]])],
        point_data={"velocity": np.tile([t, 2 * t, 0.0], (12, 1))},
        cell_data={"body_id": [np.array([10, 11, 12, 13])]},
    )
    x = np.linspace(0, 4, 6)
    beam = GeometryBlock(
        name="Beam",
        points=np.column_stack([x, 0.2 * np.sin(x + t), np.zeros(6)]),
        cells=[("line", np.column_stack([np.arange(5), np.arange(1, 6)]))],
        point_data={"strain": np.cos(x * t)},
        cell_data={"axial_force": [np.linspace(-1, 1, 5) * t]},
    )
    joints = GeometryBlock(
        name="Joint",
        points=np.array([[0.0, 0.0, 0.0], [4.0, 0.2 * np.sin(4 + t), 0.0]]),
        cells=[("vertex", np.array([[0], [1]]))],
        cell_data={"axial_force": [np.array([t, -t])]},
    )
    return [bodies, beam, joints]


def times():
    # awkward binary fractions so that repr-exactness matters
    return [i / 3.0 + 1e-13 * i for i in range(NFRAMES)]


def assert_same_mesh(got, want):
    np.testing.assert_array_equal(got.points, want.points)
    assert [c.type for c in got.cells] == [c.type for c in want.cells]
    for cg, cw in zip(got.cells, want.cells):
        np.testing.assert_array_equal(cg.data, cw.data)
    assert set(got.point_data) == set(want.point_data)
    for k, v in want.point_data.items():
        np.testing.assert_array_equal(got.point_data[k], v)
    assert set(got.cell_data) == set(want.cell_data)
    for k, blocks in want.cell_data.items():
        for bg, bw in zip(got.cell_data[k], blocks):
            np.testing.assert_array_equal(bg, bw)


# ---------------------------------------------------------------------------
# merge_blocks
# ---------------------------------------------------------------------------


def test_merge_concatenates_points_and_offsets_cells():
    bodies, beam, joints = scene(0.7)
    m = merge_blocks([bodies, beam, joints])
    np.testing.assert_array_equal(m.points, np.vstack([bodies.points, beam.points, joints.points]))
    types = [c.type for c in m.cells]
    # polygons split by vertex count (3, 4, 5 in order of first appearance)
    assert types == ["polygon", "polygon", "polygon", "line", "vertex"]
    np.testing.assert_array_equal(m.cells[0].data, [[0, 1, 2], [0, 2, 3]])
    np.testing.assert_array_equal(m.cells[1].data, [[3, 4, 5, 6]])
    np.testing.assert_array_equal(m.cells[2].data, [[7, 8, 9, 10, 11]])
    np.testing.assert_array_equal(m.cells[3].data, beam.cells[0][1] + 12)
    np.testing.assert_array_equal(m.cells[4].data, [[18], [19]])
    # per-cell data follows the split
    np.testing.assert_array_equal(m.cell_data["body_id"][0], [10, 13])
    np.testing.assert_array_equal(m.cell_data["body_id"][1], [11])
    np.testing.assert_array_equal(m.cell_data["body_id"][2], [12])


def test_merge_fills_missing_fields_with_zeros():
    bodies, beam, joints = scene(0.3)
    m = merge_blocks([bodies, beam, joints])
    # point data present only in some blocks: zeros of the right shape elsewhere
    vel = m.point_data["velocity"]
    assert vel.shape == (20, 3)
    np.testing.assert_array_equal(vel[:12], bodies.point_data["velocity"])
    np.testing.assert_array_equal(vel[12:], 0.0)
    strain = m.point_data["strain"]
    assert strain.shape == (20,)
    np.testing.assert_array_equal(strain[:12], 0.0)
    np.testing.assert_array_equal(strain[12:18], beam.point_data["strain"])
    np.testing.assert_array_equal(strain[18:], 0.0)
    # cell data present in beam and joints, missing in bodies; integers stay integers
    force = m.cell_data["axial_force"]
    assert [len(a) for a in force] == [len(c.data) for c in m.cells]
    for a in force[:3]:
        np.testing.assert_array_equal(a, 0.0)
    np.testing.assert_array_equal(force[3], beam.cell_data["axial_force"][0])
    np.testing.assert_array_equal(force[4], joints.cell_data["axial_force"][0])
    ids = m.cell_data["body_id"]
    assert all(a.dtype.kind == "i" for a in ids)
    np.testing.assert_array_equal(ids[3], 0)
    for arrays in list(m.point_data.values()) + [a for v in m.cell_data.values() for a in v]:
        assert np.all(np.isfinite(arrays))


def test_merge_element_type_ids_and_names():
    bodies, beam, joints = scene(0.0)
    m = merge_blocks([bodies, beam, joints], field_data={"TimeValue": 0.25})
    et = m.cell_data["element_type"]
    assert [int(a[0]) for a in et] == [0, 0, 0, 1, 2]
    assert all(np.all(a == a[0]) for a in et)
    assert m.field_data["element_type.RigidBody"].tolist() == [0]
    assert m.field_data["element_type.Beam"].tolist() == [1]
    assert m.field_data["element_type.Joint"].tolist() == [2]
    assert m.field_data["TimeValue"].tolist() == [0.25]


def test_merge_rejects_bad_input():
    pts = np.zeros((3, 3))
    with pytest.raises(OutputError, match="outside"):
        merge_blocks([GeometryBlock("A", pts, [("line", np.array([[0, 3]]))])])
    with pytest.raises(OutputError, match="point data 'p'"):
        merge_blocks([GeometryBlock("A", pts, [], point_data={"p": np.zeros(4)})])
    with pytest.raises(OutputError, match="varying vertex counts"):
        merge_blocks([GeometryBlock("A", pts, [("line", [[0, 1], [0, 1, 2]])])])
    with pytest.raises(OutputError, match="shape"):
        merge_blocks([GeometryBlock("A", pts, [], point_data={"p": np.zeros((3, 2))}),
                      GeometryBlock("B", pts, [], point_data={"p": np.zeros((3, 3))})])


# ---------------------------------------------------------------------------
# single files
# ---------------------------------------------------------------------------


def test_write_vtu_round_trip_with_field_data(tmp_path):
    m = merge_blocks(scene(1.1), field_data={"TimeValue": 1.0 / 3.0, "gravity": [0, -9.81, 0]})
    path = tmp_path / "one.vtu"
    write_vtu(path, m)
    got = read_frame(path)
    assert_same_mesh(got, m)
    assert got.field_data["TimeValue"][0] == 1.0 / 3.0
    np.testing.assert_array_equal(got.field_data["gravity"], [0.0, -9.81, 0.0])
    assert got.field_data["element_type.Joint"].tolist() == [2]
    assert sorted(os.listdir(tmp_path)) == ["one.vtu"]  # no temporary files left


def test_write_vtu_escapes_names(tmp_path):
    pts = np.eye(3)
    b = GeometryBlock('odd <"&"> name', pts, [("vertex", np.arange(3).reshape(3, 1))],
                      point_data={'a&b "c"': np.arange(3.0)})
    write_vtu(tmp_path / "x.vtu", merge_blocks([b]))
    got = read_frame(tmp_path / "x.vtu")
    np.testing.assert_array_equal(got.point_data['a&b "c"'], [0.0, 1.0, 2.0])
    assert 'element_type.odd <"&"> name' in got.field_data


# ---------------------------------------------------------------------------
# time series
# ---------------------------------------------------------------------------


def test_time_series_round_trip(tmp_path):
    ts = times()
    with TimeSeriesWriter(tmp_path, basename="mech") as w:
        for t in ts:
            w.write(t, scene(t))
        assert w.frames == NFRAMES
    assert w.path == tmp_path / "mech.pvd"
    entries = read_pvd(w.path)
    assert [t for t, _ in entries] == [float(f"{t:.15g}") for t in ts]  # 15 significant digits
    for i, (_, path) in enumerate(entries):
        assert path == tmp_path / f"mech_{i:06d}.vtu"
        got = meshio.read(path)
        assert_same_mesh(got, merge_blocks(scene(ts[i])))
        assert got.field_data["TimeValue"][0] == ts[i]
    files = sorted(os.listdir(tmp_path))
    assert files == sorted([f"mech_{i:06d}.vtu" for i in range(NFRAMES)] + ["mech.pvd"])


def test_pvd_is_a_vtk_collection_with_readable_times(tmp_path):
    ts = [0.1, 0.2, 0.30000000000000004, 5 * 3e-4, 1e-300, 12345.678901234567, 0.0]
    with TimeSeriesWriter(tmp_path) as w:
        for t in ts:
            w.write(t, scene(0.0))
    root = ET.parse(tmp_path / "frame.pvd").getroot()
    assert root.tag == "VTKFile" and root.get("type") == "Collection"
    sets = root.find("Collection").findall("DataSet")
    assert [d.get("timestep") for d in sets] == ["0.1", "0.2", "0.3", "0.0015", "1e-300",
                                                 "12345.6789012346", "0.0"]
    assert [d.get("file") for d in sets] == [f"frame_{i:06d}.vtu" for i in range(len(ts))]
    # the exact times stay in the frames
    for d, t in zip(sets, ts):
        assert meshio.read(tmp_path / d.get("file")).field_data["TimeValue"][0] == t


def test_pvd_time_rounds_accumulated_steps():
    assert 5 * 3e-4 == 0.0014999999999999998           # the round-off this guards against
    assert pvd_time(5 * 3e-4) == "0.0015"
    for h in (1e-5, 3e-4, 2.5e-3, 7e-6):              # the solver's times t0 + k h
        for k in range(1, 3001):
            assert pvd_time(k * h) == repr(round(k * h, 12)), (h, k)
    assert pvd_time(-2.5e-7) == "-2.5e-07"
    assert float(pvd_time(1.0 / 3.0)) == float(f"{1.0 / 3.0:.15g}")


def test_exception_inside_with_leaves_valid_pvd(tmp_path):
    class Boom(RuntimeError):
        pass

    with pytest.raises(Boom):
        with TimeSeriesWriter(tmp_path, "run") as w:
            for i, t in enumerate(times()):
                if i == 5:
                    raise Boom("solver diverged")
                w.write(t, scene(t))
    entries = read_pvd(tmp_path / "run.pvd")
    assert [t for t, _ in entries] == [float(pvd_time(t)) for t in times()[:5]]
    for t, (_, path) in zip(times(), entries):
        assert_same_mesh(read_frame(path), merge_blocks(scene(t)))
    assert sorted(os.listdir(tmp_path)) == ["run.pvd"] + [f"run_{i:06d}.vtu" for i in range(5)]


def test_pvd_written_after_first_frame_then_throttled(tmp_path, monkeypatch):
    monkeypatch.setattr(fvtk, "PVD_FLUSH_INTERVAL", 3600.0)
    w = TimeSeriesWriter(tmp_path)
    w.write(0.0, scene(0.0))
    assert len(read_pvd(w.path)) == 1  # visible at once
    w.write(0.5, scene(0.5))
    w.write(1.0, scene(1.0))
    assert len(read_pvd(w.path)) == 1  # not rewritten within the interval
    assert w.frames == 3 and len(os.listdir(tmp_path)) == 4  # frames streamed anyway
    w.close()
    assert [t for t, _ in read_pvd(w.path)] == [0.0, 0.5, 1.0]
    with pytest.raises(OutputError, match="closed"):
        w.write(2.0, scene(2.0))


def test_pvd_rewritten_every_frame_without_throttle(tmp_path, monkeypatch):
    monkeypatch.setattr(fvtk, "PVD_FLUSH_INTERVAL", 0.0)
    with TimeSeriesWriter(tmp_path) as w:
        for i in range(3):
            w.write(i, scene(i))
            assert len(read_pvd(w.path)) == i + 1


def test_every_and_mesh_input(tmp_path):
    with TimeSeriesWriter(tmp_path, every=3) as w:
        names = [w.write(t, merge_blocks(scene(t))) for t in range(10)]
    assert names == ["frame_000000.vtu", None, None, "frame_000001.vtu", None, None,
                     "frame_000002.vtu", None, None, "frame_000003.vtu"]
    assert [t for t, _ in read_pvd(w.path)] == [0.0, 3.0, 6.0, 9.0]
    assert read_frame(tmp_path / "frame_000001.vtu").field_data["TimeValue"][0] == 3.0


def test_clean_removes_stale_frames(tmp_path):
    with TimeSeriesWriter(tmp_path) as w:
        for t in range(4):
            w.write(t, scene(t))
    (tmp_path / "keep.vtu").write_text("unrelated")
    with TimeSeriesWriter(tmp_path) as w:
        w.write(0.0, scene(0.0))
    assert sorted(os.listdir(tmp_path)) == ["frame.pvd", "frame_000000.vtu", "keep.vtu"]


def test_empty_series_and_errors(tmp_path):
    with TimeSeriesWriter(tmp_path / "new" / "dir") as w:
        pass
    assert read_pvd(w.path) == []
    with pytest.raises(OutputError, match="missing.pvd"):
        read_pvd(tmp_path / "missing.pvd")
    (tmp_path / "bad.pvd").write_text("<VTKFile type='UnstructuredGrid'/>")
    with pytest.raises(OutputError, match="bad.pvd"):
        read_pvd(tmp_path / "bad.pvd")
    with pytest.raises(OutputError, match="nope.vtu"):
        read_frame(tmp_path / "nope.vtu")
    with pytest.raises(OutputError, match="every"):
        TimeSeriesWriter(tmp_path, every=0)
    with pytest.raises(OutputError, match="finite"):
        TimeSeriesWriter(tmp_path).write(float("nan"), scene(0.0))
    with pytest.raises(OutputError, match="suffix"):
        write_vtu(tmp_path / "x.vtk", merge_blocks(scene(0.0)))


def test_writing_does_not_import_pyvista(tmp_path):
    code = (
        "import sys, femb.io as io\n"
        "from femb.base.geometry import GeometryBlock as G\n"
        "import numpy as np\n"
        f"w = io.TimeSeriesWriter({str(tmp_path)!r})\n"
        "w.write(0.0, [G('A', np.zeros((1, 3)), [('vertex', np.array([[0]]))])]); w.close()\n"
        "io.render_png  # resolving the name must not import pyvista either\n"
        "bad = [m for m in ('pyvista', 'vtkmodules') if m in sys.modules]\n"
        "print(bad); sys.exit(1 if bad else 0)\n"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert res.returncode == 0, res.stdout + res.stderr


def test_bare_points_and_empty_frames(tmp_path):
    nodes = GeometryBlock("Node", np.arange(6.0).reshape(2, 3), point_data={"m": np.ones(2)})
    m = merge_blocks([nodes])
    assert [c.type for c in m.cells] == ["vertex"]
    np.testing.assert_array_equal(m.cells[0].data, [[0], [1]])
    with TimeSeriesWriter(tmp_path) as w:
        w.write(0.0, [nodes])
        w.write(1.0, [])
    first, empty = (read_frame(p) for _, p in read_pvd(w.path))
    assert_same_mesh(first, m)
    assert empty.points.shape == (0, 3) and empty.field_data["TimeValue"].tolist() == [1.0]
