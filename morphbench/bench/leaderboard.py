"""``morphbench leaderboard``: learners scored on the standard task set (benchmarks/standard.toml, docs/leaderboard.md).

The built-in learners' results are stored, summarised, in the suite's reference table (``<suite>-reference.csv``
beside the suite file, made by ``make_reference``: ``python benchmarks/leaderboard.py``), with the best gait known
for each task; the leaderboard reads them from there and never runs them again. Any other learner (a plug-in
``package.module:Class``, a centralized baseline, a built-in the table lacks) is run on the set's tasks (or those
``--tasks`` names) into a results directory, ``results/leaderboard`` by default, as a suite of its own: running the
command again skips the runs the directory holds (the suites' resume; run ids are hashes of the runs, so a learner's
runs are reused whatever others were named with it). ``DIR/leaderboard.md`` and ``DIR/leaderboard.html`` then show
every learner's score per task and overall (morphbench.bench.scores), the stored built-ins beside the named ones.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from morphbench import data_path
from morphbench.bench import scores as S
from morphbench.bench.model import Suite
from morphbench.bench.store import DAMAGED, REPAIR, Store
from morphbench.bench.suite import load_suite, suite_from_table
from morphbench.errors import ConfigError
from morphbench.files import check_path, read_toml_with_text, write_text

STANDARD = "standard.toml"
DEFAULT_OUT = "results/leaderboard"
OUTPUTS = ("leaderboard.md", "leaderboard.html")


@dataclass
class Board:
    """What one leaderboard call found: the scores, the runs that failed, where the tables are."""

    scores: pd.DataFrame
    ranking: pd.DataFrame
    """each learner's overall score over the tasks compared (scores.overall), best first."""
    tables: str
    """the Markdown of the overall ranking and the per-task table (scores.markdown)."""
    failures: list[tuple[str, str]]
    """(run id, error) of the named learners' failed runs."""
    markdown: Path
    html: Path


def standard_suite() -> Path:
    """The standard task set shipped with morphbench."""
    return data_path("benchmarks") / STANDARD


def reference_path(suite_path: str | Path) -> Path:
    """The reference table of a suite file: ``<stem>-reference.csv`` beside it."""
    suite_path = Path(suite_path)
    return suite_path.with_name(f"{suite_path.stem}-reference.csv")


def learner_suite(path: str | Path, learners: list[str], tasks: list[str] | None = None) -> Suite:
    """The suite file's tasks (all, or those named by ``tasks``) for ``learners``, without its scans (the reference
    holds their best points). A task names no learner of its own: the leaderboard sets them (defaults.learner.name)."""
    path = Path(path)
    table, text = read_toml_with_text(path, "suite file")
    defaults = dict(table.get("defaults") or {})
    learner = defaults.get("learner", {})
    defaults["learner"] = {**(learner if isinstance(learner, dict) else {}), "name": list(learners)}
    experiments = table.get("experiment", [])
    experiments = experiments if isinstance(experiments, list) else [experiments]
    kept = []
    for index, experiment in enumerate(experiments):
        if not isinstance(experiment, dict) or (tasks and experiment.get("name") not in tasks):
            continue
        if "learners" in experiment or "name" in (experiment.get("learner") or {}):
            raise ConfigError(path, f"experiment[{experiment.get('name', index)}].learner.name",
                              "no learner name in a task of the leaderboard (it runs the learners it is given)")
        kept.append({key: value for key, value in experiment.items() if key != "scans"})
    own = {key: value for key, value in table.items() if key not in ("scan", "experiment", "defaults")}
    return suite_from_table({**own, "defaults": defaults, "experiment": kept}, source=str(path), base=path.parent,
                            default_name=path.stem, text=text)


def conditions(suite: Suite) -> pd.DataFrame:
    """Per task and learner, the condition's id: ``task``, ``source``, ``id``."""
    rows = {}
    for experiment in suite.experiments:
        for run_id in experiment.run_ids:
            spec = suite.runs[run_id]
            rows[(experiment.name, spec.condition["learner"])] = spec.condition_id
    return pd.DataFrame([{"task": t, "source": s, "id": i} for (t, s), i in rows.items()],
                        columns=["task", "source", "id"])


