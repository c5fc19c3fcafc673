"""The ``morphbench`` command: run and scan write their records; bad input exits 2 with one line naming the problem.

Everything runs in-process through ``morphbench.cli.main`` except one call of the installed console script.
Budgets are tiny (a few learning steps, a 4-point scan of one cycle per point): these test the plumbing, not physics.
"""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pandas as pd
import pytest

from morphbench.identity import shape_id
from morphbench.cli import EXIT_BAD_INPUT
from morphbench.params import LearnerParams
from morphbench.shapes import load_shape

from conftest import SHAPES_DIR as SHAPES, run_cli

CHAIN2 = str(SHAPES / "chain-2.toml")
CHAIN3 = str(SHAPES / "chain-3.toml")
RUN_FILES = {"units.parquet", "steps.parquet", "pieces.parquet", "summary.json", "learning_curve.png",
             "trajectory.png"}
UNIT_COLUMNS = ["step", "unit", "position", "piece", "phase_tried", "phase_kept", "u_measured", "u_true",
                "u_memory", "accepted", "x_m", "y_m", "heading_rad"]  # records.py docs
STEP_COLUMNS = ["step", "time_s", "ubar", "ubar_true", "acceptance", "event", "x_m", "y_m", "heading_rad", "u_heading"]


def short_run(capsys, out: Path, *extra: str, shape: str = CHAIN2) -> tuple[int, str, str]:
    return run_cli(capsys, "run", shape, "--steps", "3", "--out", str(out), "--quiet", *extra)


def snapshot(directory: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(directory.iterdir())}


def assert_one_line_error(err: str, *names: str) -> str:
    """stderr is exactly one 'morphbench: error: ...' line that names each of ``names``."""
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("morphbench: error: "), err
    for name in names:
        assert name in lines[0], f"{name!r} not in {lines[0]!r}"
    return lines[0]


# --- run ----------------------------------------------------------------------------------------------------------


def test_run_writes_records_summary_and_curve(tmp_path: Path, capsys):
    out = tmp_path / "run"
    code, stdout, err = short_run(capsys, out, "--seed", "5")
    assert code == 0, err
    assert "Traceback" not in err
    assert "final Ubar" in stdout
    assert {p.name for p in out.iterdir()} == RUN_FILES  # and no temporary files left behind

    steps = pd.read_parquet(out / "steps.parquet")
    assert list(steps.columns) == STEP_COLUMNS
    assert steps.step.tolist() == [0, 1, 2, 3]
    assert (steps.time_s.diff().dropna() > 0).all()

    units = pd.read_parquet(out / "units.parquet")
    assert list(units.columns) == UNIT_COLUMNS
    assert len(units) == 8
    assert units.step.tolist() == [0, 0, 1, 1, 2, 2, 3, 3]
    assert units.unit.tolist() == [1, 2] * 4
    assert units.accepted.dtype == bool
    for column in ("phase_tried", "phase_kept"):
        assert units[column].between(0.0, 1.0, inclusive="left").all()
    assert units[["u_measured", "u_true"]].notna().all().all()
    # the default optical sensor is close to the truth, not equal to it
    assert (units.u_measured - units.u_true).abs().max() < 0.5
    assert units.u_measured.tolist() != units.u_true.tolist()
    assert steps.ubar.tolist() == pytest.approx(units.groupby("step").u_measured.mean().tolist())

    summary = json.loads((out / "summary.json").read_text())
    for key in ("seed", "final_ubar", "mean_acceptance", "wall_time_s", "config"):
        assert key in summary, key
    assert summary["seed"] == 5
    assert summary["final_ubar"] == pytest.approx(steps.ubar.iloc[-1])  # last 10% of 3 steps is the last step
    assert summary["mean_acceptance"] == pytest.approx(steps.acceptance.iloc[1:].mean())
    assert summary["wall_time_s"] > 0
    config = summary["config"]
    assert config["seed"] == 5 and config["steps"] == 3 and config["learner"] == "thermal"
    assert config["shape"] == {"name": "chain-2", "source": CHAIN2, "n_units": 2,
                               "id": shape_id(load_shape(CHAIN2))}  # render checks the file still holds it
    assert config["learner_params"] == dataclasses.asdict(LearnerParams())  # the defaults
    assert (out / "learning_curve.png").read_bytes().startswith(b"\x89PNG")


