"""Read a morphology file (TOML) into a validated ``Shape``; the one loader used by the CLI, the suites and the tests.

A file looks like this (every table but ``[assembly]`` is optional; what is left out takes the defaults of
``morphbench.params``)::

    description = "three active units and a dummy on a straight track"

    [assembly]
    generator = "chain"   # the only generator so far
    units = 3             # active units, unit 1 at the front
    dummy = true          # a passive unit behind the last active one

    [unit]                # morphbench.params.UnitParams: length, width, height (m), mass (kg), friction
    [dummy]               # morphbench.params.DummyParams: mass (kg), friction
    [actuator]            # morphbench.params.ActuatorParams: stroke, rest_gap (m), max_force (N),
                          # tau_inflate, tau_vent, cycle_time (s), alpha (fraction of a cycle)

Any mistake (unknown key, wrong type, value out of range) raises ``ConfigError`` naming the file and the key.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from pathlib import Path
from typing import Any

from morphbench.errors import ConfigError
from morphbench.params import ActuatorParams, DummyParams, UnitParams
from morphbench.shapes.model import Body, Link, Shape

GENERATORS = ("chain",)
MAX_UNITS = 200

# Allowed range of each numeric parameter: (low, high, low_inclusive). Numbers not listed must be > 0, integers >= 1.
_RANGES = {
    "friction": (0.0, math.inf, True),
    "alpha": (0.0, 1.0, False),
    "noise": (0.0, math.inf, True),
    "amplitude": (0.0, math.inf, True),
    "warmup_cycles": (0, math.inf, True),
    "discard_cycles": (0, math.inf, True),
    "seed": (0, math.inf, True),
    "blur": (0.0, math.inf, True),
    "mount_x": (-math.inf, math.inf, True),
    "mount_y": (-math.inf, math.inf, True),
}


def load_shape(path: str | Path) -> Shape:
    """Load and validate one morphology file."""
    path = Path(path)
    return shape_from_table(read_toml(path, "morphology file"), source=str(path), default_name=path.stem)


def read_toml(path: Path, what: str) -> dict[str, Any]:
    """A TOML file's table; a missing, unreadable or malformed file is a ConfigError naming it."""
    try:
        text = path.read_text(encoding="utf-8")  # TOML is UTF-8 whatever the locale
    except FileNotFoundError:
        raise ConfigError(path, "(file)", f"an existing {what} (.toml)") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(path, "(file)", f"a readable UTF-8 TOML file ({exc})") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(path, "(syntax)", f"valid TOML ({exc})") from None


def shape_from_table(table: dict[str, Any], *, source: str, default_name: str = "shape") -> Shape:
    """Build a ``Shape`` from an already-parsed TOML table (``source`` names it in messages)."""
    _check_keys(table, {"name", "description", "assembly", "unit", "dummy", "actuator"}, source, prefix="")
    name = _string(table, "name", source, default_name)
    description = _string(table, "description", source, "")
    if "assembly" not in table:
        raise ConfigError(source, "assembly", "an [assembly] table with a generator")
    unit = params_from_table(UnitParams, table.get("unit", {}), source, "unit")
    dummy = params_from_table(DummyParams, table.get("dummy", {}), source, "dummy")
    actuator = params_from_table(ActuatorParams, table.get("actuator", {}), source, "actuator")
    bodies, links = _generate(_table(table, "assembly", source), unit, dummy, actuator, source)
    return Shape(name=name, source=source, description=description, bodies=bodies, links=links, actuator=actuator)


def params_from_table(cls: type, table: Any, source: str, section: str):
    """A frozen parameter dataclass from a TOML table, every key checked against the dataclass's fields; a field
    that is itself a parameter dataclass is read from a sub-table."""
    if not isinstance(table, dict):
        raise ConfigError(source, section, f"a table of {cls.__name__} fields", table)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    _check_keys(table, set(fields), source, prefix=f"{section}.")
    values = {}
    for key, value in table.items():
        default = field_default(fields[key])
        if dataclasses.is_dataclass(default):
            values[key] = params_from_table(type(default), value, source, f"{section}.{key}")
        else:
            values[key] = _checked_value(value, default, source, f"{section}.{key}", key)
    return cls(**values)


