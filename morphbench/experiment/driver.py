"""The one driver of the run loop: a batch of runs advanced step by step through the phases of ``RunLoop``.

    records = run(config)                               # a batch of one: its records, or it raises what ended it
    outcomes = run_batch([config_seed_0, config_seed_1, ...])   # RunRecords, or the exception that ended that run
    driver = Driver([config], [controller]); driver.warm_up(); driver.step(0) ...   # the environments, a step each

A run is a batch of one world (``physics.make_world(..., copies=1)``); runs that differ only in their seeds share one
world holding a copy of the assembly each when the backend can (``batchable``), so the simulator is called once per
step for all of them. Each run keeps its own loop: its controller, sensors, noise streams, events, validity checks
and records, so every run's records equal those of ``run`` with the same configuration, bit for bit
(tests/test_batch.py). A run that fails (a plug-in error, a PhysicsError) stops alone: its copy goes on moving,
unseen, and the other runs finish.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Callable

import numpy as np

from morphbench.experiment.clocks import Schedule, clocked
from morphbench.experiment.records import RunRecords
from morphbench.experiment.run import Measurement, RunConfig, RunLoop, ground_poses
from morphbench.learning import Controller, load_learner_class, make_controller
from morphbench.learning.arrays import RunView
from morphbench.learning.plugins import make_joint_controller
from morphbench.sensing import IdealSensor
from morphbench.physics import WorldInterface, can_batch, check_memory, make_world, memory_estimate


def batchable(config: RunConfig) -> bool:
    """Whether runs of ``config`` with other seeds can share one world (decided without building one)."""
    return can_batch(config.shape, config.physics, config.environment, scene=config.sensor.kind == "camera")


class Driver:
    """Runs of ``configs`` (equal but for their seeds) in one batch of worlds; ``outcome[i]`` is None while run i
    goes on, else the exception that stopped it (or, after ``finish``, its records). ``controllers`` replace the
    ones the configurations name (the environments' agents); ``on_tick(world)`` observes every tick of a batch of
    one."""

    def __init__(self, configs: list[RunConfig], controllers: list[Controller] | None = None,
                 on_tick: Callable[[WorldInterface], None] | None = None):
        first = configs[0]
        for config in configs[1:]:
            if dataclasses.replace(config, seed=first.seed) != first:
                raise ValueError("run_batch: configurations must differ only in their seeds")
        if on_tick is not None and len(configs) > 1:
            raise ValueError("Driver: an observer watches the world of one run")
        self.started = time.perf_counter()
        self.configs, self.on_tick = configs, on_tick
        self.outcome: list[RunRecords | BaseException | None] = [None] * len(configs)
        n_units, alone = first.shape.n_units, len(configs) == 1 or clocked(first.environment)
        self.joint = None if controllers is not None or alone else make_joint_controller(
            load_learner_class(first.learner), first.learner_params, [config.seed for config in configs], n_units)
        """the built-in per-unit learners of every run as one (each run's RunView its controller), or None."""
        self.joint_sensor = None if alone or first.sensor.kind != "ideal" else IdealSensor(
            n_units * len(configs), first.sensor.sample_period)
        """the ideal sensors of every run's units as one bank (each run's own then unused), or None."""
        self.slices = [slice(index * n_units, (index + 1) * n_units) for index in range(len(configs))]
        if self.joint is not None:
            controllers = [RunView(self.joint, index, n_units) for index in range(len(configs))]
        if controllers is None:
            controllers = self._each(lambda i, _: make_controller(load_learner_class(configs[i].learner),
                                                                  configs[i].learner_params, configs[i].seed,
                                                                  configs[i].shape.n_units), configs)
        cycles = max(first.learner_params.warmup_cycles, first.learner_params.discard_cycles,
                     first.learner_params.cycles_per_step) * first.shape.actuator.cycle_time
        scene = first.sensor.kind == "camera"
        check_memory(first.shape, memory_estimate(first.shape, first.physics, first.environment, scene,
                                                  round(cycles / first.physics.timestep), len(configs)))
        self.batch = make_world(first.shape, first.physics, first.environment, scene=scene, copies=len(configs))
        self.records = [RunRecords(config) for config in configs]
        self.loops: dict[int, RunLoop] = self._each(
            lambda i, world: RunLoop(configs[i], controllers[i], world, on_tick), self.batch.worlds)
        for record, world in zip(self.records, self.batch.worlds):
            record.backend = world.backend
        some = next(iter(self.loops.values()), None)
        self.ticks = (some.warmup_ticks, some.discard_ticks, some.measured_ticks) if some else (0, 0, 0)
        world = self.batch.worlds[0]
        self.observe = (lambda k: on_tick(world)) if on_tick is not None else None
        self.schedule = Schedule(self) if clocked(first.environment) else None
        """the timeline of units with clocks of their own (experiment.clocks); None: one clock, the loop below."""

    def _each(self, action, items) -> dict:
        """``action(index, item)`` for every run still going, by index; a run whose action raises stops there."""
        done = {}
        for index, item in enumerate(items):
            if self.outcome[index] is None:
                self.guard(index, lambda: done.__setitem__(index, action(index, item)))
        return done

    def guard(self, index: int, action) -> None:
        """``action()`` for run ``index``; if it raises, that run stops there."""
        try:
            action()
        except (Exception, SystemExit) as exc:  # the run's failure, as run() raises it
            if _interrupted(exc):
                raise KeyboardInterrupt from exc
            self.outcome[index] = exc

    def going(self) -> bool:
        return any(outcome is None for outcome in self.outcome)

    def warm_up(self) -> None:
        """Start every pump at its initial kept phase and let the gait settle."""
        self._each(lambda i, loop: loop.world.set_phases(loop.kept), self._loops())
        if self.going():
            self.batch.advance(self.ticks[0], self.observe)
        if self.schedule is not None:
            self.schedule.begin()

    def _loops(self) -> list[RunLoop | None]:
        return [self.loops.get(i) for i in range(len(self.configs))]

    def step(self, step: int) -> dict[int, np.ndarray]:
        """Learning step ``step`` of every run still going, every phase in order, recorded; per run by index its
        units' measured velocities (mm/cycle). Units with clocks of their own (``schedule``) end a step inside the
        next one's span: the velocities are then those of the step recorded in this one (``step - 1``; the last
        step's records too, at the last)."""
        if self.schedule is not None:
            return self.schedule.step(step)
        loops, records = self._loops(), self.records
        applied = self._each(lambda i, loop: loop.apply_events(step), loops)
        tried = self._propose(step, loops)
        if not self.going():
            return {}
        _, discard, measured = self.ticks
        self.batch.advance(discard, self.observe)
        displacements, samples = self._measure(loops, measured)
        going = sorted(displacements)
        inside = RunLoop.all_inside([loops[i] for i in going], step, [samples[i] for i in going]) if going else False
        velocities = self._each(lambda i, loop: loop.checked(step, displacements[i], samples[i], inside), loops)
        accepted = self._update(step, loops, {i: u_measured for i, (u_measured, _) in velocities.items()})
        xy, heading = ground_poses(*self.batch.unit_poses())
        self._each(lambda i, loop: loop.record(records[i], step, tried[i], *velocities[i], accepted[i], applied[i],
                                               (xy[self.slices[i]], heading[self.slices[i]])),
                   [loop if i in accepted else None for i, loop in enumerate(loops)])
        return {i: velocities[i][0] for i in accepted if self.outcome[i] is None}

    def _alive(self, loops: list[RunLoop | None]) -> np.ndarray:
        """Every run's units side by side: alive in a run still going."""
        alive = np.zeros(self.configs[0].shape.n_units * len(loops), dtype=bool)
        for index, loop in enumerate(loops):
            if loop is not None and self.outcome[index] is None:
                alive[self.slices[index]] = loop.state.alive()
        return alive

    def _propose(self, step: int, loops: list[RunLoop | None]) -> dict[int, np.ndarray]:
        """Every run's trial phases, set in its world."""
        if self.joint is None:
            return self._each(lambda i, loop: loop.propose(step), loops)
        tried = self.joint.propose(step, self._alive(loops))
        return self._each(lambda i, loop: loop.set_trial(tried[self.slices[i]]), loops)

    def _measure(self, loops: list[RunLoop | None], n_ticks: int) -> tuple[dict[int, list], list]:
        """Advance the measured ticks; per run going its sensor banks' displacements (m) and its units' sampled
        poses."""
        if self.joint_sensor is None:
            measurements = self._each(lambda i, loop: loop.start_measurement(), loops)
            every = next(iter(measurements.values())).every if measurements else 1
            samples = self.batch.advance_sampled(n_ticks, every, self.on_tick)
            return self._each(lambda i, m: m.end(*samples[i]), [measurements.get(i) for i in range(len(loops))]), \
                samples
        measurement = Measurement([self.joint_sensor], n_ticks, self.batch.unit_poses(), self.batch.ticks_in)
        positions, orientations = self.batch.advance_sampled_joined(n_ticks, measurement.every)
        moved, = measurement.end(positions, orientations)
        samples = [(positions[:, self.slices[i]], orientations[:, self.slices[i]]) for i in range(len(loops))]
        return {i: [moved[self.slices[i]]] for i, loop in enumerate(loops) if loop is not None and
                self.outcome[i] is None}, samples

    def _update(self, step: int, loops: list[RunLoop | None], measured: dict[int, np.ndarray]) -> dict[int, np.ndarray]:
        """The controllers take the measurements of the runs in ``measured``: each run's own, or the joint learners
        all at once; per run whether each unit accepted its trial (a run whose measurements a learner refuses stops
        there, as alone)."""
        if self.joint is None:
            return self._each(lambda i, loop: loop.update(measured[i], step), [
                loop if i in measured else None for i, loop in enumerate(loops)])
        velocity = np.zeros(self.configs[0].shape.n_units * len(loops))
        for index, u_measured in measured.items():
            velocity[self.slices[index]] = u_measured
        self._each(lambda i, loop: loop.controller.check_finite(step, measured[i], loop.state.alive()),
                   [loop if i in measured else None for i, loop in enumerate(loops)])
        accepted, kept = self.joint.update(step, velocity, self._alive(loops))
        for index in measured:
            if self.outcome[index] is None:
                loops[index].kept = kept[self.slices[index]]
        return {i: accepted[self.slices[i]] for i in measured if self.outcome[i] is None}

    def finish(self) -> list[RunRecords | BaseException]:
        """Each run's records (its wall time the batch's shared out evenly), or the exception that stopped it."""
        wall = (time.perf_counter() - self.started) / len(self.configs)
        for index, record in enumerate(self.records):
            if self.outcome[index] is None:
                record.finish(wall_time=wall)
                self.outcome[index] = record
        return self.outcome

    def close(self) -> None:
        self.batch.close()


def _interrupted(exc: BaseException) -> bool:
    """Whether Ctrl-C is behind ``exc``: a library (numba, compiling) or a wrapper may turn a KeyboardInterrupt into
    another error while cleaning up; it is still the user's interrupt, not the run's failure."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


def run_batch(configs: list[RunConfig], progress: Callable[[int, RunRecords], None] | None = None,
              on_tick: Callable[[WorldInterface], None] | None = None) -> list[RunRecords | BaseException]:
    """Run ``configs`` (equal but for their seeds; more than one only if ``batchable``) together; per configuration
    its records, or the exception that stopped it. ``progress(step, records)`` is called after each step of each run
    going on; ``on_tick`` as for ``run``."""
    driver = Driver(configs, on_tick=on_tick)
    with driver.batch:
        driver.warm_up()
        for step in range(configs[0].steps + 1):
            if not driver.going():  # every run has stopped: nothing left to simulate
                break
            driver.step(step)
            if progress is not None:
                for index, record in enumerate(driver.records):
                    if driver.outcome[index] is None:
                        progress(step, record)
        return driver.finish()


def run(config: RunConfig, progress: Callable[[int, RunRecords], None] | None = None,
        on_tick: Callable[[WorldInterface], None] | None = None) -> RunRecords:
    """Learn for ``config.steps`` learning steps; ``progress(step, records)`` is called after each step and
    ``on_tick(world)`` after every physics tick of the warm-up and the steps (observers only: it must not change the
    world).

    Units keep their identity (learner, memory, noise stream, damage) when a shuffle moves them: ``order[p]`` is the
    unit at position p (0 = front), and the world sees phases by position.

    A learner that raises or returns no usable phase stops the run with a PluginError; physics that leaves the
    model's validity (see ``run._Validity``) stops it with a PhysicsError.
    """
    outcome, = run_batch([config], progress, on_tick)
    if isinstance(outcome, BaseException):
        raise outcome
    return outcome
