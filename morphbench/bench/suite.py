"""Suite files: a matrix of learning runs and a list of landscape scans, expanded into jobs with stable ids.

A suite file is TOML::

    name = "smoke"                      # optional, default: the file's stem
    description = "what this suite is for"

    [defaults]                          # optional: any experiment key, used where an experiment leaves it out
    steps = 10
    seeds = 2

    [[experiment]]                      # a matrix: every combination of the listed values is one condition,
    name = "S4"                         #   and every condition is run once per seed
    description = "Thermal vs Flaky with measurement noise"
    shapes = ["../shapes/chain-3.toml"] # morphology files, relative to the suite file
    learners = ["thermal", "flaky"]     # thermal, flaky, random or a plug-in package.module:Class
    noise = [0.0, 0.5, 1.0]             # mm/cycle, Gaussian noise on each measured velocity
    seeds = 10                          # seeds 0..9, or a list of distinct seeds: [0, 3, 7]
    steps = 300                         # learning steps (a number or a list of numbers)
    physics = "default"                 # default, fast, reference or quasistatic (or a list)
    environments = [{}, {friction_field = {amplitude = 0.3}}]   # an axis of EnvironmentParams tables (see below)
    [experiment.learner_params]         # morphbench.params.LearnerParams fields; a list sweeps the field
    step_size = [0.1, 0.025]
    temperature = 0.5
    [experiment.sensor]                 # morphbench.params.SensorParams fields (a list sweeps), kind "ideal" by
    kind = "ideal"                      #   default in suites; [experiment.sensor.optical] for an optical one
    [[experiment.events]]               # events applied to every run of the experiment (morphbench.experiment.events)
    step = 150
    kind = "damage"
    unit = 2
    mode = "no-inflate"

    [[scan]]                            # a landscape at fixed phases (morphbench.experiment.scan)
    shape = "../shapes/chain-2.toml"
    resolution = 20                     # points per phase axis (up to 3 units; beyond: `samples` seeded points)
    cycles = 12                         # cycles measured per point (default 12), after `discard` (default 2)
    environment = {friction_scale = 1.5}   # optional: the EnvironmentParams the scan runs in (no noise: scans
                                           #   measure the true velocity)

Environments: ``environments`` is an axis like the others, a list of tables each read as a run configuration's
``[environment]`` (morphbench.shapes.params_from_table: friction_scale, vibration, noise and the
friction_field and ground sub-tables), inline (``environments = [{}, {friction_scale = 1.5}]``) or as
``[[experiment.environments]]`` tables. A table may have a ``name``: the label of the environment in the condition
columns (``environment``); without one the label lists the table's settings (``friction_field.amplitude=0.3``, or
``default`` for ``{}``). Labels must differ within an experiment. Measurement noise is either the ``noise`` axis or an
environment's ``noise``, never both (ConfigError).

Events: ``events`` is one array of event tables (``[[experiment.events]]``, as a run configuration's ``[[events]]``),
applied to every run of the experiment and checked against each of its shapes (a damaged unit or a cut link out of
range is a ConfigError naming the suite file and ``experiment[NAME].events[i].unit``) and its steps (an event after
the last step would never happen). The condition column ``events`` summarises them (``step 150 damage unit=2
mode=no-inflate``; ``none`` without events).

Every key is checked: an unknown key, a value of the wrong type or out of range, a missing morphology file or an
unusable learner raises ``ConfigError`` naming the suite file and the key (``experiment[S4].noise``).

Each run's id is a hash of everything that determines its records (the shape's content, not its path; the
learner, its parameters, sensor, environment, events and physics parameters, noise, steps, seed), so the same run has
the same id in any
suite, any directory and on any machine: a results directory skips the runs it already holds, and a run listed by two
experiments of a suite is run once. A condition is a run's configuration without its seed; its id is a hash too.
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from morphbench import params as P
from morphbench.bench.identity import config_identity, environment_id, shape_id, shape_identity, stable_hash
from morphbench.errors import ConfigError
from morphbench.experiment.events import Event, parse_events
from morphbench.experiment.run import RunConfig
from morphbench.experiment.scan import DEFAULT_CYCLES, DEFAULT_DISCARD, scan_phases
from morphbench.files import read_toml_with_text
from morphbench.learning import load_learner_class
from morphbench.shapes import Shape, load_shape, params_from_table

AXIS_KEYS = ("shapes", "learners", "learner_params", "sensor", "noise", "environments", "events", "seeds", "steps",
             "physics")
EXPERIMENT_KEYS = ("name", "description", *AXIS_KEYS)
SCAN_KEYS = ("name", "shape", "resolution", "samples", "cycles", "discard", "seed", "physics", "environment")
SUITE_KEYS = ("name", "description", "defaults", "experiment", "scan")
FUTURE_KEYS = {
    "environment": "an experiment's environments are a list: environments = [{...}, ...] or [[experiment.environments]]",
}
"""Keys that are easy to mistake for a known one: rejected with a message that points to the right one."""

SCAN_PART_POINTS = 20
"""A scan is split into jobs of this many points, so its points spread over the workers like runs do."""

_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")


def body_cost(shape: Shape) -> float:
    """Relative wall time of one cycle of a shape (measured: about bodies^1.15 on chains of 3 to 21 bodies)."""
    return float(len(shape.bodies)) ** 1.15


@dataclass(frozen=True)
class RunSpec:
    """One learning run of a suite."""

    id: str
    condition_id: str
    condition: dict
    """flat, JSON-ready columns that name the condition (shape, learner, its parameters, noise, ...)."""
    seed: int
    config: RunConfig
    cost: float
    """relative cost estimate (simulated cycles x body_cost), for the progress bar and longest-first scheduling."""


@dataclass(frozen=True)
class ScanSpec:
    """One landscape scan, split into parts of at most SCAN_PART_POINTS points."""

    id: str
    name: str
    shape: Shape
    columns: dict
    """flat, JSON-ready description: scan, shape, shape_id, n_units, resolution, samples, cycles, ..."""
    physics: P.PhysicsParams
    cycles: int
    discard: int
    phases: np.ndarray
    environment: P.EnvironmentParams = field(default_factory=P.EnvironmentParams)

    def part_ids(self) -> list[str]:
        n_parts = max(1, math.ceil(len(self.phases) / SCAN_PART_POINTS))
        return [f"{self.id}-{k:03d}" for k in range(n_parts)]


@dataclass(frozen=True)
class ScanPart:
    """The payload of a scan job: the points of one part of a scan and what each point needs."""

    shape: Shape
    phases: np.ndarray
    physics: P.PhysicsParams
    cycles: int
    discard: int
    environment: P.EnvironmentParams


@dataclass(frozen=True)
class Job:
    """A unit of work for an executor: a run, or a part of a scan. ``payload`` is all a worker needs."""

    id: str
    kind: str
    """'run' or 'scan'."""
    payload: RunConfig | ScanPart
    cost: float


@dataclass(frozen=True)
class Experiment:
    name: str
    description: str
    run_ids: tuple[str, ...]
    condition_ids: tuple[str, ...]
    varying: tuple[str, ...]
    """condition columns that take more than one value in this experiment (what its figures tell apart)."""


@dataclass
class Suite:
    name: str
    description: str
    source: str
    text: str
    experiments: list[Experiment] = field(default_factory=list)
    runs: dict[str, RunSpec] = field(default_factory=dict)
    scans: list[ScanSpec] = field(default_factory=list)

    def jobs(self) -> list[Job]:
        """Every job of the suite in a fixed order: runs as the experiments list them, then scan parts."""
        jobs = [Job(spec.id, "run", spec.config, spec.cost) for spec in self.runs.values()]
        for scan in self.scans:
            per_point = (scan.cycles + scan.discard) * body_cost(scan.shape)
            for k, part_id in enumerate(scan.part_ids()):
                phases = scan.phases[k * SCAN_PART_POINTS:(k + 1) * SCAN_PART_POINTS]
                part = ScanPart(scan.shape, phases, scan.physics, scan.cycles, scan.discard, scan.environment)
                jobs.append(Job(part_id, "scan", part, per_point * len(phases)))
        return jobs

    def plan(self) -> dict:
        """JSON-ready: what the results directory needs to rebuild tables and report without the suite file."""
        return {
            "suite": self.name,
            "description": self.description,
            "source": self.source,
            "experiments": [dataclasses.asdict(e) for e in self.experiments],
            "runs": [
                {"id": r.id, "condition_id": r.condition_id, "condition": r.condition, "seed": r.seed}
                for r in self.runs.values()
            ],
            "scans": [{"id": s.id, "name": s.name, "columns": s.columns, "parts": s.part_ids()} for s in self.scans],
        }


# --- reading a suite file ---------------------------------------------------------------------------------------


def load_suite(path: str | Path) -> Suite:
    """Read, validate and expand a suite file."""
    path = Path(path)
    table, text = read_toml_with_text(path, "suite file")
    return suite_from_table(table, source=str(path), base=path.parent, default_name=path.stem, text=text)


def suite_from_table(table: dict, *, source: str, base: Path, default_name: str = "suite", text: str = "") -> Suite:
    """A suite from a parsed TOML table; morphology paths are relative to ``base``."""
    _check_keys(table, SUITE_KEYS, source, "")
    name = _name(table.get("name", default_name), source, "name")
    description = _string(table.get("description", ""), source, "description")
    defaults = table.get("defaults", {})
    if not isinstance(defaults, dict):
        raise ConfigError(source, "defaults", "a table of experiment keys", defaults)
    _check_keys(defaults, AXIS_KEYS, source, "defaults.")
    experiments = _array_of_tables(table, "experiment", source)
    scans = _array_of_tables(table, "scan", source)
    if not experiments and not scans:
        raise ConfigError(source, "experiment", "at least one [[experiment]] or [[scan]] table")
    suite = Suite(name=name, description=description, source=source, text=text)
    ctx = _Context(source, base)
    seen: set[str] = set()
    for index, raw in enumerate(experiments, start=1):
        merged = {**defaults, **raw}
        exp_name = _name(raw.get("name", f"experiment-{index}"), source, f"experiment[{index}].name")
        if exp_name in seen:
            raise ConfigError(source, f"experiment[{index}].name", "a name no other experiment has", exp_name)
        seen.add(exp_name)
        suite.experiments.append(_expand_experiment(merged, exp_name, suite.runs, ctx))
    scan_names: set[str] = set()
    for index, raw in enumerate(scans, start=1):
        spec = _expand_scan(raw, index, ctx)
        if spec.name in scan_names:
            raise ConfigError(source, f"scan[{index}].name", "a name no other scan has", spec.name)
        scan_names.add(spec.name)
        if any(s.id == spec.id for s in suite.scans):
            raise ConfigError(source, f"scan[{index}]", "a scan that differs from the others (it repeats one)")
        suite.scans.append(spec)
    return suite


@dataclass
class _Context:
    source: str
    base: Path
    shapes: dict = field(default_factory=dict)

    def shape(self, value: Any, key: str) -> Shape:
        if not isinstance(value, str) or not value:
            raise ConfigError(self.source, key, "the path of a morphology file (a string)", value)
        path = Path(value)
        if not path.is_absolute():
            path = self.base / path
        if path not in self.shapes:
            if not path.is_file():
                raise ConfigError(self.source, key, f"existing morphology files (there is no file {path})", value)
            self.shapes[path] = load_shape(path)  # a malformed shape file names itself and its key
        return self.shapes[path]


def _expand_experiment(table: dict, name: str, runs: dict[str, RunSpec], ctx: _Context) -> Experiment:
    src = ctx.source
    where = f"experiment[{name}]"
    _check_keys(table, EXPERIMENT_KEYS, src, f"{where}.")
    description = _string(table.get("description", ""), src, f"{where}.description")
    if "shapes" not in table:
        raise ConfigError(src, f"{where}.shapes", "a list of morphology files (relative to the suite file)")
    shapes = [ctx.shape(v, f"{where}.shapes") for v in _values(table["shapes"], src, f"{where}.shapes")]
    learners = _values(table.get("learners", ["thermal"]), src, f"{where}.learners")
    for learner in learners:
        _learner(learner, src, f"{where}.learners")
    learner_params = _swept_params(P.LearnerParams, table.get("learner_params", {}), src, f"{where}.learner_params",
                                   exclude=())
    sensor_table = table.get("sensor", {})
    if isinstance(sensor_table, dict):
        # Suites score the true velocity and run thousands of learning runs: they measure with the ideal sensor
        # (10% cheaper than the optical one) unless told otherwise.
        sensor_table = {"kind": "ideal", **sensor_table}
    sensors = _swept_params(P.SensorParams, sensor_table, src, f"{where}.sensor", exclude=("noise",))
    noises = [P.check(P.EnvironmentParams, "noise", v, src, f"{where}.noise")
              for v in _values(table.get("noise", [0.0]), src, f"{where}.noise")]
    steps = [P.check_rule(P.STEPS, "", v, src, f"{where}.steps")
             for v in _values(table.get("steps", [100]), src, f"{where}.steps")]
    physics = [P.check_rule(P.PHYSICS_PRESET, "", v, src, f"{where}.physics")
               for v in _values(table.get("physics", ["default"]), src, f"{where}.physics")]
    seeds = _seeds(table.get("seeds", [0]), src, f"{where}.seeds")
    environments = _environments(table.get("environments", [{}]), "noise" in table, src, f"{where}.environments")
    events = {id(shape): _events(table.get("events", []), shape, steps, src, f"{where}.events") for shape in shapes}
    summary = events_summary(events[id(shapes[0])])

    run_ids: list[str] = []
    condition_ids: list[str] = []
    conditions: list[dict] = []
    for shape, learner, lp, sensor, (label, environment, own_noise), noise, n_steps, preset in itertools.product(
            shapes, learners, learner_params, sensors, environments, noises, steps, physics):
        noise = environment.noise if own_noise else noise
        environment = dataclasses.replace(environment, noise=noise)
        for seed in seeds:
            config = RunConfig(shape=shape, learner=learner, learner_params=lp, sensor=sensor,
                               environment=environment, events=events[id(shape)],
                               physics=P.PHYSICS_PRESETS[preset], steps=n_steps, seed=seed)
            identity = config_identity(config, preset)
            run_id = stable_hash(identity)
            del identity["seed"]
            condition_id = stable_hash(identity)
            condition = _condition_columns(shape, learner, lp, sensor, noise, preset, n_steps)
            condition.update(environment=label, environment_id=environment_id(environment), events=summary)
            if run_id not in runs:
                cycles = lp.warmup_cycles + (n_steps + 1) * (lp.cycles_per_step + lp.discard_cycles)
                runs[run_id] = RunSpec(run_id, condition_id, condition, seed, config, cost=cycles * body_cost(shape))
            if run_id not in run_ids:
                run_ids.append(run_id)
        if condition_id not in condition_ids:
            condition_ids.append(condition_id)
            conditions.append(condition)
    varying = tuple(k for k in conditions[0] if len({json.dumps(c[k]) for c in conditions}) > 1)
    return Experiment(name, description, tuple(run_ids), tuple(condition_ids), varying)


def events_summary(events: tuple[Event, ...]) -> str:
    """One text for a condition column: ``step 150 damage unit=2 mode=no-inflate; step 300 noise sigma=0.5``."""
    return "; ".join(f"step {e.step} {e.describe()}" for e in events) or "none"


def _environments(value: Any, noise_axis: bool, src: str, key: str) -> list[tuple[str, P.EnvironmentParams, bool]]:
    """(label, EnvironmentParams, whether it sets its own noise) for each table of an experiment's environments."""
    if isinstance(value, dict):
        value = [value]
    if not isinstance(value, list) or not value or not all(isinstance(v, dict) for v in value):
        raise ConfigError(src, key, "a non-empty list of environment tables ([{...}, ...] or "
                                    "[[experiment.environments]])", value)
    result, labels, seen = [], set(), set()
    for index, raw in enumerate(value):
        where = f"{key}[{index}]"
        table = dict(raw)
        name = table.pop("name", None)
        if name is not None:
            name = _name(name, src, f"{where}.name")
        if "noise" in table and noise_axis:
            raise ConfigError(src, f"{where}.noise", "no noise here when the experiment has a 'noise' axis: give "
                                                     "measurement noise in one place or the other", table["noise"])
        environment = params_from_table(P.EnvironmentParams, table, src, where)
        label = name or _environment_label(table)
        if label in labels:
            raise ConfigError(src, f"{where}.name", "a label no other environment of the experiment has (give each "
                                                    "a distinct name)", label)
        content = json.dumps(dataclasses.asdict(environment), sort_keys=True)
        if content in seen:
            raise ConfigError(src, where, "distinct environments (this one repeats another)", raw)
        labels.add(label)
        seen.add(content)
        result.append((label, environment, "noise" in table))
    return result


