"""Each parameter's allowed values are declared once (morphbench.params) and checked the same way in every file
format, on the command line and through the API, with the same message."""

from __future__ import annotations

import argparse
import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from morphbench import params as P
from morphbench import rules as R
from morphbench.errors import ConfigError
from morphbench.experiment.config import load_run_config
from morphbench.learning import ThermalLearner
from morphbench.readers import params_from_table

from conftest import PARAMETER_CLASSES, ROOT


@pytest.mark.parametrize("cls", PARAMETER_CLASSES, ids=lambda c: c.__name__)
def test_every_field_declares_its_allowed_values_and_its_default_is_one(cls):
    for f in dataclasses.fields(cls):
        default = getattr(cls(), f.name)
        if dataclasses.is_dataclass(default):
            continue  # a nested parameter dataclass: its own fields declare theirs
        assert "rule" in f.metadata, f"{cls.__name__}.{f.name} declares no allowed values"
    R.check_params(cls(), cls.__name__)


def run_file(tmp_path: Path, key: str, value: str) -> Path:
    path = tmp_path / "run.toml"
    path.write_text(f'shape = "{ROOT / "shapes" / "chain-2.toml"}"\n[learner]\n{key} = {value}\n')
    return path


@pytest.mark.parametrize("key, text, value", [
    ("temperature", "0", 0.0), ("temperature", "inf", math.inf), ("temperature", "0.5", 0.5),
    ("step_size", "0", 0.0), ("step_size", "1", 1.0),
])
def test_a_value_allowed_anywhere_is_allowed_everywhere(tmp_path, key, text, value):
    assert getattr(load_run_config(run_file(tmp_path, key, text)).learner_params, key) == value
    assert R.field_option(P.LearnerParams, key)(text) == value
    ThermalLearner(P.LearnerParams(**{key: value}), np.random.default_rng(0))


@pytest.mark.parametrize("key, text, value, expected", [
    ("temperature", "-0.5", -0.5, "a number >= 0 or inf (mm/cycle)"),
    ("temperature", "nan", math.nan, "a number >= 0 or inf (mm/cycle)"),
    ("step_size", "2.0", 2.0, "a number in [0, 1] (cycles)"),
    ("step_size", "-0.1", -0.1, "a number in [0, 1] (cycles)"),
])
def test_a_value_refused_anywhere_is_refused_everywhere_with_one_message(tmp_path, key, text, value, expected):
    path = run_file(tmp_path, key, text)
    with pytest.raises(ConfigError) as in_file:
        load_run_config(path)
    assert str(in_file.value) == f"{path}: learner.{key}: expected {expected}, got {value!r}"
    with pytest.raises(argparse.ArgumentTypeError) as on_the_command_line:
        R.field_option(P.LearnerParams, key)(text)
    assert str(on_the_command_line.value) == f"expected {expected}, got {text!r}"
    with pytest.raises(ConfigError) as in_the_api:
        ThermalLearner(P.LearnerParams(**{key: value}), np.random.default_rng(0))
    assert str(in_the_api.value) == f"LearnerParams: {key}: expected {expected}, got {value!r}"


def test_choices_and_nested_tables_use_the_same_rules():
    with pytest.raises(ConfigError, match=r"^s: sensor\.kind: expected one of optical, camera, ideal, got 'sonar'$"):
        params_from_table(P.SensorParams, {"kind": "sonar"}, "s", "sensor")
    with pytest.raises(ConfigError, match=r"^s: sensor\.optical\.patch_size: expected an integer in \[16, 256\]"):
        params_from_table(P.SensorParams, {"optical": {"patch_size": 8}}, "s", "sensor")
    with pytest.raises(ConfigError, match=r"^E: friction_field\.amplitude: expected a number in \[0, 1\), got 1\.0$"):
        R.check_params(P.EnvironmentParams(friction_field=P.FrictionFieldParams(amplitude=1.0)), "E")


@pytest.mark.parametrize("rule, text", [
    (R.Range(0, low_inclusive=False), "a finite number > 0"),
    (R.Range(0, 1, low_inclusive=False), "a number in (0, 1)"),
    (R.Range(0, math.inf, high_inclusive=True), "a number >= 0 or inf"),
    (R.Range(1, integer=True), "an integer >= 1"),
    (R.Range(16, 64, high_inclusive=True, integer=True, even=True), "an even integer in [16, 64]"),
    (R.Range(low_inclusive=False), "a finite number"),
])
def test_range_descriptions(rule, text):
    assert rule.describe() == text


def test_integers_and_infinities():
    assert not P.COUNT.accepts(2.0) and not P.COUNT.accepts(True) and P.COUNT.accepts(np.int64(3))
    assert not R.Range(low_inclusive=False).accepts(-math.inf) and not R.Range(0).accepts(math.inf)
    assert type(R.check(P.LearnerParams, "temperature", 1, "s")) is float  # files' integers become floats


def test_the_moved_configuration_names_are_still_importable_from_their_old_modules():
    """The rule engine left params.py for rules.py, the table readers shapes/loader.py for readers.py, and the suite's
    model, expansion, aliases and cost model bench/suite.py for modules of their own: the old import paths still give
    the very same objects."""
    import morphbench.bench.aliases as aliases
    import morphbench.bench.cost as cost
    import morphbench.bench.expand as expand
    import morphbench.bench.model as model
    import morphbench.bench.suite as suite
    import morphbench.readers as readers
    import morphbench.shapes as shapes
    import morphbench.shapes.loader as loader
    from morphbench.bench import Suite

    for name in ("Range", "Choices", "OfType", "StepSpan", "between", "param", "rule_of", "expected", "check",
                 "check_rule", "check_params", "check_plan_size", "option_type", "field_option"):
        assert getattr(P, name) is getattr(R, name), name
    for name in ("params_from_table", "params_from_dict", "field_default"):
        assert getattr(loader, name) is getattr(readers, name), name
    assert shapes.params_from_table is readers.params_from_table and shapes.params_from_dict is readers.params_from_dict
    for name in ("RunSpec", "ScanSpec", "ScanPart", "Job", "Experiment", "Suite", "SCAN_PART_POINTS"):
        assert getattr(suite, name) is getattr(model, name), name
    assert Suite is model.Suite and suite.body_cost is cost.body_cost and suite.rename is aliases.rename
    assert suite.events_summary is expand.events_summary and suite.AXIS_ORDER is expand.AXIS_ORDER
