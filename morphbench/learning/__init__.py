"""Learning: each unit's decentralized learner, fed only its own measurements, with its own random stream."""

from morphbench.learning.base import Learner
from morphbench.learning.baselines import RandomLearner
from morphbench.learning.metropolis import FlakyLearner, ThermalLearner
from morphbench.learning.plugins import LEARNERS, load_learner_class, make_learners, unit_rng

__all__ = ["FlakyLearner", "LEARNERS", "Learner", "RandomLearner", "ThermalLearner", "load_learner_class",
           "make_learners", "unit_rng"]
