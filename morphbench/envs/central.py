"""A run as a Gymnasium environment with one central controller: every unit's phase at once.

The parallel environment (morphbench.envs.parallel) with all agents' actions, observations and rewards gathered:
the action is every unit's trial phase (``Box(0, 1, (n,))``, unit order), the observation every unit's measured
velocity (mm/cycle, 0 for a dead unit), the reward Ubar (the mean measured velocity of the living units, as in
``steps.parquet``). An episode ends truncated after the configuration's ``steps``, terminated when no unit is left
alive, or by a PhysicsError (reward 0, the error in ``info["error"]``). Construction, seeding, ``records`` and what
an action may be are the parallel environment's: an action that is not n finite real phases is an ActionError.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

# first: it says how to install gymnasium
from morphbench.envs.parallel import MAX_ACTION, SOURCE, ParallelEnv, observation_bound
import gymnasium
from gymnasium.spaces import Box
from morphbench.errors import ActionError
from morphbench.experiment.run import RunConfig
from morphbench.params import PhysicsParams


class CentralEnv(gymnasium.Env):
    """See the module docstring; ``parallel`` is the wrapped environment."""

    metadata = {"render_modes": []}

    def __init__(self, source: RunConfig | str | Path, *, steps: int | None = None,
                 physics: str | PhysicsParams | None = None):
        self.parallel = ParallelEnv(source, steps=steps, physics=physics)
        n = len(self.parallel.possible_agents)
        self.action_space = Box(0.0, 1.0, shape=(n,), dtype=np.float32)
        bound = observation_bound(self.parallel.config)
        self.observation_space = Box(-bound, bound, shape=(n,), dtype=np.float32)

    @property
    def records(self):
        return self.parallel.records

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)  # Gymnasium's own np_random; the episode is seeded by the parallel environment
        self.parallel.reset(seed=seed, options=options)
        return self.parallel.state(), self._info()

    def step(self, action):
        n = self.action_space.shape[0]
        expected = (f"{n} phases for Box(0, 1, ({n},)): an array or sequence of finite real numbers (not bools), "
                    f"|phase| <= {MAX_ACTION:g}, wrapped modulo 1")
        try:
            values = np.asarray(action)
        except (TypeError, ValueError):  # a ragged sequence
            values = None
        # dtype kinds i, u, f: ints and floats (no bools, complex numbers, strings, bytes, dates or objects)
        if values is None or values.shape != self.action_space.shape or values.dtype.kind not in "iuf":
            raise ActionError(SOURCE, "action", expected, action)
        agents = self.parallel.possible_agents
        _, _, terminations, truncations, _ = self.parallel.step(
            {agent: values[u:u + 1] for u, agent in enumerate(agents) if agent in self.parallel.agents})
        alive = [agent for agent in terminations if not terminations[agent]]
        reward = self.records.last_ubar if alive else 0.0
        return self.parallel.state(), float(reward), not alive, any(truncations.values()), self._info()

    def _info(self) -> dict[str, Any]:
        """The learning step, the phase each unit ran and the PhysicsError that ended the episode, if one did."""
        info = {"step": self.parallel.learning_step, "phases": self.parallel.phases()}
        if self.parallel.error is not None:
            info["error"] = str(self.parallel.error)
        return info

    def close(self) -> None:
        self.parallel.close()
