"""Input that the simulator cannot take, or that would run for ever or exhaust memory, is refused before anything is
simulated: one line naming the file or option, the key and what was expected, exit status 2."""

from __future__ import annotations

import dataclasses
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from morphbench import params as P
from morphbench import rules as R
from morphbench.cli import EXIT_BAD_INPUT
from morphbench.errors import ConfigError
from morphbench.experiment import RunConfig, run
from morphbench.physics import memory_estimate

from conftest import PARAMETER_CLASSES, ROOT, SHAPES_DIR, chain, run_cli, sheet, shown_lines

CHAIN2 = str(SHAPES_DIR / "chain-2.toml")


@pytest.mark.parametrize("cls", PARAMETER_CLASSES, ids=lambda cls: cls.__name__)
def test_every_number_has_two_finite_ends(cls):
    for f in dataclasses.fields(cls):
        rule = f.metadata.get("rule")
        if isinstance(rule, R.Range) and f.name != "temperature":  # inf is a temperature: accept every trial
            assert math.isfinite(rule.low) and math.isfinite(rule.high), f"{cls.__name__}.{f.name}: {rule}"
            assert rule.accepts(f.default), f"{cls.__name__}.{f.name}"


@pytest.mark.parametrize("rule", [P.COUNT, P.NATURAL, P.STEPS, P.SEED, P.CYCLES])
def test_named_rules_are_bounded(rule):
    assert math.isfinite(rule.high) and not rule.accepts(int(rule.high) + 1) and rule.accepts(int(rule.high))


def _shape_file(tmp_path: Path, sections: str) -> Path:
    path = tmp_path / "shape.toml"
    path.write_text('[assembly]\ngenerator = "chain"\nunits = 2\ndummy = true\n' + sections, encoding="utf-8")
    return path


def _run_file(tmp_path: Path, body: str, steps: int = 1) -> Path:
    path = tmp_path / "run.toml"
    path.write_text(f'shape = "{SHAPES_DIR / "chain-2.toml"}"\nsteps = {steps}\n' + body, encoding="utf-8")
    return path


def _one_line_error(capsys, *argv: str) -> str:
    code, out, err = run_cli(capsys, *argv)
    assert code == EXIT_BAD_INPUT, err
    assert "Traceback" not in err and len(shown_lines(err)) == 1, err
    return err.strip()


SHAPE_CASES = [
    ("[unit]\nmass = 1e300\n", "unit.mass"),
    ("[actuator]\nstroke = 1e300\n", "actuator.stroke"),
    ("[unit]\nfriction = 1e300\n", "unit.friction"),
    ("[unit]\nlength = 1e-300\n", "unit.length"),
    ("[actuator]\nalpha = 0.999999\n", "actuator.alpha"),
    ("[actuator]\ncycle_time = 1e300\n", "actuator.cycle_time"),
    ("[actuator]\ncycle_time = 0.02\n", "actuator.cycle_time"),  # in range, but the pump phase is < 4 ticks
    ("[actuator]\nalpha = 0.01\n", "actuator.cycle_time"),  # the same with a short pump phase
]


@pytest.mark.parametrize("sections, key", SHAPE_CASES)
def test_shape_values_the_simulator_cannot_take(tmp_path, capsys, sections, key):
    path = _shape_file(tmp_path, sections)
    out = tmp_path / "out"
    error = _one_line_error(capsys, "run", str(path), "--steps", "1", "--quiet", "--out", str(out))
    assert error.startswith(f"morphbench: error: {path}: {key}: expected "), error
    assert not out.exists()


RUN_CASES = [
    ("[physics]\ntimestep = 1e-300\n", "physics.timestep"),
    ("[physics]\nsettle_time = 1e300\n", "physics.settle_time"),
    ("[environment]\nnoise = 1e300\n", "environment.noise"),
    ("[environment]\nfriction_scale = 1e300\n", "environment.friction_scale"),
    ("[environment.friction_field]\ncorrelation_length = 1e-300\n", "environment.friction_field.correlation_length"),
    ("[environment.friction_field]\ncorrelation_length = 0.001\nperiod = 100\n",
     "environment.friction_field.correlation_length"),  # each in range, but 100,000 waves per period
    ("[learner]\ncycles_per_step = 100000000\n", "learner.cycles_per_step"),
    ("[learner]\ncycles_per_step = 1000\n[physics]\ntimestep = 0.0001\n", "learner.cycles_per_step"),  # 2e7 ticks
    ("seed = 4611686018427387904000\n", "seed"),
    ('description = 3\n', "description"),
]