def test_run_is_reproducible_by_seed(tmp_path: Path, capsys):
    for name, seed in (("a", "3"), ("b", "3"), ("c", "4")):
        code, _, err = short_run(capsys, tmp_path / name, "--seed", seed)
        assert code == 0, err
    a, b, c = (pd.read_parquet(tmp_path / name / "units.parquet") for name in "abc")
    pd.testing.assert_frame_equal(a, b)
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "a" / "steps.parquet"),
                                  pd.read_parquet(tmp_path / "b" / "steps.parquet"))
    assert not a.equals(c)
    assert a.phase_tried.tolist() != c.phase_tried.tolist()


def test_run_refuses_to_overwrite_without_overwrite(tmp_path: Path, capsys):
    out = tmp_path / "run"
    assert short_run(capsys, out)[0] == 0
    before = snapshot(out)
    code, stdout, err = short_run(capsys, out, "--seed", "1")
    assert code == EXIT_BAD_INPUT
    assert_one_line_error(err, "--out", str(out), "--overwrite")
    assert "final Ubar" not in stdout
    assert snapshot(out) == before  # byte-identical, nothing added

    code, _, err = short_run(capsys, out, "--seed", "1", "--overwrite")
    assert code == 0, err
    assert set(snapshot(out)) == RUN_FILES
    assert json.loads((out / "summary.json").read_text())["seed"] == 1


def test_plugin_learner_runs_end_to_end(tmp_path: Path, capsys, monkeypatch):
    module = "morphbench_test_plugin_learner"
    (tmp_path / f"{module}.py").write_text(textwrap.dedent("""
        class Stubborn:
            '''Keeps phase 0.25 and never accepts anything: easy to recognise in the records.'''
            def __init__(self, params, rng):
                self.phase = 0.25
                self.velocities = []
            def propose(self):
                return self.phase
            def update(self, velocity):
                self.velocities.append(velocity)
                return False
    """))
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, module, raising=False)
    out = tmp_path / "run"
    try:
        code, _, err = short_run(capsys, out, "--learner", f"{module}:Stubborn")
    finally:
        sys.modules.pop(module, None)
    assert code == 0, err
    assert {p.name for p in out.iterdir()} == RUN_FILES
    units = pd.read_parquet(out / "units.parquet")
    assert len(units) == 8
    assert (units.phase_tried == 0.25).all() and (units.phase_kept == 0.25).all()
    assert not units.accepted.any()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["config"]["learner"] == f"{module}:Stubborn"
    assert summary["mean_acceptance"] == 0.0


# --- scan ---------------------------------------------------------------------------------------------------------


def test_scan_two_units(tmp_path: Path, capsys):
    out = tmp_path / "scan"
    code, stdout, err = run_cli(capsys, "scan", CHAIN2, "--resolution", "4", "--cycles", "1", "--out", str(out),
                                "--quiet")
    assert code == 0, err
    assert "max Ubar" in stdout
    assert {p.name for p in out.iterdir()} == {"scan.csv", "scan.png"}
    table = pd.read_csv(out / "scan.csv")
    assert list(table.columns) == ["dphi_2", "ubar"]
    assert table.dphi_2.tolist() == [0.0, 0.25, 0.5, 0.75]
    assert table.ubar.notna().all()


