"""Wall time of a learning run, and its overhead over raw PyBullet stepping of the same bodies.

    python benchmarks/run_speed.py                 # chain-3 and chain-20, 300 learning steps each
    python benchmarks/run_speed.py --steps 50      # quicker
    git worktree add /tmp/before COMMIT && python benchmarks/run_speed.py --compare /tmp/before
                                                   # against an earlier commit, side by side

Each row times the PyBullet world at the fast setting (with its overhead over bare stepping) and the default
physics (the quasi-static model for a chain; targets chain-3 <= 1 s, chain-20 <= 3 s), after one warm-up run that
loads the compiled solvers from numba's cache.

For each shape and sensor (ideal, optical) it times one full run (``morphbench.experiment.run``: pressures, bellows
forces, sensors, learners, records), then, in the same process, the bare ``stepSimulation`` loop of a world with the
same bodies, timestep and number of ticks (no forces, no sensing). The overhead ratio is run time / bare stepping
time. Targets on one core: chain-3 in <= 10 s, chain-20 in <= 60 s, overhead <= 1.2. The call floor is bare stepping
plus the three PyBullet calls per body and tick that explicit link forces cannot do without (a pose read, a force, a
torque), over bare stepping: no run with such links can have a lower overhead ratio.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import platform
import subprocess
import sys
import time

import pybullet as pb

from morphbench.experiment import RunConfig, run
from morphbench.params import FAST_PHYSICS, SensorParams
from morphbench.physics import World
from morphbench.shapes import load_shape


def bare_stepping(shape, n_ticks: int, with_calls: bool = False) -> float:
    """Seconds for n_ticks stepSimulation calls on the same world, nothing else. With ``with_calls``, each tick
    also makes the fewest PyBullet calls any explicit link force needs (one pose read, one force and one torque
    per body, all zero): the floor of the overhead ratio for links that are not PyBullet constraints."""
    with World(shape) as world:
        client, bodies = world.client, world.bodies
        get_pose, push, turn, frame, zero = (pb.getBasePositionAndOrientation, pb.applyExternalForce,
                                             pb.applyExternalTorque, pb.WORLD_FRAME, [0.0, 0.0, 0.0])
        started = time.perf_counter()
        for _ in range(n_ticks):
            if with_calls:
                for uid in bodies:
                    position, _ = get_pose(uid, physicsClientId=client)
                    push(uid, -1, zero, position, frame, physicsClientId=client)
                    turn(uid, -1, zero, frame, physicsClientId=client)
            pb.stepSimulation(physicsClientId=client)
        return time.perf_counter() - started


def run_time(path: str, steps: int, sensor: str, physics=None) -> tuple[float, float]:
    """Wall time of one run and its simulated time (s); ``physics`` None is the default."""
    config = RunConfig(shape=load_shape(path), steps=steps, seed=0, sensor=SensorParams(kind=sensor))
    if physics is not None:
        config = dataclasses.replace(config, physics=physics)
    records = run(config)
    return records.wall_time, float(records.steps().time_s.iloc[-1])


def run_time_elsewhere(tree: str, path: str, steps: int, sensor: str) -> float:
    """Wall time of the same run, at that checkout's defaults, with the package of another checkout (a worktree of
    an earlier commit)."""
    code = ("import json, sys; sys.path.insert(0, sys.argv[1]); sys.path.insert(0, sys.argv[5]);"
            "import run_speed; print(json.dumps(run_speed.run_time(sys.argv[2], int(sys.argv[3]), sys.argv[4])))")
    env = {**os.environ, "PYTHONPATH": tree}
    out = subprocess.run([sys.executable, "-c", code, tree, path, str(steps), sensor, os.path.dirname(__file__)],
                         env=env, capture_output=True, text=True, check=True, cwd=tree)
    return json.loads(out.stdout.strip().splitlines()[-1])[0]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=300)
    parser.add_argument("--compare", metavar="TREE", help="a checkout of an earlier commit to time side by side")
    parser.add_argument("shapes", nargs="*", default=["shapes/chain-3.toml", "shapes/chain-20.toml"])
    args = parser.parse_args()
    print(f"# {time.strftime('%Y-%m-%d')} {platform.machine()} {platform.processor() or ''} "
          f"python {platform.python_version()}")
    print("| shape | sensor | learning steps | simulated s | PyBullet fast wall s | bare stepping s | overhead ratio | "
          "call floor ratio | default wall s |"
          + (" earlier commit (its default) wall s | default now / earlier |" if args.compare else ""))
    print("|---|---|---|---|---|---|---|---|---|" + ("---|---|" if args.compare else ""))
    run_time(args.shapes[0], 2, "ideal")  # load the compiled solvers once
    for path in args.shapes:
        shape = load_shape(path)
        for sensor in ("ideal", "optical"):
            wall, simulated = run_time(path, args.steps, sensor, FAST_PHYSICS)  # the pumps' clock: every step
            with World(shape) as world:
                n_ticks = world.ticks_in(simulated)
            bare = bare_stepping(shape, n_ticks)
            floor = bare_stepping(shape, n_ticks, with_calls=True)
            default, _ = run_time(path, args.steps, sensor)
            row = (f"| {shape.name} | {sensor} | {args.steps} | {simulated:.0f} | {wall:.2f} | {bare:.2f} | "
                   f"{wall / bare:.2f} | {floor / bare:.2f} | {default:.2f} |")
            if args.compare:
                before = run_time_elsewhere(args.compare, os.path.abspath(path), args.steps, sensor)
                row += f" {before:.2f} | {default / before:.2f} |"
            print(row, flush=True)


if __name__ == "__main__":
    main()
