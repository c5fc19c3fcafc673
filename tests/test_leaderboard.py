"""The standard task set and ``morphbench leaderboard``: the scoring on a stored fixture with known answers, the
reference made by benchmarks/leaderboard.py and the command end to end on a two-task set (2 seeds of 6 steps), a
plug-in scored on its own tasks only or a group's, the scale figure, version 1 scored by name against its shipped
reference, and bad input refused in one line with exit status 2."""

from __future__ import annotations

import importlib.util
import json
import math
import os
import shutil
import textwrap

import pandas as pd
import pytest

from morphbench.bench import scores as S
from morphbench.bench.leaderboard import (conditions, learner_suite, reference_path, scale_points, scale_sentence,
                                          shipped_sets, standard_suite, suite_file, task_names, task_sizes)
from morphbench.learning import plugins
from morphbench.bench.suite import load_suite
from morphbench.errors import ConfigError

from conftest import BENCHMARKS_DIR, ROOT, SHAPES_DIR, run_cli

FIXTURE = ROOT / "tests" / "data" / "leaderboard-reference.csv"
TWO_TASKS = f"""
name = "two-v1"
description = "Two tasks for the tests."
groups = {{scale = ["c2", "c3-noise"]}}
[defaults]
learner = {{name = ["thermal", "flaky", "random"]}}
seeds = 2
steps = 6
[[experiment]]
name = "c2"
shape = "{SHAPES_DIR / 'chain-2.toml'}"
scans = ["c2"]
[[experiment]]
name = "c3-noise"
shape = "{SHAPES_DIR / 'chain-3.toml'}"
environment = {{noise = 1.0}}
[[scan]]
name = "c2"
shape = "{SHAPES_DIR / 'chain-2.toml'}"
resolution = 8
cycles = 3
discard = 1
"""
BROKEN = """
class Broken:
    def __init__(self, params, rng):
        self.phase = 0.0

    def propose(self):
        raise RuntimeError("no idea")

    def update(self, velocity):
        return False
"""
GREEDY = plugins.__doc__.split("# my_learners.py")[1].split("\n", 1)[1]
"""the documented plug-in example (morphbench.learning.plugins), a greedy learner."""
FACTORY = f"def make():\n{textwrap.indent(textwrap.dedent(GREEDY), '    ')}    return Greedy\n\n\nMade = make()\n"
"""the same learner, its class made by a factory: its qualified name is make.<locals>.Greedy."""


# --- the scoring, on a stored fixture --------------------------------------------------------------------------------


def test_scores_of_the_fixture_are_the_hand_computed_ones():
    # tests/data/leaderboard-reference.csv: task a (scan best 4, thermal 2.0 +- std 0.8 over 4 runs, random 0.0 +- 0.4),
    # task b (no scan: the best is thermal's 3.0; random 1.0 +- 0.2), task c (scan best 2; thermal has 1 run of 4
    # finished, 5.0: neither scored nor a known gait; random 0.5 +- 0.2); 'broken' finished no run on a and one on b,
    # so it is scored nowhere, and the others are compared without it
    reference = pd.read_csv(FIXTURE).drop(columns="suite")
    best = S.best_known(reference)
    assert best.to_dict() == {"a": 4.0, "b": 3.0, "c": 2.0}
    assert S.best_source(reference).to_dict() == {"a": "scan s-a", "b": "thermal", "c": "scan s-c"}
    scores = S.task_scores(reference, best).set_index(["task", "learner"])
    expected = {("a", "thermal"): (0.5, 0.1), ("a", "random"): (0.0, 0.05), ("b", "thermal"): (1.0, 1 / 6),
                ("b", "random"): (1 / 3, 0.2 / 2 / 3), ("c", "random"): (0.25, 0.05)}
    for key, (score, se) in expected.items():
        assert scores.score[key] == pytest.approx(score) and scores.score_se[key] == pytest.approx(se), key
    assert math.isnan(scores.score["c", "thermal"]) and math.isnan(scores.score_se["c", "thermal"])
    assert math.isnan(scores.score["a", "broken"]) and math.isnan(scores.score["b", "broken"])
    assert scores.failed["a", "broken"] == 4
    assert S.common_tasks(scores.reset_index()) == ["a", "b"]  # thermal is not scored on c
    ranking = S.overall(scores.reset_index()).set_index("learner")
    assert list(ranking.index) == ["thermal", "random"]  # best first
    assert ranking.score["thermal"] == pytest.approx(0.75)
    assert ranking.score_se["thermal"] == pytest.approx(math.sqrt(0.1 ** 2 + (1 / 6) ** 2) / 2)
    assert ranking.score["random"] == pytest.approx(1 / 6)
    assert ranking.score_se["random"] == pytest.approx(math.sqrt(0.05 ** 2 + (0.2 / 6) ** 2) / 2)
    assert (ranking.tasks == 2).all()
    on_c = S.overall(scores.reset_index(), ["c"]).set_index("learner")
    assert on_c.score["random"] == pytest.approx(0.25) and on_c.tasks["random"] == 1


