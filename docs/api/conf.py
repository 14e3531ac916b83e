"""Sphinx configuration of femb's API reference and element catalogue.

Build (from the repository root, after ``pip install -e ".[docs]"``)::

    python -m sphinx -W --keep-going -b html docs/api docs/api/_build

During the build three local extensions (``_ext/``) generate, into the
git-ignored folder ``_generated/``:

* ``femb_apipages``: one autodoc page per module of the ``femb`` package
  (found by walking the package, so new modules appear without edits here);
* ``femb_catalogue``: a picture of every element type, rendered off-screen by
  :func:`femb.io.render.render_png` from a tiny mechanism simulated by femb;
* ``femb_examples``: runs the README's example and every script in
  ``examples/``; the build fails when one of them fails.
"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "_ext"))

import femb  # noqa: E402  (the installed package; its version goes on every page)

project = "femb"
author = "the femb authors"
copyright = "femb authors"
version = release = femb.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
    "femb_apipages",
    "femb_catalogue",
    "femb_examples",
]

root_doc = "index"
source_suffix = {".rst": "restructuredtext"}
exclude_patterns = ["_build", "examples", "_ext"]
templates_path = []

# autodoc: members in source order, only members defined in the module itself
# (re-exports such as femb.Mechanism are documented once, where they are defined)
autodoc_default_options = {"members": True, "member-order": "bysource", "show-inheritance": True}
autodoc_typehints = "none"
autoclass_content = "class"

# numpydoc renders the Parameters/Returns sections; autodoc lists the members
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

html_theme = "alabaster"
html_static_path = []
html_title = f"femb {release}"


def _escape_bars(app, what, name, obj, options, lines):
    """Docstrings write norms and absolute values as |x| (math, not reST substitutions):
    escape every bar that is not part of a table line."""
    for i, line in enumerate(lines):
        s = line.lstrip()
        if "|" in line and not (s.startswith("|") or s.startswith("+")):
            lines[i] = line.replace("\\|", "|").replace("|", "\\|")


def setup(app):
    app.connect("autodoc-process-docstring", _escape_bars)
    return {"parallel_read_safe": True}
