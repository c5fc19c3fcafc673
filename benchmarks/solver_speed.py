"""The quasi-static chain solver per tick: the dynamic programme alone against guessed patterns first (the default),
side by side on the same ticks (a chain's own pressures at random phases, the default actuator and friction).

    python benchmarks/solver_speed.py [--ticks 24000] [--repeat 3]

Prints a Markdown table for benchmarks/RESULTS.md: ns per tick (best of the repeats, process CPU time), the ratio,
and the largest difference between the two settings' final displacements (rounding: tests/test_quasistatic.py).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from morphbench.params import QUASISTATIC_PHYSICS
from morphbench.physics import make_world
from morphbench.physics import quasistatic as Q
from morphbench.shapes import load_shape

LIBRARY = Path(__file__).resolve().parents[1] / "shapes"
SHAPES = ("chain-3", "chain-5", "chain-7", "chain-10", "chain-15", "chain-20")


def ticks_of(name: str, n_ticks: int):
    """What one chain's solver is given for ``n_ticks`` ticks from rest (rest lengths beyond the empty pitch and
    friction limits)."""
    shape = load_shape(LIBRARY / f"{name}.toml")
    world = make_world(shape, QUASISTATIC_PHYSICS)
    world.set_phases(np.random.default_rng(0).random(shape.n_units))
    extension = world._rest_lengths(world._pressures(0.0, n_ticks, True)) - world._empty_pitch
    limits = np.ascontiguousarray(np.broadcast_to(world._base_friction * world._weights, (n_ticks, len(world.s))))
    return world, extension, limits


def solve(world, extension, limits, guess_from: int) -> tuple[float, np.ndarray]:
    """Process seconds for the ticks, and the final displacements."""
    n, actuator = len(world.s), world.shape.actuator
    s = np.zeros(n)
    started = time.process_time()
    Q._solve_ticks(s, extension, limits, world._order, world._starts, world._pair_link, world._pair_sign,
                   world.link_stiffness, actuator.max_force, np.full(len(extension), -1, dtype=np.int64),
                   np.empty((0, n)), np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64), guess_from, 0, 0,
                   np.zeros((0, 4)), np.zeros(3), np.ones(n), np.zeros((n, 2)), np.zeros(2))
    return time.process_time() - started, s


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ticks", type=int, default=24000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    print("| shape | bodies | programme alone, ns/tick | default (guess from "
          f"{Q.PATTERN_MIN_BODIES} bodies), ns/tick | ratio | largest difference (m) |")
    print("|---|---|---|---|---|---|")
    for name in SHAPES:
        world, extension, limits = ticks_of(name, args.ticks)
        n = len(world.s)
        best = {}
        for label, guess_from in (("programme", n + 1), ("default", Q.PATTERN_MIN_BODIES)):
            solve(world, extension[:10], limits[:10], guess_from)  # compiled before timing
            runs = [solve(world, extension, limits, guess_from) for _ in range(args.repeat)]
            best[label] = (min(t for t, _ in runs) / args.ticks * 1e9, runs[0][1])
        difference = np.abs(best["programme"][1] - best["default"][1]).max()
        print(f"| {name} | {n} | {best['programme'][0]:.0f} | {best['default'][0]:.0f} | "
              f"{best['programme'][0] / best['default'][0]:.2f} | {difference:.1e} |")


if __name__ == "__main__":
    main()
