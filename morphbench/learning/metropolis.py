"""Metropolis learners (Oliveri et al., PNAS 2021, and its SI Fig. S1; docs/paper.md, Protocol): Thermal and Flaky
differ only in what the memory holds after a trial; beyond the paper (docs/learners.md), Averaged keeps an exponential
average of the measurements, Adaptive is Thermal with a step size steered by its acceptance rate, and Sparse tries a
new phase only on some steps, refreshing its memory on the others.

Each step a learner tries ``phi_try = (phi + eps * step_size) mod 1`` with ``eps ~ uniform[-1, 1]`` and accepts it
with probability ``min(1, exp((U_try - U_mem) / T))``. A uniform for that decision is drawn exactly when the trial
is worse than the memory, so a given stream of draws always gives the same decisions, whatever T is. ``memory``
(U_mem, mm/cycle) is public: the run loop records it after every step as ``u_memory``, beside the trial's velocity.
"""

from __future__ import annotations

import math
from abc import abstractmethod

import numpy as np

from morphbench.learning.base import Learner, wrap_phase
from morphbench.params import LearnerParams


def acceptance_probability(delta: float, temperature: float) -> float:
    """exp(delta / T) for a worse trial (delta < 0), with T = 0 (never) and T = inf (always) handled exactly."""
    if temperature == 0:
        return 0.0
    return math.exp(delta / temperature)  # delta / inf is -0.0 -> 1.0; underflow gives 0.0, never a warning


def averaged_memory(memory, velocity, weight: float):
    """(1 - w) memory + w velocity, of numbers or arrays: exactly the velocity at w = 1 (memory + w (velocity -
    memory) is not, by rounding), so that Averaged at w = 1 is Flaky bit for bit; an infinite memory (the '-inf'
    start) is replaced by the velocity instead of averaged into NaN."""
    finite = np.isfinite(memory)
    return np.where(finite, (1.0 - weight) * np.where(finite, memory, 0.0) + weight * velocity, velocity)


def trial_probability(params: LearnerParams, own_steps):
    """The sparse learner's probability of trying at a unit's step, having taken ``own_steps`` steps of its own
    (a count, or an array of them): trial_probability, falling as p0 / (1 + t / tau) to its floor if it decays."""
    if not params.trial_decay_steps:
        return params.trial_probability
    decayed = params.trial_probability / (1.0 + np.asarray(own_steps) / params.trial_decay_steps)
    return np.maximum(params.trial_probability_min, decayed)


def adapted_step_size(step_size, accepted: int | np.ndarray, params: LearnerParams):
    """The adaptive learner's step size after a window of ``params.adapt_window`` trials of which ``accepted`` were
    accepted, of numbers or arrays: times exp(c) above the target rate, exp(-c) below it, clipped to [step_size_min,
    step_size_max]; unchanged (and not clipped) at c = 0, so that Adaptive is then Thermal."""
    if params.adapt_rate == 0:
        return step_size
    rate = np.asarray(accepted) / params.adapt_window
    # the factors from math.exp once, so that a unit's object and its row of arrays multiply by the same doubles
    factor = np.where(rate > params.target_acceptance, math.exp(params.adapt_rate),
                      np.where(rate < params.target_acceptance, math.exp(-params.adapt_rate), 1.0))
    return np.clip(step_size * factor, params.step_size_min, params.step_size_max)


