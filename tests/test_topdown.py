"""The top view (render.topdown) and the phase maps: rectangles on the right pixels, the right colours on the right
bodies, a cyclic phase map, the commands that write them, and the one-line refusals."""

import math

import cv2
import numpy as np
import pandas as pd
import pytest

from morphbench.cli import main
from morphbench.errors import ConfigError
from morphbench.experiment.records import RunRecords
from morphbench.params import VideoParams
from morphbench.render import open_recorder
from morphbench.render.checks import AUTO_TOP_UNITS, resolve_view
from morphbench.render.recorder import FOV
from morphbench.render.topdown import COLOUR_LEVELS, TopDownRecorder, TopView, fill_rectangles, headings_of
from morphbench.shapes import load_shape, shape_from_table
from morphbench.shapes.colours import DAMAGED_RGBA, DUMMY_RGBA, phase_rgb, pressure_rgb

from conftest import SHAPES_DIR

RED = np.array([[255, 0, 0]], np.uint8)
GRID_2X2 = load_shape(SHAPES_DIR / "grid-2x2.toml")
STACK = load_shape(SHAPES_DIR / "stack-2x2x2.toml")


def covered(frame: np.ndarray) -> set[tuple[int, int]]:
    """(row, column) of every pixel that is not black."""
    return set(zip(*np.nonzero(frame.any(axis=2))))


def test_a_rectangle_covers_the_pixels_under_it_and_a_quarter_turn_turns_it():
    # 1 cm pixels, the frame's top left corner at (0, 0.2) m: pixel (i, j) is centred on x = j + 0.5 cm,
    # y = 19.5 - i cm. A 6 x 4 cm body centred on (10, 10) cm spans x 7..13 cm and y 8..12 cm.
    view = TopView(left=0.0, top=0.2, pixel=0.01, width=40, height=20)
    frame = np.zeros((20, 40, 3), np.uint8)
    fill_rectangles(frame, view, np.array([[0.10, 0.10]]), np.array([[0.03, 0.02]]), np.array([[1.0, 0.0]]), RED)
    assert covered(frame) == {(i, j) for i in range(8, 12) for j in range(7, 13)}
    assert (frame[8:12, 7:13] == RED).all()
    frame[:] = 0
    turned = headings_of(np.array([[0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4)]]))  # 90 deg yaw
    np.testing.assert_allclose(turned, [[0.0, 1.0]], atol=1e-12)
    fill_rectangles(frame, view, np.array([[0.10, 0.10]]), np.array([[0.03, 0.02]]), turned, RED)
    assert covered(frame) == {(i, j) for i in range(7, 13) for j in range(8, 12)}  # 4 wide, 6 high


def test_a_turned_rectangle_covers_exactly_the_pixel_centres_inside_it():
    view = TopView(left=0.0, top=0.3, pixel=0.01, width=30, height=30)
    frame = np.zeros((30, 30, 3), np.uint8)
    angle = math.radians(30)
    axis = np.array([[math.cos(angle), math.sin(angle)]])
    fill_rectangles(frame, view, np.array([[0.15, 0.15]]), np.array([[0.08, 0.03]]), axis, RED)
    x, y = np.meshgrid(view.column_x() - 0.15, view.row_y() - 0.15)
    inside = (np.abs(x * axis[0, 0] + y * axis[0, 1]) <= 0.08) & (np.abs(y * axis[0, 0] - x * axis[0, 1]) <= 0.03)
    assert covered(frame) == set(zip(*np.nonzero(inside)))
    assert 0.9 * 96 < len(covered(frame)) < 1.1 * 96  # 16 x 6 cm at 1 cm per pixel


