"""Short summaries of femb objects for the console and notebooks.

Every summarized object (mechanism, model, result, static and modal result)
describes itself as a title and a few ``(label, value)`` rows; :func:`text`
turns them into its ``repr`` (a few lines) and :func:`html` into its
``_repr_html_`` (a table, shown by Jupyter).
"""
from __future__ import annotations

import html as _html

#: longest value text shown in a row (longer lists are cut with "…")
MAX_VALUE = 110


def short_list(names, limit: int = 6) -> str:
    """``"a, b, c, … (+n more)"``: the first ``limit`` names of a sequence."""
    names = [str(n) for n in names]
    if len(names) <= limit:
        return ", ".join(names)
    return ", ".join(names[:limit]) + f", … (+{len(names) - limit} more)"


def _cut(value: str) -> str:
    value = str(value)
    return value if len(value) <= MAX_VALUE else value[:MAX_VALUE - 1] + "…"


def text(title: str, rows) -> str:
    """The title line and one indented ``label: value`` line per row.

    Parameters
    ----------
    title : str
    rows : sequence of (str, object)

    Returns
    -------
    str
    """
    rows = [(str(k), _cut(v)) for k, v in rows]
    width = max((len(k) for k, _ in rows), default=0)
    return "\n".join([title] + [f"  {k + ':':{width + 1}s} {v}" for k, v in rows])


def html(title: str, rows) -> str:
    """The same as :func:`text` as an HTML table (title as caption)."""
    body = "".join(f"<tr><th style='text-align:left'>{_html.escape(str(k))}</th>"
                   f"<td style='text-align:left'>{_html.escape(_cut(v))}</td></tr>" for k, v in rows)
    return f"<table><caption style='text-align:left'><b>{_html.escape(title)}</b></caption>{body}</table>"


def span(t) -> str:
    """``"0 … 2 s (2001 stored)"`` for a time array of shape (nt,)."""
    n = len(t)
    if n == 0:
        return "empty (0 stored)"
    return f"{float(t[0]):.6g} … {float(t[-1]):.6g} s ({n} stored)"


class Animation:
    """An animated GIF of a result, shown inline by Jupyter (see :meth:`femb.Result.animate`).

    Attributes
    ----------
    data : bytes
        The GIF file.
    frames : int
        Number of pictures.
    """

    def __init__(self, data: bytes, frames: int) -> None:
        self.data = bytes(data)
        self.frames = int(frames)

    def save(self, path) -> None:
        """Write the GIF to ``path``."""
        from pathlib import Path

        Path(path).write_bytes(self.data)

    def _repr_html_(self) -> str:
        import base64

        return f'<img src="data:image/gif;base64,{base64.b64encode(self.data).decode("ascii")}"/>'

    def __repr__(self) -> str:
        return f"femb Animation: {self.frames} frames, {len(self.data) / 1024:.0f} KiB GIF (shown inline in Jupyter)"
