"""Wall time of a suite on 1 local worker, 2 local workers and a Dask LocalCluster of 2 workers, in one process.

    python benchmarks/bench_parallel.py                          # the smoke suite, each executor once
    python benchmarks/bench_parallel.py --repeat 3               # best of 3 (the machine is shared and noisy)
    python benchmarks/bench_parallel.py benchmarks/paper-quick.toml

Each executor runs the whole suite into a fresh directory, timed from the call to ``run_suite`` to its return (pool
start, every job, writing each job's results and consolidating the tables; no figures). The Dask cluster is
started before timing (its start-up is reported on its own line). The tables of the three runs are compared:
they must be identical but for wall times. Prints a markdown table with the date and the ratios to 1 worker.
"""

from __future__ import annotations

import argparse
import platform
import shutil
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd

from morphbench.bench import DaskExecutor, LocalExecutor, load_suite, run_suite

HERE = Path(__file__).resolve().parent
TABLES = ("runs", "steps", "units", "scans")


def timed(suite, executor, scratch: Path, repeat: int) -> tuple[float, dict]:
    """Best wall time of ``repeat`` runs of the suite into fresh directories, and the last run's tables."""
    best, tables = float("inf"), {}
    for _ in range(repeat):
        out = Path(tempfile.mkdtemp(dir=scratch))
        started = time.perf_counter()
        outcome = run_suite(suite, out, executor, progress=False)
        best = min(best, time.perf_counter() - started)
        if outcome.failed:
            sys.exit(f"{outcome.failed} jobs failed on {executor.describe()}: {outcome.failures[:3]}")
        tables = outcome.tables
        shutil.rmtree(out)
    return best, tables


def same(a: dict, b: dict) -> bool:
    try:
        for name in TABLES:
            pd.testing.assert_frame_equal(a[name].drop(columns=["wall_time_s"], errors="ignore"),
                                          b[name].drop(columns=["wall_time_s"], errors="ignore"), check_exact=True)
    except AssertionError:
        return False
    return True


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("suite", nargs="?", default=str(HERE / "smoke.toml"))
    parser.add_argument("--repeat", type=int, default=1, help="runs per executor; the best is kept")
    parser.add_argument("--no-dask", action="store_true")
    args = parser.parse_args()
    suite = load_suite(args.suite)
    n_runs = len(suite.runs)
    n_parts = len(suite.jobs()) - n_runs
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        scratch = Path(scratch)
        one, reference = timed(suite, LocalExecutor(1), scratch, args.repeat)
        rows.append(("local pool", 1, one, True))
        two, tables = timed(suite, LocalExecutor(2), scratch, args.repeat)
        rows.append(("local pool", 2, two, same(tables, reference)))
        cluster_start = None
        if not args.no_dask:
            from dask.distributed import Client, LocalCluster

            started = time.perf_counter()
            with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
                    Client(cluster) as client:
                cluster_start = time.perf_counter() - started
                dask, tables = timed(suite, DaskExecutor(client), scratch, args.repeat)
            rows.append(("Dask LocalCluster", 2, dask, same(tables, reference)))

    command = " ".join(["python benchmarks/bench_parallel.py", *sys.argv[1:]])
    print(f"## Parallel suites — `{command}` ({time.strftime('%Y-%m-%d')})")
    print()
    print(f"Suite {suite.name}: {n_runs} runs and {n_parts} scan parts. {platform.machine()}, "
          f"Python {platform.python_version()}, best of {args.repeat}.")
    print()
    print("| executor | workers | wall s | speed-up vs 1 worker | tables identical to 1 worker |")
    print("|---|---|---|---|---|")
    for name, workers, seconds, identical in rows:
        print(f"| {name} | {workers} | {seconds:.2f} | {one / seconds:.2f} | {'yes' if identical else 'NO'} |")
    if cluster_start is not None:
        print()
        print(f"Dask LocalCluster start-up (not included above): {cluster_start:.2f} s.")


if __name__ == "__main__":
    main()
