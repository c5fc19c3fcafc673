"""The optical sensor: each unit films the ground under it, like an optical mouse, and integrates the image motion.

Each frame, for every unit at once:
1. Pose -> view. The sensor sits at the mount point (unit frame) and looks along the unit's own down axis. The
   image's columns run along the unit's forward axis and its rows along its left axis, so forward motion is image
   motion along the columns. Tilt is modelled for a telecentric (orthographic) lens: the image is projected along
   the optical axis onto the ground, so a tilted sensor sees a stretched footprint and reports a ground motion
   along the tilt direction shortened by cos(tilt). The footprint is centred on the mount point itself, not on
   where the tilted optical axis meets the ground: the two differ by at most ``liftoff_height * tan(tilt)``. The
   image scale does not change with height (no perspective); instead the sensor sees nothing above
   ``liftoff_height``, as a lifted mouse does.
2. View -> frame: the ground patch is cut from the texture (``GroundTexture.patches``, one remap for all units),
   optionally blurred, given Gaussian pixel noise and quantised to 8 bits (OpenCV's Lucas-Kanade needs 8-bit
   images, and real sensors have 6-8 bit pixels).
3. Two frames -> shift: pyramidal Lucas-Kanade tracks the centre of the previous frame into the current one
   (``ShiftEstimator``), for all units in one OpenCV call on their frames stacked in one image. When tracking fails
   (no convergence, a shift beyond a quarter of the patch, or a residual that shows a wrong match) the frame
   reports no motion and counts in ``lost_frames``.
4. Shift -> displacement: the image moves opposite to the unit, so the forward displacement is minus the column
   shift times the pixel size. A frame reports motion only if the sensor was on the ground at both of its ends.

Cost: per frame a fixed few dozen numpy/OpenCV calls for all units together plus one Lucas-Kanade point per unit,
so the sensor's cost is set by its frame rate; ``OpticalParams`` trades frame rate against pixel size.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from morphbench.errors import ConfigError
from morphbench.params import OpticalParams
from morphbench.sensing.base import Sensor
from morphbench.sensing.ground import GroundTexture

MIN_PATCH = 16
"""px, smallest patch: Lucas-Kanade needs a window of at least 7 px and room for it to move."""
MAX_PATCH = 256
"""px, largest patch (a bigger one would cost more than the physics)."""
MIN_COS_TILT = 0.5
"""A sensor tilted more than 60 degrees (unit on its side or upside down) sees no ground."""
NOISE_BANK_FRAMES = 64
"""Pre-drawn noise frames. Drawing fresh Gaussian noise costs about 9 us per unit per frame, as much as the rest of
the frame; each frame instead takes a run of consecutive noise frames from a random place in the bank. A unit gets
the same noise in two consecutive frames with probability about 1 / NOISE_BANK_FRAMES, when the noise adds no error
to that frame's shift, which is harmless."""
MAX_RESIDUAL = 0.4
"""Largest accepted Lucas-Kanade residual (mean absolute grey-level difference over the window) as a fraction of the
window's standard deviation. A wrong match leaves about 0.65 of it (under 0.4 in no test); a right one only the
noise, about 0.65 noise standard deviations, so the limit is never set below one noise standard deviation."""


def _pose_table(mount: np.ndarray) -> np.ndarray:
    """(4, 4, 8) coefficients of the quadratic forms of a unit quaternion (x, y, z, w) that give, for a body with
    rotation R: R22 * (the footprint matrix of a tilted downward view, see ``OpticalSensor.views``) as
    [R11, -R10, -R01, R00], then R22, then R @ mount."""
    x, y, z, w = range(4)
    rotation = [  # R00, R01, ..., R22, each a sum of coefficient * q_i * q_j
        {(w, w): 1, (x, x): 1, (y, y): -1, (z, z): -1}, {(x, y): 2, (w, z): -2}, {(x, z): 2, (w, y): 2},
        {(x, y): 2, (w, z): 2}, {(w, w): 1, (x, x): -1, (y, y): 1, (z, z): -1}, {(y, z): 2, (w, x): -2},
        {(x, z): 2, (w, y): -2}, {(y, z): 2, (w, x): 2}, {(w, w): 1, (x, x): -1, (y, y): -1, (z, z): 1},
    ]
    table = np.zeros((4, 4, 9))
    for k, entry in enumerate(rotation):
        for (i, j), coefficient in entry.items():
            table[i, j, k] = coefficient
    outputs = np.zeros((9, 8))  # which combination of R's entries (row-major) each output is
    for column, (entry, sign) in enumerate([(4, 1), (3, -1), (1, -1), (0, 1), (8, 1)]):
        outputs[entry, column] = sign
    for row in range(3):
        outputs[3 * row : 3 * row + 3, 5 + row] = mount
    return table @ outputs


