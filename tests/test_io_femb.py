"""VTK output of real femb runs: read back, compare with the result, survive failures."""
import numpy as np
import pytest

import femb
import femb.io
from femb.benchmarks.scenes.planar import andrews
from femb.io.vtk import pvd_time


def _cells_of(mesh, type_name):
    """Point indices of all cells of one element type (by the element_type cell data)."""
    tid = int(mesh.field_data[f"element_type.{type_name}"][0])
    idx = []
    for block, et in zip(mesh.cells, mesh.cell_data["element_type"]):
        sel = np.asarray(et) == tid
        if sel.any():
            idx.append((block.type, block.data[sel]))
    return idx


@pytest.fixture(scope="module")
def andrews_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("andrews")
    model = andrews.build().compile()
    with femb.io.VTKStream(model, out, every=5) as vtk:
        res = femb.simulate(model, 0.006, 1e-4, observer=vtk)
    return model, res, vtk.path


def test_every_frame_listed_with_exact_times(andrews_run):
    model, res, pvd = andrews_run
    frames = femb.io.read_pvd(pvd)
    assert [t for t, _ in frames] == [float(pvd_time(t)) for t in res.t[::5]]   # 15 digits
    for (_, f), t in zip(frames, res.t[::5]):
        mesh = femb.io.read_frame(f)
        assert mesh.field_data["TimeValue"][0] == t                             # exact


def test_points_and_reactions_match_result(andrews_run):
    model, res, pvd = andrews_run
    hinges = ["O", "P", "E23", "E24", "E26", "B", "A5", "F", "A7", "G"]   # build order
    frames = femb.io.read_pvd(pvd)
    for k, (t, f) in enumerate(frames):
        i = 5 * k
        mesh = femb.io.read_frame(f)
        ((ctype, conn),) = _cells_of(mesh, "Hinge")
        assert ctype == "vertex"
        pts = mesh.points[conn[:, 0]]
        reac = mesh.point_data["reaction"][conn[:, 0]]
        for j, name in enumerate(hinges):
            el = next(g for g in model.groups if g.name == "Hinge").elements[j]
            assert el.name == name
            expect = res.position(el.a.name, el.sa)[i]
            np.testing.assert_allclose(pts[j, :2], expect, atol=1e-12)
            np.testing.assert_allclose(reac[j, :2], res.reaction(name)[i], rtol=1e-12, atol=1e-9)
        # the bodies' outline polygons carry the rigid-body velocity field v + ω × d
        ((_, poly4), (_, poly3)) = _cells_of(mesh, "RigidBody")
        vel = mesh.point_data["velocity"]
        for poly in (poly4, poly3):
            v = vel[poly.ravel(), :2]
            assert np.all(np.isfinite(v)) and np.abs(v).max() > 0 or i == 0


def test_failed_run_leaves_valid_pvd(tmp_path):
    model = andrews.build().compile()
    with pytest.raises(femb.ConvergenceError) as err:
        with femb.io.VTKStream(model, tmp_path, every=1) as vtk:
            femb.simulate(model, 0.03, 2e-3, observer=vtk)
    frames = femb.io.read_pvd(vtk.path)
    accepted = err.value.result
    assert len(frames) == accepted.t.size            # every accepted step, nothing more
    np.testing.assert_array_equal([t for t, _ in frames], [float(pvd_time(t)) for t in accepted.t])
    for _, f in frames:
        femb.io.read_frame(f)                         # each one readable


def test_result_write_vtk_round_trip(tmp_path):
    model = andrews.build().compile()
    res = femb.simulate(model, 0.002, 1e-4, stride=4)
    pvd = res.write_vtk(tmp_path / "post")
    frames = femb.io.read_pvd(pvd)
    np.testing.assert_array_equal([t for t, _ in frames], [float(pvd_time(t)) for t in res.t])
    mesh = femb.io.read_frame(frames[-1][1])
    ((_, conn),) = _cells_of(mesh, "SpringDamper")
    f = mesh.cell_data["force"]
    assert any(np.asarray(a).size for a in f)


def test_render_andrews_png_and_gif(andrews_run, tmp_path, renderer):
    from PIL import Image
    model, res, pvd = andrews_run
    png = tmp_path / "a.png"
    femb.io.render_png(pvd, png, time=0.003)
    img = np.asarray(Image.open(png).convert("L"), dtype=float)
    assert img.var() > 50.0
    gif = tmp_path / "a.gif"
    femb.io.render_animation(pvd, gif, fps=10, window_size=(320, 240))
    with Image.open(gif) as im:
        assert im.n_frames == len(femb.io.read_pvd(pvd))


def test_cli_run_vtk_then_render(tmp_path, capsys):
    from femb.console.cli import main

    out = tmp_path / "andrews"
    assert main(["run", "andrews", "--t-end", "0.003", "--h", "1e-4", "--vtk", str(out), "--every", "5",
                 "--progress", "off"]) == 0
    frames = femb.io.read_pvd(out / "frame.pvd")
    assert len(frames) == 7 and frames[-1][0] == pytest.approx(0.003)
    assert main(["render", str(out / "missing")]) == 2
    assert main(["render", str(out)]) == 2                       # no output asked for
    assert "give at least one of" in capsys.readouterr().err
    ok, reason = femb.io.can_render()
    if not ok:
        pytest.skip(f"no off-screen OpenGL context: {reason}")
    from PIL import Image
    gif = tmp_path / "a.gif"
    assert main(["render", str(out), "--gif", str(gif), "--size", "200", "160"]) == 0
    with Image.open(gif) as im:
        assert im.n_frames == 7
