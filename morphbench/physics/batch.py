"""Copies of one assembly in one world (the quasi-static chain's, or the dynamic one's), one per run of a batch, so
that the simulator is called once per learning step for all of them.

Each copy of the assembly is its own piece of the batched world (copies share no link, so the solver treats them one
by one, with the same arithmetic as a world of one): a run on its copy gives the records it gives alone, bit for bit
(tests/test_batch.py). ``make_world(..., copies=n)`` builds a ``Copies``; ``can_batch`` says which configurations
can be batched.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from morphbench.physics.protocol import Batch, Scene
from morphbench.physics.quasistatic import QuasiStaticWorld
from morphbench.shapes.checks import connected_groups
from morphbench.shapes.model import Shape


def copies_of(shape: Shape, count: int) -> Shape:
    """``count`` copies of ``shape`` in one shape, each on the same place, joined to none of the others: copy c's
    body b is body c * n_bodies + b, its link l link c * n_links + l."""
    n = len(shape.bodies)
    links = tuple(dataclasses.replace(link, front=link.front + c * n, rear=link.rear + c * n,
                                      unit=None if link.unit is None else link.unit + c * n)
                  for c in range(count) for link in shape.links)
    return dataclasses.replace(shape, bodies=shape.bodies * count, links=links)


class Copies(Batch):
    """``count`` copies of ``shape`` in one world of ``world_class`` (a backend whose bodies move by their own
    arithmetic, so a copy moves as it does alone); ``worlds`` are the copies' views."""

    world_class = QuasiStaticWorld

    def __init__(self, shape: Shape, physics, environment, count: int):
        self.world = self.world_class(copies_of(shape, count), physics, environment)
        self.n_units = shape.n_units
        self.worlds = [Copy(self, index, shape) for index in range(count)]
        self._poses: tuple[np.ndarray, np.ndarray] | None = None

    def poses(self) -> tuple[np.ndarray, np.ndarray]:
        """Every body's pose, computed once between advances (each run's loop reads its copy's several times a
        step; a body's pose is the same computed alone or with the others)."""
        if self._poses is None:
            self._poses = self.world.poses()
        return self._poses

    def advance(self, n_ticks, on_tick=None):
        self._poses = None
        self.world.advance(n_ticks, on_tick)

    def advance_sampled(self, n_ticks, every, on_tick=None):
        self._poses = None
        positions, orientations = self.world.advance_sampled(n_ticks, every, on_tick)
        n = self.n_units
        return [(np.ascontiguousarray(positions[:, c * n:(c + 1) * n]),
                 np.ascontiguousarray(orientations[:, c * n:(c + 1) * n])) for c in range(len(self.worlds))]

    def advance_sampled_joined(self, n_ticks, every):
        self._poses = None
        return self.world.advance_sampled(n_ticks, every)  # the copies' units are the world's, in copy order

    def unit_poses(self):
        units = list(self.world.shape.units)
        positions, orientations = self.poses()
        return positions[units], orientations[units]

    def body_poses(self):
        positions, orientations = self.poses()  # copy c's body b at c * n_bodies + b
        return positions.reshape(len(self.worlds), -1, 3), orientations.reshape(len(self.worlds), -1, 4)

    def set_phases(self, worlds, phases):
        """Every copy's phases at once, as each copy's ``set_phases`` sets its own."""
        units = (np.asarray(worlds)[:, None] * self.n_units + np.arange(self.n_units)).ravel()
        self.world.phases[units] = np.mod(np.asarray(phases, dtype=float), 1.0).ravel()

    def close(self):
        self.world.close()


class Copy:
    """What one run sees of a batched world: its own copy's bodies, units and links, the shared clock. The batch
    advances every copy at once, so a copy cannot be advanced alone."""

    scene: Scene | None = None

    def __init__(self, batch: Copies, index: int, shape: Shape):
        self.batch, self.world, self.shape = batch, batch.world, shape
        self.backend = batch.world.backend
        world = batch.world
        self._bodies = index * len(shape.bodies)
        self._units = index * shape.n_units
        self._links = index * len(shape.links)
        self._n_bodies = len(shape.bodies)
        self._pieces: tuple[bytes, list[list[int]]] | None = None
        self._all = np.arange(self._bodies, self._bodies + self._n_bodies)
        mine = world.link_units[self._links:self._links + len(shape.links)]
        self.link_units = np.where(mine >= 0, mine - self._units, -1)

    @property
    def time(self) -> float:
        return self.world.time

    @property
    def phases(self) -> np.ndarray:
        return self.world.phases[self._units:self._units + self.shape.n_units]

    @property
    def pressure(self) -> np.ndarray:
        return self.world.pressure[self._links:self._links + len(self.shape.links)]

    @property
    def link_stiffness(self) -> np.ndarray:
        return self.world.link_stiffness[self._links:self._links + len(self.shape.links)]

    @property
    def periods(self) -> np.ndarray:
        return self.world.periods[self._units:self._units + self.shape.n_units]

    def set_clock_rates(self, errors) -> None:
        if np.shape(errors) != (self.shape.n_units,):
            raise ValueError(f"expected {self.shape.n_units} clock rate errors, got {np.shape(errors)}")
        self.world.set_clock_rates(errors, self._units)

    @property
    def damage(self) -> list[str]:
        return self.world.damage[self._units:self._units + self.shape.n_units]

    def ticks_in(self, duration: float) -> int:
        return self.world.ticks_in(duration)

    def set_phases(self, phases) -> None:
        phases = np.asarray(phases, dtype=float)
        if phases.shape != (self.shape.n_units,):
            raise ValueError(f"expected {self.shape.n_units} phases, got {phases.shape}")
        self.world.phases[self._units:self._units + len(phases)] = np.mod(phases, 1.0)

    def poses(self, which=None) -> tuple[np.ndarray, np.ndarray]:
        index = self._all if which is None else self._bodies + np.asarray(which, dtype=int)
        positions, orientations = self.batch.poses()
        return positions[index], orientations[index]

    def unit_poses(self) -> tuple[np.ndarray, np.ndarray]:
        return self.poses(self.shape.units)

    def pieces(self) -> list[list[int]]:
        """The world's pieces of this copy (each sorted, sorted by their first body: the same computed over the
        copy's own links), kept until a cut of the copy changes them."""
        intact = self.world.intact[self._links:self._links + len(self.shape.links)]
        key = intact.tobytes()
        if self._pieces is None or self._pieces[0] != key:
            links = [(link.front, link.rear) for link, whole in zip(self.shape.links, intact) if whole]
            self._pieces = (key, connected_groups(self._n_bodies, links))
        return [list(piece) for piece in self._pieces[1]]

    def set_damage(self, unit: int, mode: str) -> None:
        self.world.set_damage(self._units + unit, mode)

    def set_friction_scale(self, scale: float, bodies: str = "all") -> None:
        self.world.set_friction_scale(scale, bodies)  # every copy's runs change it alike: their events are the same

    def cut(self, link: int) -> None:
        self.world.cut(self._links + link)

    def advance(self, n_ticks: int, on_tick=None, pumps: bool = True, every: int = 1) -> None:
        raise RuntimeError("a copy of a batched world is advanced with all the others (its Batch)")

    def advance_sampled(self, n_ticks: int, every: int, on_tick=None):
        raise RuntimeError("a copy of a batched world is advanced with all the others (its Batch)")

    def close(self) -> None:
        """The batch closes the world its copies share."""

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()
