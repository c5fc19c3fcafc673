"""Metropolis learners (Oliveri et al., PNAS 2021, and its SI Fig. S1; docs/paper.md, Protocol): Thermal and Flaky
differ only in what the memory holds after a trial.

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


class MetropolisLearner(Learner):
    """The shared Metropolis step; subclasses choose the memory rule in ``_remember``."""

    def __init__(self, params: LearnerParams, rng: np.random.Generator):
        super().__init__(params, rng)
        self._trial: float | None = None  # the proposed phase awaiting its measurement

    def propose(self) -> float:
        if self._trial is not None:
            raise RuntimeError("propose() called twice without update() in between")
        if self.memory is None:
            # 'measure': the first step measures the initial phase itself, so no eps is drawn
            self._trial = self.phase
        else:
            eps = float(self.rng.uniform(-1.0, 1.0))
            self._trial = wrap_phase(self.phase + eps * self.params.step_size)
        return self._trial

    def update(self, velocity: float) -> bool:
        if self._trial is None:
            raise RuntimeError("update() called without a pending propose()")
        velocity = float(velocity)
        if not math.isfinite(velocity):
            # a NaN would compare as 'not worse' and poison the memory for good
            raise ValueError(f"measured velocity must be finite, got {velocity!r}")
        trial, self._trial = self._trial, None
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