def test_rectangles_off_the_frame_are_clipped_and_later_ones_drawn_over_earlier_ones():
    view = TopView(left=0.0, top=0.1, pixel=0.01, width=10, height=10)
    frame = np.zeros((10, 10, 3), np.uint8)
    centres = np.array([[0.0, 0.05], [0.05, 0.05], [0.06, 0.05], [5.0, 5.0]])  # half off, inside, over it, far away
    half = np.tile([[0.02, 0.02]], (4, 1))
    colours = np.array([[255, 0, 0], [0, 255, 0], [0, 0, 255], [255, 255, 255]], np.uint8)
    fill_rectangles(frame, view, centres, half, np.tile([[1.0, 0.0]], (4, 1)), colours)
    assert (frame[4, 0] == colours[0]).all() and (frame[4, 1] == colours[0]).all() and not frame[4, 2].any()
    assert (frame[4, 3] == colours[1]).all()
    assert (frame[4, 4:8] == colours[2]).all()  # the third rectangle over the second where they overlap
    assert not (frame == 255).all(axis=2).any()


def test_the_phase_colour_map_is_cyclic_and_tells_phases_apart():
    np.testing.assert_array_equal(phase_rgb(0.0), phase_rgb(1.0))
    np.testing.assert_array_equal(phase_rgb(0.25), phase_rgb(-0.75))
    assert np.abs(phase_rgb(0.999) - phase_rgb(0.0)).max() < 0.01  # continuous across 1 -> 0
    ring = phase_rgb(np.arange(12) / 12)
    gaps = np.linalg.norm(ring[:, None] - ring[None, :], axis=2)
    assert gaps[~np.eye(12, dtype=bool)].min() > 0.1  # twelve phases, twelve colours
    assert ring.min() >= 0.1 and ring.max() <= 0.96  # never black or white


class FakeWorld:
    """A world that stands still where it is put: what a recorder reads of one."""

    def __init__(self, shape, positions, orientations=None):
        self.shape, self.time = shape, 0.0
        self.positions = np.asarray(positions, dtype=float)
        self.orientations = (np.tile([0.0, 0.0, 0.0, 1.0], (len(self.positions), 1)) if orientations is None
                             else np.asarray(orientations, dtype=float))
        self.link_units = np.array([-1 if link.unit is None else shape.units.index(link.unit) for link in shape.links])
        self.pressure = np.zeros(len(shape.links))
        self.phases = np.zeros(shape.n_units)
        self.damage = [""] * shape.n_units

    def poses(self):
        return self.positions, self.orientations


def centre_pixel(recorder: TopDownRecorder, world: FakeWorld, body: int) -> tuple[int, int]:
    """(row, column) of the pixel under a body's centre, for a recorder with a fixed ``distance`` and no follow."""
    params = recorder.params
    pixel = 2 * params.distance * math.tan(math.radians(FOV) / 2) / params.height
    centre = world.positions.mean(axis=0)
    view = TopView.centred(centre[0], centre[1], pixel, params.width, params.height)
    x, y = world.positions[body, :2]
    return int((view.top - y) / pixel), int((x - view.left) / pixel)


@pytest.mark.parametrize("colour", ["pressure", "phase"])
def test_top_view_frames_colour_each_body_at_its_place(tmp_path, colour):
    world = FakeWorld(GRID_2X2, GRID_2X2.placed_positions())
    params = VideoParams(width=160, height=120, view="top", colour=colour, distance=0.3, follow=False, overlay=False)
    units = list(GRID_2X2.units)
    with TopDownRecorder(world, tmp_path / "v.mp4", params) as recorder:
        world.pressure[:] = [0.0 if k < 0 else [0.0, 0.5, 1.0, 0.25][k] for k in world.link_units]
        kept = np.array([0.0, 0.25, 0.5, 0.999])
        recorder.set_status(kept=kept)
        world.damage[1] = "dead"
        frame = recorder.render()
        for k, body in enumerate(units):
            if k == 1:
                expected = np.array(DAMAGED_RGBA[:3])  # dead: black, whatever its pressure or phase
            elif colour == "phase":
                expected = phase_rgb(round(kept[k] * COLOUR_LEVELS) % COLOUR_LEVELS / COLOUR_LEVELS)
            else:
                expected = pressure_rgb([0.0, 0.5, 1.0, 0.25][k])
            assert np.abs(frame[centre_pixel(recorder, world, body)] - 255 * expected).max() <= 1.5, (k, colour)
        dummies = [i for i, body in enumerate(GRID_2X2.bodies) if body.dummy]
        for body in dummies:
            assert np.abs(frame[centre_pixel(recorder, world, body)] - 255 * np.array(DUMMY_RGBA[:3])).max() <= 1
        if colour == "phase":  # kept 0.999 wraps round to the colour of 0
            np.testing.assert_array_equal(frame[centre_pixel(recorder, world, units[3])],
                                          frame[centre_pixel(recorder, world, units[0])])
        # the bodies move: a body moved by 5 cm along +x shows 5 cm (pixels) further right, the same colour
        row, col = centre_pixel(recorder, world, units[0])
        world.positions = world.positions.copy()
        world.positions[units[0], 0] += 0.05
        moved = recorder.render()
        pixel = 2 * params.distance * math.tan(math.radians(FOV) / 2) / params.height
        shift = round(0.05 / pixel)
        np.testing.assert_array_equal(moved[row, col + shift], frame[row, col])
        recorder(world)  # as run()'s observer: one frame due at time 0
    assert recorder.frames == 1 and (tmp_path / "v.mp4").is_file()


