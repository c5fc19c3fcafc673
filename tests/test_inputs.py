"""Input the interfaces must refuse or survive (issue 21, items 8-12): environment actions and a PhysicsError in an
episode, unbounded scans and suites, missing optional packages, replays of tampered runs, and smaller checks."""

import dataclasses
import datetime
import importlib
import json
import re
import shutil
import sys
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import morphbench.bench.expand as expand_module
from morphbench import params as P
from morphbench.bench.suite import load_suite
from morphbench.envs import CentralEnv, ParallelEnv
from morphbench.errors import ActionError, ConfigError, EpisodeOver, PhysicsError, PluginError
from morphbench.experiment import RunConfig, run
from morphbench.experiment.config import load_run_config
from morphbench.experiment.scan import scan_phases, scan_size
from morphbench.learning.plugins import update_accepted
from morphbench.params import PHYSICS_PRESETS, SensorParams
from morphbench.shapes import load_shape, shape_from_table
from morphbench.experiment.run import RunLoop

import fuzz_interfaces
import fuzzing
from conftest import ROOT, SHAPES_DIR, run_cli, shown_lines

BAD_ACTIONS = [True, np.bool_(False), "0.3", b"0.3", 2 ** 1000, -1e7, datetime.datetime(2020, 1, 1), {"phase": 0.3},
               0.3 + 0j, None, float("nan"), float("inf"), [0.1, 0.2], [], np.array([0.1, 0.2]),
               np.array([True]), np.array(["0.3"]), np.array(0.3 + 1j), [[0.3]], object()]
GOOD_ACTIONS = [(0.3, 0.3), (1, 0.0), (np.float32(0.25), 0.25), (np.int64(2), 0.0), (np.array(0.5), 0.5),
                (np.array([0.75], dtype=np.float32), 0.75), ([1.25], 0.25), ((-0.1,), 0.9), (-1e6, 0.0)]


@pytest.fixture(scope="module")
def env():
    env = ParallelEnv(SHAPES_DIR / "chain-3.toml", steps=50, physics="quasistatic")
    yield env
    env.close()


def _id(action) -> str:
    """The test id: an object's repr holds its address, which differs between xdist's workers."""
    return type(action).__name__ if type(action) is object else repr(action)


@pytest.mark.parametrize("action", BAD_ACTIONS, ids=_id)
def test_every_action_that_is_not_one_finite_real_phase_is_refused_naming_the_agent_and_the_space(env, action):
    env.reset(seed=0)
    with pytest.raises(ActionError) as info:
        env.step({"unit_1": 0.1, "unit_2": action, "unit_3": 0.2})
    message = str(info.value)
    assert message.startswith("morphbench.envs: unit_2: expected one finite phase in cycles for Box(0, 1, (1,))")
    assert "\n" not in message and isinstance(info.value, ValueError)
    assert env.learning_step == 0 and env.records.n_steps == 1  # nothing ran


@pytest.mark.parametrize("action, phase", GOOD_ACTIONS, ids=repr)
def test_finite_real_phases_are_taken_and_wrapped(env, action, phase):
    env.reset(seed=0)
    env.step({"unit_1": 0.1, "unit_2": action, "unit_3": 0.2})
    assert env.phases()[1] == pytest.approx(phase, abs=1e-7)


def test_actions_for_unknown_or_dead_agents_and_missing_ones_are_refused(env):
    env.reset(seed=0)
    with pytest.raises(ActionError, match=r"unit_9: expected actions for living agents only \(not an agent of this "
                                          r"environment \(unit_1 to unit_3\)\)"):
        env.step({"unit_1": 0.1, "unit_2": 0.1, "unit_3": 0.2, "unit_9": 0.5})
    with pytest.raises(ActionError, match="unit_3: expected an action from every living agent .*no action for unit_3"):
        env.step({"unit_1": 0.1, "unit_2": 0.1})
    with pytest.raises(ActionError, match="actions: expected a dict"):
        env.step([0.1, 0.2, 0.3])
    env.agents.remove("unit_2")  # as after its death
    with pytest.raises(ActionError, match="unit_2: expected actions for living agents only .an agent no longer alive"):
        env.step({"unit_1": 0.1, "unit_2": 0.1, "unit_3": 0.2})


