"""Figures and report.md of a results directory, rebuilt from the store alone (no simulation).

``build_report(DIR)`` consolidates the tables from the job directories (so it also works on the results of an
interrupted bench, reporting the missing runs), computes ``curves.parquet`` and ``metrics.parquet``
(morphbench.bench.metrics) and writes, per experiment, into ``DIR/figures/``:
- ``<experiment>-ubar.png``: Ubar (true) vs learning step, median with 25-75% and 10-90% bands over seeds, the
  exponential fit dashed and the scan's best Ubar dotted, one panel per condition;
- ``<experiment>-acceptance.png``: mean acceptance vs learning step (10-step running mean), one line per condition;
- ``<experiment>-scaling.png`` when the experiment spans several numbers of units: U_eq and steps to 0.8 U_eq vs N;
- ``<experiment>-trajectories.png``: every run's centroid track on the ground, one colour per condition (when the
  runs recorded one: runs stored before steps.parquet had ``x_m`` are left out);
and ``scan-<name>.png`` per scan (a curve for 2 units, a heat map for 3, a histogram beyond). ``DIR/report.md``
holds the tables of metrics (a centralized controller's rows marked), the figures, a comparison of decentralized
learners with centralized controllers when the suite has both, and the failed runs with their errors.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from morphbench import plots  # noqa: E402
from morphbench.bench import metrics as M  # noqa: E402
from morphbench.bench.html import write_html  # noqa: E402
from morphbench.bench.store import Store  # noqa: E402
from morphbench.files import write_text  # noqa: E402

MAX_PANELS = 24


def build_report(out: str | Path, tables: dict[str, pd.DataFrame] | None = None, videos: bool = False) -> Path:
    """Write curves.parquet, metrics.parquet, figures/ and report.md into ``out``; returns the report's path."""
    store = Store(out)
    plan = store.require_plan()
    tables = tables or store.consolidate(plan)
    runs, steps, scans = tables["runs"], tables["steps"], tables["scans"]
    curves = M.curves(steps)
    metrics = M.condition_metrics(steps, runs, scans)
    store.write_table("curves", curves)
    store.write_table("metrics", metrics)
    figures = store.root / "figures"
    figures.mkdir(exist_ok=True)
    for old in figures.glob("*.png"):
        old.unlink()

    lines = [f"# Suite {plan['suite']}", ""]
    if plan.get("description"):
        lines += [plan["description"], ""]
    n_done, n_failed = int((runs.status == "done").sum()), int((runs.status == "failed").sum())
    n_missing = int((runs.status == "missing").sum())
    wall = tables["jobs"].wall_time_s.sum()
    lines += [f"{len(runs)} runs: {n_done} done, {n_failed} failed, {n_missing} not run yet; {len(plan['scans'])} "
              f"scans. Compute time {wall / 60:.1f} min (sum over jobs). Report written "
              f"{time.strftime('%Y-%m-%d %H:%M')} from `{store.root}`.", "",
              "Ubar is the true mean velocity of the active units (mm/cycle), whatever the learners measured. "
              "Final Ubar: mean over the last 10% of steps, mean +- std over seeds. U_eq, U_0, k_0: fit of "
              "U(k) = U_eq - (U_eq - U_0) exp(-k/k_0) to the seed-averaged curve ('no plateau' when k_0 exceeds a "
              f"third of the run: U_eq would be an extrapolation). Steps to {M.THRESHOLD:g} U_eq: first step a run "
              "reaches it, mean +- std over the runs that do, and the fraction that do. 'of scan best': final Ubar "
              "over the best Ubar of the suite's scans of the same shape and ground. With events: the step of the "
              f"first one, and the steps runs take from it to regain {M.RECOVERY_FRACTION:g} of their mean Ubar over "
              f"the {M.RECOVERY_WINDOW} steps before it (mean +- std over the runs that do, 'never' if none does), "
              "and the fraction that do. U along heading: the assembly centroid's velocity along its heading "
              "(mm/cycle, over the same last steps as final Ubar; pump cycles between steps include the discarded "
              "ones); turning rate: slope of its heading over time (deg/cycle, positive counter-clockwise seen from "
              "above); both mean +- std over seeds.", ""]
    if n_missing:
        lines += [f"**{n_missing} runs have no results yet**: the bench was interrupted; run it again with the same "
                  "--out to finish.", ""]

    central = set(runs.condition_id[runs.centralized == 1]) if "centralized" in runs else set()
    for experiment in plan["experiments"]:
        lines += _experiment_section(experiment, metrics, curves, steps, figures, central)
    lines += _decentralization_section(metrics, steps, central)
    if plan["scans"]:
        lines += ["## Scans", ""]
        lines += _scan_section(plan, scans, figures)
    failed = runs[runs.status == "failed"]
    failed_scans = tables["jobs"][(tables["jobs"].kind == "scan") & (tables["jobs"].status == "failed")]
    if len(failed) or len(failed_scans):
        lines += ["## Failed jobs", "", "| job | condition | seed | error |", "|---|---|---|---|"]
        for _, row in failed.iterrows():
            lines.append(f"| run {row.run_id} | {row['shape']} {row.learner} | {row.seed} | {_cell(row.error)} |")
        for _, row in failed_scans.iterrows():
            lines.append(f"| scan part {row.job_id} | | | {_cell(row.error)} |")
        lines.append("")
    path = store.root / "report.md"
    write_text(path, "\n".join(lines) + "\n")
    write_html(store.root, videos=videos)  # report.html: this report as one page, with a video per experiment
    return path


