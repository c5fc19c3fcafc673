"""Do Thermal learners still learn when units have clocks of their own? (docs/sensing.md, "Units with their own
clocks").

Chain-2 and chain-3 on the default physics and sensor, 100 learning steps, a few seeds: final Ubar (mm/cycle, the
measured velocity over the last 10 steps) and final true Ubar of Thermal learners on one shared clock, with offsets
uniform over a whole step, with 0.1% and 1% clock drift, with 1% drift and the offsets, and of the random learner (no
learning) on one clock and on those clocks. Prints a
markdown table; ``--seeds`` and ``--steps`` shorten it.

    PYTHONPATH=. python benchmarks/clocks.py [--seeds 4] [--steps 100]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from morphbench.experiment import RunConfig
from morphbench.experiment.driver import run_batch
from morphbench.params import EnvironmentParams
from morphbench.shapes import load_shape

SHAPES = Path(__file__).resolve().parents[1] / "shapes"
OWN = EnvironmentParams(clock_drift=0.01, clock_offset=1.0)
CONDITIONS = {
    "thermal, one clock": ("thermal", EnvironmentParams()),
    "thermal, offsets over a step only": ("thermal", EnvironmentParams(clock_offset=1.0)),
    "thermal, 0.1% drift only": ("thermal", EnvironmentParams(clock_drift=0.001)),
    "thermal, 1% drift only": ("thermal", EnvironmentParams(clock_drift=0.01)),
    "thermal, 1% drift and offsets": ("thermal", OWN),
    "random, one clock": ("random", EnvironmentParams()),
    "random, 1% drift and offsets": ("random", OWN),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=4)
    parser.add_argument("--steps", type=int, default=100)
    args = parser.parse_args()
    print("| shape | condition | final Ubar (mean ± sd over seeds) | final true Ubar | wall s |")
    print("|---|---|---|---|---|")
    for name in ("chain-2", "chain-3"):
        shape = load_shape(SHAPES / f"{name}.toml")
        for label, (learner, environment) in CONDITIONS.items():
            started = time.perf_counter()
            configs = [RunConfig(shape=shape, learner=learner, environment=environment, steps=args.steps, seed=seed)
                       for seed in range(args.seeds)]
            summaries = [records.summary() for records in run_batch(configs)]
            measured = np.array([s["final_ubar"] for s in summaries])
            true = np.array([s["final_ubar_true"] for s in summaries])
            print(f"| {name} | {label} | {measured.mean():+.2f} ± {measured.std():.2f} | {true.mean():+.2f} ± "
                  f"{true.std():.2f} | {time.perf_counter() - started:.0f} |", flush=True)


if __name__ == "__main__":
    main()
