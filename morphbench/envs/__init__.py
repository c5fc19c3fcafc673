"""Reinforcement-learning interfaces to the run loop (the ``rl`` extra: ``pip install 'morphbench[rl]'``).

``ParallelEnv`` (PettingZoo): one agent per unit, each choosing its own phase from its own measurements;
``CentralEnv`` (Gymnasium): one controller choosing every phase from every measurement. Both run the world and the
run loop of ``morphbench run`` and record the same RunRecords.
"""

from morphbench.lazy import export_lazily

export_lazily(__name__, {"ParallelEnv": "parallel", "CentralEnv": "central"})
