"""The figures of a suite's report, one function per kind, each drawn from tables it is handed (matplotlib, Agg).

morphbench.bench.report chooses what each figure shows (conditions, runs, scans, stretches of steps) and writes why
one is left out; these functions draw, each into one PNG through ``plots.save_figure``:

- ``ubar_distribution``: per condition, the distribution of per-run Ubar over the seeds at each learning step as a
  2-D histogram (colour: the fraction of the runs), with the mean over seeds, the exponential fit, the best of the
  healthy scan and the events drawn on top (the paper's Fig. 1F, 2A, 2G, 4B);
- ``acceptance``: mean acceptance (over units and runs, 10-step running mean) against the step, one line per
  condition, events marked (2B, 2H); beside it, when the noise varies, the final acceptance against the noise;
- ``scaling``: U_eq, steps to 0.8 U_eq and the fraction of runs that reach it against the number of units (4C, 4D);
- ``landscapes``: 3-unit scans with the phase differences that runs tried drawn on them as trails (3C-F);
- ``positions``: every unit's position along the track at the first and the last step, one row per run (4A);
- ``events``: mean Ubar of each condition against the step with its events marked, and each piece's after a cut;

and one of the leaderboard (morphbench.bench.leaderboard, benchmarks/leaderboard.py):

- ``leaderboard_scale``: each learner's task score against the number of units, one panel per kind of shape.
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib import ticker  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from morphbench import plots  # noqa: E402
from morphbench.bench import metrics as M  # noqa: E402

MAX_PANELS = 24
"""conditions drawn at most in a figure of one panel per condition."""
N_BINS = 40
"""Ubar bins of the distribution figure."""
TRAIL_COLOURS = ("k", "#1b9e3a", "#7b3294", "#e66101")
"""one per run drawn on a landscape: visible on its red-white-blue map."""
DPI = 100
LOG_N_FROM = 20
"""the largest number of units over the smallest beyond which the scaling figure draws N on a log scale."""


def _grid(n: int, width: float = 4.2, height: float = 3.0):
    """A figure of ``n`` panels, three a row, sharing Ubar's axis, laid out to leave room for a shared colour bar."""
    n_cols = min(3, n)
    n_rows = math.ceil(n / n_cols)
    fig, axes = plt.subplots(n_rows, n_cols, figsize=(width * n_cols + 1, height * n_rows), sharey=True,
                             squeeze=False, layout="constrained")
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    return fig, axes


def _mark_events(ax, events: list[tuple[int, str]], label: bool = True) -> None:
    """A vertical line at each event's step (labelled once)."""
    for i, (step, _) in enumerate(events):
        ax.axvline(step, color="C2", ls="-.", lw=1, label="event" if label and i == 0 else None)


def ubar_distribution(name: str, conditions: list[tuple[str, pd.DataFrame, pd.Series, list[tuple[int, str]]]],
                      path: Path, column: str = "ubar_true", n_bins: int = N_BINS) -> Path:
    """One panel per condition ``(label, its steps table, its metrics row, its events)``: the fraction of its runs in
    each Ubar bin at each step (bins shared by the panels, so they compare), the mean over seeds, the fit (when it has
    a plateau), the scan's best and the events."""
    conditions = conditions[:MAX_PANELS]
    values = np.concatenate([table[column].to_numpy(dtype=float) for _, table, _, _ in conditions])
    values = values[np.isfinite(values)]
    lo, hi = float(values.min()), float(values.max())
    pad = 0.05 * (hi - lo) or 0.5
    edges = np.linspace(lo - pad, hi + pad, n_bins + 1)
    histograms = [M.ubar_distribution(table, edges, column) for _, table, _, _ in conditions]
    top = max(float(f.max()) for _, f in histograms if f.size) or 1.0
    fig, axes = _grid(len(conditions))
    mesh = None
    for ax, (label, table, row, events), (k, fraction) in zip(axes.flat, conditions, histograms):
        if not len(k):
            continue
        x = np.concatenate([[k[0] - 0.5], (k[1:] + k[:-1]) / 2, [k[-1] + 0.5]])
        mesh = ax.pcolormesh(x, edges, fraction, cmap="Blues", vmin=0, vmax=top, shading="flat", rasterized=True)
        mean = table.groupby("step")[column].mean()
        ax.plot(mean.index, mean.to_numpy(), color="C3", lw=1.2, label="mean over seeds")
        if row is not None and np.isfinite(row.get("u_eq", np.nan)) and bool(row.get("plateau", False)):
            kk = k.astype(float)
            ax.plot(kk, row.u_eq - (row.u_eq - row.u_0) * np.exp(-kk / row.k_0), "k--", lw=0.8, label="fit")
        if row is not None and np.isfinite(row.get("scan_best_ubar", np.nan)):
            ax.axhline(row.scan_best_ubar, color="C1", ls=":", lw=1.2, label="scan best")
        _mark_events(ax, events)
        ax.axhline(0, color="k", lw=0.4)
        ax.set_title(f"{label} ({table.run_id.nunique()} runs)", fontsize="small")
        ax.set_xlabel("learning step")
    for ax in axes[:, 0]:
        ax.set_ylabel("Ubar (mm/cycle)")
    axes.flat[0].legend(fontsize="x-small", loc="lower right")
    if mesh is not None:
        fig.colorbar(mesh, ax=list(axes.flat), label="fraction of runs", shrink=0.8)
    fig.suptitle(f"{name}: distribution of Ubar over seeds")
    return plots.save_figure(fig, path, dpi=DPI)