def _experiment_section(experiment: dict, metrics: pd.DataFrame, curves: pd.DataFrame, steps: pd.DataFrame,
                        figures: Path, central: set[str]) -> list[str]:
    name = experiment["name"]
    lines = [f"## {name}", ""]
    if experiment.get("description"):
        lines += [experiment["description"], ""]
    mine = metrics.set_index("condition_id").reindex(experiment["condition_ids"]).reset_index()
    varying = _display_columns(experiment["varying"])
    fixed = [c for c in ("shape", "learner", "step_size", "temperature", "noise", "environment", "events", "steps")
             if c not in varying]
    if len(mine):
        first = mine.iloc[0]
        lines += ["Fixed: " + ", ".join(f"{c} = {_cell_value(first, c, central)}" for c in fixed if c in mine) + ".",
                  ""]
    with_events = "recovery_step" in mine and bool(np.isfinite(mine.recovery_step.astype(float)).any())
    header = [*varying, "runs", "final Ubar", "U_eq", "U_0", "k_0", f"steps to {M.THRESHOLD:g} U_eq", "reached",
              "acceptance (end)", "of scan best", "U along heading", "turning rate (deg/cycle)"]
    if with_events:
        header += ["event at", f"steps to regain {M.RECOVERY_FRACTION:g} of before", "recovered"]
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
        if with_events:
            never = row.recovered_fraction == 0
            cells += [str(int(row.recovery_step)) if np.isfinite(row.recovery_step) else "-",
                      "never" if never else _pm(row.recovery_steps, row.recovery_steps_std, 1),
                      _fmt(row.recovered_fraction, 2)]
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    labels = {row.condition_id: _label(row, varying) for _, row in mine.iterrows()}
    if curves[curves.condition_id.isin(labels)].empty:
        return lines + ["No finished runs yet.", ""]
    ubar_png = _ubar_figure(name, mine, curves, labels, figures / f"{name}-ubar.png")
    acc_png = _acceptance_figure(name, mine, curves, labels, figures / f"{name}-acceptance.png")
    lines += [f"![Ubar vs step](figures/{ubar_png.name})", "", f"![acceptance vs step](figures/{acc_png.name})", ""]
    if mine.n_units.nunique() > 1:
        scaling = _scaling_figure(name, mine, varying, figures / f"{name}-scaling.png")
        lines += [f"![scaling with the number of units](figures/{scaling.name})", ""]
    tracks = {labels[c]: steps[steps.condition_id == c] for c in labels} if "x_m" in steps else {}
    if any(table.x_m.notna().any() for table in tracks.values()):
        path = plots.trajectory_figure(tracks, figures / f"{name}-trajectories.png",
                                       title=f"{name}: trajectories of the runs")
        lines += [f"![trajectories](figures/{path.name})", ""]
    return lines


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
    lines = ["| scan | shape | points | max Ubar | at | min Ubar | at |", "|---|---|---|---|---|---|---|"]
    pictures = []
    for scan in plan["scans"]:
        points = scans[scans.scan_id == scan["id"]] if len(scans) else scans
        columns = scan["columns"]
        dphi = [f"dphi_{i}" for i in range(2, columns["n_units"] + 1)]
        if points.empty:
            lines.append(f"| {scan['name']} | {columns['shape']} | 0 of {columns['samples']} | | | | |")
            continue
        points = points[[*dphi, "ubar"]].reset_index(drop=True)
        best, worst = points.loc[points.ubar.idxmax()], points.loc[points.ubar.idxmin()]
        where = lambda row: ", ".join(f"{c} {row[c]:.2f}" for c in dphi)  # noqa: E731
        lines.append(f"| {scan['name']} | {columns['shape']} | {len(points)} of {columns['samples']} | "
                     f"{best.ubar:+.2f} | {where(best)} | {worst.ubar:+.2f} | {where(worst)} |")
        if len(points) == columns["samples"]:
            path = plots.scan_figure(points, figures / f"scan-{scan['name']}.png",
                                     title=f"{columns['shape']}: Ubar at fixed phases ({scan['name']})")
            pictures.append(f"![scan {scan['name']}](figures/{path.name})")
    return lines + [""] + [p + "\n" for p in pictures]


