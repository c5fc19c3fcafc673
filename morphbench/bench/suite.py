"""Suite files: a matrix of learning runs and a list of landscape scans, expanded into jobs with stable ids.

A suite file is TOML::

    name = "smoke"                      # optional, default: the file's stem
    description = "what this suite is for"

    physics = "quasistatic"             # optional: the preset of every run and scan that names no physics of its own
    [defaults]                          # optional: any experiment key, used where an experiment leaves it out
    steps = 10                          #   (tables merge key by key)
    seeds = 2

    [[experiment]]                      # a run configuration (morphbench.experiment.config) in which any value
    name = "S4"                         #   may be a list: every combination of the lists is one condition, and
    description = "Thermal vs Flaky with measurement noise"    # every condition is run once per seed
    shape = "../shapes/chain-3.toml"    # relative to the suite file (a list sweeps shapes)
    seeds = 10                          # seeds 0..9; or seed = 3, or seed = [0, 3, 7]
    steps = 300                         # learning steps (a number or a list of numbers)
    learner = {name = ["thermal", "flaky"], step_size = [0.1, 0.025]}   # name and LearnerParams fields
    scans = ["S3", "S3-damaged"]        # optional: the scans its figures draw its runs on (see "Scans of an
                                        #   experiment" below); not a run-configuration key, never an axis
    [experiment.environment]            # EnvironmentParams fields, as a run file's [environment]
    noise = [0.0, 0.5, 1.0]             # mm/cycle, Gaussian noise on each measured velocity
    [experiment.physics]                # preset (default, fast, reference, quasistatic) and PhysicsParams fields
    preset = "default"
    [experiment.sensor]                 # SensorParams fields; suites measure with kind = "ideal" unless told
    kind = "ideal"
    [[experiment.events]]               # events applied to every run of the experiment (morphbench.experiment.events)
    step = 150
    kind = "damage"
    unit = 2
    mode = "no-inflate"

    [[scan]]                            # a landscape at fixed phases (morphbench.experiment.scan)
    shape = "../shapes/chain-2.toml"
    resolution = 20                     # points per phase axis (up to 3 units; beyond: `samples` seeded points)
    cycles = 12                         # cycles measured per point (default 12), after `discard` (default 2)
    physics = "default"                 # a preset
    environment = {friction_scale = 1.5}   # optional: the EnvironmentParams the scan runs in (no noise: scans
                                           #   measure the true velocity)
    damage = {unit = 2, mode = "no-inflate"}   # optional: the assembly is damaged from the start, as a damage event
                                               #   does it (morphbench.experiment.events: the same fields and checks)

Axes: every list is an axis, at any depth (``[experiment.physics] timestep = [0.005, 0.01]``), except ``events``,
one list of event tables applied to every run. A list of tables is an axis of tables, each of which may sweep its
own fields: ``environment = [{name = "uniform", noise = [0.0, 0.5]}, {friction_scale = 1.5}]``. The values of a
list must differ. Each combination is read by ``run_config_from_table``, so a suite accepts, refuses and names
exactly what a run file does, under ``experiment[NAME].`` (``experiment[S4].environment.noise``); an event after
an experiment's last step is refused too (it would never happen). ``seeds = N`` (seeds 0..N-1) is the one key a
run file does not have.

Environments: a table may have a ``name``, the label of the environment in the condition column ``environment``;
without one the label lists the table's settings but its noise, which has a column of its own
(``friction_field.amplitude=0.3``, or ``default``). Different grounds need different labels. The column
``environment_id`` is a hash of the ground (the environment without noise). The column ``physics`` is the preset,
followed by any fields set beside it (``quasistatic, timestep=0.005``). The column ``events`` summarises the events
(``step 150 damage unit=2 mode=no-inflate``; ``none`` without events).

The first suites' keys are still read, as aliases of the run-configuration keys: ``shapes`` (``shape``),
``learners`` (``learner.name``), ``[experiment.learner_params]`` (``learner.*``), ``noise`` (``environment.noise``,
in each environment), ``environments`` (``environment``, a list of tables), ``seeds = [...]`` (``seed``) and
``physics = "fast"`` (``physics.preset``). A value given both ways in one table is a ConfigError.

Scans of an experiment: the report draws an experiment's runs on landscapes (on a 3-unit map, the phase differences
its learners tried). ``scans = [names]`` names the scans an experiment's figures use; without it they are the
suite's scans of the experiment's shape, physics and ground that are healthy or have the very damage (unit and mode)
of one of the experiment's events. Either way, a scan describes the part of a run whose world it measured: a healthy
scan the steps before the run's first event, a damaged scan the steps from the damage event that matches it until
the next event. So an experiment with a damage event at step 300 and ``scans = ["S3", "S6-damaged"]`` shows its
runs' steps 0-299 on S3 and 300 onwards on S6-damaged. A named scan must be a scan of the suite; one of another
shape, physics or ground is drawn without runs on it. The report's 'of scan best' (learned Ubar over the best Ubar of
a scan) always takes the healthy scans of the same shape, physics and ground, named or not: a damaged landscape is
no measure of what the healthy robot could do.

Every key is checked: an unknown key, a value of the wrong type or out of range, a missing morphology file or an
unusable learner raises ``ConfigError`` naming the suite file and the key as written (``experiment[S4].noise``).

Each run's id is a hash of everything that determines its records (the shape's content, not its path; the
learner, its parameters, sensor, environment, events and physics parameters, noise, steps, seed:
morphbench.bench.identity), so the same run has the same id in any suite, written with either keys, in any
directory and on any machine: a results directory skips the runs it already holds, and a run listed by two
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
from morphbench.experiment.config import RUN_KEYS, run_config_from_table
from morphbench.experiment.events import DamageEvent, Event, parse_event
from morphbench.experiment.run import RunConfig
from morphbench.experiment.scan import DEFAULT_CYCLES, DEFAULT_DISCARD, check_scan_size, scan_phases
from morphbench.files import is_file, read_toml_with_text
from morphbench.shapes import Shape, load_shape, params_from_table

ALIASES = ("shapes", "learners", "learner_params", "noise", "environments", "seeds")
"""The first suites' keys, still read: translated into run-configuration keys (_translate)."""
EXPERIMENT_KEYS = ("name", "scans", *RUN_KEYS, *ALIASES)
DEFAULT_KEYS = tuple(k for k in EXPERIMENT_KEYS if k not in ("name", "description", "scans"))
SCAN_KEYS = ("name", "shape", "resolution", "samples", "cycles", "discard", "seed", "physics", "environment",
             "damage")
