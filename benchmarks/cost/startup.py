"""Start-up cost of femb: whole-process wall times of ``import femb``, ``femb --help`` and ``femb list``.

Each command runs in a fresh Python process, ``--runs`` times, interleaved with a bare
interpreter (``python -c pass``) so that the machine's load hits every command alike;
the figures are medians (``time.perf_counter`` around ``subprocess.run``) and their
excess over the bare interpreter. Nothing is compiled: run it warm (after one
``femb run``), as a user meets it.

Usage::

    python -m femb.benchmarks.cost.startup [--runs 7]
"""
from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time

COMMANDS = {
    "python -c pass": [sys.executable, "-c", "pass"],
    "import femb": [sys.executable, "-c", "import femb"],
    "from femb import Mechanism, simulate": [sys.executable, "-c", "from femb import Mechanism, simulate"],
    "femb --help": [sys.executable, "-m", "femb.console.cli", "--help"],
    "femb list": [sys.executable, "-m", "femb.console.cli", "list"],
}


def measure(runs=7):
    """Median wall time (s) of each command of :data:`COMMANDS` over ``runs`` interleaved rounds.

    Returns
    -------
    dict of str to float
    """
    times = {k: [] for k in COMMANDS}
    for _ in range(runs):
        for name, argv in COMMANDS.items():
            t0 = time.perf_counter()
            subprocess.run(argv, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            times[name].append(time.perf_counter() - t0)
    return {k: statistics.median(v) for k, v in times.items()}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=7)
    args = ap.parse_args(argv)
    med = measure(args.runs)
    base = med["python -c pass"]
    print(f"median of {args.runs} runs (s); excess over the bare interpreter")
    for k, v in med.items():
        print(f"  {k:<38s} {v:7.3f}   +{v - base:6.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
