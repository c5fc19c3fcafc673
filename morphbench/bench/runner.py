"""Run a suite into a results directory: skip what is there, run the rest on an executor, save each job as it ends.

    from morphbench.bench import load_suite, run_suite, LocalExecutor
    outcome = run_suite(load_suite("benchmarks/smoke.toml"), "results/smoke", LocalExecutor(2))
"""

from __future__ import annotations

import dataclasses
import math
import sys
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterator

import pandas as pd

from morphbench.bench.executors import LocalExecutor
from morphbench.bench.jobs import execute
from morphbench.bench.provenance import record_session
from morphbench.bench.store import Store
from morphbench.bench.model import Job, Suite
from morphbench.experiment.driver import batchable
from morphbench.experiment.run import RunConfig
from morphbench.errors import ConfigError
from morphbench.files import directory_lock


BATCH_SEEDS = 112
"""seeds of a condition run together at most: a batch's step costs its Python once, whatever its size (28 chain-3
seeds at a time cost 1.36x the CPU of 112: benchmarks/RESULTS.md)."""
JOBS_PER_WORKER = 4
"""a batch costs at most the suite's work to do over this many jobs per worker of a local pool, so that the workers'
loads stay even (a suite of one condition of 112 seeds on 2 workers runs as 8 batches). A Dask cluster does not say
its workers: its batches are of BATCH_SEEDS (small tasks there let Dask blame a healthy task queued beside one that
kills its worker: tests/test_bench_faults.py)."""


@dataclass
class Outcome:
    """What one call of ``run_suite`` did."""

    total: int
    """jobs in the suite (runs and scan parts)."""
    skipped: int
    """jobs already in the directory."""
    done: int = 0
    failed: int = 0
    failures: list[tuple[str, str]] = field(default_factory=list)
    """(job id, error) of the jobs that failed in this call."""
    wall_time_s: float = 0.0
    tables: dict[str, pd.DataFrame] = field(default_factory=dict)


def run_suite(suite: Suite, out: str | Path, executor=None, *, resume: bool = False, retry_failed: bool = False,
              progress: bool = True, on_result: Callable[[Job, dict], None] | None = None,
              batch_seeds: int | None = None) -> Outcome:
    """Run every job of ``suite`` that ``out`` does not hold yet, then consolidate the tables (morphbench.bench.store).

    ``out`` may hold this suite's earlier (interrupted) results: its finished jobs are skipped, failed ones too
    unless ``retry_failed``, but for a job whose worker died under it once (a crash may have been another's doing:
    the memory of the machine, a kill), which is run once more. If it holds results of a different suite, or of an
    earlier version of this one, it is refused unless ``resume``: then the finished jobs both suites share are
    reused. One process at a time writes ``out`` (``files.directory_lock``): another is refused. ``on_result(job,
    result)`` is called after each job is saved; an exception it raises (like Ctrl-C) stops the suite with every
    finished job saved and the rest cancelled. Seeds of a condition on the quasi-static chain model run together, up
    to ``batch_seeds`` at a time (default BATCH_SEEDS; 1: each alone), on a local pool a batch costing at most the
    work to do over JOBS_PER_WORKER jobs per worker, with the same results; a batch whose worker dies is run again
    seed by seed, so that only the seed that crashes fails.
    """
    started, started_at = time.perf_counter(), time.time()
    executor = executor or LocalExecutor()
    with writing(suite, out, resume) as store:
        store.clean_temporaries()
        plan = suite.plan()
        store.write_plan(plan, suite.text)
        jobs = suite.jobs()
        todo = [job for job in jobs if _needs_run(store, job, retry_failed)]
        outcome = Outcome(total=len(jobs), skipped=len(jobs) - len(todo))
        bar = _progress_bar(suite, todo, executor, progress)
        # longest first: the long runs start early and the short ones fill the gaps at the end (tables are in plan
        # order)
        workers = getattr(executor, "workers", None)
        budget = sum(job.cost for job in todo) / (JOBS_PER_WORKER * workers) if workers else math.inf
        work = sorted(batched(todo, batch_seeds or BATCH_SEEDS, budget), key=lambda job: -job.cost)
        try:
            while work:
                work = _run_round(work, executor, store, outcome, bar, len(todo), on_result)
        finally:
            if bar is not None:
                bar.close()
            if outcome.done or outcome.failed:  # the versions these jobs ran with, for the report
                record_session(store.root, started_at, executor.describe(), outcome.done, outcome.failed)
        outcome.tables = store.consolidate(plan)
    outcome.wall_time_s = time.perf_counter() - started
    return outcome


@contextmanager
def writing(suite: Suite, out: str | Path, resume: bool = False) -> Iterator[Store]:
    """The store of ``out``, held by this process for ``suite`` while the block runs (``run_suite`` holds it itself;
    ``morphbench bench`` holds it over the report too). Refused (ConfigError) if ``out`` is a file, holds another
    suite (unless ``resume``) or is held by another process; a directory refused is refused before anything is
    written in it."""
    store = Store(out)
    _check_directory(store, suite, resume)
    _make_directory(store.root)
    with directory_lock(store.root):
        _check_directory(store, suite, resume)  # again, held: another bench may have written it meanwhile
        yield store


