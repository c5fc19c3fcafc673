"""Video of a finished run: replay its configuration (the simulation is deterministic) with a recorder attached.

Before anything is simulated, the stored configuration is read by the rules of ``morphbench run`` (the run-file
loader, ``run_config_from_dict``), its shape file must still be the shape the run had (name, units and, for runs
that stored it, the content's id), and ``steps.parquet`` must have the records' schema (an integer ``step`` 0 to the
run's steps, each once, and a float ``ubar``). The replay is then checked against the run's own records: if its
learning steps do not give the Ubar that ``steps.parquet`` recorded (the learner changed since, or another PyBullet
build), no video is written and a ConfigError says where they part.

``phase_maps`` needs no replay: the kept phases and poses at the end of each step are in ``units.parquet``.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Callable

import numpy as np
import pandas as pd

from morphbench.errors import ConfigError
from morphbench.experiment import RunConfig, run
from morphbench.experiment.config import run_config_from_dict
from morphbench.files import is_dir, is_file
from morphbench.identity import shape_id
from morphbench.params import VideoParams
from morphbench.render.checks import check_output_path, check_video_params, resolve_view
from morphbench.render.views import open_recorder

REPLAY_TOLERANCE = 1e-6
"""mm/cycle: a replayed step's Ubar may differ from the recorded one by this much (Parquet stores the exact float)."""


class _Done(Exception):
    """Raised from the progress callback once the last step the video shows has been simulated."""


def load_run(run_dir: str | os.PathLike) -> tuple[RunConfig, pd.DataFrame]:
    """The configuration and recorded ``steps.parquet`` table of a finished run; ConfigError if ``run_dir`` is not a
    run directory written by ``morphbench run`` (its summary.json holds the configuration) or a finished run of a
    suite's results directory, ``DIR/runs/<run_id>/`` (its result.json holds summary.json's content under
    ``summary``)."""
    path = Path(run_dir)
    expected = ("a run directory written by `morphbench run` (summary.json and steps.parquet) or by `morphbench "
                "bench` (DIR/runs/<run_id>: result.json and steps.parquet)")
    if not is_dir(path):
        raise ConfigError(str(run_dir), "(directory)", expected, "no such directory")
    summary_file, steps_file = path / "summary.json", path / "steps.parquet"
    in_suite = not is_file(summary_file) and is_file(path / "result.json")
    if in_suite:
        summary_file = path / "result.json"
    for file in (summary_file, steps_file):
        if not is_file(file):
            raise ConfigError(str(run_dir), file.name, expected, "missing")
    try:
        summary = json.loads(summary_file.read_text(encoding="utf-8"))
        config_data = (summary["summary"] if in_suite else summary)["config"]
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, KeyError, TypeError) as exc:
        written = "a suite run's result.json" if in_suite else "a summary.json"
        raise ConfigError(str(summary_file), "config", f"{written} written by morphbench ({exc})") from None
    key = "summary.config" if in_suite else "config"
    config = run_config_from_dict(config_data, str(summary_file), key)
    _check_shape(config, config_data["shape"], str(summary_file), key)
    _check_ground(config, str(summary_file), key)
    try:
        steps = pd.read_parquet(steps_file)
    except Exception as exc:  # pyarrow raises its own types for a damaged file
        raise ConfigError(str(steps_file), "(file)", f"a steps table written by morphbench ({exc})") from None
    _check_steps(steps, config.steps, str(steps_file))
    return config, steps


def _check_shape(config: RunConfig, stored: dict, source: str, key: str) -> None:
    """ConfigError unless the shape file loaded now is the one the run had: its name and units, and its content's id
    where the run stored one (a file swapped for another of as many units would replay, and show, another robot)."""
    shape = config.shape
    for name, now in (("name", shape.name), ("n_units", shape.n_units), ("id", shape_id(shape))):
        if (name in stored or name != "id") and stored.get(name) != now:
            raise ConfigError(source, f"{key}.shape.{name}", f"the shape the run had; its file {shape.source} now "
                                                             f"holds another ({name} {now!r})", stored.get(name))


def _check_ground(config: RunConfig, source: str, key: str) -> None:
    """ConfigError unless the ground image the configuration names (``environment.ground.image``) is still one the
    sensors load (sensing.ground: an existing image OpenCV reads, of a size it takes), whatever the run's sensor. An
    ideal sensor never reads it, and the video draws its own ground; but the replay re-runs the configuration, and
    one naming an input that is gone is no longer the run's (as a shape file that changed: ``_check_shape``)."""
    if not config.environment.ground.image:
        return
    from morphbench.sensing.ground import GroundTexture  # the one loader of grounds; not its cache, which may hold
                                                         # the image as it was when this process first loaded it
    try:
        GroundTexture(config.environment.ground)
    except ConfigError as exc:  # named by the file and key the image came from, not by the sensor's parameters
        raise ConfigError(source, f"{key}.environment.ground.{exc.key}", exc.expected, exc.got) from None


def _check_steps(steps: pd.DataFrame, last: int, source: str) -> None:
    """ConfigError unless ``steps`` has the records' schema where a replay reads it: an integer ``step`` holding 0 to
    ``last`` each once, and a float ``ubar``."""
    for column, kinds, what in (("step", "iu", "integers"), ("ubar", "f", "floats")):
        if column not in steps.columns:
            raise ConfigError(source, "columns", f"a steps table with '{column}'", list(steps.columns))
        if steps[column].dtype.kind not in kinds:
            raise ConfigError(source, column, f"a column of {what}", str(steps[column].dtype))
    if sorted(steps.step.tolist()) != list(range(last + 1)):
        raise ConfigError(source, "step", f"the learning steps 0 to {last} of the run, each once",
                          f"{len(steps)} rows from {steps.step.min()} to {steps.step.max()}" if len(steps) else
                          "no rows")


