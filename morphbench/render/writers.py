"""Video files from frames: MP4 through OpenCV, GIF through Pillow.

MP4 is H.264 ('avc1', plays in browsers) when this OpenCV build can encode it, MPEG-4 part 2 ('mp4v') otherwise; GIF
goes through Pillow with one fixed palette. A writer writes to the file it is given (the recorder gives it a
temporary name and renames the finished file).
"""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
from pathlib import Path

import cv2
import numpy as np

from morphbench.errors import ConfigError

_h264_works: bool | None = None  # whether this process's OpenCV can open an 'avc1' writer (probed once)


def open_writer(tmp: Path, size: tuple[int, int], fps: float, path: Path, source: str):
    """A writer of frames of ``size`` (width, height) at ``fps`` into ``tmp``, of the format of ``path``'s suffix
    (``path`` and ``source``, the option it came from, name the output in errors)."""
    return (GifWriter if path.suffix.lower() == ".gif" else Mp4Writer)(tmp, size, fps, path, source)


class Mp4Writer:
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


class GifWriter:
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
