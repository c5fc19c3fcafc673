"""Landscape scans: Ubar at fixed phases over the phase differences relative to unit 1 (no learning).

For 2 units the scan is a curve over dphi_2, for 3 a grid over (dphi_2, dphi_3); beyond that the space is sampled
at seeded random points. A scan of travelling waves (``wave_phases``) measures instead gaits of the whole assembly
that random samples miss beyond a few units: the unit in column c (counted from the front along the shape's heading,
``grid_places``; in a chain, its place) at phase c * delta mod 1, for lags delta in [0, 1). Each point is its own
world (fresh, settled, ``discard`` cycles of transient dropped), so points are independent and the result is the
same whatever the number of workers.

A scan may measure a damaged assembly: ``damage``, a DamageEvent (morphbench.experiment.events, parsed with
``parse_event(table, ..., kind="damage")``), is applied to each point's fresh world before anything moves, exactly as
the run loop applies it at its step; Ubar is then the mean over the units that are not dead, as in a run's records.
"""

from __future__ import annotations

import itertools
from contextlib import nullcontext
from dataclasses import dataclass
from concurrent.futures import ProcessPoolExecutor
from typing import Callable

import numpy as np
import pandas as pd

from morphbench.experiment.events import DamageEvent, RunState
from morphbench.experiment.run import measure
from morphbench.params import DEFAULT_PHYSICS, MAX_SCAN_POINTS, SCAN_POINT_BYTES, EnvironmentParams, PhysicsParams
from morphbench.physics import make_world
from morphbench.rules import check_plan_size
from morphbench.sensing import IdealSensor
from morphbench.shapes import Shape
from morphbench.streams import SCAN_STREAM

DEFAULT_CYCLES = 12  # cycles measured per point: the gait repeats every cycle, 12 average out slow transients
DEFAULT_DISCARD = 2  # cycles dropped first: the pressures and the chain settle into the periodic gait


def scan_size(n_units: int, resolution: int, samples: int | None = None) -> int:
    """The number of points ``scan_phases`` gives, computed without building them."""
    if n_units < 2:
        return 1
    return resolution ** (n_units - 1) if n_units <= 3 else samples or resolution * resolution


def check_scan_size(n_units: int, resolution: int, samples: int | None, source: str, key: str) -> int:
    """The number of points of a scan, or ConfigError naming ``source`` and ``key`` (the option or file key that set
    it) if it exceeds MAX_SCAN_POINTS."""
    sampled = n_units > 3 and samples
    what = f"scan points ({'samples' if sampled else f'resolution^{min(n_units - 1, 2)}'})"
    return check_plan_size(scan_size(n_units, resolution, samples), MAX_SCAN_POINTS, SCAN_POINT_BYTES, what, source,
                           key, samples if sampled else resolution)


def scan_phases(n_units: int, resolution: int, samples: int | None = None, seed: int = 0) -> np.ndarray:
    """(P, n_units) phase vectors with unit 1 at phase 0: a full grid up to 3 units, seeded samples beyond (at most
    MAX_SCAN_POINTS: ConfigError)."""
    check_scan_size(n_units, resolution, samples, "scan", "samples" if n_units > 3 and samples else "resolution")
    if n_units < 2:
        return np.zeros((1, n_units))
    if n_units <= 3:
        axis = np.arange(resolution) / resolution
        grid = np.array(list(itertools.product(axis, repeat=n_units - 1)))
    else:
        rng = np.random.default_rng(np.random.SeedSequence([seed, SCAN_STREAM]))
        grid = rng.uniform(0.0, 1.0, size=(samples or resolution * resolution, n_units - 1))
    return np.hstack([np.zeros((len(grid), 1)), grid])


def grid_places(shape: Shape) -> tuple[np.ndarray, np.ndarray]:
    """Each unit's column (0 at the front, along the heading) and row (0 on the left of the heading), in unit order:
    units whose centres are equally far along the heading (to 1 nm) share a column, those equally far across it a
    row. For a chain, a unit's column is its place (0 the front unit)."""
    xy = np.array([shape.bodies[body].position[:2] for body in shape.units])
    heading = np.asarray(shape.heading[:2], dtype=float)
    along = xy @ heading
    across = xy @ np.array([-heading[1], heading[0]])
    columns = np.unique(np.round(along, 9), return_inverse=True)[1]
    rows = np.unique(np.round(across, 9), return_inverse=True)[1]
    return columns.max() - columns, rows.max() - rows


def wave_lags(n_waves: int) -> np.ndarray:
    """The lags of ``n_waves`` travelling waves, delta in arange(n_waves) / n_waves (delta 0: every unit in phase)."""
    return np.arange(n_waves) / n_waves


def wave_phases(shape: Shape, lags) -> np.ndarray:
    """(len(lags), n_units) phase vectors of travelling waves along the heading: for each lag delta, the unit in
    column c (``grid_places``) at phase c * delta mod 1 (cycles); the front column at 0."""
    columns, _ = grid_places(shape)
    return np.mod(np.outer(np.asarray(lags, dtype=float), columns), 1.0)


