"""A suite's ``include``: other suite files whose experiments, runs, scans and groups join it (morphbench.bench.suite),
its plan's ``includes`` and the claims its report checks (morphbench.bench.claims.claims_for).

The suites here are tiny (chain-2 and chain-3, 2 or 3 learning steps, one seed, 3-point one-cycle scans); one is run
end to end, the others are only loaded.
"""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import pytest

from morphbench.bench import claims as C
from morphbench.bench.suite import load_suite
from morphbench.errors import ConfigError

from conftest import BENCHMARKS_DIR, SHAPES_DIR, run_cli, shown_lines, write_suite

CHAIN2, CHAIN3 = SHAPES_DIR / "chain-2.toml", SHAPES_DIR / "chain-3.toml"

MAIN = f"""
name = "main"
description = "the including suite"
groups = {{mine = ["own"]}}
include = ["sub/other.toml"]
[defaults]
steps = 2
seeds = 1
learner = {{name = "thermal"}}

[[experiment]]
name = "own"
shape = "{CHAIN2}"

[[scan]]
name = "own-scan"
shape = "{CHAIN2}"
resolution = 3
cycles = 1
discard = 0
"""

OTHER = f"""
name = "other"
description = "the included suite"
groups = {{theirs = ["inc"]}}
[defaults]
steps = 3
seeds = 1
learner = {{name = "flaky"}}

[[experiment]]
name = "inc"
shape = "{CHAIN3}"

[[scan]]
name = "inc-scan"
shape = "{CHAIN2}"
resolution = 3
cycles = 1
discard = 1
"""


def experiment(name: str, shape: Path = CHAIN2, steps: int = 2, learner: str = "thermal") -> str:
    return f"""
[[experiment]]
name = "{name}"
shape = "{shape}"
steps = {steps}
seeds = 1
learner = {{name = "{learner}"}}
"""


def scan(name: str, discard: int = 0) -> str:
    return f"""
[[scan]]
name = "{name}"
shape = "{CHAIN2}"
resolution = 3
cycles = 1
discard = {discard}
"""


@pytest.fixture
def main_suite(tmp_path) -> Path:
    (tmp_path / "sub").mkdir()
    write_suite(tmp_path / "sub", OTHER, "other.toml")
    return write_suite(tmp_path, MAIN, "main.toml")


def refused(path: Path, key: str, expected: str, got: object = ...) -> ConfigError:
    """load_suite(path) raises a one-line ConfigError naming ``path``, ``key`` and ``expected`` (and ``got``)."""
    with pytest.raises(ConfigError) as info:
        load_suite(path)
    error, message = info.value, str(info.value)
    assert error.source == str(path), message
    assert error.key == key, message
    assert expected in error.expected, message
    if got is not ...:
        assert error.got == got, message
    assert "\n" not in message
    return error


# --- what joins ---------------------------------------------------------------------------------------------------


def test_the_included_experiments_scans_and_groups_join_after_the_own_ones_with_their_own_defaults(main_suite):
    suite = load_suite(main_suite)
    assert (suite.name, suite.description, suite.includes) == ("main", "the including suite", ("other",))
    assert [e.name for e in suite.experiments] == ["own", "inc"]
    assert [s.name for s in suite.scans] == ["own-scan", "inc-scan"]
    assert suite.groups == {"mine": ("own",), "theirs": ("inc",)}
    own, inc = ([suite.runs[i] for i in e.run_ids] for e in suite.experiments)
    assert [(r.config.steps, r.condition["learner"], r.condition["shape"]) for r in own] == [(2, "thermal", "chain-2")]
    assert [(r.config.steps, r.condition["learner"], r.condition["shape"]) for r in inc] == [(3, "flaky", "chain-3")]
    assert list(suite.runs) == [own[0].id, inc[0].id]  # the own runs first
    alone = load_suite(main_suite.parent / "sub" / "other.toml")  # the same runs and scans as the suite alone
    assert [r.id for r in inc] == list(alone.runs) and suite.scans[1].id == alone.scans[0].id
    assert [job.id for job in suite.jobs()] == [own[0].id, inc[0].id, *suite.scans[0].part_ids(),
                                                *suite.scans[1].part_ids()]


def test_one_string_includes_one_suite_and_includes_are_flattened_in_order(tmp_path):
    write_suite(tmp_path, 'name = "c"\n' + experiment("c-exp"), "c.toml")
    write_suite(tmp_path, 'name = "b"\ninclude = "c.toml"\n' + experiment("b-exp"), "b.toml")
    write_suite(tmp_path, 'name = "d"\n' + experiment("d-exp"), "d.toml")
    path = write_suite(tmp_path, 'name = "a"\ninclude = ["b.toml", "d.toml"]\n' + experiment("a-exp"), "a.toml")
    suite = load_suite(path)
    assert suite.includes == ("b", "c", "d")
    assert [e.name for e in suite.experiments] == ["a-exp", "b-exp", "c-exp", "d-exp"]
    assert suite.plan()["includes"] == ["b", "c", "d"]


