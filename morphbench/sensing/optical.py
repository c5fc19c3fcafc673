"""The optical sensor: each unit films the ground under it, like an optical mouse, and integrates the image motion.

Each frame, for every unit at once:
1. Pose -> view. The sensor sits at ``mount`` (unit frame) and looks along the unit's own down axis. The image's
   columns run along the unit's forward axis and its rows along the unit's left axis, so forward motion is image
   motion along the columns. Tilt is modelled exactly for a telecentric (orthographic) lens: the view is projected
   along the optical axis onto the ground, so a tilted sensor sees a stretched (foreshortened) footprint and reports
   a ground motion along the tilt direction shortened by cos(tilt). The image scale does not change with height (no
   perspective); instead the sensor sees nothing above ``liftoff_height``, as a lifted mouse does.
2. View -> frame: the ground patch is cut from the texture (``GroundTexture.patches``, one vectorised remap for all
   units), optionally blurred, given Gaussian pixel noise and quantised to 8 bits (Lucas-Kanade in OpenCV needs 8-bit
   images, and real sensors have 6-8 bit pixels).
3. Two frames -> shift: pyramidal Lucas-Kanade tracks the centre point of the previous frame into the current one
   (``ShiftEstimator``), for all units in one OpenCV call on the frames stacked in one image. A shift is rejected
   (the frame reports no motion) when tracking fails: no convergence, a shift beyond a quarter of the patch, or a
   residual that shows the match is wrong.
4. Shift -> displacement: the image moves opposite to the unit, so the forward displacement is minus the column
   shift times the pixel size. A frame reports motion only if the sensor was on the ground at both ends of it.
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
the frame; each frame instead takes a block of consecutive noise frames from a random place in the bank. A unit gets
the same noise in two consecutive frames with probability 1 / NOISE_BANK_FRAMES, when its frame shows no noise
motion at all, which is harmless."""
MAX_RESIDUAL = 0.5
"""Largest accepted Lucas-Kanade residual (mean absolute grey-level difference over the window) as a fraction of the
window's own mean absolute contrast: a right match leaves only the noise (about 0.1-0.2), a wrong one about 1."""


