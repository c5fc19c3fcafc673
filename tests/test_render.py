"""Off-screen video: files that decode with the right frames, motion shown the way the robot moved, replays that show
the same run, and bad paths or options caught before anything is simulated."""

import argparse
import sys
from types import SimpleNamespace

import cv2
import numpy as np
import pandas as pd
import pytest
from PIL import Image

from morphbench.bench.store import Store
from morphbench.errors import ConfigError
from morphbench.experiment import RunConfig, run
from morphbench.params import LearnerParams, VideoParams
from morphbench.physics import World
from morphbench.render import (
    VideoRecorder,
    add_render_arguments,
    pressure_colour,
    render_run,
    video_params_from_args,
    writers,
)
from morphbench.shapes import load_shape

from conftest import SHAPES_DIR

CHAIN_2 = load_shape(SHAPES_DIR / "chain-2.toml")
CHAIN_3 = load_shape(SHAPES_DIR / "chain-3.toml")
SMALL = VideoParams(width=160, height=90, fps=10, speed=4)  # a frame every 0.4 s of simulated time: 5 per cycle
FORWARD_WAVE, BACKWARD_WAVE = (0.0, 0.4, 0.8), (0.0, 0.6, 0.2)  # +3.9 and -4.3 mm/cycle for chain-3


def decode(path) -> tuple[list[np.ndarray], float]:
    """Every frame (RGB) of a video file, and its frame rate."""
    capture = cv2.VideoCapture(str(path))
    assert capture.isOpened(), f"{path} does not open"
    fps, frames = capture.get(cv2.CAP_PROP_FPS), []
    ok, frame = capture.read()
    while ok:
        frames.append(cv2.cvtColor(frame, cv2.COLOR_BGR2RGB))
        ok, frame = capture.read()
    capture.release()
    return frames, fps


def record_fixed_phases(shape, phases, path, params, cycles) -> VideoRecorder:
    with World(shape) as world, VideoRecorder(world, path, params) as recorder:
        world.set_phases(phases)
        world.advance(world.ticks_in(cycles * shape.actuator.cycle_time), lambda k: recorder(world))
    return recorder


def test_mp4_decodes_with_the_expected_frame_count_size_and_rate(tmp_path):
    params = VideoParams(width=160, height=90, fps=10, speed=4, overlay=False)
    recorder = record_fixed_phases(CHAIN_2, (0.0, 0.4), tmp_path / "v.mp4", params, cycles=4)
    frames, fps = decode(tmp_path / "v.mp4")
    simulated = 4 * CHAIN_2.actuator.cycle_time
    assert abs(len(frames) - simulated * params.fps / params.speed) <= 1
    assert len(frames) == recorder.frames
    assert recorder.codec == "h264"  # PyAV, a test dependency through the package's own
    assert frames[0].shape == (90, 160, 3)
    assert fps == pytest.approx(10)
    # the pumps recolour the units and the camera follows them: consecutive frames differ
    changes = [np.abs(a.astype(int) - b.astype(int)).mean() for a, b in zip(frames, frames[1:])]
    assert np.mean(np.array(changes) > 0.5) > 0.8
    assert sorted(p.name for p in tmp_path.iterdir()) == ["v.mp4"]  # no temporary file left behind


@pytest.mark.parametrize("phases", [FORWARD_WAVE, BACKWARD_WAVE], ids=["forward", "backward"])
def test_the_assembly_moves_across_a_fixed_camera_the_way_it_travels(tmp_path, phases):
    params = VideoParams(width=160, height=90, fps=10, speed=4, follow=False, overlay=False)
    recorder = record_fixed_phases(CHAIN_3, phases, tmp_path / "v.mp4", params, cycles=10)
    frames, _ = decode(tmp_path / "v.mp4")

    def unit_centroid(frame) -> float:
        """Column of the centroid of the coloured pixels: the units (blue to red); ground and dummy are grey."""
        rgb = frame.astype(int)
        columns = np.nonzero(rgb.max(axis=2) - rgb.min(axis=2) > 60)[1]
        assert len(columns) > 50
        return float(columns.mean())

    per_cycle = 5  # frames per actuation cycle: average whole cycles so the pump strokes cancel
    image_shift = np.mean([unit_centroid(f) for f in frames[-per_cycle:]]) - np.mean(
        [unit_centroid(f) for f in frames[:per_cycle]])
    travel = np.mean(recorder.positions[-1][:, 0]) - np.mean(recorder.positions[0][:, 0])  # m, along +x
    assert abs(travel) > 0.025
    assert np.sign(image_shift) == np.sign(travel) and abs(image_shift) > 4  # +x is left to right