def leaderboard(learners: list[str], out: str | Path = DEFAULT_OUT, suite_path: str | Path | None = None,
                tasks: list[str] | None = None, executor=None, progress: bool = True) -> Board:
    """Score ``learners`` (names as ``--learner`` takes them; none: the stored built-ins alone) on the suite
    (default: the standard set) against its reference table, running those it does not store into ``out``; write
    ``out``/leaderboard.md and .html. Bad input (a learner that cannot be loaded, an unknown task, a reference
    table that is not this suite's, a results directory of another suite or with damaged runs) is a ConfigError."""
    from morphbench.learning.plugins import learner_name

    out = check_path(str(out), "--out")  # before anything is read: an impossible name writes nothing
    suite_path = Path(suite_path) if suite_path is not None else standard_suite()
    named = list(dict.fromkeys(learner_name(name) for name in learners))
    full = load_suite(suite_path)
    names = [e.name for e in full.experiments]
    for name in tasks or ():
        if name not in names:
            raise ConfigError("--tasks", name, f"a task of {suite_path} ({', '.join(names)})")
    reference = S.read_reference(reference_path(suite_path), full)
    stored_rows = reference[reference.kind == "learner"]
    S.check_conditions(reference, conditions(full)[lambda t: t.source.isin(set(stored_rows.source))],
                       str(reference_path(suite_path)))
    stored = list(dict.fromkeys(stored_rows.source))
    to_run = [name for name in named if name not in stored]
    results, failures = [stored_rows], []
    _check_out(out, full.name)
    if to_run:
        from morphbench.bench.runner import run_suite

        suite = learner_suite(suite_path, to_run, tasks)
        outcome = run_suite(suite, out, executor, resume=True, progress=progress)
        runs = outcome.tables["runs"]
        damaged = runs[runs.status == DAMAGED]
        if len(damaged):
            raise ConfigError(out, "runs", f"results without damaged runs ({len(damaged)} damaged, e.g. "
                                           f"{damaged.run_id.iloc[0]}: {REPAIR})")
        failed = runs[runs.status == "failed"]
        failures = list(zip(failed.run_id, failed.error.fillna("unknown error")))
        results.append(S.learner_results(suite, runs))
    else:
        out.mkdir(parents=True, exist_ok=True)
    scores = S.task_scores(pd.concat(results, ignore_index=True), S.best_known(reference))
    compared = S.compared_tasks(scores, tasks)
    tables = S.markdown(scores, reference, compared, stored=stored)
    title = f"Leaderboard: {full.name}"
    return Board(scores, S.overall(scores, compared), tables, failures,
                 *write_board(out, f"# {title}\n\n{full.description}\n\n{tables}", title))


def make_reference(suite_path: str | Path, out: str | Path, executor=None, progress: bool = True):
    """Run the suite in full (its scans and its own learners: the built-ins) into ``out`` (resumed if it holds them)
    and write its reference table beside the suite file; the table and the run's Outcome (bench.runner)."""
    from morphbench.bench.runner import run_suite

    suite = load_suite(suite_path)
    outcome = run_suite(suite, out, executor, resume=True, progress=progress)
    jobs = outcome.tables["jobs"]
    if (jobs.status == DAMAGED).any():
        raise ConfigError(out, "jobs", f"results without damaged jobs ({REPAIR})")
    table = S.reference_table(suite, outcome.tables["runs"], outcome.tables["scans"])
    S.write_reference(reference_path(suite_path), table)
    return table, outcome


def tasks_markdown(suite: Suite) -> str:
    """The suite's tasks as a Markdown table: shape, the physics backend its runs resolve to, seeds, learning
    steps, the scans whose best point is a known gait, what it tests."""
    from morphbench.physics import resolve_backend

    lines = ["| task | shape | backend | seeds | steps | known gaits from | what it tests |", "|---" * 7 + "|"]
    for experiment in suite.experiments:
        specs = [suite.runs[run_id] for run_id in experiment.run_ids]
        config = specs[0].config
        backend = resolve_backend(config.shape, config.physics, config.environment)
        scans = ", ".join(f"scan {name}" for name in experiment.scans) or "the learners only"
        lines.append(f"| {experiment.name} | {config.shape.name} | {backend} | {len({s.seed for s in specs})} | "
                     f"{config.steps} | {scans} | {experiment.description} |")
    return "\n".join(lines) + "\n"


def write_board(out: Path, text: str, title: str) -> tuple[Path, Path]:
    """``out``/leaderboard.md and the same as one page, leaderboard.html."""
    from morphbench.bench.html import markdown_page

    md, page = (out / name for name in OUTPUTS)
    write_text(md, text)
    write_text(page, markdown_page(text, title))
    return md, page


def _check_out(out: Path, suite_name: str) -> None:
    """``out`` may be new, a leaderboard's own directory (its tables, or the runs of this suite), nothing else: the
    leaderboard resumes into it without asking."""
    if out.exists() and not out.is_dir():
        raise ConfigError("--out", str(out), "a directory (this is a file)")
    plan = Store(out).read_plan()
    if plan is not None and plan.get("suite") != suite_name:
        raise ConfigError("--out", str(out), f"a leaderboard's directory of {suite_name}; it holds the results of "
                                             f"suite {plan.get('suite')!r} (choose another --out)")
    if plan is None and out.is_dir():
        other = sorted(p.name for p in out.iterdir() if not p.name.startswith(".") and p.name not in OUTPUTS)
        if other:
            raise ConfigError("--out", str(out), f"a new directory or a leaderboard's (it holds {other[0]})")