def _environment_label(table: dict, prefix: str = "") -> str:
    """``friction_scale=1.5, friction_field.amplitude=0.3``: the settings of an environment table, or ``default``."""
    parts = []
    for key, value in table.items():
        if isinstance(value, dict):
            inner = _environment_label(value, f"{prefix}{key}.")
            parts += [inner] if inner != "default" else []
        else:
            parts.append(f"{prefix}{key}={value}")
    return ", ".join(parts) or "default"


def _events(items: Any, shape: Shape, steps: list[int], src: str, key: str) -> tuple[Event, ...]:
    """An experiment's events, validated against one of its shapes and its numbers of steps."""
    try:
        events = parse_events(items, src, shape.n_units, len(shape.links))
    except ConfigError as exc:
        # parse_events names keys as a run configuration has them (events[0].unit): put them under the experiment
        sub = exc.key[len("events"):] if exc.key.startswith("events") else f".{exc.key}"
        expected = exc.expected + (f" (shape {shape.name})" if sub.endswith((".unit", ".link")) else "")
        raise ConfigError(src, f"{key}{sub}", expected, exc.got) from None
    for index, item in enumerate(items):
        if item["step"] > min(steps):
            raise ConfigError(src, f"{key}[{index}].step", f"a learning step <= the experiment's steps "
                                                          f"({min(steps)}): a later event never happens",
                              item["step"])
    return events


