"""The mechanical system: the element contract and the nodes, the user's
:class:`~femb.system.mechanism.Mechanism`, the frozen :class:`~femb.system.model.Model` and
its :class:`~femb.system.model.State`, the kernels called from Python, the assembly of
M, f, Φ, Φ_q, K_t, C_t and the consistent initial state. Shares its floor with
:mod:`femb.elements` (the element library).
"""


def __getattr__(name):
    """A submodule, imported when first used (``femb.system.<module>`` after ``import femb``)."""
    import importlib
    import importlib.util

    if not name.startswith("_") and importlib.util.find_spec(f"{__name__}.{name}") is not None:
        return importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