def acceptance(name: str, conditions: list[tuple[str, pd.DataFrame]], events: list[tuple[int, str]], path: Path,
               by_noise: list[tuple[str, np.ndarray, np.ndarray]] | None = None) -> Path:
    """Mean acceptance against the step (``(label, curve)`` per condition: curves.parquet rows, its ``acceptance``
    smoothed by a 10-step running mean); with ``by_noise`` (``(label, noise, final acceptance)`` per group of
    conditions), a second panel of the final acceptance against the measurement noise."""
    fig, axes = plt.subplots(1, 2 if by_noise else 1, figsize=(12 if by_noise else 7, 4), squeeze=False)
    ax = axes[0, 0]
    for i, (label, curve) in enumerate(conditions):
        curve = curve[curve.step > 0]
        if len(curve):
            ax.plot(curve.step, curve.acceptance.rolling(10, min_periods=1).mean(), lw=1, color=f"C{i % 10}",
                    label=label)
    _mark_events(ax, events, label=False)
    ax.set_ylim(-0.02, 1.02)
    ax.set_xlabel("learning step")
    ax.set_ylabel("acceptance (10-step mean)")
    if len(conditions) <= 12:
        ax.legend(fontsize="x-small")
    ax.set_title("over seeds and units" + (" (dash-dot: events)" if events else ""), fontsize="small")
    if by_noise:
        ax = axes[0, 1]
        for i, (label, noise, final) in enumerate(by_noise):
            ax.plot(noise, final, "o-", color=f"C{i % 10}", label=label)
        ax.set_ylim(-0.02, 1.02)
        ax.set_xlabel("measurement noise (mm/cycle)")
        ax.set_ylabel("acceptance (last 10% of steps)")
        ax.legend(fontsize="x-small")
        ax.set_title("against the noise", fontsize="small")
    fig.suptitle(f"{name}: acceptance")
    return plots.save_figure(fig, path, dpi=DPI)


def scaling(name: str, groups: list[tuple[str | None, pd.DataFrame]], path: Path) -> Path:
    """Per group ``(label, metrics rows)`` (e.g. one step size), against the number of units: U_eq with the std of the
    runs' final Ubar over seeds as error bars (where the fit found no plateau, U_eq would be an extrapolation: the
    final Ubar is drawn instead, hollow); steps to 0.8 U_eq (mean +- std over the runs that reach it); the fraction
    of runs that reach it. N is drawn on a log scale when it spans more than LOG_N_FROM (sheets of 4 to 256 units
    beside chains)."""
    fig, (ax_u, ax_k, ax_f) = plt.subplots(1, 3, figsize=(14, 4))
    sizes = pd.concat([rows.n_units for _, rows in groups]).to_numpy(dtype=float) if groups else np.ones(1)
    for i, (label, rows) in enumerate(groups):
        rows = rows.sort_values("n_units")
        colour = f"C{i % 10}"
        n = rows.n_units.to_numpy(dtype=float)
        plateau = rows.plateau.astype(bool).to_numpy()
        u_eq = np.where(plateau, rows.u_eq.to_numpy(dtype=float), rows.final_ubar.to_numpy(dtype=float))
        spread = rows.final_ubar_std.to_numpy(dtype=float)
        ax_u.errorbar(n, u_eq, yerr=np.nan_to_num(spread), fmt="-", color=colour, capsize=3, label=label)
        ax_u.plot(n[plateau], u_eq[plateau], "o", color=colour)
        ax_u.plot(n[~plateau], u_eq[~plateau], "o", mfc="white", color=colour)
        ax_k.errorbar(n, rows.steps_to_threshold.to_numpy(dtype=float),
                      yerr=np.nan_to_num(rows.steps_to_threshold_std.to_numpy(dtype=float)), fmt="o-", color=colour,
                      capsize=3, label=label)
        ax_f.plot(n, rows.reached_fraction.to_numpy(dtype=float), "o-", color=colour, label=label)
    ax_u.set_ylabel("U_eq (mm/cycle)")
    ax_u.set_title("error bars: std of final Ubar over seeds;\nhollow: no plateau, final Ubar instead",
                   fontsize="small")
    ax_k.set_ylabel(f"steps to {M.THRESHOLD:g} U_eq")
    ax_k.set_title("mean +- std over the runs that reach it", fontsize="small")
    ax_f.set_ylabel(f"fraction of runs reaching {M.THRESHOLD:g} U_eq")
    ax_f.set_ylim(-0.02, 1.02)
    for ax in (ax_u, ax_k, ax_f):
        ax.set_xlabel("active units N")
        if sizes.max() > LOG_N_FROM * sizes.min():
            ax.set_xscale("log")
            # plain numbers at the decades only: over less than two decades the default labels every minor tick
            ax.xaxis.set_major_formatter(ticker.ScalarFormatter())
            ax.xaxis.set_minor_formatter(ticker.NullFormatter())
    if any(label for label, _ in groups):
        ax_u.legend(fontsize="x-small")
    fig.suptitle(f"{name}: scaling with the number of units")
    return plots.save_figure(fig, path, dpi=DPI)


