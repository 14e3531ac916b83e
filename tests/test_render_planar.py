"""Pictures of planar mechanisms as readable as the spatial ones: each body in its colour with its
name in the legend, the ground, joint and spring glyphs, drives marked, seen straight onto the plane
with gravity pointing down; in PNG, strips and GIF.

The content is checked from the scene description (:func:`femb.io.render.picture_scene`), the
pixels once per format. Drawing tests skip only when no off-screen OpenGL context can be made here.
"""
import numpy as np
import pytest

import femb
from femb import Mechanism
from femb.study.registry import load
from femb.elements import (DrivenAngle, Force, Gravity, Hinge, PointMass, RigidBody, RotationalSpringDamper, Slider,
                           SpringDamper)
from femb.base.functions import Linear
from femb.io import read_frame
from femb.io.render import _legend_labels, picture_scene, render_animation, render_png, render_strip

pytest.importorskip("pyvista")
SIZE = (480, 360)


def _series(model, tmp, t_end, h, frames=6):
    res = femb.simulate(model, t_end, h)
    return res.write_vtk(tmp, every=max(1, int(round(t_end / h / frames))))


@pytest.fixture(scope="module")
def andrews(tmp_path_factory):
    return _series(load("andrews").model(), tmp_path_factory.mktemp("andrews"), 0.003, 1e-5)


@pytest.fixture(scope="module")
def slider_crank(tmp_path_factory):
    """A driven crank (DrivenAngle), a slider on a ground rail, a torsion spring, a point mass on a spring."""
    m = Mechanism("driven")
    crank = m.add(RigidBody("crank", 1.0, 0.01, position=(0.1, 0.0), points={"O": (-0.1, 0.0), "A": (0.1, 0.0)}))
    rod = m.add(RigidBody("rod", 1.0, 0.05, position=(0.4, 0.0), points={"A": (-0.2, 0.0), "B": (0.2, 0.0)}))
    block = m.add(RigidBody("block", 0.5, 0.01, position=(0.6, 0.0)))
    bob = m.add(PointMass("bob", 0.2, position=(0.6, -0.3)))
    m.add(Hinge("O", "ground", crank, point_b="O"), Hinge("A", crank, rod, point_a="A", point_b="A"),
          Hinge("B", rod, block, point_a="B"), Slider("rail", "ground", block, axis=(1.0, 0.0), at=(0.6, 0.0)),
          DrivenAngle("motor", "ground", crank, Linear(2.0)),
          RotationalSpringDamper("twist", crank, rod, 0.5),
          SpringDamper("hang", block, bob, 50.0, damping=0.1), Force("push", rod, (0.0, -1.0)),
          Gravity((0.0, -9.81)))
    return _series(m.compile(), tmp_path_factory.mktemp("driven"), 0.2, 1e-3)


def test_planar_frames_describe_the_mechanism(slider_crank):
    mesh = read_frame(sorted(slider_crank.parent.glob("*.vtu"))[-1])
    fd = mesh.field_data
    assert {k[len("body."):] for k in fd if k.startswith("body.")} == {"crank", "rod", "block", "bob"}
    glyph = {k[len("glyph."):]: int(v[0]) for k, v in fd.items() if k.startswith("glyph.")}
    assert glyph["RigidBody"] == 1 and glyph["PointMass"] == 3 and glyph["Hinge"] == 10
    assert glyph["Slider"] == 12 and glyph["DrivenAngle"] == 17 and glyph["SpringDamper"] == 20
    assert glyph["RotationalSpringDamper"] == 22 and glyph["Force"] == 30
    assert "reaction" in mesh.point_data and "joint_axis" in mesh.point_data      # the old fields stay


