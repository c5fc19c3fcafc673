"""The ``bench`` and ``report`` subcommands, added to the ``morphbench`` command by ``add_bench_commands``.

    morphbench bench SUITE --out DIR [--workers N | --scheduler ADDRESS] [--resume] [--retry-failed] [--quiet]
                     [--no-report | --no-videos]
    morphbench report DIR [--compare A B] [--no-videos]
    morphbench check DIR [--repair]
    morphbench leaderboard [LEARNER ...] [--out DIR] [--tasks TASK ...] [--suite FILE] [--workers N] [--quiet]
"""

from __future__ import annotations

import argparse
import functools
import os
import sys

from morphbench.params import LEARNER_HELP, PHYSICS_PRESETS

EXIT_FAILED_RUNS = 1
EXIT_INTERRUPTED = 130


def add_bench_commands(subparsers) -> None:
    """Add ``bench`` and ``report`` to an argparse sub-parser collection; each sets ``func(args) -> exit code``."""
    bench = subparsers.add_parser(
        "bench", help="run a suite of learning runs and scans into a results directory, then report",
        description="Run every run and scan of a suite file that the results directory does not hold yet (a local "
                    "process pool by default, or a Dask cluster), write them to DIR as Parquet, then DIR/report.md.")
    bench.add_argument("suite", help="suite file, e.g. benchmarks/smoke.toml")
    bench.add_argument("--out", required=True, help="results directory; run again to resume an interrupted suite")
    where = bench.add_mutually_exclusive_group()
    where.add_argument("--workers", type=_positive_int, default=None,
                       help="local worker processes (default: the cores available; at most the number of jobs and "
                            "of CPUs are used)")
    where.add_argument("--scheduler", metavar="ADDRESS",
                       help="run on a Dask distributed cluster, e.g. tcp://10.0.0.5:8786 (needs morphbench[dask])")
    bench.add_argument("--resume", action="store_true",
                       help="use DIR even if it holds another suite or another version of this one (its finished "
                            "runs are reused)")
    bench.add_argument("--retry-failed", action="store_true", help="run again the runs that failed last time")
    bench.add_argument("--no-report", action="store_true",
                       help="write the tables but not the figures, report.md and report.html")
    bench.add_argument("--no-videos", action="store_true",
                       help="report without the video of one run per experiment in report.html")
    bench.add_argument("--quiet", action="store_true", help="no progress bar")
    bench.add_argument("--physics", choices=sorted(PHYSICS_PRESETS),
                       help="run every run and scan of the suite on this physics preset instead of its own")
    bench.set_defaults(func=cmd_bench)

    report = subparsers.add_parser(
        "report", help="rebuild the tables, figures, report.md and report.html of a results directory",
        description="Rebuild DIR's consolidated tables, metrics, figures, report.md and report.html (the same report "
                    "as one self-contained page) from its finished runs, with a short video of one run per "
                    "experiment replayed off-screen (a few seconds each; reused while the run is the same).")
    report.add_argument("dir", help="results directory written by 'morphbench bench'")
    report.add_argument("--compare", nargs=2, metavar=("A", "B"),
                        help="two results directories of one suite on different physics (e.g. paper-quick on "
                             "PyBullet and on the quasi-static model, their reports built): compare them condition "
                             "by condition into DIR/backends.parquet, which DIR's report shows from then on")
    report.add_argument("--no-videos", action="store_true",
                        help="no videos in report.html (nothing is simulated)")
    report.set_defaults(func=cmd_report)

    check = subparsers.add_parser(
        "check", help="check a results directory against its plan; --repair moves damaged jobs aside",
        description="Check every job directory (result.json, each Parquet table's columns, types and values), "
                    "plan.json and the consolidated tables of DIR; print each damaged job or file with what was "
                    "expected, one line each. Exit 0 if clean, 1 if damaged, 2 if DIR is not a results directory "
                    "or this user may not read it (its modes are no damage: nothing is moved for them).")
    check.add_argument("dir", help="results directory written by 'morphbench bench'")
    check.add_argument("--repair", action="store_true",
                       help="move damaged jobs and files into DIR/damaged/<time>/ (nothing is deleted) and drop the "
                            "tables left stale, so that 'morphbench bench SUITE --out DIR' runs those jobs again")
    check.set_defaults(func=cmd_check)

    board = subparsers.add_parser(
        "leaderboard", help="score learners on the standard task set against the stored built-ins",
        description="Run the standard task set (benchmarks/standard-v2.toml) for the named learners into DIR "
                    "(resumed: runs it holds are not run again) and score each task's final true Ubar over the best "
                    "gait known for it; the built-ins' results are read from the stored reference table, not run. "
                    "Writes DIR/leaderboard.md and DIR/leaderboard.html, and DIR/leaderboard-scale.png (score "
                    "against the number of units) when the tasks include some of the group 'scale' "
                    "(docs/leaderboard.md).")
    board.add_argument("learners", nargs="*", metavar="LEARNER",
                       help=f"{LEARNER_HELP}; none: the stored built-ins alone")
    board.add_argument("--out", metavar="DIR",
                       help="results directory of the learners' runs and the tables (default results/leaderboard)")
    board.add_argument("--tasks", nargs="+", metavar="TASK",
                       help="run the learners on these tasks only, or on a group's (scale: chains of 2 to 100 units "
                            "and sheets to 10,000); every learner is then compared overall on them")
    board.add_argument("--suite", metavar="FILE|NAME",
                       help="another task set, its reference table beside it as STEM-reference.csv, or a shipped "
                            "set's name (standard-v1; default: the standard set, standard-v2)")
    board.add_argument("--workers", metavar="N", type=_positive_int, default=None,
                       help="local worker processes (default: the cores available)")
    board.add_argument("--quiet", action="store_true", help="no progress bar")
    board.set_defaults(func=cmd_leaderboard)