@pytest.mark.parametrize("action", [np.array(["a", "b", "c"]), np.array([1 + 0j, 0, 0]), np.array([True] * 3),
                                    {"unit_1": 0.5}, None, [0.1, [0.2], 0.3], np.zeros(2)], ids=repr)
def test_the_central_env_refuses_what_is_not_n_real_phases(action):
    env = CentralEnv(SHAPES_DIR / "chain-3.toml", steps=2, physics="quasistatic")
    env.reset(seed=0)
    with pytest.raises(ActionError, match=r"morphbench.envs: action: expected 3 phases for Box\(0, 1, \(3,\)\)"):
        env.step(action)
    with pytest.raises(ActionError, match="unit_2: expected one finite phase"):
        env.step(np.array([0.1, np.inf, 0.2]))
    env.close()


def break_at(monkeypatch, step):
    """The run's own validity check finds the world left the model at ``step`` (at that step the quick test of a
    batch's runs at once, ``all_inside``, does not pass, so that each run's own check runs, as it would)."""
    original, all_inside = RunLoop.check_physics, RunLoop.all_inside

    def check(self, at, *samples):
        if at == step:
            raise PhysicsError("test", at, "unit 2", "tipped over")
        original(self, at, *samples)

    monkeypatch.setattr(RunLoop, "check_physics", check)
    monkeypatch.setattr(RunLoop, "all_inside", staticmethod(lambda loops, at, *poses: at != step and
                                                            all_inside(loops, at, *poses)))


def test_a_physics_error_ends_the_parallel_episode(monkeypatch):
    env = ParallelEnv(SHAPES_DIR / "chain-3.toml", steps=5, physics="quasistatic")
    break_at(monkeypatch, 2)
    env.reset(seed=0)
    env.step(dict.fromkeys(env.agents, 0.3))
    observations, rewards, terminations, truncations, infos = env.step(dict.fromkeys(env.agents, 0.3))
    agents = ["unit_1", "unit_2", "unit_3"]
    assert terminations == dict.fromkeys(agents, True) and truncations == dict.fromkeys(agents, False)
    assert rewards == dict.fromkeys(agents, 0.0) and all(o.tolist() == [0.0] for o in observations.values())
    assert infos["unit_1"]["error"] == "test: physics left the model's validity at learning step 2: unit 2 tipped over"
    assert env.agents == [] and isinstance(env.error, PhysicsError)
    assert env.records.units().step.max() == 1  # the records end at the last valid step
    with pytest.raises(EpisodeOver, match="the episode is over .a PhysicsError at learning step 2: .*call reset"):
        env.step(dict.fromkeys(agents, 0.3))
    monkeypatch.undo()
    env.reset(seed=0)  # a new episode goes on as usual
    assert env.agents == agents and env.error is None
    env.step(dict.fromkeys(agents, 0.3))
    env.close()


def test_a_physics_error_terminates_the_central_episode(monkeypatch):
    env = CentralEnv(SHAPES_DIR / "chain-3.toml", steps=5, physics="quasistatic")
    break_at(monkeypatch, 1)
    env.reset(seed=0)
    _, reward, terminated, truncated, info = env.step(np.full(3, 0.3))
    assert (reward, terminated, truncated) == (0.0, True, False) and "unit 2 tipped over" in info["error"]
    with pytest.raises(EpisodeOver):
        env.step(np.full(3, 0.3))
    env.close()


# --- 9: unbounded plans -----------------------------------------------------------------------------------------


def test_a_scan_of_more_points_than_the_limit_is_refused_before_anything_is_built(tmp_path, capsys):
    out = tmp_path / "scan"
    status, _, err = run_cli(capsys, "scan", "chain-3", "--resolution", "10000", "--out", str(out), "--quiet")
    assert status == 2 and not out.exists()
    assert err.strip().splitlines() == [
        "morphbench: error: --resolution: chain-3 (3 units): expected at most 100,000 scan points (resolution^2) "
        "(this asks for 100,000,000, about 30 GB of memory before anything runs), got 10000"]
    status, _, err = run_cli(capsys, "scan", "chain-5", "--resolution", "400", "--out", str(out), "--quiet")
    assert status == 2 and "--resolution: chain-5 (5 units): expected at most 100,000 scan points" in err
    with pytest.raises(ConfigError, match="scan: resolution: expected at most 100,000 scan points"):
        scan_phases(3, 317)
    assert scan_size(3, 316) == len(scan_phases(3, 316)) == 99856 and scan_size(5, 4, 7) == 7