SUITE_KEYS = ("name", "description", "physics", "defaults", "experiment", "scan")
AXIS_ORDER = ("shape", "learner", "sensor", "environment", "steps", "physics")
"""The matrix's axes, the first varying slowest: runs are listed in the order the first suites listed them."""
SUITE_DEFAULTS = {"sensor": {"kind": "ideal"}}
"""Suites score the true velocity and run thousands of learning runs: they measure with the ideal sensor (10%
cheaper than the optical one) unless told otherwise."""

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
    damage: DamageEvent | None = None
    """the assembly's damage from the start (None: healthy)."""

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
    damage: DamageEvent | None = None


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
    scans: tuple[str, ...] = ()
    """the names of the scans its figures use (its ``scans`` key; empty: found by shape, physics and ground)."""


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
                part = ScanPart(scan.shape, phases, scan.physics, scan.cycles, scan.discard, scan.environment,
                                scan.damage)
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


def load_suite(path: str | Path, physics: str | None = None) -> Suite:
    """Read, validate and expand a suite file; ``physics``, a preset name, replaces every run's and scan's physics
    (``morphbench bench --physics``)."""
    path = Path(path)
    table, text = read_toml_with_text(path, "suite file")
    return suite_from_table(table, source=str(path), base=path.parent, default_name=path.stem, text=text,
                            physics=physics)


