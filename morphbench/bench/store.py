"""The results directory of a suite: one directory per finished job, written atomically, and consolidated tables.

Layout of ``DIR``::

    plan.json            the expanded suite: experiments, runs (id, condition, seed) and scans (what the tables need)
    suite.toml           a copy of the suite file, for the record
    runs/<run_id>/       one finished run: result.json; its steps.parquet and units.parquet (the RunRecords schema)
                         until the tables are consolidated, which moves their rows into DIR/steps.parquet and
                         DIR/units.parquet (ABSORBED: every row is stored once)
    scans/<part_id>/     one finished part of a scan: points.parquet (dphi_2.., ubar), result.json
    runs.parquet         one row per run of the suite: run_id, condition_id, experiments, condition columns, seed,
                         status ('done' | 'failed' | 'missing' | 'damaged'), error, final_ubar, final_ubar_true,
                         mean_acceptance, sensor_error, final_u_heading, turning_rate_deg_per_cycle,
                         centralized (1.0 for a centralized controller, 0.0 for per-unit learners; NaN, like every
                         summary value, for a run not done or stored before the value existed), wall_time_s
    steps.parquet        every finished run's steps rows, with run_id, condition_id, condition columns, seed (a run
                         stored before a column existed has NaN in it): the only copy of a consolidated run's steps
    units.parquet        every finished run's units rows, with run_id: the only copy of a consolidated run's units
    scans.parquet        every scan point: scan_id, scan columns (scan, shape, resolution, ...), dphi_2.., ubar
    jobs.parquet         one row per job: job_id, kind, status, error, wall_time_s
    environment.json     one entry per bench that ran jobs here: when, how many, executor, machine, software versions
                         (morphbench.bench.provenance)
    curves.parquet, metrics.parquet, figures/, report.md    (morphbench.bench.report)
    report.html, videos/ the report as one self-contained page, a video of one run per experiment
                         (morphbench.bench.html, morphbench.bench.videos)
    damaged/<time>/      what 'morphbench check DIR --repair' moved aside, under its own relative path

A job directory is assembled under a temporary name and renamed into place, so it exists whole or not at all; a
job whose directory exists is finished (done or failed: ``result.json`` says which) and is skipped when the suite
is run again into the same directory. What is read back is checked, never trusted: a job whose result.json or
tables are not what this module and experiment/records.py write (unreadable, another schema, an unknown status,
an infinite value, rows that disagree with its summary) is **damaged**: ``load`` says which file and why, the
tables list it with status 'damaged' and leave its rows out, and ``morphbench check DIR --repair``
(morphbench.bench.check) moves it aside to be run again. A plan.json that is not one ``bench`` writes, or that names
an experiment, scan or job by anything but a plain name (a path would put figures outside DIR), is a ConfigError.
The consolidated tables are rebuilt from the job directories, the rows steps.parquet and units.parquet already hold
and the plan, always in plan order, so they are the same whichever executor ran the jobs and in whatever order they
finished. A run's rows are in its directory (a job just saved: a kill never leaves half of it) or in the consolidated
tables (a job consolidated), never needed from both: where its directory has them, they are the run's. Once both new
tables are written, consolidating removes the runs' own copies; it first writes back into its directory the rows of a
run the plan no longer lists (a suite resumed into the directory of another), so that nothing of a finished job is
lost. A results directory of an older morphbench (each run's tables in its directory and in the consolidated
tables) is read as it is, and the next consolidation (``bench`` or ``report``) removes the copies. A consolidated
steps or units table that cannot be read is set aside into DIR/damaged/, never written over (its runs are damaged),
and so are its rows of runs that neither the plan lists nor runs/ holds (``orphans``: rows no directory takes back).
A file or directory this process may not read or write for its permissions is no damage: ``Unreadable``, a
ConfigError, refuses (nothing is set aside for it).
``wall_time_s`` is the only column that changes from one execution to the next.
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import tempfile
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from morphbench.errors import ConfigError
from morphbench.failures import describe
from morphbench.experiment.records import STEP_COLUMNS, atomic_write
from morphbench.files import is_stale, present

KIND_DIRS = {"run": "runs", "scan": "scans"}
RESULT = "result.json"
PLAN = "plan.json"
SUMMARY_COLUMNS = ("final_ubar", "final_ubar_true", "mean_acceptance", "sensor_error", "final_u_heading",
                   "turning_rate_deg_per_cycle", "centralized")
"""the summary values the runs table has a column of."""
NUMBER, COUNT, INTEGER, BOOLEAN, TEXT, OBJECT, LIST = "a number", "an integer >= 0", "an integer", "a boolean", \
    "a string", "an object", "a list"
SUMMARY_SCHEMA: dict[str, tuple[str, bool, bool]] = {
    "config": (OBJECT, True, True), "seed": (INTEGER, True, True), "n_units": (COUNT, True, True),
    "steps": (COUNT, True, True), "final_ubar": (NUMBER, True, True), "final_ubar_true": (NUMBER, True, True),
    "mean_acceptance": (NUMBER, True, False), "sensor_error": (NUMBER, True, False),
    "wall_time_s": (NUMBER, True, False), "final_ubar_by_piece": (OBJECT, False, False), "events": (LIST, False, False),
    "final_u_heading": (NUMBER, False, False), "turning_rate_deg_per_cycle": (NUMBER, False, False),
    "centralized": (BOOLEAN, False, False), "backend": (TEXT, False, False),
}
"""A done run's summary (experiment/records.py), key -> (kind, required, finite), as JOB_SCHEMAS its tables: no other
key; 'required': every summary has it (keys the records gained later may be absent from results stored before them);
'finite': never null, and a number never NaN, but for the final values of a run of no learning step (NaN: nothing
to average); else null, and NaN for a number, stand for no value. No number is ever infinite."""
STATUSES = ("done", "failed")
"""what a finished job's result.json says; in the tables a job may also be 'missing' (no directory yet) or
DAMAGED."""
DAMAGED = "damaged"
DAMAGED_DIR = "damaged"
"""DIR/damaged/<time>/: damaged jobs and files set aside (``Store.set_aside``), never deleted."""
ABSORBED = ("steps", "units")
"""a run's tables whose rows consolidating moves into the consolidated table of the same name."""
FRONT = b"morphbench_front"
"""the key of a consolidated steps or units table's metadata that lists the columns in front of the runs' own."""
TABLES = ("runs", "steps", "units", "scans", "jobs")
"""the consolidated tables, rebuilt from the job directories by ``consolidate``."""
SAFE_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,199}$")
"""a name of plan.json that becomes a file name (an experiment's figures, a job's directory): never a path, and
short enough for the longest file made from it."""
REPAIR = "morphbench check DIR --repair moves it aside"