@pytest.mark.parametrize("body, key", RUN_CASES)
def test_run_file_values_the_simulator_cannot_take(tmp_path, capsys, body, key):
    path = _run_file(tmp_path, body)
    out = tmp_path / "out"
    error = _one_line_error(capsys, "run", str(path), "--quiet", "--out", str(out))
    assert f": {key}: expected " in error, error
    assert not out.exists()


def test_steps_beyond_the_maximum(tmp_path, capsys):
    path = _run_file(tmp_path, "", steps=P.MAX_STEPS + 1)
    error = _one_line_error(capsys, "run", str(path), "--quiet", "--out", str(tmp_path / "out"))
    assert ": steps: expected an integer in [0, 1000000]" in error


@pytest.mark.parametrize("option, value", [("--steps", str(10**30)), ("--cycles-per-step", "100000000"),
                                           ("--seed", str(2**63))])
def test_resource_options_beyond_their_maxima(tmp_path, capsys, option, value):
    error = _one_line_error(capsys, "run", CHAIN2, "--quiet", "--out", str(tmp_path / "out"), option, value)
    assert error.startswith(f"morphbench run: error: argument {option}: expected an integer in [")


def test_the_api_applies_the_same_rules():
    with pytest.raises(ConfigError, match=r"^test: actuator\.cycle_time: expected a cycle_time >= "):
        RunConfig(shape=chain(2, actuator={"cycle_time": 0.02}))
    with pytest.raises(ConfigError, match=r"^test: steps: expected an integer in \[0, 1000000\], got 10000000"):
        RunConfig(shape=chain(2), steps=10**7)
    fine = RunConfig(shape=chain(2, actuator={"cycle_time": 0.2}))  # 32 ticks in the pump phase at the default step
    assert fine.shape.actuator.cycle_time == 0.2


def test_a_nul_byte_in_a_shape_path(tmp_path, capsys):
    path = tmp_path / "run.toml"
    path.write_text('shape = "chain\\u0000.toml"\n', encoding="utf-8")
    error = _one_line_error(capsys, "run", str(path), "--quiet", "--out", str(tmp_path / "out"))
    assert error.endswith(": shape: expected a path without a NUL byte, got 'chain\\x00.toml'"), error


@pytest.mark.parametrize("name", ["a\0b", "x" * 300])
def test_an_out_name_the_file_system_cannot_take(tmp_path, capsys, name):
    error = _one_line_error(capsys, "run", CHAIN2, "--quiet", "--out", str(tmp_path / name))
    assert error.startswith("morphbench: error: --out: ") and "expected a path" in error


def test_report_on_a_file(tmp_path, capsys):
    path = tmp_path / "summary.json"
    path.write_text("{}")
    error = _one_line_error(capsys, "report", str(path))
    assert error == f"morphbench: error: report: {path}: expected a results directory written by 'morphbench bench' " \
                    "(this is a file)"


@pytest.mark.parametrize("nested", ["[" * 5000 + "]" * 5000, "{a = " * 5000 + "1" + "}" * 5000])
def test_deeply_nested_toml(tmp_path, capsys, nested):
    path = _shape_file(tmp_path, "")
    path.write_text(f"description = {nested}\n", encoding="utf-8")
    error = _one_line_error(capsys, "shapes", "check", str(path))
    assert error == f"morphbench: error: {path}: (syntax): expected TOML nested less deeply (arrays or inline tables " \
                    "thousands deep)"


def test_an_error_after_the_simulator_is_imported_is_one_line_in_all(tmp_path):
    """In a fresh process, where ``import pybullet`` prints its build time unless morphbench silences it."""
    result = subprocess.run(
        [sys.executable, "-m", "morphbench.cli", "run", CHAIN2, "--steps", "3", "--physics", "fast", "--quiet",
         "--out", str(tmp_path / "out"), "--video", str(tmp_path / "v.gif"), "--video-steps", "9:"],
        env={**os.environ, "PYTHONPATH": str(ROOT)}, cwd=ROOT, capture_output=True, text=True,
        timeout=120)
    assert result.returncode == EXIT_BAD_INPUT
    assert result.stdout == ""
    assert result.stderr == ("morphbench: error: --video-steps: steps: expected learning steps of this run, which "
                             "ends at step 3, got '9:'\n")


def test_a_mesh_path_longer_than_the_file_system_takes(tmp_path, capsys):
    path = tmp_path / "long-mesh.toml"
    path.write_text(f'[assembly]\ngenerator = "chain"\nunits = 2\n[unit]\nmesh = "{"x" * 300}.obj"\n', encoding="utf-8")
    error = _one_line_error(capsys, "shapes", "check", str(path))
    assert f"{path}: unit.mesh: expected an existing mesh file" in error