def suite_from_table(table: dict, *, source: str, base: Path, default_name: str = "suite", text: str = "",
                     physics: str | None = None) -> Suite:
    """A suite from a parsed TOML table; morphology paths are relative to ``base``; ``physics`` as in load_suite."""
    if physics is not None:
        P.check_rule(P.PHYSICS_PRESET, "", physics, "--physics", "physics")
    _check_keys(table, SUITE_KEYS, source, "")
    name = _name(table.get("name", default_name), source, "name")
    description = _string(table.get("description", ""), source, "description")
    defaults = table.get("defaults", {})
    if not isinstance(defaults, dict):
        raise ConfigError(source, "defaults", "a table of experiment keys", defaults)
    _check_keys(defaults, DEFAULT_KEYS, source, "defaults.")
    defaults, default_names = _translate(defaults, source, "defaults.")
    defaults = _merge(SUITE_DEFAULTS, defaults)
    own_physics = table.get("physics")  # the suite's backend: a preset for every run and scan that names none
    if own_physics is not None:
        P.check_rule(P.PHYSICS_PRESET, "", own_physics, source, "physics")
        defaults.setdefault("physics", {"preset": own_physics})
    experiments = _array_of_tables(table, "experiment", source)
    scans = _array_of_tables(table, "scan", source)
    if not experiments and not scans:
        raise ConfigError(source, "experiment", "at least one [[experiment]] or [[scan]] table")
    suite = Suite(name=name, description=description, source=source, text=text)
    ctx = _Context(source, base)
    seen: set[str] = set()
    for index, raw in enumerate(experiments):  # keys count from 0, as everywhere; default names from 1
        exp_name = _name(raw.get("name", f"experiment-{index + 1}"), source, f"experiment[{index}].name")
        if exp_name in seen:
            raise ConfigError(source, f"experiment[{index}].name", "a name no other experiment has", exp_name)
        seen.add(exp_name)
        where = f"experiment[{exp_name}]"
        _check_keys(raw, EXPERIMENT_KEYS, source, f"{where}.")
        exp_description = _string(raw.get("description", ""), source, f"{where}.description")
        own, names = _translate({k: v for k, v in raw.items() if k not in ("name", "description", "scans")}, source,
                                f"{where}.")
        merged = _merge(defaults, {k: v for k, v in own.items() if k != "events"})
        if physics is not None:
            merged["physics"] = {"preset": physics}
        merged["events"] = own.get("events", defaults.get("events", []))  # an experiment's events replace the defaults'
        experiment = _expand_experiment(merged, {**default_names, **names}, exp_name, exp_description, suite.runs,
                                        ctx)
        suite.experiments.append(dataclasses.replace(experiment, scans=_scan_names(raw.get("scans", []), source,
                                                                                    f"{where}.scans")))
    scan_names: set[str] = set()
    for index, raw in enumerate(scans):
        if isinstance(raw, dict) and (physics or (own_physics is not None and "physics" not in raw)):
            raw = {**raw, "physics": physics or own_physics}
        spec = _expand_scan(raw, index, ctx)
        if spec.name in scan_names:
            raise ConfigError(source, f"scan[{index}].name", "a name no other scan has", spec.name)
        scan_names.add(spec.name)
        if any(s.id == spec.id for s in suite.scans):
            raise ConfigError(source, f"scan[{index}]", "a scan that differs from the others (it repeats one)")
        suite.scans.append(spec)
    for experiment in suite.experiments:
        for name in experiment.scans:
            if name not in scan_names:
                raise ConfigError(source, f"experiment[{experiment.name}].scans", "names of the suite's scans ("
                                  f"{', '.join(sorted(scan_names)) or 'it has none'})", name)
    return suite


def _scan_names(value: Any, source: str, key: str) -> tuple[str, ...]:
    """An experiment's ``scans``: a scan's name or a list of distinct ones."""
    names = value if isinstance(value, list) else [value]
    for name in names:
        _name(name, source, key)
    return tuple(_distinct(names, source, key))


@dataclass
class _Context:
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


# --- an experiment: a run configuration whose lists are the axes of a matrix ------------------------------------


