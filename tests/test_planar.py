"""The planar quasi-static world against the exact chain solver, an independent energy, and the plane's symmetries."""

import dataclasses

import numpy as np
import pytest

from morphbench.params import QUASISTATIC_PHYSICS
from morphbench.physics import PlanarWorld, QuasiStaticWorld, make_world
from morphbench.physics.bellows import GRAVITY
from morphbench.shapes import load_shape, rotate, shape_from_table

from conftest import SHAPES_DIR


def grid(rows: int, columns: int, **sections):
    return shape_from_table({"assembly": {"generator": "grid", "rows": rows, "columns": columns, "dummy": True},
                             **sections}, source="test")


def chain(units: int):
    return grid(1, units)


def trajectory(world, phases, seconds=4.0, every=0.5):
    """Each body's (x, y, heading) every ``every`` seconds: (samples, bodies, 3)."""
    world.set_phases(phases)
    out = []
    for _ in range(round(seconds / every)):
        world.advance(world.ticks_in(every))
        out.append(world.q.copy())
    return np.array(out)


@pytest.mark.parametrize("units", [1, 2, 3, 7])
def test_a_chain_moves_as_the_exact_chain_solver_says(units):
    """On a chain the plane adds nothing: no sideways motion, no turning, and the same positions as the exact
    one-dimensional solve (which is tested against hand cases in test_quasistatic.py)."""
    shape = chain(units)
    phases = np.random.default_rng(units).random(units)
    planar, line = PlanarWorld(shape, QUASISTATIC_PHYSICS), QuasiStaticWorld(shape, QUASISTATIC_PHYSICS)
    for world in (planar, line):
        world.set_phases(phases)
    for _ in range(6):
        planar.advance(planar.ticks_in(0.5))
        line.advance(line.ticks_in(0.5))
        assert np.abs(planar.poses()[0] - line.poses()[0]).max() < 1e-9
    assert np.abs(planar.q[:, 2]).max() < 1e-12
    assert planar.unconverged_ticks == 0


def mirrored(shape):
    bodies = tuple(dataclasses.replace(b, position=(b.position[0], -b.position[1], b.position[2]))
                   for b in shape.bodies)
    return dataclasses.replace(shape, bodies=bodies)


def test_turning_the_assembly_turns_its_motion():
    shape = grid(2, 3)
    phases = [0.0, 0.4, 0.8, 0.1, 0.5, 0.7]
    base = trajectory(PlanarWorld(shape, QUASISTATIC_PHYSICS), phases)
    turned = trajectory(PlanarWorld(rotate(shape, 90), QUASISTATIC_PHYSICS), phases)
    assert np.abs(turned[..., 0] + base[..., 1]).max() < 1e-9  # x' = -y
    assert np.abs(turned[..., 1] - base[..., 0]).max() < 1e-9  # y' = x
    assert np.abs(turned[..., 2] - base[..., 2] - np.pi / 2).max() < 1e-9
    assert np.ptp(base[..., 2]) > 1e-3  # the rows' different gaits do turn the bodies


def test_a_mirrored_assembly_moves_as_the_mirror_image():
    shape = grid(2, 2)
    phases = [0.0, 0.4, 0.2, 0.9]
    base = trajectory(PlanarWorld(shape, QUASISTATIC_PHYSICS), phases)
    mirror = trajectory(PlanarWorld(mirrored(shape), QUASISTATIC_PHYSICS), phases)
    assert np.abs(mirror[..., 0] - base[..., 0]).max() < 1e-9
    assert np.abs(mirror[..., 1] + base[..., 1]).max() < 1e-9
    assert np.abs(mirror[..., 2] + base[..., 2]).max() < 1e-9


def test_rows_with_the_same_gait_stay_together():
    world = PlanarWorld(grid(2, 3), QUASISTATIC_PHYSICS)
    path = trajectory(world, [0.0, 0.4, 0.8] * 2, seconds=10.0)
    rows = path[:, :4], path[:, 4:]
    assert np.abs(rows[0][..., 0] - rows[1][..., 0]).max() < 1e-9
    assert np.abs(path[..., 2]).max() < 1e-9
    assert rows[0][-1, 0, 0] - world._rest[0, 0] > 5e-3  # and they crawled


