"""The world contract (morphbench.physics.protocol): every backend, and the copies of a batch, behave alike through
the one interface the run loop, the events, the sensors and the renderer use. A new backend is tested by adding
it to WORLDS."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from morphbench.experiment import RunConfig, parse_events, run, run_batch
from morphbench.experiment.events import RunState
from morphbench.params import DEFAULT_PHYSICS, FAST_PHYSICS, QUASISTATIC_PHYSICS, SensorParams
from morphbench.physics import BACKENDS, Scene, WorldInterface, can_batch, make_world
from morphbench.shapes import load_shape
from morphbench.shapes.checks import connected_groups

from conftest import SHAPES_DIR

WORLDS = {
    # name: (shape, physics, copies in the batch the world is taken from, backend expected)
    "pybullet": ("chain-3", FAST_PHYSICS, 1, "pybullet"),
    "quasistatic": ("chain-3", QUASISTATIC_PHYSICS, 1, "quasistatic"),
    "planar": ("grid-2x2", DEFAULT_PHYSICS, 1, "planar"),
    "copy": ("chain-3", DEFAULT_PHYSICS, 3, "quasistatic"),
    "dynamic": ("grid-2x2", dataclasses.replace(DEFAULT_PHYSICS, backend="dynamic"), 1, "dynamic"),
}
TICKS = 60
PHASES = (0.0, 0.3, 0.6, 0.9)


def batch_of(name: str, **actuator):
    """A fresh batch holding the world ``name`` tests (its last copy for a batch of several: every other copy moves
    with it), its shape's actuator changed by ``actuator``."""
    shape_name, physics, copies, _ = WORLDS[name]
    shape = load_shape(SHAPES_DIR / f"{shape_name}.toml")
    shape = dataclasses.replace(shape, actuator=dataclasses.replace(shape.actuator, **actuator))
    return make_world(shape, physics, copies=copies)


def phases(world) -> np.ndarray:
    return np.array(PHASES[:world.shape.n_units])


def moved(name: str, action=None, ticks: int = TICKS, **actuator) -> tuple[np.ndarray, np.ndarray, WorldInterface]:
    """Every body's poses after ``ticks`` ticks at PHASES, ``action(world)`` done first; and the world (closed)."""
    with batch_of(name, **actuator) as batch:
        world = batch.worlds[-1]
        world.set_phases(phases(world))
        if action is not None:
            action(world)
        batch.advance(ticks)
        return (*world.poses(), world)


@pytest.mark.parametrize("name", WORLDS)
def test_a_world_declares_the_interface_and_its_capabilities(name):
    with batch_of(name) as batch:
        world = batch.worlds[-1]
        assert isinstance(world, WorldInterface)
        assert world.backend == WORLDS[name][3] and world.backend in BACKENDS
        assert world.scene is None or isinstance(world.scene, Scene)
        assert (world.scene is not None) == (world.backend == "pybullet")  # the camera sensor needs a scene
        n, n_links = world.shape.n_units, len(world.shape.links)
        assert world.link_units.shape == (n_links,) and set(world.link_units) <= set(range(-1, n))
        assert len(world.phases) == n and len(world.damage) == n and len(world.pressure) == n_links
        with pytest.raises(ValueError):
            world.set_phases(np.zeros(n + 1))


@pytest.mark.parametrize("name", WORLDS)
def test_phases_advance_and_poses(name):
    with batch_of(name) as batch:
        world = batch.worlds[-1]
        n_bodies, n = len(world.shape.bodies), world.shape.n_units
        world.set_phases(phases(world) + 1.25)  # wrapped into [0, 1)
        assert np.allclose(world.phases, np.mod(phases(world) + 1.25, 1.0))
        start, at = world.poses()[0], world.time
        assert start.shape == (n_bodies, 3) and world.poses()[1].shape == (n_bodies, 4)
        batch.advance(TICKS)
        assert world.time > at and world.ticks_in(world.time - at) == TICKS  # the clock counts ticks
        assert not np.allclose(world.poses()[0], start)  # the pumps move it
        samples = batch.advance_sampled(TICKS, 20)[-1]
        assert samples[0].shape == (3, n, 3) and samples[1].shape == (3, n, 4)
        assert np.array_equal(samples[0][-1], world.unit_poses()[0])  # the last sample is the end
        assert np.array_equal(world.unit_poses()[0], world.poses(world.shape.units)[0])
        assert np.isfinite(world.poses()[0]).all()


@pytest.mark.parametrize("name", WORLDS)
def test_the_same_world_moves_the_same_way(name):
    first, second = moved(name), moved(name)
    assert np.array_equal(first[0], second[0]) and np.array_equal(first[1], second[1])


