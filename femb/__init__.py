"""femb: flexible multibody dynamics in absolute coordinates.

Build a :class:`Mechanism` from elements (:mod:`femb.elements`), compile it
into a frozen :class:`~femb.model.Model`, and integrate it with the index-3
generalized-α scheme of Arnold & Brüls (2007) via :func:`simulate`.
"""
from femb.alpha import GeneralizedAlpha
from femb.errors import (AccuracyWarning, ConvergenceError, FembError, InitializationError, InitialMoveWarning,
                         InitialVelocityWarning, ModelError, OutputError, ParameterError, ParameterWarning, RedundantConstraintWarning,
                         SingularMatrixError, SolverError)
from femb.mechanism import Mechanism
from femb.model import Model, State
from femb.result import Result
from femb.initial import consistent_initial_state
from femb.solver import GeneralizedAlphaSolver, simulate
from femb.checks import JacobianReport, check_jacobians
from femb.motion import set_rigid_velocity

__version__ = "0.1.0"

__all__ = [
    "GeneralizedAlpha", "Mechanism", "Model", "State", "Result", "GeneralizedAlphaSolver",
    "simulate", "consistent_initial_state", "FembError", "ModelError", "ParameterError",
    "InitializationError", "SolverError", "ConvergenceError", "SingularMatrixError", "OutputError",
    "ParameterWarning", "AccuracyWarning", "InitialMoveWarning", "InitialVelocityWarning",
    "RedundantConstraintWarning", "sweep", "check_jacobians", "JacobianReport", "set_rigid_velocity",
]


def __getattr__(name):
    """Lazy attributes: ``femb.sweep`` (imports Dask and pandas only when used)."""
    if name == "sweep":
        import importlib

        fn = importlib.import_module("femb.sweep").sweep
        globals()["sweep"] = fn
        return fn
    raise AttributeError(f"module 'femb' has no attribute {name!r}")
