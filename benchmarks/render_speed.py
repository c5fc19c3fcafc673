"""Frames per second of the off-screen video (morphbench.render) at 640x360, and what the alternative would cost.

    python benchmarks/render_speed.py                  # chain-3 and chain-7, 20 simulated s each
    python benchmarks/render_speed.py --seconds 60 shapes/chain-20.toml
    python benchmarks/render_speed.py --top            # the top view of sheets of 100 to 10,000 units, on one core

For each shape it advances a world at a peristaltic wave for ``--seconds`` simulated seconds with a VideoRecorder at
30 fps and speed 1 (one frame every 4 ticks), then the same world without one. Render fps is frames / (wall time with
the recorder - wall time without): bodies through TinyRenderer, the recorder's own checkered ground, the overlay and
MP4 encoding. Real time is simulated seconds per wall second while recording. The last column renders the same view
with the ground as a textured mesh drawn by TinyRenderer itself (the obvious alternative), frames only.

There are no grid shapes yet: chain-7 (8 bodies) stands in for a 3x3 grid (9 bodies), and a grid-*.toml in shapes/
is measured too once it exists.

``--top`` measures the top view (render.topdown) alone, pinned to one core (``os.sched_setaffinity``; libx264's
threads share it): square sheets of ``--sizes`` units (generator grid, bellows along both axes) whose bodies a
``WavingSheet`` moves in a travelling wave (every body displaced, turned and its bellows' pressure changing each
frame, so nothing is cached), drawn by a TopDownRecorder with its overlay. Draw fps is frames / the time of
``render()`` (ground, footprints, colours, overlay); with H.264 adds writing each frame to an MP4. The physics of a
10,000-unit sheet is not part of it: a real run feeds the recorder the same arrays from its world.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
import pybullet as pb

from morphbench.params import ActuatorParams, DummyParams, UnitParams, VideoParams
from morphbench.physics import World
from morphbench.render import TopDownRecorder, VideoRecorder
from morphbench.shapes import Shape, load_shape
from morphbench.shapes.generators import grid

PARAMS = VideoParams(width=640, height=360, fps=30, speed=1)


def wave(n_units: int) -> np.ndarray:
    return np.mod(0.4 * np.arange(n_units), 1.0)


def advance(shape, seconds: float, observer_for=None) -> tuple[float, VideoRecorder | None]:
    """Wall seconds to simulate ``seconds`` at a wave, with the observer ``observer_for(world)`` if given."""
    with World(shape) as world:
        world.set_phases(wave(shape.n_units))
        observer = observer_for(world) if observer_for else None
        started = time.perf_counter()
        world.advance(world.ticks_in(seconds), (lambda k: observer(world)) if observer else None)
        if observer is not None:
            observer.close()
        return time.perf_counter() - started, observer


def tiny_renderer_ground_fps(shape, frames: int = 20) -> float:
    """Frames per second of TinyRenderer alone drawing the bodies and a textured ground mesh (5 cm checker)."""
    with World(shape) as world, tempfile.TemporaryDirectory() as tmp:
        c = world.client
        recorder = VideoRecorder(world, Path(tmp) / "unused.mp4", PARAMS)  # for its camera
        tile = np.full((64, 64, 3), 208, np.uint8)
        tile[:32, :32] = tile[32:, 32:] = 172
        cv2.imwrite(str(Path(tmp) / "checker.png"), tile)
        texture = pb.loadTexture(str(Path(tmp) / "checker.png"), physicsClientId=c)
        size, repeat = 20.0, 20.0 / 0.1
        mesh = pb.createVisualShape(pb.GEOM_MESH, vertices=[[-size, -size, 0], [size, -size, 0], [size, size, 0],
                                                            [-size, size, 0]], indices=[0, 1, 2, 0, 2, 3],
                                    uvs=[[-repeat, -repeat], [repeat, -repeat], [repeat, repeat], [-repeat, repeat]],
                                    normals=[[0, 0, 1]] * 4, physicsClientId=c)
        ground = pb.createMultiBody(0, -1, mesh, physicsClientId=c)
        pb.changeVisualShape(ground, -1, textureUniqueId=texture, physicsClientId=c)
        view = pb.computeViewMatrixFromYawPitchRoll(recorder._target.tolist(), recorder._distance, 0.0, PARAMS.pitch,
                                                    0.0, 2, physicsClientId=c)
        started = time.perf_counter()
        for _ in range(frames):
            pb.getCameraImage(PARAMS.width, PARAMS.height, view, recorder._projection, renderer=pb.ER_TINY_RENDERER,
                              physicsClientId=c)
        elapsed = time.perf_counter() - started
        recorder.abort()
        return frames / elapsed


class WavingSheet:
    """What a recorder reads of a world, for a sheet whose bodies move in a travelling wave along x: positions,
    headings and pressures change every frame (``tick``), as a learning sheet's would."""

    def __init__(self, shape, fps: float):
        self.shape, self.time, self.dt = shape, 0.0, 1.0 / fps
        self.rest = shape.placed_positions()
        unit_of_body = {body: k for k, body in enumerate(shape.units)}
        self.link_units = np.array([-1 if link.unit is None else unit_of_body[link.unit] for link in shape.links])
        self.phases = wave(shape.n_units)
        self.damage = [""] * shape.n_units
        self._link_phase = np.array([0.0 if k < 0 else self.phases[k] for k in self.link_units])
        self.tick()

    def tick(self) -> None:
        self.time += self.dt
        angle = 2 * np.pi * (self.time / 2.0 - 3.0 * self.rest[:, 0])  # 2 s cycle, a wave of 33 cm
        self.positions = self.rest + np.stack([0.004 * np.sin(angle) + 0.01 * self.time, 0.002 * np.cos(angle),
                                               0 * angle], axis=1)
        yaw = 0.05 * np.sin(angle)
        self.orientations = np.stack([0 * yaw, 0 * yaw, np.sin(yaw / 2), np.cos(yaw / 2)], axis=1)
        self.pressure = 0.5 + 0.5 * np.sin(2 * np.pi * (self.time / 2.0 - self._link_phase))

    def poses(self):
        return self.positions, self.orientations


