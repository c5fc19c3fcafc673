"""Centralized baselines (morphbench.learning.controllers) in the run loop, its records and the suites."""

from __future__ import annotations

import hashlib
import json

import numpy as np
import pytest

from morphbench.bench import LocalExecutor, build_report, load_suite, run_suite
from morphbench.experiment import RunConfig, run
from morphbench.experiment.events import parse_events
from morphbench.experiment.records import RunRecords
from morphbench.experiment.driver import Driver
from morphbench.learning import CENTRALIZED, Controller, load_learner_class
from morphbench.params import EnvironmentParams, SensorParams
from morphbench.shapes import load_shape

from conftest import SHAPES_DIR, write_suite

CHAIN_3 = load_shape(SHAPES_DIR / "chain-3.toml")
IDEAL = SensorParams(kind="ideal")


def units_digest(records: RunRecords) -> str:
    return hashlib.sha256(records.units().to_numpy(dtype=float).tobytes()).hexdigest()[:16]


def test_per_unit_learners_are_reproducible_and_not_centralized():
    """Noise, a dead unit and every per-unit learner: the same seed gives the same records, another seed others."""
    events = parse_events([{"step": 10, "kind": "damage", "unit": 2, "mode": "dead"}], "test", 3, len(CHAIN_3.links))
    for learner in ("thermal", "flaky", "random"):
        a, b, c = (run(RunConfig(shape=CHAIN_3, learner=learner, steps=20, seed=seed, sensor=IDEAL,
                                 environment=EnvironmentParams(noise=0.5), events=events)) for seed in (5, 5, 6))
        assert units_digest(a) == units_digest(b) != units_digest(c), learner
        assert a.summary()["centralized"] is False


@pytest.mark.parametrize("name", sorted(CENTRALIZED))
def test_each_controller_runs_reproducibly_from_its_seed_alone(name):
    state = np.random.get_state()[1].copy()
    a, b, c = (run(RunConfig(shape=CHAIN_3, learner=name, steps=12, seed=s, sensor=IDEAL)) for s in (3, 3, 4))
    assert units_digest(a) == units_digest(b) != units_digest(c)
    assert (np.random.get_state()[1] == state).all()  # cma leaves numpy's global generator alone
    assert a.summary()["centralized"] is True and load_learner_class(name.upper()) is CENTRALIZED[name]
    units = a.units()
    tried = units.pivot(index="step", columns="unit", values="phase_tried").to_numpy()
    kept = units.pivot(index="step", columns="unit", values="phase_kept").to_numpy()
    assert ((tried >= 0) & (tried < 1)).all() and (tried[0] == kept[0]).all()  # step 0 measures the initial vector
    # every unit accepts together, exactly when Ubar beats the best measured so far, and then keeps the trial
    ubar = a.steps().ubar.to_numpy()
    accepted = units.pivot(index="step", columns="unit", values="accepted").to_numpy()
    best = np.maximum.accumulate(ubar)
    improved = np.r_[True, ubar[1:] > best[:-1]]
    assert (accepted == improved[:, None]).all()
    assert (kept[improved] == tried[improved]).all() and (kept[1:][~improved[1:]] == kept[:-1][~improved[1:]]).all()


def test_cmaes_beyond_its_full_units_adapts_a_diagonal_covariance():
    """A full covariance of 10,000 units would be 800 MB and an O(n^3) eigendecomposition per update: beyond
    CMA_FULL_UNITS the covariance is diagonal (no n x n matrix is built), up to it full as before."""
    import cma

    from morphbench.learning.controllers import CMA_FULL_UNITS, CMAES, controller_rng
    from morphbench.params import LearnerParams

    assert CMA_FULL_UNITS == 100
    full = CMAES(LearnerParams(), controller_rng(0), CMA_FULL_UNITS)
    assert isinstance(full.es.sm, cma.sampler.GaussFullSampler) and not full.es.opts["CMA_diagonal"]
    n = 150
    controller = CMAES(LearnerParams(), controller_rng(0), n)
    assert controller.es.opts["CMA_diagonal"] is True and not isinstance(controller.es.sm, cma.sampler.GaussFullSampler)
    alive = np.ones(n, dtype=bool)
    rng = np.random.default_rng(1)
    for step in range(2 * controller.es.popsize + 1):  # step 0 and two generations, each told
        trial = controller.propose(step, alive)
        assert trial.shape == (n,) and ((trial >= 0) & (trial < 1)).all()
        controller.update(step, rng.normal(size=n), alive)
    assert controller.es.countiter == 2 and np.shape(controller.es.sm.variances) == (n,)


