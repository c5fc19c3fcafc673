"""Off-screen video of a world: an ``on_tick`` observer that renders frames and writes an MP4 or a GIF.

``VideoRecorder`` is passed as ``on_tick`` to ``run()`` or ``measure()`` (or ``World.advance`` through a lambda). Every
``speed / fps`` simulated seconds it renders one frame:

- the bodies, with PyBullet's TinyRenderer (software, needs no display), through the world's own client; each active
  unit is coloured by the pressure of the bellows it drives, from blue (empty) to red (full); dummies are grey and
  damaged units black;
- the ground, a checker of 5 cm squares drawn by the recorder itself: every pixel that shows no body is mapped back to
  the ground plane through the camera's homography and shaded with a box-filtered checker (no aliasing near the
  horizon). TinyRenderer rasterises a textured ground over the whole frame at ~0.1 s a frame at 640x360; drawn here it
  costs a few milliseconds, and runs without a video pay nothing (the world itself is not touched but for colours);
- an overlay: simulated time, learning step, last Ubar and each unit's phase.

The camera looks along +y from the side and above, so forward (+x) motion runs left to right. It follows the
assembly's mean body position, smoothed over ``follow_time``, or stays where it started (``follow=False``).

Frames are written to a temporary file beside the output and renamed onto it by ``close()``; ``abort()`` (or leaving
the ``with`` block by an exception) removes it, so a half-written video is never left behind. MP4 is H.264 ('avc1',
plays in browsers) when this OpenCV build can encode it, MPEG-4 part 2 ('mp4v') otherwise; GIF goes through Pillow
with one fixed palette.
"""

from __future__ import annotations

import contextlib
import math
import os
import sys
import tempfile
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping

import cv2
import numpy as np
import pybullet as pb

from morphbench.errors import ConfigError
from morphbench.params import VideoParams
from morphbench.physics.geometry import body_shapes
from morphbench.shapes.export import DUMMY_RGBA, UNIT_RGBA

FORMATS = (".mp4", ".gif")
FOV = 40.0
"""degrees, vertical field of view of the camera."""
FILL = 0.55
"""fraction of the frame's width (or depth) the assembly takes when the camera distance is picked automatically."""
EMPTY_COLOUR = np.array(UNIT_RGBA[:3])
"""RGB (0..1) of a unit whose bellows is empty: the world's own unit blue."""
FULL_COLOUR = np.array([0.90, 0.15, 0.10])
"""RGB of a unit whose bellows is at full pressure."""
DUMMY_COLOUR = DUMMY_RGBA
DAMAGED_COLOUR = (0.05, 0.05, 0.05, 1.0)
COLOUR_LEVELS = 64
"""pressure is quantised to this many colours, so a body is recoloured only when its colour visibly changes."""
CHECKER = 0.05
"""m, side of a ground square."""
GROUND_GREYS = (172.0, 208.0)
"""grey levels (0..255) of the dark and light ground squares."""
SKY = (214, 222, 232)
"""RGB of whatever is above the horizon (only seen at shallow pitches)."""
GIF_MAX_FPS = 50.0
"""browsers show faster GIFs at 10 frames per second, so a GIF is refused above this rate."""
CLI_OPTIONS = {"width": "--video-width", "height": "--video-height", "fps": "--video-fps", "speed": "--video-speed",
               "steps": "--video-steps"}
"""the command-line option of each VideoParams field that has one (for error messages)."""

_h264_works: bool | None = None  # whether this process's OpenCV can open an 'avc1' writer (probed once)


def check_video_params(params: VideoParams, cli: bool = False) -> VideoParams:
    """``params`` if every field is in range, else a ConfigError naming the field (its option if ``cli``)."""

    def fail(key: str, expected: str):
        source = CLI_OPTIONS.get(key, "VideoParams") if cli else "VideoParams"
        raise ConfigError(source, key, expected, getattr(params, key))

    def number(value) -> bool:
        return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)

    for key in ("width", "height"):
        value = getattr(params, key)
        if isinstance(value, bool) or not isinstance(value, int) or not 16 <= value <= 4096 or value % 2:
            fail(key, "an even integer from 16 to 4096 (pixels)")
    if not number(params.fps) or not 0 < params.fps <= 240:
        fail("fps", "a number > 0 and <= 240 (frames per second)")
    if not number(params.speed) or params.speed <= 0:
        fail("speed", "a number > 0 (simulated seconds per video second)")
    if params.steps is not None:
        ok = isinstance(params.steps, (tuple, list)) and len(params.steps) == 2
        first, last = params.steps if ok else (None, None)
        ok = ok and isinstance(first, int) and not isinstance(first, bool) and first >= 0
        ok = ok and (last is None or (isinstance(last, int) and not isinstance(last, bool) and last >= first))
        if not ok:
            fail("steps", "None or (first, last) learning steps with 0 <= first <= last (last None: to the end)")
    if not number(params.distance) or params.distance < 0:
        fail("distance", "a number >= 0 (m; 0 fits the assembly)")
    if not number(params.pitch) or not -89 <= params.pitch <= 0:
        fail("pitch", "a number from -89 to 0 (degrees; negative looks down)")
    if not isinstance(params.follow, bool):
        fail("follow", "True or False")
    if not number(params.follow_time) or params.follow_time <= 0:
        fail("follow_time", "a number > 0 (simulated seconds)")
    if not isinstance(params.overlay, bool):
        fail("overlay", "True or False")
    return params


