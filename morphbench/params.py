"""Every parameter of a morphbench run, with its unit, meaning and default, in one place.

Lengths are metres, masses kilograms, times seconds, forces newtons. Velocities are reported in mm/cycle
(the paper's unit) only where they leave the simulation: in measurements, records and summaries.

The defaults are calibrated so that the 2-unit phase scan reproduces the paper's curve (forward maximum of about
+4.5 mm/cycle near a phase difference of 0.4, backward minimum of about -3 to -4 near 0.6, zero at equal phases);
see docs/calibration.md for the measured curve and how it moves with each parameter.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True, kw_only=True)
class UnitParams:
    """One active unit: a rigid box sliding on the ground."""

    length: float = 0.060
    """m, extent along the unit's forward axis (the actuator axis)."""
    width: float = 0.040
    """m, extent across the forward axis."""
    height: float = 0.030
    """m, vertical extent."""
    mass: float = 0.050
    """kg, mass of the whole unit (body, pump, battery)."""
    friction: float = 0.5
    """Coulomb friction coefficient against the ground (the ground itself is 1.0; Bullet multiplies the two)."""


@dataclass(frozen=True, kw_only=True)
class DummyParams:
    """The passive unit at the rear of a chain: no actuator, no pump, no learner.

    Its friction is 1.2x an active unit's: the paper explains its forward/backward asymmetry by the pump vibration
    lowering active units' friction, and equal friction everywhere leaves an even chain drifting at equal phases.
    """

    mass: float = 0.050
    """kg."""
    friction: float = 0.6
    """Coulomb friction coefficient against the ground."""


@dataclass(frozen=True, kw_only=True)
class ActuatorParams:
    """A unit's pneumatic bellows, between the unit and its neighbour towards the dummy.

    The pump runs for a fraction ``alpha`` of each cycle starting at the unit's phase; pressure (0..1) rises towards 1
    with time constant ``tau_inflate`` while it runs and vents towards 0 with ``tau_vent`` (the needle is always
    open). The bellows extends by ``stroke * pressure`` beyond ``rest_gap``. It is force-limited: it cannot push or
    pull harder than ``max_force``, so a long chain can stall it.
    """

    stroke: float = 0.0086
    """m, extension at full pressure."""
    rest_gap: float = 0.010
    """m, gap between the two units' faces when the bellows is empty."""
    max_force: float = 5.0
    """N, the largest force the bellows exerts along its axis (stall force)."""
    tau_inflate: float = 0.2
    """s, pressure time constant while the pump runs."""
    tau_vent: float = 0.3
    """s, pressure time constant while the bellows vents."""
    alpha: float = 0.4
    """fraction of each cycle the pump runs, in (0, 1)."""
    cycle_time: float = 2.0
    """s, duration of one actuation cycle."""


@dataclass(frozen=True, kw_only=True)
class PhysicsParams:
    """Integration settings of the PyBullet world."""

    timestep: float = 1 / 120
    """s, physics step."""
    solver_iterations: int = 10
    """constraint solver iterations per physics step."""
    substeps: int = 2
    """physics steps per control tick: actuator targets change once per tick (a tick of 1/60 s resolves
    pressure time constants of 0.2 s)."""
    settle_time: float = 0.25
    """s, simulated before the first cycle so the units rest on the ground."""


FAST_PHYSICS = PhysicsParams()
"""The default: fast, and within a few percent of the reference landscape (docs/calibration.md)."""

REFERENCE_PHYSICS = PhysicsParams(timestep=1 / 240, solver_iterations=50, substeps=4)
"""Small step and many solver iterations: what the fast setting is measured against."""

PHYSICS_PRESETS = {"fast": FAST_PHYSICS, "reference": REFERENCE_PHYSICS}


@dataclass(frozen=True, kw_only=True)
class LearnerParams:
    """Each unit's learner. Every unit gets its own copy and its own random stream."""

    step_size: float = 0.1
    """delta_s: a trial phase is the kept phase plus uniform(-1, 1) * step_size, modulo 1."""
    temperature: float = 0.2
    """T, mm/cycle: a worse trial (lower velocity by d) is accepted with probability exp(-d / T)."""
    cycles_per_step: int = 2
    """n_act: actuation cycles per learning step; a measurement is the displacement over them / n_act."""
    initial_memory: str = "measure"
    """what the memory holds before the first trial: 'measure' (velocity at the initial phase), '-inf' or 'zero'."""


INITIAL_MEMORY_CHOICES = ("measure", "-inf", "zero")


@dataclass(frozen=True, kw_only=True)
class SensorParams:
    """How each unit measures its own displacement."""

    kind: str = "ideal"
    """'ideal': the unit's true displacement along its own forward axis."""
    noise: float = 0.0
    """mm/cycle, standard deviation of Gaussian noise added to each measured velocity."""
    sample_period: float = 0.1
    """s, how often the sensor reads the unit's pose and integrates its forward displacement."""


SENSOR_KINDS = ("ideal",)
