"""The per-unit learners side by side (docs/learners.md, "Measured"): final Ubar of random, thermal, flaky, averaged,
adaptive and sparse at their defaults (sparse: its own, params.LEARNER_PRESETS) over 8 seeds (mean +- standard
error), ideal sensor, on chains and on the S5 and S6 examples (whose cells add the mean true Ubar from the event on).
Prints the table's rows in markdown.

    python benchmarks/learners.py      # under a minute on one core
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from morphbench.experiment import RunConfig, load_run_config
from morphbench.experiment.driver import run_batch
from morphbench.params import EnvironmentParams, SensorParams, learner_defaults
from morphbench.shapes import load_shape

ROOT = Path(__file__).resolve().parent.parent
IDEAL = SensorParams(kind="ideal")
LEARNERS = ("random", "thermal", "flaky", "averaged", "adaptive", "sparse")
SEEDS = range(8)


def row(name: str, base: RunConfig, event_step: int | None = None) -> str:
    cells = []
    for learner in LEARNERS:
        done = run_batch([dataclasses.replace(base, learner=learner, seed=seed,
                                              learner_params=learner_defaults(learner)) for seed in SEEDS])
        final = np.array([records.summary()["final_ubar"] for records in done])
        cell = f"{final.mean():+.2f} ± {final.std(ddof=1) / np.sqrt(len(final)):.2f}"
        if event_step is not None:
            after = [records.steps().ubar_true[records.steps().step >= event_step].mean() for records in done]
            cell += f" (after: {np.mean(after):+.2f})"
        cells.append(cell)
    return f"| {name} | " + " | ".join(cells) + " |"


def main() -> None:
    print("| scenario | " + " | ".join(LEARNERS) + " |")
    print("|---" * (len(LEARNERS) + 1) + "|")
    chain2, chain3 = (load_shape(ROOT / "shapes" / f"chain-{n}.toml") for n in (2, 3))
    print(row("chain-2, 150 steps", RunConfig(shape=chain2, steps=150, sensor=IDEAL)), flush=True)
    print(row("chain-3, 150 steps", RunConfig(shape=chain3, steps=150, sensor=IDEAL)), flush=True)
    print(row("chain-3, 150 steps, noise 1 mm/cycle",
              RunConfig(shape=chain3, steps=150, sensor=IDEAL, environment=EnvironmentParams(noise=1.0))), flush=True)
    for example in ("s5-friction-drop", "s6-damage"):
        config = dataclasses.replace(load_run_config(ROOT / "examples" / f"{example}.toml"), sensor=IDEAL)
        step = config.events[0].step
        print(row(f"{example}, {config.steps} steps, event at {step}", config, step), flush=True)


if __name__ == "__main__":
    main()
