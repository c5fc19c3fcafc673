"""Issue 36 at scale: the dynamic backend by name (the 'dynamic' physics preset, for ``morphbench run`` and suites),
its advance holding nothing per tick, and a learning step's work (learners, sensors, validity, records) done at once
over the units, with every record as before (bit for bit: tests/test_batch.py, test_clocks.py, test_records.py and
test_learning.py). Nothing here times anything: benchmarks/cost_per_unit.py --run-loop measures the cost per unit
(benchmarks/RESULTS.md)."""

from __future__ import annotations

import dataclasses
import json
import math
import sys
import tracemalloc

import numpy as np
import pytest

from morphbench.bench import load_suite
from morphbench.experiment import RunConfig
from morphbench.experiment.config import load_run_config
from morphbench.experiment.driver import Driver
from morphbench.experiment.events import parse_events
from morphbench.experiment.run import _Validity
from morphbench.learning import arrays
from morphbench.learning.metropolis import acceptance_probability
from morphbench.params import (
    DEFAULT_PHYSICS,
    PHYSICS_PRESETS,
    EnvironmentParams,
    FrictionFieldParams,
    SensorParams,
)
from morphbench.physics import make_world, resolve_backend
from morphbench.physics.dynamic import DynamicWorld
from morphbench.sensing import ideal
from morphbench.shapes import load_shape, shape_from_table
from morphbench.streams import NOISE_STREAM

from conftest import SHAPES_DIR, run_cli, sheet, write_suite

RUN_LOOP = sys.modules[_Validity.__module__]
"""morphbench.experiment.run (the package's ``run`` is the function)."""
DYNAMIC = PHYSICS_PRESETS["dynamic"]
IDEAL = SensorParams(kind="ideal")


# --- the preset ---------------------------------------------------------------------------------------------------

def test_the_dynamic_preset_is_the_dynamic_backend_and_auto_never_picks_it():
    assert DYNAMIC == dataclasses.replace(DEFAULT_PHYSICS, backend="dynamic")
    shape = sheet(3)
    assert resolve_backend(shape, DYNAMIC) == "dynamic"
    assert resolve_backend(shape, PHYSICS_PRESETS["default"]) == "planar"  # the default is unchanged
    assert load_run_config(SHAPES_DIR / "chain-2.toml", physics="dynamic").physics == DYNAMIC


def test_a_suite_names_the_dynamic_physics(tmp_path):
    path = write_suite(tmp_path, f"""
        name = "dynamic"
        [[experiment]]
        name = "sheet"
        shape = "{SHAPES_DIR / 'grid-2x2.toml'}"
        seeds = 2
        steps = 2
        physics = "dynamic"
        """)
    runs = list(load_suite(path).runs.values())
    assert len(runs) == 2 and all(run.config.physics == DYNAMIC for run in runs)


def test_morphbench_run_takes_physics_dynamic(tmp_path, capsys):
    out = tmp_path / "run"
    code, _, err = run_cli(capsys, "run", str(SHAPES_DIR / "grid-2x2.toml"), "--physics", "dynamic", "--sensor",
                           "ideal", "--steps", "2", "--out", str(out), "--quiet")
    assert code == 0, err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["backend"] == "dynamic" and summary["config"]["physics"]["backend"] == "dynamic"


# --- the advance: tick by tick, nothing per tick held -----------------------------------------------------------

def damaged_world(environment: EnvironmentParams) -> DynamicWorld:
    """A 4 x 5 grid with dummies in motion, with every damage that changes pressures, lengths or friction."""
    shape = shape_from_table({"assembly": {"generator": "grid", "rows": 4, "columns": 5, "dummy": True,
                                           "actuated_axes": ["x", "y"]}}, source="test")
    world = DynamicWorld(shape, DYNAMIC, environment)
    rng = np.random.default_rng(3)
    world.set_phases(rng.random(shape.n_units))
    world.set_clock_rates(0.03 * rng.standard_normal(shape.n_units))
    world.advance(50)
    world.set_damage(0, "stuck")
    world.set_damage(1, "open")
    world.set_damage(2, "dead")
    world.set_damage(3, "no-inflate")
    return world


@pytest.mark.parametrize("environment", [EnvironmentParams(), EnvironmentParams(vibration=1.5),
                                         EnvironmentParams(friction_field=FrictionFieldParams(amplitude=0.3))],
                         ids=["uniform", "vibration", "field"])
def test_each_ticks_pressures_are_those_of_the_whole_advance(environment):
    """The dynamic world finds each tick's pressures (and from them its rest lengths and friction limits) as it
    steps, from the same law as every world's ``_pressures`` for a whole advance: the same numbers, bit for bit."""
    world = damaged_world(environment)
    n_ticks = 97  # not a multiple of the pumps' cycle
    expected = world._pressures(world.time, n_ticks, True)
    seen = []
    world.advance(n_ticks, lambda k: seen.append(world.pressure.copy()))
    assert np.array_equal(np.array(seen), expected)
    world.advance(20, pumps=False)
    assert not world.pressure.any()


@pytest.mark.parametrize("environment", [EnvironmentParams(), EnvironmentParams(vibration=1.5)],
                         ids=["uniform", "vibration"])
