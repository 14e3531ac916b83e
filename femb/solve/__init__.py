"""Solving in time: the generalized-α parameters, the solver's options, the per-model data
of the compiled engine, its compile cache, the step-size diagnostics and
:func:`~femb.solve.solver.simulate` (the Python side of :mod:`femb.engine`).
"""


def __getattr__(name):
    """A submodule, imported when first used (``femb.solve.<module>`` after ``import femb``)."""
    import importlib
    import importlib.util

    if not name.startswith("_") and importlib.util.find_spec(f"{__name__}.{name}") is not None:
        return importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