INT, FLOAT, STRING, BOOL = "int64", "double", "string", "bool"
JOB_SCHEMAS: dict[str, dict[str, tuple[str, bool, bool]]] = {
    "steps": {"step": (INT, True, True), "time_s": (FLOAT, True, True), "ubar": (FLOAT, True, True),
              "ubar_true": (FLOAT, True, True), "acceptance": (FLOAT, True, False), "event": (STRING, False, True),
              "x_m": (FLOAT, False, False), "y_m": (FLOAT, False, False), "heading_rad": (FLOAT, False, False),
              "u_heading": (FLOAT, False, False)},
    "units": {"step": (INT, True, True), "unit": (INT, True, True), "position": (INT, False, True),
              "piece": (INT, False, True), "phase_tried": (FLOAT, True, False), "phase_kept": (FLOAT, True, False),
              "u_measured": (FLOAT, True, False), "u_true": (FLOAT, True, False), "u_memory": (FLOAT, False, False),
              "accepted": (BOOL, True, True), "x_m": (FLOAT, False, False), "y_m": (FLOAT, False, False),
              "heading_rad": (FLOAT, False, False)},
}
"""The tables of a run's directory (experiment/records.py), column -> (Arrow type, required, finite). Columns the
records gained later are not required (results stored before them lack them); no float is ever infinite, and NaN
only where 'finite' is False. A scan part's points.parquet: ``points_schema``."""


def points_schema(n_units: int) -> dict[str, tuple[str, bool, bool]]:
    return {**{f"dphi_{i}": (FLOAT, True, True) for i in range(2, n_units + 1)}, "ubar": (FLOAT, True, True)}


@dataclass(frozen=True)
class Damage:
    """A damaged file or directory of a results directory: which, what was expected there, and its job if any."""

    path: Path
    reason: str
    """'expected ..., got ...' or 'KEY: expected ...'."""
    kind: str | None = None
    job_id: str | None = None
    rows: bool = False
    """whether what is damaged is the rows of run ``job_id`` in the consolidated table ``path`` (Store.orphans):
    they go aside alone, not the table."""

    def where(self, root: Path) -> str:
        """The path relative to ``root``."""
        try:
            return str(self.path.relative_to(root))
        except ValueError:
            return str(self.path)

    def line(self, root: Path) -> str:
        # a run id read from a table may be any text: shown as a plain name or quoted, on one line
        shown = self.job_id if self.job_id and SAFE_NAME.match(self.job_id) else _short(self.job_id)
        job = f"{self.kind} {shown}: " if self.job_id else ""
        return f"{job}{self.where(root)}: {self.reason}"


@dataclass
class Loaded:
    """A job as its directory holds it: status 'missing', 'done', 'failed' or DAMAGED (then ``damage`` says why),
    its result.json and, done, its tables."""

    status: str
    result: dict | None = None
    tables: dict[str, pa.Table] = field(default_factory=dict)
    damage: Damage | None = None


class Unreadable(ConfigError):
    """A file or directory of a results directory that this process may not read or write for its permissions (its
    mode or owner), not for its content: refused in one line, never taken for damage (nothing is set aside for it)."""

    def __init__(self, path: str | Path):
        super().__init__(str(_refusing(Path(path))), "(permissions)", "a file or directory this user may read and "
                         "write (permission denied: its mode or owner, not its content; chmod it or run as its owner)")


def _refusing(path: Path) -> Path:
    """The directory above ``path`` that this user may not search, if one is (it is what to chmod), else ``path``."""
    for parent, child in zip(reversed(path.parents), [*reversed(path.parents)][1:] + [path]):
        try:
            os.lstat(child)
        except PermissionError:
            return parent
        except OSError:
            break
    return path


class _Bad(Exception):
    """What ``Store.load`` found wrong in one file (becomes a Damage): what was expected, and what was found."""

    def __init__(self, path: Path, reason: str):
        super().__init__(reason)
        self.path, self.reason = path, reason


