"""The scores of the standard task set (docs/leaderboard.md): pure tables, no simulation.

A task's results for a learner are its runs' final true Ubar (``final_ubar_true``, each run's mean over its last
10% of learning steps): ``runs`` finished, ``failed``, their mean ``ubar`` and sample std ``ubar_std``. Its
reference, the **best known gait**, is the highest of its scans' best points and of the built-in learners' means
(the reference table, ``REFERENCE_COLUMNS``, committed beside the suite file as ``<suite>-reference.csv``). Then

    score    = ubar / best                               (1: as good as the best gait known; 0: no motion)
    score_se = ubar_std / sqrt(runs) / best              (the standard error over the seeds; best is a stored constant)
    overall  = mean of the task scores,  overall_se = sqrt(sum score_se^2) / tasks

so that a task's score does not depend on how fast its robot can go, and the overall score weighs the tasks
equally. A learner is scored on a task when at least ``MIN_RUNS`` of its runs there finished; learners are compared
overall on the tasks every one of them is scored on (a plug-in run on a few tasks is compared on those). A
centralized baseline (learning.controllers.CENTRALIZED) is a reference for the per-unit learners, not one of them:
it does not narrow their comparison, and is averaged over the compared tasks it is scored on (it cannot run units
whose steps start at their own moments).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from morphbench.errors import ConfigError
from morphbench.files import write_text

if TYPE_CHECKING:
    from morphbench.bench.model import Suite

REFERENCE_COLUMNS = ("suite", "task", "kind", "source", "id", "runs", "failed", "ubar", "ubar_std")
"""The reference table: one row per task and scan ('scan': ``source`` the scan's name, ``id`` its id, ``runs`` its
points, ``ubar`` its best point, mm/cycle) and per task and built-in learner ('learner': ``source`` its name, ``id``
the condition's id, ``runs`` finished and ``failed`` runs, ``ubar`` and ``ubar_std`` the mean and sample std of
their final true Ubar, mm/cycle). ``suite`` is the suite's name, its version."""
RESULT_COLUMNS = REFERENCE_COLUMNS[1:]
KINDS = ("scan", "learner")
MIN_RUNS = 2
"""finished runs a learner needs on a task to be scored there (a standard error needs two)."""


def learner_results(suite: Suite, runs: pd.DataFrame) -> pd.DataFrame:
    """Per task (the suite's experiments) and learner, its runs' final true Ubar (``RESULT_COLUMNS``), from a
    results directory's runs table; a run that is not done (failed, missing, damaged) counts as failed."""
    by_id = runs.set_index("run_id")
    rows = []
    for experiment in suite.experiments:
        table = by_id.loc[[run_id for run_id in experiment.run_ids if run_id in by_id.index]]
        for (learner, condition_id), group in table.groupby(["learner", "condition_id"], sort=False):
            done = group.final_ubar_true[group.status == "done"].astype(float)
            rows.append({"task": experiment.name, "kind": "learner", "source": learner, "id": condition_id,
                         "runs": len(done), "failed": len(group) - len(done), "ubar": done.mean(),
                         "ubar_std": done.std()})  # pandas: NaN for no value, the sample std (NaN for one)
    return pd.DataFrame(rows, columns=list(RESULT_COLUMNS))


def scan_results(suite: Suite, scans: pd.DataFrame) -> pd.DataFrame:
    """Per task and each of its scans (an experiment's ``scans``), the scan's best point (``RESULT_COLUMNS``)."""
    ids = {scan.name: scan.id for scan in suite.scans}
    rows = []
    for experiment in suite.experiments:
        for name in experiment.scans:
            points = scans.ubar[scans.scan == name].to_numpy(dtype=float)
            rows.append({"task": experiment.name, "kind": "scan", "source": name, "id": ids[name],
                         "runs": len(points), "failed": 0, "ubar": float(np.max(points)) if len(points) else math.nan,
                         "ubar_std": math.nan})
    return pd.DataFrame(rows, columns=list(RESULT_COLUMNS))


def reference_table(suite: Suite, runs: pd.DataFrame, scans: pd.DataFrame) -> pd.DataFrame:
    """The reference table of a suite run in full (its scans and the built-in learners): ``REFERENCE_COLUMNS``.
    A task with no gait known to move forward has no reference: a ConfigError naming it in the suite file."""
    table = pd.concat([scan_results(suite, scans), learner_results(suite, runs)], ignore_index=True)
    table.insert(0, "suite", suite.name)
    for task, best in best_known(table).items():
        if not best > 0:
            raise ConfigError(suite.source, f"experiment[{task}]", "a task on which some scan point or learner "
                                                                   "moves forward (its best known Ubar)", best)
    return table.sort_values(["task", "kind", "source"], key=_task_order(suite), kind="stable", ignore_index=True)


