"""Events: changes of the world or the robot at the start of a learning step, declared in run configs and suites.

| kind | fields | effect |
|---|---|---|
| friction | scale, bodies | friction times ``scale`` from now on (a drop: < 1) of `all`, `active` or `passive` bodies |
| damage | unit, mode | unit ``unit`` (1 = front) is damaged: a mode of params.DAMAGE_MODES ('open': needle gone) |
| shuffle | seed | the units are reordered by a seeded permutation; each keeps its learner, memory, noise and damage |
| cut | link | link ``link`` (1-based, see below) is cut; each piece is scored on its own |
| noise | sigma | measurement noise becomes ``sigma`` mm/cycle |

Links are numbered from 1 in the shape's order (for a chain, link k is unit k's bellows).

A friction event that takes a quasi-static world below its model's range (params.check_quasistatic_friction) stops the
run at its step with a PhysicsError: that model neglects inertia, which little friction no longer allows.

One frozen dataclass per kind: ``parse`` reads its fields from a TOML table, ``apply(world, state)`` is what the run
loop does at its step, ``describe()`` is recorded in ``steps.parquet`` (column ``event``) at the step it happened.
"""

from __future__ import annotations

import dataclasses
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from morphbench.errors import ConfigError, PhysicsError, require_integer
from morphbench.identity import ADDED_LATER, identity
from morphbench.params import DAMAGE_MODES, FRICTION_TARGETS, SEED, EnvironmentParams
from morphbench.rules import Choices, check, check_rule
from morphbench.shapes.transforms import shuffle_order

if TYPE_CHECKING:  # configs and suites parse events without loading the simulator
    from morphbench.physics import WorldInterface


@dataclass
class RunState:
    """What events change during a run, besides the world."""

    order: np.ndarray
    """``order[p]``: the unit (0-based) at position p (0 = front); units keep their identity when shuffled."""
    damage: list[str]
    """per unit: '' (healthy) or one of DAMAGE_MODES."""
    noise: float
    """current measurement noise, mm/cycle."""

    @classmethod
    def initial(cls, n_units: int, noise: float) -> RunState:
        return cls(order=np.arange(n_units), damage=[""] * n_units, noise=noise)

    def position(self) -> np.ndarray:
        """``position[u]``: where unit u sits."""
        return np.argsort(self.order)

    def alive(self) -> np.ndarray:
        """Per unit: not dead."""
        return np.array([mode != "dead" for mode in self.damage])

    def place_damage(self, world: WorldInterface) -> None:
        """The world sees damage by position: it travels with its unit."""
        for p, unit in enumerate(self.order):
            world.set_damage(p, self.damage[unit])


@dataclass(frozen=True, kw_only=True)
class Event(ABC):
    """One event: ``step`` and ``kind`` (a field, so ``dataclasses.asdict`` gives the table it was parsed from)
    followed by its kind's fields."""

    step: int
    """learning step at whose start it happens (>= 1; 0 for a standing condition: parse_event with a kind)."""
    kind: str = field(init=False)
    """the key of its class in EVENT_KINDS."""

    @classmethod
    @abstractmethod
    def parse(cls, item: dict, source: str, where: str, n_units: int, n_links: int) -> dict[str, Any]:
        """The kind's fields of the table ``item`` (at key ``where`` of ``source``), validated."""

    @abstractmethod
    def apply(self, world: WorldInterface, state: RunState) -> None:
        """Change ``world`` or ``state`` as the event does, at the start of its step."""

    @classmethod
    def kind_fields(cls) -> tuple[str, ...]:
        """The kind's own fields, in the order ``describe`` lists them."""
        return tuple(f.name for f in dataclasses.fields(cls) if f.name not in ("step", "kind"))

    @classmethod
    def optional_fields(cls) -> tuple[str, ...]:
        """The kind's fields a table may leave out (they have a default)."""
        return tuple(f.name for f in dataclasses.fields(cls)
                     if f.name not in ("step", "kind") and f.default is not dataclasses.MISSING)

    def settings(self) -> dict[str, Any]:
        """step, kind and the kind's fields, less those added later at their default (``morphbench.identity``): what
        identifies the event, so the events written before such a field keep their ids and text."""
        return identity(self)

    def describe(self) -> str:
        """Short text for the records, e.g. 'damage unit=2 mode=no-inflate'."""
        settings = self.settings()
        return " ".join([self.kind] + [f"{name}={settings[name]}" for name in self.kind_fields() if name in settings])


@dataclass(frozen=True, kw_only=True)
class FrictionEvent(Event):
    kind: str = field(default="friction", init=False)
    scale: float
    """new friction scale (EnvironmentParams.friction_scale's range)."""
    bodies: str = field(default="all", metadata=ADDED_LATER)
    """the bodies whose friction it scales (params.FRICTION_TARGETS): the others keep theirs."""

    @classmethod
    def parse(cls, item, source, where, n_units, n_links):
        return {"scale": check(EnvironmentParams, "friction_scale", item["scale"], source, f"{where}.scale"),
                "bodies": check_rule(Choices(FRICTION_TARGETS), "", item.get("bodies", "all"), source,
                                     f"{where}.bodies")}

    def apply(self, world, state):
        try:
            world.set_friction_scale(self.scale, self.bodies)
        except ConfigError as exc:  # a quasi-static world refuses friction below its model's range
            raise PhysicsError(exc.source, self.step, f"a friction event (scale {self.scale:g})",
                               f"takes friction outside the quasi-static model's range: expected {exc.expected}") \
                from None


