"""A suite's expansion: each experiment a run configuration whose lists are the axes of a matrix, every combination
read by the run-configuration loader (experiment/config.py) and run once per seed, with stable ids
(morphbench/identity.py); each scan table into a ScanSpec. The format is described in bench/suite.py."""

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
from morphbench.bench.aliases import rename
from morphbench.bench.cost import run_cost
from morphbench.identity import config_identity, identity, shape_id, shape_identity, stable_hash
from morphbench.bench.model import SCAN_PART_POINTS, Experiment, RunSpec, ScanSpec
from morphbench.errors import ConfigError
from morphbench.experiment.config import environment_from_table, physics_from_table, run_config_from_table
from morphbench.experiment.events import Event, parse_event
from morphbench.experiment.run import RunConfig
from morphbench.experiment.scan import (DEFAULT_CYCLES, DEFAULT_DISCARD, check_scan_size, scan_phases, wave_lags,
                                       wave_phases)
from morphbench.files import is_file
from morphbench.readers import check_keys, distinct, is_tables
from morphbench.rules import check_plan_size, check_rule
from morphbench.shapes import Shape, load_shape

SCAN_KEYS = ("name", "shape", "resolution", "samples", "waves", "cycles", "discard", "seed", "physics",
             "environment", "damage")
AXIS_ORDER = ("shape", "learner", "sensor", "environment", "steps", "physics")
"""The matrix's axes, the first varying slowest: runs are listed in the order the first suites listed them."""

_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")


@dataclass
class Context:
    source: str
    base: Path
    shapes: dict = field(default_factory=dict)

    def load(self, path: Path) -> Shape:
        """A morphology file, read once per suite (a malformed one names itself and its key)."""
        if path not in self.shapes:
            self.shapes[path] = load_shape(path)
        return self.shapes[path]

    def shape(self, value: Any, key: str) -> Shape:
        if not isinstance(value, str) or not value:
            raise ConfigError(self.source, key, "the path of a morphology file (a string)", value)
        path = self.base / value  # an absolute value stays itself
        if not is_file(path):
            raise ConfigError(self.source, key, f"an existing morphology file (there is no file {path})", value)
        return self.load(path)


def merge(base: Any, over: Any) -> Any:
    """``over`` where it has a value, else ``base``: tables key by key, a table into each table of a list of them
    (defaults for every environment of an experiment); any other value replaces."""
    if isinstance(base, dict) and isinstance(over, dict):
        return {**base, **{k: merge(base[k], v) if k in base else v for k, v in over.items()}}
    if isinstance(base, dict) and is_tables(over):
        return [merge(base, o) for o in over]
    if is_tables(base) and isinstance(over, dict):
        return [merge(b, over) for b in base]
    return over


def _alternatives(value: Any, src: str, path: str, where: str) -> list[tuple[Any, dict[str, str]]]:
    """Every value ``value`` stands for: a table every combination of its fields' values, a list of tables each of
    its tables' values in turn, a list of plain values each of them, anything else itself. Each comes with where its
    tables came from: ``path`` is the key in one combination, ``where`` the key as written (``environment`` and
    ``environment[1]``)."""
    if isinstance(value, dict):
        keys = list(value)
        options = [_alternatives(value[k], src, _join(path, k), _join(where, k)) for k in keys]
        return [({k: v for k, (v, _) in zip(keys, combo)}, {p: w for _, found in combo for p, w in found.items()})
                for combo in itertools.product(*options)]
    if is_tables(value):
        distinct(value, src, where)
        return [(v, {path: f"{where}[{i}]", **found}) for i, table in enumerate(value)
                for v, found in _alternatives(table, src, path, f"{where}[{i}]")]
    return [(v, {}) for v in _values(value, src, where)]


