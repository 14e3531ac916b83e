"""The documentation sources: generated API pages, catalogue coverage, README example (no Sphinx build).

The full build (``python -m sphinx -W --keep-going -b html docs/api docs/api/_build``,
the last step of ``.ci/run``) renders the catalogue and runs the examples; these
fast checks catch the common breakages without it. They need the ``docs`` extra.
"""
import importlib
import sys
from pathlib import Path

import pytest

pytest.importorskip("sphinx")

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs" / "api" / "_ext"))


def test_api_pages_cover_every_public_module(tmp_path):
    apipages = importlib.import_module("femb_apipages")
    apipages.generate(tmp_path)
    pages = {p.stem for p in (tmp_path / "_generated" / "api").glob("*.rst")}
    for mod in ("femb", "femb.solver", "femb.result", "femb.io.vtk", "femb.io.render", "femb.elements.joints",
                "femb.elements.beam", "femb.benchmarks.registry"):
        assert mod in pages
    assert not any(part.startswith("_") for p in pages for part in p.split("."))   # private modules skipped
    toc = (tmp_path / "_generated" / "api_toc.inc").read_text()
    assert all(f"_generated/api/{p}" in toc for p in pages)
    text = (tmp_path / "_generated" / "api" / "femb.solver.rst").read_text()
    assert ".. automodule:: femb.solver" in text


def test_catalogue_has_an_entry_for_every_element_type():
    catalogue = importlib.import_module("femb_catalogue")
    covered = {c for e in catalogue.ENTRIES for c in e.classes}
    types = catalogue.element_types()
    assert "femb.elements.joints.Hinge" in types and "femb.elements.beam.Clamp" in types
    assert {"femb.elements.spatial_joints.UniversalJoint", "femb.elements.spatial_forces.Bushing",
            "femb.elements.spatial_bodies.SpatialRigidBody"} <= types           # the spatial element types too
    assert types <= covered, sorted(types - covered)
    for e in catalogue.ENTRIES:                      # each tiny mechanism compiles
        e.build().compile()


def test_readme_example_is_found():
    examples = importlib.import_module("femb_examples")
    src = examples.readme_example(ROOT / "README.md")
    assert 'femb.Mechanism("pendulum")' in src and "femb.simulate(" in src
    compile(src, "README.md", "exec")


def test_a_failing_example_fails_the_build(tmp_path):
    from sphinx.errors import ExtensionError

    examples = importlib.import_module("femb_examples")
    assert examples.run("ok", "print('fine')", tmp_path / "ok") == "fine\n"
    with pytest.raises(ExtensionError, match=r"(?s)example .bad. failed .exit status 1.*ZeroDivisionError"):
        examples.run("bad", "print('before')\n1 / 0\n", tmp_path / "bad")
