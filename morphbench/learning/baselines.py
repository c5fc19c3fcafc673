"""Baselines a learner must beat: what a unit does without learning."""

from __future__ import annotations

import numpy as np

from morphbench.learning.base import Learner, wrap_phase
from morphbench.params import LearnerParams


class RandomLearner(Learner):
    """Random phase changes: every step the unit runs a fresh phase drawn uniformly from its own stream and keeps
    it, whatever it measured (every trial accepted; its ``memory`` is only the last measurement, which it never
    uses). A learner that beats it has learned something."""

    def __init__(self, params: LearnerParams, rng: np.random.Generator):
        super().__init__(params, rng)
        self._trial = self.phase

    def propose(self) -> float:
        self._trial = wrap_phase(float(self.rng.uniform(0.0, 1.0)))
        return self._trial

    def update(self, velocity: float) -> bool:
        self.phase, self.memory = self._trial, velocity
        return True
