"""What a run records, and how it is written: the one results schema.

A run directory holds:
- ``units.parquet``: one row per learning step and unit: ``step`` (0 is the initial measurement), ``unit`` (1-based,
  unit 1 starts at the front; a unit keeps its number when a shuffle moves it), ``position`` (1-based, where it sits
  now, 1 = front), ``piece`` (1-based, which piece of a cut assembly it belongs to; 1 while uncut), ``phase_tried``,
  ``phase_kept`` (cycles, 0..1), ``u_measured`` (mm/cycle, what the unit's sensor reported, noise included; NaN for a
  dead unit), ``u_true`` (mm/cycle, the unit's true displacement along its forward axis per cycle), ``u_memory``
  (mm/cycle, the velocity the learner remembers after the step, what its next trial is compared with: Thermal's last
  accepted measurement (Adaptive's too), Flaky's and the random baseline's last measurement, Averaged's exponential
  average of its measurements, a centralized controller's measurement of the unit at its kept vector; NaN for a
  plug-in without a ``memory``), ``accepted`` (whether the learner kept the tried phase), ``x_m``, ``y_m`` (m,
  where the unit's centre is on the ground at the end of the step: start and end positions, 2-D trajectories),
  ``heading_rad`` (the direction of the unit's forward axis on the ground, from +x towards +y, in (-pi, pi]).
- ``steps.parquet``: one row per learning step: ``step``, ``time_s`` (simulated time at the end of the step),
  ``ubar`` (mean ``u_measured`` over the units that are not dead), ``ubar_true`` (the same units' true velocities),
  ``acceptance`` (fraction of those units that accepted), ``event`` (the events applied at the start of the step,
  '' if none), and the assembly's track on the ground: ``x_m``, ``y_m`` (m, the centroid of all units' centres at the
  end of the step), ``heading_rad`` (the assembly's heading: the angle of the shape's ``heading`` in the ground plane
  plus the circular mean of the units' ``heading_rad``, unwrapped over the steps so that a turning assembly's heading
  runs on past pi; NaN when the shape's heading has no ground component, e.g. a stack scored along z) and
  ``u_heading`` (mm/cycle, the centroid's displacement since the previous step along the heading at the previous
  step, per pump cycle in between; NaN at step 0 and without a heading). ``turning_rate`` is the slope
  of ``heading_rad``.
- ``pieces.parquet``: one row per learning step and piece: ``step``, ``piece``, ``n_units``, ``ubar``, ``ubar_true``:
  after a cut, each piece is a robot of its own and is scored on its own.
- ``summary.json``: the full configuration, seed, ``centralized`` (whether one controller ran every unit:
  morphbench.learning.controllers), final Ubar, mean acceptance, sensor error, wall time, the final
  ``u_heading`` (``final_u_heading``, over the same final steps as final Ubar) and the turning rate
  (``turning_rate_deg_per_cycle``: degrees per pump cycle over the learning steps).
Read them with ``pandas.read_parquet``. The directory is written whole (``RunRecords.write``): a killed or interrupted
run leaves the earlier directory or the new one complete, never half of one.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pandas as pd

from morphbench.files import atomic_write, replace_directory  # noqa: F401 (bench.store takes atomic_write from here)
from morphbench.learning.controllers import is_centralized

UNIT_COLUMNS = ("step", "unit", "position", "piece", "phase_tried", "phase_kept", "u_measured", "u_true", "u_memory",
                "accepted", "x_m", "y_m", "heading_rad")
STEP_COLUMNS = ("step", "time_s", "ubar", "ubar_true", "acceptance", "event", "x_m", "y_m", "heading_rad", "u_heading")
PIECE_COLUMNS = ("step", "piece", "n_units", "ubar", "ubar_true")
STORED_COLUMNS = {"position": np.int64, "piece": np.int64, "phase_tried": float, "phase_kept": float,
                  "u_measured": float, "u_true": float, "u_memory": float, "accepted": bool, "x_m": float,
                  "y_m": float, "heading_rad": float}
"""The unit columns ``StepRows`` keeps, with their types (``step`` and ``unit`` follow from the rows)."""
STEP_ROWS = {"step": np.int64, "time_s": float, "event": object}
"""The columns ``StepRows`` keeps once per row."""
FINAL_FRACTION = 0.1  # final Ubar is the mean over the last 10% of learning steps (at least one)
NO_GROUND_HEADING = 1e-9  # a shape heading whose ground-plane part is shorter than this has no heading on the ground


class StepRows:
    """The rows of the learning steps of ``n_runs`` runs with as many units each: per column of STEP_ROWS one array
    (rows, runs), per column of STORED_COLUMNS one (rows, runs, units). ``add`` appends a row to each of the runs it
    is given, so that a batch's driver stores a step of all its runs at once; each run's ``RunRecords`` reads its
    own rows, as many as were added for it (a run that stopped early keeps exactly the rows it had)."""

    def __init__(self, n_runs: int, capacity: int = 16):
        self.counts = np.zeros(n_runs, dtype=np.int64)
        """rows per run."""
        self.columns = {name: np.zeros((capacity, n_runs), dtype=kind) for name, kind in STEP_ROWS.items()}
        """the unit columns join at the first ``add``, which gives the number of units."""

    def add(self, runs: np.ndarray, step: int, time_s: float, event, units: dict[str, np.ndarray]) -> None:
        """A row for each of ``runs`` (run indices): ``event`` one text or one per run, ``units`` every column of
        STORED_COLUMNS, (len(runs), n_units) in unit order."""
        if not len(runs):
            return
        rows = self.counts[runs]
        if rows.max() >= len(self.columns["step"]):
            self._grow(2 * int(rows.max()) + 1)
        if "phase_tried" not in self.columns:
            shape = self.columns["step"].shape + np.shape(units["phase_tried"])[-1:]
            self.columns.update({name: np.zeros(shape, dtype=kind) for name, kind in STORED_COLUMNS.items()})
        for name, values in (("step", step), ("time_s", time_s), ("event", event), *units.items()):
            self.columns[name][rows, runs] = values
        self.counts[runs] += 1

    def _grow(self, capacity: int) -> None:
        for name, values in self.columns.items():
            more = np.zeros((capacity - len(values),) + values.shape[1:], dtype=values.dtype)
            self.columns[name] = np.concatenate([values, more])

    def of(self, run: int, name: str) -> np.ndarray:
        """Run ``run``'s rows of column ``name``: (rows, n_units) for a unit column, (rows,) for a step column."""
        return self.columns[name][:self.counts[run], run]


