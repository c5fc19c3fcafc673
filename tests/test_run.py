"""The run loop: reproducible, each learner fed only its own unit's measurement, and it learns to move."""

import dataclasses
import importlib
import signal
import sys

import numpy as np
import pandas as pd
import pytest

from morphbench.errors import PluginError
from morphbench.experiment import RunConfig, run
from morphbench.lazy import import_keeping_interrupts
from morphbench.params import DEFAULT_PHYSICS, FAST_PHYSICS, EnvironmentParams, LearnerParams, SensorParams
from morphbench.shapes import load_shape

from conftest import SHAPES_DIR

CHAIN_2 = load_shape(SHAPES_DIR / "chain-2.toml")
CHAIN_3 = load_shape(SHAPES_DIR / "chain-3.toml")


def test_same_seed_gives_identical_records_and_another_seed_does_not():
    a, b, c = (run(RunConfig(shape=CHAIN_2, steps=4, seed=s)) for s in (7, 7, 8))
    pd.testing.assert_frame_equal(a.units(), b.units())
    pd.testing.assert_frame_equal(a.steps(), b.steps())
    assert not np.allclose(a.units().phase_tried, c.units().phase_tried)


class SpyLearner:
    """A plug-in that keeps every measurement it is given (instances are listed in creation = unit order)."""

    instances: list = []

    def __init__(self, params, rng):
        self.rng, self.phase, self.seen = rng, float(rng.uniform()), []
        SpyLearner.instances.append(self)

    def propose(self):
        self.phase = float((self.phase + self.rng.uniform(-0.1, 0.1)) % 1.0)
        return self.phase

    def update(self, velocity):
        self.seen.append(velocity)
        return True


def test_each_learner_gets_only_its_own_units_measurement():
    SpyLearner.instances = []
    records = run(RunConfig(shape=CHAIN_3, learner=f"{__name__}:SpyLearner", steps=5, seed=1,
                            environment=EnvironmentParams(noise=0.5)))
    units = records.units()
    assert len(SpyLearner.instances) == 3
    for k, learner in enumerate(SpyLearner.instances):
        own = units[units.unit == k + 1].u_measured.to_numpy()
        assert learner.seen == pytest.approx(own.tolist(), abs=0, rel=0)
    # the units moved differently, so a learner fed another unit's data would have been caught above
    assert not np.allclose(SpyLearner.instances[0].seen, SpyLearner.instances[2].seen)


def remembered_as_rule(units: pd.DataFrame, rule: str) -> np.ndarray:
    """Per unit, the memory the rule says follows from the recorded measurements: Thermal keeps the last accepted
    measurement (step 0's is always taken), Flaky the last one."""
    expected = []
    for _, own in units.groupby("unit", sort=True):
        memory = np.nan
        for measured, accepted in zip(own.u_measured, own.accepted):
            memory = measured if (accepted or rule == "flaky") else memory
            expected.append(memory)
    return np.array(expected)


@pytest.mark.parametrize("learner", ["thermal", "flaky", "hill-climber"])
def test_the_memory_recorded_is_the_one_each_learner_compares_with(learner):
    records = run(RunConfig(shape=CHAIN_3, learner=learner, steps=12, seed=2, environment=EnvironmentParams(noise=0.5)))
    units = records.units().sort_values(["unit", "step"])
    if learner == "hill-climber":  # each unit's measurement at the kept vector: kept while no trial beats it
        memory = units.pivot(index="step", columns="unit", values="u_memory")
        measured = units.pivot(index="step", columns="unit", values="u_measured")
        kept = [step for step, row in units.groupby("step") if row.accepted.all()]
        assert len(kept) < len(memory)  # some trial was refused, or memory would just be the measurement
        last = memory.index.map(lambda k: max(s for s in kept if s <= k))
        np.testing.assert_array_equal(memory.to_numpy(), measured.loc[last].to_numpy())
        return
    assert not units.accepted.all() or learner == "flaky"
    np.testing.assert_array_equal(units.u_memory.to_numpy(), remembered_as_rule(units, learner))
    if learner == "thermal":
        assert (units.u_memory != units.u_measured).any()


class Remembering(SpyLearner):
    """A plug-in whose memory is its last measurement doubled for 2 steps, then no number."""

    @property
    def memory(self):
        if len(self.seen) > 2:
            return "no number"
        return 2 * self.seen[-1] if self.seen else None


class Forgetful(SpyLearner):
    @property
    def memory(self):
        raise RuntimeError("lost it")


def test_a_plugin_without_a_usable_memory_records_nan_and_one_that_raises_stops_the_run():
    units = run(RunConfig(shape=CHAIN_3, learner=f"{__name__}:SpyLearner", steps=2, seed=1)).units()
    assert units.u_memory.isna().all() and units.u_measured.notna().all()
    units = run(RunConfig(shape=CHAIN_3, learner=f"{__name__}:Remembering", steps=4, seed=1)).units()
    early = units.step < 2
    np.testing.assert_array_equal(units.u_memory[early], 2 * units.u_measured[early])
    assert units.u_memory[~early].isna().all()
    with pytest.raises(PluginError, match="memory of unit 1 to be readable .*lost it"):
        run(RunConfig(shape=CHAIN_3, learner=f"{__name__}:Forgetful", steps=1, seed=1))


def test_measurement_noise_has_the_requested_spread_and_its_own_stream_per_unit():
    records = run(RunConfig(shape=CHAIN_3, steps=40, seed=3, environment=EnvironmentParams(noise=1.0)))
    units = records.units()
    error = (units.u_measured - units.u_true).to_numpy().reshape(-1, 3)
    assert error.std() == pytest.approx(1.0, rel=0.2)
    assert abs(np.corrcoef(error[:, 0], error[:, 1])[0, 1]) < 0.4
    noiseless = run(RunConfig(shape=CHAIN_3, steps=2, seed=3, sensor=SensorParams(kind="ideal"))).units()
    assert np.array_equal(noiseless.u_measured, noiseless.u_true)


