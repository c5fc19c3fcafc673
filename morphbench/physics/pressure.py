"""The pump schedule and the bellows' first-order pressure, integrated exactly over control ticks (pure numpy).

The pump of a unit with phase phi is on while ``((t / cycle_time) - phi) mod 1 < alpha``. Pressure relaxes towards 1
with time constant ``tau_inflate`` while the pump runs and towards 0 with ``tau_vent`` otherwise. Switches are taken
at their exact times inside a tick, so velocity varies smoothly with phase instead of in steps of one tick.
"""

from __future__ import annotations

import numba
import numpy as np

from morphbench.params import ActuatorParams


def pump_on(t: float, phases: np.ndarray, actuator: ActuatorParams) -> np.ndarray:
    """Whether each pump runs at time t (s) for the given phases."""
    return np.mod(t / actuator.cycle_time - np.asarray(phases), 1.0) < actuator.alpha


def pressure_trajectory(
    pressure: np.ndarray, phases: np.ndarray, t0: float, tick: float, n_ticks: int, actuator: ActuatorParams
) -> np.ndarray:
    """Pressure of each bellows at the end of each of ``n_ticks`` ticks of ``tick`` s starting at time ``t0``.

    Returns an (n_ticks, n) array. A tick must be shorter than both the on and the off part of a cycle, so each
    pump switches at most once per tick.
    """
    T, alpha = actuator.cycle_time, actuator.alpha
    if not tick < min(alpha, 1 - alpha) * T:
        raise ValueError(f"control tick {tick} s must be shorter than the pump's on and off times")
    phases = np.asarray(phases, dtype=float)
    starts = t0 + tick * np.arange(n_ticks)[:, None]  # (n_ticks, 1)
    cycle_pos = np.mod(starts / T - phases, 1.0)  # (n_ticks, n), in cycles
    on = cycle_pos < alpha
    until_switch = np.where(on, alpha - cycle_pos, 1.0 - cycle_pos) * T
    first = np.minimum(until_switch, tick)  # s spent in the state the tick starts in
    second = tick - first  # s spent in the other state
    # Each segment maps p -> target + (p - target) * decay; compose both segments into one affine map per tick.
    decay_on, decay_off = np.exp(-first / actuator.tau_inflate), np.exp(-first / actuator.tau_vent)
    a1 = np.where(on, decay_on, decay_off)
    b1 = np.where(on, 1.0 - decay_on, 0.0)
    decay2_on, decay2_off = np.exp(-second / actuator.tau_inflate), np.exp(-second / actuator.tau_vent)
    a2 = np.where(on, decay2_off, decay2_on)  # the second segment is in the flipped state
    b2 = np.where(on, 0.0, 1.0 - decay2_on)
    a, b = a1 * a2, b1 * a2 + b2
    return _affine_recurrence(np.asarray(pressure, dtype=float), a, b)


@numba.njit(cache=True)
def _affine_recurrence(p0, a, b):
    """p_k = a_k p_{k-1} + b_k for every tick k (sequential: compiled, it costs nanoseconds a tick)."""
    out = np.empty_like(a)
    p = p0.copy()
    for k in range(a.shape[0]):
        for i in range(a.shape[1]):
            p[i] = a[k, i] * p[i] + b[k, i]
            out[k, i] = p[i]
    return out
