"""The dynamic backend against the quasi-static one: the 2-unit curve (chain-2, true Ubar over 20 phase
differences, measured as benchmarks/fidelity.py measures curves), its timestep convergence, its quasi-static limit
and the cost of a 32 x 32 sheet. Prints its figures (the issue's target: rms within 0.2 mm/cycle of the quasi-static
curve; halving the step changes the curve by less than 0.05 mm/cycle rms).

    python benchmarks/dynamic_fidelity.py                # about 10 s on one core
    python benchmarks/dynamic_fidelity.py --pybullet     # and the PyBullet fast curve beside them (a minute more)
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import numpy as np

from fidelity import CURVE_POINTS, CYCLES, DISCARD, curve, fmt, rms
from morphbench.params import DEFAULT_PHYSICS, FAST_PHYSICS, QUASISTATIC_PHYSICS, PhysicsParams
from morphbench.physics import make_world
from morphbench.shapes import load_shape, shape_from_table

ROOT = Path(__file__).resolve().parent.parent
DYNAMIC = dataclasses.replace(DEFAULT_PHYSICS, backend="dynamic")
SLOWER = (1.0, 2.0, 4.0)
"""how many times slower the pumps run (cycle time and pressure time constants) in the quasi-static limit's rows:
the quasi-static curve is the same at each, the inertial forces fall as 1 / factor^2."""


def with_step(physics: PhysicsParams, step: float) -> PhysicsParams:
    return dataclasses.replace(physics, dynamic_step=step)


def slowed(shape, factor: float):
    a = shape.actuator
    return dataclasses.replace(shape, actuator=dataclasses.replace(
        a, cycle_time=a.cycle_time * factor, tau_inflate=a.tau_inflate * factor, tau_vent=a.tau_vent * factor))


def sheet(side: int):
    """A side x side sheet of units with bellows along both axes, no dummies (as shapes/sheet-10x10.toml)."""
    return shape_from_table({"assembly": {"generator": "grid", "rows": side, "columns": side, "dummy": False,
                                          "actuated_axes": ["x", "y"]}}, source=f"sheet-{side}x{side}")


def sheet_cost(shape, physics: PhysicsParams, seconds: float, friction: float = 1.0, seed: int = 0
               ) -> tuple[float, bool, float]:
    """CPU s per simulated s of ``seconds`` of ``shape`` at random phases with every friction times ``friction``
    (after a short first advance that compiles), whether every pose stayed finite, and the fastest body's speed
    (m/s) at the end."""
    with make_world(shape, physics) as world:
        world.set_friction_scale(friction)
        world.set_phases(np.random.default_rng(seed).random(shape.n_units))
        world.advance(10)
        started = time.process_time()
        world.advance(world.ticks_in(seconds))
        cost = (time.process_time() - started) / seconds
        finite = bool(np.isfinite(world.q).all())
        return cost, finite, float(np.abs(world.v[:, :2]).max()) if finite else float("nan")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--pybullet", action="store_true", help="also measure the PyBullet fast curve")
    parser.add_argument("--side", type=int, default=32, help="the timed sheet's side (units)")
    parser.add_argument("--seconds", type=float, default=4.0, help="simulated seconds of the timed sheet")
    args = parser.parse_args()
    w, step = args.workers, DYNAMIC.dynamic_step
    started = time.perf_counter()
    chain2 = load_shape(ROOT / "shapes" / "chain-2.toml")
    print(f"dynamic: {DYNAMIC}\nquasi-static: {QUASISTATIC_PHYSICS}\nchain-2, {CURVE_POINTS} points, unit 1 at "
          f"phase 0, {DISCARD} cycles dropped, {CYCLES} measured, true Ubar (mm/cycle)\n")
    curves = {"quasi-static": curve(chain2, QUASISTATIC_PHYSICS, w)}
    for name, factor in (("dynamic, step x 2", 2.0), ("dynamic", 1.0), ("dynamic, step / 2", 0.5),
                         ("dynamic, step / 4", 0.25)):
        curves[name] = curve(chain2, with_step(DYNAMIC, step * factor), w)
    if args.pybullet:
        curves["PyBullet fast"] = curve(chain2, FAST_PHYSICS, w)
    d = np.arange(CURVE_POINTS) / CURVE_POINTS
    print("| setting | " + " | ".join(f"{x:.2f}" for x in d) + " |")
    print("|---|" + "---|" * CURVE_POINTS)
    for name, values in curves.items():
        print(f"| {name} | {fmt(values)} |")
    qs = curves["quasi-static"]
    print("\n| comparison | rms (mm/cycle) | max abs | target |\n|---|---|---|---|")
    rows = [("dynamic", "quasi-static", "rms <= 0.2"), ("dynamic", "dynamic, step / 2", "rms < 0.05"),
            ("dynamic, step x 2", "dynamic", ""), ("dynamic, step / 2", "dynamic, step / 4", "")]
    if args.pybullet:
        rows += [("dynamic", "PyBullet fast", ""), ("PyBullet fast", "quasi-static", "")]
    for a, b, target in rows:
        print(f"| {a} vs {b} | {rms(curves[a], curves[b]):.4f} | {np.abs(curves[a] - curves[b]).max():.4f} | "
              f"{target} |")
    print(f"\nstep {step:.6g} s (1/{1 / step:.0f}), {DYNAMIC.timestep / step:.3g} per tick of {DYNAMIC.timestep:.6g} s")
    peak = int(np.argmax(curves["dynamic"]))
    print(f"dynamic maximum {curves['dynamic'][peak]:+.2f} at {d[peak]:.2f} (quasi-static {qs.max():+.2f} at "
          f"{d[int(np.argmax(qs))]:.2f})")

    print("\nThe quasi-static limit: the pumps slower by a factor (friction against inertia times factor^2)")
    print("| slower by | rms dynamic vs quasi-static | max abs |\n|---|---|---|")
    for factor in SLOWER:
        shape = slowed(chain2, factor)
        a, b = curve(shape, DYNAMIC, w), curve(shape, QUASISTATIC_PHYSICS, w)
        print(f"| {factor:g} | {rms(a, b):.4f} | {np.abs(a - b).max():.4f} |")

    big = sheet(args.side)
    print(f"\nsheet-{args.side}x{args.side} ({len(big.bodies)} bodies, {len(big.links)} links), random phases, "
          f"{args.seconds:g} simulated s:")
    print("| step | friction scale | CPU s per simulated s | finite | fastest body (m/s) |\n|---|---|---|---|---|")
    for factor, friction in ((1.0, 1.0), (1.0, 0.0), (0.5, 1.0)):
        cost, finite, fastest = sheet_cost(big, with_step(DYNAMIC, step * factor), args.seconds, friction)
        print(f"| 1/{1 / (step * factor):.0f} s | {friction:g} | {cost:.4f} | {finite} | {fastest:.3g} |")
    # the step's stability bound, the lattice's fastest mode (205 rad/s at the defaults), shown without friction,
    # which would hold the bodies that it stops
    small = sheet(10)
    print("\nsheet-10x10 without friction, one step per tick:\n| step | finite | fastest body (m/s) |\n|---|---|---|")
    for hz in (120, 180, 240):
        _, finite, fastest = sheet_cost(small, dataclasses.replace(DYNAMIC, timestep=1 / hz, dynamic_step=1 / hz),
                                        args.seconds, 0.0)
        print(f"| 1/{hz} s | {finite} | {fastest:.3g} |")
    print(f"\nwall time {time.perf_counter() - started:.1f} s")


if __name__ == "__main__":
    main()
