"""The sensor interface: how a unit learns its own displacement, from its own pose only.

A ``Sensor`` is a bank of identical per-unit sensors (one row per active unit) so a run makes one call per sample,
not one per unit; row i only ever reads unit i's pose. Poses come from the physics as plain arrays, so sensors are
pure numpy and testable without a simulator.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np


def forward_axes(orientations: np.ndarray) -> np.ndarray:
    """Unit vectors of each body's own +x axis in the world, from (N, 4) quaternions (x, y, z, w)."""
    x, y, z, w = np.asarray(orientations, dtype=float).T
    axes = np.empty((len(x), 3))
    axes[:, 0], axes[:, 1], axes[:, 2] = 1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y)
    return axes


def tilts(orientations: np.ndarray) -> np.ndarray:
    """Degrees of each body's own z axis from the vertical, from (N, 4) quaternions (x, y, z, w), normalised first."""
    q = np.asarray(orientations, dtype=float)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    upright = 1.0 - 2.0 * (q[:, 0] ** 2 + q[:, 1] ** 2)  # the z component of the body's own z axis
    return np.degrees(np.arccos(np.clip(upright, -1.0, 1.0)))


class Sensor(ABC):
    """Measures each unit's displacement along its own forward axis, integrated between ``reset`` calls."""

    sample_period: float
    """s, how often the run loop calls ``sample``."""

    @abstractmethod
    def reset(self, positions: np.ndarray, orientations: np.ndarray) -> None:
        """Start a new measurement at the given poses: (N, 3) positions in m, (N, 4) quaternions (x, y, z, w)."""

    @abstractmethod
    def sample(self, positions: np.ndarray, orientations: np.ndarray) -> None:
        """Integrate the motion since the previous sample (or reset)."""

    def sample_many(self, positions: np.ndarray, orientations: np.ndarray) -> None:
        """``sample`` at K poses in turn: (K, N, 3) positions and (K, N, 4) quaternions, oldest first (a bank may
        do it at once, with the same result)."""
        for p, q in zip(positions, orientations):
            self.sample(p, q)

    @abstractmethod
    def displacement(self) -> np.ndarray:
        """m, (N,) displacement of each unit along its own forward axis since the last reset."""
