"""The installed package: shipped data, shape names, the version, light imports and a wheel that works on its own."""

from __future__ import annotations

import importlib.metadata
import os
import shutil
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import pytest

import morphbench
from morphbench.errors import ConfigError
from morphbench.shapes.loader import resolve_shape_path

from conftest import BENCHMARKS_DIR, EXAMPLES_DIR, LIBRARY, ROOT, SHAPES_DIR, run_cli

HEAVY = ("pybullet", "pandas", "matplotlib", "numba")
"""What a command that needs no simulator must not import (each costs 0.1-0.5 s)."""


def test_data_path_is_the_checkouts_top_level_directories():
    assert morphbench.data_path("shapes") == SHAPES_DIR
    assert morphbench.data_path("examples") == EXAMPLES_DIR
    assert morphbench.data_path("benchmarks") == BENCHMARKS_DIR


def test_a_bare_name_is_a_shipped_shape(tmp_path: Path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert resolve_shape_path("chain-2") == SHAPES_DIR / "chain-2.toml"
    (tmp_path / "chain-2").write_text("")  # a file of that name here wins
    assert resolve_shape_path("chain-2") == Path("chain-2")


@pytest.mark.parametrize("name", ["nosuch.toml", "sub/chain-2", str(SHAPES_DIR / "chain-3.toml")])
def test_paths_are_left_as_given(name: str):
    assert resolve_shape_path(name) == Path(name)


def test_an_unknown_bare_name_lists_the_library(tmp_path: Path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError) as info:
        resolve_shape_path("chain-99")
    message = str(info.value)
    assert message.startswith("chain-99: ") and "\n" not in message
    assert ", ".join(sorted(p.stem for p in LIBRARY)) in message


def test_commands_take_shipped_names(tmp_path: Path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    code, out, err = run_cli(capsys, "shapes", "check", "grid-2x2")
    assert (code, err) == (0, "") and out.startswith("OK grid-2x2: grid-2x2, 4 units")
    code, _, err = run_cli(capsys, "run", "chain-99", "--steps", "1", "--out", "out")
    assert code == 2 and err.count("\n") == 1 and "chain-2, chain-20" in err
    assert not (tmp_path / "out").exists()


def test_version_is_the_package_metadata(capsys):
    code, out, _ = run_cli(capsys, "--version")
    assert code == 0
    assert out == f"morphbench {importlib.metadata.version('morphbench')}\n"


def test_every_subpackage_is_built():
    """pyproject.toml names the packages (the data mapping needs it): a new sub-package must be added there."""
    setuptools = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    code = {".".join(p.parent.relative_to(ROOT).parts) for p in (ROOT / "morphbench").rglob("__init__.py")}
    data = {name for name in setuptools["packages"] if name.startswith("morphbench.data.")}
    assert set(setuptools["packages"]) - data == code
    assert {ROOT / setuptools["package-dir"][name] for name in data} == {SHAPES_DIR, EXAMPLES_DIR, BENCHMARKS_DIR}


def imported_by(statement: str) -> set[str]:
    """The top-level modules a fresh interpreter has imported after ``statement``."""
    result = subprocess.run([sys.executable, "-c", f"{statement}; import sys; print(' '.join(sys.modules))"],
                            capture_output=True, text=True, check=True)
    return {name.split(".")[0] for name in result.stdout.split()}


def test_the_shapes_commands_import_no_simulator():
    assert not imported_by("import morphbench.shapes.cli") & set(HEAVY)


def test_the_command_line_imports_no_simulator_before_reading_its_arguments():
    assert not imported_by("import morphbench.cli") & set(HEAVY)


@pytest.mark.slow
@pytest.mark.skipif(os.environ.get("MORPHBENCH_WHEEL_TEST") != "1",
                    reason="builds a wheel and a virtual environment (about a minute): set MORPHBENCH_WHEEL_TEST=1")
def test_the_wheel_works_outside_the_checkout(tmp_path: Path):
    started = time.perf_counter()
    # a clean copy: setuptools packs whatever an earlier build left in build/
    source = tmp_path / "src"
    shutil.copytree(ROOT, source, ignore=shutil.ignore_patterns(".git", "build", "*.egg-info", "__pycache__", "runs",
                                                                 "results", ".pytest_cache", ".hypothesis"))
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "-w", tmp_path / "dist", source],
                   check=True)
    (wheel,) = (tmp_path / "dist").glob("morphbench-*.whl")
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", venv], check=True)
    subprocess.run([venv / "bin" / "python", "-m", "pip", "install", "--quiet", wheel], check=True)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}  # nothing but the installed package
    work = tmp_path / "elsewhere"
    work.mkdir()

    def morphbench_command(*argv: str) -> subprocess.CompletedProcess:
        return subprocess.run([venv / "bin" / "morphbench", *argv], cwd=work, env=env, capture_output=True, text=True,
                              timeout=300)

    where = subprocess.run([venv / "bin" / "python", "-c", "import morphbench; print(morphbench.__file__)"],
                           cwd=work, env=env, capture_output=True, text=True, check=True).stdout
    assert where.startswith(str(venv))
    version = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    assert morphbench_command("--version").stdout == f"morphbench {version}\n"
    listing = morphbench_command("shapes", "list")
    assert listing.returncode == 0, listing.stderr
    assert [line.split()[0] for line in listing.stdout.splitlines()[1:]] == [p.stem for p in LIBRARY]
    ran = morphbench_command("run", "chain-2", "--steps", "5", "--out", str(tmp_path / "x"), "--quiet")
    assert ran.returncode == 0, ran.stderr
    assert (tmp_path / "x" / "summary.json").is_file()
    missing = morphbench_command("run", "chain-99")
    assert missing.returncode == 2  # PyBullet's banner may come first: the error is the last line
    assert missing.stderr.splitlines()[-1].startswith("morphbench: error: chain-99: ")
    assert "chain-2, chain-20" in missing.stderr
    listed = ("import morphbench\nfor kind in 'examples', 'benchmarks':\n"
              "    print(*sorted(p.name for p in morphbench.data_path(kind).glob('*.toml')))")
    shipped = subprocess.run([venv / "bin" / "python", "-c", listed], cwd=work, env=env, capture_output=True, text=True,
                             check=True).stdout.splitlines()
    assert shipped == [" ".join(sorted(p.name for p in d.glob("*.toml"))) for d in (EXAMPLES_DIR, BENCHMARKS_DIR)]
    paper = ("import morphbench\nfrom morphbench.bench.suite import load_suite\n"  # its include found beside it
             "suite = load_suite(morphbench.data_path('benchmarks') / 'paper.toml')\nprint(*suite.includes)")
    assert subprocess.run([venv / "bin" / "python", "-c", paper], cwd=work, env=env, capture_output=True, text=True,
                          check=True).stdout == "paper-hardware\n"
    print(f"wheel built, installed and checked in {time.perf_counter() - started:.0f} s")