def write_reference(path: str | Path, table: pd.DataFrame) -> Path:
    """The reference table as CSV (every float to 6 significant digits: the table is compared across machines)."""
    path = Path(path)
    write_text(path, table.to_csv(index=False, float_format="%.6g", lineterminator="\n"))
    return path


def read_reference(path: str | Path, suite: Suite) -> pd.DataFrame:
    """The reference table of ``suite``, checked: its columns, kinds and values, and that it was made from this
    suite (its version, each task's scans and built-in conditions: a table left from an earlier definition would
    score against gaits of other tasks). Anything else is a ConfigError naming the file and the row."""
    path = Path(path)
    regenerate = "(regenerate it with python benchmarks/leaderboard.py)"
    try:
        table = pd.read_csv(path, dtype={"suite": str, "task": str, "kind": str, "source": str, "id": str})
    except FileNotFoundError:
        raise ConfigError(path, "(file)", f"the reference table of {suite.name}, a CSV file {regenerate}") from None
    except (OSError, ValueError, UnicodeDecodeError) as exc:
        raise ConfigError(path, "(file)", f"a readable CSV reference table {regenerate}", str(exc)) from None
    if tuple(table.columns) != REFERENCE_COLUMNS:
        raise ConfigError(path, "(columns)", f"{', '.join(REFERENCE_COLUMNS)} {regenerate}",
                          ", ".join(map(str, table.columns)))
    for column in ("ubar", "ubar_std"):
        if not pd.api.types.is_numeric_dtype(table[column]):
            raise ConfigError(path, f"(column {column})", "velocities in mm/cycle (numbers)")
    repeated = table[table.duplicated(["task", "kind", "source"])]
    if len(repeated):
        raise ConfigError(path, f"row {repeated.index[0] + 2}", "one row per task and scan or learner (it repeats "
                                                                f"{repeated.kind.iloc[0]} {repeated.source.iloc[0]})")
    for index, row in table.iterrows():
        where = f"row {index + 2}"  # as a spreadsheet counts: the header is row 1
        if row.kind not in KINDS:
            raise ConfigError(path, f"{where}: kind", f"one of {', '.join(KINDS)}", row.kind)
        for column in ("runs", "failed"):
            if not (isinstance(row[column], (int, np.integer)) and row[column] >= 0):
                raise ConfigError(path, f"{where}: {column}", "a count >= 0", row[column])
        if not np.isfinite(row.ubar) and row.runs:
            raise ConfigError(path, f"{where}: ubar", "a finite velocity (mm/cycle)", row.ubar)
    if (table.suite != suite.name).any():
        other = table.suite[table.suite != suite.name].iloc[0]
        raise ConfigError(path, "suite", f"the results of {suite.name} {regenerate}", other)
    expected = {(e.name, "scan", name) for e in suite.experiments for name in e.scans}
    stored = set(zip(table.task, table.kind, table.source))
    missing = sorted(expected - stored)
    if missing:
        raise ConfigError(path, f"task {missing[0][0]}", f"its scan {missing[0][2]} {regenerate}")
    ids = {scan.name: scan.id for scan in suite.scans}
    for row in table[table.kind == "scan"].itertuples():
        if (row.task, row.kind, row.source) not in expected or ids.get(row.source) != row.id:
            raise ConfigError(path, f"task {row.task}", f"the suite's scans {regenerate}", row.source)
    tasks = {e.name for e in suite.experiments}
    if not tasks <= set(table.task):
        raise ConfigError(path, f"task {sorted(tasks - set(table.task))[0]}", f"a row {regenerate}")
    if not set(table.task) <= tasks:
        raise ConfigError(path, f"task {sorted(set(table.task) - tasks)[0]}", f"a task of {suite.name} {regenerate}")
    for task, best in best_known(table).items():
        if not best > 0:
            raise ConfigError(path, f"task {task}", "a best known Ubar > 0 (a gait that moves it forward)", best)
    return table.drop(columns="suite")


