"""Off-screen video of runs: a recorder that observes a world tick by tick, and the replay of a finished run.

    morphbench run SHAPE --video OUT.mp4       (a VideoRecorder as run()'s on_tick)
    morphbench render RUN_DIR --out OUT.mp4    (render_run: replay summary.json, check it against steps.parquet)

Besides physics/, this is the only package that talks to PyBullet (TinyRenderer, through the world's own client).

    checks.py     video parameters and output paths, checked before anything is simulated
    video.py      VideoRecorder: the on_tick observer that renders frames (bodies, overlay) and owns the output file
    ground.py     the checkered ground of a frame, drawn without the simulator
    writers.py    MP4 (OpenCV) and GIF (Pillow) writers
    options.py    the --video options of the command line
    replay.py     render_run: a finished run replayed into a video
"""

from morphbench.render.checks import check_output_path, check_video_params
from morphbench.render.options import add_render_arguments, video_params_from_args
from morphbench.render.replay import load_run, render_run
from morphbench.render.video import VideoRecorder, pressure_colour

__all__ = [
    "VideoRecorder",
    "add_render_arguments",
    "check_output_path",
    "check_video_params",
    "load_run",
    "pressure_colour",
    "render_run",
    "video_params_from_args",
]