def _permitted(command):
    """``command``, but a file or directory this user may not read or write (PermissionError, wherever it comes
    from) is a ConfigError naming it (store.Unreadable): one line, not a traceback."""

    @functools.wraps(command)
    def guarded(args) -> int:
        try:
            return command(args)
        except PermissionError as exc:
            from morphbench.bench.store import Unreadable

            raise Unreadable(exc.filename or getattr(args, "dir", None) or args.out) from None

    return guarded


@_permitted
def cmd_bench(args) -> int:
    from morphbench.bench.executors import DaskExecutor, LocalExecutor, connect
    from morphbench.bench.runner import writing
    from morphbench.bench.suite import load_suite
    from morphbench.files import check_path

    check_path(args.out, "--out")  # before the suite is read: an empty or impossible name writes nothing
    suite = load_suite(args.suite, physics=args.physics)
    client = connect(args.scheduler) if args.scheduler else None  # a bad address fails before anything runs
    executor = (DaskExecutor(client) if client is not None
                else LocalExecutor(args.workers and min(args.workers, os.cpu_count() or 1)))
    try:
        with writing(suite, args.out, args.resume):  # one bench at a time in DIR, the report included
            code = _bench(args, suite, executor)
    except KeyboardInterrupt:
        print(f"morphbench: interrupted; finished runs are saved in {args.out}: run the same command again to resume",
              file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        if client is not None:
            client.close()
    return code


def _bench(args, suite, executor) -> int:
    """Run the suite, say how it went, report; the exit code."""
    from morphbench.bench.report import build_report, require_outputs
    from morphbench.bench.runner import run_suite

    if not args.no_report:  # before the suite runs, not after
        require_outputs(args.out, videos=not args.no_videos)

    outcome = run_suite(suite, args.out, executor, resume=args.resume, retry_failed=args.retry_failed,
                        progress=not args.quiet)
    print(f"{suite.name}: {outcome.done} jobs done, {outcome.failed} failed, {outcome.skipped} already in {args.out}; "
          f"{outcome.wall_time_s:.1f} s")
    for job_id, error in outcome.failures[:10]:
        print(f"  failed {job_id}: {error}")
    if len(outcome.failures) > 10:
        print(f"  ... and {len(outcome.failures) - 10} more (see {args.out}/runs.parquet)")
    if not args.no_report:
        path = build_report(args.out, outcome.tables, videos=not args.no_videos)
        print(f"report in {path} and {path.with_suffix('.html')}")
    _warn_damaged(outcome.tables["jobs"], args.out)
    runs = outcome.tables["runs"]
    return EXIT_FAILED_RUNS if (runs.status == "failed").any() or outcome.failed else 0


@_permitted
def cmd_report(args) -> int:
    import pandas as pd

    from morphbench.bench.report import build_report, require_outputs
    from morphbench.bench.store import Store
    from morphbench.errors import ConfigError

    if not os.path.isdir(args.dir):
        raise ConfigError("report", args.dir, "a results directory written by 'morphbench bench'"
                                              + (" (this is a file)" if os.path.exists(args.dir) else ""))
    store = Store(args.dir)
    store.require_plan()  # a damaged results directory refuses before anything is compared or written
    store.require_layout()
    require_outputs(store.root, videos=not args.no_videos)  # before the comparison is written
    if args.compare:
        from morphbench.bench.backends import TABLE, compare

        store.write_table(TABLE, compare(*args.compare))
    path = build_report(args.dir, videos=not args.no_videos)
    print(f"report in {path} and {path.with_suffix('.html')}")
    _warn_damaged(pd.read_parquet(store.root / "jobs.parquet"), args.dir)  # the jobs table the report rebuilt
    return 0


def _warn_damaged(jobs, directory: str) -> None:
    """One line on stderr when the tables left damaged jobs out (morphbench.bench.store)."""
    from morphbench.bench.store import DAMAGED

    damaged = int((jobs.status == DAMAGED).sum())
    if damaged:
        print(f"morphbench: warning: {damaged} damaged jobs left out of the tables and the report ('morphbench check "
              f"{directory}' lists them, with --repair it moves them aside)", file=sys.stderr)


@_permitted
def cmd_check(args) -> int:
    from morphbench.bench.check import run

    return run(args.dir, repair=args.repair)


def cmd_leaderboard(args) -> int:
    from morphbench.bench.executors import LocalExecutor
    from morphbench.bench.leaderboard import DEFAULT_OUT, leaderboard

    out = DEFAULT_OUT if args.out is None else args.out
    executor = LocalExecutor(args.workers and min(args.workers, os.cpu_count() or 1))
    try:
        board = leaderboard(args.learners, out, args.suite, args.tasks, executor, progress=not args.quiet)
    except KeyboardInterrupt:
        print(f"morphbench: interrupted; finished runs are saved in {out}: run the same command again to resume",
              file=sys.stderr)
        return EXIT_INTERRUPTED
    for run_id, error in board.failures[:10]:
        print(f"  failed {run_id}: {error}")
    for rank, row in enumerate(board.ranking.itertuples(), 1):
        print(f"{rank}. {row.learner}: {row.score:.3f} +- {row.score_se:.3f} over {row.tasks} "
              f"task{'s' if row.tasks != 1 else ''}")
    for name in sorted(set(board.scores.learner) - set(board.ranking.learner)):
        print(f"-. {name}: not scored (no task where 2 of its runs finished)")
    figure = f" (the scale figure: {board.figure})" if board.figure is not None else ""
    print(f"leaderboard in {board.markdown} and {board.html}{figure}")
    return EXIT_FAILED_RUNS if board.failures else 0


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {text!r}")
    return value