class RunRecords:
    """A run's measurements step by step, offered as tables and a summary: its rows of ``rows`` (a ``StepRows``
    shared with the other runs of its batch, at index ``run``; its own by default)."""

    def __init__(self, config: Any, rows: StepRows | None = None, run: int = 0):
        self.config = config
        self.rows, self.run = StepRows(1) if rows is None else rows, run
        self.wall_time: float | None = None
        self.backend: str | None = None
        """the physics backend the run's world used (``physics.resolve_backend``; 'auto' resolved), set by its
        driver."""
        self._built: tuple[int, pd.DataFrame, pd.DataFrame, pd.DataFrame] | None = None
        """(steps recorded, units, steps, pieces): the tables as last built (``_tables``)."""

    def add_step(self, step, time_s, tried, kept, u_measured, u_true, accepted, position, piece, xy, heading,
                 event="", u_memory=None) -> None:
        """One learning step; the arrays are per unit, in unit order (``xy``: (n, 2) ground positions, m;
        ``heading``: rad; ``u_memory``: mm/cycle, None for none kept)."""
        memory = np.full(len(tried), np.nan) if u_memory is None else u_memory
        columns = {"position": position, "piece": piece, "phase_tried": tried, "phase_kept": kept,
                   "u_measured": u_measured, "u_true": u_true, "u_memory": memory, "accepted": accepted,
                   "x_m": xy[:, 0], "y_m": xy[:, 1], "heading_rad": heading}
        self.rows.add(np.array([self.run]), step, time_s, event,
                      {name: np.asarray(values)[None] for name, values in columns.items()})

    def finish(self, wall_time: float) -> None:
        self.wall_time = wall_time

    @property
    def n_steps(self) -> int:
        return int(self.rows.counts[self.run])

    @property
    def last_ubar(self) -> float:
        """Ubar of the last step recorded; NaN before any (units on clocks of their own record a step only once the
        next one is under way: their run's first progress call comes before its step 0 is recorded)."""
        if not self.n_steps:
            return math.nan
        return float(np.nanmean(self.rows.of(self.run, "u_measured")[-1]))

    def last_kept_by_place(self) -> np.ndarray | None:
        """The units' kept phases at the end of the last step recorded, by the place each sits at (the world's unit
        order, as ``world.phases``): what a video colours each unit's body by; None before any step is recorded."""
        if not self.n_steps:
            return None
        kept, place = self.rows.of(self.run, "phase_kept")[-1], self.rows.of(self.run, "position")[-1] - 1
        by_place = np.empty(len(kept))
        by_place[place] = kept
        return by_place

    def units(self) -> pd.DataFrame:
        """Per step and unit (see the module docstring)."""
        return self._tables()[0].copy()

    def steps(self) -> pd.DataFrame:
        """Per step (see the module docstring). Dead units (NaN measurement) are left out of the means."""
        return self._tables()[1].copy()

    def pieces(self) -> pd.DataFrame:
        """Per step and piece (see the module docstring)."""
        return self._tables()[2].copy()

    def _tables(self) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
        """The units, steps and pieces tables, built once for the steps recorded so far: a finished run's summary
        and files read each of them several times."""
        if self._built is None or self._built[0] != self.n_steps:
            self._built = (self.n_steps, self._units_table(), self._steps_table(), self._pieces_table())
        return self._built[1:]

    def _units_table(self) -> pd.DataFrame:
        if not self.n_steps:
            return pd.DataFrame(columns=UNIT_COLUMNS)
        steps = self.rows.of(self.run, "step")
        n = self.rows.columns["phase_tried"].shape[-1]
        # StepRows holds each column in its type (STORED_COLUMNS): the table needs no conversion
        return pd.DataFrame({"step": np.repeat(steps, n), "unit": np.tile(np.arange(1, n + 1, dtype=np.int64),
                                                                          len(steps)),
                             **{name: self.rows.of(self.run, name).ravel() for name in STORED_COLUMNS}},
                            columns=UNIT_COLUMNS)

    def _of(self, name: str) -> np.ndarray:
        return self.rows.of(self.run, name)

    def _living(self) -> np.ndarray:
        """(rows, units): the units scored at each step, those not dead (a dead unit measures NaN)."""
        return ~np.isnan(self._of("u_measured"))

    def _steps_table(self) -> pd.DataFrame:
        if not self.n_steps:
            return pd.DataFrame(columns=STEP_COLUMNS)
        scored = self._of("u_measured"), self._of("u_true"), self._of("accepted").astype(float)
        (ubar, ubar_true, acceptance), _ = group_means(scored, np.where(self._living(), 0, -1), 1)
        angle = self._of("heading_rad")
        (x, y, cos, sin), _ = group_means((self._of("x_m"), self._of("y_m"), np.cos(angle), np.sin(angle)),
                                          np.zeros(angle.shape, dtype=np.int64), 1)
        time_s = self._of("time_s")
        h_x, h_y, _ = self.config.shape.heading
        if np.hypot(h_x, h_y) < NO_GROUND_HEADING:
            heading = np.full(len(time_s), np.nan)
        else:
            heading = np.unwrap(np.arctan2(h_y, h_x) + np.arctan2(sin[:, 0], cos[:, 0]))
        cycles = np.diff(time_s) / self.config.shape.actuator.cycle_time
        along = np.diff(x[:, 0]) * np.cos(heading[:-1]) + np.diff(y[:, 0]) * np.sin(heading[:-1])
        u_heading = np.concatenate([[np.nan], 1000.0 * along / cycles])  # at step 0: no previous step
        return pd.DataFrame({"step": self._of("step"), "time_s": time_s, "ubar": ubar[:, 0],
                             "ubar_true": ubar_true[:, 0], "acceptance": acceptance[:, 0],
                             "event": list(self._of("event")), "x_m": x[:, 0], "y_m": y[:, 0],
                             "heading_rad": heading, "u_heading": u_heading}, columns=STEP_COLUMNS)

    def _pieces_table(self) -> pd.DataFrame:
        if not self.n_steps:
            return pd.DataFrame(columns=PIECE_COLUMNS)
        names, piece = np.unique(self._of("piece"), return_inverse=True)
        piece = np.where(self._living(), piece.reshape(self._of("piece").shape), -1)
        (ubar, ubar_true), sizes = group_means((self._of("u_measured"), self._of("u_true")), piece, len(names))
        row, which = np.nonzero(sizes)  # by step, then piece: the rows of a groupby of both, sorted
        return pd.DataFrame({"step": self._of("step")[row], "piece": names[which], "n_units": sizes[row, which],
                             "ubar": ubar[row, which], "ubar_true": ubar_true[row, which]}, columns=PIECE_COLUMNS)

    def summary(self) -> dict[str, Any]:
        """Configuration, seed and the run's headline figures."""
        units, steps, _ = self._tables()
        learning = steps[steps.step > 0]
        return {
            "config": self.config.to_dict(),
            "seed": self.config.seed,
            "centralized": is_centralized(self.config.learner),
            "backend": self.backend,
            "n_units": self.config.shape.n_units,
            "steps": int(learning.step.max()) if len(learning) else 0,
            "final_ubar": final_value(steps.step, steps.ubar),
            "final_ubar_true": final_value(steps.step, steps.ubar_true),
            "mean_acceptance": float(learning.acceptance.mean()) if len(learning) else float("nan"),
            "final_u_heading": final_value(steps.step, steps.u_heading),
            "turning_rate_deg_per_cycle": turning_rate(steps, self.config.shape.actuator.cycle_time),
            "final_ubar_by_piece": self._final_by_piece(final_steps(len(learning))),
            "events": [event for event in steps.event if event],
            "sensor_error": float((units.u_measured - units.u_true).abs().mean()),
            "wall_time_s": self.wall_time,
        }

    def _final_by_piece(self, n_final: int) -> dict[str, float]:
        """Final true Ubar of each piece of the last step's assembly (one entry while uncut)."""
        pieces = self._tables()[2]
        last_steps = sorted(pieces.step.unique())[-n_final:]
        final = pieces[pieces.step.isin(last_steps)].groupby("piece").ubar_true.mean()
        return {str(piece): float(value) for piece, value in final.items()}

    def write(self, out_dir: str | Path, more: Callable[[Path], object] | None = None) -> Path:
        """Write ``units.parquet``, ``steps.parquet``, ``pieces.parquet`` and ``summary.json`` (and whatever
        ``more(directory)`` writes, e.g. figures) as the directory ``out_dir``: into a new directory beside it, then
        swapped in whole, so ``out_dir`` holds an earlier run or this one complete, never a mix."""

        def write_all(directory: Path) -> None:
            self.units().to_parquet(directory / "units.parquet", index=False)
            self.steps().to_parquet(directory / "steps.parquet", index=False)
            self.pieces().to_parquet(directory / "pieces.parquet", index=False)
            text = json.dumps(self.summary(), indent=2, sort_keys=True)
            (directory / "summary.json").write_text(text + "\n", encoding="utf-8")
            if more is not None:
                more(directory)

        return replace_directory(out_dir, write_all)


