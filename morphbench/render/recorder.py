"""What every video of a world shares, whatever draws its frames: when a frame is due, what the overlay says, the
units' colours, and the output file. ``VideoRecorder`` (render.video, the 3-D camera) and ``TopDownRecorder``
(render.topdown, footprints seen from above) draw; ``render.views.open_recorder`` picks one for a shape
(``VideoParams.view``).

A recorder is an ``on_tick`` observer: every ``speed / fps`` simulated seconds it draws one frame. Frames are written
(``render.writers``) to a temporary file beside the output and renamed onto it by ``close()``; ``abort()`` (or leaving
the ``with`` block by an exception) removes it, so a half-written video is never left behind. Parameters and the
output path are checked first (``render.checks``).
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping

import cv2
import numpy as np

from morphbench.errors import ConfigError
from morphbench.files import Replacement
from morphbench.params import VideoParams
from morphbench.render.checks import CLI_OPTIONS, GIF_MAX_FPS, check_output_path, check_video_params
from morphbench.render.writers import open_writer
from morphbench.shapes.colours import DAMAGED_RGBA, phase_rgb, pressure_rgb

FOV = 40.0
"""degrees, vertical field of view of the side camera (the top view shows what it would see from ``distance``)."""
FILL = 0.55
"""fraction of the frame's width (or depth) the assembly takes when the camera distance is picked automatically."""


