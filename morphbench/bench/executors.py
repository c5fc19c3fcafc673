"""Where jobs run: a local process pool (the default) or a Dask distributed cluster.

An executor has one method, ``run(jobs, fn)``, a generator of ``(job, result)`` pairs in completion order; the
caller writes each result as it arrives, so stopping the generator (Ctrl-C, an error) loses no finished job.
Closing the generator cancels the jobs not yet started. Every job is independent and deterministic, so the
results are the same whichever executor and however many workers: only their order of arrival differs.

A job whose worker process dies under it (a segfault in C code, ``os._exit`` in a plug-in, the out-of-memory killer)
comes back as failed with the reason (``jobs.lost``: 'worker died: signal SIGSEGV'); the other jobs go on.
"""

from __future__ import annotations

import collections
import ctypes
import multiprocessing
import os
import pickle
import signal
import sys
import threading
import time
from multiprocessing.connection import wait
from typing import Any, Callable, Iterable, Iterator

from morphbench.errors import ConfigError
from morphbench.failures import describe


def default_workers() -> int:
    """The cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


class LocalExecutor:
    """A pool of ``workers`` fresh processes (spawned: nothing of the parent's state but ``sys.path`` and the
    environment is inherited; each run opens its own PyBullet client in its worker).

    Each worker holds one job at a time, so a worker that dies takes exactly that job with it: the job is failed
    (``jobs.lost``), a fresh worker takes the dead one's place, and no other job is lost. Workers ignore Ctrl-C (the
    bench stops them: no traceback of theirs comes before its one line) and end with the bench, even when it is
    killed (SIGKILL): on Linux the kernel ends them (``PR_SET_PDEATHSIG``), elsewhere they watch their parent. A
    worker asks for that before it imports anything of the jobs: this module imports nothing heavy, and ``fn`` reaches
    the worker pickled, loaded once it is bound to its parent (importing the simulator takes seconds, more on a busy
    machine, and a worker killed with its parent meanwhile would live on until it finished)."""

    def __init__(self, workers: int | None = None):
        self.workers = workers or default_workers()

    def describe(self) -> str:
        return f"local pool of {self.workers} worker{'s' if self.workers != 1 else ''}"

    def run(self, jobs: Iterable, fn: Callable[[Any], dict]) -> Iterator[tuple[Any, dict]]:
        queue = collections.deque(jobs)
        size = min(self.workers, len(queue))
        workers: list[_Worker] = []
        try:
            while True:
                workers = [w for w in workers if not w.dead]
                idle = [w for w in workers if w.job is None]
                while len(idle) < len(queue) and len(workers) < size:
                    workers.append(_Worker(fn))
                    idle.append(workers[-1])
                    workers[-1].start()  # once listed: Ctrl-C from here on stops it with the others
                for worker in idle[:len(queue)]:
                    worker.give(queue.popleft(), queue)
                busy = [w for w in workers if w.job is not None]
                if not busy:
                    if queue:  # the idle workers had died: fresh ones take their jobs
                        continue
                    return
                ready = set(wait([w.conn for w in busy] + [w.process.sentinel for w in busy]))
                for worker in busy:
                    if worker.conn in ready or worker.process.sentinel in ready:
                        yield worker.take()
        finally:
            _stop([w for w in workers if not w.dead and w.process.pid is not None])  # started and alive


class _Worker:
    """One worker process and the parent's end of its pipe; ``job`` is the job it runs, None when idle."""

    def __init__(self, fn: Callable[[Any], dict]):
        context = multiprocessing.get_context("spawn")
        self.conn, child = context.Pipe()
        self.child = child
        self.process = context.Process(target=_serve, args=(child, pickle.dumps(fn), os.getpid()),
                                       name="morphbench-worker")
        self.job, self.dead = None, False

    def start(self) -> None:
        # Ctrl-C held off while the worker starts: it inherits the blocked signal until it ignores it for good, and
        # the parent gets it right after
        held = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        try:
            self.process.start()
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, held)
            self.child.close()

    def give(self, job, queue: collections.deque) -> None:
        """Send ``job``; if the worker has died meanwhile, ``job`` goes back to the head of ``queue``."""
        try:
            self.conn.send(job)
        except OSError:  # a broken pipe: the worker is gone
            queue.appendleft(job)
            self._end()
        else:
            self.job = job

    def take(self) -> tuple[Any, dict]:
        """The job and its result, or ``jobs.lost`` with why the worker died (then ``dead`` is True)."""
        job, self.job = self.job, None
        try:
            return job, self.conn.recv()
        except (EOFError, OSError):  # the worker died before it sent a result
            self._end()
            return job, _jobs().lost(_death(self.process.exitcode))
        except Exception as exc:  # a result that cannot be unpickled here
            return job, _jobs().failed(describe(exc))

    def _end(self) -> None:
        self.dead = True
        self.process.join()
        self.conn.close()


