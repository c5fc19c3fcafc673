"""One short video per experiment of a results directory, replayed off-screen from its stored runs (for report.html).

    videos = render_videos(DIR)     # DIR/videos/<experiment>.mp4, one Video per experiment of DIR/plan.json

Each experiment shows one run: the first seed of its first condition that finished (plan order; its result.json says
so, whatever the consolidated tables hold). Its first learning
steps are replayed (``morphbench.render.render_run`` on the run's result.json, which holds its configuration, and its
steps: ``Store.replayable``; the replay is checked against the stored Ubar) up to the step that ends nearest
``VIDEO_SECONDS`` of simulated time, at ``REPORT_VIDEO``'s small size, in H.264 (render.writers), in the view
``VideoParams.view = "auto"`` gives its shape (from above for a one-layer sheet of more than 100 units:
render.topdown). A video whose run,
steps, parameters, morphbench version and encoder (PyAV or the OpenCV fallback) have not changed since it was rendered
(``DIR/videos/<experiment>.json`` says what it shows) is reused, if it still decodes (``video_problem``: a file
damaged since is rendered again): delete ``DIR/videos/`` to render again. Videos of experiments the plan no longer
has are removed. A replay that fails is reported in its Video (``error``), never
raised: the report goes on without that video.

The simulator is imported only when a video is rendered: importing this module (and bench.report) needs none.
"""

from __future__ import annotations

import dataclasses
import json
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import pandas as pd

from morphbench.bench.store import Store, Unreadable
from morphbench.errors import ConfigError
from morphbench.failures import describe
from morphbench.files import write_text
from morphbench.params import VideoParams

VIDEO_SECONDS = 15.0
"""s of simulated time a report video aims at: it shows the learning steps up to the one that ends nearest this."""
REPORT_VIDEO = VideoParams(width=480, height=270, fps=20.0)
"""size and rate of a report video (steps are set per run)."""
VIDEO_DIR = "videos"


@dataclass
class Video:
    """What the report shows of one experiment's video."""

    experiment: str
    run_id: str | None = None
    """the run replayed (None: the experiment has no finished run)."""
    seed: int | None = None
    label: str = ""
    """the run's condition: its shape, learner and the values that tell the experiment's conditions apart."""
    path: Path | None = None
    """DIR/videos/<experiment>.mp4, None when there is no video."""
    steps: tuple[int, int] | None = None
    """learning steps shown, inclusive (0 includes the warm-up)."""
    simulated_s: float = math.nan
    """s of simulated time shown."""
    codec: str = ""
    """'h264' (plays in browsers); 'avc1' or 'mp4v' from the OpenCV fallback when PyAV is missing."""
    wall_time_s: float = 0.0
    """s spent rendering it (0 when an earlier rendering was reused)."""
    reused: bool = False
    error: str | None = None
    """why there is no video (no finished run, or the replay failed)."""


def label(condition: dict, varying=()) -> str:
    """A condition in a few words: shape, learner and the ``varying`` values (ids left out)."""
    keys = ["shape", "learner", *(k for k in varying if k not in ("shape", "learner") and not k.endswith("_id"))]
    return ", ".join(str(condition[k]) if k in ("shape", "learner") else f"{k} {condition[k]}"
                     for k in keys if k in condition)


def pick_runs(plan: dict, finished: Callable[[str], bool]) -> dict[str, dict | None]:
    """Per experiment, the plan entry of the run its video shows: the first seed of its first condition that has a
    finished run (``finished(run_id)``); None if no run of it has finished."""
    entries = {entry["id"]: entry for entry in plan["runs"]}
    chosen: dict[str, dict | None] = {}
    for experiment in plan["experiments"]:
        order = {condition: k for k, condition in enumerate(experiment["condition_ids"])}
        candidates = sorted((entries[run_id] for run_id in experiment["run_ids"] if run_id in entries),
                            key=lambda e: (order.get(e["condition_id"], len(order)), e["seed"]))
        chosen[experiment["name"]] = next((e for e in candidates if finished(e["id"])), None)
    return chosen


