"""The floor every other part of femb stands on: numba in one place (:mod:`femb.base.jit`),
rotations (:mod:`femb.base.rotations`), functions of time, geometry records for output,
interpolation between steps and short summaries. Imports nothing of femb but the errors.
"""


def __getattr__(name):
    """A submodule, imported when first used (``femb.base.<module>`` after ``import femb``)."""
    import importlib
    import importlib.util

    if not name.startswith("_") and importlib.util.find_spec(f"{__name__}.{name}") is not None:
        return importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
