"""The engine: the generalized-α time step of Arnold & Brüls (2007), compiled once for every mechanism.

One module per stage of the step (docs/engine.md has the map):

=============  ==========================================================================
``layout``     every named field: the packs' arrays, ``ip``/``fp``/``si``/``sf`` fields, codes
``linalg``     band and dense LU of the iteration matrix, and their solves
``evaluate``   gather the batches' coordinates, call their kernels, scatter r, Φ and S_t
``newton``     the Newton step (Algorithm 1): predictor, corrections, stopping rules, Lie update
``control``    the local error estimate, step-size control and re-synchronisation
``loop``       the time loop: chunks of accepted steps, fixed or adaptive
``build``      the entry points' signatures, their compilation and the disk cache
``parallel``   the entry points and stages compiled at once in worker processes
=============  ==========================================================================

The package re-exports the entry points and the layout's names: ``femb.engine.run``,
``femb.engine.FP_H``. It is compiled once per installation and CPU (:func:`ensure_engine`) and
serves any combination of element types (their kernels are called through their addresses).
"""
from femb.engine.layout import *  # noqa: F401,F403  (the named fields, re-exported)
from femb.engine.layout import NewtonArrays, Out, Par, StepState, carry_rule, named_array  # noqa: F401
from femb.engine.linalg import band_lu, band_solve, dense_lu_solve  # noqa: F401
from femb.engine.evaluate import (constraint_B, copy_B, eval_time_functions, evaluate,  # noqa: F401
                                  jacobian_times, rates)
from femb.engine.newton import ggl_matrix, lie_reset  # noqa: F401
from femb.engine.control import kkt_solve, project_normal_velocity  # noqa: F401
from femb.engine.loop import run  # noqa: F401
from femb.engine.build import engine_signatures, ensure_engine, stage_signatures  # noqa: F401