class Recorder:
    """Draws a world every ``params.speed / params.fps`` simulated seconds into ``path`` (.mp4 or .gif).

    Use it as the ``on_tick`` observer of ``run()`` or ``measure()``::

        with VideoRecorder(None, "out.mp4", VideoParams(speed=10)) as video:
            records = run(config, progress=video.progress, on_tick=video)

    ``world`` may be None: the recorder then attaches to the world of the first tick it sees (``run()`` builds its
    world itself). One recorder serves one world.

    What the overlay shows besides time comes from ``set_status(step=..., ubar=..., phases=..., kept=...)``, which
    ``progress`` (run()'s progress callback) calls after every learning step, and/or from ``status()``, a callable
    returning a mapping with any of the same keys, asked at every frame. ``step`` is the learning step just
    finished (as given to run()'s progress callback): the frames that follow show step + 1 in progress (before any
    status, step 0, which includes the warm-up); ``ubar`` (mm/cycle) is that finished step's; ``phases`` (one per
    unit, front to rear) default to the world's current phases, the ones the pumps are running; ``kept`` (one per
    unit, the world's unit order) are the learners' kept phases that ``colour = "phase"`` shows, the world's phases
    until a step has ended (step 0 measures the initial phases).

    ``damaged``: units (0-based, front to rear, as ``world.phases``) drawn black; it can be changed at any time, and
    units that the world itself marks as damaged (``world.damage``) are drawn black too.

    After each frame, ``times`` (s), ``positions`` ((n_bodies, 3) m, every body's position) and ``frame_steps`` hold
    what it showed; ``frames`` counts the frames written.
    """

    def __init__(self, world, path: str | os.PathLike, params: VideoParams = VideoParams(),
                 status: Callable[[], Mapping[str, Any]] | None = None, *, damaged: Iterable[int] = (),
                 source: str = "--video"):
        self.params = check_video_params(params)
        self.path = check_output_path(path, source)
        self.format = self.path.suffix.lower()
        if self.format == ".gif" and params.fps > GIF_MAX_FPS:
            raise ConfigError(CLI_OPTIONS["fps"], "fps", f"at most {GIF_MAX_FPS:g} frames per second for a GIF "
                                                         "(browsers slow faster GIFs down); use .mp4", params.fps)
        self.status = status
        self.damaged = set(damaged)
        self.interval = params.speed / params.fps
        """s of simulated time between frames."""
        self.frames = 0
        self.times: list[float] = []
        self.positions: list[np.ndarray] = []
        self.frame_steps: list[int] = []
        self._source = source
        self._status: dict[str, Any] = {}
        self._output = Replacement(self.path)
        self._writer = open_writer(self._output.tmp, (params.width, params.height), params.fps, self.path, source)
        self._closed = False
        self.world = None
        if world is not None:
            self._attach(world)

    # -- status ------------------------------------------------------------------------------------------------------

    def set_status(self, *, step: int | None = None, ubar: float | None = None, phases=None, kept=None) -> None:
        """What the overlay and the colours show from now on (see the class docstring); None leaves a value as it
        was."""
        for key, value in (("step", step), ("ubar", ubar), ("phases", phases), ("kept", kept)):
            if value is not None:
                self._status[key] = value

    def progress(self, step: int, records) -> None:
        """run()'s ``progress(step, records)`` callback: learning step ``step`` has finished with Ubar
        ``records.last_ubar`` and the kept phases ``records.last_kept_by_place()``."""
        self.set_status(step=step, ubar=records.last_ubar, kept=records.last_kept_by_place())

    def current_status(self) -> dict[str, Any]:
        status = dict(self._status)
        if self.status is not None:
            status.update({k: v for k, v in (self.status() or {}).items() if v is not None})
        return status

    @property
    def step(self) -> int:
        """The learning step in progress: one after the last finished step, 0 before any."""
        finished = self.current_status().get("step")
        return 0 if finished is None else int(finished) + 1

    def _shows(self, step: int) -> bool:
        if self.params.steps is None:
            return True
        first, last = self.params.steps
        return first <= step and (last is None or step <= last)

    # -- observer ----------------------------------------------------------------------------------------------------

    def _attach(self, world) -> None:
        """Start recording ``world``: the subclass sets up its drawing after this."""
        self.world = world
        link_units = np.asarray(world.link_units)
        driven = np.flatnonzero(link_units >= 0)
        self._driven = driven[np.argsort(link_units[driven], kind="stable")]
        """the driven links grouped by their unit (world order): a unit's colour is their highest pressure."""
        self._driving, self._first_link = np.unique(link_units[self._driven], return_index=True)
        """the units that drive a link, and where each one's links start in ``_driven``."""
        positions, _ = world.poses()
        self._target = positions.mean(axis=0)
        self._target_time = world.time
        self._start = world.time
        self._slots = 0  # frame times passed so far: start, start + interval, ...

    def __call__(self, world=None) -> None:
        """The ``on_tick(world)`` observer: renders the frames that are due at the world's current time."""
        if self._closed:
            raise RuntimeError(f"this {type(self).__name__} is closed")
        if self.world is None:
            if world is None:
                raise ValueError(f"{type(self).__name__} was given no world")
            self._attach(world)
        elif world is not None and world is not self.world:
            raise ValueError("one recorder records one world; make a new one for another world")
        slots = math.floor((self.world.time - self._start) / self.interval + 1e-6) + 1
        due = slots - self._slots
        if due <= 0:
            return
        self._slots = slots
        positions, _ = self.world.poses()
        self._follow(positions)
        step = self.step
        if not self._shows(step):
            return
        frame = self.render(step)
        for _ in range(due):  # slower than one frame per tick: repeat the frame so the video keeps its speed
            self._writer.write(frame)
        self.frames += due
        self.times.append(self.world.time)
        self.positions.append(positions)
        self.frame_steps.append(step)

    def _follow(self, positions: np.ndarray) -> None:
        if not self.params.follow:
            return
        elapsed = self.world.time - self._target_time
        self._target_time = self.world.time
        blend = 1.0 - math.exp(-elapsed / self.params.follow_time)
        self._target = self._target + blend * (positions.mean(axis=0) - self._target)

    # -- drawing -----------------------------------------------------------------------------------------------------

    def render(self, step: int | None = None) -> np.ndarray:
        """The frame for the world as it is now: (height, width, 3) uint8 RGB (``step``: the learning step the overlay
        names; default ``self.step``)."""
        raise NotImplementedError

    def unit_values(self) -> np.ndarray:
        """Per unit (the world's order), what its colour shows, 0..1: its bellows' pressure (the highest of the links
        its pump drives) or its kept phase (``params.colour``)."""
        world = self.world
        if self.params.colour == "phase":
            return np.mod(np.asarray(self.current_status().get("kept", world.phases), dtype=float), 1.0)
        values = np.zeros(world.shape.n_units)
        if len(self._driven):
            pressure = np.asarray(world.pressure, dtype=float)[self._driven]
            values[self._driving] = np.maximum.reduceat(pressure, self._first_link)
        return values

    def unit_damaged(self) -> np.ndarray:
        """Per unit (the world's order), whether it is drawn black: named in ``damaged`` or damaged in the world."""
        marked = np.array([bool(mode) for mode in self.world.damage], dtype=bool)
        marked[[k for k in self.damaged if 0 <= k < len(marked)]] = True
        return marked

    def unit_levels(self, levels: int) -> np.ndarray:
        """Per unit (the world's order), its row of ``colour_table(levels)``: its value (``unit_values``) quantised
        to ``levels`` colours (a frame changes a unit's colour only when it visibly changes), ``levels`` if
        damaged."""
        values = self.unit_values()
        if self.params.colour == "phase":
            index = np.round(values * levels).astype(int) % levels  # cyclic: a phase near 1 is a phase near 0
        else:
            index = np.round(np.clip(values, 0.0, 1.0) * (levels - 1)).astype(int)
        index[self.unit_damaged()] = levels
        return index

    def colour_table(self, levels: int) -> np.ndarray:
        """(levels + 1, 3) RGB (0..1): ``levels`` colours of ``params.colour``'s map (pressure 0 to 1, or phases
        0, 1 / levels, ... round the circle), then the damaged units' black."""
        k = np.arange(levels)
        rgb = phase_rgb(k / levels) if self.params.colour == "phase" else pressure_rgb(k / (levels - 1))
        return np.vstack([rgb, DAMAGED_RGBA[:3]])

    def _overlay_lines(self, step: int, status: Mapping[str, Any]) -> list[str]:
        """The overlay's text: time, step and the last Ubar."""
        ubar, finished = status.get("ubar"), status.get("step")
        lapse = f"   x{self.params.speed:g}" if self.params.speed != 1 else ""
        return [f"t {self.world.time:.1f} s   step {step}{lapse}",
                f"Ubar {ubar:+.2f} mm/cycle (step {finished})" if ubar is not None and np.isfinite(ubar)
                else "Ubar --"]

    def _overlay(self, frame: np.ndarray, step: int) -> None:
        """The overlay's lines, white on a darkened panel in the top left corner."""
        lines = self._overlay_lines(step, self.current_status())
        font, scale, margin = cv2.FONT_HERSHEY_SIMPLEX, font_scale(frame.shape[0]), 4
        text_height = cv2.getTextSize("Ag", font, scale, 1)[0][1]
        spacing = text_height + max(3, text_height // 2)
        width = max(cv2.getTextSize(line, font, scale, 1)[0][0] for line in lines) + 3 * margin
        panel = frame[:len(lines) * spacing + 2 * margin, :width]
        panel[:] = (panel * 0.45).astype(np.uint8)  # a dark panel keeps the text legible on any ground
        for i, line in enumerate(lines):
            cv2.putText(frame, line, (margin + 1, margin + text_height + i * spacing), font, scale, (255, 255, 255),
                        1, cv2.LINE_AA)

    # -- output ------------------------------------------------------------------------------------------------------

    def _release(self) -> None:
        """Free what the drawing holds (a render-only scene); called once the recorder closes or aborts."""

    def close(self) -> Path:
        """Finish the file and move it onto ``path``; returns the path. A recorder that wrote no frame leaves no file
        and raises ConfigError."""
        if self._closed:
            return self.path
        self._closed = True
        self._release()
        try:
            if self.frames == 0:
                raise ConfigError(self._source, str(self.path), "a video of at least one frame, but none was recorded "
                                  "(no simulated time passed, or --video-steps selects no step of the run)")
            self._writer.close()
            self._output.commit()
        finally:
            self._writer.abort()
            self._output.discard()
        return self.path

    def abort(self) -> None:
        """Stop without writing: the temporary file is removed and ``path`` is left as it was."""
        self._closed = True
        self._release()
        self._writer.abort()
        self._output.discard()

    @property
    def codec(self) -> str:
        """'h264' (PyAV), 'avc1' (H.264 through OpenCV), 'mp4v' (MPEG-4 part 2, OpenCV without H.264) or 'gif'."""
        return self._writer.codec

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, traceback) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()


def font_scale(height: int) -> float:
    """The overlay's font scale for frames ``height`` pixels high."""
    return max(0.3, 0.45 * height / 360)


def shape_extent(shape) -> tuple[np.ndarray, np.ndarray]:
    """m, the lowest and highest corner (x, y, z) of the box around the assembly at rest on the ground."""
    # each body's half-extents on the ground, turned with the assembly
    half = np.array([b.size for b in shape.bodies], dtype=float) / 2 @ np.abs(shape.rotation).T
    centres = shape.placed_positions()
    return np.min(centres - half, axis=0), np.max(centres + half, axis=0)
