"""``femb view``: the browser player, opened in headless Chromium.

The player is started as a user starts it (``femb view DIR --port P --no-browser``) on small
series written by ``femb run --vtk`` (a spatial mechanism and a planar one), and the page is
driven through the Chrome DevTools protocol (:mod:`cdp_browser`). Checked: the 3-D canvas is
there and not blank (many colours, the bodies' colours among them), the time slider is there
with one step per frame, clicking the slider's end shows the last frame (its time, a changed
picture), play moves the time on and pause stops it, the legend names the bodies, and every
request of the page goes to the local server (nothing from the network: the player works
offline).

``python tests/test_view.py`` writes the documentation's screenshot, docs/figures/viewer.png.
"""
from __future__ import annotations

import asyncio
import io
import os
import re
import socket
import subprocess
import sys
import time
import urllib.parse
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from cdp_browser import Browser, chromium_path  # noqa: E402

from femb.io.view import viewer_available  # noqa: E402

_OK, _WHY = viewer_available()
pytestmark = pytest.mark.skipif(not _OK, reason=_WHY)
needs_chromium = pytest.mark.skipif(
    chromium_path() is None, reason="no chromium on this machine (apt-get install chromium) for the browser test")

FEMB = [sys.executable, "-c", "import sys; from femb.console.cli import main; sys.exit(main())"]


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _series(tmp, scene, *args):
    out = Path(tmp) / scene
    subprocess.run([*FEMB, "run", scene, *args, "--vtk", str(out)], check=True, capture_output=True, timeout=600)
    return out


class _Server:
    """``femb view DIR --port P --no-browser`` in a child process, until its address is printed."""

    def __init__(self, source):
        self.port = _free_port()
        self.proc = subprocess.Popen([*FEMB, "view", str(source), "--port", str(self.port), "--no-browser"],
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        lines = []
        deadline = time.monotonic() + 300.0
        while time.monotonic() < deadline:
            line = self.proc.stdout.readline()
            if not line and self.proc.poll() is not None:
                break
            lines.append(line)
            m = re.search(r"at (http://\S+) ", line)
            if m:
                self.url = m.group(1)
                return
        self.close()
        raise AssertionError("femb view did not print its address:\n" + "".join(lines))

    def close(self):
        self.proc.terminate()
        try:
            self.proc.wait(20)
        except subprocess.TimeoutExpired:
            self.proc.kill()


def _canvas_pixels(png, rect):
    from PIL import Image

    img = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))
    x, y, w, h = (int(round(v)) for v in rect)
    return img[y:y + h, x:x + w]


def _colours(px):
    """Number of distinct colours and the fraction of pixels that are not the white background."""
    flat = px.reshape(-1, 3)
    return len(np.unique(flat, axis=0)), float(np.mean(np.any(flat < 245, axis=1)))


_RECT = "(() => {const c = document.querySelector('.femb-scene canvas'); if (!c) return null;" \
        " const r = c.getBoundingClientRect(); return r.width > 100 && r.height > 100 ?" \
        " [r.x, r.y, r.width, r.height] : null})()"
_SLIDER = "(() => {const t = document.querySelector('.femb-time [role=slider]');" \
          " return t ? [+t.getAttribute('aria-valuemin'), +t.getAttribute('aria-valuemax')," \
          " +t.getAttribute('aria-valuenow')] : null})()"
_TIME = "(document.querySelector('.femb-time-text') || {}).innerText"


async def _scene(b, timeout=90.0, rect=None):
    """Wait until the canvas shows a drawn scene; returns (its rectangle, its pixels)."""
    rect = rect or await b.wait_for(_RECT, timeout)
    assert rect, "no 3-D canvas on the page"
    deadline = time.monotonic() + timeout
    while True:
        px = _canvas_pixels(await b.screenshot(), rect)
        n, ink = _colours(px)
        if n > 50 and ink > 0.02 or time.monotonic() > deadline:
            return rect, px
        await asyncio.sleep(0.5)


async def _click(b, x, y):
    for kind in ("mousePressed", "mouseReleased"):
        await b.send("Input.dispatchMouseEvent", type=kind, x=x, y=y, button="left", clickCount=1)