def steps_to_show(steps: pd.DataFrame, seconds: float = VIDEO_SECONDS) -> tuple[tuple[int, int], float]:
    """The learning steps (0, last) of a run's steps table that end nearest ``seconds`` of simulated time (at least
    one learning step when the run has one), and the simulated time they span (s)."""
    table = steps.sort_values("step")
    times, numbers = table.time_s.to_numpy(dtype=float), table.step.to_numpy()
    learning = numbers >= 1
    pool = learning if learning.any() else numbers >= 0
    k = int(np.argmin(np.abs(times[pool] - seconds)))
    last = int(numbers[pool][k])
    return (0, last), float(times[pool][k])


def render_videos(root: str | Path, plan: dict | None = None, params: VideoParams = REPORT_VIDEO,
                  seconds: float = VIDEO_SECONDS) -> list[Video]:
    """One Video per experiment of ``root`` (a results directory), rendered into ``root/videos/`` or reused; never
    raises for a run that cannot be replayed (its Video says why)."""
    root = Path(root)
    store = Store(root)
    plan = plan or store.require_plan()
    folder = root / VIDEO_DIR
    folder.mkdir(exist_ok=True)
    names = {experiment["name"] for experiment in plan["experiments"]}
    for old in [*folder.glob("*.mp4"), *folder.glob("*.json")]:
        if old.stem not in names:
            old.unlink()
    videos = []
    varying = {experiment["name"]: experiment.get("varying", []) for experiment in plan["experiments"]}
    for name, entry in pick_runs(plan, lambda run_id: store.status("run", run_id) == "done").items():
        if entry is None:
            videos.append(Video(name, error="no run of this experiment has finished"))
            continue
        video = Video(name, run_id=entry["id"], seed=entry["seed"], label=label(entry["condition"], varying[name]))
        videos.append(_render_one(store, folder, video, params, seconds))
    return videos


def _render_one(store: Store, folder: Path, video: Video, params: VideoParams, seconds: float) -> Video:
    name = video.experiment
    out, record = folder / f"{name}.mp4", folder / f"{name}.json"
    started = time.perf_counter()
    try:
        with store.replayable(video.run_id) as run_dir:
            video.steps, video.simulated_s = steps_to_show(pd.read_parquet(run_dir / "steps.parquet"), seconds)
            shown = dataclasses.replace(params, steps=video.steps)
            from morphbench.render import writers  # OpenCV and PyAV, not the simulator

            encoder = "pyav" if writers.pyav() is not None else "opencv"
            key = json.loads(json.dumps({"run_id": video.run_id, "params": dataclasses.asdict(shown),
                                         "morphbench": _version(), "encoder": encoder}))  # as stored: tuples are lists
            if out.is_file() and _read_json(record).get("key") == key and video_problem(out) is None:
                video.path, video.reused, video.codec = out, True, _read_json(record).get("codec", "")
                return video
            from morphbench.render import render_run  # the simulator, only now

            record.unlink(missing_ok=True)
            video.path = render_run(run_dir, out, shown)
        video.codec = "h264" if encoder == "pyav" else "avc1" if writers._h264_works else "mp4v"
        write_text(record, json.dumps({"key": key, "codec": video.codec, "simulated_s": video.simulated_s},
                                      indent=1, sort_keys=True) + "\n")
    except Exception as exc:  # a replay that fails (shape file gone, records that do not replay...) loses its video
        out.unlink(missing_ok=True)
        video.path, video.error = None, str(exc) if isinstance(exc, ConfigError) else describe(exc)
    finally:
        video.wall_time_s = 0.0 if video.reused else time.perf_counter() - started
    return video


def video_problem(path: Path) -> str | None:
    """Why ``path`` is not a video PyAV decodes (every frame its first video stream declares, at least one), or
    None. Unreadable if this user may not read it."""
    import av  # FFmpeg's decoders, only when a video is looked at

    try:
        with av.open(str(path)) as container:
            if not container.streams.video:
                return "it has no video stream"
            declared = container.streams.video[0].frames
            frames = sum(1 for _ in container.decode(video=0))
    except PermissionError:
        raise Unreadable(path) from None
    except Exception as exc:  # noqa: BLE001 - whatever FFmpeg raises on a damaged file is the answer
        return describe(exc, where=False)[:160]
    if not frames or frames < declared:
        return f"{frames} of its {declared} frames decode"
    return None


def _read_json(path: Path) -> dict:
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def _version() -> str:
    from morphbench import __version__

    return __version__
