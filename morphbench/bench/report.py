"""Figures and report.md of a results directory, rebuilt from the store alone (no simulation).

``build_report(DIR)`` consolidates the tables from the job directories (so it also works on the results of an
interrupted bench, reporting the missing runs), computes ``curves.parquet`` and ``metrics.parquet``
(morphbench.bench.metrics) and writes, per experiment, a table of its conditions' metrics, with events a table of
each event's recovery (metrics.event_recovery), and into ``DIR/figures/`` (morphbench.bench.figures draws them):
- ``<experiment>-ubar.png``: per condition, the distribution of per-run Ubar (true) over seeds against the learning
  step (colour: fraction of runs), the mean over seeds, the exponential fit dashed, the scan's best dotted, events;
- ``<experiment>-acceptance.png``: mean acceptance vs learning step (10-step running mean), one line per condition;
  beside it the final acceptance against the noise when the experiment sweeps the noise;
- ``<experiment>-scaling.png`` when the experiment spans several numbers of units: U_eq (error bars: std of final
  Ubar over seeds), steps to 0.8 U_eq and the fraction of runs that reach it, against N;
- ``<experiment>-events.png`` with events: mean Ubar per condition with the events marked, per piece after a cut;
- ``<experiment>-landscapes.png`` when 3-unit scans go with the experiment (its ``scans`` key, or the scans of its
  shape, physics and ground: morphbench.bench.suite): each map with the phase differences tried by one run per
  learner over the stretch of the run the map describes (a damaged map: from the damage on);
- ``<experiment>-positions.png``: the units' positions along the track at the first and last step, a few runs;
- ``<experiment>-trajectories.png``: the centroid tracks of the first TRACKS_PER_CONDITION runs of each condition,
  one colour per condition (when the runs recorded one: runs stored before steps.parquet had ``x_m`` are left out);
and ``scan-<name>.png`` per scan (a curve for 2 units, a heat map for 3, a histogram beyond). ``DIR/report.md``
holds the tables and figures, a comparison of decentralized learners with centralized controllers when the suite
has both, the paper's claims checked against the tables (morphbench.bench.claims), the failed runs with their
errors and the damaged jobs (morphbench.bench.store: left out of every table, each with its file and what was
expected). A damaged plan.json, ``runs/`` or backends.parquet is a ConfigError before anything is written, and so is
a path the report writes that holds the other kind (a directory at report.md, a file at figures/: ``require_outputs``).
A figure the tables cannot give (an experiment without finished runs, results stored before a column existed, an
unfinished scan) is left out with a line saying why.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from morphbench import plots  # noqa: E402
from morphbench.bench import backends as B  # noqa: E402
from morphbench.bench import claims as C  # noqa: E402
from morphbench.bench import figures as F  # noqa: E402
from morphbench.bench import metrics as M  # noqa: E402
from morphbench.bench.html import start_videos, write_html  # noqa: E402
from morphbench.bench.store import ABSORBED, DAMAGED, TABLES, Store  # noqa: E402
from morphbench.bench.videos import VIDEO_DIR  # noqa: E402
from morphbench.errors import ConfigError  # noqa: E402
from morphbench.files import present, write_text  # noqa: E402

MAX_POSITION_RUNS = 6
"""runs drawn at most in a figure of start and end positions."""
MAX_CURVES = 12
"""conditions drawn at most as lines of one plot."""
FIGURES = "figures"
WRITTEN_INSIDE = {FIGURES: ("*.png",), VIDEO_DIR: ("*.mp4", "*.json")}
"""the report's directories, and the files in them it replaces or removes."""