def check_output_path(path: str | os.PathLike, source: str = "--video") -> Path:
    """The output file as a Path if a video can be written there: suffix .mp4 or .gif, in an existing writable
    directory, not a directory itself. Otherwise a ConfigError naming ``source`` (the option it came from)."""
    out = Path(path)
    if out.suffix.lower() not in FORMATS:
        raise ConfigError(source, str(path), "a video file name ending in .mp4 or .gif")
    if out.is_dir():
        raise ConfigError(source, str(path), "a video file name (this is a directory)")
    parent = out.parent
    if not parent.is_dir():
        raise ConfigError(source, str(path), f"a file in an existing directory ({parent} does not exist)")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ConfigError(source, str(path), f"a file in a writable directory ({parent} is not writable)")
    if out.exists() and not os.access(out, os.W_OK):
        raise ConfigError(source, str(path), "a file that can be replaced (this one is read-only)")
    return out


def pressure_colour(pressure: float, damaged: bool = False) -> tuple[float, float, float, float]:
    """RGBA (0..1) of a unit whose bellows is at ``pressure`` (0..1): blue when empty to red when full; black if
    damaged."""
    if damaged:
        return DAMAGED_COLOUR
    p = min(1.0, max(0.0, float(pressure)))
    r, g, b = (1 - p) * EMPTY_COLOUR + p * FULL_COLOUR
    return float(r), float(g), float(b), 1.0


class RenderScene:
    """A PyBullet scene that only draws: the bodies of a world that has none (the quasi-static backend), placed at
    that world's poses before each frame."""

    def __init__(self, shape):
        self.client = pb.connect(pb.DIRECT)
        self.bodies = []
        for body, position in zip(shape.bodies, shape.placed_positions()):
            shapes = body_shapes(self.client, body)
            self.bodies.append(pb.createMultiBody(0, shapes.collision, shapes.visual, basePosition=position.tolist(),
                                                  baseOrientation=shape.orientation, physicsClientId=self.client))

    def place(self, positions, orientations) -> None:
        for uid, position, orientation in zip(self.bodies, positions, orientations):
            pb.resetBasePositionAndOrientation(uid, position.tolist(), orientation.tolist(),
                                               physicsClientId=self.client)

    def close(self) -> None:
        if pb.isConnected(self.client):
            pb.disconnect(self.client)


