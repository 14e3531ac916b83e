"""What a run keeps: stored states and per-step records in numpy arrays, never per-step Python objects.

:class:`Storage` receives the compiled loop's buffers chunk by chunk (``femb.solve.solver.simulate``).
With fixed steps the number of stored states and steps is known before the run: the arrays
are allocated once, at their final size, and a run whose storage would not fit into the
memory available is refused up front (:func:`check_memory`), with the figure. Adaptive runs
keep chunks of arrays and join them once at the end.
"""
from __future__ import annotations

import os

import numpy as np

from femb.errors import ParameterError

#: bytes kept per accepted step besides the stored states: h (float64), Newton iterations (int32)
#: and the error estimate (float64)
STEP_BYTES = 8 + 4 + 8


def available_memory():
    """Bytes of memory available to a new allocation (MemAvailable on Linux), or None if unknown."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def check_memory(need, what):
    """A ParameterError when ``need`` bytes exceed the memory available (``what`` says for what)."""
    avail = available_memory()
    if avail is not None and need > avail:
        raise ParameterError(f"{what} would need {need / 2**30:.3g} GiB, but {avail / 2**30:.3g} GiB of memory are "
                             "available: store fewer states (stride=..., store=False) or stream them "
                             "through an observer (femb.io.VTKStream)")


class Column:
    """One stored quantity, rows appended chunk by chunk.

    Parameters
    ----------
    tail : tuple of int
        The shape of one row (() for a scalar per row).
    dtype : numpy dtype
    capacity : int or None
        Rows to allocate at once (known count); None: chunks joined at the end.
    """

    def __init__(self, tail, dtype, capacity=None):
        self.tail, self.dtype, self.n = tuple(tail), np.dtype(dtype), 0
        self.buf = None if capacity is None else np.empty((capacity,) + self.tail, dtype=self.dtype)
        self.chunks = []

    def append(self, rows):
        """Append rows (m,) + tail (copied)."""
        m = len(rows)
        if not m:
            return
        if self.buf is not None and self.n + m <= len(self.buf):
            self.buf[self.n:self.n + m] = rows
        else:
            if self.buf is not None:       # more than announced: the filled part becomes a chunk
                self.chunks.append(self.buf[:self.n])
                self.buf = None
            self.chunks.append(np.array(rows, dtype=self.dtype))
        self.n += m

    def array(self):
        """The rows stored so far, (n,) + tail."""
        if self.buf is not None:
            return self.buf[:self.n]
        if len(self.chunks) != 1:
            joined = np.concatenate(self.chunks) if self.chunks else np.empty((0,) + self.tail, self.dtype)
            self.chunks = [joined]
        return self.chunks[0]

    def last(self):
        return self.buf[self.n - 1] if self.buf is not None else self.chunks[-1][-1]


class Storage:
    """The stored states (t, q, q̇, q̈, λ) and per-step records (h, Newton iterations, error) of a run.

    Parameters
    ----------
    model : Model
    n_steps : int or None
        Fixed steps: their number (the arrays are allocated at their final size, after
        :func:`check_memory`); None for adaptive steps.
    stride : int
        Every stride-th step is stored (and the initial and the last state).
    store : bool
        False: only the initial and the last state.
    """

    def __init__(self, model, n_steps, stride, store):
        # the multipliers [λ; μ]: nc holonomic, then nn velocity-constraint (non-holonomic) rows
        nx, nv, nc = model.nx, model.nq, model.nc + getattr(model, "nn", 0)
        states = steps = None
        if n_steps is not None:
            states = 2 + (n_steps // stride if store else 0)
            steps = n_steps
            row = 8 * (1 + nx + 2 * nv + nc)
            check_memory(states * row + steps * STEP_BYTES,
                         f"storing {states} states of {row} bytes and {steps} steps of {STEP_BYTES} bytes")
        self.t = Column((), np.float64, states)
        self.q = Column((nx,), np.float64, states)
        self.qd = Column((nv,), np.float64, states)
        self.qdd = Column((nv,), np.float64, states)
        self.lam = Column((nc,), np.float64, states)
        self.h = Column((), np.float64, steps)
        self.it = Column((), np.int32, steps)
        self.err = Column((), np.float64, steps)

    def add_states(self, t, q, qd, qdd, lam):
        for col, rows in ((self.t, t), (self.q, q), (self.qd, qd), (self.qdd, qdd), (self.lam, lam)):
            col.append(rows)

    def add_steps(self, h, it, err):
        for col, rows in ((self.h, h), (self.it, it), (self.err, err)):
            col.append(rows)

    @property
    def t_last(self):
        return float(self.t.last())

    def result(self, model, status, message, solver, wall_time):
        """The :class:`~femb.results.result.Result` of what is stored (the arrays, not copies)."""
        from femb.results.result import Result
        res = Result(model=model, t=self.t.array(), q=self.q.array(), qd=self.qd.array(), qdd=self.qdd.array(),
                     lam=self.lam.array(), newton_iterations=self.it.array(), status=status, message=message,
                     wall_time=wall_time, init_time=solver.init_time, stats=solver.stats,
                     settings=solver.settings())
        res.h_steps = self.h.array()
        res.error_estimates = self.err.array()
        res.n_rejected = int(solver.si[solver.cp.mod.SI_REJECTED])
        res.n_newton_failures = int(solver.si[solver.cp.mod.SI_NFAIL])
        return res