def test_markdown_shows_every_task_and_marks_the_stored_learners():
    reference = pd.read_csv(FIXTURE).drop(columns="suite")
    scores = S.task_scores(reference, S.best_known(reference))
    text = S.markdown(scores, reference, S.compared_tasks(scores), stored=["thermal", "random"])
    assert "| 1 | thermal* | 0.750 +- 0.097 | 2 |" in text
    assert "| 2 | random* | 0.167 +- 0.030 | 2 |" in text
    assert "the 2 of 3 tasks every learner is scored on" in text
    assert "| c | - (3 failed) | 0.250 +- 0.050 | not run | 2.00 | scan s-c |" in text
    assert "| b | 1.000 +- 0.167 | 0.333 +- 0.033 | - (3 failed) | 3.00 | thermal |" in text
    assert "| - | broken | not scored | 0 |" in text
    renamed = reference.assign(source=reference.source.replace("random", "cmaes"))
    scores = S.task_scores(renamed, S.best_known(renamed))
    assert "| 2 | cmaes (centralized) | 0.167 +- 0.030 | 2 |" in S.markdown(scores, renamed, S.compared_tasks(scores))


# --- the scale figure's data and a centralized baseline's comparison, on the fixture ----------------------------------


def test_the_scale_table_gives_each_learner_s_score_against_n_by_family():
    reference = pd.read_csv(FIXTURE).drop(columns="suite")
    reference = reference.assign(source=reference.source.replace("random", "cmaes"))
    scores = S.task_scores(reference, S.best_known(reference))
    sizes = pd.DataFrame({"task": ["b", "a", "c"], "family": ["chain", "chain", "sheet"], "n_units": [20, 2, 256]})
    table = S.scale_table(scores, sizes)
    assert list(table.columns) == ["family", "n_units", "task", "learner", "centralized", "score", "score_se", "low",
                                   "high"]
    # by family in the sizes' order, then N, learners in the scores' order; thermal is not scored on c (1 of its 4
    # runs finished) and broken nowhere: neither is drawn there
    assert list(zip(table.family, table.n_units, table.task, table.learner)) == [
        ("chain", 2, "a", "cmaes"), ("chain", 2, "a", "thermal"), ("chain", 20, "b", "cmaes"),
        ("chain", 20, "b", "thermal"), ("sheet", 256, "c", "cmaes")]
    row = table.set_index(["task", "learner"])
    assert row.score["a", "thermal"] == pytest.approx(0.5) and row.low["a", "thermal"] == pytest.approx(0.3)
    assert row.high["a", "thermal"] == pytest.approx(0.7) and row.score_se["b", "cmaes"] == pytest.approx(0.2 / 6)
    assert list(row.centralized) == [True, False, True, False, True]
    assert S.scale_table(scores, sizes.iloc[:0]).empty
    assert scale_sentence(table) == (
        "Each learner's score on the tasks of the group `scale` against their number of units N (log scale): chains "
        "of 2 to 20 units (left); sheets of 256 units (right); the mean over the seeds +- 2 standard errors, 1 the "
        "best gait known for each task.")