def test_the_physics_override_reaches_the_included_suites_and_the_own_physics_key_does_not(main_suite, tmp_path):
    suite = load_suite(main_suite, physics="fast")
    assert {r.condition["physics"] for r in suite.runs.values()} == {"fast"}
    assert {s.columns["physics"] for s in suite.scans} == {"fast"}
    main_suite.write_text('physics = "fast"\n' + main_suite.read_text())
    suite = load_suite(main_suite)
    physics = {e.name: {suite.runs[i].condition["physics"] for i in e.run_ids} for e in suite.experiments}
    assert physics["own"] == {"fast"} and physics["inc"] != {"fast"}
    assert [s.columns["physics"] == "fast" for s in suite.scans] == [True, False]


def test_a_run_listed_by_both_suites_is_run_once(tmp_path):
    write_suite(tmp_path, 'name = "shared"\n' + experiment("theirs") + experiment("more", steps=3), "shared.toml")
    path = write_suite(tmp_path, 'include = ["shared.toml"]\n' + experiment("mine"), "main.toml")
    suite = load_suite(path)
    mine, theirs, more = suite.experiments
    assert mine.run_ids == theirs.run_ids and len(suite.runs) == 2
    assert list(suite.runs) == [*mine.run_ids, *more.run_ids]
    assert len([job for job in suite.jobs() if job.kind == "run"]) == 2


def test_a_suite_of_includes_alone_loads_and_one_of_nothing_is_refused(main_suite, tmp_path):
    path = write_suite(tmp_path, 'name = "only"\ninclude = ["main.toml"]\n', "only.toml")
    suite = load_suite(path)
    assert (suite.name, suite.includes) == ("only", ("main", "other"))
    assert [e.name for e in suite.experiments] == ["own", "inc"] and len(suite.scans) == 2
    for text in ('name = "empty"\n', 'name = "empty"\ninclude = []\n'):
        refused(write_suite(tmp_path, text, "empty.toml"), "experiment", "at least one [[experiment]] or [[scan]]")


def test_own_groups_and_experiment_scans_may_name_what_is_included(main_suite):
    text = main_suite.read_text().replace('groups = {mine = ["own"]}', 'groups = {mine = ["own", "inc"]}')
    main_suite.write_text(text.replace('name = "own"\n', 'name = "own"\nscans = ["inc-scan"]\n'))
    suite = load_suite(main_suite)
    assert suite.groups["mine"] == ("own", "inc") and suite.experiments[0].scans == ("inc-scan",)


# --- what is refused ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("value, key, got", [
    ("3", "include", 3),
    ("{a = 1}", "include", {"a": 1}),
    ("[1]", "include[0]", 1),
    ('["sub/other.toml", ["x.toml"]]', "include[1]", ["x.toml"]),
    ('[""]', "include[0]", ""),
])
def test_an_include_that_is_not_a_list_of_paths_is_refused(main_suite, value, key, got):
    main_suite.write_text(main_suite.read_text().replace('include = ["sub/other.toml"]', f"include = {value}"))
    refused(main_suite, key, "suite file", got)


def test_a_missing_or_malformed_included_file_is_refused_naming_the_include(main_suite, tmp_path):
    text = main_suite.read_text()
    main_suite.write_text(text.replace('include = ["sub/other.toml"]', 'include = ["sub/other.toml", "nosuch.toml"]'))
    error = refused(main_suite, "include[1]", "an existing suite file", "nosuch.toml")
    assert str(tmp_path / "nosuch.toml") in str(error)
    write_suite(tmp_path, "name = = 1\n", "broken.toml")
    main_suite.write_text(text.replace('include = ["sub/other.toml"]', 'include = ["broken.toml"]'))
    refused(main_suite, "include[0]", "valid TOML", "broken.toml")
    main_suite.write_text(text.replace('include = ["sub/other.toml"]', 'include = ["sub"]'))
    refused(main_suite, "include[0]", "a readable UTF-8 TOML file", "sub")


def test_an_error_inside_an_included_suite_names_that_file_and_its_key(main_suite):
    other = main_suite.parent / "sub" / "other.toml"
    other.write_text(other.read_text().replace("steps = 3", "steps = 3\nnosuch = 1"))
    with pytest.raises(ConfigError) as info:
        load_suite(main_suite)
    assert info.value.source == str(other) and info.value.key == "defaults.nosuch"


