"""Sampled advancing: a quasi-static world records the sensors' poses inside its compiled loop, and a sensor bank
takes many samples at once; both give exactly what one callback and one ``sample`` per tick give."""

import numpy as np
import pytest

from morphbench.params import QUASISTATIC_PHYSICS, EnvironmentParams, FrictionFieldParams, GroundParams, OpticalParams
from morphbench.physics import make_world
from morphbench.physics.bellows import Bellows
from morphbench.sensing import IdealSensor, OpticalSensor
from morphbench.sensing.ground import GroundTexture
from morphbench.shapes import load_shape

from conftest import SHAPES_DIR

FIELD = EnvironmentParams(friction_field=FrictionFieldParams(amplitude=0.3))


@pytest.mark.parametrize("shape_name, environment", [("chain-3", EnvironmentParams()), ("chain-7", FIELD),
                                                     ("grid-2x3", EnvironmentParams()), ("grid-2x3", FIELD)])
@pytest.mark.parametrize("n_ticks, every", [(800, 25), (801, 25), (30, 7), (5, 9), (1, 1)])
def test_sampled_poses_equal_the_callback_ones(shape_name, environment, n_ticks, every):
    """The compiled recording (QuasiStatic.advance_sampled) against the generic one of every world (a callback
    reading the poses), from the same phases: identical poses, same count, same final state."""
    shape = load_shape(SHAPES_DIR / f"{shape_name}.toml")
    worlds = [make_world(shape, QUASISTATIC_PHYSICS, environment) for _ in range(2)]
    phases = np.random.default_rng(n_ticks).random(shape.n_units)
    results = []
    for world, advance_sampled in zip(worlds, [type(worlds[0]).advance_sampled, Bellows.advance_sampled]):
        world.set_phases(phases)
        world.advance(123)
        results.append(advance_sampled(world, n_ticks, every))
    (p_fast, q_fast), (p_slow, q_slow) = results
    assert len(p_fast) == len(range(every, n_ticks, every)) + 1
    np.testing.assert_array_equal(p_fast, p_slow)
    np.testing.assert_array_equal(q_fast, q_slow)
    np.testing.assert_array_equal(worlds[0].poses()[0], worlds[1].poses()[0])
    assert worlds[0].time == worlds[1].time


def sensors(n_units):
    ground = GroundTexture(GroundParams())
    return [IdealSensor(n_units, 0.125),
            OpticalSensor(n_units, OpticalParams(), ground, np.random.default_rng(5)),
            OpticalSensor(n_units, OpticalParams(noise=0.0), ground, np.random.default_rng(5))]


@pytest.mark.parametrize("kind", range(3))
def test_many_samples_at_once_equal_one_at_a_time(kind):
    """A bank's sample_many over a path equals its sample called once per pose (the optical bank renders in batches
    of its own size either way, and draws its noise frame by frame)."""
    n_units, n_frames = 3, 1500  # more frames than one optical batch holds
    rng = np.random.default_rng(1)
    # a random walk on the ground (at a resting unit's height, where the optical sensor sees it)
    positions = np.cumsum(rng.normal(0, 2e-5, (n_frames + 1, n_units, 3)), axis=0) * [1, 1, 0] + [0, 0, 0.015]
    yaw = np.cumsum(rng.normal(0, 1e-3, (n_frames + 1, n_units)), axis=0)
    orientations = np.stack([0 * yaw, 0 * yaw, np.sin(yaw / 2), np.cos(yaw / 2)], axis=2)
    one, many = sensors(n_units)[kind], sensors(n_units)[kind]
    for sensor in (one, many):
        sensor.reset(positions[0], orientations[0])
    for p, q in zip(positions[1:], orientations[1:]):
        one.sample(p, q)
    many.sample_many(positions[1:], orientations[1:])
    assert np.abs(one.displacement()).max() > 1e-4  # it moved
    np.testing.assert_array_equal(one.displacement(), many.displacement())