def suite_file(tmp_path, experiment: str, scan: str = "") -> Path:
    path = tmp_path / "suite.toml"
    path.write_text(f'[[experiment]]\nname = "a"\nshape = "{SHAPES_DIR / "chain-2.toml"}"\nsteps = 1\n{experiment}\n'
                    + (f'[[scan]]\nshape = "{SHAPES_DIR / "chain-3.toml"}"\n{scan}\n' if scan else ""))
    return path


@pytest.mark.parametrize("experiment, scan, key, asked", [
    ("seeds = 1000000", "", "experiment[a].seeds", "1,000,000"),
    # 6 learners x 5 environments x 4000 seeds, counted from the axes, not expanded
    ("seeds = 4000\nlearner = {step_size = [0.1, 0.2], temperature = [0.1, 0.2, 0.3]}\n"
     "environment = [{noise = [0.0, 0.5]}, {friction_scale = [1.0, 1.5, 2.0]}]", "", "experiment[a].seeds", "120,000"),
    ("seeds = 2", "resolution = 1000", "scan[0].resolution", "1,000,000"),
])
def test_a_suite_of_too_many_runs_or_scan_points_is_refused_before_it_is_expanded(tmp_path, experiment, scan, key,
                                                                                    asked):
    with pytest.raises(ConfigError) as info:
        load_suite(suite_file(tmp_path, experiment, scan))
    assert info.value.key == key and f"(this asks for {asked}," in info.value.expected


def test_the_limit_counts_every_experiment_of_the_suite(tmp_path, monkeypatch):
    monkeypatch.setattr(P, "MAX_SUITE_RUNS", 100)
    second = f"seeds = 60\n[[experiment]]\nname = 'b'\nshape = '{SHAPES_DIR / 'chain-3.toml'}'\nseeds = 60"
    with pytest.raises(ConfigError, match=r"experiment\[b\].seeds: expected at most 100 runs in a suite .* \(this asks "
                                          r"for 120, about 72 kB"):
        load_suite(suite_file(tmp_path, second))


class CountedId(str):
    """A run id that counts how often it is compared for equality (a set or dict compares only on a hash match)."""

    comparisons = 0

    def __eq__(self, other):
        CountedId.comparisons += 1
        return str.__eq__(self, other)

    __hash__ = str.__hash__


def test_suite_expansion_compares_each_run_id_a_bounded_number_of_times(tmp_path, monkeypatch):
    """Checking each seed's run id against a list of the experiment's ids made expansion quadratic in the seeds
    (10^4 seeds 0.9 s, 10^5 57 s); ids are now compared a few times each, whatever the number of seeds."""
    real = expand_module.stable_hash
    monkeypatch.setattr(expand_module, "stable_hash", lambda data: CountedId(real(data)))
    CountedId.comparisons = 0
    suite = load_suite(suite_file(tmp_path, "seeds = 2000"))
    assert len(suite.runs) == len(suite.experiments[0].run_ids) == 2000
    assert [suite.runs[r].seed for r in suite.experiments[0].run_ids] == list(range(2000))
    assert CountedId.comparisons < 3 * 2000  # a list scan: about 2000^2 / 2


# --- 10: dependencies -------------------------------------------------------------------------------------------


def test_cma_is_a_core_dependency_and_the_extras_hold_only_what_is_optional():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    names = [re.match(r"[A-Za-z0-9_.-]+", d).group() for d in project["dependencies"]]
    assert "cma" in names
    assert not any(d.startswith("cma") for extra in project["optional-dependencies"].values() for d in extra)


@pytest.mark.parametrize("missing", ["pettingzoo", "gymnasium"])
def test_without_the_rl_extra_the_environments_say_what_to_install_in_one_line(monkeypatch, missing):
    for name in [m for m in sys.modules if m.startswith("morphbench.envs.")]:
        monkeypatch.delitem(sys.modules, name)
    for name in [m for m in sys.modules if m == missing or m.startswith(f"{missing}.")] + [missing]:
        monkeypatch.setitem(sys.modules, name, None)  # an import of it fails as if it were not installed
    for module in ("morphbench.envs.parallel", "morphbench.envs.central"):
        with pytest.raises(ImportError) as info:
            importlib.import_module(module)
        message = str(info.value)
        assert message.startswith("morphbench.envs needs the rl extra: pip install 'morphbench[rl]' (")
        assert "\n" not in message and info.value.name.split(".")[0] == missing


