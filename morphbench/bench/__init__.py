"""Benchmark suites: matrices of learning runs and landscape scans, run in parallel, stored as Parquet, reported.

    suite.py      the suite file format (TOML) and its expansion into runs and scan parts with stable ids
    jobs.py       what a worker does with one job (never raises: a failure is a result)
    executors.py  a local process pool (default) or a Dask distributed cluster
    store.py      the results directory: one atomically written directory per job, consolidated tables
    runner.py     run_suite: skip what the directory holds, run the rest, save each job as it finishes
    metrics.py    per-condition metrics (final Ubar, exponential fit, steps to 0.8 U_eq, acceptance, scan best)
    report.py     figures and report.md, rebuilt from the store
    cli.py        the `bench` and `report` subcommands (add_bench_commands)
"""

from morphbench.bench.cli import add_bench_commands
from morphbench.bench.executors import DaskExecutor, LocalExecutor
from morphbench.bench.report import build_report
from morphbench.bench.runner import Outcome, run_suite
from morphbench.bench.store import Store
from morphbench.bench.suite import Suite, load_suite

__all__ = ["DaskExecutor", "LocalExecutor", "Outcome", "Store", "Suite", "add_bench_commands", "build_report",
           "load_suite", "run_suite"]
