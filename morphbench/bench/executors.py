"""Where jobs run: a local process pool (the default) or a Dask distributed cluster.

An executor has one method, ``run(jobs, fn)``, a generator of ``(job, result)`` pairs in completion order; the
caller writes each result as it arrives, so stopping the generator (Ctrl-C, an error) loses no finished job.
Closing the generator cancels the jobs not yet started. Every job is independent and deterministic, so the
results are the same whichever executor and however many workers: only their order of arrival differs.
"""

from __future__ import annotations

import multiprocessing
import os
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any, Callable, Iterable, Iterator

from morphbench.bench.jobs import describe
from morphbench.errors import ConfigError


class WorkerLost(RuntimeError):
    """A worker process died (killed, out of memory, a crash in C code): the jobs still pending are not run."""


def default_workers() -> int:
    """The cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


class LocalExecutor:
    """A pool of ``workers`` fresh processes (spawned: nothing of the parent's state but ``sys.path`` and the
    environment is inherited; each run opens its own PyBullet client in its worker). ``initializer(*initargs)``
    runs once in each worker, e.g. to put a plug-in's directory on ``sys.path``."""

    def __init__(self, workers: int | None = None, initializer: Callable | None = None, initargs: tuple = ()):
        self.workers = workers or default_workers()
        self.initializer, self.initargs = initializer, initargs

    def describe(self) -> str:
        return f"local pool of {self.workers} worker{'s' if self.workers != 1 else ''}"

    def run(self, jobs: Iterable, fn: Callable[[Any], dict]) -> Iterator[tuple[Any, dict]]:
        jobs = list(jobs)
        if not jobs:
            return
        pool = ProcessPoolExecutor(max_workers=min(self.workers, len(jobs)),
                                   mp_context=multiprocessing.get_context("spawn"),
                                   initializer=self.initializer, initargs=self.initargs)
        try:
            pending = {pool.submit(fn, job): job for job in jobs}
            while pending:
                done, _ = wait(pending, return_when=FIRST_COMPLETED)
                for future in done:
                    job = pending.pop(future)
                    try:
                        result = future.result()
                    except BrokenProcessPool as exc:
                        raise WorkerLost(f"a worker process died ({exc}); {len(pending) + 1} jobs did not finish")
                    except Exception as exc:  # e.g. a result that cannot be pickled back
                        result = {"status": "failed", "error": describe(exc), "traceback": None, "wall_time_s": None}
                    yield job, result
        finally:
            pool.shutdown(wait=True, cancel_futures=True)


class DaskExecutor:
    """A Dask distributed cluster: ``scheduler`` is its address (``tcp://host:8786``) or a ``dask.distributed.Client``
    (then it is used as is and not closed). Workers need morphbench (and any plug-in learner) importable."""

    def __init__(self, scheduler: Any, timeout: float = 20.0):
        self.scheduler, self.timeout = scheduler, timeout

    def describe(self) -> str:
        address = getattr(self.scheduler, "scheduler", None)
        address = getattr(address, "address", None) or self.scheduler
        return f"Dask cluster at {address}"

    def run(self, jobs: Iterable, fn: Callable[[Any], dict]) -> Iterator[tuple[Any, dict]]:
        jobs = list(jobs)
        if not jobs:
            return
        distributed = import_dask()
        own = not isinstance(self.scheduler, distributed.Client)
        client = connect(self.scheduler, self.timeout) if own else self.scheduler
        futures = []
        try:
            futures = [client.submit(fn, job, pure=False) for job in jobs]
            by_key = {f.key: job for f, job in zip(futures, jobs)}
            for future in distributed.as_completed(futures):
                job = by_key[future.key]
                try:
                    result = future.result()
                except Exception as exc:  # KilledWorker (the job took its workers down), a lost connection, ...
                    result = {"status": "failed", "error": describe(exc), "traceback": None, "wall_time_s": None}
                future.release()
                yield job, result
        finally:
            if futures:
                try:
                    client.cancel([f for f in futures if not f.done()])
                except Exception:  # the cluster may be gone already; nothing more to cancel then
                    pass
            if own:
                client.close()


def import_dask():
    """``dask.distributed``, or a ConfigError that says how to install it."""
    try:
        import dask.distributed as distributed
    except ImportError as exc:
        raise ConfigError("--scheduler", "dask", "the optional dependency dask[distributed] installed: "
                          f"pip install 'morphbench[dask]' ({exc})") from None
    return distributed


def connect(address: str, timeout: float = 20.0):
    """A client of the Dask scheduler at ``address``; a ConfigError if it cannot be reached."""
    distributed = import_dask()
    try:
        return distributed.Client(address, timeout=timeout)
    except (OSError, TimeoutError, ValueError) as exc:
        expected = f"the address of a running Dask scheduler ({describe(exc)})"
        raise ConfigError("--scheduler", address, expected) from None