def test_without_dask_a_scheduler_is_refused_in_one_line_naming_the_extra(monkeypatch, tmp_path, capsys):
    monkeypatch.setitem(sys.modules, "dask.distributed", None)
    monkeypatch.setitem(sys.modules, "dask", None)
    status, _, err = run_cli(capsys, "bench", str(suite_file(tmp_path, "seeds = 1")), "--out", str(tmp_path / "r"),
                             "--scheduler", "tcp://127.0.0.1:1", "--quiet", "--no-report")
    assert status == 2 and len(shown_lines(err)) == 1
    assert err.startswith("morphbench: error: --scheduler: dask: expected the optional dependency dask[distributed] "
                          "installed: pip install 'morphbench[dask]'")


# --- 11: render replays only what run would accept ----------------------------------------------------------------

SMALL_VIDEO = ["--video-width", "32", "--video-height", "32", "--video-fps", "2", "--quiet"]


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory):
    """A 1-step run of a shape file of its own (tests swap its content)."""
    root = tmp_path_factory.mktemp("finished")
    shape = root / "robot.toml"
    shape.write_text('[assembly]\ngenerator = "chain"\nunits = 2\n')
    records = run(RunConfig(shape=load_shape(shape), steps=1, sensor=SensorParams(kind="ideal")))
    records.write(root / "run")
    return root / "run"


def tampered(finished_run, tmp_path, config=None, steps=None) -> Path:
    copy = tmp_path / "run"
    shutil.copytree(finished_run, copy)
    summary = json.loads((copy / "summary.json").read_text())
    if config is not None:
        config(summary["config"])
        (copy / "summary.json").write_text(json.dumps(summary))
    if steps is not None:
        table = pd.read_parquet(copy / "steps.parquet")
        steps(table).to_parquet(copy / "steps.parquet", index=False)
    return copy


@pytest.mark.parametrize("change, line", [
    (lambda c: c.update(physics="fast"), "config.physics: expected a table, got 'fast'"),
    (lambda c: c.update(steps="1"), "config.steps: expected an integer in [0, 1000000], got '1'"),
    (lambda c: c["physics"].update(timestep=-1), "config.physics.timestep: expected a number in [0.0001, 0.1] (s), "
                                                 "got -1"),
    (lambda c: c["learner_params"].update(step_size=[0.1]), "config.learner_params.step_size: expected a number"),
    (lambda c: c["environment"].update(colour=1), "config.environment.colour: expected one of the known keys"),
    (lambda c: c.update(events=[{"step": 9, "kind": "noise", "sigma": 1.0}]),
     "config.events[0].step: expected a learning step <= the run's steps (1)"),
    (lambda c: c.pop("seed"), "config.seed: expected a run configuration written by morphbench (it is missing)"),
    (lambda c: c["shape"].update(source=str(SHAPES_DIR / "chain-3.toml")),
     "config.shape.name: expected the shape the run had"),
    (lambda c: c["shape"].update(id="0123456789ab"), "config.shape.id: expected the shape the run had"),
], ids=["physics-string", "steps-string", "timestep", "step-size", "unknown-key", "late-event", "no-seed",
        "other-shape", "other-id"])
def test_render_refuses_a_stored_configuration_run_would_refuse(finished_run, tmp_path, capsys, change, line):
    run_dir = tampered(finished_run, tmp_path, config=change)
    status, _, err = run_cli(capsys, "render", str(run_dir), "--out", str(tmp_path / "v.gif"), *SMALL_VIDEO)
    assert status == 2 and err.startswith(f"morphbench: error: {run_dir / 'summary.json'}: {line}"), err
    assert len(shown_lines(err)) == 1 and not (tmp_path / "v.gif").exists()


def test_render_refuses_a_shape_file_swapped_for_another_of_as_many_units(finished_run, tmp_path, capsys):
    run_dir = tampered(finished_run, tmp_path)
    shape = Path(json.loads((run_dir / "summary.json").read_text())["config"]["shape"]["source"])
    original = shape.read_text()
    try:
        shape.write_text(original + '[unit]\nmesh = "capsule"\n')
        status, _, err = run_cli(capsys, "render", str(run_dir), "--out", str(tmp_path / "v.gif"), *SMALL_VIDEO)
    finally:
        shape.write_text(original)
    assert status == 2 and "config.shape.id: expected the shape the run had; its file" in err, err


