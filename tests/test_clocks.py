"""Units with clocks of their own (EnvironmentParams.clock_drift, clock_offset; morphbench.experiment.clocks)."""

from __future__ import annotations

import dataclasses
import hashlib
import json

import numpy as np
import pandas as pd
import pytest

from morphbench.bench import LocalExecutor, load_suite, run_suite
from morphbench.cli import main
from morphbench.errors import ConfigError
from morphbench.experiment import RunConfig, run
from morphbench.experiment.clocks import clock_ticks, draw_clocks, schedule_grid
from morphbench.experiment.driver import batchable, run_batch
from morphbench.experiment.events import parse_events
from morphbench.params import (FAST_PHYSICS, QUASISTATIC_PHYSICS, EnvironmentParams, LearnerParams, SensorParams,
                               check_params)
from morphbench.physics import make_world
from morphbench.shapes import load_shape

from conftest import ROOT, SHAPES_DIR, write, write_suite

CHAIN_2, CHAIN_3 = (load_shape(SHAPES_DIR / f"chain-{n}.toml") for n in (2, 3))
IDEAL = SensorParams(kind="ideal")
DRIFT = EnvironmentParams(clock_drift=0.01)
OFFSET = EnvironmentParams(clock_offset=1.0)
BOTH = EnvironmentParams(clock_drift=0.01, clock_offset=1.0)

BEFORE = LearnerParams(temperature=0.5, discard_cycles=1)
"""the learners' defaults when the baseline was made (the paper's protocol changed them later)."""
BASELINE = {
    "quasistatic": RunConfig(shape=CHAIN_3, steps=12, seed=4, sensor=IDEAL, environment=EnvironmentParams(noise=0.3),
                             learner_params=BEFORE),
    "pybullet-fast": RunConfig(shape=CHAIN_2, steps=4, seed=4, physics=FAST_PHYSICS,  # the optical sensor too
                               learner_params=BEFORE),
}
"""runs whose records tests/data/clocks_baseline.json holds the digests of, as the code before the option made
them."""


def digest(records) -> str:
    steps = records.steps().drop(columns=["event"])
    data = records.units().to_numpy(dtype=float).tobytes() + steps.to_numpy(dtype=float).tobytes()
    return hashlib.sha256(data).hexdigest()


def timeline(config: RunConfig) -> tuple[int, int, np.ndarray, np.ndarray, float]:
    """The warm-up's ticks, a step's, each unit's offset and window (ticks) and the tick (s) of ``config``'s run,
    checked against what the clocks ask for: offsets and windows within one grid interval of it."""
    tick, lp, cycle = config.physics.timestep, config.learner_params, config.shape.actuator.cycle_time

    def ticks_in(duration):
        return max(0, round(duration / tick))

    step = ticks_in(lp.discard_cycles * cycle) + ticks_in(lp.cycles_per_step * cycle)
    grid = schedule_grid(ticks_in(config.sensor.sample_period), step)
    errors, offsets, windows, _ = clock_ticks(config, ticks_in, grid)
    _, starts = draw_clocks(config.environment, config.shape.n_units, config.seed)
    assert grid * tick <= config.sensor.sample_period / 5
    assert (np.abs(offsets - starts * step) <= grid).all()
    assert (np.abs(windows - lp.cycles_per_step * cycle * (1 + errors) / tick) <= grid / 2 + 1).all()
    return ticks_in(lp.warmup_cycles * cycle), step, offsets, windows, tick


def units_table(config: RunConfig) -> pd.DataFrame:
    return run(config).units()


@pytest.mark.parametrize("name", BASELINE)
def test_off_is_bit_identical_to_the_code_before_the_option(name):
    expected = json.loads((ROOT / "tests" / "data" / "clocks_baseline.json").read_text())[name]
    config = BASELINE[name]
    assert digest(run(config)) == expected
    zero = dataclasses.replace(config.environment, clock_drift=0.0, clock_offset=0.0)
    assert digest(run(dataclasses.replace(config, environment=zero))) == expected


