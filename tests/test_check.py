"""Damaged results directories: ``morphbench check`` finds each kind of damage (tests/fuzz_results.py DAMAGES), the
report skips damaged jobs or refuses a damaged directory in one line, and ``check --repair`` followed by the same
bench gives the tables of the undamaged directory again."""

from __future__ import annotations

import json
import math
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import fuzz_results
import fuzzing
from fuzz_results import DAMAGES, Inline
from morphbench.bench import load_suite, run_suite
from morphbench.bench.store import DAMAGED, JOB_SCHEMAS, TABLES, Store, check_plan
from morphbench.experiment.records import STEP_COLUMNS, UNIT_COLUMNS
from morphbench.render.writers import H264Writer

from conftest import BENCHMARKS_DIR, run_cli


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    """fuzz_results.SUITE run with its report: (suite file, results directory, its consolidated tables)."""
    out = tmp_path_factory.mktemp("finished") / "R"
    suite = fuzz_results.build(out)
    return suite, out, Store(out).consolidate(write=False)


def listing(root: Path) -> dict[str, tuple[int, int]]:
    """Every path under ``root`` with its size and modification time: what a refused command must leave alone."""
    return {str(p.relative_to(root)): (p.lstat().st_size, p.lstat().st_mtime_ns) for p in root.rglob("*")}


def comparable(tables: dict[str, pd.DataFrame]) -> dict[str, pd.DataFrame]:
    return {name: tables[name].drop(columns=["wall_time_s"]) if "wall_time_s" in tables[name] else tables[name]
            for name in TABLES}


def assert_same_tables(a: dict[str, pd.DataFrame], b: dict[str, pd.DataFrame]) -> None:
    a, b = comparable(a), comparable(b)
    for name in TABLES:
        pd.testing.assert_frame_equal(a[name], b[name], check_exact=True, obj=name)


def one_line(err: str) -> str:
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


@pytest.mark.parametrize("kind", DAMAGES, ids=lambda kind: kind.name)
def test_each_kind_of_damage_is_found_reported_and_repaired(kind, finished, tmp_path, capsys):
    suite, source, expected = finished
    root = tmp_path / "R"
    shutil.copytree(source, root)
    plan = json.loads((root / "plan.json").read_text())
    path, _ = kind.damage(root)
    relative = str(path.relative_to(root))

    code, out, err = run_cli(capsys, "check", str(root))
    if not kind.check:
        assert code == 0 and "no damage" in out, out + err
        return
    assert code == 1 and err == "", out + err
    assert any(relative in line for line in out.splitlines()[:-1]), out

    if kind.report == "compare":  # the damaged directory compared: refused, nothing written into the one reported
        target = tmp_path / "T"
        shutil.copytree(source, target)
        before = listing(target)
        code, out, err = run_cli(capsys, "report", str(target), "--compare", str(root), str(source), "--no-videos")
        assert code == 2 and str(root) in one_line(err) and path.name in err, err
        assert listing(target) == before
    elif kind.report == "refuse":
        before = listing(tmp_path)
        code, out, err = run_cli(capsys, "report", str(root), "--no-videos")
        line = one_line(err)
        assert code == 2 and line.startswith("morphbench: error: ") and path.name in line, err
        assert listing(tmp_path) == before  # nothing written, inside the directory or out of it
    else:
        code, out, err = run_cli(capsys, "report", str(root), "--no-videos")
        assert code == 0, err
        jobs = pd.read_parquet(root / "jobs.parquet")
        if kind.report.startswith("skip"):
            job_ids = ([run["id"] for run in plan["runs"]] if kind.report == "skip-all" else
                       [plan["runs"][-1]["id"]] if kind.report == "skip-last" else [Path(relative).parts[1]])
            assert "damaged jobs left out of the tables and the report" in one_line(err)
            report = (root / "report.md").read_text()
            for job_id in job_ids:
                assert jobs.set_index("job_id").status[job_id] == DAMAGED
                # a run's rows the new tables leave out are written back into its directory: named there
                wheres = (relative, f"runs/{job_id}/{relative}")
                assert any(f"{job_id} | {where}: expected " in report for where in wheres)
            if kind.report != "skip-all" and (relative.startswith("runs/") or kind.report == "skip-last"):
                runs = pd.read_parquet(root / "runs.parquet").set_index("run_id")  # never counted as finished
                metrics = pd.read_parquet(root / "metrics.parquet").set_index("condition_id")
                row = metrics.loc[runs.condition_id[job_ids[0]]]
                assert (runs.status[job_ids[0]], row.runs - row.failed - row.missing) == (DAMAGED, 1)
            for name in ("steps", "units"):  # their rows are left out of the tables
                assert not pd.read_parquet(root / f"{name}.parquet").run_id.isin(job_ids).any()
        else:  # a consolidated table: rebuilt from the jobs
            assert err == "" and (jobs.status == "done").all()
            assert_same_tables(Store(root).consolidate(write=False), expected)
            kind.damage(root)  # again, for the repair

    code, out, _ = run_cli(capsys, "check", str(root), "--repair")
    assert code == 1 and "moved " in out
    aside = "/".join(Path(relative).parts[:2]) if kind.where.startswith("<") else relative  # a job: its directory
    if kind.report == "skip-last":  # the report wrote the run's rows back into its directory: the run goes aside
        aside = f"runs/{plan['runs'][-1]['id']}"
    kept = [aside] if kind.report != "skip-all" or any((root / "damaged").glob(f"*/{aside}")) else \
        [f"runs/{run['id']}" for run in plan["runs"]]  # a table the runs' rows went back from: the runs
    assert all(len(list((root / "damaged").glob(f"*/{path}"))) == 1 for path in kept)  # kept, not deleted
    plan_moved = kind.where == "plan.json"
    outcome = run_suite(load_suite(suite), root, Inline(), resume=plan_moved, progress=False)
    assert_same_tables(outcome.tables, expected)
    code, out, _ = run_cli(capsys, "check", str(root))
    assert code == 0, out


