"""The ideal sensor: each unit's true displacement along its own forward axis (ground truth)."""

from __future__ import annotations

import numpy as np

from morphbench.sensing.base import Sensor, forward_axes


UNITS_AT_ONCE = 4096
"""units whose samples ``IdealSensor.sample_many`` takes at a time: each unit's arithmetic is its own, and blocks of
a few megabytes stay in the caches and in memory the process already holds (a measurement of 100,000 units at once
made hundreds of megabytes of new arrays, new pages to fault in every step)."""


class IdealSensor(Sensor):
    """Projects each sampled step of a unit's motion on its forward axis at the middle of that step."""

    def __init__(self, n_units: int, sample_period: float):
        self.sample_period = sample_period
        self._last_positions = np.zeros((n_units, 3))
        self._last_axes = np.zeros((n_units, 3))
        self._displacement = np.zeros(n_units)

    def reset(self, positions: np.ndarray, orientations: np.ndarray) -> None:
        self._last_positions = np.array(positions, dtype=float)
        self._last_axes = forward_axes(orientations)
        self._displacement = np.zeros(len(self._last_positions))

    def sample(self, positions: np.ndarray, orientations: np.ndarray) -> None:
        positions = np.asarray(positions, dtype=float)
        axes = forward_axes(orientations)
        mid_axes = self._last_axes + axes  # direction of the mean axis; its length is normalised below
        mid_axes /= np.linalg.norm(mid_axes, axis=1, keepdims=True)
        self._displacement += np.einsum("ij,ij->i", positions - self._last_positions, mid_axes)
        self._last_positions, self._last_axes = positions, axes

    def sample_many(self, positions: np.ndarray, orientations: np.ndarray) -> None:
        positions = np.asarray(positions, dtype=float)
        k, n = positions.shape[:2]
        if k == 0:
            return
        orientations = np.asarray(orientations)
        displacement, last_axes = np.empty(n), np.empty((n, 3))
        for first in range(0, n, UNITS_AT_ONCE):
            units = slice(first, first + UNITS_AT_ONCE)
            displacement[units], last_axes[units] = self._sample_units(positions[:, units], orientations[:, units],
                                                                        units)
        self._displacement, self._last_positions, self._last_axes = displacement, positions[-1], last_axes

    def _sample_units(self, positions: np.ndarray, orientations: np.ndarray, units: slice
                      ) -> tuple[np.ndarray, np.ndarray]:
        """``sample_many`` of the units ``units``, whose K samples are ``positions`` and ``orientations``: their
        displacements after the samples and their last forward axes."""
        k, n = positions.shape[:2]
        axes = forward_axes(np.reshape(orientations, (k * n, 4))).reshape(k, n, 3)
        # each sample's step from the one before (the first's from the last reset or sample), without copies of the
        # samples shifted by one: the same differences and sums, element by element
        steps, mid_axes = np.empty((k, n, 3)), np.empty((k, n, 3))
        np.subtract(positions[0], self._last_positions[units], out=steps[0])
        np.subtract(positions[1:], positions[:-1], out=steps[1:])
        np.add(self._last_axes[units], axes[0], out=mid_axes[0])
        np.add(axes[:-1], axes[1:], out=mid_axes[1:])
        mid_axes /= np.linalg.norm(mid_axes, axis=2, keepdims=True)
        moved = np.einsum("kij,kij->ki", steps, mid_axes)
        # Summed in sample order, as ``sample`` would: cumsum adds sequentially.
        return np.cumsum(np.concatenate([self._displacement[None, units], moved]), axis=0)[-1], axes[-1]

    def displacement(self) -> np.ndarray:
        return self._displacement.copy()
