"""Pictures of the spatial scenes: bodies, joints and ground drawn, everything in the frame.

Each scene is simulated briefly and written as a VTK series; the content of
its pictures is checked from the scene data (:func:`femb.io.render.picture_scene`:
what is drawn and where the camera puts it), and the rendered PNGs, strips and
GIFs are checked for ink where the joints are. Drawing tests are skipped only
when no off-screen OpenGL context can be made here.
"""
import numpy as np
import pytest

import femb
from femb.io import OutputError, read_frame
from femb.io.mechanism import JOINT_KINDS, parse_view, view_direction
from femb.io.render import picture_scene, render_animation, render_png, render_strip
from femb.study.registry import load

pytest.importorskip("pyvista")
pytestmark = pytest.mark.filterwarnings("ignore:mechanism 'bricard'.*dependent constraint")

#: scene -> (t_end, h, number of joints, body names)
SCENES = {
    "spatial_slider_crank": (0.5, 1e-3, 4, {"crank", "rod", "slider"}),
    "spatial_double_pendulum": (0.5, 1e-3, 2, {"link1", "link2"}),
    "bricard": (0.5, 1e-3, 6, {f"rod{k}" for k in range(1, 6)}),
    "heavy_top": (0.5, 2.0 ** -9, 1, {"top"}),
}
SIZE = (480, 360)


@pytest.fixture(scope="module", params=sorted(SCENES))
def scene(request, tmp_path_factory):
    name = request.param
    t_end, h, _, _ = SCENES[name]
    sc = load(name)
    model = sc.model()
    res = femb.simulate(model, t_end=t_end, h=h, rho_inf=0.9)
    every = max(1, int(round(t_end / h / 10)))
    pvd = res.write_vtk(tmp_path_factory.mktemp(name), every=every)
    return name, pvd


def read_png(path):
    from PIL import Image

    with Image.open(path) as im:
        return np.asarray(im.convert("RGB")).astype(int)


def inside(cam, points, margin=0):
    px, depth = cam.project(points)
    w, h = cam.window_size
    return (np.all(depth > 0) and px[:, 0].min() >= margin and px[:, 0].max() <= w - margin
            and px[:, 1].min() >= margin and px[:, 1].max() <= h - margin)


# ---------------------------------------------------------------------------
# the VTK frames carry what the renderer needs (and keep their fields)
# ---------------------------------------------------------------------------
def test_frames_describe_the_mechanism(scene):
    name, pvd = scene
    _, njoints, bodies = SCENES[name][1:]
    mesh = read_frame(sorted(pvd.parent.glob("*.vtu"))[-1])
    fd = mesh.field_data
    assert {k[len("body."):] for k in fd if k.startswith("body.")} == bodies
    assert np.linalg.norm(fd["gravity"]) == pytest.approx(9.81)
    kinds = {int(v[0]) for k, v in fd.items() if k.startswith("glyph.")}
    assert 1 in kinds and 2 in kinds                         # bodies and their frames
    # joints: a unit axis per joint vertex, the linked bodies, and the old fields
    assert "joint_axis" in mesh.point_data and "reaction_force" in mesh.point_data
    et = np.concatenate(mesh.cell_data["element_type"])
    ba = np.concatenate(mesh.cell_data["body_a"])
    joint_ids = {int(v[0]) for k, v in fd.items() if k.startswith("element_type.") and k.endswith("Joint")}
    vertex = np.concatenate([np.full(len(c.data), c.type == "vertex") for c in mesh.cells])
    sel = vertex & np.isin(et, list(joint_ids))
    assert sel.sum() == njoints
    conn = np.concatenate([c.data[:, 0] if c.type == "vertex" else np.full(len(c.data), -1) for c in mesh.cells])
    axes = mesh.point_data["joint_axis"][conn[sel]]
    np.testing.assert_allclose(np.linalg.norm(axes, axis=1), 1.0, atol=1e-9)
    assert np.all(ba[sel] >= 0)
    assert "velocity" in mesh.point_data and "body_id" in mesh.cell_data