def test_kept_phases_follow_each_unit_to_its_place():
    records = RunRecords(config=None)
    n = 3
    position = np.array([3, 1, 2])  # unit 1 sits at place 3, unit 2 at place 1, unit 3 at place 2
    records.add_step(0, 1.0, np.zeros(n), np.array([0.1, 0.2, 0.3]), np.zeros(n), np.zeros(n), np.ones(n, bool),
                     position, np.ones(n, int), np.zeros((n, 2)), np.zeros(n))
    np.testing.assert_array_equal(records.last_kept_by_place(), [0.2, 0.3, 0.1])


def test_auto_view_is_top_for_large_sheets_only_and_a_stack_is_refused_on_one_line():
    sheet = load_shape(SHAPES_DIR / "sheet-10x10.toml")
    assert sheet.n_units == AUTO_TOP_UNITS  # the library's largest sheet keeps the side view
    assert resolve_view(sheet, VideoParams()) == "side"
    bigger = shape_from_table({"assembly": {"generator": "grid", "rows": 11, "columns": 10, "dummy": False}},
                              source="test")
    assert resolve_view(bigger, VideoParams()) == "top"
    assert resolve_view(bigger, VideoParams(view="side")) == "side"
    assert resolve_view(STACK, VideoParams()) == "side"
    with pytest.raises(ConfigError) as info:
        resolve_view(STACK, VideoParams(view="top"))
    assert str(info.value).startswith("--view: top: expected a shape in one layer on the ground")
    assert "\n" not in str(info.value)


def test_open_recorder_picks_the_view(tmp_path):
    top = open_recorder(GRID_2X2, tmp_path / "a.mp4", VideoParams(view="top"))
    side = open_recorder(GRID_2X2, tmp_path / "b.mp4", VideoParams())
    try:
        assert type(top).__name__ == "TopDownRecorder" and type(side).__name__ == "VideoRecorder"
    finally:
        top.abort()
        side.abort()


