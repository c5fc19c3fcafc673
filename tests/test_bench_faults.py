"""Suites that survive their workers and their users: a worker that dies (a segfault, ``os._exit`` in a plug-in)
fails its own job only, an exception of any kind in a plug-in fails its run only, one bench at a time writes a
results directory, Ctrl-C prints one line and no worker's traceback, and a killed bench leaves no worker behind.

The plug-ins are written into a temporary directory on the workers' PYTHONPATH. The tests with two processes start
``morphbench bench`` as real subprocesses and wait on files (a plug-in learner writes its worker's process id and
waits for a gate to open), never on a clock.
"""

from __future__ import annotations

import json
import os
import random
import signal
import socket
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pandas as pd
import pytest

from morphbench.bench import DaskExecutor, LocalExecutor, load_suite, run_suite
from morphbench.bench import jobs as bench_jobs
from morphbench.bench.runner import batched
from morphbench.files import LOCK, directory_lock, is_stale
from morphbench.errors import ConfigError

import fuzz_suites
import fuzzing
from conftest import ROOT, SHAPES_DIR, write_suite

CHAIN2, CHAIN3 = SHAPES_DIR / "chain-2.toml", SHAPES_DIR / "chain-3.toml"
DEAD_PID = 4194305
"""Above the largest process id Linux gives (pid_max is at most 2**22): no process has it."""
PATIENCE_S = 120.0
"""How long a test waits for another process before it gives up (a hang, not a measurement: a cold checkout compiles
its numba functions first, slowly on a loaded machine)."""

FAULTY = '''
import os
import resource
import signal


class Unusual(BaseException):
    """Neither an Exception nor SystemExit nor KeyboardInterrupt."""


class Faulty:
    """A greedy learner whose run with seed SEED calls fault() in its unit 1's second update(); the others run well."""

    SEED = 0

    def __init__(self, params, rng):
        self.seed = rng.bit_generator.seed_seq.entropy[0]  # the run's seed (learning/plugins.py unit_rng)
        self.rng, self.phase, self.calls = rng, float(rng.uniform()), 0

    def propose(self):
        return (self.phase + 0.05) % 1.0

    def update(self, velocity):
        self.calls += 1
        if self.seed == self.SEED and self.calls == 2:
            self.fault()
        return False


class Exit3(Faulty):
    SEED = 1

    def fault(self):
        os._exit(3)


class Segfault(Faulty):
    def fault(self):
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))  # no core file
        os.kill(os.getpid(), signal.SIGSEGV)


class Interrupt(Faulty):
    SEED = 1

    def fault(self):
        raise KeyboardInterrupt


class Exits(Faulty):
    SEED = 1

    def fault(self):
        raise SystemExit(4)


class Strange(Faulty):
    def fault(self):
        raise Unusual("odd")
'''

GATED = '''
import os, time
from pathlib import Path

GATE = Path({gate!r})


class Gated:
    """Writes its worker's process id into GATE, then waits in its first propose() until GATE/open exists."""

    def __init__(self, params, rng):
        (GATE / str(os.getpid())).touch()
        self.phase, self.waited = 0.5, False

    def propose(self):
        while not self.waited and not (GATE / "open").exists():
            time.sleep(0.05)
        self.waited = True
        return 0.5

    def update(self, velocity):
        return False
'''


@pytest.fixture
def plugins(tmp_path, monkeypatch):
    """A directory for plug-in modules on sys.path here and on the PYTHONPATH of workers and subprocesses."""
    directory = tmp_path / "plugins"
    directory.mkdir()
    monkeypatch.syspath_prepend(str(directory))
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(directory), str(ROOT)]))
    names = []

    def write(name: str, source: str) -> str:
        (directory / f"{name}.py").write_text(textwrap.dedent(source))
        names.append(name)
        return name

    yield write
    for name in names:
        sys.modules.pop(name, None)


def runs_by(outcome) -> dict[tuple[str, int], tuple[str, str | None]]:
    """(learner, seed) -> (status, error) of every run of an outcome's runs table."""
    runs = outcome.tables["runs"]
    return {(r.learner.split(":")[-1], r.seed): (r.status, r.error if isinstance(r.error, str) else None)
            for r in runs.itertuples()}


def result_json(out: Path, run_id: str) -> dict:
    return json.loads((out / "runs" / run_id / "result.json").read_text())


# --- a worker that dies, an exception of any kind ---------------------------------------------------------------------


