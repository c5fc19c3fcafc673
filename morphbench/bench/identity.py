"""The ids of runs, conditions, shapes and grounds: hashes of plain data, so that the same thing has the same id on
every machine and in every results directory. Pure functions with no imports beyond the standard library and
``params``: the metrics and the report use them without loading the run loop or the simulator."""

from __future__ import annotations

import dataclasses
import hashlib
import json
from typing import Any

from morphbench.params import ActuatorParams, EnvironmentParams, LearnerParams

LATER_FIELDS: dict[str, dict[str, Any]] = {
    "environment": {"clock_drift": 0.0, "clock_offset": 0.0},
    "learner_params": {name: getattr(LearnerParams(), name) for name in (
        "memory_weight", "adapt_rate", "adapt_window", "target_acceptance", "step_size_min", "step_size_max")},
    "actuator": {"open_stiffness": ActuatorParams().open_stiffness},
}
"""Fields added after results existed (the own clocks; the averaged and adaptive learners' own; the open bellows'
wall), by the table that holds them, with the value that acts as before: hashed only when set otherwise, so every
run and scan that existed before them keeps its id."""


def without_later(section: str, data: dict) -> dict:
    """``data`` (the fields of the table ``section``) without the LATER_FIELDS that have the value of before."""
    later = LATER_FIELDS[section]
    return {key: value for key, value in data.items() if key not in later or later[key] != value}


def stable_hash(data: Any, length: int = 12) -> str:
    """A short hex digest of canonical JSON: the same data gives the same id on every machine and run."""
    text = json.dumps(data, sort_keys=True, separators=(",", ":"), allow_nan=True, default=_plain)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:length]


def _plain(value: Any) -> Any:
    """numpy values as plain Python ones, for hashing."""
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"cannot hash a {type(value).__name__} in a run configuration")


def shape_identity(shape) -> dict:
    """What a shape is physically (its bodies, links and actuator) and its name, not where it was loaded from."""
    data = dataclasses.asdict(shape)
    data.pop("source", None)
    data.pop("description", None)
    data["actuator"] = without_later("actuator", data["actuator"])
    return data


def shape_id(shape) -> str:
    return stable_hash(shape_identity(shape))


def config_identity(config, preset: str) -> dict:
    """Everything that determines a run's records (a RunConfig), JSON-ready, the shape by content (what its id
    hashes). ``noise`` and ``physics_preset`` are there because the first suites hashed them: existing results keep
    their ids."""
    data = {}
    for f in dataclasses.fields(config):
        value = getattr(config, f.name)
        data[f.name] = dataclasses.asdict(value) if dataclasses.is_dataclass(value) else value
    data["learner_params"] = without_later("learner_params", data["learner_params"])
    data["shape"] = shape_identity(config.shape)
    data["events"] = [e.settings() for e in config.events]  # each its kind, step and own fields
    data["environment"] = environment_identity(config.environment)
    data["noise"] = config.environment.noise
    data["physics_preset"] = preset
    return data


def environment_id(environment: EnvironmentParams) -> str:
    """A hash of the ground a run or scan moves on (the environment without measurement noise, which changes what
    learners measure, not the landscape): a scan's best Ubar is compared with the runs in the same environment."""
    data = environment_identity(environment)
    data.pop("noise", None)
    return stable_hash(data)


def environment_identity(environment: EnvironmentParams) -> dict:
    """An environment's fields, as hashed: without the LATER_FIELDS at their old value."""
    return without_later("environment", dataclasses.asdict(environment))

