"""A run directory is written whole: a run that is killed or interrupted leaves the earlier run complete (or
nothing), never a mix of two runs or half of one; --overwrite is refused before the simulation where it cannot work."""

from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from morphbench.cli import EXIT_BAD_INPUT, EXIT_INTERRUPTED
from morphbench.errors import ConfigError
from morphbench.files import replace_directory, replace_section

from conftest import ROOT, SHAPES_DIR, run_cli, shown_lines

PATIENCE_S = 120.0
"""How long a test waits for a command before it gives up (a hang, not a measurement: a cold checkout compiles its
numba functions first, slowly on a loaded machine)."""

CHAIN2 = str(SHAPES_DIR / "chain-2.toml")
RUN_FILES = {"units.parquet", "steps.parquet", "pieces.parquet", "summary.json", "learning_curve.png",
             "trajectory.png"}


def _cli(*argv: str, path: Path | None = None) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT)] + ([str(path)] if path else []))}
    return subprocess.Popen([sys.executable, "-m", "morphbench.cli", *argv], env=env, cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _assert_one_complete_run(out: Path, allowed_steps: set[int]) -> int:
    """``out`` holds every file of one run and nothing else; its step count (one of ``allowed_steps``)."""
    assert set(os.listdir(out)) == RUN_FILES
    steps = json.loads((out / "summary.json").read_text())["config"]["steps"]
    assert steps in allowed_steps
    for table in ("units", "steps", "pieces"):  # every table from the same run as the summary
        assert pd.read_parquet(out / f"{table}.parquet").step.max() == steps
    return steps


def test_replace_directory_swaps_whole_or_not_at_all(tmp_path: Path):
    target = tmp_path / "run"
    replace_directory(target, lambda d: (d / "a").write_text("old"))
    replace_directory(target, lambda d: (d / "b").write_text("new"))
    assert os.listdir(target) == ["b"] and os.listdir(tmp_path) == ["run"]

    def half(directory: Path):
        (directory / "c").write_text("half")
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        replace_directory(target, half)
    assert os.listdir(target) == ["b"] and os.listdir(tmp_path) == ["run"]  # no temporary directory left


def test_replace_section_keeps_the_markers_and_the_rest(tmp_path: Path):
    doc = tmp_path / "page.md"
    doc.write_text("head\n<!-- a -->\nold\n<!-- b -->\ntail <!-- b -->\n")
    replace_section(doc, "<!-- a -->", "<!-- b -->", "\nnew\n")
    assert doc.read_text() == "head\n<!-- a -->\nnew\n<!-- b -->\ntail <!-- b -->\n"
    with pytest.raises(ConfigError, match="page.md.*generated-section markers <!-- a --> and <!-- c -->"):
        replace_section(doc, "<!-- a -->", "<!-- c -->", "x")
    assert doc.read_text() == "head\n<!-- a -->\nnew\n<!-- b -->\ntail <!-- b -->\n"  # nothing written
    with pytest.raises(ConfigError, match="missing.md"):
        replace_section(tmp_path / "missing.md", "<!-- a -->", "<!-- b -->", "x")


def test_overwrite_replaces_the_whole_run(tmp_path: Path, capsys):
    out = tmp_path / "run"
    assert run_cli(capsys, "run", CHAIN2, "--steps", "3", "--quiet", "--out", str(out))[0] == 0
    assert run_cli(capsys, "run", CHAIN2, "--steps", "2", "--quiet", "--out", str(out), "--overwrite")[0] == 0
    assert _assert_one_complete_run(out, {2}) == 2
    assert os.listdir(tmp_path) == ["run"]


@pytest.mark.parametrize("setup, expected", [
    (lambda out: (out.mkdir(), (out / "notes.txt").write_text("mine")),
     "a new or empty directory (it holds notes.txt)"),
    (lambda out: out.write_text("a file"), "a directory (this is a file)"),
])
def test_out_that_cannot_be_used_is_refused_before_simulating(tmp_path: Path, capsys, setup, expected):
    out = tmp_path / "run"
    setup(out)
    before = sorted(os.listdir(tmp_path))
    code, stdout, err = run_cli(capsys, "run", CHAIN2, "--steps", "2", "--quiet", "--out", str(out))
    assert code == EXIT_BAD_INPUT and stdout == ""
    assert err == f"morphbench: error: --out: {out}: expected {expected}\n"
    assert sorted(os.listdir(tmp_path)) == before


def test_overwrite_keeps_files_that_are_not_a_runs(tmp_path: Path, capsys):
    out = tmp_path / "run"
    assert run_cli(capsys, "run", CHAIN2, "--steps", "1", "--quiet", "--out", str(out))[0] == 0
    (out / "notes.txt").write_text("mine")
    code, stdout, err = run_cli(capsys, "run", CHAIN2, "--steps", "1", "--quiet", "--out", str(out), "--overwrite")
    assert code == EXIT_BAD_INPUT and stdout == ""
    assert "it also holds notes.txt" in err and len(shown_lines(err)) == 1
    assert (out / "notes.txt").read_text() == "mine"


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only directories")
def test_overwrite_in_a_read_only_directory_is_refused_before_simulating(tmp_path: Path, capsys):
    parent = tmp_path / "ro"
    out = parent / "run"
    assert run_cli(capsys, "run", CHAIN2, "--steps", "1", "--quiet", "--out", str(out))[0] == 0
    parent.chmod(0o555)
    try:
        code, _, err = run_cli(capsys, "run", CHAIN2, "--steps", "1", "--quiet", "--out", str(out), "--overwrite")
    finally:
        parent.chmod(0o755)
    assert code == EXIT_BAD_INPUT and "is not a writable directory" in err


def test_a_video_step_range_after_the_run_is_refused_before_simulating(tmp_path: Path, capsys):
    out = tmp_path / "run"
    code, stdout, err = run_cli(capsys, "run", CHAIN2, "--steps", "3", "--quiet", "--out", str(out),
                                "--video", str(tmp_path / "v.gif"), "--video-steps", "5:8")
    assert code == EXIT_BAD_INPUT and stdout == ""
    assert err == ("morphbench: error: --video-steps: steps: expected learning steps of this run, which ends at "
                   "step 3, got '5:8'\n")
    assert os.listdir(tmp_path) == []


STEPPING = '''
from pathlib import Path


class Stepping:
    """Thermal's phase, never a change; touches STARTED once a learning step has been simulated."""

    def __init__(self, params, rng):
        self.phase = 0.25

    def propose(self):
        return self.phase

    def update(self, velocity):
        Path({started!r}).touch()
        return False
'''


def test_ctrl_c_during_a_run_is_one_line_and_leaves_the_old_run(tmp_path: Path, tmp_path_factory, capsys):
    out, plugins = tmp_path / "run", tmp_path_factory.mktemp("plugins")
    started = plugins / "started"
    (plugins / "mb_stepping.py").write_text(STEPPING.format(started=str(started)))
    assert run_cli(capsys, "run", CHAIN2, "--steps", "2", "--quiet", "--out", str(out))[0] == 0
    process = _cli("run", CHAIN2, "--steps", "100000", "--physics", "fast", "--learner", "mb_stepping:Stepping",
                   "--quiet", "--out", str(out), "--overwrite", path=plugins)
    try:
        deadline = time.monotonic() + PATIENCE_S
        while not started.exists() and process.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)  # until the run is simulating: a fixed delay may land in the imports on a busy machine
        process.send_signal(signal.SIGINT)
        stdout, stderr = process.communicate(timeout=PATIENCE_S)
    finally:
        process.kill()  # a command that did not stop is not left running
    assert started.exists(), stderr
    assert process.returncode == EXIT_INTERRUPTED, stderr
    assert stdout == ""
    assert stderr == f"morphbench: interrupted; nothing of this run was written to {out}\n"
    assert _assert_one_complete_run(out, {2}) == 2
    assert os.listdir(tmp_path) == ["run"]


