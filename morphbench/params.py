"""Every parameter of a morphbench run, with its unit, meaning and default, in one place.

Lengths are metres, masses kilograms, times seconds, forces newtons. Velocities are reported in mm/cycle
(the paper's unit) only where they leave the simulation: in measurements, records and summaries.

The defaults are calibrated on the converged physics of a chain (the quasi-static model) so that the 2-unit phase
scan has the paper's shape (a forward maximum of about +4.5 mm/cycle near a phase difference of 0.4, a backward
minimum of about -4.5 near 0.6, no flat stretch) and 2-unit Thermal learners find the peak within about 20 steps;
docs/calibration.md says why each default is what it is, docs/fidelity.md has the figures.

Each field declares its allowed values beside it (``param(default, rule, unit)``: a ``Range``, ``Choices`` or type),
and that declaration is the only one: the rule engine (``morphbench.rules``: ``check`` / ``check_params``) serves
every file format (morphology files, run configurations, suites, through ``morphbench.readers.params_from_table``)
and the API (learners, sensors, ground and video check their parameters when built), and its ``field_option`` /
``option_type`` build the command-line option types. A value is accepted or refused the same way everywhere, with
one message: ``SOURCE: KEY: expected ..., got ...``. This module holds the declarations only: the dataclasses, the
limits, the presets and the rules across fields of a run.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Literal, get_args

from morphbench.errors import ConfigError
from morphbench.identity import identity, stable_hash
from morphbench.rules import Choices, OfType, Range, StepSpan, between, check_rule, param
# the rest of the rule engine, still importable from here (new code imports it from morphbench.rules)
from morphbench.rules import (
    Rule as Rule,
    check as check,
    check_params as check_params,
    check_plan_size as check_plan_size,
    expected as expected,
    field_option as field_option,
    option_type as option_type,
    rule_of as rule_of,
)

# --- limits: what a run, a scan and a suite may ask for --------------------------------------------------------


MAX_COUNT = 10_000
COUNT = between(1, MAX_COUNT, integer=True)
"""an integer in [1, 10000]: solver iterations, scan points per axis, cycles per scan point. More is hours of
simulation per tick or point, not a setting."""
NATURAL = between(0, MAX_COUNT, integer=True)
"""an integer in [0, 10000] (cycles that may be none)."""
BOOL = OfType(bool, "true or false")
TEXT = OfType(str, "a string")

MAX_STEPS = 1_000_000
STEPS = between(0, MAX_STEPS, integer=True)
"""learning steps of a run after the initial measurement (RunConfig.steps, a suite's steps, --steps). At most a
million: at the default 6 s per step that is 70 days of simulated time, days of wall time for a chain on the
quasi-static model, and about 100 bytes of records per unit and step held in memory; more is not a run anyone waits
for."""
SEED = between(0, 2**63 - 1, integer=True)
"""a seed (RunConfig.seed, a suite's seeds, --seed, ground, friction field and shuffle seeds): it is stored in int64
columns (records, suite tables)."""
DEFAULT_STEPS = 100
"""learning steps of a run when nothing says otherwise (RunConfig.steps, --steps)."""
DEFAULT_SEED = 0
"""a run's seed when nothing says otherwise (RunConfig.seed, --seed)."""
MAX_CYCLES_PER_STEP = 1000
CYCLES = between(1, MAX_CYCLES_PER_STEP, integer=True)
"""actuation cycles measured per learning step (--cycles-per-step): at most 1000 (over half an hour of simulated time
per step at the default cycle; the paper measures over 2)."""
MIN_TICKS_PER_PHASE = 4
"""physics ticks that the shorter of a cycle's pump and vent phases must span at least: fewer and the pump switches
within one tick, so the schedule is not resolved (and a phase shorter than a tick is none at all)."""
MAX_TICKS_PER_ADVANCE = 2_000_000
"""physics ticks in one stretch of warm-up, discarded or measured cycles at most: the pressures of a stretch are
computed at once (8 bytes per tick and bellows per array), so 2 million ticks is 16 MB per bellows."""
MAX_CLOCK_DRIFT = 0.05
"""a unit's clock rate error at most (EnvironmentParams.clock_drift): 5% is a free-running oscillator at its worst;
more and a unit's learning step would be another number of cycles, not the same step on a wrong clock."""
MAX_FIELD_WAVES = 1000
"""friction field period / correlation_length at most: the field holds one wave per ratio unit and evaluates them
on 2048 points to normalise (1000 waves are 16 MB)."""
MAX_SCAN_POINTS = 100_000
"""points of one scan at most (a 3-unit grid of resolution 316, or 100,000 samples): each point is a fresh world run
for its cycles (3 ms for chain-5 on the quasi-static model, a second on PyBullet: up to a day on one core); the plan
alone holds about SCAN_POINT_BYTES per point (`scan chain-3 --resolution 10000` asked for 10^8 points, 30 GB, and
ended in a MemoryError)."""
SCAN_POINT_BYTES = 300
"""bytes a scan's plan holds per point (its phases and job; measured with tracemalloc on chain-3)."""
MAX_SUITE_RUNS = 100_000
"""runs of one suite at most (22 times the paper suite's 4,480), counted before any is built: each is a run
directory and a row of every table, and the plan alone holds about SUITE_RUN_BYTES per run."""
SUITE_RUN_BYTES = 600
"""bytes a suite's plan holds per run (its spec, configuration and job; measured with tracemalloc on chain-2)."""

GRAVITY = 9.81
"""m/s^2."""
MIN_FRICTION_INERTIA = 10.0
"""The quasi-static model's range: ``friction_inertia`` at least this. The model neglects inertia, which holds while
friction dominates it; below 10 its gaits part from PyBullet's beyond the targets docs/fidelity.md sets between the
two (rms 0.4 mm/cycle over the 2-unit curve, 0.6 over 3-unit phases), and at a friction scale of 1e-6 the
quasi-static chain-2 still walks at +6.7 mm/cycle where PyBullet's glides at 0 (docs/fidelity.md, "Friction against
inertia")."""


SensorKind = Literal["optical", "camera", "ideal"]
SENSOR_KINDS: tuple[str, ...] = get_args(SensorKind)
DamageMode = Literal["no-inflate", "open", "stuck", "dead"]
DAMAGE_MODES: tuple[str, ...] = get_args(DamageMode)
"""no-inflate: the bellows cannot extend but pump, vibration and learner go on, and it stays as stiff as a bellows
holding air; open: the needle is gone (the paper's damage), so the bellows, open to the air, cannot extend and
resists with its wall only (``ActuatorParams.open_stiffness``); stuck: the bellows keeps its length; dead: the unit
stops everything (pump, vibration, learner)."""
FrictionTarget = Literal["all", "active", "passive"]
FRICTION_TARGETS: tuple[str, ...] = get_args(FrictionTarget)
"""the bodies a friction event changes: every body, the active units', or the passive ones' (the dummy's)."""
InitialMemory = Literal["measure", "-inf", "zero"]
INITIAL_MEMORY_CHOICES: tuple[str, ...] = get_args(InitialMemory)
LEARNER_HELP = ("thermal, flaky, averaged, adaptive, sparse, random (no learning), a centralized baseline (cmaes, "
                "random-search, hill-climber) or a plug-in package.module:Class (its directory on PYTHONPATH)")
"""How the command line names the learners (run, leaderboard): every built-in of learning.plugins.LEARNERS, which
tests/test_cli.py holds it to."""
PhysicsBackend = Literal["auto", "pybullet", "quasistatic", "dynamic"]
PHYSICS_BACKENDS: tuple[str, ...] = get_args(PhysicsBackend)
VideoView = Literal["auto", "side", "top"]
VIDEO_VIEWS: tuple[str, ...] = get_args(VideoView)
VideoColour = Literal["pressure", "phase"]
VIDEO_COLOURS: tuple[str, ...] = get_args(VideoColour)

# --- the parameters ------------------------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class UnitParams:
    """One active unit: a rigid box sliding on the ground."""

    length: float = param(0.060, between(0.001, 1), "m")
    """m, extent along the unit's forward axis (the actuator axis)."""
    width: float = param(0.040, between(0.001, 1), "m")
    """m, extent across the forward axis."""
    height: float = param(0.030, between(0.001, 1), "m")
    """m, vertical extent (every extent from 1 mm to 1 m: smaller bodies have no collision margin in Bullet)."""
    mass: float = param(0.050, between(0.001, 10), "kg")
    """kg, mass of the whole unit (body, pump, battery)."""
    friction: float = param(0.5, between(0, 10))
    """Coulomb friction coefficient against the ground (the ground itself is 1.0; Bullet multiplies the two)."""


@dataclass(frozen=True, kw_only=True)
class DummyParams:
    """The passive unit at the rear of a chain: no actuator, no pump, no learner.

    Its friction is 1.4x an active unit's: the paper explains its forward/backward asymmetry by the pump vibration
    lowering active units' friction (which a heavier-friction dummy stands in for), and equal friction everywhere
    makes the 2-unit curve antisymmetric and leaves even chains in a friction tie at equal phases.
    """

    mass: float = param(0.050, between(0.001, 10), "kg")
    """kg."""
    friction: float = param(0.7, between(0, 10))
    """Coulomb friction coefficient against the ground."""


@dataclass(frozen=True, kw_only=True)
class ActuatorParams:
    """A unit's pneumatic bellows, between the unit and its neighbour towards the dummy.

    The pump runs for a fraction ``alpha`` of each cycle starting at the unit's phase; pressure (0..1) rises towards 1
    with time constant ``tau_inflate`` while it runs and vents towards 0 with ``tau_vent`` (the needle is always
    open). The bellows is a spring-damper whose rest length is ``rest_gap + stroke * pressure``: unloaded it extends
    by the stroke, loaded it gives way by force / stiffness. Its force is capped at ``max_force``.
    """

    stroke: float = param(0.0105, between(1e-4, 0.1), "m")
    """m, extension at full pressure with no load. It scales the gait: 10.5 mm puts the quasi-static 2-unit
    curve's peak at +4.7 mm/cycle, the paper's 4.5 (docs/fidelity.md)."""
    rest_gap: float = param(0.010, between(1e-4, 0.1), "m")
    """m, gap between the two units' faces when the bellows is empty."""
    stiffness: float = param(300.0, between(1e-3, 1e10), "N/m")
    """N/m, axial stiffness of the bellows (up to 1e10: the quasi-static model takes a rigid link; PyBullet's
    explicit springs need a finer timestep above a few hundred)."""
    open_stiffness: float = param(30.0, between(1e-3, 1e10), "N/m", later=True)
    """N/m, axial stiffness of a bellows open to the air (damage 'open': the paper's removed needle). It holds no
    air, so it cannot inflate and only its elastomer wall resists being pushed or pulled; ``stiffness`` is that of
    a bellows holding air behind its needle."""
    damping: float = param(2.0, between(1e-6, 1e3), "N s/m")
    """N s/m, axial damping of the bellows."""
    max_force: float = param(5.0, between(1e-3, 1e3), "N")
    """N, the largest force the bellows exerts along its axis."""
    shear_stiffness: float = param(100.0, between(1e-3, 1e5), "N/m")
    """N/m, stiffness of a link against its two bodies sliding past each other across its axis (every link, passive
    ones too). A bellows is soft across as well as along; stiffer links need smaller PyBullet steps
    (docs/fidelity.md)."""
    shear_damping: float = param(0.3, between(1e-6, 1e3), "N s/m")
    """N s/m, damping of that shear motion (PyBullet and dynamic physics: the quasi-static model has no rates)."""
    bending_stiffness: float = param(0.1, between(1e-6, 100), "N m/rad")
    """N m/rad, stiffness of a link against its two bodies turning relative to each other across its axis: a body's
    friction torque (about 0.005 N m) bends a link by about 3 degrees."""
    twist_stiffness: float = param(0.05, between(1e-6, 100), "N m/rad")
    """N m/rad, stiffness against the two bodies turning relative to each other about the link's axis (PyBullet
    only: the planar model has no twist)."""
    rotational_damping: float = param(2e-4, between(1e-9, 1), "N m s/rad")
    """N m s/rad, damping of the relative rotation (PyBullet and dynamic physics)."""
    tau_inflate: float = param(0.3, between(1e-3, 100), "s")
    """s, pressure time constant while the pump runs."""
    tau_vent: float = param(0.3, between(1e-3, 100), "s")
    """s, pressure time constant while the bellows vents."""
    alpha: float = param(0.4, between(0.01, 0.99), "fraction of a cycle")
    """fraction of each cycle the pump runs, in [0.01, 0.99] (and both the pump and the vent phase must span a few
    physics ticks: ``check_timing``)."""
    cycle_time: float = param(2.0, between(0.01, 3600), "s")
    """s, duration of one actuation cycle (10 ms to an hour)."""


@dataclass(frozen=True, kw_only=True)
class PhysicsParams:
    """How the assembly's motion is computed: the backend and its integration settings."""

    backend: PhysicsBackend = param("auto", Choices(PHYSICS_BACKENDS))
    """'pybullet': rigid bodies on a ground plane (morphbench.physics.world), any shape; 'quasistatic': springs and
    Coulomb friction without inertia, exact and fast, for any assembly in one layer on the ground (solved along the
    axis for a chain, morphbench.physics.quasistatic, and in the plane otherwise, morphbench.physics.planar);
    'auto': quasistatic where it applies (dynamic for one-layer shapes other than chains of more than
    ``physics.AUTO_DYNAMIC_UNITS`` units, where the exact planar solver grows as N^1.6), pybullet for stacks (and for
    the camera sensor, which renders a PyBullet scene). The quasi-static model is the limit the PyBullet world
    converges to (docs/fidelity.md). 'dynamic': the same springs with inertia, planar rigid bodies with stick-slip
    Coulomb friction integrated at ``dynamic_step`` (morphbench.physics.dynamic), for any assembly in one layer on the
    ground, at any friction."""
    timestep: float = param(1 / 120, between(1e-4, 0.1), "s")
    """s, physics step (quasistatic: the interval between solves; the solution depends on time only through the
    pressures)."""
    solver_iterations: int = param(10, between(1, 1000, integer=True))
    """constraint solver iterations per physics step (pybullet only)."""
    substeps: int = param(1, between(1, 100, integer=True))
    """PyBullet steps (and link-force updates) per tick (pybullet only): the links' springs are explicit, so stiffer
    links than the default, and stacks, need 2 or more ('auto' gives a stack ``physics.STACK_SUBSTEPS``)."""
    settle_time: float = param(0.25, between(0, 60, low_inclusive=False), "s")
    """s, simulated before the first cycle so the units rest on the ground (pybullet only)."""
    cone_friction: bool = param(True, BOOL)
    """pybullet only: Bullet's implicit friction cone (True) or its pyramid of two friction directions per contact
    (False). Along a chain turned to any angle on the ground the cone is isotropic and the pyramid is not (it is
    18% slower at 30 degrees); a turning grid turns with the cone about as the planar model says, with a small
    chirality (a body twisted counter-clockwise slides a little more easily), and hardly at all with the pyramid
    (docs/fidelity.md, "In the plane")."""
    dynamic_step: float = param(1 / 240, between(1e-5, 0.1), "s", later=True)
    """s, dynamic backend only: its integration step at most. Each tick of ``timestep`` is split into
    ceil(timestep / dynamic_step) semi-implicit Euler steps (the bellows' rest lengths interpolated between the
    ticks' ends). The explicit springs bound it: with the default stiffnesses and 50 g units a sheet's fastest mode is
    205 rad/s, unstable at 1/120 s with the links' damping and stable from 1/180 s; at 1/240 s halving the step
    changes the 2-unit curve by 0.004 mm/cycle rms (benchmarks/dynamic_fidelity.py measures both). Stiffer links or
    lighter bodies need a smaller step (the fastest mode goes as sqrt(stiffness / mass))."""


DEFAULT_PHYSICS = PhysicsParams()
"""The default: the quasi-static model for shapes on the ground, the PyBullet world at the fast setting for stacks
(with ``physics.STACK_SUBSTEPS`` steps per tick)."""

FAST_PHYSICS = PhysicsParams(backend="pybullet")
"""PyBullet at a step the speed targets allow (docs/fidelity.md measures how far it is from converged)."""

REFERENCE_PHYSICS = PhysicsParams(backend="pybullet", timestep=1 / 240, solver_iterations=50)
"""Small step and many solver iterations: what the fast setting is measured against."""

QUASISTATIC_PHYSICS = PhysicsParams(backend="quasistatic", timestep=1 / 200)
"""The inertia-free limit of the same assembly: the oracle of the PyBullet world, and a fast backend for chains."""

DYNAMIC_PHYSICS = PhysicsParams(backend="dynamic")
"""The same springs with inertia and stick-slip friction (morphbench.physics.dynamic): every body a planar rigid
body, integrated in steps of ``dynamic_step`` (two per 1/120 s tick), linear in the assembly's size; for one layer
on the ground at any friction. 'auto' picks it for one-layer shapes other than chains of more than
``physics.AUTO_DYNAMIC_UNITS`` units."""

PHYSICS_PRESETS = {"default": DEFAULT_PHYSICS, "fast": FAST_PHYSICS, "reference": REFERENCE_PHYSICS,
                   "quasistatic": QUASISTATIC_PHYSICS, "dynamic": DYNAMIC_PHYSICS}
PHYSICS_PRESET = Choices(tuple(PHYSICS_PRESETS))
"""a physics preset by name (a run configuration's [physics] preset, a suite's physics, --physics)."""


@dataclass(frozen=True, kw_only=True)
class LearnerParams:
    """Each unit's learner. Every unit gets its own copy and its own random stream."""

    step_size: float = param(0.1, Range(0, 1, high_inclusive=True), "cycles")
    """delta_s: a trial phase is the kept phase plus uniform(-1, 1) * step_size, modulo 1 (the 'adaptive' learner's
    first step size)."""
    temperature: float = param(0.6, Range(0, math.inf, high_inclusive=True), "mm/cycle")
    """T, mm/cycle: a worse trial (lower velocity by d) is accepted with probability exp(-d / T). Chosen as the
    paper reports for its simulations (Fig. 2B): a noiseless 3-unit Thermal run accepts about 25% of trials once
    learned (0.22 at 0.6, 0.26 at 0.7: docs/fidelity.md, "Temperature"); of the two, 0.6 also keeps S6's freeze
    (docs/calibration.md)."""
    cycles_per_step: int = param(2, CYCLES, "cycles")
    """n_act: actuation cycles per learning step; a measurement is the displacement over them / n_act."""
    warmup_cycles: int = param(1, between(0, MAX_CYCLES_PER_STEP, integer=True), "cycles")
    """cycles the units run at their initial phases before the first measurement, so that step 0 does not
    measure the start from rest (the first extension from rest is a one-off transient of several mm)."""
    discard_cycles: int = param(0, between(0, MAX_CYCLES_PER_STEP, integer=True), "cycles")
    """cycles run after each phase change before the measurement starts: none, as in the paper (a learning step is
    its 2 actuation cycles: "20 learning iterations" are 80 s). A measurement that starts at a phase change also
    holds the change of the unit's own offset in the chain, several mm/cycle; 1 leaves that edge effect out
    (docs/fidelity.md, S1 with 0 and 1)."""
    initial_memory: InitialMemory = param("measure", Choices(INITIAL_MEMORY_CHOICES))
    """what the memory holds before the first trial: 'measure' (velocity at the initial phase), '-inf' or 'zero'."""
    memory_weight: float = param(0.5, between(0, 1, low_inclusive=False), later=True)
    """beta, the 'averaged' learner's only own field: after every trial its memory moves the fraction beta of the
    way to the measured velocity, memory <- (1 - beta) memory + beta U', an exponential average of its measurements
    over about 1 / beta steps; 1 is Flaky."""
    adapt_rate: float = param(0.2, between(0, 5), later=True)
    """c, of the 'adaptive' learner: after every ``adapt_window`` trials its step size is multiplied by exp(c) if
    it accepted more than ``target_acceptance`` of them, by exp(-c) if fewer; 0 keeps step_size (Thermal)."""
    adapt_window: int = param(10, COUNT, "steps", later=True)
    """the trials the 'adaptive' learner's acceptance rate is counted over before each change of its step size."""
    target_acceptance: float = param(0.4, Range(0, 1, low_inclusive=False), later=True)
    """the acceptance rate the 'adaptive' learner steers to. Not the 1/5 rule's 0.2: a learned Thermal unit accepts
    0.2-0.35 of trials at step 0.1, so 0.2 grows the step and loses, where 0.4 gains (docs/learners.md)."""
    step_size_min: float = param(0.01, between(0, 1, low_inclusive=False), "cycles", later=True)
    """the smallest step size the 'adaptive' learner shrinks to."""
    step_size_max: float = param(0.5, between(0, 1, low_inclusive=False), "cycles", later=True)
    """the largest step size the 'adaptive' learner grows to (at least step_size_min; 0.5 already reaches every
    phase)."""
    trial_probability: float = param(0.25, Range(0, 1, low_inclusive=False, high_inclusive=True), later=True)
    """p0, of the 'sparse' learner: each learning step a unit tries a new phase with probability
    p = max(trial_probability_min, p0 / (1 + t / trial_decay_steps)), t its own learning steps so far (0 at its
    first), else keeps its phase and takes the step's measurement as its memory; p = 1 tries every step (Thermal's
    rule, with that refresh)."""
    trial_decay_steps: int = param(0, NATURAL, "steps", later=True)
    """tau, of the 'sparse' learner: the unit's own steps over which its trial probability halves (p0 / (1 + t /
    tau)): many units try at first, when any change helps, fewer once the gait is found and a trial mostly disturbs
    the others. 0 keeps p = trial_probability. A unit counts only its own steps (its own clock, no global signal)."""
    trial_probability_min: float = param(0.05, between(0, 1), later=True)
    """the floor the decaying trial probability stops at (at most trial_probability), so that a unit never stops
    trying: the assembly can still re-learn after its ground or its body changes (continuous learning)."""


LEARNER_PRESETS: dict[str, LearnerParams] = {
    "sparse": LearnerParams(step_size=0.05, temperature=0.01, cycles_per_step=1, discard_cycles=1,
                            trial_probability=0.5, trial_decay_steps=100),
}
"""The learners whose own settings differ from LearnerParams' defaults, by ``--learner`` name: what a run of that
learner starts from (a file's or an option's fields on top). The sparse learner's: small steps, a cold temperature
(a single unit's effect in a chain of 20 is 0.3-1.5 mm/cycle, against Thermal's 0.6), and each 2-cycle step judged on
its second cycle, after its first has carried the phase change's transient (docs/learners.md)."""


def learner_defaults(name: str) -> LearnerParams:
    """The parameters a run of learner ``name`` starts from: its preset (``LEARNER_PRESETS``), else the defaults."""
    return LEARNER_PRESETS.get(name.strip().lower(), LearnerParams()) if isinstance(name, str) else LearnerParams()


def check_learner(params: LearnerParams, source: str, prefix: str = "") -> LearnerParams:
    """``params`` if every field is allowed and the adaptive learner's step sizes and the sparse learner's trial
    probabilities are ordered, else ConfigError naming the first bad key (``prefix`` + field)."""
    check_params(params, source, prefix)
    if params.step_size_min > params.step_size_max:
        raise ConfigError(source, f"{prefix}step_size_max", f"a step size >= step_size_min "
                          f"({params.step_size_min:g} cycles)", params.step_size_max)
    if params.trial_decay_steps and params.trial_probability_min > params.trial_probability:
        raise ConfigError(source, f"{prefix}trial_probability_min", f"a probability <= trial_probability "
                          f"({params.trial_probability:g})", params.trial_probability_min)
    return params



@dataclass(frozen=True, kw_only=True)
class FrictionFieldParams:
    """Ground friction that varies with position: mu(x, y) = mu0 (1 + amplitude f(x, y)), f a smooth periodic random
    field with values in [-1, 1], the same for every body (mu0 is the body's own friction)."""

    amplitude: float = param(0.0, Range(0, 1))
    """a, in [0, 1): 0 is a uniform ground; docs/paper.md suggests 0.2-0.4."""
    correlation_length: float = param(0.06, between(0.001, 100), "m")
    """m, shortest wavelength in the field (about one unit)."""
    period: float = param(2.0, between(0.01, 1e4), "m")
    """m, the field repeats with this period along x (and y): the length of the paper's circular track, unrolled."""
    two_d: bool = param(False, BOOL)
    """false: the field varies along x only (a track); true: along x and y (a plane)."""
    seed: int = param(1, SEED)
    """the same seed gives the same field."""
    offset: float = param(0.0, between(0, 1e4), "m", later=True)
    """m, where on the track the assembly starts: the field is read at x + offset (its features shifted by offset
    along x, the same track), so scans at offsets 0, period / 4, ... measure one gait at places along one track
    (benchmarks/paper-hardware.toml, claim hw-3-track); 0 reads it as before."""


@dataclass(frozen=True, kw_only=True)
class EnvironmentParams:
    """The world the robot runs in; events can change some of it during a run (morphbench.experiment.events)."""

    friction_scale: float = param(1.0, between(0, 100, low_inclusive=False))
    """multiplies every body's friction (a friction drop is an event that changes it)."""
    vibration: float = param(1.0, between(0, 10, low_inclusive=False))
    """factor on an active unit's friction while its own pump runs (the pump shakes the unit); 1 is no vibration,
    docs/paper.md suggests 0.8. The dummy never vibrates."""
    noise: float = param(0.0, between(0, 1000), "mm/cycle")
    """mm/cycle, standard deviation of Gaussian noise added to each measured velocity, on top of the sensor's own."""
    noise_ground: float = param(0.0, Range(0, 1), "fraction", later=True)
    """how the noise depends on the ground: a unit's noise is ``noise`` times (1 + noise_ground f(x, y)) where it
    stands at the end of its measurement, f the shape of ``friction_field`` (in [-1, 1], read at the same offset),
    so that where the track's surface changes its friction it changes what the optical sensor sees too (its error
    grows as the ground's contrast falls: docs/sensing.md, 0.04 to 0.33 mm/cycle from contrast 0.5 to 0.1). 0: the
    same everywhere. The field of the run's environment, whatever its amplitude; a friction event does not change
    it."""
    friction_field: FrictionFieldParams = field(default_factory=FrictionFieldParams)
    ground: GroundParams = field(default_factory=lambda: GroundParams())
    """the texture optical sensors look at (and videos show)."""
    clock_drift: float = param(0.0, between(0, MAX_CLOCK_DRIFT), "fraction of the cycle time", later=True)
    """each unit's own clock runs at its own rate: its pump period is cycle_time * (1 + e), e drawn per unit uniform
    over [-clock_drift, clock_drift] from the run's seed (a stream of its own, streams.CLOCK_STREAM), from 0 (one
    shared clock) to 0.05; a crystal is off by tens of ppm (1e-5), an RC oscillator by about 1%. The phase between
    two units then drifts by (e_i - e_j) cycles per cycle unless their learners hold it, and a unit measures over
    cycles_per_step of its own cycles (docs/sensing.md, "Units with their own clocks")."""
    clock_offset: float = param(0.0, between(0, 1), "fraction of a learning step", later=True)
    """each unit starts its learning steps at its own moment: offset o drawn per unit uniform over [0, clock_offset]
    of a learning step ((discard_cycles + cycles_per_step) cycles) from the same stream; 0 is every unit changing
    phase at once. A unit's measurement window then overlaps its neighbours' phase changes. Per-unit learners only
    (a centralized controller measures every unit at once)."""


@dataclass(frozen=True, kw_only=True)
class GroundParams:
    """The textured ground that optical sensors look at: one tile, procedural or from an image file, centred on the
    world origin and repeated over the whole plane (morphbench.sensing.ground)."""

    image: str = param("", TEXT)
    """path of an image file used as the tile, read in greyscale; '' makes a procedural tile from the fields below."""
    seed: int = param(1, SEED)
    """seed of the procedural tile: the same seed gives the same ground."""
    grain: float = param(0.003, between(1e-6, 1), "m")
    """m, feature size of the procedural tile: standard deviation of the Gaussian that smooths its white noise
    (2 pixels of the default optical sensor, which Lucas-Kanade tracks best)."""
    contrast: float = param(0.5, Range(0, 1, low_inclusive=False, high_inclusive=True))
    """in (0, 1], of the procedural tile: its grey levels have a standard deviation of contrast / 6 of the full range
    around mid-grey, so +-3 standard deviations span this fraction of black to white."""
    resolution: float = param(0.0015, between(1e-6, 1), "m")
    """m, ground size of one tile pixel, for a procedural tile and an image file alike (the default is the optical
    sensor's pixel size)."""
    length: float = param(2.0, between(0, 1e4, low_inclusive=False), "m")
    """m, procedural tile's extent along the world x axis (an image's extent is its size times the resolution)."""
    width: float = param(0.5, between(0, 1e4, low_inclusive=False), "m")
    """m, procedural tile's extent along the world y axis."""


DEFAULT_ENVIRONMENT = EnvironmentParams()
"""The paper's simulations: a uniform ground, no vibration, no noise, one shared clock."""

HARDWARE_ENVIRONMENT = EnvironmentParams(
    vibration=0.866,
    noise=0.247,
    friction_field=FrictionFieldParams(amplitude=0.412, correlation_length=0.213, period=2.0, seed=1),
    clock_drift=0.00079,
    clock_offset=1.0,
)
"""The paper's robots on their track (docs/hardware.md): the effects morphbench has that its experiments show and
its simulations do not, all at once. CALIBRATED against the experiments' findings, not set by hand: the best of
``python benchmarks/calibrate.py --targets hardware --trials 40 --seeds 8`` (CMA-ES over the effects alone,
docs/calibration-hardware.md) after its two best candidates were scored again at the paper's 56 experiment seeds
(16.80 against 17.40), to three digits.

- ``vibration`` 0.866: a unit's friction while its own pump runs (the dummy never vibrates), the paper's explanation
  of the experiments' forward/backward asymmetry (Results of Two Units).
- ``friction_field``: +-41% (amplitude 0.412, a little above docs/paper.md's 0.2-0.4; the search allowed 0-0.5),
  features no shorter than 0.213 m (stretches of a few robot lengths, where a gait may stop: Fig. 2F), repeating
  every 2 m (the circular track, unrolled: the paper's main text gives no size; 2 m is the field's own default; not
  searched), seed 1.
- ``noise`` 0.247 mm/cycle: Gaussian noise on each measured velocity, the low end of SI Fig. S5's 0.25-1.
- ``clock_drift`` 0.00079: each unit's pump period off by up to 0.08% (a ceramic resonator; 1% stops learning:
  docs/sensing.md); ``clock_offset`` 1 (not searched): each unit starts its learning steps at its own moment (no
  shared clock).

A scan measures the preset's ground and pumps only (``scan_environment``: no noise, one clock)."""

ENVIRONMENT_PRESETS: dict[str, EnvironmentParams] = {"default": DEFAULT_ENVIRONMENT, "hardware": HARDWARE_ENVIRONMENT}
ENVIRONMENT_PRESET = Choices(tuple(ENVIRONMENT_PRESETS))
"""an environment preset by name (a run file's ``environment = "hardware"`` or ``[environment] preset``, a suite's
experiment or scan ``environment``, ``run --environment``, ``scan --environment``); fields beside ``preset`` override
the preset's, key by key (a ``friction_field`` sub-table field by field)."""


def scan_environment(environment: EnvironmentParams) -> EnvironmentParams:
    """What a scan of ``environment`` measures in: its ground and pumps (friction scale and field, vibration), without
    its measurement noise or clocks of their own (a scan measures the true velocity at fixed phases on one clock)."""
    return dataclasses.replace(environment, noise=0.0, noise_ground=0.0, clock_drift=0.0, clock_offset=0.0)


def environment_id(environment: EnvironmentParams) -> str:
    """A hash of the ground and pumps a run or scan moves on: what a scan of the environment measures in
    (``scan_environment``: without the measurement noise and the units' clocks, which change what and when learners
    measure, not the landscape). A scan's best Ubar is compared with, and its landscape drawn under, the runs on the
    same ground, so runs with clocks of their own (the preset 'hardware') find their scans too."""
    data = identity(scan_environment(environment))
    data.pop("noise", None)
    return stable_hash(data)


@dataclass(frozen=True, kw_only=True)
class OpticalParams:
    """Each unit's optical motion sensor (morphbench.sensing.optical): a small camera on the unit's underside that
    looks straight down at the ground, like an optical mouse, and tracks the image's motion between frames.

    Scaled to what the simulation affords: a real mouse sensor takes thousands of frames a second of pixels of about
    0.05 mm. Here 8 frames a second of 1.5 mm pixels keep the sensor's cost under a tenth of the physics' while the
    fastest units (up to about 10 mm per frame in long chains) still move only a few pixels between frames, the
    regime a mouse sensor works in. Finer pixels lower the error in mm but need a proportionally higher frame rate
    (units would move more pixels per frame), and the cost grows with the frame rate.
    """

    frame_rate: float = param(8.0, between(0, 1e4, low_inclusive=False), "Hz")
    """Hz, frames per second: the sensor's sample rate."""
    patch_size: int = param(32, Range(16, 256, high_inclusive=True, integer=True), "px")
    """px, side of the square image: at least 16 (Lucas-Kanade needs a window of 7 px or more and room for it to
    move), at most 256 (a bigger one would cost more than the physics)."""
    pixel_size: float = param(0.0015, between(1e-6, 0.1), "m")
    """m, ground size of one image pixel when the sensor looks straight down (its nominal resolution)."""
    noise: float = param(0.01, between(0, 10), "fraction of the grey range")
    """standard deviation of the Gaussian noise added to every pixel, as a fraction of the black-to-white range."""
    blur: float = param(0.0, between(0, 100), "px")
    """px, standard deviation of a Gaussian blur of the optics, applied before the noise (0: none)."""
    liftoff_height: float = param(0.0015, between(0, 1, low_inclusive=False), "m")
    """m, above this height over the ground the sensor reports no motion, as a mouse does when lifted."""
    mount_x: float = param(0.0, between(-1, 1), "m")
    """m, the sensor's position along the unit's forward axis, from the unit's centre."""
    mount_y: float = param(0.0, between(-1, 1), "m")
    """m, the sensor's position along the unit's left axis, from the unit's centre."""
    mount_depth: float = param(0.015, between(-1, 1), "m")
    """m, how far below the unit's centre (along the unit's own down axis) the sensor sits: half the unit's height
    puts it on the underside, where a unit resting on the ground has zero lift."""


@dataclass(frozen=True, kw_only=True)
class SensorParams:
    """How each unit measures its own displacement along its own forward axis."""

    kind: SensorKind = param("optical", Choices(SENSOR_KINDS))
    """'optical': an optical-flow sensor under the unit looking at the textured ground (OpticalParams), its images
    cut out of the texture; 'camera': the same sensor with its images rendered by PyBullet's own camera (about 60x
    slower, for validation); 'ideal': the unit's true displacement (ground truth, also recorded as u_true in every
    run)."""
    sample_period: float = param(0.125, between(0, 3600, low_inclusive=False), "s")
    """s, how often the ideal sensor reads the unit's pose; the ground truth of an optical run is sampled at the
    optical frame rate instead, so both read the same poses."""
    optical: OpticalParams = field(default_factory=lambda: OpticalParams())



_FRAME_PIXELS = Range(16, 4096, high_inclusive=True, integer=True, even=True)
"""px, a video frame's side (even: the codecs need it)."""


@dataclass(frozen=True, kw_only=True)
class VideoParams:
    """An off-screen video of a run (morphbench.render): what it shows, how big, how fast. The container follows the
    output file's suffix: .mp4 (H.264 through PyAV; without it, through OpenCV: H.264 where its build can write it,
    else MPEG-4 part 2) or .gif."""

    width: int = param(640, _FRAME_PIXELS, "px")
    """px, frame width (an even number)."""
    height: int = param(360, _FRAME_PIXELS, "px")
    """px, frame height (an even number)."""
    fps: float = param(30.0, Range(0, 240, low_inclusive=False, high_inclusive=True), "frames per second")
    """frames per second of the output video (at most 50 for a GIF: browsers slow faster GIFs down)."""
    speed: float = param(1.0, between(0, 1e5, low_inclusive=False), "simulated seconds per video second")
    """playback speed: simulated seconds per video second (> 1 is a time-lapse); a frame every speed / fps
    simulated seconds."""
    steps: tuple[int, int | None] | None = param(None, StepSpan(STEPS))
    """learning steps to show, (first, last) inclusive, last None for 'to the end'; None shows every step. Step 0
    includes the warm-up before it."""
    distance: float = param(0.0, between(0, 1000), "m; 0 fits the assembly")
    """m, from the camera to the point it looks at; 0 picks one that fits the whole assembly in the frame."""
    pitch: float = param(-30.0, Range(-89, 0, high_inclusive=True), "degrees; negative looks down")
    """degrees, camera elevation: 0 looks horizontally, -90 straight down. The camera looks along +y, so forward (+x)
    motion runs left to right in the image."""
    follow: bool = param(True, BOOL)
    """True: the camera follows the assembly (its mean body position, smoothed); False: it stays where it started."""
    follow_time: float = param(4.0, between(0, 1e5, low_inclusive=False), "simulated seconds")
    """s of simulated time, time constant of the camera's smoothing (two cycles by default, so it does not shake with
    each pump stroke)."""
    overlay: bool = param(True, BOOL)
    """draw simulated time, learning step, Ubar and each unit's phase on the frames (the top view leaves the phases
    out: its colours can show them)."""
    view: VideoView = param("auto", Choices(VIDEO_VIEWS))
    """'side': the 3-D camera (PyBullet's TinyRenderer) from the side and above; 'top': every body's footprint seen
    from straight above, drawn with numpy (morphbench.render.topdown; shapes in one layer on the ground only), fast
    for sheets of thousands of units; 'auto': top for one-layer shapes of more than ``render.checks.AUTO_TOP_UNITS``
    units, side otherwise."""
    colour: VideoColour = param("pressure", Choices(VIDEO_COLOURS))
    """what a unit's colour shows: 'pressure', its bellows' pressure (blue empty, red full); 'phase', its kept phase
    (the learner's, updated at the end of each learning step) on a cyclic colour map, so a travelling wave shows as
    bands of hue."""


# --- rules across fields: checked wherever a RunConfig is built -------------------------------------------------------


def friction_inertia(shape: Any, environment: EnvironmentParams, friction_scale: float | None = None
                     ) -> tuple[float, float, float, float]:
    """How many times the assembly's friction exceeds the inertial force of its bellows' motion, per unit of mass:
    mu g / (stroke / tau^2) (dimensionless), with mu, tau (s) and stroke (m). A bellows starts to extend or retract
    with the acceleration stroke / tau^2 (its pressure follows exp(-t / tau)): the largest stroke, the faster time
    constant. mu is the bodies' mean friction coefficient weighted by mass, times ``friction_scale`` (the
    environment's by default), at its lowest: where the pumps' vibration (if below 1) and the friction field's troughs
    (1 - amplitude) lower it. Masses and stiffness cancel out: in the PyBullet runs that measured the bound
    (docs/fidelity.md) 4 times the mass or a third of the stiffness parted from the quasi-static model at the same
    friction scale."""
    scale = environment.friction_scale if friction_scale is None else friction_scale
    mass = sum(body.mass for body in shape.bodies)
    mu = sum(body.mass * body.friction for body in shape.bodies) / mass * scale * min(1.0, environment.vibration) \
        * (1.0 - environment.friction_field.amplitude)
    actuator = shape.actuator
    stroke = max([actuator.stroke] + [link.stroke for link in shape.links if link.stroke is not None])
    tau = min(actuator.tau_inflate, actuator.tau_vent)
    return mu * GRAVITY * tau**2 / stroke, mu, tau, stroke


def check_quasistatic_friction(shape: Any, environment: EnvironmentParams, source: str,
                               friction_scale: float | None = None) -> None:
    """ConfigError naming ``source`` and environment.friction_scale unless the quasi-static model holds for
    ``shape`` in ``environment`` (with ``friction_scale`` instead of the environment's, if given):
    ``friction_inertia`` at least MIN_FRICTION_INERTIA."""
    scale = environment.friction_scale if friction_scale is None else friction_scale
    ratio, mu, tau, stroke = friction_inertia(shape, environment, scale)
    if ratio >= MIN_FRICTION_INERTIA:
        return
    needed = f"a friction_scale >= {scale * MIN_FRICTION_INERTIA / ratio:.3g}" if ratio > 0 else "bodies with friction"
    raise ConfigError(source, "environment.friction_scale",
                      f"{needed} on the quasi-static physics, which holds only while friction is at least "
                      f"{MIN_FRICTION_INERTIA:g} times the bellows' inertial force (mu g tau^2 / stroke = {ratio:.3g} "
                      f"with mu {mu:.3g}, tau {tau:g} s, stroke {stroke:g} m; docs/fidelity.md): use the PyBullet "
                      "physics (--physics fast or reference)", scale)


def check_run(config: Any, source: str) -> None:
    """ConfigError naming ``source`` unless the fields of a RunConfig fit together: steps and seed in range, the pump
    and the vent phase each spanning MIN_TICKS_PER_PHASE physics ticks, a stretch of cycles (warm-up, discarded,
    measured) at most MAX_TICKS_PER_ADVANCE ticks, the friction field at most MAX_FIELD_WAVES waves per period, a
    clock drift whose fast clocks still measure within their step, and on the quasi-static backend friction within
    the model's range (``check_quasistatic_friction``)."""
    check_rule(STEPS, "", config.steps, source, "steps")
    check_rule(SEED, "", config.seed, source, "seed")
    actuator, physics, learner = config.shape.actuator, config.physics, config.learner_params
    check_learner(learner, source, "learner.")
    tick, cycle = physics.timestep, actuator.cycle_time
    shorter = min(actuator.alpha, 1 - actuator.alpha)
    if shorter * cycle < MIN_TICKS_PER_PHASE * tick:
        raise ConfigError(source, "actuator.cycle_time",
                          f"a cycle_time >= {MIN_TICKS_PER_PHASE * tick / shorter:g} s, so that with alpha "
                          f"{actuator.alpha:g} the pump and the vent phase each last {MIN_TICKS_PER_PHASE} physics "
                          f"ticks of {tick:g} s", cycle)
    cycles = max(learner.warmup_cycles, learner.discard_cycles, learner.cycles_per_step)
    if cycles * cycle / tick > MAX_TICKS_PER_ADVANCE:
        raise ConfigError(source, "learner.cycles_per_step",
                          f"at most {int(MAX_TICKS_PER_ADVANCE * tick / cycle)} cycles in a stretch of warm-up, "
                          f"discarded or measured cycles ({MAX_TICKS_PER_ADVANCE} physics ticks of {tick:g} s)",
                          cycles)
    friction = config.environment.friction_field
    if friction.period / friction.correlation_length > MAX_FIELD_WAVES:
        raise ConfigError(source, "environment.friction_field.correlation_length",
                          f"at least period / {MAX_FIELD_WAVES} = {friction.period / MAX_FIELD_WAVES:g} m",
                          friction.correlation_length)
    if physics.backend == "quasistatic":  # 'auto' is checked where it picks its model (physics.make_world)
        check_quasistatic_friction(config.shape, config.environment, source)
