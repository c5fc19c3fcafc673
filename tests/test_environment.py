"""Environments and events, checked against physics and against the records."""

import dataclasses

import numpy as np
import pytest

from morphbench.errors import ConfigError
from morphbench.experiment import RunConfig, load_run_config, parse_events, run, run_config_from_table
from morphbench.experiment.events import CutEvent, DamageEvent, FrictionEvent, NoiseEvent, ShuffleEvent
from morphbench.experiment.scan import velocity_at
from morphbench.params import EnvironmentParams, FrictionFieldParams, SensorParams
from morphbench.physics import World
from morphbench.shapes import load_shape

from conftest import EXAMPLES_DIR, SHAPES_DIR, chain

CHAIN_3 = load_shape(SHAPES_DIR / "chain-3.toml")
EXAMPLES = sorted(EXAMPLES_DIR.glob("*.toml"))


def link_strokes(world: World, cycles: int = 1) -> np.ndarray:
    """How much each bellows' length varied (max - min, m) over the coming cycles."""
    lengths = []

    def record(k):
        positions = world.poses()[0]
        lengths.append([np.linalg.norm(positions[f] - positions[r]) for f, r in world._links])

    world.advance(world.ticks_in(cycles * world.shape.actuator.cycle_time), record)
    lengths = np.array(lengths)
    return lengths.max(axis=0) - lengths.min(axis=0)


def test_a_no_inflate_actuator_no_longer_extends_while_the_others_do():
    with World(CHAIN_3) as world:
        world.set_phases([0.0, 0.4, 0.8])
        healthy = link_strokes(world, 2)
        world.set_damage(1, "no-inflate")
        world.advance(world.ticks_in(2.0))
        damaged = link_strokes(world, 2)
    stroke = CHAIN_3.actuator.stroke
    assert np.all(healthy > 0.5 * stroke)
    # unit 2's bellows is now a passive spring: it only gives a little under its neighbours' pushes
    assert damaged[1] < 0.25 * stroke and damaged[1] < 0.3 * healthy.min()
    assert damaged[0] > 0.5 * stroke and damaged[2] > 0.5 * stroke


def test_a_stuck_actuator_keeps_its_length():
    with World(CHAIN_3) as world:
        world.set_phases([0.0, 0.4, 0.8])
        world.advance(world.ticks_in(2.3))
        world.set_damage(0, "stuck")
        strokes = link_strokes(world, 2)
    assert strokes[0] < 0.25 * CHAIN_3.actuator.stroke and strokes[1] > 0.5 * CHAIN_3.actuator.stroke


def test_friction_field_makes_the_same_gait_faster_on_some_stretches_than_on_others():
    """A wave at fixed phases crossing a rough field: its per-step velocity varies far more than on a uniform ground."""
    def step_velocities(environment):
        shape = chain(2)
        with World(shape, environment=environment) as world:
            world.set_phases([0.0, 0.4])
            x = []
            for _ in range(30):
                world.advance(world.ticks_in(2 * shape.actuator.cycle_time))
                x.append(world.unit_poses()[0][:, 0].mean())
        return np.diff(x) * 1000 / 2

    uniform = step_velocities(EnvironmentParams())
    field = step_velocities(EnvironmentParams(
        friction_field=FrictionFieldParams(amplitude=0.4, correlation_length=0.05)))
    assert field.std() > 2 * uniform.std(), (field.std(), uniform.std())
    assert field.max() - field.min() > 2.0


def test_pump_vibration_breaks_the_forward_backward_symmetry():
    """With equal friction everywhere the 2-unit curve is antisymmetric, U(d) = -U(1 - d); when a pumping unit's
    friction drops, the mirrored points no longer cancel."""
    shape = chain(2, dummy={"friction": 0.5})

    def residual(environment):
        return np.mean([abs(sum(velocity_at(shape, [0.0, x], cycles=6, environment=environment).mean()
                                for x in (d, 1 - d))) for d in (0.05, 0.15, 0.25, 0.3, 0.35)])

    still, shaking = residual(EnvironmentParams()), residual(EnvironmentParams(vibration=0.6))
    assert shaking > 0.5 and shaking > 2 * still, (still, shaking)


def test_a_friction_drop_changes_the_landscape():
    """Less friction means less load on each bellows, so it gives way less (mu m g / k) and every gait covers more
    ground: the landscape is stretched, forward and backward alike."""
    shape = chain(2)
    before = np.array([velocity_at(shape, [0.0, d], cycles=4).mean() for d in (0.3, 0.4, 0.6)])
    after = np.array([velocity_at(shape, [0.0, d], cycles=4, environment=EnvironmentParams(friction_scale=0.4)).mean()
                      for d in (0.3, 0.4, 0.6)])
    assert np.all(np.abs(after) > np.abs(before) + 0.1), (before, after)
    assert np.all(np.abs(after[1:]) > np.abs(before[1:]) + 0.5), (before, after)  # most at the peaks, where the
    # give matters most


