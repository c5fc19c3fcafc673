"""The ground texture and the optical sensor, checked against motions whose answer is known (no simulator).

Tolerances: frame-to-frame shifts of noise-free frames within 0.05 px (measured: about 0.01 px mean error); a
40 mm move within 0.6 mm (measured over 200 seeds at the default 1 % noise: 0.08 mm bias, 0.1 mm standard deviation).
"""

import math

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from morphbench.errors import ConfigError
from morphbench.params import GroundParams, OpticalParams
from morphbench.sensing.ground import GroundTexture
from morphbench.sensing.optical import OpticalSensor, ShiftEstimator

# The numbers below were worked out for this sensor and ground resolution; pinning them keeps the tests about the
# sensor's behaviour rather than about the current defaults (morphbench.params), which may be tuned.
PINNED_OPTICAL = {"frame_rate": 10.0, "pixel_size": 0.00125}
PINNED_GROUND = {"resolution": 0.00125, "grain": 0.0025}


def pinned_optical(**fields) -> OpticalParams:
    return OpticalParams(**{**PINNED_OPTICAL, **fields})


def pinned_ground(**fields) -> GroundParams:
    return GroundParams(**{**PINNED_GROUND, **fields})


GROUND = pinned_ground(length=0.4, width=0.2)  # a small tile: fast to make, and its edges are easy to reach
REST_Z = 0.015  # a 30 mm unit resting on the ground: its sensor (default mount) is at zero lift
PIXEL = pinned_optical().pixel_size


@pytest.fixture(scope="module")
def ground() -> GroundTexture:
    return GroundTexture(GROUND)


def quaternion(yaw: float, pitch: float = 0.0) -> np.ndarray:
    """(x, y, z, w) of a yaw about the world z axis followed by a pitch about the body's own y axis."""
    cy, sy, cp, sp = math.cos(yaw / 2), math.sin(yaw / 2), math.cos(pitch / 2), math.sin(pitch / 2)
    return np.array([-sy * sp, cy * sp, sy * cp, cy * cp])


def axes(yaw: float) -> tuple[np.ndarray, np.ndarray]:
    """A unit's forward and left axes in the world at this yaw."""
    return np.array([math.cos(yaw), math.sin(yaw), 0.0]), np.array([-math.sin(yaw), math.cos(yaw), 0.0])


def sensed(sensor: OpticalSensor, positions: list, orientations: list) -> np.ndarray:
    """Reset at the first pose, sample every later one, return the displacement (m)."""
    sensor.reset(np.array(positions[0]), np.array(orientations[0]))
    for p, q in zip(positions[1:], orientations[1:]):
        sensor.sample(np.array(p), np.array(q))
    return sensor.displacement()


def one_unit_path(start, yaw: float, step, n_frames: int, z: float = REST_Z):
    """Poses of one unit moving by ``step`` (m, world) per frame at a fixed yaw."""
    start = np.array([start[0], start[1], z])
    positions = [[start + k * np.asarray(step)] for k in range(n_frames + 1)]
    return positions, [[quaternion(yaw)]] * (n_frames + 1)


# ---- ground texture ------------------------------------------------------------------------------------------------

def test_procedural_texture_is_seeded_and_has_the_asked_contrast(ground):
    again, other = GroundTexture(GROUND), GroundTexture(pinned_ground(length=0.4, width=0.2, seed=2))
    assert np.array_equal(ground.image, again.image)
    assert not np.array_equal(ground.image, other.image)
    assert ground.image.dtype == np.float32 and ground.image.shape == (160, 320)
    assert ground.extent == pytest.approx((0.4, 0.2))
    assert ground.image.mean() == pytest.approx(0.5, abs=0.01)
    assert ground.image.std() == pytest.approx(GROUND.contrast / 6, rel=0.02)


def test_texture_repeats_without_seam(ground):
    """A patch one tile away is the same patch, and one straddling the tile's edge is as smooth as any other."""
    x, y = 0.05, -0.03
    assert np.array_equal(ground.patch(x, y, 0.3, 32, PIXEL), ground.patch(x + 0.4, y - 0.2, 0.3, 32, PIXEL))
    tile = np.tile(ground.image, (2, 2))  # neighbouring pixels across the edge differ no more than inside the tile
    across = np.abs(np.diff(tile, axis=1))[:, 319].mean()
    inside = np.abs(np.diff(ground.image, axis=1)).mean()
    assert across == pytest.approx(inside, rel=0.2)