def energy(shape, q, u, lengths, limits):
    """The tick's incremental energy with exact (not linearised) strains, written independently of the solver: each
    link's frame is the mean of its bodies' frames, built from rotation matrices."""
    actuator = shape.actuator
    k, k_s, k_b, cap = actuator.stiffness, actuator.shear_stiffness, actuator.bending_stiffness, actuator.max_force
    new = q + u.reshape(-1, 3)
    total = 0.0
    for link, length in zip(shape.links, lengths):
        rest = np.subtract(shape.bodies[link.front].position, shape.bodies[link.rear].position)[:2]
        theta = (new[link.front, 2] + new[link.rear, 2]) / 2
        frame = np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])
        along, across = frame.T @ (new[link.front, :2] - new[link.rear, :2]) @ np.array(
            [[rest[0], -rest[1]], [rest[1], rest[0]]]) / np.linalg.norm(rest)
        z = along - length
        total += 0.5 * k * z * z if abs(k * z) <= cap else cap * abs(z) - cap * cap / (2 * k)
        total += 0.5 * k_s * across ** 2 + 0.5 * k_b * (new[link.front, 2] - new[link.rear, 2]) ** 2
    rho = np.array([world_rho(b) for b in shape.bodies])
    d = u.reshape(-1, 3)
    return total + np.sum(limits * np.sqrt(d[:, 0] ** 2 + d[:, 1] ** 2 + (rho * d[:, 2]) ** 2))


def world_rho(body):
    """The mean distance of the footprint from its centre, by a finer rule than the world's."""
    x = (np.arange(400) + 0.5) / 400 - 0.5
    xx, yy = np.meshgrid(x * body.size[0], x * body.size[1])
    return np.mean(np.hypot(xx, yy))


TOLERANCE = 1e-12


def test_each_tick_minimises_the_incremental_energy():
    """No small change of the solved increments lowers an independently written energy: not a random perturbation
    of every body, and not stopping any one body. (The solver linearises the strains over a tick, so the exact
    energy may differ by far less than TOLERANCE, J; a wrong stiffness or friction radius shows up well above it.)"""
    shape = grid(2, 2)
    world = PlanarWorld(shape, QUASISTATIC_PHYSICS)
    world.set_phases([0.0, 0.3, 0.6, 0.1])
    rng = np.random.default_rng(0)
    checked = 0
    for _ in range(40):
        world.advance(world.ticks_in(0.05))
        lengths = world._rest_lengths(world._pressures(world.time, 1, True))[0]
        limits = np.array([b.friction * b.mass * GRAVITY for b in shape.bodies])
        before = world.q.copy()
        world.relax_ticks(lengths[None, :], limits[None, :])
        u = (world.q - before).ravel()
        best = energy(shape, before, u, lengths, limits)
        rho = world._rho
        for _ in range(20):
            delta = rng.normal(size=(len(shape.bodies), 3)) * 1e-6
            delta[:, 2] /= rho
            assert energy(shape, before, u + delta.ravel(), lengths, limits) > best - TOLERANCE
        for i in range(len(shape.bodies)):
            stopped = u.copy().reshape(-1, 3)
            if np.any(stopped[i]):
                stopped[i] = 0.0
                assert energy(shape, before, stopped.ravel(), lengths, limits) > best - TOLERANCE
                checked += 1
    assert checked > 20 and world.unconverged_ticks == 0


def test_halving_the_tick_changes_a_grid_little():
    shape = grid(2, 3)
    phases = [0.0, 0.4, 0.8, 0.1, 0.5, 0.7]
    fine = dataclasses.replace(QUASISTATIC_PHYSICS, timestep=QUASISTATIC_PHYSICS.timestep / 2)
    a = trajectory(PlanarWorld(shape, QUASISTATIC_PHYSICS), phases, seconds=8.0)
    b = trajectory(PlanarWorld(shape, fine), phases, seconds=8.0)
    assert np.abs(a[..., :2] - b[..., :2]).max() < 2e-4  # m, over 4 cycles in which the grid crawls centimetres
    assert np.abs(a[-1, :, 0] - a[0, :, 0]).max() > 5e-3


def test_every_shape_in_one_layer_runs_on_the_quasistatic_default():
    for name in ("grid-3x3", "custom-irregular", "grid-2x4-split"):
        world = make_world(load_shape(SHAPES_DIR / f"{name}.toml"), QUASISTATIC_PHYSICS)
        assert isinstance(world, (PlanarWorld, QuasiStaticWorld))
        world.set_phases(np.linspace(0, 0.9, world.shape.n_units))
        world.advance(world.ticks_in(4.0))
        assert np.all(np.isfinite(world.poses()[0]))


