"""Parsing values given as text (``--set NAME=VALUE``, ``--grid NAME=V1,V2``).

A library module: the command line (:mod:`femb.cli`, :mod:`femb.cli_sweep`) and
parameter studies (:mod:`femb.sweep`) both import it; it imports neither.
"""
from __future__ import annotations

import ast


def parse_value(text):
    """A ``--set`` value: a Python literal when it is one (numbers, True, None, tuples), else the string."""
    t = text.strip()
    low = t.lower()
    if low in ("true", "false"):
        return low == "true"
    if low in ("none", "null"):
        return None
    try:
        return ast.literal_eval(t)
    except (ValueError, SyntaxError, MemoryError, RecursionError):
        pass
    try:
        return float(t)             # inf, nan, 1_000.5 variants literal_eval rejects
    except ValueError:
        return text