def test_a_centralized_baseline_does_not_narrow_the_comparison():
    """cmaes cannot run units on clocks of their own (its runs of the clocks tasks fail): the others are still
    compared on every task, and it is averaged over those it is scored on."""
    reference = pd.read_csv(FIXTURE).drop(columns="suite")
    reference = reference.assign(source=reference.source.replace("thermal", "cmaes"))  # not scored on c
    scores = S.task_scores(reference, S.best_known(reference))
    assert S.common_tasks(scores) == ["a", "b", "c"]  # random's: cmaes, scored on a and b only, does not narrow them
    ranking = S.overall(scores).set_index("learner")
    assert ranking.tasks.to_dict() == {"cmaes": 2, "random": 3}
    assert ranking.score["cmaes"] == pytest.approx(0.75)
    assert ranking.score["random"] == pytest.approx((0.0 + 1 / 3 + 0.25) / 3)
    text = S.markdown(scores, reference, S.compared_tasks(scores))
    assert "Mean task score over all 3 tasks" in text and "A centralized baseline is averaged over those" in text
    only = S.task_scores(reference[reference.source == "cmaes"], S.best_known(reference))
    assert S.common_tasks(only) == ["a", "b"]  # a centralized learner alone is compared on its own tasks


# --- the standard set -------------------------------------------------------------------------------------------------


def test_a_leaderboard_suite_that_includes_another_is_refused(tmp_path):
    """An included suite's experiments would keep their own learners: a leaderboard's suite lists its tasks itself."""
    path = tmp_path / "board.toml"
    path.write_text(f'include = ["other.toml"]\n[[experiment]]\nname = "t"\nshape = "{SHAPES_DIR / "chain-2.toml"}"\n')
    with pytest.raises(ConfigError) as info:
        learner_suite(path, ["random"])
    assert info.value.source == str(path) and info.value.key == "include"


def test_the_default_set_is_version_2_and_a_plugin_runs_its_tasks_with_the_same_ids():
    suite = load_suite(standard_suite())
    assert standard_suite() == BENCHMARKS_DIR / "standard-v2.toml" and suite.name == "standard-v2"
    assert len(suite.experiments) == 21 and "scale" in suite.groups
    for experiment in suite.experiments:
        learners = {suite.runs[r].condition["learner"] for r in experiment.run_ids}
        stored = {"thermal", "flaky", "sparse", "random", "cmaes"}
        assert learners == stored and len(experiment.condition_ids) == len(stored), experiment.name
    shapes = {suite.runs[r].config.shape.source.rsplit("/", 1)[-1] for r in suite.runs}
    assert {"chain-2.toml", "chain-20.toml", "chain-100.toml", "grid-2x2.toml", "ring-8.toml", "t-5.toml",
            "stack-2x2x2.toml", "sheet-100x100.toml"} <= shapes
    plug = learner_suite(standard_suite(), ["random"], ["chain-2", "ring-8"])  # its groups left out with its tasks
    assert [e.name for e in plug.experiments] == ["chain-2", "ring-8"] and not plug.scans and not plug.groups
    same = {r for e in suite.experiments if e.name in ("chain-2", "ring-8") for r in e.run_ids
            if suite.runs[r].condition["learner"] == "random"}
    assert set(plug.runs) == same  # the same runs, the same ids: stored results are found again
    sizes = task_sizes(suite, suite.groups["scale"])
    assert list(zip(sizes.task, sizes.family, sizes.n_units)) == [
        ("chain-2", "chain", 2), ("chain-7", "chain", 7), ("chain-20", "chain", 20), ("chain-50", "chain", 50),
        ("chain-100", "chain", 100), ("sheet-16x16", "sheet", 256), ("sheet-32x32", "sheet", 1024),
        ("sheet-100x100", "sheet", 10000)]
    assert task_names(["chain-3", "scale", "chain-7"], suite, "v2") == ["chain-3", *suite.groups["scale"]]


def test_version_1_is_found_by_name_and_its_shipped_reference_still_reads(capsys, tmp_path):
    path = suite_file("standard-v1")
    assert path == BENCHMARKS_DIR / "standard-v1.toml" == suite_file("standard-v1.toml")
    assert suite_file(None) == standard_suite() and suite_file(str(path)) == path
    assert {"standard-v1", "standard-v2"} <= set(shipped_sets())
    suite = load_suite(path)
    assert suite.name == "standard-v1" and len(suite.experiments) == 16 and not suite.groups
    reference = S.read_reference(reference_path(path), suite)  # its scans' ids, its built-ins' conditions
    assert reference_path(path) == BENCHMARKS_DIR / "standard-v1-reference.csv"
    S.check_conditions(reference, conditions(suite), str(reference_path(path)))
    assert set(reference[reference.kind == "learner"].source) == {"thermal", "flaky", "averaged", "adaptive",
                                                                  "random"}
    out = tmp_path / "v1"
    code, stdout, stderr = run_cli(capsys, "leaderboard", "--suite", "standard-v1", "--out", str(out), "--quiet")
    assert code == 0, stderr
    assert stdout.count(" over 16 tasks") == 5 and "1. adaptive: 0.410 +- 0.012 over 16 tasks" in stdout
    assert sorted(p.name for p in out.iterdir()) == ["leaderboard.html", "leaderboard.md"]  # no group scale: no figure


