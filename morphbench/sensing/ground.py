"""The textured ground under the units: what their optical sensors look at (pure numpy/OpenCV, no simulator).

The texture is one tile, a grey image in [0, 1] whose column index runs along the world x axis and whose row index
runs along the world y axis, ``resolution`` metres per pixel. The tile is centred on the world origin: it covers
x in [-length / 2, length / 2) and y in [-width / 2, width / 2), so units that start near the origin are far from
its edges (a patch across an edge takes OpenCV's slower border path). It repeats without end in both directions, so
a unit can travel any distance without leaving it. A procedural tile is periodic (its noise is smoothed across the
edges), so the repetition has no seam; an image file usually has seams where its opposite edges meet.

Patches are cut with ``cv2.remap``: bilinear, sub-pixel. OpenCV rounds positions to 1/32 of a texture pixel; for a
translating view the rounding errors of consecutive frames cancel in the summed displacement.
"""

from __future__ import annotations

import functools
import math
from pathlib import Path

import cv2
import numpy as np

from morphbench.errors import ConfigError
from morphbench.files import is_file
from morphbench.params import GroundParams
from morphbench.rules import check_params

MAX_TEXTURE_PIXELS = 64_000_000
"""Largest tile, in pixels (256 MB as float32): a larger one is almost certainly a mistake of units."""
MIN_TEXTURE_PIXELS = 8
"""Smallest side of a tile, in pixels."""
MAX_REMAP_ROWS = 32767 - 1
"""OpenCV's remap takes images under 32767 px a side: the largest tile side, and the most rows of patches cut in one
call."""


class GroundTexture:
    """One tile of ground texture, repeated over the whole plane; cuts the patch a sensor sees at any pose."""

    def __init__(self, params: GroundParams = GroundParams(), *, source: str = "GroundParams"):
        """Make the procedural tile of ``params``, or load ``params.image``. Bad input raises ``ConfigError``
        naming ``source`` (the file or table the parameters came from) and the key."""
        _check(params, source)
        self.params = params
        self.resolution = params.resolution
        """m, ground size of one texture pixel."""
        self.image = _load(params, source) if params.image else _procedural(params)
        """float32 (rows along world y, columns along world x) grey levels in [0, 1]; one tile."""
        self.image.setflags(write=False)
        self._tile_px = np.array([[self.image.shape[1]], [self.image.shape[0]]], dtype=float)  # (x, y) periods, px
        self._origin_px = self._tile_px / 2 - 0.5  # texture coordinates of the world origin (remap: pixel centres)

    @property
    def extent(self) -> tuple[float, float]:
        """m, size of one tile along the world x and y axes: it covers [-x / 2, x / 2) by [-y / 2, y / 2) and repeats
        with this period."""
        rows, cols = self.image.shape
        return cols * self.resolution, rows * self.resolution

    def patch(self, x: float, y: float, yaw: float, size_px: int, m_per_px: float) -> np.ndarray:
        """The ``size_px`` x ``size_px`` float32 image seen straight down from above ground point (x, y) m.

        Image columns run along the unit's forward axis (world angle ``yaw``, rad), rows along its left axis
        (yaw + 90 degrees); each image pixel covers ``m_per_px`` metres of ground and the point (x, y) is at the
        image centre, ((size_px - 1) / 2, (size_px - 1) / 2).
        """
        c, s = math.cos(yaw) * m_per_px, math.sin(yaw) * m_per_px
        return self.patches(np.array([[[c, -s, x], [s, c, y]]]), size_px)[0]

    def patches(self, affines: np.ndarray, size_px: int) -> np.ndarray:
        """(N, size_px, size_px) float32 images, one per view, cut in one vectorised remap per thousand views.

        ``affines``: (N, 2, 3), for each view the map from an image pixel's offset (u, v, 1) from the image centre
        (u along the columns, v along the rows) to the ground point (x, y) it shows, in metres. The first two columns
        are the ground steps of one pixel along u and v (a rotation times the pixel size for a sensor looking
        straight down), the third the ground point at the image centre.
        """
        n = len(affines)
        per_call = MAX_REMAP_ROWS // size_px
        if n > per_call:
            return np.concatenate([self.patches(affines[k : k + per_call], size_px) for k in range(0, n, per_call)])
        rows = np.asarray(affines, dtype=float).transpose(1, 0, 2) / self.resolution  # texture px; x rows, then y rows
        # Wrap the centres into the tile so coordinates stay small (float32 keeps them exact); BORDER_WRAP does the
        # rest.
        rows[:, :, 2] = (rows[:, :, 2] + self._origin_px) % self._tile_px
        # Every pixel's texture coordinates, already laid out as remap's two maps: a per-row part plus a per-column
        # part, added in one broadcast pass. Element-wise, not a matrix product: BLAS rounds differently for
        # different numbers of views, and a patch must not depend on which other patches are cut with it.
        steps = rows.reshape(2 * n, 3, 1).astype(np.float32)
        offsets = _pixel_offsets(size_px)
        maps = (steps[:, 0] * offsets + steps[:, 2])[:, None, :] + (steps[:, 1] * offsets)[:, :, None]
        x_map, y_map = maps.reshape(2, n * size_px, size_px)
        views = cv2.remap(self.image, x_map, y_map, cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP)
        return views.reshape(n, size_px, size_px)


