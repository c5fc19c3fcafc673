"""The one mechanism that keeps ids stable when a field is added (morphbench.identity): a field marked ADDED_LATER is
left out of what is hashed while it has its default, whatever dataclass holds it (parameters, events, a shape's
actuator), and hashed as soon as it is set."""

import dataclasses
from pathlib import Path

import pytest

from morphbench.experiment.events import FrictionEvent
from morphbench.identity import ADDED_LATER, config_identity, identity, shape_id, stable_hash
from morphbench.params import ActuatorParams, EnvironmentParams, LearnerParams
from morphbench.shapes import load_shape
from morphbench.experiment import RunConfig


@dataclasses.dataclass(frozen=True)
class Inner:
    a: float = 1.0
    b: float = dataclasses.field(default=2.0, metadata=ADDED_LATER)


@dataclasses.dataclass(frozen=True)
class Outer:
    inner: Inner = Inner()
    items: tuple = (Inner(), Inner(b=3.0))
    named: dict = dataclasses.field(default_factory=lambda: {"x": Inner(a=5.0)})


def test_identity_is_asdict_without_later_fields_at_their_default():
    assert identity(Inner()) == {"a": 1.0}
    assert identity(Inner(b=2.5)) == {"a": 1.0, "b": 2.5}
    nested = identity(Outer())
    assert nested == {"inner": {"a": 1.0}, "items": ({"a": 1.0}, {"a": 1.0, "b": 3.0}), "named": {"x": {"a": 5.0}}}
    assert type(nested["items"]) is tuple  # hashed as asdict gives it


@pytest.mark.parametrize("owner, name", [(EnvironmentParams, "clock_drift"), (EnvironmentParams, "clock_offset"),
                                         (LearnerParams, "memory_weight"), (LearnerParams, "adapt_rate"),
                                         (ActuatorParams, "open_stiffness"), (FrictionEvent, "bodies")])
def test_fields_added_later_are_marked(owner, name):
    assert next(f for f in dataclasses.fields(owner) if f.name == name).metadata.get("later")


def test_run_ids_stay_until_a_later_field_is_set():
    shape = load_shape("shapes/chain-2.toml")
    config = RunConfig(shape=shape, steps=3, seed=0)
    same = dataclasses.replace(config, environment=EnvironmentParams(clock_drift=0.0),
                               events=(FrictionEvent(step=2, scale=0.5, bodies="all"),))
    other = dataclasses.replace(same, events=(FrictionEvent(step=2, scale=0.5, bodies="active"),))
    with_event = dataclasses.replace(config, events=(FrictionEvent(step=2, scale=0.5),))
    ids = [stable_hash(config_identity(c, "default")) for c in (config, same, with_event, other)]
    assert ids[1] == ids[2] != ids[0] and ids[3] != ids[1]
    assert config_identity(same, "default")["events"] == [{"step": 2, "kind": "friction", "scale": 0.5}]
    assert "clock_drift" not in config_identity(same, "default")["environment"]
    drifting = dataclasses.replace(config, environment=EnvironmentParams(clock_drift=0.01))
    assert config_identity(drifting, "default")["environment"]["clock_drift"] == 0.01
    stiffer = dataclasses.replace(shape, actuator=dataclasses.replace(shape.actuator, open_stiffness=40.0))
    assert shape_id(stiffer) != shape_id(shape)


def test_a_ground_id_is_the_ground_and_pumps_alone_so_runs_with_clocks_find_their_scans():
    """environment_id hashes what a scan of the environment measures (params.scan_environment): the measurement
    noise and the units' clocks leave it as it is, the pumps' vibration and the friction do not. So the hardware
    suite's runs (noise, clocks of their own) share the ground of its scans (no noise, one clock)."""
    from morphbench.bench.suite import load_suite
    from morphbench.params import HARDWARE_ENVIRONMENT, environment_id, scan_environment

    ground = environment_id(EnvironmentParams())
    assert environment_id(EnvironmentParams(noise=0.5, clock_drift=0.01, clock_offset=1.0)) == ground
    assert environment_id(EnvironmentParams(vibration=0.8)) != ground
    assert environment_id(EnvironmentParams(friction_scale=1.5)) != ground
    assert environment_id(HARDWARE_ENVIRONMENT) == environment_id(scan_environment(HARDWARE_ENVIRONMENT))
    suite = load_suite(Path(__file__).resolve().parents[1] / "benchmarks" / "paper-hardware.toml")
    scan = next(s for s in suite.scans if s.name == "hw-S3")
    experiment = next(e for e in suite.experiments if e.name == "hw-S4")
    grounds = {suite.runs[run_id].condition["environment_id"] for run_id in experiment.run_ids}
    assert grounds == {scan.columns["environment_id"]}
