"""Sphinx configuration of femb's documentation site.

Build (from the repository root, after ``pip install -e ".[docs]"``)::

    python -m sphinx -W --keep-going -b html docs docs/_build/html

The site is made of the Markdown notes in ``docs/`` (read by MyST, equations
rendered by MathJax), the gallery (``docs/gallery/*.py``, run by
sphinx-gallery during the build), the element catalogue and the API
reference. Local extensions (``_ext/``) generate, into the git-ignored folder
``_generated/``:

* ``femb_apipages``: the API reference, public API first, internal modules in
  a separate section (found by walking the packages, so new modules appear
  without edits here);
* ``femb_catalogue``: a picture of every element type, rendered off-screen by
  :func:`femb.io.render.render_png` from a tiny mechanism simulated by femb;
* ``femb_notes``: Markdown notes of ``docs/`` that no table of contents names
  yet (a new method note) are listed under Theory instead of failing the build.
"""
import os
import re
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "_ext"))
os.environ.setdefault("FEMB_BACKGROUND_BUILD", "0")     # no background compile while the docs build
os.environ.setdefault("FEMB_PROGRESS", "0")

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
    "myst_parser",
    "sphinx_gallery.gen_gallery",
    "femb_apipages",
    "femb_catalogue",
    "femb_notes",
]

root_doc = "index"
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "_ext", "gallery", "_generated/*.md", "figures/README.md", "**.ipynb_checkpoints",
                    "auto_gallery/*.md5", "auto_gallery/*.py", "auto_gallery/*.ipynb",
                    "auto_gallery/*.codeobj.json", "auto_gallery/*.zip"]
templates_path = []

# MyST: $...$ and $$...$$ math, amsmath environments, ::: fences, anchors for section links
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 4
myst_dmath_double_inline = True

# autodoc: members in source order, only members defined in the module itself
# (re-exports such as femb.Mechanism are documented once, where they are defined)
autodoc_default_options = {"members": True, "member-order": "bysource", "show-inheritance": True}
autodoc_typehints = "none"
autoclass_content = "class"

# numpydoc renders the Parameters/Returns sections; autodoc lists the members
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

# the gallery: every script runs during the build; its last figure is its thumbnail
sphinx_gallery_conf = {
    "examples_dirs": ["gallery"],
    "gallery_dirs": ["auto_gallery"],
    "filename_pattern": r"\.py$",          # run every example, not only plot_*.py
    "abort_on_example_error": True,
    "only_warn_on_example_error": False,
    "download_all_examples": True,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "image_scrapers": ("matplotlib",),
    "matplotlib_animations": False,
    "show_memory": False,
    "reset_modules": ("matplotlib",),
    "min_reported_time": 1,
}

html_theme = "pydata_sphinx_theme"
html_title = f"femb {release}"
html_static_path = []
html_theme_options = {
    "navbar_align": "left",
    "show_toc_level": 2,
    "navigation_with_keys": False,
    "header_links_before_dropdown": 8,
    "secondary_sidebar_items": ["page-toc", "sourcelink"],
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version", "theme-version"],
}
html_sidebars = {"index": []}


def _escape_bars(app, what, name, obj, options, lines):
    """Docstrings write norms and absolute values as |x| (math, not reST substitutions):
    escape every bar that is not part of a table line."""
    for i, line in enumerate(lines):
        s = line.lstrip()
        if "|" in line and not (s.startswith("|") or s.startswith("+")):
            lines[i] = line.replace("\\|", "|").replace("|", "\\|")


_HTML_ANCHOR = re.compile(r'^<a id="([A-Za-z][\w-]*)"></a>\s*$', re.M)


def _html_anchors(app, docname, source):
    """Markdown notes mark link targets with ``<a id="name"></a>`` (GitHub renders them);
    MyST needs ``(name)=`` to resolve ``[text](#name)``."""
    if app.env.doc2path(docname).suffix == ".md":
        source[0] = _HTML_ANCHOR.sub(r"(\1)=", source[0])


def _drop_sourceless_modules(app):
    """viewcode's index lists every module it looked at, also those without Python source
    (``builtins`` for a compiled function), and links them to pages it never writes."""
    modules = getattr(app.env, "_viewcode_modules", {})
    for name in [n for n, entry in modules.items() if entry is False]:
        del modules[name]
    return []


def setup(app):
    app.connect("autodoc-process-docstring", _escape_bars)
    app.connect("source-read", _html_anchors)
    app.connect("html-collect-pages", _drop_sourceless_modules, priority=400)
    return {"parallel_read_safe": True}
