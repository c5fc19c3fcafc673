"""Events: changes of the world or the robot at the start of a learning step, declared in run configs and suites.

| kind | fields | effect |
|---|---|---|
| friction | scale | every body's friction is its own times ``scale`` from now on (a friction drop: scale < 1) |
| damage | unit, mode | unit ``unit`` (1 = front) is damaged: 'no-inflate', 'stuck' or 'dead' (see params.DAMAGE_MODES) |
| shuffle | seed | the units are reordered by a seeded permutation; each keeps its learner, memory, noise and damage |
| cut | link | link ``link`` (1-based, in the shape's order; for a chain, unit k's bellows) is cut; each piece is scored on its own |
| noise | sigma | measurement noise becomes ``sigma`` mm/cycle |

Each applied event is recorded in ``steps.parquet`` (column ``event``) at the step it happened.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from morphbench.errors import ConfigError
from morphbench.params import DAMAGE_MODES

EVENT_FIELDS = {
    "friction": ("scale",),
    "damage": ("unit", "mode"),
    "shuffle": ("seed",),
    "cut": ("link",),
    "noise": ("sigma",),
}


@dataclass(frozen=True, kw_only=True)
class Event:
    """One event; only the fields of its kind are set."""

    step: int
    """learning step at whose start it happens (>= 1)."""
    kind: str
    """one of EVENT_FIELDS."""
    scale: float | None = None
    """friction: new friction scale (> 0)."""
    unit: int | None = None
    """damage: the unit, 1 = front."""
    mode: str | None = None
    """damage: one of DAMAGE_MODES."""
    seed: int | None = None
    """shuffle: seed of the permutation."""
    link: int | None = None
    """cut: the link, 1-based."""
    sigma: float | None = None
    """noise: new measurement noise, mm/cycle (>= 0)."""

    def describe(self) -> str:
        """Short text for the records, e.g. 'damage unit=2 mode=no-inflate'."""
        return " ".join([self.kind] + [f"{name}={getattr(self, name)}" for name in EVENT_FIELDS[self.kind]])


def parse_events(items: Any, source: str, n_units: int, n_links: int) -> tuple[Event, ...]:
    """Validate a TOML array of event tables (``[[events]]``) against the shape they will act on."""
    if not isinstance(items, list):
        raise ConfigError(source, "events", "an array of tables ([[events]])", items)
    events = []
    for i, item in enumerate(items):
        where = f"events[{i}]"
        if not isinstance(item, dict):
            raise ConfigError(source, where, "a table with step, kind and the kind's fields", item)
        kind = item.get("kind")
        if kind not in EVENT_FIELDS:
            raise ConfigError(source, f"{where}.kind", f"one of {', '.join(EVENT_FIELDS)}", kind)
        allowed = {"step", "kind", *EVENT_FIELDS[kind]}
        for key in item:
            if key not in allowed:
                raise ConfigError(source, f"{where}.{key}", f"one of the keys of a {kind} event: {', '.join(sorted(allowed))}")
        for key in allowed:
            if key not in item:
                raise ConfigError(source, f"{where}.{key}", f"a value (a {kind} event needs {', '.join(sorted(allowed))})")
        values = {"step": _integer(item["step"], 1, math.inf, source, f"{where}.step", "a learning step >= 1")}
        if kind == "friction":
            values["scale"] = _positive(item["scale"], source, f"{where}.scale", strict=True)
        elif kind == "noise":
            values["sigma"] = _positive(item["sigma"], source, f"{where}.sigma", strict=False)
        elif kind == "damage":
            values["unit"] = _integer(item["unit"], 1, n_units, source, f"{where}.unit", f"a unit number in [1, {n_units}]")
            if item["mode"] not in DAMAGE_MODES:
                raise ConfigError(source, f"{where}.mode", f"one of {', '.join(DAMAGE_MODES)}", item["mode"])
            values["mode"] = item["mode"]
        elif kind == "shuffle":
            values["seed"] = _integer(item["seed"], 0, math.inf, source, f"{where}.seed", "an integer >= 0")
        elif kind == "cut":
            values["link"] = _integer(item["link"], 1, n_links, source, f"{where}.link", f"a link number in [1, {n_links}]")
        events.append(Event(kind=kind, **values))
    return tuple(sorted(events, key=lambda e: e.step))


def _integer(value: Any, low: float, high: float, source: str, key: str, expected: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise ConfigError(source, key, expected, value)
    return value


def _positive(value: Any, source: str, key: str, strict: bool) -> float:
    ok = not isinstance(value, bool) and isinstance(value, (int, float)) and math.isfinite(value)
    if not ok or (value <= 0 if strict else value < 0):
        raise ConfigError(source, key, f"a finite number {'>' if strict else '>='} 0", value)
    return float(value)