class VideoRecorder:
    """Renders a world every ``params.speed / params.fps`` simulated seconds into ``path`` (.mp4 or .gif).

    Use it as the ``on_tick`` observer of ``run()`` or ``measure()``::

        with VideoRecorder(None, "out.mp4", VideoParams(speed=10)) as video:
            records = run(config, progress=video.progress, on_tick=video)

    ``world`` may be None: the recorder then attaches to the world of the first tick it sees (``run()`` builds its
    world itself). One recorder serves one world.

    What the overlay shows besides time and phases comes from ``set_status(step=..., ubar=..., phases=...)``, which
    ``progress`` (run()'s progress callback) calls after every learning step, and/or from ``status()``, a callable
    returning a mapping with any of the same keys, asked at every frame. ``step`` is the learning step just
    finished (as given to run()'s progress callback): the frames that follow show step + 1 in progress (before any
    status, step 0, which includes the warm-up); ``ubar`` (mm/cycle) is that finished step's; ``phases`` (one per
    unit, front to rear) default to the world's current phases, the ones the pumps are running.

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
        self._tmp = self.path.with_name(f".{self.path.stem}.tmp-{os.getpid()}{self.path.suffix}")
        self._writer = (_GifWriter if self.format == ".gif" else _Mp4Writer)(
            self._tmp, (params.width, params.height), params.fps, self.path, source)
        self._closed = False
        self.world = None
        self._scene: RenderScene | None = None
        if world is not None:
            self._attach(world)

    # -- status ------------------------------------------------------------------------------------------------------

    def set_status(self, *, step: int | None = None, ubar: float | None = None, phases=None) -> None:
        """What the overlay shows from now on (see the class docstring); None leaves a value as it was."""
        for key, value in (("step", step), ("ubar", ubar), ("phases", phases)):
            if value is not None:
                self._status[key] = value

    def progress(self, step: int, records) -> None:
        """run()'s ``progress(step, records)`` callback: learning step ``step`` has finished with Ubar
        ``records.last_ubar``."""
        self.set_status(step=step, ubar=records.last_ubar)

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
        self.world = world
        if world.client is None:  # a world with no scene of its own (quasi-static): draw its bodies in ours
            self._scene = RenderScene(world.shape)
            c, body_ids = self._scene.client, self._scene.bodies
        else:
            c, body_ids = world.client, world.bodies
            # hide the physics plane: the recorder draws its own ground, far faster
            pb.changeVisualShape(world.ground, -1, rgbaColor=[0, 0, 0, 0], physicsClientId=c)
        self._client, self._body_ids = c, body_ids
        shape = world.shape
        width, height = self.params.width, self.params.height
        for i, body in enumerate(shape.bodies):
            if body.dummy:
                pb.changeVisualShape(body_ids[i], -1, rgbaColor=DUMMY_COLOUR, physicsClientId=c)
        self._unit_bodies = [body_ids[i] for i in shape.units]
        link_units = np.asarray(world.link_units)
        self._driven = [np.flatnonzero(link_units == k) for k in range(len(shape.units))]
        self._levels: dict[int, object] = {}
        self._distance = self.params.distance or self._fit_distance(shape)
        positions, _ = world.poses()
        self._target = positions.mean(axis=0)
        self._target_time = world.time
        self._near, self._far = self._distance / 50, self._distance * 200
        self._projection = pb.computeProjectionMatrixFOV(FOV, width / height, self._near, self._far,
                                                         physicsClientId=c)
        self._cols = np.arange(width, dtype=np.float32)
        self._rows = np.arange(height, dtype=np.float32) + 1  # TinyRenderer's row r is at viewport y = r + 1
        self._ground_cache: tuple[tuple, np.ndarray] | None = None
        self._start = world.time
        self._slots = 0  # frame times passed so far: start, start + interval, ...

    def _fit_distance(self, shape) -> float:
        """m, a camera distance at which the assembly at rest fills FILL of the frame's width and depth."""
        # each body's half-extents on the ground, turned with the assembly
        half = np.array([b.size for b in shape.bodies], dtype=float) / 2 @ np.abs(shape.rotation).T
        centres = shape.placed_positions()
        lows, highs = np.min(centres - half, axis=0), np.max(centres + half, axis=0)
        extent = highs - lows
        half_v = math.tan(math.radians(FOV) / 2)
        half_h = half_v * self.params.width / self.params.height
        along_x = extent[0] / FILL / (2 * half_h)
        along_y = extent[1] * abs(math.sin(math.radians(self.params.pitch))) / FILL / (2 * half_v)
        return max(along_x, along_y, 0.15)

    def __call__(self, world=None) -> None:
        """The ``on_tick(world)`` observer: renders the frames that are due at the world's current time."""
        if self._closed:
            raise RuntimeError("this VideoRecorder is closed")
        if self.world is None:
            if world is None:
                raise ValueError("VideoRecorder was given no world")
            self._attach(world)
        elif world is not None and world is not self.world:
            raise ValueError("one VideoRecorder records one world; make a new one for another world")
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

    # -- rendering ---------------------------------------------------------------------------------------------------

    def render(self, step: int | None = None) -> np.ndarray:
        """The frame for the world as it is now: (height, width, 3) uint8 RGB (``step``: the learning step the overlay
        names; default ``self.step``)."""
        if self.world is None:
            raise ValueError("VideoRecorder has no world yet: pass one, or let it see a tick first")
        c = self._client
        if self._scene is not None:
            self._scene.place(*self.world.poses())
        width, height = self.params.width, self.params.height
        self._recolour()
        view = pb.computeViewMatrixFromYawPitchRoll(
            self._target.tolist(), self._distance, 0.0, self.params.pitch, 0.0, 2, physicsClientId=c)
        _, _, rgba, _, seg = pb.getCameraImage(width, height, view, self._projection, renderer=pb.ER_TINY_RENDERER,
                                               physicsClientId=c)
        rgb = np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3]
        bodies = np.asarray(seg).reshape(height, width) >= 0
        frame = self._ground(view).copy()
        frame[bodies] = rgb[bodies]
        if self.params.overlay:
            self._overlay(frame, self.step if step is None else step)
        return frame

    def _recolour(self) -> None:
        world, c = self.world, self._client
        pressure = np.asarray(world.pressure)
        for k, uid in enumerate(self._unit_bodies):
            damaged = k in self.damaged or bool(world.damage[k])
            p = float(pressure[self._driven[k]].max()) if len(self._driven[k]) else 0.0
            level = "damaged" if damaged else round(p * (COLOUR_LEVELS - 1))
            if self._levels.get(uid) != level:
                self._levels[uid] = level
                colour = pressure_colour(0.0 if damaged else level / (COLOUR_LEVELS - 1), damaged)
                pb.changeVisualShape(uid, -1, rgbaColor=colour, physicsClientId=c)

    def _ground(self, view) -> np.ndarray:
        """(height, width, 3) uint8: the checkered ground plane z = 0 (and sky above the horizon) seen through
        ``view``. Each pixel is mapped to the ground by the inverse of the plane's homography and shaded with the
        checker averaged over the pixel's footprint."""
        key = tuple(view)
        if self._ground_cache is not None and self._ground_cache[0] == key:
            return self._ground_cache[1]
        width, height = self.params.width, self.params.height
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
        self._ground_cache = (key, image)
        return image

    def _overlay(self, frame: np.ndarray, step: int) -> None:
        """Time, step, last Ubar and phases, white on a darkened panel in the top left corner."""
        status = self.current_status()
        ubar, finished = status.get("ubar"), status.get("step")
        phases = np.atleast_1d(status.get("phases", self.world.phases))
        lapse = f"   x{self.params.speed:g}" if self.params.speed != 1 else ""
        lines = [f"t {self.world.time:.1f} s   step {step}{lapse}",
                 f"Ubar {ubar:+.2f} mm/cycle (step {finished})" if ubar is not None and np.isfinite(ubar)
                 else "Ubar --"]
        font, scale, margin = cv2.FONT_HERSHEY_SIMPLEX, _font_scale(frame.shape[0]), 4
        lines += _wrap("phases " + " ".join(f"{float(p):.2f}" for p in phases), frame.shape[1], scale)
        text_height = cv2.getTextSize("Ag", font, scale, 1)[0][1]
        spacing = text_height + max(3, text_height // 2)
        width = max(cv2.getTextSize(line, font, scale, 1)[0][0] for line in lines) + 3 * margin
        panel = frame[:len(lines) * spacing + 2 * margin, :width]
        panel[:] = (panel * 0.45).astype(np.uint8)  # a dark panel keeps the text legible on any ground
        for i, line in enumerate(lines):
            cv2.putText(frame, line, (margin + 1, margin + text_height + i * spacing), font, scale, (255, 255, 255),
                        1, cv2.LINE_AA)

    # -- output ------------------------------------------------------------------------------------------------------

    def close(self) -> Path:
        """Finish the file and move it onto ``path``; returns the path. A recorder that wrote no frame leaves no file
        and raises ConfigError."""
        if self._closed:
            return self.path
        self._closed = True
        if self._scene is not None:
            self._scene.close()
        try:
            if self.frames == 0:
                raise ConfigError(self._source, str(self.path), "a video of at least one frame, but none was recorded "
                                  "(no simulated time passed, or --video-steps selects no step of the run)")
            self._writer.close()
            os.replace(self._tmp, self.path)
        finally:
            self._writer.abort()
            self._tmp.unlink(missing_ok=True)
        return self.path

    def abort(self) -> None:
        """Stop without writing: the temporary file is removed and ``path`` is left as it was."""
        self._closed = True
        self._writer.abort()
        self._tmp.unlink(missing_ok=True)

    @property
    def codec(self) -> str:
        """'avc1' (H.264), 'mp4v' (MPEG-4 part 2) or 'gif'."""
        return self._writer.codec

    def __enter__(self) -> VideoRecorder:
        return self

    def __exit__(self, exc_type, exc, traceback) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()


def _square_wave_integral(z: np.ndarray) -> np.ndarray:
    """Integral from 0 to z of the square wave that is +1 on [0, CHECKER) and -1 on [CHECKER, 2 CHECKER): a triangle
    wave between 0 and CHECKER. (floor rather than np.mod: ten times faster on float32.)"""
    cycles = z * np.float32(0.5 / CHECKER)
    fraction = cycles - np.floor(cycles)
    return np.float32(CHECKER) * (1 - np.abs(2 * fraction - 1))


def _font_scale(height: int) -> float:
    return max(0.3, 0.45 * height / 360)


def _wrap(text: str, width: int, scale: float) -> list[str]:
    """``text`` split at spaces into lines that fit ``width`` pixels at font ``scale``."""
    lines, current = [], ""
    for word in text.split(" "):
        candidate = f"{current} {word}" if current else word
        if current and cv2.getTextSize(candidate, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)[0][0] > width - 10:
            lines.append(current)
            current = "  " + word
        else:
            current = candidate
    lines.append(current)
    return lines


class _Mp4Writer:
    """cv2.VideoWriter: H.264 ('avc1') if this OpenCV build has an encoder for it, else MPEG-4 part 2 ('mp4v')."""

    def __init__(self, tmp: Path, size: tuple[int, int], fps: float, path: Path, source: str):
        global _h264_works
        self._writer = None
        for codec in ("avc1", "mp4v"):
            if codec == "avc1" and _h264_works is False:
                continue
            # FFmpeg reports a missing H.264 encoder on stderr in several lines: probe quietly.
            with _quiet_stderr() if codec == "avc1" else contextlib.nullcontext():
                writer = cv2.VideoWriter(str(tmp), cv2.VideoWriter_fourcc(*codec), float(fps), size)
            if codec == "avc1":
                _h264_works = writer.isOpened()
            if writer.isOpened():
                self._writer, self.codec = writer, codec
                return
            writer.release()
        tmp.unlink(missing_ok=True)
        raise ConfigError(source, str(path), "a .gif: this OpenCV build cannot write MP4 video")

    def write(self, frame: np.ndarray) -> None:
        self._writer.write(cv2.cvtColor(frame, cv2.COLOR_RGB2BGR))

    def close(self) -> None:
        self._writer.release()

    def abort(self) -> None:
        self._writer.release()


class _GifWriter:
    """Frames quantised to one fixed 256-colour palette, spooled to an anonymous temporary file (a long GIF does not
    sit in memory), written by Pillow on close. GIF delays are whole hundredths of a second: they alternate so that
    the video keeps its rate on average."""

    codec = "gif"

    def __init__(self, tmp: Path, size: tuple[int, int], fps: float, path: Path, source: str):
        from PIL import Image  # matplotlib's dependency: always installed with morphbench

        self._image, self._tmp, self._size, self._fps = Image, tmp, size, fps
        self._palette = Image.new("P", (1, 1))
        self._palette.putpalette(_palette())
        self._spool = tempfile.TemporaryFile()
        self._count = 0

    def write(self, frame: np.ndarray) -> None:
        image = self._image.fromarray(frame, "RGB").quantize(palette=self._palette, dither=self._image.Dither.NONE)
        self._spool.write(image.tobytes())
        self._count += 1

    def close(self) -> None:
        n, (width, height) = self._count, self._size
        ends = np.round(np.arange(1, n + 1) * 100 / self._fps).astype(int)  # cumulative, in hundredths of a second
        delays = (np.diff(ends, prepend=0) * 10).tolist()  # ms, multiples of 10
        palette = _palette()
        self._spool.seek(0)

        def frames():
            for _ in range(n):
                image = self._image.frombytes("P", (width, height), self._spool.read(width * height))
                image.putpalette(palette)
                yield image

        images = frames()
        first = next(images)
        first.save(self._tmp, format="GIF", save_all=True, append_images=images, duration=delays, loop=0,
                   optimize=False)

    def abort(self) -> None:
        self._spool.close()


def _palette() -> list[int]:
    """256 RGB entries: a 6 x 6 x 6 colour cube and 40 greys (the ground and the dummies are grey)."""
    levels = [0, 51, 102, 153, 204, 255]
    cube = [(r, g, b) for r in levels for g in levels for b in levels]
    greys = [(round(v), round(v), round(v)) for v in np.linspace(4, 250, 40)]
    return [channel for colour in cube + greys for channel in colour]


@contextlib.contextmanager
def _quiet_stderr():
    """Silence the process's standard error (file descriptor 2, where FFmpeg writes) for the duration."""
    try:
        fd = sys.stderr.fileno()
    except (AttributeError, OSError, ValueError):
        yield
        return
    sys.stderr.flush()
    saved = os.dup(fd)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, fd)
        yield
    finally:
        os.dup2(saved, fd)
        os.close(saved)
        os.close(devnull)
