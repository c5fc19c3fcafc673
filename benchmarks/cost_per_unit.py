"""Wall time per simulated second against the number of units, on the default physics and on PyBullet fast.

    python benchmarks/cost_per_unit.py            # chains and grids of 1 to 100 units, 20 simulated s each;
                                                  # then square sheets of 100 to 10,000 units, 2 simulated s each
    python benchmarks/cost_per_unit.py --sheets-only --sheet-seconds 1
    python benchmarks/cost_per_unit.py --sheets-only --banded    # the sheets on the banded solver, up to 1,024 units
    python benchmarks/cost_per_unit.py --breakdown               # where a tick of the sparse solver goes, per sheet

Each row builds the shape, sets random phases (seed 0) and times ``advance`` over the simulated time (pressures,
link forces or solves, friction; no sensing or learning), after a warm-up (a second, a quarter of the time for a
sheet) that loads numba's cache. The sheets (no dummies, bellows along x and y) run on the default physics only, with
the exponent of the cost against the number of units between each sheet and the one before, and from the first to
the last. ``--breakdown`` times, on each sheet, a tick (its Newton steps from the world's count) and, at one tick's
state, the pieces a Newton step is made of: the residual with its gradient and Hessian blocks, the Newton system
(assembled, factorised and solved) and its solve alone; what a tick costs beyond its Newton systems is what a faster
linear solver could not remove. Prints Markdown tables for benchmarks/RESULTS.md.
"""

from __future__ import annotations

import argparse
import platform
import time

import numpy as np

from morphbench.params import DEFAULT_PHYSICS, FAST_PHYSICS
from morphbench.physics import PlanarWorld, make_world
from morphbench.shapes import shape_from_table

SHAPES = [
    ("chain", 1, 1), ("chain", 1, 3), ("chain", 1, 10), ("chain", 1, 20),
    ("grid", 2, 2), ("grid", 3, 3), ("grid", 5, 5), ("grid", 10, 10),
]


SHEETS = [10, 20, 32, 64, 100]
"""sides of the square sheets: 100, 400, 1,024, 4,096 and 10,000 units."""


def shape_of(kind: str, rows: int, columns: int):
    assembly = {"generator": "chain", "units": columns} if kind == "chain" else \
        {"generator": "grid", "rows": rows, "columns": columns, "actuated_axes": ["x", "y"], "dummy": kind != "sheet"}
    return shape_from_table({"assembly": assembly}, source=f"{kind}-{rows}x{columns}")


def seconds_per_second(shape, physics, simulated: float, warm_up: float = 1.0, build=make_world) -> tuple[float, float]:
    """Wall and process CPU seconds per simulated second (on a shared machine the CPU time is what one core alone
    would take: the wall time counts the waits for a core)."""
    with build(shape, physics) as world:
        world.set_phases(np.random.default_rng(0).random(shape.n_units))
        world.advance(world.ticks_in(warm_up))
        wall, cpu = time.perf_counter(), time.process_time()
        world.advance(world.ticks_in(simulated))
        return (time.perf_counter() - wall) / simulated, (time.process_time() - cpu) / simulated


def _best(call, repeats: int = 5) -> float:
    """Process seconds of the fastest of ``repeats`` calls."""
    best = np.inf
    for _ in range(repeats):
        started = time.process_time()
        call()
        best = min(best, time.process_time() - started)
    return best