def test_without_its_reference_the_default_set_says_how_to_make_it(capsys, tmp_path):
    """Until benchmarks/standard-v2-reference.csv is made (python benchmarks/leaderboard.py), the leaderboard's
    default set is refused in one line that says so; once it is there, the stored learners are ranked."""
    if reference_path(standard_suite()).is_file():
        code, stdout, stderr = run_cli(capsys, "leaderboard", "--out", str(tmp_path / "v2"), "--quiet")
        assert code == 0 and stdout.count(" over ") == 5, stderr
        return
    message = _refused(capsys, "--out", str(tmp_path / "v2"))
    assert "standard-v2-reference.csv: (file): expected the reference table of standard-v2" in message
    assert "python benchmarks/leaderboard.py" in message


# --- the reference and the command, end to end ------------------------------------------------------------------------


@pytest.fixture(scope="module")
def two_tasks(tmp_path_factory):
    """The two-task set, its reference made by benchmarks/leaderboard.py (its doc section too), and a plug-in
    directory on the path of this process and of the workers."""
    root = tmp_path_factory.mktemp("leaderboard")
    suite = root / "two.toml"
    suite.write_text(textwrap.dedent(TWO_TASKS))
    plugins = root / "plugins"
    plugins.mkdir()
    (plugins / "greedy_learner.py").write_text(textwrap.dedent(GREEDY))
    (plugins / "broken_learner.py").write_text(textwrap.dedent(BROKEN))
    (plugins / "factory_learner.py").write_text(textwrap.dedent(FACTORY))
    with pytest.MonkeyPatch.context() as patch:
        patch.syspath_prepend(str(plugins))
        patch.setenv("PYTHONPATH", os.pathsep.join([str(plugins), str(ROOT)]))
        script = _script()
        doc = root / "doc.md"
        doc.write_text("# Leaderboard\n\nintro\n\n" + script.BEGIN + "\nold\n" + script.END + "\n\nafter\n")
        assert script.main(["--suite", str(suite), "--doc", str(doc), "--out", str(root / "full"), "--workers", "1",
                            "--quiet"]) == 0
        yield root, suite, doc


def test_the_reference_holds_the_scans_and_the_builtins(two_tasks):
    root, suite, doc = two_tasks
    reference = pd.read_csv(reference_path(suite))
    assert tuple(reference.columns) == S.REFERENCE_COLUMNS and (reference.suite == "two-v1").all()
    runs = pd.read_parquet(root / "full" / "runs.parquet")
    scans = pd.read_parquet(root / "full" / "scans.parquet")
    row = reference.set_index(["task", "kind", "source"])
    assert row.ubar["c2", "scan", "c2"] == pytest.approx(scans.ubar.max(), rel=1e-5)
    for task in ("c2", "c3-noise"):
        for learner in ("thermal", "flaky", "random"):
            mine = runs[(runs.experiments.astype(str) == task) & (runs.learner == learner)].final_ubar_true
            assert row.runs[task, "learner", learner] == 2
            assert row.ubar[task, "learner", learner] == pytest.approx(mine.mean(), rel=1e-5, abs=1e-6)
            assert row.ubar_std[task, "learner", learner] == pytest.approx(mine.std(), rel=1e-5)
    text = doc.read_text()
    assert text.startswith("# Leaderboard\n\nintro\n\n") and text.endswith("\n\nafter\n") and "old" not in text
    assert "## The tasks (two-v1)" in text and "| c2 | chain-2 | quasistatic | 2 | 6 | scan c2 |" in text
    assert "| c3-noise | chain-3 | quasistatic | 2 | 6 | the learners only |" in text
    assert "13 jobs run" in text  # 12 runs, 1 scan part
    assert "## Scale" in text and "![score against the number of units](media/leaderboard-scale.png)" in text
    assert "chains of 2 to 3 units (alone)" in text
    assert (doc.parent / "media" / "leaderboard-scale.png").read_bytes()[:4] == b"\x89PNG"