@pytest.mark.parametrize("included, name", [
    ('name = "x"\n' + experiment("own"), "own"),  # an experiment of the suite
    ('name = "x"\n' + experiment("mine"), "mine"),  # a group of the suite
    ('name = "x"\ngroups = {own = ["y"]}\n' + experiment("y"), "own"),  # a group named as an experiment of the suite
    ('name = "x"\n' + experiment("y") + scan("own-scan", discard=1), "own-scan"),  # a scan of the suite
])
def test_a_name_the_suite_already_has_is_refused(main_suite, included, name):
    write_suite(main_suite.parent, included, "x.toml")
    main_suite.write_text(main_suite.read_text().replace('include = ["sub/other.toml"]', 'include = ["x.toml"]'))
    error = refused(main_suite, "include[0]", "suites whose experiment, scan and group names differ from this suite's",
                    name)
    assert "'x'" in error.expected


@pytest.mark.parametrize("included, name", [
    ('name = "x"\n' + experiment("inc"), "inc"),
    ('name = "x"\n' + experiment("theirs"), "theirs"),
    ('name = "x"\n' + experiment("y") + scan("inc-scan"), "inc-scan"),
])
def test_a_name_an_earlier_include_has_is_refused(main_suite, included, name):
    write_suite(main_suite.parent, included, "x.toml")
    main_suite.write_text(main_suite.read_text().replace('include = ["sub/other.toml"]',
                                                         'include = ["sub/other.toml", "x.toml"]'))
    refused(main_suite, "include[1]", "names differ from this suite's", name)


def test_a_suite_included_twice_is_refused_by_its_names(main_suite):
    main_suite.write_text(main_suite.read_text().replace('include = ["sub/other.toml"]',
                                                         'include = ["sub/other.toml", "sub/../sub/other.toml"]'))
    refused(main_suite, "include[1]", "names differ", "inc")


def test_a_scan_that_repeats_one_of_the_suite_is_refused(main_suite):
    write_suite(main_suite.parent, 'name = "x"\n' + scan("same-as-own-scan"), "x.toml")
    main_suite.write_text(main_suite.read_text().replace('include = ["sub/other.toml"]', 'include = ["x.toml"]'))
    refused(main_suite, "include[0]", "suites whose scans differ from this suite's", "same-as-own-scan")


def test_a_cycle_is_refused(tmp_path):
    path = write_suite(tmp_path, 'name = "self"\ninclude = ["self.toml"]\n' + experiment("e"), "self.toml")
    refused(path, "include[0]", "a cycle: self.toml -> self.toml", "self.toml")
    a = write_suite(tmp_path, 'name = "a"\ninclude = ["b.toml"]\n' + experiment("a-exp"), "a.toml")
    b = write_suite(tmp_path, 'name = "b"\ninclude = ["c.toml"]\n' + experiment("b-exp"), "b.toml")
    write_suite(tmp_path, 'name = "c"\ninclude = ["./a.toml"]\n' + experiment("c-exp"), "c.toml")
    with pytest.raises(ConfigError) as info:
        load_suite(a)
    assert info.value.source == str(tmp_path / "c.toml") and info.value.key == "include[0]"
    assert "a cycle: a.toml -> b.toml -> c.toml -> a.toml" in info.value.expected
    with pytest.raises(ConfigError, match="cycle: b.toml -> c.toml -> a.toml -> b.toml"):
        load_suite(b)


def test_bench_refuses_a_bad_include_in_one_line(main_suite, tmp_path, capsys):
    main_suite.write_text(main_suite.read_text().replace('include = ["sub/other.toml"]', 'include = ["nosuch.toml"]'))
    out = tmp_path / "results"
    code, _, err = run_cli(capsys, "bench", str(main_suite), "--out", str(out), "--quiet", "--no-report")
    assert code == 2 and "Traceback" not in err
    lines = shown_lines(err)
    assert len(lines) == 1 and lines[0].startswith("morphbench: error: ") and "include[0]" in lines[0]
    assert not out.exists()


# --- the plan -------------------------------------------------------------------------------------------------------


def test_the_plan_lists_includes_only_when_there_are_some(main_suite):
    plan = load_suite(main_suite).plan()
    assert plan["includes"] == ["other"] and list(plan)[-1] == "includes"
    alone = load_suite(main_suite.parent / "sub" / "other.toml").plan()
    assert "includes" not in alone
    smoke = load_suite(BENCHMARKS_DIR / "smoke.toml")
    assert smoke.includes == () and "includes" not in smoke.plan()
    assert list(smoke.plan()) == ["suite", "description", "source", "experiments", "runs", "scans"]


# --- claims ---------------------------------------------------------------------------------------------------------