def test_patch_axes_follow_the_unit(ground):
    """Image columns run along the unit's forward axis and rows along its left axis: turning the unit by 90 degrees
    turns the image by 90 degrees, and a patch at yaw 0 is a plain crop of the tile (which is centred on the
    origin)."""
    crop = ground.image[40:72, 100:132]  # pixel (row, col) centred at ((col + 0.5) res - 0.2, (row + 0.5) res - 0.1)
    centre_x, centre_y = (116 * PIXEL) - 0.2, (56 * PIXEL) - 0.1
    assert np.array_equal(ground.patch(centre_x, centre_y, 0.0, 32, PIXEL), crop)
    turned = ground.patch(centre_x, centre_y, math.pi / 2, 32, PIXEL)
    assert np.array_equal(turned, np.rot90(crop))  # the forward axis along +y: the crop turned counterclockwise


def test_texture_from_image_file(tmp_path):
    image = np.random.default_rng(0).integers(0, 256, (40, 60), dtype=np.uint8)
    path = tmp_path / "floor.png"
    cv2.imwrite(str(path), image)
    texture = GroundTexture(pinned_ground(image=str(path), resolution=0.002))
    assert np.allclose(texture.image, image / 255.0)
    assert texture.extent == pytest.approx((0.12, 0.08))


def test_bad_texture_file_gives_config_error(tmp_path):
    missing = tmp_path / "nowhere.png"
    with pytest.raises(ConfigError, match=r"ground.toml: image: expected an existing image file.*nowhere\.png"):
        GroundTexture(pinned_ground(image=str(missing)), source="ground.toml")
    garbage = tmp_path / "garbage.png"
    garbage.write_text("not an image")
    with pytest.raises(ConfigError, match=r"image: expected an image file OpenCV can read.*garbage\.png"):
        GroundTexture(pinned_ground(image=str(garbage)))


@pytest.mark.parametrize(
    "field, value, message",
    [
        ("contrast", 1.5, r"contrast: expected a number in \(0, 1\], got 1.5"),
        ("grain", 0.0, r"grain: expected a number in \[1e-06, 1\] \(m\), got 0.0"),
        ("resolution", float("nan"), r"resolution: expected a number in \[1e-06, 1\]"),
        ("seed", -1, r"seed: expected an integer in \[0, 9223372036854775807\], got -1"),
        ("resolution", 1e-6, r"length, width, resolution: expected a tile of 8 to 32,766 px a side and at most "
                             r"64,000,000 px, got '2000000 x 500000 px \(2.0 m x 0.5 m at 1e-06 m/px\)'"),
        ("length", 0.005, r"length, width, resolution: expected a tile of 8 to 32,766 px a side.*'4 x 400 px"),
        ("length", 50.0, r"length, width, resolution: expected a tile of 8 to 32,766 px a side.*'40000 x 400 px"),
    ],
)
def test_bad_ground_parameters_give_config_error(field, value, message):
    with pytest.raises(ConfigError, match=r"^GroundParams: " + message):
        GroundTexture(pinned_ground(**{field: value}))


@pytest.mark.parametrize(
    "field, value, message",
    [
        ("frame_rate", 0.0, r"frame_rate: expected a number in \(0, 10000\] \(Hz\), got 0.0"),
        ("pixel_size", -0.001, r"pixel_size: expected a number in \[1e-06, 0.1\] \(m\)"),
        ("noise", -0.1, r"noise: expected a number in \[0, 10\]"),
        ("liftoff_height", float("inf"), r"liftoff_height: expected a number in \(0, 1\]"),
        ("patch_size", 8, r"patch_size: expected an integer in \[16, 256\] \(px\), got 8"),
        ("mount_x", "front", r"mount_x: expected a number in \[-1, 1\] \(m\), got 'front'"),
    ],
)
def test_bad_optical_parameters_give_config_error(ground, field, value, message):
    with pytest.raises(ConfigError, match=r"^sensors.toml: " + message):
        OpticalSensor(1, pinned_optical(**{field: value}), ground, np.random.default_rng(0), source="sensors.toml")


# ---- shift estimation ----------------------------------------------------------------------------------------------

