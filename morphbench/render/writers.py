"""Video files from frames: MP4 through PyAV (H.264) or OpenCV, GIF through Pillow.

MP4 is H.264 (libx264, yuv420p, which every browser plays) through PyAV, whose wheel carries libx264
(``H264Writer``). Without PyAV (or with a build of it that lacks libx264) it falls back to OpenCV (``Mp4Writer``):
H.264 ('avc1') when that OpenCV build can encode it, else MPEG-4 part 2 ('mp4v'), which players open but most
browsers do not (the pip build of OpenCV has no H.264 encoder). GIF goes through Pillow with one fixed palette. A
writer writes to the file it is given (the recorder gives it a temporary name and renames the finished file).
"""

from __future__ import annotations

import contextlib
import importlib
import os
import sys
import tempfile
from fractions import Fraction
from pathlib import Path

import cv2
import numpy as np

from morphbench.errors import ConfigError

_h264_works: bool | None = None  # whether this process's OpenCV can open an 'avc1' writer (probed once)

H264_CRF = 23
"""libx264's constant rate factor (0 lossless .. 51; 23 is its default): the quality of H.264 videos."""
H264_PRESET = "fast"
"""libx264's speed preset: encoding a frame costs far less than rendering it at any preset; 'fast' keeps files small."""


def open_writer(tmp: Path, size: tuple[int, int], fps: float, path: Path, source: str):
    """A writer of frames of ``size`` (width, height) at ``fps`` into ``tmp``, of the format of ``path``'s suffix
    (``path`` and ``source``, the option it came from, name the output in errors): a GIF, or an MP4 in H.264 through
    PyAV when it is there with libx264, else through OpenCV."""
    if path.suffix.lower() == ".gif":
        return GifWriter(tmp, size, fps, path, source)
    return (H264Writer if pyav() is not None else Mp4Writer)(tmp, size, fps, path, source)


def pyav():
    """The ``av`` module (PyAV) if it is installed and can encode with libx264, else None."""
    try:
        av = importlib.import_module("av")
    except ImportError:
        return None
    return av if "libx264" in getattr(av, "codecs_available", ()) else None


class H264Writer:
    """PyAV: H.264 (libx264, pixel format yuv420p: what browsers decode) in an MP4 whose index is at the front
    (``+faststart``, so a browser starts playing before the whole file has arrived). yuv420p halves the chroma
    resolution, so width and height must be even (VideoParams requires it).

    libx264's output is not always byte-identical for identical frames: in a process that simulates between frames,
    two encodings of the same frames came out about 0.1 dB PSNR apart (36 dB from the frames at this quality). Checks
    that compare decoded frames exactly use the OpenCV writer."""

    codec = "h264"

    def __init__(self, tmp: Path, size: tuple[int, int], fps: float, path: Path, source: str):
        width, height = size
        if width % 2 or height % 2:
            raise ConfigError(source, str(path), f"an even width and height for H.264 video, got {width} x {height}")
        av = pyav()
        self._av = av
        self._container = av.open(str(tmp), mode="w", format="mp4", options={"movflags": "+faststart"})
        try:
            self._stream = self._container.add_stream("libx264", rate=Fraction(fps).limit_denominator(1001),
                                                      options={"crf": str(H264_CRF), "preset": H264_PRESET})
            self._stream.width, self._stream.height, self._stream.pix_fmt = width, height, "yuv420p"
        except Exception:
            self._container.close()
            raise
        self._closed = False

    def write(self, frame: np.ndarray) -> None:
        picture = self._av.VideoFrame.from_ndarray(np.ascontiguousarray(frame), format="rgb24")
        for packet in self._stream.encode(picture):
            self._container.mux(packet)

    def close(self) -> None:
        """Flush the encoder's delayed frames into the file, then finish it (its index is written last)."""
        for packet in self._stream.encode(None):
            self._container.mux(packet)
        self._closed = True
        self._container.close()

    def abort(self) -> None:
        if not self._closed:
            self._closed = True
            with contextlib.suppress(Exception):  # a container that never got a frame may fail to write its trailer
                self._container.close()


class Mp4Writer:
    """The fallback without PyAV, cv2.VideoWriter: H.264 ('avc1') if this OpenCV build has an encoder for it, else
    MPEG-4 part 2 ('mp4v')."""

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
