"""Process CPU time of a batch of runs (``run_batch``: the seeds of one condition in one batched world), and how
much of it is the solver, per run and learning step.

    python benchmarks/batch_speed.py                        # chain-3 (28 seeds x 300 steps), chain-7, chain-20
    git worktree add /tmp/before COMMIT && python benchmarks/batch_speed.py --compare /tmp/before
                                                            # against an earlier commit, alternately, side by side
    python benchmarks/batch_speed.py --sizes                # 112 seeds in batches of 28, 56 and 112 (BATCH_SEEDS)

The paper suite runs its conditions as such batches (up to 28 seeds, ideal sensor, the quasi-static chain solver):
the time outside the solver is the Python around each learning step. Each figure is the best of ``--repeats``
batches in one process after a warm-up batch (numba's caches loaded); with ``--compare`` the two checkouts run in
turn, ``--rounds`` times, each in a process of its own, and the table gives each one's best.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

CASES = (("chain-3", 300), ("chain-7", 60), ("chain-20", 60))
SEEDS = 28


def measure(repeats: int) -> dict:
    """Per case: the best CPU seconds of a batch, and the solver's share of that batch."""
    from morphbench.experiment import RunConfig
    from morphbench.experiment.driver import run_batch
    from morphbench.params import SensorParams
    from morphbench.physics import quasistatic
    from morphbench.shapes import load_shape

    solve, spent = quasistatic._solve_ticks, [0.0]

    def timed(*args, **kwargs):
        started = time.process_time()
        try:
            return solve(*args, **kwargs)
        finally:
            spent[0] += time.process_time() - started

    quasistatic._solve_ticks = timed  # the batched world calls it through the module
    out = {}
    root = Path(__file__).resolve().parent.parent
    for name, steps in CASES:
        shape = load_shape(root / "shapes" / f"{name}.toml")
        configs = [RunConfig(shape=shape, steps=steps, seed=seed, sensor=SensorParams(kind="ideal"))
                   for seed in range(SEEDS)]
        run_batch(configs[:2])
        best = None
        for _ in range(repeats):
            spent[0] = 0.0
            started = time.process_time()
            run_batch(configs)
            total = time.process_time() - started
            if best is None or total < best[0]:
                best = (total, spent[0])
        out[name] = {"steps": steps, "cpu_s": best[0], "solver_s": best[1]}
    return out


def sizes(repeats: int) -> None:
    """CPU of 112 seeds (150 steps) run in batches of 28, 56 and 112, chain-3 and chain-20: what a batch's size
    saves."""
    from morphbench.experiment import RunConfig
    from morphbench.experiment.driver import run_batch
    from morphbench.params import SensorParams
    from morphbench.shapes import load_shape

    root = Path(__file__).resolve().parent.parent
    print("| shape, 112 seeds x 150 steps | batches of 28: CPU s | of 56 | of 112 | 28 over 112 |")
    print("|---|---|---|---|---|")
    for name in ("chain-3", "chain-20"):
        shape = load_shape(root / "shapes" / f"{name}.toml")
        configs = [RunConfig(shape=shape, steps=150, seed=seed, sensor=SensorParams(kind="ideal"))
                   for seed in range(112)]
        run_batch(configs[:2])
        best = {}
        for _ in range(repeats):
            for size in (28, 56, 112):
                started = time.process_time()
                for first in range(0, len(configs), size):
                    run_batch(configs[first:first + size])
                best[size] = min(best.get(size, float("inf")), time.process_time() - started)
        print(f"| {name} | {best[28]:.2f} | {best[56]:.2f} | {best[112]:.2f} | {best[28] / best[112]:.2f} |",
              flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--compare", help="another checkout of morphbench, timed alternately with this one")
    parser.add_argument("--rounds", type=int, default=2, help="with --compare: processes per checkout")
    parser.add_argument("--sizes", action="store_true", help="112 seeds in batches of 28, 56 and 112")
    parser.add_argument("--json", action="store_true", help=argparse.SUPPRESS)  # one process's figures
    args = parser.parse_args()
    if args.sizes:
        sizes(args.repeats)
        return
    if args.json:
        print(json.dumps(measure(args.repeats)))
        return
    here = str(Path(__file__).resolve().parent.parent)
    checkouts = {"this": here} if args.compare is None else {"before": str(Path(args.compare).resolve()),
                                                             "after": here}
    best: dict[str, dict] = {}
    for _ in range(args.rounds if args.compare else 1):
        for label, root in checkouts.items():
            env = {**os.environ, "PYTHONPATH": root}
            output = subprocess.run([sys.executable, __file__, "--json", "--repeats", str(args.repeats)], env=env,
                                    capture_output=True, text=True, check=True, cwd=root).stdout
            for name, figures in json.loads(output).items():
                kept = best.setdefault(label, {}).get(name)
                if kept is None or figures["cpu_s"] < kept["cpu_s"]:
                    best[label][name] = figures
    print(f"{time.strftime('%Y-%m-%d')}, {platform.python_version()}, {platform.machine()}, {os.cpu_count()} cores; "
          f"{SEEDS} seeds a batch, ideal sensor, best of {args.repeats} (x {args.rounds} processes with --compare)")
    print()
    labels = list(checkouts)
    head = " | ".join(f"{label}: CPU s, solver s, us per run-step" for label in labels)
    print(f"| batch | {head} |" + (" ratio |" if args.compare else ""))
    print("|---|" + "---|" * (len(labels) + bool(args.compare)))
    for name, steps in CASES:
        cells = []
        for label in labels:
            f = best[label][name]
            cells.append(f"{f['cpu_s']:.2f}, {f['solver_s']:.2f}, {1e6 * f['cpu_s'] / SEEDS / steps:.0f}")
        ratio = f" {best['before'][name]['cpu_s'] / best['after'][name]['cpu_s']:.2f} |" if args.compare else ""
        print(f"| {name}, {SEEDS} seeds x {steps} steps | " + " | ".join(cells) + " |" + ratio)


if __name__ == "__main__":
    main()
