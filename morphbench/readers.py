"""The generic readers of configuration tables (TOML read by ``files.read_toml``): a parameter dataclass from a table,
checked field by field by its declared rule (``morphbench.rules``); back from stored plain data; and the checks every
file format shares (known keys, lists of tables, distinct values). Morphology files (shapes/loader.py), run
configurations (experiment/config.py) and suites (bench/suite.py) all read their tables through here, so a key is
accepted or refused, and named, the same way in each.
"""

from __future__ import annotations

import dataclasses
import json
from typing import Any

from morphbench.errors import ConfigError
from morphbench.rules import check


def params_from_table(cls: type, table: Any, source: str, section: str, base: Any = None):
    """A frozen parameter dataclass from a TOML table, every key checked against the dataclass's fields; a field
    that is itself a parameter dataclass is read from a sub-table; the fields the table leaves out are ``base``'s
    (an instance of ``cls``; a sub-table's, the base's sub-table's), else the defaults."""
    if not isinstance(table, dict):
        raise ConfigError(source, section, f"a table of {cls.__name__} fields", table)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    check_keys(table, set(fields), source, prefix=f"{section}.")
    values = {}
    for key, value in table.items():
        default = field_default(fields[key])
        if dataclasses.is_dataclass(default):  # a sub-table on top of the base's own (a preset's friction field)
            values[key] = params_from_table(type(default), value, source, f"{section}.{key}",
                                            None if base is None else getattr(base, key))
        else:
            values[key] = check(cls, key, value, source, f"{section}.{key}")
    return cls(**values) if base is None else dataclasses.replace(base, **values)


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


def check_keys(table: dict[str, Any], allowed, source: str, prefix: str) -> None:
    """ConfigError naming the first key of ``table`` that is not in ``allowed`` (as ``prefix`` + key)."""
    for key in table:
        if key not in allowed:
            raise ConfigError(source, f"{prefix}{key}", f"one of the known keys {', '.join(sorted(allowed))}")


def is_tables(value: Any) -> bool:
    """Whether ``value`` is a non-empty list of tables (an array of tables, or an axis of them in a suite)."""
    return isinstance(value, list) and bool(value) and all(isinstance(v, dict) for v in value)


def distinct(values: list, source: str, key: str) -> list:
    """``values`` if no two are equal (as JSON, tables key by key), else ConfigError naming ``key``."""
    if len({json.dumps(v, sort_keys=True) for v in values}) != len(values):
        raise ConfigError(source, key, "distinct values (a value is repeated)", values)
    return values
