"""Off-screen pictures and animations of a written time series.

Everything here reads a ``.pvd`` collection written by
:class:`femb.io.vtk.TimeSeriesWriter` and renders it without a display.
pyvista (and through it VTK's rendering) is imported inside the functions
only, so ``import femb`` stays fast and works on machines without OpenGL.

Common conventions of the rendering functions:

* the camera is fitted once to the **whole motion** (the union of every
  frame) and kept fixed, so successive pictures are comparable;
* a **3-D mechanism written by femb** (its frames carry the scene description
  of :func:`femb.io.frames.scene_field_data`) is drawn by parts
  (:mod:`femb.io.mechanism`): bodies in distinct colours with a legend of
  their names, joints as glyphs sized from the mechanism, the ground (base
  blocks at the joints to the ground, named ground points), a faint floor
  normal to gravity, springs as coils, loads as arrows, an axes triad, and
  optionally paths of chosen points (``trace``); in perspective with gravity
  pointing down the picture (``view``: ``"3d"`` by default, ``"iso"``,
  ``"front"``, ``"side"``, ``"top"`` or ``"azimuth,elevation"`` in degrees);
  :func:`picture_scene` returns what such a picture shows and its camera
  without drawing it;
* other data is drawn cell by cell, coloured by element type: planar data
  (all z equal) in a 2D view (looking down the z axis, parallel
  projection), 3-D data in the same perspective views with z up;
  ``view="xy"``, ``"xz"`` or ``"yz"`` gives the parallel view along an axis
  for any data;
* each picture carries a time label ``t = ... s``;
* lines are drawn with some width and vertex cells as round points, so thin
  mechanisms stay visible; ``scalars`` names a point or cell data array to
  colour by instead (vectors are shown by their magnitude, with a colour
  range fixed over the whole motion; always drawn cell by cell).
"""
from __future__ import annotations

import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np

from .progress import progress as _progress
from .vtk import OutputError, check_writable_dir, read_pvd

__all__ = ["can_render", "render_png", "render_strip", "render_animation", "camera_3d", "picture_scene"]

#: Colours of the element types (id 0, 1, ...), cycled when there are more.
PALETTE = (
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (127, 127, 127),
    (188, 189, 34),
    (23, 190, 207),
)

LINE_WIDTH = 3.0
POINT_SIZE = 10.0
_MARGIN = 1.08  # empty border around the motion, as a factor on its size
_BAR = 0.14  # fraction of the width kept for the colour bar
_LEGEND = 0.25  # fraction of the width kept for the legend of times

#: parallel views along a coordinate axis; the others ("3d", "iso", "front", "side", "top" or
#: "azimuth,elevation") are perspective views with gravity pointing down (z up without gravity)
_AXIS_VIEWS = ("xy", "xz", "yz")

# ---------------------------------------------------------------------------
# can we render here?
# ---------------------------------------------------------------------------

_PROBE = r"""
import sys
from vtkmodules.vtkCommonCore import vtkUnsignedCharArray
from vtkmodules.vtkRenderingCore import vtkRenderWindow, vtkRenderer
import vtkmodules.vtkRenderingOpenGL2  # noqa: F401  (registers the OpenGL classes)
rw = vtkRenderWindow()
rw.SetOffScreenRendering(1)
rw.SetSize(8, 8)
ren = vtkRenderer()
ren.SetBackground(1.0, 0.0, 0.0)
rw.AddRenderer(ren)
rw.Render()
px = vtkUnsignedCharArray()
rw.GetPixelData(0, 0, 0, 0, 0, px, 0)
ok = px.GetNumberOfValues() >= 3 and px.GetValue(0) > 200 and px.GetValue(1) < 50
print(("OK " if ok else "BLANK ") + rw.GetClassName())
rw.Finalize()
"""

_CAN_RENDER: tuple[bool, str] | None = None


def _probe(window_class, timeout):
    env = dict(os.environ)
    if window_class is not None:
        env["VTK_DEFAULT_OPENGL_WINDOW"] = window_class
    try:
        res = subprocess.run(
            [sys.executable, "-c", _PROBE],
            env=env,
            capture_output=True,
            text=True,
            timeout=timeout,
            stdin=subprocess.DEVNULL,
        )
    except subprocess.TimeoutExpired:
        what = window_class or os.environ.get("VTK_DEFAULT_OPENGL_WINDOW") or "default window"
        return False, f"{what}: timed out after {timeout} s"
    out = res.stdout.strip().splitlines()
    if res.returncode == 0 and out and out[-1].startswith("OK "):
        return True, out[-1][3:]
    stderr = re.sub(r"\x1b\[[0-9;]*m", "", res.stderr).strip()
    # drop VTK's log prefix (date, clock, thread, source:line, level)
    lines = [re.sub(r"^.*?\b(?:WARN|ERR|INFO)\|\s*", "", ln).strip() for ln in stderr.splitlines()]
    err = " ".join(ln for ln in lines[-2:] if ln)
    what = window_class or os.environ.get("VTK_DEFAULT_OPENGL_WINDOW") or "default window"
    if res.returncode < 0:
        how = f"crashed (signal {-res.returncode})"
    elif out and out[-1].startswith("BLANK"):
        how = "rendered a blank image"
    else:
        how = f"failed (exit code {res.returncode})"
    return False, f"{what} {how}" + (f": {err}" if err else "")


