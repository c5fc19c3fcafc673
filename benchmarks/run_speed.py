"""Wall time of a learning run, and its overhead over raw PyBullet stepping of the same bodies.

    python benchmarks/run_speed.py                 # chain-3 and chain-20, 300 learning steps each
    python benchmarks/run_speed.py --steps 50      # quicker

For each shape and sensor (ideal, optical) it times one full run (``morphbench.experiment.run``: pressures, bellows
forces, sensors, learners, records), then, in the same process, the bare ``stepSimulation`` loop of a world with the same bodies, timestep and
number of ticks (no forces, no sensing). The overhead ratio is run time / bare stepping time. Targets on one core:
chain-3 in <= 10 s, chain-20 in <= 60 s, overhead <= 1.2.
"""

from __future__ import annotations

import argparse
import platform
import time

import pybullet as pb

from morphbench.experiment import RunConfig, run
from morphbench.params import SensorParams
from morphbench.physics import World
from morphbench.shapes import load_shape


def bare_stepping(shape, n_ticks: int) -> float:
    """Seconds for n_ticks stepSimulation calls on the same world, nothing else."""
    with World(shape) as world:
        client = world.client
        started = time.perf_counter()
        for _ in range(n_ticks):
            pb.stepSimulation(physicsClientId=client)
        return time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=300)
    parser.add_argument("shapes", nargs="*", default=["shapes/chain-3.toml", "shapes/chain-20.toml"])
    args = parser.parse_args()
    print(f"# {time.strftime('%Y-%m-%d')} {platform.machine()} {platform.processor() or ''} python {platform.python_version()}")
    print("| shape | sensor | learning steps | simulated s | run wall s | bare stepping s | overhead ratio |")
    print("|---|---|---|---|---|---|---|")
    for path in args.shapes:
        shape = load_shape(path)
        for sensor in ("ideal", "optical"):
            records = run(RunConfig(shape=shape, steps=args.steps, seed=0, sensor=SensorParams(kind=sensor)))
            simulated = records.steps().time_s.iloc[-1]  # the pumps' clock: warm-up and every learning step
            with World(shape) as world:
                n_ticks = world.ticks_in(simulated)
            bare = bare_stepping(shape, n_ticks)
            print(f"| {shape.name} | {sensor} | {args.steps} | {simulated:.0f} | {records.wall_time:.2f} | {bare:.2f} | "
                  f"{records.wall_time / bare:.2f} |", flush=True)


if __name__ == "__main__":
    main()
