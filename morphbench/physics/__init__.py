"""Physics: the only package (with rendering) that talks to PyBullet.

Two backends behind one interface (set phases, advance ticks, read poses; damage, cuts, friction): the PyBullet
``World`` for any shape and the ``QuasiStaticWorld`` for chains. ``make_world`` picks the one ``physics`` names.
"""

from morphbench.errors import ConfigError
from morphbench.params import PHYSICS_BACKENDS, EnvironmentParams, PhysicsParams
from morphbench.physics.pressure import pressure_trajectory, pump_on
from morphbench.physics.quasistatic import QuasiStaticWorld, chain_axis
from morphbench.physics.world import World


def make_world(shape, physics: PhysicsParams, environment: EnvironmentParams = EnvironmentParams(),
               scene: bool = False):
    """A world of ``shape`` on the backend ``physics.backend``: a PyBullet ``World`` or a ``QuasiStaticWorld``
    ('auto': the quasi-static one for a chain, unless ``scene`` asks for a PyBullet scene to render, as the camera
    sensor does)."""
    if physics.backend == "auto":
        try:
            chain_axis(shape)
        except ConfigError:
            return World(shape, physics, environment)
        return World(shape, physics, environment) if scene else QuasiStaticWorld(shape, physics, environment)
    if physics.backend == "pybullet":
        return World(shape, physics, environment)
    if physics.backend == "quasistatic":
        return QuasiStaticWorld(shape, physics, environment)
    raise ConfigError("physics", "backend", f"one of {', '.join(PHYSICS_BACKENDS)}", physics.backend)


__all__ = ["QuasiStaticWorld", "World", "make_world", "pressure_trajectory", "pump_on"]
