"""The seeds of one condition run together: one quasi-static world holds a copy of the assembly per run, and the
runs' loops take their learning steps in lockstep, so the simulator is called once per step for all of them.

    records = run_batch([config_seed_0, config_seed_1, ...])   # RunRecords, or the exception that ended that run

Only the seed may differ between the configurations (``batchable`` says which configurations can be batched: a
chain on the quasi-static model with a sensor that needs no PyBullet scene). Each copy of the assembly is its own
piece of the batched world (copies share no link, so the solver treats them one by one, with the same arithmetic as
a world of one), and each run keeps its own loop: its controller, sensors, noise streams, events, validity checks
and records. So every run's records equal those of ``run`` with the same configuration, bit for bit
(tests/test_batch.py). A run that fails (a plug-in error, a PhysicsError) stops alone: its copy goes on moving,
unseen, and the other runs finish.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from morphbench.errors import ConfigError
from morphbench.experiment.records import RunRecords
from morphbench.experiment.run import RunConfig, RunLoop
from morphbench.learning import load_learner_class, make_controller
from morphbench.physics import QuasiStaticWorld, make_world
from morphbench.shapes.model import Shape


def batchable(config: RunConfig) -> bool:
    """Whether ``config`` runs on the quasi-static chain model (the batched world) with a sensor needing no scene."""
    if config.sensor.kind == "camera" or config.physics.backend not in ("auto", "quasistatic"):
        return False
    try:
        world = make_world(config.shape, config.physics, config.environment)
    except ConfigError:
        return False
    with world:
        return isinstance(world, QuasiStaticWorld)


def run_batch(configs: list[RunConfig]) -> list[RunRecords | BaseException]:
    """Run ``configs`` (equal but for their seeds, all ``batchable``) together; per configuration its records, or
    the exception that stopped it. Each record's wall time is the batch's shared out evenly."""
    first = configs[0]
    for config in configs[1:]:
        if dataclasses.replace(config, seed=first.seed) != first:
            raise ValueError("run_batch: configurations must differ only in their seeds")
    started = time.perf_counter()
    world = QuasiStaticWorld(_copies(first.shape, len(configs)), first.physics, first.environment)
    loops = []
    for index, config in enumerate(configs):
        controller = make_controller(load_learner_class(config.learner), config.learner_params, config.seed,
                                     config.shape.n_units)
        loops.append(RunLoop(config, controller, _Copy(world, index, config.shape), None))
    records = [RunRecords(config) for config in configs]
    outcome: list[RunRecords | BaseException | None] = [None] * len(configs)
    n = first.shape.n_units

    def each(action) -> dict:
        """``action(index, loop)`` for every run still going, by index; a run whose action raises stops there."""
        done = {}
        for index, loop in enumerate(loops):
            if outcome[index] is None:
                try:
                    done[index] = action(index, loop)
                except (Exception, SystemExit) as exc:  # the run's failure, as run() would raise it
                    outcome[index] = exc
        return done

    each(lambda index, loop: loop.world.set_phases(loop.kept))
    world.advance(loops[0].warmup_ticks)
    for step in range(first.steps + 1):
        applied = each(lambda index, loop: loop.apply_events(step))
        tried = each(lambda index, loop: loop.propose(step))
        world.advance(loops[0].discard_ticks)
        measurements = each(lambda index, loop: loop.start_measurement())
        every = next(iter(measurements.values())).every if measurements else 1
        positions, orientations = world.advance_sampled(loops[0].measured_ticks, every)

        def finish(index, loop):
            mine = slice(index * n, (index + 1) * n)
            samples = np.ascontiguousarray(positions[:, mine]), np.ascontiguousarray(orientations[:, mine])
            loop.finish_step(step, records[index], applied[index], tried[index], measurements[index], samples)

        each(finish)
    wall = (time.perf_counter() - started) / len(configs)
    for index, record in enumerate(records):
        if outcome[index] is None:
            record.finish(wall_time=wall)
            outcome[index] = record
    return outcome


def _copies(shape: Shape, count: int) -> Shape:
    """``count`` copies of ``shape`` in one shape, each on the same place, joined to none of the others: copy c's
    body b is body c * n_bodies + b, its link l link c * n_links + l."""
    n = len(shape.bodies)
    links = tuple(dataclasses.replace(link, front=link.front + c * n, rear=link.rear + c * n,
                                      unit=None if link.unit is None else link.unit + c * n)
                  for c in range(count) for link in shape.links)
    return dataclasses.replace(shape, bodies=shape.bodies * count, links=links)


class _Copy:
    """What one run's loop sees of a batched world: its own copy's bodies, units and links, the shared clock. The
    batch advances every copy at once, so a copy cannot be advanced alone."""

    client = None

    def __init__(self, world: QuasiStaticWorld, index: int, shape: Shape):
        self.world, self.shape = world, shape
        self._bodies = index * len(shape.bodies)
        self._units = index * shape.n_units
        self._links = index * len(shape.links)
        self._n_bodies = len(shape.bodies)

    @property
    def time(self) -> float:
        return self.world.time

    def ticks_in(self, duration: float) -> int:
        return self.world.ticks_in(duration)

    def set_phases(self, phases) -> None:
        phases = np.asarray(phases, dtype=float)
        if phases.shape != (self.shape.n_units,):
            raise ValueError(f"expected {self.shape.n_units} phases, got {phases.shape}")
        self.world.phases[self._units:self._units + len(phases)] = np.mod(phases, 1.0)

    def poses(self, which=None) -> tuple[np.ndarray, np.ndarray]:
        index = np.arange(self._n_bodies) if which is None else np.asarray(which, dtype=int)
        return self.world.poses(self._bodies + index)

    def unit_poses(self) -> tuple[np.ndarray, np.ndarray]:
        return self.poses(self.shape.units)

    def pieces(self) -> list[list[int]]:
        first, last = self._bodies, self._bodies + self._n_bodies
        return [[body - first for body in piece] for piece in self.world.pieces() if first <= piece[0] < last]

    def set_damage(self, unit: int, mode: str) -> None:
        self.world.set_damage(self._units + unit, mode)

    def set_friction_scale(self, scale: float) -> None:
        self.world.set_friction_scale(scale)  # every copy's runs change it alike: their events are the same

    def cut(self, link: int) -> None:
        self.world.cut(self._links + link)

    def advance(self, n_ticks: int, on_tick=None, pumps: bool = True, every: int = 1) -> None:
        raise RuntimeError("a copy of a batched world is advanced with all the others (run_batch)")

    advance_sampled = advance
