"""Benchmark suites: matrices of learning runs and landscape scans, run in parallel, stored as Parquet, reported.

    suite.py      the suite file format (TOML) and its reader
    model.py      a suite once read: its runs, scans (in parts), experiments and jobs
    expand.py     an experiment's matrix and each scan expanded into runs and scan parts with stable ids
                  (morphbench.identity)
    aliases.py    the first suites' keys, still read (translated into run-configuration keys)
    cost.py       the cost estimate of a job (for the progress bar and longest-first scheduling)
    jobs.py       what a worker does with one job (never raises: a failure is a result)
    executors.py  a local process pool (default) or a Dask distributed cluster
    store.py      the results directory: one atomically written directory per job, consolidated tables
    runner.py     run_suite: skip what the directory holds, run the rest, save each job as it finishes
    provenance.py the versions and machine each bench ran with (DIR/environment.json)
    metrics.py    per-condition metrics (final Ubar, exponential fit, steps to 0.8 U_eq, acceptance, scan best)
    figures.py    the report's figures of an experiment (Ubar distribution, acceptance, scaling, events,
                  landscapes with the phases tried, start and end positions), drawn from tables
    claims.py     the paper's quantitative statements, each measured on the stored tables
    check.py      morphbench check: damaged jobs and files of a results directory; --repair moves them aside
    report.py     figures and report.md, rebuilt from the store
    html.py       report.html: report.md as one self-contained page (figures, videos inline), suite file, versions
    videos.py     one short video per experiment, replayed off-screen from a stored run (DIR/videos/)
    scores.py     the standard task set's scores: task score, standard errors, overall; its reference table
    leaderboard.py `morphbench leaderboard`: stored built-ins, other learners run, leaderboard.md and .html, the
                  scale figure (score against the number of units)
    cli.py        the `bench`, `report`, `check` and `leaderboard` subcommands (add_bench_commands)

The names below are imported on first use (``morphbench.lazy``): the metrics, figures, claims and the report need no
simulator.
"""

from morphbench.lazy import export_lazily

export_lazily(__name__, {
    "add_bench_commands": "cli",
    "DaskExecutor": "executors", "LocalExecutor": "executors",
    "build_report": "report",
    "Outcome": "runner", "run_suite": "runner",
    "Store": "store",
    "Suite": "model", "load_suite": "suite",
})
