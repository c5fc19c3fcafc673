"""Off-screen video of runs: a recorder that observes a world tick by tick, and the replay of a finished run.

    morphbench run SHAPE --video OUT.mp4       (a VideoRecorder as run()'s on_tick)
    morphbench render RUN_DIR --out OUT.mp4    (render_run: replay summary.json, check it against steps.parquet)
    morphbench render RUN_DIR --phases 0,50 --out OUT.png   (phase_maps: the kept phases over the sheet)

Besides physics/, this is the only package that talks to PyBullet (TinyRenderer, through the world's own client; the
top view needs none).

    checks.py     video parameters and output paths, checked before anything is simulated
    recorder.py   Recorder, what every video of a world shares (frame times, overlay, colours, the output file)
    video.py      VideoRecorder: the side view, bodies rendered by TinyRenderer
    topdown.py    TopDownRecorder: the top view of a one-layer shape, every body's footprint drawn with numpy
    views.py      open_recorder, the recorder a shape's video uses (VideoParams.view)
    ground.py     the checkered ground of a frame (side and top views), drawn without the simulator
    writers.py    MP4 in H.264 (PyAV; OpenCV without it) and GIF (Pillow) writers
    options.py    the --video options of the command line
    replay.py     render_run: a finished run replayed into a video; phase_maps: its kept phases at chosen steps

The names below are imported on first use (``morphbench.lazy``): the command line reads its video options without
loading the simulator.
"""

from morphbench.lazy import export_lazily

export_lazily(__name__, {
    "check_output_path": "checks", "check_video_params": "checks",
    "add_render_arguments": "options", "video_params_from_args": "options",
    "load_run": "replay", "render_run": "replay", "phase_maps": "replay",
    "Recorder": "recorder", "open_recorder": "views",
    "VideoRecorder": "video", "pressure_colour": "video",
    "TopDownRecorder": "topdown",
})