def frame_pair(ground, start, yaw, move_px, yaw_after=None):
    """Noise-free frames of one sensor before and after its viewpoint moves by ``move_px`` (forward, left) pixels."""
    sensor = OpticalSensor(2, pinned_optical(noise=0.0), ground, np.random.default_rng(0))
    forward, left = axes(yaw)
    before = np.array([start[0], start[1], REST_Z])
    after = before + (move_px[0] * forward + move_px[1] * left) * PIXEL
    yaw_after = yaw if yaw_after is None else yaw_after
    frames, _ = sensor.frames(np.array([before, after]), np.array([quaternion(yaw), quaternion(yaw_after)]))
    return frames[:32], frames[32:]


@pytest.mark.parametrize("yaw_deg", [0.0, 30.0, -135.0])
@pytest.mark.parametrize("move_px", [(0.3, 0.0), (1.7, 0.0), (0.0, -0.3), (-1.7, 1.2), (4.5, -2.5)])
def test_known_subpixel_shifts_are_recovered(ground, move_px, yaw_deg):
    """The image content moves opposite to the viewpoint, along the unit's own axes whatever its yaw."""
    previous, current = frame_pair(ground, (0.03, -0.02), math.radians(yaw_deg), move_px)
    shifts, tracked = ShiftEstimator(32)(previous, current)
    assert tracked[0]
    assert shifts[0] == pytest.approx(-np.array(move_px), abs=0.05)


@settings(max_examples=40, deadline=None)
@given(
    x=st.floats(-0.15, 0.15), y=st.floats(-0.08, 0.08), yaw=st.floats(-math.pi, math.pi),
    forward=st.floats(-5.0, 5.0), left=st.floats(-5.0, 5.0),
)
def test_any_shift_within_range_is_recovered(ground, x, y, yaw, forward, left):
    """Shifts up to 6 px in any direction are always tracked (the range docs/sensing.md promises); on the corners
    of the +-5 px square (up to 7.1 px) tracking may be lost at some spots of the texture (seen from 6.5 px on), and
    is then reported as lost, never as a wrong shift."""
    previous, current = frame_pair(ground, (x, y), yaw, (forward, left))
    shifts, tracked = ShiftEstimator(32)(previous, current)
    if math.hypot(forward, left) <= 6.0:
        assert tracked[0]
    if tracked[0]:
        assert shifts[0] == pytest.approx([-forward, -left], abs=0.08)


def test_a_long_diagonal_shift_is_lost_not_misread(ground):
    """The case hypothesis found: 7.1 px diagonally at this spot is beyond the tracker; it says so."""
    previous, current = frame_pair(ground, (0.0, 0.01953125), 0.0, (5.0, 5.0))
    shifts, tracked = ShiftEstimator(32)(previous, current)
    assert not tracked[0] and np.all(shifts[0] == 0)


def test_turning_in_place_is_almost_no_shift(ground):
    """A unit turning about its sensor rotates the image about the tracked centre: only a small false shift (about
    0.04 px per degree on average, measured), growing with the turn."""
    def false_shift(degrees: float) -> float:
        previous, current = frame_pair(ground, (0.01, 0.02), 0.4, (0.0, 0.0), yaw_after=0.4 + math.radians(degrees))
        shifts, tracked = ShiftEstimator(32)(previous, current)
        assert tracked[0]
        return np.abs(shifts[0]).max()

    assert false_shift(0.0) == 0.0
    assert false_shift(1.0) < 0.1


def test_shifts_beyond_the_windows_travel_are_rejected(ground):
    """Past the window's travel limit (9.5 px at 32 px) Lucas-Kanade is often wrong, so even a right estimate is not
    trusted."""
    for x in np.linspace(-0.15, 0.15, 8):
        previous, current = frame_pair(ground, (x, 0.05), 0.2, (11.0, 0.0))
        shifts, tracked = ShiftEstimator(32)(previous, current)
        assert not tracked[0] and shifts[0].tolist() == [0.0, 0.0]


def test_lost_tracking_reports_no_motion(ground):
    """A jump far beyond the patch is rejected, reported as no motion and counted as a lost frame."""
    sensor = OpticalSensor(1, pinned_optical(), ground, np.random.default_rng(0))
    positions, orientations = one_unit_path((0.0, 0.0), 0.0, (30 * PIXEL, 0.0, 0.0), 1)
    assert sensed(sensor, positions, orientations)[0] == 0.0
    assert sensor.lost_frames.tolist() == [1]