@pytest.mark.parametrize("change, line", [
    (lambda t: t.astype({"step": str}), "step: expected a column of integers, got '"),
    (lambda t: t.astype({"ubar": str}), "ubar: expected a column of floats, got '"),
    (lambda t: t.drop(columns="ubar"), "columns: expected a steps table with 'ubar'"),
    (lambda t: t[t.step != 1], "step: expected the learning steps 0 to 1 of the run, each once, got '1 rows from 0 "
                               "to 0'"),
    (lambda t: pd.concat([t, t]), "step: expected the learning steps 0 to 1 of the run, each once"),
], ids=["step-strings", "ubar-strings", "no-ubar", "missing-step", "repeated-steps"])
def test_render_refuses_records_without_their_schema(finished_run, tmp_path, capsys, change, line):
    run_dir = tampered(finished_run, tmp_path, steps=change)
    status, _, err = run_cli(capsys, "render", str(run_dir), "--out", str(tmp_path / "v.gif"), *SMALL_VIDEO)
    assert status == 2 and err.startswith(f"morphbench: error: {run_dir / 'steps.parquet'}: {line}"), err


def test_an_untouched_run_still_renders(finished_run, tmp_path, capsys):
    status, out, err = run_cli(capsys, "render", str(finished_run), "--out", str(tmp_path / "v.gif"), *SMALL_VIDEO)
    assert status == 0 and (tmp_path / "v.gif").stat().st_size > 0, err


# --- 12: smaller checks ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("axes", [[""], ["xy"], ["x", "x"], [], "x", ["X"], [1]], ids=repr)
def test_actuated_axes_are_exact_distinct_axis_names(axes):
    table = {"assembly": {"generator": "grid", "rows": 2, "columns": 2, "actuated_axes": axes}}
    with pytest.raises(ConfigError, match="assembly.actuated_axes: expected a non-empty list of distinct axes among "
                                          "'x', 'y'"):
        shape_from_table(table, source="grid.toml")
    grid = shape_from_table({"assembly": {**table["assembly"], "actuated_axes": ["y", "x"]}}, source="grid.toml")
    along_x = shape_from_table({"assembly": {**table["assembly"], "actuated_axes": ["x"]}}, source="grid.toml")
    bellows = [sum(link.unit is not None for link in shape.links) for shape in (grid, along_x)]
    assert bellows[0] > bellows[1] > 0


class Returns:
    """A learner whose update returns ``value``."""

    def __init__(self, value):
        self.value = value

    def update(self, velocity):
        return self.value


@pytest.mark.parametrize("value", [float("nan"), None, 1, 0.0, "yes", np.array([True, False]), np.nan], ids=repr)
def test_an_update_that_returns_anything_but_true_or_false_is_a_plugin_error(value):
    with pytest.raises(PluginError) as info:
        update_accepted(Returns(value), 1, 4, 0.5)
    assert info.value.method == "update(velocity)"
    assert "of unit 2 at learning step 4 to return whether it accepted the trial (True or False), got" in str(
        info.value)


@pytest.mark.parametrize("value", [True, False, np.True_, np.False_], ids=repr)
def test_an_update_returning_a_bool_is_taken(value):
    assert update_accepted(Returns(value), 0, 1, 0.5) is bool(value)


def run_file(tmp_path, text: str) -> Path:
    path = tmp_path / "my-run.toml"
    path.write_text(f'shape = "{SHAPES_DIR / "chain-2.toml"}"\nsteps = 1\n{text}')
    return path


@pytest.mark.parametrize("file_physics, option, expected", [
    ('preset = "quasistatic"\ntimestep = 0.004', "fast", dict(backend="pybullet", timestep=0.004)),
    ('backend = "pybullet"\nsolver_iterations = 20', "quasistatic", dict(backend="quasistatic", timestep=1 / 200,
                                                                        solver_iterations=20)),
    ("", "reference", {}),
])
def test_run_physics_replaces_the_preset_and_keeps_the_files_other_physics_fields(tmp_path, file_physics, option,
                                                                                   expected):
    path = run_file(tmp_path, f"[physics]\n{file_physics}\n")
    config = load_run_config(path, physics=option)
    assert config.physics == dataclasses.replace(PHYSICS_PRESETS[option], **expected)
    assert load_run_config(SHAPES_DIR / "chain-2.toml", physics=option).physics == PHYSICS_PRESETS[option]


