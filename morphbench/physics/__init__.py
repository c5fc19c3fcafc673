"""Physics: the only package (with rendering) that talks to PyBullet.

Three worlds behind one interface (set phases, advance ticks, read poses; damage, cuts, friction): the PyBullet
``World`` for any shape, and the quasi-static model (springs and Coulomb friction without inertia), solved exactly
along a line by ``QuasiStaticWorld`` for chains and by ``PlanarWorld`` for any assembly in one layer on the ground.
``make_world`` picks the one ``physics`` names.
"""

import ctypes
import os
import sys


def _import_pybullet_quietly() -> None:
    """``import pybullet`` prints its build time straight to the C-level stdout or stderr, beside whatever the
    command prints (a one-line error among others): the first import is made with both file descriptors on
    /dev/null, then they are restored. Every module that imports pybullet is loaded after this package."""
    if "pybullet" in sys.modules:
        return
    for stream in (sys.stdout, sys.stderr):
        if stream is not None:
            stream.flush()
    saved = {fd: os.dup(fd) for fd in (1, 2)}
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        for fd in saved:
            os.dup2(devnull, fd)
        import pybullet  # noqa: F401

        ctypes.CDLL(None).fflush(None)  # the banner may still sit in C's stdout buffer
    finally:
        for fd, copy in saved.items():
            os.dup2(copy, fd)
            os.close(copy)
        os.close(devnull)


_import_pybullet_quietly()

from morphbench.errors import ConfigError  # noqa: E402
from morphbench.params import (  # noqa: E402
    PHYSICS_BACKENDS,
    EnvironmentParams,
    PhysicsParams,
    check_quasistatic_friction,
)
from morphbench.physics.planar import PlanarWorld, check_one_layer  # noqa: E402
from morphbench.physics.pressure import pressure_trajectory, pump_on  # noqa: E402
from morphbench.physics.quasistatic import QuasiStaticWorld, chain_axis  # noqa: E402
from morphbench.physics.world import World  # noqa: E402


def quasistatic_world(shape, physics: PhysicsParams, environment: EnvironmentParams = EnvironmentParams()):
    """The quasi-static model of ``shape``: along its axis for a chain, in the plane for any other one-layer shape; a
    ConfigError for a stack."""
    try:
        chain_axis(shape)
    except ConfigError:
        check_one_layer(shape)
        return PlanarWorld(shape, physics, environment)
    return QuasiStaticWorld(shape, physics, environment)


def make_world(shape, physics: PhysicsParams, environment: EnvironmentParams = EnvironmentParams(),
               scene: bool = False):
    """A world of ``shape`` on the backend ``physics.backend`` ('auto': the quasi-static model for any shape in one
    layer on the ground, unless ``scene`` asks for a PyBullet scene to render, as the camera sensor does; PyBullet
    for stacks). A quasi-static world outside the model's range (``check_quasistatic_friction``) is refused, also when
    'auto' picks it: a run is never switched to another model behind its back."""
    if physics.backend not in PHYSICS_BACKENDS:
        raise ConfigError("physics", "backend", f"one of {', '.join(PHYSICS_BACKENDS)}", physics.backend)
    if physics.backend == "pybullet" or (physics.backend == "auto" and scene):
        return World(shape, physics, environment)
    try:
        world = quasistatic_world(shape, physics, environment)
    except ConfigError:
        if physics.backend == "quasistatic":
            raise
        return World(shape, physics, environment)  # auto: a stack
    check_quasistatic_friction(shape, environment, shape.source)
    return world


__all__ = ["PlanarWorld", "QuasiStaticWorld", "World", "make_world", "pressure_trajectory", "pump_on",
           "quasistatic_world"]
