"""Choosing a learner by name (``--learner``), per-unit random streams, and building one learner per unit.

``--learner`` takes ``thermal``, ``flaky``, ``averaged``, ``adaptive``, ``sparse`` or ``random`` (the no-learning
baseline; any case; docs/learners.md), or a plug-in class as ``package.module:ClassName``; the module is imported
with ``importlib``, so its directory must be on ``sys.path`` (e.g. via ``PYTHONPATH``).
It also takes the centralized baselines ``cmaes``, ``random-search`` and ``hill-climber``
(morphbench.learning.controllers): one controller for all units instead of one learner per unit.
``make_controller`` builds either for the run loop.

The plug-in interface. A plug-in need not subclass ``morphbench.learning.Learner``, but it must:

- be a class constructible as ``Cls(params, rng)``: ``params`` is the run's ``morphbench.params.LearnerParams``
  and ``rng`` the unit's own ``numpy.random.Generator`` (draw every random number from it, so runs are
  reproducible and units independent);
- have ``propose() -> float``: the phase the unit actuates with during the next learning step;
- have ``update(velocity: float) -> bool``: the unit's own measured velocity (mm/cycle) at the proposed phase;
  return whether the trial was accepted, True or False (this feeds the acceptance rate). The two calls strictly
  alternate;
- expose ``phase``: the kept phase, in [0, 1) right after construction, recorded every step.
- optionally expose ``memory``: the velocity (mm/cycle) its next trial is compared with, recorded every step as
  ``u_memory`` (NaN for a plug-in without one, or whose ``memory`` is no real number).

Phases are in cycles: a proposed or kept phase that is a finite number outside [0, 1) is wrapped modulo 1 (1.25 is
0.25, -0.1 is 0.9). Anything else (a bool, a list, None, a string, NaN or an infinity) is refused, as is an
``update`` that returns anything but True or False, and a plug-in whose ``__init__``, ``propose``, ``update`` or
``phase`` raises (any exception, ``RecursionError`` and ``SystemExit`` included): the run stops with a
``morphbench.errors.PluginError`` naming the plug-in, the method, the unit and the learning step (one line and exit
status 2 from ``morphbench run``; a failed run with that reason in a suite).

Each unit gets its own instance and sees only its own measurements. A complete minimal example, a greedy learner
that keeps a trial only when it measured faster than the kept phase::

    # my_learners.py    use with: --learner my_learners:Greedy
    class Greedy:
        def __init__(self, params, rng):
            self.step_size = params.step_size
            self.rng = rng
            self.phase = float(rng.uniform(0.0, 1.0))
            self.memory = float("-inf")
            self.trial = self.phase

        def propose(self):
            self.trial = (self.phase + self.rng.uniform(-1.0, 1.0) * self.step_size) % 1.0
            return self.trial

        def update(self, velocity):
            if velocity > self.memory:
                self.phase, self.memory = self.trial, velocity
                return True
            return False
"""

from __future__ import annotations

import importlib
import inspect
import keyword
import math
import numbers
from typing import Any

import numpy as np

from morphbench.errors import ConfigError, PluginError
from morphbench.failures import describe
from morphbench.learning.base import Controller, wrap_phase
from morphbench.learning.arrays import UnitArrays
from morphbench.learning.baselines import RandomLearner
from morphbench.learning.controllers import CENTRALIZED, controller_rng
from morphbench.learning.metropolis import (
    AdaptiveLearner,
    AveragedLearner,
    FlakyLearner,
    SparseLearner,
    ThermalLearner,
)
from morphbench.params import LearnerParams
from morphbench.streams import LEARNER_STREAM

ARRAYS = {"thermal": ThermalLearner, "flaky": FlakyLearner, "averaged": AveragedLearner, "adaptive": AdaptiveLearner,
          "sparse": SparseLearner, "random": RandomLearner}
"""The per-unit built-ins by ``--learner`` name, which a run steps as arrays over its units (learning/arrays.py),
with the same draws as their objects."""

LEARNERS: dict[str, type] = {**ARRAYS, **CENTRALIZED}
"""Every built-in by ``--learner`` name: the per-unit learners, then the centralized controllers."""