def expand_experiment(table: dict, names: dict[str, str], name: str, description: str, runs: dict[str, RunSpec],
                      ctx: Context) -> Experiment:
    """Each combination of the axes through the run-configuration loader, then once per seed."""
    src = ctx.source
    where = f"experiment[{name}]"
    table = dict(table)
    events = table.pop("events")
    axes = {k: table[k] for k in AXIS_ORDER if k in table}
    try:
        seeds = [check_rule(P.SEED, "", s, src, "seed") for s in _values(table.pop("seed", 0), src, "seed")]
        # counted before anything is expanded: a product of a few long lists is more runs than memory holds
        check_plan_size(len(runs) + _count(axes) * len(seeds), P.MAX_SUITE_RUNS, P.SUITE_RUN_BYTES,
                        "runs in a suite (its experiments' combinations times seeds)", src, "seed",
                        len(seeds))
        combinations = _alternatives(axes, src, "", "")
    except ConfigError as exc:
        raise _named(exc, where, names) from None

    # dicts as ordered sets: a membership test by list scan made expansion quadratic in the seeds
    run_ids: dict[str, None] = {}
    condition_ids: dict[str, None] = {}
    conditions: list[dict] = []
    grounds: dict[str, str] = {}  # environment label -> environment id
    labels: dict[str, str] = {}  # environment content -> label
    for combo, found in combinations:
        environment = combo.get("environment", {})
        label = None
        if isinstance(environment, dict):  # its name labels it in the results; it is no EnvironmentParams field
            environment = dict(environment)
            label = environment.pop("name", None)
        env_key = f"{where}.{rename(rename('environment', found), names)}"
        try:
            if label is not None:
                check_name(label, src, "environment.name")
            config = run_config_from_table({**combo, "environment": environment, "events": events}, src, ctx.base,
                                           load=ctx.load)
        except ConfigError as exc:
            if exc.source != src:  # a morphology file's own error
                raise
            if exc.key.startswith("events") and exc.key.endswith((".unit", ".link")):
                exc = ConfigError(src, exc.key, f"{exc.expected} (shape {ctx.load(ctx.base / combo['shape']).name})",
                                  exc.got)
            raise _named(exc, where, found, names) from None
        label = label or environment_label(environment)
        ground = P.environment_id(config.environment)
        if grounds.setdefault(label, ground) != ground:
            raise ConfigError(src, f"{env_key}.name", "a label no other environment of the experiment has (give each "
                                                      "a distinct name)", label)
        content = json.dumps(dataclasses.asdict(config.environment), sort_keys=True)
        if labels.setdefault(content, label) != label:
            raise ConfigError(src, env_key, "distinct environments (this one repeats another)", combo["environment"])
        physics = dict(combo.get("physics", {}))
        preset = physics.pop("preset", "default")
        condition = _condition_columns(config, ", ".join([preset, _settings_label(physics)]) if physics else preset)
        condition.update(environment=label, environment_id=ground, events=events_summary(config.events))
        hashed = config_identity(config, preset)
        del hashed["seed"]
        condition_id = stable_hash(hashed)
        cost = run_cost(config)
        for seed in seeds:
            run_id = stable_hash({**hashed, "seed": seed})
            if run_id not in runs:
                runs[run_id] = RunSpec(run_id, condition_id, condition, seed, dataclasses.replace(config, seed=seed),
                                       cost=cost)
            run_ids.setdefault(run_id)
        if condition_id not in condition_ids:
            condition_ids[condition_id] = None
            conditions.append(condition)
    varying = tuple(k for k in conditions[0] if len({json.dumps(c[k]) for c in conditions}) > 1)
    return Experiment(name, description, tuple(run_ids), tuple(condition_ids), varying)


def _count(value: Any) -> int:
    """How many alternatives ``_alternatives`` would list for ``value``, without listing them."""
    if isinstance(value, dict):
        return math.prod(_count(v) for v in value.values())
    if is_tables(value):
        return sum(_count(table) for table in value)
    return len(value) if isinstance(value, list) else 1


def events_summary(events: tuple[Event, ...]) -> str:
    """One text for a condition column: ``step 150 damage unit=2 mode=no-inflate; step 300 noise sigma=0.5``."""
    return "; ".join(f"step {e.step} {e.describe()}" for e in events) or "none"


def environment_label(environment: dict | str) -> str:
    """The label of an environment without a name: its preset, then the settings written beside it but the noise
    (``hardware, friction_field.offset=0.5``), or the settings alone (``friction_scale=1.5``, ``default``)."""
    if isinstance(environment, str):
        return environment
    settings = {k: v for k, v in environment.items() if k not in ("noise", "preset")}
    if "preset" not in environment:
        return _settings_label(settings)
    preset = str(environment["preset"])
    return ", ".join([preset, _settings_label(settings)]) if settings else preset