def can_render(*, refresh=False, timeout=60.0):
    """Tell whether an off-screen OpenGL context can be created here.

    The check renders an 8 x 8 picture in a child process (a failing OpenGL
    set-up can crash the process that tries it) and reads a pixel back. It
    tries, in order, the window systems that can work without a display:
    EGL, then OSMesa, then VTK's default (X11 when ``DISPLAY`` is set; with a
    display the default is tried first). The first that works is remembered
    for this process through the environment variable
    ``VTK_DEFAULT_OPENGL_WINDOW`` (unless the user set it), which also spares
    VTK's warning about a missing X server. The answer is cached.

    Parameters
    ----------
    refresh : bool, default False
        Check again instead of returning the cached answer.
    timeout : float, default 60
        Seconds allowed for each attempt.

    Returns
    -------
    ok : bool
        Whether rendering works.
    reason : str
        The window class used when it works, else what failed and how to fix it.
    """
    global _CAN_RENDER
    if _CAN_RENDER is not None and not refresh:
        return _CAN_RENDER
    import importlib.util

    for mod in ("vtkmodules", "pyvista"):
        if importlib.util.find_spec(mod) is None:
            _CAN_RENDER = (False, f"{mod} is not installed (pip install pyvista)")
            return _CAN_RENDER
    user = os.environ.get("VTK_DEFAULT_OPENGL_WINDOW")
    if user:
        candidates = [None]
    elif os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"):
        candidates = [None, "vtkEGLRenderWindow", "vtkOSOpenGLRenderWindow"]
    else:
        candidates = ["vtkEGLRenderWindow", "vtkOSOpenGLRenderWindow", None]
    failures = []
    for cls in candidates:
        ok, msg = _probe(cls, timeout)
        if ok:
            if cls is not None and not user:
                os.environ["VTK_DEFAULT_OPENGL_WINDOW"] = cls
            _CAN_RENDER = (True, f"off-screen rendering works with {msg}")
            return _CAN_RENDER
        failures.append(msg)
    _CAN_RENDER = (
        False,
        "no off-screen OpenGL context could be created ("
        + "; ".join(failures)
        + "). On Debian/Ubuntu install Mesa's EGL: apt-get install libegl1 "
        "libegl-mesa0 libgl1-mesa-dri (or libosmesa6), or run under xvfb-run",
    )
    return _CAN_RENDER


def _require_render():
    ok, reason = can_render()
    if not ok:
        raise OutputError(f"cannot render pictures on this machine: {reason}")


# ---------------------------------------------------------------------------
# reading and scanning a series
# ---------------------------------------------------------------------------


def _entries(pvd):
    pvd = Path(pvd)
    if pvd.suffix.lower() != ".pvd":
        raise OutputError(f"{pvd}: expected a .pvd collection file")
    entries = read_pvd(pvd)
    if not entries:
        raise OutputError(f"{pvd}: the collection lists no frames")
    return entries


def _read(pv, path):
    path = Path(path)
    if not path.is_file():
        raise OutputError(f"{path}: frame file listed in the collection is missing")
    try:
        return pv.read(str(path))
    except Exception as exc:
        raise OutputError(f"{path}: cannot read frame ({exc})") from exc


def _values(mesh, name):
    """Array ``name`` of a frame (point data first), as scalars; None if absent."""
    for data in (mesh.point_data, mesh.cell_data):
        if name in data:
            a = np.asarray(data[name], dtype=float)
            return np.linalg.norm(a, axis=1) if a.ndim == 2 else a
    return None


class _Scan:
    """Bounds, planarity and scalar range of a whole motion (reads every frame)."""

    def __init__(self, pv, entries, scalars):
        lo = np.full(3, np.inf)
        hi = np.full(3, -np.inf)
        smin, smax = np.inf, -np.inf
        found = False
        names = set()
        for _, path in entries:
            m = _read(pv, path)
            if m.n_points:
                pts = np.asarray(m.points)
                lo = np.minimum(lo, pts.min(axis=0))
                hi = np.maximum(hi, pts.max(axis=0))
            if scalars is not None:
                v = _values(m, scalars)
                if v is None:
                    names.update(m.point_data.keys())
                    names.update(m.cell_data.keys())
                    continue
                found = True
                v = v[np.isfinite(v)]
                if v.size:
                    smin, smax = min(smin, v.min()), max(smax, v.max())
        if not np.all(np.isfinite(lo)):
            lo = hi = np.zeros(3)
        self.lo, self.hi = lo, hi
        size = float(np.max(hi - lo))
        self.size = size if size > 0 else 1.0
        self.planar = (hi[2] - lo[2]) <= 1e-9 * self.size
        # a 3-D mechanism written by femb (drawn by parts, in perspective, even when it moves in a plane)
        fd0 = _read(pv, entries[0][1]).field_data if entries else {}
        glyphs = [int(np.asarray(fd0[k]).reshape(-1)[0]) for k in fd0.keys() if k.startswith("glyph.")]
        self.mechanism = bool(glyphs)
        # a planar mechanism (bodies without frames, z = 0, no gravity along z): seen straight onto its plane
        g = np.asarray(fd0["gravity"], dtype=float).reshape(-1) if "gravity" in fd0.keys() else np.zeros(3)
        self.plane = self.mechanism and self.planar and 2 not in glyphs and (g.size < 3 or g[2] == 0.0)
        if scalars is not None and not found:
            raise OutputError(
                f"scalars={scalars!r}: no point or cell data of that name in the frames "
                f"(available: {', '.join(sorted(names)) or 'none'})"
            )
        if scalars is not None:
            if not np.isfinite(smin):
                smin, smax = 0.0, 1.0
            if smax <= smin:
                pad = abs(smin) * 1e-6 or 1e-12
                smin, smax = smin - pad, smax + pad
            self.clim = (float(smin), float(smax))
        else:
            self.clim = None


def _time_format(entries):
    """Format string for times: enough decimals to tell the frames apart."""
    ts = np.unique([t for t, _ in entries])
    dt = np.diff(ts)
    dt = dt[dt > 0]
    dec = 3 if dt.size == 0 else int(math.ceil(-math.log10(dt.min()) - 1e-9))
    return "{:.%df}" % min(max(dec, 2), 9)


def _label(fmt, t):
    return "t = " + fmt.format(t) + " s"


def _nearest(entries, time):
    if time is None:
        return len(entries) - 1
    ts = np.array([t for t, _ in entries])
    return int(np.argmin(np.abs(ts - float(time))))


def _check_suffix(path, allowed, param):
    path = Path(path)
    suf = path.suffix.lower()
    if suf not in allowed:
        raise OutputError(
            f"{param}={str(path)!r}: unknown output suffix {suf or '(none)'!r}; "
            f"expected {' or '.join(allowed)}"
        )
    try:
        check_writable_dir(path.parent, "folder of the output file")
    except OutputError as exc:
        raise OutputError(f"{param}={str(path)!r}: {exc}") from None
    if path.is_dir():
        raise OutputError(f"{param}={str(path)!r}: is a folder; give a file name")
    return path, suf