@pytest.mark.parametrize("kind", ['["friction"]', '{ a = 1 }', "3"])
def test_an_event_kind_that_is_not_a_string(tmp_path, capsys, kind):
    path = tmp_path / "run.toml"
    path.write_text(f'shape = "{CHAIN2}"\n[[events]]\nstep = 1\nkind = {kind}\n', encoding="utf-8")
    error = _one_line_error(capsys, "run", str(path), "--quiet", "--out", str(tmp_path / "out"))
    assert f"{path}: events[0].kind: expected one of friction, damage" in error
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("plane", ["1", '"xy"', "[1]"])
def test_a_cut_plane_that_is_not_an_axis(tmp_path, capsys, plane):
    path = tmp_path / "cut.toml"
    path.write_text(f'[assembly]\ngenerator = "chain"\nunits = 3\n[transform]\ncut = {{plane = {plane}, at = 0.1}}\n',
                    encoding="utf-8")
    error = _one_line_error(capsys, "shapes", "check", str(path))
    assert f"{path}: transform.cut.plane: expected one of x, y, z" in error


def test_an_event_after_the_last_step_is_refused_in_a_run_file_and_after_steps(tmp_path, capsys):
    """As in suites: an event that would never happen is an error, not silently dropped."""
    path = tmp_path / "late.toml"
    path.write_text(f'shape = "{CHAIN2}"\nsteps = 60\n[[events]]\nstep = 50\nkind = "noise"\nsigma = 0.5\n',
                    encoding="utf-8")
    out = tmp_path / "out"
    error = _one_line_error(capsys, "run", str(path), "--steps", "5", "--quiet", "--out", str(out))
    assert error == "morphbench: error: --steps: 5: expected at least 50, the step of events[0], got 5"
    path.write_text(path.read_text().replace("steps = 60", "steps = 40"), encoding="utf-8")
    error = _one_line_error(capsys, "run", str(path), "--quiet", "--out", str(out))
    assert f"{path}: events[0].step: expected a learning step <= the run's steps (40)" in error
    assert not out.exists()


@pytest.mark.parametrize("backend", ["quasistatic", "dynamic"])
def test_the_memory_estimate_grows_with_the_shape(backend):
    small, large, physics = sheet(10, 10), sheet(100, 100), dataclasses.replace(P.DEFAULT_PHYSICS, backend=backend)
    assert 0 < memory_estimate(small, physics, ticks=480) < memory_estimate(large, physics, ticks=480)
    assert memory_estimate(large, physics, ticks=480, copies=2) == 2 * memory_estimate(large, physics, ticks=480)


def test_a_run_that_would_not_fit_in_memory_is_refused_before_it_starts(monkeypatch):
    monkeypatch.setattr("morphbench.physics.available_memory", lambda: 2.0**20)
    built = []
    monkeypatch.setattr("morphbench.experiment.driver.make_world", lambda *a, **k: built.append(a))
    with pytest.raises(ConfigError, match=r"sheet 10 x 10: assembly: expected an assembly whose run fits in the "
                                          r"memory available \(1\.0 MiB\), got '100 bodies, an estimated \d+\.\d MiB'"):
        run(RunConfig(shape=sheet(10, 10), seed=0, steps=1, sensor=P.SensorParams(kind="ideal")))
    assert not built


def test_the_command_line_refuses_it_in_one_line(tmp_path: Path, capsys, monkeypatch):
    monkeypatch.setattr("morphbench.physics.available_memory", lambda: 2.0**20)
    shape = tmp_path / "sheet.toml"
    shape.write_text('[assembly]\ngenerator = "grid"\nrows = 10\ncolumns = 10\ndummy = false\n')
    error = _one_line_error(capsys, "run", str(shape), "--out", str(tmp_path / "out"), "--steps", "1", "--quiet")
    assert f"{shape}: assembly: expected an assembly whose run fits in the memory available (1.0 MiB)" in error
    assert "got '100 bodies, an estimated" in error
    assert not (tmp_path / "out" / "summary.json").exists()


def test_a_shape_beyond_the_limit_is_refused_saying_why(tmp_path, capsys):
    shape = tmp_path / "large.toml"
    shape.write_text('[assembly]\ngenerator = "grid"\nrows = 317\ncolumns = 317\n')
    error = _one_line_error(capsys, "run", str(shape), "--out", str(tmp_path / "out"), "--quiet")
    assert error == (f"morphbench: error: {shape}: assembly.columns: expected at most 100000 active units in all "
                     "(rows x columns = 100489; a larger assembly takes over 4 CPU s per simulated second, a 300-step "
                     "run over 80 minutes), got 317")
    with pytest.raises(ConfigError, match="at most 100000 active units in all .rows x columns = 100489; a larger "
                                          "assembly takes over 4 CPU s per simulated second"):
        sheet(317, 317)
