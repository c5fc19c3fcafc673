"""Malformed input, generated (tests/fuzzing.py): every refused input exits 2 with one line on stderr, no traceback
and nothing written; every accepted one exits 0 with its output complete.

One test per input kind and mutation family, so that a failure names the family. Cases run in-process through
``morphbench.cli.main`` (``fuzzing.run_case``); a few run in a subprocess, where PyBullet's banner would show.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings

import fuzz_physics
import fuzzing
import pandas as pd
from conftest import ROOT, SHAPES_DIR, shown_lines

FAST = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
SUITE = settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])  # a pool per suite


def check(case: fuzzing.Case) -> fuzzing.Outcome:
    """Run ``case`` and assert the promise: refused cleanly or accepted completely."""
    with tempfile.TemporaryDirectory() as directory:
        outcome = fuzzing.run_case(case, Path(directory) / "case")  # time limits that catch hangs only (fuzzing)
    detail = (f"{case.kind} {case.short()}: {outcome.verdict}; exit {outcome.status!r}, "
              f"exception {outcome.exception!r}, stderr {outcome.err[-400:]!r}, written {outcome.written[:5]}")
    assert outcome.exception is None, detail
    assert "Traceback" not in outcome.err, detail
    if outcome.status == 0 or (case.argv[0] == "bench" and outcome.status == 1):
        assert outcome.verdict == "accepted", detail  # the run directory, scan or results are complete
    else:
        assert outcome.status == 2, detail
        lines = shown_lines(outcome.err)
        assert len(lines) == 1, detail
        assert fuzzing.is_error_line(lines[0]), detail
        assert outcome.written == [], detail  # no run or results directory, nothing in the working directory
        assert outcome.verdict == "refused", detail
    return outcome


# --- the judge itself: it tells accepted from refused from broken -------------------------------------------------

def test_a_valid_run_file_is_accepted_with_a_complete_run_directory(tmp_path):
    case = fuzzing.Case("run", "none", "s6 as shipped", ["run", "{in}", "--steps", "1", "--quiet", "--out", "{out}"],
                        fuzzing.dump_toml(fuzzing.seed_documents("run")[-1][1]).encode())
    outcome = fuzzing.run_case(case, tmp_path / "case")
    assert (outcome.status, outcome.verdict) == (0, "accepted"), outcome.err
    assert fuzzing.RUN_FILES <= {p.name for p in (tmp_path / "case" / "out").iterdir()}


def test_an_unknown_key_is_refused_with_a_line_naming_the_file_and_the_key(tmp_path):
    doc = dict(fuzzing.seed_documents("shape")[0][1], colour="red")
    case = fuzzing.Case("shape", "unknown", "colour", ["shapes", "check", "{in}"], fuzzing.dump_toml(doc).encode())
    outcome = fuzzing.run_case(case, tmp_path / "case")
    assert outcome.verdict == "refused"
    assert outcome.line().startswith(f"morphbench: error: {tmp_path / 'case' / 'in' / 'input.toml'}: colour: expected ")


def test_the_judge_calls_a_leaked_exception_a_crash(tmp_path):
    # a shape file whose name is too long for the file system: the kind of case the pending path checks are about
    case = fuzzing.Case("options", "shapes check", "long name", ["shapes", "check", "{dir}/" + "p" * 300 + ".toml"])
    outcome = fuzzing.run_case(case, tmp_path / "case")
    assert outcome.verdict != "accepted"
    assert (outcome.verdict == "refused") == (outcome.exception is None and outcome.status == 2)


def test_the_toml_writer_round_trips_every_seed_file():
    for kind in ("shape", "run", "suite"):
        for name, doc in fuzzing.seed_documents(kind):
            assert fuzzing.tomllib.loads(fuzzing.dump_toml(doc)) == doc, name


# --- shape files: morphbench shapes check FILE ----------------------------------------------------------------------

@FAST
@given(fuzzing.cases("shape", ("delete", "unknown", "type", "number", "syntax")))
def test_shape_files(case):
    check(case)


@FAST
@given(fuzzing.cases("shape", ("path",)))
def test_shape_files_with_bad_paths(case):
    check(case)


@FAST
@given(fuzzing.cases("shape", ("deep",)))
def test_shape_files_nested_deep(case):
    check(case)


# --- run configurations: morphbench run FILE --steps 1 --out DIR -----------------------------------------------------

@FAST
@given(fuzzing.cases("run", ("delete", "unknown", "type", "syntax")))
def test_run_configurations(case):
    check(case)


@FAST
@given(fuzzing.cases("run", ("number",)))
def test_run_configurations_with_absurd_numbers(case):
    check(case)


@FAST
@given(fuzzing.cases("run", ("path",)))
def test_run_configurations_with_bad_paths(case):
    check(case)


@FAST
@given(fuzzing.cases("run", ("deep",)))
def test_run_configurations_nested_deep(case):
    check(case)


# --- suites: morphbench bench FILE --out DIR (smoke.toml shrunk to seconds) ------------------------------------------

@SUITE
@given(fuzzing.cases("suite", ("delete", "unknown", "type", "number", "syntax")))
def test_suites(case):
    check(case)


@FAST
@given(fuzzing.cases("suite", ("path",)))
def test_suites_with_bad_paths(case):
    check(case)


@FAST
@given(fuzzing.cases("suite", ("deep",)))
def test_suites_nested_deep(case):
    check(case)


# --- the command line and plug-ins ----------------------------------------------------------------------------------

@FAST
@given(fuzzing.cases("options", pending=False))
def test_command_line_options(case):
    check(case)


@FAST
@given(fuzzing.cases("options"))
def test_command_line_options_with_bad_paths(case):
    check(case)


@FAST
@given(fuzzing.cases("plugin"))
def test_plugin_learners(case):
    check(case)


# --- in a subprocess: what a user sees, PyBullet's banner included --------------------------------------------------

SUBPROCESS_CASES = {
    "unknown key in a shape file": (["shapes", "check", "{in}"], 'colour = "red"\n'),
    "truncated run file": (["run", "{in}", "--steps", "1", "--quiet", "--out", "{out}"], 'shape = "../sh'),
    "bad --steps": (["run", str(SHAPES_DIR / "chain-2.toml"), "--steps", "-1", "--out", "{out}"], None),
    "broken plug-in spec": (["run", str(SHAPES_DIR / "chain-2.toml"), "--learner", "a:b:c", "--out", "{out}"], None),
}


@pytest.mark.parametrize("name", SUBPROCESS_CASES)
def test_refused_in_a_subprocess(name, tmp_path):
    argv, text = SUBPROCESS_CASES[name]
    source = tmp_path / "in" / "input.toml"
    source.parent.mkdir()
    if text is not None:
        source.write_text(text)
    out = tmp_path / "out"
    argv = [a.replace("{in}", str(source)).replace("{out}", str(out)) for a in argv]
    result = subprocess.run([sys.executable, "-m", "morphbench.cli", *argv], cwd=tmp_path, capture_output=True,
                            text=True, timeout=120, env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"})
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in"]  # no runs/ in the working directory either
    assert len(lines) == 1, result.stderr
    assert fuzzing.is_error_line(lines[0]), lines[0]


@pytest.mark.parametrize("case", fuzz_physics.random_cases(6, seed=3), ids=lambda case: case.short(60))
def test_extreme_physics_is_refused_or_gives_finite_reachable_velocities(case, tmp_path):
    assert fuzz_physics.run_case(case, tmp_path / "case").verdict in ("accepted", "refused")


def test_the_physics_judge_calls_an_unreachable_velocity_garbage(tmp_path):
    """A run directory whose velocities no bellows can give: the judge must not call it accepted."""
    out = tmp_path / "out"
    fuzzing.run_case(fuzzing.Case("run", "valid", "chain-2", ["run", str(SHAPES_DIR / "chain-2.toml"), "--steps", "1",
                                                               "--quiet", "--out", str(out)]), tmp_path / "w")
    assert fuzz_physics._garbage(out) is None
    units = pd.read_parquet(out / "units.parquet")
    units.loc[units.index[-1], "u_true"] = 1e3
    units.to_parquet(out / "units.parquet")
    assert fuzz_physics._garbage(out).startswith("garbage: a unit at 1e+03 mm/cycle")
