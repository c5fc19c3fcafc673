"""The learner interface: one unit's learner, which sees only that unit's own measurements.

A run builds one learner per active unit, each with its own random stream, and then alternates, per learning
step, ``propose()`` (the phase the unit actuates with during the step) and ``update(velocity)`` (the unit's own
measured velocity at that phase, in mm/cycle). A learner is never given another unit's phase, measurement or stream.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod

import numpy as np

from morphbench.params import LearnerParams, check_learner


def wrap_phase(phase: float) -> float:
    """``phase`` modulo 1, always in [0, 1)."""
    wrapped = phase % 1.0
    # a tiny negative phase rounds up to exactly 1.0 under float modulo (-1e-18 % 1.0 == 1.0)
    return 0.0 if wrapped >= 1.0 else wrapped


def wrap_phases(phases) -> np.ndarray:
    """``wrap_phase`` of every phase of an array (a controller's phase vector)."""
    wrapped = np.asarray(phases, dtype=float) % 1.0
    return np.where(wrapped >= 1.0, 0.0, wrapped)


def initial_memory(params: LearnerParams) -> float | None:
    """U_mem before the first trial: None while it is still to be measured ('measure'), else -inf or 0.0."""
    return {"measure": None, "-inf": -math.inf, "zero": 0.0}[params.initial_memory]


class Learner(ABC):
    """One unit's learner; sees only its own unit's measurements.

    Protocol: ``propose()`` and ``update(velocity)`` strictly alternate, starting with ``propose()``.
    """

    phase: float
    """The kept phase, in [0, 1)."""
    memory: float | None
    """U_mem, mm/cycle: None before the first measurement when ``initial_memory == 'measure'``."""

    def __init__(self, params: LearnerParams, rng: np.random.Generator):
        check_learner(params, "LearnerParams")
        self.params = params
        self.rng = rng
        self.phase = wrap_phase(float(rng.uniform(0.0, 1.0)))
        self.memory = initial_memory(params)

    @abstractmethod
    def propose(self) -> float:
        """The phase to run during the next learning step, in [0, 1)."""

    @abstractmethod
    def update(self, velocity: float) -> bool:
        """Take the measured velocity (mm/cycle) at the proposed phase; return whether the trial was accepted."""


class Controller(ABC):
    """What the run loop drives: every unit's phase for a learning step in, every unit's measurement out.

    Protocol: ``initial()`` once (the phases the warm-up runs at), then per learning step ``propose(step, alive)``
    and ``update(step, u_measured, alive)``, strictly alternating. Arrays are per unit, in unit order; ``alive[u]`` is
    False for a unit killed by a damage event: it keeps its kept phase and measures NaN. A per-unit controller also
    takes ``units`` (a boolean mask) in both: only those units step then, the others' pending trials are kept (units
    on clocks of their own step at their own moments, morphbench.experiment.clocks); the strict alternation then
    holds unit by unit. The per-unit learners run as
    one (morphbench.learning.plugins.Decentralized); centralized ones see every unit (morphbench.learning.controllers).
    """

    centralized: bool
    """Whether one controller sees every unit's measurement (summary.json's ``centralized``)."""

    @abstractmethod
    def initial(self) -> np.ndarray:
        """Every unit's kept phase before the first step, in [0, 1)."""

    @abstractmethod
    def propose(self, step: int, alive: np.ndarray) -> np.ndarray:
        """Every unit's phase for learning step ``step``, in [0, 1) (a dead unit's: its kept phase)."""

    @abstractmethod
    def update(self, step: int, u_measured: np.ndarray, alive: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Take every unit's measured velocity (mm/cycle, NaN for a dead unit) at the proposed phases; whether each
        unit accepted its trial and every unit's kept phase after the step (what ``phase_kept`` records)."""

    def memory(self) -> np.ndarray | None:
        """Every unit's remembered velocity (mm/cycle) after the last update, what its next trial is compared with
        (``u_memory`` of the records); None for a controller that keeps none (recorded as NaN)."""
        return None