def build_report(out: str | Path, tables: dict[str, pd.DataFrame] | None = None, videos: bool = False) -> Path:
    """Write curves.parquet, metrics.parquet, figures/ and report.md into ``out``; returns the report's path."""
    store = Store(out)
    plan = store.require_plan()  # a damaged plan, runs/ or backends table refuses before anything is written
    store.require_layout()
    require_outputs(store.root, videos=bool(videos))
    backends = B.read_table(store.root)
    tables = tables or store.consolidate(plan)
    runs, steps, scans = tables["runs"], tables["steps"], tables["scans"]
    curves = M.curves(steps)
    metrics = M.condition_metrics(steps, runs, scans)
    store.write_table("curves", curves)
    store.write_table("metrics", metrics)
    videos = start_videos(store.root) if videos else False  # rendered while the report is written
    figures = store.root / FIGURES
    figures.mkdir(exist_ok=True)
    for old in figures.glob("*.png"):
        old.unlink()

    lines = [f"# Suite {plan['suite']}", ""]
    if plan.get("description"):
        lines += [plan["description"], ""]
    n_done, n_failed = int((runs.status == "done").sum()), int((runs.status == "failed").sum())
    n_missing = int((runs.status == "missing").sum())
    damaged = tables["jobs"][tables["jobs"].status == DAMAGED]
    wall = tables["jobs"].wall_time_s.sum()
    n_damaged = int((runs.status == DAMAGED).sum())
    n_damaged = f", {n_damaged} damaged" if n_damaged else ""
    lines += [f"{len(runs)} runs: {n_done} done, {n_failed} failed, {n_missing} not run yet{n_damaged}; "
              f"{len(plan['scans'])} scans. Compute time {_duration(wall)} (sum over jobs). Report written "
              f"{time.strftime('%Y-%m-%d %H:%M')} from `{store.root}`.", "",
              "Ubar is the true mean velocity of the active units (mm/cycle), whatever the learners measured. "
              "Final Ubar: mean over the last 10% of steps, mean +- std over seeds. U_eq, U_0, k_0: fit of "
              "U(k) = U_eq - (U_eq - U_0) exp(-k/k_0) to the seed-averaged curve ('no plateau' when k_0 exceeds a "
              f"third of the run: U_eq would be an extrapolation). Steps to {M.THRESHOLD:g} U_eq: first step a run "
              "reaches it, mean +- std over the runs that do, and the fraction that do. 'of scan best': final Ubar "
              "over the best Ubar of the suite's healthy scans of the same shape, physics and ground. Experiments "
              "with events have a table of each event's recovery. Figures: the distribution of Ubar over seeds at "
              "each step (colour: fraction of runs; the mean over seeds on top), acceptance, and as the experiment "
              "allows scaling with N, Ubar around events, the phases tried on landscapes, start and end positions "
              "and trajectories. U along heading: the assembly centroid's velocity along its heading "
              "(mm/cycle, over the same last steps as final Ubar; pump cycles between steps include the discarded "
              "ones); turning rate: slope of its heading over time (deg/cycle, positive counter-clockwise seen from "
              "above); both mean +- std over seeds.", ""]
    if n_missing:
        lines += [f"**{n_missing} runs have no results yet**: the bench was interrupted; run it again with the same "
                  "--out to finish.", ""]

    central = set(runs.condition_id[runs.centralized == 1]) if "centralized" in runs else set()
    context = _Context(plan, tables, metrics, curves, M.event_recovery(steps), figures, central)
    for experiment in plan["experiments"]:
        lines += _experiment_section(experiment, context)
    lines += _decentralization_section(metrics, steps, central)
    if backends is not None:
        lines += B.section(backends)
    if plan["scans"]:
        lines += ["## Scans", ""]
        lines += _scan_section(plan, scans, figures)
    lines += _claims_section({**tables, "metrics": metrics, "curves": curves}, plan["suite"], _includes(plan))
    failed = runs[runs.status == "failed"]
    failed_scans = tables["jobs"][(tables["jobs"].kind == "scan") & (tables["jobs"].status == "failed")]
    if len(failed) or len(failed_scans):
        lines += ["## Failed jobs", "", "| job | condition | seed | error |", "|---|---|---|---|"]
        for _, row in failed.iterrows():
            lines.append(f"| run {row.run_id} | {row['shape']} {row.learner} | {row.seed} | {_cell(row.error)} |")
        for _, row in failed_scans.iterrows():
            lines.append(f"| scan part {row.job_id} | | | {_cell(row.error)} |")
        lines.append("")
    lines += _damaged_section(damaged)
    path = store.root / "report.md"
    write_text(path, "\n".join(lines) + "\n")
    write_html(store.root, videos=videos)  # report.html: this report as one page, with a video per experiment
    return path


def require_outputs(root: str | Path, videos: bool = False) -> None:
    """ConfigError naming the first path the report (with ``videos``, its videos too) writes that holds the other
    kind: a directory where it writes a file (a table, report.md, a figure), a file where it writes into a directory
    (figures/, videos/). Writing would fail half-way or lose it, so nothing is written, and it is not moved (no
    results data: whoever put it there moves it)."""
    root = Path(root)
    files = [f"{name}.parquet" for name in (*TABLES, "curves", "metrics", B.TABLE) if name not in ABSORBED]
    files += ["report.md", "report.html"]  # (an unreadable steps or units table is set aside: store.consolidate)
    for name in [FIGURES, VIDEO_DIR] if videos else [FIGURES]:
        folder = root / name
        if present(folder) and not folder.is_dir():
            raise ConfigError(str(root), name, "a directory the report writes its files into, got a file (move it "
                                               "away)")
        files += [f"{name}/{path.name}" for pattern in WRITTEN_INSIDE[name] for path in sorted(folder.glob(pattern))]
    for name in files:
        if (root / name).is_dir():
            raise ConfigError(str(root), name, "a file the report writes over, got a directory (move it away)")


