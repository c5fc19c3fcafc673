"""The dynamic planar world (morphbench.physics.dynamic): the physics invariants the quasi-static model and PyBullet
keep (docs/fidelity.md, test_quasistatic.py, test_planar.py), its friction's sticking, its conservation laws, its
timestep and its quasi-static limit. The world contract itself is tests/test_worlds.py's."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from morphbench.errors import ConfigError
from morphbench.experiment import RunConfig, run, run_batch
from morphbench.experiment.scan import motion_at, velocity_at
from morphbench.params import (
    DEFAULT_PHYSICS,
    QUASISTATIC_PHYSICS,
    EnvironmentParams,
    FrictionFieldParams,
    PhysicsParams,
    SensorParams,
)
from morphbench.physics import AUTO_DYNAMIC_UNITS, can_batch, make_world, resolve_backend
from morphbench.physics.dynamic import DynamicWorld, _stick_slip
from morphbench.shapes import load_shape, rotate, shape_from_table

from conftest import SHAPES_DIR, chain, sheet
from test_planar import trajectory as world_trajectory

DYNAMIC = dataclasses.replace(DEFAULT_PHYSICS, backend="dynamic")
CURVE = np.arange(10) / 10
"""phase differences of the 2-unit curves measured here (docs/fidelity.md's are every 0.05)."""


def grid(rows: int, columns: int, **sections):
    return shape_from_table({"assembly": {"generator": "grid", "rows": rows, "columns": columns, "dummy": True},
                             **sections}, source="test")


def trajectory(shape, phases, seconds=4.0, every=0.5, physics=DYNAMIC, environment=EnvironmentParams()):
    """Each body's (x, y, heading) every ``every`` seconds on the dynamic world: (samples, bodies, 3)."""
    return world_trajectory(DynamicWorld(shape, physics, environment), phases, seconds, every)


def ubar_curve(shape, physics=DYNAMIC, phases=CURVE, cycles=4) -> np.ndarray:
    return np.array([velocity_at(shape, [0.0, d], physics=physics, cycles=cycles).mean() for d in phases])


def rms(a, b) -> float:
    return float(np.sqrt(np.mean((np.asarray(a) - np.asarray(b)) ** 2)))


# --- the invariants of docs/fidelity.md -------------------------------------------------------------------------


@pytest.mark.parametrize("phase", [0.0, 0.3, 0.7])
def test_a_unit_and_a_dummy_alone_do_not_travel(phase):
    """One bellows only extends and contracts along the same path: no net progress (docs/fidelity.md: <= 0.1
    mm/cycle; PyBullet 0.014, the quasi-static model 0)."""
    assert abs(velocity_at(chain(1), [phase], physics=DYNAMIC, cycles=4)[0]) < 1e-3


def test_a_unit_with_no_neighbour_stays_exactly_where_it_is():
    pair = chain(1)  # the loader refuses a unit with nothing to push against: its dummy and bellows taken away
    shape = dataclasses.replace(pair, bodies=pair.bodies[:1], links=())
    assert shape.n_units == 1
    path = trajectory(shape, [0.3], seconds=4.0)
    assert np.array_equal(path[-1], path[0]) and np.array_equal(path[0, :, :2], shape.placed_positions()[:, :2])


@pytest.mark.parametrize("units", [2, 3, 7])
def test_equal_phases_go_nowhere(units):
    """All bellows in step only stretch and shrink the chain: docs/fidelity.md's target |Ubar| <= 0.2; with equal
    friction on every body the chain is its own mirror image and stays put to rounding."""
    assert abs(velocity_at(chain(units), np.zeros(units), physics=DYNAMIC, cycles=4).mean()) < 1e-3
    symmetric = chain(units, dummy={"friction": 0.5})
    assert abs(velocity_at(symmetric, np.zeros(units), physics=DYNAMIC, cycles=4).mean()) < 1e-4


def test_equal_friction_gives_an_antisymmetric_curve():
    """With equal friction everywhere the 2-unit curve at d and 1 - d are opposite (docs/fidelity.md: max
    |U(d) + U(1 - d)| <= 0.3; PyBullet 0.01): the chain run backwards in time and mirrored is the same chain."""
    shape = chain(2, dummy={"friction": 0.5})
    ahead, behind = ubar_curve(shape, phases=CURVE[1:]), ubar_curve(shape, phases=1 - CURVE[1:])
    assert ahead[3] > 2.0  # it does walk
    assert np.abs(ahead + behind).max() < 1e-3


def test_the_default_two_unit_curve_has_the_papers_shape():
    """The calibration targets of docs/fidelity.md on the dynamic model: a forward maximum of +4.5 +- 0.5 near 0.4,
    a backward minimum of -5 to -3 near 0.6."""
    curve = ubar_curve(load_shape(SHAPES_DIR / "chain-2.toml"))
    assert 4.0 <= curve[4] <= 5.0 and -5.0 <= curve[6] <= -3.0
    assert curve.argmax() == 4 and curve.argmin() == 6


# --- the plane's symmetries (as test_planar.py checks the planar model) -----------------------------------------


def mirrored(shape):
    bodies = tuple(dataclasses.replace(b, position=(b.position[0], -b.position[1], b.position[2]))
                   for b in shape.bodies)
    return dataclasses.replace(shape, bodies=bodies)


def translated(shape, dx, dy):
    bodies = tuple(dataclasses.replace(b, position=(b.position[0] + dx, b.position[1] + dy, b.position[2]))
                   for b in shape.bodies)
    return dataclasses.replace(shape, bodies=bodies)


PLANE_PHASES = [0.0, 0.4, 0.8, 0.1, 0.5, 0.7]
"""grid(2, 3): rows with different gaits, so the bodies also turn."""


def test_turning_the_assembly_turns_its_motion():
    shape = grid(2, 3)
    base = trajectory(shape, PLANE_PHASES)
    turned = trajectory(rotate(shape, 90), PLANE_PHASES)
    assert np.abs(turned[..., 0] + base[..., 1]).max() < 1e-9  # x' = -y
    assert np.abs(turned[..., 1] - base[..., 0]).max() < 1e-9  # y' = x
    assert np.abs(turned[..., 2] - base[..., 2] - np.pi / 2).max() < 1e-9
    assert np.ptp(base[..., 2]) > 1e-3  # the rows' different gaits do turn the bodies
    c, s = np.cos(np.radians(30)), np.sin(np.radians(30))
    oblique = trajectory(rotate(shape, 30), PLANE_PHASES)
    assert np.abs(oblique[..., 0] - (c * base[..., 0] - s * base[..., 1])).max() < 1e-9
    assert np.abs(oblique[..., 1] - (s * base[..., 0] + c * base[..., 1])).max() < 1e-9


def test_moving_the_assembly_moves_its_motion():
    shape = grid(2, 3)
    base = trajectory(shape, PLANE_PHASES)
    moved = trajectory(translated(shape, 0.37, -0.21), PLANE_PHASES)
    assert np.abs(moved[..., 0] - 0.37 - base[..., 0]).max() < 1e-9
    assert np.abs(moved[..., 1] + 0.21 - base[..., 1]).max() < 1e-9
    assert np.abs(moved[..., 2] - base[..., 2]).max() < 1e-9


def test_a_mirrored_assembly_moves_as_the_mirror_image():
    shape = grid(2, 2)
    phases = [0.0, 0.4, 0.2, 0.9]
    base, mirror = trajectory(shape, phases), trajectory(mirrored(shape), phases)
    assert np.abs(mirror[..., 0] - base[..., 0]).max() < 1e-9
    assert np.abs(mirror[..., 1] + base[..., 1]).max() < 1e-9
    assert np.abs(mirror[..., 2] + base[..., 2]).max() < 1e-9
    assert np.abs(base[..., 2]).max() > 1e-4  # it turns


def test_swapping_a_grids_gaits_mirrors_its_turn():
    """docs/fidelity.md's mirror: rows of grid-2x2 running the forward and backward gaits, then swapped."""
    grid2 = load_shape(SHAPES_DIR / "grid-2x2.toml")
    a = motion_at(grid2, (0.0, 0.4, 0.0, 0.6), DYNAMIC, cycles=4)
    b = motion_at(grid2, (0.0, 0.6, 0.0, 0.4), DYNAMIC, cycles=4)
    assert abs(a.turning) > 0.1
    assert a.centroid[0] == pytest.approx(b.centroid[0], abs=1e-3)
    assert a.centroid[1] == pytest.approx(-b.centroid[1], abs=1e-3)
    assert a.turning == pytest.approx(-b.turning, abs=1e-3)


# --- friction, inertia and the step ------------------------------------------------------------------------------


def test_friction_beyond_the_bellows_force_holds_every_body_exactly():
    """Static friction: a body whose springs pull less than its friction limit is at rest, not creeping."""
    shape = grid(2, 2)
    cap = shape.actuator.max_force
    weakest = min(b.friction * b.mass for b in shape.bodies) * 9.81
    assert 100 * weakest > 3 * cap  # a body has at most 3 links, its bellows' forces capped, the others unstrained
    path = trajectory(shape, [0.0, 0.4, 0.2, 0.9], environment=EnvironmentParams(friction_scale=100.0))
    assert np.array_equal(path[-1, :, :2], shape.placed_positions()[:, :2]) and not path[..., 2].any()


def test_without_friction_the_centre_of_mass_stays_and_nothing_turns_it():
    """The links' forces come in pairs whose moments cancel: with no friction the centre of mass stays put and the
    angular momentum is zero (to rounding), however the bodies move."""
    shape = grid(2, 3)
    world = DynamicWorld(shape, DYNAMIC)
    world.set_friction_scale(0.0)
    mass = world._mass[:, None]
    centre = (world.q[:, :2] * mass).sum(axis=0)
    world.set_phases(PLANE_PHASES)
    for _ in range(4):
        world.advance(world.ticks_in(0.5))
        assert np.abs((world.q[:, :2] * mass).sum(axis=0) - centre).max() < 1e-12
        momentum = (world.v[:, :2] * mass).sum(axis=0)
        moment = world.q[:, 0] * world.v[:, 1] - world.q[:, 1] * world.v[:, 0]
        spin = (world._mass * moment + world._inertia * world.v[:, 2]).sum()
        assert np.abs(momentum).max() < 1e-12 and abs(spin) < 1e-12
    assert np.abs(world.v).max() > 1e-3  # they do move


def test_almost_no_friction_is_taken_and_goes_nowhere():
    """The quasi-static model refuses friction below its range; the dynamic one runs it, and a chain that cannot push
    against the ground glides in place (docs/fidelity.md: PyBullet +0.03 mm/cycle at a friction scale of 1e-6)."""
    environment = EnvironmentParams(friction_scale=1e-6)
    shape = load_shape(SHAPES_DIR / "chain-2.toml")
    with pytest.raises(ConfigError):
        make_world(shape, QUASISTATIC_PHYSICS, environment)
    assert abs(velocity_at(shape, [0.0, 0.4], physics=DYNAMIC, cycles=4, environment=environment).mean()) < 0.1


def test_stick_slip_is_the_exact_minimiser_of_each_bodys_step():
    """The friction step: at rest within the limit; else the minimiser of the kinetic energy about the free velocity
    plus the friction's dissipation, which opposes the motion and never reverses it."""
    rng = np.random.default_rng(0)
    for _ in range(200):
        masses = np.array([1.0, 1.0, rng.uniform(0.2, 5.0)]) * rng.uniform(0.01, 1.0)
        free = rng.normal(size=3)
        impulse = np.linalg.norm(masses * free)
        limit = impulse * rng.uniform(0.0, 1.5)
        z = free.copy()
        _stick_slip(z, masses, limit)
        if limit >= impulse:
            assert not z.any()
            continue
        # the optimality condition: masses (z - free) + limit z / |z| = 0
        assert np.abs(masses * (z - free) + limit * z / np.linalg.norm(z)).max() < 1e-10 * max(1.0, impulse)
        assert np.all(z * free >= 0) and np.all(np.abs(z) <= np.abs(free))


def test_halving_the_step_changes_the_curve_little():
    """The step of PhysicsParams.dynamic_step is converged: halving it changes the 2-unit curve by < 0.05 mm/cycle
    rms (benchmarks/dynamic_fidelity.py measures 0.004 over 20 points)."""
    shape = load_shape(SHAPES_DIR / "chain-2.toml")
    half = dataclasses.replace(DYNAMIC, dynamic_step=DYNAMIC.dynamic_step / 2)
    assert rms(ubar_curve(shape), ubar_curve(shape, half)) < 0.05


def test_a_sheet_is_stable_at_the_default_step():
    """The explicit springs bound the step: a sheet with bellows along both axes (its fastest mode is the lattice's)
    stays finite and slow at the default step, with and without friction."""
    sheet = shape_from_table({"assembly": {"generator": "grid", "rows": 8, "columns": 8, "dummy": False,
                                           "actuated_axes": ["x", "y"]}}, source="test")
    phases = np.random.default_rng(1).random(sheet.n_units)
    for scale in (1.0, 0.0):
        world = DynamicWorld(sheet, DYNAMIC)
        world.set_friction_scale(scale)
        world.set_phases(phases)
        world.advance(world.ticks_in(4.0))
        assert np.isfinite(world.q).all() and np.abs(world.v[:, :2]).max() < 0.3, scale


def slowed(shape, factor: float):
    """``shape`` with its pumps ``factor`` times slower (cycle time and pressure time constants): the quasi-static
    model's curve is the same, and inertia's share shrinks as 1 / factor^2 (docs/fidelity.md, "Friction against
    inertia")."""
    a = shape.actuator
    return dataclasses.replace(shape, actuator=dataclasses.replace(
        a, cycle_time=a.cycle_time * factor, tau_inflate=a.tau_inflate * factor, tau_vent=a.tau_vent * factor))


def test_with_friction_outweighing_inertia_the_curve_becomes_the_quasistatic_one():
    shape = load_shape(SHAPES_DIR / "chain-2.toml")
    gaps = []
    for factor in (1.0, 4.0):
        slow = slowed(shape, factor)
        gaps.append(rms(ubar_curve(slow), ubar_curve(slow, QUASISTATIC_PHYSICS)))
    assert gaps[0] < 0.2  # the target at the defaults
    assert gaps[1] < 0.05 and gaps[1] < gaps[0] / 3


def test_the_friction_field_and_vibration_change_the_motion_and_callbacks_do_not():
    """A friction field under the bodies and the pumps' vibration change the motion; reading poses every few ticks
    (advance_sampled, an observer's on_tick) changes nothing: the field is read on the advance's own tick grid."""
    shape = load_shape(SHAPES_DIR / "grid-2x2.toml")
    rough = EnvironmentParams(vibration=0.8, friction_field=FrictionFieldParams(amplitude=0.4, two_d=True))
    phases, ticks = [0.0, 0.4, 0.1, 0.5], 500

    def end(environment, how):
        with make_world(shape, DYNAMIC, environment) as world:
            world.set_phases(phases)
            if how == "sampled":
                world.advance_sampled(ticks, 7)
            elif how == "observed":
                world.advance(ticks, on_tick=lambda k: None, every=5)
            else:
                world.advance(ticks)
            return world.poses()[0]

    plain, shaken = end(EnvironmentParams(), "whole"), end(rough, "whole")
    assert np.abs(plain - shaken).max() > 1e-4
    assert not np.array_equal(end(EnvironmentParams(vibration=0.8), "whole"), plain)
    assert np.array_equal(end(rough, "sampled"), shaken) and np.array_equal(end(rough, "observed"), shaken)


# --- the backend among the others --------------------------------------------------------------------------------


def test_auto_takes_the_backend_for_sheets_beyond_the_library_and_a_name_anywhere_but_stacks():
    chain2, grid2 = load_shape(SHAPES_DIR / "chain-2.toml"), load_shape(SHAPES_DIR / "grid-2x2.toml")
    stack, library_largest = load_shape(SHAPES_DIR / "stack-2x2x2.toml"), load_shape(SHAPES_DIR / "sheet-10x10.toml")
    assert resolve_backend(chain2, DYNAMIC) == resolve_backend(grid2, DYNAMIC) == "dynamic"
    assert resolve_backend(chain2, DEFAULT_PHYSICS) == "quasistatic"  # 'auto' is what it was up to 100 units
    assert resolve_backend(grid2, DEFAULT_PHYSICS) == resolve_backend(library_largest, DEFAULT_PHYSICS) == "planar"
    assert library_largest.n_units == AUTO_DYNAMIC_UNITS
    assert resolve_backend(sheet(10, 11), DEFAULT_PHYSICS) == "dynamic"  # beyond: the linear model
    assert resolve_backend(chain(AUTO_DYNAMIC_UNITS + 1), DEFAULT_PHYSICS) == "quasistatic"  # a chain keeps its own
    quasistatic = PhysicsParams(backend="quasistatic")
    assert resolve_backend(sheet(10, 11), quasistatic) == "planar"  # named, the exact solver at any size
    assert resolve_backend(sheet(10, 11), DEFAULT_PHYSICS, scene=True) == "pybullet"
    assert resolve_backend(stack, DEFAULT_PHYSICS) == "pybullet"
    with pytest.raises(ConfigError, match="dynamic"):
        resolve_backend(stack, DYNAMIC)
    with pytest.raises(ConfigError, match="dynamic"):
        make_world(stack, DYNAMIC)
    assert PhysicsParams(backend="dynamic").backend == "dynamic"


def test_a_batch_of_copies_moves_each_as_it_moves_alone():
    """Copies of the assembly are disjoint pieces of one world: each moves bit for bit as alone (tests/test_worlds.py
    checks the records of a batch of two runs)."""
    shape = load_shape(SHAPES_DIR / "grid-2x2.toml")
    assert can_batch(shape, DYNAMIC)
    phases = np.random.default_rng(2).random((3, shape.n_units))
    with make_world(shape, DYNAMIC, copies=3) as batch:
        batch.set_phases(np.arange(3), phases)
        batch.worlds[1].set_damage(1, "open")
        batch.worlds[2].cut(2)
        batch.advance(240)
        together = batch.body_poses()
    for index in range(3):
        with make_world(shape, DYNAMIC) as world:
            world.set_phases(phases[index])
            if index == 1:
                world.set_damage(1, "open")
            if index == 2:
                world.cut(2)
            world.advance(240)
            assert np.array_equal(world.poses()[0], together[0][index])
            assert np.array_equal(world.poses()[1], together[1][index])


def test_units_on_clocks_of_their_own_run_and_repeat():
    """Per-unit clock rates (set_clock_rates): a unit on a slower clock changes the motion; a run with drifting
    clocks goes through the run loop and repeats."""
    shape = load_shape(SHAPES_DIR / "chain-3.toml")
    moved = []
    for errors in ((0.0, 0.0, 0.0), (0.0, 0.03, 0.0)):
        with make_world(shape, DYNAMIC) as world:
            world.set_phases([0.0, 0.4, 0.8])
            world.set_clock_rates(np.array(errors))
            world.advance(world.ticks_in(8.0))
            moved.append(world.poses()[0])
    assert not np.array_equal(*moved)
    config = RunConfig(shape=shape, physics=DYNAMIC, steps=3, sensor=SensorParams(kind="ideal"),
                       environment=EnvironmentParams(clock_drift=0.02, clock_offset=0.3))
    first, second = run(config), run(config)
    assert first.steps().equals(second.steps()) and first.units().equals(second.units())
    (batched,) = run_batch([config])
    assert batched.steps().equals(first.steps())