def test_a_worker_that_dies_fails_its_own_run_and_the_others_go_on(plugins, tmp_path):
    module = plugins("mb_faulty_workers", FAULTY)
    learners = ["thermal"] + [f"{module}:{name}" for name in ("Exit3", "Segfault", "Interrupt", "Exits", "Strange")]
    suite = load_suite(write_suite(tmp_path, f"""
        [[experiment]]
        name = "faults"
        shape = "{CHAIN2}"
        learner = {{name = {json.dumps(learners)}}}
        seeds = 2
        steps = 3
    """))
    assert {job.kind for job in batched(suite.jobs())} == {"batch"}  # each learner's two seeds run in one worker
    out = tmp_path / "out"
    outcome = run_suite(suite, out, LocalExecutor(2), progress=False)
    expected = {("thermal", 0): ("done", None), ("thermal", 1): ("done", None),
                ("Exit3", 0): ("done", None), ("Exit3", 1): ("failed", "worker died: exit code 3"),
                ("Segfault", 0): ("failed", "worker died: signal SIGSEGV"), ("Segfault", 1): ("done", None),
                ("Interrupt", 0): ("done", None), ("Exits", 0): ("done", None), ("Strange", 1): ("done", None)}
    got = runs_by(outcome)
    assert {key: got[key] for key in expected} == expected
    # an exception, whatever its kind, fails its run (named, with where it was raised) and is no crash
    assert got[("Interrupt", 1)][0] == got[("Exits", 1)][0] == got[("Strange", 0)][0] == "failed"
    assert got[("Interrupt", 1)][1].startswith("KeyboardInterrupt (in fault, mb_faulty_workers.py:")
    assert got[("Exits", 1)][1].startswith("--learner: mb_faulty_workers:Exits: expected update(velocity) of unit 1 "
                                           "at learning step 1 to return (it raised SystemExit: 4 (in fault")
    assert got[("Strange", 0)][1].startswith("Unusual: odd (in fault, mb_faulty_workers.py:")
    assert (outcome.done, outcome.failed) == (7, 5)
    runs = outcome.tables["runs"].set_index(["seed", "learner"])
    crashed = {runs.loc[(1, f"{module}:Exit3"), "run_id"], runs.loc[(0, f"{module}:Segfault"), "run_id"]}
    raised = runs.loc[(1, f"{module}:Interrupt"), "run_id"]
    assert {run_id: result_json(out, run_id).get("crashes") for run_id in crashed | {raised}} == \
        {**dict.fromkeys(crashed, 1), raised: None}
    # the runs around a crash have the steps of runs that never met one
    steps = outcome.tables["steps"]
    assert set(steps[steps.learner.str.endswith("Exit3")].seed) == {0}

    # run again: a crashed run is run once more (a crash may have been another's doing), an exception is final
    again = run_suite(suite, out, LocalExecutor(2), progress=False)
    assert (again.skipped, again.done, again.failed) == (10, 0, 2)
    assert sorted(job_id for job_id, _ in again.failures) == sorted(crashed)
    assert {run_id: result_json(out, run_id)["crashes"] for run_id in crashed} == dict.fromkeys(crashed, 2)
    # and then left failed: no endless reruns
    last = run_suite(suite, out, LocalExecutor(2), progress=False)
    assert (last.skipped, last.done, last.failed) == (12, 0, 0)
    assert runs_by(last) == runs_by(outcome)


def test_a_job_that_raises_anything_in_the_worker_process_is_a_failed_result(plugins, tmp_path):
    module = plugins("mb_faulty_inline", FAULTY)
    suite = load_suite(write_suite(tmp_path, f"""
        [[experiment]]
        name = "raises"
        shape = "{CHAIN2}"
        learner = {{name = ["{module}:Interrupt"]}}
        seeds = 2
        steps = 3
    """))
    run_jobs = suite.jobs()
    alone = [bench_jobs.execute(job) for job in run_jobs]  # KeyboardInterrupt does not leave execute
    together = bench_jobs.execute(batched(run_jobs)[0])["results"]  # it escapes run_batch: each run alone then
    for result in (alone, together):
        assert [r["status"] for r in result] == ["done", "failed"]
        assert result[1]["error"].startswith("KeyboardInterrupt (in fault") and "Traceback" in result[1]["traceback"]