def _damaged_section(damaged: pd.DataFrame) -> list[str]:
    """The jobs whose directories are damaged (morphbench.bench.store), left out of every table and figure."""
    if not len(damaged):
        return []
    lines = ["## Damaged jobs", "",
             f"{len(damaged)} jobs have a directory whose files are not what 'morphbench bench' writes: they are left "
             "out of every table and figure above (counted as missing). `morphbench check DIR --repair` moves them "
             "aside, and `morphbench bench SUITE --out DIR` then runs them again.", "",
             "| job | file: what was expected |", "|---|---|"]
    lines += [f"| {row.kind} {row.job_id} | {_cell(row.error)} |" for _, row in damaged.iterrows()]
    return lines + [""]


@dataclass
class _Context:
    """What every experiment's section reads: the plan, the store's tables and what the report computed."""

    plan: dict
    tables: dict[str, pd.DataFrame]
    metrics: pd.DataFrame
    curves: pd.DataFrame
    recovery: pd.DataFrame
    """metrics.event_recovery of every condition."""
    figures: Path
    central: set[str]

    def __post_init__(self):
        steps, units = self.tables["steps"], self.tables.get("units", pd.DataFrame())
        self._steps = steps.groupby("condition_id", sort=False).indices if len(steps) else {}
        self._cut: dict[str, pd.DataFrame] = {}
        self._units = units.groupby("run_id", sort=False).indices if len(units) and "run_id" in units else {}

    def steps_of(self, condition_id: str) -> pd.DataFrame:
        """The steps of a condition's finished runs, in plan order (cut once: every figure of the condition reads
        them, and cutting them out of a suite's table takes most of a second)."""
        if condition_id not in self._cut:
            rows = self._steps.get(condition_id)
            self._cut[condition_id] = self.tables["steps"].iloc[rows] if rows is not None else \
                self.tables["steps"].iloc[:0]
        return self._cut[condition_id]

    def has_units(self, *columns: str) -> bool:
        """Whether the store holds units tables with these columns."""
        units = self.tables.get("units", pd.DataFrame())
        return bool(self._units) and set(columns) <= set(units.columns)

    def units_of(self, run_id: str) -> pd.DataFrame:
        """A finished run's units table (empty if the store has none for it)."""
        units = self.tables.get("units", pd.DataFrame())
        rows = self._units.get(run_id)
        return units.iloc[rows] if rows is not None else units.iloc[:0]


TRACKS_PER_CONDITION = 12
"""runs per condition drawn on the trajectories figure (their first seeds): thousands of tracks are one blot."""


def _first_runs(steps: pd.DataFrame, count: int) -> pd.DataFrame:
    """The steps of a condition's first ``count`` runs (plan order)."""
    first = pd.unique(steps.run_id)[:count]
    return steps[steps.run_id.isin(first)]


