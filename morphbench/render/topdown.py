"""The top view of a shape in one layer on the ground: every body its footprint (a rectangle of its length and width at
its pose), seen from straight above and drawn with numpy straight into the frame, no simulator.

TinyRenderer's side view costs more with every body; this view draws a sheet of 10,000 units, checkered ground and
overlay included, well above 30 frames per second on one core at 640x360 (benchmarks/render_speed.py --top;
benchmarks/RESULTS.md). ``TopDownRecorder`` is the ``Recorder`` (render.recorder) that draws it: +x runs to the right
and +y up, the frame centred on the assembly (followed, smoothed, as the side camera follows it); units coloured by
their bellows' pressure or by their kept phase on a cyclic map (``VideoParams.colour``), dummies grey, damaged units
black; an overlay with time, step, Ubar and a key to the colours.

``fill_rectangles`` is the rasteriser: a pixel belongs to a rectangle when its centre lies inside it (edges
included), so a rectangle whose sides fall between pixel centres covers exactly the pixels it should; where rectangles
overlap the later one is drawn over the earlier.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
import cv2
import numpy as np

from morphbench.render.ground import top_image
from morphbench.render.recorder import FILL, FOV, Recorder, font_scale, shape_extent
from morphbench.shapes.colours import DUMMY_RGBA

COLOUR_LEVELS = 256
"""pressures (or phases) are looked up in a table of this many colours: finer than the eye tells apart."""
CHUNK_PIXELS = 1 << 21
"""candidate pixels tested at once: bounds the rasteriser's memory whatever the rectangles' size on screen."""
MIN_SPAN = 2 * 0.15 * math.tan(math.radians(FOV) / 2)
"""m, the least ground a frame's height spans when it is fitted to the assembly (a side camera at least 15 cm away)."""
KEY_WIDTH = 0.3
"""fraction of the frame's width the colour key takes."""


@dataclass(frozen=True)
class TopView:
    """Which part of the ground a frame shows: ``left`` and ``top`` (m), the ground coordinates of its top left
    corner, and ``pixel`` (m), the side of one square pixel; columns run along +x, rows along -y."""

    left: float
    top: float
    pixel: float
    width: int
    height: int

    @classmethod
    def centred(cls, x: float, y: float, pixel: float, width: int, height: int) -> TopView:
        """The view of ``width`` x ``height`` pixels of side ``pixel`` centred on the ground point (x, y)."""
        return cls(x - width * pixel / 2, y + height * pixel / 2, pixel, width, height)

    def column_x(self) -> np.ndarray:
        """m, the ground x of each column's pixel centres."""
        return self.left + (np.arange(self.width) + 0.5) * self.pixel

    def row_y(self) -> np.ndarray:
        """m, the ground y of each row's pixel centres."""
        return self.top - (np.arange(self.height) + 0.5) * self.pixel


