"""An interactive 3-D player of a result or a VTK series, in the browser.

``femb view DIR`` (or :func:`view`, or :meth:`femb.Result.view`) serves a web page on this
machine that shows the mechanism of a ``.pvd`` series as :mod:`femb.io.render` draws it
(bodies in their colours, joints, ground, floor, springs, loads; the same scene building,
:func:`femb.io.mechanism.frame_items`) with a time slider, play/pause, the frame's time and
the legend of the pictures. The 3-D view turns with the mouse (left drag), zooms (wheel or
right drag) and pans (shift + drag), rendered in the browser by vtk.js.

Built on trame (Kitware's web framework for VTK: trame, trame-vtk, trame-vuetify, the
``view`` extra). Everything the page loads (JavaScript, styles, fonts, icons) is served by
the local server from those packages: no CDN, so the player works offline and through an
SSH tunnel. Other data than femb's mechanisms (planar or 3-D meshes) are drawn cell by cell,
coloured by element type, as the pictures draw them.
"""
from __future__ import annotations

import asyncio
import os
import sys
from pathlib import Path

import numpy as np

from femb.errors import OutputError

__all__ = ["Player", "view", "viewer_available"]

_INSTALL = 'pip install "femb[view]"'
_FPS = 20.0


def viewer_available():
    """Tell whether the browser player's libraries are installed.

    Returns
    -------
    ok : bool
    reason : str
        What is missing and how to install it, or ``"ok"``.
    """
    import importlib.util

    for mod in ("trame", "trame_vtk", "trame_vuetify", "pyvista"):
        if importlib.util.find_spec(mod) is None:
            return False, f"the browser player needs {mod.replace('_', '-')} ({_INSTALL})"
    return True, "ok"


def _series(source):
    """The ``.pvd`` file of a folder, a ``.pvd`` path, or None."""
    p = Path(source)
    if not p.exists():
        raise OutputError(f"{p}: no such file or folder")
    if p.is_dir():
        found = sorted(p.glob("*.pvd"))
        if not found:
            raise OutputError(f"{p}: the folder holds no .pvd collection (write one with femb run SCENE --vtk DIR)")
        if len(found) > 1:
            names = ", ".join(f.name for f in found)
            raise OutputError(f"{p}: the folder holds several .pvd collections ({names}); give one of them")
        return found[0]
    if p.suffix.lower() != ".pvd":
        raise OutputError(f"{p}: expected a folder with a .pvd collection or a .pvd file")
    return p


class Player:
    """The scene of a series in an off-screen plotter, one frame at a time (no server).

    Parameters
    ----------
    pvd : str or Path
        A ``.pvd`` collection (or a folder holding one).
    view : str, optional
        The initial camera, as for :func:`femb.io.render.render_png` (default onto the
        plane for planar mechanisms, else the 3-D view).
    window_size : (int, int)
        Size used to fit the initial camera (the page fills the browser window).

    Attributes
    ----------
    entries : list of (float, Path)
        Time and file of each frame.
    labels : list of [str, str]
        The legend: name and colour (``#rrggbb``) of each body, the ground, joints, springs.
    plotter : pyvista.Plotter
        The off-screen plotter whose render window the page shows.
    """

    def __init__(self, pvd, *, view=None, window_size=(1024, 768)):
        from . import render as r

        ok, why = viewer_available()
        if not ok:
            raise OutputError(why)
        r.can_render()                 # picks the off-screen window class (EGL) when there is one
        import pyvista as pv

        self.pvd = _series(pvd)
        self.entries = r._entries(self.pvd)
        self._pv, self._r = pv, r
        self._scan = r._Scan(pv, self.entries, None)
        self.view = r._check_view(view, self._scan)
        self._mech = r._mechanism(pv, self.entries, self._scan, None, self.view, ())
        self._fmt = r._time_format(self.entries)
        self._names = []
        self.frame = -1
        self.plotter = r._plotter(pv, window_size)
        self.labels = []
        self._fit(window_size)
        self.show(0)

    def _fit(self, window_size):
        r, pv = self._r, self._pv
        if self._mech is None:
            r._fit_camera(self.plotter, self._scan, self.view, window_size[0] / window_size[1])
            return
        from . import mechanism as mx

        items = mx.frame_items(pv, self._mech.frames[0], self._mech.motion)
        self.labels = r._legend_labels(items)
        cam = self._mech.camera(pv, self.view, window_size)
        r._apply_camera(self.plotter, cam)

    @property
    def n_frames(self):
        """Number of frames of the series."""
        return len(self.entries)

    def time_text(self, k):
        """The label ``t = ... s`` of frame ``k``."""
        return self._r._label(self._fmt, self.entries[k][0])

    def show(self, k):
        """Put frame ``k`` into the plotter (replacing the previous one)."""
        k = int(k)
        if not 0 <= k < self.n_frames:
            raise OutputError(f"frame {k}: the series has frames 0 to {self.n_frames - 1}")
        if k == self.frame:
            return
        r, pv, pl = self._r, self._pv, self.plotter
        if self._mech is not None:
            from . import mechanism as mx

            new = r._draw_items(pl, mx.frame_items(pv, self._mech.frames[k], self._mech.motion), "item")
        else:
            r._add_frame(pv, pl, r._read(pv, self.entries[k][1]), self._scan, None, name="frame")
            new = ["frame"]
        for name in set(self._names) - set(new):
            pl.remove_actor(name, render=False)
        self._names = new
        pl.renderer.ResetCameraClippingRange()
        self.frame = k

    def close(self):
        """Release the plotter."""
        self.plotter.close()


