"""Command-line options of the video: ``--video OUT``, ``--video-width/-height/-fps/-speed/-steps``, ``--view`` and
``--colour``."""

from __future__ import annotations

import argparse

from morphbench.errors import ConfigError
from morphbench.params import VideoParams
from morphbench.render.checks import check_video_params
from morphbench.rules import field_option


def add_render_arguments(parser: argparse.ArgumentParser, output: bool = True) -> None:
    """Add the video options to ``parser``: ``--video OUT`` (if ``output``; a command whose output is a video, such as
    ``render --out``, names the file itself) and the size, rate, speed and steps options, each with VideoParams'
    default. A bad value is an argparse error naming the option."""
    defaults = VideoParams()
    group = parser.add_argument_group("video")
    if output:
        group.add_argument("--video", metavar="OUT", help="also write a video of the run to OUT (.mp4 or .gif)")
    group.add_argument("--video-width", type=field_option(VideoParams, "width"), default=defaults.width, metavar="PX",
                       help="frame width in pixels, even (default %(default)s)")
    group.add_argument("--video-height", type=field_option(VideoParams, "height"), default=defaults.height,
                       metavar="PX",
                       help="frame height in pixels, even (default %(default)s)")
    group.add_argument("--video-fps", type=field_option(VideoParams, "fps"), default=defaults.fps, metavar="FPS",
                       help="frames per second of the video (default %(default)g; at most 50 for a GIF)")
    group.add_argument("--video-speed", type=field_option(VideoParams, "speed"), default=defaults.speed, metavar="X",
                       help="simulated seconds per video second; > 1 is a time-lapse (default %(default)g)")
    group.add_argument("--video-steps", type=_step_range, default=defaults.steps, metavar="FIRST:LAST",
                       help="learning steps to show, inclusive: FIRST:LAST, FIRST: (to the end), :LAST or N "
                            "(default all)")
    group.add_argument("--view", type=field_option(VideoParams, "view"), default=defaults.view,
                       metavar="auto|side|top",
                       help="side: the 3-D camera; top: every body's footprint from above (one-layer shapes; fast "
                            "for thousands of units); auto: top beyond 100 units in one layer (default %(default)s)")
    group.add_argument("--colour", type=field_option(VideoParams, "colour"), default=defaults.colour,
                       metavar="pressure|phase",
                       help="what a unit's colour shows: its bellows' pressure, or its kept phase on a cyclic colour "
                            "map (default %(default)s)")


def video_params_from_args(args: argparse.Namespace, last_step: int | None = None) -> VideoParams:
    """The VideoParams of parsed ``add_render_arguments`` options (ConfigError naming the option if out of range, or
    if ``--video-steps`` starts after ``last_step``, the run's last learning step, when it is known)."""
    params = VideoParams(width=args.video_width, height=args.video_height, fps=args.video_fps,
                         speed=args.video_speed, steps=args.video_steps, view=args.view, colour=args.colour)
    check_video_params(params, cli=True)
    if last_step is not None and params.steps is not None and params.steps[0] > last_step:
        raise ConfigError("--video-steps", "steps", f"learning steps of this run, which ends at step {last_step}",
                          f"{params.steps[0]}:{'' if params.steps[1] is None else params.steps[1]}")
    return params


def _step_range(text: str) -> tuple[int, int | None]:
    """'FIRST:LAST', 'FIRST:', ':LAST' or 'N' -> (first, last), last None for 'to the end'."""
    first_text, sep, last_text = text.partition(":")
    if not sep:
        last_text = first_text
    try:
        first = int(first_text) if first_text.strip() else 0
        last = int(last_text) if last_text.strip() else None
    except ValueError:
        first = last = -1
    if first < 0 or (last is not None and last < first):
        raise argparse.ArgumentTypeError(
            f"expected learning steps FIRST:LAST with 0 <= FIRST <= LAST (FIRST: or :LAST leave one end open), "
            f"got {text!r}")
    return first, last