def _ubar_figure(name, mine, curves, labels, path: Path) -> Path:
    ids = [c for c in mine.condition_id if c in set(curves.condition_id)][:MAX_PANELS]
    n_cols = min(3, len(ids))
    n_rows = math.ceil(len(ids) / n_cols)
    fig, axes = plt.subplots(n_rows, n_cols, figsize=(4.2 * n_cols, 3.0 * n_rows), sharey=True, squeeze=False)
    by_id = mine.set_index("condition_id")
    for ax, condition_id in zip(axes.flat, ids):
        c = curves[curves.condition_id == condition_id]
        ax.fill_between(c.step, c.q10, c.q90, alpha=0.2, color="C0", lw=0, label="10-90%")
        ax.fill_between(c.step, c.q25, c.q75, alpha=0.35, color="C0", lw=0, label="25-75%")
        ax.plot(c.step, c.q50, color="C0", lw=1.2, label="median")
        row = by_id.loc[condition_id]
        if np.isfinite(row.u_eq) and np.isfinite(row.k_0) and row.plateau:
            k = c.step.to_numpy(dtype=float)
            ax.plot(k, row.u_eq - (row.u_eq - row.u_0) * np.exp(-k / row.k_0), "k--", lw=0.8, label="fit")
        if np.isfinite(row.scan_best_ubar):
            ax.axhline(row.scan_best_ubar, color="C3", ls=":", lw=1, label="scan best")
        if np.isfinite(row.get("recovery_step", math.nan)):
            ax.axvline(row.recovery_step, color="C2", ls="-.", lw=1, label="event")
        ax.axhline(0, color="k", lw=0.4)
        ax.set_title(f"{labels[condition_id]} ({int(c.runs.max())} runs)", fontsize="small")
        ax.set_xlabel("learning step")
    for ax in axes[:, 0]:
        ax.set_ylabel("Ubar (mm/cycle)")
    for ax in list(axes.flat)[len(ids):]:
        ax.set_visible(False)
    axes.flat[0].legend(fontsize="x-small", loc="lower right")
    fig.suptitle(f"{name}: Ubar over seeds")
    return plots.save_figure(fig, path, dpi=100)


def _acceptance_figure(name, mine, curves, labels, path: Path) -> Path:
    fig, ax = plt.subplots(figsize=(7, 4))
    for i, condition_id in enumerate(mine.condition_id):
        c = curves[(curves.condition_id == condition_id) & (curves.step > 0)]
        if len(c):
            ax.plot(c.step, c.acceptance.rolling(10, min_periods=1).mean(), lw=1, color=f"C{i % 10}",
                    label=labels[condition_id])
    ax.set_ylim(-0.02, 1.02)
    ax.set_xlabel("learning step")
    ax.set_ylabel("acceptance (10-step mean)")
    if len(mine) <= 12:
        ax.legend(fontsize="x-small")
    ax.set_title(f"{name}: acceptance over seeds and units")
    return plots.save_figure(fig, path, dpi=100)


def _scaling_figure(name, mine, varying, path: Path) -> Path:
    others = [c for c in varying if c not in ("shape", "shape_id", "n_units")]
    fig, (ax_u, ax_k) = plt.subplots(1, 2, figsize=(10, 4))
    groups = mine.groupby(others, sort=False) if others else [((), mine)]
    for i, (key, rows) in enumerate(groups):
        rows = rows.sort_values("n_units")
        key = key if isinstance(key, tuple) else (key,)
        label = ", ".join(f"{c} {_fmt(v)}" for c, v in zip(others, key)) or None
        ax_u.plot(rows.n_units, rows.u_eq.where(rows.plateau.astype(bool)), "o-", color=f"C{i % 10}", label=label)
        ax_k.errorbar(rows.n_units, rows.steps_to_threshold, yerr=rows.steps_to_threshold_std.fillna(0), fmt="o-",
                      color=f"C{i % 10}", capsize=3, label=label)
    ax_u.set_xlabel("active units N")
    ax_u.set_ylabel("U_eq (mm/cycle)")
    ax_k.set_xlabel("active units N")
    ax_k.set_ylabel(f"steps to {M.THRESHOLD:g} U_eq")
    if others:
        ax_u.legend(fontsize="x-small")
    fig.suptitle(f"{name}: scaling with the number of units")
    return plots.save_figure(fig, path, dpi=100)


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