# ---- the sensor on known motions -----------------------------------------------------------------------------------

def test_still_unit_senses_no_motion(ground):
    params = pinned_optical()
    positions, orientations = one_unit_path((0.02, 0.01), 0.7, (0.0, 0.0, 0.0), 100)
    exact = OpticalSensor(1, pinned_optical(noise=0.0), ground, np.random.default_rng(0))
    assert sensed(exact, positions, orientations)[0] == 0.0
    noisy = OpticalSensor(1, params, ground, np.random.default_rng(0))
    assert abs(sensed(noisy, positions, orientations)[0]) < 0.4e-3  # noise alone: 0.06 mm std over 40 frames


@pytest.mark.parametrize("yaw_deg", [0.0, 30.0, -135.0])
@pytest.mark.parametrize("step_mm", [2.0, -1.5, 4.5])
def test_motion_along_the_forward_axis_is_sensed(ground, yaw_deg, step_mm):
    yaw = math.radians(yaw_deg)
    forward, _ = axes(yaw)
    n_frames = 20
    positions, orientations = one_unit_path((-0.05, 0.03), yaw, forward * step_mm * 1e-3, n_frames)
    sensor = OpticalSensor(1, pinned_optical(), ground, np.random.default_rng(1))
    assert sensed(sensor, positions, orientations)[0] == pytest.approx(n_frames * step_mm * 1e-3, abs=0.6e-3)
    assert sensor.lost_frames.tolist() == [0]


@pytest.mark.parametrize("yaw_deg", [0.0, 30.0])
def test_sideways_motion_is_no_forward_motion(ground, yaw_deg):
    _, left = axes(math.radians(yaw_deg))
    positions, orientations = one_unit_path((0.0, -0.04), math.radians(yaw_deg), left * 2e-3, 20)
    sensor = OpticalSensor(1, pinned_optical(), ground, np.random.default_rng(2))
    assert abs(sensed(sensor, positions, orientations)[0]) < 0.6e-3


def test_each_unit_senses_only_its_own_motion(ground):
    """Three units, only the middle one moves: the others sense nothing, and what the middle one senses does not
    depend on what the others do."""
    params = pinned_optical(noise=0.0)
    starts = np.array([[0.1, 0.0, REST_Z], [0.0, 0.0, REST_Z], [-0.1, 0.0, REST_Z]])
    q = np.tile(quaternion(0.0), (3, 1))
    middle_moves = [starts + [[0, 0, 0], [k * 1e-3, 0, 0], [0, 0, 0]] for k in range(11)]
    alone = sensed(OpticalSensor(3, params, ground, np.random.default_rng(0)), middle_moves, [q] * 11)
    assert alone[0] == 0.0 and alone[2] == 0.0
    assert alone[1] == pytest.approx(0.010, abs=0.2e-3)
    others_move = [p + [[-k * 2e-3, 0, 0], [0, 0, 0], [0, k * 1e-3, 0]] for k, p in enumerate(middle_moves)]
    together = sensed(OpticalSensor(3, params, ground, np.random.default_rng(0)), others_move, [q] * 11)
    assert together[1] == alone[1]


def test_many_units_over_many_frames(ground):
    """40 units for 70 frames: more views than one remap or one Lucas-Kanade call takes, and more frames than one
    batch holds; every unit still senses its own motion."""
    n_units, n_frames = 40, 70
    starts = np.column_stack([np.linspace(-0.15, 0.15, n_units), np.zeros(n_units), np.full(n_units, REST_Z)])
    steps = np.linspace(-2e-3, 2e-3, n_units)  # m per frame along x, a different speed for every unit
    positions = [starts + np.outer(k * steps, [1.0, 0.0, 0.0]) for k in range(n_frames + 1)]
    sensor = OpticalSensor(n_units, pinned_optical(), ground, np.random.default_rng(0))
    displacement = sensed(sensor, positions, [np.tile(quaternion(0.0), (n_units, 1))] * (n_frames + 1))
    assert displacement == pytest.approx(n_frames * steps, abs=0.8e-3)


