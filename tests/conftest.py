"""What several test files share: the repository's paths (so the tests pass whatever directory pytest runs in) and
small helpers. Test files import them (``from conftest import SHAPES_DIR``); ``reference`` is a fixture.

Markers (pyproject.toml): ``quick`` is the core, ``python -m pytest -m quick`` in under a minute on 2 cores (the files
of QUICK, set here so that the core is read in one place); ``slow`` builds and installs a wheel, only with
MORPHBENCH_WHEEL_TEST=1.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

from morphbench import params as P
from morphbench.bench import LocalExecutor, load_suite, run_suite
from morphbench.cli import main
from morphbench.errors import ConfigError
from morphbench.shapes import Shape, load_shape, shape_from_table

PARAMETER_CLASSES = [P.UnitParams, P.DummyParams, P.ActuatorParams, P.PhysicsParams, P.LearnerParams,
                     P.FrictionFieldParams, P.EnvironmentParams, P.GroundParams, P.OpticalParams, P.SensorParams,
                     P.VideoParams]
"""every parameter dataclass: the checks that each field declares its range run over all of them."""

ROOT = Path(__file__).resolve().parents[1]
SHAPES_DIR = ROOT / "shapes"
EXAMPLES_DIR = ROOT / "examples"
BENCHMARKS_DIR = ROOT / "benchmarks"
LIBRARY = sorted(SHAPES_DIR.glob("*.toml"))
"""Every shipped morphology file."""

QUICK = {
    "test_shapes_loader.py", "test_shapes_library.py", "test_transforms.py",  # shapes and the loader
    "test_physics.py",  # physics invariants
    "test_quasistatic.py",  # the quasi-static solvers against hand cases and an independent minimiser
    "test_learning.py",  # learners and plug-ins
    "test_run.py",  # short runs and their records
    "test_cli.py",  # the command line and its one-line errors
    "test_package.py",  # shipped data, shape names, version, imports
}
"""The core: about 400 tests, under 30 s on 2 cores."""


@pytest.hookimpl(tryfirst=True)  # before -m reads the markers
def pytest_collection_modifyitems(items):
    for item in items:
        if item.path.name in QUICK and not item.get_closest_marker("slow"):
            item.add_marker(pytest.mark.quick)


def sheet(rows: int, columns: int | None = None) -> Shape:
    """A sheet of ``rows`` x ``columns`` (default: square) units, no dummies, bellows along x and y (as
    shapes/sheet-10x10.toml)."""
    columns = rows if columns is None else columns
    return shape_from_table({"assembly": {"generator": "grid", "rows": rows, "columns": columns, "dummy": False,
                                          "actuated_axes": ["x", "y"]}}, source=f"sheet {rows} x {columns}")


def chain(units: int, **sections) -> Shape:
    """A chain of ``units`` active units and a dummy; ``sections``: more tables of a morphology file (unit,
    actuator)."""
    return shape_from_table({"assembly": {"generator": "chain", "units": units, "dummy": True}, **sections},
                            source="test")


def write(directory: Path, text: str | bytes, name: str = "shape.toml") -> Path:
    path = directory / name
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text, encoding="utf-8")
    return path


def assert_config_error(path: Path, key: str, expected: str) -> ConfigError:
    """load_shape(path) raises ConfigError whose message names the file, the key and what was expected."""
    with pytest.raises(ConfigError) as info:
        load_shape(path)
    error, message = info.value, str(info.value)
    assert error.source == str(path)
    assert error.key == key, message
    assert message.startswith(f"{path}: {key}: expected ")
    assert expected in message, f"{expected!r} not in {message!r}"
    assert "\n" not in message  # the CLI prints it on one line
    return error


def shown_lines(text: str) -> list[str]:
    """The lines a terminal shows of ``text`` (stderr): of each, what follows its last carriage return, if not blank
    (a progress line that long work redraws, erased before a refusal's one-line error, is none)."""
    return [line.rsplit("\r", 1)[-1] for line in text.split("\n") if line.rsplit("\r", 1)[-1].strip()]


def run_cli(capsys, *argv: str) -> tuple[int, str, str]:
    """main(argv) in-process: (exit code, stdout, stderr); argparse's SystemExit becomes its code."""
    try:
        code = main(list(argv))
    except SystemExit as exc:
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


TINY = f"""
name = "tiny"
description = "two learners, two noise levels, two seeds of 4 steps on chain-2, and a 4-point scan"

[[experiment]]
name = "pair"
shapes = ["{SHAPES_DIR / 'chain-2.toml'}"]
learners = ["thermal", "flaky"]
noise = [0.0, 0.5]
seeds = 2
steps = 4

[[scan]]
shape = "{SHAPES_DIR / 'chain-2.toml'}"
resolution = 4
cycles = 1
discard = 0
"""
"""A suite small enough to run in every test module that needs finished suite results."""


def write_suite(directory: Path, text: str, name: str = "suite.toml") -> Path:
    path = directory / name
    path.write_text(textwrap.dedent(text))
    return path


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The tiny suite run straight through on a local pool of 2 workers: (suite path, results dir, outcome)."""
    directory = tmp_path_factory.mktemp("reference")
    suite_path = write_suite(directory, TINY)
    out = directory / "results"
    outcome = run_suite(load_suite(suite_path), out, LocalExecutor(2), progress=False)
    return suite_path, out, outcome