def group_means(values: tuple[np.ndarray, ...], groups: np.ndarray, n_groups: int
                ) -> tuple[np.ndarray, np.ndarray]:
    """Per row and group, the means of each of ``values`` (arrays (rows, units)) over the entries of that group
    (``groups``, (rows, units): 0 .. n_groups - 1, or -1 for none), NaN entries left out, NaN where none is left:
    (len(values), rows, n_groups); and each group's size (rows, n_groups), NaN entries counted.

    Summed as a pandas (3) groupby of the rows sums them, so that the tables stay bit for bit those of the versions
    that built them with pandas (tests/test_records.py): the entries in row order, by ``np.add.reduceat`` when they
    come sorted by row and group and none is NaN, else with Kahan's compensation; without the cost of pandas'
    groupbys and merges, which was most of a short run's cost beyond its physics."""
    groups = np.asarray(groups, dtype=np.int64)
    member = groups >= 0
    label = (np.arange(len(groups))[:, None] * n_groups + groups)[member]  # the entries' groups, in row order
    sizes = np.bincount(label, minlength=len(groups) * n_groups).reshape(len(groups), n_groups)
    starts = np.flatnonzero(np.r_[True, label[1:] != label[:-1]]) if len(label) else label
    in_order = bool(np.all(label[1:] >= label[:-1]))
    means = np.full((len(values), len(groups), n_groups), np.nan)
    for column, value in enumerate(values):
        value = np.asarray(value, dtype=float)
        entries = value[member]
        if not len(entries):
            continue
        if in_order and not np.isnan(entries).any():
            present = label[starts]
            means[column].reshape(-1)[present] = np.add.reduceat(entries, starts) / sizes.reshape(-1)[present]
        else:
            means[column] = _compensated_means(value, groups, n_groups)
    return means, sizes