def _translate(table: dict, src: str, prefix: str) -> tuple[dict, dict[str, str]]:
    """A table of experiment keys with the old keys (ALIASES, ``physics = "preset"``) in run-configuration form, and
    what each translated key was called in the file (for messages). A value given both ways is a ConfigError."""
    table = dict(table)
    names: dict[str, str] = {}

    def both(key: str, alias: str) -> ConfigError:
        return ConfigError(src, f"{prefix}{_rename(key, names)}", f"one value (the old key '{alias}' gives it too)")

    def move(alias: str, key: str) -> None:
        if alias in table:
            if key in table:
                raise both(key, alias)
            table[key] = table.pop(alias)
            names[key] = alias

    def insert(key: str, field_name: str, value: Any, alias: str) -> None:
        """``value`` as ``field_name`` of the table ``table[key]``, or of each table if it is a list of them."""
        target = table.get(key, {})
        if isinstance(target, dict):
            tables, paths = [target], [key]
        elif _is_tables(target):
            tables, paths = target, [f"{key}[{i}]" for i in range(len(target))]
        else:
            return  # not a table: the run-configuration loader says so
        copies = []
        for path, t in zip(paths, tables):
            if field_name in t:
                raise both(f"{path}.{field_name}", alias)
            copies.append({**t, field_name: value})
            names[f"{path}.{field_name}"] = alias
        table[key] = copies[0] if isinstance(target, dict) else copies

    move("shapes", "shape")
    move("environments", "environment")
    seeds = table.get("seeds")
    if isinstance(seeds, int) and not isinstance(seeds, bool):  # a number of seeds: 0..n-1
        if seeds < 1:
            raise ConfigError(src, f"{prefix}seeds", "a number of seeds >= 1 (seeds 0..n-1) or a list of seeds", seeds)
        P.check_plan_size(seeds, P.MAX_SUITE_RUNS, P.SUITE_RUN_BYTES, "runs in a suite", src, f"{prefix}seeds", seeds)
        table["seeds"] = list(range(seeds))
    move("seeds", "seed")
    learner_params = table.pop("learner_params", {})
    if not isinstance(learner_params, dict):
        raise ConfigError(src, f"{prefix}learner_params", "a table of LearnerParams fields", learner_params)
    learners = {"name": table.pop("learners")} if "learners" in table else {}
    for key, value in {**learners, **learner_params}.items():
        insert("learner", key, value, "learners" if learners and key == "name" else f"learner_params.{key}")
    if "noise" in table:
        insert("environment", "noise", table.pop("noise"), "noise")
    if "physics" in table and not isinstance(table["physics"], dict) and not _is_tables(table["physics"]):
        table["physics"] = {"preset": table["physics"]}
        names["physics.preset"] = "physics"
    return table, names


def _merge(base: Any, over: Any) -> Any:
    """``over`` where it has a value, else ``base``: tables key by key, a table into each table of a list of them
    (defaults for every environment of an experiment); any other value replaces."""
    if isinstance(base, dict) and isinstance(over, dict):
        return {**base, **{k: _merge(base[k], v) if k in base else v for k, v in over.items()}}
    if isinstance(base, dict) and _is_tables(over):
        return [_merge(base, o) for o in over]
    if _is_tables(base) and isinstance(over, dict):
        return [_merge(b, over) for b in base]
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
    if _is_tables(value):
        _distinct(value, src, where)
        return [(v, {path: f"{where}[{i}]", **found}) for i, table in enumerate(value)
                for v, found in _alternatives(table, src, path, f"{where}[{i}]")]
    return [(v, {}) for v in _values(value, src, where)]


