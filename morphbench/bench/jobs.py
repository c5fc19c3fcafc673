"""What a worker does with a job: run it and hand back its tables, or the reason it failed. Never raises.

This is the one function executors ship to their workers (a local process or a Dask worker): it takes a
``suite.Job`` and returns a plain dict of DataFrames and JSON-ready values, which the parent process writes to the
store. Workers never touch the results directory, so a Dask cluster needs no shared file system.
"""

from __future__ import annotations

import time
import traceback
from typing import Any

import numpy as np
import pandas as pd

from morphbench.errors import ConfigError, PhysicsError
from morphbench.experiment.driver import run, run_batch
from morphbench.experiment.scan import ScanPoint
from morphbench.failures import describe


def execute(job) -> dict[str, Any]:
    """``{'status': 'done' | 'failed', 'error', 'traceback', 'wall_time_s', ...tables}`` for one job; for a batch
    (``kind`` 'batch', its payload run jobs of one condition), ``{'status': 'batch', 'results': [...]}``, one such
    result per run, as each would have alone."""
    if job.kind == "batch":
        return {"status": "batch", "results": _batch(job.payload)}
    started = time.perf_counter()
    try:
        result = _finished(run(job.payload)) if job.kind == "run" else _scan(job.payload)
    except BaseException as exc:  # a plug-in's KeyboardInterrupt or SystemExit too: a worker ignores Ctrl-C
        result = _failure(exc)  # (bench/executors.py), so whatever reaches here was raised by the job's own code
    return _complete(result, time.perf_counter() - started)


def failed(error: str) -> dict[str, Any]:
    """The result of a job that could not even report its own failure (e.g. a result that cannot be pickled)."""
    return {"status": "failed", "error": error, "traceback": None, "wall_time_s": None}


def lost(reason: str) -> dict[str, Any]:
    """The result of a job whose worker died under it (``reason``: 'signal SIGSEGV', 'exit code 3', ...): failed,
    with ``crashes`` 1, which the runner adds to the job's earlier crashes (it runs a job that crashed once again)."""
    return {**failed(f"worker died: {reason}"), "crashes": 1}


def _batch(jobs) -> list[dict[str, Any]]:
    started = time.perf_counter()
    try:
        outcomes = run_batch([job.payload for job in jobs])
    except BaseException:  # the batch as a whole could not run: each run alone says why it cannot
        return [execute(job) for job in jobs]
    wall = (time.perf_counter() - started) / len(jobs)
    return [_complete(_failure(outcome) if isinstance(outcome, BaseException) else _finished(outcome), wall)
            for outcome in outcomes]


def _complete(result: dict[str, Any], wall_time: float) -> dict[str, Any]:
    result.setdefault("error", None)
    result.setdefault("traceback", None)
    result["wall_time_s"] = wall_time
    return result


def _failure(exc: BaseException) -> dict[str, Any]:
    """A failed job's result: a ConfigError or PhysicsError by its own one line (naming the plug-in or body, what
    and where), anything else (a plug-in calling sys.exit() or raising KeyboardInterrupt fails its run, not the
    suite) described."""
    error = str(exc) if isinstance(exc, (ConfigError, PhysicsError)) else describe(exc)
    trace = "".join(traceback.format_exception(exc))
    return {"status": "failed", "error": error, "traceback": trace}


def _finished(records) -> dict[str, Any]:
    steps = records.steps()
    bad = non_finite_step(steps)
    if bad is not None:
        return {"status": "failed", "error": f"non-finite Ubar at learning step {bad}"}
    return {"status": "done", "steps": steps, "units": records.units(), "summary": records.summary()}


def _scan(part) -> dict[str, Any]:
    """A ``model.ScanPart``: Ubar at each of its points."""
    ubar = [ScanPoint(part.shape, p, part.physics, part.cycles, part.discard, part.environment, part.damage).ubar()
            for p in part.phases]
    columns = [f"dphi_{i}" for i in range(2, part.shape.n_units + 1)]
    points = pd.DataFrame(np.asarray(part.phases)[:, 1:], columns=columns)
    points["ubar"] = ubar
    bad = np.flatnonzero(~np.isfinite(points.ubar.to_numpy()))
    if len(bad):
        return {"status": "failed", "error": f"non-finite Ubar at scan point {bad[0]} of this part"}
    return {"status": "done", "points": points}


def non_finite_step(steps: pd.DataFrame) -> int | None:
    """The first learning step whose Ubar (measured or true) is NaN or infinite, or None."""
    values = steps[["ubar", "ubar_true"]].to_numpy(dtype=float)
    bad = np.flatnonzero(~np.isfinite(values).all(axis=1))
    return int(steps.step.iloc[bad[0]]) if len(bad) else None

