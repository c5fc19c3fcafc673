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
               "steps": "--video-steps", "view": "--view", "colour": "--colour"}
"""the command-line option of each VideoParams field that has one (for error messages)."""
AUTO_TOP_UNITS = 100
"""``view = "auto"`` shows a one-layer shape of more units than this from above: beyond the library's largest sheet
(10 x 10), TinyRenderer's side view draws each unit in a few pixels, and slowly (benchmarks/render_speed.py), and the
overlay's list of phases would fill the frame."""


def check_video_params(params: VideoParams, cli: bool = False) -> VideoParams:
    """``params`` if every field is in range, else a ConfigError naming the field (its option if ``cli``)."""
    for f in dataclasses.fields(params):
        check(params, f.name, getattr(params, f.name), CLI_OPTIONS.get(f.name, "VideoParams") if cli else "VideoParams")
    return params


def resolve_view(shape, params: VideoParams, source: str = "--view") -> str:
    """'side' or 'top': the view ``params.view`` gives a video of ``shape`` (see ``AUTO_TOP_UNITS``). A top view of a
    shape not in one layer on the ground (a stack) is a ConfigError naming ``source``."""
    if params.view == "side" or (params.view == "auto" and shape.n_units <= AUTO_TOP_UNITS):
        return "side"
    from morphbench.physics.planar import check_one_layer  # the planar model's own test of one layer

    try:
        check_one_layer(shape)
    except ConfigError:
        if params.view == "auto":
            return "side"
        raise ConfigError(source, params.view, f"a shape in one layer on the ground for a view from above "
                                               f"({shape.name} is a stack, which only --view side shows)") from None
    return "top"


def check_output_path(path: str | os.PathLike, source: str = "--video", formats: tuple[str, ...] = FORMATS) -> Path:
    """The output file as a Path if it can be written there: a suffix of ``formats`` (a video's by default), in an
    existing writable directory, not a directory itself. Otherwise a ConfigError naming ``source`` (the option it came
    from)."""
    out = Path(path)
    what = "a video file" if formats == FORMATS else "a file"
    if out.suffix.lower() not in formats:
        raise ConfigError(source, str(path), f"{what} name ending in {' or '.join(formats)}")
    if out.is_dir():
        raise ConfigError(source, str(path), f"{what} name (this is a directory)")
    parent = out.parent
    if not parent.is_dir():
        raise ConfigError(source, str(path), f"a file in an existing directory ({parent} does not exist)")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ConfigError(source, str(path), f"a file in a writable directory ({parent} is not writable)")
    if out.exists() and not os.access(out, os.W_OK):
        raise ConfigError(source, str(path), "a file that can be replaced (this one is read-only)")
    return out