def test_with_a_dask_cluster_a_worker_that_dies_fails_its_own_run(plugins, tmp_path):
    distributed = pytest.importorskip("dask.distributed", reason="dask.distributed is not installed")
    import dask

    module = plugins("mb_faulty_dask", FAULTY)
    suite = load_suite(write_suite(tmp_path, f"""
        [[experiment]]
        name = "dies"
        shape = "{CHAIN2}"
        learner = {{name = ["thermal", "{module}:Exit3"]}}
        seeds = 2
        steps = 3
    """))
    # one task per worker at a time and no retries on other workers: the task that kills a worker is the one that
    # ran on it (with Dask's defaults a task is tried on 4 workers, and one queued behind it is suspected too)
    exact = {"distributed.scheduler.allowed-failures": 0, "distributed.scheduler.worker-saturation": 1.0}
    with dask.config.set(exact), \
            distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) \
            as cluster, distributed.Client(cluster) as client:
        outcome = run_suite(suite, tmp_path / "out", DaskExecutor(client), progress=False)
    got = runs_by(outcome)
    assert {key: status for key, (status, _) in got.items()} == {
        ("thermal", 0): "done", ("thermal", 1): "done", ("Exit3", 0): "done", ("Exit3", 1): "failed"}
    assert got[("Exit3", 1)][1].startswith("worker died: Dask worker tcp://")


# --- one writer per results directory ---------------------------------------------------------------------------------


def bench_command(suite: Path, out: Path, workers: int = 1) -> list[str]:
    return [sys.executable, "-m", "morphbench.cli", "bench", str(suite), "--out", str(out), "--quiet", "--no-report",
            "--workers", str(workers)]


def wait_for(condition, what: str, process: subprocess.Popen | None = None) -> None:
    """Poll ``condition()`` until it holds; fail (with the process's output) if ``process`` ends first or after
    PATIENCE_S."""
    deadline = time.monotonic() + PATIENCE_S
    while not condition():
        if process is not None and process.poll() is not None:
            pytest.fail(f"the bench ended ({process.returncode}) before {what}: {process.stderr.read()}")
        if time.monotonic() > deadline:
            pytest.fail(f"still waiting after {PATIENCE_S:g} s for {what}")
        time.sleep(0.05)


def running(pid: int) -> bool:
    """Whether process ``pid`` runs (a zombie, ended but not yet reaped, does not)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, IndexError, ProcessLookupError):
        return False
    return state != "Z"


def error_lines(stderr: str) -> list[str]:
    """stderr without blank lines and the simulator's banner (printed by each process that imports it)."""
    return [line for line in stderr.splitlines() if line.strip() and not line.startswith("pybullet build time")]


@pytest.fixture
def gated(plugins, tmp_path):
    """A suite of two runs (chain-2 and chain-3) of the Gated learner or, with ``quick``, one (chain-3) and a run of
    the thermal learner (chain-2, 1 step); (suite path, gate directory)."""
    gate = tmp_path / "gate"
    gate.mkdir()
    module = plugins("mb_gated", GATED.format(gate=str(gate)))

    def make(quick: bool = False) -> tuple[Path, Path]:
        text = f"""
            [[experiment]]
            name = "gated"
            shape = {json.dumps([str(CHAIN3)] if quick else [str(CHAIN2), str(CHAIN3)])}
            learner = {{name = ["{module}:Gated"]}}
            seeds = 1
            steps = 1
        """
        if quick:
            text += f"""
            [[experiment]]
            name = "quick"
            shape = "{CHAIN2}"
            seeds = 1
            steps = 1
            """
        return write_suite(tmp_path, text, "gated.toml"), gate

    return make


def finished(out: Path) -> list[Path]:
    """The job directories of ``out`` (not those being written)."""
    runs = out / "runs"
    return [p for p in runs.iterdir() if not p.name.startswith(".")] if runs.is_dir() else []


def worker_pids(gate: Path) -> list[int]:
    return [int(p.name) for p in gate.iterdir() if p.name.isdigit()]


