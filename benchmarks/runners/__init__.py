"""The benchmark suite (``femb bench``): work–precision diagrams and stress tests.
"""


def __getattr__(name):
    """A submodule, imported when first used (``femb.benchmarks.runners.<module>`` after ``import femb``)."""
    import importlib
    import importlib.util

    if not name.startswith("_") and importlib.util.find_spec(f"{__name__}.{name}") is not None:
        return importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