@pytest.mark.parametrize("physics", [QUASISTATIC_PHYSICS, FAST_PHYSICS], ids=["quasistatic", "pybullet-fast"])
def test_rate_alone_and_offset_alone_change_the_records(physics):
    steps = 6 if physics is QUASISTATIC_PHYSICS else 2
    base = RunConfig(shape=CHAIN_2, steps=steps, seed=3, sensor=IDEAL, physics=physics)
    tables = {name: units_table(dataclasses.replace(base, environment=env))
              for name, env in (("off", EnvironmentParams()), ("drift", DRIFT), ("offset", OFFSET))}
    for name in ("drift", "offset"):
        changed = tables[name]
        assert len(changed) == len(tables["off"]) and np.isfinite(changed.u_true).all()
        assert not np.array_equal(changed.u_true.to_numpy(), tables["off"].u_true.to_numpy()), name
    # the learners draw what they draw without clocks: the same initial phases
    first = {name: t[t.step == 0].phase_tried.to_numpy() for name, t in tables.items()}
    assert np.array_equal(first["off"], first["drift"]) and np.array_equal(first["off"], first["offset"])


@pytest.mark.parametrize("physics", [QUASISTATIC_PHYSICS, FAST_PHYSICS], ids=["quasistatic", "pybullet-fast"])
def test_a_fast_clock_moves_its_pump_n_e_cycles_from_its_neighbour_in_n_cycles(physics):
    """Known answer: pumps at one phase, unit 1's clock fast by e: after n of its cycles, its pump switches on
    n e cycles (of the nominal clock) after unit 2's."""
    e, n = 0.012, 20
    world = make_world(CHAIN_2, physics)
    world.set_clock_rates([e, 0.0])
    world.set_phases([0.3, 0.3])
    cycle = CHAIN_2.actuator.cycle_time
    pressures = []
    world.advance(world.ticks_in((n + 1.5) * cycle), lambda k: pressures.append(world.pressure.copy()))
    world.close()
    pressures = np.array(pressures)[:, :2]  # the two units' bellows (the dummy's link has no pump)
    rising = np.diff(pressures, axis=0) > 0
    ons = [np.flatnonzero(rising[1:, i] & ~rising[:-1, i]) + 2 for i in range(2)]  # ticks whose pressure rose first
    gap = (ons[0][:n + 1] - ons[1][:n + 1]) * world.tick / cycle  # unit 1's switch-on after unit 2's, in cycles
    assert gap[0] == pytest.approx(0.3 * e, abs=2 * world.tick / cycle)
    assert gap[n] - gap[0] == pytest.approx(n * e, abs=2 * world.tick / cycle)
    assert np.all(np.diff(gap) > 0)


def test_each_unit_changes_phase_at_its_own_offset_and_the_steps_keep_their_length():
    """With a random learner every unit changes phase every step: unit i at warm-up + k L + its offset (ticks)."""
    config = RunConfig(shape=CHAIN_3, learner="random", steps=3, seed=5, sensor=IDEAL, physics=QUASISTATIC_PHYSICS,
                       environment=OFFSET)
    phases = []
    records = run(config, on_tick=lambda world: phases.append(world.phases.copy()))
    phases = np.array(phases)
    warmup, step, offsets, _, tick = timeline(config)
    assert len(set(offsets)) == 3 and offsets.max() > step / 2
    tried = records.units().pivot(index="step", columns="unit", values="phase_tried").to_numpy()
    changes = [np.flatnonzero(np.diff(phases[:, i]) != 0) + 1 for i in range(3)]  # first tick of each new phase
    assert (np.diff(tried, axis=0) != 0).all()  # a random learner tries a fresh phase every step
    for i in range(3):
        assert list(changes[i]) == [warmup + k * step + offsets[i] for k in range(4)]
    # the steps are recorded when their last unit has measured them, one step apart
    time = records.steps().time_s.to_numpy()
    assert time == pytest.approx((warmup + np.arange(1, 5) * step + offsets.max()) * tick)