def test_retry_failed_runs_a_job_with_a_damaged_result_again_and_keeps_the_damaged_one(finished, tmp_path, capsys):
    suite, source, expected = finished
    root = tmp_path / "R"
    shutil.copytree(source, root)
    job = sorted((root / "runs").iterdir())[0]
    (job / "result.json").write_text("[]")
    code, _, err = run_cli(capsys, "bench", str(suite), "--out", str(root), "--no-report", "--quiet")
    assert code == 0 and "1 damaged jobs left out" in one_line(err)  # skipped, not run over
    assert pd.read_parquet(root / "runs.parquet").status.eq(DAMAGED).sum() == 1
    outcome = run_suite(load_suite(suite), root, Inline(), retry_failed=True, progress=False)
    assert outcome.done == 1
    assert_same_tables(outcome.tables, expected)
    kept = list((root / "damaged").glob(f"*/runs/{job.name}/result.json"))
    assert len(kept) == 1 and kept[0].read_text() == "[]"


def test_a_clean_directory_is_clean_and_other_directories_are_not_results(finished, tmp_path, capsys):
    _, source, _ = finished
    code, out, err = run_cli(capsys, "check", str(source))
    assert (code, err) == (0, "") and "no damage" in out
    (tmp_path / "empty").mkdir()
    (tmp_path / "file").write_text("x")
    for target in (tmp_path / "empty", tmp_path / "file", tmp_path / "absent"):
        code, _, err = run_cli(capsys, "check", str(target))
        assert code == 2 and one_line(err).startswith("morphbench: error: ") and str(target) in err


def test_without_a_usable_plan_the_job_directories_are_still_checked(finished, tmp_path, capsys):
    _, source, _ = finished
    root = tmp_path / "R"
    shutil.copytree(source, root)
    (root / "plan.json").write_text("{")
    run = sorted((root / "runs").iterdir())[1]
    (run / "units.parquet").write_bytes(b"")
    code, out, _ = run_cli(capsys, "check", str(root))
    assert code == 1
    assert out.splitlines()[0].startswith("plan.json: (syntax): expected the JSON plan")
    assert f"run {run.name}: runs/{run.name}/units.parquet: expected a Parquet file" in out
    (root / "plan.json").unlink()
    code, out, err = run_cli(capsys, "check", str(root), "--repair")
    assert (code, err) == (1, "") and out.startswith("plan.json: expected the plan 'morphbench bench' writes, got none")
    assert f"moved runs/{run.name} to damaged/" in out and out.rstrip().endswith(f"--out {root} --resume")


@pytest.mark.parametrize("suite", sorted(BENCHMARKS_DIR.glob("*.toml")), ids=lambda path: path.name)
def test_the_plans_of_the_shipped_suites_pass_the_checks(suite):
    check_plan(json.loads(json.dumps(load_suite(suite).plan())), str(suite))


def test_the_schemas_cover_the_records_columns():
    assert tuple(JOB_SCHEMAS["steps"]) == STEP_COLUMNS
    assert tuple(JOB_SCHEMAS["units"]) == UNIT_COLUMNS


