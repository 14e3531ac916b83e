"""femb: flexible multibody dynamics in absolute coordinates.

Build a :class:`Mechanism` from elements (:mod:`femb.elements`), compile it
into a frozen :class:`~femb.system.model.Model`, and integrate it with the index-3
generalized-α scheme of Arnold & Brüls (2007) via :func:`simulate`.

``import femb`` loads only the exception classes; the names below come from
their modules on first use (those import numba, scipy and, for :func:`sweep`,
Dask and pandas), so that ``import femb`` and ``femb --help`` start at once.
"""
from femb.errors import (AccuracyWarning, ConvergenceError, FembError, InitializationError, InitialMoveWarning,
                         InitialVelocityWarning, ModelError, OutputError, ParameterError, ParameterWarning,
                         RedundantConstraintWarning, SingularMatrixError, SolverError)

__version__ = "0.1.0"

#: public name -> the module that defines it (imported on first access)
_LAZY = {
    "GeneralizedAlpha": "femb.solve.alpha",
    "Mechanism": "femb.system.mechanism",
    "Model": "femb.system.model",
    "State": "femb.system.model",
    "Result": "femb.results.result",
    "consistent_initial_state": "femb.system.initial",
    "GeneralizedAlphaSolver": "femb.solve.solver",
    "simulate": "femb.solve.solver",
    "check_jacobians": "femb.analysis.checks",
    "JacobianReport": "femb.analysis.checks",
    "sweep": "femb.study.sweep",
    "set_rigid_velocity": "femb.system.motion",
    "view": "femb.io.view",
}

__all__ = [
    "GeneralizedAlpha", "Mechanism", "Model", "State", "Result", "GeneralizedAlphaSolver",
    "simulate", "consistent_initial_state", "FembError", "ModelError", "ParameterError",
    "InitializationError", "SolverError", "ConvergenceError", "SingularMatrixError", "OutputError",
    "ParameterWarning", "AccuracyWarning", "InitialMoveWarning", "InitialVelocityWarning",
    "RedundantConstraintWarning", "sweep", "check_jacobians", "JacobianReport", "set_rigid_velocity",
    "view",
]


def __getattr__(name):
    """The public names of :data:`_LAZY`, imported from their modules when first asked for; a
    submodule (``femb.system.assembly``, ``femb.analysis.static``, ``femb.io``, ...) is imported when first used."""
    import importlib

    module = _LAZY.get(name)
    if module is None:
        if not name.startswith("_"):
            import importlib.util

            if importlib.util.find_spec(f"femb.{name}") is not None:
                return importlib.import_module(f"femb.{name}")
        raise AttributeError(f"module 'femb' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
