"""Pictures and animations of a written time series, and progress reports.

Tests that draw are skipped only when :func:`femb.io.can_render` says that no
off-screen OpenGL context can be made here; the skip message gives its reason.
"""
import importlib.util
import io

import numpy as np
import pytest

from femb.base.geometry import GeometryBlock
from femb.io import OutputError, TimeSeriesWriter, can_render, progress
from femb.io.progress import PlainProgress
from femb.io.render import render_animation, render_png, render_strip

NFRAMES = 12


def planar_scene(t):
    """A crank (polygon), a flexible rod (lines) and two joints (vertices), in z = 0."""
    c, s = np.cos(t), np.sin(t)
    crank = np.array([[0, -0.05, 0], [1, -0.05, 0], [1, 0.05, 0], [0, 0.05, 0]]) @ np.array(
        [[c, s, 0], [-s, c, 0], [0, 0, 1]]
    )
    tip = np.array([c, s, 0.0])
    rod = np.linspace(tip, [2.5, 0.0, 0.0], 6)
    rod[:, 1] += 0.1 * np.sin(np.linspace(0, np.pi, 6)) * np.cos(3 * t)
    return [
        GeometryBlock("RigidBody", crank, [("polygon", np.array([[0, 1, 2, 3]]))],
                      point_data={"speed": np.full(4, t)}),
        GeometryBlock("Beam", rod, [("line", np.column_stack([np.arange(5), np.arange(1, 6)]))],
                      point_data={"strain": np.sin(3 * t) * np.linspace(0, 1, 6)}),
        GeometryBlock("Joint", np.array([[0, 0, 0], tip]), [("vertex", np.array([[0], [1]]))]),
    ]


@pytest.fixture(scope="module")
def series(tmp_path_factory):
    d = tmp_path_factory.mktemp("series")
    with TimeSeriesWriter(d, "crank") as w:
        for i in range(NFRAMES):
            t = 0.5 * i
            w.write(t, planar_scene(t))
    return w.path


def read_png(path):
    from PIL import Image

    with Image.open(path) as im:
        return np.asarray(im.convert("RGB"))


# ---------------------------------------------------------------------------
# errors (no rendering needed)
# ---------------------------------------------------------------------------


def test_can_render_answers_and_caches():
    ok, reason = can_render()
    assert isinstance(ok, bool) and isinstance(reason, str) and reason
    assert can_render() == (ok, reason)


def test_missing_and_empty_collections(tmp_path):
    with pytest.raises(OutputError, match="nothere.pvd"):
        render_png(tmp_path / "nothere.pvd", tmp_path / "a.png")
    with TimeSeriesWriter(tmp_path, "empty"):
        pass
    with pytest.raises(OutputError, match="empty.pvd.*no frames"):
        render_animation(tmp_path / "empty.pvd", tmp_path / "a.gif")
    with pytest.raises(OutputError, match="no frames"):
        render_strip(tmp_path / "empty.pvd", tmp_path / "a.png")


def test_unknown_suffixes(series, tmp_path):
    with pytest.raises(OutputError, match=r"out_png=.*'\.jpg'"):
        render_png(series, tmp_path / "a.jpg")
    with pytest.raises(OutputError, match=r"out=.*'\.avi'.*\.gif or \.mp4"):
        render_animation(series, tmp_path / "a.avi")
    with pytest.raises(OutputError, match=r"out_png=.*'\.gif'"):
        render_strip(series, tmp_path / "a.gif")


def test_bad_parameters(series, tmp_path):
    with pytest.raises(OutputError, match="layout"):
        render_strip(series, tmp_path / "a.png", layout="grid")
    with pytest.raises(OutputError, match="fps"):
        render_animation(series, tmp_path / "a.gif", fps=0)
    with pytest.raises(OutputError, match="every"):
        render_animation(series, tmp_path / "a.gif", every=0)


def test_mp4_without_ffmpeg_says_how_to_enable(series, tmp_path, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)   # import now fails as if absent
    with pytest.raises(OutputError, match="pip install imageio-ffmpeg"):
        render_animation(series, tmp_path / "a.mp4")
    assert not (tmp_path / "a.mp4").exists()


def test_motion_bounds_are_the_union_of_all_frames(series):
    pv = pytest.importorskip("pyvista")
    from femb.io.render import _Scan, _entries

    scan = _Scan(pv, _entries(series), "strain")
    pts = np.vstack([np.vstack([b.points for b in planar_scene(0.5 * i)])
                     for i in range(NFRAMES)])
    np.testing.assert_allclose(scan.lo, pts.min(axis=0))
    np.testing.assert_allclose(scan.hi, pts.max(axis=0))
    assert scan.planar
    strain = np.concatenate([planar_scene(0.5 * i)[1].point_data["strain"]
                             for i in range(NFRAMES)])
    # other blocks carry zeros for "strain", so 0 is inside the range too
    assert scan.clim == pytest.approx((min(strain.min(), 0.0), max(strain.max(), 0.0)))
    with pytest.raises(OutputError, match="scalars='nope'.*available.*strain"):
        _Scan(pv, _entries(series), "nope")


# ---------------------------------------------------------------------------
# pictures
# ---------------------------------------------------------------------------


