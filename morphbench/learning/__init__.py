"""Learning: each unit's decentralized learner, fed only its own measurements, with its own random stream; and the
centralized baselines (controllers.py), one controller for every unit."""

from morphbench.learning.base import Controller, Learner
from morphbench.learning.baselines import RandomLearner
from morphbench.learning.metropolis import AdaptiveLearner, AveragedLearner, FlakyLearner, ThermalLearner
from morphbench.learning.controllers import CENTRALIZED, is_centralized
from morphbench.learning.plugins import (LEARNERS, Decentralized, load_learner_class, make_controller, make_learners,
                                         unit_rng)

__all__ = ["AdaptiveLearner", "AveragedLearner", "CENTRALIZED", "Controller", "Decentralized", "FlakyLearner",
           "LEARNERS", "Learner", "RandomLearner", "ThermalLearner", "is_centralized", "load_learner_class",
           "make_controller", "make_learners", "unit_rng"]
