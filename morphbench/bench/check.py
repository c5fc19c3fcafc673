"""``morphbench check DIR [--repair]``: a results directory against its plan, each damaged job or file on one line.

What is checked, each finding a ``store.Damage`` (the file, and what was expected there):

- ``plan.json``: the JSON plan ``bench`` writes, every experiment, scan and job named by a plain name, never a path
  (``store.check_plan``); ``runs/`` and ``scans/``: directories;
- every job of the plan that has a directory (``Store.load``): result.json (an object of the keys ``bench`` writes,
  status 'done' or 'failed', numbers finite; a done run's summary the keys of ``store.SUMMARY_SCHEMA`` and no other,
  each of its kind, final Ubar finite), each of its tables, in its directory or (a run consolidated) its rows
  of ``steps.parquet`` and ``units.parquet`` (readable; the columns and types of experiment/records.py; no infinity,
  NaN only where the records have one) and a run's rows against its summary; without a usable plan, every job
  directory under ``runs/`` and ``scans/``;
- the consolidated tables: readable, and, when no job is damaged, the derived ones equal to what the jobs give now
  (``runs``, ``scans``, ``jobs``, and ``curves`` and ``metrics`` once a report was built; columns in any order;
  ``steps`` and ``units`` hold the consolidated runs' only copy, checked run by run above, and no rows of a run
  that neither the plan lists nor runs/ holds: ``Store.orphans``); ``backends.parquet`` readable with the columns a
  report shows (morphbench.bench.backends);
- the report's cached videos, ``videos/*.mp4``: each decodes (``videos.video_problem``; a report would embed it).

Exit status: 0 clean, 1 damage found, 2 when DIR is not a results directory at all, or when a file or directory of
it may not be read for its permissions (``store.Unreadable``: its mode, not its content, so never damage).

``--repair`` moves every damaged job directory (a run's rows of the consolidated tables written into it first), and a
damaged plan.json, ``runs/``, ``scans/``, table or video, into ``DIR/damaged/<UTC time>/`` under its own relative path
(the rows of runs neither the plan nor runs/ has: into tables of their names there), all or nothing (DIR/damaged a
file, or a path this user may not move, refuses before anything moves; nothing is deleted but tables rebuilt from
the jobs), and removes the derived consolidated tables that no longer describe the jobs (never ``steps`` and
``units``: the next consolidation leaves the moved runs' rows out). A moved video is rendered again by the next
report.
``morphbench bench SUITE --out DIR`` then runs exactly the moved jobs again (with ``--resume`` when plan.json was
moved aside: DIR then has none) and rebuilds the tables.
"""

from __future__ import annotations

import io
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from morphbench.bench import backends as B
from morphbench.bench import metrics as M
from morphbench.bench import videos as V
from morphbench.bench.store import ABSORBED, KIND_DIRS, PLAN, TABLES, Damage, Store, Unreadable
from morphbench.errors import ConfigError
from morphbench.failures import describe
from morphbench.files import is_dir, present

REPORT_TABLES = ("curves", "metrics")
"""tables a report computes from the consolidated ones."""
EXIT_DAMAGED = 1


@dataclass
class Findings:
    """What ``check`` found in a results directory."""

    root: Path
    damages: list[Damage] = field(default_factory=list)
    plan: dict | None = None
    """the plan, None if plan.json is missing or damaged."""
    jobs: int = 0
    """job directories checked."""


def check(root: str | Path) -> Findings:
    """Every damaged job and file of the results directory ``root`` (see the module doc); ConfigError if ``root`` is
    not a results directory."""
    store = Store(root)
    root = store.root
    if not is_dir(root):
        raise ConfigError("check", str(root), "a results directory written by 'morphbench bench'"
                          + (" (this is a file)" if root.exists() else ""))
    if not any(present(root / name) for name in (PLAN, *KIND_DIRS.values())):
        raise ConfigError(str(root), PLAN, "a results directory written by 'morphbench bench' (it has no plan.json, "
                                           "runs/ or scans/)")
    found = Findings(root)
    try:
        found.plan = store.read_plan()
        if found.plan is None:
            found.damages.append(Damage(root / PLAN, "expected the plan 'morphbench bench' writes, got none"))
    except Unreadable:
        raise  # its mode, not its content: refused, never moved aside
    except ConfigError as exc:
        found.damages.append(Damage(root / PLAN, _after(exc, str(root / PLAN))))
    layout = store.layout_damage()
    found.damages += layout
    if not layout:
        for kind, job_id, n_units in _jobs(store, found.plan):
            found.jobs += 1
            job = store.load(kind, job_id, n_units)
            if job.damage is not None:
                found.damages.append(job.damage)
        if found.plan is not None:
            found.damages += _orphans(store, found.plan)
    found.damages += _tables(store, found)
    found.damages += _videos(root)
    return found