def top_view_fps(units: int, frames: int, colour: str, directory: Path) -> tuple[float, float]:
    """(draw fps, draw and H.264 fps) of the top view of a square sheet of about ``units`` units."""
    side = round(units ** 0.5)
    # built from the generator itself: morphology files stop at shapes.generators.MAX_UNITS units
    bodies, links = grid(side, side, False, UnitParams(), DummyParams(), ActuatorParams(), actuated_axes=("x", "y"))
    shape = Shape(name=f"sheet-{side}x{side}", source="render_speed.py", bodies=bodies, links=links,
                  actuator=ActuatorParams())
    sheet = WavingSheet(shape, PARAMS.fps)
    params = dataclasses.replace(PARAMS, view="top", colour=colour)
    recorder = TopDownRecorder(sheet, directory / "top.mp4", params)
    recorder.set_status(step=0, ubar=1.0, kept=np.mod(sheet.phases + 0.01, 1.0))
    drawing = writing = 0.0
    for _ in range(frames):
        sheet.tick()
        started = time.perf_counter()
        frame = recorder.render()
        drawn = time.perf_counter()
        recorder._writer.write(frame)
        writing += time.perf_counter() - drawn
        drawing += drawn - started
    recorder.abort()
    return frames / drawing, frames / (drawing + writing)


def top_views(sizes: list[int], frames: int) -> None:
    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    print(f"# {time.strftime('%Y-%m-%d')} {platform.machine()} {platform.processor() or ''} "
          f"python {platform.python_version()}, {PARAMS.width}x{PARAMS.height}, top view, one core")
    print("| date | units | colour | frames | draw fps | with H.264 fps |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for units in sizes:
            for colour in ("pressure", "phase"):
                draw, encoded = top_view_fps(units, frames, colour, Path(tmp))
                print(f"| {time.strftime('%Y-%m-%d')} | {units} | {colour} | {frames} | {draw:.0f} | {encoded:.0f} |",
                      flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="simulated seconds per shape (default 20)")
    parser.add_argument("--top", action="store_true", help="the top view of sheets of --sizes units instead")
    parser.add_argument("--sizes", type=lambda text: [int(n) for n in text.split(",")], default=[100, 2500, 10000],
                        help="units of the sheets --top draws (square sheets; default 100,2500,10000)")
    parser.add_argument("--frames", type=int, default=300, help="frames per sheet with --top (default 300)")
    parser.add_argument("shapes", nargs="*")
    args = parser.parse_args()
    if args.top:
        top_views(args.sizes, args.frames)
        return
    grids = sorted(str(path) for path in Path("shapes").glob("grid-*.toml"))
    shapes = args.shapes or ["shapes/chain-3.toml", "shapes/chain-7.toml", *grids]
    print(f"# {time.strftime('%Y-%m-%d')} {platform.machine()} {platform.processor() or ''} "
          f"python {platform.python_version()}, {PARAMS.width}x{PARAMS.height}, {PARAMS.fps:g} fps, speed 1")
    if not any("grid" in s for s in shapes):
        print("# no grid shapes yet: chain-7 (8 bodies) stands in for a 3x3 grid (9 bodies)")
    print("| date | shape | bodies | frames | render fps | real time x | physics only s | TinyRenderer-ground fps "
          "| codec |")
    print("|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for path in shapes:
            shape = load_shape(path)
            bare, _ = advance(shape, args.seconds)
            recorded, recorder = advance(shape, args.seconds,
                                         lambda world: VideoRecorder(world, Path(tmp) / "video.mp4", PARAMS))
            fps = recorder.frames / max(recorded - bare, 1e-9)
            print(f"| {time.strftime('%Y-%m-%d')} | {shape.name} | {len(shape.bodies)} | {recorder.frames} | "
                  f"{fps:.0f} | {args.seconds / recorded:.2f} | {bare:.2f} | {tiny_renderer_ground_fps(shape):.1f} | "
                  f"{recorder.codec} |", flush=True)


if __name__ == "__main__":
    main()