def landscapes(name: str, panels: list[tuple[str, pd.DataFrame, list[tuple[str, pd.DataFrame]]]], path: Path) -> Path:
    """One panel per 3-unit scan ``(title, its points, trails)``, all in one colour scale; each trail ``(label,
    table of step, dphi_2, dphi_3)`` (metrics.phase_differences of the stretch of a run the scan describes) drawn as
    its tried points joined in step order (a jump across the map's edge is not joined), a circle at its first step
    and a star at its last."""
    limit = max(float(np.nanmax(np.abs(points.ubar.to_numpy(dtype=float)))) for _, points, _ in panels) or 1.0
    fig, axes = plt.subplots(1, len(panels), figsize=(5.2 * len(panels) + 1, 5.2), squeeze=False, layout="constrained")
    mesh = None
    for ax, (title, points, trails) in zip(axes.flat, panels):
        mesh = plots.landscape(ax, points, limit)
        for i, (label, trail) in enumerate(trails):
            colour = TRAIL_COLOURS[i % len(TRAIL_COLOURS)]
            x, y = trail.dphi_2.to_numpy(dtype=float), trail.dphi_3.to_numpy(dtype=float)
            jump = np.flatnonzero((np.abs(np.diff(x)) > 0.5) | (np.abs(np.diff(y)) > 0.5)) + 1
            ax.plot(np.insert(x, jump, np.nan), np.insert(y, jump, np.nan), "-", color=colour, lw=0.6, alpha=0.7)
            ax.plot(x, y, ".", color=colour, ms=3, label=label)
            ax.plot(x[:1], y[:1], "o", mfc="none", mec=colour, ms=8)
            ax.plot(x[-1:], y[-1:], "*", color=colour, ms=11, mec="white", mew=0.5)
        if trails:
            ax.legend(fontsize="x-small", loc="upper right", framealpha=0.8)
        ax.set_title(title, fontsize="small")
    fig.colorbar(mesh, ax=list(axes.flat), label="Ubar at fixed phases (mm/cycle)", shrink=0.85)
    fig.suptitle(f"{name}: phase differences tried (circle: first step, star: last)")
    return plots.save_figure(fig, path, dpi=DPI)