def _experiment_section(experiment: dict, ctx: _Context) -> list[str]:
    name = experiment["name"]
    central = ctx.central
    lines = [f"## {name}", ""]
    if experiment.get("description"):
        lines += [experiment["description"], ""]
    mine = ctx.metrics.set_index("condition_id").reindex(experiment["condition_ids"]).reset_index()
    varying = _display_columns(experiment["varying"])
    fixed = [c for c in ("shape", "learner", "step_size", "temperature", "noise", "environment", "events", "steps")
             if c not in varying]
    if len(mine):
        first = mine.iloc[0]
        lines += ["Fixed: " + ", ".join(f"{c} = {_cell_value(first, c, central)}" for c in fixed if c in mine) + ".",
                  ""]
    header = [*varying, "runs", "final Ubar", "U_eq", "U_0", "k_0", f"steps to {M.THRESHOLD:g} U_eq", "reached",
              "acceptance (end)", "of scan best", "U along heading", "turning rate (deg/cycle)"]
    lines += ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for _, row in mine.iterrows():
        runs = f"{row.runs - row.failed - row.missing}" + (f" ({row.failed} failed)" if row.failed else "") \
            + (f" ({row.missing} missing)" if row.missing else "")
        cells = [_cell_value(row, c, central) for c in varying] + [
            runs, _pm(row.final_ubar, row.final_ubar_std),
            "no plateau" if not row.plateau and np.isfinite(row.u_eq) else _fmt(row.u_eq, 2),
            _fmt(row.u_0, 2), _fmt(row.k_0, 1) if row.plateau else "-",
            _pm(row.steps_to_threshold, row.steps_to_threshold_std, 1),
            _fmt(row.reached_fraction, 2), _fmt(row.acceptance_final, 2), _fmt(row.learned_fraction, 2),
            _pm(row.final_u_heading, row.final_u_heading_std), _pm(row.turning_rate, row.turning_rate_std, 3)]
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    labels = {row.condition_id: _label(row, varying) for _, row in mine.iterrows()}
    done = [c for c in mine.condition_id if len(ctx.steps_of(c))]
    if not done:
        return lines + ["No finished runs yet.", ""]
    marks = _event_marks(pd.concat([ctx.steps_of(c) for c in done]))
    lines += _events_table(mine, labels, ctx.recovery, varying)

    if np.isfinite(pd.concat([ctx.steps_of(c).ubar_true for c in done]).to_numpy(dtype=float)).any():
        ubar_png = F.ubar_distribution(name, [(labels[c], ctx.steps_of(c), _row(mine, c),
                                               _event_marks(ctx.steps_of(c))) for c in done],
                                       ctx.figures / f"{name}-ubar.png")
        lines += [f"![distribution of Ubar vs step](figures/{ubar_png.name})", ""]
        if len(done) > F.MAX_PANELS:
            lines += [f"(the first {F.MAX_PANELS} of {len(done)} conditions)", ""]
    else:
        lines += ["Distribution of Ubar: not drawn (no finite true Ubar in these runs' steps).", ""]
    curves = ctx.curves
    acc_png = F.acceptance(name, [(labels[c], curves[curves.condition_id == c]) for c in done], marks,
                           ctx.figures / f"{name}-acceptance.png", _by_noise(mine, varying))
    lines += [f"![acceptance vs step](figures/{acc_png.name})", ""]
    if mine.n_units.nunique() > 1:
        scaling = F.scaling(name, _scaling_groups(mine, varying), ctx.figures / f"{name}-scaling.png")
        lines += [f"![scaling with the number of units](figures/{scaling.name})", ""]
    if marks:
        lines += _events_figure(name, done, labels, marks, ctx)
    lines += _landscapes(name, experiment, mine, done, labels, ctx)
    lines += _positions(name, done, labels, ctx)
    steps = ctx.tables["steps"]
    tracks = {labels[c]: _first_runs(ctx.steps_of(c), TRACKS_PER_CONDITION) for c in done} if "x_m" in steps else {}
    if any(table.x_m.notna().any() for table in tracks.values()):
        path = plots.trajectory_figure(tracks, ctx.figures / f"{name}-trajectories.png",
                                       title=f"{name}: trajectories of the first {TRACKS_PER_CONDITION} runs of "
                                             "each condition")
        lines += [f"![trajectories](figures/{path.name})", ""]
    return lines


def _row(mine: pd.DataFrame, condition_id: str) -> pd.Series:
    return mine.set_index("condition_id").loc[condition_id]


def _event_marks(steps: pd.DataFrame) -> list[tuple[int, str]]:
    """The (step, text) of every event the steps recorded, in step order, each once."""
    if "event" not in steps or steps.empty:
        return []
    marked = steps[steps.event.fillna("").astype(str) != ""]
    return sorted({(int(k), str(text)) for k, text in zip(marked.step, marked.event)})


def _events_table(mine: pd.DataFrame, labels: dict, recovery: pd.DataFrame, varying: list[str]) -> list[str]:
    """Per condition and event: Ubar before, just after and at the end of its stretch, and the recovery."""
    rows = recovery[recovery.condition_id.isin(labels)] if len(recovery) else recovery
    if not len(rows):
        return []
    window = M.RECOVERY_WINDOW
    lines = [f"Events: Ubar (true, mean +- std over runs) over the {window} steps before each event, over the {window} "
             f"steps from it on, and over the last {window} steps before the next event or the end; steps from it to "
             f"regain {M.RECOVERY_FRACTION:g} of the level before (mean +- std over the runs that do; 'never' if none "
             "does) and the fraction of runs that do.", "",
             "| " + " | ".join([*(varying or ["condition"]), "event at", "event", "runs", "Ubar before", "Ubar after",
                                "Ubar at the end", f"steps to regain {M.RECOVERY_FRACTION:g} of before",
                                "recovered"]) + " |",
             "|" + "---|" * (max(len(varying), 1) + 8)]
    order = {c: i for i, c in enumerate(mine.condition_id)}
    for _, event in rows.sort_values(["condition_id", "event_index"], key=lambda c: c.map(order)
                                     if c.name == "condition_id" else c).iterrows():
        row = _row(mine, event.condition_id)
        names = [_fmt(row[c]) for c in varying] if varying else [labels[event.condition_id]]
        never = event.recovered_fraction == 0
        lines.append("| " + " | ".join([
            *names, str(int(event.event_step)), _cell(event.event), str(int(event.runs)),
            _pm(event.ubar_before, event.ubar_before_std), _pm(event.ubar_after, event.ubar_after_std),
            _pm(event.ubar_end, event.ubar_end_std),
            "never" if never else _pm(event.recovery_steps, event.recovery_steps_std, 1),
            _fmt(event.recovered_fraction, 2)]) + " |")
    return lines + [""]