def test_a_plan_naming_an_experiment_by_a_path_writes_nothing_outside(finished, tmp_path, capsys):
    """The report of a plan whose experiment is '../../evil' would have drawn figures/../../evil-ubar.png."""
    _, source, _ = finished
    root = tmp_path / "a" / "b" / "R"
    shutil.copytree(source, root)
    plan = json.loads((root / "plan.json").read_text())
    plan["experiments"][0]["name"] = "../../evil"
    (root / "plan.json").write_text(json.dumps(plan))
    code, _, err = run_cli(capsys, "report", str(root), "--no-videos")
    assert code == 2 and "experiments[0].name: expected a name" in err and "'../../evil'" in err
    assert not list(tmp_path.rglob("*evil*"))


def test_generated_cases_keep_the_promise():
    """A few of the robustness benchmark's cases: refused cleanly, accepted, or (check) damage found."""
    for case in fuzz_results.random_cases(6, seed=1):
        with tempfile.TemporaryDirectory() as directory:
            outcome = fuzzing.run_case(case, Path(directory) / "case", timeout_s=60)
        assert fuzz_results.verdict(outcome) in ("accepted", "refused"), (case.short(), outcome.verdict, outcome.err)


def edit_summary(root: Path, run_id: str, edit) -> Path:
    path = root / "runs" / run_id / "result.json"
    result = json.loads(path.read_text())
    edit(result["summary"])
    path.write_text(json.dumps(result))  # NaN as JSON's NaN, as json.dumps writes a summary
    return path


@pytest.mark.parametrize("edit, expected", [
    (lambda s: s.update(final_ubar=math.nan), "expected summary.final_ubar a finite number, got nan"),
    (lambda s: s.update(final_ubar_true=None), "expected summary.final_ubar_true a finite number, got None"),
    (lambda s: s.update(colour="red"), "expected summary keys among a run's (config, seed, "),
    (lambda s: s.pop("config"), "expected summary.config, an object (every run's summary has it), got none"),
    (lambda s: s.update(centralized="no"), "expected summary.centralized a boolean or null, got 'no'"),
], ids=["final NaN", "final null", "unknown key", "no config", "centralized text"])
def test_a_summary_out_of_its_schema_is_damage(edit, expected, finished, tmp_path, capsys):
    """A done run's summary (store.SUMMARY_SCHEMA), once the tables were rebuilt from it: the job itself is damaged,
    not only a stale runs table."""
    suite, source, _ = finished
    root = tmp_path / "R"
    shutil.copytree(source, root)
    run_id = json.loads((root / "plan.json").read_text())["runs"][0]["id"]
    path = edit_summary(root, run_id, edit)
    code, out, err = run_cli(capsys, "check", str(root))
    assert code == 1 and err == "", out + err
    assert out.splitlines()[0].startswith(f"run {run_id}: {path.relative_to(root)}: {expected}"), out
    code, _, err = run_cli(capsys, "report", str(root), "--no-videos")
    assert code == 0 and "1 damaged jobs left out" in one_line(err)
    assert pd.read_parquet(root / "runs.parquet").set_index("run_id").status[run_id] == DAMAGED


def test_the_nan_final_values_of_a_run_without_learning_steps_are_no_damage(tmp_path, capsys):
    """final Ubar averages the learning steps: a run of none has NaN, as its records write it."""
    suite = tmp_path / "zero.toml"
    suite.write_text(fuzz_results.SUITE.replace("steps = 3", "steps = 0"))
    root = tmp_path / "R"
    run_suite(load_suite(suite), root, Inline(), progress=False)
    summaries = [json.loads(path.read_text())["summary"] for path in (root / "runs").glob("*/result.json")]
    assert summaries and all(math.isnan(s["final_ubar"]) and s["steps"] == 0 for s in summaries)
    code, out, _ = run_cli(capsys, "check", str(root))
    assert code == 0 and "no damage" in out, out


def with_rows_of(root: Path, run_ids: list[str]) -> pd.DataFrame:
    """Append to the consolidated steps and units tables a copy of the first run's rows under each of ``run_ids``;
    the units table as it was before."""
    before = {}
    for name in ("steps", "units"):
        table = pd.read_parquet(root / f"{name}.parquet")
        first = table[table.run_id == table.run_id.iloc[0]]
        before[name] = table
        pd.concat([table, *(first.assign(run_id=run_id) for run_id in run_ids)]).to_parquet(
            root / f"{name}.parquet", index=False)
    return before["units"]


