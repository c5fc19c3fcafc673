"""PNG figures of a run and of a scan (matplotlib, off-screen)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # off-screen: no display on the machines that run suites
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from morphbench.files import atomic_write  # noqa: E402
from morphbench.shapes.colours import phase_rgb  # noqa: E402

PHASE_MAP_COLUMNS = 4
"""panels per row of a phase-map figure."""


LEGEND_UNITS = 8
"""units up to which the learning curve draws each unit's kept phases in a colour of its own, with a legend."""


def learning_curve(steps: pd.DataFrame, units: pd.DataFrame, path: str | Path, title: str = "") -> Path:
    """Ubar and acceptance vs learning step, and each unit's kept phase (``learning_curve_figure``), as a PNG."""
    return save_figure(learning_curve_figure(steps, units, title), path)


def learning_curve_figure(steps: pd.DataFrame, units: pd.DataFrame, title: str = ""):
    """The learning curve's figure: Ubar and acceptance vs learning step, each unit's kept phase, and the run's
    events (``steps.event``) as a dashed line at their step in every panel, named above the first."""
    fig, (ax_u, ax_a, ax_p) = plt.subplots(3, 1, figsize=(7, 7.5), sharex=True)
    ax_u.plot(steps.step, steps.ubar, lw=1, label="measured")
    if not np.allclose(steps.ubar, steps.ubar_true):
        ax_u.plot(steps.step, steps.ubar_true, lw=1, alpha=0.7, label="true")
        ax_u.legend(loc="lower right")
    ax_u.axhline(0, color="k", lw=0.5)
    ax_u.set_ylabel("Ubar (mm/cycle)")
    ax_a.plot(steps.step, steps.acceptance.rolling(10, min_periods=1).mean(), lw=1)
    ax_a.set_ylabel("acceptance\n(10-step mean)")
    ax_a.set_ylim(-0.02, 1.02)
    if units.unit.nunique() <= LEGEND_UNITS:
        for unit, rows in units.groupby("unit"):
            ax_p.plot(rows.step, rows.phase_kept, ".", ms=2, label=f"unit {unit}")
        ax_p.legend(loc="upper right", fontsize="small", markerscale=4)
    else:  # one artist for every unit: a sheet of 10,000 units drew 10,000 lines (6 s)
        ax_p.scatter(units.step, units.phase_kept, s=1, c=units.unit, cmap="viridis", linewidths=0, rasterized=True)
    ax_p.set_ylabel("kept phase (cycles)")
    ax_p.set_ylim(0, 1)
    ax_p.set_xlabel("learning step")
    events = steps[steps.event.fillna("").astype(str) != ""] if "event" in steps else steps.iloc[:0]
    for step, text in zip(events.step, events.event):
        for ax in (ax_u, ax_a, ax_p):
            ax.axvline(step, color="0.4", lw=0.8, ls="--")
        ax_u.annotate(text, (step, 1.0), xycoords=("data", "axes fraction"), xytext=(2, 2),
                      textcoords="offset points", fontsize="x-small", color="0.3", va="bottom")
    fig.suptitle(title)
    return fig


def trajectory_figure(tracks: pd.DataFrame | Mapping[str, pd.DataFrame], path: str | Path, title: str = "") -> Path:
    """The assembly's centroid on the ground (steps.parquet's ``x_m``, ``y_m``, in mm, axes to the same scale), start
    marked by a circle and end by a dot with an arrow along the final ``heading_rad``. ``tracks`` is one run's steps
    table, or label -> steps table: one colour per label, one line per run (``run_id``) of its table."""
    groups = tracks.items() if isinstance(tracks, Mapping) else [(None, tracks)]
    runs = [(i, label, run) for i, (label, table) in enumerate(groups)
            for _, run in (table.groupby("run_id", sort=False) if "run_id" in table else [(None, table)])]
    runs = [(i, label, run.sort_values("step")) for i, label, run in runs if np.isfinite(run.x_m).any()]
    every_point = pd.concat([run[["x_m", "y_m"]] for _, _, run in runs]) * 1000.0
    arrow = 0.08 * max(float(np.nanmax(every_point.max() - every_point.min())), 1.0)  # mm, visible on a short track
    fig, ax = plt.subplots(figsize=(6.5, 5.5))
    labelled = set()
    for i, label, run in runs:
        colour = f"C{i % 10}"
        x, y = run.x_m.to_numpy() * 1000.0, run.y_m.to_numpy() * 1000.0
        ax.plot(x, y, lw=1, color=colour, label=label if label not in labelled else None)
        labelled.add(label)
        ax.plot(x[0], y[0], "o", mfc="none", color=colour, ms=6)
        ax.plot(x[-1], y[-1], "o", color=colour, ms=4)
        heading = run.heading_rad.iloc[-1]
        if np.isfinite(heading):
            tip = (x[-1] + arrow * np.cos(heading), y[-1] + arrow * np.sin(heading))
            ax.annotate("", xy=tip, xytext=(x[-1], y[-1]), arrowprops={"arrowstyle": "->", "color": colour})
            ax.update_datalim([tip])  # an annotation does not widen the axes by itself
    ax.autoscale_view()
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    if len(labelled - {None}) and len(labelled) <= 12:
        ax.legend(fontsize="x-small")
    ax.set_title((f"{title}\n" if title else "") + "centroid: circle at the start, dot at the end, arrow the final "
                 "heading", fontsize="small")
    return save_figure(fig, path)