class Store:
    def __init__(self, root: str | Path):
        self.root = Path(root)
        self._absorbed: dict[str, dict[str, pa.Table] | _Bad] = {}
        """per ABSORBED table: each run's rows in it (its own columns only), or what is wrong with the file; read
        once, forgotten when the tables are written."""

    # --- job directories ---

    def job_dir(self, kind: str, job_id: str) -> Path:
        return self.root / KIND_DIRS[kind] / job_id

    def load(self, kind: str, job_id: str, n_units: int | None = None, tables: bool = True) -> Loaded:
        """The job's directory, checked (see the module doc); with ``tables``, a done job's tables read too
        (``n_units``: a scan's, for its points' columns; None: any number of dphi columns)."""
        directory = self.job_dir(kind, job_id)
        try:
            result = _read_result(directory, kind, job_id)
            if result is None:
                return Loaded("missing")
            read = {}
            if tables and result["status"] == "done":
                names = ABSORBED if kind == "run" else ("points",)
                for name in names:
                    path = directory / f"{name}.parquet"
                    absorbed = kind == "run" and not present(path)
                    read[name] = self._rows(name, job_id) if absorbed else _read_table(path, n_units)
                if kind == "run":
                    _check_counts(read, result["summary"], directory)
            return Loaded(result["status"], result, read)
        except _Bad as bad:
            return Loaded(DAMAGED, damage=Damage(bad.path, f"expected {bad.reason}", kind, job_id))

    def status(self, kind: str, job_id: str) -> str | None:
        """'done', 'failed' or DAMAGED from the job's result.json alone; None if the job has not run (no directory)."""
        self.require_layout()
        status = self.load(kind, job_id, tables=False).status
        return None if status == "missing" else status

    def layout_damage(self) -> list[Damage]:
        """``runs`` or ``scans`` that is there but is not a directory."""
        found = []
        for sub in KIND_DIRS.values():
            path = self.root / sub
            if present(path) and not path.is_dir():
                found.append(Damage(path, "expected a directory of job directories, got a file"))
        return found

    def require_layout(self) -> None:
        for damage in self.layout_damage():
            raise ConfigError(str(self.root), damage.where(self.root), f"a directory of job directories, not a file "
                              f"({REPAIR})")

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
            if self.status(job.kind, job.id) == DAMAGED:  # run again (--retry-failed): kept, as check --repair does
                self.set_aside([final])
            elif final.exists():  # a failed job run again (--retry-failed): move the old one out of the way first
                old = final.parent / f".tmp-old-{job.id}-{os.getpid()}"
                os.replace(final, old)
                shutil.rmtree(old)
            os.replace(tmp, final)
        finally:
            if tmp.exists():
                shutil.rmtree(tmp)
        return final

    def set_aside(self, paths: list[Path], folder: Path | None = None) -> list[Path]:
        """Move ``paths`` (inside the directory) into ``folder`` (by default a new ``aside_folder``) under their own
        relative paths, each whole (a rename); their new paths. All or nothing: a path that cannot be moved (this
        user may not write there) is a ConfigError naming it, the ones moved before it moved back."""
        if not paths:
            return []
        folder = folder or self.aside_folder()
        moved: list[tuple[Path, Path]] = []
        for path in paths:
            destination = folder / path.relative_to(self.root)
            try:
                destination.parent.mkdir(parents=True, exist_ok=True)
                os.replace(path, destination)
            except OSError as exc:
                for back, there in reversed(moved):
                    os.replace(there, back)
                for there in {destination, *(there for _, there in moved)}:
                    _prune(there.parent, self.root / DAMAGED_DIR)  # the folders made for them
                raise ConfigError(str(path), "(set aside)", f"a file or directory this user can move into "
                                  f"{folder} ({exc.strerror}); nothing was moved") from None
            moved.append((path, destination))
        return [destination for _, destination in moved]

    def aside_folder(self) -> Path:
        """A new DIR/damaged/<UTC time>/ (not made yet: what is set aside makes it); ConfigError if DIR/damaged is
        there but no directory (checked before anything is moved)."""
        aside = self.root / DAMAGED_DIR
        if present(aside) and not aside.is_dir():
            raise ConfigError(str(self.root), DAMAGED_DIR, "the directory damaged jobs and files are set aside in, "
                              "got a file (move it away)")
        stamp = time.strftime("%Y%m%dT%H%M%SZ", time.gmtime())
        folder, k = aside / stamp, 1
        while present(folder):
            folder, k = aside / f"{stamp}-{k}", k + 1
        return folder

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
        """plan.json, checked (``check_plan``); None if there is none. A damaged one is a ConfigError naming it."""
        path = self.root / PLAN
        try:
            text = path.read_bytes()
        except (FileNotFoundError, NotADirectoryError):
            return None
        except IsADirectoryError:
            raise ConfigError(str(path), "(file)",
                              f"the JSON plan 'morphbench bench' writes, not a directory ({REPAIR})") from None
        except PermissionError:
            raise Unreadable(path) from None
        except OSError as exc:
            raise ConfigError(str(path), "(file)", f"a readable file ({exc.strerror})") from None
        try:
            plan = json.loads(text)
        except (ValueError, RecursionError):  # UnicodeDecodeError is a ValueError
            raise ConfigError(str(path), "(syntax)", f"the JSON plan 'morphbench bench' writes ({REPAIR})") from None
        check_plan(plan, str(path))
        return plan

    def require_plan(self) -> dict:
        plan = self.read_plan()
        if plan is None:
            expected = "a results directory written by 'morphbench bench' (it has no plan.json)"
            raise ConfigError(self.root, PLAN, expected)
        return plan

    def write_plan(self, plan: dict, suite_text: str = "") -> None:
        self.root.mkdir(parents=True, exist_ok=True)
        # in the suite's order, not sorted: tables rebuilt from plan.json then have their columns in the order of
        # those the bench wrote from the suite itself
        text = json.dumps(plan, indent=1, default=_json_default)
        atomic_write(self.root / PLAN, lambda tmp: Path(tmp).write_text(text + "\n"))
        if suite_text:
            atomic_write(self.root / "suite.toml", lambda tmp: Path(tmp).write_text(suite_text))

    # --- consolidated tables ---

    def consolidate(self, plan: dict | None = None, write: bool = True) -> dict[str, pd.DataFrame]:
        """runs, steps, units, scans and jobs tables of the plan's jobs from their directories (see module doc); a
        damaged job is a row of status DAMAGED in runs and jobs, its error the file and why, and has no other rows."""
        plan = plan or self.require_plan()
        self.require_layout()
        membership: dict[str, list[str]] = {}
        for experiment in plan["experiments"]:
            for run_id in experiment["run_ids"]:
                membership.setdefault(run_id, []).append(experiment["name"])
        run_rows, step_tables, unit_tables, job_rows, step_keys, unit_keys = [], [], [], [], [], []
        for entry in plan["runs"]:
            run_id, condition = entry["id"], entry["condition"]
            job = self.load("run", run_id)
            row = _job_row(run_id, "run", job, self.root)
            summary = (job.result or {}).get("summary") or {}
            ids = {"run_id": run_id, "condition_id": entry["condition_id"]}
            run_rows.append({**ids, "experiments": ";".join(membership.get(run_id, [])), **condition,
                             "seed": entry["seed"], "status": row["status"], "error": row["error"],
                             **{k: _float(summary.get(k)) for k in SUMMARY_COLUMNS}, "backend": summary.get("backend"),
                             "wall_time_s": row["wall_time_s"]})
            job_rows.append(row)
            if job.status == "done":
                step_tables.append(job.tables["steps"])
                step_keys.append({**ids, **condition, "seed": entry["seed"]})
                unit_tables.append(job.tables["units"])
                unit_keys.append({"run_id": run_id})
        scan_tables, scan_keys = [], []
        for scan in plan["scans"]:
            for part_id in scan["parts"]:
                job = self.load("scan", part_id, scan["columns"]["n_units"])
                job_rows.append(_job_row(part_id, "scan", job, self.root))
                if job.status == "done":
                    scan_tables.append(job.tables["points"])
                    scan_keys.append({"scan_id": scan["id"], **scan["columns"]})
        tables = {
            "runs": pd.DataFrame(run_rows, columns=_run_columns(plan)),
            "steps": _joined(step_tables, step_keys, _step_columns(plan)),
            "units": _joined(unit_tables, unit_keys, ["run_id"]),
            "scans": _joined(scan_tables, scan_keys, ["scan_id", "scan", "shape", "shape_id", "n_units", "ubar"]),
            "jobs": pd.DataFrame(job_rows, columns=["job_id", "kind", "status", "error", "wall_time_s"]),
        }
        if write:
            kept = {key["run_id"] for key in unit_keys}
            held = {name: self._absorbed_ids(name) for name in ABSORBED}
            for run_id in set().union(*filter(None, held.values())) - kept:  # rows the new tables drop: back into
                self.restore(run_id)                                          # their directories
            self.set_aside_rows(self.orphans(plan))  # or, a run with no directory the plan does not list, aside
            unreadable = [self.root / f"{name}.parquet" for name in ABSORBED
                          if held[name] is None or isinstance(self._absorbed.get(name), _Bad)]
            self.set_aside([path for path in unreadable if present(path)])  # kept, never written over
            for name, table in tables.items():
                self.write_table(name, table)
            self._absorbed.clear()
            for run_id in kept:  # only now, both tables written: a kill before leaves two copies, not none
                for name in ABSORBED:
                    (self.job_dir("run", run_id) / f"{name}.parquet").unlink(missing_ok=True)
        return tables

    def write_table(self, name: str, table: pd.DataFrame) -> Path:
        """``DIR/<name>.parquet``, atomically: zstd, floats split by byte (half the size of the default snappy on
        the records' floats; pandas, Arrow and DuckDB read it alike); a consolidated table of ABSORBED names its
        columns in front of the runs' own in its metadata (``_split`` reads them as such)."""
        arrow = pa.Table.from_pandas(table, preserve_index=False)
        if name in ABSORBED:
            front = [c for c in arrow.column_names if c not in JOB_SCHEMAS[name]]
            arrow = arrow.replace_schema_metadata({**arrow.schema.metadata, FRONT: json.dumps(front).encode()})
        return _write_arrow(self.root / f"{name}.parquet", arrow)

    @contextmanager
    def replayable(self, run_id: str, units: bool = False) -> Iterator[Path]:
        """A directory ``morphbench.render.render_run`` replays run ``run_id`` from (result.json and steps.parquet):
        the run's own, or, consolidated, a temporary one with its result.json and its rows of steps.parquet (and of
        units.parquet if ``units``: what ``render.phase_maps`` reads), removed after the block. ConfigError if the run
        is not done and sound."""
        job = self.load("run", run_id)
        directory = self.job_dir("run", run_id)
        if job.status != "done":
            why = f": {job.damage.line(self.root)}" if job.damage else ""
            raise ConfigError(str(directory), RESULT, f"a finished run (status {job.status}{why})")
        if (directory / "steps.parquet").is_file():
            yield directory
            return
        with tempfile.TemporaryDirectory(prefix=f"morphbench-{run_id}-") as folder:
            shutil.copyfile(directory / RESULT, Path(folder) / RESULT)
            for name in ("steps", "units") if units else ("steps",):
                pq.write_table(job.tables[name], Path(folder) / f"{name}.parquet")
            yield Path(folder)

    # --- a run's rows in the consolidated tables ---

    def _rows(self, name: str, run_id: str) -> pa.Table:
        """Run ``run_id``'s rows of the consolidated table ``name`` (ABSORBED), its own columns, checked."""
        rows = self._split_table(name)
        path = self.root / f"{name}.parquet"
        if isinstance(rows, _Bad):
            raise _Bad(rows.path, rows.reason)
        if run_id not in rows:
            raise _Bad(path, f"run {run_id}'s rows (a done run's {name} are in its directory until the tables are "
                             f"consolidated, then in {path.name}), got none")
        _check_table(rows[run_id], JOB_SCHEMAS[name], path, f"run {run_id}'s rows")
        return rows[run_id]

    def _split_table(self, name: str) -> dict[str, pa.Table] | _Bad:
        """The consolidated table ``name``'s rows per run (``_split``; none without the file), read once."""
        if name not in self._absorbed:
            path = self.root / f"{name}.parquet"
            try:
                if not present(path):
                    rows: dict[str, pa.Table] | _Bad = {}
                elif not path.is_file():
                    raise _Bad(path, "a Parquet table, got a directory")
                else:
                    table = _parquet(path)
                    declared = (table.schema.metadata or {}).get(FRONT)
                    rows = _split(table, name, path, set(json.loads(declared)) if declared else self._front(name))
            except _Bad as bad:
                rows = bad
            self._absorbed[name] = rows
        return self._absorbed[name]

    def _front(self, name: str) -> set[str] | None:
        """The columns the plan puts in front of a run's own in the consolidated table ``name``; None without a
        usable plan."""
        try:
            plan = self.read_plan()
        except ConfigError:
            plan = None
        if plan is None:
            return None
        return set(_step_columns(plan)) - set(STEP_COLUMNS) if name == "steps" else {"run_id"}

    def _absorbed_ids(self, name: str) -> set[str] | None:
        """The runs with rows in the consolidated table ``name`` (only its run_id column read, unless it was read
        whole already); None if it is there but unreadable."""
        rows = self._absorbed.get(name)
        if rows is not None:
            return None if isinstance(rows, _Bad) else set(rows)
        path = self.root / f"{name}.parquet"
        if not present(path):
            return set()
        try:
            return set(pq.read_table(path, columns=["run_id"]).column("run_id").unique().to_pylist())
        except PermissionError:
            raise Unreadable(path) from None
        except (OSError, ValueError, KeyError, pa.ArrowException):
            return None

    def orphans(self, plan: dict) -> dict[str, list[str]]:
        """Per ABSORBED table, the runs it holds rows of that the plan does not list and that have no directory under
        runs/ (rows copied in from elsewhere, or of a run deleted by hand): no consolidation keeps them (it writes a
        run's rows back only into its directory), so they are set aside (``set_aside_rows``). A table that cannot be
        read has none (its damage is its own)."""
        listed = {entry["id"] for entry in plan["runs"]}
        found = {}
        for name in ABSORBED:
            held = {run_id for run_id in self._absorbed_ids(name) or () if isinstance(run_id, str)} - listed
            found[name] = sorted(run_id for run_id in held  # an id that is a path names no directory
                                 if not SAFE_NAME.match(run_id) or not present(self.job_dir("run", run_id)))
        return found

    def set_aside_rows(self, orphans: dict[str, list[str]], folder: Path | None = None) -> list[tuple[str, Path]]:
        """Move the rows of the runs ``orphans`` names (per ABSORBED table, as ``orphans`` gives them) out of the
        consolidated table into a table of its name in ``folder`` (by default a new ``aside_folder``): written there
        first, the table rewritten without them after. (The table's name, where it went) of each table."""
        moved = []
        for name, run_ids in orphans.items():
            if not run_ids:
                continue
            folder = folder or self.aside_folder()
            path = self.root / f"{name}.parquet"
            table = pq.read_table(path)
            odd = pc.is_in(table.column("run_id"), value_set=pa.array(run_ids, table.schema.field("run_id").type))
            _write_arrow(folder / path.name, table.filter(odd))
            _write_arrow(path, table.filter(pc.invert(odd)))
            self._absorbed.pop(name, None)
            moved.append((path.name, folder / path.name))
        return moved

    def restore(self, run_id: str) -> None:
        """Write run ``run_id``'s rows of the consolidated tables back into its directory, where it has none: what
        consolidating does for a run the new tables leave out (not in the plan, or damaged), and ``check --repair``
        before moving a run's directory aside. Nothing for a run without a directory."""
        if not SAFE_NAME.match(run_id):  # a run id of a hand-edited table that is a path: no run's directory
            return
        directory = self.job_dir("run", run_id)
        if not directory.is_dir():
            return
        for name in ABSORBED:
            rows = self._split_table(name)
            path = directory / f"{name}.parquet"
            if not isinstance(rows, _Bad) and run_id in rows and not present(path):
                atomic_write(path, lambda tmp, table=rows[run_id]: pq.write_table(table, tmp))


