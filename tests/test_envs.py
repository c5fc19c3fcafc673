"""The environments: PettingZoo's and Gymnasium's own API checks, and the run loop of ``morphbench run`` underneath
(fed a Thermal run's phases, an environment records that run)."""

import dataclasses
import re
import warnings

import numpy as np
import pandas as pd
import pytest
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import parallel_api_test

from morphbench.envs import CentralEnv, ParallelEnv
from morphbench.errors import ConfigError, EpisodeOver
from morphbench.experiment import RunConfig, parse_events, run
from morphbench.params import PHYSICS_PRESETS, EnvironmentParams, SensorParams
from morphbench.shapes import load_shape

from conftest import EXAMPLES_DIR, ROOT, SHAPES_DIR

CHAIN_3 = load_shape(SHAPES_DIR / "chain-3.toml")
EVENTS = parse_events([{"step": 2, "kind": "friction", "scale": 0.8}, {"step": 3, "kind": "shuffle", "seed": 1},
                       {"step": 4, "kind": "noise", "sigma": 0.2}, {"step": 5, "kind": "damage", "unit": 2,
                                                                    "mode": "dead"},
                       {"step": 6, "kind": "cut", "link": 1}], "test", 3, len(CHAIN_3.links))
"""one event of each kind, the death before the cut."""
LEARNER_OWN = ["phase_kept", "accepted", "u_memory"]
"""what an environment's records cannot share with a run's: the learners' decisions."""


def thermal_run(physics: str, steps: int) -> RunConfig:
    return RunConfig(shape=CHAIN_3, steps=steps, seed=4, events=EVENTS, physics=PHYSICS_PRESETS[physics],
                     environment=EnvironmentParams(noise=0.5))


def replay(env: ParallelEnv, units: pd.DataFrame, seed: int) -> None:
    """Reset ``env`` with ``seed`` and feed each living agent its unit's ``phase_tried`` of ``units``, step by step."""
    env.reset(seed=seed)
    for step in range(1, units.step.max() + 1):
        tried = units[units.step == step].set_index("unit").phase_tried
        env.step({agent: np.array([tried[int(agent.split("_")[1])]], dtype=np.float64) for agent in env.agents})


@pytest.mark.parametrize("physics, steps", [("default", 8), ("fast", 7)])
def test_fed_a_thermal_runs_phases_the_parallel_env_records_that_run(physics, steps):
    """The same world and loop as ``morphbench run``: measurements, noise, truth, poses, events, pieces all match,
    on both backends; only the learners' own decisions (kept phase, acceptance) are the environment's."""
    config = thermal_run(physics, steps)
    expected = run(config)
    env = ParallelEnv(config)
    replay(env, expected.units(), config.seed)
    units, expected_units = env.records.units(), expected.units()
    assert expected_units.step.max() == units.step.max() == steps
    # A dead unit's recorded phase is the one its learner kept: a run's Thermal learner may have reverted, an agent
    # keeps the last phase it ran (a dead pump runs no phase, so the physics is the same).
    dead = expected_units.u_measured.isna()
    assert dead.any()
    expected_units.loc[dead, "phase_tried"] = units.phase_tried[dead]
    pd.testing.assert_frame_equal(units.drop(columns=LEARNER_OWN), expected_units.drop(columns=LEARNER_OWN))
    pd.testing.assert_frame_equal(env.records.steps().drop(columns="acceptance"),
                                  expected.steps().drop(columns="acceptance"))
    pd.testing.assert_frame_equal(env.records.pieces(), expected.pieces())
    living = units.u_measured.notna()
    assert units.accepted[living].all() and (units.phase_kept == units.phase_tried).all()
    assert env.records.summary()["config"]["learner"] == "morphbench.envs.parallel:Agent"
    env.close()


def test_the_parallel_env_passes_pettingzoo_api_test_through_every_event():
    env = ParallelEnv(thermal_run("default", 8))
    parallel_api_test(env, num_cycles=20)
    assert env.records.units().step.max() == 8 and not env.agents
    assert env.records.steps().event.str.contains("dead").any()


