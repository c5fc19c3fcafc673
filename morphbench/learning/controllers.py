"""Centralized baselines: one controller that sets every unit's phase and sees every unit's measurement.

They answer what decentralization costs. Each gets what the per-unit learners get: one phase vector tried per
learning step (step 0 measures the initial vector) and each unit's measured velocity; its objective is Ubar, the mean
over the living units. Every draw comes from one stream, ``[run seed, CONTROLLER_STREAM]``. All three keep the best
vector measured so far (its Ubar as measured then, like Thermal's memory): a trial that measures a higher Ubar is
accepted by every living unit, and the kept vector is what ``phase_kept`` records; each unit's velocity measured at
that vector is what ``u_memory`` records (their mean is the remembered Ubar). They differ in what they try:

- ``random-search``: a fresh uniform phase vector every step;
- ``hill-climber``: the kept vector with every phase perturbed by ``uniform(-1, 1) * step_size``;
- ``cmaes``: candidates of ``cma.CMAEvolutionStrategy`` over the phase vector (unwrapped; wrapped modulo 1 to run),
  started at the initial vector with ``CMA_SIGMA0``, one candidate per step, each generation told once all its
  candidates are measured; a full covariance matrix up to ``CMA_FULL_UNITS`` units, a diagonal one beyond.
"""

from __future__ import annotations

import math
from abc import abstractmethod

import numpy as np

from morphbench.learning.base import Controller, wrap_phases
from morphbench.params import LearnerParams
from morphbench.rules import check_params
from morphbench.streams import CONTROLLER_STREAM

CMA_SIGMA0 = 0.1
"""cycles: CMA-ES's initial step size, the per-unit learners' default step size (on chain-3, 60 steps, seeds 0-7,
final Ubar 2.5 mm/cycle against 1.0 with a quarter cycle: larger steps spend the few generations exploring)."""


CMA_FULL_UNITS = 100
"""units up to which CMA-ES adapts a full covariance matrix; beyond, a diagonal one (cma's ``CMA_diagonal=True``,
separable CMA-ES): the full matrix of 10,000 units would be 800 MB and each of its eigendecompositions O(n^3), where
the diagonal one costs O(n) a candidate. Runs of up to 100 units are those of the full matrix, as before it."""


def controller_rng(seed: int) -> np.random.Generator:
    """The one random stream of a centralized controller in a run seeded with ``seed``."""
    return np.random.default_rng(np.random.SeedSequence([seed, CONTROLLER_STREAM]))


class CentralController(Controller):
    """Keeps the best vector measured; subclasses choose the trials (``_candidate``) and may learn from each
    measured trial (``_measured``)."""

    centralized = True

    def __init__(self, params: LearnerParams, rng: np.random.Generator, n_units: int):
        check_params(params, "LearnerParams")
        self.params, self.rng = params, rng
        self.kept = wrap_phases(rng.uniform(0.0, 1.0, n_units))
        self.best: float | None = None
        """Ubar measured at the kept vector (None before step 0)."""
        self.remembered: np.ndarray | None = None
        """each unit's velocity measured at the kept vector (None before step 0; their mean is ``best``)."""
        self._trial = self.kept

    def initial(self) -> np.ndarray:
        return self.kept.copy()

    def propose(self, step: int, alive: np.ndarray) -> np.ndarray:
        trial = self.kept if self.best is None else wrap_phases(self._candidate())
        self._trial = np.where(alive, trial, self.kept)
        return self._trial.copy()

    def update(self, step: int, u_measured: np.ndarray, alive: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        ubar = float(np.mean(u_measured[alive])) if alive.any() else math.nan
        if self.best is not None:
            self._measured(ubar)
        accepted = self.best is None or ubar > self.best  # False for NaN: nobody is left to move
        if accepted:
            self.kept, self.best, self.remembered = self._trial, ubar, np.array(u_measured, dtype=float)
        return alive & accepted, self.kept.copy()

    def memory(self) -> np.ndarray | None:
        return None if self.remembered is None else self.remembered.copy()

    @abstractmethod
    def _candidate(self) -> np.ndarray:
        """The next phase vector to try (any reals: it is wrapped modulo 1)."""

    def _measured(self, ubar: float) -> None:
        """The Ubar the last candidate measured (NaN if no unit is alive)."""


class RandomSearch(CentralController):
    def _candidate(self) -> np.ndarray:
        return self.rng.uniform(0.0, 1.0, len(self.kept))


class HillClimber(CentralController):
    def _candidate(self) -> np.ndarray:
        return self.kept + self.rng.uniform(-1.0, 1.0, len(self.kept)) * self.params.step_size


class CMAES(CentralController):
    def __init__(self, params: LearnerParams, rng: np.random.Generator, n_units: int):
        super().__init__(params, rng, n_units)
        import cma  # imported here: only a cmaes run needs it

        # cma seeds numpy's global generator unless it samples from its own randn and the seed is NaN
        options = {"randn": lambda *shape: rng.standard_normal(shape), "seed": math.nan, "verbose": -9,
                   "verb_log": 0, "verb_disp": 0}
        if n_units > CMA_FULL_UNITS:  # up to it the options, and so every draw, are those of the first runs
            options["CMA_diagonal"] = True
        self.es = cma.CMAEvolutionStrategy(self.kept.copy(), CMA_SIGMA0, options)
        self._asked: list[np.ndarray] = []
        self._told: list[tuple[np.ndarray, float]] = []

    def _candidate(self) -> np.ndarray:
        if not self._asked:
            self._asked = list(self.es.ask())
        self._x = self._asked.pop(0)
        return self._x

    def _measured(self, ubar: float) -> None:
        self._told.append((self._x, -ubar if math.isfinite(ubar) else math.inf))  # cma minimises
        if not self._asked:
            xs, fs = zip(*self._told)
            self.es.tell(list(xs), list(fs))
            self._told = []


CENTRALIZED: dict[str, type[CentralController]] = {"cmaes": CMAES, "random-search": RandomSearch,
                                                   "hill-climber": HillClimber}
"""The centralized controllers by ``--learner`` name."""


def is_centralized(spec: str) -> bool:
    """Whether ``--learner spec`` names a centralized controller."""
    return isinstance(spec, str) and spec.strip().lower() in CENTRALIZED
