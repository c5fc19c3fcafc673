"""Physics: the only package (with rendering) that talks to PyBullet.

Four worlds behind one declared interface (``protocol.WorldInterface``: set phases, advance ticks, read poses;
damage, cuts, friction; ``backend`` and ``scene``): the PyBullet ``World`` for any shape; the quasi-static model
(springs and Coulomb friction without inertia), solved exactly along a line by ``QuasiStaticWorld`` for chains and
by ``PlanarWorld`` for any assembly in one layer on the ground; the same springs with inertia and sticking friction,
``DynamicWorld``, integrated in steps linear in the assembly's size ('auto' picks it for sheets beyond
``AUTO_DYNAMIC_UNITS`` units); and the copies of a batch (``batch.Copy``).
``make_world`` builds the one ``resolve_backend`` picks for a configuration, alone or as a ``Batch`` of copies.
"""

import ctypes
import os
import sys
from dataclasses import replace


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
from morphbench.physics.batch import Copies  # noqa: E402
from morphbench.physics.dynamic import DynamicCopies, DynamicWorld, check_dynamic  # noqa: E402
from morphbench.physics.protocol import Batch, Scene, Single, WorldInterface  # noqa: E402


def resolve_backend(shape, physics: PhysicsParams, environment: EnvironmentParams = EnvironmentParams(),
                    scene: bool = False) -> str:
    """The backend ``make_world`` builds for this configuration, decided without building it ('auto': the
    quasi-static model for any shape in one layer on the ground, along its axis for a chain, the dynamic model for a
    one-layer shape that is not a chain and has more than ``AUTO_DYNAMIC_UNITS`` units, unless ``scene`` asks for a
    PyBullet scene to render, as the camera sensor does; PyBullet for stacks). A quasi-static model outside its
    range (``check_quasistatic_friction``) is a ConfigError, also when 'auto' picks it: a run is never switched to
    another model behind its back."""
    return _resolve(shape, physics, environment, scene)[0]


STACK_SUBSTEPS = 2
"""PyBullet steps per tick that 'auto' gives a stack: the explicit link springs of bodies standing on bodies need
them (benchmarks/library_seeds.py: at 1, stack-2x2x2-lift left the model's validity in 2 of 100 seeds, its Ubar far
from the reference setting's; at 2 it agrees with the reference)."""

AUTO_DYNAMIC_UNITS = 100
"""units beyond which 'auto' runs a one-layer shape that is not a chain on the dynamic model instead of the exact
planar solver. Measured through the run loop (benchmarks/RESULTS.md, "Which model 'auto' picks"): the dynamic model
is the cheaper at every size (4-30x from 4 to 256 units), but the planar solver is exact, the limit the others are
checked against, and affordable up to the library's largest shape (sheet-10x10: 100 units, under a minute for 300
steps); beyond, its cost grows as N^1.6 (a 300-step run of 256 units takes minutes, of 1,024 units half an hour)
while the dynamic model's grows as N and agrees with it in every library shape's learning outcome
(docs/fidelity.md, "The dynamic backend")."""


def _resolve(shape, physics: PhysicsParams, environment: EnvironmentParams, scene: bool
             ) -> tuple[str, PhysicsParams]:
    """The backend (``resolve_backend``) and the integration settings it runs with: 'auto' gives a stack on PyBullet
    ``STACK_SUBSTEPS``; a backend named explicitly keeps the settings it is given."""
    if physics.backend not in PHYSICS_BACKENDS:
        raise ConfigError("physics", "backend", f"one of {', '.join(PHYSICS_BACKENDS)}", physics.backend)
    if physics.backend == "pybullet":
        return World.backend, physics
    if physics.backend == DynamicWorld.backend:  # named: any one-layer shape, at any friction
        check_dynamic(shape)
        return DynamicWorld.backend, physics
    try:
        backend = _quasistatic_backend(shape)
    except ConfigError:
        if physics.backend == "quasistatic":
            raise
        return World.backend, replace(physics, substeps=max(physics.substeps, STACK_SUBSTEPS))  # auto: a stack
    if physics.backend == "auto" and scene:
        return World.backend, physics
    if physics.backend == "auto" and backend == PlanarWorld.backend and shape.n_units > AUTO_DYNAMIC_UNITS:
        return DynamicWorld.backend, physics
    check_quasistatic_friction(shape, environment, shape.source)
    return backend, physics