# ---------------------------------------------------------------------------
# what a picture shows, from the scene data
# ---------------------------------------------------------------------------
def test_every_body_and_joint_is_drawn_inside_the_frame(scene):
    name, pvd = scene
    _, _, njoints, bodies = SCENES[name]
    times = [t for t, _ in femb.io.read_pvd(pvd)]
    for t in (times[0], times[len(times) // 2], times[-1]):
        pic = picture_scene(pvd, time=t, window_size=SIZE)
        drawn = {it.label for it in pic.items if it.kind == "body"}
        assert drawn == bodies
        joints = [it for it in pic.items if it.kind.startswith("joint:")]
        assert len(joints) == njoints
        assert {it.kind.split(":")[1] for it in joints} <= set(JOINT_KINDS)
        assert any(it.kind == "ground" for it in pic.items)          # the ground is drawn
        assert any(it.kind == "floor" for it in pic.items)           # gravity acts: a floor
        for it in pic.items:
            if it.kind != "floor":
                assert inside(pic.camera, it.points), (name, t, it.kind, it.label)
        # nothing under the legend (right) or the time label (top): the camera keeps them free
        right, top = pic.camera.window_center
        assert 0.0 < right < 0.5 and 0.0 < top < 0.2
        for it in pic.items:
            if it.kind != "floor":
                px, _ = pic.camera.project(it.points)
                assert px[:, 0].max() <= SIZE[0] * (1.0 - right) + 1.0 and px[:, 1].min() >= SIZE[1] * top - 1.0
        from femb.io.render import _legend_labels

        named = {label for label, _ in _legend_labels(pic.items)}
        assert bodies | {"ground"} <= named and any(n.endswith(" joint") for n in named)
        # the mechanism fills a good part of the picture (not a speck in a corner)
        px, _ = pic.camera.project(np.vstack([it.points for it in pic.items if it.kind != "floor"]))
        assert np.ptp(px[:, 0]) > 0.2 * SIZE[0] or np.ptp(px[:, 1]) > 0.2 * SIZE[1]


def test_gravity_points_down_the_picture(scene):
    name, pvd = scene
    pic = picture_scene(pvd, window_size=SIZE)
    g = pic.motion.gravity
    c = pic.camera.focal
    px, _ = pic.camera.project(np.array([c, c + 0.1 * pic.motion.size * g / np.linalg.norm(g)]))
    down = px[1] - px[0]
    assert down[1] > 0 and abs(down[1]) > 3 * abs(down[0])      # image rows grow downwards


def test_views_and_traces(scene):
    name, pvd = scene
    body = sorted(SCENES[name][3])[0]
    for view in ("iso", "front", "side", "top", "30,20"):
        pic = picture_scene(pvd, view=view, window_size=SIZE, trace=[body])
        (trace,) = [it for it in pic.items if it.kind == "trace"]
        assert trace.label == body and len(trace.points) >= 5
        for it in pic.items:
            if it.kind != "floor":
                assert inside(pic.camera, it.points), (view, it.kind)
    with pytest.raises(OutputError, match="no body 'nope'.*bodies:"):
        picture_scene(pvd, trace=["nope"])
    with pytest.raises(OutputError, match="has no point 'nowhere'"):
        picture_scene(pvd, trace=[f"{body}:nowhere"])
    with pytest.raises(OutputError, match="azimuth,elevation"):
        picture_scene(pvd, view="sideways")


def test_view_directions():
    up = np.array([0.0, 0.0, 1.0])
    d, pic_up = view_direction(parse_view("3d")[1], up)
    np.testing.assert_allclose(d, np.array([1.0, -1.0, 0.7]) / np.linalg.norm([1.0, -1.0, 0.7]), atol=2e-3)
    d, pic_up = view_direction(parse_view("front")[1], up)
    np.testing.assert_allclose(d, [0.0, -1.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(pic_up, up, atol=1e-12)
    d, pic_up = view_direction(parse_view("top")[1], np.array([0.0, 1.0, 0.0]))   # gravity along −y
    np.testing.assert_allclose(d, [0.0, 1.0, 0.0], atol=1e-12)
    assert abs(pic_up @ d) < 1e-12
    with pytest.raises(OutputError, match="elevation"):
        parse_view("10,95")


# ---------------------------------------------------------------------------
# rendered pictures
# ---------------------------------------------------------------------------
def test_projection_matches_the_renderer(scene, renderer):
    """Camera.project gives the pixels VTK draws at (checked with VTK's own transform)."""
    import pyvista as pv
    from vtkmodules.vtkRenderingCore import vtkCoordinate

    from femb.io.render import _apply_camera

    name, pvd = scene
    pic = picture_scene(pvd, window_size=SIZE)
    pl = pv.Plotter(off_screen=True, window_size=SIZE)
    try:
        _apply_camera(pl, pic.camera)
        pl.add_mesh(pv.Sphere(radius=1e-3, center=pic.camera.focal))
        pl.render()
        pts = np.vstack([it.points[:3] for it in pic.items])
        px, _ = pic.camera.project(pts)
        co = vtkCoordinate()
        co.SetCoordinateSystemToWorld()
        for p, q in zip(pts, px):
            co.SetValue(*p)
            x, y = co.GetComputedDoubleDisplayValue(pl.renderer)
            assert x == pytest.approx(q[0], abs=1.0) and SIZE[1] - y == pytest.approx(q[1], abs=1.0)
    finally:
        pl.close()


def test_render_png_shows_the_joints(scene, renderer, tmp_path):
    name, pvd = scene
    out = render_png(pvd, tmp_path / f"{name}.png", window_size=SIZE)
    img = read_png(out)
    assert img.shape == (SIZE[1], SIZE[0], 3) and img.var() > 100.0
    colourful = np.count_nonzero(img.max(axis=2) - img.min(axis=2) > 60)
    assert colourful > 400                                  # the bodies, in colour
    pic = picture_scene(pvd, window_size=SIZE)
    dark = 0
    joints = [it for it in pic.items if it.kind.startswith("joint:")]
    for it in joints:
        c, _ = pic.camera.project(it.points.mean(axis=0))
        x, y = np.clip(c[0].round().astype(int), 2, [SIZE[0] - 3, SIZE[1] - 3])
        patch = img[y - 2:y + 3, x - 2:x + 3]
        dark += patch.max(axis=2).min() < 120                # a dark glyph at the joint (unless hidden)
    assert dark >= max(1, len(joints) // 2)


def test_strips_and_animation(scene, renderer, tmp_path):
    name, pvd = scene
    body = sorted(SCENES[name][3])[-1]
    out = render_strip(pvd, tmp_path / "row.png", n=4, window_size=(4 * 200 + 150, 200), trace=[body])
    img = read_png(out)
    assert img.shape == (200, 950, 3)
    for j in range(4):                                      # every panel has a drawing
        panel = img[30:, j * 200 + 5:(j + 1) * 200 - 5]
        assert np.count_nonzero(panel.max(axis=2) - panel.min(axis=2) > 60) > 50
    out = render_strip(pvd, tmp_path / "overlay.png", n=3, layout="overlay", window_size=SIZE)
    assert read_png(out).var() > 100.0
    gif = render_animation(pvd, tmp_path / "m.gif", max_frames=4, window_size=(200, 150))
    from PIL import Image, ImageSequence

    with Image.open(gif) as im:
        frames = [np.asarray(f.convert("RGB")).astype(int) for f in ImageSequence.Iterator(im)]
    assert len(frames) == 4 and all(f.var() > 100 for f in frames)


def test_cli_render_options(scene, renderer, tmp_path, capsys):
    from femb.console.cli import main

    name, pvd = scene
    body = sorted(SCENES[name][3])[0]
    d = str(pvd.parent)
    assert main(["render", d, "--png", str(tmp_path / "a.png"), "--view", "front", "--trace", body,
                 "--size", "240", "180"]) == 0
    assert main(["render", d, "--strip", str(tmp_path / "s.png"), "--overlay", "--n", "3",
                 "--size", "240", "180"]) == 0
    assert main(["render", d, "--png", str(tmp_path / "b.png"), "--trace", "nobody"]) == 2
    assert "no body 'nobody'" in capsys.readouterr().err
    assert main(["render", d, "--png", str(tmp_path / "b.png"), "--view", "sideways"]) == 2
    assert main(["render", d, "--png", str(tmp_path / "b.png"), "--overlay"]) == 2
    assert not (tmp_path / "b.png").exists()


# ---------------------------------------------------------------------------
# element types of other kinds: a beam's centre line drawn as a tube
# ---------------------------------------------------------------------------
def test_a_beam_kind_is_drawn_as_a_tube(tmp_path):
    """Frames with a body and a beam (field data only, as an element with ``glyph = "beam"`` writes)."""
    from femb.base.geometry import GeometryBlock
    from femb.io import TimeSeriesWriter
    from femb.io.frames import GLYPHS, glyphs

    assert glyphs(type("Rope", (), {"glyph": "beam"})) == {"Rope": "beam"}
    assert glyphs(type("Crane", (), {"glyph": {"": "body", "Frame": "body_frame"}})) == {
        "Crane": "body", "CraneFrame": "body_frame"}
    cube = np.array([[x, y, z] for x in (-0.1, 0.1) for y in (-0.1, 0.1) for z in (-0.1, 0.1)])
    tris = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                     [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    fd = {"glyph.Box": np.array([GLYPHS["body"]]), "glyph.Rope": np.array([GLYPHS["beam"]]),
          "body.box": np.array([1]), "gravity": np.array([0.0, 0.0, -9.81])}
    with TimeSeriesWriter(tmp_path, "rope") as w:
        for k in range(4):
            tip = np.array([1.0, 0.0, -0.2 * k])
            s = np.linspace(0.0, 1.0, 9)[:, None]
            line = s * tip + np.column_stack((0 * s[:, 0], 0.1 * np.sin(np.pi * s[:, 0]), 0 * s[:, 0]))
            w.write(0.1 * k, [
                GeometryBlock("Box", cube + tip, [("triangle", tris)],
                              cell_data={"body": [np.ones(12, np.int32)], "body_look": [np.zeros(12, np.int32)]}),
                GeometryBlock("Rope", line, [("line", np.column_stack((np.arange(8), np.arange(1, 9))))],
                              point_data={"radius": np.full(9, 0.02)}),
            ], field_data=fd)
    pic = picture_scene(w.path, window_size=SIZE)
    (beam,) = [it for it in pic.items if it.kind == "beam"]
    assert beam.label == "Rope" and beam.mesh.n_cells > 8
    centre = np.vstack([a + f * (b - a) for a, b in zip(line[:-1], line[1:]) for f in np.linspace(0, 1, 50)])
    gap = np.min(np.linalg.norm(beam.points[:, None, :] - centre[None], axis=2), axis=1)
    assert gap.max() == pytest.approx(0.02, rel=0.05)                # the tube has the beam's radius
    assert {it.label for it in pic.items if it.kind == "body"} == {"box"}
    for it in pic.items:
        if it.kind != "floor":
            assert inside(pic.camera, it.points)


def test_the_spatial_beam_scene_is_drawn_as_tubes(tmp_path):
    """femb's own SpatialBeam: the right-angle cantilever's elements are drawn as a tube (its
    element type's kind is 'beam'), inside the picture, with the welded root's ground."""
    import femb
    from femb.benchmarks.scenes.beams import right_angle_cantilever as rac
    from femb.io.frames import VTKStream

    mech = rac.build()
    model = mech.compile() if hasattr(mech, "compile") else mech
    with VTKStream(model, tmp_path / "vtk", dt=0.5) as vtk:
        femb.simulate(model, 2.0, 0.05, observer=vtk)
    pic = picture_scene(vtk.path, window_size=SIZE)
    beams = [it for it in pic.items if it.kind == "beam"]
    assert beams and beams[0].label == "SpatialBeam" and beams[0].mesh.n_cells > 20
    assert any(it.kind == "ground" for it in pic.items)
    for it in pic.items:
        if it.kind != "floor":
            assert inside(pic.camera, it.points)