def _death(exitcode: int | None) -> str:
    """How a process ended, from its exit code ('signal SIGSEGV', 'exit code 3')."""
    if exitcode is not None and exitcode < 0:
        try:
            return f"signal {signal.Signals(-exitcode).name}"
        except ValueError:
            return f"signal {-exitcode}"
    return f"exit code {exitcode}"


def _stop(workers: list[_Worker]) -> None:
    """End every worker: an idle one is told to exit, a busy one (its job cancelled) is terminated."""
    for worker in workers:
        if worker.job is None:
            try:
                worker.conn.send(None)
            except OSError:  # it has just died
                pass
        else:
            worker.process.terminate()
    for worker in workers:
        worker.process.join(timeout=10)
        if worker.process.is_alive():
            worker.process.kill()
            worker.process.join()
        worker.conn.close()


def _jobs():
    """bench.jobs, imported when first needed: it imports the simulator, which a worker must not import before it is
    bound to its parent (``_serve``)."""
    from morphbench.bench import jobs

    return jobs


def _serve(conn, pickled_fn: bytes, parent: int) -> None:
    """A worker's life: bound to its parent, then run the jobs the parent sends with ``fn`` (``pickled_fn``, loaded
    only now: loading it imports its module), one at a time, and send back each result; end at None, or when the
    parent is gone."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the bench's to handle: it stops its workers itself
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    _end_with_parent(parent)
    fn, failed = pickle.loads(pickled_fn), _jobs().failed
    while True:
        try:
            job = conn.recv()
        except (EOFError, OSError):  # the parent has gone
            return
        if job is None:
            return
        try:
            result = fn(job)
        except BaseException as exc:  # jobs.execute never raises; another ``fn`` might
            result = failed(describe(exc))
        try:
            conn.send(result)
        except (BrokenPipeError, ConnectionResetError):
            return
        except Exception as exc:  # a result that cannot be pickled (nothing was sent)
            conn.send(failed(f"its result could not be sent back ({describe(exc)})"))


def _end_with_parent(parent: int) -> None:
    """Have this process end when its parent does, however the parent ends (SIGKILL included)."""
    if sys.platform.startswith("linux"):
        pr_set_pdeathsig = 1
        ctypes.CDLL(None, use_errno=True).prctl(pr_set_pdeathsig, signal.SIGKILL)
    else:
        def watch():
            while os.getppid() == parent:
                time.sleep(1.0)
            os._exit(1)

        threading.Thread(target=watch, daemon=True, name="morphbench-parent-watch").start()
    if os.getppid() != parent:  # the parent ended before the request above was made
        os._exit(1)


class DaskExecutor:
    """A Dask distributed cluster: ``scheduler`` is its address (``tcp://host:8786``) or a ``dask.distributed.Client``
    (then it is used as is and not closed). Workers need morphbench (and any plug-in learner) importable. A job that
    takes its worker down is tried on others first (Dask's ``distributed.scheduler.allowed-failures``), then comes
    back failed (``jobs.lost``); Dask reschedules the jobs queued on a dead worker itself (each counted suspect once:
    ``distributed.scheduler.worker-saturation`` 1.0 queues none)."""

    def __init__(self, scheduler: Any, timeout: float = 20.0):
        self.scheduler, self.timeout = scheduler, timeout
        self._workers = 0
        """the most workers the cluster has had at the start of a round."""

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
            self._wait_for_workers(client, distributed)
            futures = [client.submit(fn, job, pure=False) for job in jobs]
            by_key = {f.key: job for f, job in zip(futures, jobs)}
            for future in distributed.as_completed(futures):
                job = by_key[future.key]
                try:
                    result = future.result()
                except distributed.KilledWorker as exc:  # the job took every worker that ran it down
                    last = getattr(exc.last_worker, "address", exc.last_worker)
                    before = f" and {exc.allowed_failures} before it" if exc.allowed_failures else ""
                    result = _jobs().lost(f"Dask worker {last}{before}")
                except Exception as exc:  # a lost connection, ...
                    result = _jobs().failed(describe(exc))
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

    def _wait_for_workers(self, client, distributed) -> None:
        """Wait (up to ``timeout``) for as many workers as the cluster had before: after a job took a worker down, its
        nanny restarts it, and the next round (the runs of a batch that died, one by one) would otherwise queue on
        the survivors, where the run that kills a worker again takes the healthy runs queued beside it down too."""
        self._workers = max(self._workers, len(client.scheduler_info().get("workers", {})))
        try:
            client.wait_for_workers(self._workers, timeout=self.timeout)
        except (distributed.TimeoutError, TimeoutError):  # a worker that does not come back: run on those there are
            pass


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