async def _changed(b, expr, before, timeout=30.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        now = await b.evaluate(expr)
        if now != before:
            return now
        await asyncio.sleep(0.2)
    return before


async def _settled(b, expr, quiet=1.0, timeout=30.0):
    """The value of ``expr`` once it has not changed for ``quiet`` seconds (None if it never settles)."""
    deadline = time.monotonic() + timeout
    last, since = await b.evaluate(expr), time.monotonic()
    while time.monotonic() < deadline:
        await asyncio.sleep(0.2)
        now = await b.evaluate(expr)
        if now != last:
            last, since = now, time.monotonic()
        elif time.monotonic() - since >= quiet:
            return now
    return None


async def _check_player(url, n_frames, legend, png_out=None):
    async with Browser() as b:
        await b.goto(url)
        rect, px = await _scene(b)
        n, ink = _colours(px)
        assert n > 50 and ink > 0.02, f"the 3-D canvas looks blank ({n} colours, {ink:.1%} drawn)"
        slider = await b.wait_for(_SLIDER, 30)
        assert slider == [0, n_frames - 1, 0], f"time slider {slider}, expected frames 0 to {n_frames - 1}"
        t0 = await b.evaluate(_TIME)
        assert t0.startswith("t = 0"), t0
        names = await b.evaluate("(document.querySelector('.femb-legend') || {}).innerText")
        for name in legend:
            assert name in (names or ""), f"legend {names!r} lacks {name!r}"
        if png_out is not None:
            Path(png_out).write_bytes(await b.screenshot())

        # click at the far end of the slider's track: the last frame, its time, another picture
        track = await b.evaluate("(() => {const r = document.querySelector('.femb-time .v-slider-track')"
                                 ".getBoundingClientRect(); return [r.x, r.y, r.width, r.height]})()")
        await _click(b, track[0] + track[2] - 1, track[1] + track[3] / 2)
        t1 = await _changed(b, _TIME, t0)
        assert t1 != t0, "the time label did not follow the slider"
        assert (await b.evaluate(_SLIDER))[2] == n_frames - 1
        await asyncio.sleep(1.0)
        _, px1 = await _scene(b, rect=rect)
        assert np.mean(np.any(px1 != px, axis=2)) > 0.001, "the picture did not change with the frame"

        # play: the time moves on; pause: it stops
        await b.evaluate("document.querySelector('.femb-play').click()")
        t2 = await _changed(b, _TIME, t1)
        assert t2 != t1, "play did not move the time on"
        await b.evaluate("document.querySelector('.femb-play').click()")
        # the pause reaches the server and back within a second on a quiet machine, later on a
        # loaded one: wait until the time stands still for a second, then check that it stays
        t3 = await _settled(b, _TIME)
        assert t3 is not None, "pause did not stop the player (the time still moves after 30 s)"
        await asyncio.sleep(1.5)
        assert await b.evaluate(_TIME) == t3, "pause did not stop the player"

        origin = "{0.scheme}://{0.netloc}".format(urllib.parse.urlsplit(url))
        local = (origin, "data:", "blob:")
        remote = [u for u in b.requests if not u.startswith(local)]
        assert not remote, f"the page loaded from the network: {remote}"


def _frames(source):
    return len(list(Path(source).glob("*.vtu")))


@needs_chromium
def test_view_spatial_mechanism_in_chromium(tmp_path):
    src = _series(tmp_path, "bricard", "--t-end", "0.3", "--h", "0.01")
    server = _Server(src)
    try:
        asyncio.run(_check_player(server.url, _frames(src), ["rod1", "rod5", "ground", "revolute joint"]))
    finally:
        server.close()


@needs_chromium
def test_view_planar_mechanism_in_chromium(tmp_path):
    src = _series(tmp_path, "andrews", "--t-end", "0.01", "--every", "10")
    server = _Server(src)
    try:
        asyncio.run(_check_player(server.url, _frames(src), ["b1", "b7", "ground", "revolute joint"]))
    finally:
        server.close()


def test_view_bad_source_is_one_line(tmp_path):
    res = subprocess.run([*FEMB, "view", str(tmp_path / "missing"), "--no-browser"], capture_output=True,
                         text=True, timeout=300)
    assert res.returncode == 1
    assert res.stderr.strip() == f"femb: error: {tmp_path / 'missing'}: no such file or folder"
    res = subprocess.run([*FEMB, "view", str(tmp_path), "--no-browser"], capture_output=True, text=True,
                         timeout=300)
    assert res.returncode == 1 and "holds no .pvd collection" in res.stderr


def test_player_frames_legend_and_errors(tmp_path):
    """The scene behind the page, without a browser: one set of actors per frame, the legend, bad input."""
    import femb
    from femb.errors import OutputError
    from femb.io.view import Player

    src = _series(tmp_path, "bricard", "--t-end", "0.05", "--h", "0.01")
    p = Player(src)
    try:
        assert p.n_frames == _frames(src) == 6 and p.view == "3d"
        assert [lb for lb, _ in p.labels][:5] == ["rod1", "rod2", "rod3", "rod4", "rod5"]
        assert all(re.fullmatch(r"#[0-9a-f]{6}", c) for _, c in p.labels)
        first = {k: np.asarray(a.GetBounds()) for k, a in p.plotter.actors.items()}
        p.show(p.n_frames - 1)
        last = {k: np.asarray(a.GetBounds()) for k, a in p.plotter.actors.items()}
        assert set(first) == set(last)                  # the same things drawn, moved
        assert any(not np.allclose(first[k], last[k]) for k in first)
        assert p.time_text(p.n_frames - 1) == "t = 0.05 s"
        with pytest.raises(OutputError, match="frames 0 to 5"):
            p.show(6)
    finally:
        p.close()
    with pytest.raises(OutputError, match="port=70000"):
        femb.view(src, port=70000)
    with pytest.raises(OutputError, match="fps"):
        femb.view(src, fps=0)
    (tmp_path / "bricard" / "copy.pvd").write_text((src / "frame.pvd").read_text())
    with pytest.raises(OutputError, match="several .pvd collections"):
        femb.view(src)


if __name__ == "__main__":            # the documentation's screenshot
    import tempfile

    out = Path(__file__).resolve().parents[1] / "docs" / "figures" / "viewer.png"
    with tempfile.TemporaryDirectory() as tmp:
        src = _series(tmp, "bricard", "--t-end", "1.0", "--h", "0.01")
        server = _Server(src)
        try:
            asyncio.run(_check_player(server.url, _frames(src), ["rod1"], png_out=out))
        finally:
            server.close()
    print(f"wrote {out}")


_NOTEBOOK_CELL = """
import femb
from femb.elements import Gravity, Hinge, RigidBody
mech = femb.Mechanism("pendulum")
bar = mech.add(RigidBody("bar", mass=1.0, inertia=1 / 12, position=(0.5, 0.0), points={"O": (-0.5, 0.0)}))
mech.add(Hinge("pivot", "ground", bar, point_b="O"))
mech.add(Gravity((0.0, -9.81)))
result = femb.simulate(mech.compile(), t_end=0.5, h=1e-2)
result.view()
"""


def _kernel_outputs(kc, msg_id, timeout):
    """IOPub messages of one execution, then its update_display_data (the player's iframe)."""
    deadline = time.monotonic() + timeout
    out, idle = [], False
    while time.monotonic() < deadline:
        try:
            msg = kc.get_iopub_msg(timeout=1.0)
        except Exception:                   # queue.Empty: nothing yet
            continue
        kind, content = msg["msg_type"], msg["content"]
        out.append((kind, content))
        if kind == "error":
            pytest.fail("the notebook cell raised: " + "\n".join(content["traceback"])[-2000:])
        idle = idle or (kind == "status" and content["execution_state"] == "idle"
                        and msg["parent_header"].get("msg_id") == msg_id)
        if idle and any(k == "update_display_data" for k, _ in out):
            return out
    pytest.fail(f"no player shown within {timeout:.0f} s; the kernel said {[k for k, _ in out]}")


@needs_chromium
def test_result_view_in_a_jupyter_kernel_shows_the_player(tmp_path):
    """``result.view()`` run in a real Jupyter kernel (ipykernel), as in a notebook cell.

    The cell must return at once (the player's server runs in the kernel's event loop), show one
    output that is then replaced by an iframe (no warning on stderr), and the iframe's page, opened
    in Chromium while the kernel lives on, must be the player: scene, slider over the result's
    frames, legend.
    """
    jupyter_client = pytest.importorskip("jupyter_client", reason="the test extra installs ipykernel")
    km = jupyter_client.KernelManager(kernel_name="python3")
    km.start_kernel(cwd=str(tmp_path), env={**os.environ, "MPLBACKEND": "Agg"})
    try:
        kc = km.client()
        kc.start_channels()
        kc.wait_for_ready(timeout=120)
        out = _kernel_outputs(kc, kc.execute(_NOTEBOOK_CELL), timeout=600)
        stderr = [c["text"] for k, c in out if k == "stream" and c["name"] == "stderr"]
        assert not any("Warning" in s for s in stderr), f"the cell printed warnings: {stderr}"
        shown = [c for k, c in out if k == "display_data"]
        update = [c for k, c in out if k == "update_display_data"][-1]
        assert len(shown) == 1 and update["transient"]["display_id"] == shown[0]["transient"]["display_id"]
        html = update["data"]["text/html"]
        url = re.search(r'src="([^"]+)"', html).group(1)
        asyncio.run(_check_player(url, 51, ["bar", "ground", "revolute joint"]))
        kc.stop_channels()
    finally:
        km.shutdown_kernel(now=True)