def check_conditions(reference: pd.DataFrame, results: pd.DataFrame, source: str) -> None:
    """That the stored learners' conditions are those of ``results`` (the same learners' conditions as the suite
    defines them now): a ConfigError naming the first task that differs."""
    stored = reference[reference.kind == "learner"].set_index(["task", "source"]).id
    for row in results.itertuples():
        if stored.get((row.task, row.source)) != row.id:
            raise ConfigError(source, f"task {row.task}", f"{row.source}'s results on the task as the suite defines "
                                                          "it (regenerate it with python benchmarks/leaderboard.py)")


def best_known(reference: pd.DataFrame) -> pd.Series:
    """Per task, the best known Ubar (mm/cycle): the highest scan point and scored learner mean."""
    counted = reference[(reference.kind == "scan") | (reference.runs >= MIN_RUNS)]
    return counted.groupby("task", sort=False).ubar.max()


def best_source(reference: pd.DataFrame) -> pd.Series:
    """Per task, what its best known Ubar comes from: 'scan NAME' or the learner's name."""
    counted = reference[(reference.kind == "scan") | (reference.runs >= MIN_RUNS)]
    best = counted.loc[counted.groupby("task", sort=False).ubar.idxmax()]
    return pd.Series([f"scan {s}" if k == "scan" else s for k, s in zip(best.kind, best.source)], index=best.task)


def task_scores(results: pd.DataFrame, best: pd.Series) -> pd.DataFrame:
    """Per task and learner of ``results`` (learner rows): ``task``, ``learner``, ``runs``, ``failed``, ``score``
    and ``score_se`` (NaN where it is not scored: fewer than MIN_RUNS finished runs)."""
    results = results[results.kind == "learner"]
    scale = best.reindex(results.task).to_numpy(dtype=float)
    scored = results.runs.to_numpy() >= MIN_RUNS
    score = np.where(scored, results.ubar.to_numpy(dtype=float) / scale, math.nan)
    se = np.where(scored, results.ubar_std.to_numpy(dtype=float) / np.sqrt(np.maximum(results.runs, 1)) / scale,
                  math.nan)
    return pd.DataFrame({"task": results.task.to_numpy(), "learner": results.source.to_numpy(),
                         "runs": results.runs.to_numpy(), "failed": results.failed.to_numpy(), "score": score,
                         "score_se": se})


def common_tasks(scores: pd.DataFrame) -> list[str]:
    """The tasks every learner of ``scores`` that is scored anywhere is scored on, in their order (a learner whose
    runs all failed leaves the others their comparison). Centralized baselines count only if no other learner is
    scored anywhere: they are compared on the others' tasks, not the others on theirs."""
    from morphbench.learning.controllers import CENTRALIZED

    scored = scores[np.isfinite(scores.score)]
    deciding = scored[~scored.learner.isin(list(CENTRALIZED))]
    deciding = deciding if len(deciding) else scored
    counts = deciding.groupby("task", sort=False).learner.nunique()
    return [task for task in scores.task.unique() if counts.get(task, 0) == deciding.learner.nunique()]


def overall(scores: pd.DataFrame, tasks: list[str] | None = None) -> pd.DataFrame:
    """Per learner, its mean score over ``tasks`` (default: ``common_tasks``) and the standard error propagated from
    the tasks': ``learner``, ``score``, ``score_se``, ``tasks``; best first (a learner scored on none of them is
    left out)."""
    tasks = common_tasks(scores) if tasks is None else tasks
    rows = []
    for learner, group in scores[scores.task.isin(tasks) & np.isfinite(scores.score)].groupby("learner", sort=False):
        n = len(group)
        rows.append({"learner": learner, "score": float(group.score.mean()) if n else math.nan,
                     "score_se": float(np.sqrt((group.score_se ** 2).sum())) / n if n else math.nan, "tasks": n})
    table = pd.DataFrame(rows, columns=["learner", "score", "score_se", "tasks"])
    return table.sort_values("score", ascending=False, kind="stable", ignore_index=True)


