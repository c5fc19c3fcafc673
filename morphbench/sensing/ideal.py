"""The ideal sensor: each unit's true displacement along its own forward axis (ground truth)."""

from __future__ import annotations

import numpy as np

from morphbench.sensing.base import Sensor, forward_axes


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
        axes = forward_axes(np.reshape(orientations, (k * n, 4))).reshape(k, n, 3)
        before = np.concatenate([self._last_positions[None], positions[:-1]])
        mid_axes = np.concatenate([self._last_axes[None], axes[:-1]]) + axes
        mid_axes /= np.linalg.norm(mid_axes, axis=2, keepdims=True)
        moved = np.einsum("kij,kij->ki", positions - before, mid_axes)
        # Summed in sample order, as ``sample`` would: cumsum adds sequentially.
        self._displacement = np.cumsum(np.concatenate([self._displacement[None], moved]), axis=0)[-1]
        self._last_positions, self._last_axes = positions[-1], axes[-1]

    def displacement(self) -> np.ndarray:
        return self._displacement.copy()
