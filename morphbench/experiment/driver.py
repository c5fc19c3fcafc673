"""The one driver of the run loop: a batch of runs advanced step by step through the phases of ``RunLoop``.

    records = run(config)                               # a batch of one: its records, or it raises what ended it
    outcomes = run_batch([config_seed_0, config_seed_1, ...])   # RunRecords, or the exception that ended that run
    driver = Driver([config], [controller]); driver.warm_up(); driver.step(0) ...   # the environments, a step each

A run is a batch of one world (``physics.make_world(..., copies=1)``); runs that differ only in their seeds share one
world holding a copy of the assembly each when the backend can (``batchable``), so the simulator is called once per
step for all of them. Each run keeps its own loop: its controller, sensors, noise streams, events, validity and
records. What is the same arithmetic on every run is done once over every run's units side by side, arrays (runs,
units): the trial phases set, the measured velocities, the validity tests when every run passes them, a step's
records; a batch's built-in learners and ideal sensors are one each. The same numbers in the same order either way,
so every run's records equal those of ``run`` with the same configuration, bit for bit (tests/test_batch.py). A run
that fails (a plug-in error, a PhysicsError) stops alone, with its rows of the steps before: its copy goes on
moving, unseen, and the other runs finish.

Units with clocks of their own (experiment.clocks) take another timeline, ``Schedule``: the batch advances a fixed
grid of ticks at a time and each unit ends its step, proposes and starts measuring at its own tick (its run's
``OwnClocks``); ``Driver.step`` runs one or the other.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time
from typing import Callable

import numpy as np

from morphbench.experiment.clocks import OwnClocks, clocked, schedule_grid
from morphbench.experiment.events import Event, describe
from morphbench.experiment.records import RunRecords, StepRows
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
        self.n_units = n_units
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
        self.rows = StepRows(len(configs), capacity=first.steps + 1)
        """every run's records, stored a step of all the runs at a time."""
        self.records = [RunRecords(config, self.rows, index) for index, config in enumerate(configs)]
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
        self.event_steps = {event.step for event in first.events}
        self._places: _Places | None = None
        """every run's units' places, pieces and life, found again after events (``_apply_events``)."""

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
        loops = self._loops()
        applied = self._apply_events(step, loops)
        tried = self._propose(step, loops)
        if not self.going():
            return {}
        _, discard, measured = self.ticks
        self.batch.advance(discard, self.observe)
        sensed, true, samples = self._measure(loops, measured)
        u_measured, u_true = self._measured(loops, sensed, true)
        self._check_physics(step, loops, samples)
        accepted, kept = self._update(step, loops, u_measured)
        self._record(step, loops, applied, tried, u_measured, u_true, accepted, kept)
        return {i: u_measured[i] for i in self._going()}

    def _going(self) -> np.ndarray:
        """The runs still going, by index."""
        return np.flatnonzero([outcome is None for outcome in self.outcome])

    def _live(self) -> np.ndarray:
        """Every run's units (runs, n_units): alive in a run still going."""
        going = np.array([outcome is None for outcome in self.outcome])
        return self._places.alive & going[:, None]

    def _joined(self, per_run: dict[int, np.ndarray], fill=0.0) -> np.ndarray:
        """Arrays of some runs' units side by side (runs, n_units), ``fill`` for the other runs."""
        joined = np.full((len(self.configs), self.n_units), fill)
        for index, values in per_run.items():
            joined[index] = values
        return joined

    def _apply_events(self, step: int, loops: list[RunLoop | None]) -> dict[int, list[Event]]:
        """The events of ``step`` in every run going (the same in each: their configurations differ only in their
        seeds), by index; the units' places found again after any."""
        applied = self._each(lambda i, loop: loop.apply_events(step), loops) if step in self.event_steps else {}
        if self._places is None or any(applied.values()):
            self._places = _Places.of(loops, self.n_units)
        return applied

    def _propose(self, step: int, loops: list[RunLoop | None]) -> np.ndarray:
        """Every run's trial phases (runs, n_units), set in the worlds of the runs going, by position."""
        if self.joint is None:
            tried = self._joined(self._each(lambda i, loop: loop.propose(step), loops))
        else:
            tried = self.joint.propose(step, self._live().ravel()).reshape(len(loops), -1)
        going = self._going()
        self.batch.set_phases(going, tried.ravel()[self._places.order[going]])
        return tried

    def _measure(self, loops: list[RunLoop | None], n_ticks: int
                 ) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray]]:
        """Advance the measured ticks; per run (runs, n_units, by position) its sensor bank's displacements (m) and
        its ground truth's (the same bank for an ideal sensor), and its units' sampled poses (runs, K, n_units, 3)
        and (..., 4)."""
        if self.joint_sensor is None:
            measurements = self._each(lambda i, loop: loop.start_measurement(), loops)
            every = next(iter(measurements.values())).every if measurements else 1
            samples = self.batch.advance_sampled(n_ticks, every, self.on_tick)
            banks = self._each(lambda i, m: m.end(*samples[i]), [measurements.get(i) for i in range(len(loops))])
            return (self._joined({i: moved[0] for i, moved in banks.items()}),
                    self._joined({i: moved[-1] for i, moved in banks.items()}),
                    (_stacked([p for p, _ in samples]), _stacked([q for _, q in samples])))
        measurement = Measurement([self.joint_sensor], n_ticks, self.batch.unit_poses(), self.batch.ticks_in)
        positions, orientations = self.batch.advance_sampled_joined(n_ticks, measurement.every)
        moved = measurement.end(positions, orientations)[0].reshape(len(loops), -1)
        k = len(positions)
        return moved, moved, (positions.reshape(k, len(loops), -1, 3).swapaxes(0, 1),
                              orientations.reshape(k, len(loops), -1, 4).swapaxes(0, 1))

    def _measured(self, loops: list[RunLoop | None], sensed: np.ndarray, true: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
        """Per run and unit (runs, n_units) the measured velocity (with the unit's own noise; NaN for a dead unit)
        and the true one, mm/cycle, from the displacements (m, by position) over the measured cycles."""
        places, to_mm_per_cycle = self._places, 1000.0 / self.configs[0].learner_params.cycles_per_step
        u_true = true.ravel()[places.where] * to_mm_per_cycle
        noise = 0.0  # added without noise, as to every unit with it (-0.0 + 0.0 is 0.0: the records keep that)
        noisy = [i for i in self._going() if places.noise[i]]
        if noisy:
            noise = np.zeros(u_true.shape)
            # where each run's units stand, in unit order, for a noise that depends on the ground
            positions = self.batch.unit_poses()[0][places.where] if self.configs[0].environment.noise_ground else None
            for index in noisy:  # each unit draws from its own stream
                sigma = places.noise[index] if positions is None else \
                    loops[index].noise_sigma(places.noise[index], positions[index])
                noise[index] = loops[index].noise(sigma)
        u_measured = sensed.ravel()[places.where] * to_mm_per_cycle + noise
        u_measured[~places.alive] = np.nan
        return u_measured, u_true

    def _check_physics(self, step: int, loops: list[RunLoop | None], samples: tuple[np.ndarray, np.ndarray]
                       ) -> None:
        """Every run going checked for the model's validity: all at once when every one surely passes (nearly every
        step), else each run's own ``check_physics``, which finds what fails (and stops that run)."""
        going = self._going()
        if not len(going):
            return
        positions, orientations = self.batch.body_poses()
        inside = (samples, (positions, orientations)) if len(going) == len(loops) else (  # all: not copied
            (samples[0][going], samples[1][going]), (positions[going], orientations[going]))
        if RunLoop.all_inside([loops[i] for i in going], step, *inside):
            return
        self._each(lambda i, loop: loop.check_physics(step, (samples[0][i], samples[1][i])), loops)

    def _update(self, step: int, loops: list[RunLoop | None], u_measured: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
        """The controllers take the measurements: each run's own, or the joint learners every run's at once; per run
        and unit (runs, n_units) whether it accepted its trial, and its kept phase (a run whose measurements a
        learner refuses stops there, as alone)."""
        if self.joint is None:
            accepted = self._each(lambda i, loop: loop.update(u_measured[i], step), loops)
            return self._joined(accepted, False), self._joined({i: loops[i].kept for i in accepted})
        live = self._live()
        for index in np.flatnonzero((live & ~np.isfinite(u_measured)).any(axis=1)):
            self.guard(index, functools.partial(loops[index].controller.check_finite, step, u_measured[index],
                                                live[index]))
        accepted, kept = self.joint.update(step, u_measured.ravel(), self._live().ravel())
        kept = kept.reshape(u_measured.shape)
        for index in self._going():
            loops[index].kept = kept[index]
        return accepted.reshape(kept.shape), kept

    def _record(self, step: int, loops: list[RunLoop | None], applied: dict[int, list[Event]], tried: np.ndarray,
                u_measured: np.ndarray, u_true: np.ndarray, accepted: np.ndarray, kept: np.ndarray) -> None:
        """The step's rows of every run going, stored at once: per unit what ``RunLoop.record`` stores of one run
        (its position, piece, pose, the controller's memory) and the events applied."""
        if self.joint is None:
            memory = self._each(lambda i, loop: loop.controller.memory(), loops)
            memory = self._joined({i: values for i, values in memory.items() if values is not None}, np.nan)
        else:
            memory = self.joint.memory().reshape(kept.shape)
        runs, places = self._going(), self._places
        xy, heading = ground_poses(*self.batch.unit_poses())  # every run's units, by position
        where = places.where[runs]
        event = [describe(applied[i]) for i in runs] if any(applied.values()) else ""
        self.rows.add(runs, step, self.batch.worlds[0].time, event, {
            "position": places.position[runs] + 1, "piece": places.piece[runs], "phase_tried": tried[runs],
            "phase_kept": kept[runs], "u_measured": u_measured[runs], "u_true": u_true[runs],
            "u_memory": memory[runs], "accepted": accepted[runs], "x_m": xy[where, 0], "y_m": xy[where, 1],
            "heading_rad": heading[where]})

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


@dataclasses.dataclass(frozen=True)
class _Places:
    """Every run's units side by side (runs, n_units), as the events left them (``RunLoop``'s ``position``,
    ``piece`` and ``alive``; a run without a loop: its units in order, dead)."""

    position: np.ndarray
    """where each unit sits in its run."""
    where: np.ndarray
    """``position`` among every run's units (run r's place p is r * n_units + p: the batch's order)."""
    order: np.ndarray
    """the unit at each place, among every run's units (``RunState.order``)."""
    piece: np.ndarray
    alive: np.ndarray
    noise: list[float]
    """per run, its measurement noise now (mm/cycle)."""

    @classmethod
    def of(cls, loops: list[RunLoop | None], n_units: int) -> _Places:
        first = np.arange(n_units)
        offsets = n_units * np.arange(len(loops))[:, None]
        position = np.array([first if loop is None else loop.position for loop in loops])
        order = np.array([first if loop is None else loop.state.order for loop in loops])
        return cls(position=position, where=position + offsets, order=order + offsets,
                   piece=np.array([np.ones(n_units, dtype=int) if loop is None else loop.piece for loop in loops]),
                   alive=np.array([np.zeros(n_units, dtype=bool) if loop is None else loop.alive for loop in loops]),
                   noise=[0.0 if loop is None else loop.state.noise for loop in loops])


END, EVENTS, PROPOSE, START, RECORD = range(5)
"""What happens at one tick, in this order (a unit's step ends before it proposes the next one; a step is recorded
once its last unit has ended it)."""


class Schedule:
    """The timeline of a batch's runs whose units have clocks of their own (``Driver`` with ``clocked``
    environments): ``step(k)`` runs learning step k's span of L ticks, in which each unit ends its step k - 1 and
    starts its step k at its own offset, and records step k - 1; the last step also runs on until every unit has
    measured it."""

    def __init__(self, driver: Driver):
        self.driver = driver
        _, discard, measured = driver.ticks
        self.step_ticks = discard + measured
        self.steps = driver.configs[0].steps
        some = next(iter(driver.loops.values()), None)
        self.every = 1 if some is None else math.gcd(
            *[max(1, some.world.ticks_in(bank.sample_period)) for bank in (some.sensor, some.truth) if bank])
        """ticks between the sensors' samples."""
        self.grid = schedule_grid(self.every, self.step_ticks)
        self.clocks: dict[int, OwnClocks] = driver._each(lambda i, loop: OwnClocks(loop, self.grid), driver._loops())
        self.now = 0
        """ticks since the end of the warm-up."""

    def begin(self) -> None:
        self.driver._each(lambda i, clocks: clocks.begin(), self._clocks())

    def _clocks(self) -> list[OwnClocks | None]:
        return [self.clocks.get(i) if self.driver.outcome[i] is None else None for i in range(len(self.driver.configs))]

    def step(self, step: int) -> dict[int, np.ndarray]:
        """Learning step ``step``'s span (and, for the last, the span that ends it); per run by index the measured
        velocities of the step recorded (``step - 1``, then the last)."""
        recorded = self._span(step)
        if step == self.steps:
            recorded = self._span(step + 1)
        return recorded

    def _actions(self, k: int) -> list[tuple[int, int, int, int, np.ndarray | None]]:
        """Span k's actions of every run going: (tick, what, run, step, due units)."""
        L, base, actions = self.step_ticks, k * self.step_ticks, []
        for r, clocks in enumerate(self._clocks()):
            if clocks is None:
                continue
            if k <= self.steps:
                actions.append((base, EVENTS, r, k, None))
            for offset in np.unique(clocks.offsets):
                due = clocks.offsets == offset
                if k >= 1:
                    actions.append((base + int(offset), END, r, k - 1, due))
                if k <= self.steps:
                    actions.append((base + int(offset), PROPOSE, r, k, due))
            for s in (k - 1, k):
                if 0 <= s <= self.steps:
                    starts = (s + 1) * L + clocks.offsets - clocks.windows
                    for tick in np.unique(starts[(starts >= base) & (starts < base + L)]):
                        actions.append((int(tick), START, r, s, starts == tick))
            if k >= 1:
                actions.append((base + int(clocks.offsets.max()), RECORD, r, k - 1, None))
        return sorted(actions, key=lambda a: a[:3])

    def _span(self, k: int) -> dict[int, np.ndarray]:
        driver, recorded = self.driver, {}
        for tick, what, r, step, due in self._actions(k):
            if driver.outcome[r] is not None:
                continue
            self._advance(tick)
            clocks = self.clocks[r]
            action = {END: lambda: clocks.end(step, due), EVENTS: lambda: clocks.apply_events(step),
                      PROPOSE: lambda: clocks.propose(step, due), START: lambda: clocks.start(due),
                      RECORD: lambda: recorded.__setitem__(r, clocks.record(step, driver.records[r]))}[what]
            driver.guard(r, action)
        if k <= self.steps:
            self._advance((k + 1) * self.step_ticks)
        return recorded

    def _advance(self, tick: int) -> None:
        """The batch advanced to ``tick`` a grid interval at a time, every going run's banks sampled every ``every``
        ticks (and where its windows end or start)."""
        while self.now < tick and self.driver.going():
            samples = self.driver.batch.advance_sampled(self.grid, self.grid, self.driver.on_tick)
            self.now += self.grid
            for r, clocks in enumerate(self._clocks()):
                if clocks is not None:
                    clocks.sampled(*samples[r], self.now % self.every == 0)


def _stacked(arrays: list[np.ndarray]) -> np.ndarray:
    """``np.stack(arrays)``, without a copy of the one array of a batch of one."""
    return arrays[0][None] if len(arrays) == 1 else np.stack(arrays)


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