def test_each_agent_observes_and_is_rewarded_with_its_own_units_measurement_and_the_dead_are_terminated():
    env = ParallelEnv(thermal_run("default", 8))
    observations, infos = env.reset(seed=2)
    assert set(observations) == set(infos) == set(env.agents) == {"unit_1", "unit_2", "unit_3"}
    assert infos["unit_1"] == {"step": 0, "phase": env.phases()[0]}
    seen = {0: observations}
    step, rng = 0, np.random.default_rng(0)
    while env.agents:
        actions = {agent: rng.uniform(0, 1, 1) for agent in env.agents}
        observations, rewards, terminations, truncations, infos = env.step(actions)
        step += 1
        seen[step] = observations
        assert observations.keys() == rewards.keys() == terminations.keys() == actions.keys()
        for agent, action in actions.items():
            ran = env.phases()[int(agent[-1]) - 1]  # a unit dead at the step's start runs no new phase
            assert infos[agent] == {"step": step, "phase": ran}
            assert ran == pytest.approx(action[0]) or terminations[agent]
            assert observations[agent] in env.observation_space(agent)
        if step == 5:  # unit 2 dies
            assert terminations == {"unit_1": False, "unit_2": True, "unit_3": False}
            assert observations["unit_2"][0] == rewards["unit_2"] == 0.0
            assert env.agents == ["unit_1", "unit_3"]
    assert step == 8 and truncations == {"unit_1": True, "unit_3": True}
    units = env.records.units()
    for (step, unit), u in units.set_index(["step", "unit"]).u_measured.items():
        agent = f"unit_{unit}"
        if agent in seen[step]:
            assert seen[step][agent][0] == np.float32(0.0 if np.isnan(u) else u)
    assert np.array_equal(env.state(), np.nan_to_num(units[units.step == 8].u_measured.to_numpy(), nan=0.0)
                          .astype(np.float32))
    with pytest.raises(RuntimeError, match="episode is over"):
        env.step({})


def test_reset_seeds_reproduce_episodes_and_start_where_a_run_of_that_seed_starts():
    env = ParallelEnv(SHAPES_DIR / "chain-3.toml", steps=3)

    def episode(seed=None) -> pd.DataFrame:
        env.reset(seed=seed)
        while env.agents:
            env.step({agent: np.array([0.25 * int(agent[-1])]) for agent in env.agents})
        return env.records.units()

    first = episode()  # the configuration's seed, then each reset without a seed the next one
    assert env.config.seed == 0
    pd.testing.assert_frame_equal(episode(), episode(1))
    pd.testing.assert_frame_equal(first, episode(0))
    assert not np.allclose(episode(5).u_measured, first.u_measured)
    started = run(RunConfig(shape=CHAIN_3, steps=0, seed=5)).units()
    env.reset(seed=5)
    assert np.array_equal(env.phases(), started.phase_tried)


def test_the_central_env_passes_gymnasium_check_env_and_is_the_parallel_env_with_ubar_as_reward():
    env = CentralEnv(thermal_run("default", 8))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env)
    # only the unbounded velocities and the missing registry entry are remarked on
    assert all(re.search("infinity|spec", str(w.message)) for w in caught), [str(w.message) for w in caught]
    observation, info = env.reset(seed=4)
    assert observation.shape == (3,) and info["step"] == 0
    rewards = []
    terminated = truncated = False
    while not (terminated or truncated):
        action = env.action_space.sample()
        observation, reward, terminated, truncated, info = env.step(action)
        rewards.append(reward)
        alive = observation != 0
        assert np.allclose(info["phases"][alive], action[alive])
    assert truncated and not terminated and info["step"] == 8
    steps = env.records.steps()
    assert rewards == pytest.approx(steps.ubar[1:].tolist(), rel=1e-12)
    assert np.array_equal(observation, np.nan_to_num(env.records.units().u_measured.to_numpy()[-3:]).astype(np.float32))
    parallel = ParallelEnv(thermal_run("default", 8))
    replay(parallel, env.records.units(), 4)
    pd.testing.assert_frame_equal(parallel.records.units(), env.records.units())


def test_the_central_env_terminates_when_no_unit_is_left():
    events = parse_events([{"step": 2, "kind": "damage", "unit": u, "mode": "dead"} for u in (1, 2)], "test", 2, 2)
    env = CentralEnv(RunConfig(shape=load_shape(SHAPES_DIR / "chain-2.toml"), events=events, steps=5))
    env.reset()
    assert env.step(np.full(2, 0.5, dtype=np.float32))[2:4] == (False, False)
    _, reward, terminated, truncated, _ = env.step(np.full(2, 0.5, dtype=np.float32))
    assert (reward, terminated, truncated) == (0.0, True, False)


@pytest.mark.parametrize("source", [SHAPES_DIR / "chain-2.toml", str(EXAMPLES_DIR / "s6-damage.toml"), "chain-2"])
def test_environments_are_built_from_shape_files_run_files_and_library_names(source):
    env = CentralEnv(source, steps=2, physics="fast")
    assert env.parallel.config.physics == PHYSICS_PRESETS["fast"] and env.parallel.config.steps == 2
    assert env.reset()[0].shape == env.observation_space.shape
    env.close()
    run_file = "s6" in str(source)  # its seed and event, the others every default
    assert env.parallel.config.seed == run_file and bool(env.parallel.config.events) == run_file