def _prune(directory: Path, top: Path) -> None:
    """Remove ``directory`` and its parents up to ``top`` (included) while they are empty."""
    while directory.is_relative_to(top):
        try:
            directory.rmdir()
        except OSError:  # not empty (or not ours to remove): the folders above are not either
            return
        directory = directory.parent


def _job_row(job_id: str, kind: str, job: Loaded, root: Path) -> dict:
    """A job's row of jobs.parquet (a damaged one: its error says which file and why; nothing of it is trusted)."""
    if job.damage is not None:
        return {"job_id": job_id, "kind": kind, "status": DAMAGED, "error": f"{job.damage.where(root)}: "
                f"{job.damage.reason}", "wall_time_s": math.nan}
    result = job.result or {}
    return {"job_id": job_id, "kind": kind, "status": job.status, "error": result.get("error"),
            "wall_time_s": _float(result.get("wall_time_s"))}


def _read_result(directory: Path, kind: str, job_id: str) -> dict | None:
    """A job's result.json, checked; None if the job has no directory (not run yet)."""
    if not present(directory):
        return None
    if not directory.is_dir():
        raise _Bad(directory, "a job directory (this is not a directory)")
    path = directory / RESULT
    try:
        result = json.loads(path.read_bytes())
    except FileNotFoundError:
        raise _Bad(path, "the job's result.json (a finished job's directory has one), got none") from None
    except IsADirectoryError:
        raise _Bad(path, "a JSON file, got a directory") from None
    except PermissionError:
        raise Unreadable(path) from None
    except OSError as exc:
        raise _Bad(path, f"a readable file ({exc.strerror})") from None
    except (ValueError, RecursionError):
        raise _Bad(path, "the JSON object 'morphbench bench' writes, got something that is not JSON") from None
    _check_result(result, kind, job_id, path)
    return result