def test_a_second_bench_on_a_directory_is_refused_with_the_process_that_holds_it(gated, tmp_path):
    suite, gate = gated()
    out = tmp_path / "out"
    first = subprocess.Popen(bench_command(suite, out), stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
    try:
        wait_for(lambda: len(worker_pids(gate)) == 1, "its worker started its run", first)
        holder = json.loads((out / LOCK).read_text())
        assert holder["pid"] == first.pid and holder["host"] == socket.gethostname()
        before = sorted(p.relative_to(out) for p in out.rglob("*"))
        second = subprocess.run(bench_command(suite, out), capture_output=True, text=True, timeout=PATIENCE_S)
        assert second.returncode == 2
        [line] = error_lines(second.stderr)
        assert line.startswith(f"morphbench: error: --out: {out}: expected a directory no other process is writing "
                               f"(process {first.pid} on {socket.gethostname()} holds it: {sys.executable} -m "
                               f"morphbench.cli bench {suite} --out {out} --quiet")
        assert sorted(p.relative_to(out) for p in out.rglob("*")) == before  # it wrote nothing
        (gate / "open").touch()
        assert first.wait(PATIENCE_S) == 0
        check = subprocess.run([sys.executable, "-m", "morphbench.cli", "check", str(out)], capture_output=True,
                               text=True, timeout=PATIENCE_S, env={**os.environ, "PYTHONPATH": str(ROOT)})
        assert check.returncode == 0, check.stdout + check.stderr  # both ended: the directory is consistent
    finally:
        first.kill()
        first.wait()
    # the lock went with its holder: the directory is free again, and its runs are there
    third = subprocess.run(bench_command(suite, out), capture_output=True, text=True, timeout=PATIENCE_S)
    assert third.returncode == 0, third.stderr
    assert "0 jobs done, 0 failed, 2 already in" in third.stdout


def test_the_lock_nests_in_one_process_and_is_refused_to_another_open_file(tmp_path):
    with directory_lock(tmp_path):
        with directory_lock(tmp_path):  # run_suite inside morphbench bench takes it again
            pass
        holder = json.loads((tmp_path / LOCK).read_text())
        assert holder["pid"] == os.getpid()  # still held after the inner block
        code = f"from morphbench.files import directory_lock\nwith directory_lock({str(tmp_path)!r}): pass"
        other = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=PATIENCE_S,
                               env={**os.environ, "PYTHONPATH": str(ROOT)})
        assert other.returncode == 1 and f"ConfigError: --out: {tmp_path}: expected a directory no other process " \
                                          f"is writing (process {os.getpid()} on" in other.stderr
    assert (tmp_path / LOCK).read_text() == ""  # released: no holder named
    with directory_lock(tmp_path):
        pass


ONE_RUN = f"""
    [[experiment]]
    name = "one"
    shape = "{CHAIN2}"
    seeds = 1
    steps = 1
"""
"""a suite of one chain-2 run of one step."""


def test_temporaries_of_ended_processes_are_cleaned_and_those_of_running_ones_kept(tmp_path):
    suite = load_suite(write_suite(tmp_path, ONE_RUN))
    out = tmp_path / "out"
    run_suite(suite, out, LocalExecutor(1), progress=False)
    alive = subprocess.Popen([sys.executable, "-c", "import sys; sys.stdin.read()"], stdin=subprocess.PIPE)
    try:
        dead = [out / "runs" / f".tmp-r-123-{DEAD_PID}", out / f".runs.parquet.tmp-{DEAD_PID}.parquet",
                out / f".plan.json.tmp-{DEAD_PID}"]
        live = [out / "runs" / f".tmp-r-123-{alive.pid}", out / f".steps.parquet.tmp-{alive.pid}.parquet"]
        for path in dead + live:
            if path.parent.name == "runs":  # a job directory
                path.mkdir()
            else:
                path.write_bytes(b"half")
        assert [is_stale(p) for p in dead + live] == [True] * 3 + [False] * 2
        assert not is_stale(out / LOCK) and not is_stale(out / "plan.json")
        again = run_suite(suite, out, LocalExecutor(1), progress=False)
        assert again.skipped == 1
        assert [p.exists() for p in dead + live] == [False] * 3 + [True] * 2
    finally:
        alive.stdin.close()
        alive.wait()