def test_an_advance_holds_no_array_per_tick(environment):
    """The memory an advance allocates does not grow with its ticks: a 10-times longer advance peaks as high (the
    whole advance's pressures, rest lengths and friction limits would be 8 bytes per tick and link or body)."""
    world = damaged_world(environment)
    world.advance(10)  # compiled, and whatever is kept between advances made

    def peak(n_ticks: int) -> int:
        tracemalloc.start()
        try:
            world.advance(n_ticks)
            return tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()

    short, long = peak(60), peak(600)
    per_tick = 8 * (len(world.shape.links) + len(world.shape.bodies))
    assert long <= short + per_tick, (short, long)


def test_an_advance_cut_at_callbacks_is_the_same_advance():
    """Stopping at each callback (the sensors' samples) carries the pressures and rest lengths over exactly."""
    worlds = [damaged_world(EnvironmentParams(vibration=1.3)) for _ in range(2)]
    worlds[0].advance(90)
    worlds[1].advance(90, lambda k: None, every=7)
    assert worlds[0].q.tobytes() == worlds[1].q.tobytes() and worlds[0].v.tobytes() == worlds[1].v.tobytes()
    assert worlds[0].pressure.tobytes() == worlds[1].pressure.tobytes()


# --- a learning step, vectorised over the units -------------------------------------------------------------------

def python_calls(action) -> int:
    """Python and C function calls made by ``action()`` (a loop over units calls something per unit)."""
    count = [0]

    def profile(frame, event, arg):
        if event in ("call", "c_call"):
            count[0] += 1

    sys.setprofile(profile)
    try:
        action()
    finally:
        sys.setprofile(None)
    return count[0]


@pytest.mark.parametrize("environment", [EnvironmentParams(), EnvironmentParams(noise=0.5)], ids=["ideal", "noise"])
def test_a_learning_step_makes_no_call_per_unit(environment):
    """The calls a learning step makes (physics, sensors, validity, learners, noise, records) do not grow with the
    number of units: 16 and 144 units make as many, give or take a few (it was one or more per unit that accepted
    a worse trial, and one per unit and step with noise)."""
    calls = {}
    for side in (4, 12):
        config = RunConfig(shape=sheet(side), physics=DYNAMIC, sensor=IDEAL, steps=4, seed=0,
                           environment=environment)
        driver = Driver([config])
        with driver.batch:
            driver.warm_up()
            driver.step(0)
            driver.step(1)  # the noise streams made, the first draws read
            calls[side] = [python_calls(lambda s=step: driver.step(s)) for step in (2, 3, 4)]
    assert max(calls[12]) <= min(calls[4]) + 10, calls


@pytest.mark.parametrize("temperature", [0.0, 1e-3, 0.6, 5.0, math.inf])
def test_worse_trials_are_decided_as_each_learner_decides_them(temperature):
    """``arrays.accepts`` takes every decision a Metropolis learner takes (draw < acceptance_probability), numpy's
    exp or not: also for draws at the probability itself, where numpy's exp and math.exp may differ in the last
    place."""
    rng = np.random.default_rng(1)
    delta = -np.abs(rng.standard_normal(20000)) * rng.choice([1e-3, 1.0, 10.0, 1000.0], 20000)
    draws = rng.random(20000)
    if temperature not in (0.0, math.inf):
        exact = np.array([acceptance_probability(d, temperature) for d in delta[:500]])
        draws[:500] = exact  # on the boundary: not accepted (draw < p is false)
        draws[500:1000] = np.nextafter(exact[:500], 0.0)  # just below it: accepted
    decided = arrays.accepts(draws, delta, temperature)
    assert decided.tolist() == [d < acceptance_probability(x, temperature) for d, x in zip(draws, delta)]


def test_noise_is_each_units_own_normal_stream_read_ahead():
    """``RunLoop.noise`` gives what ``rng.normal(0.0, sigma)`` of each unit's own stream gives, bit for bit, across
    the blocks it reads ahead and as the noise changes."""
    config = RunConfig(shape=load_shape(SHAPES_DIR / "chain-3.toml"), sensor=IDEAL, steps=1, seed=7,
                       environment=EnvironmentParams(noise=0.5))
    driver = Driver([config])
    loop = driver.loops[0]
    streams = [np.random.default_rng(np.random.SeedSequence([7, NOISE_STREAM, u])) for u in range(3)]
    for step in range(150):
        sigma = (0.5, 1.7, 1e-3)[step % 3]
        expected = np.array([rng.normal(0.0, sigma) for rng in streams])
        assert loop.noise(sigma).tobytes() == expected.tobytes(), step
    driver.close()


