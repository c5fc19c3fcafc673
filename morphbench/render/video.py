"""Off-screen video of a world from the side: the 3-D camera of the ``Recorder`` (render.recorder), which renders frames
and writes an MP4 or a GIF.

Every ``speed / fps`` simulated seconds it renders one frame:

- the bodies, with PyBullet's TinyRenderer (software, needs no display), through the world's own client; each active
  unit is coloured by the pressure of the bellows it drives, from blue (empty) to red (full), or by its kept phase
  (``VideoParams.colour``); dummies are grey and damaged units black;
- the ground, a checker of 5 cm squares drawn by the recorder itself (``render.ground``), far faster than
  TinyRenderer's; runs without a video pay nothing (the world itself is not touched but for colours);
- an overlay: simulated time, learning step, last Ubar and each unit's phase.

The camera looks along +y from the side and above, so forward (+x) motion runs left to right. It follows the
assembly's mean body position, smoothed over ``follow_time``, or stays where it started (``follow=False``).
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import cv2
import numpy as np
import pybullet as pb

from morphbench.physics.geometry import body_shapes
from morphbench.render.ground import GroundRasteriser
from morphbench.render.recorder import FILL, FOV, Recorder, font_scale, shape_extent
from morphbench.shapes.colours import DAMAGED_RGBA, DUMMY_RGBA, pressure_rgb

DUMMY_COLOUR = DUMMY_RGBA
COLOUR_LEVELS = 64
"""pressure (or phase) is quantised to this many colours, so a body is recoloured only when its colour visibly
changes."""


def pressure_colour(pressure: float, damaged: bool = False) -> tuple[float, float, float, float]:
    """RGBA (0..1) of a unit whose bellows is at ``pressure`` (0..1): blue when empty to red when full; black if
    damaged."""
    if damaged:
        return DAMAGED_RGBA
    r, g, b = pressure_rgb(pressure)
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


class VideoRecorder(Recorder):
    """Renders a world every ``params.speed / params.fps`` simulated seconds into ``path`` (.mp4 or .gif), seen by
    PyBullet's camera from the side and above (the ``Recorder`` docstring says how it is used)."""

    _scene: RenderScene | None = None
    """the render-only scene of a world without one of its own."""

    def _attach(self, world) -> None:
        super()._attach(world)
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
        self._levels: dict[int, int] = {}
        self._colours = [(*rgb, 1.0) for rgb in self.colour_table(COLOUR_LEVELS).tolist()]
        self._distance = self.params.distance or self._fit_distance(shape)
        self._near, self._far = self._distance / 50, self._distance * 200
        self._projection = pb.computeProjectionMatrixFOV(FOV, width / height, self._near, self._far,
                                                         physicsClientId=c)
        self._ground = GroundRasteriser(width, height, self._projection)

    def _fit_distance(self, shape) -> float:
        """m, a camera distance at which the assembly at rest fills FILL of the frame's width and depth."""
        lows, highs = shape_extent(shape)
        extent = highs - lows
        half_v = math.tan(math.radians(FOV) / 2)
        half_h = half_v * self.params.width / self.params.height
        along_x = extent[0] / FILL / (2 * half_h)
        along_y = extent[1] * abs(math.sin(math.radians(self.params.pitch))) / FILL / (2 * half_v)
        return max(along_x, along_y, 0.15)

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
        c = self._client
        for uid, level in zip(self._unit_bodies, self.unit_levels(COLOUR_LEVELS).tolist()):
            if self._levels.get(uid) != level:
                self._levels[uid] = level
                pb.changeVisualShape(uid, -1, rgbaColor=self._colours[level], physicsClientId=c)

    def _overlay_lines(self, step: int, status: Mapping[str, Any]) -> list[str]:
        """Time, step, last Ubar and each unit's phase (wrapped to the frame's width)."""
        phases = np.atleast_1d(status.get("phases", self.world.phases))
        return [*super()._overlay_lines(step, status),
                *_wrap("phases " + " ".join(f"{float(p):.2f}" for p in phases), self.params.width,
                       font_scale(self.params.height))]

    def _release(self) -> None:
        if self._scene is not None:
            self._scene.close()


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
