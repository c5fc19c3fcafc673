"""``morphbench leaderboard``: learners scored on the standard task set (benchmarks/standard-v2.toml,
docs/leaderboard.md).

The built-in learners' results are stored, summarised, in the suite's reference table (``<suite>-reference.csv``
beside the suite file, made by ``make_reference``: ``python benchmarks/leaderboard.py``), with the best gait known
for each task; the leaderboard reads them from there and never runs them again. Any other learner (a plug-in
``package.module:Class``, a centralized baseline, a built-in the table lacks) is run on the set's tasks (or those
``--tasks`` names) into a results directory, ``results/leaderboard`` by default, as a suite of its own: running the
command again skips the runs the directory holds (the suites' resume; run ids are hashes of the runs, so a learner's
runs are reused whatever others were named with it). ``DIR/leaderboard.md`` and ``DIR/leaderboard.html`` then show
every learner's score per task and overall (morphbench.bench.scores), the stored built-ins beside the named ones.

``--suite`` takes a suite file or the name of a task set shipped with morphbench (``standard-v1``: the file
``standard-v1.toml`` of ``data_path("benchmarks")``); ``--tasks`` takes task names and the names of the suite's
``groups`` (``scale``: its tasks). When the tasks shown include some of the group ``scale`` (SCALE_GROUP), each
learner's score on them against the number of units is drawn into ``DIR/leaderboard-scale.png``, shown under the
tables of leaderboard.md and .html (``scale_points``; benchmarks/leaderboard.py draws the same figure into
docs/media/ for docs/leaderboard.md).
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
from morphbench.files import check_path, is_file, read_toml_with_text, write_text

STANDARD = "standard-v2.toml"
"""the task set ``morphbench leaderboard`` scores on unless ``--suite`` names another (its version: docs/leaderboard.md,
"Versions")."""
SETS = "standard-*.toml"
"""the task sets shipped with morphbench, in ``data_path("benchmarks")``: ``--suite`` takes their names."""
DEFAULT_OUT = "results/leaderboard"
SCALE_GROUP = "scale"
"""the group of tasks whose scores the scaling figure draws against the number of units."""
SCALE_FIGURE = "leaderboard-scale.png"
OUTPUTS = ("leaderboard.md", "leaderboard.html", SCALE_FIGURE)


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
    scale: pd.DataFrame
    """the learners' scores on the tasks of the group ``scale`` shown (``scale_points``; empty if none)."""
    figure: Path | None = None
    """``DIR/leaderboard-scale.png``, the scale figure, if drawn."""


def standard_suite() -> Path:
    """The standard task set shipped with morphbench."""
    return data_path("benchmarks") / STANDARD


def shipped_sets() -> list[str]:
    """The names of the task sets shipped with morphbench (``standard-v1``, ``standard-v2``, ...)."""
    return sorted(path.stem for path in data_path("benchmarks").glob(SETS))


def suite_file(value: str | Path | None) -> Path:
    """``--suite``: a suite file, or the name of a task set shipped with morphbench (``standard-v1`` or
    ``standard-v1.toml``, in ``data_path("benchmarks")``) where no such file exists; None: the standard set. A bare
    name that is neither is a ConfigError listing the shipped sets (a path is left to the suite reader)."""
    if value is None:
        return standard_suite()
    path = Path(value)
    if is_file(path) or str(path.name) != str(value):
        return path
    shipped = data_path("benchmarks") / (path.name if path.suffix == ".toml" else f"{path.name}.toml")
    if is_file(shipped):
        return shipped
    raise ConfigError("--suite", str(value), "a suite file or the name of a task set shipped with morphbench ("
                                             f"{', '.join(shipped_sets())})")


def task_names(names: list[str], suite: Suite, suite_path: str | Path) -> list[str]:
    """``--tasks``: each name a task of ``suite`` or one of its groups (its tasks, in the group's order); the tasks
    once each, in the order named. Any other name is a ConfigError listing both."""
    tasks = [e.name for e in suite.experiments]
    chosen = []
    for name in names:
        if name in tasks:
            chosen.append(name)
        elif name in suite.groups:
            chosen.extend(suite.groups[name])
        else:
            groups = ", ".join(suite.groups) or "it has none"
            raise ConfigError("--tasks", name, f"a task of {suite_path} ({', '.join(tasks)}) or one of its groups "
                                               f"({groups})")
    return list(dict.fromkeys(chosen))


