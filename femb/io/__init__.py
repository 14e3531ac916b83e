"""Output layer: VTK time series, pictures, animations, output channels and progress reports.

This is the only layer that imports meshio or pyvista. The public names are
loaded on first use, so ``import femb.io`` costs nothing; meshio is imported
with :mod:`femb.io.vtk`, and pyvista only inside the rendering functions of
:mod:`femb.io.render` (so writing files never needs OpenGL or a display).

Public names
------------
OutputError, merge_blocks, write_vtu, TimeSeriesWriter, read_pvd, read_frame
    from :mod:`femb.io.vtk`
can_render, render_png, render_strip, render_animation, picture_scene
    from :mod:`femb.io.render` (what a picture of a mechanism shows:
    :mod:`femb.io.mechanism`)
OutputChannels
    re-exported from :mod:`femb.results.channels` (named outputs to CSV or Parquet during a run)
progress
    from :mod:`femb.io.progress`
model_blocks, scene_field_data, VTKStream, write_vtk, write_vtk_stream
    from :mod:`femb.io.frames` (elements → frames, streaming during a run)
"""
from __future__ import annotations

import importlib

# Imported eagerly (it is light): the function must shadow the submodule of
# the same name, which any import of femb.io.progress would bind here.
from .progress import progress  # noqa: F401

_EXPORTS = {
    "OutputError": "vtk",
    "merge_blocks": "vtk",
    "write_vtu": "vtk",
    "TimeSeriesWriter": "vtk",
    "read_pvd": "vtk",
    "read_frame": "vtk",
    "can_render": "render",
    "render_png": "render",
    "render_strip": "render",
    "render_animation": "render",
    "picture_scene": "render",
    "model_blocks": "frames",
    "scene_field_data": "frames",
    "VTKStream": "frames",
    "write_vtk": "frames",
    "write_vtk_stream": "frames",
    "OutputChannels": "femb.results.channels",
}

__all__ = sorted([*_EXPORTS, "progress"])


def __getattr__(name):
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'femb.io' has no attribute {name!r}")
    value = getattr(importlib.import_module(module if module.startswith("femb.") else f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))