@dataclass(frozen=True)
class Motion:
    """How an assembly moves at fixed phases, per pump cycle."""

    units: np.ndarray
    """mm/cycle, each unit's true velocity along its own forward axis (unit order)."""
    centroid: np.ndarray
    """mm/cycle, (x, y) velocity of the mean of all bodies' centres on the ground."""
    turning: float
    """degrees/cycle, mean rate at which the bodies turn about the vertical (> 0 counter-clockwise from above)."""
    scored: np.ndarray
    """per unit: whether it counts in Ubar (not dead), as in a run's records."""


def motion_at(shape: Shape, phases, physics: PhysicsParams = DEFAULT_PHYSICS, cycles: int = DEFAULT_CYCLES,
              discard: int = DEFAULT_DISCARD, environment: EnvironmentParams = EnvironmentParams(),
              damage: DamageEvent | None = None) -> Motion:
    """The assembly's motion at fixed phases, averaged over ``cycles`` after ``discard`` (a fresh world, damaged by
    ``damage`` from the start if given)."""
    state = RunState.initial(shape.n_units, environment.noise)
    with make_world(shape, physics, environment) as world:
        if damage is not None:
            damage.apply(world, state)
        world.set_phases(phases)
        world.advance(world.ticks_in(discard * shape.actuator.cycle_time))
        start, start_turn = world.poses()
        (displacement,) = measure(world, [IdealSensor(shape.n_units, sample_period=0.5)], cycles)
        end, end_turn = world.poses()
    # yaw change of each body from its quaternions (it turns far less than half a turn over a measurement)
    turned = 2 * (np.arctan2(end_turn[:, 2], end_turn[:, 3]) - np.arctan2(start_turn[:, 2], start_turn[:, 3]))
    turned = np.angle(np.exp(1j * turned))
    return Motion(units=displacement * 1000.0 / cycles, centroid=(end - start)[:, :2].mean(axis=0) * 1000.0 / cycles,
                  turning=float(np.degrees(turned.mean())) / cycles, scored=state.alive())


def velocity_at(shape: Shape, phases, physics: PhysicsParams = DEFAULT_PHYSICS, cycles: int = DEFAULT_CYCLES,
                discard: int = DEFAULT_DISCARD, environment: EnvironmentParams = EnvironmentParams(),
                damage: DamageEvent | None = None) -> np.ndarray:
    """True velocity of each unit (mm/cycle) at fixed phases, averaged over ``cycles`` after ``discard``."""
    return motion_at(shape, phases, physics, cycles, discard, environment, damage).units


@dataclass(frozen=True)
class ScanPoint:
    """One point of a scan: all a worker process needs to measure it."""

    shape: Shape
    phases: np.ndarray
    """cycles, one per unit (unit 1 at 0)."""
    physics: PhysicsParams = DEFAULT_PHYSICS
    cycles: int = DEFAULT_CYCLES
    discard: int = DEFAULT_DISCARD
    environment: EnvironmentParams = EnvironmentParams()
    damage: DamageEvent | None = None
    """the damage of the assembly, applied before anything moves (None: healthy)."""

    def ubar(self) -> float:
        """mm/cycle, the mean true velocity of the units at these phases (``velocity_at``), over the units that are
        not dead."""
        motion = motion_at(self.shape, self.phases, self.physics, self.cycles, self.discard, self.environment,
                           self.damage)
        return float(np.mean(motion.units[motion.scored]))


def scan(shape: Shape, resolution: int = 20, *, physics: PhysicsParams = DEFAULT_PHYSICS, cycles: int = DEFAULT_CYCLES,
         discard: int = DEFAULT_DISCARD, samples: int | None = None, seed: int = 0, workers: int = 1,
         environment: EnvironmentParams = EnvironmentParams(), damage: DamageEvent | None = None,
         progress: Callable[[int], None] | None = None) -> pd.DataFrame:
    """Ubar over phase differences: columns ``dphi_2`` ... ``dphi_N`` (cycles) and ``ubar`` (mm/cycle)."""
    phases = scan_phases(shape.n_units, resolution, samples, seed)
    jobs = [ScanPoint(shape, p, physics, cycles, discard, environment, damage) for p in phases]
    ubar = []
    with ProcessPoolExecutor(max_workers=workers) if workers > 1 else nullcontext() as pool:
        chunk = max(1, len(jobs) // (8 * workers))
        for value in pool.map(ScanPoint.ubar, jobs, chunksize=chunk) if pool else map(ScanPoint.ubar, jobs):
            ubar.append(value)
            if progress:
                progress(1)
    table = pd.DataFrame(phases[:, 1:], columns=[f"dphi_{i}" for i in range(2, shape.n_units + 1)])
    table["ubar"] = ubar
    return table