def _condition_columns(shape: Shape, learner: str, lp, sensor, noise: float, preset: str, steps: int) -> dict:
    columns: dict[str, Any] = {"shape": shape.name, "shape_id": shape_id(shape), "n_units": shape.n_units,
                               "learner": learner}
    columns.update(dataclasses.asdict(lp))
    columns["sensor"] = sensor.kind
    for f in dataclasses.fields(sensor):
        value = getattr(sensor, f.name)
        if f.name in ("kind", "noise"):
            continue
        if dataclasses.is_dataclass(value):  # a sensor's own parameters (sensor.optical): only for that sensor
            if f.name == sensor.kind:
                columns.update({f"sensor_{f.name}_{k}": v for k, v in dataclasses.asdict(value).items()})
        else:
            columns[f"sensor_{f.name}"] = value
    columns.update(noise=noise, physics=preset, steps=steps)
    return columns


def _expand_scan(table: dict, index: int, ctx: _Context) -> ScanSpec:
    src = ctx.source
    where = f"scan[{index}]"
    if not isinstance(table, dict):
        raise ConfigError(src, where, "a table", table)
    _check_keys(table, SCAN_KEYS, src, f"{where}.")
    if "shape" not in table:
        raise ConfigError(src, f"{where}.shape", "the path of a morphology file")
    shape = ctx.shape(table["shape"], f"{where}.shape")
    if shape.n_units < 2:
        raise ConfigError(src, f"{where}.shape", "a shape with at least 2 active units to scan phase differences",
                          table["shape"])
    resolution = P.check_rule(P.COUNT, "", table.get("resolution", 20), src, f"{where}.resolution")
    samples = table.get("samples")
    if samples is not None:
        samples = P.check_rule(P.COUNT, "", samples, src, f"{where}.samples")
    cycles = P.check_rule(P.COUNT, "", table.get("cycles", DEFAULT_CYCLES), src, f"{where}.cycles")
    discard = P.check_rule(P.NATURAL, "", table.get("discard", DEFAULT_DISCARD), src, f"{where}.discard")
    seed = P.check_rule(P.SEED, "", table.get("seed", 0), src, f"{where}.seed")
    preset = P.check_rule(P.PHYSICS_PRESET, "", table.get("physics", "default"), src, f"{where}.physics")
    environment_table = table.get("environment", {})
    if not isinstance(environment_table, dict):
        raise ConfigError(src, f"{where}.environment", "a table of EnvironmentParams fields", environment_table)
    if "noise" in environment_table:
        raise ConfigError(src, f"{where}.environment.noise", "no noise in a scan's environment: scans measure the "
                                                              "true velocity", environment_table["noise"])
    environment = params_from_table(P.EnvironmentParams, environment_table, src, f"{where}.environment")
    name = _name(table.get("name", f"{shape.name}-r{resolution}"), src, f"{where}.name")
    phases = scan_phases(shape.n_units, resolution, samples, seed)
    sampled = shape.n_units > 3
    identity = {"shape": shape_identity(shape), "resolution": resolution, "samples": samples if sampled else None,
                "seed": seed if sampled else None, "cycles": cycles, "discard": discard,
                "physics": dataclasses.asdict(P.PHYSICS_PRESETS[preset]), "part_points": SCAN_PART_POINTS,
                "environment": dataclasses.asdict(environment)}  # the default one keeps earlier scans' ids
    scan_id = stable_hash(identity)
    columns = {"scan": name, "shape": shape.name, "shape_id": shape_id(shape), "n_units": shape.n_units,
               "resolution": resolution, "samples": len(phases), "cycles": cycles, "discard": discard, "seed": seed,
               "physics": preset, "environment": _environment_label(environment_table),
               "environment_id": environment_id(environment)}
    return ScanSpec(scan_id, name, shape, columns, P.PHYSICS_PRESETS[preset], cycles, discard, phases, environment)