def positions(name: str, runs: list[tuple[str, pd.DataFrame]], path: Path) -> Path:
    """One row per run ``(label, its units table)``: each unit's x on the track (mm) at the run's first step (hollow)
    and last step (filled), in the unit's colour, an arrow from the first centroid to the last."""
    fig, ax = plt.subplots(figsize=(9, 0.8 + 0.55 * len(runs)))
    n_units = 0
    for row, (label, units) in enumerate(runs):
        first, last = units.step.min(), units.step.max()
        for step, filled in ((first, False), (last, True)):
            at = units[units.step == step].sort_values("unit")
            x = at.x_m.to_numpy(dtype=float) * 1000.0
            colours = [f"C{(u - 1) % 10}" for u in at.unit]
            ax.scatter(x, np.full(len(x), row), s=36, marker="s", c=colours if filled else "none",
                       edgecolors=colours, linewidths=1.2, zorder=3)
            n_units = max(n_units, len(at))
        start = units[units.step == first].x_m.mean() * 1000.0
        end = units[units.step == last].x_m.mean() * 1000.0
        ax.annotate("", xy=(end, row), xytext=(start, row), arrowprops={"arrowstyle": "->", "color": "0.6", "lw": 0.8},
                    zorder=1)
    ax.set_yticks(range(len(runs)), [label for label, _ in runs], fontsize="x-small")
    ax.set_ylim(len(runs) - 0.5, -0.5)
    ax.set_xlabel("x along the track (mm)")
    for u in range(1, min(n_units, 10) + 1):
        ax.scatter([], [], s=36, marker="s", color=f"C{u - 1}", label=f"unit {u}")
    ax.legend(fontsize="x-small", loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    ax.set_title(f"{name}: units at the first step (hollow) and the last (filled); arrow: the centroid's way",
                 fontsize="small")
    return plots.save_figure(fig, path, dpi=DPI)


def events(name: str, conditions: list[tuple[str, pd.DataFrame, pd.DataFrame | None]],
           marks: list[tuple[int, str]], path: Path, column: str = "ubar_true") -> Path:
    """Per condition ``(label, its steps table, its per-piece curves or None)``: mean Ubar over runs +- std against
    the step with the events ``marks`` drawn and named; with pieces (metrics.piece_curves of a cut), a second panel
    of each piece's mean Ubar."""
    with_pieces = any(pieces is not None and len(pieces) and pieces.piece.nunique() > 1
                      for _, _, pieces in conditions)
    fig, axes = plt.subplots(1, 2 if with_pieces else 1, figsize=(13 if with_pieces else 7.5, 4.2), squeeze=False,
                             sharey=True)
    ax = axes[0, 0]
    for i, (label, table, _) in enumerate(conditions):
        grouped = table.groupby("step")[column]
        mean, std = grouped.mean(), grouped.std().fillna(0.0)
        ax.fill_between(mean.index, mean - std, mean + std, color=f"C{i % 10}", alpha=0.2, lw=0)
        ax.plot(mean.index, mean.to_numpy(), color=f"C{i % 10}", lw=1.1, label=label)
    ax.set_title("whole assembly: mean +- std over runs", fontsize="small")
    if with_pieces:
        for i, (label, _, pieces) in enumerate(conditions):
            if pieces is None or not len(pieces):
                continue
            for j, (piece, rows) in enumerate(pieces.groupby("piece")):
                mean = rows.groupby("step").ubar.mean()
                axes[0, 1].plot(mean.index, mean.to_numpy(), color=f"C{i % 10}", ls=("-", "--", ":", "-.")[j % 4],
                                lw=1, label=f"{label}, piece {piece}")
        axes[0, 1].set_title("each piece (units of one connected piece): mean over runs", fontsize="small")
    for ax in axes.flat:
        for step, text in marks:
            ax.axvline(step, color="C2", ls="-.", lw=1)
            ax.annotate(text, (step, 1.0), xycoords=("data", "axes fraction"), xytext=(3, -3),
                        textcoords="offset points", fontsize="x-small", va="top", color="C2")
        ax.axhline(0, color="k", lw=0.4)
        ax.set_xlabel("learning step")
        ax.legend(fontsize="x-small", loc="lower right")
    axes[0, 0].set_ylabel("Ubar (mm/cycle)")
    fig.suptitle(f"{name}: Ubar around its events")
    return plots.save_figure(fig, path, dpi=DPI)


def leaderboard_scale(points: pd.DataFrame, path: Path, title: str = "") -> Path:
    """Each learner's score (mean +- 2 standard errors over the seeds) against the number of units N on a log axis,
    one panel per ``family`` (chains, sheets) sharing the score axis: ``points`` as ``scores.scale_table`` makes it.
    A centralized baseline is dashed (a reference for the per-unit learners); 1, the best gait known for each task,
    and 0 are drawn across."""
    families = list(dict.fromkeys(points.family))
    learners = list(dict.fromkeys(points.learner))
    fig, axes = plt.subplots(1, len(families), figsize=(5.2 * len(families), 4.2), sharey=True, squeeze=False)
    for ax, family in zip(axes[0], families):
        mine = points[points.family == family]
        for k, learner in enumerate(learners):
            rows = mine[mine.learner == learner].sort_values("n_units")
            if not len(rows):
                continue
            central = bool(rows.centralized.iloc[0])
            ax.errorbar(rows.n_units.to_numpy(dtype=float), rows.score.to_numpy(dtype=float),
                        yerr=2 * np.nan_to_num(rows.score_se.to_numpy(dtype=float)), fmt="o--" if central else "o-",
                        ms=4, lw=1.2, capsize=3, color=f"C{k % 10}",
                        label=f"{learner} (centralized)" if central else learner)
        ax.axhline(1.0, color="0.5", lw=0.8, ls=":")
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_xscale("log")
        sizes = sorted(set(mine.n_units.astype(int)))
        ax.set_xticks(sizes)
        ax.xaxis.set_major_formatter(ticker.FuncFormatter(lambda value, _: f"{value:,.0f}"))
        ax.xaxis.set_minor_formatter(ticker.NullFormatter())
        ax.set_xlabel("active units N (log scale)")
        ax.set_title(f"{family}s")
    axes[0][0].set_ylabel("score: final true Ubar / best known gait")
    axes[0][-1].legend(fontsize="x-small")
    if title:
        fig.suptitle(title)
    return plots.save_figure(fig, path, dpi=DPI)