def test_a_plugin_is_run_and_scored_beside_the_stored_builtins(two_tasks, capsys):
    root, suite, _ = two_tasks
    out = root / "board"
    code, stdout, stderr = run_cli(capsys, "leaderboard", "greedy_learner:Greedy", "thermal", "--suite", str(suite),
                                   "--out", str(out), "--workers", "1", "--quiet")
    assert code == 0, stderr
    runs = pd.read_parquet(out / "runs.parquet")
    assert set(runs.learner) == {"greedy_learner:Greedy"} and len(runs) == 4  # thermal is stored: not run again
    assert (runs.status == "done").all()
    reference = pd.read_csv(reference_path(suite)).drop(columns="suite")
    best = S.best_known(reference)
    mine = runs.groupby(runs.experiments.astype(str)).final_ubar_true.agg(["mean", "std"])
    score = (mine["mean"] / best).mean()
    se = math.sqrt(sum((mine["std"][t] / math.sqrt(2) / best[t]) ** 2 for t in best.index)) / 2
    assert f"greedy_learner:Greedy: {score:.3f} +- {se:.3f} over 2 tasks" in stdout
    text = (out / "leaderboard.md").read_text()
    assert "| greedy_learner:Greedy |" in text and "thermal*" in text and "flaky*" in text
    page = (out / "leaderboard.html").read_text()
    assert page.startswith("<!DOCTYPE html>") and "<table>" in page and "greedy_learner:Greedy" in page
    stamp = json.loads(next((out / "runs").glob("*/result.json")).read_text())["wall_time_s"]
    assert run_cli(capsys, "leaderboard", "greedy_learner:Greedy", "--suite", str(suite), "--out", str(out),
                   "--quiet")[0] == 0
    again = json.loads(next((out / "runs").glob("*/result.json")).read_text())["wall_time_s"]
    assert again == stamp  # resumed: its runs were not run again


def test_a_plugin_run_on_some_tasks_is_compared_on_those_only(two_tasks, capsys):
    root, suite, _ = two_tasks
    out = root / "one-task"
    code, stdout, stderr = run_cli(capsys, "leaderboard", "greedy_learner:Greedy", "--tasks", "c2", "--suite",
                                   str(suite), "--out", str(out), "--workers", "1", "--quiet")
    assert code == 0, stderr
    assert set(pd.read_parquet(out / "runs.parquet").experiments.astype(str)) == {"c2"}
    lines = [line for line in stdout.splitlines() if " +- " in line]
    assert len(lines) == 4 and all(line.endswith("over 1 task") for line in lines)
    text = (out / "leaderboard.md").read_text()
    assert "the 1 of 2 tasks every learner is scored on" in text
    row = next(line for line in text.splitlines() if line.startswith("| c3-noise |"))
    assert row.count("| not run |") == 1 and row.count(" +- ") == 3  # the plug-in's cell, the stored built-ins


def test_a_plugin_whose_runs_fail_is_listed_unscored_and_the_others_still_ranked(two_tasks, capsys):
    root, suite, _ = two_tasks
    out = root / "broken"
    code, stdout, _ = run_cli(capsys, "leaderboard", "broken_learner:Broken", "--suite", str(suite), "--out",
                              str(out), "--workers", "1", "--quiet")
    assert code == 1  # runs failed, as a bench with failed runs
    assert stdout.count("  failed ") == 4 and "no idea" in stdout
    assert stdout.count(" over 2 tasks") == 3  # the built-ins, compared on every task
    assert "-. broken_learner:Broken: not scored" in stdout
    text = (out / "leaderboard.md").read_text()
    assert "| - | broken_learner:Broken | not scored | 0 |" in text
    assert text.count("| - (2 failed) |") == 2


