"""Reinforcement-learning interfaces to the run loop (the ``rl`` extra: ``pip install 'morphbench[rl]'``).

``ParallelEnv`` (PettingZoo): one agent per unit, each choosing its own phase from its own measurements;
``CentralEnv`` (Gymnasium): one controller choosing every phase from every measurement. Both run the world and the
run loop of ``morphbench run`` and record the same RunRecords.

``CentralEnv`` is registered with Gymnasium as ``morphbench/Central-v0`` when Gymnasium is installed:
``gymnasium.make("morphbench.envs:morphbench/Central-v0", source="chain-2", steps=60)`` imports this package and
makes it (its keyword arguments are CentralEnv's).
"""

import importlib.util

from morphbench.lazy import export_lazily

export_lazily(__name__, {"ParallelEnv": "parallel", "CentralEnv": "central"})

CENTRAL_ID = "morphbench/Central-v0"
"""CentralEnv's id in Gymnasium's registry."""

if importlib.util.find_spec("gymnasium") is not None:  # the rl extra; the registry alone, the simulator on make
    from gymnasium.envs.registration import register, registry

    if CENTRAL_ID not in registry:
        register(id=CENTRAL_ID, entry_point="morphbench.envs.central:CentralEnv")