def _expand_experiment(table: dict, names: dict[str, str], name: str, description: str, runs: dict[str, RunSpec],
                       ctx: _Context) -> Experiment:
    """Each combination of the axes through the run-configuration loader, then once per seed."""
    src = ctx.source
    where = f"experiment[{name}]"
    table = dict(table)
    events = table.pop("events")
    axes = {k: table[k] for k in AXIS_ORDER if k in table}
    try:
        seeds = [P.check_rule(P.SEED, "", s, src, "seed") for s in _values(table.pop("seed", 0), src, "seed")]
        # counted before anything is expanded: a product of a few long lists is more runs than memory holds
        P.check_plan_size(len(runs) + _count(axes) * len(seeds), P.MAX_SUITE_RUNS, P.SUITE_RUN_BYTES,
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
        env_key = f"{where}.{_rename(_rename('environment', found), names)}"
        try:
            if label is not None:
                _name(label, src, "environment.name")
            config = run_config_from_table({**combo, "environment": environment, "events": events}, src, ctx.base,
                                           load=ctx.load)
        except ConfigError as exc:
            if exc.source != src:  # a morphology file's own error
                raise
            if exc.key.startswith("events") and exc.key.endswith((".unit", ".link")):
                exc = ConfigError(src, exc.key, f"{exc.expected} (shape {ctx.load(ctx.base / combo['shape']).name})",
                                  exc.got)
            raise _named(exc, where, found, names) from None
        label = label or _settings_label({k: v for k, v in environment.items() if k != "noise"})
        ground = environment_id(config.environment)
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
        identity = config_identity(config, preset)
        del identity["seed"]
        condition_id = stable_hash(identity)
        lp = config.learner_params
        cycles = lp.warmup_cycles + (config.steps + 1) * (lp.cycles_per_step + lp.discard_cycles)
        for seed in seeds:
            run_id = stable_hash({**identity, "seed": seed})
            if run_id not in runs:
                runs[run_id] = RunSpec(run_id, condition_id, condition, seed, dataclasses.replace(config, seed=seed),
                                       cost=cycles * body_cost(config.shape))
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
    if _is_tables(value):
        return sum(_count(table) for table in value)
    return len(value) if isinstance(value, list) else 1


def events_summary(events: tuple[Event, ...]) -> str:
    """One text for a condition column: ``step 150 damage unit=2 mode=no-inflate; step 300 noise sigma=0.5``."""
    return "; ".join(f"step {e.step} {e.describe()}" for e in events) or "none"


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
    damage = None
    if "damage" in table:
        damage = parse_event(table["damage"], src, f"{where}.damage", shape.n_units, len(shape.links), kind="damage")
    default_name = f"{shape.name}-r{resolution}" + (f"-unit{damage.unit}-{damage.mode}" if damage else "")
    name = _name(table.get("name", default_name), src, f"{where}.name")
    sampled = shape.n_units > 3
    check_scan_size(shape.n_units, resolution, samples, src, f"{where}.samples" if sampled and samples else
                    f"{where}.resolution")
    phases = scan_phases(shape.n_units, resolution, samples, seed)
    identity = {"shape": shape_identity(shape), "resolution": resolution, "samples": samples if sampled else None,
                "seed": seed if sampled else None, "cycles": cycles, "discard": discard,
                "physics": dataclasses.asdict(P.PHYSICS_PRESETS[preset]), "part_points": SCAN_PART_POINTS,
                "environment": dataclasses.asdict(environment)}  # the default one keeps earlier scans' ids
    if damage is not None:  # a healthy scan keeps the id it had before scans could be damaged
        identity["damage"] = {"unit": damage.unit, "mode": damage.mode}
    scan_id = stable_hash(identity)
    columns = {"scan": name, "shape": shape.name, "shape_id": shape_id(shape), "n_units": shape.n_units,
               "resolution": resolution, "samples": len(phases), "cycles": cycles, "discard": discard, "seed": seed,
               "physics": preset, "environment": _settings_label(environment_table),
               "environment_id": environment_id(environment), "damage": damage.describe() if damage else "none"}
    return ScanSpec(scan_id, name, shape, columns, P.PHYSICS_PRESETS[preset], cycles, discard, phases, environment,
                    damage)


# --- validation helpers -----------------------------------------------------------------------------------------


def _check_keys(table: dict, allowed, source: str, prefix: str) -> None:
    for key in table:
        if key not in allowed:
            raise ConfigError(source, f"{prefix}{key}", f"one of the known keys {', '.join(sorted(allowed))}")


def _array_of_tables(table: dict, key: str, source: str) -> list[dict]:
    value = table.get(key, [])
    if isinstance(value, dict):
        value = [value]
    if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
        raise ConfigError(source, key, f"an array of tables ([[{key}]])", value)
    return value


def _is_tables(value: Any) -> bool:
    return isinstance(value, list) and bool(value) and all(isinstance(v, dict) for v in value)


def _values(value: Any, source: str, key: str) -> list:
    """A scalar or a non-empty list of distinct scalars, as a list."""
    values = value if isinstance(value, list) else [value]
    if not values:
        raise ConfigError(source, key, "a value or a non-empty list of values", value)
    for v in values:
        if isinstance(v, (list, dict)):
            raise ConfigError(source, key, "a value or a list of plain values (no nested lists or tables)", value)
    return _distinct(values, source, key)


def _distinct(values: list, source: str, key: str) -> list:
    if len({json.dumps(v, sort_keys=True) for v in values}) != len(values):
        raise ConfigError(source, key, "distinct values (a value is repeated)", values)
    return values


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


def _rename(key: str, names: dict[str, str]) -> str:
    """``key`` with its longest prefix that ``names`` knows (a whole key, up to a '.' or a '[') renamed."""
    for end in range(len(key), 0, -1):
        if key[:end] in names and (end == len(key) or key[end] in ".["):
            return names[key[:end]] + key[end:]
    return key


def _named(exc: ConfigError, where: str, *names: dict[str, str]) -> ConfigError:
    """An error of the run-configuration loader or of an axis, its key as the suite file writes it."""
    key = exc.key
    for known in names:
        key = _rename(key, known)
    return ConfigError(exc.source, f"{where}.{key}", exc.expected, exc.got)


def _string(value: Any, source: str, key: str) -> str:
    if not isinstance(value, str):
        raise ConfigError(source, key, "a string", value)
    return value


def _name(value: Any, source: str, key: str) -> str:
    if not isinstance(value, str) or not _NAME.match(value):
        raise ConfigError(source, key, "a name of letters, digits, '_', '.' and '-' (starting with a letter or digit)",
                          value)
    return value
