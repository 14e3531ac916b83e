"""Output channels: named outputs written to CSV or Parquet while a simulation runs.

A long run need not keep its states in memory: :class:`OutputChannels` is an
observer of :func:`femb.simulate` (use it with ``store=False``) that evaluates
chosen outputs (the names of :meth:`femb.Result.outputs`, e.g. ``"bar.theta"``,
``"pivot.Fy"``; what Exudyn calls sensors) every ``every``-th step, or at times
t0 + k·dt interpolated between accepted steps, and appends them to a file in
chunks. Each output is evaluated exactly as :meth:`femb.Result.series` would
evaluate it at that state (same code); energies, which need the whole history
(work of loads, dissipation), are not available as channels.

CSV files have one header line, ``t [s]`` then ``name [unit]`` per output;
Parquet files (``pip install pyarrow``) have the names as columns and the units
in the schema's metadata (``b"units"``: JSON).
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from femb.errors import OutputError


class OutputChannels:
    """Observer of :func:`femb.simulate` that writes named outputs to a CSV or Parquet file.

    Parameters
    ----------
    model : Model
    path : str or Path
        ``.csv`` or ``.parquet``; its directory must exist.
    outputs : sequence of str
        Names as in :meth:`femb.Result.series` (not ``energy.*``).
    every : int
        Write every ``every``-th accepted step (step 0, the initial state, included).
    dt : float, optional
        Write at t0 + k·dt instead, interpolated between accepted steps (cubic
        Hermite in q and q̇, linear in q̈ and λ: :func:`femb.base.interp.state_between`);
        ``every`` is then ignored (the compiled loop returns every step).
    flush_rows : int
        Rows kept in memory before they are appended to the file.

    Examples
    --------
    >>> with OutputChannels(model, "out.csv", ["bar.theta", "pivot.Fy"], every=10) as ch:  # doctest: +SKIP
    ...     femb.simulate(model, 100.0, 1e-3, store=False, observer=ch)
    """

    def __init__(self, model, path, outputs, *, every: int = 1, dt: float | None = None,
                 flush_rows: int = 1000) -> None:
        self.model = model
        self.path = Path(path)
        self.format = {".csv": "csv", ".parquet": "parquet"}.get(self.path.suffix.lower())
        if self.format is None:
            raise OutputError(f"OutputChannels: {self.path}: expected a .csv or .parquet file")
        if not self.path.parent.is_dir():
            raise OutputError(f"OutputChannels: {self.path}: directory {self.path.parent} does not exist")
        if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 1:
            raise OutputError(f"OutputChannels: every must be a positive integer, got {every!r}")
        self.every, self.dt = int(every), None
        if dt is not None:
            self.dt = float(dt) if isinstance(dt, (int, float, np.floating)) and not isinstance(dt, bool) else -1.0
            if not (self.dt > 0.0 and np.isfinite(self.dt)):
                raise OutputError(f"OutputChannels: dt must be a positive finite time (s), got {dt!r}")
            self.every = 1
        self.outputs = self._check(outputs)
        self.units = self._units()
        self.flush_rows = max(1, int(flush_rows))
        self.rows, self.n_rows = [], 0
        self._prev, self._t0, self._k, self._writer = None, None, 0, None
        if self.format == "csv":
            header = ",".join(_csv_cell(f"{n} [{u}]") for n, u in [("t", "s")] + list(zip(self.outputs, self.units)))
            self.path.write_text(header + "\n")

    def _check(self, outputs):
        if isinstance(outputs, str):
            outputs = [outputs]
        outputs = [str(n) for n in outputs]
        if not outputs:
            raise OutputError("OutputChannels: give at least one output name")
        known = set(self._result(self.model.initial_state()).outputs())
        bad = [n for n in outputs if n not in known or n.startswith("energy.")]
        if bad:
            raise OutputError(f"OutputChannels: unknown output(s) {', '.join(map(repr, bad))} (energies need the "
                              "whole run and are not channels; names: Result.outputs())")
        return outputs

    def _result(self, state):
        """A one-step :class:`~femb.results.result.Result` at ``state``: the outputs are evaluated by its code."""
        from femb.results.result import Result

        return Result(model=self.model, t=np.array([state.t]), q=np.asarray(state.q)[None],
                      qd=np.asarray(state.qd)[None], qdd=np.asarray(state.qdd)[None],
                      lam=np.asarray(state.lam)[None], newton_iterations=np.zeros(0, dtype=np.int32))

    def _units(self):
        r = self._result(self.model.initial_state())
        return [r.series(n)[1] for n in self.outputs]

    def _record(self, state):
        r = self._result(state)
        self.rows.append([float(state.t)] + [float(r.series(n)[0][0]) for n in self.outputs])
        if len(self.rows) >= self.flush_rows:
            self.flush()

    def __call__(self, state, step):
        if self.dt is None:
            if step % self.every == 0:
                self._record(state)
            return
        from femb.base.interp import state_between
        from femb.system.model import State

        if step == 0 or self._prev is None:
            self._t0, self._k = state.t, 1
            self._record(state)
        else:
            while True:
                t = self._t0 + self._k * self.dt
                if t > state.t * (1 + 1e-12) + 1e-300:
                    break
                q, qd, qdd, lam = state_between(self._prev, state, min(t, state.t), self.model)
                self._record(State(t, q, qd, qdd, lam))
                self._k += 1
        self._prev = state.copy()

    def flush(self):
        """Append the rows kept in memory to the file."""
        if not self.rows:
            return
        rows, self.rows = self.rows, []
        self.n_rows += len(rows)
        try:
            if self.format == "csv":
                with open(self.path, "a") as fh:
                    fh.write("".join(",".join(repr(v) for v in row) + "\n" for row in rows))
            else:
                self._parquet(np.array(rows, dtype=float))
        except OSError as exc:
            raise OutputError(f"OutputChannels: cannot write {self.path}: {exc}") from exc

    def _parquet(self, data):
        try:
            import pyarrow as pa
            import pyarrow.parquet as pq
        except ImportError:
            raise OutputError("OutputChannels: Parquet needs pyarrow: pip install pyarrow (or write .csv)") from None
        names = ["t"] + self.outputs
        table = pa.table({n: data[:, k] for k, n in enumerate(names)})
        if self._writer is None:
            meta = {b"units": json.dumps(dict(zip(names, ["s"] + self.units))).encode()}
            table = table.replace_schema_metadata(meta)
            self._writer = pq.ParquetWriter(os.fspath(self.path), table.schema)
        self._writer.write_table(table.replace_schema_metadata(self._writer.schema.metadata))

    def close(self):
        """Write what is left and close the file (also on leaving a ``with`` block)."""
        self.flush()
        if self._writer is not None:
            self._writer.close()
            self._writer = None

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        self.close()
        return False


def _csv_cell(text):
    return '"' + text.replace('"', '""') + '"' if ("," in text or '"' in text) else text