_SOURCE = "--learner"
_SPEC_FORM = ("'thermal', 'flaky', 'averaged', 'adaptive', 'sparse' or 'random' (per unit), 'cmaes', 'random-search' "
              "or 'hill-climber' (centralized; any case), or a plug-in class as 'package.module:ClassName'")
_METHODS = ("propose", "update")


def _is_identifier(name: str) -> bool:
    return name.isidentifier() and not keyword.iskeyword(name)


def load_learner_class(spec: str) -> type:
    """The learner class named by ``spec``; raises ConfigError (never another exception) if it is unusable."""
    if not isinstance(spec, str):
        raise ConfigError(_SOURCE, repr(spec), f"a string: {_SPEC_FORM}")
    builtin = LEARNERS.get(spec.strip().lower())
    if builtin is not None:
        return builtin
    module_name, colon, class_name = spec.strip().partition(":")
    if not (colon and all(_is_identifier(part) for part in module_name.split(".")) and _is_identifier(class_name)):
        raise ConfigError(_SOURCE, spec, _SPEC_FORM)

    def fail(expected: str) -> ConfigError:
        return ConfigError(_SOURCE, spec, expected)

    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        # tell a missing plug-in module apart from a plug-in whose own imports fail
        missing = exc.name or ""
        if missing == module_name or module_name.startswith(missing + "."):
            raise fail(f"an importable module {module_name!r} ({exc}; is its directory on sys.path?)") from None
        raise fail(f"module {module_name!r} to import cleanly (it raised {describe(exc, where=False)})") from None
    except (Exception, SystemExit, GeneratorExit) as exc:  # sys.exit() in a plug-in must not end the run
        raise fail(f"module {module_name!r} to import cleanly (it raised {describe(exc, where=False)})") from None

    try:
        cls = getattr(module, class_name)
    except AttributeError:
        raise fail(f"module {module_name!r} to define a class {class_name!r} (it has no such attribute)") from None
    except Exception as exc:  # a module-level __getattr__ may raise anything
        raise fail(f"module {module_name!r} to define a class {class_name!r} "
                   f"(it raised {describe(exc, where=False)})") from None
    if not inspect.isclass(cls):
        raise fail(f"{class_name!r} to be a class (it is a {type(cls).__name__})")
    missing_methods = [name for name in _METHODS if not callable(getattr(cls, name, None))]
    if missing_methods:
        raise fail(
            f"class {class_name!r} to have methods propose() and update(velocity) "
            f"(missing: {', '.join(missing_methods)})"
        )
    if inspect.isabstract(cls):
        raise fail(f"a concrete class ({class_name!r} leaves abstract: {', '.join(sorted(cls.__abstractmethods__))})")
    try:
        signature = inspect.signature(cls)
    except (TypeError, ValueError):
        signature = None  # some classes (e.g. C extensions) have no inspectable signature: construction will tell
    if signature is not None:
        try:
            signature.bind(None, None)
        except TypeError:
            expected = f"class {class_name!r} constructible as {class_name}(params, rng) (its signature is {signature})"
            raise fail(expected) from None
    return cls


def unit_rng(seed: int, unit: int) -> np.random.Generator:
    """The learner's random stream of unit ``unit`` (0-based) in a run seeded with ``seed``."""
    return np.random.default_rng(np.random.SeedSequence([seed, LEARNER_STREAM, unit]))


def make_learners(cls: type, params: LearnerParams, seed: int, n_units: int) -> list:
    """One learner per unit, unit i with ``unit_rng(seed, i)``; a failing plug-in raises ConfigError."""
    if n_units < 0:
        raise ValueError(f"n_units must be >= 0, got {n_units}")
    name = learner_spec(cls)
    learners = []
    for unit in range(n_units):
        try:
            learner = cls(params, unit_rng(seed, unit))
        except ConfigError:
            raise  # already names its source and key (e.g. bad LearnerParams)
        except (Exception, SystemExit, GeneratorExit) as exc:
            raise PluginError(name, "__init__(params, rng)", f"of unit {unit + 1} to construct a learner "
                              f"{cls.__name__}(params, rng) (constructing it raised {describe(exc)})") from None
        _check_phase(learner, name)
        learners.append(learner)
    return learners


