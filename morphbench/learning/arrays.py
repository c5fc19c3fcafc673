"""The built-in per-unit learners of a run (thermal, flaky, averaged, adaptive, sparse, random) stepped as arrays
over its units.

Each unit keeps its own state and its own random stream (``plugins.unit_rng``), and draws from it exactly the numbers
``metropolis.MetropolisLearner`` or ``baselines.RandomLearner`` draws, in the same order: every draw of those learners
is one double of the unit's stream (``uniform(low, high)`` is ``low + (high - low) * random()``), so a stream read
ahead in blocks (``Draws``) gives the same numbers as one draw at a time. A run's records are therefore the same,
bit for bit, as with one learner object per unit (tests/test_learning.py), at a fraction of the Python per step.
Plug-ins keep their per-unit objects (``plugins.Decentralized``).
"""

from __future__ import annotations

import math

import numpy as np

from morphbench.errors import PluginError
from morphbench.learning.base import Controller, initial_memory, wrap_phases
from morphbench.learning.metropolis import acceptance_probability, adapted_step_size, averaged_memory, trial_probability
from morphbench.params import LearnerParams, check_learner

BLOCK = 64
"""doubles read ahead from each unit's stream at a time."""


class Draws:
    """Each unit's random stream, read ahead in blocks: ``next(units)`` is the next double of each of ``units``'
    streams, as ``rng.random()`` would give it."""

    def __init__(self, rngs: list[np.random.Generator]):
        self.rngs = rngs
        self.block = np.empty((len(rngs), BLOCK))
        self.used = np.full(len(rngs), BLOCK)

    def next(self, units: np.ndarray) -> np.ndarray:
        for unit in units[self.used[units] == BLOCK]:
            self.block[unit], self.used[unit] = self.rngs[unit].random(BLOCK), 0
        values = self.block[units, self.used[units]]
        self.used[units] += 1
        return values


EXACT_MARGIN = 1e-12, 1e-300
"""relative and absolute distance of a draw from numpy's exp(delta / T) within which ``accepts`` asks math.exp
instead: numpy's exp is within a few units in the last place of the C library's (or of the smallest doubles, below
1e-300), so a decision is taken from numpy's only when no such difference could change it."""


def accepts(draws: np.ndarray, delta: np.ndarray, temperature: float) -> np.ndarray:
    """Per worse trial (``delta`` < 0, mm/cycle), whether its ``draws`` accept it: draw < acceptance_probability(delta,
    T), the Metropolis learner's own decision, at once over the units. numpy's exp decides every draw that is not
    within EXACT_MARGIN of it; those few (none, nearly always) are decided by the learner's own math.exp, so every
    decision is the one a learner object takes."""
    if temperature == 0:
        return np.zeros(len(draws), dtype=bool)
    with np.errstate(over="ignore", under="ignore"):
        probability = np.exp(delta / temperature)  # delta / inf is -0.0 -> 1.0, as math.exp gives it
    decided = draws < probability
    relative, floor = EXACT_MARGIN
    close = np.flatnonzero(np.abs(draws - probability) <= relative * probability + floor)
    for unit in close:
        decided[unit] = draws[unit] < acceptance_probability(float(delta[unit]), temperature)
    return decided