def test_a_unit_measures_the_last_cycles_per_step_of_its_own_cycles():
    """An ideal sensor and no noise: each unit's u_true is its forward displacement over its own window (the
    cycles_per_step of its own cycles before its next step starts), per cycle, read from the poses of every tick."""
    config = RunConfig(shape=CHAIN_2, steps=2, seed=2, sensor=IDEAL, physics=QUASISTATIC_PHYSICS, environment=BOTH,
                       learner_params=LearnerParams(discard_cycles=1))
    x = []
    records = run(config, on_tick=lambda world: x.append(world.unit_poses()[0][:, 0].copy()))
    x = np.array(x)
    warmup, step, offsets, windows, tick = timeline(config)
    errors, _ = draw_clocks(BOTH, 2, 2)
    lp = config.learner_params
    u_true = records.units().pivot(index="step", columns="unit", values="u_true").to_numpy()
    for k in range(3):
        for i in range(2):
            end = warmup + (k + 1) * step + offsets[i]  # ticks run when its window ends; x[t - 1] is after tick t
            moved = x[end - 1, i] - x[end - windows[i] - 1, i]
            own_cycles = windows[i] * tick / (config.shape.actuator.cycle_time * (1 + errors[i]))
            assert own_cycles == pytest.approx(lp.cycles_per_step, rel=0.02)  # to the grid: it fits in the step
            assert u_true[k, i] == pytest.approx(moved * 1000 / own_cycles, abs=1e-9)


def test_a_batch_gives_each_seed_its_own_records():
    events = parse_events([{"step": 3, "kind": "shuffle", "seed": 2},
                           {"step": 5, "kind": "damage", "unit": 1, "mode": "dead"}], "test", 3, len(CHAIN_3.links))
    base = RunConfig(shape=CHAIN_3, steps=8, sensor=IDEAL, events=events,
                     environment=dataclasses.replace(BOTH, noise=0.4))
    configs = [dataclasses.replace(base, seed=seed) for seed in (0, 1, 2)]
    assert all(batchable(c) for c in configs)
    for config, records in zip(configs, run_batch(configs)):
        alone = run(config)
        for got, expected in zip((records.units(), records.steps()), (alone.units(), alone.steps())):
            pd.testing.assert_frame_equal(got, expected, check_exact=True)