def test_run_and_render_write_a_top_view_video_and_phase_maps_of_a_small_sheet(tmp_path, capsys):
    run_dir, video = tmp_path / "run", tmp_path / "top.mp4"
    assert main(["run", str(SHAPES_DIR / "grid-3x3.toml"), "--steps", "2", "--cycles-per-step", "1", "--quiet",
                 "--out", str(run_dir), "--video", str(video), "--view", "top", "--colour", "phase",
                 "--video-width", "128", "--video-height", "96", "--video-fps", "10", "--video-speed", "4"]) == 0
    capture = cv2.VideoCapture(str(video))
    frames = []
    while True:
        ok, frame = capture.read()
        if not ok:
            break
        frames.append(frame)
    assert len(frames) >= 5 and frames[0].shape == (96, 128, 3)
    steps = pd.read_parquet(run_dir / "steps.parquet")
    assert len(steps) == 3

    replayed = tmp_path / "replayed.mp4"
    assert main(["render", str(run_dir), "--out", str(replayed), "--view", "top", "--quiet", "--video-width", "128",
                 "--video-height", "96", "--video-fps", "10", "--video-speed", "4", "--video-steps", "0:0"]) == 0
    assert cv2.VideoCapture(str(replayed)).get(cv2.CAP_PROP_FRAME_COUNT) >= 1

    figure = tmp_path / "phases.png"
    assert main(["render", str(run_dir), "--phases", "0,2", "--out", str(figure)]) == 0
    image = cv2.imread(str(figure))
    assert image is not None and image.shape[1] > image.shape[0]  # two panels side by side
    capsys.readouterr()
    assert main(["render", str(run_dir), "--phases", "0,7", "--out", str(figure)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("morphbench: error: --phases: 0,7: expected learning steps of this run, 0 to 2")
    assert "\n" not in err
    assert main(["render", str(run_dir), "--phases", "0", "--out", str(tmp_path / "phases.mp4")]) == 2
    assert "expected a file name ending in .png" in capsys.readouterr().err


def test_a_stack_gets_one_line_for_a_top_view_before_anything_is_simulated(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", str(SHAPES_DIR / "stack-2x2x2.toml"), "--steps", "1", "--quiet", "--out", str(out),
                 "--video", str(tmp_path / "v.mp4"), "--view", "top"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("morphbench: error: --view: top: expected a shape in one layer on the ground")
    assert "\n" not in err
    assert not out.exists() and not (tmp_path / "v.mp4").exists()


def test_a_unit_driving_several_bellows_shows_the_fullest(tmp_path):
    sheet = shape_from_table({"assembly": {"generator": "grid", "rows": 2, "columns": 2, "dummy": False,
                                           "actuated_axes": ["x", "y"]}}, source="test")
    world = FakeWorld(sheet, sheet.placed_positions())
    world.pressure = np.linspace(0.1, 0.9, len(sheet.links))
    recorder = TopDownRecorder(world, tmp_path / "v.mp4", VideoParams(view="top"))
    try:
        links = [np.flatnonzero(world.link_units == k) for k in range(sheet.n_units)]
        expected = [world.pressure[own].max() if len(own) else 0.0 for own in links]
        assert max(len(own) for own in links) == 2 and min(len(own) for own in links) == 0
        np.testing.assert_allclose(recorder.unit_values(), expected)
    finally:
        recorder.abort()


def test_phase_maps_of_a_consolidated_suite_run_read_its_rows_of_the_units_table(reference, tmp_path):
    _, out, outcome = reference
    run_id = outcome.tables["runs"].run_id.iloc[0]
    assert not (out / "runs" / run_id / "units.parquet").exists()  # its rows are in the consolidated tables only
    figure = tmp_path / "phases.png"
    assert main(["render", str(out / "runs" / run_id), "--phases", "0,4", "--out", str(figure)]) == 0
    assert cv2.imread(str(figure)) is not None


def test_the_side_view_colours_units_by_kept_phase_too(tmp_path):
    import pybullet as pb

    from morphbench.physics import World
    from morphbench.render import VideoRecorder
    from morphbench.render.video import COLOUR_LEVELS as SIDE_LEVELS

    chain = load_shape(SHAPES_DIR / "chain-2.toml")
    with World(chain) as world:
        recorder = VideoRecorder(world, tmp_path / "v.mp4", VideoParams(width=64, height=48, colour="phase"))
        try:
            kept = np.array([0.25, 0.75])
            recorder.set_status(kept=kept)
            recorder.render()
            scene = world.scene
            for k, body in enumerate(chain.units):
                rgba = pb.getVisualShapeData(scene.bodies[body], physicsClientId=scene.client)[0][7]
                np.testing.assert_allclose(rgba[:3], phase_rgb(round(kept[k] * SIDE_LEVELS) / SIDE_LEVELS), atol=1e-6)
        finally:
            recorder.abort()
