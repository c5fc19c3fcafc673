"""The optical sensor: each unit films the ground under it, like an optical mouse, and integrates the image motion.

Each frame, for every unit (the work is done for many frames and all units at once, see Cost below):
1. Pose -> view. The sensor sits at the mount point (unit frame) and looks along the unit's own down axis. The
   image's columns run along the unit's forward axis and its rows along its left axis, so forward motion is image
   motion along the columns. Tilt is modelled for a telecentric (orthographic) lens: the image is projected along
   the optical axis onto the ground, so a tilted sensor sees a stretched footprint and reports a ground motion
   along the tilt direction shortened by cos(tilt). The footprint is centred on the mount point itself, not on
   where the tilted optical axis meets the ground: the two differ by at most ``liftoff_height * tan(tilt)``. The
   image scale does not change with height (no perspective); instead the sensor sees nothing above
   ``liftoff_height``, as a lifted mouse does.
2. View -> frame: the ground patch is cut from the texture (``GroundTexture.patches``, one remap for all views),
   optionally blurred, given Gaussian pixel noise and quantised to 8 bits (OpenCV's Lucas-Kanade needs 8-bit
   images, and real sensors have 6-8 bit pixels).
3. Two frames -> shift: pyramidal Lucas-Kanade tracks the centre of the previous frame into the current one
   (``ShiftEstimator``), for dozens of views per OpenCV call, stacked (and kept apart) in one image.
   When tracking fails (no convergence, a shift that takes the tracking window out of the patch, or a residual
   that shows a wrong match) the frame reports no motion and counts in ``lost_frames``. A unit turning between two
   frames rotates the image about the tracked point, which reads as a small false shift: about 0.04 px per degree
   of turn on average, at most about 0.07.
4. Shift -> displacement: the image moves opposite to the unit, so the forward displacement is minus the column
   shift times the pixel size. A frame reports motion only if the sensor was on the ground at both of its ends.

Cost: ``sample`` only records the poses (and draws the noise). The frames are rendered and compared in batches,
when the displacement is read or when ``BATCH_VIEWS`` unit-frames are waiting: a few dozen numpy/OpenCV calls then
serve dozens of frames of every unit, and what remains per unit and frame is one Lucas-Kanade point, one patch to
cut and one noise frame to add, about 15 us. Batching changes a result only by float rounding (at most about 1e-3 px
per frame).
"""

from __future__ import annotations


import cv2
import numpy as np

from morphbench.params import OpticalParams
from morphbench.rules import check_params
from morphbench.sensing.base import Sensor
from morphbench.sensing.ground import GroundTexture