def _check_result(result: Any, kind: str, job_id: str, path: Path) -> None:
    if not isinstance(result, dict):
        raise _Bad(path, f"a JSON object of job_id, kind, status, error, wall_time_s and summary, got "
                         f"{type(result).__name__}")
    for key, wanted in (("job_id", job_id), ("kind", kind)):
        if result.get(key) != wanted:
            raise _Bad(path, f"{key} {wanted!r} (its directory's), got {_short(result.get(key, '(none)'))}")
    status = result.get("status")
    if status not in STATUSES:
        raise _Bad(path, f"status 'done' or 'failed', got {_short(status)}")
    if not isinstance(result.get("error"), (str, type(None))):
        raise _Bad(path, f"error a string or null, got {_short(result['error'])}")
    wall = result.get("wall_time_s")
    if wall is not None and not (_number(wall) and math.isfinite(wall) and wall >= 0):
        raise _Bad(path, f"wall_time_s a number of seconds >= 0 or null, got {_short(wall)}")
    summary = result.get("summary")
    if kind == "run" and status == "done" and not isinstance(summary, dict):
        raise _Bad(path, f"summary, the run's summary (an object), got {_short(summary)}")
    if not isinstance(summary, (dict, type(None))):
        raise _Bad(path, f"summary an object or null, got {_short(summary)}")
    if kind == "run" and summary is not None:
        _check_summary(summary, path)


