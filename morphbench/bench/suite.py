"""Suite files: a matrix of learning runs and a list of landscape scans, expanded into jobs with stable ids.

A suite file is TOML::

    name = "smoke"                      # optional, default: the file's stem
    description = "what this suite is for"
    groups = {small = ["S1", "S4"]}     # optional: named lists of its experiments (morphbench leaderboard --tasks
                                        #   small); a group's name is no experiment's
    include = ["paper-hardware.toml"]   # optional: suite files (relative to this one; or one string) whose
                                        #   experiments, scans and groups join this suite's ("Included suites")

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
    [experiment.environment]            # EnvironmentParams fields, as a run file's [environment] (preset =
    noise = [0.0, 0.5, 1.0]             #   "hardware" and fields on top; or environment = "hardware" alone)
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
                                        # or waves = 40: the 40 travelling waves along the heading instead (unit in
                                        #   column c at phase c * delta mod 1, delta = 0, 1/40, ...; not with
                                        #   resolution or samples)
    cycles = 12                         # cycles measured per point (default 12), after `discard` (default 2)
    physics = "default"                 # a preset, or a table as an experiment's: {preset = "fast", timestep = 0.005}
    environment = {friction_scale = 1.5}   # optional: the EnvironmentParams the scan runs in (no noise: scans
                                           #   measure the true velocity), or a preset: "hardware", or
                                           #   {preset = "hardware", friction_field = {offset = 0.5}}, whose
                                           #   ground and pumps it measures (without its noise and clocks)
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
without one the label is its preset, if any, then the table's settings but its noise, which has a column of its own
(``friction_field.amplitude=0.3``, ``hardware``, ``hardware, vibration=0.7``, or ``default``). Different grounds
need different labels. The column ``environment_id`` is a hash of the ground (the environment without noise and
clocks: what a scan of it measures). The column ``physics`` is the preset, followed by any fields set beside it
(``quasistatic, timestep=0.005``). The column ``events`` summarises the events (``step 150 damage unit=2
mode=no-inflate``; ``none`` without events).

The first suites' keys are still read, as aliases of the run-configuration keys: ``shapes`` (``shape``),
``learners`` (``learner.name``), ``[experiment.learner_params]`` (``learner.*``), ``noise`` (``environment.noise``,
in each environment), ``environments`` (``environment``, a list of tables), ``seeds = [...]`` (``seed``) and
``physics = "fast"`` (``physics.preset``), by morphbench.bench.aliases alone. A value given both ways in one table is
a ConfigError.

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

Included suites: ``include`` names suite files, each read as a suite of its own (its ``name``, ``defaults`` and
``physics``; this suite's do not reach it, ``morphbench bench --physics`` does), whose experiments, runs, scans and
groups join this suite's after its own, in the order listed (an included suite's own includes with it). Their names
must differ from this suite's and the earlier includes' (experiments and groups share one set of names, scans have
their own); a run listed by both is run once; a scan both measure is refused, and so is a cycle (a suite that
includes itself, directly or not). This suite's ``scans`` and ``groups`` may name what it includes. A suite of
includes alone is a suite. Its plan lists the included suites' names (``includes``), and the report checks the claims
of each that has claims of its own (morphbench.bench.claims.claims_for) beside this suite's. The copy of the suite
file a results directory keeps (``suite.toml``) has each included file after it, as it was read, in comments.

Every key is checked: an unknown key, a value of the wrong type or out of range, a missing morphology file or an
unusable learner raises ``ConfigError`` naming the suite file and the key as written (``experiment[S4].noise``).

Each run's id is a hash of everything that determines its records (the shape's content, not its path; the
learner, its parameters, sensor, environment, events and physics parameters, noise, steps, seed:
morphbench.identity), so the same run has the same id in any suite, written with either keys, in any
directory and on any machine: a results directory skips the runs it already holds, and a run listed by two
experiments of a suite is run once. A condition is a run's configuration without its seed; its id is a hash too.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from morphbench.bench.aliases import ALIASES, translate
from morphbench.bench.expand import Context, check_name, expand_experiment, expand_scan, merge
from morphbench.bench.model import Suite
from morphbench.errors import ConfigError
from morphbench.experiment.config import RUN_KEYS
from morphbench.files import read_toml_with_text
from morphbench.params import PHYSICS_PRESET
from morphbench.readers import check_keys, distinct
from morphbench.rules import check_rule

# the names this module held before the model, the expansion, the aliases and the cost model had modules of their
# own, still importable from here
from morphbench.bench.aliases import rename as rename
from morphbench.bench.cost import body_cost as body_cost
from morphbench.bench.expand import AXIS_ORDER as AXIS_ORDER, SCAN_KEYS as SCAN_KEYS
from morphbench.bench.expand import events_summary as events_summary
from morphbench.bench.model import (
    SCAN_PART_POINTS as SCAN_PART_POINTS,
    Experiment as Experiment,
    Job as Job,
    RunSpec as RunSpec,
    ScanPart as ScanPart,
    ScanSpec as ScanSpec,
)

EXPERIMENT_KEYS = ("name", "scans", *RUN_KEYS, *ALIASES)
DEFAULT_KEYS = tuple(k for k in EXPERIMENT_KEYS if k not in ("name", "description", "scans"))
SUITE_KEYS = ("name", "description", "groups", "include", "physics", "defaults", "experiment", "scan")
SUITE_DEFAULTS = {"sensor": {"kind": "ideal"}}
"""Suites score the true velocity and run thousands of learning runs: they measure with the ideal sensor (10%
cheaper than the optical one) unless told otherwise."""


def load_suite(path: str | Path, physics: str | None = None) -> Suite:
    """Read, validate and expand a suite file and the suites it includes; ``physics``, a preset name, replaces every
    run's and scan's physics, theirs too (``morphbench bench --physics``)."""
    path = Path(path)
    table, text = read_toml_with_text(path, "suite file")
    return suite_from_table(table, source=str(path), base=path.parent, default_name=path.stem, text=text,
                            physics=physics, chain=(_resolved(path),))


def suite_from_table(table: dict, *, source: str, base: Path, default_name: str = "suite", text: str = "",
                     physics: str | None = None, chain: tuple[Path, ...] = ()) -> Suite:
    """A suite from a parsed TOML table; morphology paths and included suites are relative to ``base``; ``physics``
    as in load_suite; ``chain``: the suite files being read that lead to this one (this one's last), whose inclusion
    is a cycle."""
    if physics is not None:
        check_rule(PHYSICS_PRESET, "", physics, "--physics", "physics")
    check_keys(table, SUITE_KEYS, source, "")
    name = check_name(table.get("name", default_name), source, "name")
    description = _string(table.get("description", ""), source, "description")
    includes = _include_paths(table.get("include", []), source)
    defaults = table.get("defaults", {})
    if not isinstance(defaults, dict):
        raise ConfigError(source, "defaults", "a table of experiment keys", defaults)
    check_keys(defaults, DEFAULT_KEYS, source, "defaults.")
    defaults, default_names = translate(defaults, source, "defaults.")
    defaults = merge(SUITE_DEFAULTS, defaults)
    own_physics = table.get("physics")  # the suite's backend: a preset for every run and scan that names none
    if own_physics is not None:
        check_rule(PHYSICS_PRESET, "", own_physics, source, "physics")
        defaults.setdefault("physics", {"preset": own_physics})
    experiments = _array_of_tables(table, "experiment", source)
    scans = _array_of_tables(table, "scan", source)
    if not experiments and not scans and not includes:
        raise ConfigError(source, "experiment", "at least one [[experiment]] or [[scan]] table (or an include)")
    suite = Suite(name=name, description=description, source=source, text=text)
    ctx = Context(source, base)
    seen: set[str] = set()
    for index, raw in enumerate(experiments):  # keys count from 0, as everywhere; default names from 1
        exp_name = check_name(raw.get("name", f"experiment-{index + 1}"), source, f"experiment[{index}].name")
        if exp_name in seen:
            raise ConfigError(source, f"experiment[{index}].name", "a name no other experiment has", exp_name)
        seen.add(exp_name)
        where = f"experiment[{exp_name}]"
        check_keys(raw, EXPERIMENT_KEYS, source, f"{where}.")
        exp_description = _string(raw.get("description", ""), source, f"{where}.description")
        own, names = translate({k: v for k, v in raw.items() if k not in ("name", "description", "scans")}, source,
                               f"{where}.")
        merged = merge(defaults, {k: v for k, v in own.items() if k != "events"})
        if physics is not None:
            merged["physics"] = {"preset": physics}
        merged["events"] = own.get("events", defaults.get("events", []))  # an experiment's events replace the defaults'
        experiment = expand_experiment(merged, {**default_names, **names}, exp_name, exp_description, suite.runs,
                                       ctx)
        suite.experiments.append(dataclasses.replace(experiment, scans=_scan_names(raw.get("scans", []), source,
                                                                                    f"{where}.scans")))
    scan_names: set[str] = set()
    for index, raw in enumerate(scans):
        if isinstance(raw, dict) and (physics or (own_physics is not None and "physics" not in raw)):
            raw = {**raw, "physics": physics or own_physics}
        spec = expand_scan(raw, index, ctx)
        if spec.name in scan_names:
            raise ConfigError(source, f"scan[{index}].name", "a name no other scan has", spec.name)
        scan_names.add(spec.name)
        if any(s.id == spec.id for s in suite.scans):
            raise ConfigError(source, f"scan[{index}]", "a scan that differs from the others (it repeats one)")
        suite.scans.append(spec)
    own_groups = table.get("groups", {})
    included_groups: dict[str, tuple[str, ...]] = {}
    for index, relative in enumerate(includes):
        included = _include(relative, index, base, source, physics, chain)
        _join(suite, included, included_groups, set(own_groups) if isinstance(own_groups, dict) else set(), source,
              f"include[{index}]")
        if suite.text:  # the record (a results directory's suite.toml) holds what was included, as comments
            suite.text = (suite.text.rstrip("\n") + f"\n\n# --- include[{index}]: {relative}, as it was read ---\n"
                          + "".join(f"# {line}".rstrip() + "\n" for line in included.text.splitlines()))
        scan_names.update(s.name for s in included.scans)
    for experiment in suite.experiments[:len(experiments)]:  # an included suite's were checked by its own reading
        for name in experiment.scans:
            if name not in scan_names:
                raise ConfigError(source, f"experiment[{experiment.name}].scans", "names of the suite's scans ("
                                  f"{', '.join(sorted(scan_names)) or 'it has none'})", name)
    suite.groups = {**_groups(own_groups, [e.name for e in suite.experiments], source), **included_groups}
    return suite


def _include_paths(value: Any, source: str) -> list[str]:
    """The suite's ``include``: a suite file's path or a list of them (relative to the suite file's directory)."""
    if not isinstance(value, (list, str)):
        raise ConfigError(source, "include", "a list of suite files (paths relative to this file's directory)",
                          value)
    paths = value if isinstance(value, list) else [value]
    for index, path in enumerate(paths):
        if not isinstance(path, str) or not path:
            raise ConfigError(source, f"include[{index}]", "a suite file's path (relative to this file's directory)",
                              path)
    return paths


def _include(relative: str, index: int, base: Path, source: str, physics: str | None,
             chain: tuple[Path, ...]) -> Suite:
    """The suite ``include[index]`` names, read by the same loader; a ConfigError naming that key if the file is
    missing or unreadable, or includes a suite of ``chain`` (a cycle)."""
    key, path = f"include[{index}]", base / relative
    resolved = _resolved(path)
    if resolved in chain:
        cycle = " -> ".join(p.name for p in (*chain[chain.index(resolved):], resolved))
        raise ConfigError(source, key, f"a suite file that does not include this one, directly or not (a cycle: "
                                       f"{cycle})", relative)
    try:
        table, text = read_toml_with_text(path, "suite file")
    except ConfigError as error:  # it names the file alone: name the key that led there
        raise ConfigError(source, key, f"{error.expected} at {error.source}", relative) from None
    return suite_from_table(table, source=str(path), base=path.parent, default_name=path.stem, text=text,
                            physics=physics, chain=(*chain, resolved))


def _join(suite: Suite, included: Suite, groups: dict[str, tuple[str, ...]], own_groups: set[str], source: str,
          key: str) -> None:
    """Add ``included``'s experiments, runs and scans to ``suite``'s and its groups to ``groups`` (those of the
    earlier includes); a ConfigError naming ``key`` for a name ``suite`` already has or a scan it already measures."""
    expected = (f"suites whose experiment, scan and group names differ from this suite's (suite {included.name!r} "
                "has this name too)")
    taken = {e.name for e in suite.experiments} | own_groups | set(groups)  # --tasks takes experiments and groups
    for name in [e.name for e in included.experiments] + list(included.groups):
        if name in taken:
            raise ConfigError(source, key, expected, name)
    scan_names, scan_ids = {s.name for s in suite.scans}, {s.id for s in suite.scans}
    for scan in included.scans:
        if scan.name in scan_names:
            raise ConfigError(source, key, expected, scan.name)
        if scan.id in scan_ids:
            raise ConfigError(source, key, f"suites whose scans differ from this suite's (this scan of suite "
                                           f"{included.name!r} repeats one: the same shape, physics, ground and "
                                           "points)", scan.name)
    suite.experiments.extend(included.experiments)
    for run_id, spec in included.runs.items():  # a run both list is run once
        suite.runs.setdefault(run_id, spec)
    suite.scans.extend(included.scans)
    groups.update(included.groups)
    suite.includes += (included.name, *included.includes)


def _resolved(path: Path) -> Path:
    """``path`` made absolute, links followed, as far as it can be (what tells a suite file from another)."""
    try:
        return path.resolve()
    except (OSError, RuntimeError, ValueError):
        return path.absolute()


def _groups(value: Any, experiments: list[str], source: str) -> dict[str, tuple[str, ...]]:
    """The suite's ``groups``: a table of names (none an experiment's), each a non-empty list of distinct experiment
    names of the suite."""
    if not isinstance(value, dict):
        raise ConfigError(source, "groups", "a table of group names, each a list of experiment names", value)
    groups = {}
    for name, members in value.items():
        key = f"groups.{name}"
        check_name(name, source, key)
        if name in experiments:
            raise ConfigError(source, key, "a group name no experiment has (--tasks would not know which is meant)",
                              name)
        if not isinstance(members, list) or not members:
            raise ConfigError(source, key, "a non-empty list of experiment names", members)
        for member in members:
            if member not in experiments:
                raise ConfigError(source, key, f"names of the suite's experiments ({', '.join(experiments)})", member)
        groups[name] = tuple(distinct(members, source, key))
    return groups


def _scan_names(value: Any, source: str, key: str) -> tuple[str, ...]:
    """An experiment's ``scans``: a scan's name or a list of distinct ones."""
    names = value if isinstance(value, list) else [value]
    for name in names:
        check_name(name, source, key)
    return tuple(distinct(names, source, key))


def _array_of_tables(table: dict, key: str, source: str) -> list[dict]:
    value = table.get(key, [])
    if isinstance(value, dict):
        value = [value]
    if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
        raise ConfigError(source, key, f"an array of tables ([[{key}]])", value)
    return value


def _string(value: Any, source: str, key: str) -> str:
    if not isinstance(value, str):
        raise ConfigError(source, key, "a string", value)
    return value
