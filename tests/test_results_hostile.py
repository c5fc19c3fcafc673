"""Results directories the file system makes hostile (issue 34): a path a command writes that holds the other kind
(DIR/damaged a file, report.md a directory, figures/ a file), files and directories this user may not read or write,
and a run whose configuration names a ground image that is gone. Each is refused in one line that names the path and
says what was expected (exit 2), with nothing moved or written: a file that may not be read is no damage."""

from __future__ import annotations

import functools
import json
import os
import shutil
import subprocess
import sys
import tempfile
from contextlib import contextmanager
from pathlib import Path

import cv2
import numpy as np
import pytest

import fuzz_results
from morphbench.render.replay import load_run

from conftest import SHAPES_DIR, run_cli

DROP = ("--bounding-set=-dac_override,-dac_read_search", "--inh-caps=-dac_override,-dac_read_search")
"""setpriv's options that take from root the capabilities with which it ignores file modes."""


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    """fuzz_results.SUITE run with its report (no videos): (suite file, results directory)."""
    out = tmp_path_factory.mktemp("finished") / "R"
    return fuzz_results.build(out), out


@pytest.fixture
def root(finished, tmp_path) -> Path:
    """A copy of the finished results directory to spoil."""
    shutil.copytree(finished[1], tmp_path / "R")
    return tmp_path / "R"


def listing(root: Path) -> dict[str, tuple[int, int]]:
    """Every path under ``root`` with its size and modification time: what a refused command must leave alone."""
    return {str(p.relative_to(root)): (p.lstat().st_size, p.lstat().st_mtime_ns) for p in root.rglob("*")}


def refused(code: int, err: str, path: Path, expected: str) -> None:
    """Exit 2 and one line on stderr naming ``path`` and what was expected there."""
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, err
    assert lines[0].startswith(f"morphbench: error: {path}") and expected in lines[0], err


def spoil_a_scan(root: Path) -> Path:
    """Damage a scan part's result.json (a job whose repair moves its directory and writes nothing first)."""
    part = json.loads((root / "plan.json").read_text())["scans"][0]["parts"][0]
    (root / "scans" / part / "result.json").write_text("[]")
    return root / "scans" / part


# --- a path holding the other kind ------------------------------------------------------------------------------------

def test_repair_refuses_when_damaged_is_a_file(root, capsys):
    job = spoil_a_scan(root)
    (root / "damaged").write_text("not a folder\n")
    code, out, _ = run_cli(capsys, "check", str(root))
    assert code == 1 and f"scan {job.name}: scans/{job.name}/result.json" in out
    before = listing(root)
    code, _, err = run_cli(capsys, "check", str(root), "--repair")
    refused(code, err, root, "damaged: expected the directory damaged jobs and files are set aside in, got a file")
    assert listing(root) == before


@pytest.mark.parametrize("name, kind", [("report.md", "dir"), ("report.html", "dir"), ("runs.parquet", "dir"),
                                        ("metrics.parquet", "dir"), ("backends.parquet", "dir"),
                                        ("figures", "file"), ("figures/pair-ubar.png", "dir"), ("videos", "file")])
def test_report_refuses_a_path_it_writes_that_holds_the_other_kind(root, capsys, name, kind):
    path = root / name
    if path.is_dir():
        shutil.rmtree(path)
    else:
        path.unlink(missing_ok=True)
    if kind == "dir":
        path.mkdir()
        (path / "kept").write_text("whatever someone put here\n")
    else:
        path.write_text("whatever someone put here\n")
    before = listing(root)
    code, _, err = run_cli(capsys, "report", str(root), *([] if name == "videos" else ["--no-videos"]))
    expected = "expected a file the report writes over, got a directory" if kind == "dir" else \
        "expected a directory the report writes its files into, got a file"
    refused(code, err, root, f": {name}: {expected}")
    assert listing(root) == before


def test_bench_refuses_before_it_runs_when_its_report_could_not_be_written(finished, root, capsys):
    suite, _ = finished
    run_id = json.loads((root / "plan.json").read_text())["runs"][0]["id"]
    shutil.rmtree(root / "runs" / run_id)  # a job to run
    (root / "report.md").unlink()
    (root / "report.md").mkdir()
    code, _, err = run_cli(capsys, "bench", str(suite), "--out", str(root), "--quiet", "--no-videos")
    refused(code, err, root, ": report.md: expected a file the report writes over, got a directory")
    assert not (root / "runs" / run_id).exists()  # nothing ran
    code, _, _ = run_cli(capsys, "bench", str(suite), "--out", str(root), "--quiet", "--no-report")
    assert code == 0 and (root / "runs" / run_id).is_dir()  # without the report nothing is in its way


# --- permissions ------------------------------------------------------------------------------------------------------