def test_bad_construction_and_actions_are_refused():
    with pytest.raises(ConfigError, match="steps"):
        ParallelEnv(SHAPES_DIR / "chain-3.toml", steps=0)
    with pytest.raises(ConfigError, match="physics"):
        ParallelEnv(SHAPES_DIR / "chain-3.toml", physics="slow")
    env = ParallelEnv(SHAPES_DIR / "chain-3.toml", steps=2)
    env.reset()
    with pytest.raises(ValueError, match="no action for unit_3"):
        env.step({"unit_1": [0.1], "unit_2": [0.2]})
    with pytest.raises(ValueError, match="unit_1: expected one finite phase"):
        env.step({"unit_1": [np.nan], "unit_2": [0.2], "unit_3": [0.3]})
    with pytest.raises(ValueError, match="expected 3 phases"):
        CentralEnv(SHAPES_DIR / "chain-3.toml", steps=2).step(np.zeros(2))
    env.step({"unit_1": [1.25], "unit_2": [0.2], "unit_3": [-0.1]})
    assert env.phases() == pytest.approx([0.25, 0.2, 0.9])


def _step_both(env, phases):
    """A step of either environment with these phases, one per unit."""
    if isinstance(env, CentralEnv):
        return env.step(np.array(phases))
    return env.step({f"unit_{u + 1}": phase for u, phase in enumerate(phases)})


@pytest.mark.parametrize("kind", [ParallelEnv, CentralEnv])
def test_a_step_with_no_episode_running_is_one_line_episode_over(kind):
    # before any reset, after the last step, after close() and after a reset that failed: never an AttributeError
    env = kind("chain-2", steps=1)
    expected = {"before a reset": "no episode has started; call reset()",
                "after the last step": "the episode is over (its last learning step, 1); call reset()",
                "after close": "the episode is over (the environment was closed); call reset()",
                "after a failed reset": "no episode has started; call reset()"}
    for when, message in expected.items():
        if when == "after the last step":
            env.reset(seed=0)
            _step_both(env, [0.1, 0.2])
        elif when == "after close":
            env.reset(seed=0)
            env.close()
        elif when == "after a failed reset":
            env.reset(seed=0)
            with pytest.raises(ConfigError, match="seed"):
                env.reset(seed=2**63)  # beyond the records' int64, which Gymnasium's own seeding takes
        with pytest.raises(EpisodeOver) as info:
            _step_both(env, [0.1, 0.2])
        assert str(info.value) == f"morphbench.envs: {message}", when
    env.reset(seed=0)
    assert _step_both(env, [0.1, 0.2]) is not None  # a reset starts an episode again
    env.close()


def test_the_documented_example_runs():
    """docs/api.md's own multi-agent learner, trained through the parallel environment, as printed there."""
    page = (ROOT / "docs" / "api.md").read_text(encoding="utf-8")
    section = page[page.index("## Multi-agent and centralized interfaces"):]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    namespace = {}
    exec(compile(code, "docs/api.md", "exec"), namespace)
    records = namespace["env"].records
    assert records.n_steps == namespace["env"].config.steps + 1
    assert records.steps().ubar.iloc[-5:].mean() > records.steps().ubar.iloc[:5].mean()


def test_gymnasium_makes_the_central_env_by_its_id():
    import gymnasium

    env = gymnasium.make("morphbench.envs:morphbench/Central-v0", source="chain-2", steps=2)
    try:
        assert isinstance(env.unwrapped, CentralEnv)
        observation, info = env.reset(seed=3)
        assert observation.shape == (2,) and info["step"] == 0
        made = [env.step(np.array([0.0, 0.4], dtype=np.float32)) for _ in range(2)]
        assert made[-1][3] and not made[0][3]  # truncated after its 2 steps
    finally:
        env.close()
    direct = CentralEnv("chain-2", steps=2)
    try:
        assert np.array_equal(direct.reset(seed=3)[0], observation)
    finally:
        direct.close()


def test_the_observation_space_is_bounded_where_the_physics_bounds_it():
    """Ideal sensor, no noise: a unit observes at most what the physics lets a body move (a faster one ends the
    episode with a PhysicsError); noise, or a sensor whose flow can err, is unbounded."""
    from morphbench.envs.parallel import observation_bound
    from morphbench.experiment.run import max_speed

    shape = load_shape(SHAPES_DIR / "chain-2.toml")
    ideal = RunConfig(shape=shape, sensor=SensorParams(kind="ideal"), steps=3)
    bound = observation_bound(ideal)
    assert 1000 * max_speed(shape) < bound < 1000 * max_speed(shape) * (1 + 1e-6)
    env = CentralEnv(ideal)
    try:
        assert env.observation_space.high[0] == np.float32(bound)
        observation, _ = env.reset(seed=0)
        assert env.observation_space.contains(observation)
        for _ in range(3):
            observation = env.step(np.array([0.0, 0.4], dtype=np.float32))[0]
            assert env.observation_space.contains(observation)
    finally:
        env.close()
    noisy = dataclasses.replace(ideal, environment=EnvironmentParams(noise=0.5))
    later = dataclasses.replace(ideal, events=parse_events([{"step": 2, "kind": "noise", "sigma": 0.3}], "t", 2, 2))
    optical = dataclasses.replace(ideal, sensor=dataclasses.replace(ideal.sensor, kind="optical"))
    assert all(observation_bound(c) == np.inf for c in (noisy, later, optical))
