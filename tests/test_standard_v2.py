"""Version 2 of the standard task set (issue 37, "honest references"): scans of travelling waves (``waves = N``),
the suite's ``groups``, and benchmarks/standard-v2.toml itself: version 1's tasks as they were, each on a chain or a
sheet with its waves scan, and the scale tasks. Nothing is simulated (the set's reference is made by
benchmarks/leaderboard.py, test_leaderboard.py tests it on a small set)."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest

from morphbench.bench.suite import load_suite, suite_from_table
from morphbench.errors import ConfigError
from morphbench.experiment.scan import grid_places, wave_lags, wave_phases
from morphbench.shapes import load_shape

from conftest import BENCHMARKS_DIR, SHAPES_DIR, write_suite

CHAIN_7 = SHAPES_DIR / "chain-7.toml"
SHEET_4 = BENCHMARKS_DIR / "shapes" / "sheet-4x4.toml"
V1_TASKS = ["chain-2", "chain-3", "chain-7", "chain-20", "grid-2x2", "ring-8", "t-5", "stack-2x2x2", "chain-3-field",
            "chain-3-noise", "chain-3-friction-drop", "chain-3-damage", "chain-7-shuffle", "chain-7-cut",
            "chain-2-clocks", "chain-3-clocks"]
SCALE_TASKS = {"chain-50": (50, 600, 16), "chain-100": (100, 600, 8), "sheet-16x16": (256, 600, 8),
               "sheet-32x32": (1024, 300, 4), "sheet-100x100": (10000, 60, 2)}
"""task: (units, steps, seeds)."""


def scans_of(text: str, tmp_path):
    return load_suite(write_suite(tmp_path, textwrap.dedent(text))).scans


# --- the waves --------------------------------------------------------------------------------------------------------


def test_a_chain_s_columns_are_its_places_and_a_sheet_s_run_from_the_front():
    columns, rows = grid_places(load_shape(CHAIN_7))
    assert columns.tolist() == list(range(7)) and rows.tolist() == [0] * 7  # unit 1 at the front
    sheet = load_shape(SHEET_4)
    columns, rows = grid_places(sheet)
    xy = np.array([sheet.bodies[b].position[:2] for b in sheet.units])
    assert sorted(set(columns)) == sorted(set(rows)) == [0, 1, 2, 3]
    assert np.all(xy[columns == 0, 0] == xy[:, 0].max()) and np.all(xy[columns == 3, 0] == xy[:, 0].min())
    waves = wave_phases(sheet, [0.0, 0.25, 0.5])
    assert waves.shape == (3, 16)
    assert np.array_equal(waves[1], np.mod(0.25 * columns, 1.0)) and not waves[0].any()


def test_a_waves_scan_measures_the_waves_of_a_chain_and_of_a_sheet(tmp_path):
    chain, sheet = scans_of(f"""
        [[scan]]
        shape = "{CHAIN_7}"
        waves = 40
        [[scan]]
        name = "sheet"
        shape = "{SHEET_4}"
        waves = 8
        environment = {{friction_scale = 0.6}}
        """, tmp_path)
    for spec, n in ((chain, 40), (sheet, 8)):
        columns, _ = grid_places(spec.shape)
        delta = np.arange(n) / n
        assert np.array_equal(wave_lags(n), delta)
        assert spec.phases.shape == (n, spec.shape.n_units)
        assert np.array_equal(spec.phases, np.mod(np.outer(delta, columns), 1.0))  # column c at c * delta mod 1
        assert (spec.phases[:, 0] == 0).all()  # unit 1 is in the front column: at 0, as in every scan
        assert spec.columns["waves"] == spec.columns["samples"] == spec.columns["resolution"] == n
    assert chain.name == "chain-7-waves40" and chain.phases[1].tolist() == [k * (1 / 40) for k in range(7)]
    assert sheet.environment.friction_scale == 0.6


def test_the_waves_are_in_the_scan_s_id_and_every_other_scan_keeps_its_id(tmp_path):
    # the ids these scans had before scans could be waves (computed at commit 6350d08)
    table = {"scan": [{"name": "a", "shape": str(SHAPES_DIR / "chain-3.toml"), "resolution": 5},
                      {"name": "b", "shape": str(CHAIN_7), "samples": 10, "seed": 2,
                       "damage": {"unit": 2, "mode": "open"}},
                      {"name": "c", "shape": str(SHAPES_DIR / "chain-2.toml"), "environment": {"friction_scale": 0.6}}]}
    scans = suite_from_table(table, source="ids.toml", base=tmp_path).scans
    assert [(s.name, s.id) for s in scans] == [("a", "5a198cbae39b"), ("b", "0780a415ae9b"), ("c", "c519779c96f1")]
    assert all(s.columns["waves"] == 0 for s in scans)
    waves = [{"name": f"w{n}", "shape": str(CHAIN_7), "waves": n} for n in (10, 20)]
    ids = {s.id for s in suite_from_table({"scan": waves}, source="w.toml", base=tmp_path).scans}
    assert len(ids) == 2 and not ids & {s.id for s in scans}


@pytest.mark.parametrize("keys, named", [
    ('waves = 40\nresolution = 20', "resolution"), ('waves = 40\nsamples = 100', "samples"),
])
def test_waves_with_resolution_or_samples_is_refused_naming_the_file_and_key(tmp_path, keys, named):
    path = write_suite(tmp_path, f'[[scan]]\nshape = "{CHAIN_7}"\n{keys}\n')
    with pytest.raises(ConfigError) as info:
        load_suite(path)
    assert str(info.value).startswith(f"{path}: scan[0].waves: expected either waves or {named} in one scan")


@pytest.mark.parametrize("value", [0, -3, 2.5, "forty"])
def test_waves_is_a_count(tmp_path, value):
    path = write_suite(tmp_path, f'[[scan]]\nshape = "{CHAIN_7}"\nwaves = {value!r}\n'.replace("'", '"'))
    with pytest.raises(ConfigError, match=r"scan\[0\]\.waves: expected"):
        load_suite(path)


# --- groups -----------------------------------------------------------------------------------------------------------


def _suite(groups: str, tmp_path):
    return write_suite(tmp_path, f'''
{groups}
[defaults]
steps = 2
[[experiment]]
name = "a"
shape = "{SHAPES_DIR / 'chain-2.toml'}"
[[experiment]]
name = "b"
shape = "{SHAPES_DIR / 'chain-3.toml'}"
''')


def test_groups_name_lists_of_the_suite_s_experiments(tmp_path):
    suite = load_suite(_suite('groups = {both = ["b", "a"], one = ["a"]}', tmp_path))
    assert suite.groups == {"both": ("b", "a"), "one": ("a",)}
    assert load_suite(_suite("", tmp_path)).groups == {}


@pytest.mark.parametrize("groups, expected", [
    ('groups = {x = ["a", "c"]}', "groups.x: expected names of the suite's experiments (a, b), got 'c'"),
    ('groups = {a = ["b"]}', "groups.a: expected a group name no experiment has"),
    ('groups = {x = []}', "groups.x: expected a non-empty list of experiment names"),
    ('groups = {x = "a"}', "groups.x: expected a non-empty list of experiment names"),
    ('groups = {x = ["a", "a"]}', "groups.x: expected distinct values"),
    ('groups = ["a"]', "groups: expected a table of group names"),
])
def test_a_bad_group_is_refused(tmp_path, groups, expected):
    path = _suite(groups, tmp_path)
    with pytest.raises(ConfigError) as info:
        load_suite(path)
    assert str(info.value).startswith(f"{path}: {expected}")


# --- benchmarks/standard-v2.toml --------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def v2():
    return load_suite(BENCHMARKS_DIR / "standard-v2.toml")


@pytest.fixture(scope="module")
def v1():
    return load_suite(BENCHMARKS_DIR / "standard-v1.toml")


def test_version_2_is_version_1_s_tasks_as_they_were_and_the_scale_tasks(v1, v2):
    assert v2.name == "standard-v2" and v1.name == "standard-v1"
    assert [e.name for e in v1.experiments] == V1_TASKS
    assert [e.name for e in v2.experiments] == V1_TASKS + list(SCALE_TASKS)
    learners = {"thermal", "flaky", "sparse", "random", "cmaes"}
    for experiment in v2.experiments:
        assert {v2.runs[r].condition["learner"] for r in experiment.run_ids} == learners, experiment.name
    # the learners of both versions run the same runs on version 1's tasks: the same conditions, the same run ids
    for old in v1.experiments:
        new = next(e for e in v2.experiments if e.name == old.name)
        for learner in ("thermal", "flaky", "random"):
            mine = [{r for r in e.run_ids if s.runs[r].condition["learner"] == learner}
                    for e, s in ((old, v1), (new, v2))]
            assert mine[0] == mine[1] and mine[0], (old.name, learner)
    for task, (units, steps, seeds) in SCALE_TASKS.items():
        experiment = next(e for e in v2.experiments if e.name == task)
        specs = [v2.runs[r] for r in experiment.run_ids if v2.runs[r].condition["learner"] == "thermal"]
        assert {s.config.shape.n_units for s in specs} == {units} and {s.config.steps for s in specs} == {steps}
        assert sorted(s.seed for s in specs) == list(range(seeds)), task
    assert v2.groups == {"scale": ("chain-2", "chain-7", "chain-20", "chain-50", "chain-100", "sheet-16x16",
                                   "sheet-32x32", "sheet-100x100")}


def test_every_task_on_a_chain_or_a_sheet_knows_its_waves_beside_version_1_s_scans(v1, v2):
    old = {e.name: e.scans for e in v1.experiments}
    scans = {s.name: s for s in v2.scans}
    assert all(scans[name].id == s.id for s in v1.scans for name in [s.name])  # version 1's scans, unchanged
    for experiment in v2.experiments:
        shape = v2.runs[experiment.run_ids[0]].config.shape
        named = [scans[name] for name in experiment.scans]
        assert experiment.scans[:len(old.get(experiment.name, ()))] == old.get(experiment.name, ())
        waves = [s for s in named if s.columns["waves"]]
        if experiment.name == "chain-7-cut" or not shape.name.startswith(("chain", "sheet")):
            assert not waves, experiment.name  # the cut's pieces, the grid, the ring, the T, the stack: none
            continue
        (wave,) = waves
        assert wave.columns["waves"] == 40 and wave.shape == shape, experiment.name
        # on the ground and with the damage of the task's other scans (the changed assembly's, after an event)
        for other in named:
            assert (other.environment, other.damage) == (wave.environment, wave.damage), experiment.name
        if experiment.name in SCALE_TASKS:
            (sampled,) = [s for s in named if not s.columns["waves"]]
            assert sampled.columns["samples"] == (8 if shape.n_units == 10000 else 16 if "sheet" in shape.name
                                                  else 50)


def test_version_2_s_reference_is_made_beside_it():
    """benchmarks/standard-v2-reference.csv is made by python benchmarks/leaderboard.py (about an hour on 2 cores);
    until then the leaderboard's default set says so in one line (test_leaderboard.py). Once it is committed, it must
    be this set's."""
    from morphbench.bench import scores as S
    from morphbench.bench.leaderboard import conditions, reference_path, standard_suite

    path = reference_path(standard_suite())
    assert path == BENCHMARKS_DIR / "standard-v2-reference.csv"
    if not path.is_file():
        pytest.skip("benchmarks/standard-v2-reference.csv is not made yet (python benchmarks/leaderboard.py)")
    suite = load_suite(standard_suite())
    reference = S.read_reference(path, suite)
    S.check_conditions(reference, conditions(suite), str(path))
    learners = reference[reference.kind == "learner"]
    assert set(learners.source) == {"thermal", "flaky", "sparse", "random", "cmaes"}
    assert set(learners.task) == {e.name for e in suite.experiments}