def _by_noise(mine: pd.DataFrame, varying: list[str]) -> list[tuple[str, np.ndarray, np.ndarray]] | None:
    """Final acceptance against the noise, one line per combination of the other varying columns (None unless the
    noise varies)."""
    if "noise" not in varying:
        return None
    others = [c for c in varying if c != "noise"]
    groups = mine.groupby(others, sort=False, dropna=False) if others else [((), mine)]
    lines = []
    for key, rows in groups:
        key = key if isinstance(key, tuple) else (key,)
        rows = rows.sort_values("noise")
        lines.append((", ".join(_fmt(v) for v in key) or "all", rows.noise.to_numpy(dtype=float),
                      rows.acceptance_final.to_numpy(dtype=float)))
    return lines[:MAX_CURVES]


def _scaling_groups(mine: pd.DataFrame, varying: list[str]) -> list[tuple[str | None, pd.DataFrame]]:
    others = [c for c in varying if c not in ("shape", "shape_id", "n_units")]
    groups = mine.groupby(others, sort=False, dropna=False) if others else [((), mine)]
    found = []
    for key, rows in groups:
        key = key if isinstance(key, tuple) else (key,)
        found.append((", ".join(f"{c} {_fmt(v)}" for c, v in zip(others, key)) or None, rows))
    return found[:MAX_CURVES]


def _events_figure(name: str, done: list[str], labels: dict, marks: list[tuple[int, str]], ctx: _Context
                   ) -> list[str]:
    cut = any(text.startswith("cut ") or "; cut " in text for _, text in marks)
    conditions = []
    for c in done[:MAX_CURVES]:
        steps = ctx.steps_of(c)
        pieces = None
        if cut:
            units = [ctx.units_of(r) for r in steps.run_id.unique()]
            units = [u for u in units if len(u)]
            pieces = M.piece_curves(pd.concat(units)) if units else None
        conditions.append((labels[c], steps, pieces))
    path = F.events(name, conditions, marks, ctx.figures / f"{name}-events.png")
    lines = [f"![Ubar around the events](figures/{path.name})", ""]
    if cut and all(p is None or not len(p) for _, _, p in conditions):
        lines += ["Ubar per piece: not drawn (the store has no units tables for these runs).", ""]
    return lines


def _linked_scans(experiment: dict, mine: pd.DataFrame, marks: list[tuple[int, str]], plan: dict) -> list[dict]:
    """The plan's scans that go with an experiment (morphbench.bench.suite, 'Scans of an experiment')."""
    by_name = {scan["name"]: scan for scan in plan["scans"]}
    if experiment.get("scans"):
        return [by_name[n] for n in experiment["scans"] if n in by_name]
    damages = {part for _, text in marks for part in text.split("; ") if part.startswith("damage ")}
    grounds = {(row.shape_id, row.physics, row.environment_id) for _, row in mine.iterrows()
               if {"shape_id", "physics", "environment_id"} <= set(row.index)}
    return [scan for scan in plan["scans"] if scan["columns"].get("damage", "none") in {"none", *damages}
            and (scan["columns"]["shape_id"], scan["columns"]["physics"], scan["columns"].get("environment_id"))
            in grounds]


def _stretch(steps: pd.DataFrame, damage: str) -> tuple[float, float] | None:
    """The steps [first, end) of one run that a scan with ``damage`` ('none' or a damage event's text) describes:
    a healthy one up to the first event, a damaged one from the event that caused that damage to the next event;
    None if the run has no such stretch."""
    marks = _event_marks(steps)
    if damage == "none":
        return (0, marks[0][0] if marks else math.inf)
    for i, (step, text) in enumerate(marks):
        if damage in text.split("; "):
            return (step, marks[i + 1][0] if i + 1 < len(marks) else math.inf)
    return None