def test_the_cli_merges_physics_and_records_it(tmp_path, capsys):
    path = run_file(tmp_path, '[physics]\npreset = "fast"\ntimestep = 0.004\n')
    status, _, err = run_cli(capsys, "run", str(path), "--physics", "quasistatic", "--sensor", "ideal", "--out",
                             str(tmp_path / "out"), "--quiet")
    assert status == 0, err
    physics = json.loads((tmp_path / "out" / "summary.json").read_text())["config"]["physics"]
    assert physics["backend"] == "quasistatic" and physics["timestep"] == 0.004


@pytest.mark.parametrize("command", [["run", str(SHAPES_DIR / "chain-2.toml"), "--steps", "1"],
                                     ["scan", str(SHAPES_DIR / "chain-2.toml"), "--resolution", "2"]])
def test_an_empty_out_is_refused_as_bench_refuses_it(tmp_path, capsys, monkeypatch, command):
    monkeypatch.chdir(tmp_path)
    status, _, err = run_cli(capsys, *command, "--out", "", "--quiet")
    assert status == 2 and err == "morphbench: error: --out: '': expected a path, not an empty string\n"
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("text, key", [
    ("[environment.friction_field]\ncorrelation_length = 0.001\nperiod = 100\n",
     "environment.friction_field.correlation_length"),
    ("[learner]\ncycles_per_step = 1000\n[physics]\ntimestep = 0.0001\n", "learner.cycles_per_step"),
])
def test_a_rule_across_a_run_files_fields_names_the_run_file(tmp_path, text, key):
    path = run_file(tmp_path, text)
    with pytest.raises(ConfigError) as info:
        load_run_config(path)
    assert (info.value.source, info.value.key) == (str(path), key)


def test_a_rule_on_the_shapes_actuator_still_names_the_shape_file(tmp_path):
    shape = tmp_path / "fast-pump.toml"
    shape.write_text('[assembly]\ngenerator = "chain"\nunits = 2\n[actuator]\ncycle_time = 0.05\n')
    path = tmp_path / "run.toml"
    path.write_text(f'shape = "{shape}"\n[physics]\ntimestep = 0.01\n')
    with pytest.raises(ConfigError) as info:
        load_run_config(path)
    assert (info.value.source, info.value.key) == (str(shape), "actuator.cycle_time")


# --- the case generator of the robustness benchmark (tests/fuzz_interfaces.py) -----------------------------------


def test_interface_cases_are_reproducible_and_cover_every_kind():
    first, again = fuzz_interfaces.random_cases(30, 3), fuzz_interfaces.random_cases(30, 3)
    assert [(c.kind, c.description) for c in first] == [(c.kind, c.description) for c in again]
    assert {c.kind for c in first} == set(fuzz_interfaces.KINDS)
    assert all(isinstance(c, fuzzing.Case) for c in first)


def test_every_environment_case_is_refused_or_accepted_as_expected():
    cases = [c for c in fuzz_interfaces.random_cases(150, 0, kinds=("env",))]
    verdicts = {}
    for case in cases:
        outcome = fuzz_interfaces.run_case(case, Path("unused"))
        verdicts.setdefault(outcome.verdict, []).append(case.short())
    assert set(verdicts) == {"accepted", "refused"}, {k: v[:3] for k, v in verdicts.items()}


@pytest.mark.parametrize("seed", range(3))
def test_oversized_plans_are_refused(tmp_path, seed):
    for k, case in enumerate(fuzz_interfaces.random_cases(4, seed, kinds=("plan",))):
        outcome = fuzz_interfaces.run_case(case, tmp_path / str(k), timeout_s=60)
        assert outcome.verdict == "refused", (case.short(), outcome.verdict, outcome.err, outcome.exception)


def test_tampered_runs_are_refused_or_replayed_cleanly(tmp_path):
    for k, case in enumerate(fuzz_interfaces.random_cases(6, 1, kinds=("render",))):
        outcome = fuzz_interfaces.run_case(case, tmp_path / str(k), timeout_s=60)
        assert outcome.verdict in ("refused", "accepted"), (case.short(), outcome.verdict, outcome.err,
                                                            outcome.exception)