def test_replay_renders_the_same_motion_as_the_live_recording(tmp_path, monkeypatch):
    # libx264 does not always give the same bytes for the same frames (render.writers): compare the rendered frames
    # exactly through the OpenCV writer, whose encoding of the same frames is the same
    monkeypatch.setattr(writers, "pyav", lambda: None)
    config = RunConfig(shape=CHAIN_2, steps=2, seed=3)
    with VideoRecorder(None, tmp_path / "live.mp4", SMALL) as live:
        records = run(config, progress=live.progress, on_tick=live)
    # an observer does not change the run
    pd.testing.assert_frame_equal(records.steps(), run(config).steps())
    records.write(tmp_path / "run")
    out = render_run(tmp_path / "run", tmp_path / "replay.mp4", SMALL)
    assert out == tmp_path / "replay.mp4"
    live_frames, _ = decode(tmp_path / "live.mp4")
    replay_frames, _ = decode(out)
    assert len(live_frames) == len(replay_frames) == live.frames
    assert all(np.array_equal(a, b) for a, b in zip(live_frames, replay_frames))

    # only the chosen steps: step 1 lasts its discarded and measured cycles, at 10 frames/s and speed 4; the
    # replay stops after it
    steps = []
    step_1 = VideoParams(width=160, height=90, fps=10, speed=4, steps=(1, 1))
    render_run(tmp_path / "run", tmp_path / "step1.mp4", step_1, progress=lambda *done_of: steps.append(done_of))
    lp = LearnerParams()
    expected = (lp.cycles_per_step + lp.discard_cycles) * CHAIN_2.actuator.cycle_time * 10 / 4
    assert abs(len(decode(tmp_path / "step1.mp4")[0]) - expected) <= 1
    assert steps == [(1, 2), (2, 2)]


def test_a_run_of_a_suite_replays_from_its_result_json(tmp_path):
    records = run(RunConfig(shape=CHAIN_2, steps=1, seed=2))
    job = SimpleNamespace(kind="run", id="abc123")
    run_dir = Store(tmp_path / "suite").save(job, {"status": "done", "steps": records.steps(), "units": records.units(),
                                                   "summary": records.summary()})
    assert not (run_dir / "summary.json").exists()
    out = render_run(run_dir, tmp_path / "v.mp4", SMALL)
    assert len(decode(out)[0]) > 5
    (run_dir / "result.json").write_text("{}")
    with pytest.raises(ConfigError, match="result.json: config: expected a suite run's result.json"):
        render_run(run_dir, tmp_path / "v.mp4", SMALL)


def test_a_replay_that_does_not_reproduce_the_records_writes_nothing(tmp_path):
    records = run(RunConfig(shape=CHAIN_2, steps=1, seed=0))
    records.write(tmp_path / "run")
    table = pd.read_parquet(tmp_path / "run" / "steps.parquet")
    table.loc[table.step == 1, "ubar"] += 0.5
    table.to_parquet(tmp_path / "run" / "steps.parquet", index=False)
    with pytest.raises(ConfigError, match="step 1: recorded Ubar"):
        render_run(tmp_path / "run", tmp_path / "v.mp4", SMALL)
    assert not (tmp_path / "v.mp4").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


def synthetic_frames(n: int, width: int = 96, height: int = 64) -> list[np.ndarray]:
    """``n`` RGB frames, a bright square moving across a dark ground (one pixel column per frame)."""
    frames = []
    for k in range(n):
        frame = np.full((height, width, 3), 40, np.uint8)
        frame[20:40, 10 + k:30 + k] = (230, 60, 30)
        frames.append(frame)
    return frames


def write_frames(writer_class, path, frames, fps=12.5):
    height, width = frames[0].shape[:2]
    writer = writer_class(path, (width, height), fps, path, "--video")
    for frame in frames:
        writer.write(frame)
    writer.close()
    return writer