def make_controller(cls: type, params: LearnerParams, seed: int, n_units: int) -> Controller:
    """What the run loop drives for learner class ``cls``: a centralized controller with ``controller_rng(seed)``,
    a built-in per-unit learner's arrays over the units (the same streams and draws as its objects), or a plug-in's
    ``make_learners`` as one Decentralized controller."""
    if cls in CENTRALIZED.values():
        return cls(params, controller_rng(seed), n_units)
    if cls in ARRAYS.values():
        name = learner_spec(cls)
        return UnitArrays(name, params, [unit_rng(seed, unit) for unit in range(n_units)], name)
    return Decentralized(make_learners(cls, params, seed, n_units))


def make_joint_controller(cls: type, params: LearnerParams, seeds: list[int], n_units: int) -> UnitArrays | None:
    """For a batch of runs of a built-in per-unit learner, one controller over every run's units, run r's unit u
    at ``r * n_units + u`` with ``unit_rng(seeds[r], u)``: each unit keeps its own state and stream, so every run
    draws what its own ``make_controller`` would. None for any other learner (each run keeps its own)."""
    if cls not in ARRAYS.values():
        return None
    name = learner_spec(cls)
    return UnitArrays(name, params, [unit_rng(seed, unit) for seed in seeds for unit in range(n_units)], name)


class Decentralized(Controller):
    """One learner per unit as the run loop's controller: each living unit's learner proposes its own phase and gets
    its own measurement only, through the guarded calls (a PluginError names the plug-in, the unit and the step)."""

    centralized = False

    def __init__(self, learners: list):
        self.learners = learners

    def initial(self) -> np.ndarray:
        self.kept = np.array([kept_phase(learner, u, 0) for u, learner in enumerate(self.learners)], dtype=float)
        return self.kept

    def propose(self, step: int, alive: np.ndarray, units: np.ndarray | None = None) -> np.ndarray:
        # a dead unit's learner stops: it keeps its phase and is not asked (nor is one not stepping now)
        alive = alive if units is None else alive & units
        return np.array([proposed_phase(learner, u, step) if alive[u] else self.kept[u]
                         for u, learner in enumerate(self.learners)], dtype=float)

    def update(self, step: int, u_measured: np.ndarray, alive: np.ndarray, units: np.ndarray | None = None
               ) -> tuple[np.ndarray, np.ndarray]:
        alive = alive if units is None else alive & units
        accepted = np.array([update_accepted(learner, u, step, float(u_measured[u])) if alive[u] else False
                             for u, learner in enumerate(self.learners)])
        self.kept = np.array([kept_phase(learner, u, step) for u, learner in enumerate(self.learners)], dtype=float)
        return accepted, self.kept

    def memory(self) -> np.ndarray:
        """Each learner's ``memory`` (``remembered``; a dead unit's learner keeps the one it had)."""
        return np.array([remembered(learner, u) for u, learner in enumerate(self.learners)], dtype=float)


def _check_phase(learner: object, name: str) -> None:
    """A plug-in's ``phase`` must exist and lie in [0, 1) after construction: the run loop records it."""
    expected = "instances to expose 'phase', the kept phase as a number in [0, 1)"
    try:
        phase = getattr(learner, "phase")
    except AttributeError:
        raise ConfigError(_SOURCE, name, f"{expected} (it has none)") from None
    except Exception as exc:  # a property may raise anything
        raise ConfigError(_SOURCE, name, f"{expected} (reading it raised {describe(exc)})") from None
    try:
        valid = 0.0 <= float(phase) < 1.0  # False for NaN
    except (TypeError, ValueError, OverflowError):
        valid = False
    if not valid:
        raise ConfigError(_SOURCE, name, expected, phase)


def learner_name(spec: str) -> str:
    """``spec`` checked by ``load_learner_class`` and named as ``--learner`` loads it again: a built-in by its key
    (whatever its case), a plug-in by the name as given. Not ``learner_spec`` of the class it loads: a class made by a
    factory is ``module:make.<locals>.C`` there, which no import reaches."""
    cls = load_learner_class(spec)
    return learner_spec(cls) if cls in LEARNERS.values() else spec.strip()


