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

from dataclasses import dataclass
from typing import Any

from morphbench.errors import ConfigError, require_integer, require_number
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
        values = {"step": require_integer(item["step"], source, f"{where}.step", 1, expected="a learning step >= 1")}
        if kind == "friction":
            values["scale"] = require_number(item["scale"], source, f"{where}.scale", 0, strict=True)
        elif kind == "noise":
            values["sigma"] = require_number(item["sigma"], source, f"{where}.sigma", 0)
        elif kind == "damage":
            values["unit"] = require_integer(item["unit"], source, f"{where}.unit", 1, n_units,
                                             f"a unit number in [1, {n_units}]")
            if item["mode"] not in DAMAGE_MODES:
                raise ConfigError(source, f"{where}.mode", f"one of {', '.join(DAMAGE_MODES)}", item["mode"])
            values["mode"] = item["mode"]
        elif kind == "shuffle":
            values["seed"] = require_integer(item["seed"], source, f"{where}.seed", 0)
        elif kind == "cut":
            values["link"] = require_integer(item["link"], source, f"{where}.link", 1, n_links,
                                             f"a link number in [1, {n_links}]")
        events.append(Event(kind=kind, **values))
    return tuple(sorted(events, key=lambda e: e.step))
