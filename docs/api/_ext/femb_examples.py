"""Sphinx extension: run the examples during the build and show their output.

The examples are the Python block of the README's section "A mechanism in a
few lines" and every script in ``docs/api/examples/``. Each runs in a fresh
interpreter (``sys.executable``) in its own folder under
``_generated/examples/`` (files it writes land there); its standard output
and any PNG pictures it writes are shown on the examples page. A failing
example (non-zero exit status or a timeout) fails the build.
"""
from __future__ import annotations

import ast
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

from sphinx.errors import ExtensionError
from sphinx.util import logging

logger = logging.getLogger(__name__)

#: seconds an example may run
TIMEOUT = 600

README_SECTION = "## A mechanism in a few lines"


def readme_example(readme):
    """The first ```python block after README_SECTION in the README."""
    text = Path(readme).read_text(encoding="utf-8")
    at = text.find(README_SECTION)
    if at < 0:
        raise ExtensionError(f"femb_examples: {readme} has no section '{README_SECTION}'")
    m = re.search(r"```python\n(.*?)```", text[at:], re.S)
    if m is None:
        raise ExtensionError(f"femb_examples: no ```python block in the README section '{README_SECTION}'")
    return m.group(1)


def _docstring(source):
    doc = ast.get_docstring(ast.parse(source)) or ""
    title, _, body = doc.partition("\n")
    return title.strip(), body.strip()


def run(name, source, workdir):
    """Run one example; returns its standard output. Raises ExtensionError on failure."""
    if workdir.exists():
        shutil.rmtree(workdir)
    workdir.mkdir(parents=True)
    script = workdir / f"{name}.py"
    script.write_text(source, encoding="utf-8")
    t0 = time.perf_counter()
    try:
        proc = subprocess.run([sys.executable, script.name], cwd=workdir, capture_output=True, text=True,
                              timeout=TIMEOUT)
    except subprocess.TimeoutExpired:
        raise ExtensionError(f"femb_examples: example '{name}' did not finish in {TIMEOUT} s") from None
    if proc.returncode != 0:
        tail = "\n".join(proc.stderr.strip().splitlines()[-15:])
        raise ExtensionError(f"femb_examples: example '{name}' failed (exit status {proc.returncode}):\n{tail}")
    logger.info("femb_examples: %s ran in %.1f s", name, time.perf_counter() - t0)
    return proc.stdout


def _section(title, body, literal_path, output, pictures):
    lines = [title, "-" * len(title), ""]
    if body:
        lines += [body, ""]
    lines += [f".. literalinclude:: {literal_path}", "   :language: python", "", "Output:", "",
              ".. code-block:: text", ""]
    lines += ["   " + ln if ln.strip() else "" for ln in (output.rstrip() or "(no output)").splitlines()]
    lines.append("")
    for pic in pictures:
        lines += [f".. image:: {pic}", f"   :alt: {pic.rsplit('/', 1)[-1]}, written by the example", ""]
    return "\n".join(lines)


def generate(srcdir):
    src = Path(srcdir)
    out = src / "_generated" / "examples"
    parts = []
    examples = [("readme_pendulum", readme_example(src.parent.parent / "README.md"), None)]
    for script in sorted((src / "examples").glob("*.py")):
        examples.append((script.stem, script.read_text(encoding="utf-8"), f"/examples/{script.name}"))
    for name, source, path in examples:
        stdout = run(name, source, out / name)
        pictures = [f"/_generated/examples/{name}/{p.relative_to(out / name).as_posix()}"
                    for p in sorted((out / name).rglob("*.png"))]
        if path is None:
            title, body = ("The README's pendulum",
                           "The example of the README (section *A mechanism in a few lines*), run as it "
                           "stands there; it writes ``out/pendulum/frame.pvd`` for ParaView.")
            path = f"/_generated/examples/{name}/{name}.py"
        else:
            title, body = _docstring(source)
            title = title or name
        parts.append(_section(title, body, path, stdout, pictures))
    (src / "_generated" / "examples.inc").write_text("\n".join(parts), encoding="utf-8")


def _on_builder_inited(app):
    generate(app.srcdir)


def setup(app):
    app.connect("builder-inited", _on_builder_inited)
    return {"version": "1.0", "parallel_read_safe": True, "parallel_write_safe": True}
