"""Physics: the only package (with rendering) that talks to PyBullet."""

from morphbench.physics.pressure import pressure_trajectory, pump_on
from morphbench.physics.world import World

__all__ = ["World", "pressure_trajectory", "pump_on"]
