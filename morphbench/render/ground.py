"""The ground of a video frame: a checker of 5 cm squares on the plane z = 0, drawn without the simulator.

Every pixel that shows no body is mapped back to the ground plane through the camera's homography and shaded with a
box-filtered checker (no aliasing near the horizon). TinyRenderer rasterises a textured ground over the whole frame
at ~0.1 s a frame at 640x360; drawn here it costs a few milliseconds. Seen from straight above (``top_image``, the
top view) the checker is the product of one square wave along the columns and one along the rows.
"""

from __future__ import annotations

import cv2
import numpy as np

CHECKER = 0.05
"""m, side of a ground square."""
GROUND_GREYS = (172.0, 208.0)
"""grey levels (0..255) of the dark and light ground squares."""
SKY = (214, 222, 232)
"""RGB of whatever is above the horizon (only seen at shallow pitches)."""


class GroundRasteriser:
    """The ground as one camera of a fixed ``projection`` (PyBullet's, a flat list of 16) sees it in frames of
    ``width`` x ``height`` pixels; the image of the last view is kept, a fixed camera draws it once."""

    def __init__(self, width: int, height: int, projection):
        self.width, self.height = width, height
        self._projection = projection
        self._cols = np.arange(width, dtype=np.float32)
        self._rows = np.arange(height, dtype=np.float32) + 1  # TinyRenderer's row r is at viewport y = r + 1
        self._cache: tuple[tuple, np.ndarray] | None = None

    def image(self, view) -> np.ndarray:
        """(height, width, 3) uint8: the checkered ground plane z = 0 (and sky above the horizon) seen through
        ``view``. Each pixel is mapped to the ground by the inverse of the plane's homography and shaded with the
        checker averaged over the pixel's footprint."""
        key = tuple(view)
        if self._cache is not None and self._cache[0] == key:
            return self._cache[1]
        width, height = self.width, self.height
        clip = np.array(self._projection).reshape(4, 4).T @ np.array(view).reshape(4, 4).T
        to_pixels = np.array([[width / 2, 0, width / 2], [0, -height / 2, height / 2], [0, 0, 1]])
        inverse = np.linalg.inv(to_pixels @ clip[[0, 1, 3]][:, [0, 1, 3]]).astype(np.float32)
        u, v = self._cols[None, :], self._rows[:, None]
        gx, gy, gs = ((inverse[i, 0] * u) + (inverse[i, 1] * v + inverse[i, 2]) for i in range(3))
        ahead = gs > 0  # the pixel's ray meets the ground in front of the camera
        gs = np.where(ahead, gs, np.float32(1))
        x, y = gx / gs, gy / gs
        shade = np.ones_like(x)
        for coord, row in ((x, 0), (y, 1)):
            # footprint of one pixel along this ground axis, from the derivatives of the projective map
            footprint = (np.abs((inverse[row, 0] - coord * inverse[2, 0]) / gs)
                         + np.abs((inverse[row, 1] - coord * inverse[2, 1]) / gs))
            footprint = np.maximum(footprint, np.float32(CHECKER * 1e-3))
            shade *= (_square_wave_integral(coord + footprint / 2) - _square_wave_integral(coord - footprint / 2)) \
                / footprint
        np.nan_to_num(shade, copy=False)  # rays grazing the horizon: a footprint of inf shades mid-grey
        dark, light = GROUND_GREYS
        grey = ((dark + light) / 2 + (light - dark) / 2 * shade).astype(np.uint8)
        image = cv2.cvtColor(grey, cv2.COLOR_GRAY2RGB)
        image[~ahead] = SKY
        self._cache = (key, image)
        return image


def top_image(x: np.ndarray, y: np.ndarray, pixel: float) -> np.ndarray:
    """(len(y), len(x), 3) uint8: the checkered ground seen from straight above, ``x`` (m) the ground coordinate of
    each column's pixel centres, ``y`` (m) each row's, ``pixel`` (m) a pixel's side; each pixel shaded with the
    checker averaged over its square (squares smaller than a pixel blend into grey instead of flickering)."""
    half = pixel / 2
    along_x, along_y = ((_square_wave_integral(np.asarray(c, dtype=np.float64) + half)
                         - _square_wave_integral(np.asarray(c, dtype=np.float64) - half)) / pixel for c in (x, y))
    dark, light = GROUND_GREYS
    grey = ((dark + light) / 2 + (light - dark) / 2 * np.outer(along_y.astype(np.float32), along_x.astype(np.float32)))
    return cv2.cvtColor(grey.astype(np.uint8), cv2.COLOR_GRAY2RGB)


def _square_wave_integral(z: np.ndarray) -> np.ndarray:
    """Integral from 0 to z of the square wave that is +1 on [0, CHECKER) and -1 on [CHECKER, 2 CHECKER): a triangle
    wave between 0 and CHECKER. (floor rather than np.mod: ten times faster on float32.)"""
    cycles = z * np.float32(0.5 / CHECKER)
    fraction = cycles - np.floor(cycles)
    return np.float32(CHECKER) * (1 - np.abs(2 * fraction - 1))
