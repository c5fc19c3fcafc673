"""The results directory of a suite: one directory per finished job, written atomically, and consolidated tables.

Layout of ``DIR``::

    plan.json            the expanded suite: experiments, runs (id, condition, seed) and scans (what the tables need)
    suite.toml           a copy of the suite file, for the record
    runs/<run_id>/       one finished run: steps.parquet, units.parquet (the RunRecords schema), result.json
    scans/<part_id>/     one finished part of a scan: points.parquet (dphi_2.., ubar), result.json
    runs.parquet         one row per run of the suite: run_id, condition_id, experiments, condition columns, seed,
                         status ('done' | 'failed' | 'missing'), error, final_ubar, final_ubar_true,
                         mean_acceptance, sensor_error, final_u_heading, turning_rate_deg_per_cycle,
                         centralized (1.0 for a centralized controller, 0.0 for per-unit learners; NaN, like every
                         summary value, for a run not done or stored before the value existed), wall_time_s
    steps.parquet        every finished run's steps.parquet rows, with run_id, condition_id, condition columns, seed
                         (a run stored before a column existed has NaN in it)
    units.parquet        every finished run's units.parquet rows, with run_id
    scans.parquet        every scan point: scan_id, scan columns (scan, shape, resolution, ...), dphi_2.., ubar
    jobs.parquet         one row per job: job_id, kind, status, error, wall_time_s
    environment.json     one entry per bench that ran jobs here: when, how many, executor, machine, software versions
                         (morphbench.bench.provenance)
    curves.parquet, metrics.parquet, figures/, report.md    (morphbench.bench.report)
    report.html, videos/ the report as one self-contained page, a video of one run per experiment
                         (morphbench.bench.html, morphbench.bench.videos)

A job directory is assembled under a temporary name and renamed into place, so it exists whole or not at all; a
job whose directory exists is finished (done or failed: ``result.json`` says which) and is skipped when the suite
is run again into the same directory. The consolidated tables are rebuilt from the job directories and the plan,
always in plan order, so they are the same whichever executor ran the jobs and in whatever order they finished.
``wall_time_s`` is the only column that changes from one execution to the next.
"""

from __future__ import annotations

import json
import math
import os
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from morphbench.errors import ConfigError
from morphbench.experiment.records import STEP_COLUMNS, atomic_write
from morphbench.files import is_stale

KIND_DIRS = {"run": "runs", "scan": "scans"}
RESULT = "result.json"
PLAN = "plan.json"
SUMMARY_COLUMNS = ("final_ubar", "final_ubar_true", "mean_acceptance", "sensor_error", "final_u_heading",
                   "turning_rate_deg_per_cycle", "centralized")