class ShiftEstimator:
    """Sub-pixel image shift between two frames of each of N views stacked vertically in one 8-bit image.

    Pyramidal Lucas-Kanade on the centre point of each view, with a window of about half the patch: one OpenCV call
    for all views (on 32 px patches about 0.02-0.04 px error per frame at 1 % noise, up to about 4 px shifts).
    """

    def __init__(self, n_views: int, patch_size: int):
        centre = (patch_size - 1) / 2
        self.patch_size = patch_size
        self.points = np.array([[centre, i * patch_size + centre] for i in range(n_views)], np.float32).reshape(-1, 1, 2)
        side = patch_size // 2 - 1 | 1  # odd, and leaves a quarter of the patch for the window to move into
        self.window = (side, side)
        self.levels = max(0, int(math.log2(patch_size / 8)))  # the coarsest level still has 8 px per view
        self.max_shift = patch_size / 4
        """px, largest shift accepted: beyond it the window leaves the patch and the estimate is unreliable."""
        self._criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 20, 0.003)
        self._rows = np.arange(n_views)[:, None] * patch_size + np.arange(-(side // 2), side // 2 + 1) + int(centre)
        self._cols = np.arange(-(side // 2), side // 2 + 1) + int(centre)

    def __call__(self, previous: np.ndarray, current: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(N, 2) px shift (column, row) of the image content from ``previous`` to ``current``, and (N,) whether
        each was tracked; an untracked view's shift is 0."""
        moved, status, residual = cv2.calcOpticalFlowPyrLK(
            previous, current, self.points, None, winSize=self.window, maxLevel=self.levels, criteria=self._criteria
        )
        shifts = (moved - self.points).reshape(-1, 2)
        window = previous[self._rows][:, :, self._cols].astype(np.float32)
        contrast = np.abs(window - window.mean(axis=(1, 2), keepdims=True)).mean(axis=(1, 2))
        tracked = (
            (status.ravel() == 1)
            & (np.abs(shifts).max(axis=1) <= self.max_shift)
            & (residual.ravel() <= MAX_RESIDUAL * contrast)
        )
        return np.where(tracked[:, None], shifts, 0.0), tracked


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
        self._mount = np.array([params.mount_x, params.mount_y, -params.mount_depth])
        self._estimator = ShiftEstimator(n_units, params.patch_size)
        self._rng = rng
        size = params.patch_size
        bank = rng.standard_normal(((NOISE_BANK_FRAMES + n_units - 1) * size, size), dtype=np.float32)
        self._noise_bank = bank * np.float32(255 * params.noise)
        self._frame: np.ndarray | None = None
        self._on_ground = np.zeros(n_units, dtype=bool)
        self._displacement = np.zeros(n_units)
        self.lost_frames = np.zeros(n_units, dtype=int)
        """frames since the last reset in which a unit's sensor was on the ground but could not track the image."""

    def reset(self, positions: np.ndarray, orientations: np.ndarray) -> None:
        positions, orientations = np.asarray(positions, dtype=float), np.asarray(orientations, dtype=float)
        if positions.shape != (self.n_units, 3) or orientations.shape != (self.n_units, 4):
            raise ValueError(
                f"expected poses of {self.n_units} units, (N, 3) and (N, 4), got {positions.shape} and {orientations.shape}"
            )
        self._frame, self._on_ground = self.frames(positions, orientations)
        self._displacement = np.zeros(self.n_units)
        self.lost_frames = np.zeros(self.n_units, dtype=int)

    def sample(self, positions: np.ndarray, orientations: np.ndarray) -> None:
        if self._frame is None:
            raise RuntimeError("OpticalSensor.sample before reset: reset gives the first frame")
        frame, on_ground = self.frames(np.asarray(positions, dtype=float), np.asarray(orientations, dtype=float))
        shifts, tracked = self._estimator(self._frame, frame)
        valid = on_ground & self._on_ground
        self._displacement -= np.where(valid, shifts[:, 0], 0.0) * self.params.pixel_size
        self.lost_frames += valid & ~tracked
        self._frame, self._on_ground = frame, on_ground

    def displacement(self) -> np.ndarray:
        return self._displacement.copy()

    def frames(self, positions: np.ndarray, orientations: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """What every sensor sees at these poses: the 8-bit frames stacked vertically, (N * patch_size, patch_size),
        and (N,) whether each sensor is on the ground (low enough and facing it)."""
        centres, footprints, on_ground = self.views(positions, orientations)
        size = self.params.patch_size
        images = self.ground.patches(centres, footprints, size)
        if self.params.blur > 0:
            for image in images:
                cv2.GaussianBlur(image, (0, 0), self.params.blur, dst=image)
        images = images.reshape(self.n_units * size, size)
        if self.params.noise == 0:
            return cv2.convertScaleAbs(images, alpha=255), on_ground
        start = int(self._rng.integers(NOISE_BANK_FRAMES)) * size
        noise = self._noise_bank[start : start + self.n_units * size]
        return cv2.addWeighted(images, 255, noise, 1, 0, dtype=cv2.CV_8U), on_ground

    def views(self, positions: np.ndarray, orientations: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Where each sensor looks: (N, 2) ground point at the image centre (m), (N, 2, 2) ground footprint of one
        image pixel along the image columns and rows (m), and (N,) whether it is on the ground."""
        axes = rotation_matrices(orientations)  # columns: the unit's forward, left and up axes in the world
        mount = positions + axes @ self._mount
        up = axes[:, :, 2]
        facing = up[:, 2] > MIN_COS_TILT
        up_z = np.where(facing, up[:, 2], 1.0)  # keeps the projection finite for sensors that see no ground
        # Project along the optical axis onto the ground (z = 0): an axis a lands on a - (a_z / up_z) up.
        centres = mount[:, :2] - (mount[:, 2] / up_z)[:, None] * up[:, :2]
        footprints = axes[:, :2, :2] - up[:, :2, None] * (axes[:, 2, :2] / up_z[:, None])[:, None, :]
        on_ground = facing & (mount[:, 2] <= self.params.liftoff_height)
        return centres, footprints * self.params.pixel_size, on_ground


def rotation_matrices(orientations: np.ndarray) -> np.ndarray:
    """(N, 3, 3) rotation matrices from (N, 4) quaternions (x, y, z, w); column j is the body's axis j in the world."""
    q = np.asarray(orientations, dtype=float)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    x, y, z, w = q.T
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=1),
        ],
        axis=1,
    )


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
        number(key, -math.inf, inclusive=False, unit="m")
    size = params.patch_size
    if isinstance(size, bool) or not isinstance(size, int) or not MIN_PATCH <= size <= MAX_PATCH:
        raise ConfigError(source, "patch_size", f"an integer number of pixels in [{MIN_PATCH}, {MAX_PATCH}]", size)
