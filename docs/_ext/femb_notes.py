"""Sphinx extension: Markdown notes that no table of contents names yet, and the viewer slot.

The method notes live as Markdown in ``docs/`` and are placed in the site by the
tables of contents of ``index.md``, ``start/``, ``guide/``, ``theory/`` and
``bench/``. A note added to ``docs/`` later (by a change that does not edit those
pages) would fail the ``-W`` build as "not included in any toctree"; this extension
lists such notes under Theory → "More notes" instead (``_generated/more_notes.md``).

It also writes ``_generated/viewer_slot.md``: the link to ``docs/view.md`` (the
browser viewer, ``femb view``) when that page exists, a plain sentence otherwise.
"""
from __future__ import annotations

import re
from pathlib import Path

_TOCTREE = re.compile(r"```\{toctree\}(.*?)```", re.S)


def _write(path, text):
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.exists() or path.read_text(encoding="utf-8") != text:
        path.write_text(text, encoding="utf-8")


def named_in_toctrees(srcdir):
    """Docnames (``"method"``, ``"guide/run"``) named by a toctree of a Markdown page of the site."""
    srcdir = Path(srcdir)
    names = set()
    for page in srcdir.rglob("*.md"):
        rel = page.relative_to(srcdir)
        if rel.parts[0].startswith("_") or rel.parts[0] in ("gallery", "auto_gallery"):
            continue
        for block in _TOCTREE.findall(page.read_text(encoding="utf-8")):
            for line in block.splitlines():
                line = line.strip()
                if not line or line.startswith(":"):
                    continue
                target = line.split("<")[-1].rstrip(">").strip() if "<" in line else line
                base = Path() if target.startswith("/") else rel.parent
                names.add((base / target.lstrip("/")).as_posix().removesuffix(".md"))
    return names


def generate(srcdir):
    srcdir = Path(srcdir)
    out = srcdir / "_generated"
    named = named_in_toctrees(srcdir)
    extra = sorted(p.stem for p in srcdir.glob("*.md") if p.stem not in named and p.stem not in ("index", "view"))
    if extra:
        lines = ["```{toctree}", ":maxdepth: 1", ":caption: More notes", ""] + [f"/{n}" for n in extra] + ["```", ""]
    else:
        lines = [""]
    _write(out / "more_notes.md", "\n".join(lines))
    if (srcdir / "view.md").exists():
        slot = ["```{toctree}", ":maxdepth: 1", "", "/view", "```", ""]
    else:
        slot = ["The browser viewer's page (`docs/view.md`) is not part of this build of the site.", ""]
    _write(out / "viewer_slot.md", "\n".join(slot))
    return extra


def _on_builder_inited(app):
    generate(app.srcdir)


def setup(app):
    app.connect("builder-inited", _on_builder_inited)
    return {"version": "1.0", "parallel_read_safe": True, "parallel_write_safe": True}
