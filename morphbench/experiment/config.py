"""Run configuration files: a shape, a learner, a sensor, an environment, events, physics, steps and seed.

    description = "S6: unit 2's bellows loses its needle at step 300"
    shape = "../shapes/chain-3.toml"    # relative to this file
    steps = 600
    seed = 1

    [learner]                 # name: thermal | flaky | averaged | adaptive | random | package.module:Class, ...
                              # and any LearnerParams field
    name = "thermal"
    temperature = 0.5

    [sensor]                  # SensorParams fields
    kind = "ideal"

    [environment]             # preset = "default" | "hardware" (optional), and EnvironmentParams fields on top;
    noise = 0.5               # mm/cycle            or, above the tables, environment = "hardware" alone
    vibration = 0.8
    [environment.friction_field]
    amplitude = 0.3

    [physics]                 # preset = "default" | "fast" | "reference" | "quasistatic", and PhysicsParams fields
    preset = "default"

    [[events]]                # see morphbench.experiment.events
    step = 300
    kind = "damage"
    unit = 2
    mode = "no-inflate"

``morphbench run FILE`` takes a run configuration or a bare morphology file (then everything else is default);
command-line options override the file. An environment preset (``params.ENVIRONMENT_PRESETS``) is a whole
EnvironmentParams named in one word; the fields written beside it replace the preset's, a sub-table's field by
field. A suite experiment (morphbench.bench.suite) is a run configuration whose values may be lists; each
combination is read by ``run_config_from_table``.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any, Callable

from morphbench.errors import ConfigError
from morphbench.files import is_file
from morphbench.experiment.events import parse_events
from morphbench.experiment.run import RunConfig
from morphbench.learning import load_learner_class
from morphbench.params import (
    ENVIRONMENT_PRESET,
    ENVIRONMENT_PRESETS,
    PHYSICS_PRESET,
    PHYSICS_PRESETS,
    SEED,
    STEPS,
    EnvironmentParams,
    LearnerParams,
    PhysicsParams,
    SensorParams,
    TEXT,
    learner_defaults,
)
from morphbench.readers import params_from_table
from morphbench.rules import check_rule
from morphbench.shapes import Shape, load_shape, read_toml, shape_from_table

RUN_KEYS = {"description", "shape", "steps", "seed", "learner", "sensor", "environment", "physics", "events"}


def load_run_config(path: str | Path, physics: str | None = None, environment: str | None = None) -> RunConfig:
    """A run configuration file, or a morphology file taken as a run with every default. ``physics``, a preset's name
    (``run --physics``), replaces the file's preset and backend; the file's other ``[physics]`` fields stay.
    ``environment``, an environment preset's name (``run --environment``), replaces the file's preset; the fields
    the file sets in ``[environment]`` stay on top of it."""
    path = Path(path)
    table = read_toml(path, "run configuration or morphology file")
    if physics is not None:
        check_rule(PHYSICS_PRESET, "", physics, "--physics", "physics")
    if environment is not None:
        check_rule(ENVIRONMENT_PRESET, "", environment, "--environment", "environment")
    if "assembly" in table:
        shape = shape_from_table(table, source=str(path), default_name=path.stem)
        return RunConfig(shape=shape, physics=PHYSICS_PRESETS[physics or "default"],
                         environment=ENVIRONMENT_PRESETS[environment or "default"])
    if physics is not None and isinstance(table.get("physics", {}), dict):
        own = {k: v for k, v in table.get("physics", {}).items() if k not in ("preset", "backend")}
        table = {**table, "physics": {"preset": physics, **own}}
    if environment is not None and isinstance(table.get("environment", {}), (dict, str)):
        own = table.get("environment", {})
        own = {k: v for k, v in own.items() if k != "preset"} if isinstance(own, dict) else {}
        table = {**table, "environment": {"preset": environment, **own}}
    return run_config_from_table(table, str(path), base=path.parent)


def run_config_from_table(table: dict[str, Any], source: str, base: Path,
                          load: Callable[[Path], Shape] = load_shape) -> RunConfig:
    """Validate a run configuration table; ``base`` is where relative shape paths start. ``load`` reads a morphology
    file (a suite passes one that reads each file once)."""
    for key in table:
        if key not in RUN_KEYS:
            raise ConfigError(source, key, f"one of the keys of a run configuration: {', '.join(sorted(RUN_KEYS))}")
    if not isinstance(table.get("shape"), str):
        raise ConfigError(source, "shape", "the path of a morphology file (a string, relative to this file)",
                          table.get("shape", ...))
    check_rule(TEXT, "", table.get("description", ""), source, "description")
    if "\0" in table["shape"]:
        raise ConfigError(source, "shape", "a path without a NUL byte", table["shape"])
    path = base / table["shape"]
    if not is_file(path):
        raise ConfigError(source, "shape", f"an existing morphology file (there is no file {path})", table["shape"])
    shape = load(path)
    learner_table = dict(_table(table, "learner", source))
    learner = learner_table.pop("name", "thermal")
    if not isinstance(learner, str):
        raise ConfigError(source, "learner.name", "a learner name or package.module:Class", learner)
    try:
        load_learner_class(learner)
    except ConfigError as exc:  # it names the learner as if given by --learner: name this file's key instead
        raise ConfigError(source, "learner.name", exc.expected, learner) from None
    fields = dict(
        shape=shape,
        learner=learner,
        learner_params=params_from_table(LearnerParams, learner_table, source, "learner", learner_defaults(learner)),
        sensor=params_from_table(SensorParams, _table(table, "sensor", source), source, "sensor"),
        environment=environment_from_table(table.get("environment", {}), source, "environment"),
        events=parse_events(table.get("events", []), source, shape.n_units, len(shape.links)),
        physics=physics_from_table(_table(table, "physics", source), source, "physics"),
        steps=check_rule(STEPS, "", table.get("steps", RunConfig.steps), source, "steps"),
        seed=check_rule(SEED, "", table.get("seed", RunConfig.seed), source, "seed"),
    )
    try:
        config = RunConfig(**fields)
    except ConfigError as exc:  # a rule across fields (params.check_run) names the shape file: name the file the key
        if exc.source != shape.source or exc.key.startswith("actuator."):  # is in (the actuator is the shape's)
            raise
        raise ConfigError(source, exc.key, exc.expected, exc.got) from None
    check_events_happen(config, source)
    return config


STORED_KEYS = ("shape", "learner", "learner_params", "sensor", "environment", "physics", "events", "steps", "seed")
"""the keys of a stored configuration (RunConfig.to_dict, summary.json's ``config``)."""


def run_config_from_dict(data: Any, source: str, key: str = "config") -> RunConfig:
    """A stored configuration (``RunConfig.to_dict``, summary.json's ``config``) read back through the loader of run
    files, ``run_config_from_table``: a replayed run is checked by the rules of ``morphbench run``. A ConfigError
    names ``source`` and the stored key (``config.physics.timestep``)."""
    if not isinstance(data, dict):
        raise ConfigError(source, key, "a run configuration written by morphbench (a table)", data)
    for name in STORED_KEYS:
        if name not in data:
            raise ConfigError(source, f"{key}.{name}", "a run configuration written by morphbench (it is missing)")
    for name in ("shape", "learner_params"):
        if not isinstance(data[name], dict):
            raise ConfigError(source, f"{key}.{name}", "a table", data[name])
    shape = data["shape"].get("source")
    if not isinstance(shape, str):
        raise ConfigError(source, f"{key}.shape.source", "the path of the run's morphology file", shape)
    table = {"shape": shape, "learner": {"name": data["learner"], **data["learner_params"]},
             **{name: data[name] for name in ("sensor", "environment", "physics", "events", "steps", "seed")}}
    try:
        return run_config_from_table(table, source, base=Path("."))
    except ConfigError as exc:
        if exc.source != source:  # the morphology file's own error names it
            raise
        stored = ("learner" if exc.key == "learner.name" else "learner_params" + exc.key[len("learner"):]
                  if exc.key.startswith("learner.") else exc.key)
        raise ConfigError(source, f"{key}.{stored}", exc.expected, exc.got) from None


def check_events_happen(config: RunConfig, source: str, steps_key: str | None = None) -> None:
    """ConfigError unless every event falls within the run's steps (a later one would silently never happen); it
    names the event's step, or ``steps_key`` when the steps were set elsewhere (``--steps``)."""
    for index, event in enumerate(config.events):
        if event.step > config.steps:
            raise ConfigError(source, steps_key or f"events[{index}].step",
                              f"a learning step <= the run's steps ({config.steps}): a later event never happens"
                              if steps_key is None else f"at least {event.step}, the step of events[{index}]",
                              event.step if steps_key is None else config.steps)


def physics_from_table(table: dict[str, Any], source: str, section: str) -> PhysicsParams:
    """A preset by name (``preset = "default"``), optionally with fields of PhysicsParams overriding it."""
    table = dict(table)
    preset = check_rule(PHYSICS_PRESET, "", table.pop("preset", "default"), source, f"{section}.preset")
    overrides = params_from_table(PhysicsParams, table, source, section)
    return dataclasses.replace(PHYSICS_PRESETS[preset], **{key: getattr(overrides, key) for key in table})


def environment_from_table(value: Any, source: str, section: str) -> EnvironmentParams:
    """A table of EnvironmentParams fields, on top of its ``preset`` if it names one (``preset = "hardware"``: its
    ``friction_field`` and ``ground`` sub-tables field by field), or a preset's name alone (``"hardware"``)."""
    if isinstance(value, str) and value in ENVIRONMENT_PRESETS:
        return ENVIRONMENT_PRESETS[value]
    if not isinstance(value, dict):
        raise ConfigError(source, section, "a table of EnvironmentParams fields or an environment preset's name ("
                          f"{', '.join(ENVIRONMENT_PRESETS)})", value)
    table = dict(value)
    preset = check_rule(ENVIRONMENT_PRESET, "", table.pop("preset", "default"), source, f"{section}.preset")
    return params_from_table(EnvironmentParams, table, source, section, ENVIRONMENT_PRESETS[preset])


def _table(table: dict[str, Any], key: str, source: str) -> dict[str, Any]:
    value = table.get(key, {})
    if not isinstance(value, dict):
        raise ConfigError(source, key, "a table", value)
    return value
