"""Sphinx extension: one autodoc page per module of the femb package.

The modules are found by walking the packages (``femb``, ``femb.io``,
``femb.elements``, ``femb.benchmarks`` ...), so a module added to the engine
(e.g. compiled kernels) gets its page without an edit to the documentation.
Private modules (``_name``) are skipped. The pages and the table of contents
``api_toc.inc`` are written to ``_generated/`` (git-ignored).
"""
from __future__ import annotations

import importlib
import pkgutil
from pathlib import Path

#: (package, section title, one-line description) in the order of the reference.
GROUPS = [
    ("femb", "Core", "Mechanism, model, assembly, solver, results, errors."),
    ("femb.elements", "Elements", "The element library (see also the element catalogue)."),
    ("femb.io", "Output", "VTK time series, pictures, animations, progress."),
    ("femb.benchmarks", "Benchmarks", "Benchmark scenes, the scene registry and the benchmark suite."),
    ("femb.benchmarks.references", "Independent references", "Reference solutions the benchmarks compare to."),
]


def package_modules(package):
    """Public modules of one package (the package itself first), sorted by name."""
    pkg = importlib.import_module(package)
    names = [package]
    for info in pkgutil.iter_modules(pkg.__path__):
        if info.name.startswith("_") or info.ispkg:
            continue
        names.append(f"{package}.{info.name}")
    return [names[0]] + sorted(names[1:])


def _write(path, text):
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.exists() or path.read_text(encoding="utf-8") != text:
        path.write_text(text, encoding="utf-8")


def generate(srcdir):
    out = Path(srcdir) / "_generated"
    toc = []
    written = set()
    for package, title, blurb in GROUPS:
        toc += [title, "-" * len(title), "", blurb, "", ".. toctree::", "   :maxdepth: 1", ""]
        for mod in package_modules(package):
            page = out / "api" / f"{mod}.rst"
            heading = f"``{mod}``"
            _write(page, f"{heading}\n{'=' * len(heading)}\n\n.. automodule:: {mod}\n   :ignore-module-all:\n")
            written.add(page.name)
            toc.append(f"   _generated/api/{mod}")
        toc.append("")
    for stale in (out / "api").glob("*.rst"):       # a module that was removed
        if stale.name not in written:
            stale.unlink()
    _write(out / "api_toc.inc", "\n".join(toc) + "\n")


def _on_builder_inited(app):
    generate(app.srcdir)


def setup(app):
    app.connect("builder-inited", _on_builder_inited)
    return {"version": "1.0", "parallel_read_safe": True, "parallel_write_safe": True}