# --- validation helpers -----------------------------------------------------------------------------------------


def _check_keys(table: dict, allowed, source: str, prefix: str) -> None:
    for key in table:
        if key in FUTURE_KEYS and key not in allowed:
            raise ConfigError(source, f"{prefix}{key}", f"no such key here: {FUTURE_KEYS[key]}")
        if key not in allowed:
            raise ConfigError(source, f"{prefix}{key}", f"one of the known keys {', '.join(sorted(allowed))}")


def _array_of_tables(table: dict, key: str, source: str) -> list[dict]:
    value = table.get(key, [])
    if isinstance(value, dict):
        value = [value]
    if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
        raise ConfigError(source, key, f"an array of tables ([[{key}]])", value)
    return value


def _values(value: Any, source: str, key: str) -> list:
    """A scalar or a non-empty list of distinct scalars, as a list."""
    values = value if isinstance(value, list) else [value]
    if not values:
        raise ConfigError(source, key, "a value or a non-empty list of values", value)
    for v in values:
        if isinstance(v, (list, dict)):
            raise ConfigError(source, key, "a value or a list of plain values (no nested lists or tables)", value)
    if len({json.dumps(v) for v in values}) != len(values):
        raise ConfigError(source, key, "distinct values (a value is repeated)", value)
    return values