def _settings_label(table: dict, prefix: str = "") -> str:
    """``friction_scale=1.5, friction_field.amplitude=0.3``: the settings of a table, or ``default``."""
    parts = []
    for key, value in table.items():
        if isinstance(value, dict):
            inner = _settings_label(value, f"{prefix}{key}.")
            parts += [inner] if inner != "default" else []
        else:
            parts.append(f"{prefix}{key}={value}")
    return ", ".join(parts) or "default"


def _condition_columns(config: RunConfig, physics: str) -> dict:
    shape, sensor = config.shape, config.sensor
    columns: dict[str, Any] = {"shape": shape.name, "shape_id": shape_id(shape), "n_units": shape.n_units,
                               "learner": config.learner}
    columns.update(dataclasses.asdict(config.learner_params))
    columns["sensor"] = sensor.kind
    for f in dataclasses.fields(sensor):
        value = getattr(sensor, f.name)
        if f.name == "kind":
            continue
        if dataclasses.is_dataclass(value):  # a sensor's own parameters (sensor.optical): only for that sensor
            if f.name == sensor.kind:
                columns.update({f"sensor_{f.name}_{k}": v for k, v in dataclasses.asdict(value).items()})
        else:
            columns[f"sensor_{f.name}"] = value
    columns.update(noise=config.environment.noise, physics=physics, steps=config.steps)
    return columns


def expand_scan(table: dict, index: int, ctx: Context) -> ScanSpec:
    src = ctx.source
    where = f"scan[{index}]"
    if not isinstance(table, dict):
        raise ConfigError(src, where, "a table", table)
    check_keys(table, SCAN_KEYS, src, f"{where}.")
    if "shape" not in table:
        raise ConfigError(src, f"{where}.shape", "the path of a morphology file")
    shape = ctx.shape(table["shape"], f"{where}.shape")
    if shape.n_units < 2:
        raise ConfigError(src, f"{where}.shape", "a shape with at least 2 active units to scan phase differences",
                          table["shape"])
    waves = None
    if "waves" in table:
        both = next((key for key in ("resolution", "samples") if key in table), None)
        if both is not None:
            raise ConfigError(src, f"{where}.waves", f"either waves or {both} in one scan (waves = N measures N "
                                                     "travelling waves, resolution and samples a grid or random "
                                                     "phases)", table["waves"])
        waves = check_rule(P.COUNT, "", table["waves"], src, f"{where}.waves")
    resolution = check_rule(P.COUNT, "", table.get("resolution", waves or 20), src, f"{where}.resolution")
    samples = table.get("samples")
    if samples is not None:
        samples = check_rule(P.COUNT, "", samples, src, f"{where}.samples")
    cycles = check_rule(P.COUNT, "", table.get("cycles", DEFAULT_CYCLES), src, f"{where}.cycles")
    discard = check_rule(P.NATURAL, "", table.get("discard", DEFAULT_DISCARD), src, f"{where}.discard")
    seed = check_rule(P.SEED, "", table.get("seed", 0), src, f"{where}.seed")
    physics, physics_label = _scan_physics(table.get("physics", "default"), src, f"{where}.physics")
    environment_table = table.get("environment", {})
    if isinstance(environment_table, str) and environment_table in P.ENVIRONMENT_PRESETS:  # a preset's name
        environment_table = {"preset": environment_table}
    if not isinstance(environment_table, dict):
        raise ConfigError(src, f"{where}.environment", "a table of EnvironmentParams fields or an environment "
                                                       f"preset's name ({', '.join(P.ENVIRONMENT_PRESETS)})",
                          environment_table)
    for key in ("noise", "noise_ground"):
        if key in environment_table:
            raise ConfigError(src, f"{where}.environment.{key}", "no noise in a scan's environment: scans measure the "
                                                                 "true velocity", environment_table[key])
    environment = environment_from_table(environment_table, src, f"{where}.environment")
    for key in ("clock_drift", "clock_offset"):
        if environment_table.get(key):
            raise ConfigError(src, f"{where}.environment.{key}", "0 in a scan: a scan measures fixed phases, on one "
                              "clock", environment_table[key])
    environment = P.scan_environment(environment)  # a preset's ground and pumps, without its noise and clocks
    damage = None
    if "damage" in table:
        damage = parse_event(table["damage"], src, f"{where}.damage", shape.n_units, len(shape.links), kind="damage")
    kind = f"waves{waves}" if waves else f"r{resolution}"
    default_name = f"{shape.name}-{kind}" + (f"-unit{damage.unit}-{damage.mode}" if damage else "")
    name = check_name(table.get("name", default_name), src, f"{where}.name")
    sampled = shape.n_units > 3
    if waves:
        check_plan_size(waves, P.MAX_SCAN_POINTS, P.SCAN_POINT_BYTES, "scan points (waves)", src, f"{where}.waves",
                        waves)
        # unit 1 at phase 0, as in every scan (its points store dphi_i, unit i's phase minus unit 1's): a no-op where
        # unit 1 is in the front column (chains, sheets, grids, stacks), elsewhere (a shuffled chain) each wave
        # shifted by unit 1's phase, the same gait a moment later
        phases = wave_phases(shape, wave_lags(waves))
        phases = np.mod(phases - phases[:, :1], 1.0)
    else:
        check_scan_size(shape.n_units, resolution, samples, src, f"{where}.samples" if sampled and samples else
                        f"{where}.resolution")
        phases = scan_phases(shape.n_units, resolution, samples, seed)
    hashed = {"shape": shape_identity(shape), "resolution": resolution, "samples": samples if sampled else None,
              "seed": seed if sampled else None, "cycles": cycles, "discard": discard,
              "physics": identity(physics), "part_points": SCAN_PART_POINTS,
              "environment": identity(environment)}  # the default one keeps earlier scans' ids
    if damage is not None:  # a healthy scan keeps the id it had before scans could be damaged
        hashed["damage"] = {"unit": damage.unit, "mode": damage.mode}
    if waves:  # only in a scan of waves: every other scan keeps the id it had before scans could be waves
        hashed.update(resolution=None, samples=None, seed=None, waves=waves)
    scan_id = stable_hash(hashed)
    columns = {"scan": name, "shape": shape.name, "shape_id": shape_id(shape), "n_units": shape.n_units,
               "resolution": resolution, "samples": len(phases), "waves": waves or 0, "cycles": cycles,
               "discard": discard, "seed": seed, "physics": physics_label,
               "environment": environment_label(environment_table), "environment_id": P.environment_id(environment),
               "damage": damage.describe() if damage else "none"}
    return ScanSpec(scan_id, name, shape, columns, physics, cycles, discard, phases, environment, damage)