def test_the_h264_writer_writes_what_browsers_play(tmp_path):
    import av

    frames = synthetic_frames(37)
    writer = write_frames(writers.H264Writer, tmp_path / "v.mp4", frames)
    assert writer.codec == "h264"
    with av.open(str(tmp_path / "v.mp4")) as container:
        stream = container.streams.video[0]
        assert stream.codec_context.name == "h264"
        assert stream.codec_context.pix_fmt == "yuv420p"  # what browsers decode (not yuv444p, not mpeg4)
        assert (stream.codec_context.width, stream.codec_context.height) == (96, 64)
        assert stream.average_rate == 12.5
        decoded = [frame.to_ndarray(format="rgb24") for frame in container.decode(video=0)]
    assert len(decoded) == len(frames)  # the encoder's delayed frames were flushed
    # lossy, but the square is where it was in every frame
    assert all(np.abs(a.astype(int) - b).mean() < 3 for a, b in zip(decoded, frames))
    assert writers.open_writer(tmp_path / "x.mp4", (96, 64), 10, tmp_path / "x.mp4", "--video").codec == "h264"


def test_h264_needs_an_even_frame_size(tmp_path):
    with pytest.raises(ConfigError, match="even width and height"):
        writers.H264Writer(tmp_path / "v.mp4", (95, 64), 10, tmp_path / "v.mp4", "--video")


def test_without_pyav_mp4_goes_through_opencv(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "av", None)  # import av raises ImportError
    assert writers.pyav() is None
    frames = synthetic_frames(20)
    writer = writers.open_writer(tmp_path / "v.mp4", (96, 64), 10, tmp_path / "v.mp4", "--video")
    assert isinstance(writer, writers.Mp4Writer) and writer.codec in ("avc1", "mp4v")
    for frame in frames:
        writer.write(frame)
    writer.close()
    decoded, fps = decode(tmp_path / "v.mp4")
    assert len(decoded) == len(frames) and fps == pytest.approx(10)
    assert isinstance(writers.open_writer(tmp_path / "v.gif", (96, 64), 10, tmp_path / "v.gif", "--video"),
                      writers.GifWriter)


def test_an_h264_writer_aborted_before_any_frame_does_not_raise(tmp_path):
    writer = writers.H264Writer(tmp_path / "v.mp4", (96, 64), 10, tmp_path / "v.mp4", "--video")
    writer.abort()  # no frame written: closing must not raise
    writer.abort()


def test_gif_output(tmp_path):
    recorder = record_fixed_phases(CHAIN_2, (0.0, 0.4), tmp_path / "v.gif", SMALL, cycles=2)
    with Image.open(tmp_path / "v.gif") as gif:
        assert gif.size == (160, 90)
        assert gif.n_frames > 2
        total_ms = 0
        for k in range(gif.n_frames):
            gif.seek(k)
            total_ms += gif.info["duration"]
    assert total_ms == pytest.approx(recorder.frames * 1000 / SMALL.fps, abs=10)  # identical frames may merge


@pytest.mark.parametrize("name, message", [
    ("v.avi", "ending in .mp4 or .gif"),
    ("missing/v.mp4", "existing directory"),
    ("", "ending in .mp4 or .gif"),
])
def test_a_bad_output_path_is_refused_before_anything_runs(tmp_path, name, message):
    with pytest.raises(ConfigError, match=message) as error:
        VideoRecorder(None, tmp_path / name if name else tmp_path, SMALL)
    assert error.value.source == "--video"
    with pytest.raises(ConfigError, match=message) as error:
        render_run(tmp_path, tmp_path / name if name else tmp_path, SMALL)  # the output is checked first
    assert error.value.source == "--out"


def test_a_directory_named_like_a_video_is_refused(tmp_path):
    (tmp_path / "v.mp4").mkdir()
    with pytest.raises(ConfigError, match="this is a directory"):
        VideoRecorder(None, tmp_path / "v.mp4", SMALL)


