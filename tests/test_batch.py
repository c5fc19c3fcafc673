"""Seeds run together (morphbench.experiment.driver) give exactly the records each seed gives alone."""

import dataclasses

import numpy as np
import pandas as pd
import pytest

from morphbench.errors import PluginError
from morphbench.experiment import RunConfig, run
from morphbench.experiment.driver import batchable, run_batch
from morphbench.experiment.events import parse_events
from morphbench.params import (QUASISTATIC_PHYSICS, EnvironmentParams, FrictionFieldParams, LearnerParams,
                               SensorParams)
from morphbench.shapes import load_shape

from conftest import SHAPES_DIR

IDEAL = SensorParams(kind="ideal")


def shape(name):
    return load_shape(SHAPES_DIR / f"{name}.toml")


def events(name, *items):
    s = shape(name)
    return parse_events(list(items), "test", s.n_units, len(s.links))


CASES = {
    "thermal, noise": RunConfig(shape=shape("chain-3"), steps=25, sensor=IDEAL,
                                environment=EnvironmentParams(noise=0.5)),
    "flaky, friction field, friction drop": RunConfig(
        shape=shape("chain-3"), learner="flaky", steps=25, sensor=IDEAL, physics=QUASISTATIC_PHYSICS,
        environment=EnvironmentParams(friction_field=FrictionFieldParams(amplitude=0.3)),
        events=events("chain-3", {"step": 10, "kind": "friction", "scale": 0.6})),
    "damage": RunConfig(shape=shape("chain-3"), steps=20, sensor=IDEAL,
                        events=events("chain-3", {"step": 8, "kind": "damage", "unit": 2, "mode": "no-inflate"},
                                      {"step": 12, "kind": "damage", "unit": 3, "mode": "stuck"})),
    "chain-7 guessed patterns, shuffle": RunConfig(
        shape=shape("chain-7"), steps=16, sensor=IDEAL, learner_params=LearnerParams(step_size=0.025),
        events=events("chain-7", {"step": 6, "kind": "shuffle", "seed": 3})),
    "chain-7 cut, dead unit": RunConfig(
        shape=shape("chain-7"), steps=16, sensor=IDEAL,
        events=events("chain-7", {"step": 5, "kind": "cut", "link": 3},
                      {"step": 9, "kind": "damage", "unit": 6, "mode": "dead"})),
    "optical sensor": RunConfig(shape=shape("chain-2"), steps=8),
    "centralized": RunConfig(shape=shape("chain-3"), learner="cmaes", steps=12, sensor=IDEAL),
    # the other built-ins, stepped as one over the batch's runs like thermal and flaky
    "averaged": RunConfig(shape=shape("chain-3"), learner="averaged", steps=15, sensor=IDEAL),
    "adaptive": RunConfig(shape=shape("chain-3"), learner="adaptive", steps=40, sensor=IDEAL,
                          learner_params=LearnerParams(adapt_window=5)),
    "random": RunConfig(shape=shape("chain-3"), learner="random", steps=10, sensor=IDEAL),
}


def tables(records):
    return records.units(), records.steps(), records.pieces()


@pytest.mark.parametrize("name", CASES)
def test_a_batch_gives_each_seed_its_own_records(name):
    configs = [dataclasses.replace(CASES[name], seed=seed) for seed in (0, 1, 2, 7)]
    assert all(batchable(c) for c in configs)
    batched = run_batch(configs)
    for config, records in zip(configs, batched):
        alone = run(config)
        for got, expected in zip(tables(records), tables(alone)):
            pd.testing.assert_frame_equal(got, expected, check_exact=True)
        summary, expected = records.summary(), alone.summary()
        summary.pop("wall_time_s"), expected.pop("wall_time_s")
        assert summary == expected
    assert not np.array_equal(batched[0].steps().ubar_true, batched[1].steps().ubar_true)  # seeds do differ


def test_a_run_that_fails_stops_alone(monkeypatch):
    """A run whose step fails (here seed 1's measurements turn NaN at step 5, which its learners refuse) gets that
    exception; the others finish as alone."""
    from morphbench.experiment.run import RunLoop

    base = CASES["chain-7 cut, dead unit"]
    configs = [dataclasses.replace(base, seed=seed) for seed in (0, 1, 2)]
    alone = [run(configs[0]), run(configs[2])]
    checked = RunLoop.checked

    def failing(self, step, *args):
        u_measured, u_true = checked(self, step, *args)
        return (u_measured * np.nan if self.config.seed == 1 and step == 5 else u_measured), u_true

    monkeypatch.setattr(RunLoop, "checked", failing)
    batched = run_batch(configs)
    assert isinstance(batched[1], PluginError) and "at learning step 5" in str(batched[1])
    assert "of unit 1 " in str(batched[1])  # numbered within its own run
    for got, expected in zip([batched[0], batched[2]], alone):
        pd.testing.assert_frame_equal(got.units(), expected.units(), check_exact=True)


def test_only_the_seeds_may_differ_and_only_quasi_static_chains_batch():
    base = CASES["thermal, noise"]
    with pytest.raises(ValueError):
        run_batch([base, dataclasses.replace(base, steps=3)])
    assert not batchable(dataclasses.replace(base, physics=dataclasses.replace(QUASISTATIC_PHYSICS,
                                                                                 backend="pybullet")))
    assert not batchable(RunConfig(shape=shape("grid-2x2"), sensor=IDEAL))
