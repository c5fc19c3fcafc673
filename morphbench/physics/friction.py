"""Position-dependent ground friction: a smooth periodic random field f with values in [-1, 1] (numpy, and a
compiled twin for the quasi-static solvers' tick loops)."""

from __future__ import annotations

import numba
import numpy as np

from morphbench.params import FrictionFieldParams
from morphbench.streams import FRICTION_STREAM

N_MODES_2D = 48  # random wave vectors summed in a 2-D field
GRID = 2048  # samples per period used to normalise the field to [-1, 1]


class FrictionField:
    """f(x, y) = sum_m a_m cos(2 pi (kx_m x + ky_m y) / period + theta_m), scaled so that max |f| = 1.

    Wave numbers are integers (so f repeats with ``period``) up to period / correlation_length, with amplitudes that
    fall off with wave number, so features are no smaller than the correlation length. A field with an ``offset`` is
    the field without one read at x + offset.
    """

    def __init__(self, params: FrictionFieldParams):
        self.params = params
        rng = np.random.default_rng(np.random.SeedSequence([params.seed, FRICTION_STREAM]))
        k_max = max(1, int(round(params.period / params.correlation_length)))
        if params.two_d:
            k = rng.integers(-k_max, k_max + 1, size=(N_MODES_2D, 2))
            k = k[np.any(k != 0, axis=1)]
        else:
            k = np.stack([np.arange(1, k_max + 1), np.zeros(k_max, dtype=int)], axis=1)
        magnitude = np.linalg.norm(k, axis=1)
        self._k = k.astype(float)
        self._amplitude = rng.normal(size=len(k)) * np.exp(-0.5 * (magnitude / (0.5 * k_max)) ** 2)
        self._theta = rng.uniform(0, 2 * np.pi, size=len(k))
        self._scale = 1.0
        grid = np.linspace(0, params.period, GRID, endpoint=False)
        if params.two_d:
            gx, gy = np.meshgrid(grid[::8], grid[::8])
            peak = np.abs(self(gx.ravel(), gy.ravel())).max()
        else:
            peak = np.abs(self(grid, np.zeros_like(grid))).max()
        self._scale = 1.0 / peak
        if params.offset:  # f(x + offset): the same field (its scale measured above), read further along the track
            self._theta = self._theta + (2 * np.pi / params.period) * self._k[:, 0] * params.offset

    def __call__(self, x, y) -> np.ndarray:
        """f at the given points (m); arrays of equal shape."""
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        arg = (2 * np.pi / self.params.period) * (np.multiply.outer(x, self._k[:, 0])
                                                  + np.multiply.outer(y, self._k[:, 1]))
        return self._scale * np.cos(arg + self._theta) @ self._amplitude

    def friction(self, mu0, x, y) -> np.ndarray:
        """mu(x, y) = mu0 (1 + amplitude f(x, y))."""
        return np.asarray(mu0) * (1.0 + self.params.amplitude * self(x, y))

    def compiled(self) -> tuple[np.ndarray, np.ndarray]:
        """The field as ``factors`` takes it: (modes, 4) rows kx, ky, amplitude, phase, and the constants
        2 pi / period, scale and the friction amplitude."""
        modes = np.column_stack([self._k, self._amplitude, self._theta])
        return modes, np.array([2 * np.pi / self.params.period, self._scale, self.params.amplitude])


NO_FIELD = (np.zeros((0, 4)), np.zeros(3))
"""``FrictionField.compiled`` of a uniform ground (no modes: every factor is 1)."""


@numba.njit(cache=True, nogil=True)
def factors(x, y, modes, constants, out):
    """``FrictionField.friction(1, x, y)`` into ``out``, one point at a time (for compiled loops)."""
    wave, scale, amplitude = constants[0], constants[1], constants[2]
    for b in range(len(x)):
        total = 0.0
        for m in range(modes.shape[0]):
            total += np.cos(wave * (x[b] * modes[m, 0] + y[b] * modes[m, 1]) + modes[m, 3]) * modes[m, 2]
        out[b] = 1.0 + amplitude * (scale * total)
