"""The learners beyond the paper (docs/learners.md): Averaged (the memory an exponential average of the measurements),
Adaptive (Thermal with a step size steered by its acceptance rate) and Sparse (trials on a fraction of the steps, its
own settings as its defaults). Their rules on scripted measurements, the
identities with Flaky and Thermal, a batch equal to its runs alone, learning on a chain, and their parameters'
messages."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pandas as pd
import pytest

from morphbench.bench import load_suite
from morphbench.identity import config_identity, stable_hash
from morphbench.errors import ConfigError
from morphbench.experiment import RunConfig, load_run_config, run
from morphbench.experiment.driver import batchable, run_batch
from morphbench.learning import AdaptiveLearner, AveragedLearner, load_learner_class
from morphbench.learning.base import wrap_phase
from morphbench.params import EnvironmentParams, LearnerParams, SensorParams
from morphbench.shapes import load_shape

from conftest import SHAPES_DIR, run_cli, write, write_suite
from test_learning import ScriptedRng

# any RuntimeWarning (an average with -inf, exp overflow) is a bug here
pytestmark = pytest.mark.filterwarnings("error")

IDEAL = SensorParams(kind="ideal")
CHAIN2, CHAIN3 = load_shape(SHAPES_DIR / "chain-2.toml"), load_shape(SHAPES_DIR / "chain-3.toml")


def records(config: RunConfig) -> tuple[pd.DataFrame, pd.DataFrame]:
    done = run(config)
    return done.units(), done.steps()


def assert_same_records(a: RunConfig, b: RunConfig) -> None:
    for got, expected in zip(records(a), records(b)):
        pd.testing.assert_frame_equal(got, expected, check_exact=True)


# --- the rules on scripted measurements ---------------------------------------------------------------------------


def test_averaged_memory_moves_a_fraction_beta_towards_every_measurement_accepted_or_not():
    # draws: initial phase, then per trial eps and, for a worse trial only, the acceptance draw
    unit = AveragedLearner(LearnerParams(memory_weight=0.25, temperature=0.5),
                           ScriptedRng(0.3, 0.5, 0.2, 0.99, -0.4))
    memories = []
    for velocity in (2.0, 4.0, 1.0, 2.125):
        unit.propose()
        unit.update(velocity)
        memories.append(unit.memory)
    # measured 2 (the first memory), then 0.75 * 2 + 0.25 * 4, a rejected 1 (0.99 > exp(-1.5 / 0.5)) still
    # averaged in, then a trial equal to the memory (accepted without a draw, the memory unchanged)
    assert memories == [2.0, 2.5, 2.125, 2.125]
    assert unit.phase == pytest.approx(wrap_phase(0.3 + 0.5 * 0.1 - 0.4 * 0.1))


@pytest.mark.parametrize("initial_memory, first", [("-inf", 3.0), ("zero", 0.75)])
def test_averaged_memory_starts_from_minus_inf_at_the_measurement_and_from_zero_by_averaging(initial_memory, first):
    unit = AveragedLearner(LearnerParams(memory_weight=0.25, initial_memory=initial_memory), ScriptedRng(0.3, 0.5))
    unit.propose()
    assert unit.update(3.0) is True
    assert unit.memory == first


class Steady:
    """Stands in for a unit's Generator: eps is always 1 (each trial the kept phase plus the step size) and the
    acceptance draw 0.5 (a worse trial is never accepted at T = 0)."""

    def uniform(self, low: float, high: float) -> float:
        return high if low < 0 else 0.5


def step_sizes(params: LearnerParams, velocities) -> tuple[list[float], list[bool]]:
    """An adaptive unit's step size after each update and whether it accepted, against scripted velocities; each
    trial is checked to reach exactly the step size before it."""
    unit = AdaptiveLearner(params, Steady())
    sizes, accepted = [], []
    for velocity in velocities:
        reach, measured = unit.step_size, unit.memory is not None
        tried = unit.propose()
        assert tried == (wrap_phase(unit.phase + reach) if measured else unit.phase)
        accepted.append(unit.update(velocity))
        sizes.append(unit.step_size)
    return sizes, accepted


def test_adaptive_step_size_follows_the_acceptance_rate_of_each_window_within_its_bounds():
    params = LearnerParams(temperature=0.0, step_size=0.15, adapt_rate=0.5, adapt_window=2, target_acceptance=0.5,
                           step_size_min=0.05, step_size_max=0.3)
    # T = 0: a better or equal trial is accepted, a worse one never. The first step measures: no trial, not counted.
    velocities = [0.0, 1.0, 2.0, 3.0, 0.0, 4.0, 5.0] + [0.0] * 8
    sizes, accepted = step_sizes(params, velocities)
    assert accepted == [True, True, True, True, False, True, True] + [False] * 8
    up, down = math.exp(0.5), math.exp(-0.5)
    grown = 0.15 * up  # window 1: 2 of 2 accepted, above the target; window 2: 1 of 2, at it (unchanged)
    assert grown * up > 0.3  # window 3: 2 of 2 again, grown past step_size_max: clipped
    s1 = 0.3 * down  # windows 4-7: 0 of 2, shrinking
    s2 = s1 * down
    s3 = s2 * down
    assert s3 * down < 0.05  # window 7 is clipped at step_size_min
    assert sizes == [0.15, 0.15, grown, grown, grown, grown, 0.3, 0.3, s1, s1, s2, s2, s3, s3, 0.05]


def test_adaptive_without_adaptation_keeps_its_step_size_even_outside_the_bounds():
    params = LearnerParams(temperature=0.0, step_size=0.8, adapt_rate=0.0, adapt_window=1)
    sizes, _ = step_sizes(params, [0.0, 1.0, 2.0, 0.0, 0.0])
    assert sizes == [0.8] * 5


# --- identities ---------------------------------------------------------------------------------------------------


def test_averaged_with_weight_one_is_flaky_bit_for_bit():
    flaky = RunConfig(shape=CHAIN3, learner="flaky", steps=20, seed=4, sensor=IDEAL,
                      environment=EnvironmentParams(noise=0.7))
    averaged = dataclasses.replace(flaky, learner="averaged", learner_params=LearnerParams(memory_weight=1.0))
    assert_same_records(averaged, flaky)
    # and a weight below 1 is another learner on the same draws
    half = dataclasses.replace(averaged, learner_params=LearnerParams(memory_weight=0.5))
    assert not records(half)[0].u_memory.equals(records(flaky)[0].u_memory)


def test_adaptive_without_adaptation_is_thermal_bit_for_bit():
    thermal = RunConfig(shape=CHAIN3, steps=20, seed=4, sensor=IDEAL, environment=EnvironmentParams(noise=0.7),
                        learner_params=LearnerParams(step_size=0.8, adapt_window=1))
    adaptive = dataclasses.replace(thermal, learner="adaptive",
                                   learner_params=dataclasses.replace(thermal.learner_params, adapt_rate=0.0))
    assert_same_records(adaptive, thermal)
    adapting = dataclasses.replace(adaptive, learner_params=dataclasses.replace(thermal.learner_params))
    assert not records(adapting)[0].phase_tried.equals(records(thermal)[0].phase_tried)


@pytest.mark.parametrize("learner", ["averaged", "adaptive"])
def test_a_batch_gives_each_seed_the_records_it_gets_alone(learner):
    base = RunConfig(shape=CHAIN3, learner=learner, steps=25, sensor=IDEAL, environment=EnvironmentParams(noise=0.5),
                     learner_params=LearnerParams(adapt_window=3))
    configs = [dataclasses.replace(base, seed=seed) for seed in (0, 1, 5)]
    assert all(batchable(c) for c in configs)
    for config, batched in zip(configs, run_batch(configs)):
        for got, expected in zip((batched.units(), batched.steps()), records(config)):
            pd.testing.assert_frame_equal(got, expected, check_exact=True)


# --- learning -----------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("learner", ["averaged", "adaptive"])
def test_two_units_learn_to_move_faster_than_random_phase_changes(learner):
    """chain-2, 60 steps, 4 seeds: random's final Ubar is about -0.5 mm/cycle; averaged about 2.4, adaptive about
    3 (docs/learners.md)."""
    def final_ubar(name):
        return np.mean([run(RunConfig(shape=CHAIN2, learner=name, steps=60, seed=seed, sensor=IDEAL))
                        .summary()["final_ubar"] for seed in range(4)])

    assert final_ubar(learner) > final_ubar("random") + 1.0


# --- names and parameters everywhere ------------------------------------------------------------------------------


def test_the_names_work_in_the_api_the_command_line_and_suites(tmp_path, capsys):
    assert load_learner_class(" Averaged ") is AveragedLearner and load_learner_class("ADAPTIVE") is AdaptiveLearner
    code, _, err = run_cli(capsys, "run", str(SHAPES_DIR / "chain-2.toml"), "--learner", "adaptive", "--steps", "2",
                           "--sensor", "ideal", "--out", str(tmp_path / "run"), "--quiet")
    assert code == 0, err
    assert (tmp_path / "run" / "steps.parquet").is_file()
    suite = load_suite(write_suite(tmp_path, f"""
        [[experiment]]
        name = "extra"
        shape = "{SHAPES_DIR / 'chain-2.toml'}"
        steps = 4
        learner = {{name = ["averaged", "adaptive"], memory_weight = [0.5, 0.8]}}
    """))
    specs = list(suite.runs.values())
    assert sorted((s.config.learner, s.config.learner_params.memory_weight) for s in specs) == [
        ("adaptive", 0.5), ("adaptive", 0.8), ("averaged", 0.5), ("averaged", 0.8)]


def test_new_fields_change_a_run_id_only_away_from_their_defaults():
    config = RunConfig(shape=CHAIN2)
    same = dataclasses.replace(config, learner_params=LearnerParams(memory_weight=0.5, adapt_window=10))
    other = dataclasses.replace(config, learner_params=LearnerParams(memory_weight=0.8))
    ids = [stable_hash(config_identity(c, "default")) for c in (config, same, other)]
    assert ids[0] == ids[1] != ids[2]
    assert "memory_weight" not in config_identity(config, "default")["learner_params"]


BAD = [
    ("memory_weight", "0", "a number in (0, 1]"),
    ("memory_weight", "1.5", "a number in (0, 1]"),
    ("adapt_rate", "-0.1", "a number in [0, 5]"),
    ("adapt_window", "0", "an integer in [1, 10000] (steps)"),
    ("adapt_window", "2.5", "an integer in [1, 10000] (steps)"),
    ("target_acceptance", "1", "a number in (0, 1)"),
    ("step_size_min", "0", "a number in (0, 1] (cycles)"),
    ("step_size_max", "nan", "a number in (0, 1] (cycles)"),
]


@pytest.mark.parametrize("key, text, expected", BAD)
def test_a_bad_value_is_one_line_naming_its_key_in_files_and_the_api(tmp_path, key, text, expected):
    path = write(tmp_path, f'shape = "{SHAPES_DIR / "chain-2.toml"}"\n[learner]\nname = "adaptive"\n{key} = {text}\n',
                 "run.toml")
    with pytest.raises(ConfigError) as in_file:
        load_run_config(path)
    assert str(in_file.value).startswith(f"{path}: learner.{key}: expected {expected}, got ")
    value = float(text) if "." in text or text == "nan" else int(text)
    for cls in (AveragedLearner, AdaptiveLearner):
        with pytest.raises(ConfigError, match=rf"^LearnerParams: {key}: expected "):
            cls(LearnerParams(**{key: value}), np.random.default_rng(0))


def test_step_size_bounds_out_of_order_are_refused_in_files_the_api_and_the_command_line(tmp_path, capsys):
    path = write(tmp_path, f'shape = "{SHAPES_DIR / "chain-2.toml"}"\n[learner]\nname = "adaptive"\n'
                           "step_size_min = 0.3\nstep_size_max = 0.2\n", "run.toml")
    message = f"{path}: learner.step_size_max: expected a step size >= step_size_min (0.3 cycles), got 0.2"
    with pytest.raises(ConfigError) as in_file:
        load_run_config(path)
    assert str(in_file.value) == message
    code, _, err = run_cli(capsys, "run", str(path), "--steps", "1", "--out", str(tmp_path / "out"))
    assert code == 2 and err.strip().splitlines() == [f"morphbench: error: {message}"]
    with pytest.raises(ConfigError, match=r"^LearnerParams: step_size_max: expected a step size >= step_size_min"):
        AdaptiveLearner(LearnerParams(step_size_min=0.3, step_size_max=0.2), np.random.default_rng(0))


def test_the_sparse_learner_runs_with_its_own_settings_unless_given_others(tmp_path, capsys):
    """Its preset (params.LEARNER_PRESETS) is what a run of it starts from, through every door: the API, a run file
    (its fields on top) and --learner (the options on top); a file that sets its own learner fields keeps them."""
    from morphbench.params import LEARNER_PRESETS
    import json

    preset, shape = LEARNER_PRESETS["sparse"], load_shape(SHAPES_DIR / "chain-2.toml")
    assert preset != LearnerParams() and preset.cycles_per_step + preset.discard_cycles == 2  # a step of 2 cycles
    assert RunConfig(shape=shape, learner="sparse").learner_params == preset
    assert RunConfig(shape=shape, learner="Sparse").learner_params == preset
    assert RunConfig(shape=shape).learner_params == LearnerParams()
    head = f'shape = "{SHAPES_DIR / "chain-2.toml"}"\n[learner]\n'
    path = write(tmp_path, name="run.toml", text=head + 'name = "sparse"\ntemperature = 0.2\n')
    assert load_run_config(path).learner_params == dataclasses.replace(preset, temperature=0.2)

    def ran(*argv):
        out = tmp_path / f"out-{len(list(tmp_path.glob('out-*')))}"
        code, _, err = run_cli(capsys, "run", *argv, "--steps", "2", "--quiet", "--out", str(out))
        assert code == 0, err
        return json.loads((out / "summary.json").read_text())["config"]["learner_params"]

    assert ran("chain-2", "--learner", "sparse") == dataclasses.asdict(preset)
    assert ran("chain-2", "--learner", "sparse", "--step-size", "0.2") == \
        dataclasses.asdict(dataclasses.replace(preset, step_size=0.2))
    own = write(tmp_path, name="own.toml", text=head + "step_size = 0.3\n")
    assert ran(str(own), "--learner", "sparse") == dataclasses.asdict(LearnerParams(step_size=0.3))
