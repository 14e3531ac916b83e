"""What the command-line modules share (:mod:`femb.console.cli`, :mod:`femb.console.cli_sweep`).

Both import this module and it imports neither, so the command line has one
direction: ``cli`` → ``cli_sweep`` → ``cli_common``, ``sweep``, and ``sweep`` (a
library module) depends on no command-line module (:mod:`femb.study.parsing`).
"""
from __future__ import annotations

import argparse
import math

from femb.study.parsing import parse_value

SCENE_HELP = "built-in scene name (see 'femb list') or path to a Python file defining build()"


class UsageError(Exception):
    """Bad command-line input: reported in one line, exit status 2."""


def parse_sets(items):
    """``["NAME=VALUE", ...]`` -> dict, values parsed by :func:`parse_value`."""
    params = {}
    for item in items or []:
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep or not name.isidentifier():
            raise UsageError(f"--set expects NAME=VALUE with NAME a parameter name, got {item!r}")
        params[name] = parse_value(value)
    return params


def _positive(name):
    def conv(text):
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a number, got {text!r}") from None
        if not (math.isfinite(v) and v > 0.0):
            raise argparse.ArgumentTypeError(f"{name} must be a positive number, got {text!r}")
        return v
    return conv


def _rho(text):
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"rho_inf must be a number in [0, 1], got {text!r}") from None
    if not 0.0 <= v <= 1.0:
        raise argparse.ArgumentTypeError(f"rho_inf must lie in [0, 1], got {text!r}")
    return v


def _count(text):
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text!r}")
    return v


def _load_scene(spec):
    from femb.study.registry import SceneError, load

    try:
        return load(spec)
    except SceneError as exc:
        raise UsageError(str(exc)) from None