@functools.cache
def _pixel_offsets(size_px: int) -> np.ndarray:
    """(size_px,) float32 offsets of a square image's columns (or rows) from its centre."""
    return np.arange(size_px, dtype=np.float32) - np.float32((size_px - 1) / 2)


def _check(params: GroundParams, source: str) -> None:
    check_params(params, source)
    if not params.image:
        shape = (round(params.width / params.resolution), round(params.length / params.resolution))
        about = f"{params.length} m x {params.width} m at {params.resolution} m/px"
        _check_size(shape, source, "length, width, resolution", about)


def _check_size(shape: tuple[int, int], source: str, key: str, about: str) -> None:
    if min(shape) < MIN_TEXTURE_PIXELS or max(shape) > MAX_REMAP_ROWS or shape[0] * shape[1] > MAX_TEXTURE_PIXELS:
        expected = (
            f"a tile of {MIN_TEXTURE_PIXELS} to {MAX_REMAP_ROWS:,} px a side and at most {MAX_TEXTURE_PIXELS:,} px"
        )
        raise ConfigError(source, key, expected, f"{shape[1]} x {shape[0]} px ({about})")


def _procedural(params: GroundParams) -> np.ndarray:
    """Band-limited noise: white noise smoothed by a Gaussian of ``grain`` metres, periodic, scaled by contrast."""
    rows, cols = round(params.width / params.resolution), round(params.length / params.resolution)
    white = np.random.default_rng(params.seed).standard_normal((rows, cols), dtype=np.float32)
    sigma = params.grain / params.resolution
    # Pad with the opposite edges before smoothing so the tile is periodic: no seam where it repeats.
    pad = min(math.ceil(4 * sigma), rows, cols)
    smooth = cv2.GaussianBlur(np.pad(white, pad, mode="wrap"), (0, 0), sigma)[pad:-pad, pad:-pad]
    smooth = (smooth - smooth.mean()) / smooth.std()
    return np.clip(0.5 + smooth * (params.contrast / 6), 0.0, 1.0).astype(np.float32)


def _load(params: GroundParams, source: str) -> np.ndarray:
    path = Path(params.image)
    if not is_file(path):
        raise ConfigError(source, "image", "an existing image file (PNG, JPEG, BMP, TIFF, ...)", params.image)
    image = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    if image is None:
        raise ConfigError(source, "image", "an image file OpenCV can read (PNG, JPEG, BMP, TIFF, ...)", params.image)
    _check_size(image.shape, source, "image", params.image)
    return image.astype(np.float32) / 255.0