def _scan_physics(value: Any, src: str, key: str) -> tuple[P.PhysicsParams, str]:
    """A scan's ``physics``, as a run's: a preset's name, or a table of a preset and PhysicsParams fields; the
    parameters and the label of the ``physics`` column (the preset, then the fields set, as for runs)."""
    if isinstance(value, dict):
        overrides = {k: v for k, v in value.items() if k != "preset"}
        preset = value.get("preset", "default")
        physics = physics_from_table(value, src, key)  # checks the preset's name and every field
        return physics, ", ".join([preset, _settings_label(overrides)]) if overrides else preset
    preset = check_rule(P.PHYSICS_PRESET, "", value, src, key)
    return P.PHYSICS_PRESETS[preset], preset


def _values(value: Any, source: str, key: str) -> list:
    """A scalar or a non-empty list of distinct scalars, as a list."""
    values = value if isinstance(value, list) else [value]
    if not values:
        raise ConfigError(source, key, "a value or a non-empty list of values", value)
    for v in values:
        if isinstance(v, (list, dict)):
            raise ConfigError(source, key, "a value or a list of plain values (no nested lists or tables)", value)
    return distinct(values, source, key)


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


def _named(exc: ConfigError, where: str, *names: dict[str, str]) -> ConfigError:
    """An error of the run-configuration loader or of an axis, its key as the suite file writes it."""
    key = exc.key
    for known in names:
        key = rename(key, known)
    return ConfigError(exc.source, f"{where}.{key}", exc.expected, exc.got)


def check_name(value: Any, source: str, key: str) -> str:
    if not isinstance(value, str) or not _NAME.match(value):
        raise ConfigError(source, key, "a name of letters, digits, '_', '.' and '-' (starting with a letter or digit)",
                          value)
    return value
