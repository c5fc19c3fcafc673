"""The planar solver over seeds: every library shape whose default physics is the planar world runs short learning
runs for many seeds with every tick solved, and the runs that once broke it run (issue 21: a Newton system that
overflowed for a body that barely slides gave a ZeroDivisionError or NaN poses on about 1 run in 20)."""

import dataclasses
import importlib

import numpy as np
import pytest

from morphbench.experiment import RunConfig, run
from morphbench.learning import load_learner_class, make_controller
from morphbench.params import DEFAULT_PHYSICS, SensorParams
from morphbench.physics import PlanarWorld, make_world
from morphbench.shapes import load_shape, shape_from_table

from conftest import SHAPES_DIR

IDEAL = SensorParams(kind="ideal")
SEEDS = sorted(np.random.default_rng(21).choice(1000, size=12, replace=False).tolist())
"""random seeds, the same every time (a failure names its seed); on the solver before the fix, 3 of these 84 runs
of the 7 smaller planar shapes failed (grid-3x3 and grid-3x3-xy at seed 293, t-5 at 342)."""
LARGE = 50  # bodies: a shape this large gets one short run (a sheet's tick costs 50 times a grid's)


def planar_library() -> list[str]:
    names = []
    for path in sorted(SHAPES_DIR.glob("*.toml")):
        with make_world(load_shape(path), DEFAULT_PHYSICS) as world:
            if isinstance(world, PlanarWorld):
                names.append(path.stem)
    return names


@pytest.fixture
def worlds(monkeypatch):
    """Every world the runs of a test build (experiment.run closes them; their solver counters stay)."""
    module = importlib.import_module("morphbench.experiment.driver")
    built = []
    make_world = module.make_world

    def keep(*args, **kwargs):
        batch = make_world(*args, **kwargs)
        built.extend(batch.worlds)
        return batch

    monkeypatch.setattr(module, "make_world", keep)
    return built


def grid(rows: int, columns: int, **assembly):
    table = {"generator": "grid", "rows": rows, "columns": columns, "dummy": True, **assembly}
    return shape_from_table({"assembly": table}, source=f"grid {rows} x {columns}")


@pytest.mark.parametrize("name", planar_library())
def test_every_planar_library_shape_runs_for_random_seeds(name, worlds):
    shape = load_shape(SHAPES_DIR / f"{name}.toml")
    large = len(shape.bodies) >= LARGE
    for seed in SEEDS[:1] if large else SEEDS:
        records = run(RunConfig(shape=shape, seed=seed, steps=1 if large else 5, sensor=IDEAL))
        assert np.isfinite(records.steps().x_m).all(), f"{name} seed {seed}"
        assert worlds[-1].unconverged_ticks == 0, f"{name} seed {seed}"
    assert isinstance(worlds[-1], PlanarWorld)


@pytest.mark.parametrize("shape, seed", [
    (load_shape(SHAPES_DIR / "grid-3x3-xy.toml"), 9),  # was a ZeroDivisionError in the Cholesky factorisation
    (load_shape(SHAPES_DIR / "grid-3x3.toml"), 6),  # was a NaN pose taken for a converged solve
    (grid(10, 1), 1),
    (grid(2, 2, actuated_axes=["y"]), 0),
], ids=["grid-3x3-xy seed 9", "grid-3x3 seed 6", "grid 10 x 1 seed 1", "grid 2 x 2 along y seed 0"])
def test_the_runs_that_broke_the_solver_run(shape, seed, worlds):
    records = run(RunConfig(shape=shape, seed=seed, steps=5, sensor=IDEAL))
    assert len(records.steps()) == 6 and np.isfinite(records.units()[["x_m", "y_m"]].to_numpy()).all()
    assert worlds[-1].unconverged_ticks == 0


def test_a_grid_of_200_rows_warms_up():
    """The 200 x 1 grid's run at seed 0 got NaN poses at tick 49 of its warm-up: those ticks, at the run's phases
    (a whole run of 400 bodies takes minutes)."""
    shape = grid(200, 1)
    config = RunConfig(shape=shape, seed=0, sensor=IDEAL)
    phases = make_controller(load_learner_class(config.learner), config.learner_params, config.seed,
                             shape.n_units).initial()
    # the planar solver's case, at the default ticks ('auto' takes a grid of 200 units to the dynamic model)
    with make_world(shape, dataclasses.replace(config.physics, backend="quasistatic")) as world:
        world.set_phases(phases)
        world.advance(60)
        assert np.isfinite(world.q).all() and world.unconverged_ticks == 0
        assert np.abs(world.q[:, :2] - world._rest[:, :2]).max() > 1e-5  # the bellows did push


def test_ticks_with_frictionless_bodies_converge():
    """Half the bodies frictionless and rest lengths jumping by up to 10 mm each tick: the Newton steps and the
    proximal gradient steps used to undo each other and most ticks never converged; the envelope stops that."""
    for name in ("grid-2x2", "grid-3x3", "t-5"):
        world = make_world(load_shape(SHAPES_DIR / f"{name}.toml"), DEFAULT_PHYSICS)
        rng = np.random.default_rng(0)
        lengths = world._empty_pitch + 0.01 * rng.random((50, len(world._empty_pitch)))
        limits = np.zeros((50, len(world.q)))
        limits[:, ::2] = 0.5
        world.relax_ticks(lengths, limits)
        assert np.isfinite(world.q).all() and world.unconverged_ticks == 0, name