class Store:
    def __init__(self, root: str | Path):
        self.root = Path(root)

    # --- job directories ---

    def job_dir(self, kind: str, job_id: str) -> Path:
        return self.root / KIND_DIRS[kind] / job_id

    def result(self, kind: str, job_id: str) -> dict | None:
        """The job's result.json, or None if the job has not finished."""
        path = self.job_dir(kind, job_id) / RESULT
        try:
            return json.loads(path.read_text())
        except FileNotFoundError:
            return None

    def status(self, kind: str, job_id: str) -> str | None:
        result = self.result(kind, job_id)
        return None if result is None else result["status"]

    def save(self, job, result: dict) -> Path:
        """Write one job's tables and result.json into its directory, atomically (temp directory + rename)."""
        final = self.job_dir(job.kind, job.id)
        final.parent.mkdir(parents=True, exist_ok=True)
        tmp = final.parent / f".tmp-{job.id}-{os.getpid()}"
        if tmp.exists():
            shutil.rmtree(tmp)
        tmp.mkdir()
        try:
            for name in ("steps", "units", "points"):
                table = result.get(name)
                if table is not None:
                    table.to_parquet(tmp / f"{name}.parquet", index=False)
            meta = {"job_id": job.id, "kind": job.kind, "status": result["status"], "error": result.get("error"),
                    "traceback": result.get("traceback"), "wall_time_s": result.get("wall_time_s"),
                    "summary": result.get("summary")}
            if result.get("crashes"):  # times its worker died (bench/runner.py runs such a job once more)
                meta["crashes"] = result["crashes"]
            (tmp / RESULT).write_text(json.dumps(meta, indent=2, sort_keys=True, default=_json_default) + "\n")
            if final.exists():  # a failed job run again (--retry-failed): move the old one out of the way first
                old = final.parent / f".tmp-old-{job.id}-{os.getpid()}"
                os.replace(final, old)
                shutil.rmtree(old)
            os.replace(tmp, final)
        finally:
            if tmp.exists():
                shutil.rmtree(tmp)
        return final

    def read(self, kind: str, job_id: str, name: str) -> pd.DataFrame:
        return pd.read_parquet(self.job_dir(kind, job_id) / f"{name}.parquet")

    def _arrow(self, kind: str, job_id: str, name: str) -> pa.Table:
        return pq.read_table(self.job_dir(kind, job_id) / f"{name}.parquet")

    def clean_temporaries(self) -> int:
        """Remove what a killed bench left half-written (temporary job directories and files); a temporary of a
        process still running is its to finish (files.is_stale)."""
        removed = 0
        for sub in KIND_DIRS.values():
            folder = self.root / sub
            if folder.is_dir():
                for path in folder.glob(".tmp-*"):
                    if is_stale(path):
                        shutil.rmtree(path, ignore_errors=True)
                        removed += 1
        for path in self.root.glob(".*.tmp-*"):
            if is_stale(path):
                path.unlink(missing_ok=True)
                removed += 1
        return removed

    # --- the plan ---

    def read_plan(self) -> dict | None:
        try:
            return json.loads((self.root / PLAN).read_text())
        except FileNotFoundError:
            return None

    def require_plan(self) -> dict:
        plan = self.read_plan()
        if plan is None:
            expected = "a results directory written by 'morphbench bench' (it has no plan.json)"
            raise ConfigError(self.root, PLAN, expected)
        return plan

    def write_plan(self, plan: dict, suite_text: str = "") -> None:
        self.root.mkdir(parents=True, exist_ok=True)
        text = json.dumps(plan, indent=1, sort_keys=True, default=_json_default)
        atomic_write(self.root / PLAN, lambda tmp: Path(tmp).write_text(text + "\n"))
        if suite_text:
            atomic_write(self.root / "suite.toml", lambda tmp: Path(tmp).write_text(suite_text))

    # --- consolidated tables ---

    def consolidate(self, plan: dict | None = None, write: bool = True) -> dict[str, pd.DataFrame]:
        """runs, steps, units, scans and jobs tables of the plan's jobs from their directories (see module doc)."""
        plan = plan or self.require_plan()
        membership: dict[str, list[str]] = {}
        for experiment in plan["experiments"]:
            for run_id in experiment["run_ids"]:
                membership.setdefault(run_id, []).append(experiment["name"])
        run_rows, step_tables, unit_tables, job_rows, step_keys, unit_keys = [], [], [], [], [], []
        for entry in plan["runs"]:
            run_id, condition = entry["id"], entry["condition"]
            result = self.result("run", run_id)
            status = "missing" if result is None else result["status"]
            summary = (result or {}).get("summary") or {}
            ids = {"run_id": run_id, "condition_id": entry["condition_id"]}
            run_rows.append({**ids, "experiments": ";".join(membership.get(run_id, [])), **condition,
                             "seed": entry["seed"], "status": status, "error": (result or {}).get("error"),
                             **{k: _float(summary.get(k)) for k in SUMMARY_COLUMNS},
                             "wall_time_s": _float((result or {}).get("wall_time_s"))})
            job_rows.append(_job_row(run_id, "run", result))
            if status == "done":
                step_tables.append(self._arrow("run", run_id, "steps"))
                step_keys.append({**ids, **condition, "seed": entry["seed"]})
                unit_tables.append(self._arrow("run", run_id, "units"))
                unit_keys.append({"run_id": run_id})
        scan_tables, scan_keys = [], []
        for scan in plan["scans"]:
            for part_id in scan["parts"]:
                result = self.result("scan", part_id)
                job_rows.append(_job_row(part_id, "scan", result))
                if result is not None and result["status"] == "done":
                    scan_tables.append(self._arrow("scan", part_id, "points"))
                    scan_keys.append({"scan_id": scan["id"], **scan["columns"]})
        tables = {
            "runs": pd.DataFrame(run_rows, columns=_run_columns(plan)),
            "steps": _joined(step_tables, step_keys, _step_columns(plan)),
            "units": _joined(unit_tables, unit_keys, ["run_id"]),
            "scans": _joined(scan_tables, scan_keys, ["scan_id", "scan", "shape", "shape_id", "n_units", "ubar"]),
            "jobs": pd.DataFrame(job_rows, columns=["job_id", "kind", "status", "error", "wall_time_s"]),
        }
        if write:
            for name, table in tables.items():
                self.write_table(name, table)
        return tables

    def write_table(self, name: str, table: pd.DataFrame) -> Path:
        path = self.root / f"{name}.parquet"
        atomic_write(path, lambda tmp: table.to_parquet(tmp, index=False))
        return path


def _job_row(job_id: str, kind: str, result: dict | None) -> dict:
    result = result or {}
    return {"job_id": job_id, "kind": kind, "status": result.get("status", "missing"), "error": result.get("error"),
            "wall_time_s": _float(result.get("wall_time_s"))}


def _condition_keys(plan: dict) -> list[str]:
    keys: list[str] = []
    for entry in plan["runs"]:
        for key in entry["condition"]:
            if key not in keys:
                keys.append(key)
    return keys


def _run_columns(plan: dict) -> list[str]:
    return ["run_id", "condition_id", "experiments", *_condition_keys(plan), "seed", "status", "error",
            *SUMMARY_COLUMNS, "wall_time_s"]


def _step_columns(plan: dict) -> list[str]:
    return ["run_id", "condition_id", *_condition_keys(plan), "seed", *STEP_COLUMNS]


def _joined(tables: list[pa.Table], keys: list[dict[str, Any]], columns: list[str]) -> pd.DataFrame:
    """The jobs' tables one after the other, each row with its job's constant columns in front (one Arrow concat
    and one conversion: thousands of small DataFrames concatenated one by one took minutes)."""
    if not tables:
        return pd.DataFrame(columns=columns)
    body = pa.concat_tables(tables, promote_options="default").to_pandas()
    rows = np.repeat(np.arange(len(keys)), [table.num_rows for table in tables])
    front = pd.DataFrame(keys).iloc[rows].reset_index(drop=True)
    return pd.concat([front, body], axis=1)


def _float(value: Any) -> float:
    return float("nan") if value is None else float(value)


def _json_default(value: Any):
    if hasattr(value, "item"):  # numpy scalars
        return value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return str(value)