def test_a_plugin_class_made_by_a_factory_is_taken_as_run_and_bench_take_it(two_tasks, capsys):
    # the leaderboard named a plug-in by its class's module:qualname, factory_learner:make.<locals>.Greedy, which no
    # loader takes; it names it now as it was given, as run and bench do (learning.plugins.learner_name)
    root, suite, _ = two_tasks
    out = root / "factory"
    code, stdout, stderr = run_cli(capsys, "leaderboard", "factory_learner:Made", " THERMAL ", "--suite", str(suite),
                                   "--tasks", "c2", "--out", str(out), "--workers", "1", "--quiet")
    assert code == 0, stderr
    runs = pd.read_parquet(out / "runs.parquet")
    assert set(runs.learner) == {"factory_learner:Made"} and (runs.status == "done").all()
    assert "factory_learner:Made: " in stdout and "thermal: " in stdout  # thermal, whatever its case: the stored one


def test_learner_names_are_those_the_loader_takes_back(tmp_path, monkeypatch):
    (tmp_path / "made_learner.py").write_text(FACTORY)
    monkeypatch.syspath_prepend(str(tmp_path))
    assert plugins.learner_spec(plugins.load_learner_class("made_learner:Made")) == "made_learner:make.<locals>.Greedy"
    for given, name in [("Thermal", "thermal"), (" cmaes ", "cmaes"), ("made_learner:Made", "made_learner:Made"),
                        ("morphbench.learning.metropolis:FlakyLearner", "flaky")]:
        assert plugins.learner_name(given) == name
        assert plugins.load_learner_class(name) is plugins.load_learner_class(given)
    with pytest.raises(ConfigError, match="--learner: nosuch: expected"):
        plugins.learner_name("nosuch")


def test_the_stored_builtins_alone_run_nothing(two_tasks, capsys):
    root, suite, _ = two_tasks
    out = root / "builtins"
    code, stdout, _ = run_cli(capsys, "leaderboard", "--suite", str(suite), "--out", str(out), "--quiet")
    assert code == 0 and sorted(p.name for p in out.iterdir()) == ["leaderboard-scale.png", "leaderboard.html",
                                                                     "leaderboard.md"]
    assert stdout.count(" over 2 tasks") == 3
    assert run_cli(capsys, "leaderboard", "--suite", str(suite), "--out", str(out), "--quiet")[0] == 0  # its own again


def test_a_group_names_its_tasks_and_the_scale_figure_shows_them(two_tasks, capsys):
    root, suite, _ = two_tasks
    out = root / "group"
    code, stdout, stderr = run_cli(capsys, "leaderboard", "greedy_learner:Greedy", "--tasks", "scale", "--suite",
                                   str(suite), "--out", str(out), "--workers", "1", "--quiet")
    assert code == 0, stderr
    assert set(pd.read_parquet(out / "runs.parquet").experiments.astype(str)) == {"c2", "c3-noise"}
    assert stdout.count(" over 2 tasks") == 4 and f"the scale figure: {out / 'leaderboard-scale.png'}" in stdout
    assert (out / "leaderboard-scale.png").read_bytes()[:4] == b"\x89PNG"
    text = (out / "leaderboard.md").read_text()
    assert "## Scale" in text and "![score against the number of units](leaderboard-scale.png)" in text
    assert "data:image/png;base64," in (out / "leaderboard.html").read_text()  # one page that needs no other file
    full = load_suite(suite)
    reference = pd.read_csv(reference_path(suite)).drop(columns="suite")
    scores = S.task_scores(reference, S.best_known(reference))
    points = scale_points(full, scores)
    assert list(dict.fromkeys(points.task)) == ["c2", "c3-noise"] and set(points.n_units) == {2, 3}
    assert list(scale_points(full, scores, ["c2"]).task.unique()) == ["c2"]


# --- bad input --------------------------------------------------------------------------------------------------------


def _refused(capsys, *argv) -> str:
    code, stdout, stderr = run_cli(capsys, "leaderboard", *argv, "--quiet")
    assert code == 2, (stdout, stderr)
    assert stderr.startswith("morphbench: error: ") and stderr.count("\n") == 1, stderr
    return stderr


