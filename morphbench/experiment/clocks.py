"""Units with clocks of their own (``EnvironmentParams.clock_drift`` and ``clock_offset``): the run loop's timeline
when units share no clock.

Each unit's clock has its own rate error e (its pump period is cycle_time * (1 + e): the world's
``set_clock_rates``) and its own offset o, a whole number of ticks into each learning step of the run's nominal
length L = (discard_cycles + cycles_per_step) cycles. Unit i's step k starts at k L + o_i (after the warm-up): its
learner updates with its step k - 1 measurement and proposes its step k phase, which its pump runs from then on; it
measures over the last cycles_per_step of ITS cycles before its step k + 1 starts, so its window overlaps its
neighbours' phase changes. The steps keep one grid of length L (a unit's clock error changes its pump and its window,
not how many steps it makes in a run), and a step's records are written when its last unit has measured it.

The draws come from the run's seed on a stream of their own (``streams.CLOCK_STREAM``: every unit's rate error, then
every unit's offset), so the learners', noise and sensors' streams are the ones they are without clocks. With both
parameters 0 the run loop is ``Driver``'s own, untouched (records bit-identical to before the option existed).

``experiment.driver.Schedule`` drives the runs of a batch along this timeline, a run's units through its
``OwnClocks`` here. The batch advances by a fixed number of ticks at a time
(``grid``, a fifth of the sensors' sample period or less, dividing it and the step), whatever its runs, so that a
run's worlds, times and samples are the same alone or batched; offsets and windows are whole numbers of grid
intervals. A run's sensor banks are never reset: they take the poses at each sample period and at each of its units'
window ends, and a unit's measurement is the difference of its bank's displacement between its window's ends. At one
tick, in this order: units end their step (measurement, update), the run's events of a step apply, units propose,
units start measuring, the step before is recorded (with the physics checks over every sample since the last
record).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from morphbench.errors import ConfigError
from morphbench.params import EnvironmentParams
from morphbench.streams import CLOCK_STREAM

if TYPE_CHECKING:
    from morphbench.experiment.run import RunLoop

def clocked(environment: EnvironmentParams) -> bool:
    """Whether a run's units have clocks of their own."""
    return environment.clock_drift > 0 or environment.clock_offset > 0