def learner_spec(cls: type) -> str:
    """How messages and records name ``cls``: its registry key for a built-in, else 'module:QualifiedName' (which
    ``load_learner_class`` may not take back: ``learner_name`` names a spec the user gave)."""
    for key, builtin in LEARNERS.items():
        if cls is builtin:
            return key
    return f"{getattr(cls, '__module__', '?')}:{getattr(cls, '__qualname__', cls)}"


def as_phase(value: Any) -> float | None:
    """``value`` as a phase in [0, 1) if it is a finite real number (wrapped modulo 1), else None (a bool, a
    non-number, NaN or an infinity)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        return None
    try:
        phase = float(value)
    except (TypeError, ValueError, OverflowError):  # e.g. an int beyond float range, or a broken __float__
        return None
    return wrap_phase(phase) if math.isfinite(phase) else None


def call_learner(learner: object, method: str, unit: int, step: int, *args: Any) -> Any:
    """``learner.method(*args)`` for unit ``unit`` (0-based) at learning step ``step``; whatever it raises becomes one
    PluginError naming the plug-in, the method, the unit and the step."""
    try:
        return getattr(learner, method)(*args)
    except (Exception, SystemExit, GeneratorExit) as exc:  # sys.exit() in a plug-in must not end the run
        signature = "update(velocity)" if method == "update" else f"{method}()"
        raise PluginError(learner_spec(type(learner)), signature,
                          f"of unit {unit + 1} at learning step {step} to return (it raised {describe(exc)})") from None


def kept_phase(learner: object, unit: int, step: int) -> float:
    """The learner's ``phase`` as a phase in [0, 1) (wrapped modulo 1); a PluginError if reading it raises or it is no
    finite number."""
    try:
        value = learner.phase
    except (Exception, SystemExit) as exc:  # a property may raise anything
        raise PluginError(learner_spec(type(learner)), "phase", f"of unit {unit + 1} at learning step {step} to be "
                          f"readable (reading it raised {describe(exc)})") from None
    phase = as_phase(value)
    if phase is None:
        raise PluginError(learner_spec(type(learner)), "phase",
                          f"of unit {unit + 1} at learning step {step} to be a finite number (the kept phase)", value)
    return phase


def remembered(learner: object, unit: int) -> float:
    """The learner's ``memory`` (U_mem, mm/cycle) as a float; NaN when it keeps none (no such attribute, or not a
    real number: a plug-in need not have one); a PluginError if reading it raises."""
    try:
        value = getattr(learner, "memory", None)
    except (Exception, SystemExit) as exc:  # a property may raise anything
        raise PluginError(learner_spec(type(learner)), "memory", f"of unit {unit + 1} to be readable (reading it "
                          f"raised {describe(exc)})") from None
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        return math.nan
    try:
        return float(value)
    except (TypeError, ValueError, OverflowError):
        return math.nan


def proposed_phase(learner: object, unit: int, step: int) -> float:
    """The learner's ``propose()`` as a phase in [0, 1) (wrapped modulo 1); a PluginError if it raises or returns no
    finite number."""
    value = call_learner(learner, "propose", unit, step)
    phase = as_phase(value)
    if phase is None:
        raise PluginError(learner_spec(type(learner)), "propose()",
                          f"of unit {unit + 1} at learning step {step} to return a phase as a finite number", value)
    return phase


def update_accepted(learner: object, unit: int, step: int, velocity: float) -> bool:
    """The learner's ``update(velocity)``: whether it accepted, a bool (numpy's too); anything else (None, a number, a
    NaN, a string, an array) is a PluginError, as for a phase: bool(nan) is True, so a NaN counted as acceptance."""
    value = call_learner(learner, "update", unit, step, velocity)
    if not isinstance(value, (bool, np.bool_)):
        raise PluginError(learner_spec(type(learner)), "update(velocity)", f"of unit {unit + 1} at learning step "
                          f"{step} to return whether it accepted the trial (True or False)", value)
    return bool(value)