def _swept_params(cls: type, table: Any, source: str, key: str, exclude: tuple[str, ...]) -> list:
    """Every combination of a parameter table whose fields may hold lists, each validated as ``cls``."""
    if not isinstance(table, dict):
        raise ConfigError(source, key, f"a table of {cls.__name__} fields (a list of values sweeps a field)", table)
    for name in exclude:
        if name in table:
            raise ConfigError(source, f"{key}.{name}", f"no {name} here: give it as the experiment's own '{name}' key")
    names = list(table)
    # a sub-table (e.g. sensor.optical) is one value, read by params_from_table; any other value may be a list
    swept = [[table[n]] if isinstance(table[n], dict) else _values(table[n], source, f"{key}.{n}") for n in names]
    return [params_from_table(cls, dict(zip(names, combo)), source, key) for combo in itertools.product(*swept)]


def _learner(spec: Any, source: str, key: str) -> None:
    try:
        load_learner_class(spec)
    except ConfigError as exc:
        raise ConfigError(source, key, exc.expected, spec) from None


def _seeds(value: Any, source: str, key: str) -> list[int]:
    if isinstance(value, int) and not isinstance(value, bool):
        if value < 1:
            raise ConfigError(source, key, "a number of seeds >= 1 (seeds 0..n-1) or a list of distinct seeds", value)
        return list(range(value))
    if isinstance(value, list):
        return [P.check_rule(P.SEED, "", v, source, key) for v in _values(value, source, key)]
    raise ConfigError(source, key, "a number of seeds >= 1 (seeds 0..n-1) or a list of distinct seeds", value)


def _string(value: Any, source: str, key: str) -> str:
    if not isinstance(value, str):
        raise ConfigError(source, key, "a string", value)
    return value


def _name(value: Any, source: str, key: str) -> str:
    if not isinstance(value, str) or not _NAME.match(value):
        raise ConfigError(source, key, "a name of letters, digits, '_', '.' and '-' (starting with a letter or digit)",
                          value)
    return value