def _jobs(store: Store, plan: dict | None) -> list[tuple[str, str, int | None]]:
    """(kind, id, scan's number of units) of every job to check that has a directory: the plan's, or without one
    every directory under runs/ and scans/."""
    if plan is not None:
        jobs = [("run", entry["id"], None) for entry in plan["runs"]]
        jobs += [("scan", part, scan["columns"]["n_units"]) for scan in plan["scans"] for part in scan["parts"]]
        return [job for job in jobs if present(store.job_dir(*job[:2]))]
    jobs = []
    for kind, sub in KIND_DIRS.items():
        folder = store.root / sub
        if folder.is_dir():
            jobs += [(kind, path.name, None) for path in sorted(folder.iterdir()) if not path.name.startswith(".")]
    return jobs


def _tables(store: Store, found: Findings) -> list[Damage]:
    """The consolidated tables and backends.parquet that are unreadable, or that differ from the jobs."""
    root, damages = store.root, []
    rebuilt = None
    for name in (*TABLES, *REPORT_TABLES, B.TABLE):
        path = root / f"{name}.parquet"
        if not present(path):
            continue
        try:
            stored = pd.read_parquet(path) if path.is_file() else None
        except PermissionError:
            raise Unreadable(path) from None
        except Exception as exc:  # noqa: BLE001 - whatever Arrow raises on a damaged file is a finding
            damages.append(Damage(path, f"expected a Parquet table ({describe(exc, where=False)[:160]})"))
            continue
        if stored is None:
            damages.append(Damage(path, "expected a Parquet table, got a directory"))
            continue
        if name == B.TABLE:
            reason = B.table_problem(stored)
            reason = reason and f"expected {reason}"
        elif found.plan is None or found.damages or name in ABSORBED:
            continue  # compared with the jobs only when they and the plan are sound: else rebuilt after the repair;
            # steps and units are the consolidated runs' rows themselves, checked run by run
        else:
            if rebuilt is None:
                rebuilt = store.consolidate(found.plan, write=False)
                rebuilt["curves"] = M.curves(rebuilt["steps"])
                rebuilt["metrics"] = M.condition_metrics(rebuilt["steps"], rebuilt["runs"], rebuilt["scans"])
            reason = _difference(stored, rebuilt[name])
        if reason:
            damages.append(Damage(path, reason))
    return damages


def _orphans(store: Store, plan: dict) -> list[Damage]:
    """The rows of the consolidated steps and units tables whose runs the plan does not list and runs/ does not hold
    (Store.orphans): the next consolidation would drop them; --repair sets them aside."""
    return [Damage(store.root / f"{name}.parquet", "expected the rows of the plan's runs (or of a directory under "
                   "runs/), got rows of a run neither has (--repair moves them aside into a table of the same name)",
                   "run", run_id, rows=True)
            for name, run_ids in store.orphans(plan).items() for run_id in run_ids]


def _videos(root: Path) -> list[Damage]:
    """The report's cached videos that do not decode (a report would embed them as they are)."""
    folder = root / V.VIDEO_DIR
    if not folder.is_dir():
        return []
    damages = []
    for path in sorted(folder.glob("*.mp4")):
        problem = None if path.name.startswith(".") else V.video_problem(path)  # a temporary is its writer's
        if problem:
            damages.append(Damage(path, f"expected a video PyAV decodes ({problem}; --repair moves it aside and the "
                                        f"next report renders it again)"))
    return damages