def _check_view(view, scan):
    if view is None:
        if getattr(scan, "plane", False):
            return "plane"
        return "xy" if scan.planar and not getattr(scan, "mechanism", False) else "3d"
    from .mechanism import parse_view

    name, _ = parse_view(view)
    return view.strip().lower() if name == "custom" else name


def _direction(view, up=(0.0, 0.0, 1.0)):
    """Viewing direction and picture up of a perspective view (name or 'az,el') for a scene up vector."""
    from .mechanism import parse_view, view_direction

    _, angles = parse_view(view)
    if angles is None:
        return None
    return view_direction(angles, np.asarray(up, dtype=float))


# ---------------------------------------------------------------------------
# drawing
# ---------------------------------------------------------------------------


def _plotter(pv, window_size, shape=(1, 1), col_weights=None, border=False):
    w, h = (int(v) for v in window_size)
    if w < 16 or h < 16:
        raise OutputError(f"window_size={tuple(window_size)!r}: expected at least 16 x 16 pixels")
    # off_screen per plotter rather than pyvista.OFF_SCREEN: same effect, but
    # leaves the caller's global pyvista settings alone.
    kw = {} if col_weights is None else {"col_weights": list(col_weights)}
    if border:
        kw.update(border_color="#c8c8c8", border_width=1.0)
    pl = pv.Plotter(off_screen=True, window_size=(w, h), shape=shape, border=border, **kw)
    pl.set_background("white")
    return pl


def _fit_camera(pl, scan, view, aspect, *, right=0.0, top=0.0):
    """Point the active renderer's camera at the motion's bounds, once.

    ``right`` and ``top`` are fractions of the picture kept free of the
    mechanism (for a colour bar or legend, and for the time label).
    """
    lo, hi = scan.lo, scan.hi
    center = 0.5 * (lo + hi)
    ext = np.maximum(hi - lo, 0.0)
    cam = pl.camera
    dist = 4.0 * scan.size
    # shift the projection centre so the motion sits in the free part
    cam.SetWindowCenter(right, top)
    if view not in _AXIS_VIEWS:
        from .mechanism import fit_points

        pl.disable_parallel_projection()
        d, pic_up = _direction(view)
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        focal, position, up = fit_points(corners, d, pic_up, aspect, cam.view_angle, right=right, top=top)
        cam.focal_point = tuple(focal)
        cam.position = tuple(position)
        cam.up = tuple(up)
        pl.renderer.ResetCameraClippingRange(
            *[float(v) for pair in zip(lo - scan.size, hi + scan.size) for v in pair]
        )
        return
    axes = {"xy": (0, 1, 2), "xz": (0, 2, 1), "yz": (1, 2, 0)}[view]
    normal = np.zeros(3)
    normal[axes[2]] = 1.0 if view != "xz" else -1.0
    up = np.zeros(3)
    up[axes[1]] = 1.0
    w, h = ext[axes[0]], ext[axes[1]]
    if w <= 0 and h <= 0:
        w = h = scan.size
    cam.focal_point = tuple(center)
    cam.position = tuple(center + dist * normal)
    cam.up = tuple(up)
    pl.enable_parallel_projection()
    cam.parallel_scale = 0.5 * _MARGIN * max(h / (1.0 - top), w / (aspect * (1.0 - right)))
    pl.renderer.ResetCameraClippingRange(
        *[float(v) for pair in zip(lo - scan.size, hi + scan.size) for v in pair]
    )


def camera_3d(lo, hi, direction=(1.0, -1.0, 0.7), aspect=4.0 / 3.0, view_angle=30.0, *, right=0.0,
              top=0.0, size=None, margin=_MARGIN):
    """A perspective camera looking at a bounding box from a direction, z up.

    Parameters
    ----------
    lo, hi : array_like, shape (3,)
        Bounds of the whole motion (m).
    direction : array_like, shape (3,)
        From the centre of the box towards the camera (normalised here; it
        must not be parallel to z).
    aspect : float
        Picture width / height.
    view_angle : float
        Vertical view angle of the camera (degrees).
    right, top : float
        Fractions of the picture width and height kept free (colour bar,
        time label); the camera's window centre is shifted by the caller.
    size : float, optional
        Length scale of the motion (default the largest edge of the box);
        the distance is at least 1e-6 of it.
    margin : float
        Empty border, as a factor on the size of the motion.

    Returns
    -------
    focal_point, position, up : ndarray, shape (3,)
        The centre of the box, the camera at the distance where every corner
        of the box is in view with the margin, and the z axis made normal to
        the viewing direction.
    """
    lo = np.asarray(lo, dtype=float)
    hi = np.asarray(hi, dtype=float)
    center = 0.5 * (lo + hi)
    d = np.asarray(direction, dtype=float)
    d = d / np.linalg.norm(d)
    up = np.array([0.0, 0.0, 1.0]) - d[2] * d          # z axis, made normal to d
    nu = np.linalg.norm(up)
    if nu < 1e-9:
        raise OutputError(f"camera direction {tuple(direction)!r} is parallel to the z axis (the up direction)")
    up /= nu
    rgt = np.cross(up, d)
    if size is None:
        size = float(np.max(hi - lo))
    size = size if size > 0 else 1.0
    # distance at which every corner of the bounding box is in view
    half = math.tan(math.radians(view_angle) / 2.0)
    tx = half * aspect * (1.0 - right) / margin
    ty = half * (1.0 - top) / margin
    corners = np.array([[x, y, z] for x in (lo[0], hi[0])
                        for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]) - center
    need = corners @ d + np.maximum(np.abs(corners @ rgt) / tx, np.abs(corners @ up) / ty)
    dist = max(float(need.max()), 1e-6 * size)
    return center, center + dist * d, up


def _top_reserve(height_px, font_px=34):
    """Fraction of the picture height kept for the time label."""
    return min(0.2, font_px / float(height_px))