def params_from_dict(cls: type, data: dict[str, Any]):
    """The inverse of ``dataclasses.asdict`` for parameter dataclasses (no validation: the data came from us)."""
    fields = {f.name: f for f in dataclasses.fields(cls)}
    values = {}
    for key, value in data.items():
        default = field_default(fields[key])
        values[key] = params_from_dict(type(default), value) if dataclasses.is_dataclass(default) else value
    return cls(**values)


def field_default(f: dataclasses.Field) -> Any:
    return f.default if f.default is not dataclasses.MISSING else f.default_factory()


def _checked_value(value: Any, default: Any, source: str, dotted: str, key: str) -> Any:
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise ConfigError(source, dotted, "true or false", value)
        return value
    if isinstance(default, str):
        if not isinstance(value, str):
            raise ConfigError(source, dotted, "a string", value)
        return value
    if isinstance(default, int):
        low = _RANGES.get(key, (1,))[0]
        if isinstance(value, bool) or not isinstance(value, int) or value < low:
            raise ConfigError(source, dotted, f"an integer >= {low}", value)
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError(source, dotted, "a finite number", value)
    low, high, low_inclusive = _RANGES.get(key, (0.0, math.inf, False))
    if not ((value >= low if low_inclusive else value > low) and value < high):
        left = "[" if low_inclusive else "("
        interval = f"{left}{low:g}, {high:g})" if math.isfinite(high) else f"{'>=' if low_inclusive else '>'} {low:g}"
        raise ConfigError(source, dotted, f"a number {'in ' + interval if math.isfinite(high) else interval}", value)
    return float(value)


def _generate(assembly: dict[str, Any], unit: UnitParams, dummy: DummyParams, actuator: ActuatorParams, source: str):
    _check_keys(assembly, {"generator", "units", "dummy"}, source, prefix="assembly.")
    generator = assembly.get("generator")
    if generator not in GENERATORS:
        raise ConfigError(source, "assembly.generator", f"one of {', '.join(GENERATORS)}", generator)
    n_units = assembly.get("units")
    if isinstance(n_units, bool) or not isinstance(n_units, int) or not 1 <= n_units <= MAX_UNITS:
        raise ConfigError(source, "assembly.units", f"an integer number of active units in [1, {MAX_UNITS}]", n_units)
    has_dummy = assembly.get("dummy", True)
    if not isinstance(has_dummy, bool):
        raise ConfigError(source, "assembly.dummy", "true or false", has_dummy)
    if n_units == 1 and not has_dummy:
        raise ConfigError(source, "assembly.dummy", "true: a single unit's bellows needs a body to push against", False)
    return chain(n_units, has_dummy, unit, dummy, actuator)


def chain(n_units: int, has_dummy: bool, unit: UnitParams, dummy: DummyParams, actuator: ActuatorParams):
    """Bodies and links of a straight chain along x: unit 1 at the front (largest x), the dummy at the rear.

    Unit i's bellows sits between unit i and the next body towards the rear; the last active unit of a chain with no
    dummy has no body behind it, so it has no bellows (it is still a unit and still learns).
    """
    n_bodies = n_units + (1 if has_dummy else 0)
    pitch = unit.length + actuator.rest_gap
    size = (unit.length, unit.width, unit.height)
    bodies = tuple(
        Body(
            position=(-i * pitch, 0.0, unit.height / 2),
            size=size,
            mass=dummy.mass if i == n_units else unit.mass,
            friction=dummy.friction if i == n_units else unit.friction,
            dummy=i == n_units,
        )
        for i in range(n_bodies)
    )
    links = tuple(Link(front=i, rear=i + 1, unit=i) for i in range(min(n_units, n_bodies - 1)))
    return bodies, links


def _check_keys(table: dict[str, Any], allowed: set[str], source: str, prefix: str) -> None:
    for key in table:
        if key not in allowed:
            raise ConfigError(source, f"{prefix}{key}", f"one of the known keys {', '.join(sorted(allowed))}")


def _string(table: dict[str, Any], key: str, source: str, default: str) -> str:
    value = table.get(key, default)
    if not isinstance(value, str):
        raise ConfigError(source, key, "a string", value)
    return value


def _table(table: dict[str, Any], key: str, source: str) -> dict[str, Any]:
    value = table[key]
    if not isinstance(value, dict):
        raise ConfigError(source, key, "a table", value)
    return value