def _difference(stored: pd.DataFrame, expected: pd.DataFrame) -> str | None:
    """Why ``stored`` (read from Parquet) is not ``expected`` (columns in any order), or None."""
    expected = pd.read_parquet(io.BytesIO(expected.to_parquet(index=False)))  # the same types as a stored table
    fix = "stale or edited: 'morphbench report DIR' rebuilds it"
    if set(stored.columns) != set(expected.columns):
        odd = sorted(set(stored.columns) ^ set(expected.columns))
        return f"expected the columns the job directories give ({fix}), got a difference in {odd[0]!r}"
    if len(stored) != len(expected):
        return f"expected {len(expected)} rows, one per job directory's ({fix}), got {len(stored)}"
    for column in expected.columns:
        if not stored[column].reset_index(drop=True).equals(expected[column]):
            return f"expected the values the job directories give ({fix}), got others in column {column!r}"
    return None


def move_aside(found: Findings) -> tuple[list[tuple[str, str]], list[str]]:
    """Move the damaged jobs and files of ``found`` aside into DIR/damaged/<time>/ and remove the consolidated
    tables left stale; ((moved, to) relative paths, removed table names)."""
    root, store = found.root, Store(found.root)
    targets = [path for path in dict.fromkeys(store.job_dir(d.kind, d.job_id) if d.job_id else d.path
                                              for d in found.damages if not d.rows)
               if present(path)]  # not a missing plan
    orphans = store.orphans(found.plan) if any(d.rows for d in found.damages) else {}
    folder = store.aside_folder()  # before anything is written: DIR/damaged a file refuses with nothing changed
    for damage in found.damages:
        if damage.kind == "run" and damage.job_id and not damage.rows:
            store.restore(damage.job_id)  # its rows go aside with it, the next consolidation leaves them out
    moved = [(str(a.relative_to(root)), str(b.relative_to(root)))
             for a, b in zip(targets, store.set_aside(targets, folder))]
    removed = []
    if any(_of_jobs(relative) for relative, _ in moved):
        for name in (*TABLES, *REPORT_TABLES):
            path = root / f"{name}.parquet"
            if path.is_file() and name not in ABSORBED:
                path.unlink()  # rebuilt from the job directories by the next bench or report
                removed.append(path.name)
    moved += [(f"the rows of runs the plan does not list in {name}", str(b.relative_to(root)))
              for name, b in store.set_aside_rows(orphans, folder)]
    return moved, removed


def _of_jobs(relative: str) -> bool:
    """Whether a path moved aside held jobs (a job's directory, plan.json, runs/, scans/): not a table, a table's
    rows or a video."""
    return not relative.endswith((".parquet", ".mp4"))


def run(directory: str | Path, repair: bool = False) -> int:
    """``morphbench check DIR [--repair]``: the findings on stdout, one line each; the exit status (0 clean, 1
    damaged; ConfigError, 2, when DIR is not a results directory)."""
    found = check(directory)
    root = found.root
    what = f"{found.jobs} job directories" + (" and the plan" if found.plan is not None else "")
    if not found.damages:
        print(f"{root}: {what} checked, no damage")
        return 0
    for damage in found.damages:
        print(damage.line(root))
    if not repair:
        print(f"{len(found.damages)} damaged in {root} ({what} checked): 'morphbench check {root} --repair' moves "
              "them aside to be run again")
        return EXIT_DAMAGED
    moved, removed = move_aside(found)
    for relative, destination in moved:
        print(f"moved {relative} to {destination}")
    if removed:
        print(f"removed {', '.join(removed)} (stale: rebuilt from the job directories)")
    if found.plan is None or any(_of_jobs(relative) for relative, _ in moved):
        suite = found.plan.get("source") if found.plan is not None else None
        resume = "" if found.plan is not None else " --resume"
        print(f"to run the moved jobs again: morphbench bench {suite or 'SUITE'} --out {root}{resume}")
    return EXIT_DAMAGED


def _after(exc: ConfigError, source: str) -> str:
    """A ConfigError's message without its leading source (the Damage names the file)."""
    text = str(exc)
    return text[len(source) + 2:] if text.startswith(source + ": ") else text
