"""Benchmarks of :func:`femb.sweep`: per-case overhead, speed-up with workers, scheduler memory.

Run ``python -m femb.benchmarks.cost.sweep_bench [--part overhead|speedup|memory|all]``. Prints
tables; every time is a median over ``--repeat`` repetitions (time.perf_counter), the
variants of a part interleaved. The serial loops run with single-threaded BLAS, as Dask's
worker processes do (the script restarts itself with OMP/MKL/OPENBLAS_NUM_THREADS = 1).

* **overhead**: a sweep of ``--n-overhead`` (1 000) one-step slider–crank cases
  (a new ``k`` per case, so every case rebuilds its model) on a one-worker
  LocalCluster, automatic batches and one case per task, against a serial
  loop doing the same work in this process. Per-case overhead =
  (sweep wall time − serial loop wall time) / cases. The cluster's start-up is
  timed separately.
* **speedup**: ``--n-speedup`` (200) slider–crank runs over the scene's
  default 1 s (200 steps of 5 ms), ``k`` varied, serial loop vs LocalCluster
  with 1 and 2 single-threaded worker processes.
* **memory**: a ``--n-memory`` (10⁴) case sweep of one-step cases on a
  scheduler started as its own process with ``dask scheduler`` on 127.0.0.1 and
  ``--tcp-workers`` (3) processes started with ``dask worker tcp://...`` — the
  commands of a multi-machine cluster — with the resident set size of the
  scheduler process sampled every 0.2 s (psutil). Also counts the distinct
  workers that ran cases.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

SCENE = "slider_crank"
H = 5e-3


def _cases(n, lo=1e3, hi=2e3):
    return {"k": [float(v) for v in np.linspace(lo, hi, n)]}


def serial_loop(grid, t_end):
    """The work of a sweep done in a plain loop in this process; returns (seconds, per-case list)."""
    import femb
    from femb.study import registry

    scene = registry.load(SCENE)
    per = []
    t0 = time.perf_counter()
    for k in grid["k"]:
        c0 = time.perf_counter()
        result = femb.simulate(scene.model(k=k), t_end, H, rho_inf=0.7, store=False)
        outs = scene.outputs(result)
        _ = {n: float(v[-1]) for n, v in outs.items()}
        per.append(time.perf_counter() - c0)
    return time.perf_counter() - t0, per


def local_client(n_workers):
    import logging

    from dask.distributed import Client, LocalCluster

    t0 = time.perf_counter()
    cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                           dashboard_address=":0", silence_logs=logging.ERROR)
    client = Client(cluster)
    # import femb on the workers once, as a sweep's first batch would
    client.run(lambda: __import__("femb.solve.solver") and None)
    return client, cluster, time.perf_counter() - t0


def timed_sweep(client, grid, t_end, batch_size=None):
    import femb

    t0 = time.perf_counter()
    df = femb.sweep(SCENE, grid=grid, t_end=t_end, h=H, client=client, batch_size=batch_size)
    wall = time.perf_counter() - t0
    assert len(df) == len(grid["k"]) and (df["status"] == "success").all(), df["message"].unique()[:3]
    return wall, df


def med(xs):
    return statistics.median(xs)


def part_overhead(args):
    n, reps = args.n_overhead, args.repeat
    grid = _cases(n)
    print(f"\n## Per-case overhead: {n} one-step {SCENE} cases (t_end = h = {H}), medians of {reps}")
    client, cluster, startup = local_client(1)
    serial, auto, one = [], [], []
    try:
        for _ in range(reps):           # interleaved, so that a change of the machine's load hits all alike
            serial.append(serial_loop(grid, H))
            auto.append(timed_sweep(client, grid, H))
            one.append(timed_sweep(client, grid, H, batch_size=1))
    finally:
        client.close()
        cluster.close()
    s = med([w for w, _ in serial])
    case_serial = med([med(p) for _, p in serial])
    print(f"LocalCluster start (1 worker, femb imported): {startup:.2f} s\n")
    print("| run | wall s | per case ms | overhead per case ms | case on worker ms (median) |")
    print("|---|---|---|---|---|")
    print(f"| serial loop in one process | {s:.2f} | {1e3 * s / n:.2f} | – | {1e3 * case_serial:.2f} |")
    for label, runs in (("sweep, 1 worker, automatic batches", auto), ("sweep, 1 worker, 1 case per task", one)):
        w = med([r[0] for r in runs])
        on_worker = med([float(r[1]["wall_time"].median()) for r in runs])
        print(f"| {label} | {w:.2f} | {1e3 * w / n:.2f} | {1e3 * (w - s) / n:.2f} | {1e3 * on_worker:.2f} |")
    bs = max(1, min(100, -(-n // 8)))
    print(f"\n(automatic batch size here: {bs} cases per task)")


def part_speedup(args):
    n, reps, t_end = args.n_speedup, args.repeat_speedup, args.t_end
    grid = _cases(n)
    print(f"\n## Speed-up: {n} {SCENE} runs to t_end = {t_end} s (h = {H}), medians of {reps}")
    clusters = {nw: local_client(nw) for nw in (1, 2)}     # idle workers cost next to nothing
    serial, walls = [], {1: [], 2: []}
    try:
        for _ in range(reps):           # interleaved, as above
            serial.append(serial_loop(grid, t_end)[0])
            for nw, (client, _, _) in clusters.items():
                walls[nw].append(timed_sweep(client, grid, t_end)[0])
    finally:
        for client, cluster, _ in clusters.values():
            client.close()
            cluster.close()
    rows = [("serial loop in one process", med(serial), None)]
    for nw, (_, _, startup) in clusters.items():
        rows.append((f"sweep, LocalCluster {nw} worker{'s' if nw > 1 else ''} (start {startup:.1f} s, not counted)",
                     med(walls[nw]), nw))
    base = rows[0][1]
    print("| run | wall s | s per run | speed-up vs serial |")
    print("|---|---|---|---|")
    for label, w, _ in rows:
        print(f"| {label} | {w:.1f} | {w / n:.3f} | {base / w:.2f} |")


def _rss(pid):
    import psutil

    return psutil.Process(pid).memory_info().rss


def part_memory(args):
    import femb
    from dask.distributed import Client

    n, n_workers = args.n_memory, args.tcp_workers
    print(f"\n## Scheduler memory: {n} one-step cases, 'dask scheduler' + {n_workers} x 'dask worker' over TCP")
    tmp = Path(tempfile.mkdtemp(prefix="femb-sweep-bench-"))
    sched_file = tmp / "scheduler.json"
    env = dict(os.environ)
    bindir = Path(sys.executable).parent
    dask_cmd = [str(bindir / "dask")] if (bindir / "dask").exists() else [sys.executable, "-m", "dask"]
    procs = []
    try:
        sched = subprocess.Popen(dask_cmd + ["scheduler", "--host", "127.0.0.1", "--port", "0",
                                             "--no-dashboard", "--scheduler-file", str(sched_file)],
                                 env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        procs.append(sched)
        for _ in range(100):
            if sched_file.exists() and sched_file.stat().st_size > 0:
                break
            time.sleep(0.1)
        address = json.loads(sched_file.read_text())["address"]
        for i in range(n_workers):
            procs.append(subprocess.Popen(dask_cmd + ["worker", address, "--nthreads", "1", "--nworkers", "1",
                                                      "--no-dashboard", "--name", f"w{i}"],
                                          env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        client = Client(address)
        client.wait_for_workers(n_workers, timeout=120)
        rss0 = _rss(sched.pid)
        samples, stop = [], threading.Event()

        def sample():
            while not stop.is_set():
                samples.append(_rss(sched.pid))
                stop.wait(0.2)

        th = threading.Thread(target=sample, daemon=True)
        th.start()
        t0 = time.perf_counter()
        df = femb.sweep(SCENE, grid=_cases(n), t_end=H, h=H, client=address, out=tmp / "res.parquet")
        wall = time.perf_counter() - t0
        stop.set()
        th.join()
        rss1 = _rss(sched.pid)
        client.close()
        ok = int((df["status"] == "success").sum())
        workers = df["worker"].nunique()
        files = len(list((tmp / "res.parquet").glob("part-*.parquet")))
        print(f"scheduler {address}; {ok}/{n} cases succeeded in {wall:.1f} s "
              f"({1e3 * wall / n:.2f} ms per case) on {workers} distinct workers; {files} Parquet chunks\n")
        print("| scheduler RSS | MiB |")
        print("|---|---|")
        print(f"| before the sweep (workers connected) | {rss0 / 2**20:.1f} |")
        print(f"| median during the sweep | {med(samples) / 2**20:.1f} |")
        print(f"| peak during the sweep | {max(samples) / 2**20:.1f} |")
        print(f"| after the sweep | {rss1 / 2**20:.1f} |")
        print(f"\n({len(samples)} samples; cases per worker: "
              f"{', '.join(str(v) for v in df['worker'].value_counts().sort_index().tolist())})")
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--part", choices=("overhead", "speedup", "memory", "all"), default="all")
    p.add_argument("--repeat", type=int, default=3, help="repetitions of the overhead part (median)")
    p.add_argument("--repeat-speedup", type=int, default=1, help="repetitions of the speed-up part (median)")
    p.add_argument("--n-overhead", type=int, default=1000)
    p.add_argument("--n-speedup", type=int, default=200)
    p.add_argument("--t-end", type=float, default=1.0, help="final time of the speed-up runs")
    p.add_argument("--n-memory", type=int, default=10_000)
    p.add_argument("--tcp-workers", type=int, default=3)
    args = p.parse_args(argv)
    print(f"# femb.sweep benchmark ({os.cpu_count()} cores, Python {sys.version.split()[0]}, "
          f"single-threaded BLAS as in Dask's workers; load average at start "
          f"{' '.join(f'{x:.1f}' for x in os.getloadavg())})")
    if args.part in ("overhead", "all"):
        part_overhead(args)
    if args.part in ("speedup", "all"):
        part_speedup(args)
    if args.part in ("memory", "all"):
        part_memory(args)
    print(f"\n(load average at the end {' '.join(f'{x:.1f}' for x in os.getloadavg())})")
    return 0


#: Set by Dask's nanny in every worker process (distributed.nanny.pre-spawn-environ); the serial
#: loop of this benchmark runs under the same settings.
THREAD_ENV = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}


if __name__ == "__main__":
    if any(os.environ.get(k) != v for k, v in THREAD_ENV.items()):
        # BLAS reads these when numpy is first imported: start again with them set
        os.execve(sys.executable, [sys.executable, "-m", "femb.benchmarks.cost.sweep_bench"] + sys.argv[1:],
                  {**os.environ, **THREAD_ENV})
    sys.exit(main())