def test_rows_of_runs_neither_the_plan_nor_runs_has_are_found_and_set_aside(finished, tmp_path, capsys):
    """Rows that no consolidation keeps (it writes a run's rows back only into its directory): check names them,
    --repair and the report move them aside rather than drop them, and a run id that is a path writes nowhere."""
    suite, source, expected = finished
    root = tmp_path / "a" / "R"
    shutil.copytree(source, root)
    strangers = ["ffffffffffff", "../../evil"]
    units = with_rows_of(root, strangers)
    code, out, _ = run_cli(capsys, "check", str(root))
    assert code == 1
    for run_id, shown in zip(strangers, ["ffffffffffff", "'../../evil'"]):
        for name in ("steps", "units"):
            assert f"run {shown}: {name}.parquet: expected the rows of the plan's runs" in out, out

    report = tmp_path / "b" / "R"  # the report sets them aside, as its consolidation does an unreadable table
    shutil.copytree(root, report)
    code, _, err = run_cli(capsys, "report", str(report), "--no-videos")
    assert code == 0 and err == ""
    aside = pd.read_parquet(next((report / "damaged").glob("*/units.parquet")))
    first = (units.run_id == units.run_id[0]).sum()
    assert sorted(aside.run_id.unique()) == sorted(strangers) and len(aside) == 2 * first
    assert_same_tables(Store(report).consolidate(write=False), expected)

    code, out, _ = run_cli(capsys, "check", str(root), "--repair")
    assert code == 1 and "moved the rows of runs the plan does not list in units.parquet to damaged/" in out
    assert "to run the moved jobs again" not in out  # no job went
    pd.testing.assert_frame_equal(pd.read_parquet(root / "units.parquet"), units)
    assert_same_tables(Store(root).consolidate(write=False), expected)
    for name in ("steps", "units"):
        aside = pd.read_parquet(next((root / "damaged").glob(f"*/{name}.parquet")))
        assert sorted(aside.run_id.unique()) == sorted(strangers)
    code, out, _ = run_cli(capsys, "check", str(root))
    assert code == 0, out
    assert not list(tmp_path.rglob("*evil*"))


def write_video(path: Path) -> Path:
    """A few frames of H.264, as a report's video is written."""
    path.parent.mkdir(exist_ok=True)
    writer = H264Writer(path, (16, 16), 10, path, "test")
    for _ in range(5):
        writer.write(np.zeros((16, 16, 3), "uint8"))
    writer.close()
    return path


def test_a_cached_video_that_does_not_decode_is_damage_and_goes_aside(finished, tmp_path, capsys):
    _, source, _ = finished
    root = tmp_path / "R"
    shutil.copytree(source, root)
    video = write_video(root / "videos" / "pair.mp4")
    code, out, _ = run_cli(capsys, "check", str(root))
    assert code == 0, out
    for damage in (b"not a video\n", video.read_bytes()[:len(video.read_bytes()) // 2]):
        video.write_bytes(damage)
        code, out, _ = run_cli(capsys, "check", str(root))
        assert code == 1 and out.startswith("videos/pair.mp4: expected a video PyAV decodes ("), out
    code, out, _ = run_cli(capsys, "check", str(root), "--repair")
    assert code == 1 and "moved videos/pair.mp4 to damaged/" in out
    assert "removed" not in out and (root / "runs.parquet").is_file()  # a video makes no table stale
    assert [p.read_bytes() for p in (root / "damaged").glob("*/videos/pair.mp4")] == [damage]
    code, out, _ = run_cli(capsys, "check", str(root))
    assert code == 0, out


def test_every_summary_the_records_write_keeps_the_schema_check_holds_it_to():
    """store.SUMMARY_SCHEMA is the twin of records.summary: every key a run writes, with a cut (its pieces' final
    values), events and a centralized learner among them, passes the check (a key added to one and not the other
    would call every new run damaged)."""
    from morphbench.bench.store import SUMMARY_SCHEMA, _check_summary
    from morphbench.experiment import RunConfig, parse_events, run
    from morphbench.shapes import load_shape

    from conftest import SHAPES_DIR

    shape = load_shape(SHAPES_DIR / "chain-3.toml")
    cut = RunConfig(shape=shape, steps=3, events=parse_events([{"step": 2, "kind": "cut", "link": 2}], "t", 3, 3))
    keys = set()
    for config in (cut, RunConfig(shape=shape, steps=2, learner="cmaes")):
        summary = json.loads(json.dumps(run(config).summary(), default=str))  # as result.json stores it
        _check_summary(summary, Path("result.json"))
        keys |= set(summary)
    assert {"final_ubar_by_piece", "events", "centralized"} <= keys <= set(SUMMARY_SCHEMA)