def _landscapes(name: str, experiment: dict, mine: pd.DataFrame, done: list[str], labels: dict, ctx: _Context
                ) -> list[str]:
    """The 3-unit scans of the experiment with one run per learner drawn on each (over the stretch it describes)."""
    steps_all = pd.concat([ctx.steps_of(c) for c in done])
    scans = [s for s in _linked_scans(experiment, mine, _event_marks(steps_all), ctx.plan)
             if s["columns"]["n_units"] == 3]
    if not scans:
        return []
    table, lines, panels = ctx.tables["scans"], [], []
    units_known = ctx.has_units("step", "phase_tried")
    for scan in scans:
        columns = scan["columns"]
        points = table[table.scan_id == scan["id"]] if len(table) else table
        if len(points) < columns["samples"]:
            lines.append(f"Landscape {scan['name']}: not drawn ({len(points)} of {columns['samples']} points measured "
                         "yet).")
            continue
        damage = columns.get("damage", "none")
        trails, spans = [], []
        mine_here = [c for c in done if _matches(_row(mine, c), columns)]
        for learner in dict.fromkeys(_row(mine, c).learner for c in mine_here):
            condition_id = next(c for c in mine_here if _row(mine, c).learner == learner)
            steps = ctx.steps_of(condition_id)
            for run_id, run_steps in steps.groupby("run_id", sort=False):
                stretch = _stretch(run_steps, damage)
                units = ctx.units_of(run_id) if units_known else pd.DataFrame()
                if stretch is None or not len(units):
                    continue
                units = units[(units.step >= stretch[0]) & (units.step < stretch[1])]
                if len(units):
                    seed = int(run_steps.seed.iloc[0])
                    trails.append((f"{labels[condition_id]}, seed {seed}", M.phase_differences(units)))
                    spans.append((int(units.step.min()), int(units.step.max())))
                break
        what = "healthy" if damage == "none" else damage
        span = f", steps {min(a for a, _ in spans)}-{max(b for _, b in spans)}" if spans else ", no run on it"
        panels.append((f"scan {scan['name']} ({what}){span}", points[["dphi_2", "dphi_3", "ubar"]], trails))
    if panels and any(trails for _, _, trails in panels):
        path = F.landscapes(name, panels, ctx.figures / f"{name}-landscapes.png")
        lines += [f"![phases tried on the landscapes](figures/{path.name})"]
    elif panels:
        lines.append(f"Landscapes {', '.join(s['name'] for s in scans)}: no run drawn (no finished run of this "
                     "experiment with unit phases recorded on their shape, physics and ground).")
    return [part for line in lines for part in (line, "")]  # each its own paragraph


def _matches(row: pd.Series, columns: dict) -> bool:
    """Whether a condition runs on a scan's shape, physics and ground."""
    return (row.get("shape_id") == columns["shape_id"] and row.get("physics") == columns["physics"]
            and row.get("environment_id") == columns.get("environment_id"))


def _positions(name: str, done: list[str], labels: dict, ctx: _Context) -> list[str]:
    """Start and end positions of a few runs: the first seeds of each condition in turn."""
    if not ctx.has_units("x_m", "step", "unit"):
        return ["Start and end positions: not drawn (the store has no unit positions: units.parquet without x_m).",
                ""]
    per_condition = {c: list(ctx.steps_of(c).drop_duplicates("run_id")[["run_id", "seed"]].itertuples(index=False))
                     for c in done}
    chosen = []
    for k in range(max(len(v) for v in per_condition.values())):
        for c in done:
            if k < len(per_condition[c]) and len(chosen) < MAX_POSITION_RUNS:
                run_id, seed = per_condition[c][k]
                table = ctx.units_of(run_id)
                if len(table) and table.x_m.notna().any():
                    chosen.append((f"{labels[c]}, seed {seed}", table))
    if not chosen:
        return ["Start and end positions: not drawn (these runs were stored without unit positions).", ""]
    path = F.positions(name, chosen, ctx.figures / f"{name}-positions.png")
    return [f"![start and end positions](figures/{path.name})", ""]


def _cell_value(row, column: str, central: set[str]) -> str:
    """A condition's value in a table; a centralized controller's learner marked as such."""
    text = _fmt(row[column])
    return f"{text} (centralized)" if column == "learner" and row.condition_id in central else text


COMPARED = ("shape", "physics", "events", "noise")
"""What a condition of the decentralization comparison is: the learners compete within each."""