def test_scan_three_units(tmp_path: Path, capsys):
    out = tmp_path / "scan"
    code, _, err = run_cli(capsys, "scan", CHAIN3, "--resolution", "3", "--cycles", "1", "--out", str(out), "--quiet")
    assert code == 0, err
    table = pd.read_csv(out / "scan.csv")
    assert list(table.columns) == ["dphi_2", "dphi_3", "ubar"]
    assert len(table) == 9
    assert len(table[["dphi_2", "dphi_3"]].drop_duplicates()) == 9
    assert table.ubar.notna().all()


# --- bad input: exit 2, one line naming the problem, no traceback -------------------------------------------------


def test_missing_shape_file(tmp_path: Path, capsys):
    shape = tmp_path / "nosuch.toml"
    code, _, err = short_run(capsys, tmp_path / "out", shape=str(shape))
    assert code == EXIT_BAD_INPUT
    assert_one_line_error(err, str(shape), "morphology file")
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("command", ["run", "scan"])
def test_bad_shape_file(tmp_path: Path, capsys, command: str):
    shape = tmp_path / "bad.toml"
    shape.write_text('[assembly]\ngenerator = "chain"\nunits = 2\n[unit]\ncolour = "red"\n')
    out = tmp_path / "out"
    code, _, err = run_cli(capsys, command, str(shape), "--out", str(out), "--quiet")
    assert code == EXIT_BAD_INPUT
    assert_one_line_error(err, str(shape), "unit.colour", "expected one of the known keys")
    assert not out.exists()


@pytest.mark.parametrize(
    "option, value, expected",
    [
        ("--steps", "-1", "expected an integer in [0, 1000000], got '-1'"),
        ("--steps", "abc", "expected an integer in [0, 1000000], got 'abc'"),
        ("--steps", "2.5", "expected an integer in [0, 1000000]"),
        ("--temperature", "-0.1", "expected a number >= 0 or inf (mm/cycle), got '-0.1'"),
        ("--temperature", "nan", "expected a number >= 0 or inf"),
        ("--step-size", "2", "expected a number in [0, 1] (cycles), got '2'"),
        ("--noise", "-1", "expected a number in [0, 1000] (mm/cycle), got '-1'"),
        ("--cycles-per-step", "0", "expected an integer in [1, 1000] (cycles)"),
        ("--physics", "slow", "invalid choice: 'slow'"),
    ],
)
def test_bad_option_value(tmp_path: Path, capsys, option: str, value: str, expected: str):
    """argparse rejects it: usage, then one 'error:' line naming the option and the expected value."""
    out = tmp_path / "out"
    code, _, err = run_cli(capsys, "run", CHAIN2, "--out", str(out), "--quiet", option, value)
    assert code == EXIT_BAD_INPUT
    assert "Traceback" not in err
    error_lines = [line for line in err.splitlines() if "error:" in line]
    assert len(error_lines) == 1, err
    assert err.strip().splitlines()[-1] == error_lines[0]
    assert error_lines[0].startswith(f"morphbench run: error: argument {option}: ")
    assert expected in error_lines[0]
    assert not out.exists()


def test_bad_scan_option_value(tmp_path: Path, capsys):
    code, _, err = run_cli(capsys, "scan", CHAIN2, "--resolution", "0", "--out", str(tmp_path / "out"))
    assert code == EXIT_BAD_INPUT
    assert err.strip().splitlines()[-1].startswith("morphbench scan: error: argument --resolution: expected an integer")


@pytest.mark.parametrize(
    "spec, expected",
    [
        ("nosuch", "'thermal', 'flaky', 'averaged', 'adaptive', 'sparse' or 'random'"),
        ("nosuchmodule:X", "an importable module 'nosuchmodule'"),
        ("json:JSONDecoder", "to have methods propose() and update(velocity) (missing: propose, update)"),
        ("json:NoSuchClass", "to define a class 'NoSuchClass'"),
        ("json:dumps", "to be a class"),
    ],
)
def test_bad_learner(tmp_path: Path, capsys, spec: str, expected: str):
    out = tmp_path / "out"
    code, _, err = short_run(capsys, out, "--learner", spec)
    assert code == EXIT_BAD_INPUT
    assert_one_line_error(err, "--learner", spec, expected)
    assert not out.exists()  # checked before anything is simulated or written