def test_a_killed_overwrite_leaves_the_old_run_or_the_new_one(tmp_path: Path, capsys):
    """SIGKILL at random moments from the start of the simulation to the end of writing (a 60-step run takes about
    a second and its writing, figures included, about as long): each time the directory is one complete run."""
    out = tmp_path / "run"
    assert run_cli(capsys, "run", CHAIN2, "--steps", "2", "--quiet", "--out", str(out))[0] == 0
    started = time.perf_counter()
    process = _cli("run", CHAIN2, "--steps", "60", "--quiet", "--out", str(out), "--overwrite")
    process.communicate(timeout=PATIENCE_S)
    full = time.perf_counter() - started
    assert process.returncode == 0 and _assert_one_complete_run(out, {60}) == 60
    rng = random.Random(13)
    for _ in range(6):
        before = _assert_one_complete_run(out, {40, 60})
        steps = 100 - before  # each attempt writes the other step count
        process = _cli("run", CHAIN2, "--steps", str(steps), "--quiet", "--out", str(out), "--overwrite")
        time.sleep(rng.uniform(0.5 * full, 1.1 * full))
        process.kill()
        process.communicate(timeout=PATIENCE_S)
        _assert_one_complete_run(out, {before, steps})
    # a killed run leaves at most its hidden temporary directory beside the run
    assert all(name == "run" or name.startswith(".run.tmp-") for name in os.listdir(tmp_path))


def test_ctrl_c_before_a_run_starts_is_one_line(tmp_path: Path, capsys, monkeypatch):
    import morphbench.experiment

    def interrupted(path, **options):
        raise KeyboardInterrupt

    monkeypatch.setattr(morphbench.experiment, "load_run_config", interrupted)  # Ctrl-C while the file is read
    code, stdout, err = run_cli(capsys, "run", CHAIN2, "--quiet", "--out", str(tmp_path / "run"))
    assert (code, stdout, err) == (EXIT_INTERRUPTED, "", "morphbench: interrupted\n")
    assert os.listdir(tmp_path) == []