@pytest.mark.parametrize("change, key", [
    ({"fps": 0}, "fps"), ({"width": 161}, "width"), ({"height": 8}, "height"), ({"speed": -1.0}, "speed"),
    ({"steps": (3, 1)}, "steps"), ({"steps": (-1, None)}, "steps"), ({"pitch": 10.0}, "pitch"),
    ({"distance": float("nan")}, "distance"),
])
def test_bad_video_parameters_are_config_errors(tmp_path, change, key):
    params = VideoParams(**{**SMALL.__dict__, **change})
    with pytest.raises(ConfigError) as error:
        VideoRecorder(None, tmp_path / "v.mp4", params)
    assert error.value.key == key
    assert not list(tmp_path.iterdir())


def test_a_fast_gif_is_refused(tmp_path):
    with pytest.raises(ConfigError, match="GIF"):
        VideoRecorder(None, tmp_path / "v.gif", VideoParams(fps=60))


def test_a_bad_run_directory_is_a_config_error(tmp_path):
    with pytest.raises(ConfigError, match="no such directory"):
        render_run(tmp_path / "nowhere", tmp_path / "v.mp4", SMALL)
    with pytest.raises(ConfigError, match="summary.json"):
        render_run(tmp_path, tmp_path / "v.mp4", SMALL)
    (tmp_path / "summary.json").write_text("{not json")
    (tmp_path / "steps.parquet").write_bytes(b"")
    with pytest.raises(ConfigError, match="summary.json"):
        render_run(tmp_path, tmp_path / "v.mp4", SMALL)


def test_steps_outside_the_run_are_a_config_error(tmp_path):
    run(RunConfig(shape=CHAIN_2, steps=1)).write(tmp_path / "run")
    with pytest.raises(ConfigError, match="within the run's steps 0 to 1") as error:
        render_run(tmp_path / "run", tmp_path / "v.mp4", VideoParams(steps=(5, 9)))
    assert error.value.source == "--video-steps"


def test_a_recorder_that_saw_no_frame_leaves_no_file(tmp_path):
    with pytest.raises(ConfigError, match="none was recorded"):
        with World(CHAIN_2) as world, VideoRecorder(world, tmp_path / "v.mp4", VideoParams(steps=(3, 4))) as video:
            world.advance(120, lambda k: video(world))  # stays at step 0
    assert not list(tmp_path.iterdir())


def test_an_error_during_the_run_leaves_no_file(tmp_path):
    with pytest.raises(RuntimeError, match="boom"):
        with World(CHAIN_2) as world, VideoRecorder(world, tmp_path / "v.mp4", SMALL) as video:
            world.advance(120, lambda k: video(world))
            raise RuntimeError("boom")
    assert not list(tmp_path.iterdir())


def test_units_are_coloured_by_pressure_and_damaged_ones_black(tmp_path):
    assert pressure_colour(0.0)[2] > pressure_colour(0.0)[0]  # empty: blue
    assert pressure_colour(1.0)[0] > pressure_colour(1.0)[2]  # full: red
    assert pressure_colour(0.7, damaged=True)[:3] == (0.05, 0.05, 0.05)
    params = VideoParams(width=160, height=90, overlay=False)
    with World(CHAIN_2) as world:
        recorder = VideoRecorder(world, tmp_path / "v.mp4", params)
        healthy = recorder.render()
        recorder.damaged = {0}
        damaged = recorder.render()
        recorder.abort()
    dark = lambda image: int((image.max(axis=2) < 30).sum())  # noqa: E731
    assert dark(healthy) < 5 < dark(damaged)


def test_command_line_options_give_video_params():
    parser = argparse.ArgumentParser()
    add_render_arguments(parser)
    args = parser.parse_args(["--video", "out.mp4", "--video-width", "320", "--video-fps", "24",
                              "--video-speed", "10", "--video-steps", "5:"])
    assert args.video == "out.mp4"
    params = video_params_from_args(args)
    assert (params.width, params.height, params.fps, params.speed, params.steps) == (320, 360, 24, 10, (5, None))
    assert video_params_from_args(parser.parse_args(["--video-steps", "3:7"])).steps == (3, 7)
    assert video_params_from_args(parser.parse_args([])) == VideoParams()
    for bad in (["--video-width", "321"], ["--video-fps", "0"], ["--video-steps", "7:3"], ["--video-speed", "x"]):
        with pytest.raises(SystemExit):
            parser.parse_args(bad)
    no_output = argparse.ArgumentParser()
    add_render_arguments(no_output, output=False)
    assert "video" not in vars(no_output.parse_args([]))