def _check_summary(summary: dict, path: Path) -> None:
    """A run's summary against SUMMARY_SCHEMA."""
    unknown = [key for key in summary if key not in SUMMARY_SCHEMA]
    if unknown:
        raise _Bad(path, f"summary keys among a run's ({', '.join(SUMMARY_SCHEMA)}), got {_short(unknown[0])}")
    learned = summary.get("steps") != 0  # a run of no learning step has NaN final values
    for key, (what, required, finite) in SUMMARY_SCHEMA.items():
        if key not in summary:
            if required:
                raise _Bad(path, f"summary.{key}, {what} (every run's summary has it), got none")
            continue
        value = summary[key]
        empty = value is None or _number(value) and math.isnan(value)
        if empty and finite and (what != NUMBER or learned):
            raise _Bad(path, f"summary.{key} {'a finite number' if what == NUMBER else what}, got {_short(value)}")
        if not empty and not _KINDS[what](value) or value in (math.inf, -math.inf):
            none = "" if finite else ", NaN or null" if what == NUMBER else " or null"
            raise _Bad(path, f"summary.{key} {what}{none}, got {_short(value)}")


def _read_table(path: Path, n_units: int | None) -> pa.Table:
    """A job's Parquet table, its columns, types and values checked against its schema (JOB_SCHEMAS)."""
    name = path.stem
    if not path.is_file():
        what = "a directory" if path.is_dir() else "none"
        raise _Bad(path, f"the job's {path.name} (a done job has one), got {what}")
    table = _parquet(path)
    if name == "points" and n_units is None:  # a scan part checked without its plan: any dphi columns
        n_units = 1 + sum(1 for c in table.column_names if re.fullmatch(r"dphi_\d+", c))
    schema = points_schema(n_units) if name == "points" else JOB_SCHEMAS[name]
    _check_table(table, schema, path, path.name)
    return table


def _parquet(path: Path) -> pa.Table:
    try:
        return pq.read_table(path)
    except PermissionError:
        raise Unreadable(path) from None
    except (OSError, ValueError, pa.ArrowException) as exc:
        raise _Bad(path, f"a Parquet file ({describe(exc, where=False)[:160]})") from None