def _add_frame(pv, pl, mesh, scan, scalars, *, name, color=None, legend=None):
    """Add one frame's mesh to the active renderer, replacing ``name``."""
    kw = dict(
        name=name,
        reset_camera=False,
        show_edges=True,
        edge_color="black",
        line_width=LINE_WIDTH,
        point_size=POINT_SIZE,
        render_points_as_spheres=True,
        lighting=not scan.planar,  # shading shows the depth of 3-D surfaces
        render=False,
    )
    if mesh.n_cells == 0:
        # points only: show them as points
        mesh = pv.PolyData(np.asarray(mesh.points)) if mesh.n_points else pv.PolyData()
        kw.update(style="points")
    if mesh.n_points == 0:
        return
    if color is not None:
        kw.update(color=color, label=legend)
    elif scalars is not None:
        vals = _values(mesh, scalars)
        if vals is None:
            kw.update(color="lightgray")
        else:
            kw.update(
                scalars=scalars,
                clim=scan.clim,
                cmap="viridis",
                scalar_bar_args=dict(title=scalars, color="black", vertical=True,
                                     position_x=0.88, position_y=0.1,
                                     height=0.8, width=0.06),
            )
    elif "element_type" in mesh.cell_data:
        ids = np.asarray(mesh.cell_data["element_type"]).astype(int) % len(PALETTE)
        mesh = mesh.copy(deep=False)
        mesh.cell_data["_femb_rgb"] = np.array(PALETTE, dtype=np.uint8)[ids]
        kw.update(scalars="_femb_rgb", rgb=True, show_scalar_bar=False)
    else:
        kw.update(color=PALETTE[0])
    pl.add_mesh(mesh, **kw)


def _add_time(pl, text, font_size=14):
    pl.add_text(text, position="upper_left", font_size=font_size, color="black", name="time",
                render=False)


def _snapshot(pl):
    pl.render()
    img = pl.screenshot(return_img=True)
    return np.ascontiguousarray(img[..., :3])


# ---------------------------------------------------------------------------
# mechanisms: bodies, joints, ground (femb.io.mechanism)
# ---------------------------------------------------------------------------


class _Mechanism:
    """The frames of a mechanism's series read once, and what the whole motion shows."""

    def __init__(self, pv, entries, trace=()):
        from . import mechanism as mx

        self.frames = [mx.read_frame(_read(pv, path), t) for t, path in entries]
        self.motion = mx.scan_motion(self.frames, trace)

    def camera(self, pv, view, window_size, *, top=0.0, right=0.0):
        """A :class:`~femb.io.mechanism.Camera` showing the whole motion and its glyphs, fixed over it."""
        from . import mechanism as mx

        if view == "plane":             # straight onto the plane of a planar mechanism, its up along -g
            up = self.motion.up
            d, pic_up = np.array([0.0, 0.0, 1.0]), np.array([up[0], up[1], 0.0])
            pic_up /= max(float(np.hypot(up[0], up[1])), 1e-300)
        else:
            d, pic_up = _direction(view, self.motion.up)
        s = self.motion.joint_size
        pad = 2.6 * s * np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
        key = self.motion.key
        pts = [(key[:, None, :] + pad[None]).reshape(-1, 3)]
        f = mx.floor_item(pv, self.motion)
        if f is not None:                   # the floor's level, under the motion
            pts.append(f.points.mean(axis=0)[None])
        w, h = window_size
        focal, position, up = mx.fit_points(np.vstack(pts), d, pic_up, w / h, 30.0, right=right, top=top)
        return mx.Camera(focal, position, up, 30.0, (int(w), int(h)), (right, top))


def _mechanism(pv, entries, scan, scalars, view, trace):
    """A :class:`_Mechanism` when the series is a 3-D mechanism drawn by parts, else None."""
    from . import mechanism as mx

    if scalars is not None or (view in _AXIS_VIEWS) or (scan.planar and not scan.mechanism):
        if trace:
            raise OutputError("trace: paths are drawn for 3-D mechanisms in perspective views "
                              "(not with scalars or the xy/xz/yz views)")
        return None
    first = _read(pv, entries[0][1])
    if not mx.is_mechanism(first):
        if trace:
            raise OutputError("trace: this series carries no body frames (write it with femb 0.x "
                              "or later: femb run SCENE --vtk DIR)")
        return None
    return _Mechanism(pv, entries, trace)


def picture_scene(pvd, time=None, *, view=None, window_size=(1024, 768), trace=()):
    """What :func:`render_png` draws for a 3-D mechanism, without drawing it.

    Parameters
    ----------
    pvd : str or Path
        Collection written by ``femb run SCENE --vtk DIR`` (or
        :func:`femb.io.write_vtk`).
    time : float, optional
        Time in s of the frame (nearest; default the last).
    view : str, optional
        As for :func:`render_png`.
    window_size : (int, int)
        Picture size in pixels.
    trace : sequence of str
        ``"body"`` or ``"body:point"`` paths, as for :func:`render_png`.

    Returns
    -------
    femb.io.mechanism.Picture
        Its ``items`` (kind, label and mesh of each drawn thing: ``"body"``,
        ``"joint:<kind>"``, ``"ground"``, ``"floor"``, ``"spring"``,
        ``"trace"``) and its ``camera`` (``camera.project(points)`` gives
        pixel coordinates).

    Raises
    ------
    OutputError
        When the series is not a 3-D mechanism written by femb.
    """
    import pyvista as pv

    from . import mechanism as mx

    entries = _entries(pvd)
    scan = _Scan(pv, entries, None)
    v = _check_view(view, scan)
    mech = _mechanism(pv, entries, scan, None, v, trace)
    if mech is None:
        raise OutputError(f"{pvd}: not a 3-D mechanism written by femb (no scene description in its frames)")
    k = _nearest(entries, time)
    items = mx.frame_items(pv, mech.frames[k], mech.motion)
    cam = mech.camera(pv, v, window_size, top=_top_reserve(window_size[1]),
                      right=_legend_width(_legend_labels(items), *window_size))
    return mx.Picture(entries[k][0], items, cam, mech.motion)


def _hex(c):
    return "#%02x%02x%02x" % tuple(int(v) for v in c[:3])


def _apply_camera(pl, cam):
    c = pl.camera
    pl.disable_parallel_projection()
    c.view_angle = cam.view_angle
    c.focal_point = tuple(float(v) for v in cam.focal)
    c.position = tuple(float(v) for v in cam.position)
    c.up = tuple(float(v) for v in cam.up)
    c.SetWindowCenter(*cam.window_center)
    pl.renderer.ResetCameraClippingRange()


