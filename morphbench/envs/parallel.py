"""A run as a PettingZoo parallel environment: one agent per active unit, each choosing its own unit's phase.

Agent ``unit_i`` is unit i (1 = starts at the front; it keeps its name when a shuffle moves it). Each ``step`` is
one learning step of the run loop (morphbench.experiment.driver.Driver, the loop of ``morphbench run``): the step's
events, the agents' phases in place of the learners' proposals, the discarded and measured cycles, the validity
check, the records. An agent's action is its trial phase (``Box(0, 1, (1,))``, cycles: one finite real number, a
Python or numpy int or float or a one-element array or list of one, wrapped modulo 1; anything else, and an action
for an agent that is not alive, is an ActionError naming the agent), its observation and its reward what its own
sensor measured during the step (mm/cycle, noise included). A unit killed by a 'dead' damage event measures nothing:
its agent is terminated with observation and reward 0. After the configuration's ``steps`` learning steps every
agent is truncated.

A step whose physics leaves the model's validity (a PhysicsError) ends the episode: every agent living before it is
terminated with observation and reward 0 and the error in its info (``infos[agent]["error"]``, also ``error``); the
records end at the last valid step, and ``step()`` refuses to go on (EpisodeOver) until ``reset()``.

``reset(seed)`` builds a fresh world, warms it up at the phases where a run of that seed starts (each unit's learner
stream's first draw) and measures step 0 there: the initial observation. The same seed gives the same episode; the
episode is recorded in ``records`` (a RunRecords, the schema of ``morphbench run``), where an agent's kept phase is
the phase it ran (the environment keeps whatever it is given, so every living unit counts as accepting).
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path
from typing import Any

import numpy as np

try:
    from gymnasium.spaces import Box
    from pettingzoo import ParallelEnv as PettingZooParallelEnv
except ImportError as exc:  # one line that says what to install, not a traceback ending in a module name
    raise ImportError(f"morphbench.envs needs the rl extra: pip install 'morphbench[rl]' ({exc})", name=exc.name) \
        from None

from morphbench.errors import ActionError, ConfigError, EpisodeOver, PhysicsError
from morphbench.experiment.clocks import clocked
from morphbench.experiment.config import load_run_config
from morphbench.experiment.records import RunRecords
from morphbench.experiment.driver import Driver
from morphbench.experiment.run import RunConfig, max_speed
from morphbench.learning.base import wrap_phase
from morphbench.learning.plugins import Decentralized, as_phase, learner_spec, unit_rng
from morphbench.params import COUNT, PHYSICS_PRESET, PHYSICS_PRESETS, SEED, PhysicsParams
from morphbench.rules import check_rule
from morphbench.shapes.loader import resolve_shape_path

SOURCE = "morphbench.envs"
MAX_ACTION = 1e6
"""cycles: the largest action magnitude taken (wrapped modulo 1). A float this large still holds its fraction to
1e-10 cycle; beyond, the phase a policy meant is lost to rounding (2**1000 wraps to exactly 0), so it is refused."""
ACTION_SPACE = (f"one finite phase in cycles for Box(0, 1, (1,)): an int or float (numpy's too, not a bool) or a "
                f"one-element array, |phase| <= {MAX_ACTION:g}, wrapped modulo 1")


class Agent:
    """A unit's learner as the run loop sees it in an environment: it proposes the phase its agent chose (``action``)
    and keeps it. A unit that died at the start of the step is not asked, so it keeps the phase it last ran."""

    def __init__(self, phase: float):
        self.phase = self.action = phase

    def propose(self) -> float:
        self.phase = self.action
        return self.phase

    def update(self, velocity: float) -> bool:
        return True


def env_config(source: RunConfig | str | Path, steps: int | None, physics: str | PhysicsParams | None) -> RunConfig:
    """The run configuration of an environment: ``source`` (a RunConfig, or a run configuration or morphology file
    or a library shape's name, as ``morphbench run`` takes them) with ``steps`` and ``physics`` (a preset's name or
    PhysicsParams) overriding it, its learner the agents."""
    config = source if isinstance(source, RunConfig) else load_run_config(resolve_shape_path(source))
    if isinstance(physics, str):
        physics = PHYSICS_PRESETS[check_rule(PHYSICS_PRESET, "", physics, SOURCE, "physics")]
    config = dataclasses.replace(config, learner=learner_spec(Agent), steps=config.steps if steps is None else steps,
                                 physics=config.physics if physics is None else physics)
    check_rule(COUNT, "", config.steps, SOURCE, "steps")  # an episode needs a learning step
    if clocked(config.environment):  # an agent acts on every unit at once, once per step
        raise ConfigError(SOURCE, "environment.clock_drift and clock_offset", "0 (units on clocks of their own step "
                          "at their own moments, not the environment's)")
    return config


def observation_bound(config: RunConfig) -> float:
    """mm/cycle, the largest |velocity| a unit can observe: with the ideal sensor and no noise, what the physics
    allows (a body faster than ``run.max_speed`` stops the run with a PhysicsError, which ends the episode), a float32
    above it; infinite where the measurement is not bounded by the physics (noise, at the start or by an event; an
    optical or camera sensor, whose flow can err)."""
    noisy = config.environment.noise > 0 or any(getattr(event, "sigma", 0) > 0 for event in config.events)
    if noisy or config.sensor.kind != "ideal":
        return float(np.inf)
    return float(np.nextafter(np.float32(1000.0 * max_speed(config.shape)), np.float32(np.inf)))


class ParallelEnv(PettingZooParallelEnv):
    """See the module docstring. ``config``: the episode's run configuration (its seed the last reset's)."""

    metadata = {"name": "morphbench_parallel_v0", "render_modes": []}

    def __init__(self, source: RunConfig | str | Path, *, steps: int | None = None,
                 physics: str | PhysicsParams | None = None):
        self.config = env_config(source, steps, physics)
        self.possible_agents = [f"unit_{u + 1}" for u in range(self.config.shape.n_units)]
        self.agents: list[str] = []
        # One space object per agent, the same at every call (PettingZoo seeds and compares them by identity).
        self._action_spaces = {a: Box(0.0, 1.0, shape=(1,), dtype=np.float32) for a in self.possible_agents}
        bound = observation_bound(self.config)
        self._observation_spaces = {a: Box(-bound, bound, shape=(1,), dtype=np.float32) for a in self.possible_agents}
        self.records: RunRecords | None = None
        """the current (or last) episode's records."""
        self._driver: Driver | None = None
        self._seed: int | None = None
        self.error: PhysicsError | None = None
        """the PhysicsError that ended the current episode, if one did."""
        self.learning_step = 0
        """the learning step last run (0: the initial measurement, at reset)."""

    def observation_space(self, agent: str) -> Box:
        return self._observation_spaces[agent]

    def action_space(self, agent: str) -> Box:
        return self._action_spaces[agent]

    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None):
        """A new episode seeded with ``seed`` (None: the configuration's seed at the first reset, then the previous
        episode's seed + 1, so that a sequence of resets is reproducible); ``options`` are not used."""
        self.close()
        self.agents, self.records, self.error = [], None, None  # a reset that fails leaves no episode to step
        if seed is None:
            seed = self.config.seed if self._seed is None else self._seed + 1
        self._seed = check_rule(SEED, "", seed, SOURCE, "seed")
        self.config = dataclasses.replace(self.config, seed=self._seed)
        n = self.config.shape.n_units
        self._learners = [Agent(wrap_phase(float(unit_rng(self._seed, u).uniform(0.0, 1.0)))) for u in range(n)]
        self._started = time.perf_counter()
        self._driver = Driver([self.config], [Decentralized(self._learners)])
        self.records = self._driver.records[0]
        if self._driver.outcome[0] is not None:  # its loop could not be built (a sensor the world cannot give)
            failure = self._driver.outcome[0]
            self.close()
            self.records = None
            raise failure
        self._driver.warm_up()
        self.learning_step = 0
        self.agents = list(self.possible_agents)
        observations, _, _, _, infos = self._measure()
        return observations, infos

    def step(self, actions: dict[str, Any]):
        """One learning step with each living agent's phase (every living agent must act, no other agent may). Bad
        actions are refused (ActionError) before anything changes."""
        if self.records is None:
            raise EpisodeOver(f"{SOURCE}: no episode has started; call reset()")
        if not self.agents or self._driver is None:
            why = (f"a PhysicsError at learning step {self.learning_step}: {self.error}" if self.error is not None
                   else "the environment was closed" if self._driver is None
                   else "no agent is alive" if self.learning_step < self.config.steps
                   else f"its last learning step, {self.config.steps}")
            raise EpisodeOver(f"{SOURCE}: the episode is over ({why}); call reset()")
        if not isinstance(actions, dict):
            raise ActionError(SOURCE, "actions", "a dict of each living agent's action", actions)
        for agent in actions:
            if agent not in self.agents:
                why = ("an agent no longer alive" if agent in self.possible_agents
                       else f"not an agent of this environment ({self.possible_agents[0]} to "
                            f"{self.possible_agents[-1]})")
                raise ActionError(SOURCE, str(agent), f"actions for living agents only ({why})", actions[agent])
        missing = [agent for agent in self.agents if agent not in actions]
        if missing:
            raise ActionError(SOURCE, missing[0], f"an action from every living agent ({ACTION_SPACE}); no action "
                                                  f"for {', '.join(missing)}")
        phases = {agent: _phase(agent, actions[agent]) for agent in self.agents}  # all checked before any is used
        for agent, phase in phases.items():
            self._learners[self.possible_agents.index(agent)].action = phase
        self.learning_step += 1
        return self._measure()

    def _measure(self):
        """Run the current step through the run loop; its observations, rewards, terminations, truncations, infos
        for the agents living before it, who leave ``agents`` when terminated or truncated."""
        measured = self._driver.step(self.learning_step)
        failure = self._driver.outcome[0]
        if isinstance(failure, PhysicsError):
            return self._end(failure)
        if failure is not None:
            raise failure
        u_measured = measured[0]
        self._last = np.nan_to_num(u_measured, nan=0.0)
        last_step = self.learning_step == self.config.steps
        if last_step:
            self.records.finish(wall_time=time.perf_counter() - self._started)
        units = {agent: self.possible_agents.index(agent) for agent in self.agents}
        observations = {a: np.array([self._last[u]], dtype=np.float32) for a, u in units.items()}
        rewards = {a: float(self._last[u]) for a, u in units.items()}
        terminations = {a: bool(np.isnan(u_measured[u])) for a, u in units.items()}
        truncations = {a: last_step and not terminations[a] for a in units}
        infos = {a: {"step": self.learning_step, "phase": self._learners[u].phase} for a, u in units.items()}
        self.agents = [a for a in units if not (terminations[a] or truncations[a])]
        return observations, rewards, terminations, truncations, infos

    def _end(self, error: PhysicsError):
        """The episode ended by ``error``: every living agent terminated with observation and reward 0, the error in
        its info; the world, no longer valid, is closed."""
        self.error = error
        self.close()
        self._last = np.zeros(len(self.possible_agents))
        agents, self.agents = self.agents, []
        observations = {a: np.zeros(1, dtype=np.float32) for a in agents}
        infos = {a: {"step": self.learning_step, "phase": self._learners[self.possible_agents.index(a)].phase,
                     "error": str(error)} for a in agents}
        return (observations, dict.fromkeys(agents, 0.0), dict.fromkeys(agents, True), dict.fromkeys(agents, False),
                infos)

    def state(self) -> np.ndarray:
        """Every unit's velocity measured at the last step, mm/cycle, in unit order (0 for a dead unit)."""
        return self._last.astype(np.float32)

    def phases(self) -> np.ndarray:
        """Every unit's phase during the last step, in unit order (a dead unit's is the one it died with)."""
        return np.array([learner.phase for learner in self._learners])

    def close(self) -> None:
        if self._driver is not None:
            self._driver.close()
            self._driver = None


def _phase(agent: str, action: Any) -> float:
    """An action as a phase in [0, 1) (``ACTION_SPACE``), else ActionError naming the agent."""
    value = action
    if isinstance(value, (list, tuple)) and len(value) == 1:
        value = value[0]
    if isinstance(value, np.ndarray) and value.size == 1 and value.dtype.kind in "iuf":
        value = value.reshape(-1)[0]
    phase = as_phase(value)  # None for a bool, a string, bytes, a complex number, None or any other object
    if phase is None or abs(value) > MAX_ACTION:
        raise ActionError(SOURCE, agent, ACTION_SPACE, action)
    return phase