def scale_table(scores: pd.DataFrame, sizes: pd.DataFrame) -> pd.DataFrame:
    """The scaling figure's data: per task of ``sizes`` (``task``, ``family``, ``n_units``: its shape's kind and active
    units) and learner of ``scores`` scored there, ``family``, ``n_units``, ``task``, ``learner``, ``centralized``,
    ``score``, ``score_se`` and the error bar's ends ``low`` and ``high`` (score -+ 2 standard errors); by family in
    the order of ``sizes``, then N, learners in the order of ``scores``."""
    from morphbench.learning.controllers import CENTRALIZED

    columns = ["family", "n_units", "task", "learner", "centralized", "score", "score_se", "low", "high"]
    table = sizes.merge(scores[np.isfinite(scores.score)], on="task")
    if not len(table):
        return pd.DataFrame(columns=columns)
    table["centralized"] = table.learner.isin(list(CENTRALIZED))
    table["low"], table["high"] = table.score - 2 * table.score_se, table.score + 2 * table.score_se
    family = {name: k for k, name in enumerate(dict.fromkeys(sizes.family))}
    learner = {name: k for k, name in enumerate(dict.fromkeys(scores.learner))}
    table = table.assign(_f=table.family.map(family), _l=table.learner.map(learner))
    table = table.sort_values(["_f", "n_units", "_l"], kind="stable", ignore_index=True)
    return table[columns]


def compared_tasks(scores: pd.DataFrame, tasks: list[str] | None = None) -> list[str]:
    """The tasks the learners are compared on overall: every learner's (``common_tasks``), of ``tasks`` if given."""
    return [task for task in common_tasks(scores) if tasks is None or task in tasks]


def markdown(scores: pd.DataFrame, reference: pd.DataFrame, tasks: list[str], stored: list[str] = ()) -> str:
    """The leaderboard as Markdown: the overall ranking over ``tasks``, then a row per task (each learner's score
    +- its standard error, the best known Ubar and where it comes from). ``stored`` names the learners read from
    the reference."""
    ranking = overall(scores, tasks)
    all_tasks = list(dict.fromkeys(reference.task))
    best, source = best_known(reference), best_source(reference)
    over = (f"all {len(all_tasks)} tasks" if len(tasks) == len(all_tasks)
            else f"the {len(tasks)} of {len(all_tasks)} tasks every learner is scored on")
    fewer = ranking.tasks < len(tasks)
    note = (" A centralized baseline is averaged over those it is scored on (the tasks column)." if fewer.any()
            else "")
    lines = ["## Overall", "",
             f"Mean task score over {over}, +- its standard error; 1 is the best gait known for each task.{note}", "",
             "| rank | learner | score | tasks |", "|---|---|---|---|"]
    for rank, row in enumerate(ranking.itertuples(), 1):
        lines.append(f"| {rank} | {_learner(row.learner, stored)} | {_pm(row.score, row.score_se)} | {row.tasks} |")
    learners = list(ranking.learner) + [name for name in scores.learner.unique() if name not in set(ranking.learner)]
    lines += [f"| - | {_learner(name, stored)} | not scored | 0 |" for name in learners[len(ranking):]]
    lines += ["", "## Per task", "",
              "Final true Ubar over the best gait known for the task (mean over seeds +- standard error); a learner "
              "with failed runs is scored on its finished ones (fewer than "
              f"{MIN_RUNS}: not scored, -).", "",
              "| task | " + "".join(f"{_learner(name, stored)} | " for name in learners)
              + "best known (mm/cycle) | from |",
              "|---" * (len(learners) + 3) + "|"]
    cell = {(row.task, row.learner): row for row in scores.itertuples()}
    for task in all_tasks:
        cells = [_cell(cell.get((task, name))) for name in learners]
        lines.append(f"| {task} | " + " | ".join(cells) + f" | {best[task]:.2f} | {source[task]} |")
    if stored:
        lines += ["", f"{', '.join(stored)}: the stored results of the reference table (marked *)."]
    return "\n".join(lines) + "\n"


def _cell(row) -> str:
    if row is None:
        return "not run"
    if not np.isfinite(row.score):
        return f"- ({row.failed} failed)"
    text = _pm(row.score, row.score_se)
    return text + (f" ({row.failed} of {row.runs + row.failed} failed)" if row.failed else "")


def _pm(value: float, se: float) -> str:
    return f"{value:.3f} +- {se:.3f}"


def _learner(name: str, stored) -> str:
    """A learner's name in the tables: * if read from the reference; a centralized baseline marked as one (a
    reference for the decentralized learners, not one of them)."""
    from morphbench.learning.controllers import CENTRALIZED

    return f"{name}{'*' if name in stored else ''}{' (centralized)' if name in CENTRALIZED else ''}"


def _task_order(suite: Suite):
    """Sort keys: tasks in the suite's order, scans before learners."""
    order = {"task": {e.name: k for k, e in enumerate(suite.experiments)}, "kind": {k: i for i, k in enumerate(KINDS)}}
    return lambda column: column.map(order[column.name]) if column.name in order else column