def schedule_grid(every: int, step_ticks: int) -> int:
    """Ticks the batch advances at a time: the largest divisor of both the sample period ``every`` and the step
    ``step_ticks`` (ticks) that is at most a fifth of the sample period (at least 1)."""
    common = math.gcd(every, step_ticks)
    return next(d for d in range(max(1, every // 5), 0, -1) if common % d == 0)


def clock_ticks(config, ticks_in, grid: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """A run's clocks in ticks (``ticks_in(seconds)``, its world's): each unit's rate error, its offset into a learning
    step and the ticks it measures over (cycles_per_step of its own cycles, at most a step), both whole numbers of
    ``grid`` ticks; and the step's ticks."""
    lp, cycle = config.learner_params, config.shape.actuator.cycle_time
    step_ticks = ticks_in(lp.discard_cycles * cycle) + ticks_in(lp.cycles_per_step * cycle)
    errors, starts = draw_clocks(config.environment, config.shape.n_units, config.seed)
    offsets = grid * np.floor(starts * step_ticks / grid).astype(np.int64)
    windows = np.array([min(step_ticks, grid * round(ticks_in(lp.cycles_per_step * cycle * (1.0 + e)) / grid))
                        for e in errors], dtype=np.int64)
    return errors, offsets, windows, step_ticks


def draw_clocks(environment: EnvironmentParams, n_units: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Each unit's clock rate error e, uniform over [-clock_drift, clock_drift], and its offset as a fraction of a
    learning step, uniform over [0, clock_offset): one double each from the run's clock stream (unit order)."""
    rng = np.random.default_rng(np.random.SeedSequence([seed, CLOCK_STREAM]))
    errors = environment.clock_drift * (2.0 * rng.random(n_units) - 1.0)
    return errors, environment.clock_offset * rng.random(n_units)


@dataclass
class _StepRows:
    """What one learning step of a run records per unit, filled in as its units reach it."""

    n: int
    tried: np.ndarray = field(init=False)
    u_measured: np.ndarray = field(init=False)
    u_true: np.ndarray = field(init=False)
    accepted: np.ndarray = field(init=False)
    applied: list = field(default_factory=list)

    def __post_init__(self):
        self.tried, self.u_measured, self.u_true = np.zeros(self.n), np.full(self.n, np.nan), np.full(self.n, np.nan)
        self.accepted = np.zeros(self.n, dtype=bool)


class OwnClocks:
    """One run's units on their own clocks: their rates set in its world, their offsets and windows in ticks, and
    the run's phases of a learning step unit by unit (``RunLoop``'s state, sensors, controller and records)."""

    def __init__(self, loop: RunLoop, grid: int):
        config = loop.config
        n = config.shape.n_units
        self.loop = loop
        if config.environment.clock_offset > 0 and loop.controller.centralized:
            raise ConfigError(config.shape.source, "environment.clock_offset",
                              f"0 with the centralized learner {config.learner!r}, which measures every unit at once",
                              config.environment.clock_offset)
        self.errors, self.offsets, self.windows, _ = clock_ticks(config, loop.world.ticks_in, grid)
        """each unit's rate error; ticks from the start of each learning step to this unit's; ticks it measures
        over (at most a step)."""
        own_cycle = config.shape.actuator.cycle_time * (1.0 + self.errors) / config.physics.timestep
        self.cycles = self.windows / own_cycle
        """the cycles of its own each unit's window holds (its velocities are per cycle of its own): fewer than
        cycles_per_step where a slow clock's would not fit in a step."""
        loop.world.set_clock_rates(self.errors[loop.state.order])
        self.banks = [loop.sensor] if loop.truth is None else [loop.sensor, loop.truth]
        self.started = np.zeros((len(self.banks), n))
        """each bank's displacement (m) at each unit's window start, by unit."""
        self.running = np.array(loop.kept, dtype=float)
        """each unit's phase its pump runs at now (unit order)."""
        self.rows: dict[int, _StepRows] = {}
        self.samples: list[tuple[np.ndarray, np.ndarray]] = []
        """the units' sampled poses since the last record (for the physics checks)."""
        self.latest: tuple[np.ndarray, np.ndarray] | None = None
        """the units' poses at the end of the last advance, if the banks have not taken them."""

    def begin(self) -> None:
        """The sensors start integrating at the world's poses (once, after the warm-up)."""
        poses = self.loop.world.unit_poses()
        for bank in self.banks:
            bank.reset(*poses)

    def sampled(self, positions: np.ndarray, orientations: np.ndarray, due: bool) -> None:
        """The units' poses (1, n_units, ...) at the end of an advance: the banks take them if a sample is ``due``,
        else only if a window ends or starts there (``_take``)."""
        self.latest = positions, orientations
        if due:
            self._take()

    def _take(self) -> None:
        if self.latest is not None:
            for bank in self.banks:
                bank.sample_many(*self.latest)
            self.samples.append(self.latest)
            self.latest = None

    def _row(self, step: int) -> _StepRows:
        return self.rows.setdefault(step, _StepRows(len(self.running)))

    def _set_world(self) -> None:
        order = self.loop.state.order
        self.loop.world.set_phases(self.running[order])

    def apply_events(self, step: int) -> None:
        """The step's events; the world's pumps then follow the units where a shuffle put them."""
        self._row(step).applied = self.loop.apply_events(step)
        self.loop.world.set_clock_rates(self.errors[self.loop.state.order])
        self._set_world()

    def propose(self, step: int, due: np.ndarray) -> None:
        """The ``due`` units' trial phases for ``step``, run by their pumps from now."""
        controller, alive = self.loop.controller, self.loop.alive
        tried = controller.propose(step, alive) if due.all() else controller.propose(step, alive, units=due)
        self._row(step).tried[due] = tried[due]
        self.running[due] = tried[due]
        self._set_world()

    def start(self, due: np.ndarray) -> None:
        """The ``due`` units start measuring."""
        self._take()
        position = self.loop.position
        for b, bank in enumerate(self.banks):
            self.started[b, due] = bank.displacement()[position][due]

    def end(self, step: int, due: np.ndarray) -> None:
        """The ``due`` units end ``step``: their own measurement (with their own noise; NaN for a dead unit), their
        learners' update."""
        self._take()
        loop = self.loop
        position, alive, noise = loop.position, loop.alive, loop.state.noise
        moved = np.array([bank.displacement()[position] for bank in self.banks]) - self.started
        to_mm_per_cycle = 1000.0 / self.cycles
        row = self._row(step)
        row.u_true[due] = moved[-1, due] * to_mm_per_cycle[due]
        sigma = np.full(len(position), float(noise))
        if noise and loop.config.environment.noise_ground:  # where each unit stands, for a noise of the ground
            sigma = loop.noise_sigma(noise, loop.world.unit_poses()[0][position])
        for unit in np.flatnonzero(due):  # each unit's own noise stream, as the shared clock's run loop draws it
            row.u_measured[unit] = moved[0, unit] * to_mm_per_cycle[unit] + (
                loop.noise_rngs[unit].normal(0.0, sigma[unit]) if noise else 0.0)
        row.u_measured[due & ~alive] = np.nan
        controller = loop.controller
        accepted, kept = (controller.update(step, row.u_measured, alive) if due.all() else
                          controller.update(step, row.u_measured, alive, units=due))
        row.accepted[due] = accepted[due]
        loop.kept = kept

    def record(self, step: int, records) -> np.ndarray:
        """``step``'s rows once every unit has ended it, after the physics checks over the samples since the last
        record; its measured velocities."""
        loop, row = self.loop, self.rows.pop(step)
        samples = self.samples or [tuple(pose[None] for pose in loop.world.unit_poses())]
        joined = np.concatenate([p for p, _ in samples]), np.concatenate([q for _, q in samples])
        self.samples = []
        loop.check_physics(step, joined)
        loop.record(records, step, row.tried, row.u_measured, row.u_true, row.accepted, row.applied)
        return row.u_measured