def test_planar_picture_has_bodies_legend_ground_joints_and_drives(slider_crank):
    pic = picture_scene(slider_crank, window_size=SIZE)
    kinds = pic.kinds()
    assert {"body", "ground", "joint:revolute", "joint:prismatic", "joint:motor", "spring", "load"} <= set(kinds)
    assert "floor" not in kinds                                  # a plane is seen straight on: no floor
    bodies = {it.label: it.colour for it in pic.items if it.kind == "body"}
    assert set(bodies) == {"crank", "rod", "block", "bob"}
    assert len(set(bodies.values())) == 4                        # one colour per body
    labels = [lb for lb, _ in _legend_labels(pic.items)]
    assert labels[:4] == ["crank", "rod", "block", "bob"]
    assert "ground" in labels and "motor (driven)" in labels and "revolute joint" in labels
    assert {it.label for it in pic.items if it.kind == "spring"} == {"spring", "torsion"}
    motor = next(it for it in pic.items if it.kind == "joint:motor")
    assert motor.colour[0] > 150 and motor.colour[1] < 80       # drives in red
    # the motor sits on the hinge that joins the same bodies (ground and crank): at the origin
    np.testing.assert_allclose(motor.points.mean(axis=0)[:2], 0.0, atol=1e-9)
    # straight onto the plane, gravity pointing down the picture, everything inside
    cam = pic.camera
    d = cam.position - cam.focal
    assert abs(d[2]) / np.linalg.norm(d) == pytest.approx(1.0)
    assert cam.up[1] == pytest.approx(1.0)
    px, depth = cam.project(np.vstack([it.points for it in pic.items]))
    assert np.all(depth > 0) and px[:, 0].min() >= 0 and px[:, 0].max() <= SIZE[0]
    assert px[:, 1].min() >= 0 and px[:, 1].max() <= SIZE[1]


def test_andrews_picture_names_its_seven_bodies(andrews):
    pic = picture_scene(andrews, window_size=SIZE)
    assert [lb for lb, _ in _legend_labels(pic.items)][:7] == [f"b{k}" for k in range(1, 8)]
    assert {"ground", "joint:revolute", "spring", "load"} <= set(pic.kinds())


def test_planar_png_strip_and_gif(slider_crank, renderer, tmp_path):
    from PIL import Image, ImageSequence

    pic = picture_scene(slider_crank, window_size=SIZE)
    img = np.asarray(Image.open(render_png(slider_crank, tmp_path / "p.png", window_size=SIZE)).convert("RGB"))
    img = img.astype(int)
    assert img.shape == (SIZE[1], SIZE[0], 3)
    for name, colour in {it.label: it.colour for it in pic.items if it.kind == "body"}.items():
        near = np.abs(img - np.array(colour[:3])).max(axis=2) < 40
        assert near.sum() > 20, name                              # every body shows in its colour
    strip = np.asarray(Image.open(render_strip(slider_crank, tmp_path / "s.png", n=3,
                                               window_size=(3 * 200 + 150, 200))).convert("RGB")).astype(int)
    for j in range(3):
        panel = strip[30:, j * 200 + 5:(j + 1) * 200 - 5]
        assert np.count_nonzero(panel.max(axis=2) - panel.min(axis=2) > 60) > 50
    gif = render_animation(slider_crank, tmp_path / "m.gif", max_frames=3, window_size=(200, 150))
    with Image.open(gif) as im:
        frames = [np.asarray(f.convert("RGB")).astype(int) for f in ImageSequence.Iterator(im)]
    assert len(frames) == 3 and all(f.var() > 100 for f in frames)


def test_result_animates_inline(renderer):
    import base64
    import io

    from PIL import Image

    from femb.errors import OutputError

    res = femb.simulate(load("pendulum").model(), 0.5, 1e-3)
    anim = res.animate(frames=4, size=(160, 120))
    html = anim._repr_html_()
    assert html.startswith('<img src="data:image/gif;base64,')
    data = base64.b64decode(html.split(",", 1)[1].rstrip('"/>'))
    assert data == anim.data and anim.frames == 4 and "4 frames" in repr(anim)
    with Image.open(io.BytesIO(data)) as im:
        assert im.size == (160, 120) and im.n_frames == 4
    with pytest.raises(OutputError, match="frames must be a positive integer"):
        res.animate(frames=0)