def test_every_event_is_recorded_at_its_step_and_acts():
    events = (FrictionEvent(step=2, scale=0.8), NoiseEvent(step=3, sigma=0.5), DamageEvent(step=3, unit=3, mode="dead"),
              ShuffleEvent(step=4, seed=5), CutEvent(step=5, link=1))
    records = run(RunConfig(shape=CHAIN_3, steps=6, seed=2, events=events, sensor=SensorParams(kind="ideal")))
    steps, units = records.steps(), records.units()
    assert steps.event[2] == "friction scale=0.8"
    assert steps.event[3] == "noise sigma=0.5; damage unit=3 mode=dead"
    assert steps.event[4] == "shuffle seed=5" and steps.event[5] == "cut link=1"
    assert (steps.event[[0, 1, 6]] == "").all()
    # noise from step 3 on; unit 3 dead from step 3 on: no measurement, a frozen phase, left out of Ubar
    living = units[units.unit != 3]
    assert np.allclose(living[living.step < 3].u_measured, living[living.step < 3].u_true)
    assert not np.allclose(living[living.step >= 3].u_measured, living[living.step >= 3].u_true)
    dead = units[(units.unit == 3) & (units.step >= 3)]
    assert dead.u_measured.isna().all() and dead.phase_tried.nunique() == 1 and not dead.accepted.any()
    assert steps.ubar[4] == pytest.approx(living[living.step == 4].u_measured.mean())
    # shuffle: every unit exactly once at a position; each keeps its phase across the shuffle
    for step, rows in units.groupby("step"):
        assert sorted(rows.position) == [1, 2, 3]
    assert not (units[units.step == 4].position.to_numpy() == [1, 2, 3]).all()
    kept = units.pivot(index="step", columns="unit", values="phase_kept")
    tried = units.pivot(index="step", columns="unit", values="phase_tried")
    assert np.all(np.abs(((tried.loc[4] - kept.loc[3]) + 0.5) % 1 - 0.5) <= 0.1 + 1e-12)
    # cut: two pieces from step 5, each scored on its own
    pieces = records.pieces()
    assert set(pieces[pieces.step < 5].piece) == {1} and set(pieces[pieces.step >= 5].piece) == {1, 2}
    for (step, piece), rows in units[units.step >= 5].groupby(["step", "piece"]):
        living_rows = rows[rows.u_measured.notna()]
        if len(living_rows):
            row = pieces[(pieces.step == step) & (pieces.piece == piece)].iloc[0]
            assert row.ubar == pytest.approx(living_rows.u_measured.mean())


def test_after_a_cut_each_piece_moves_as_its_own_robot():
    """Cut a 4-unit wave between units 2 and 3: the front pair has no body to push at its rear and stalls, the
    rear pair with the dummy still walks, so the pieces separate."""
    shape = chain(4)
    with World(shape) as world:
        world.set_phases(np.arange(4) * 0.4 % 1)
        world.advance(world.ticks_in(4.0))
        world.cut(1)
        assert world.pieces() == [[0, 1], [2, 3, 4]]
        gap_before = world.poses()[0][1, 0] - world.poses()[0][2, 0]
        world.advance(world.ticks_in(16.0))
        gap_after = world.poses()[0][1, 0] - world.poses()[0][2, 0]
    assert abs(gap_after - gap_before) > 0.005


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_every_example_runs_with_its_events_brought_forward(path):
    config = load_run_config(path)
    events = tuple(dataclasses.replace(e, step=2) for e in config.events)
    records = run(dataclasses.replace(config, steps=3, events=events))
    assert records.steps().event[2] == "; ".join(e.describe() for e in events)
    assert np.isfinite(records.steps().ubar_true).all()


@pytest.mark.parametrize("table, key", [
    ({"events": [{"step": 1, "kind": "melt"}]}, "events[0].kind"),
    ({"events": [{"step": 0, "kind": "noise", "sigma": 1.0}]}, "events[0].step"),
    ({"events": [{"step": 1, "kind": "noise", "sigma": -1.0}]}, "events[0].sigma"),
    ({"events": [{"step": 1, "kind": "friction", "scale": 0}]}, "events[0].scale"),
    ({"events": [{"step": 1, "kind": "damage", "unit": 4, "mode": "dead"}]}, "events[0].unit"),
    ({"events": [{"step": 1, "kind": "damage", "unit": 1, "mode": "broken"}]}, "events[0].mode"),
    ({"events": [{"step": 1, "kind": "damage", "unit": 1}]}, "events[0].mode"),
    ({"events": [{"step": 1, "kind": "cut", "link": 9}]}, "events[0].link"),
    ({"events": [{"step": 1, "kind": "shuffle", "seed": 1, "unit": 2}]}, "events[0].unit"),
    ({"events": {"step": 1}}, "events"),
    ({"environment": {"windy": True}}, "environment.windy"),
    ({"environment": {"noise": -0.5}}, "environment.noise"),
    ({"environment": {"friction_field": {"amplitude": 1.0}}}, "environment.friction_field.amplitude"),
    ({"environment": {"friction_field": {"colour": 1}}}, "environment.friction_field.colour"),
    ({"physics": {"preset": "turbo"}}, "physics.preset"),
    ({"learner": {"name": "nosuch"}}, "nosuch"),
    ({"steps": -1}, "steps"),
    ({"weather": 1}, "weather"),
])
def test_bad_environment_and_event_entries_give_clear_errors(table, key, tmp_path):
    full = {"shape": "chain-3.toml", **table}
    with pytest.raises(ConfigError) as error:
        run_config_from_table(full, "cfg.toml", base=SHAPES_DIR)
    assert key in str(error.value)


def test_parse_events_sorts_by_step():
    events = parse_events([{"step": 5, "kind": "noise", "sigma": 1.0}, {"step": 2, "kind": "shuffle", "seed": 0}],
                          "x", 3, 3)
    assert [e.step for e in events] == [2, 5]