def test_a_directory_refused_gets_no_lock_file(tmp_path):
    (tmp_path / "notes.txt").write_text("someone's files")
    suite = load_suite(write_suite(tmp_path, ONE_RUN, "one.toml"))
    with pytest.raises(ConfigError, match="a new or empty directory"):
        run_suite(suite, tmp_path, LocalExecutor(1), progress=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt", "one.toml"]


# --- Ctrl-C and a killed bench ----------------------------------------------------------------------------------------


def test_ctrl_c_prints_one_line_and_no_worker_traceback(gated, tmp_path):
    suite, gate = gated(quick=True)
    out = tmp_path / "out"
    # a session of its own: Ctrl-C at a terminal signals the whole foreground group, the workers with the bench
    bench = subprocess.Popen(bench_command(suite, out, workers=2), stderr=subprocess.PIPE, stdout=subprocess.DEVNULL,
                             text=True, start_new_session=True)
    try:
        # one worker waits in a run, the other, its quick run done, for a job
        wait_for(lambda: worker_pids(gate) and len(finished(out)) == 1, "a worker in a run and one idle", bench)
        workers = worker_pids(gate)
        os.killpg(bench.pid, signal.SIGINT)
        assert bench.wait(PATIENCE_S) == 130
        assert error_lines(bench.stderr.read()) == [
            f"morphbench: interrupted; finished runs are saved in {out}: run the same command again to resume"]
        assert not [pid for pid in workers if running(pid)]
        assert len(finished(out)) == 1
    finally:
        (gate / "open").touch()
        bench.kill()
        bench.wait()


def test_a_killed_bench_leaves_no_worker_running(gated, tmp_path):
    suite, gate = gated()
    bench = subprocess.Popen(bench_command(suite, tmp_path / "out", workers=2), stderr=subprocess.PIPE,
                             stdout=subprocess.DEVNULL, text=True)
    try:
        wait_for(lambda: len(worker_pids(gate)) == 2, "both workers started their runs", bench)
        workers = worker_pids(gate)
        assert all(running(pid) for pid in workers)
        bench.send_signal(signal.SIGKILL)
        bench.wait()
        wait_for(lambda: not any(running(pid) for pid in workers), "the workers to end with their bench")
    finally:
        (gate / "open").touch()
        bench.kill()
        bench.wait()


SLOW_IMPORT = '''
import os, time
from pathlib import Path

GATE = Path({gate!r})
if str(os.getpid()) != os.environ.get("MB_POOL_PARENT"):  # a worker: its import waits, as a slow one of the simulator
    (GATE / str(os.getpid())).touch()
    while not (GATE / "open").exists():
        time.sleep(0.05)


def work(job):
    return {{"status": "done", "job": job}}
'''
"""a job function whose module takes a worker as long as the gate stays shut to import."""
POOL = """
import os, sys
os.environ["MB_POOL_PARENT"] = str(os.getpid())
import mb_slow_import
from morphbench.bench.executors import LocalExecutor
print(list(LocalExecutor(1).run([1], mb_slow_import.work)))
"""
"""a pool's parent: one worker, one job of mb_slow_import.work."""


def test_a_worker_killed_with_its_pool_while_it_imports_the_jobs_ends_too(plugins, tmp_path):
    # A killed leaderboard's workers lived on for seconds: they were still importing the jobs' module (the simulator:
    # seconds on a busy machine), which came before they asked to end with their parent. A worker now asks first.
    gate = tmp_path / "gate"
    gate.mkdir()
    plugins("mb_slow_import", SLOW_IMPORT.format(gate=str(gate)))
    pool = subprocess.Popen([sys.executable, "-c", POOL], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True)
    try:
        wait_for(lambda: worker_pids(gate), "the worker importing the jobs' module", pool)
        [worker] = worker_pids(gate)
        assert running(worker)
        pool.send_signal(signal.SIGKILL)
        pool.wait()
        wait_for(lambda: not running(worker), "the worker to end with its pool")
    finally:
        (gate / "open").touch()
        pool.kill()
        pool.wait()


# --- the robustness benchmark's cases ---------------------------------------------------------------------------------


@pytest.mark.parametrize("family, verdict", [("crash", "accepted"), ("held", "refused"), ("stale", "accepted")])
def test_each_family_of_generated_suite_cases_keeps_its_promise(family, verdict, tmp_path):
    for seed in range(2):
        case = fuzz_suites.make_case(fuzzing.RandomChooser(random.Random(f"{family}-{seed}")), (family,))
        outcome = fuzzing.run_case(case, tmp_path / f"case-{seed}", timeout_s=PATIENCE_S)
        assert outcome.verdict == verdict, (case.short(), outcome.err, outcome.exception)
        if family == "crash":  # the plug-in's failures recorded, the thermal runs done
            runs = pd.read_parquet(tmp_path / f"case-{seed}" / "out" / "runs.parquet")
            assert (runs[runs.learner == "thermal"].status == "done").all() and (runs.status == "failed").any()
        if family == "held":
            assert " holds it: " in outcome.line() and "directory_lock" in outcome.line()
