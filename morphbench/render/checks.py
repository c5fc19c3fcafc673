"""What a video needs before anything is simulated: its parameters in range and a file that can be written."""

from __future__ import annotations

import math
import os
from pathlib import Path

from morphbench.errors import ConfigError
from morphbench.params import VideoParams

FORMATS = (".mp4", ".gif")
GIF_MAX_FPS = 50.0
"""browsers show faster GIFs at 10 frames per second, so a GIF is refused above this rate."""
CLI_OPTIONS = {"width": "--video-width", "height": "--video-height", "fps": "--video-fps", "speed": "--video-speed",
               "steps": "--video-steps"}
"""the command-line option of each VideoParams field that has one (for error messages)."""


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