def _decentralization_section(metrics: pd.DataFrame, steps: pd.DataFrame, central: set[str]) -> list[str]:
    """Per (shape, events, noise), each learner's final Ubar, steps to 0.8 of the best found and recovery, and the
    ratio of the best decentralized learner's final Ubar to the best centralized one's; nothing unless both ran."""
    done = metrics[np.isfinite(metrics.final_ubar.astype(float))] if len(metrics) else metrics
    if not len(done) or done.condition_id.isin(central).all() or not done.condition_id.isin(central).any():
        return []
    keys = [c for c in COMPARED if c in done]
    lines = ["## Decentralized against centralized", "",
             f"Per {', '.join(keys)}: final Ubar (true, mean +- std over seeds); steps to {M.THRESHOLD:g} of the best "
             "found (the highest final Ubar of any learner there): first step a run reaches it, mean +- std over "
             "the runs that do, and the fraction that do; steps to regain "
             f"{M.RECOVERY_FRACTION:g} of Ubar before the first event. Ratio: the best decentralized learner's final "
             "Ubar over the best centralized controller's ('-' unless the latter moves forward).", "",
             "| " + " | ".join([*keys, "learner", "final Ubar", f"steps to {M.THRESHOLD:g} of best", "reached",
                                f"steps to regain {M.RECOVERY_FRACTION:g}"]) + " |",
             "|" + "---|" * (len(keys) + 5)]
    ratios = []
    for key, group in done.groupby(keys, sort=False):
        best = float(group.final_ubar.max())
        for _, row in group.iterrows():
            runs = [g.sort_values("step") for _, g in steps[steps.condition_id == row.condition_id].groupby("run_id")]
            reach = np.array([M.steps_to_reach(g.step.to_numpy(), g.ubar_true.to_numpy(), M.THRESHOLD * best)
                              for g in runs]) if best > 0 else np.array([])
            reached = reach[np.isfinite(reach)]
            if not np.isfinite(row.recovery_step):
                recovery = "-"
            elif row.recovered_fraction == 0:
                recovery = "never"
            else:
                recovery = _pm(row.recovery_steps, row.recovery_steps_std, 1)
            reached_fraction = _fmt(len(reached) / len(reach), 2) if len(reach) else "-"
            cells = [*(_fmt(v) for v in key), _cell_value(row, "learner", central),
                     _pm(row.final_ubar, row.final_ubar_std), _pm(*_mean_std(reached), 1), reached_fraction, recovery]
            lines.append("| " + " | ".join(cells) + " |")
        is_central = group.condition_id.isin(central)
        ratios.append((key, _best(group[~is_central]), _best(group[is_central])))
    lines += ["", "| " + " | ".join([*keys, "best decentralized", "best centralized", "ratio"]) + " |",
              "|" + "---|" * (len(keys) + 3)]
    for key, (decentral, d_name), (centralized, c_name) in ratios:
        ratio = decentral / centralized if centralized > 0 else math.nan
        lines.append("| " + " | ".join([*(_fmt(v) for v in key), f"{_fmt(decentral)} ({d_name})",
                                        f"{_fmt(centralized)} ({c_name})", _fmt(ratio, 2)]) + " |")
    return lines + [""]


def _best(rows: pd.DataFrame) -> tuple[float, str]:
    """The highest final Ubar of ``rows`` and its learner (NaN and '-' without rows)."""
    if not len(rows):
        return math.nan, "-"
    best = rows.loc[rows.final_ubar.astype(float).idxmax()]
    return float(best.final_ubar), str(best.learner)


def _mean_std(values: np.ndarray) -> tuple[float, float]:
    return (float(np.mean(values)) if len(values) else math.nan,
            float(np.std(values, ddof=1)) if len(values) > 1 else math.nan)


def _scan_section(plan: dict, scans: pd.DataFrame, figures: Path) -> list[str]:
    damaged = any(scan["columns"].get("damage", "none") != "none" for scan in plan["scans"])
    lines = ["| scan | shape | " + ("damage | " if damaged else "") + "points | max Ubar | at | min Ubar | at |",
             "|---|---|" + ("---|" if damaged else "") + "---|---|---|---|---|"]
    pictures = []
    for scan in plan["scans"]:
        points = scans[scans.scan_id == scan["id"]] if len(scans) else scans
        columns = scan["columns"]
        damage = columns.get("damage", "none")
        first = f"| {scan['name']} | {columns['shape']} | " + (f"{damage} | " if damaged else "")
        dphi = [f"dphi_{i}" for i in range(2, columns["n_units"] + 1)]
        if points.empty:
            lines.append(f"{first}0 of {columns['samples']} | | | | |")
            continue
        points = points[[*dphi, "ubar"]].reset_index(drop=True)
        best, worst = points.loc[points.ubar.idxmax()], points.loc[points.ubar.idxmin()]
        where = lambda row: ", ".join(f"{c} {row[c]:.2f}" for c in dphi)  # noqa: E731
        lines.append(f"{first}{len(points)} of {columns['samples']} | "
                     f"{best.ubar:+.2f} | {where(best)} | {worst.ubar:+.2f} | {where(worst)} |")
        if len(points) == columns["samples"]:
            what = "" if damage == "none" else f", {damage}"
            path = plots.scan_figure(points, figures / f"scan-{scan['name']}.png",
                                     title=f"{columns['shape']}{what}: Ubar at fixed phases ({scan['name']})")
            pictures.append(f"![scan {scan['name']}](figures/{path.name})")
    return lines + [""] + [p + "\n" for p in pictures]


def _duration(seconds: float) -> str:
    """A compute time as a reader reads it: seconds under two minutes (a smoke suite's 0.0 min), else minutes."""
    return f"{seconds:.1f} s" if seconds < 120 else f"{seconds / 60:.1f} min"


