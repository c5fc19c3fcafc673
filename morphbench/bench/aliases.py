"""The first suites' keys, still read: the one place that knows them. ``translate`` turns them into
run-configuration keys (``shapes`` -> ``shape``, ``learners`` -> ``learner.name``, ``[experiment.learner_params]``
-> ``learner.*``, ``noise`` -> ``environment.noise`` in each environment, ``environments`` -> ``environment``,
``seeds = [...]`` -> ``seed``, ``physics = "fast"`` -> ``physics.preset``; and ``seeds = N``, seeds 0..N-1) and
says what each key was called in the file, so that every message names the key as written."""

from __future__ import annotations

from typing import Any

from morphbench.errors import ConfigError
from morphbench.params import MAX_SUITE_RUNS, SUITE_RUN_BYTES
from morphbench.readers import is_tables
from morphbench.rules import check_plan_size

ALIASES = ("shapes", "learners", "learner_params", "noise", "environments", "seeds")
"""The first suites' keys, still read: translated into run-configuration keys (translate)."""


def translate(table: dict, src: str, prefix: str) -> tuple[dict, dict[str, str]]:
    """A table of experiment keys with the old keys (ALIASES, ``physics = "preset"``) in run-configuration form, and
    what each translated key was called in the file (for messages). A value given both ways is a ConfigError."""
    table = dict(table)
    names: dict[str, str] = {}

    def both(key: str, alias: str) -> ConfigError:
        return ConfigError(src, f"{prefix}{rename(key, names)}", f"one value (the old key '{alias}' gives it too)")

    def move(alias: str, key: str) -> None:
        if alias in table:
            if key in table:
                raise both(key, alias)
            table[key] = table.pop(alias)
            names[key] = alias

    def insert(key: str, field_name: str, value: Any, alias: str) -> None:
        """``value`` as ``field_name`` of the table ``table[key]``, or of each table if it is a list of them."""
        target = table.get(key, {})
        if key == "environment" and isinstance(target, str):  # a preset's name: its noise set beside it
            target = {"preset": target}
        if isinstance(target, dict):
            tables, paths = [target], [key]
        elif is_tables(target):
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
        check_plan_size(seeds, MAX_SUITE_RUNS, SUITE_RUN_BYTES, "runs in a suite", src, f"{prefix}seeds", seeds)
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
    if "physics" in table and not isinstance(table["physics"], dict) and not is_tables(table["physics"]):
        table["physics"] = {"preset": table["physics"]}
        names["physics.preset"] = "physics"
    return table, names


def rename(key: str, names: dict[str, str]) -> str:
    """``key`` with its longest prefix that ``names`` knows (a whole key, up to a '.' or a '[') renamed."""
    for end in range(len(key), 0, -1):
        if key[:end] in names and (end == len(key) or key[end] in ".["):
            return names[key[:end]] + key[end:]
    return key