class MetropolisLearner(Learner):
    """The shared Metropolis step; subclasses choose the memory rule in ``_remember``."""

    def __init__(self, params: LearnerParams, rng: np.random.Generator):
        super().__init__(params, rng)
        self._trial: float | None = None  # the proposed phase awaiting its measurement
        self.step_size = params.step_size
        """delta_s, cycles: the reach of the next trial (only Adaptive changes it)."""

    def propose(self) -> float:
        if self._trial is not None:
            raise RuntimeError("propose() called twice without update() in between")
        self._trial = self._next_trial()
        return self._trial

    def _next_trial(self) -> float:
        """The phase to try next (its draws from the unit's stream, in order)."""
        if self.memory is None:
            return self.phase  # 'measure': the first step measures the initial phase itself, so no eps is drawn
        eps = float(self.rng.uniform(-1.0, 1.0))
        return wrap_phase(self.phase + eps * self.step_size)

    def update(self, velocity: float) -> bool:
        if self._trial is None:
            raise RuntimeError("update() called without a pending propose()")
        velocity = float(velocity)
        if not math.isfinite(velocity):
            # a NaN would compare as 'not worse' and poison the memory for good
            raise ValueError(f"measured velocity must be finite, got {velocity!r}")
        trial, self._trial = self._trial, None
        return self._judge(trial, velocity)

    def _judge(self, trial: float, velocity: float) -> bool:
        """Keep ``trial`` or not, having measured ``velocity`` at it; whether it was accepted."""
        if self.memory is None:
            self.memory = velocity
            return True
        if velocity < self.memory:
            accepted = float(self.rng.uniform(0.0, 1.0)) < acceptance_probability(
                velocity - self.memory, self.params.temperature
            )
        else:
            accepted = True  # no draw: a trial at least as good is always accepted
        if accepted:
            self.phase = trial
        self.memory = self._remember(self.memory, velocity, accepted)
        return accepted

    @abstractmethod
    def _remember(self, memory: float, velocity: float, accepted: bool) -> float:
        """The memory after a trial that measured ``velocity`` and was or was not ``accepted``."""


class ThermalLearner(MetropolisLearner):
    """Classic Metropolis: the memory is the last ACCEPTED measurement."""

    def _remember(self, memory: float, velocity: float, accepted: bool) -> float:
        return velocity if accepted else memory


class FlakyLearner(MetropolisLearner):
    """The memory is the last MEASURED velocity, accepted or not, so it tracks a changing environment."""

    def _remember(self, memory: float, velocity: float, accepted: bool) -> float:
        return velocity


class AveragedLearner(MetropolisLearner):
    """The memory is an exponential average of every measured velocity, accepted or not (weight ``memory_weight``):
    between Flaky (weight 1, the last measurement) and a long average that noise hardly moves."""

    def _remember(self, memory: float, velocity: float, accepted: bool) -> float:
        return float(averaged_memory(memory, velocity, self.params.memory_weight))


class AdaptiveLearner(ThermalLearner):
    """Thermal whose step size follows its acceptance rate (the 1/5 rule of evolution strategies): counted over
    every ``adapt_window`` trials, above ``target_acceptance`` the step grows, below it shrinks
    (``adapted_step_size``). The first step of 'measure', which tries nothing, is no trial."""

    def __init__(self, params: LearnerParams, rng: np.random.Generator):
        super().__init__(params, rng)
        self.window_trials = self.window_accepted = 0

    def update(self, velocity: float) -> bool:
        tried = self.memory is not None
        accepted = super().update(velocity)
        if tried:
            self.window_trials, self.window_accepted = self.window_trials + 1, self.window_accepted + accepted
            if self.window_trials == self.params.adapt_window:
                self.step_size = float(adapted_step_size(self.step_size, self.window_accepted, self.params))
                self.window_trials = self.window_accepted = 0
        return accepted


class SparseLearner(ThermalLearner):
    """Thermal that tries a new phase only with a probability per step (``trial_probability``, falling with the
    unit's own steps if ``trial_decay_steps`` is set: ``trial_probability()``), so that fewer units of an assembly
    change at once; on the other steps it keeps its phase and its memory becomes the step's measurement, what its
    kept phase gives among the others' current phases (so a later trial is judged against the present, not against a
    reading taken before the others moved). Such a step tried nothing and accepted nothing (False). The uniform that
    decides whether to try is drawn before the trial's own, and not on the first step of 'measure'."""

    def __init__(self, params: LearnerParams, rng: np.random.Generator):
        super().__init__(params, rng)
        self.trying = False
        self.own_steps = 0
        """the learning steps this unit has taken (its first, measuring, step counts), by its own clock."""

    def _next_trial(self) -> float:
        p = trial_probability(self.params, self.own_steps)
        self.own_steps += 1
        self.trying = self.memory is not None and float(self.rng.uniform(0.0, 1.0)) < p
        return super()._next_trial() if self.trying else self.phase

    def _judge(self, trial: float, velocity: float) -> bool:
        if self.trying or self.memory is None:
            return super()._judge(trial, velocity)
        self.memory = velocity
        return False
