"""Wall time per simulated second against the number of units, on the default physics and on PyBullet fast.

    python benchmarks/cost_per_unit.py            # chains and grids of 1 to 100 units, 20 simulated s each

Each row builds the shape, sets random phases (seed 0) and times ``advance`` over the simulated time (pressures,
link forces or solves, friction; no sensing or learning), after a warm-up second that loads numba's cache. Prints a
Markdown table for benchmarks/RESULTS.md.
"""

from __future__ import annotations

import argparse
import platform
import time

import numpy as np

from morphbench.params import DEFAULT_PHYSICS, FAST_PHYSICS
from morphbench.physics import make_world
from morphbench.shapes import shape_from_table

SHAPES = [
    ("chain", 1, 1), ("chain", 1, 3), ("chain", 1, 10), ("chain", 1, 20),
    ("grid", 2, 2), ("grid", 3, 3), ("grid", 5, 5), ("grid", 10, 10),
]


def shape_of(kind: str, rows: int, columns: int):
    assembly = {"generator": "chain", "units": columns} if kind == "chain" else \
        {"generator": "grid", "rows": rows, "columns": columns, "actuated_axes": ["x", "y"]}
    return shape_from_table({"assembly": assembly}, source=f"{kind}-{rows}x{columns}")


def seconds_per_second(shape, physics, simulated: float) -> float:
    with make_world(shape, physics) as world:
        world.set_phases(np.random.default_rng(0).random(shape.n_units))
        world.advance(world.ticks_in(1.0))
        started = time.perf_counter()
        world.advance(world.ticks_in(simulated))
        return (time.perf_counter() - started) / simulated


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="simulated seconds per row")
    args = parser.parse_args()
    print(f"# {time.strftime('%Y-%m-%d')} {platform.machine()}  python {platform.python_version()}")
    print("| shape | units | bodies | default backend | default wall s per simulated s | "
          "PyBullet fast wall s per simulated s |")
    print("|---|---|---|---|---|---|")
    for kind, rows, columns in SHAPES:
        shape = shape_of(kind, rows, columns)
        with make_world(shape, DEFAULT_PHYSICS) as world:
            backend = type(world).__name__
        default = seconds_per_second(shape, DEFAULT_PHYSICS, args.seconds)
        fast = seconds_per_second(shape, FAST_PHYSICS, args.seconds)
        name = f"chain-{columns}" if kind == "chain" else f"grid-{rows}x{columns}-xy"
        print(f"| {name} | {shape.n_units} | {len(shape.bodies)} | {backend} | {default:.4f} | {fast:.4f} |",
              flush=True)


if __name__ == "__main__":
    main()
