"""The ids of runs, conditions, shapes and grounds: hashes of plain data, so that the same thing has the same id on
every machine and in every results directory. Pure functions of the standard library: the run loop records a shape's
id, the replay checks it, the suites name runs and conditions by them, and the metrics match scans to runs.

A field added after results existed is marked in its dataclass (``ADDED_LATER`` in its metadata: ``rules.param(...,
later=True)`` for a parameter, ``field(..., metadata=ADDED_LATER)`` for an event's field) with a default that acts as
before it existed. ``identity`` leaves it out while it has that default, so every run, scan and event written before
it keeps its id; that is the one mechanism, whatever holds the field.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
from typing import Any

ADDED_LATER = {"later": True}
"""The metadata of a field added after results existed (its default acts as before it existed)."""


def identity(value: Any, skip: tuple[str, ...] = ()) -> Any:
    """``value`` as plain data, as ``dataclasses.asdict`` gives it (dataclasses within lists, tuples and dicts
    included), less the fields marked ``ADDED_LATER`` that have their default and, of ``value`` itself, the fields
    ``skip`` names (a caller that fills them in otherwise)."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: identity(getattr(value, f.name)) for f in dataclasses.fields(value)
                if f.name not in skip and not (f.metadata.get("later") and getattr(value, f.name) == f.default)}
    if isinstance(value, (list, tuple)):
        return type(value)(identity(item) for item in value)
    if isinstance(value, dict):
        return {key: identity(item) for key, item in value.items()}
    return value


def stable_hash(data: Any, length: int = 12) -> str:
    """A short hex digest of canonical JSON: the same data gives the same id on every machine and run."""
    text = json.dumps(data, sort_keys=True, separators=(",", ":"), allow_nan=True, default=_plain)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:length]


def _plain(value: Any) -> Any:
    """numpy values as plain Python ones, for hashing."""
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"cannot hash a {type(value).__name__} in a run configuration")


@functools.lru_cache(maxsize=64)
def shape_identity(shape) -> dict:
    """What a shape is physically (its bodies, links and actuator) and its name, not where it was loaded from.
    Cached per shape (a frozen Shape: equal shapes have equal identities), as a suite asks it of every condition and
    scan and a 10,000-unit sheet's takes 0.2 s against 5 ms to look it up: the dict is shared, never to be changed."""
    return identity(shape, skip=("source", "description"))


@functools.lru_cache(maxsize=64)
def shape_id(shape) -> str:
    return stable_hash(shape_identity(shape))


def config_identity(config, preset: str) -> dict:
    """Everything that determines a run's records (a RunConfig), JSON-ready, the shape by content (what its id
    hashes). ``noise`` and ``physics_preset`` are there because the first suites hashed them: existing results keep
    their ids."""
    data = identity(config, skip=("shape",))
    data["shape"] = shape_identity(config.shape)
    data["events"] = list(data["events"])  # each its kind, step and own fields
    data["noise"] = config.environment.noise
    data["physics_preset"] = preset
    return data
