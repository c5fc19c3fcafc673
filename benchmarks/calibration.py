"""The calibration figures in docs/calibration.md: the 2-unit curve at the fast and reference physics, the 3-unit
landscape's maximum, and the step-to-step spread of measurements at fixed phases.

    python benchmarks/calibration.py --workers 2      # about 2 minutes on 2 cores
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from morphbench.experiment import scan
from morphbench.params import FAST_PHYSICS, REFERENCE_PHYSICS
from morphbench.physics import World
from morphbench.shapes import load_shape


def step_spread(shape, phases, steps: int = 25) -> tuple[float, float]:
    """Mean and standard deviation of Ubar over successive 2-cycle learning steps at fixed phases."""
    with World(shape) as world:
        world.set_phases(phases)
        world.advance(world.ticks_in(2 * shape.actuator.cycle_time))
        x = [world.unit_poses()[0][:, 0]]
        for _ in range(steps):
            world.advance(world.ticks_in(2 * shape.actuator.cycle_time))
            x.append(world.unit_poses()[0][:, 0])
    ubar = (np.diff(np.array(x), axis=0) * 1000 / 2).mean(axis=1)
    return float(ubar.mean()), float(ubar.std())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--resolution-3", type=int, default=20)
    args = parser.parse_args()
    chain2, chain3 = load_shape("shapes/chain-2.toml"), load_shape("shapes/chain-3.toml")
    print(f"# measured {time.strftime('%Y-%m-%d')}")
    curves = {}
    for name, physics in (("fast", FAST_PHYSICS), ("reference", REFERENCE_PHYSICS)):
        started = time.perf_counter()
        curves[name] = scan(chain2, 20, physics=physics, workers=args.workers)
        print(f"2-unit scan at {name}: {time.perf_counter() - started:.1f} s")
    fast, ref = curves["fast"].ubar.to_numpy(), curves["reference"].ubar.to_numpy()
    print("\n| dphi_2 | Ubar fast (mm/cycle) | Ubar reference (mm/cycle) |\n|---|---|---|")
    for d, f, r in zip(curves["fast"].dphi_2, fast, ref):
        print(f"| {d:.2f} | {f:+.2f} | {r:+.2f} |")
    print(f"\nfast vs reference: max |difference| {np.abs(fast - ref).max():.2f} mm/cycle, "
          f"rms {np.sqrt(np.mean((fast - ref) ** 2)):.2f}, correlation {np.corrcoef(fast, ref)[0, 1]:.3f}; "
          f"peak {fast.max():+.2f} vs {ref.max():+.2f}, minimum {fast.min():+.2f} vs {ref.min():+.2f}")
    started = time.perf_counter()
    land = scan(chain3, args.resolution_3, workers=args.workers)
    best = land.loc[land.ubar.idxmax()]
    print(f"\n3-unit landscape ({args.resolution_3}x{args.resolution_3}, {time.perf_counter() - started:.0f} s): "
          f"max {best.ubar:+.2f} mm/cycle at (dphi_2, dphi_3) = ({best.dphi_2:.2f}, {best.dphi_3:.2f}); "
          f"min {land.ubar.min():+.2f}; fraction of phase space above 2 mm/cycle {(land.ubar > 2).mean():.2f}")
    print("\n| phases | mean Ubar per 2-cycle step | std |\n|---|---|---|")
    for shape, phases in ((chain2, [0, 0.4]), (chain2, [0, 0.6]), (chain2, [0, 0.8]), (chain3, [0, 0.4, 0.8])):
        mean, std = step_spread(shape, phases)
        print(f"| {phases} | {mean:+.2f} | {std:.2f} |")


if __name__ == "__main__":
    main()