def centroid_and_heading(world, phases, cycles=10):
    """The assembly's centroid displacement (m) and mean heading change (rad) over ``cycles`` cycles."""
    world.set_phases(phases)
    start = world.q.copy()
    world.advance(world.ticks_in(cycles * world.shape.actuator.cycle_time))
    return (world.q[:, :2] - start[:, :2]).mean(axis=0), (world.q[:, 2] - start[:, 2]).mean()


def test_bellows_along_y_push_a_grid_sideways():
    """Each column is a chain along y (front row at +y) whose bellows run the forward gait of a chain: the grid
    crawls towards +y, and its two identical columns keep it from drifting along x or turning."""
    shape = grid(3, 2, assembly={"generator": "grid", "rows": 3, "columns": 2, "dummy": False,
                                 "actuated_axes": ["y"]})
    world = PlanarWorld(shape, QUASISTATIC_PHYSICS)
    # rows 1 and 2 drive the bellows to the row behind; row 3 drives none
    (dx, dy), turn = centroid_and_heading(world, [0.0, 0.0, 0.4, 0.4, 0.0, 0.0])
    assert dy / 10 > 1e-3  # more than 1 mm/cycle sideways
    assert abs(dx) < 1e-9 and abs(turn) < 1e-9


def test_a_grid_whose_sides_disagree_turns_towards_the_slower_side():
    """Row 1 (the left side, +y) runs the chain's forward gait, row 2 (the right side) its backward gait: the left
    side pushes ahead, so the grid turns clockwise (heading decreases); swapping the gaits turns it back."""
    shape = grid(2, 2)
    forward, backward = [0.0, 0.4], [0.0, 0.6]
    (_, _), left = centroid_and_heading(PlanarWorld(shape, QUASISTATIC_PHYSICS), forward + backward)
    (_, _), right = centroid_and_heading(PlanarWorld(shape, QUASISTATIC_PHYSICS), backward + forward)
    assert left < -0.02 and right > 0.02  # rad over 10 cycles
    assert left == pytest.approx(-right, rel=1e-6)  # mirrored gaits, mirrored turns


def test_a_run_records_each_units_heading():
    from morphbench.experiment import RunConfig, run

    shape = grid(2, 2)
    records = run(RunConfig(shape=shape, physics=QUASISTATIC_PHYSICS, steps=4, seed=1))
    units = records.units()
    assert np.all(np.isfinite(units.heading_rad)) and np.all(np.abs(units.heading_rad) <= np.pi)
    assert units.heading_rad.abs().max() > 0  # the rows' random phases turned it


def row_lead(shape, physics, phases, cycles=10):
    """m, how far the first half of the bodies (row 1) has moved ahead of the rest (row 2) along the grid's heading
    (the grid turns: the rows' offset is measured in its own frame), from rest."""
    with make_world(shape, physics) as world:
        start, _ = world.poses()
        world.set_phases(phases)
        world.advance(world.ticks_in(cycles * shape.actuator.cycle_time))
        end, turn = world.poses()
    heading = np.mean(2 * np.arctan2(turn[:, 2], turn[:, 3]))
    along = (end - end.mean(axis=0))[:, :2] @ [np.cos(heading), np.sin(heading)]
    moved = along - (start[:, 0] - start[:, 0].mean())
    half = len(shape.bodies) // 2
    return float(moved[:half].mean() - moved[half:].mean())


def test_a_loop_deforms_as_far_as_its_rungs_shear_stiffness_allows():
    """Rows joined by soft rungs, running a forward and a backward gait: they stay together but offset, the rungs'
    shear force carrying the drag. Quasi-static estimate: that force depends on the gaits only, not on the rungs'
    stiffness (so the offset falls as 1 / k_s), and it cannot exceed a row's friction limit. PyBullet agrees."""
    from morphbench.params import FAST_PHYSICS

    gaits = [0.0, 0.4, 0.0, 0.6]
    forces = []
    for k in (30.0, 100.0):
        shape = grid(2, 2, actuator={"shear_stiffness": k})
        rungs = sum(1 for link in shape.links if link.unit is None)
        lead = row_lead(shape, QUASISTATIC_PHYSICS, gaits)
        assert lead > 0  # the forward row leads
        forces.append(rungs * k * lead)
    row_friction = sum(b.friction * b.mass * GRAVITY for b in shape.bodies[:3])
    assert forces[1] == pytest.approx(forces[0], rel=0.1)
    assert 0.02 * row_friction < forces[0] < row_friction
    assert row_lead(shape, FAST_PHYSICS, gaits) == pytest.approx(row_lead(shape, QUASISTATIC_PHYSICS, gaits), rel=0.15)