def test_out_is_an_existing_file(tmp_path: Path, capsys):
    out = tmp_path / "results.txt"
    out.write_text("not a directory\n")
    for argv in (["run", CHAIN2, "--steps", "1"], ["scan", CHAIN2, "--resolution", "2", "--cycles", "1"]):
        code, _, err = run_cli(capsys, *argv, "--out", str(out), "--quiet")
        assert code == EXIT_BAD_INPUT
        assert_one_line_error(err, "--out", str(out), "a directory")
        assert out.read_text() == "not a directory\n"


@pytest.mark.parametrize("where", ["under a file", "in /proc"])
def test_out_that_cannot_be_written_is_refused_before_simulating(tmp_path: Path, capsys, where: str):
    # access bits say yes to root in /proc, where no directory can be made: the run was simulated, then lost in a
    # FileNotFoundError. A directory is now made where the run would go (and removed) before anything is simulated.
    if where == "in /proc":
        if not Path("/proc/self").is_dir():
            pytest.skip("no /proc on this system")
        out = Path("/proc") / f"morphbench-{os.getpid()}"
    else:
        (tmp_path / "file.txt").write_text("a file\n")
        out = tmp_path / "file.txt" / "sub"
    code, stdout, err = run_cli(capsys, "run", CHAIN2, "--steps", "1", "--quiet", "--out", str(out))
    assert code == EXIT_BAD_INPUT and stdout == ""
    assert_one_line_error(err, "--out", str(out), "expected a directory that can be written")
    assert not out.exists()


def test_the_out_check_leaves_nothing_when_the_run_is_refused_later(tmp_path: Path, capsys):
    out = tmp_path / "new" / "deeper" / "run"
    code, _, err = run_cli(capsys, "run", CHAIN2, "--steps", "1", "--quiet", "--out", str(out), "--video",
                           str(tmp_path / "video.txt"))  # refused after --out was tried
    assert code == EXIT_BAD_INPUT
    assert_one_line_error(err, "--video")
    assert list(tmp_path.iterdir()) == []  # neither the parents nor the temporary it made
    assert run_cli(capsys, "run", CHAIN2, "--steps", "1", "--quiet", "--out", str(out))[0] == 0
    assert os.listdir(out.parent) == ["run"]  # the writer's own temporary name, gone once it is renamed


def test_scan_needs_two_units(tmp_path: Path, capsys):
    shape = tmp_path / "single.toml"
    shape.write_text('[assembly]\ngenerator = "chain"\nunits = 1\n')
    code, _, err = run_cli(capsys, "scan", str(shape), "--out", str(tmp_path / "out"), "--quiet")
    assert code == EXIT_BAD_INPUT
    assert_one_line_error(err, str(shape), "assembly.units", "at least 2 active units")


def test_no_command_is_an_argparse_error(capsys):
    code, _, err = run_cli(capsys)
    assert code == EXIT_BAD_INPUT
    assert "Traceback" not in err and "error:" in err


# --- the installed console script ---------------------------------------------------------------------------------


def test_console_script_entry_point(tmp_path: Path):
    script = Path(sys.executable).parent / ("morphbench.exe" if sys.platform == "win32" else "morphbench")
    assert script.exists(), f"console script not installed next to {sys.executable}"
    result = subprocess.run(
        [str(script), "run", CHAIN2, "--steps", "1", "--seed", "2", "--out", "out", "--quiet"],
        cwd=tmp_path, capture_output=True, text=True, timeout=120,
    )
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    assert "final Ubar" in result.stdout
    assert {p.name for p in (tmp_path / "out").iterdir()} == RUN_FILES
    assert len(pd.read_parquet(tmp_path / "out" / "units.parquet")) == 4