def test_random_search_tries_a_fresh_vector_and_the_hill_climber_a_step_from_the_kept_one():
    search = run(RunConfig(shape=CHAIN_3, learner="random-search", steps=30, seed=1, sensor=IDEAL)).units()
    climb = run(RunConfig(shape=CHAIN_3, learner="hill-climber", steps=30, seed=1, sensor=IDEAL)).units()
    for units, near in ((search, False), (climb, True)):
        tried = units.pivot(index="step", columns="unit", values="phase_tried").to_numpy()
        kept = units.pivot(index="step", columns="unit", values="phase_kept").to_numpy()
        gap = np.abs((tried[1:] - kept[:-1] + 0.5) % 1.0 - 0.5)  # circular distance to the previous kept phase
        assert bool(gap.max() <= 0.1 + 1e-12) == near


class Replay(Controller):
    """Runs given phases (the initial ones, then one vector per step) and keeps what it is told."""

    centralized = True

    def __init__(self, phases: np.ndarray):
        self.phases, self.seen = phases, []

    def initial(self):
        return self.phases[0].copy()

    def propose(self, step, alive):
        return self.phases[step].copy()

    def update(self, step, u_measured, alive):
        self.seen.append(u_measured.copy())
        return alive.copy(), self.phases[step].copy()


def test_a_controller_sees_the_measurements_a_thermal_run_s_units_see_at_the_same_phases():
    config = RunConfig(shape=CHAIN_3, steps=15, seed=2, sensor=IDEAL, environment=EnvironmentParams(noise=0.3))
    thermal = run(config).units()
    tried = thermal.pivot(index="step", columns="unit", values="phase_tried").to_numpy()
    replay = Replay(tried)
    driver = Driver([config], [replay])
    with driver.batch:
        driver.warm_up()
        for step in range(config.steps + 1):
            driver.step(step)
    records = driver.records[0]
    measured = thermal.pivot(index="step", columns="unit", values="u_measured").to_numpy()
    assert np.array_equal(np.array(replay.seen), measured)  # noise included: the same per-unit streams
    assert np.array_equal(records.units().u_true, thermal.u_true)


def test_a_dead_unit_keeps_its_phase_under_a_centralized_controller():
    events = parse_events([{"step": 4, "kind": "damage", "unit": 1, "mode": "dead"}], "test", 3, len(CHAIN_3.links))
    units = run(RunConfig(shape=CHAIN_3, learner="cmaes", steps=10, seed=0, sensor=IDEAL, events=events)).units()
    dead = units[(units.unit == 1) & (units.step >= 4)]
    assert dead.u_measured.isna().all() and not dead.accepted.any()
    assert dead.phase_tried.nunique() == 1 and (dead.phase_tried == dead.phase_kept).all()


def test_on_chain_3_hill_climber_and_cmaes_beat_random_phase_changes():
    def final(learner):
        return np.mean([run(RunConfig(shape=CHAIN_3, learner=learner, steps=60, seed=s, sensor=IDEAL)).summary()
                        ["final_ubar_true"] for s in range(4)])

    baseline = final("random")
    assert final("hill-climber") > baseline + 1.0 and final("cmaes") > baseline + 1.0


def test_a_suite_names_controllers_like_learners_and_its_report_compares_them(tmp_path):
    suite = write_suite(tmp_path, f"""
        [[experiment]]
        name = "central"
        shape = "{SHAPES_DIR / 'chain-2.toml'}"
        learner = {{name = ["thermal", "hill-climber"]}}
        seeds = 2
        steps = 6
    """)
    outcome = run_suite(load_suite(suite), tmp_path / "out", LocalExecutor(1), progress=False)
    runs = outcome.tables["runs"]
    assert dict(zip(runs.learner, runs.centralized)) == {"thermal": 0.0, "hill-climber": 1.0}
    assert set(runs.backend) == {"quasistatic"}  # what 'auto' chose, recorded in the suite's runs table
    summary = json.loads((tmp_path / "out" / "runs" / runs.run_id.iloc[-1] / "result.json").read_text())["summary"]
    assert summary["centralized"] is True
    report = build_report(tmp_path / "out").read_text()
    assert "| hill-climber (centralized) |" in report and "| thermal |" in report
    section = report[report.index("## Decentralized against centralized"):]
    section = section[:section.find("\n## ", 1)] if "\n## " in section[1:] else section  # up to the next section
    headline = [line for line in section.splitlines() if line.startswith("|")][-1]
    finals = runs.groupby("learner").final_ubar_true.mean()
    ratio = finals["thermal"] / finals["hill-climber"]
    assert headline.endswith(f"| {ratio:.2f} |" if finals["hill-climber"] > 0 else "| - |")
