"""The contract every world keeps, whatever computes its motion: what the run loop, the events, the sensors and the
renderer may ask of a world, and the capabilities that differ between backends, declared instead of guessed.

Code outside ``physics/`` types a world as ``WorldInterface`` and never names a world class or a backend: it asks
``world.backend`` (recorded), ``world.scene`` (a PyBullet scene to render, or None) and, for batches,
``physics.can_batch`` and ``make_world(..., copies=n)``. tests/test_worlds.py checks every world against it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Protocol, runtime_checkable

import numpy as np

from morphbench.shapes.model import Shape


@dataclass(frozen=True)
class Scene:
    """A world's own PyBullet scene: its client id, one body id per shape body (shape order) and the ground plane's
    id. The camera sensor renders the ground in it; the video recorder draws the bodies' own scene."""

    client: int
    bodies: list[int]
    ground: int


@runtime_checkable
class WorldInterface(Protocol):
    """One assembly's world: set phases, advance ticks, read poses; damage, cuts, friction. Bodies, units and links
    are indexed as in ``shape`` (units in unit order)."""

    backend: str
    """which model moves the bodies ('pybullet', 'quasistatic', 'planar'): what summary.json records."""
    shape: Shape
    time: float
    """s, the pumps' clock."""
    link_units: np.ndarray
    """per link, the unit (unit order) whose pump drives it; -1 for a passive link."""
    phases: np.ndarray
    """per unit (unit order), its pump's phase in [0, 1)."""
    periods: np.ndarray
    """s, per unit (unit order), its pump's period: the cycle time, or its own clock's (``set_clock_rates``)."""
    pressure: np.ndarray
    """per link, its bellows' pressure (0..1) now."""
    damage: list[str]
    """per unit (unit order), '' or its damage mode."""
    link_stiffness: np.ndarray
    """N/m, per link, its bellows' axial stiffness now (an open one's is its wall's)."""

    @property
    def scene(self) -> Scene | None:
        """The world's own PyBullet scene, or None for a world without one (a quasi-static model, a copy)."""

    def ticks_in(self, duration: float) -> int:
        """How many ticks make ``duration`` seconds."""

    def set_clock_rates(self, errors) -> None:
        """Every active unit's clock rate error e (unit order): its pump period is cycle_time * (1 + e) from now."""

    def set_phases(self, phases) -> None:
        """Every active unit's phase (unit order, cycles, wrapped into [0, 1))."""

    def advance(self, n_ticks: int, on_tick: Callable[[int], None] | None = None, pumps: bool = True,
                every: int = 1) -> None:
        """Run ``n_ticks`` ticks; ``on_tick(k)`` after tick k when k + 1 is a multiple of ``every``."""

    def advance_sampled(self, n_ticks: int, every: int, on_tick=None) -> tuple[np.ndarray, np.ndarray]:
        """Run ``n_ticks`` ticks; the units' poses every ``every`` ticks and at the end, (K, n_units, 3) and
        (K, n_units, 4)."""

    def poses(self, which=None) -> tuple[np.ndarray, np.ndarray]:
        """Positions (N, 3) and quaternions (N, 4, x y z w) of the bodies ``which`` (default all)."""

    def unit_poses(self) -> tuple[np.ndarray, np.ndarray]:
        """Poses of the active units, unit order."""

    def pieces(self) -> list[list[int]]:
        """Connected groups of bodies over the links not cut, the piece holding body 0 first."""

    def set_damage(self, unit: int, mode: str) -> None:
        """Damage the unit at ``unit`` (unit order): '' heals, else a mode of params.DAMAGE_MODES."""

    def set_friction_scale(self, scale: float, bodies: str = "all") -> None:
        """The friction of ``bodies`` (params.FRICTION_TARGETS) times ``scale`` from now on (a ConfigError if the
        model cannot take it)."""

    def cut(self, link: int) -> None:
        """Cut link ``link`` (index into shape.links)."""

    def close(self) -> None:
        """Release what the world holds."""

    def __enter__(self) -> WorldInterface: ...

    def __exit__(self, *exc) -> None: ...


class Batch:
    """Worlds advanced together, one per run: ``worlds`` (each a ``WorldInterface``) move only when the batch
    advances. A batch of one is a world by itself; more are the copies of one batched world (``physics.batch``)."""

    worlds: list[WorldInterface]

    def advance(self, n_ticks: int, on_tick: Callable[[int], None] | None = None) -> None:
        """Run ``n_ticks`` ticks of every world, pumps on."""
        raise NotImplementedError

    def advance_sampled(self, n_ticks: int, every: int, on_tick=None) -> list[tuple[np.ndarray, np.ndarray]]:
        """Run ``n_ticks`` ticks of every world; each world's sampled unit poses, as its ``advance_sampled``."""
        raise NotImplementedError

    def advance_sampled_joined(self, n_ticks: int, every: int) -> tuple[np.ndarray, np.ndarray]:
        """``advance_sampled`` with the worlds' units side by side: (K, worlds x n_units, 3) and (..., 4)."""
        samples = self.advance_sampled(n_ticks, every)
        return np.concatenate([p for p, _ in samples], axis=1), np.concatenate([q for _, q in samples], axis=1)

    def unit_poses(self) -> tuple[np.ndarray, np.ndarray]:
        """Every world's ``unit_poses``, side by side."""
        poses = [world.unit_poses() for world in self.worlds]
        return np.concatenate([p for p, _ in poses]), np.concatenate([q for _, q in poses])

    def body_poses(self) -> tuple[np.ndarray, np.ndarray]:
        """Every world's ``poses()``, stacked: (worlds, n_bodies, 3) and (worlds, n_bodies, 4)."""
        poses = [world.poses() for world in self.worlds]
        return np.stack([p for p, _ in poses]), np.stack([q for _, q in poses])

    def set_phases(self, worlds: np.ndarray, phases: np.ndarray) -> None:
        """``set_phases`` of each of the worlds ``worlds`` (indices), ``phases`` (len(worlds), n_units) in order."""
        for index, values in zip(worlds, phases):
            self.worlds[index].set_phases(values)

    def ticks_in(self, duration: float) -> int:
        """Ticks in ``duration`` seconds: the worlds share their clock."""
        return self.worlds[0].ticks_in(duration)

    def close(self) -> None:
        """Release every world."""
        raise NotImplementedError

    def __enter__(self) -> Batch:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class Single(Batch):
    """A batch of one: the world itself, advanced as it advances alone (an observer ``on_tick`` sees it)."""

    def __init__(self, world: WorldInterface):
        self.worlds = [world]

    def advance(self, n_ticks, on_tick=None):
        self.worlds[0].advance(n_ticks, on_tick)

    def advance_sampled(self, n_ticks, every, on_tick=None):
        return [self.worlds[0].advance_sampled(n_ticks, every, on_tick)]

    def close(self):
        self.worlds[0].close()