def _write_arrow(path: Path, arrow: pa.Table) -> Path:
    """An Arrow table into ``path``, atomically: zstd, floats split by byte."""
    floats = [f.name for f in arrow.schema if pa.types.is_floating(f.type)]
    others = [c for c in arrow.column_names if c not in floats]
    return atomic_write(path, lambda tmp: pq.write_table(arrow, tmp, compression="zstd", use_dictionary=others,
                                                         use_byte_stream_split=floats))


def _check_table(table: pa.Table, schema: dict[str, tuple[str, bool, bool]], path: Path, what: str) -> None:
    """``table``'s columns, types and values against ``schema``; ``what`` names it in a reason (a file, or a run's
    rows of a consolidated table)."""
    unknown = [c for c in table.column_names if c not in schema]
    if unknown or len(set(table.column_names)) < len(table.column_names):
        raise _Bad(path, f"the columns of {what} ({', '.join(schema)}), got {_short(unknown or 'a repeated one')}")
    if table.num_rows == 0:
        raise _Bad(path, "at least one row, got none")
    for column, (kind, required, finite) in schema.items():
        if column not in table.column_names:
            if required:
                raise _Bad(path, f"a column {column} (the columns of {what}: {', '.join(schema)}), got none")
            continue
        data = table.column(column)
        found = str(data.type)
        if found != kind and not (kind == STRING and found == "large_string"):
            raise _Bad(path, f"column {column} of type {kind}, got {found}")
        if data.null_count and (finite or kind != FLOAT):
            raise _Bad(path, f"a value in every row of column {column}, got {data.null_count} nulls")
        if kind == FLOAT:
            values = data.to_numpy()
            bad = np.isinf(values) | (np.isnan(values) if finite else False)
            if bad.any():
                row = int(np.flatnonzero(bad)[0])
                raise _Bad(path, f"{'finite values' if finite else 'no infinite value'} in column {column}, got "
                                 f"{values[row]} in row {row}")


def _split(table: pa.Table, name: str, path: Path, front: set[str] | None) -> dict[str, pa.Table]:
    """A consolidated table's rows per run, each with the run's own columns only (those of JOB_SCHEMAS; a column
    the run lacked, null throughout its rows, left out). ``front``: the columns the plan puts in front of them (None
    without a plan: any other column)."""
    schema = JOB_SCHEMAS[name]
    if "run_id" not in table.column_names or str(table.column("run_id").type) not in (STRING, "large_string") or \
            table.column("run_id").null_count:
        raise _Bad(path, "a consolidated table with a run_id in every row, got none")
    own = [c for c in table.column_names if c in schema]
    others = [c for c in table.column_names if c not in schema]
    unknown = [c for c in others if front is not None and c not in front]
    if unknown:
        raise _Bad(path, f"the columns of {path.name} (the plan's in front of {', '.join(schema)}), got "
                         f"{_short(unknown)}")
    encoded = table.column("run_id").combine_chunks().dictionary_encode()  # codes in order of first appearance
    codes, runs = encoded.indices.to_numpy(), encoded.dictionary.to_pylist()
    if (np.diff(codes) < 0).any():  # a run's rows apart (an edited table): gathered, in their order
        table, codes = table.take(np.argsort(codes, kind="stable")), np.sort(codes, kind="stable")
    table = table.select(own)
    rows, start = {}, 0
    for run_id, count in zip(runs, np.bincount(codes, minlength=len(runs))):
        part = table.slice(start, count)
        start += count
        lacked = [c for c in own if not schema[c][1] and part.column(c).null_count == count]
        rows[run_id] = part.drop_columns(lacked) if lacked else part
    return rows


def _check_counts(tables: dict[str, pa.Table], summary: dict, directory: Path) -> None:
    """A run's tables have the rows its summary says: step 0 and each learning step, each of every unit."""
    n_steps = tables["steps"].num_rows
    if summary.get("steps") is not None and n_steps != summary["steps"] + 1:
        raise _Bad(directory / "steps.parquet", f"{summary['steps'] + 1} rows (step 0 and the summary's "
                   f"{summary['steps']} learning steps), got {n_steps}")
    if summary.get("n_units") is not None and tables["units"].num_rows != n_steps * summary["n_units"]:
        raise _Bad(directory / "units.parquet", f"{n_steps * summary['n_units']} rows (each of the summary's "
                   f"{summary['n_units']} units at each of {n_steps} steps), got {tables['units'].num_rows}")