MIN_COS_TILT = 0.5
"""A sensor tilted more than 60 degrees (unit on its side or upside down) sees no ground."""
NOISE_BANK_FRAMES = 256
"""Pre-drawn noise frames. Drawing fresh Gaussian noise costs about 9 us per unit per frame, as much as the rest of
the frame; each unit's frame instead takes a noise frame from the bank at random. A unit gets the same noise in two
consecutive frames with probability 1 / NOISE_BANK_FRAMES, when the noise adds no error to that frame's shift,
which is harmless."""
MAX_STACK_ROWS = 2048
"""px, tallest stacked image per Lucas-Kanade call. OpenCV tracks in float32 image coordinates, which resolve 1e-4 px
only up to about 2000 px; the call's fixed cost is still shared by many views (39 of 32 px with their gaps)."""
BATCH_VIEWS = 2048
"""Most unit-frames held before they are rendered and compared: bounds the batch's memory (about 17 kB per view at
32 px while it is processed, 35 MB in all)."""
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
    """Sub-pixel image shifts between pairs of 8-bit frames, for many views at once.

    Pyramidal Lucas-Kanade on the centre point of each view, with a window of about 0.4 patch, in one OpenCV call
    per ``chunk`` views stacked vertically (on 32 px patches at 1 % noise, about 0.03 px mean error for shifts up to
    about 6 px). A window of half the patch is about 12 % more accurate and 25 % slower.

    The views are stacked with flat grey gaps around them, wide enough that no window, interpolation, derivative or
    pyramid filter of one view ever reads another's pixels: each view's shift depends on that view alone, not on
    which views share the call.
    """

    LEVELS = 1
    """Pyramid levels above the frame: enough for shifts up to the window's travel limit (more changed nothing in
    tests), and few enough that the gaps stay narrow."""

    def __init__(self, patch_size: int, noise_levels: float = 0.0):
        """``noise_levels``: standard deviation of the frames' pixel noise in grey levels (0-255)."""
        self.patch_size, self.noise_levels = patch_size, noise_levels
        side = 2 * patch_size // 5 | 1  # odd, and leaves over a quarter of the patch for the window to move into
        self.window = (side, side)
        self.max_shift = (patch_size - side) / 2
        """px, largest shift accepted: beyond it the window leaves the patch. Tracking is nearly always right up to
        about 0.2 patch (6 px at 32 px: 99.8 % of shifts tracked), then fails more and more often (9 px: 67 %)."""
        # A window reaches max_shift + side / 2 + 2 (interpolation, derivative) px, about 0.5 patch + 2, beyond its
        # view's edge at level 0, half that at level 1, where a neighbour's pyramid filter also reaches 1 px into the
        # gap. Gap and cell are even so that every view meets the pyramid's sampling grid in the same way.
        self.gap = 2 * (patch_size // 4 + 2)
        """px, rows of grey before the first view, between views and after the last."""
        self.cell = self.gap + patch_size + patch_size % 2
        """px, rows per view in the stacked image: a gap, then the view."""
        self._criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 20, 0.003)
        first = (patch_size - side) // 2
        self._window_slice = slice(first, first + side)
        self.chunk = max(1, (MAX_STACK_ROWS - self.gap) // self.cell)
        """views per Lucas-Kanade call."""
        centre = (patch_size - 1) / 2
        rows = np.arange(self.chunk) * self.cell + self.gap + centre
        self._points = np.stack([np.full(self.chunk, centre), rows], axis=1).astype(np.float32).reshape(-1, 1, 2)
        """(chunk, 1, 2) centre points of the views in one spaced stack."""

    def __call__(self, previous: np.ndarray, current: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(N, 2) px shift (column, row) of the image content of each view from ``previous`` to ``current``, both
        (N * patch_size, patch_size) stacks of N views, and (N,) whether each was tracked; an untracked view's shift
        is 0."""
        size = self.patch_size
        n = previous.shape[0] // size
        shifts = np.empty((n, 2), np.float32)
        status = np.empty(n, bool)
        residual = np.empty(n, np.float32)
        for first in range(0, n, self.chunk):
            last = min(first + self.chunk, n)
            rows, points = slice(first * size, last * size), self._points[: last - first]
            moved, found, error = cv2.calcOpticalFlowPyrLK(
                self._spaced(previous[rows]), self._spaced(current[rows]), points, None,
                winSize=self.window, maxLevel=self.LEVELS, criteria=self._criteria,
            )
            shifts[first:last] = (moved - points)[:, 0]
            status[first:last], residual[first:last] = found[:, 0], error[:, 0]
        window = self._window_slice
        contrast = previous.reshape(n, size, size)[:, window, window].std(axis=(1, 2))
        tracked = (
            status
            & (np.abs(shifts).max(axis=1) <= self.max_shift)
            & (residual <= np.maximum(MAX_RESIDUAL * contrast, self.noise_levels))
        )
        return shifts * tracked[:, None], tracked

    def _spaced(self, frames: np.ndarray) -> np.ndarray:
        """The stacked views with mid-grey gaps around each."""
        size = self.patch_size
        n = frames.shape[0] // size
        spaced = np.full((n * self.cell + self.gap, size), 128, np.uint8)
        cells = spaced[: n * self.cell].reshape(n, self.cell, size)
        cells[:, self.gap : self.gap + size] = frames.reshape(n, size, size)
        return spaced


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
        check_params(params, source)
        self.params, self.ground, self.n_units = params, ground, n_units
        self.sample_period = 1.0 / params.frame_rate
        self._pose_table = _pose_table(np.array([params.mount_x, params.mount_y, -params.mount_depth]))
        self._estimator = ShiftEstimator(params.patch_size, 255 * params.noise)
        self._rng = rng
        size = params.patch_size
        bank = rng.standard_normal((NOISE_BANK_FRAMES, size, size), dtype=np.float32)
        self._noise_bank = bank * np.float32(255 * params.noise)
        # Poses and noise frame indices of the frames not rendered yet, oldest first.
        self._pending: list[tuple[np.ndarray, np.ndarray, np.ndarray | None]] = []
        self._frame: np.ndarray | None = None  # newest rendered frame of every unit, stacked, or None before any
        self._on_ground = np.zeros(n_units, dtype=bool)  # whether each unit's sensor was on the ground in it
        self._columns_moved = np.zeros(n_units)  # px, summed image shift along the forward axis, sign of the unit
        self._lost = np.zeros(n_units, dtype=int)

    def reset(self, positions: np.ndarray, orientations: np.ndarray) -> None:
        self._pending.clear()
        self._frame = None
        self._columns_moved = np.zeros(self.n_units)
        self._lost = np.zeros(self.n_units, dtype=int)
        self._record(np.array(positions, dtype=float)[None], np.array(orientations, dtype=float)[None])

    def sample(self, positions: np.ndarray, orientations: np.ndarray) -> None:
        self.sample_many(np.asarray(positions)[None], np.asarray(orientations)[None])

    def sample_many(self, positions: np.ndarray, orientations: np.ndarray) -> None:
        if self._frame is None and not self._pending:
            raise RuntimeError("OpticalSensor.sample before reset: reset gives the first frame")
        positions, orientations = np.array(positions, dtype=float), np.array(orientations, dtype=float)  # held
        first = 0
        while first < len(positions):  # in batches of BATCH_VIEWS views, as many as fill the pending batch
            last = first + max(1, -(-(BATCH_VIEWS - self._pending_count()) // self.n_units))
            self._record(positions[first:last], orientations[first:last])
            if self._pending_count() >= BATCH_VIEWS:
                self._integrate()
            first = last

    def displacement(self) -> np.ndarray:
        self._integrate()
        return self._columns_moved * self.params.pixel_size

    @property
    def lost_frames(self) -> np.ndarray:
        """(N,) frames since the last reset in which a unit's sensor was on the ground but could not track the
        image (and so reported no motion)."""
        self._integrate()
        return self._lost.copy()

    def frames(
        self, positions: np.ndarray, orientations: np.ndarray, noise_frames: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """What sensors see at M poses (any number, e.g. every unit at several times): the 8-bit frames stacked
        vertically, (M * patch_size, patch_size), and (M,) whether each sensor is on the ground (low enough and
        facing it). ``noise_frames``: (M,) indices of the noise bank's frames to add (drawn from the sensor's noise
        stream if omitted). Poses as in ``views``."""
        affines, on_ground = self.views(positions, orientations)
        size, m = self.params.patch_size, len(affines)
        images = self.ground.patches(affines, size)
        if self.params.blur > 0:
            for image in images:
                cv2.GaussianBlur(image, (0, 0), self.params.blur, dst=image)
        images = images.reshape(m * size, size)
        if self.params.noise == 0:
            return cv2.convertScaleAbs(images, alpha=255), on_ground
        if noise_frames is None:
            noise_frames = self._rng.integers(NOISE_BANK_FRAMES, size=m)
        noise = self._noise_bank[noise_frames].reshape(m * size, size)
        return cv2.addWeighted(images, 255, noise, 1, 0, dtype=cv2.CV_8U), on_ground

    def views(self, positions: np.ndarray, orientations: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Where sensors at M poses ((M, 3) unit centres in m, (M, 4) unit quaternions x, y, z, w, as PyBullet gives
        them) look: (M, 2, 3) affine maps from image pixel offsets (u, v, 1) to ground points (m), as
        ``GroundTexture.patches`` takes them, and (M,) whether each sensor is on the ground.

        Projected along the optical axis (the unit's up axis, column 2 of its rotation R), the image axes land on
        the ground as R's first two columns minus (their z / R22) times the third. That 2 x 2 footprint equals
        [[R11, -R10], [-R01, R00]] / R22 (a rotation matrix equals its own cofactor matrix), so one einsum of the
        quaternions gives footprint, tilt and mount point for every pose at once.
        """
        pose = np.einsum("ni,nj,ijk->nk", orientations, orientations, self._pose_table)
        up_z = pose[:, 4]
        mount = positions + pose[:, 5:]
        affines = np.empty((len(pose), 2, 3))
        # up_z is clamped for sensors that see no ground, which keeps their (unused) views finite.
        scale = self.params.pixel_size / np.maximum(up_z, MIN_COS_TILT)
        affines[:, :, :2] = (pose[:, :4] * scale[:, None]).reshape(-1, 2, 2)
        affines[:, :, 2] = mount[:, :2]
        on_ground = (up_z > MIN_COS_TILT) & (mount[:, 2] <= self.params.liftoff_height)
        return affines, on_ground

    def _record(self, positions: np.ndarray, orientations: np.ndarray) -> None:
        """Hold K frames of every unit: (K, N, 3) positions and (K, N, 4) quaternions."""
        k, n = len(positions), self.n_units
        if positions.shape[1:] != (n, 3) or orientations.shape != (k, n, 4):
            raise ValueError(f"expected poses of {n} units, (N, 3) and (N, 4), "
                             f"got {positions.shape[1:]} and {orientations.shape[1:]}")
        # Noise is drawn now, frame by frame, so the results do not depend on when the frames are processed.
        noise_frames = np.concatenate([self._rng.integers(NOISE_BANK_FRAMES, size=n) for _ in range(k)]) \
            if self.params.noise else None
        self._pending.append((positions.reshape(k * n, 3), orientations.reshape(k * n, 4), noise_frames))

    def _pending_count(self) -> int:
        """Unit-frames held, not rendered yet."""
        return sum(len(positions) for positions, _, _ in self._pending)

    def _integrate(self) -> None:
        """Render the pending frames and add their motion, all units and frames in one batch."""
        if not self._pending:
            return
        positions, orientations, noise_frames = zip(*self._pending)
        self._pending.clear()
        noise = None if self.params.noise == 0 else np.concatenate(noise_frames)
        frames, on_ground = self.frames(np.concatenate(positions), np.concatenate(orientations), noise)
        if self._frame is not None:  # the newest frame of the previous batch is this batch's first reference
            frames = np.concatenate([self._frame, frames])
            on_ground = np.concatenate([self._on_ground, on_ground])
        rows = self.n_units * self.params.patch_size
        self._frame, self._on_ground = frames[-rows:].copy(), on_ground[-self.n_units :]
        if len(frames) == rows:
            return
        shifts, tracked = self._estimator(frames[:-rows], frames[rows:])
        valid = on_ground[: -self.n_units] & on_ground[self.n_units :]
        # The image moves opposite to the unit. Views are ordered frame by frame, unit by unit.
        self._columns_moved -= (shifts[:, 0] * valid).reshape(-1, self.n_units).sum(axis=0)
        self._lost += (valid > tracked).reshape(-1, self.n_units).sum(axis=0)