def _legend_html(labels):
    """The legend as small coloured boxes and names (trame html elements)."""
    from trame.widgets import html

    with html.Div(style="position: absolute; top: 8px; right: 8px; background: rgba(255,255,255,0.8);"
                        "padding: 4px 8px; font-size: 13px; pointer-events: none; z-index: 1;",
                  classes="femb-legend"):
        for name, colour in labels:
            with html.Div(style="display: flex; align-items: center; margin: 2px 0;"):
                html.Span(style=f"display: inline-block; width: 14px; height: 14px; margin-right: 6px;"
                                f"background: {colour}; border: 1px solid #444;")
                html.Span(name)


def _build_ui(server, player, title):
    """The page: a toolbar with play/pause, the time slider and the time; the 3-D view; the legend."""
    from trame.ui.vuetify3 import SinglePageLayout
    from trame.widgets import html
    from trame.widgets import vtk as vtk_widgets
    from trame.widgets import vuetify3 as v3

    state, ctrl = server.state, server.controller
    state.trame__title = title
    state.frame = 0
    state.playing = False
    state.time_text = player.time_text(0)
    with SinglePageLayout(server, full_height=True) as layout:
        layout.title.set_text(title)
        layout.icon.hide()                  # no side drawer: no button to open one
        with layout.toolbar:
            v3.VSpacer()
            v3.VBtn(icon=("playing ? 'mdi-pause' : 'mdi-play'",), click="playing = !playing",
                    classes="femb-play", variant="text", density="compact")
            v3.VSlider(v_model=("frame", 0), min=0, max=player.n_frames - 1, step=1, hide_details=True,
                       density="compact", style="max-width: 50%; min-width: 200px;", classes="femb-time mx-2")
            html.Div("{{ time_text }}", classes="femb-time-text text-body-2", style="min-width: 9em;")
            v3.VBtn(icon="mdi-crop-free", click=ctrl.view_reset_camera, variant="text", density="compact",
                    title="reset the camera")
        with layout.content:
            with v3.VContainer(fluid=True, classes="pa-0 fill-height", style="position: relative;"):
                vw = vtk_widgets.VtkLocalView(player.plotter.ren_win, classes="femb-scene")
                ctrl.view_update = vw.update
                ctrl.view_reset_camera = vw.reset_camera
                if player.labels:
                    _legend_html(player.labels)
    return layout


def _wire(server, player, fps):
    """Slider → frame shown; play/pause → a loop stepping the slider at ``fps`` frames per second."""
    state, ctrl = server.state, server.controller

    @state.change("frame")
    def _on_frame(frame, **_):
        k = int(frame)
        player.show(k)
        state.time_text = player.time_text(k)
        ctrl.view_update()

    @state.change("playing")
    def _on_play(playing, **_):
        if playing:
            asyncio.get_event_loop().create_task(_play())

    async def _play():
        while state.playing:
            with state:
                state.frame = (int(state.frame) + 1) % player.n_frames
            await asyncio.sleep(1.0 / fps)