@pytest.mark.parametrize("sensor", ["ideal", "optical"])
def test_a_thermal_chain_learns_to_move_forward(sensor):
    """Thermal learners beat blind phase changes (every trial accepted) on the same seeds, by a clear margin, with
    the ideal sensor and with the optical one alike."""
    def late_ubar(temperature: float) -> float:
        values = []
        for seed in range(4):
            steps = run(RunConfig(shape=CHAIN_2, steps=60, seed=seed, sensor=SensorParams(kind=sensor),
                                  learner_params=LearnerParams(temperature=temperature))).steps()
            values.append(steps.ubar_true[steps.step > 30].mean())
        return float(np.mean(values))

    learned, blind = late_ubar(LearnerParams().temperature), late_ubar(float("inf"))
    assert learned > blind + 0.5, (learned, blind)
    assert learned > 0.8, learned


def test_recorded_positions_follow_the_measured_motion():
    """Each unit's recorded ground position moves by its true velocity times the cycles of the step, also after a
    shuffle has moved units to other places."""
    from morphbench.experiment.events import ShuffleEvent

    lp = LearnerParams(discard_cycles=0)  # every cycle of a step is measured
    units = run(RunConfig(shape=CHAIN_3, steps=6, seed=4, sensor=SensorParams(kind="ideal"), learner_params=lp,
                          events=(ShuffleEvent(step=3, seed=1),))).units()
    x = units.pivot(index="step", columns="unit", values="x_m")
    u = units.pivot(index="step", columns="unit", values="u_true")
    moved = x.diff().iloc[1:] * 1000 / lp.cycles_per_step
    assert np.allclose(moved.drop(index=3), u.iloc[1:].drop(index=3), atol=0.05)  # a shuffle teleports units
    order = units[units.step == 3].sort_values("position").unit.tolist()
    front_x = units[(units.step == 3)].set_index("unit").x_m
    assert front_x[order[0]] > front_x[order[1]] > front_x[order[2]]  # position 1 is at the front


def test_a_camera_sensor_needs_its_world():
    from morphbench.experiment import make_sensor

    with pytest.raises(ValueError, match="camera sensor renders its world's PyBullet scene"):
        make_sensor(SensorParams(kind="camera"), 2, EnvironmentParams(), seed=0)


def test_the_backend_auto_chose_is_recorded():
    """'auto' is resolved once, by physics.resolve_backend, and summary.json says what it chose."""
    chain = RunConfig(shape=load_shape(SHAPES_DIR / "chain-2.toml"), steps=1)
    grid = dataclasses.replace(chain, shape=load_shape(SHAPES_DIR / "grid-2x2.toml"))
    assert run(chain).summary()["backend"] == "quasistatic"
    assert run(grid).summary()["backend"] == "planar"
    assert run(dataclasses.replace(chain, physics=FAST_PHYSICS)).summary()["backend"] == "pybullet"


def test_auto_gives_a_stack_the_substeps_its_springs_need():
    """A stack on 'auto' runs PyBullet with physics.STACK_SUBSTEPS steps per tick; a backend named explicitly keeps
    the settings it is given, and shapes on the ground are not touched."""
    from morphbench.physics import STACK_SUBSTEPS, make_world

    stack, chain = load_shape(SHAPES_DIR / "stack-2x2x2.toml"), load_shape(SHAPES_DIR / "chain-2.toml")
    with make_world(stack, DEFAULT_PHYSICS) as world:
        assert world.backend == "pybullet" and world.physics.substeps == STACK_SUBSTEPS >= 2
    with make_world(stack, FAST_PHYSICS) as world:
        assert world.physics.substeps == FAST_PHYSICS.substeps == 1
    with make_world(chain, DEFAULT_PHYSICS) as world:
        assert world.physics == DEFAULT_PHYSICS


SWALLOWER = """
import os, signal
try:  # as trimesh wraps each optional import of its own
    os.kill(os.getpid(), signal.SIGINT)
    for _ in range(10 ** 6):  # the handler runs between bytecodes
        pass
except BaseException:
    pass
imported = True
"""


@pytest.mark.parametrize("keeping", [False, True])
def test_ctrl_c_during_an_import_that_swallows_it_reaches_the_command(tmp_path, monkeypatch, keeping):
    """Ctrl-C during trimesh's first import (seconds of SciPy in a fresh process) was lost and the run went on."""
    name = f"swallower_{keeping}"
    (tmp_path / f"{name}.py").write_text(SWALLOWER)
    monkeypatch.syspath_prepend(str(tmp_path))
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        if keeping:
            with pytest.raises(KeyboardInterrupt):
                import_keeping_interrupts(name)
        else:  # what the library does to a plain import
            importlib.import_module(name)
        assert sys.modules[name].imported
    finally:
        signal.signal(signal.SIGINT, previous)


class _InterruptedCleanUp:
    """A learner whose propose meets Ctrl-C inside a library that turns it into another error while cleaning up (as
    numba does when compiling)."""

    def __init__(self, params, rng):
        self.phase = 0.0

    def propose(self):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt:
            raise RuntimeError("no compiled object yet") from None

    def update(self, velocity):
        return False


def test_ctrl_c_that_a_library_turned_into_another_error_is_still_an_interrupt():
    config = RunConfig(shape=load_shape(SHAPES_DIR / "chain-2.toml"), steps=3,
                       learner=f"{__name__}:_InterruptedCleanUp")
    with pytest.raises(KeyboardInterrupt):
        run(config)