def scan_figure(table: pd.DataFrame, path: str | Path, title: str = "") -> Path:
    """A curve for 2 units, a heat map for 3, the distribution of sampled Ubar beyond."""
    dphi = [c for c in table.columns if c.startswith("dphi_")]
    fig, ax = plt.subplots(figsize=(6.5, 5))
    if len(dphi) == 1:
        ax.plot(table[dphi[0]], table.ubar, "o-", ms=3)
        ax.axhline(0, color="k", lw=0.5)
        ax.set_xlabel("phase difference dphi_2 (cycles)")
        ax.set_ylabel("Ubar (mm/cycle)")
    elif len(dphi) == 2:
        fig.colorbar(landscape(ax, table), ax=ax, label="Ubar (mm/cycle)")
    else:
        ax.hist(table.ubar, bins=30)
        ax.set_xlabel(f"Ubar (mm/cycle) at {len(table)} sampled phase vectors")
        ax.set_ylabel("count")
    ax.set_title(title)
    return save_figure(fig, path)


def landscape(ax, table: pd.DataFrame, limit: float | None = None):
    """A 3-unit scan's Ubar over (dphi_2, dphi_3) on ``ax`` as a heat map (red forward, blue backward, white at rest;
    ``limit``: the |Ubar| of the darkest colour, default the scan's largest); returns the mesh, for a colour bar.
    Phases are periodic: the map covers [0, 1) on both axes, the points at 0 repeated at 1, each point's cell centred
    on it (so the cells on the edges are halves)."""
    grid = table.pivot(index="dphi_3", columns="dphi_2", values="ubar")
    x, y, values = grid.columns.to_numpy(dtype=float), grid.index.to_numpy(dtype=float), grid.to_numpy()
    if len(x) > 1 and len(y) > 1 and x[0] == 0 and y[0] == 0:  # a full grid: wrap it round
        x, y = np.append(x, 1.0), np.append(y, 1.0)
        values = np.vstack([values, values[:1]])
        values = np.hstack([values, values[:, :1]])
    limit = limit or float(np.nanmax(np.abs(values))) or 1.0
    mesh = ax.pcolormesh(x, y, values, cmap="RdBu_r", vmin=-limit, vmax=limit, shading="nearest")
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    ax.set_xlabel("dphi_2 (cycles)")
    ax.set_ylabel("dphi_3 (cycles)")
    ax.set_aspect("equal")
    return mesh


def phase_maps(units: pd.DataFrame, half: np.ndarray, steps: list[int], path: str | Path, title: str = "") -> Path:
    """Small multiples of the kept phases over a one-layer assembly, one panel per learning step of ``steps``: each
    unit of ``units`` (a run's units table) at the end of that step, as its footprint (``half``: per place, the half
    length and width, m) at its pose, coloured on the cyclic phase map (``colours.phase_rgb``: phases 0 and 1 alike).
    Panels share their scale and limits, so motion between them shows."""
    from matplotlib.collections import PolyCollection
    from matplotlib.colors import ListedColormap

    shown = units[units.step.isin(steps)]
    corners = {}
    for step in steps:
        rows = shown[shown.step == step]
        h = half[rows.position.to_numpy() - 1]
        angle = rows.heading_rad.to_numpy(dtype=float)
        along = np.stack([np.cos(angle), np.sin(angle)], axis=1) * h[:, :1]
        across = np.stack([-np.sin(angle), np.cos(angle)], axis=1) * h[:, 1:]
        centre = rows[["x_m", "y_m"]].to_numpy(dtype=float)
        corners[step] = (np.stack([centre + along + across, centre - along + across, centre - along - across,
                                   centre + along - across], axis=1), rows.phase_kept.to_numpy(dtype=float))
    every = np.concatenate([c.reshape(-1, 2) for c, _ in corners.values()])
    low, high = every.min(axis=0), every.max(axis=0)
    margin = 0.05 * max(high - low)
    n_cols = min(len(steps), PHASE_MAP_COLUMNS)
    n_rows = -(-len(steps) // n_cols)
    aspect = (high[1] - low[1] + 2 * margin) / (high[0] - low[0] + 2 * margin)
    fig, axes = plt.subplots(n_rows, n_cols, figsize=(3.2 * n_cols + 1, 3.2 * n_rows * min(max(aspect, 0.3), 2) + 0.6),
                             sharex=True, sharey=True, squeeze=False, layout="constrained")
    for ax, step in zip(axes.flat, steps):
        polygons, phases = corners[step]
        ax.add_collection(PolyCollection(polygons, facecolors=phase_rgb(phases), edgecolors="none"))
        ax.set_title(f"step {step}", fontsize="medium")
        ax.set_xlim(low[0] - margin, high[0] + margin)
        ax.set_ylim(low[1] - margin, high[1] + margin)
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
    for ax in axes[:, 0]:
        ax.set_ylabel("y (m)")
    for ax in axes.flat[len(steps):]:
        ax.axis("off")
    cyclic = ListedColormap(phase_rgb(np.arange(256) / 256))
    bar = fig.colorbar(plt.cm.ScalarMappable(plt.Normalize(0, 1), cyclic), ax=axes, shrink=0.8)
    bar.set_label("kept phase (cycles; 0 = 1)")
    fig.suptitle(title)
    return save_figure(fig, path)


def save_figure(fig, path: str | Path, dpi: int = 110) -> Path:
    """Lay ``fig`` out (tightly, unless it was made with a layout engine of its own, e.g. ``layout="constrained"``
    for a colour bar shared by several panels), write it to ``path`` atomically (the format from its suffix) and close
    it."""
    if fig.get_layout_engine() is None:
        fig.tight_layout()
    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=dpi))
    plt.close(fig)
    return Path(path)