@pytest.mark.parametrize("environment, key", [
    ({"clock_drift": -0.01}, "environment.clock_drift"),
    ({"clock_drift": 0.2}, "environment.clock_drift"),
    ({"clock_offset": 1.5}, "environment.clock_offset"),
    ({"clock_offset": "half"}, "environment.clock_offset"),
])
def test_bad_values_are_refused_in_one_line(tmp_path, capsys, environment, key):
    table = ", ".join(f"{k} = {json.dumps(v)}" for k, v in environment.items())
    path = write(tmp_path, f'shape = "{SHAPES_DIR / "chain-2.toml"}"\nsteps = 1\n[environment]\n{table}\n',
                 "run.toml")
    assert main(["run", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and key in err and "Traceback" not in err
    with pytest.raises(ConfigError):
        check_params(EnvironmentParams(**{k: v for k, v in environment.items()}), "env")


@pytest.mark.parametrize("clock", ["clock_offset = 0.5", "clock_drift = 0.01"])
@pytest.mark.parametrize("sensor, quiet", [("ideal", True), ("optical", True), ("ideal", False)])
def test_morphbench_run_runs_units_on_clocks_of_their_own(tmp_path, capsys, clock, sensor, quiet):
    # the progress callback was called after a clocked run's step 0 before that step was recorded (units end a step
    # in the next one's span): it asked the records for the last Ubar and failed with KeyError 'u_measured'
    path = write(tmp_path, f'shape = "{SHAPES_DIR / "chain-2.toml"}"\n[environment]\n{clock}\n', "run.toml")
    out = tmp_path / "out"
    code = main(["run", str(path), "--steps", "3", "--out", str(out), "--sensor", sensor] + ["--quiet"] * quiet)
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "Traceback" not in captured.err and captured.out.startswith("run: final Ubar ")
    steps = pd.read_parquet(out / "steps.parquet")
    assert steps.step.tolist() == [0, 1, 2, 3] and np.isfinite(steps.ubar).all()
    config = json.loads((out / "summary.json").read_text())["config"]
    assert config["environment"][clock.split(" = ")[0]] == float(clock.split(" = ")[1])


def test_a_video_of_a_run_on_clocks_of_its_own_colours_the_kept_phases(tmp_path, capsys):
    # a video's recorder reads the kept phases at each progress call too: none are recorded after step 0 yet
    path = write(tmp_path, f'shape = "{SHAPES_DIR / "chain-2.toml"}"\n[environment]\nclock_offset = 0.5\n',
                 "run.toml")
    video = tmp_path / "run.gif"
    code = main(["run", str(path), "--steps", "2", "--out", str(tmp_path / "out"), "--quiet", "--video", str(video),
                 "--video-width", "160", "--video-height", "90", "--video-fps", "10", "--video-speed", "4",
                 "--colour", "phase"])
    assert code == 0, capsys.readouterr().err
    assert video.stat().st_size > 0


def test_a_slow_clock_measures_the_cycles_of_its_own_that_fit_in_a_step():
    """With no discarded cycle (the paper's protocol) a slow clock's 2 cycles are longer than a step: it measures
    the whole step, as the fraction of its own cycles that fits, and its velocities are per cycle of its own."""
    config = RunConfig(shape=CHAIN_3, steps=2, seed=1, sensor=IDEAL, environment=DRIFT)
    _, step, _, windows, tick = timeline(config)
    errors, _ = draw_clocks(DRIFT, 3, 1)
    assert (windows <= step).all() and (windows[errors > 0] == step).all()
    assert np.isfinite(run(config).units().u_true).all()


def test_offsets_with_a_centralized_learner_are_refused():
    with pytest.raises(ConfigError, match="environment.clock_offset: expected 0 with the centralized learner"):
        run(RunConfig(shape=CHAIN_2, learner="cmaes", steps=1, sensor=IDEAL, environment=OFFSET))
    drift_only = run(RunConfig(shape=CHAIN_2, learner="cmaes", steps=2, sensor=IDEAL, environment=DRIFT))
    assert np.isfinite(drift_only.steps().ubar).all()


def test_a_suite_sets_the_clocks_per_environment(tmp_path):
    suite = load_suite(write_suite(tmp_path, f"""
        name = "clocks"
        [[experiment]]
        name = "own-clocks"
        shape = "{SHAPES_DIR / 'chain-2.toml'}"
        seed = 0
        steps = 2
        environment = [{{}}, {{name = "own", clock_drift = 0.01, clock_offset = 0.5}}]
    """))
    shared, own = (suite.runs[i] for i in suite.experiments[0].run_ids)
    assert (shared.config.environment.clock_drift, shared.config.environment.clock_offset) == (0.0, 0.0)
    assert (own.config.environment.clock_drift, own.config.environment.clock_offset) == (0.01, 0.5)
    assert shared.condition["environment"] == "default" and own.condition["environment"] == "own"
    assert shared.condition_id != own.condition_id
    outcome = run_suite(suite, tmp_path / "results", LocalExecutor(1), progress=False)
    assert (outcome.done, outcome.failed) == (2, 0)
    steps = outcome.tables["steps"]
    assert not np.array_equal(*(steps[steps.run_id == r.id].ubar_true.to_numpy() for r in (shared, own)))


def test_runs_and_scans_keep_their_ids_while_the_clocks_are_off_and_scans_refuse_them(tmp_path):
    """The ids the code before the option gave (d5e1a3b, at today's learner defaults: the paper's protocol changed
    them later): results directories of then still resume."""
    chain2 = SHAPES_DIR / "chain-2.toml"
    text = f"""
        name = "ids"
        [[experiment]]
        name = "runs"
        shape = "{chain2}"
        seed = 0
        steps = 2
        environment = [{{}}, {{friction_scale = 1.5}}]
        [[scan]]
        name = "plain"
        shape = "{chain2}"
        resolution = 2
        [[scan]]
        name = "sticky"
        shape = "{chain2}"
        resolution = 2
        environment = {{friction_scale = 1.5}}
    """
    suite = load_suite(write_suite(tmp_path, text))
    assert list(suite.runs) == ["6709e67d771d", "8a6def5cc744"]
    assert sorted({r.condition_id for r in suite.runs.values()}) == ["f214fb8fc5f4", "faebe14ff822"]
    assert [scan.id for scan in suite.scans] == ["dce403929fbf", "d646dcad4c3b"]
    clocked = load_suite(write_suite(tmp_path, text.replace("friction_scale = 1.5}]", "clock_offset = 0.5}]"),
                                     "clocked.toml"))
    assert list(clocked.runs)[0] == "6709e67d771d" and list(clocked.runs)[1] != "8a6def5cc744"
    with pytest.raises(ConfigError, match=r"scan\[1\].environment.clock_drift: expected 0 in a scan"):
        load_suite(write_suite(tmp_path, text.replace("environment = {friction_scale = 1.5}",
                                                      "environment = {clock_drift = 0.01}"), "scan.toml"))


@pytest.mark.parametrize("physics", [QUASISTATIC_PHYSICS, FAST_PHYSICS], ids=["quasistatic", "pybullet-fast"])
def test_the_own_clocks_timeline_with_one_clock_is_the_shared_clock_loop(physics):
    """Clocks 1e-12 apart take the own-clock timeline (unit by unit, a fixed grid, banks never reset) and must give
    what the shared clock's loop gives: the same trials and decisions, velocities equal to rounding."""
    steps = 12 if physics is QUASISTATIC_PHYSICS else 3
    base = RunConfig(shape=CHAIN_3 if physics is QUASISTATIC_PHYSICS else CHAIN_2, steps=steps, seed=2, sensor=IDEAL,
                     physics=physics, environment=EnvironmentParams(noise=0.2))
    shared = run(base)
    own = run(dataclasses.replace(base, environment=dataclasses.replace(base.environment, clock_drift=1e-12)))
    a, b = shared.units(), own.units()
    for column in ("phase_tried", "phase_kept", "accepted", "position", "piece"):
        assert np.array_equal(a[column].to_numpy(), b[column].to_numpy()), column
    for column in ("u_measured", "u_true", "u_memory"):
        np.testing.assert_allclose(b[column], a[column], rtol=0, atol=1e-7)  # mm/cycle
    np.testing.assert_allclose(own.steps().time_s, shared.steps().time_s, rtol=1e-12)
    assert not np.array_equal(a.u_true.to_numpy(), b.u_true.to_numpy())  # it did take the other timeline


@pytest.mark.parametrize("name", ["thermal", "flaky", "random"])
def test_units_stepped_one_by_one_learn_as_units_stepped_together(name):
    """Per-unit controllers (built-in arrays and plug-in objects) take the units whose step it is (``units``): each
    unit's ends and starts interleaved with the others' (as on clocks of their own) give every unit the trials,
    decisions and memory it has when all step together, a dead unit's included."""
    from morphbench.learning import load_learner_class
    from morphbench.learning.plugins import Decentralized, make_controller, make_learners

    cls, params, n = load_learner_class(name), LearnerParams(), 4
    together, arrays, objects = (make_controller(cls, params, 3, n), make_controller(cls, params, 3, n),
                                 Decentralized(make_learners(cls, params, 3, n)))
    for controller in (together, arrays, objects):
        controller.initial()
    order = np.random.default_rng(0).permutation(n)

    def velocity(trial):
        return 3.0 * np.sin(2 * np.pi * trial)

    history = []  # the shared clock's (tried, accepted, kept, memory) per step
    for step in range(25):
        alive = np.arange(n) != 2 if step >= 10 else np.ones(n, dtype=bool)
        tried = together.propose(step, alive)
        accepted, kept = together.update(step, velocity(tried), alive)
        history.append((tried, accepted, kept, together.memory(), alive))
    for controller in (arrays, objects):
        trials = np.zeros(n)
        for step in range(26):  # each unit in turn ends step - 1 (its update), then starts step (its proposal)
            got_accepted, got_kept = np.zeros(n, dtype=bool), np.zeros(n)
            for unit in order:
                due = np.arange(n) == unit
                if step > 0:
                    tried, accepted, kept, memory, alive = history[step - 1]
                    result = controller.update(step - 1, velocity(trials), alive, units=due)
                    got_accepted[unit], got_kept[unit] = result[0][unit], result[1][unit]
                if step < 25:
                    trials[unit] = controller.propose(step, history[step][4], units=due)[unit]
                    assert trials[unit] == history[step][0][unit], (step, unit)
            if step > 0:
                assert np.array_equal(got_accepted, accepted) and np.array_equal(got_kept, kept), step
                assert np.array_equal(controller.memory(), memory, equal_nan=True), step
