"""The documentation sources: generated API pages, catalogue coverage, notes on the site (no Sphinx build).

The full build (``python -m sphinx -W --keep-going -b html docs docs/_build/html``,
the last step of ``.ci/run``) renders the catalogue and runs the gallery;
``tests/test_docs_site.py`` checks the built site. These fast checks catch the
common breakages without a build. They need the ``docs`` extra.
"""
import importlib
import shutil
import sys
from pathlib import Path

import pytest

pytest.importorskip("sphinx")

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs" / "_ext"))


def test_api_pages_public_first_internal_apart(tmp_path):
    apipages = importlib.import_module("femb_apipages")
    apipages.generate(tmp_path)
    pages = {p.stem for p in (tmp_path / "_generated" / "api").glob("*.rst")}
    for mod in ("femb", "femb.solve.solver", "femb.results.result", "femb.io.vtk", "femb.io.render", "femb.elements.joints",
                "femb.elements.beam", "femb.study.registry", "femb.engine.loop", "femb.base.jit"):
        assert mod in pages
    assert not any(part.startswith("_") for p in pages for part in p.split("."))   # private modules skipped
    public = (tmp_path / "_generated" / "api_public.inc").read_text()
    internal = (tmp_path / "_generated" / "api_internal.inc").read_text()
    bench = (tmp_path / "_generated" / "api_benchmarks.inc").read_text()
    tocs = public + internal + bench
    assert all(f"_generated/api/{p}\n" in tocs for p in pages)                   # every page in one list
    assert all(tocs.count(f"_generated/api/{p}\n") == 1 for p in pages)          # ... and only one
    assert "femb.solve.solver\n" in public and "femb.base.jit\n" in internal and "femb.benchmarks.scenes.planar.andrews\n" in bench
    assert "femb.benchmarks" not in public and "femb.console.cli_common" not in public
    text = (tmp_path / "_generated" / "api" / "femb.solve.solver.rst").read_text()
    assert ".. automodule:: femb.solve.solver" in text


def test_every_note_is_on_the_site(tmp_path):
    """A Markdown note of docs/ that no table of contents names is listed under More notes."""
    notes = importlib.import_module("femb_notes")
    docs = ROOT / "docs"
    named = notes.named_in_toctrees(docs)
    for page in ("method", "spatial", "beams", "stepsize", "linearize", "contact", "engine", "kernels", "sweep",
                 "conventions", "benchmarks", "benchmark-suite", "bench-report/report", "theory/statics",
                 "start/install", "guide/cache"):
        assert page in named, page
    shutil.copytree(docs, tmp_path / "docs", ignore=shutil.ignore_patterns("_build", "auto_gallery", "_generated"))
    (tmp_path / "docs" / "new-note.md").write_text("# A new note\n")
    assert notes.generate(tmp_path / "docs") == ["new-note"]
    assert "/new-note" in (tmp_path / "docs" / "_generated" / "more_notes.md").read_text()
    assert "{toctree}" in (tmp_path / "docs" / "_generated" / "viewer_slot.md").read_text()   # docs/view.md exists
    (tmp_path / "docs" / "view.md").unlink()                                  # without it: a sentence, no link
    notes.generate(tmp_path / "docs")
    assert "{toctree}" not in (tmp_path / "docs" / "_generated" / "viewer_slot.md").read_text()
    (tmp_path / "docs" / "view.md").write_text("# femb view\n")
    notes.generate(tmp_path / "docs")
    assert "{toctree}" in (tmp_path / "docs" / "_generated" / "viewer_slot.md").read_text()


def test_no_note_points_outside_the_repository():
    for path in list((ROOT / "docs").rglob("*.md")) + list((ROOT / "docs").rglob("*.rst")) + [ROOT / "README.md"]:
        if "_build" in path.parts or "auto_gallery" in path.parts:
            continue
        assert "../shared/" not in path.read_text(encoding="utf-8"), path


def test_catalogue_has_an_entry_for_every_element_type():
    catalogue = importlib.import_module("femb_catalogue")
    covered = {c for e in catalogue.ENTRIES for c in e.classes}
    types = catalogue.element_types()
    assert "femb.elements.joints.Hinge" in types and "femb.elements.beam.Clamp" in types
    assert {"femb.elements.spatial_joints.UniversalJoint", "femb.elements.spatial_forces.Bushing",
            "femb.elements.spatial_bodies.SpatialRigidBody"} <= types           # the spatial element types too
    assert {"femb.elements.spatial_beam.SpatialBeam", "femb.elements.rolling.RollingDisc",
            "femb.elements.contact.SphereOnPlane"} <= types                      # beams, rolling, contact
    assert types <= covered, sorted(types - covered)
    for e in catalogue.ENTRIES:                      # each tiny mechanism compiles
        e.build().compile()