def test_render_png_is_not_blank(series, tmp_path, renderer):
    out = render_png(series, tmp_path / "snap.png", time=1.4, window_size=(320, 240))
    img = read_png(out)
    assert img.shape == (240, 320, 3)
    assert img.astype(float).var() > 100.0
    # mostly white background, but with coloured (non-grey) pixels of the bodies
    rgb = img.astype(int)
    assert np.mean(rgb.min(axis=2) > 240) > 0.5
    assert np.count_nonzero(rgb.max(axis=2) - rgb.min(axis=2) > 60) > 50


def test_render_png_by_scalars(series, tmp_path, renderer):
    out = render_png(series, tmp_path / "strain.png", scalars="strain", window_size=(320, 240))
    assert read_png(out).astype(float).var() > 100.0


@pytest.mark.parametrize("layout", ["overlay", "row"])
def test_render_strip(series, tmp_path, renderer, layout):
    out = render_strip(series, tmp_path / f"{layout}.png", n=4, layout=layout,
                       window_size=(480, 200))
    img = read_png(out)
    assert img.shape == (200, 480, 3)
    assert img.astype(float).var() > 100.0


def read_gif(path):
    from PIL import Image, ImageSequence

    with Image.open(path) as im:
        frames = [np.asarray(f.convert("RGB")) for f in ImageSequence.Iterator(im)]
        durations = im.info.get("duration")
    return np.array(frames), durations


def test_render_animation_gif_frame_count(series, tmp_path, renderer):
    out = render_animation(series, tmp_path / "motion.gif", fps=10, every=2,
                           window_size=(160, 120))
    frames, duration = read_gif(out)
    assert frames.shape == (NFRAMES // 2, 120, 160, 3)
    assert duration == 100
    assert all(f.astype(float).var() > 100.0 for f in frames)
    # the mechanism moves: successive frames differ
    assert all(np.any(frames[i] != frames[i + 1]) for i in range(len(frames) - 1))

    out = render_animation(series, tmp_path / "short.gif", max_frames=5, window_size=(160, 120))
    assert read_gif(out)[0].shape[0] == 5


def test_render_animation_mp4(series, tmp_path, renderer):
    # imageio-ffmpeg ships its own ffmpeg binary; it is part of femb's test and mp4 extras
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg", reason="install femb[mp4] for MP4 output")

    out = render_animation(series, tmp_path / "motion.mp4", window_size=(161, 121))
    reader = imageio_ffmpeg.read_frames(str(out))
    meta = next(reader)
    assert tuple(meta["size"]) == (162, 122)  # rounded up to even sizes for H.264
    assert sum(1 for _ in reader) == NFRAMES


# ---------------------------------------------------------------------------
# progress
# ---------------------------------------------------------------------------


def test_plain_progress_prints_sparse_lines():
    buf = io.StringIO()
    with PlainProgress(total=1000, desc="solve", stream=buf) as bar:
        for _ in range(1000):
            bar.update(1)
    lines = buf.getvalue().splitlines()
    assert 9 <= len(lines) <= 11
    assert all(line.startswith("solve: ") for line in lines)
    assert "10%" in lines[0] and lines[-1].startswith("solve: done 1000/1000")
    assert all("left" in line for line in lines[:-1])        # each line with the estimated time remaining


def test_plain_progress_over_an_iterable_and_disabled():
    buf = io.StringIO()
    assert list(PlainProgress(range(5), desc="x", stream=buf)) == [0, 1, 2, 3, 4]
    assert buf.getvalue().splitlines()[-1].startswith("x: done 5/5")
    quiet = io.StringIO()
    with PlainProgress(total=10, stream=quiet, enabled=False) as bar:
        bar.update(10)
    assert bar.n == 10 and quiet.getvalue() == ""


def test_progress_without_terminal_is_plain(capsys):
    # under pytest stderr is not a terminal
    with progress(4, "render") as bar:
        for _ in range(4):
            bar.update()
    assert isinstance(bar, PlainProgress)
    assert "render: done 4/4" in capsys.readouterr().err
    assert list(progress(iter("ab"), "it", enabled=False)) == ["a", "b"]


def test_progress_on_a_terminal_is_a_rich_bar_with_eta(monkeypatch):
    import importlib

    P = importlib.import_module("femb.io.progress")      # femb.io.progress is also the function's name
    monkeypatch.setattr(P, "_is_terminal", lambda stream: True)
    bar = P.progress(3, "render")
    assert isinstance(bar, P.RichProgress)
    cols = [type(c).__name__ for c in bar._bar.columns]
    assert "TimeRemainingColumn" in cols and "BarColumn" in cols
    bar.close()
    buf = io.StringIO()
    with P.RichProgress(range(4), desc="sweep", stream=buf) as it:
        assert list(it) == [0, 1, 2, 3]
    assert it.n == 4 and "sweep: done 4/4" in buf.getvalue()
    assert P._eta(10.0, 1, 5) == 40.0 and P._eta(1.0, 0, 5) is None and P._clock(3725) == "1:02:05"


def test_progress_with_unknown_total():
    import io as _io

    from femb.io.progress import PlainProgress, progress

    bar = progress(None, "open-ended")
    bar.update(3)
    bar.close()
    assert bar.n == 3