def test_claims_for_merges_the_included_suites_claims():
    merged = C.claims_for("paper", ("paper-hardware",))
    hardware = {claim.id: claim for claim in C.HARDWARE_CLAIMS}
    replaced = [claim.id for claim in C.CLAIMS if claim.id in hardware]
    assert replaced == ["hw-trough", "hw-local-max", "hw-local-max-at", "hw-3-gait", "hw-3-track",
                        "hw-damaged-optimum"]
    assert len(merged) == len(C.CLAIMS) + len(C.HARDWARE_CLAIMS) - 6 == 73
    assert len({claim.id for claim in merged}) == 73
    head, tail = merged[:len(C.CLAIMS)], merged[len(C.CLAIMS):]
    assert [claim.id for claim in head] == [claim.id for claim in C.CLAIMS]
    for mine, paper in zip(head, C.CLAIMS):
        assert mine is (hardware[paper.id] if paper.id in hardware else paper)
    assert tail == tuple(claim for claim in C.HARDWARE_CLAIMS if claim.id not in replaced)
    assert C.claims_for("paper", ["paper-hardware"]) == merged  # a plan's list


def test_claims_for_without_includes_with_claims_is_as_before():
    assert C.claims_for("paper") is C.CLAIMS and C.claims_for(None) is C.CLAIMS
    assert C.claims_for("paper", ("other", "smoke")) is C.CLAIMS
    assert C.claims_for(C.HARDWARE_SUITE) is C.HARDWARE_CLAIMS
    assert C.claims_for(C.HARDWARE_SUITE, (C.HARDWARE_SUITE,)) is C.HARDWARE_CLAIMS


def test_the_paper_suite_includes_the_hardware_suite(tmp_path):
    """benchmarks/paper.toml runs the hardware twin's scenarios beside the simulations' (issue 38, part 3)."""
    both, hardware = load_suite(BENCHMARKS_DIR / "paper.toml"), load_suite(BENCHMARKS_DIR / "paper-hardware.toml")
    text = (BENCHMARKS_DIR / "paper.toml").read_text()
    assert 'include = ["paper-hardware.toml"]\n' in text
    alone = text.replace('include = ["paper-hardware.toml"]\n', "").replace('"../shapes/',
                                                                             f'"{BENCHMARKS_DIR}/../shapes/')
    paper = load_suite(write_suite(tmp_path, alone, "paper.toml"))
    assert (both.name, both.includes, paper.includes) == ("paper", ("paper-hardware",), ())
    assert [e.name for e in both.experiments] == [e.name for e in paper.experiments + hardware.experiments]
    assert [s.name for s in both.scans] == [s.name for s in paper.scans + hardware.scans]
    assert list(both.runs) == list(dict.fromkeys([*paper.runs, *hardware.runs]))
    assert both.plan()["includes"] == ["paper-hardware"]
    assert len(C.claims_for(both.name, both.includes)) == 73


# --- end to end -----------------------------------------------------------------------------------------------------


def test_bench_and_report_a_suite_that_includes_the_hardware_suites_name(main_suite, tmp_path, capsys):
    other = main_suite.parent / "sub" / "other.toml"
    other.write_text(other.read_text().replace('name = "other"', 'name = "paper-hardware"'))
    out = tmp_path / "results"
    code, _, err = run_cli(capsys, "bench", str(main_suite), "--out", str(out), "--quiet", "--no-report",
                           "--workers", "1")
    assert code == 0, err
    plan = json.loads((out / "plan.json").read_text())
    assert plan["includes"] == ["paper-hardware"] and [e["name"] for e in plan["experiments"]] == ["own", "inc"]
    code, _, err = run_cli(capsys, "report", str(out), "--no-videos")
    assert code == 0, err
    report = (out / "report.md").read_text()
    section = report.split("## Claims", 1)[1]
    assert "of 73 claims hold" in section
    assert "The paper's findings (Oliveri et al." in section and "hardware twin" in section
    assert "included suite paper-hardware's experiments" in section
    assert "| hw-peak |" in section and "| hw-trough |" in section
    record = (out / "suite.toml").read_text()  # the including file, then the included one in comments
    assert record.startswith(main_suite.read_text().rstrip("\n"))
    assert "# --- include[0]: sub/other.toml, as it was read ---" in record and '# name = "paper-hardware"' in record
    assert tomllib.loads(record)["include"] == ["sub/other.toml"]
    plan["includes"] = ["../elsewhere"]  # a damaged plan is refused by the store, naming the key
    (out / "plan.json").write_text(json.dumps(plan))
    code, _, err = run_cli(capsys, "report", str(out), "--no-videos")
    assert code != 0 and "includes[0]" in err and "Traceback" not in err