def breakdown(side: int, ticks: int) -> dict:
    """CPU ms of a tick of a side x side sheet on the sparse path, its Newton steps, and at the state a tick starts
    from: one residual evaluation, one Newton system (assembled, factorised, solved), its solve alone."""
    from morphbench.physics import cholesky
    from morphbench.physics import planar as P

    shape = shape_of("sheet", side, side)
    world = PlanarWorld(shape, DEFAULT_PHYSICS, sparse=True)
    world.set_phases(np.random.default_rng(0).random(shape.n_units))
    world.advance(world.ticks_in(0.5))  # moving, and numba's caches loaded
    seen, solve = {}, world._solve

    def capture(lengths, limits, *rest):
        seen.setdefault("tick", (world.q.copy(), world._last.copy(), lengths[0].copy(), limits[0].copy()))
        return solve(lengths, limits, *rest)

    world._solve = capture
    steps, started = world.newton_steps, time.process_time()
    world.advance(ticks)
    tick = (time.process_time() - started) / ticks
    newton = (world.newton_steps - steps) / ticks
    q, last, lengths, limits = seen["tick"]
    n, links = len(q), len(world._front)
    scale = np.ones(3 * n)
    scale[2::3] = world._rho
    work = P._workspace(n, links, True)
    pattern = world._pattern
    system = (pattern, np.zeros((len(pattern.rows), 3, 3)), np.empty(n, dtype=np.int64), np.empty((n, 3)))
    springs, cap = world._springs(), shape.actuator.max_force
    geometry = (world._front, world._rear, world._plane_axes, world.intact, springs)
    z = last.ravel() * scale
    top = P._step_size(q, *geometry, lengths, scale, work)
    gamma = 1.0 / top
    residual = _best(lambda: P._residual(q, z, scale, *geometry, cap, lengths, limits, gamma, work))
    active = (work[4].reshape(n, 3) != 0.0).any(axis=1)
    rest = np.where(np.repeat(active, 3), 0.0, -z)
    dz = rest.copy()

    def step():
        dz[:] = rest
        P._sparse_step(z, work, limits, gamma, 1e-9 * top, active, world._front, world._rear, world.intact, system,
                       dz)

    system_time = _best(step)
    x = system[3].copy()
    solve_time = _best(lambda: cholesky.solve(system[1], pattern.columns, pattern.rows, x.copy()))
    return {"units": shape.n_units, "tick": tick * 1e3, "newton": newton, "residual": residual * 1e3,
            "system": system_time * 1e3, "solve": solve_time * 1e3, "sliding": float(active.mean())}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="simulated seconds per row")
    parser.add_argument("--sheet-seconds", type=float, default=2.0, help="simulated seconds per sheet")
    parser.add_argument("--sheets-only", action="store_true", help="only the square sheets")
    parser.add_argument("--banded", action="store_true", help="the sheets of up to 1,024 units on the planar "
                        "solver's banded path (what every shape had before the sparse one; beyond, its dense "
                        "Hessians take gigabytes)")
    parser.add_argument("--breakdown", action="store_true", help="where a tick of the sparse solver goes, per sheet")
    parser.add_argument("--ticks", type=int, default=24, help="ticks timed per sheet with --breakdown")
    args = parser.parse_args()
    print(f"# {time.strftime('%Y-%m-%d')} {platform.machine()}  python {platform.python_version()}")
    if args.breakdown:
        print("| square sheet | units | CPU ms per tick | Newton steps per tick | bodies sliding | residual, ms | "
              "Newton system (assembled, factorised, solved), ms | its solve alone, ms | a tick beyond its Newton "
              "systems, ms | that part, s per simulated s |")
        print("|---|---|---|---|---|---|---|---|---|---|")
        for side in SHEETS:
            row = breakdown(side, args.ticks)
            beyond = row["tick"] - row["newton"] * row["system"]
            print(f"| {side} x {side} | {row['units']} | {row['tick']:.1f} | {row['newton']:.1f} | "
                  f"{row['sliding']:.0%} | {row['residual']:.2f} | {row['system']:.1f} | {row['solve']:.2f} | "
                  f"{beyond:.1f} | {beyond / 1e3 / DEFAULT_PHYSICS.timestep:.2f} |", flush=True)
        return
    if not args.sheets_only:
        print("| shape | units | bodies | default backend | default wall s per simulated s | "
              "PyBullet fast wall s per simulated s |")
        print("|---|---|---|---|---|---|")
        for kind, rows, columns in SHAPES:
            shape = shape_of(kind, rows, columns)
            with make_world(shape, DEFAULT_PHYSICS) as world:
                backend = type(world).__name__
            default = seconds_per_second(shape, DEFAULT_PHYSICS, args.seconds)[0]
            fast = seconds_per_second(shape, FAST_PHYSICS, args.seconds)[0]
            name = f"chain-{columns}" if kind == "chain" else f"grid-{rows}x{columns}-xy"
            print(f"| {name} | {shape.n_units} | {len(shape.bodies)} | {backend} | {default:.4f} | {fast:.4f} |",
                  flush=True)
        print()
    print("| square sheet | units | links | default wall s per simulated s | CPU s per simulated s | "
          "exponent (CPU) from the sheet before |")
    print("|---|---|---|---|---|---|")
    costs = []
    build = (lambda shape, physics: PlanarWorld(shape, physics, sparse=False)) if args.banded else make_world
    for side in [side for side in SHEETS if side <= 32] if args.banded else SHEETS:
        shape = shape_of("sheet", side, side)
        wall, cost = seconds_per_second(shape, DEFAULT_PHYSICS, args.sheet_seconds, args.sheet_seconds / 4, build)
        exponent = f"{np.log(cost / costs[-1][1]) / np.log(shape.n_units / costs[-1][0]):.2f}" if costs else ""
        costs.append((shape.n_units, cost))
        print(f"| {side} x {side} | {shape.n_units} | {len(shape.links)} | {wall:.4f} | {cost:.4f} | {exponent} |",
              flush=True)
    (first, low), (last, high) = costs[0], costs[-1]
    print(f"\nexponent (CPU) from {first} to {last} units: {np.log(high / low) / np.log(last / first):.2f}")


if __name__ == "__main__":
    main()