def claims_of(out: str | Path) -> list[C.Verdict]:
    """The paper's claims measured on the results directory ``out``, as its report measures them (the claims of its
    suite and the suites it includes: ``claims.claims_for``)."""
    store = Store(out)
    plan = store.require_plan()
    tables = store.consolidate(plan)
    steps = tables["steps"]
    return C.check({**tables, "metrics": M.condition_metrics(steps, tables["runs"], tables["scans"]),
                    "curves": M.curves(steps)}, C.claims_for(plan.get("suite"), _includes(plan)))


def _includes(plan: dict) -> tuple[str, ...]:
    """The names of the suites the plan's suite includes (none in a plan without ``includes``; store.check_plan
    checked them)."""
    return tuple(plan.get("includes", ()))


def _claims_section(tables: dict[str, pd.DataFrame], suite: str | None = None,
                    includes: tuple[str, ...] = ()) -> list[str]:
    """The paper's quantitative statements against what the tables measure (morphbench.bench.claims): those of
    suite ``suite`` and of the suites it includes (``claims.claims_for``: the hardware twin's, or the paper's, or
    the paper's and the hardware twin's)."""
    claims = C.claims_for(suite, includes)
    own = C.claims_for(suite)
    which = ("The paper's experimental findings, on the hardware twin (docs/hardware.md lists each with its figure "
             "and the effects it needs)" if own is not C.CLAIMS else
             "The paper's findings (Oliveri et al., PNAS 2021; docs/paper.md lists each with its figure)")
    for name in dict.fromkeys(includes):  # the included suites whose claims join
        if C.SUITE_CLAIMS.get(name, own) is own:
            continue
        if name == C.HARDWARE_SUITE:
            which += (f" and its experimental findings on the hardware twin (ids starting hw-, measured on the "
                      f"included suite {name}'s experiments; docs/hardware.md lists each with its figure and the "
                      "effects it needs)")
        else:
            which += f" and the claims of the included suite {name} (measured on its experiments)"
    lines = ["## Claims", "",
             f"{which}, each measured on this suite's tables: 'holds' applies the rule to the measured value; 'not "
             "measured' says what the suite lacks.", ""]
    verdicts = C.check(tables, claims)
    held = sum(v.holds is True for v in verdicts)
    unmeasured = sum(v.holds is None for v in verdicts)
    small = sum(v.holds is None and v.reason.startswith(C.TOO_SMALL) for v in verdicts)
    small = f"; {small} of them because this suite's runs are too short for them" if small else ""
    lines += [f"{held} of {len(verdicts)} claims hold ({len(verdicts) - held - unmeasured} do not, {unmeasured} not "
              f"measured{small}).", "",
              "| claim | scenario | statement | paper | measured | measured on | holds if | holds |",
              "|---|---|---|---|---|---|---|---|"]
    for verdict in verdicts:
        claim, measured = verdict.claim, verdict.measured
        unit = f" {claim.unit}" if claim.unit else ""
        if measured is None:
            value, on, holds = "-", _cell(verdict.reason), "not measured"
        else:
            value = "never" if measured.value == math.inf else _fmt(float(measured.value))
            value += unit if value not in ("-", "never") else ""
            on, holds = _cell(measured.on), "yes" if verdict.holds else "no"
        scenario = f"{claim.scenario}, {claim.source}" if claim.source else claim.scenario
        lines.append(f"| {claim.id} | {_cell(scenario)} | {_cell(claim.statement)} | {_fmt(claim.paper)}{unit} | "
                     f"{value} | {on} | {claim.rule_text()} | {holds} |")
    return lines + [""]


def _display_columns(varying) -> list[str]:
    """The condition columns that tell an experiment's conditions apart, without redundant ones (a shape's id and
    number of units vary with it)."""
    columns = [c for c in varying if c not in ("shape_id", "environment_id")]
    if "shape" in columns and "n_units" in columns:
        columns.remove("n_units")
    if "shape" not in columns and "shape_id" in varying:
        columns.insert(0, "shape")
    return columns


def _label(row, varying: list[str]) -> str:
    parts = [_fmt(row[c]) if c in ("shape", "learner") else f"{c} {_fmt(row[c])}" for c in varying]
    return ", ".join(parts) or str(row["shape"])


def _fmt(value, digits: int = 3) -> str:
    if isinstance(value, (float, np.floating)):
        if not np.isfinite(value):
            return "-"
        return f"{value:.{digits}g}" if digits >= 3 else f"{value:.{digits}f}"
    return str(value)


def _pm(mean: float, std: float, digits: int = 2) -> str:
    if not np.isfinite(mean):
        return "-"
    return f"{mean:.{digits}f} +- {std:.{digits}f}" if np.isfinite(std) else f"{mean:.{digits}f}"


def _cell(text) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")
