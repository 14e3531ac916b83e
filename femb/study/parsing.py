"""Parsing values given as text (``--set NAME=VALUE``, ``--grid NAME=V1,V2``).

A library module: the command line (:mod:`femb.console.cli`, :mod:`femb.console.cli_sweep`) and
parameter studies (:mod:`femb.study.sweep`) both import it; it imports neither.
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


def plain(value):
    """``value`` as JSON-ready data: numpy arrays and tuples → lists, numpy scalars → Python numbers,
    non-finite floats → None; anything else that is not JSON data → its ``repr``."""
    import math

    if value is None or isinstance(value, (bool, str)):
        return value
    if hasattr(value, "tolist") and not isinstance(value, (int, float)):
        value = value.tolist()          # numpy array or scalar
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, dict):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, int):
        return int(value)
    if isinstance(value, float):
        return float(value) if math.isfinite(value) else None
    return repr(value)


def parameter_record(info, given):
    """Every parameter of a scene with its value, unit and whether it was given.

    Parameters
    ----------
    info : dict
        ``{name: (default, meaning, unit)}`` (a scene's ``parameter_info()``); a
        required parameter's default is ``inspect.Parameter.empty``.
    given : dict
        ``{name: value}`` set for this run (``--set``, a sweep's fixed and varied values).

    Returns
    -------
    dict
        ``{name: {"value", "unit", "given"}}`` in the order of ``info``, then names
        of ``given`` that ``info`` does not list (unit ``""``); JSON-ready values.
    """
    import inspect

    out = {}
    for name, (default, _meaning, unit) in info.items():
        value = given.get(name, default)
        out[name] = {"value": None if value is inspect.Parameter.empty else plain(value), "unit": unit or "",
                     "given": name in given}
    for name, value in given.items():
        if name not in out:
            out[name] = {"value": plain(value), "unit": "", "given": True}
    return out
