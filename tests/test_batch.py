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
    exception and keeps exactly its rows of the steps before; the others finish as alone."""
    from morphbench.experiment.driver import Driver

    base = CASES["chain-7 cut, dead unit"]
    configs = [dataclasses.replace(base, seed=seed) for seed in (0, 1, 2)]
    alone = [run(config) for config in configs]
    measured = Driver._measured

    def failing(self, *args):
        u_measured, u_true = measured(self, *args)
        if self.rows.counts[1] == 5:  # seed 1's step 5
            u_measured[1] = np.nan
        return u_measured, u_true

    monkeypatch.setattr(Driver, "_measured", failing)
    driver = Driver(configs)
    with driver.batch:
        driver.warm_up()
        for step in range(base.steps + 1):
            driver.step(step)
    batched = driver.finish()
    assert isinstance(batched[1], PluginError) and "at learning step 5" in str(batched[1])
    assert "of unit 1 " in str(batched[1])  # numbered within its own run
    stopped = driver.records[1]
    assert stopped.n_steps == 5
    for got, expected in zip(tables(stopped), tables(alone[1])):
        expected = expected[expected.step < 5].reset_index(drop=True)
        pd.testing.assert_frame_equal(got, expected, check_exact=True)
    for got, expected in zip([batched[0], batched[2]], [alone[0], alone[2]]):
        for got_table, expected_table in zip(tables(got), tables(expected)):
            pd.testing.assert_frame_equal(got_table, expected_table, check_exact=True)


def test_each_run_reads_its_own_rows_of_the_shared_store():
    """Rows added for some runs at a time (a batch's step), or one run at a time (units on clocks of their own),
    past the store's first capacity: each run's records are its own rows, in order, and no other."""
    from morphbench.experiment.records import STORED_COLUMNS, RunRecords, StepRows

    rows, n = StepRows(3, capacity=2), 2
    records = [RunRecords(CASES["random"], rows, index) for index in range(3)]

    def add(runs, step):
        values = np.array([[10 * r + step + u / 10 for u in range(n)] for r in runs])
        rows.add(np.array(runs), step, 0.5 * step, [f"r{r}" for r in runs],
                 {name: values.astype(kind) for name, kind in STORED_COLUMNS.items()})

    for step in range(5):
        add([0, 1, 2] if step < 2 else [0, 2], step)  # run 1 stops after step 1
    add([2], 5)
    assert [r.n_steps for r in records] == [5, 2, 6]
    for index, record in enumerate(records):
        units = record.units()
        expected = [10 * index + step + u / 10 for step in range(record.n_steps) for u in range(n)]
        assert units.u_true.tolist() == expected and units.step.tolist() == np.repeat(range(record.n_steps), n).tolist()
        assert units.unit.tolist() == [1, 2] * record.n_steps
        steps = record.steps()
        assert steps.time_s.tolist() == [0.5 * step for step in range(record.n_steps)]
        assert set(steps.event) == {f"r{index}"}


def test_only_the_seeds_may_differ_and_only_quasi_static_chains_batch():
    base = CASES["thermal, noise"]
    with pytest.raises(ValueError):
        run_batch([base, dataclasses.replace(base, steps=3)])
    assert not batchable(dataclasses.replace(base, physics=dataclasses.replace(QUASISTATIC_PHYSICS,
                                                                                 backend="pybullet")))
    assert not batchable(RunConfig(shape=shape("grid-2x2"), sensor=IDEAL))