def test_crossing_the_tile_edge_is_sensed(ground):
    positions, orientations = one_unit_path((0.19, 0.0), 0.0, (2e-3, 0.0, 0.0), 10)  # the tile ends at x = 0.2
    sensor = OpticalSensor(1, pinned_optical(), ground, np.random.default_rng(3))
    assert sensed(sensor, positions, orientations)[0] == pytest.approx(0.020, abs=0.4e-3)


def test_lift_off_stops_sensing(ground):
    params = pinned_optical()
    sensor = OpticalSensor(1, params, ground, np.random.default_rng(0))
    lifted = REST_Z + 2 * params.liftoff_height
    positions, orientations = one_unit_path((0.0, 0.0), 0.0, (2e-3, 0.0, 0.0), 10, z=lifted)
    assert sensed(sensor, positions, orientations)[0] == 0.0
    low = REST_Z + 0.5 * params.liftoff_height  # below lift-off the sensor still sees the ground
    positions, orientations = one_unit_path((0.0, 0.0), 0.0, (2e-3, 0.0, 0.0), 10, z=low)
    assert sensed(sensor, positions, orientations)[0] == pytest.approx(0.020, abs=0.4e-3)
    # Down, lifted for two frames while moving 2 mm each, down again: only the motion on the ground counts.
    heights = [REST_Z, REST_Z, lifted, lifted, REST_Z, REST_Z]
    positions = [[np.array([k * 2e-3, 0.0, z])] for k, z in enumerate(heights)]
    assert sensed(sensor, positions, [[quaternion(0.0)]] * 6)[0] == pytest.approx(0.004, abs=0.3e-3)


def test_tilted_sensor_sees_foreshortened_motion(ground):
    """A sensor pitched by 30 degrees sees ground motion along its tilt shortened by cos(30 degrees); past 60
    degrees it sees no ground at all."""
    pitch = math.radians(30)
    centre_z = 0.015 * math.cos(pitch)  # keeps the underside's centre on the ground
    q = quaternion(0.0, pitch)
    positions = [[np.array([k * 2e-3, 0.0, centre_z])] for k in range(21)]
    sensor = OpticalSensor(1, pinned_optical(), ground, np.random.default_rng(4))
    assert sensed(sensor, positions, [[q]] * 21)[0] == pytest.approx(0.040 * math.cos(pitch), abs=0.6e-3)
    on_side = quaternion(0.0, math.radians(70))
    assert sensed(sensor, positions, [[on_side]] * 21)[0] == 0.0


def test_same_seeds_give_same_texture_and_measurements():
    """Same texture seed and same noise stream: the same measurements (to rounding, however the frames are batched);
    another noise stream or another texture gives different ones."""
    positions, orientations = one_unit_path((0.0, 0.0), 0.3, (1.2e-3, 0.4e-3, 0.0), 90)

    def measured(texture_seed: int, noise_seed: int, read_midway: bool) -> float:
        texture = GroundTexture(pinned_ground(length=0.4, width=0.2, seed=texture_seed))
        sensor = OpticalSensor(1, pinned_optical(), texture, np.random.default_rng(noise_seed))
        assert sensor.sample_period == pytest.approx(0.1)
        sensor.reset(np.array(positions[0]), np.array(orientations[0]))
        for k, (p, q) in enumerate(zip(positions[1:], orientations[1:])):
            sensor.sample(np.array(p), np.array(q))
            if read_midway and k in (10, 70):
                sensor.displacement()
        return sensor.displacement()[0]

    reference = measured(1, 5, read_midway=False)
    assert measured(1, 5, read_midway=False) == reference
    # Batching moves a frame to another row of the stacked image, where float32 coordinates round differently and
    # Lucas-Kanade may stop an iteration sooner or later: at most about 1e-3 px per frame, far below the noise.
    assert measured(1, 5, read_midway=True) == pytest.approx(reference, abs=90 * 1e-3 * PIXEL)
    assert measured(1, 6, read_midway=False) != reference
    assert measured(2, 5, read_midway=False) != reference


def test_sample_before_reset_is_an_error(ground):
    sensor = OpticalSensor(1, pinned_optical(), ground, np.random.default_rng(0))
    with pytest.raises(RuntimeError, match="before reset"):
        sensor.sample(np.zeros((1, 3)), np.array([quaternion(0.0)]))
