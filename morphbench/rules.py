"""The rule engine of every parameter: what a value may be (``Range``, ``Choices``, ``OfType``, ``StepSpan``), declared
once per field with ``param(default, rule, unit)`` in ``morphbench.params``, and checked the same way everywhere.

``check`` / ``check_rule`` / ``check_params`` serve every file format (through ``morphbench.readers``) and the API;
``option_type`` / ``field_option`` are their argparse adapters, so an option is refused with the message a file gets:
``SOURCE: KEY: expected ..., got ...``. This module declares no parameter: the declarations, limits and presets live
in ``morphbench.params``.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import numbers
from dataclasses import dataclass, field
from typing import Any

from morphbench.errors import ConfigError
from morphbench.identity import ADDED_LATER

# --- what a value may be: declared once per field, checked the same way in files, options and the API -----------


@dataclass(frozen=True)
class Range:
    """An interval of numbers. An infinite end is allowed only if its side is inclusive: ``Range(0)`` is a finite
    number >= 0, ``Range(0, math.inf, high_inclusive=True)`` also takes inf."""

    low: float = -math.inf
    high: float = math.inf
    low_inclusive: bool = True
    high_inclusive: bool = False
    integer: bool = False
    """only integers (never a bool, never 2.0)."""
    even: bool = False
    """only even integers."""

    def accepts(self, value: Any) -> bool:
        if isinstance(value, bool) or not isinstance(value, numbers.Integral if self.integer else numbers.Real):
            return False
        above = value >= self.low if self.low_inclusive else value > self.low  # NaN fails both
        below = value <= self.high if self.high_inclusive else value < self.high
        return above and below and not (self.even and value % 2)

    def describe(self) -> str:
        kind = ("an even integer" if self.even else "an integer") if self.integer else "a number"
        if math.isfinite(self.low) and math.isfinite(self.high):
            left, right = "[" if self.low_inclusive else "(", "]" if self.high_inclusive else ")"
            return f"{kind} in {left}{_number(self.low)}, {_number(self.high)}{right}"
        takes_inf = (self.low_inclusive and self.low == -math.inf) or (self.high_inclusive and self.high == math.inf)
        if math.isfinite(self.low):
            bound = f" {'>=' if self.low_inclusive else '>'} {self.low:g}"
        elif math.isfinite(self.high):
            bound = f" {'<=' if self.high_inclusive else '<'} {self.high:g}"
        else:
            bound = ""
        if takes_inf:
            return f"{kind}{bound} or inf"
        return f"{kind}{bound}" if self.integer else f"a finite number{bound}"

    def normalize(self, value: Any) -> Any:
        return int(value) if self.integer else float(value)

    def parse(self, text: str) -> Any:
        return int(text) if self.integer else float(text)


def _number(value: float) -> str:
    """A bound as a message shows it: whole numbers in full (2**63 - 1, not 9.22337e+18), others with %g."""
    return (str(int(value)) if float(value).is_integer() and abs(value) < 1e16 or isinstance(value, int)
            else f"{value:g}")


@dataclass(frozen=True)
class Choices:
    """One of a few strings (the values users write)."""

    values: tuple[str, ...]

    def accepts(self, value: Any) -> bool:
        return isinstance(value, str) and value in self.values

    def describe(self) -> str:
        return f"one of {', '.join(self.values)}"

    def normalize(self, value: Any) -> Any:
        return value

    def parse(self, text: str) -> Any:
        return text


@dataclass(frozen=True)
class OfType:
    """Any value of one type: a flag or a free string."""

    type: type
    description: str

    def accepts(self, value: Any) -> bool:
        return isinstance(value, self.type)

    def describe(self) -> str:
        return self.description

    def normalize(self, value: Any) -> Any:
        return value


@dataclass(frozen=True)
class StepSpan:
    """None, or learning steps (first, last) inclusive with 0 <= first <= last, last None for 'to the end'; a step is
    what ``steps`` accepts (params.STEPS)."""

    steps: Range

    def accepts(self, value: Any) -> bool:
        if value is None:
            return True
        if not (isinstance(value, (tuple, list)) and len(value) == 2):
            return False
        first, last = value
        step = self.steps
        return step.accepts(first) and (last is None or (step.accepts(last) and last >= first))

    def describe(self) -> str:
        return (f"None or (first, last) learning steps with 0 <= first <= last <= {_number(self.steps.high)} "
                "(last None: to the end)")

    def normalize(self, value: Any) -> Any:
        return value if value is None else tuple(value)


Rule = Range | Choices | OfType | StepSpan


def between(low: float, high: float, *, low_inclusive: bool = True, integer: bool = False) -> Range:
    """[low, high] (or (low, high] if not ``low_inclusive``): every field has both ends, chosen for what the simulator
    can take and what a robot of these units can be."""
    return Range(low, high, low_inclusive=low_inclusive, high_inclusive=True, integer=integer)


def check_plan_size(count: int, limit: int, bytes_each: int, what: str, source: str, key: str, got: object) -> int:
    """``count`` if at most ``limit``, else ConfigError naming ``source`` and ``key``, with the memory the plan of
    ``count`` would take, before anything is built."""
    if count > limit:
        size = float(min(count, 10 ** 30) * bytes_each)  # a product of axes may be past float range
        units = ((1e12, "TB"), (1e9, "GB"), (1e6, "MB"), (1e3, "kB"), (1, "B"))
        shown = next(f"{size / scale:.3g} {unit}" for scale, unit in units if size >= scale or unit == "B")
        raise ConfigError(source, key, f"at most {limit:,} {what} (this asks for {count:,}, about {shown} of memory "
                                       "before anything runs)", got)
    return count


def param(default: Any, rule: Rule, unit: str = "", *, later: bool = False) -> Any:
    """A dataclass field with its allowed values (``rule``) and the unit its messages name. ``later``: added after
    results existed, its default acting as before it did, so ids leave it out at its default
    (``morphbench.identity``)."""
    return field(default=default, metadata={"rule": rule, "unit": unit, **(ADDED_LATER if later else {})})


def rule_of(owner: Any, name: str) -> tuple[Rule, str]:
    """The rule and unit of field ``name`` of a parameter dataclass (class or instance)."""
    for f in dataclasses.fields(owner):
        if f.name == name:
            return f.metadata["rule"], f.metadata["unit"]
    raise KeyError(f"{owner.__name__ if isinstance(owner, type) else type(owner).__name__} has no field {name!r}")


def expected(rule: Rule, unit: str = "") -> str:
    """What a message says was expected: ``a number in [0, 1] (cycles)``."""
    return rule.describe() + (f" ({unit})" if unit else "")


def check(owner: Any, name: str, value: Any, source: str, key: str | None = None) -> Any:
    """``value`` for field ``name`` of the parameter dataclass ``owner`` (as a float for a real-valued field), or a
    ConfigError ``SOURCE: KEY: expected ..., got ...`` (``key`` defaults to the field's name)."""
    return check_rule(*rule_of(owner, name), value, source, key or name)


def check_rule(rule: Rule, unit: str, value: Any, source: str, key: str) -> Any:
    """``value`` if ``rule`` accepts it (normalised), else ConfigError naming ``source`` and ``key``."""
    if not rule.accepts(value):
        raise ConfigError(source, key, expected(rule, unit), value)
    return rule.normalize(value)


def check_params(params: Any, source: str, prefix: str = "") -> Any:
    """``params`` if every field (and every field of a nested parameter dataclass) is allowed, else ConfigError
    naming the first bad one (``optical.frame_rate``)."""
    for f in dataclasses.fields(params):
        value = getattr(params, f.name)
        if dataclasses.is_dataclass(value):
            check_params(value, source, f"{prefix}{f.name}.")
        else:
            check_rule(f.metadata["rule"], f.metadata["unit"], value, source, prefix + f.name)
    return params


def option_type(rule: Rule, unit: str = ""):
    """An argparse ``type=`` that accepts what ``rule`` accepts, with the same message as files get."""

    def parse(text: str) -> Any:
        try:
            value = rule.parse(text)
        except ValueError:
            value = None
        if value is None or not rule.accepts(value):
            raise argparse.ArgumentTypeError(f"expected {expected(rule, unit)}, got {text!r}")
        return rule.normalize(value)

    return parse


def field_option(owner: Any, name: str):
    """The argparse ``type=`` of field ``name`` of a parameter dataclass."""
    return option_type(*rule_of(owner, name))