def fill_rectangles(frame: np.ndarray, view: TopView, centres: np.ndarray, half: np.ndarray, axes: np.ndarray,
                    colours: np.ndarray) -> None:
    """Draw rectangles into ``frame`` ((height, width, 3) uint8, seen through ``view``): rectangle k centred on
    ``centres[k]`` (x, y, m), half-extents ``half[k]`` (m) along its own axis ``axes[k]`` (a unit vector on the ground:
    a body's forward axis) and across it, in ``colours[k]`` (RGB uint8). Every pixel whose centre lies inside one is
    painted; later rectangles over earlier ones.

    All at once in numpy: each rectangle tests the pixels of the largest rectangle's bounding box around its own
    centre, in chunks of at most CHUNK_PIXELS candidates."""
    height, width = frame.shape[:2]
    scale = 1.0 / view.pixel
    # pixel coordinates: column u and row v, pixel (i, j) centred on (j + 0.5, i + 0.5)
    u = (np.asarray(centres[:, 0], dtype=np.float64) - view.left) * scale
    v = (view.top - np.asarray(centres[:, 1], dtype=np.float64)) * scale
    a, b = half[:, 0] * scale, half[:, 1] * scale
    c, s = axes[:, 0], axes[:, 1]
    reach_u = np.abs(a * c) + np.abs(b * s)  # half-extents of each rectangle's bounding box, in pixels
    reach_v = np.abs(a * s) + np.abs(b * c)
    first_col, last_col = np.ceil(u - reach_u - 0.5), np.floor(u + reach_u - 0.5)
    first_row, last_row = np.ceil(v - reach_v - 0.5), np.floor(v + reach_v - 0.5)
    seen = np.flatnonzero((last_col >= 0) & (first_col < width) & (last_row >= 0) & (first_row < height)
                          & (last_col >= first_col) & (last_row >= first_row))
    if not len(seen):
        return
    cols = int((last_col - first_col)[seen].max()) + 1
    rows = int((last_row - first_row)[seen].max()) + 1
    # a rectangle far larger than the frame tests no more than the frame's pixels
    cols, rows = min(cols, width + 1), min(rows, height + 1)
    first_col = np.clip(first_col, -1, width + 1 - cols)
    first_row = np.clip(first_row, -1, height + 1 - rows)
    per_chunk = max(1, CHUNK_PIXELS // (rows * cols))
    step_col, step_row = np.arange(cols, dtype=np.float32), np.arange(rows, dtype=np.float32)
    for start in range(0, len(seen), per_chunk):
        k = seen[start:start + per_chunk]
        j = first_col[k, None].astype(np.float32) + step_col  # (n, cols) column of each candidate
        i = first_row[k, None].astype(np.float32) + step_row  # (n, rows)
        dx = j + np.float32(0.5) - u[k, None].astype(np.float32)  # from the centre, in pixels, x to the right
        dy = v[k, None].astype(np.float32) - i - np.float32(0.5)  # and y up (rows run down)
        ck, sk = c[k, None, None].astype(np.float32), s[k, None, None].astype(np.float32)
        along = dx[:, None, :] * ck + dy[:, :, None] * sk
        across = dy[:, :, None] * ck - dx[:, None, :] * sk
        inside = ((np.abs(along) <= a[k, None, None]) & (np.abs(across) <= b[k, None, None])
                  & ((j >= 0) & (j < width))[:, None, :] & ((i >= 0) & (i < height))[:, :, None])
        n, r, q = np.nonzero(inside)  # in rectangle order: a later rectangle's pixels are written last
        frame[i[n, r].astype(np.intp), j[n, q].astype(np.intp)] = colours[k[n]]


def headings_of(orientations: np.ndarray) -> np.ndarray:
    """(N, 2) unit vectors: each body's forward axis on the ground, from (N, 4) quaternions (x, y, z, w)."""
    x, y, z, w = np.asarray(orientations, dtype=float).T
    axes = np.stack([1 - 2 * (y * y + z * z), 2 * (x * y + w * z)], axis=1)
    return axes / np.maximum(np.linalg.norm(axes, axis=1, keepdims=True), 1e-12)


def _rgb8(rgb) -> np.ndarray:
    return np.round(np.asarray(rgb, dtype=float) * 255).astype(np.uint8)


class TopDownRecorder(Recorder):
    """Draws a world of a shape in one layer every ``params.speed / params.fps`` simulated seconds into ``path`` (.mp4
    or .gif), seen from straight above (the ``Recorder`` docstring says how it is used). ``params.distance``, if set,
    shows as much ground as the side camera sees across the frame's height from that distance; otherwise the
    assembly at rest fills FILL of the frame's width or height."""

    def _attach(self, world) -> None:
        super()._attach(world)
        shape = world.shape
        width, height = self.params.width, self.params.height
        self._half = np.array([body.size[:2] for body in shape.bodies], dtype=float) / 2
        self._units = np.asarray(shape.units, dtype=np.intp)
        self._body_colours = np.tile(_rgb8(DUMMY_RGBA[:3]), (len(shape.bodies), 1))
        self._table = _rgb8(self.colour_table(COLOUR_LEVELS))
        if self.params.distance:
            span = 2 * self.params.distance * math.tan(math.radians(FOV) / 2)
        else:
            lows, highs = shape_extent(shape)
            extent = highs - lows
            span = max(extent[0] / FILL * height / width, extent[1] / FILL, MIN_SPAN)
        self._pixel = span / height
        """m, the side of one pixel on the ground."""
        self._key = self._draw_key()

    def render(self, step: int | None = None) -> np.ndarray:
        """The frame for the world as it is now: (height, width, 3) uint8 RGB (``step``: the learning step the overlay
        names; default ``self.step``)."""
        if self.world is None:
            raise ValueError("TopDownRecorder has no world yet: pass one, or let it see a tick first")
        positions, orientations = self.world.poses()
        view = TopView.centred(self._target[0], self._target[1], self._pixel, self.params.width, self.params.height)
        frame = top_image(view.column_x(), view.row_y(), view.pixel)
        self._body_colours[self._units] = self._table[self.unit_levels(COLOUR_LEVELS)]
        fill_rectangles(frame, view, positions[:, :2], self._half, headings_of(orientations), self._body_colours)
        if self.params.overlay:
            self._overlay(frame, self.step if step is None else step)
            key = self._key
            frame[-key.shape[0]:, :key.shape[1]] = key
        return frame

    def _draw_key(self) -> np.ndarray:
        """The key to the colours, for the bottom left corner: the colour map as a bar between its ends' names, white
        on a dark panel."""
        width, height = self.params.width, self.params.height
        font, scale, margin = cv2.FONT_HERSHEY_SIMPLEX, font_scale(height), 4
        phase = self.params.colour == "phase"
        low, high = ("kept phase 0", "1") if phase else ("pressure 0", "1")
        text_height = cv2.getTextSize("Ag", font, scale, 1)[0][1]
        low_width = cv2.getTextSize(low, font, scale, 1)[0][0]
        high_width = cv2.getTextSize(high, font, scale, 1)[0][0]
        bar = max(8, int(KEY_WIDTH * width))
        key_width = min(width, low_width + bar + high_width + 6 * margin)
        bar = max(1, key_width - low_width - high_width - 6 * margin)
        key = np.full((text_height + 3 * margin, key_width, 3), 40, np.uint8)
        baseline = margin + text_height
        cv2.putText(key, low, (margin, baseline), font, scale, (255, 255, 255), 1, cv2.LINE_AA)
        cv2.putText(key, high, (key_width - margin - high_width, baseline), font, scale, (255, 255, 255), 1,
                    cv2.LINE_AA)
        levels = self._table[:COLOUR_LEVELS]  # the damaged row left out
        along = np.minimum((np.arange(bar) * COLOUR_LEVELS) // bar, COLOUR_LEVELS - 1)
        start = low_width + 3 * margin
        key[margin:margin + text_height, start:start + bar] = levels[along][None, :, :]
        return key
