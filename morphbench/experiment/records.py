"""What a run records, and how it is written: the one results schema.

A run directory holds:
- ``units.parquet``: one row per learning step and unit: ``step`` (0 is the initial measurement), ``unit`` (1-based,
  unit 1 at the front), ``phase_tried``, ``phase_kept`` (cycles, 0..1), ``u_measured`` (mm/cycle, what the unit's
  sensor reported, noise included), ``u_true`` (mm/cycle, the unit's true displacement along its forward axis per
  cycle), ``accepted`` (whether the learner kept the tried phase).
- ``steps.parquet``: one row per learning step: ``step``, ``time_s`` (simulated time at the end of the step),
  ``ubar`` (mean ``u_measured`` over active units), ``ubar_true`` and ``acceptance`` (fraction of units that accepted).
- ``summary.json``: the full configuration, seed, final Ubar, mean acceptance, sensor error and wall time.
Read them with ``pandas.read_parquet``. Every file is written to a temporary name and renamed, so a directory never
holds a half-written file.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

UNIT_COLUMNS = ("step", "unit", "phase_tried", "phase_kept", "u_measured", "u_true", "accepted")
STEP_COLUMNS = ("step", "time_s", "ubar", "ubar_true", "acceptance")
FINAL_FRACTION = 0.1  # final Ubar is the mean over the last 10% of learning steps (at least one)


class RunRecords:
    """Accumulates a run's measurements step by step, then offers them as tables and a summary."""

    def __init__(self, config: Any):
        self.config = config
        self._rows: list[tuple[int, float, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []
        self.wall_time: float | None = None

    def add_step(self, step, time_s, tried, kept, u_measured, u_true, accepted) -> None:
        self._rows.append((step, time_s, tried, kept, u_measured, u_true, accepted))

    def finish(self, wall_time: float) -> None:
        self.wall_time = wall_time

    @property
    def n_steps(self) -> int:
        return len(self._rows)

    @property
    def last_ubar(self) -> float:
        return float(np.mean(self._rows[-1][4]))

    def units(self) -> pd.DataFrame:
        """Per step and unit (see the module docstring)."""
        if not self._rows:
            return pd.DataFrame(columns=UNIT_COLUMNS)
        step, _, tried, kept, u_measured, u_true, accepted = zip(*self._rows)
        n = len(tried[0])
        return pd.DataFrame(
            {
                "step": np.repeat(np.asarray(step, dtype=np.int64), n),
                "unit": np.tile(np.arange(1, n + 1, dtype=np.int64), len(step)),
                "phase_tried": np.concatenate(tried),
                "phase_kept": np.concatenate(kept),
                "u_measured": np.concatenate(u_measured),
                "u_true": np.concatenate(u_true),
                "accepted": np.concatenate(accepted).astype(bool),
            },
            columns=UNIT_COLUMNS,
        )

    def steps(self) -> pd.DataFrame:
        """Per step (see the module docstring)."""
        return pd.DataFrame(
            {
                "step": np.array([r[0] for r in self._rows], dtype=np.int64),
                "time_s": np.array([r[1] for r in self._rows], dtype=float),
                "ubar": np.array([np.mean(r[4]) for r in self._rows], dtype=float),
                "ubar_true": np.array([np.mean(r[5]) for r in self._rows], dtype=float),
                "acceptance": np.array([np.mean(r[6]) for r in self._rows], dtype=float),
            },
            columns=STEP_COLUMNS,
        )

    def summary(self) -> dict[str, Any]:
        """Configuration, seed and the run's headline figures."""
        steps, units = self.steps(), self.units()
        learning = steps[steps.step > 0]
        n_final = max(1, int(round(len(learning) * FINAL_FRACTION)))
        return {
            "config": self.config.to_dict(),
            "seed": self.config.seed,
            "n_units": self.config.shape.n_units,
            "steps": int(learning.step.max()) if len(learning) else 0,
            "final_ubar": float(learning.ubar.tail(n_final).mean()) if len(learning) else float("nan"),
            "final_ubar_true": float(learning.ubar_true.tail(n_final).mean()) if len(learning) else float("nan"),
            "mean_acceptance": float(learning.acceptance.mean()) if len(learning) else float("nan"),
            "sensor_error": float((units.u_measured - units.u_true).abs().mean()),
            "wall_time_s": self.wall_time,
        }

    def write(self, out_dir: str | Path) -> Path:
        """Write ``units.parquet``, ``steps.parquet`` and ``summary.json`` into ``out_dir`` (created if needed)."""
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        atomic_write(out / "units.parquet", lambda tmp: self.units().to_parquet(tmp, index=False))
        atomic_write(out / "steps.parquet", lambda tmp: self.steps().to_parquet(tmp, index=False))
        text = json.dumps(self.summary(), indent=2, sort_keys=True)
        atomic_write(out / "summary.json", lambda tmp: Path(tmp).write_text(text + "\n"))
        return out


def atomic_write(path: Path, write) -> None:
    """Call ``write(tmp_path)`` then rename onto ``path``: readers see the old file or the new one, never half."""
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