@functools.cache
def _setpriv_binds() -> bool:
    """Whether setpriv runs a command as root without the capabilities that let root ignore file modes."""
    setpriv = shutil.which("setpriv")
    if setpriv is None:
        return False
    with tempfile.TemporaryDirectory() as folder:
        probe = Path(folder) / "probe"
        probe.write_text("x")
        probe.chmod(0)
        return subprocess.run([setpriv, *DROP, "cat", str(probe)], capture_output=True).returncode != 0


def bound(capsys, *argv: str) -> tuple[int, str, str]:
    """``morphbench argv`` as a user whom file modes bind: in this process when it is not root's; as root, in a
    process without the capabilities that let root ignore them (setpriv); skipped where neither can be had."""
    if os.geteuid() != 0:
        return run_cli(capsys, *argv)
    if not _setpriv_binds():
        pytest.skip("root ignores file modes here, and setpriv cannot take that from it")
    done = subprocess.run([shutil.which("setpriv"), *DROP, sys.executable, "-m", "morphbench.cli", *argv],
                          capture_output=True, text=True, timeout=300)
    return done.returncode, done.stdout, done.stderr


@contextmanager
def mode(path: Path, bits: int):
    """``path`` with the mode ``bits`` for the block (restored after: pytest removes its directories)."""
    old = path.stat().st_mode
    path.chmod(bits)
    try:
        yield path
    finally:
        path.chmod(old)


UNREADABLE = "(permissions): expected a file or directory this user may read and write (permission denied"


@pytest.mark.parametrize("name", ["runs", "<run>", "<run>/result.json", "plan.json", "steps.parquet", "jobs.parquet"])
def test_check_refuses_what_it_may_not_read(root, capsys, name):
    """Not damage (its content may be sound): named, so that its mode is fixed, and nothing set aside."""
    run_id = json.loads((root / "plan.json").read_text())["runs"][0]["id"]
    path = root / name.replace("<run>", f"runs/{run_id}")
    before = listing(root)
    with mode(path, 0):
        code, out, err = bound(capsys, "check", str(root), "--repair")
    refused(code, err, path, f"{path}: {UNREADABLE}")
    assert out == "" and listing(root) == before


def test_a_consolidated_table_unreadable_by_its_mode_sets_no_run_aside(root, capsys):
    """units.parquet holds every consolidated run's rows: taken for damage, every intact run went aside."""
    path = root / "units.parquet"
    before = listing(root)
    with mode(path, 0):
        for command in (["check", str(root), "--repair"], ["report", str(root), "--no-videos"]):
            code, _, err = bound(capsys, *command)
            refused(code, err, path, UNREADABLE)
    assert listing(root) == before
    code, out, _ = run_cli(capsys, "check", str(root))
    assert code == 0, out


@pytest.mark.parametrize("read_only", ["", "scans"])
def test_repair_of_a_directory_it_may_not_write_moves_nothing(root, capsys, read_only):
    job = spoil_a_scan(root)
    before = listing(root)
    with mode(root / read_only, 0o555):
        code, _, err = bound(capsys, "check", str(root), "--repair")
    refused(code, err, job, f"{job}: (set aside): expected a file or directory this user can move into "
                            f"{root}/damaged/")
    assert "(Permission denied); nothing was moved" in err
    assert listing(root) == before
    code, out, _ = run_cli(capsys, "check", str(root), "--repair")  # writable again: the repair goes through
    assert code == 1 and f"moved scans/{job.name} to damaged/" in out


# --- a ground image that is gone ------------------------------------------------------------------------------------

def test_render_refuses_a_run_whose_ground_image_is_gone(tmp_path, capsys):
    """An ideal sensor never reads the image, and the video draws its own ground; but the replay re-runs the
    configuration, and one naming an input that is gone is no longer the run's."""
    image = tmp_path / "ground.png"
    cv2.imwrite(str(image), np.random.default_rng(0).integers(0, 256, (64, 64), dtype=np.uint8))
    config = tmp_path / "run.toml"
    config.write_text(f'shape = "{SHAPES_DIR / "chain-2.toml"}"\nsteps = 1\n\n[sensor]\nkind = "ideal"\n\n'
                      f'[environment.ground]\nimage = "{image}"\n')
    run = tmp_path / "run"
    code, _, err = run_cli(capsys, "run", str(config), "--out", str(run), "--quiet")
    assert code == 0, err
    assert load_run(run)[0].environment.ground.image == str(image)  # replayable while the image is there
    for spoil, expected in ((lambda: image.write_text("not an image\n"), "an image file OpenCV can read"),
                            (image.unlink, "an existing image file")):
        spoil()
        code, _, err = run_cli(capsys, "render", str(run), "--out", str(tmp_path / "video.mp4"), "--quiet")
        refused(code, err, run / "summary.json", f": config.environment.ground.image: expected {expected}")
        assert not (tmp_path / "video.mp4").exists()
