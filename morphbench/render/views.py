"""The recorder of a shape's video: the view ``VideoParams.view`` resolves to for it, and the recorder that draws it
(render.topdown from above, without the simulator; render.video through the simulator's camera). Above both, so
that neither the recorders nor what they share (render.recorder) need to know of the other."""

from __future__ import annotations

import os

from morphbench.params import VideoParams
from morphbench.render.checks import resolve_view
from morphbench.render.recorder import Recorder


def open_recorder(shape, path: str | os.PathLike, params: VideoParams = VideoParams(), *, source: str = "--video"
                  ) -> Recorder:
    """A recorder of a run of ``shape`` (its world given at the first tick) in the view ``params.view`` resolves to
    for it (``checks.resolve_view``: a ConfigError naming ``--view`` for a top view of a shape not in one layer)."""
    if resolve_view(shape, params) == "top":
        from morphbench.render.topdown import TopDownRecorder  # numpy only

        return TopDownRecorder(None, path, params, source=source)
    from morphbench.render.video import VideoRecorder  # the simulator's camera

    return VideoRecorder(None, path, params, source=source)
