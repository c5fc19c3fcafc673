"""Benchmark suites: expansion and validation, executors that agree, resume, failures, metrics, report and CLI.

The suites here are tiny (chain-2, a few learning steps, a scan of a few one-cycle points): they test the plumbing.
The metrics are checked on synthetic curves whose answers are known exactly.
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from morphbench.bench.runner import batched
from morphbench.bench import DaskExecutor, LocalExecutor, add_bench_commands, build_report, load_suite, run_suite
from morphbench.bench import jobs as bench_jobs
from morphbench.bench.store import Store
from morphbench.bench.metrics import condition_metrics, curves, fit_exponential, recovery_steps, steps_to_reach
from morphbench.errors import ConfigError

from conftest import BENCHMARKS_DIR as BENCHMARKS, SHAPES_DIR as SHAPES, TINY, write_suite

TABLES = ("runs", "steps", "units", "scans", "jobs")
N_TINY_RUNS = 8
N_TINY_JOBS = 9  # 8 runs and one scan part


def comparable(tables: dict[str, pd.DataFrame]) -> dict[str, pd.DataFrame]:
    """The tables without wall times, the one thing that changes from one execution to the next."""
    return {name: tables[name].drop(columns=["wall_time_s"], errors="ignore") for name in TABLES}


def assert_same_tables(a: dict[str, pd.DataFrame], b: dict[str, pd.DataFrame]) -> None:
    a, b = comparable(a), comparable(b)
    for name in TABLES:
        pd.testing.assert_frame_equal(a[name], b[name], check_exact=True, obj=name)


# --- executors agree ---------------------------------------------------------------------------------------------


def test_straight_run_records_every_job(reference):
    _, out, outcome = reference
    assert (outcome.total, outcome.done, outcome.failed, outcome.skipped) == (N_TINY_JOBS, N_TINY_JOBS, 0, 0)
    runs, steps, scans = outcome.tables["runs"], outcome.tables["steps"], outcome.tables["scans"]
    assert len(runs) == N_TINY_RUNS and runs.run_id.is_unique and (runs.status == "done").all()
    assert len(steps) == N_TINY_RUNS * 5 and not steps.duplicated(["run_id", "step"]).any()
    assert set(steps.columns) >= {"run_id", "condition_id", "shape", "n_units", "learner", "step_size", "temperature",
                                  "noise", "steps", "seed", "step", "ubar", "ubar_true", "acceptance"}
    assert runs.groupby("condition_id").seed.apply(sorted).tolist() == [[0, 1]] * 4
    assert len(scans) == 4 and list(scans.dphi_2) == [0.0, 0.25, 0.5, 0.75]
    # noise is measurement noise only: measured and true Ubar agree without it and differ with it
    noiseless, noisy = steps[steps.noise == 0], steps[steps.noise == 0.5]
    assert np.array_equal(noiseless.ubar, noiseless.ubar_true)
    assert not np.allclose(noisy.ubar, noisy.ubar_true)
    # what the store holds on disk is what run_suite returned
    on_disk = {name: pd.read_parquet(out / f"{name}.parquet") for name in TABLES}
    assert_same_tables(on_disk, outcome.tables)
    assert len(list((out / "runs").iterdir())) == N_TINY_RUNS
    # each row once: a consolidated run's directory keeps its result.json, its rows are in steps and units.parquet
    assert {path.name for path in (out / "runs").rglob("*") if path.is_file()} == {"result.json"}


def test_an_old_directory_with_two_copies_is_read_as_it_is_and_consolidating_removes_the_copies(reference, tmp_path):
    """A directory of an older morphbench (each run's tables in its directory and in the consolidated tables), or
    one whose bench was killed between writing the new tables and removing the runs' copies."""
    _, source, outcome = reference
    out = tmp_path / "old"
    shutil.copytree(source, out)
    store = Store(out)
    for run_id in outcome.tables["runs"].run_id:
        store.restore(run_id)
    assert len(list((out / "runs").glob("*/units.parquet"))) == N_TINY_RUNS
    assert_same_tables(Store(out).consolidate(write=False), outcome.tables)
    assert_same_tables(Store(out).consolidate(), outcome.tables)
    assert not list((out / "runs").glob("*/*.parquet"))
    assert_same_tables({name: pd.read_parquet(out / f"{name}.parquet") for name in TABLES}, outcome.tables)


def test_one_worker_and_a_dask_cluster_give_the_same_tables(reference, tmp_path):
    suite_path, _, outcome = reference
    one = run_suite(load_suite(suite_path), tmp_path / "one", LocalExecutor(1), progress=False)
    assert_same_tables(one.tables, outcome.tables)
    # seeds run together (the default) or each alone: the same tables
    alone = run_suite(load_suite(suite_path), tmp_path / "alone", LocalExecutor(1), progress=False, batch_seeds=1)
    assert_same_tables(alone.tables, outcome.tables)
    assert {job.kind for job in batched(load_suite(suite_path).jobs())} == {"batch", "scan"}
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError:
        pytest.skip("dask.distributed is not installed (pip install 'morphbench[dask]')")
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        dask = run_suite(load_suite(suite_path), tmp_path / "dask", DaskExecutor(client), progress=False)
        # and through the command line, by the scheduler's address
        address = cluster.scheduler_address
        assert cli("bench", str(suite_path), "--out", str(tmp_path / "cli"), "--scheduler", address, "--quiet",
                   "--no-report") == 0
    assert dask.done == N_TINY_JOBS
    assert_same_tables(dask.tables, outcome.tables)
    assert_same_tables({name: pd.read_parquet(tmp_path / "cli" / f"{name}.parquet") for name in TABLES},
                       outcome.tables)


def test_building_a_report_imports_no_simulator(reference, tmp_path):
    _, out, _ = reference
    shutil.copytree(out, tmp_path / "results")
    code = ("import sys, morphbench.bench.report as r; r.build_report(sys.argv[1]); "
            "assert 'pybullet' not in sys.modules, 'pybullet imported'")
    subprocess.run([sys.executable, "-c", code, str(tmp_path / "results")], check=True, timeout=300)
    assert (tmp_path / "results" / "report.md").is_file()


# --- resume ------------------------------------------------------------------------------------------------------


class Killed(Exception):
    pass


def test_a_suite_killed_midway_and_resumed_equals_one_run_straight_through(reference, tmp_path):
    suite_path, _, outcome = reference
    out = tmp_path / "resumed"
    saved = []

    def kill_after_three(job, result):
        saved.append(job.id)
        if len(saved) == 3:
            raise Killed

    with pytest.raises(Killed):
        run_suite(load_suite(suite_path), out, LocalExecutor(2), progress=False, on_result=kill_after_three)
    finished = [p for sub in ("runs", "scans") if (out / sub).is_dir() for p in (out / sub).iterdir()]
    assert sorted(p.name for p in finished) == sorted(saved)
    # what a kill during a write leaves behind: a half-written job directory and a temporary file
    (out / "runs" / f".tmp-{saved[0]}-99999").mkdir()
    (out / "runs" / f".tmp-{saved[0]}-99999" / "steps.parquet").write_bytes(b"half")
    (out / ".runs.parquet.tmp-99999").write_bytes(b"half")

    resumed = run_suite(load_suite(suite_path), out, LocalExecutor(2), progress=False)
    assert (resumed.skipped, resumed.done, resumed.failed) == (3, N_TINY_JOBS - 3, 0)
    assert_same_tables(resumed.tables, outcome.tables)
    assert sorted(p.name for p in (out / "runs").iterdir()) == sorted(outcome.tables["runs"].run_id)
    assert not list(out.glob(".*tmp*"))
    again = run_suite(load_suite(suite_path), out, LocalExecutor(2), progress=False)
    assert (again.skipped, again.done) == (N_TINY_JOBS, 0)
    assert_same_tables(again.tables, outcome.tables)


def test_a_directory_of_another_suite_is_refused_unless_resume(reference, tmp_path):
    suite_path, out, _ = reference
    grown = write_suite(tmp_path, TINY.replace("seeds = 2", "seeds = 3"), "tiny.toml")
    with pytest.raises(ConfigError, match="--out.*earlier version of this suite.*--resume"):
        run_suite(load_suite(grown), out, LocalExecutor(1), progress=False)
    copy = tmp_path / "copy"
    shutil.copytree(out, copy)
    outcome = run_suite(load_suite(grown), copy, LocalExecutor(2), progress=False, resume=True)
    assert (outcome.skipped, outcome.done) == (N_TINY_JOBS, 4)  # only the new seed's runs
    assert sorted(outcome.tables["runs"].seed.unique()) == [0, 1, 2]


def test_a_consolidated_run_replays_from_its_result_and_its_rows(reference):
    from morphbench.render.replay import load_run

    _, out, outcome = reference
    run_id = outcome.tables["runs"].run_id.iloc[0]
    with Store(out).replayable(run_id) as directory:
        config, steps = load_run(directory)
    expected = outcome.tables["steps"].query("run_id == @run_id")[steps.columns].reset_index(drop=True)
    pd.testing.assert_frame_equal(steps, expected, check_exact=True)
    assert config.seed == outcome.tables["runs"].seed.iloc[0] and not directory.exists()  # the temporary one: gone


def test_morphbench_render_replays_a_consolidated_run_of_a_suite(reference, tmp_path, capsys):
    from conftest import run_cli

    _, out, outcome = reference
    run_id = outcome.tables["runs"].run_id.iloc[0]
    assert not (out / "runs" / run_id / "steps.parquet").exists()  # its rows are in the consolidated tables only
    code, _, err = run_cli(capsys, "render", str(out / "runs" / run_id), "--out", str(tmp_path / "v.gif"), "--quiet",
                           "--video-width", "32", "--video-height", "32", "--video-fps", "2")
    assert code == 0, err
    assert (tmp_path / "v.gif").stat().st_size > 0


def test_resuming_a_smaller_suite_keeps_the_rows_of_the_runs_it_leaves_out(reference, tmp_path):
    suite_path, out, outcome = reference
    copy = tmp_path / "copy"
    shutil.copytree(out, copy)
    fewer = write_suite(tmp_path, TINY.replace("seeds = 2", "seeds = 1"), "tiny.toml")
    small = run_suite(load_suite(fewer), copy, LocalExecutor(1), progress=False, resume=True)
    left_out = set(outcome.tables["runs"].run_id) - set(small.tables["runs"].run_id)
    assert small.done == 0 and len(left_out) == N_TINY_RUNS // 2
    assert not pd.read_parquet(copy / "units.parquet").run_id.isin(left_out).any()  # their rows: in their directories
    assert {path.parent.name for path in (copy / "runs").glob("*/units.parquet")} == left_out
    again = run_suite(load_suite(suite_path), copy, LocalExecutor(1), progress=False, resume=True)
    assert (again.done, again.skipped) == (0, N_TINY_JOBS)
    assert_same_tables(again.tables, outcome.tables)
    assert not list((copy / "runs").glob("*/*.parquet"))


# --- failures ----------------------------------------------------------------------------------------------------

EXPLODING = '''
class Exploding:
    """Measures twice, then raises in its third update."""

    def __init__(self, params, rng):
        self.rng, self.phase, self.calls = rng, float(rng.uniform()), 0

    def propose(self):
        return (self.phase + 0.05) % 1.0

    def update(self, velocity):
        self.calls += 1
        if self.calls == 3:
            raise RuntimeError("exploding learner: boom")
        return False
'''


def test_a_failing_run_is_recorded_and_the_others_go_on(tmp_path, monkeypatch):
    plugins = tmp_path / "plugins"
    plugins.mkdir()
    (plugins / "bench_test_exploding.py").write_text(EXPLODING)
    monkeypatch.syspath_prepend(str(plugins))  # for the suite's check in this process
    monkeypatch.setenv("PYTHONPATH", str(plugins))  # for the worker processes
    suite = write_suite(tmp_path, f"""
        [[experiment]]
        name = "mixed"
        shapes = ["{SHAPES / 'chain-2.toml'}"]
        learners = ["thermal", "bench_test_exploding:Exploding"]
        seeds = 2
        steps = 4
    """)
    outcome = run_suite(load_suite(suite), tmp_path / "out", LocalExecutor(2), progress=False)
    runs = outcome.tables["runs"]
    assert (outcome.done, outcome.failed) == (2, 2)
    failed = runs[runs.learner.str.contains("Exploding")]
    assert (failed.status == "failed").all()
    assert failed.error.str.contains("RuntimeError: exploding learner: boom").all()
    assert (runs[runs.learner == "thermal"].status == "done").all()
    assert set(outcome.tables["steps"].learner) == {"thermal"}
    result = json.loads((tmp_path / "out" / "runs" / failed.run_id.iloc[0] / "result.json").read_text())
    assert "Traceback" in result["traceback"] and result["status"] == "failed"
    report = build_report(tmp_path / "out").read_text()
    assert "## Failed jobs" in report and "exploding learner: boom" in report
    # a failed run is finished: it is not run again unless asked
    again = run_suite(load_suite(suite), tmp_path / "out", LocalExecutor(1), progress=False)
    assert (again.skipped, again.done, again.failed) == (4, 0, 0)
    retried = run_suite(load_suite(suite), tmp_path / "out", LocalExecutor(1), progress=False, retry_failed=True)
    assert (retried.skipped, retried.failed) == (2, 2)


def test_a_run_with_non_finite_ubar_fails_with_the_step(monkeypatch):
    class Records:
        def steps(self):
            return pd.DataFrame({"step": [0, 1, 2], "ubar": [0.1, np.nan, 0.3], "ubar_true": [0.1, 0.2, 0.3]})

    monkeypatch.setattr(bench_jobs, "run", lambda config: Records())
    suite = load_suite(BENCHMARKS / "smoke.toml")
    result = bench_jobs.execute(suite.jobs()[0])
    assert result["status"] == "failed" and result["error"] == "non-finite Ubar at learning step 1"


# --- suite files -------------------------------------------------------------------------------------------------


def test_a_condition_is_batched_in_pieces_that_keep_the_workers_busy(tmp_path):
    suite = load_suite(write_suite(tmp_path, f"""
        name = "many"
        [defaults]
        steps = 5
        seeds = 16
        [[experiment]]
        name = "a"
        shape = "{SHAPES / 'chain-3.toml'}"
    """))
    jobs, total = suite.jobs(), sum(job.cost for job in suite.jobs())

    def seeds(size=112, budget=math.inf):
        return [len(job.payload) if job.kind == "batch" else 1 for job in batched(jobs, size, budget)]

    assert seeds() == [16]  # one condition's seeds together
    assert seeds(budget=total / 8) == [2] * 8  # 4 jobs for each of 2 workers
    assert seeds(size=5, budget=total / 2) == [5, 5, 5, 1]
    assert [job.kind for job in batched(jobs, budget=0.0)] == ["run"] * 16  # at least one seed: each alone


def test_suite_expansion_ids_are_stable_and_shared_runs_run_once(tmp_path):
    text = f"""
        name = "ids"
        [defaults]
        steps = 5
        seeds = [3, 4]
        [[experiment]]
        name = "a"
        shapes = ["{SHAPES / 'chain-2.toml'}", "{SHAPES / 'chain-3.toml'}"]
        learners = ["thermal", "flaky"]
        [experiment.learner_params]
        step_size = [0.1, 0.025]
        [[experiment]]
        name = "b"
        shapes = ["{SHAPES / 'chain-2.toml'}"]
        [experiment.learner_params]
        step_size = 0.1
    """
    suite = load_suite(write_suite(tmp_path, text))
    a, b = suite.experiments
    assert len(a.run_ids) == 2 * 2 * 2 * 2 and len(a.condition_ids) == 8
    assert set(a.varying) == {"shape", "shape_id", "n_units", "learner", "step_size"}
    assert len(b.run_ids) == 2 and set(b.run_ids) <= set(a.run_ids)  # b's runs are a's: run once
    assert len(suite.runs) == 16 and [r.seed for r in suite.runs.values()][:2] == [3, 4]
    # the same runs from a suite elsewhere, naming copies of the shape files by a relative path, have the same ids
    (tmp_path / "shapes").mkdir()
    for name in ("chain-2.toml", "chain-3.toml"):
        (tmp_path / "shapes" / name).write_bytes((SHAPES / name).read_bytes())
    elsewhere = tmp_path / "deeper" / "still"
    elsewhere.mkdir(parents=True)
    moved = load_suite(write_suite(elsewhere, text.replace(str(SHAPES), "../../shapes")))
    assert list(moved.runs) == list(suite.runs)


def test_suites_use_the_ideal_sensor_unless_told_and_put_noise_in_the_run_config(tmp_path):
    suite = load_suite(write_suite(tmp_path, f"""
        [[experiment]]
        name = "ideal"
        shapes = ["{SHAPES / 'chain-2.toml'}"]
        noise = [0.0, 0.25]
        [[experiment]]
        name = "optical"
        shapes = ["{SHAPES / 'chain-2.toml'}"]
        [experiment.sensor]
        kind = "optical"
        [experiment.sensor.optical]
        frame_rate = 20.0
    """))
    ideal, optical = ([suite.runs[i] for i in e.run_ids] for e in suite.experiments)
    assert [r.config.sensor.kind for r in ideal] == ["ideal", "ideal"]
    assert [r.condition["noise"] for r in ideal] == [0.0, 0.25]
    assert [r.config.environment.noise for r in ideal] == [0.0, 0.25]
    assert optical[0].config.sensor.kind == "optical" and optical[0].config.sensor.optical.frame_rate == 20.0
    assert optical[0].condition["sensor_optical_frame_rate"] == 20.0
    assert "sensor_optical_frame_rate" not in ideal[0].condition


def test_environments_are_an_axis_and_events_apply_to_every_run_of_an_experiment(tmp_path):
    text = f"""
        [[experiment]]
        name = "world"
        shapes = ["{SHAPES / 'chain-2.toml'}", "{SHAPES / 'chain-3.toml'}"]
        noise = [0.0, 0.5]
        seeds = 2
        steps = 6
        environments = [{{}}, {{friction_field = {{amplitude = 0.3}}}}, {{name = "slippery", friction_scale = 0.5}}]
        [[experiment.events]]
        step = 4
        kind = "noise"
        sigma = 1.0
        [[experiment.events]]
        step = 2
        kind = "damage"
        unit = 2
        mode = "stuck"
        [[experiment]]
        name = "own-noise"
        shapes = ["{SHAPES / 'chain-2.toml'}"]
        steps = 6
        [[experiment.environments]]
        name = "quiet"
        [[experiment.environments]]
        name = "noisy"
        noise = 0.7
        vibration = 0.8
    """
    suite = load_suite(write_suite(tmp_path, text))
    world, own = suite.experiments
    assert len(world.run_ids) == 2 * 3 * 2 * 2 and len(world.condition_ids) == 12
    assert set(world.varying) == {"shape", "shape_id", "n_units", "noise", "environment", "environment_id"}
    runs = [suite.runs[i] for i in world.run_ids]
    assert [r.condition["environment"] for r in runs[:12:2]] == ["default", "default", "friction_field.amplitude=0.3",
                                                                 "friction_field.amplitude=0.3", "slippery", "slippery"]
    assert {r.condition["events"] for r in runs} == {"step 2 damage unit=2 mode=stuck; step 4 noise sigma=1.0"}
    field, slippery = runs[4].config.environment, runs[8].config.environment
    assert field.friction_field.amplitude == 0.3 and field.friction_scale == 1.0 and field.noise == 0.0
    assert slippery.friction_scale == 0.5 and runs[10].config.environment.noise == 0.5
    assert [(e.step, e.kind) for e in runs[0].config.events] == [(2, "damage"), (4, "noise")]
    # the environment's noise is the run's noise, and the condition's noise column
    quiet, noisy = (suite.runs[i] for i in own.run_ids)
    assert (quiet.condition["noise"], noisy.condition["noise"]) == (0.0, 0.7)
    assert noisy.config.environment.noise == 0.7 and noisy.config.environment.vibration == 0.8
    # run ids change with the environment and with the events; without either they are the suite's usual ones
    plain = load_suite(write_suite(tmp_path, text.split("[[experiment.events]]")[0], "plain.toml"))  # no events
    plain_ids = set(plain.runs)
    assert len(plain_ids) == 24 and len({r.condition_id for r in plain.runs.values()}) == 12
    assert not plain_ids & set(world.run_ids)
    usual = load_suite(write_suite(tmp_path, text.split("environments")[0], "usual.toml"))
    assert set(usual.experiments[0].run_ids) < plain_ids  # the default environment, no events: the same runs


EVENTS = """
    [[experiment.events]]
    step = 3
    kind = "damage"
    unit = 1
    mode = "stuck"
"""


def test_a_suite_in_the_old_keys_and_in_run_configuration_keys_gives_the_same_runs(tmp_path):
    chain2, chain3 = SHAPES / "chain-2.toml", SHAPES / "chain-3.toml"
    old = f"""
        [defaults]
        steps = 6
        seeds = [2, 5]
        physics = ["default", "quasistatic"]
        [[experiment]]
        name = "a"
        shapes = ["{chain2}", "{chain3}"]
        learners = ["thermal", "random"]
        noise = [0.0, 0.3]
        environments = [{{}}, {{friction_scale = 1.5}}, {{name = "field", friction_field = {{amplitude = 0.2}}}}]
        [experiment.learner_params]
        step_size = [0.1, 0.05]
        temperature = 0.25
        [experiment.sensor]
        sample_period = [0.125, 0.25]
        {EVENTS}
        [[experiment]]
        name = "b"
        shapes = "{chain2}"
        seeds = 3
        steps = [4, 6]
        physics = "fast"
        [[experiment.environments]]
        noise = 0.7
        vibration = 0.8
        [[experiment.environments]]
        name = "quiet"
    """
    new = f"""
        [defaults]
        steps = 6
        seed = [2, 5]
        physics = {{preset = ["default", "quasistatic"]}}
        [[experiment]]
        name = "a"
        shape = ["{chain2}", "{chain3}"]
        learner = {{name = ["thermal", "random"], step_size = [0.1, 0.05], temperature = 0.25}}
        sensor = {{sample_period = [0.125, 0.25]}}
        environment = [
            {{noise = [0.0, 0.3]}},
            {{friction_scale = 1.5, noise = [0.0, 0.3]}},
            {{name = "field", friction_field = {{amplitude = 0.2}}, noise = [0.0, 0.3]}},
        ]
        {EVENTS}
        [[experiment]]
        name = "b"
        shape = "{chain2}"
        seed = [0, 1, 2]
        steps = [4, 6]
        environment = [{{noise = 0.7, vibration = 0.8}}, {{name = "quiet"}}]
        [experiment.physics]
        preset = "fast"
    """
    before, after = (load_suite(write_suite(tmp_path, text, f"{name}.toml")) for name, text in (("old", old),
                                                                                               ("new", new)))
    assert len(before.runs) == 2 * 2 * 2 * 2 * 3 * 2 * 2 * 2 + 2 * 2 * 3
    assert before.plan()["runs"] == after.plan()["runs"] and before.experiments == after.experiments
    assert [job.id for job in before.jobs()] == [job.id for job in after.jobs()]
    b = after.experiments[1]
    assert {after.runs[i].condition["environment"] for i in b.run_ids} == {"vibration=0.8", "quiet"}
    # the ids the code before run-configuration keys gave these runs, at today's defaults (a changed default is a
    # different run: the paper's protocol of 2026-12-02 changed them): their results directories still resume
    assert list(before.runs)[:3] == ["76a65b4cb7ec", "9ba9301e9821", "7735d0911674"]


def test_anything_a_run_configuration_sets_a_suite_can_sweep(tmp_path):
    suite = load_suite(write_suite(tmp_path, f"""
        [defaults]
        environment = {{noise = 0.5}}
        [[experiment]]
        name = "sweep"
        shape = "{SHAPES / 'chain-2.toml'}"
        steps = 4
        learner = {{initial_memory = ["measure", "zero"]}}
        environment = {{friction_field = {{amplitude = [0.0, 0.3], two_d = true}}}}
        [experiment.physics]
        preset = "quasistatic"
        timestep = [0.005, 0.01]
        [[experiment]]
        name = "override"
        shape = "{SHAPES / 'chain-2.toml'}"
        environment = [{{name = "loud", noise = 1.0}}, {{name = "calm"}}]
    """))
    sweep, override = suite.experiments
    runs = [suite.runs[i] for i in sweep.run_ids]
    assert len(runs) == 8 and set(sweep.varying) == {"initial_memory", "environment", "environment_id", "physics"}
    assert [r.config.physics.timestep for r in runs[:2]] == [0.005, 0.01]
    assert {r.config.physics.backend for r in runs} == {"quasistatic"}
    assert {r.condition["physics"] for r in runs} == {"quasistatic, timestep=0.005", "quasistatic, timestep=0.01"}
    assert {r.condition["environment"] for r in runs} == {f"friction_field.amplitude={a}, friction_field.two_d=True"
                                                          for a in (0.0, 0.3)}
    assert {r.config.environment.noise for r in runs} == {0.5}  # from [defaults]
    # an experiment's value wins over the defaults', in every one of its environments that does not set its own
    assert [suite.runs[i].config.environment.noise for i in override.run_ids] == [1.0, 0.5]


def test_a_suite_with_environments_events_and_a_scan_environment_runs_and_records_them(tmp_path):
    path = write_suite(tmp_path, f"""
        [[experiment]]
        name = "drop"
        shapes = ["{SHAPES / 'chain-2.toml'}"]
        steps = 3
        environments = [{{name = "plain"}}, {{name = "field", friction_field = {{amplitude = 0.3}}}}]
        [[experiment.events]]
        step = 2
        kind = "friction"
        scale = 0.5
        [[scan]]
        name = "sticky"
        shape = "{SHAPES / 'chain-2.toml'}"
        resolution = 2
        cycles = 1
        discard = 0
        environment = {{friction_scale = 1.5}}
    """)
    suite = load_suite(path)
    assert suite.scans[0].environment.friction_scale == 1.5
    out = tmp_path / "results"
    outcome = run_suite(suite, out, LocalExecutor(2), progress=False)
    assert outcome.failed == 0 and outcome.done == 3
    steps, runs, scans = outcome.tables["steps"], outcome.tables["runs"], outcome.tables["scans"]
    assert sorted(runs.environment) == ["field", "plain"] and set(runs.events) == {"step 2 friction scale=0.5"}
    assert steps.groupby("run_id").apply(lambda g: g.set_index("step").event.to_dict()).tolist() == [
        {0: "", 1: "", 2: "friction scale=0.5", 3: ""}] * 2
    assert set(scans.environment) == {"friction_scale=1.5"} and len(scans) == 2
    # the scan's ground is not the runs': no 'of scan best' for them
    report = build_report(out).read_text()
    assert "| environment | runs |" in report and "event at" in report and "Fixed:" in report
    assert "step 2 friction scale=0.5" in report


@pytest.mark.parametrize("body, key, expected", [
    ('[[experiment]]\nname = "x"\nshapes = ["{chain2}"]\nsteeps = 10', "experiment[x].steeps", "known keys"),
    ('[[experiment]]\nname = "x"\nshapes = ["{chain2}"]\nsteps = "ten"', "experiment[x].steps", "an integer"),
    ('[[experiment]]\nname = "x"\nshapes = ["{chain2}"]\nseeds = 0', "experiment[x].seeds", "number of seeds"),
    ('[[experiment]]\nname = "x"\nshapes = ["nowhere/chain-9.toml"]', "experiment[x].shapes", "existing morphology"),
    ('[[experiment]]\nname = "x"\nshapes = ["{chain2}"]\nnoise = [0.5, -1]', "experiment[x].noise",
     "a number in [0, 1000] (mm/cycle)"),
    ('[[experiment]]\nname = "x"\nshapes = ["{chain2}"]\nlearners = ["greedy"]', "experiment[x].learners",
     "thermal"),
    ('[[experiment]]\nname = "x"\nshapes = ["{chain2}"]\n[experiment.learner_params]\ntemprature = 1',
     "experiment[x].learner_params.temprature", "known keys"),
    ('[[experiment]]\nname = "x"\nshapes = ["{chain2}"]\n[experiment.learner_params]\ntemperature = [1, "hot"]',
     "experiment[x].learner_params.temperature", "a number >= 0 or inf (mm/cycle), got 'hot'"),
    ('[[experiment]]\nname = "x"\nshapes = ["{chain2}"]\nenvironments = ["slippery"]', "experiment[x].environments",
     "a table"),
    ('[[experiment]]\nname = "x"\nshapes = ["{chain2}"]\nenvironments = [{{frictionscale = 2}}]',
     "experiment[x].environments[0].frictionscale", "known keys"),
    ('[[experiment]]\nname = "x"\nshapes = ["{chain2}"]\n[[experiment.environments]]\n[[experiment.environments]]\n'
     'friction_field = {{amplitude = 1.5}}', "experiment[x].environments[1].friction_field.amplitude", "[0, 1)"),
    ('[[experiment]]\nname = "x"\nshapes = ["{chain2}"]\n'
     'environments = [{{name = "a"}}, {{name = "a", vibration = 0.8}}]',
     "experiment[x].environments[1].name", "a label no other"),
    ('[[experiment]]\nname = "x"\nshapes = ["{chain2}"]\nnoise = [0.5]\nenvironments = [{{noise = 1.0}}]',
     "experiment[x].environments[0].noise", "one value (the old key 'noise' gives it too)"),
    ('[[experiment]]\nname = "x"\nshapes = ["{chain2}"]\nshape = "{chain2}"', "experiment[x].shape",
     "the old key 'shapes'"),
    ('[[experiment]]\nname = "x"\nshape = "{chain2}"\nlearners = ["flaky"]\nlearner = {{name = "thermal"}}',
     "experiment[x].learner.name", "the old key 'learners'"),
    ('[[experiment]]\nname = "x"\nshape = "{chain2}"\nenvironment = {{friction_scale = [2, -1]}}',
     "experiment[x].environment.friction_scale", "a number in (0, 100]"),
    ('[[experiment]]\nname = "x"\nshape = "{chain2}"\nphysics = {{preset = "fast", timestep = [0.01, 0]}}',
     "experiment[x].physics.timestep", "a number in [0.0001, 0.1] (s)"),
    ('[[experiment]]\nname = "x"\nshape = "{chain2}"\nphysics = ["fast", "turbo"]', "experiment[x].physics",
     "one of default"),
    ('[[experiment]]\nname = "x"\nshape = "{chain2}"\nseeds = [1, -1]', "experiment[x].seeds",
     "an integer in [0, 9223372036854775807]"),
    ('[[experiment]]\nname = "x"\nshape = "{chain2}"\nseed = [1, 1]', "experiment[x].seed", "distinct values"),
    ('[[experiment]]\nname = "x"\nshape = "{chain2}"\nsteps = []', "experiment[x].steps", "a non-empty list"),
    ('[[experiment]]\nname = "x"\nshape = "{chain2}"\nenvironment = [{{name = "a"}}, {{name = "b"}}]',
     "experiment[x].environment[1]", "distinct environments"),
    ('[[experiment]]\nname = "x"\nshapes = ["{chain2}"]\nsteps = 10\n[[experiment.events]]\nstep = 2\nkind = "damage"\n'
     'unit = 3\nmode = "no-inflate"', "experiment[x].events[0].unit", "[1, 2] (shape chain-2)"),
    ('[[experiment]]\nname = "x"\nshapes = ["{chain2}"]\nsteps = 10\n[[experiment.events]]\nstep = 2\nkind = "cut"\n'
     'link = 9', "experiment[x].events[0].link", "a link number"),
    ('[[experiment]]\nname = "x"\nshapes = ["{chain2}"]\nsteps = 10\n[[experiment.events]]\nstep = 2\nkind = "flood"',
     "experiment[x].events[0].kind", "one of friction"),
    ('[[experiment]]\nname = "x"\nshapes = ["{chain2}"]\nsteps = 10\n[[experiment.events]]\nstep = 2\nkind = "noise"',
     "experiment[x].events[0].sigma", "a value"),
    ('[[experiment]]\nname = "x"\nshapes = ["{chain2}"]\nsteps = [10, 5]\n[[experiment.events]]\nstep = 8\n'
     'kind = "noise"\nsigma = 1', "experiment[x].events[0].step", "<= the run's steps (5)"),
    ('[[experiment]]\nname = "x"\nshapes = ["{chain2}"]\nevents = {{step = 2}}', "experiment[x].events",
     "an array of tables"),
    ('[[scan]]\nshape = "{chain2}"\nenvironment = {{noise = 0.5}}', "scan[0].environment.noise", "no noise"),
    ('[[scan]]\nshape = "{chain2}"\nenvironment = {{friction_scale = -1}}', "scan[0].environment.friction_scale",
     "a number in (0, 100]"),
    ('[[scan]]\nshape = "{chain2}"\nresolution = 0', "scan[0].resolution", "an integer in [1, 10000]"),
    ('[[scan]]\nshape = "{chain2}"\ncolour = "red"', "scan[0].colour", "known keys"),
    ('title = "x"', "title", "known keys"),
    ('name = "x"', "experiment", "at least one"),
])
def test_a_bad_suite_file_names_the_file_and_the_key(tmp_path, body, key, expected):
    body = body.replace("{chain2}", str(SHAPES / "chain-2.toml")).replace("{{", "{").replace("}}", "}")
    path = write_suite(tmp_path, body, "bad-suite.toml")
    with pytest.raises(ConfigError) as info:
        load_suite(path)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: {key}: expected"), message
    assert expected in message


def test_a_broken_shape_file_names_the_shape_file_and_its_key(tmp_path):
    (tmp_path / "broken.toml").write_text('[assembly]\ngenerator = "chain"\nunits = "three"\n')
    path = write_suite(tmp_path, '[[experiment]]\nshapes = ["broken.toml"]\n')
    with pytest.raises(ConfigError, match=r"broken\.toml: assembly\.units: expected"):
        load_suite(path)


def test_the_shipped_suites_load():
    counts = {}
    for name in ("smoke", "paper-quick", "paper", "morphologies"):
        suite = load_suite(BENCHMARKS / f"{name}.toml")
        counts[name] = len(suite.runs)
        assert suite.name == name and suite.experiments
    smoke = load_suite(BENCHMARKS / "smoke.toml")
    assert {r.condition["n_units"] for r in smoke.runs.values()} == {2, 3}
    assert {r.condition["learner"] for r in smoke.runs.values()} == {"thermal", "flaky"}
    assert counts["smoke"] < counts["paper-quick"] < counts["paper"]


# --- metrics -----------------------------------------------------------------------------------------------------


def test_the_fit_recovers_an_exact_exponential():
    k = np.arange(0, 301)
    fit = fit_exponential(k, 4.5 - (4.5 - (-1.0)) * np.exp(-k / 23.0))
    assert fit["u_eq"] == pytest.approx(4.5, abs=1e-6)
    assert fit["u_0"] == pytest.approx(-1.0, abs=1e-6)
    assert fit["k_0"] == pytest.approx(23.0, rel=1e-5)
    assert fit["rmse"] < 1e-6 and fit["plateau"]


def test_the_fit_tolerates_noise_and_flags_a_curve_without_plateau():
    k = np.arange(0, 301)
    rng = np.random.default_rng(0)
    fit = fit_exponential(k, 3.0 - 3.0 * np.exp(-k / 40.0) + rng.normal(0, 0.2, len(k)))
    assert fit["u_eq"] == pytest.approx(3.0, abs=0.1) and fit["k_0"] == pytest.approx(40.0, rel=0.15)
    assert not fit_exponential(k, 0.01 * k)["plateau"]
    assert not fit_exponential(k, 3.0 - 3.0 * np.exp(-k / 150.0))["plateau"]  # still rising at the end of the window


def test_steps_to_reach_is_the_first_step_at_or_over_the_threshold():
    steps = np.arange(10, 20)
    ubar = np.array([0, 1, 2, 3.2, 3.1, 5, 5, 5, 5, 5], dtype=float)
    assert steps_to_reach(steps, ubar, 3.2) == 13
    assert steps_to_reach(steps, ubar, 3.15) == 13
    assert steps_to_reach(steps, ubar, 5) == 15
    assert math.isnan(steps_to_reach(steps, ubar, 5.1))
    assert math.isnan(steps_to_reach(steps, ubar, math.nan))


def test_recovery_is_the_steps_to_regain_80_percent_of_the_pre_event_level():
    steps = np.arange(0, 101)
    # level 5 over the 20 steps before the event at 50 (earlier steps lower: outside the window), a drop to 1, then
    # a linear climb of 0.5 per step from step 60: 4.0 = 0.8 x 5 is first reached at step 66
    ubar = np.where(steps < 30, 0.0, 5.0)
    ubar = np.where(steps >= 50, np.clip(1.0 + 0.5 * (steps - 60), 1.0, 5.0), ubar)
    assert recovery_steps(steps, ubar, 50) == 16
    assert recovery_steps(steps, np.where(steps >= 50, 3.9, 5.0), 50) == math.inf  # never
    assert recovery_steps(steps, np.where(steps >= 50, 4.0, 5.0), 50) == 0  # not hurt
    assert math.isnan(recovery_steps(steps, np.where(steps >= 50, 4.0, -1.0), 50))  # nothing to regain
    # in the condition metrics: two runs, one recovers in 16 steps, one never
    rows = []
    for run_id, u in (("a", ubar), ("b", np.where(steps >= 50, 1.0, 5.0))):
        rows += [{"run_id": run_id, "condition_id": "c", "step": k, "ubar_true": v, "acceptance": 0.5,
                  "event": "friction scale=0.5" if k == 50 else ""} for k, v in zip(steps, u)]
    runs = pd.DataFrame({"run_id": ["a", "b"], "condition_id": ["c", "c"], "seed": [0, 1], "status": "done"})
    row = condition_metrics(pd.DataFrame(rows), runs).iloc[0]
    assert (row.recovery_step, row.recovery_steps, row.recovered_fraction) == (50, 16, 0.5)


def synthetic_tables(u_eq=6.0, k_0=20.0, n_steps=200):
    """Two runs that follow U(k) = u_eq (1 - exp(-k/k_0)) exactly and one stuck at 0: the seed mean is the same
    exponential scaled by 2/3, so every metric has a closed form."""
    k = np.arange(n_steps + 1)
    curve = u_eq * (1 - np.exp(-k / k_0))
    rows, runs = [], []
    for seed, (ubar, acceptance) in enumerate([(curve, 0.5), (curve, 0.25), (np.zeros_like(curve), 0.0)]):
        run_id = f"r{seed}"
        runs.append({"run_id": run_id, "condition_id": "c", "experiments": "x", "shape": "chain-2", "shape_id": "s2",
                     "n_units": 2, "learner": "thermal", "physics": "fast", "seed": seed, "status": "done",
                     "error": None, "wall_time_s": 1.0})
        rows.append(pd.DataFrame({"run_id": run_id, "condition_id": "c", "seed": seed, "step": k, "ubar": ubar,
                                  "ubar_true": ubar, "acceptance": acceptance}))
    runs.append({**runs[0], "run_id": "r3", "seed": 3, "status": "failed", "error": "boom"})
    return pd.concat(rows, ignore_index=True), pd.DataFrame(runs), curve


def test_condition_metrics_on_synthetic_curves_have_the_known_answers():
    steps, runs, curve = synthetic_tables()
    scans = pd.DataFrame({"shape_id": ["s2"] * 3 + ["s3"], "physics": "fast", "ubar": [1.0, 8.0, -2.0, 99.0]})
    (row,) = condition_metrics(steps, runs, scans).to_dict("records")
    assert (row["runs"], row["failed"], row["missing"]) == (4, 1, 0)
    assert row["u_eq"] == pytest.approx(4.0, abs=1e-6) and row["u_0"] == pytest.approx(0.0, abs=1e-6)
    assert row["k_0"] == pytest.approx(20.0, rel=1e-5)
    # 0.8 * 4 = 3.2 = 6 (1 - exp(-k/20)) at k = 20 ln(6/2.8) = 15.24: the two learning runs reach it at step 16
    assert row["threshold"] == pytest.approx(3.2, abs=1e-6)
    assert row["steps_to_threshold"] == 16 and row["steps_to_threshold_std"] == 0
    assert row["reached_fraction"] == pytest.approx(2 / 3)
    final = curve[-20:].mean()  # the last 10% of 200 learning steps
    assert row["final_ubar"] == pytest.approx(2 / 3 * final)
    assert row["final_ubar_std"] == pytest.approx(np.std([final, final, 0.0], ddof=1))
    assert row["acceptance_final"] == pytest.approx(0.25) and row["acceptance_mean"] == pytest.approx(0.25)
    assert row["scan_best_ubar"] == 8.0 and row["learned_fraction"] == pytest.approx(2 / 3 * final / 8.0)
    table = curves(steps)
    at_15 = table[table.step == 15].iloc[0]
    assert at_15.runs == 3 and at_15.q50 == pytest.approx(curve[15])
    assert at_15["mean"] == pytest.approx(2 / 3 * curve[15])
    assert at_15.acceptance == pytest.approx(0.25)


# --- the command line --------------------------------------------------------------------------------------------


def cli(*argv: str) -> int:
    """The way morphbench.cli runs a subcommand: its func, a ConfigError becoming exit status 2."""
    parser = argparse.ArgumentParser(prog="morphbench")
    add_bench_commands(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(list(argv))
    try:
        return args.func(args)
    except ConfigError as exc:
        print(f"morphbench: error: {exc}", file=sys.stderr)
        return 2


def test_cli_bench_and_report_end_to_end(tmp_path, capsys):
    suite = write_suite(tmp_path, TINY)
    out = tmp_path / "results"
    assert cli("bench", str(suite), "--out", str(out), "--workers", "2", "--quiet") == 0
    printed = capsys.readouterr().out
    assert f"tiny: {N_TINY_JOBS} jobs done, 0 failed, 0 already in" in printed and "report.md" in printed
    report = (out / "report.md").read_text()
    assert "## pair" in report and "## Scans" in report
    figures = {p.name for p in (out / "figures").iterdir()}
    assert {"pair-ubar.png", "pair-acceptance.png", "scan-chain-2-r4.png"} <= figures
    metrics = pd.read_parquet(out / "metrics.parquet")
    assert len(metrics) == 4 and metrics.scan_best_ubar.notna().all()

    (out / "report.md").unlink()
    for png in (out / "figures").iterdir():
        png.unlink()
    assert cli("report", str(out)) == 0
    assert (out / "report.md").read_text().split("Report written")[1].split("\n", 1)[1] == \
        report.split("Report written")[1].split("\n", 1)[1]
    assert {p.name for p in (out / "figures").iterdir()} == figures

    assert cli("bench", str(suite), "--out", str(out), "--quiet") == 0  # everything is there: nothing to do
    assert f"0 jobs done, 0 failed, {N_TINY_JOBS} already in" in capsys.readouterr().out


def test_cli_bad_input_is_one_line_with_status_2(tmp_path, capsys):
    bad = write_suite(tmp_path, '[[experiment]]\nshapes = ["missing.toml"]\n', "bad.toml")
    assert cli("bench", str(bad), "--out", str(tmp_path / "out")) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and str(bad) in err and "experiment[experiment-1].shapes" in err
    assert cli("report", str(tmp_path)) == 2
    assert "plan.json" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        cli("bench", str(bad), "--out", "x", "--workers", "2", "--scheduler", "tcp://localhost:1")
    capsys.readouterr()


def test_physics_from_the_command_line_replaces_every_runs_and_scans_physics():
    from morphbench.params import FAST_PHYSICS

    smoke = BENCHMARKS / "smoke.toml"
    own, fast = load_suite(smoke), load_suite(smoke, physics="fast")
    assert {spec.config.physics for spec in fast.runs.values()} == {FAST_PHYSICS}
    assert {spec.config.physics for spec in own.runs.values()} != {FAST_PHYSICS}
    assert not set(own.runs) & set(fast.runs)  # other physics, other runs: a results directory keeps them apart
    assert {scan.columns["physics"] for scan in fast.scans} == {"fast"}
    with pytest.raises(ConfigError) as info:
        load_suite(smoke, physics="slow")
    assert info.value.source == "--physics"


def test_a_suite_names_its_physics_for_what_names_none(tmp_path):
    """A suite's top-level physics is every run's and scan's preset unless they name their own; --physics still
    replaces them all; a preset that does not exist is a ConfigError naming the suite file and the key."""
    from morphbench.params import FAST_PHYSICS, QUASISTATIC_PHYSICS

    chain = SHAPES / "chain-2.toml"
    path = write_suite(tmp_path, f"""
        physics = "quasistatic"
        [[experiment]]
        name = "plain"
        shape = "{chain}"
        steps = 2
        [[experiment]]
        name = "own"
        shape = "{chain}"
        steps = 2
        physics = "fast"
        [[scan]]
        shape = "{chain}"
        resolution = 4
    """)
    suite = load_suite(path)
    by_experiment = {e.name: {suite.runs[r].config.physics for r in e.run_ids} for e in suite.experiments}
    assert by_experiment == {"plain": {QUASISTATIC_PHYSICS}, "own": {FAST_PHYSICS}}
    assert {scan.columns["physics"] for scan in suite.scans} == {"quasistatic"}
    assert {spec.config.physics for spec in load_suite(path, physics="fast").runs.values()} == {FAST_PHYSICS}
    (tmp_path / "bad.toml").write_text(path.read_text().replace('"quasistatic"', '"slow"', 1))
    with pytest.raises(ConfigError) as info:
        load_suite(tmp_path / "bad.toml")
    assert info.value.key == "physics" and "bad.toml" in str(info.value.source)


def test_a_scan_takes_the_same_physics_table_as_an_experiment(tmp_path):
    """``physics = {preset = ..., field = ...}`` on a scan gives it the parameters a run's table gives (the same
    reader and checks), its own id and a label of the preset and the fields; a preset's name alone keeps the id it
    had; a bad field names the scan's key."""
    from morphbench.experiment.config import physics_from_table

    chain = SHAPES / "chain-2.toml"

    def scan(physics: str):
        path = write_suite(tmp_path, f"""
            [[scan]]
            shape = "{chain}"
            resolution = 4
            physics = {physics}
        """)
        return load_suite(path).scans[0]

    table = scan('{preset = "quasistatic", timestep = 0.01}')
    assert table.physics == physics_from_table({"preset": "quasistatic", "timestep": 0.01}, "x", "physics")
    assert table.physics.timestep == 0.01 and table.columns["physics"].startswith("quasistatic, ")
    assert "0.01" in table.columns["physics"]
    named, same = scan('"quasistatic"'), scan('{preset = "quasistatic"}')
    assert named.id == same.id and named.columns["physics"] == same.columns["physics"] == "quasistatic"
    assert table.id != named.id
    with pytest.raises(ConfigError) as info:
        scan('{preset = "quasistatic", timestep = -1}')
    assert info.value.key == "scan[0].physics.timestep"
    with pytest.raises(ConfigError) as info:
        scan('"slow"')
    assert info.value.key == "scan[0].physics"