def _compensated_means(values: np.ndarray, groups: np.ndarray, n_groups: int) -> np.ndarray:
    """``group_means`` of one array by Kahan's compensated sum, as pandas' grouped mean (an infinite value resets
    the compensation rather than making it NaN): unit by unit, over every row at once (each row's sequence of
    operations is the scalar algorithm's)."""
    rows = np.arange(len(values))
    total, compensation = np.zeros((len(values), n_groups)), np.zeros((len(values), n_groups))
    counts = np.zeros((len(values), n_groups), dtype=np.int64)
    with np.errstate(invalid="ignore"):
        for value, group in zip(values.T, groups.T):
            take = (group >= 0) & ~np.isnan(value)
            at = rows[take], group[take]
            y = value[take] - compensation[at]
            t = total[at] + y
            lost = t - total[at] - y
            compensation[at] = np.where(np.isnan(lost), 0.0, lost)
            total[at] = t
            counts[at] += 1
    return np.where(counts > 0, total / np.maximum(counts, 1), np.nan)


def final_steps(n_learning: int) -> int:
    """How many of a run's ``n_learning`` learning steps final values average over: the last FINAL_FRACTION, at
    least one."""
    return max(1, int(round(n_learning * FINAL_FRACTION)))


def final_value(steps, values) -> float:
    """Mean of ``values`` over the ``final_steps`` last learning steps, step 0 (the initial measurement) excluded,
    NaN values left out: the definition of a run's final Ubar (and final u_heading, final acceptance); NaN with no
    learning step or no value."""
    steps, values = np.asarray(steps), np.asarray(values, dtype=float)
    learning = values[steps > 0]
    final = learning[-final_steps(len(learning)):]
    final = final[~np.isnan(final)]
    return float(np.mean(final)) if len(final) else math.nan


def turning_rate(steps: pd.DataFrame, cycle_time: float) -> float:
    """Degrees per pump cycle: the least-squares slope of a run's unwrapped ``heading_rad`` (steps.parquet) against
    time in cycles (``time_s / cycle_time``) over the learning steps (step 0 excluded); NaN with fewer than two finite
    points or no time between them."""
    learning = steps[steps.step > 0]
    t = learning.time_s.to_numpy(dtype=float) / cycle_time
    heading = learning.heading_rad.to_numpy(dtype=float)
    keep = np.isfinite(t) & np.isfinite(heading)
    t, heading = t[keep], heading[keep]
    if len(t) < 2 or np.ptp(t) == 0:
        return math.nan
    t = t - t.mean()
    return math.degrees(float(t @ (heading - heading.mean()) / (t @ t)))