@dataclass(frozen=True, kw_only=True)
class DamageEvent(Event):
    kind: str = field(default="damage", init=False)
    unit: int
    """the unit, 1 = front."""
    mode: str
    """one of DAMAGE_MODES."""

    @classmethod
    def parse(cls, item, source, where, n_units, n_links):
        unit = require_integer(item["unit"], source, f"{where}.unit", 1, n_units, f"a unit number in [1, {n_units}]")
        if item["mode"] not in DAMAGE_MODES:
            raise ConfigError(source, f"{where}.mode", f"one of {', '.join(DAMAGE_MODES)}", item["mode"])
        return {"unit": unit, "mode": item["mode"]}

    def apply(self, world, state):
        state.damage[self.unit - 1] = self.mode
        state.place_damage(world)


@dataclass(frozen=True, kw_only=True)
class ShuffleEvent(Event):
    kind: str = field(default="shuffle", init=False)
    seed: int
    """seed of the permutation."""

    @classmethod
    def parse(cls, item, source, where, n_units, n_links):
        return {"seed": check_rule(SEED, "", item["seed"], source, f"{where}.seed")}

    def apply(self, world, state):
        state.order = state.order[shuffle_order(len(state.order), self.seed)]  # the permutation of the shape transform
        state.place_damage(world)


@dataclass(frozen=True, kw_only=True)
class CutEvent(Event):
    kind: str = field(default="cut", init=False)
    link: int
    """the link, 1-based."""

    @classmethod
    def parse(cls, item, source, where, n_units, n_links):
        return {"link": require_integer(item["link"], source, f"{where}.link", 1, n_links,
                                        f"a link number in [1, {n_links}]")}

    def apply(self, world, state):
        world.cut(self.link - 1)


@dataclass(frozen=True, kw_only=True)
class NoiseEvent(Event):
    kind: str = field(default="noise", init=False)
    sigma: float
    """new measurement noise, mm/cycle (EnvironmentParams.noise's range)."""

    @classmethod
    def parse(cls, item, source, where, n_units, n_links):
        return {"sigma": check(EnvironmentParams, "noise", item["sigma"], source, f"{where}.sigma")}

    def apply(self, world, state):
        state.noise = self.sigma


def describe(events: list[Event]) -> str:
    """What the records say of the events applied at a step (column ``event``): each one's ``describe()``, '' for
    none."""
    return "; ".join(event.describe() for event in events)


EVENT_KINDS: dict[str, type[Event]] = {"friction": FrictionEvent, "damage": DamageEvent, "shuffle": ShuffleEvent,
                                       "cut": CutEvent, "noise": NoiseEvent}


def parse_events(items: Any, source: str, n_units: int, n_links: int) -> tuple[Event, ...]:
    """Validate a TOML array of event tables (``[[events]]``) against the shape they will act on."""
    if not isinstance(items, list):
        raise ConfigError(source, "events", "an array of tables ([[events]])", items)
    events = [parse_event(item, source, f"events[{i}]", n_units, n_links) for i, item in enumerate(items)]
    return tuple(sorted(events, key=lambda e: e.step))


def parse_event(item: Any, source: str, where: str, n_units: int, n_links: int, kind: str | None = None) -> Event:
    """One event table (at key ``where`` of ``source``): step, kind and the kind's fields. With ``kind`` given, the
    table holds that kind's fields only: a standing condition of a world from its start (step 0), such as the damage
    of a scan's assembly (``damage = {unit = 2, mode = "no-inflate"}``)."""
    standing = kind is not None
    if not isinstance(item, dict):
        what = f"a table of a {kind} event's fields" if standing else "a table with step, kind and the kind's fields"
        raise ConfigError(source, where, what, item)
    if not standing:
        kind = item.get("kind")
        if not isinstance(kind, str) or kind not in EVENT_KINDS:  # an array or table is not a kind (nor hashable)
            raise ConfigError(source, f"{where}.kind", f"one of {', '.join(EVENT_KINDS)}", kind)
    cls = EVENT_KINDS[kind]
    allowed = set(cls.kind_fields()) if standing else {"step", "kind", *cls.kind_fields()}
    for key in item:
        if key not in allowed:
            raise ConfigError(source, f"{where}.{key}",
                              f"one of the keys of a {kind} event: {', '.join(sorted(allowed))}")
    for key in allowed - set(cls.optional_fields()):
        if key not in item:
            raise ConfigError(source, f"{where}.{key}",
                              f"a value (a {kind} event needs {', '.join(sorted(allowed))})")
    step = 0 if standing else require_integer(item["step"], source, f"{where}.step", 1,
                                               expected="a learning step >= 1")
    return cls(step=step, **cls.parse(item, source, where, n_units, n_links))
