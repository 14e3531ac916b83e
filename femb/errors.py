"""femb's exception and warning classes.

Every error raised for bad input names the element or parameter at fault and
says what is wrong. Errors raised during a simulation carry the time, the step
index and the residual norms, and the partial result computed so far.
"""
from __future__ import annotations


def user_stacklevel():
    """The ``stacklevel`` for :func:`warnings.warn` called here that names the first frame outside
    femb's own packages (femb, femb.elements, femb.benchmarks): the user's line, however deep
    inside femb the warning is raised."""
    import os
    import sys

    roots = tuple(os.path.dirname(os.path.dirname(os.path.abspath(__file__))) + os.sep + d + os.sep
                  for d in ("femb", "elements", "benchmarks"))
    f, level = sys._getframe(1), 1
    while f is not None and os.path.abspath(f.f_code.co_filename).startswith(roots):
        f, level = f.f_back, level + 1
    return level


class FembError(Exception):
    """Base class of all femb errors."""


class ModelError(FembError, ValueError):
    """Invalid mechanism input: a bad parameter, reference or name."""


class ParameterError(FembError, ValueError):
    """Invalid solver or method parameter (step size, end time, rho_inf, ...)."""


class InitializationError(FembError):
    """The initial state cannot be made consistent with the constraints."""


class SolverError(FembError):
    """A simulation failed; carries where and how, and the partial result.

    Attributes
    ----------
    t : float or None
        Time the failing step was trying to reach.
    step : int or None
        Index of the failing step (1 is the first step).
    residuals : dict
        Residual norms at the last Newton iterate (``"r_q"`` in force units,
        ``"Phi"`` in length units), when known.
    result : femb.results.result.Result or None
        Everything stored up to the last accepted step.
    """

    def __init__(self, message, *, t=None, step=None, residuals=None, result=None):
        super().__init__(message)
        self.t = t
        self.step = step
        self.residuals = dict(residuals or {})
        self.result = result


class ConvergenceError(SolverError):
    """Newton's method did not converge within the iteration limit."""


class SingularMatrixError(SolverError):
    """The iteration matrix (or an initialization matrix) is singular."""


class OutputError(FembError):
    """Writing or reading output (VTK files, pictures) failed."""


class ParameterWarning(UserWarning):
    """Method parameters that violate an order or stability condition."""


class InitialMoveWarning(UserWarning):
    """Initialization moved bodies onto the constraints by more than a tolerance (lists them)."""


class InitialVelocityWarning(InitialMoveWarning):
    """Initialization changed initial velocities that were given, to satisfy the constraints (lists the bodies)."""


class RedundantConstraintWarning(UserWarning):
    """Dependent constraint equations were eliminated; their joints' reactions are not unique."""


SINGULAR_HINT = (
    "hint: look for redundant constraints (two joints that remove the same motion, "
    "e.g. a duplicated hinge, or a Slider where a PointOnLine suffices), a coordinate "
    "that has neither mass nor a constraint, or a mechanism locked in a singular "
    "(dead-centre) position"
)

SINGULAR_HINT_DIVERGED = (
    "hint: the Newton iteration was diverging when the matrix became singular; this is the step "
    "size, not the model (a stiff element or a fast motion that h does not resolve): reduce h"
)

SINGULAR_HINT_INDEPENDENT = (
    "hint: the constraints are independent here (Φ_q has full rank), so this is not a redundant "
    "joint: a coordinate has neither mass nor stiffness nor a constraint (a body with zero inertia "
    "and no joint fixing its rotation), or h is so large that the stiffness swamps the mass in a "
    "direction without stiffness; check masses and inertias, or reduce h"
)

SINGULAR_HINT_STEP = (
    "hint: the step size: h is too large for this model. The constraints are independent here "
    "(Φ_q has full rank) and the matrix [[M, Φ_qᵀ], [Φ_q, 0]] is regular (every coordinate has mass or "
    "a constraint), so the iteration matrix, M/(βh²) + C_t γ/(βh) + K_t with the constraint rows, "
    "became singular through its h-dependent terms: stiffness (or a compressive load on a stiff member) "
    "swamps the mass at this h. Reduce h (or use adaptive steps, simulate(..., rtol=...))"
)

NEWTON_HINT = "try a smaller h"

NEWTON_HINT_START = (
    "hint: this is the start, not the step size alone: the initial state sets going motions that h does "
    "not resolve (a driver at full speed from rest, initial velocities the joints change, a deformable "
    "element released out of equilibrium). What helps: the consistent start (initialize=True, "
    "start=\"consistent\", the defaults), which sets deformable elements moving with the least strain "
    "rate the joints allow; a driver whose rate ramps up from zero; adaptive steps (simulate(..., rtol=...)), "
    "which resolve the start and then grow. A smaller h helps only once it resolves the stiff modes "
    "(h ω < 1)"
)


class PathJumpWarning(UserWarning):
    """Load stepping left the equilibrium path: a converged state far from the path's continuation
    (a limit point passed, snap-through); :func:`femb.analysis.static.solve_static` with
    ``method="arc_length"`` follows the path instead."""


class AccuracyWarning(UserWarning):
    """A fixed-step run whose local error estimate says the steps are far too large."""


class ContactError(SolverError):
    """A contact step has no consistent solution (or none was found): names the time, the step,
    the contact and why (e.g. Painlevé's paradox: no contact force is consistent with Coulomb
    friction). Carries the partial result like every :class:`SolverError`; ``contact`` is the
    name of the contact element at fault (or None)."""

    def __init__(self, message, *, contact=None, **kw):
        super().__init__(message, **kw)
        self.contact = contact