class _Session:
    """A player, its trame server and page (one per call of :func:`view`)."""

    _count = 0

    def __init__(self, pvd, view, fps, title=None):
        from trame.app import get_server

        self.player = Player(pvd, view=view)
        _Session._count += 1
        self.server = get_server(f"femb-view-{os.getpid()}-{_Session._count}", client_type="vue3")
        # trame reads its own options from sys.argv unless given a list: give it none
        cli = self.server.cli
        parse = cli.parse_known_args
        cli.parse_known_args = lambda args=None, namespace=None: parse([] if args is None else args, namespace)
        title = title or f"femb view: {self.player.pvd.parent.name}/{self.player.pvd.name}"
        self.layout = _build_ui(self.server, self.player, title)
        _wire(self.server, self.player, fps)


def _in_notebook():
    ip = sys.modules.get("IPython")
    if ip is None:
        return False
    try:
        shell = ip.get_ipython()
    except AttributeError:
        return False
    return shell is not None and shell.__class__.__name__ == "ZMQInteractiveShell"


_NOTEBOOK_SESSIONS = []      # players shown in a notebook live as long as the kernel


def _notebook(session, port, host, height=600):
    """Show the player inline: its server starts as a task in the kernel's event loop, then an iframe."""
    from IPython.display import HTML, IFrame, display

    _NOTEBOOK_SESSIONS.append(session)
    layout = session.layout
    handle = display(HTML("<div>femb view: starting the player ...</div>"), display_id=True)

    session.server.start(exec_mode="task", port=port, host=host, open_browser=False, show_connection_info=False,
                         disable_logging=True, timeout=0)

    async def _show():
        await session.server.ready
        session.iframe = IFrame(layout.url, width="100%", height=height)
        handle.update(session.iframe)

    asyncio.get_event_loop().create_task(_show())


def _check_port(port):
    if port is None:
        return 0
    if isinstance(port, bool) or not isinstance(port, (int, np.integer)) or not 0 <= int(port) <= 65535:
        raise OutputError(f"port={port!r}: expected an integer from 0 to 65535 (0: any free port)")
    return int(port)


def view(source, *, port=None, open_browser=True, view=None, fps=_FPS, host="localhost"):
    """Show a result or a VTK series in an interactive 3-D player in the browser.

    Parameters
    ----------
    source : femb.Result, str or Path
        A result (its stored steps are written to a temporary series first, at most about
        400 frames), a folder holding a ``.pvd`` collection, or a ``.pvd`` file.
    port : int, optional
        Port of the local web server (default any free port).
    open_browser : bool, default True
        Open the page in the system's browser; otherwise print its address.
    view : str, optional
        Initial camera, as for :func:`femb.io.render.render_png`.
    fps : float, default 20
        Frames per second when playing.
    host : str, default "localhost"
        Interface the server listens on (``"0.0.0.0"``: every interface; prefer an SSH
        tunnel, see the documentation).

    Returns
    -------
    None
        In a Jupyter notebook the player is shown inline, in the cell's output (its server
        runs in the kernel's event loop); elsewhere the call serves until interrupted (Ctrl-C).

    Raises
    ------
    OutputError
        Missing libraries (the ``view`` extra), no series there, or bad arguments.
    """
    port = _check_port(port)
    if not (isinstance(fps, (int, float, np.number)) and np.isfinite(fps) and fps > 0):
        raise OutputError(f"fps={fps!r}: expected a positive number of frames per second")
    ok, why = viewer_available()
    if not ok:
        raise OutputError(why)
    tmp = title = None
    if hasattr(source, "write_vtk") and hasattr(source, "t"):
        import tempfile

        tmp = tempfile.TemporaryDirectory(prefix="femb-view-")
        every = max(1, len(source.t) // 400)
        name = getattr(getattr(source, "model", None), "name", "") or "result"
        title = f"femb view: {name}"
        source = source.write_vtk(tmp.name, every=every)
    session = _Session(source, view, float(fps), title)
    session.tmp = tmp                      # the temporary series lives as long as the session
    if _in_notebook():
        _notebook(session, port, host)
        return None
    server = session.server

    def _announce(**_):
        print(f"femb view: serving {session.player.pvd} at http://{host}:{server.port}/ (Ctrl-C stops)",
              flush=True)

    server.controller.on_server_ready.add(_announce)
    try:
        server.start(port=port, host=host, open_browser=bool(open_browser), show_connection_info=False,
                     timeout=0)
    finally:
        session.player.close()
        if tmp is not None:
            tmp.cleanup()
    return None
