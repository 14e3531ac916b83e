"""Sphinx extension: the API reference, public API first, internal modules apart.

One autodoc page per module is written to ``_generated/api/`` (git-ignored). The
modules are found by walking the packages (``femb``, ``femb.engine``, ``femb.io``,
``femb.contact``, ``femb.elements``, ``femb.benchmarks`` ...), so a module added
later gets its page without an edit here. :data:`PUBLIC` names the modules of the
public API, in reading order; every other module of ``femb`` goes to the internal
section (``_generated/api_internal.inc``), and the benchmark modules to a page of
their own (``_generated/api_benchmarks.inc``). Private modules (``_name``) are skipped.
"""
from __future__ import annotations

import importlib
import pkgutil
from pathlib import Path

#: (section title, one-line description, modules) of the public API, in reading order.
PUBLIC = [
    ("Build, run, read", "The objects of every script: a mechanism, its compiled model, the time "
     "integration and its result.",
     ["femb", "femb.system.mechanism", "femb.system.model", "femb.solve.solver", "femb.results.result", "femb.errors", "femb.base.functions"]),
    ("Statics, modes, linearization, sweeps", "Analyses of a compiled model besides time integration.",
     ["femb.analysis.static", "femb.analysis.modal", "femb.analysis.linearize", "femb.study.sweep", "femb.contact", "femb.results.energy",
      "femb.analysis.checks", "femb.system.initial", "femb.system.motion"]),
    ("Elements", "The element library (pictured in the element catalogue).",
     ["femb.elements", "femb.elements.bodies", "femb.elements.joints", "femb.elements.forces",
      "femb.elements.beam", "femb.elements.spatial_bodies", "femb.elements.spatial_joints",
      "femb.elements.spatial_forces", "femb.elements.spatial_beam", "femb.elements.rolling",
      "femb.elements.contact"]),
    ("Output", "ParaView time series, pictures and animations, output channels.",
     ["femb.io", "femb.io.vtk", "femb.io.render", "femb.results.channels"]),
]

#: packages walked for the internal section, and the benchmark packages (a page of their own).
INTERNAL_PACKAGES = ['femb', 'femb.base', 'femb.engine', 'femb.system', 'femb.elements', 'femb.io', 'femb.results', 'femb.solve', 'femb.analysis', 'femb.study', 'femb.console', 'femb.contact']
BENCHMARK_PACKAGES = ['femb.benchmarks', 'femb.benchmarks.scenes.planar', 'femb.benchmarks.scenes.spatial', 'femb.benchmarks.scenes.beams', 'femb.benchmarks.scenes.contact', 'femb.benchmarks.references', 'femb.benchmarks.accuracy', 'femb.benchmarks.cost', 'femb.benchmarks.runners']


def package_modules(package):
    """Public modules of one package (the package itself first, then its modules sorted by name)."""
    pkg = importlib.import_module(package)
    names = []
    for info in pkgutil.iter_modules(pkg.__path__):
        if info.name.startswith("_") or info.ispkg:
            continue
        names.append(f"{package}.{info.name}")
    return [package] + sorted(names)


def _write(path, text):
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.exists() or path.read_text(encoding="utf-8") != text:
        path.write_text(text, encoding="utf-8")


def _toc(title, blurb, modules):
    lines = [title, "-" * len(title), "", blurb, "", ".. toctree::", "   :maxdepth: 1", ""]
    return lines + [f"   /_generated/api/{m}" for m in modules] + [""]


def sections():
    """``(public, internal, benchmarks)``: lists of ``(title, blurb, modules)``."""
    public_mods = {m for _, _, mods in PUBLIC for m in mods}
    internal = []
    for package in INTERNAL_PACKAGES:
        mods = [m for m in package_modules(package) if m not in public_mods]
        if mods:
            internal.append((f"``{package}``", f"Modules of ``{package}`` below the public API.", mods))
    bench = [(f"``{p}``", "Scenes, studies and their reference solutions.", package_modules(p))
             for p in BENCHMARK_PACKAGES]
    return PUBLIC, internal, bench


def generate(srcdir):
    out = Path(srcdir) / "_generated"
    written = set()
    for name, groups in zip(("api_public.inc", "api_internal.inc", "api_benchmarks.inc"), sections()):
        toc = []
        for title, blurb, modules in groups:
            toc += _toc(title, blurb, modules)
            for mod in modules:
                page = out / "api" / f"{mod}.rst"
                heading = f"``{mod}``"
                _write(page, f"{heading}\n{'=' * len(heading)}\n\n.. automodule:: {mod}\n   :ignore-module-all:\n")
                written.add(page.name)
        _write(out / name, "\n".join(toc) + "\n")
    for stale in (out / "api").glob("*.rst"):       # a module that was removed
        if stale.name not in written:
            stale.unlink()


def _on_builder_inited(app):
    generate(app.srcdir)


def setup(app):
    app.connect("builder-inited", _on_builder_inited)
    return {"version": "1.0", "parallel_read_safe": True, "parallel_write_safe": True}