class UnitArrays(Controller):
    """``rule`` 'thermal', 'flaky', 'averaged', 'adaptive', 'sparse' or 'random' for every unit of a run, unit u
    drawing from ``rngs[u]``."""

    centralized = False

    def __init__(self, rule: str, params: LearnerParams, rngs: list[np.random.Generator], name: str):
        check_learner(params, "LearnerParams")
        self.rule, self.params, self.name = rule, params, name
        self.draws = Draws(rngs)
        self.phase = self.draws.next(np.arange(len(rngs)))  # uniform(0, 1): already in [0, 1)
        first = initial_memory(params)
        self._memory = np.full(len(rngs), math.nan if first is None else first)
        self.measured = np.full(len(rngs), first is not None)
        """per unit, whether it has a memory to compare with (not so before its first measurement, 'measure')."""
        self.trial = self.phase.copy()
        self.step_size = np.full(len(rngs), params.step_size)
        self.window_trials = np.zeros(len(rngs), dtype=int)  # the adaptive rule's current window, per unit
        self.window_accepted = np.zeros(len(rngs), dtype=int)
        self.trying = np.ones(len(rngs), dtype=bool)  # the sparse rule's units trying a phase this step
        self.own_steps = np.zeros(len(rngs), dtype=int)  # the sparse rule's learning steps per unit, by its clock

    def initial(self) -> np.ndarray:
        return self.phase.copy()

    def propose(self, step: int, alive: np.ndarray, units: np.ndarray | None = None) -> np.ndarray:
        # a dead unit keeps its phase; a Metropolis unit's first trial is its phase; a unit not stepping its trial
        trial = self.phase.copy() if units is None else np.where(units, self.phase, self.trial)
        due = alive if units is None else alive & units
        if self.rule == "random":
            asking = np.flatnonzero(due)
            trial[asking] = self.draws.next(asking)
        else:
            asking = np.flatnonzero(due & self.measured)
            if self.rule == "sparse":  # whether to try, drawn before the trial's own uniform
                p = trial_probability(self.params, self.own_steps[asking])
                self.own_steps[due] += 1
                self.trying[asking] = self.draws.next(asking) < p
                asking = asking[self.trying[asking]]
            eps = -1.0 + 2.0 * self.draws.next(asking)
            trial[asking] = wrap_phases(self.phase[asking] + eps * self.step_size[asking])
        self.trial = trial
        return trial.copy()

    def update(self, step: int, u_measured: np.ndarray, alive: np.ndarray, units: np.ndarray | None = None
               ) -> tuple[np.ndarray, np.ndarray]:
        live = np.flatnonzero(alive if units is None else alive & units)
        velocity = np.asarray(u_measured, dtype=float)
        accepted = np.zeros(len(self.phase), dtype=bool)
        if self.rule == "random":
            self.phase[live], self._memory[live] = self.trial[live], velocity[live]
            accepted[live] = True
            return accepted, self.phase.copy()
        self.check_finite(step, velocity, live)
        first, rest = live[~self.measured[live]], live[self.measured[live]]
        self._memory[first], self.measured[first] = velocity[first], True
        accepted[first] = True
        if self.rule == "sparse":  # a unit that tried nothing takes the step's measurement as its memory
            kept = rest[~self.trying[rest]]
            self._memory[kept] = velocity[kept]
            rest = rest[self.trying[rest]]
        worse = rest[velocity[rest] < self._memory[rest]]
        accepted[rest] = True  # no draw: a trial at least as good is always accepted
        accepted[worse] = accepts(self.draws.next(worse), velocity[worse] - self._memory[worse],
                                  self.params.temperature)
        self.phase[accepted] = self.trial[accepted]
        if self.rule == "averaged":
            self._memory[rest] = averaged_memory(self._memory[rest], velocity[rest], self.params.memory_weight)
        else:
            remembers = rest if self.rule == "flaky" else rest[accepted[rest]]
            self._memory[remembers] = velocity[remembers]
        if self.rule == "adaptive":
            self._adapt(rest, accepted)
        return accepted, self.phase.copy()

    def check_finite(self, step: int, velocity: np.ndarray, live: np.ndarray, first_unit: int = 0) -> None:
        """A PluginError naming the first of the ``live`` units whose measured velocity is not finite (a NaN would
        compare as 'not worse' and poison the memory for good); units numbered from ``first_unit``."""
        bad = live[~np.isfinite(velocity[live])]
        if len(bad):
            raise PluginError(self.name, "update(velocity)", f"of unit {bad[0] - first_unit + 1} at learning step "
                              f"{step} to return (it raised ValueError: measured velocity must be finite, got "
                              f"{float(velocity[bad[0]])!r})")

    def _adapt(self, tried: np.ndarray, accepted: np.ndarray) -> None:
        """Count the trials of units ``tried``; a unit whose window is full changes its step size."""
        self.window_trials[tried] += 1
        self.window_accepted[tried] += accepted[tried]
        full = tried[self.window_trials[tried] == self.params.adapt_window]
        self.step_size[full] = adapted_step_size(self.step_size[full], self.window_accepted[full], self.params)
        self.window_trials[full] = self.window_accepted[full] = 0

    def memory(self) -> np.ndarray:
        return self._memory.copy()


class RunView(Controller):
    """Run ``run``'s units of a ``UnitArrays`` that holds the units of several runs side by side, ``n_units``
    each (``plugins.make_joint_controller``): a controller of that run alone, which steps only its own units (the
    batch's driver steps every run's at once through the joint one)."""

    centralized = False

    def __init__(self, joint: UnitArrays, run: int, n_units: int):
        self.joint, self.units = joint, slice(run * n_units, (run + 1) * n_units)

    def _mask(self, values: np.ndarray | None, fill) -> np.ndarray:
        full = np.full(len(self.joint.phase), fill)
        full[self.units] = True if values is None else values
        return full

    def initial(self) -> np.ndarray:
        return self.joint.phase[self.units].copy()

    def propose(self, step: int, alive: np.ndarray, units: np.ndarray | None = None) -> np.ndarray:
        return self.joint.propose(step, self._mask(alive, False), self._mask(units, False))[self.units]

    def update(self, step: int, u_measured: np.ndarray, alive: np.ndarray, units: np.ndarray | None = None
               ) -> tuple[np.ndarray, np.ndarray]:
        live = alive if units is None else alive & units
        self.check_finite(step, u_measured, live)
        accepted, kept = self.joint.update(step, self._mask(u_measured, 0.0), self._mask(live, False))
        return accepted[self.units], kept[self.units]

    def check_finite(self, step: int, u_measured: np.ndarray, live: np.ndarray) -> None:
        """``UnitArrays.check_finite`` of this run's ``live`` units, numbered within the run: the joint learners
        would refuse the whole batch's measurements, a driver refuses this run's alone."""
        self.joint.check_finite(step, self._mask(u_measured, 0.0), np.flatnonzero(self._mask(live, False)),
                                first_unit=self.units.start)

    def memory(self) -> np.ndarray:
        return self.joint._memory[self.units].copy()