class ShiftEstimator:
    """Sub-pixel image shift between two frames of each of N views stacked vertically in one 8-bit image.

    Pyramidal Lucas-Kanade on the centre point of each view, with a window of about half the patch: one OpenCV call
    for all views (on 32 px patches at 1 % noise, about 0.03 px mean error per frame for shifts up to about 6 px).
    """

    def __init__(self, n_views: int, patch_size: int, noise_levels: float = 0.0):
        """``noise_levels``: standard deviation of the frames' pixel noise in grey levels (0-255)."""
        centre = (patch_size - 1) / 2
        self.n_views, self.patch_size, self.noise_levels = n_views, patch_size, noise_levels
        self.points = np.array([[centre, i * patch_size + centre] for i in range(n_views)], np.float32).reshape(-1, 1, 2)
        side = patch_size // 2 - 1 | 1  # odd, and leaves a quarter of the patch for the window to move into
        self.window = (side, side)
        self.levels = max(0, int(math.log2(patch_size / 8)))  # the coarsest level still has 8 px per view
        self.max_shift = patch_size / 4
        """px, largest shift accepted: beyond it the window leaves the patch and the estimate is unreliable."""
        self._criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 20, 0.003)
        first = (patch_size - side) // 2
        self._window_slice = slice(first, first + side)

    def __call__(self, previous: np.ndarray, current: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(N, 2) px shift (column, row) of the image content from ``previous`` to ``current``, and (N,) whether
        each was tracked; an untracked view's shift is 0."""
        moved, status, residual = cv2.calcOpticalFlowPyrLK(
            previous, current, self.points, None, winSize=self.window, maxLevel=self.levels, criteria=self._criteria
        )
        shifts = (moved - self.points)[:, 0]
        window = self._window_slice
        contrast = previous.reshape(self.n_views, self.patch_size, self.patch_size)[:, window, window].std(axis=(1, 2))
        tracked = (
            (status[:, 0] == 1)
            & (np.abs(shifts).max(axis=1) <= self.max_shift)
            & (residual[:, 0] <= np.maximum(MAX_RESIDUAL * contrast, self.noise_levels))
        )
        return shifts * tracked[:, None], tracked


class OpticalSensor(Sensor):
    """A bank of optical motion sensors, one per unit: row i only ever reads unit i's pose."""

    def __init__(
        self,
        n_units: int,
        params: OpticalParams,
        ground: GroundTexture,
        rng: np.random.Generator,
        *,
        source: str = "OpticalParams",
    ):
        """``rng`` draws the image noise; ``source`` names where ``params`` came from in a ``ConfigError``."""
        if n_units < 1:
            raise ValueError(f"an optical sensor needs at least one unit, got {n_units}")
        _check(params, source)
        self.params, self.ground, self.n_units = params, ground, n_units
        self.sample_period = 1.0 / params.frame_rate
        self._pose_table = _pose_table(np.array([params.mount_x, params.mount_y, -params.mount_depth]))
        self._estimator = ShiftEstimator(n_units, params.patch_size, 255 * params.noise)
        self._rng = rng
        size = params.patch_size
        bank = rng.standard_normal(((NOISE_BANK_FRAMES + n_units - 1) * size, size), dtype=np.float32)
        self._noise_bank = bank * np.float32(255 * params.noise)
        self._frame: np.ndarray | None = None
        self._on_ground = np.zeros(n_units, dtype=bool)
        self._columns_moved = np.zeros(n_units)  # px, summed image shift along the forward axis, sign of the unit
        self.lost_frames = np.zeros(n_units, dtype=int)
        """frames since the last reset in which a unit's sensor was on the ground but could not track the image."""

    def reset(self, positions: np.ndarray, orientations: np.ndarray) -> None:
        positions, orientations = np.asarray(positions, dtype=float), np.asarray(orientations, dtype=float)
        if positions.shape != (self.n_units, 3) or orientations.shape != (self.n_units, 4):
            raise ValueError(
                f"expected poses of {self.n_units} units, (N, 3) and (N, 4), got {positions.shape} and {orientations.shape}"
            )
        self._frame, self._on_ground = self.frames(positions, orientations)
        self._columns_moved = np.zeros(self.n_units)
        self.lost_frames = np.zeros(self.n_units, dtype=int)

    def sample(self, positions: np.ndarray, orientations: np.ndarray) -> None:
        if self._frame is None:
            raise RuntimeError("OpticalSensor.sample before reset: reset gives the first frame")
        frame, on_ground = self.frames(positions, orientations)
        shifts, tracked = self._estimator(self._frame, frame)
        valid = on_ground & self._on_ground
        self._columns_moved -= shifts[:, 0] * valid  # the image moves opposite to the unit
        self.lost_frames += valid > tracked
        self._frame, self._on_ground = frame, on_ground

    def displacement(self) -> np.ndarray:
        return self._columns_moved * self.params.pixel_size

    def frames(self, positions: np.ndarray, orientations: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """What every sensor sees at these poses: the 8-bit frames stacked vertically, (N * patch_size, patch_size),
        and (N,) whether each sensor is on the ground (low enough and facing it)."""
        affines, on_ground = self.views(positions, orientations)
        size = self.params.patch_size
        images = self.ground.patches(affines, size)
        if self.params.blur > 0:
            for image in images:
                cv2.GaussianBlur(image, (0, 0), self.params.blur, dst=image)
        images = images.reshape(self.n_units * size, size)
        if self.params.noise == 0:
            return cv2.convertScaleAbs(images, alpha=255), on_ground
        start = int(self._rng.integers(NOISE_BANK_FRAMES)) * size
        noise = self._noise_bank[start : start + self.n_units * size]
        return cv2.addWeighted(images, 255, noise, 1, 0, dtype=cv2.CV_8U), on_ground

    def views(self, positions: np.ndarray, orientations: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Where each sensor looks: (N, 2, 3) affine maps from image pixel offsets (u, v, 1) to ground points (m),
        as ``GroundTexture.patches`` takes them, and (N,) whether each sensor is on the ground.

        Projected along the optical axis (the unit's up axis, column 2 of its rotation R), the image axes land on
        the ground as R's first two columns minus (their z / R22) times the third. That 2 x 2 footprint equals
        [[R11, -R10], [-R01, R00]] / R22 (a rotation matrix equals its own cofactor matrix), so one einsum of the
        quaternions gives footprint, tilt and mount point for every unit at once.
        """
        pose = np.einsum("ni,nj,ijk->nk", orientations, orientations, self._pose_table)
        up_z = pose[:, 4]
        mount = positions + pose[:, 5:]
        affines = np.empty((self.n_units, 2, 3))
        # up_z is clamped for sensors that see no ground, which keeps their (unused) views finite.
        scale = self.params.pixel_size / np.maximum(up_z, MIN_COS_TILT)
        affines[:, :, :2] = (pose[:, :4] * scale[:, None]).reshape(-1, 2, 2)
        affines[:, :, 2] = mount[:, :2]
        on_ground = (up_z > MIN_COS_TILT) & (mount[:, 2] <= self.params.liftoff_height)
        return affines, on_ground


def _check(params: OpticalParams, source: str) -> None:
    def number(key: str, low: float, *, inclusive: bool, unit: str) -> None:
        value = getattr(params, key)
        finite = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
        if not finite or value < low or (value == low and not inclusive):
            raise ConfigError(source, key, f"a finite number {'>=' if inclusive else '>'} {low:g} ({unit})", value)

    number("frame_rate", 0, inclusive=False, unit="Hz")
    number("pixel_size", 0, inclusive=False, unit="m")
    number("noise", 0, inclusive=True, unit="fraction of the grey range")
    number("blur", 0, inclusive=True, unit="px")
    number("liftoff_height", 0, inclusive=False, unit="m")
    for key in ("mount_x", "mount_y", "mount_depth"):
        value = getattr(params, key)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ConfigError(source, key, "a finite number (m)", value)
    size = params.patch_size
    if isinstance(size, bool) or not isinstance(size, int) or not MIN_PATCH <= size <= MAX_PATCH:
        raise ConfigError(source, "patch_size", f"an integer number of pixels in [{MIN_PATCH}, {MAX_PATCH}]", size)
