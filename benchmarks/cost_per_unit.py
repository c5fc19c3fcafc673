"""Wall time per simulated second against the number of units, on the default physics and on PyBullet fast.

    python benchmarks/cost_per_unit.py            # chains and grids of 1 to 100 units, 20 simulated s each;
                                                  # then square sheets of 100 to 10,000 units, 2 simulated s each
    python benchmarks/cost_per_unit.py --sheets-only --sheet-seconds 1
    python benchmarks/cost_per_unit.py --sheets-only --banded    # the sheets on the banded solver, up to 1,024 units
    python benchmarks/cost_per_unit.py --breakdown               # where a tick of the sparse solver goes, per sheet
    python benchmarks/cost_per_unit.py --run-loop                # sheets of 100 to 10,000 units learning on the
                                                                 # dynamic backend, through the run loop
    git archive COMMIT | tar -x -C /tmp/before && python benchmarks/cost_per_unit.py --run-loop --compare /tmp/before
                                                  # the same, and an earlier commit's package side by side

``--run-loop`` measures what issue 36's targets are about: CPU seconds per simulated second of a learning run of a
square sheet (no dummies, bellows along x and y; 100, 1,024, 4,096 and 10,000 units) on ``--backend`` (dynamic by
default) with the ideal sensor and the default learner, through the path ``morphbench run`` takes: a
``experiment.driver.Driver`` of one run, its warm-up and learning steps (physics, sensing, validity checks, learners,
records, the progress callback's ``last_ubar``), then its records and figures written as the command writes them.
The figure is the CPU time of the warm-up and the steps over their simulated time (2 s and 4 s a step); building the
world and writing the records are once per run, given in seconds beside it, and the physics' share (the world's
``advance``) with the run loop's CPU beyond it. The cost exponent is fitted (least squares of log cost on log units)
from 100 to 10,000 units, and given from each sheet to the next. Each sheet runs in a process of its own with
``--compare`` (this checkout's package and the other's, one sheet after the other), after a run of a 3 x 3 sheet that
loads numba's caches.

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
import json
import os
import platform
import subprocess
import sys
import tempfile
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

RUN_SHEETS = {10: 40, 32: 12, 64: 5, 100: 3}
"""``--run-loop``: side of each square sheet (100, 1,024, 4,096 and 10,000 units) and the learning steps it runs
after step 0 (4 simulated s each), a few CPU seconds of each."""


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


def run_loop_cost(side: int, steps: int, backend: str = "dynamic") -> dict:
    """A learning run of a side x side sheet on ``backend`` with the ideal sensor, as ``morphbench run`` makes it: CPU
    seconds of building it, of its warm-up and steps (and of the world's ``advance`` among them), their simulated
    seconds, and the CPU seconds of writing its records and figures. Written against the interfaces of the commit
    before issue 36's run loop work too, so that ``--compare`` can time that commit's package with it."""
    import dataclasses

    from morphbench import plots
    from morphbench.experiment.driver import Driver
    from morphbench.experiment.run import RunConfig
    from morphbench.params import PhysicsParams, SensorParams

    physics = dataclasses.replace(PhysicsParams(), backend=backend)

    def config(side: int, steps: int) -> RunConfig:
        return RunConfig(shape=shape_of("sheet", side, side), physics=physics, sensor=SensorParams(kind="ideal"),
                         steps=steps, seed=0)

    def learn(config: RunConfig, timed: dict | None = None) -> Driver:
        started = time.process_time()
        driver = Driver([config])
        world = driver.batch.worlds[0]
        cls = type(world)
        advance, spent = cls.advance, [0.0]

        def timed_advance(self, *args, **kwargs):  # the physics: the world's ticks, its callbacks' pose reads
            begun = time.process_time()
            try:
                return advance(self, *args, **kwargs)
            finally:
                spent[0] += time.process_time() - begun

        built = time.process_time()
        cls.advance = timed_advance
        try:
            with driver.batch:
                driver.warm_up()
                for step in range(config.steps + 1):
                    if not driver.going():
                        break
                    driver.step(step)
                    for index, records in enumerate(driver.records):  # what the progress bar reads each step
                        if driver.outcome[index] is None and records.n_steps:
                            float(records.last_ubar)
                learned = time.process_time()
                driver.finish()
        finally:
            cls.advance = advance
        if timed is not None:
            timed.update(build=built - started, learn=learned - built, physics=spent[0], simulated=world.time)
        return driver

    learn(config(3, 1))  # numba's caches loaded, the modules imported
    timed = {"units": side * side, "links": len(shape_of("sheet", side, side).links), "steps": steps}
    driver = learn(config(side, steps), timed)
    outcome = driver.outcome[0]
    if isinstance(outcome, BaseException):
        raise outcome
    started = time.process_time()
    with tempfile.TemporaryDirectory() as directory:
        def figures(path):
            plots.learning_curve(outcome.steps(), outcome.units(), path / "learning_curve.png", title="cost")
            plots.trajectory_figure(outcome.steps(), path / "trajectory.png", title="cost")

        outcome.write(os.path.join(directory, "run"), figures)
    timed["write"] = time.process_time() - started
    return timed


def run_loop_elsewhere(tree: str, side: int, steps: int, backend: str) -> dict:
    """``run_loop_cost`` in a process of its own with the package of ``tree`` (a checkout of this or another
    commit)."""
    code = ("import json, sys; sys.path.insert(0, sys.argv[1]); import cost_per_unit; "
            "print(json.dumps(cost_per_unit.run_loop_cost(int(sys.argv[2]), int(sys.argv[3]), sys.argv[4])))")
    tree = os.path.abspath(tree)
    out = subprocess.run([sys.executable, "-c", code, os.path.dirname(os.path.abspath(__file__)), str(side),
                          str(steps), backend], env={**os.environ, "PYTHONPATH": tree}, cwd=tree,
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def fitted_exponent(units, costs) -> float:
    """The least-squares slope of log cost against log units."""
    return float(np.polyfit(np.log(units), np.log(costs), 1)[0])


def run_loop_table(args) -> None:
    """``--run-loop``: the sheets' learning runs (each the best of ``--repeat``), and with ``--compare`` the other
    checkout's side by side, the two alternating."""
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    sheets = {side: args.run_steps or RUN_SHEETS.get(side, 1) for side in args.sides}
    compare = ["before: ", "after: "] if args.compare else [""]
    print(f"{args.backend} backend, ideal sensor, thermal learner, seed 0, best of {args.repeat}: CPU s per simulated "
          "s of the warm-up and the learning steps (physics, sensing, validity, learners, records), the world's "
          "advance alone and the run loop beyond it; CPU s of building the run and of writing its records and "
          "figures\n")
    print("| square sheet | units | links | steps | simulated s | " + " | ".join(
        f"{label}{column}" for label in compare for column in (
            "CPU s per simulated s", "physics, s per simulated s", "run loop beyond physics, s per simulated s",
            "build, s", "write, s")) + (" | after / before |" if args.compare else " |"))
    print("|---" * (5 + 5 * len(compare) + (1 if args.compare else 0)) + "|")
    rows = {label: [] for label in compare}
    for side, steps in sheets.items():
        measured = {label: [] for label in compare}
        for _ in range(args.repeat):
            for label in compare:
                if args.compare:
                    tree = args.compare if label == "before: " else here
                    measured[label].append(run_loop_elsewhere(tree, side, steps, args.backend))
                else:
                    measured[label].append(run_loop_cost(side, steps, args.backend))
        cells = []
        for label in compare:
            runs = measured[label]
            simulated = runs[0]["simulated"]
            best = {key: min(run[key] for run in runs) for key in ("learn", "physics", "build", "write")}
            beyond = min(run["learn"] - run["physics"] for run in runs)
            rows[label].append((runs[0]["units"], best["learn"] / simulated))
            cells += [f"{best['learn'] / simulated:.4f}", f"{best['physics'] / simulated:.4f}",
                      f"{beyond / simulated:.4f}", f"{best['build']:.2f}", f"{best['write']:.2f}"]
        ratio = f" {rows['after: '][-1][1] / rows['before: '][-1][1]:.2f} |" if args.compare else ""
        some = measured[compare[-1]][0]
        print(f"| {side} x {side} | {some['units']:,} | {some['links']:,} | {steps} | {some['simulated']:g} | "
              + " | ".join(cells) + " |" + ratio, flush=True)
    print()
    for label in compare:
        units, costs = (np.array(column) for column in zip(*rows[label]))
        steps = ", ".join(f"{np.log(costs[i + 1] / costs[i]) / np.log(units[i + 1] / units[i]):.2f} "
                          f"({units[i]:,} -> {units[i + 1]:,})" for i in range(len(units) - 1))
        fitted = (units >= 100) & (units <= 10_000)
        if fitted.sum() >= 2:
            first, last = np.flatnonzero(fitted)[[0, -1]]
            end_to_end = np.log(costs[last] / costs[first]) / np.log(units[last] / units[first])
            print(f"{label or 'cost '}exponent from {units[first]:,} to {units[last]:,} units: fitted "
                  f"{fitted_exponent(units[fitted], costs[fitted]):.2f}, end to end {end_to_end:.2f}; from each "
                  f"sheet to the next {steps}")
        else:
            print(f"{label or 'cost '}exponent from each sheet to the next {steps}")


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
    parser.add_argument("--run-loop", action="store_true", help="learning runs of sheets of 100 to 10,000 units "
                        "through the run loop (ideal sensor), CPU s per simulated s, and the cost exponent")
    parser.add_argument("--backend", default="dynamic", help="with --run-loop: the physics backend (default dynamic)")
    parser.add_argument("--run-steps", type=int, help="with --run-loop: learning steps of every sheet (default: "
                        "40, 12, 5 and 3 from the smallest, 1 for another side)")
    parser.add_argument("--sides", type=int, nargs="+", default=list(RUN_SHEETS), help="with --run-loop: the "
                        "sheets' sides (default 10 32 64 100; 316 is 99,856 units)")
    parser.add_argument("--repeat", type=int, default=1, help="with --run-loop: runs of each sheet (and tree), the "
                        "best CPU time of each column kept")
    parser.add_argument("--compare", metavar="TREE", help="with --run-loop: a checkout of an earlier commit to time "
                        "side by side (each sheet in a process of its own, this checkout's too)")
    args = parser.parse_args()
    print(f"# {time.strftime('%Y-%m-%d')} {platform.machine()} {_cpu_model()}, {os.cpu_count()} cores  "
          f"python {platform.python_version()}")
    if args.run_loop:
        run_loop_table(args)
        return
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


def _cpu_model() -> str:
    """The processor's model name (/proc/cpuinfo), else what platform says."""
    try:
        with open("/proc/cpuinfo", encoding="ascii", errors="replace") as cpuinfo:
            for line in cpuinfo:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown processor"


if __name__ == "__main__":
    main()