def _quasistatic_backend(shape) -> str:
    """The quasi-static model that solves ``shape``: along its axis for a chain, in the plane for any other one-layer
    shape; a ConfigError for a stack."""
    try:
        chain_axis(shape)
    except ConfigError:
        check_one_layer(shape)
        return PlanarWorld.backend
    return QuasiStaticWorld.backend


def quasistatic_world(shape, physics: PhysicsParams, environment: EnvironmentParams = EnvironmentParams()):
    """The quasi-static model of ``shape``, whatever its friction (``_quasistatic_backend``; benchmarks/fidelity.py
    compares it with PyBullet)."""
    return BACKENDS[_quasistatic_backend(shape)](shape, physics, environment)


BACKENDS = {World.backend: World, QuasiStaticWorld.backend: QuasiStaticWorld, PlanarWorld.backend: PlanarWorld,
            DynamicWorld.backend: DynamicWorld}
"""Every world class by the backend name ``resolve_backend`` gives: a new backend is one module and one entry here
(and its choice in params.PHYSICS_BACKENDS, its rule in ``resolve_backend``)."""
BATCHING = {QuasiStaticWorld.backend: Copies, DynamicWorld.backend: DynamicCopies}
"""The backends that hold a batch's copies in one world, and the batch that does."""


def can_batch(shape, physics: PhysicsParams, environment: EnvironmentParams = EnvironmentParams(),
              scene: bool = False) -> bool:
    """Whether ``make_world(..., copies=n)`` holds the copies in one world (decided without building one)."""
    try:
        return resolve_backend(shape, physics, environment, scene) in BATCHING
    except ConfigError:
        return False


def memory_estimate(shape, physics: PhysicsParams, environment: EnvironmentParams = EnvironmentParams(),
                    scene: bool = False, ticks: int = 0, copies: int = 1) -> float:
    """bytes a run of ``shape`` holds that grow with its size, as the world ``resolve_backend`` picks counts them for
    its longest advance of ``ticks`` (``memory``; copies of a batch hold that many)."""
    backend = BACKENDS[resolve_backend(shape, physics, environment, scene)]
    return copies * backend.memory(len(shape.bodies), len(shape.links), ticks)


def available_memory() -> float:
    """bytes this machine can give a new run now: MemAvailable of /proc/meminfo (Linux), else its free pages, else
    unknown (inf)."""
    try:
        with open("/proc/meminfo", encoding="ascii") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return float(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, ValueError, OSError):
        return float("inf")


def check_memory(shape, needed: float) -> None:
    """A ConfigError naming the shape if ``needed`` bytes (``memory_estimate``) exceed ``available_memory``."""
    available = available_memory()
    if needed > available:
        raise ConfigError(shape.source, "assembly", f"an assembly whose run fits in the memory available "
                          f"({_size(available)})", f"{len(shape.bodies)} bodies, an estimated {_size(needed)}")


def _size(size: float) -> str:
    return f"{size / 2**30:.2f} GiB" if size >= 2**30 else f"{size / 2**20:.1f} MiB"


def make_world(shape, physics: PhysicsParams, environment: EnvironmentParams = EnvironmentParams(),
               scene: bool = False, copies: int | None = None) -> WorldInterface | Batch:
    """A world of ``shape`` on the backend ``resolve_backend`` picks. With ``copies``, a Batch whose ``worlds`` are
    that many copies advanced together: one world in a batch of one, or the copies of one batched world (a
    ValueError if the backend cannot hold more than one, see ``can_batch``)."""
    backend, physics = _resolve(shape, physics, environment, scene)
    if copies is None or copies == 1:
        world = BACKENDS[backend](shape, physics, environment)
        return world if copies is None else Single(world)
    if backend not in BATCHING:
        raise ValueError(f"make_world: the {backend} backend holds one copy of an assembly, asked for {copies}")
    return BATCHING[backend](shape, physics, environment, copies)


__all__ = ["AUTO_DYNAMIC_UNITS", "BACKENDS", "Batch", "PlanarWorld", "QuasiStaticWorld", "Scene", "World",
           "WorldInterface", "available_memory", "can_batch", "check_memory", "make_world", "memory_estimate",
           "pressure_trajectory", "pump_on", "quasistatic_world", "resolve_backend"]
