"""Progress reporting on stderr that suits both terminals and log files.

:func:`progress` returns a live bar drawn by rich (description, bar, done/total,
elapsed time and the estimated time remaining) when stderr is a terminal;
otherwise a plain reporter that prints a few lines (every 10 %, or every few
seconds when the total is unknown), each with the elapsed time and the
estimated time remaining, which keeps CI logs and redirected output readable
(rich draws nothing until the end when its output is not a terminal).
Runs (``simulate(progress=True)``, ``femb run``), sweeps, renders and
``femb cache build`` report through it.
"""
from __future__ import annotations

import numbers
import sys
import time

__all__ = ["progress", "PlainProgress", "RichProgress"]


def _eta(elapsed, done, total):
    """Estimated seconds remaining at a constant rate (None before the first step or without a total)."""
    if not total or done <= 0 or done >= total:
        return None
    return elapsed * (total - done) / done


def _clock(seconds):
    s = int(round(seconds))
    return f"{s // 3600}:{s % 3600 // 60:02d}:{s % 60:02d}" if s >= 3600 else f"{s // 60}:{s % 60:02d}"


class _Reporter:
    """What both reporters share: iterating over ``iterable`` with an update per item, and the
    ``with`` block that closes them (subclasses define ``iterable``, ``update`` and ``close``)."""

    def __iter__(self):
        if self.iterable is None:
            raise TypeError("this progress reporter was made from a total, not an iterable")
        try:
            for item in self.iterable:
                yield item
                self.update(1)
        finally:
            self.close()

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        self.close()
        return False


class PlainProgress(_Reporter):
    """Line-based progress reporter (no carriage returns, sparse output).

    Parameters
    ----------
    iterable : iterable, optional
        Items to iterate over (reported as they are consumed).
    total : int, optional
        Number of steps; taken from ``len(iterable)`` when possible.
    desc : str
        Label printed at the start of each line.
    enabled : bool, default True
        When False nothing is printed; counting still works.
    stream : file, optional
        Where to print (default ``sys.stderr``).
    step : float, default 0.1
        Print each time another ``step`` fraction of the total is done.
    interval : float, default 10
        With an unknown total, print at most once per ``interval`` seconds.
    """

    def __init__(self, iterable=None, total=None, desc="", enabled=True, stream=None,
                 step=0.1, interval=10.0):
        self.iterable = iterable
        if total is None and iterable is not None:
            try:
                total = len(iterable)
            except TypeError:
                total = None
        self.total = total
        self.desc = desc
        self.enabled = enabled
        self.stream = stream
        self.step = step
        self.interval = interval
        self.n = 0
        self._t0 = time.monotonic()
        self._next_frac = step
        self._last_print = self._t0
        self._closed = False

    def _print(self, msg):
        if self.enabled:
            stream = self.stream if self.stream is not None else sys.stderr
            print(f"{self.desc}: {msg}" if self.desc else msg, file=stream, flush=True)

    def update(self, n=1):
        """Advance by ``n`` steps, printing a line when a threshold is crossed."""
        self.n += n
        now = time.monotonic()
        if self.total:
            frac = self.n / self.total
            if frac >= self._next_frac and self.n < self.total:
                eta = _eta(now - self._t0, self.n, self.total)
                self._print(f"{100 * frac:3.0f}% ({self.n}/{self.total}) "
                            f"{now - self._t0:.1f} s" + (f", about {_clock(eta)} left" if eta is not None else ""))
                while self._next_frac <= frac:
                    self._next_frac += self.step
        elif now - self._last_print >= self.interval:
            self._print(f"{self.n} done, {now - self._t0:.1f} s")
            self._last_print = now

    def close(self):
        """Print the closing line (once)."""
        if self._closed:
            return
        self._closed = True
        elapsed = time.monotonic() - self._t0
        total = f"/{self.total}" if self.total else ""
        self._print(f"done {self.n}{total} in {elapsed:.1f} s")



class RichProgress(_Reporter):
    """A live bar on a terminal, drawn by ``rich.progress``: what, how far, elapsed, time remaining.

    Same interface as :class:`PlainProgress` (``update``, ``close``, iteration,
    context manager); the bar disappears from the screen when closed and one
    closing line stays.
    """

    def __init__(self, iterable=None, total=None, desc="", stream=None):
        from rich.console import Console
        from rich.progress import (BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn,
                                   TimeRemainingColumn)

        if total is None and iterable is not None:
            try:
                total = len(iterable)
            except TypeError:
                total = None
        self.iterable, self.total, self.desc, self.n = iterable, total, desc, 0
        self._console = Console(file=stream if stream is not None else sys.stderr)
        self._bar = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                             TimeElapsedColumn(), TextColumn("eta"), TimeRemainingColumn(),
                             console=self._console, transient=True)
        from rich.markup import escape

        self._task = self._bar.add_task(escape(desc or "working"), total=total)     # "[t0, t_end]" is text
        self._t0 = time.monotonic()
        self._closed = False
        self._bar.start()

    def update(self, n=1):
        self.n += n
        self._bar.update(self._task, advance=n)

    def close(self):
        if self._closed:
            return
        self._closed = True
        self._bar.stop()
        total = f"/{self.total}" if self.total else ""
        self._console.print(f"{self.desc + ': ' if self.desc else ''}done {self.n}{total} in "
                            f"{time.monotonic() - self._t0:.1f} s", highlight=False, markup=False)



def progress(iterable_or_total, desc="", enabled=True):
    """Progress reporter over an iterable or for a number of steps.

    Parameters
    ----------
    iterable_or_total : iterable or int or None
        What to iterate over, or the total number of steps (None if unknown).
    desc : str
        Label of the task.
    enabled : bool, default True
        When False nothing is shown.

    Returns
    -------
    RichProgress or PlainProgress
        A rich bar when stderr is a terminal, else plain lines. Both iterate
        (when given an iterable), support ``update(n)`` and ``close()``, and
        are context managers.

    Examples
    --------
    >>> with progress(100, "solve") as bar:  # doctest: +SKIP
    ...     for _ in range(100):
    ...         bar.update(1)
    """
    if isinstance(iterable_or_total, bool):
        raise TypeError("iterable_or_total must be an iterable or an int, not a bool")
    if iterable_or_total is None or isinstance(iterable_or_total, numbers.Integral):
        iterable = None
        total = None if iterable_or_total is None else int(iterable_or_total)
    else:
        iterable, total = iterable_or_total, None
    if enabled and _is_terminal(sys.stderr):
        return RichProgress(iterable, total=total, desc=desc)
    return PlainProgress(iterable, total=total, desc=desc, enabled=enabled)


def _is_terminal(stream):
    try:
        return stream.isatty()
    except (AttributeError, ValueError):
        return False
