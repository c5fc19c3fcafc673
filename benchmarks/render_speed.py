"""Frames per second of the off-screen video (morphbench.render) at 640x360, and what the alternative would cost.

    python benchmarks/render_speed.py                  # chain-3 and chain-7, 20 simulated s each
    python benchmarks/render_speed.py --seconds 60 shapes/chain-20.toml

For each shape it advances a world at a peristaltic wave for ``--seconds`` simulated seconds with a VideoRecorder at
30 fps and speed 1 (one frame every 4 ticks), then the same world without one. Render fps is frames / (wall time with
the recorder - wall time without): bodies through TinyRenderer, the recorder's own checkered ground, the overlay and
MP4 encoding. Real time is simulated seconds per wall second while recording. The last column renders the same view
with the ground as a textured mesh drawn by TinyRenderer itself (the obvious alternative), frames only.

There are no grid shapes yet: chain-7 (8 bodies) stands in for a 3x3 grid (9 bodies), and a grid-*.toml in shapes/
is measured too once it exists.
"""

from __future__ import annotations

import argparse
import platform
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
import pybullet as pb

from morphbench.params import VideoParams
from morphbench.physics import World
from morphbench.render import VideoRecorder
from morphbench.shapes import load_shape

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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="simulated seconds per shape (default 20)")
    parser.add_argument("shapes", nargs="*")
    args = parser.parse_args()
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