@pytest.mark.parametrize("name", WORLDS)
def test_every_event_kind_acts_on_every_world(name):
    """friction, damage, shuffle, cut, noise: each applied by its Event.apply through the interface changes what it
    says it changes."""
    world_shape = load_shape(SHAPES_DIR / f"{WORLDS[name][0]}.toml")
    n, n_links = world_shape.n_units, len(world_shape.links)
    events = {event.kind: event for event in parse_events([
        {"step": 1, "kind": "friction", "scale": 0.6}, {"step": 1, "kind": "damage", "unit": 1, "mode": "dead"},
        {"step": 1, "kind": "shuffle", "seed": 3}, {"step": 1, "kind": "cut", "link": 1},
        {"step": 1, "kind": "noise", "sigma": 0.4}], "test", n, n_links)}
    healthy = moved(name)
    for kind, event in events.items():
        state = RunState.initial(n, 0.0)
        positions, _, world = moved(name, lambda w: event.apply(w, state))  # noqa: B023
        if kind == "noise":
            assert state.noise == 0.4 and np.array_equal(positions, healthy[0])  # the world is not touched
        elif kind == "shuffle":
            assert sorted(state.order) == list(range(n)) and not np.array_equal(state.order, np.arange(n))
        else:
            assert not np.array_equal(positions, healthy[0]), kind
        if kind == "damage":
            assert world.damage[0] == "dead" and state.damage[0] == "dead"
        if kind == "cut":
            links = [(link.front, link.rear) for j, link in enumerate(world.shape.links) if j != event.link - 1]
            assert world.pieces() == connected_groups(len(world.shape.bodies), links)


@pytest.mark.parametrize("name", WORLDS)
def test_an_open_bellows_is_a_no_inflate_one_as_soft_as_its_wall(name):
    """Damage 'open' (the paper's removed needle): with the wall as stiff as a bellows holding air it moves exactly
    as 'no-inflate' does; a softer wall changes the motion, and only through the damaged unit's own links."""
    cycle = round(2 * 2.0 / WORLDS[name][1].timestep)  # two pump cycles: every unit pumps
    stiff = moved(name, lambda w: w.set_damage(0, "no-inflate"), cycle, open_stiffness=1.0)[0]
    for wall in (30.0, 300.0):
        positions, _, world = moved(name, lambda w: w.set_damage(0, "open"), cycle, open_stiffness=wall)
        driven = world.link_units == 0
        assert np.all(world.link_stiffness[driven] == wall) and np.all(world.link_stiffness[~driven] == 300.0)
        assert np.array_equal(positions, stiff) == (wall == world.shape.actuator.stiffness), wall


@pytest.mark.parametrize("name", WORLDS)
def test_a_friction_event_scales_the_bodies_it_names(name):
    """bodies = 'all' scales every body ('all' is the default), 'active' the units' and 'passive' the others': a
    scale of 1 on either part changes nothing, and the two parts together are 'all'."""
    def scaled(*targets):
        def act(world):
            for scale, bodies in targets:
                world.set_friction_scale(scale, bodies)
        return act

    cycle = round(2 * 2.0 / WORLDS[name][1].timestep)  # two pump cycles: the dummy moves too
    healthy, everything = moved(name, None, cycle)[0], moved(name, scaled((0.6, "all")), cycle)[0]
    assert np.array_equal(moved(name, scaled((1.0, "passive")), cycle)[0], healthy)
    assert np.array_equal(moved(name, scaled((0.6, "active"), (0.6, "passive")), cycle)[0], everything)
    assert not np.array_equal(moved(name, scaled((0.5, "passive")), cycle)[0], healthy)


@pytest.mark.parametrize("name", WORLDS)
def test_a_batch_equals_its_runs_alone(name):
    """Copies of a world that can batch move each as it moves alone; a backend that cannot is refused copies,
    and can_batch says which before any world is built."""
    shape_name, physics, _, _ = WORLDS[name]
    shape = load_shape(SHAPES_DIR / f"{shape_name}.toml")
    config = RunConfig(shape=shape, physics=physics, steps=3, sensor=SensorParams(kind="ideal"))
    if not can_batch(shape, physics):
        with pytest.raises(ValueError):
            make_world(shape, physics, copies=2)
        return
    configs = [dataclasses.replace(config, seed=seed) for seed in (0, 1)]
    for together, seed in zip(run_batch(configs), configs):
        assert together.steps().equals(run(seed).steps()) and together.units().equals(run(seed).units())
    assert not run(configs[0]).units().equals(run(configs[1]).units())


@pytest.mark.parametrize("name", WORLDS)
def test_a_batch_sets_phases_and_reads_poses_as_its_worlds_do(name):
    """``Batch.set_phases`` and ``Batch.body_poses``, the driver's calls for every run at once, do what each world's
    own ``set_phases`` and ``poses`` do (a world left out keeps its phases)."""
    with batch_of(name) as batch, batch_of(name) as alone:
        count, n = len(batch.worlds), batch.worlds[0].shape.n_units
        values = np.linspace(-0.4, 1.7, count * n).reshape(count, n)  # wrapped into [0, 1) by both
        chosen = np.arange(count)[-1:] if count > 1 else np.arange(count)
        batch.set_phases(chosen, values[chosen])
        for index in chosen:
            alone.worlds[index].set_phases(values[index])
        for got, expected in zip(batch.worlds, alone.worlds):
            np.testing.assert_array_equal(got.phases, expected.phases)
        batch.advance(TICKS)
        positions, orientations = batch.body_poses()
        assert positions.shape == (count, len(batch.worlds[0].shape.bodies), 3)
        for index, world in enumerate(batch.worlds):
            np.testing.assert_array_equal(positions[index], world.poses()[0])
            np.testing.assert_array_equal(orientations[index], world.poses()[1])