def render_run(run_dir: str | os.PathLike, out_path: str | os.PathLike, params: VideoParams = VideoParams(),
               progress: Callable[[int, int], None] | None = None) -> Path:
    """Replay the run in ``run_dir`` (``morphbench run``'s output, or ``DIR/runs/<run_id>`` of a suite: see
    ``load_run``) and write its video to ``out_path`` (.mp4 or .gif); returns the path.

    Only the learning steps up to the last one the video shows (``params.steps``) are simulated. ``progress(done,
    total)``, if given, is called after each replayed learning step (for a progress bar). Bad input (run directory,
    output path, parameters, a steps range outside the run) and a replay that does not reproduce the recorded
    Ubar raise ConfigError, and then no video is written.
    """
    check_video_params(params)
    check_output_path(out_path, "--out")
    config, recorded = load_run(run_dir)
    last = config.steps
    if params.steps is not None:
        first, wanted = params.steps
        if first > config.steps:
            raise ConfigError("--video-steps", "steps", f"a range within the run's steps 0 to {config.steps}",
                              params.steps)
        last = config.steps if wanted is None else min(wanted, config.steps)
    total = last + 1
    replayed = []

    with open_recorder(config.shape, out_path, params, source="--out") as recorder:
        def on_step(step, records):
            recorder.progress(step, records)
            if progress is not None:
                progress(step + 1, total)
            if step >= last:
                replayed.append(records)
                raise _Done

        try:
            replayed.append(run(config, on_step, recorder))
        except _Done:
            pass
        _check_replay(run_dir, recorded, replayed[0].steps(), last)
    return recorder.path


def _check_replay(run_dir, recorded: pd.DataFrame, replayed: pd.DataFrame, last: int) -> None:
    """ConfigError at the first step whose replayed Ubar differs from the recorded one."""
    expected = recorded[recorded.step <= last].sort_values("step")
    if list(expected.step) != list(replayed.step):
        raise ConfigError(str(run_dir), "steps.parquet", f"the steps 0 to {last} the replay simulated",
                          f"steps {list(expected.step)[:5]}...")
    a, b = expected.ubar.to_numpy(float), replayed.ubar.to_numpy(float)
    same = np.isclose(a, b, rtol=0, atol=REPLAY_TOLERANCE, equal_nan=True)
    if not same.all():
        k = int(np.flatnonzero(~same)[0])
        raise ConfigError(
            str(run_dir), "steps.parquet",
            "a run that its summary.json replays exactly (has the shape file, the learner or PyBullet changed since?)",
            f"step {int(expected.step.iloc[k])}: recorded Ubar {a[k]:+.6f} mm/cycle, replayed {b[k]:+.6f}")


PHASE_COLUMNS = {"step": "iu", "position": "iu", "phase_kept": "f", "x_m": "f", "y_m": "f", "heading_rad": "f"}
"""the columns of units.parquet a phase map reads, and their dtype kinds."""


def phase_maps(run_dir: str | os.PathLike, out_path: str | os.PathLike, steps: list[int]) -> Path:
    """A PNG at ``out_path`` of the kept phases over the assembly of the run in ``run_dir`` (as ``load_run``) at the
    end of each of ``steps``: one panel per step, every unit its footprint at its pose, coloured on the cyclic phase
    map (``plots.phase_maps``). Read from its ``units.parquet``; nothing is simulated. ConfigError (naming --out,
    --phases or the file) for an output that is not a .png, a step the run does not have, a shape not in one layer
    or a units table without the columns."""
    out = check_output_path(out_path, "--out", (".png",))
    config, _ = load_run(run_dir)
    shape = config.shape
    resolve_view(shape, VideoParams(view="top"), "--phases")
    wrong = [step for step in steps if not 0 <= step <= config.steps]
    if wrong:
        raise ConfigError("--phases", ",".join(map(str, steps)), f"learning steps of this run, 0 to {config.steps}",
                          wrong[0])
    units_file = Path(run_dir) / "units.parquet"
    if not is_file(units_file):
        raise ConfigError(str(run_dir), "units.parquet", "a run's units table (written by morphbench run)",
                          "missing")
    try:
        units = pd.read_parquet(units_file, columns=list(PHASE_COLUMNS))
    except Exception as exc:  # a column missing or a damaged file: pyarrow's own error types
        raise ConfigError(str(units_file), "(file)", "a units table written by morphbench with the columns "
                          f"{', '.join(PHASE_COLUMNS)} ({exc})") from None
    for column, kinds in PHASE_COLUMNS.items():
        if units[column].dtype.kind not in kinds:
            raise ConfigError(str(units_file), column, "a column of numbers", str(units[column].dtype))
    missing = sorted(set(steps) - set(units.step.unique().tolist()))
    if missing:
        raise ConfigError(str(units_file), "step", "a row per unit at every step of the run", f"none at {missing[0]}")
    from morphbench import plots

    half = np.array([shape.bodies[body].size[:2] for body in shape.units], dtype=float) / 2
    return plots.phase_maps(units, half, steps, out, title=f"{shape.name}: kept phases")
