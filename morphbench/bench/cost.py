"""The cost model of a suite's jobs: relative wall time, for the progress bar and longest-first scheduling (never
for ids or records)."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from morphbench.experiment.run import RunConfig
    from morphbench.shapes import Shape


def body_cost(shape: Shape) -> float:
    """Relative wall time of one cycle of a shape (measured: about bodies^1.15 on chains of 3 to 21 bodies)."""
    return float(len(shape.bodies)) ** 1.15


def run_cost(config: RunConfig) -> float:
    """A learning run's cost: the cycles it simulates (warm-up, then per step the discarded and measured ones) times
    its shape's body_cost."""
    lp = config.learner_params
    cycles = lp.warmup_cycles + (config.steps + 1) * (lp.cycles_per_step + lp.discard_cycles)
    return cycles * body_cost(config.shape)


def scan_point_cost(shape: Shape, cycles: int, discard: int) -> float:
    """One scan point's cost: its discarded and measured cycles times the shape's body_cost."""
    return (cycles + discard) * body_cost(shape)