def check_plan(plan: Any, source: str) -> None:
    """ConfigError unless ``plan`` has what the tables and the report read from plan.json, with plain names."""
    _require(plan, dict, source, "(plan)", "the JSON object 'morphbench bench' writes")
    _require(plan.get("suite"), str, source, "suite", "the suite's name")
    _require(plan.get("description", ""), str, source, "description", "a string")
    for i, name in enumerate(_require(plan.get("includes", []), list, source, "includes",
                                      "a list of the names of the suites it includes")):
        _name(name, source, f"includes[{i}]")
    runs = _require(plan.get("runs"), list, source, "runs", "a list of runs")
    conditions, run_ids, settings = set(), set(), set()
    reserved = {*_run_columns({"runs": []}), *STEP_COLUMNS}  # a setting of that name would be a second column
    for i, run in enumerate(runs):
        key = f"runs[{i}]"
        _require(run, dict, source, key, "an object of id, condition_id, condition and seed")
        _unique(_name(run.get("id"), source, f"{key}.id"), run_ids, source, f"{key}.id")
        conditions.add(_name(run.get("condition_id"), source, f"{key}.condition_id"))
        condition = _require(run.get("condition"), dict, source, f"{key}.condition", "an object of settings")
        for name, value in condition.items():
            if name in reserved or not isinstance(value, (str, int, float, bool, type(None))):
                raise _refused(source, f"{key}.condition.{name}", "a setting (not a column of the tables) whose "
                               "value is a string, number or boolean", value)
        for name, kind in (("shape", str), ("learner", str), ("n_units", int)):
            _require(condition.get(name), kind, source, f"{key}.condition.{name}", f"a {kind.__name__}")
        settings.update(condition)
        if isinstance(run.get("seed"), bool) or not isinstance(run.get("seed"), int):
            raise _refused(source, f"{key}.seed", "an integer", run.get("seed"))
    experiments = _require(plan.get("experiments"), list, source, "experiments", "a list of experiments")
    names: set[str] = set()
    for i, experiment in enumerate(experiments):
        key = f"experiments[{i}]"
        _require(experiment, dict, source, key, "an object of name, run_ids, condition_ids and varying")
        _unique(_name(experiment.get("name"), source, f"{key}.name"), names, source, f"{key}.name")
        _require(experiment.get("description", ""), str, source, f"{key}.description", "a string")
        for field_name, known in (("run_ids", run_ids), ("condition_ids", conditions)):
            values = _require(experiment.get(field_name), list, source, f"{key}.{field_name}", "a list of ids")
            for value in values:
                if value not in known:
                    raise _refused(source, f"{key}.{field_name}", "ids of the plan's runs", value)
            if len(set(values)) < len(values):
                raise _refused(source, f"{key}.{field_name}", "each id once", values)
        varying = _require(experiment.get("varying"), list, source, f"{key}.varying", "a list of settings")
        if not all(isinstance(v, str) and v in settings for v in varying):
            raise _refused(source, f"{key}.varying", "settings of the plan's runs", varying)
        listed = _require(experiment.get("scans", []), list, source, f"{key}.scans", "a list of scan names")
        if not all(isinstance(v, str) for v in listed):
            raise _refused(source, f"{key}.scans", "a list of scan names", listed)
    scans = _require(plan.get("scans"), list, source, "scans", "a list of scans")
    scan_ids, scan_names, part_ids = set(), set(), set()
    for i, scan in enumerate(scans):
        key = f"scans[{i}]"
        _require(scan, dict, source, key, "an object of id, name, columns and parts")
        _unique(_name(scan.get("id"), source, f"{key}.id"), scan_ids, source, f"{key}.id")
        _unique(_name(scan.get("name"), source, f"{key}.name"), scan_names, source, f"{key}.name")
        columns = _require(scan.get("columns"), dict, source, f"{key}.columns", "an object of the scan's columns")
        for name, value in columns.items():
            if name in ("scan_id", "ubar") or name.startswith("dphi_") or not isinstance(
                    value, (str, int, float, bool, type(None))):
                raise _refused(source, f"{key}.columns.{name}", "a scan setting (not a column of points) whose "
                               "value is a string, number or boolean", value)
        for column, low in (("n_units", 2), ("samples", 1)):
            value = columns.get(column)
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise _refused(source, f"{key}.columns.{column}", f"an integer >= {low}", value)
        for column in ("shape", "shape_id", "physics"):
            _require(columns.get(column), str, source, f"{key}.columns.{column}", "a string")
        parts = _require(scan.get("parts"), list, source, f"{key}.parts", "a list of ids")
        for k, part in enumerate(parts):
            _unique(_name(part, source, f"{key}.parts[{k}]"), part_ids, source, f"{key}.parts[{k}]")


def _unique(name: str, seen: set[str], source: str, key: str) -> None:
    if name in seen:
        raise _refused(source, key, "a name no other of its kind has", name)
    seen.add(name)


def _require(value: Any, kind: type, source: str, key: str, expected: str) -> Any:
    if not isinstance(value, kind):
        raise _refused(source, key, expected, value)
    return value


def _name(value: Any, source: str, key: str) -> str:
    if not isinstance(value, str) or not SAFE_NAME.match(value):
        raise _refused(source, key, "a name of at most 200 letters, digits, '_', '.' and '-' starting with a letter "
                       f"or digit (never a path; {REPAIR})", value)
    return value


def _refused(source: str, key: str, expected: str, value: Any) -> ConfigError:
    return ConfigError(source, key, f"{expected}, got {_short(value)}")


def _number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


_KINDS = {NUMBER: _number, INTEGER: lambda v: isinstance(v, int) and not isinstance(v, bool),
          COUNT: lambda v: isinstance(v, int) and not isinstance(v, bool) and v >= 0,
          BOOLEAN: lambda v: isinstance(v, bool), TEXT: lambda v: isinstance(v, str),
          OBJECT: lambda v: isinstance(v, dict), LIST: lambda v: isinstance(v, list)}
"""what a value of each kind of SUMMARY_SCHEMA is."""


def _short(value: Any, width: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= width else text[:width - 3] + "..."



def _condition_keys(plan: dict) -> list[str]:
    keys: list[str] = []
    for entry in plan["runs"]:
        for key in entry["condition"]:
            if key not in keys:
                keys.append(key)
    return keys


def _run_columns(plan: dict) -> list[str]:
    return ["run_id", "condition_id", "experiments", *_condition_keys(plan), "seed", "status", "error",
            *SUMMARY_COLUMNS, "backend", "wall_time_s"]


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