def task_sizes(suite: Suite, tasks) -> pd.DataFrame:
    """Per task of ``tasks`` (in that order): ``task``, ``family`` (its shape's name up to the first '-': chain,
    sheet, ...) and ``n_units`` (its shape's active units at the start), for the scaling figure."""
    rows = []
    for experiment in suite.experiments:
        if experiment.name in tasks:
            shape = suite.runs[experiment.run_ids[0]].config.shape
            rows.append({"task": experiment.name, "family": shape.name.split("-", 1)[0], "n_units": shape.n_units})
    order = {task: k for k, task in enumerate(tasks)}
    table = pd.DataFrame(rows, columns=["task", "family", "n_units"])
    return table.sort_values("task", key=lambda column: column.map(order), ignore_index=True)


def scale_points(suite: Suite, scores: pd.DataFrame, tasks: list[str] | None = None) -> pd.DataFrame:
    """The scores of the suite's group ``scale`` (of ``tasks`` if given) against the number of units
    (``scores.scale_table``): empty if the suite has no such group."""
    group = [task for task in suite.groups.get(SCALE_GROUP, ()) if tasks is None or task in tasks]
    return S.scale_table(scores, task_sizes(suite, group))


def scale_sentence(points: pd.DataFrame, who: str = "Each learner's") -> str:
    """One sentence saying what the scaling figure of ``points`` (``scale_points``) shows."""
    panels = []
    for family, rows in points.groupby("family", sort=False):
        low, high = int(rows.n_units.min()), int(rows.n_units.max())
        panels.append(f"{family}s of {low:,} to {high:,} units" if low != high else f"{family}s of {low:,} units")
    where = "; ".join(f"{text} ({side})" for text, side in zip(panels, _sides(len(panels))))
    return (f"{who} score on the tasks of the group `{SCALE_GROUP}` against their number of units N (log scale): "
            f"{where}; the mean over the seeds +- 2 standard errors, 1 the best gait known for each task.")


def _sides(n: int) -> list[str]:
    return ["alone"] if n == 1 else ["left", "right"] if n == 2 else [f"panel {k}" for k in range(1, n + 1)]


def reference_path(suite_path: str | Path) -> Path:
    """The reference table of a suite file: ``<stem>-reference.csv`` beside it."""
    suite_path = Path(suite_path)
    return suite_path.with_name(f"{suite_path.stem}-reference.csv")


def learner_suite(path: str | Path, learners: list[str], tasks: list[str] | None = None) -> Suite:
    """The suite file's tasks (all, or those named by ``tasks``) for ``learners``, without its scans (the reference
    holds their best points). A task names no learner of its own: the leaderboard sets them (defaults.learner.name)."""
    path = Path(path)
    table, text = read_toml_with_text(path, "suite file")
    if "include" in table:  # an included suite's experiments would keep their own learners
        raise ConfigError(path, "include", "no include in a leaderboard's suite (it runs every task with the learners "
                                           "it is given: write the tasks into the file)", table["include"])
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
    own = {key: value for key, value in table.items() if key not in ("scan", "experiment", "defaults", "groups")}
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
    (``suite_file``: a file or a shipped set's name; default: the standard set) against its reference table, running
    those it does not store into ``out``; write ``out``/leaderboard.md and .html (and the scale figure,
    leaderboard-scale.png, when the tasks shown include some of the group ``scale``). ``tasks``: task or group names
    (``task_names``). Bad input (a learner that cannot be loaded, an unknown task or group, a reference table that
    is not this suite's, a results directory of another suite or with damaged runs) is a ConfigError."""
    from morphbench.learning.plugins import learner_name

    out = check_path(str(out), "--out")  # before anything is read: an impossible name writes nothing
    suite_path = suite_file(suite_path)
    named = list(dict.fromkeys(learner_name(name) for name in learners))
    full = load_suite(suite_path)
    tasks = task_names(tasks, full, suite_path) if tasks else None
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
    text = f"# {title}\n\n{full.description}\n\n{tables}"
    points, figure = scale_points(full, scores, tasks), None
    if len(points):
        from morphbench.bench.figures import leaderboard_scale

        figure = leaderboard_scale(points, out / SCALE_FIGURE, f"{full.name}: score against the number of units")
        text += f"\n## Scale\n\n{scale_sentence(points)}\n\n![score against the number of units]({SCALE_FIGURE})\n"
    return Board(scores, S.overall(scores, compared), tables, failures, *write_board(out, text, title), points, figure)


def make_reference(suite_path: str | Path, out: str | Path, executor=None, progress: bool = True):
    """Run the suite in full (its scans and its own learners: the built-ins) into ``out`` (resumed if it holds them)
    and write its reference table beside the suite file (``suite_file``: a file or a shipped set's name); the table
    and the run's Outcome (bench.runner)."""
    from morphbench.bench.runner import run_suite

    suite_path = suite_file(suite_path)
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

    md, page = (out / name for name in OUTPUTS[:2])
    write_text(md, text)
    write_text(page, markdown_page(text, title, root=out))  # its figure inline: one page that needs no other file
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
