"""Off-screen video of a world: an ``on_tick`` observer that renders frames and writes an MP4 or a GIF.

``VideoRecorder`` is passed as ``on_tick`` to ``run()`` or ``measure()`` (or to a world's ``advance`` through a
lambda). Every ``speed / fps`` simulated seconds it renders one frame:

- the bodies, with PyBullet's TinyRenderer (software, needs no display), through the world's own client; each active
  unit is coloured by the pressure of the bellows it drives, from blue (empty) to red (full); dummies are grey and
  damaged units black;
- the ground, a checker of 5 cm squares drawn by the recorder itself (``render.ground``), far faster than
  TinyRenderer's; runs without a video pay nothing (the world itself is not touched but for colours);
- an overlay: simulated time, learning step, last Ubar and each unit's phase.

The camera looks along +y from the side and above, so forward (+x) motion runs left to right. It follows the
assembly's mean body position, smoothed over ``follow_time``, or stays where it started (``follow=False``).

Frames are written (``render.writers``) to a temporary file beside the output and renamed onto it by ``close()``;
``abort()`` (or leaving the ``with`` block by an exception) removes it, so a half-written video is never left behind.
Parameters and the output path are checked first (``render.checks``).
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping

import cv2
import numpy as np
import pybullet as pb

from morphbench.errors import ConfigError
from morphbench.files import Replacement
from morphbench.params import VideoParams
from morphbench.physics.geometry import body_shapes
from morphbench.render.checks import CLI_OPTIONS, GIF_MAX_FPS, check_output_path, check_video_params
from morphbench.render.ground import GroundRasteriser
from morphbench.render.writers import open_writer
from morphbench.shapes.colours import DUMMY_RGBA, UNIT_RGBA

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
        self._output = Replacement(self.path)
        self._writer = open_writer(self._output.tmp, (params.width, params.height), params.fps, self.path, source)
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
        scene = world.scene
        if scene is None:  # a world with no scene of its own (quasi-static): draw its bodies in ours
            self._scene = RenderScene(world.shape)
            c, body_ids = self._scene.client, self._scene.bodies
        else:
            c, body_ids = scene.client, scene.bodies
            # hide the physics plane: the recorder draws its own ground, far faster
            pb.changeVisualShape(scene.ground, -1, rgbaColor=[0, 0, 0, 0], physicsClientId=c)
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
        self._ground = GroundRasteriser(width, height, self._projection)
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
        frame = self._ground.image(view).copy()
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
            self._output.commit()
        finally:
            self._writer.abort()
            self._output.discard()
        return self.path

    def abort(self) -> None:
        """Stop without writing: the temporary file is removed and ``path`` is left as it was."""
        self._closed = True
        self._writer.abort()
        self._output.discard()

    @property
    def codec(self) -> str:
        """'h264' (PyAV), 'avc1' (H.264 through OpenCV), 'mp4v' (MPEG-4 part 2, OpenCV without H.264) or 'gif'."""
        return self._writer.codec

    def __enter__(self) -> VideoRecorder:
        return self

    def __exit__(self, exc_type, exc, traceback) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()


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
