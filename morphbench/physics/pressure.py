"""The pump schedule and the bellows' first-order pressure, integrated exactly over control ticks (pure numpy).

The pump of a unit with phase phi is on while ``((t / period) - phi) mod 1 < alpha``, its period the cycle time
(or its own clock's, ``EnvironmentParams.clock_drift``). Pressure relaxes towards 1
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
    pressure: np.ndarray, phases: np.ndarray, t0: float, tick: float, n_ticks: int, actuator: ActuatorParams,
    periods: np.ndarray | None = None
) -> np.ndarray:
    """Pressure of each bellows at the end of each of ``n_ticks`` ticks of ``tick`` s starting at time ``t0``;
    ``periods`` (s), each pump's cycle (the actuator's cycle time by default).

    Returns an (n_ticks, n) array. A tick must be shorter than both the on and the off part of a cycle, so each
    pump switches at most once per tick.
    """
    alpha = actuator.alpha
    periods = np.full(len(phases), actuator.cycle_time) if periods is None else np.asarray(periods, dtype=float)
    if len(periods) and not tick < min(alpha, 1 - alpha) * periods.min():
        raise ValueError(f"control tick {tick} s must be shorter than the pump's on and off times")
    return _trajectory(np.asarray(pressure, dtype=float), np.asarray(phases, dtype=float), float(t0), float(tick),
                       int(n_ticks), periods, float(alpha), float(actuator.tau_inflate), float(actuator.tau_vent))


@numba.njit(cache=True, nogil=True)
def _trajectory(p0, phases, t0, tick, n_ticks, periods, alpha, tau_inflate, tau_vent):
    """Per tick and bellows: the time spent in the state the tick starts in, then in the other; each part maps
    p -> target + (p - target) * decay, composed into one affine map, applied in sequence (compiled: a tick without
    a switch, nearly all of them, costs one multiply-add)."""
    n = len(phases)
    out = np.empty((n_ticks, n))
    p = p0.copy()
    whole_on, whole_off = np.exp(-tick / tau_inflate), np.exp(-tick / tau_vent)
    for k in range(n_ticks):
        start = t0 + tick * k
        for i in range(n):
            T = periods[i]
            position = (start / T - phases[i]) % 1.0  # in cycles since the pump last switched on
            on = position < alpha
            first = min(((alpha - position) if on else (1.0 - position)) * T, tick)
            if first == tick:
                a, b = (whole_on, 1.0 - whole_on) if on else (whole_off, 0.0)
            else:  # the pump switches inside this tick
                second = tick - first
                if on:
                    decay, after = np.exp(-first / tau_inflate), np.exp(-second / tau_vent)
                    a, b = decay * after, (1.0 - decay) * after
                else:
                    decay, after = np.exp(-first / tau_vent), np.exp(-second / tau_inflate)
                    a, b = decay * after, 1.0 - after
            p[i] = a * p[i] + b
            out[k, i] = p[i]
    return out