def _draw_items(pl, items, prefix):
    """Add items (femb.io.mechanism.Item) to the active renderer; returns the actor names."""
    names = []
    for i, it in enumerate(items):
        name = f"{prefix}{i}"
        kw = dict(color=_hex(it.colour), opacity=it.opacity, name=name, reset_camera=False, render=False,
                  lighting=it.kind != "floor", show_scalar_bar=False)
        if it.line_width:
            kw.update(line_width=it.line_width)
        if it.kind in ("body", "ground") or it.kind.startswith("joint:"):
            kw.update(specular=0.3, smooth_shading=it.kind.startswith("joint:") or it.edges is None)
        pl.add_mesh(it.mesh, **kw)
        names.append(name)
        if it.edges is not None:
            ecol = "#bdbdb6" if it.kind == "floor" else "#202020"
            pl.add_mesh(it.edges, color=ecol, line_width=1.0 if it.kind == "floor" else 1.5,
                        name=name + "e", reset_camera=False, render=False, lighting=False,
                        show_scalar_bar=False)
            names.append(name + "e")
    return names


def _legend_labels(items):
    """Names of the bodies in their colours, then the ground, the joints and the paths."""
    labels = []
    seen = set()
    for it in items:
        if it.kind == "body" and it.label not in seen:
            seen.add(it.label)
            labels.append([it.label, _hex(it.colour)])
    kinds = sorted({it.kind.split(":", 1)[1] for it in items if it.kind.startswith("joint:")})
    from .mechanism import DRIVE_COLOUR, GROUND_COLOUR, JOINT_COLOUR, LOAD_COLOUR, SPRING_COLOUR
    for it in items:
        if it.kind == "beam" and ("beam", it.label) not in seen:
            seen.add(("beam", it.label))
            labels.append([it.label, _hex(it.colour)])
    if any(it.kind == "ground" for it in items):
        labels.append(["ground", _hex(GROUND_COLOUR)])
    for kind in kinds:
        if kind in ("motor", "actuator"):
            labels.append([f"{kind} (driven)", _hex(DRIVE_COLOUR)])
        else:
            labels.append([f"{kind} joint", _hex(JOINT_COLOUR)])
    names = {"spring": "spring-damper", "torsion": "torsion spring", "bushing": "bushing"}
    for kind in sorted({it.label for it in items if it.kind == "spring"}):
        labels.append([names.get(kind, kind), _hex(SPRING_COLOUR)])
    if any(it.kind == "load" for it in items):
        labels.append(["load", _hex(LOAD_COLOUR)])
    if any(it.kind == "contact" for it in items):
        from .mechanism import CONTACT_COLOUR
        labels.append(["contact force", _hex(CONTACT_COLOUR)])
    for it in items:
        if it.kind == "trace" and ("path", it.label) not in seen:
            seen.add(("path", it.label))
            labels.append([f"path of {it.label}", _hex(it.colour)])
    return labels


def _legend_row(height_px):
    """Height in pixels of a legend row: 26 in a 768-pixel picture, down to 16 in small ones."""
    return min(26.0, max(16.0, height_px / 28.0))


def _legend_width(labels, width_px, height_px=768):
    """Fraction of a panel's width taken by the legend."""
    if not labels:
        return 0.0
    row = _legend_row(height_px)
    return min(0.5, (1.0 * row + 0.5 * row * max(len(lb) for lb, _ in labels)) / float(width_px))


def _legend(pl, labels, panel_size, fill=False, row=None):
    """The legend of :func:`_legend_labels` in the upper right corner of the active panel (or filling it)."""
    if labels:
        w, h = panel_size
        row = _legend_row(h) if row is None else row
        bw, bh = (0.94 if fill else _legend_width(labels, w, h)), min(row * len(labels) / h, 0.9)
        box = pl.add_legend(labels=labels, bcolor="white", border=False, loc="upper right", size=(bw, bh),
                            face="rectangle", name="legend", background_opacity=0.75)
        box.SetPosition(1.0 - bw - 0.005, 1.0 - bh - 0.01)      # flush with the corner kept free
        box.SetPosition2(bw, bh)


def _axes(pl):
    try:
        pl.add_axes(line_width=3, color="black", labels_off=False, interactive=False)
    except Exception:                   # pragma: no cover (an orientation widget is decoration)
        pass


def _mech_png(pv, mech, entries, k, out, view, window_size):
    from . import mechanism as mx

    top = _top_reserve(window_size[1])
    items = mx.frame_items(pv, mech.frames[k], mech.motion)
    labels = _legend_labels(items)
    cam = mech.camera(pv, view, window_size, top=top, right=_legend_width(labels, *window_size))
    return _one_panel(pv, items, labels, cam, window_size, _label(_time_format(entries), entries[k][0]), out)


def _one_panel(pv, items, labels, cam, window_size, time_text, out):
    """A picture of one panel: the items under the camera, legend, axes triad, time label; to PNG."""
    pl = _plotter(pv, window_size)
    try:
        _apply_camera(pl, cam)
        _draw_items(pl, items, "item")
        _legend(pl, labels, window_size)
        _axes(pl)
        _add_time(pl, time_text)
        pl.renderer.ResetCameraClippingRange()
        _save_png(_snapshot(pl), out)
    finally:
        pl.close()
    return out