def test_default_run_directories_tell_configurations_apart(capsys, monkeypatch, tmp_path):
    """The overview's commands one after another: runs that differ (steps, noise) get their own default directory;
    the same configuration again finds its earlier run and says which option to pass."""
    monkeypatch.chdir(tmp_path)
    shape = str(SHAPES / "chain-2.toml")
    written = []
    for extra in ([], ["--noise", "0.5"], ["--steps", "3"]):
        code, out, err = run_cli(capsys, "run", shape, "--steps", "2", "--quiet", *extra)
        assert code == 0, err
        written.append(out.split("records in ")[1].split(" ")[0])
    assert len(set(written)) == 3 and all(w.startswith("runs/chain-2-thermal-seed0-") for w in written)
    code, _, err = run_cli(capsys, "run", shape, "--steps", "2", "--quiet")
    assert code == 2 and written[0].rstrip("/") in err and "--overwrite" in err and "another --out" in err


def test_the_readme_main_job_prints_what_the_readme_shows(capsys, monkeypatch, tmp_path):
    """The README's first command, run: its two lines as the README prints them (but for the wall time), the
    directory included (its configuration's hash)."""
    root = Path(__file__).resolve().parents[1]
    readme = (root / "README.md").read_text(encoding="utf-8")
    command = readme.split("```bash\n")[1].splitlines()[0].split("&& morphbench ")[1].split()
    shown = readme.split("```text\n")[1].split("```")[0].splitlines()
    command = [str(root / word) if word.endswith(".toml") else word for word in command]
    monkeypatch.chdir(tmp_path)
    code, out, err = run_cli(capsys, *command, "--quiet")
    assert code == 0, err
    printed = out.splitlines()
    assert printed[0].rsplit(",", 1)[0] == shown[0].rsplit(",", 1)[0]  # all but the wall time
    assert printed[1] == shown[1]


def test_the_help_names_every_learner_and_shows_examples(capsys):
    from morphbench.learning.plugins import LEARNERS
    from morphbench.params import LEARNER_HELP

    assert all(name in LEARNER_HELP for name in LEARNERS), [n for n in LEARNERS if n not in LEARNER_HELP]
    code, out, _ = run_cli(capsys, "--help")
    assert code == 0 and "``" not in out and "examples:\n  morphbench run chain-2" in out
    for command in (["run", "--help"], ["leaderboard", "--help"]):
        code, out, _ = run_cli(capsys, *command)
        assert code == 0 and "averaged, adaptive" in " ".join(out.split())
    code, out, _ = run_cli(capsys, "run", "--help")
    assert "name of a shipped shape" in " ".join(out.split()) and "after its discarded cycles" in " ".join(out.split())


def test_the_camera_sensor_says_it_moves_the_run_to_pybullet(capsys):
    from morphbench.cli import _say_backend
    from morphbench.experiment import RunConfig
    from morphbench.params import SensorParams

    shape = load_shape(SHAPES / "chain-2.toml")
    _say_backend(RunConfig(shape=shape, sensor=SensorParams(kind="camera")), quiet=False)
    assert "camera sensor renders its images in a scene of the pybullet backend" in capsys.readouterr().err
    _say_backend(RunConfig(shape=shape, sensor=SensorParams(kind="camera")), quiet=True)
    _say_backend(RunConfig(shape=shape, sensor=SensorParams(kind="ideal")), quiet=False)
    assert capsys.readouterr().err == ""


def test_a_refused_replay_draws_no_progress_bar(capsys, tmp_path):
    code, _, err = run_cli(capsys, "run", str(SHAPES / "chain-2.toml"), "--steps", "2", "--quiet", "--out",
                           str(tmp_path / "run"))
    assert code == 0, err
    (tmp_path / "run" / "steps.parquet").write_text("not a table")
    code, _, err = run_cli(capsys, "render", str(tmp_path / "run"), "--out", str(tmp_path / "a.mp4"))
    assert code == 2 and "replay" not in err.split("error")[0] and err.count("\n") == 1, err
