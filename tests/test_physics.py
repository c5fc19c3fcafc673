"""Physics checked against physics: cases whose answer is known without a simulator."""

import numpy as np
import pytest

from morphbench.experiment import velocity_at
from morphbench.params import FAST_PHYSICS, ActuatorParams
from morphbench.physics import World, pressure_trajectory, pump_on

from conftest import chain


def test_pressure_matches_fine_integration():
    """The exact per-tick integration agrees with a fine explicit integration of dp/dt = (target - p) / tau."""
    actuator = ActuatorParams()
    phases = np.array([0.0, 0.137, 0.5, 0.93])
    tick, n_ticks = 1 / 60, 240
    exact = pressure_trajectory(np.zeros(4), phases, 0.0, tick, n_ticks, actuator)
    fine_dt, p, fine = 1e-4, np.zeros(4), []
    for k in range(n_ticks):
        for j in range(round(tick / fine_dt)):
            t = k * tick + j * fine_dt
            on = pump_on(t + fine_dt / 2, phases, actuator)
            tau = np.where(on, actuator.tau_inflate, actuator.tau_vent)
            p = p + fine_dt * (on.astype(float) - p) / tau
        fine.append(p)
    assert np.max(np.abs(exact - np.array(fine))) < 2e-3


def test_pressure_varies_smoothly_with_phase():
    """Switches inside a tick are taken at their exact time: a phase shift of a tenth of a tick moves pressure a bit,
    not by a whole tick's worth or not at all."""
    actuator, tick = ActuatorParams(), 1 / 60
    shift = 0.1 * tick / actuator.cycle_time
    a, b = (pressure_trajectory(np.zeros(1), np.array([phi]), 0.0, tick, 240, actuator) for phi in (0.3, 0.3 + shift))
    difference = np.max(np.abs(a - b))
    assert 0 < difference < 0.02


def test_pressure_rises_while_pumping_and_vents_after():
    actuator = ActuatorParams()
    p = pressure_trajectory(np.zeros(1), np.zeros(1), 0.0, 1 / 60, 120, actuator)[:, 0]
    on_ticks = round(actuator.alpha * 120)
    assert np.all(np.diff(p[:on_ticks]) > 0) and np.all(np.diff(p[on_ticks + 1:]) < 0)
    assert p[on_ticks - 1] == pytest.approx(1 - np.exp(-actuator.alpha * actuator.cycle_time / actuator.tau_inflate),
                                            abs=1e-9)


@pytest.mark.parametrize("phase", [0.0, 0.25, 0.7])
def test_one_unit_and_a_dummy_do_not_travel(phase):
    """One bellows only extends and contracts along the same path: reciprocal motion makes no net progress."""
    u = velocity_at(chain(1), [phase], physics=FAST_PHYSICS, cycles=6)
    assert abs(u[0]) < 0.3, u


def test_bellows_extends_with_pressure_and_gives_way_under_friction():
    """While the pump runs the bodies move apart by the stroke times the pressure, less the spring's give under the
    sliding unit's friction (mu m g / k); after venting they come back to within that give of the empty length."""
    shape = chain(1)
    actuator, unit = shape.actuator, shape.bodies[0]
    give = unit.friction * unit.mass * 9.81 / actuator.stiffness
    with World(shape) as world:
        gap = lambda: -np.diff(world.poses()[0][:, 0])[0]  # noqa: E731
        empty = gap()
        world.set_phases([0.0])
        on_time = actuator.alpha * actuator.cycle_time
        world.advance(world.ticks_in(on_time))
        inflated = gap()
        world.advance(world.ticks_in(actuator.cycle_time - on_time))
        vented = gap()
    p_on = 1 - np.exp(-on_time / actuator.tau_inflate)
    p_end = p_on * np.exp(-(actuator.cycle_time - on_time) / actuator.tau_vent)
    assert inflated - empty == pytest.approx(actuator.stroke * p_on - give, rel=0.1)
    assert vented - empty == pytest.approx(actuator.stroke * p_end + give, rel=0.25)


@pytest.mark.parametrize("units", [2, 3])
def test_peristaltic_wave_moves_forward_and_reversed_wave_backward(units):
    """Pumps firing from front to back, alpha apart, push the chain forward; the mirrored order pulls it back."""
    alpha = ActuatorParams().alpha
    wave = np.arange(units) * alpha % 1.0
    forward = velocity_at(chain(units), wave, physics=FAST_PHYSICS, cycles=6).mean()
    backward = velocity_at(chain(units), (-wave) % 1.0, physics=FAST_PHYSICS, cycles=6).mean()
    assert forward > 2.0, forward
    assert backward < -1.0, backward


@pytest.mark.parametrize("units", [2, 3])
def test_equal_phases_give_no_systematic_drift(units):
    """All bellows in step only stretch and shrink the chain: any drift is small next to a real gait."""
    alpha = ActuatorParams().alpha
    gait = velocity_at(chain(units), np.arange(units) * alpha % 1.0, physics=FAST_PHYSICS, cycles=6).mean()
    drift = velocity_at(chain(units), np.zeros(units), physics=FAST_PHYSICS, cycles=6).mean()
    assert abs(drift) < 0.15 * gait, (drift, gait)


def test_symmetric_friction_gives_antisymmetric_scan():
    """With equal friction on every body the 2-unit curve is antisymmetric: Ubar(d) = -Ubar(1 - d)."""
    shape = chain(2, dummy={"friction": 0.5})
    ahead, behind = (velocity_at(shape, [0.0, x], physics=FAST_PHYSICS, cycles=6).mean() for x in (0.4, 0.6))
    assert ahead > 2.0
    assert ahead == pytest.approx(-behind, rel=0.3)
