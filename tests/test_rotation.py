"""Frame invariance: an assembly turned on the ground (``[transform] rotate``) moves as the same assembly, turned."""

import numpy as np
import pytest

from morphbench.errors import ConfigError
from morphbench.experiment import motion_at
from morphbench.params import FAST_PHYSICS, QUASISTATIC_PHYSICS
from morphbench.shapes import load_shape, rotate, shape_from_table

from conftest import SHAPES_DIR as SHAPES

CYCLES = 8


def grid(rows: int, columns: int, axes=("x",)):
    return shape_from_table({"assembly": {"generator": "grid", "rows": rows, "columns": columns, "dummy": True,
                                          "actuated_axes": list(axes)}}, source="test")


def turned(v, degrees):
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def test_the_rotate_key_turns_the_placed_assembly_only(tmp_path):
    text = (SHAPES / "chain-3.toml").read_text() + "\n[transform]\nrotate = 90\n"
    (tmp_path / "turned.toml").write_text(text)
    shape, plain = load_shape(tmp_path / "turned.toml"), load_shape(SHAPES / "chain-3.toml")
    assert shape.yaw == pytest.approx(np.pi / 2)
    assert shape.bodies == plain.bodies and shape.links == plain.links and shape.heading == plain.heading
    assert np.abs(shape.placed_positions()[:, :2] - [turned(p, 90) for p in plain.placed_positions()]).max() < 1e-12


@pytest.mark.parametrize("value", ['"quarter"', "400", "true", "nan"])
def test_a_bad_rotation_is_refused_with_the_key(tmp_path, value):
    (tmp_path / "bad.toml").write_text(f'[assembly]\ngenerator = "chain"\nunits = 2\n[transform]\nrotate = {value}\n')
    with pytest.raises(ConfigError) as info:
        load_shape(tmp_path / "bad.toml")
    assert info.value.key == "transform.rotate" and "degrees in [-360, 360]" in str(info.value)


@pytest.mark.parametrize("degrees", [90, -37])
def test_quasistatic_worlds_are_frame_invariant(degrees):
    """Exact on the quasi-static models: the chain solver (chain-3) and the planar one (a grid that pushes sideways
    and turns)."""
    for shape, phases in ((load_shape(SHAPES / "chain-3.toml"), [0.0, 0.35, 0.7]),
                          (grid(2, 2, ("x", "y")), [0.0, 0.4, 0.1, 0.7])):
        base = motion_at(shape, phases, QUASISTATIC_PHYSICS, cycles=CYCLES)
        other = motion_at(rotate(shape, degrees), phases, QUASISTATIC_PHYSICS, cycles=CYCLES)
        assert np.abs(base.units).max() > 0.3  # mm/cycle: it does move
        assert np.abs(other.units - base.units).max() < 1e-6
        assert np.abs(other.centroid - turned(base.centroid, degrees)).max() < 1e-6
        assert other.turning == pytest.approx(base.turning, abs=1e-6)


@pytest.mark.parametrize("path, phases", [("chain-2.toml", [0.0, 0.4]), ("grid-2x2.toml", [0.0, 0.4, 0.0, 0.4])])
def test_pybullet_is_frame_invariant_within_five_percent(path, phases):
    """PyBullet's contacts and friction are not exactly symmetric: a quarter turn keeps the units' speed along
    their own axes within 5% and turns the assembly's path with it."""
    shape = load_shape(SHAPES / path)
    base = motion_at(shape, phases, FAST_PHYSICS, cycles=CYCLES)
    other = motion_at(rotate(shape, 90), phases, FAST_PHYSICS, cycles=CYCLES)
    assert base.units.mean() > 1.0
    assert other.units.mean() == pytest.approx(base.units.mean(), rel=0.05)
    assert np.linalg.norm(other.centroid - turned(base.centroid, 90)) < 0.05 * np.linalg.norm(base.centroid)


def test_a_run_of_a_turned_shape_scores_the_same():
    """Through the run loop, records and all, the turned chain learns as the plain one (quasi-static, ideal sensor:
    an optical sensor sees another patch of ground texture)."""
    from morphbench.experiment import RunConfig, run
    from morphbench.params import SensorParams

    shape, ideal = load_shape(SHAPES / "chain-3.toml"), SensorParams(kind="ideal")
    plain = run(RunConfig(shape=shape, physics=QUASISTATIC_PHYSICS, sensor=ideal, steps=6, seed=3)).units()
    other = run(RunConfig(shape=rotate(shape, 90), physics=QUASISTATIC_PHYSICS, sensor=ideal, steps=6, seed=3)).units()
    assert np.abs(other.u_true - plain.u_true).max() < 1e-6
    assert (other.phase_kept == plain.phase_kept).all()
    assert np.abs(other.heading_rad - np.pi / 2).max() < 1e-9
    assert np.abs(other.y_m - plain.x_m).max() < 1e-9