@pytest.mark.parametrize("block", [1, 2, 5, ideal.UNITS_AT_ONCE])
def test_the_ideal_sensor_samples_units_a_block_at_a_time_as_one_sample_at_a_time(monkeypatch, block):
    monkeypatch.setattr(ideal, "UNITS_AT_ONCE", block)
    n_units, n_frames = 7, 40
    rng = np.random.default_rng(2)
    positions = np.cumsum(rng.normal(0, 2e-4, (2 * n_frames + 1, n_units, 3)), axis=0)
    yaw = np.cumsum(rng.normal(0, 1e-2, (2 * n_frames + 1, n_units)), axis=0)
    orientations = np.stack([0 * yaw, 0 * yaw, np.sin(yaw / 2), np.cos(yaw / 2)], axis=2)
    one, many = ideal.IdealSensor(n_units, 0.1), ideal.IdealSensor(n_units, 0.1)
    for sensor in (one, many):
        sensor.reset(positions[0], orientations[0])
    for p, q in zip(positions[1:], orientations[1:]):
        one.sample(p, q)
    many.sample_many(positions[1:n_frames + 1], orientations[1:n_frames + 1])
    many.sample_many(positions[n_frames + 1:], orientations[n_frames + 1:])
    assert one.displacement().tobytes() == many.displacement().tobytes()


def validity_of(shape, events=()):
    world = make_world(shape, DYNAMIC)
    return world, _Validity(shape, world, events)


def test_the_links_checked_are_the_links_not_cut_between_the_bodies():
    shape = load_shape(SHAPES_DIR / "chain-7.toml")
    events = parse_events([{"step": 3, "kind": "cut", "link": 3}, {"step": 5, "kind": "cut", "link": 6}], "test",
                          shape.n_units, len(shape.links))
    _, validity = validity_of(shape, events)
    for step in (0, 3, 4, 5):
        cut = {event.link - 1 for event in events if event.step <= step}
        for bodies in (validity.units, validity.bodies):
            links, front, rear = validity._links(step, bodies)
            expected = [j for j in range(len(shape.links))
                        if j not in cut and shape.links[j].front in bodies and shape.links[j].rear in bodies]
            assert links.tolist() == expected
            column = {body: k for k, body in enumerate(bodies)}
            assert front.tolist() == [column[shape.links[j].front] for j in expected]
            assert rear.tolist() == [column[shape.links[j].rear] for j in expected]


@pytest.mark.parametrize("block", [1, 5, RUN_LOOP.LINKS_AT_ONCE])
def test_the_quick_link_test_never_passes_a_link_the_detector_fails(monkeypatch, block):
    """``_links_surely_within`` compares squared lengths, a block of links at a time: a link a few units in the last
    place inside or outside its span passes only if the detector's length passes, and every link well inside
    passes."""
    monkeypatch.setattr(RUN_LOOP, "LINKS_AT_ONCE", block)
    shape = sheet(3)
    world, validity = validity_of(shape)
    positions = world.poses()[0]
    links, front, rear = validity._links(0, validity.bodies)
    assert validity._links_surely_within(0, validity.bodies, positions[None])
    axis = positions[front[0]] - positions[rear[0]]
    axis /= np.linalg.norm(axis)
    for bound in (validity.span[0][links[0]], validity.span[1][links[0]]):
        for ulps in range(-4, 5):
            length = bound * (1 + ulps * 2.0 ** -52)
            moved = positions.copy()
            moved[front[0]] = positions[rear[0]] + length * axis
            surely = validity._links_surely_within(0, validity.bodies, moved[None])
            _, lengths = validity._link_lengths(0, validity.bodies, moved[None])
            inside = ((lengths >= validity.span[0][links]) & (lengths <= validity.span[1][links])).all()
            assert inside or not surely, (bound, ulps)
    for bad in (np.nan, np.inf, 1e200):
        moved = positions.copy()
        moved[front[0], 0] = bad
        assert not validity._links_surely_within(0, validity.bodies, moved[None])


def test_pieces_are_found_for_every_unit_after_a_cut():
    shape = load_shape(SHAPES_DIR / "chain-7.toml")
    events = [{"step": 1, "kind": "cut", "link": 3}, {"step": 2, "kind": "shuffle", "seed": 3}]
    config = RunConfig(shape=shape, sensor=IDEAL, steps=3, seed=0,
                       events=parse_events(events, "test", shape.n_units, len(shape.links)))
    driver = Driver([config])
    with driver.batch:
        driver.warm_up()
        for step in range(4):
            driver.step(step)
            loop = driver.loops[0]
            piece_of_body = {body: k for k, piece in enumerate(loop.world.pieces()) for body in piece}
            expected = [piece_of_body[shape.units[p]] + 1 for p in loop.position]
            assert loop.piece.tolist() == expected
            assert len(set(expected)) == (1 if step == 0 else 2)


def test_the_memory_estimate_counts_what_each_world_holds():
    """The dynamic world holds nothing per tick: its estimate does not grow with the advance, the others' does, and
    the planar solver's adds its Newton systems."""
    from morphbench.physics import memory_estimate

    shape = sheet(10)
    dynamic = [memory_estimate(shape, DYNAMIC, ticks=ticks) for ticks in (1, 1000)]
    planar = [memory_estimate(shape, PHYSICS_PRESETS["default"], ticks=ticks) for ticks in (1, 1000)]
    assert dynamic[0] == dynamic[1] < planar[0] < planar[1]
    assert 0 < dynamic[0] < 100 * len(shape.bodies) * 8 * 16