def test_bad_learners_tasks_and_directories_are_one_line(two_tasks, capsys, tmp_path):
    _, suite, _ = two_tasks
    where = ["--suite", str(suite), "--out", str(tmp_path / "out")]
    assert "--learner: nosuch: expected" in _refused(capsys, "nosuch", *where)
    assert "no_such_module_xyz:Cls" in _refused(capsys, "no_such_module_xyz:Cls", *where)
    message = _refused(capsys, "random", "--tasks", "nosuch", *where)
    assert "--tasks: nosuch: expected a task of" in message and "(c2, c3-noise) or one of its groups (scale)" in message
    assert "--suite: nosuch: expected a suite file or the name of a task set shipped with morphbench (" \
        f"{', '.join(shipped_sets())})" in _refused(capsys, "--suite", "nosuch", "--out", str(tmp_path / "out"))
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("keep")
    assert "a new directory or a leaderboard's" in _refused(capsys, "--suite", str(suite), "--out",
                                                            str(tmp_path / "mine"))
    assert "missing.toml: (file): expected an existing suite file" in _refused(capsys, "--suite",
                                                                              str(tmp_path / "missing.toml"))
    assert "--out: '': expected a path" in _refused(capsys, "--suite", str(suite), "--out", "")


def test_damaged_results_are_refused(two_tasks, capsys, tmp_path):
    _, suite, _ = two_tasks
    out = tmp_path / "board"
    assert run_cli(capsys, "leaderboard", "greedy_learner:Greedy", "--suite", str(suite), "--out", str(out),
                   "--workers", "1", "--quiet")[0] == 0
    result = next((out / "runs").glob("*/result.json"))
    result.write_text("{not json")
    message = _refused(capsys, "greedy_learner:Greedy", "--suite", str(suite), "--out", str(out))
    assert "damaged" in message and "morphbench check DIR --repair" in message


@pytest.mark.parametrize("damage, key", [
    (lambda t: t.assign(kind=t.kind.replace("scan", "other")), "kind"),
    (lambda t: t.assign(suite="two-v0"), "suite"),
    (lambda t: t[t.kind != "scan"], "task c2"),
    (lambda t: t.drop(columns="ubar_std"), "(columns)"),
    (lambda t: t.assign(id=t.id.where(t.source != "thermal", "0" * 12)), "task c2"),
    (lambda t: t.assign(ubar=t.ubar.astype(str).where(t.kind != "scan", "fast")), "(column ubar)"),
    (lambda t: pd.concat([t, t.iloc[:1]]), "it repeats"),
    (lambda t: t.assign(runs=t.runs.astype(float).where(t.kind != "scan", math.nan)), "runs: expected a count"),
])
def test_a_damaged_or_stale_reference_is_refused(two_tasks, capsys, tmp_path, damage, key):
    _, suite, _ = two_tasks
    copy = tmp_path / "two.toml"
    shutil.copy(suite, copy)
    damage(pd.read_csv(reference_path(suite), dtype={"id": str})).to_csv(reference_path(copy), index=False)
    message = _refused(capsys, "--suite", str(copy), "--out", str(tmp_path / "out"))
    assert f"{reference_path(copy)}: " in message and key in message


def test_a_task_nothing_moves_forward_has_no_reference(two_tasks):
    _, suite_path, _ = two_tasks
    suite = load_suite(suite_path)
    runs = pd.DataFrame([{"run_id": r.id, "learner": r.condition["learner"], "condition_id": r.condition_id,
                          "status": "done", "final_ubar_true": -1.0} for r in suite.runs.values()])
    with pytest.raises(ConfigError) as info:
        S.reference_table(suite, runs, pd.DataFrame({"scan": ["c2"], "ubar": [-0.5]}))
    assert str(info.value).startswith(f"{suite_path}: experiment[c2]: expected a task on which some scan point")
    moving = S.reference_table(suite, runs.assign(final_ubar_true=[1.0, 3.0] * (len(runs) // 2)),
                               pd.DataFrame({"scan": ["c2"], "ubar": [-0.5]}))
    assert S.best_known(moving).to_dict() == {"c2": 2.0, "c3-noise": 2.0}  # seeds 0 and 1 of each learner
    assert list(moving.kind[moving.task == "c2"]) == ["scan", "learner", "learner", "learner"]


def test_a_reference_of_another_definition_is_refused(two_tasks, capsys, tmp_path):
    _, suite, _ = two_tasks
    copy = tmp_path / "two.toml"
    copy.write_text(suite.read_text().replace("steps = 6", "steps = 7"))
    shutil.copy(reference_path(suite), reference_path(copy))
    message = _refused(capsys, "--suite", str(copy), "--out", str(tmp_path / "out"))
    assert "task c2: expected thermal's results on the task as the suite defines it" in message


def _script():
    spec = importlib.util.spec_from_file_location("leaderboard_script", BENCHMARKS_DIR / "leaderboard.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