def _run_round(work: list[Job], executor, store: Store, outcome: Outcome, bar, n_todo: int,
               on_result: Callable[[Job, dict], None] | None) -> list[Job]:
    """Run ``work`` and save each job as it ends; the runs of the batches whose worker died, to run one by one."""
    again: list[Job] = []
    for work_job, work_result in executor.run(work, execute):
        if work_job.kind == "batch" and work_result.get("crashes"):
            again.extend(work_job.payload)
            continue
        pairs = zip(work_job.payload, work_result["results"]) if work_job.kind == "batch" else \
            [(work_job, work_result)]
        for job, result in pairs:
            if result.get("crashes"):
                result["crashes"] += _crashes(store.load(job.kind, job.id, tables=False).result)
            store.save(job, result)
            if result["status"] == "done":
                outcome.done += 1
            else:
                outcome.failed += 1
                outcome.failures.append((job.id, result.get("error") or "unknown error"))
            if bar is not None:
                bar.update(job.cost)
                bar.set_postfix_str(f"{outcome.done + outcome.failed}/{n_todo} jobs, {outcome.failed} failed")
            if on_result is not None:
                on_result(job, result)
    return again


def batched(jobs: list[Job], size: int = BATCH_SEEDS, budget: float = math.inf) -> list[Job]:
    """The run jobs of one condition that can run together (experiment.driver) as batch jobs of up to ``size``
    seeds, and of a cost up to ``budget`` (at least one seed), in job order; every other job as it is. Records are
    the same either way: only the speed differs."""
    groups: dict[RunConfig, list[Job]] = {}
    can: dict[RunConfig, bool] = {}
    out: list[Job] = []
    for job in jobs:
        condition = dataclasses.replace(job.payload, seed=0) if job.kind == "run" else None
        if condition is not None and condition not in can:
            can[condition] = batchable(condition)
        if condition is not None and can[condition]:
            groups.setdefault(condition, []).append(job)
        else:
            out.append(job)
    for members in groups.values():
        seeds = max(1, int(min(size, budget / members[0].cost if members[0].cost > 0 else size)))
        for first in range(0, len(members), seeds):
            chunk = tuple(members[first:first + seeds])
            out.append(chunk[0] if len(chunk) == 1 else
                       Job(f"batch-{chunk[0].id}", "batch", chunk, sum(job.cost for job in chunk)))
    return out


def _needs_run(store: Store, job: Job, retry_failed: bool) -> bool:
    """Whether ``job`` runs: not run yet; failed and ``retry_failed``; or failed by its worker's death only once. A
    damaged job runs only with ``retry_failed`` (``morphbench check --repair`` sets it aside otherwise)."""
    loaded = store.load(job.kind, job.id, tables=False)
    if loaded.status == "missing":
        return True
    return loaded.status != "done" and (retry_failed or _crashes(loaded.result) == 1)


def _crashes(result: dict | None) -> int:
    """How many times a job's workers died under it, as its result.json says (0 for a job not failed so)."""
    result = result or {}
    return (result.get("crashes") or 0) if result.get("status") == "failed" else 0


def _make_directory(root: Path) -> None:
    """``root`` as a directory, created if need be (the lock that guards it lives in it)."""
    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError("--out", str(root), f"a directory that can be created ({exc.strerror})") from None


def _check_directory(store: Store, suite: Suite, resume: bool) -> None:
    root = store.root
    if root.exists() and not root.is_dir():
        raise ConfigError("--out", str(root), "a directory (this is a file)")
    old = store.read_plan()
    if old is None:
        if root.is_dir() and any(p for p in root.iterdir() if not p.name.startswith(".")) and not resume:
            raise ConfigError("--out", str(root), "a new or empty directory, or one written by 'morphbench bench' "
                                                  "(pass --resume to use it anyway)")
        return
    same = old.get("suite") == suite.name and _job_ids(old) == {job.id for job in suite.jobs()}
    if not same and not resume:
        what = f"suite {old.get('suite')!r}" if old.get("suite") != suite.name else "an earlier version of this suite"
        raise ConfigError("--out", str(root), f"a directory holding this suite's results; it holds {what} "
                                              "(pass --resume to reuse its finished runs, or choose another --out)")


def _job_ids(plan: dict) -> set[str]:
    ids = {run["id"] for run in plan.get("runs", [])}
    for scan in plan.get("scans", []):
        ids.update(scan["parts"])
    return ids


def _progress_bar(suite: Suite, todo: list[Job], executor, enabled: bool):
    if not enabled or not todo:
        return None
    from tqdm import tqdm

    n_runs = sum(job.kind == "run" for job in todo)
    print(f"{suite.name}: {n_runs} runs and {len(todo) - n_runs} scan parts to do on a {executor.describe()}; the "
          f"bar counts their estimated work (cycles x bodies^1.15), longest jobs first", file=sys.stderr)
    # smoothing 0: the time left from the mean rate since the start; batches of seeds end together, and tqdm's
    # default moving average of the last bursts made the estimate jump (0:41 to 9:58 in 15 s on the paper suite)
    return tqdm(total=sum(job.cost for job in todo), desc=suite.name, unit="work", smoothing=0,
                bar_format="{desc}: {percentage:3.0f}% of the work|{bar}| [{elapsed}<{remaining}{postfix}]")
