"""What a video needs before anything is simulated: its parameters in range and a file that can be written."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

from morphbench.errors import ConfigError
from morphbench.params import VideoParams
from morphbench.rules import check

FORMATS = (".mp4", ".gif")
GIF_MAX_FPS = 50.0
"""browsers show faster GIFs at 10 frames per second, so a GIF is refused above this rate."""
CLI_OPTIONS = {"width": "--video-width", "height": "--video-height", "fps": "--video-fps", "speed": "--video-speed",
               "steps": "--video-steps"}
"""the command-line option of each VideoParams field that has one (for error messages)."""


def check_video_params(params: VideoParams, cli: bool = False) -> VideoParams:
    """``params`` if every field is in range, else a ConfigError naming the field (its option if ``cli``)."""
    for f in dataclasses.fields(params):
        check(params, f.name, getattr(params, f.name), CLI_OPTIONS.get(f.name, "VideoParams") if cli else "VideoParams")
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