def _mech_strip(pv, mech, entries, idx, out, view, window_size, layout, fmt):
    from . import mechanism as mx

    m = len(idx)
    if layout == "overlay":
        window_size = window_size or (1024, 768)
        top = _top_reserve(window_size[1])
        items = []
        for j, k in enumerate(idx):
            frac = 0.3 + 0.7 * (j / (m - 1) if m > 1 else 1.0)
            items += mx.frame_items(pv, mech.frames[k], mech.motion, shade=frac, floor=j == 0,
                                    traces=j == m - 1)
        labels = _legend_labels(mx.frame_items(pv, mech.frames[idx[-1]], mech.motion, floor=False))
        cam = mech.camera(pv, view, window_size, top=top, right=_legend_width(labels, *window_size))
        first, last = entries[idx[0]][0], entries[idx[-1]][0]
        return _one_panel(pv, items, labels, cam, window_size,
                          f"t = {fmt.format(first)} ... {fmt.format(last)} s ({m} instants, light to dark)", out)
    # small multiples: one panel per instant, and a narrow legend panel
    labels = _legend_labels(mx.frame_items(pv, mech.frames[idx[-1]], mech.motion, floor=False))
    if window_size is None:
        window_size = (400 * m + 180, 400)
    W, H = (int(v) for v in window_size)
    row = min(24.0, max(13.0, 0.9 * H / max(len(labels), 1)))   # a legend panel: rows as large as fit
    lw = int(1.0 * row + 0.5 * row * max(len(lb) for lb, _ in labels)) + 10 if labels else 0
    lw = min(lw, W // (m + 1))
    pw = (W - lw) / m
    shape = (1, m + 1) if lw else (1, m)
    weights = [pw] * m + ([lw] if lw else [])
    pl = _plotter(pv, (W, H), shape=shape, col_weights=weights, border=True)
    try:
        cam = mech.camera(pv, view, (pw, H), top=_top_reserve(H, 26))
        for j, k in enumerate(idx):
            pl.subplot(0, j)
            pl.set_background("white")
            _apply_camera(pl, cam)
            _draw_items(pl, mx.frame_items(pv, mech.frames[k], mech.motion), f"item{j}_")
            pl.add_text(_label(fmt, entries[k][0]), position="upper_left", font_size=11, color="black",
                        name=f"time{j}", render=False)
            if j == 0:
                _axes(pl)
            pl.renderer.ResetCameraClippingRange()
        if lw:
            pl.subplot(0, m)
            pl.set_background("white")
            _legend(pl, labels, (lw, H), fill=True, row=row)
        _save_png(_snapshot(pl), out)
    finally:
        pl.close()
    return out


def _mech_animation(pv, mech, entries, sel, sink, view, size, fmt, show_progress):
    from . import mechanism as mx

    w, h = size
    labels = _legend_labels(mx.frame_items(pv, mech.frames[sel[0]], mech.motion, floor=False))
    cam = mech.camera(pv, view, (w, h), top=_top_reserve(h), right=_legend_width(labels, w, h))
    pl = _plotter(pv, (w, h))
    try:
        _apply_camera(pl, cam)
        _legend(pl, labels, (w, h))
        _axes(pl)
        names = []
        with _progress(len(sel), "render", enabled=show_progress) as bar:
            for k in sel:
                t, _ = entries[k]
                new = _draw_items(pl, mx.frame_items(pv, mech.frames[k], mech.motion), "item")
                for name in set(names) - set(new):
                    pl.remove_actor(name, render=False)
                names = new
                _add_time(pl, _label(fmt, t))
                pl.renderer.ResetCameraClippingRange()
                sink.add(_snapshot(pl))
                bar.update(1)
    finally:
        pl.close()


# ---------------------------------------------------------------------------
# public functions
# ---------------------------------------------------------------------------


def render_png(pvd, out_png, time=None, *, scalars=None, window_size=(1024, 768), view=None, trace=()):
    """Render the frame nearest to a time into a PNG picture.

    Parameters
    ----------
    pvd : str or Path
        Collection written by :class:`~femb.io.vtk.TimeSeriesWriter`.
    out_png : str or Path
        Output picture (``.png``).
    time : float, optional
        Time in s; the frame with the nearest time is drawn (default: last).
    scalars : str, optional
        Point or cell data array to colour by (default: element type).
    window_size : (int, int), default (1024, 768)
        Picture size in pixels.
    view : str, optional
        ``"3d"`` (default for 3-D data and femb mechanisms: perspective from
        azimuth −45°, elevation 26° about the up direction, −g or z; for z up
        the direction (1, −1, 0.7)), ``"iso"`` (elevation 35.3°), ``"front"``,
        ``"side"``, ``"top"``, ``"azimuth,elevation"`` in degrees,
        ``"plane"`` (default for planar mechanisms written by femb: straight
        onto the plane z = 0, −g pointing down), or ``"xy"`` (default for other
        planar data), ``"xz"``, ``"yz"``: parallel views along a coordinate axis.
    trace : sequence of str, optional
        Paths to draw over the whole motion: ``"body"`` (its centre of mass)
        or ``"body:point"`` (a named point), for 3-D mechanisms written by
        femb.

    Returns
    -------
    Path
        ``out_png``.

    Raises
    ------
    OutputError
        Missing or empty collection, unknown suffix, unknown ``scalars``,
        view or traced body or point, or no off-screen rendering on this
        machine (see :func:`can_render`).
    """
    out, _ = _check_suffix(out_png, (".png",), "out_png")
    entries = _entries(pvd)
    _require_render()
    import pyvista as pv

    scan = _Scan(pv, entries, scalars)
    view = _check_view(view, scan)
    k = _nearest(entries, time)
    t, path = entries[k]
    mech = _mechanism(pv, entries, scan, scalars, view, trace)
    if mech is not None:
        return _mech_png(pv, mech, entries, k, out, view, window_size)
    pl = _plotter(pv, window_size)
    try:
        _fit_camera(pl, scan, view, window_size[0] / window_size[1],
                    right=_BAR if scalars else 0.0, top=_top_reserve(window_size[1]))
        _add_frame(pv, pl, _read(pv, path), scan, scalars, name="frame")
        _add_time(pl, _label(_time_format(entries), t))
        _save_png(_snapshot(pl), out)
    finally:
        pl.close()
    return out


def render_strip(
    pvd,
    out_png,
    n=6,
    *,
    times=None,
    layout="row",
    scalars=None,
    window_size=None,
    view=None,
    trace=(),
):
    """Render several instants of the motion in one picture.

    Parameters
    ----------
    pvd : str or Path
        Collection written by :class:`~femb.io.vtk.TimeSeriesWriter`.
    out_png : str or Path
        Output picture (``.png``).
    n : int, default 6
        Number of instants, evenly spaced over the frames (first and last
        included); ignored when ``times`` is given.
    times : sequence of float, optional
        Instants in s; the nearest frame of each is drawn.
    layout : {"row", "overlay"}, default "row"
        ``"row"``: small multiples, one panel per instant side by side, same
        fixed camera, each with its time label (for a 3-D mechanism a last
        narrow panel holds the legend of the bodies and joints).
        ``"overlay"``: all instants in one view, from light (early) to dark
        (late), later ones drawn on top (motion snapshots as in a paper
        figure); a planar series gets a legend of the times.
    scalars : str, optional
        Colour by this array instead (overlay: fixed colour range, times
        listed in the label).
    window_size : (int, int), optional
        Picture size; default (1024, 768) for overlay, (360 n, 360) for row
        (3-D mechanisms: (400 n + 180, 400)).
    view : str, optional
        As for :func:`render_png`.
    trace : sequence of str, optional
        Paths of points, as for :func:`render_png` (drawn whole in every panel,
        with the point's position at each panel's instant).

    Returns
    -------
    Path
        ``out_png``.
    """
    out, _ = _check_suffix(out_png, (".png",), "out_png")
    if layout not in ("overlay", "row"):
        raise OutputError(f"layout={layout!r}: expected 'overlay' or 'row'")
    entries = _entries(pvd)
    if times is not None:
        idx = [_nearest(entries, t) for t in times]
        if not idx:
            raise OutputError("times=[]: give at least one instant")
    else:
        if int(n) < 1:
            raise OutputError(f"n={n!r}: expected at least 1 instant")
        idx = np.unique(np.linspace(0, len(entries) - 1, int(n)).round().astype(int)).tolist()
    _require_render()
    import pyvista as pv

    scan = _Scan(pv, entries, scalars)
    view = _check_view(view, scan)
    fmt = _time_format(entries)
    m = len(idx)
    mech = _mechanism(pv, entries, scan, scalars, view, trace)
    if mech is not None:
        return _mech_strip(pv, mech, entries, idx, out, view, window_size, layout, fmt)
    if window_size is None:
        window_size = (1024, 768) if layout == "overlay" else (360 * m, 360)
    if layout == "row":
        pl = _plotter(pv, window_size, shape=(1, m))
        aspect = (window_size[0] / m) / window_size[1]
        try:
            for j, k in enumerate(idx):
                pl.subplot(0, j)
                pl.set_background("white")
                _fit_camera(pl, scan, view, aspect, right=_BAR if scalars else 0.0,
                            top=_top_reserve(window_size[1], 24))
                _add_frame(pv, pl, _read(pv, entries[k][1]), scan, scalars, name=f"frame{j}")
                pl.add_text(_label(fmt, entries[k][0]), position="upper_left",
                            font_size=10, color="black", name=f"time{j}", render=False)
            _save_png(_snapshot(pl), out)
        finally:
            pl.close()
        return out

    import matplotlib

    cmap = matplotlib.colormaps["Blues"]
    pl = _plotter(pv, window_size)
    try:
        _fit_camera(pl, scan, view, window_size[0] / window_size[1],
                    right=_BAR if scalars else _LEGEND, top=_top_reserve(window_size[1]))
        axis = {"xy": 2, "xz": 1, "yz": 0}.get(view)
        sign = -1.0 if view == "xz" else 1.0
        for j, k in enumerate(idx):
            mesh = _read(pv, entries[k][1])
            if axis is not None and mesh.n_points:
                # lift later instants towards the camera so they are drawn on top
                pts = np.array(mesh.points, dtype=float)
                pts[:, axis] += sign * 1e-3 * scan.size * j
                mesh.points = pts
            if scalars is None:
                frac = 0.35 + 0.65 * (j / (m - 1) if m > 1 else 1.0)
                color = tuple(float(c) for c in cmap(frac)[:3])
                _add_frame(pv, pl, mesh, scan, None, name=f"frame{j}", color=color,
                           legend=_label(fmt, entries[k][0]))
            else:
                _add_frame(pv, pl, mesh, scan, scalars, name=f"frame{j}")
        if scalars is None:
            pl.add_legend(bcolor="white", border=False, loc="upper right",
                          size=(_LEGEND - 0.03, min(0.05 * m, 0.8)), face="rectangle")
        else:
            first, last = entries[idx[0]][0], entries[idx[-1]][0]
            _add_time(pl, f"t = {fmt.format(first)} ... {fmt.format(last)} s ({m} instants)")
        _save_png(_snapshot(pl), out)
    finally:
        pl.close()
    return out


def render_animation(
    pvd,
    out,
    *,
    fps=20,
    every=1,
    max_frames=None,
    scalars=None,
    window_size=(800, 600),
    view=None,
    show_progress=False,
    trace=(),
):
    """Render the motion as an animated GIF or an MP4 video.

    Parameters
    ----------
    pvd : str or Path
        Collection written by :class:`~femb.io.vtk.TimeSeriesWriter`.
    out : str or Path
        Output file, ``.gif`` (always available) or ``.mp4`` (needs an ffmpeg
        writer: ``pip install imageio-ffmpeg``).
    fps : float, default 20
        Frames per second of the result. GIF stores delays in hundredths of a
        second, so its rate is rounded to 100 / round(100 / fps).
    every : int, default 1
        Use every ``every``-th frame of the collection.
    max_frames : int, optional
        At most this many frames, evenly spaced over the (thinned) series
        (first and last kept).
    scalars : str, optional
        Point or cell data array to colour by (default: element type).
    window_size : (int, int), default (800, 600)
        Picture size in pixels (rounded up to even numbers for MP4).
    view : str, optional
        As for :func:`render_png`.
    show_progress : bool, default False
        Report progress on stderr.
    trace : sequence of str, optional
        Paths of points, as for :func:`render_png` (the whole path, and the
        point at each frame's instant).

    Returns
    -------
    Path
        ``out``.

    Notes
    -----
    Frames are encoded as they are rendered and then dropped: memory does
    not grow with the number of frames (GIF frames are quantised to a
    256-colour palette each).
    """
    out, suf = _check_suffix(out, (".gif", ".mp4"), "out")
    if not fps or fps <= 0:
        raise OutputError(f"fps={fps!r}: expected a positive number")
    if not isinstance(every, (int, np.integer)) or every < 1:
        raise OutputError(f"every={every!r}: expected a positive integer")
    if max_frames is not None and int(max_frames) < 1:
        raise OutputError(f"max_frames={max_frames!r}: expected a positive integer")
    entries = _entries(pvd)
    sel = list(range(0, len(entries), int(every)))
    if max_frames is not None and len(sel) > int(max_frames):
        pick = np.unique(np.linspace(0, len(sel) - 1, int(max_frames)).round().astype(int))
        sel = [sel[i] for i in pick]
    w, h = (int(v) for v in window_size)
    if suf == ".mp4":
        w, h = w + w % 2, h + h % 2
        sink = _Mp4Sink(out, (w, h), fps)  # fails early when no ffmpeg writer
    else:
        sink = _GifSink(out, fps)
    try:
        _require_render()
        import pyvista as pv

        scan = _Scan(pv, entries, scalars)
        v = _check_view(view, scan)
        fmt = _time_format(entries)
        mech = _mechanism(pv, entries, scan, scalars, v, trace)
        if mech is not None:
            _mech_animation(pv, mech, entries, sel, sink, v, (w, h), fmt, show_progress)
        else:
            pl = _plotter(pv, (w, h))
            try:
                _fit_camera(pl, scan, v, w / h, right=_BAR if scalars else 0.0,
                            top=_top_reserve(h))
                with _progress(len(sel), "render", enabled=show_progress) as bar:
                    for k in sel:
                        t, path = entries[k]
                        _add_frame(pv, pl, _read(pv, path), scan, scalars, name="frame")
                        _add_time(pl, _label(fmt, t))
                        sink.add(_snapshot(pl))
                        bar.update(1)
            finally:
                pl.close()
    except OSError as exc:              # a full disk while frames stream to the file
        sink.abort()
        raise OutputError(f"{out}: writing the animation failed after {sink.count} frames "
                          f"({exc.strerror or exc}); {'the earlier file is unchanged' if out.exists() else 'nothing was written'}") from exc
    except BaseException:
        sink.abort()
        raise
    try:
        sink.close()
    except OSError as exc:
        sink.abort()
        raise OutputError(f"{out}: finishing the animation failed ({exc.strerror or exc}); "
                          f"{'the earlier file is unchanged' if out.exists() else 'nothing was written'}") from exc
    return out


# ---------------------------------------------------------------------------
# encoders
# ---------------------------------------------------------------------------


def _save_png(img, out):
    from PIL import Image

    tmp = out.with_name(f".{out.name}.{os.getpid()}.tmp")
    try:
        Image.fromarray(img).save(tmp, format="PNG")
        os.replace(tmp, out)
    except OSError as exc:
        raise OutputError(f"{out}: cannot write the picture ({exc.strerror or exc}); "
                          f"{'the earlier file is unchanged' if out.exists() else 'nothing was written'}") from exc
    finally:
        if tmp.exists():
            tmp.unlink()


class _GifSink:
    """Write GIF frames to disk as they come (one local palette per frame)."""

    def __init__(self, path, fps):
        self.path = Path(path)
        self.tmp = self.path.with_name(f".{self.path.name}.{os.getpid()}.tmp")
        self.delay_ms = 10 * max(1, round(100.0 / fps))
        self.f = None
        self.count = 0

    def add(self, rgb):
        from PIL import GifImagePlugin, Image

        # the fast octree quantiser: ~5 ms per 800 x 600 frame, visually exact
        # for flat-shaded drawings (median cut is ~5x slower)
        im = Image.fromarray(rgb).quantize(
            colors=256, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE
        )
        if self.f is None:
            self.f = open(self.tmp, "wb")
            header, _ = GifImagePlugin.getheader(im, info={"loop": 0})
            for part in header:
                self.f.write(part)
            self.size = im.size
        elif im.size != self.size:
            raise OutputError(f"{self.path}: frame size changed from {self.size} to {im.size}")
        for part in GifImagePlugin.getdata(im, duration=self.delay_ms, include_color_table=True):
            self.f.write(part)
        self.count += 1

    def close(self):
        if self.f is None:
            raise OutputError(f"{self.path}: no frame to write")
        self.f.write(b";")
        self.f.close()
        os.replace(self.tmp, self.path)

    def abort(self):
        if self.f is not None:
            self.f.close()
        if self.tmp.exists():
            self.tmp.unlink()


class _Mp4Sink:
    """Stream frames to ffmpeg (H.264, yuv420p) through imageio-ffmpeg."""

    def __init__(self, path, size, fps):
        try:
            import imageio_ffmpeg
        except ImportError:
            raise OutputError(
                f"{path}: MP4 output needs an ffmpeg writer, which is not installed; "
                "enable it with `pip install imageio-ffmpeg` (it ships an ffmpeg "
                "binary), or write a .gif instead"
            ) from None
        try:
            imageio_ffmpeg.get_ffmpeg_exe()
        except Exception as exc:
            raise OutputError(
                f"{path}: MP4 output needs an ffmpeg executable ({exc}); reinstall "
                "imageio-ffmpeg or set IMAGEIO_FFMPEG_EXE, or write a .gif instead"
            ) from exc
        self.path = Path(path)
        self.tmp = self.path.with_name(f".{self.path.stem}.{os.getpid()}.tmp.mp4")
        self.size = size
        self.gen = imageio_ffmpeg.write_frames(
            str(self.tmp), size, fps=fps, codec="libx264", pix_fmt_in="rgb24",
            pix_fmt_out="yuv420p", quality=7, macro_block_size=2,
        )
        self.gen.send(None)
        self.count = 0

    def add(self, rgb):
        h, w = rgb.shape[:2]
        if (w, h) != tuple(self.size):
            raise OutputError(f"{self.path}: frame size {w}x{h} differs from {self.size}")
        self.gen.send(np.ascontiguousarray(rgb, dtype=np.uint8).tobytes())
        self.count += 1

    def close(self):
        if self.count == 0:
            self.abort()
            raise OutputError(f"{self.path}: no frame to write")
        self.gen.close()
        os.replace(self.tmp, self.path)

    def abort(self):
        try:
            self.gen.close()
        except Exception:
            pass
        if self.tmp.exists():
            self.tmp.unlink()
