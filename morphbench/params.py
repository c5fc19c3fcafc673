"""Every parameter of a morphbench run, with its unit, meaning and default, in one place.

Lengths are metres, masses kilograms, times seconds, forces newtons. Velocities are reported in mm/cycle
(the paper's unit) only where they leave the simulation: in measurements, records and summaries.

The defaults are calibrated on the converged physics of a chain (the quasi-static model) so that the 2-unit phase
scan has the paper's shape (a forward maximum of about +4.5 mm/cycle near a phase difference of 0.4, a backward
minimum of about -4.5 near 0.6, no flat stretch) and 2-unit Thermal learners find the peak within about 20 steps;
docs/calibration.md says why each default is what it is, docs/fidelity.md has the figures.
"""

from __future__ import annotations

from dataclasses import dataclass, field


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

    Its friction is 1.4x an active unit's: the paper explains its forward/backward asymmetry by the pump vibration
    lowering active units' friction (which a heavier-friction dummy stands in for), and equal friction everywhere
    makes the 2-unit curve antisymmetric and leaves even chains in a friction tie at equal phases.
    """

    mass: float = 0.050
    """kg."""
    friction: float = 0.7
    """Coulomb friction coefficient against the ground."""


@dataclass(frozen=True, kw_only=True)
class ActuatorParams:
    """A unit's pneumatic bellows, between the unit and its neighbour towards the dummy.

    The pump runs for a fraction ``alpha`` of each cycle starting at the unit's phase; pressure (0..1) rises towards 1
    with time constant ``tau_inflate`` while it runs and vents towards 0 with ``tau_vent`` (the needle is always
    open). The bellows is a spring-damper whose rest length is ``rest_gap + stroke * pressure``: unloaded it extends
    by the stroke, loaded it gives way by force / stiffness. Its force is capped at ``max_force``.
    """

    stroke: float = 0.0105
    """m, extension at full pressure with no load. It scales the gait: 10.5 mm puts the quasi-static 2-unit
    curve's peak at +4.7 mm/cycle, the paper's 4.5 (docs/fidelity.md)."""
    rest_gap: float = 0.010
    """m, gap between the two units' faces when the bellows is empty."""
    stiffness: float = 300.0
    """N/m, axial stiffness of the bellows."""
    damping: float = 2.0
    """N s/m, axial damping of the bellows."""
    max_force: float = 5.0
    """N, the largest force the bellows exerts along its axis."""
    shear_stiffness: float = 100.0
    """N/m, stiffness of a link against its two bodies sliding past each other across its axis (every link, passive
    ones too). A bellows is soft across as well as along; stiffer links need smaller PyBullet steps (docs/fidelity.md)."""
    shear_damping: float = 0.3
    """N s/m, damping of that shear motion (PyBullet only: the quasi-static model has no rates)."""
    bending_stiffness: float = 0.1
    """N m/rad, stiffness of a link against its two bodies turning relative to each other across its axis: a body's
    friction torque (about 0.005 N m) bends a link by about 3 degrees."""
    twist_stiffness: float = 0.05
    """N m/rad, stiffness against the two bodies turning relative to each other about the link's axis (PyBullet
    only: the planar model has no twist)."""
    rotational_damping: float = 2e-4
    """N m s/rad, damping of the relative rotation (PyBullet only)."""
    tau_inflate: float = 0.3
    """s, pressure time constant while the pump runs."""
    tau_vent: float = 0.3
    """s, pressure time constant while the bellows vents."""
    alpha: float = 0.4
    """fraction of each cycle the pump runs, in (0, 1)."""
    cycle_time: float = 2.0
    """s, duration of one actuation cycle."""


@dataclass(frozen=True, kw_only=True)
class PhysicsParams:
    """How the assembly's motion is computed: the backend and its integration settings."""

    backend: str = "auto"
    """'pybullet': rigid bodies on a ground plane (morphbench.physics.world), any shape; 'quasistatic': springs and
    Coulomb friction without inertia, exact and fast, for any assembly in one layer on the ground (solved along the
    axis for a chain, morphbench.physics.quasistatic, and in the plane otherwise, morphbench.physics.planar);
    'auto': quasistatic where it applies, pybullet for stacks (and for the camera sensor, which renders a PyBullet
    scene). The quasi-static model is the limit the PyBullet world converges to (docs/fidelity.md)."""
    timestep: float = 1 / 120
    """s, physics step (quasistatic: the interval between solves; the solution depends on time only through the
    pressures)."""
    solver_iterations: int = 10
    """constraint solver iterations per physics step (pybullet only)."""
    substeps: int = 1
    """PyBullet steps (and link-force updates) per tick (pybullet only): the links' springs are explicit, so stiffer
    links than the default, or stacks of three layers or more, need 2 or more."""
    settle_time: float = 0.25
    """s, simulated before the first cycle so the units rest on the ground (pybullet only)."""
    cone_friction: bool = True
    """pybullet only: Bullet's implicit friction cone (True) or its pyramid of two friction directions per contact
    (False). Along a chain turned to any angle on the ground the cone is isotropic and the pyramid is not (it is
    18% slower at 30 degrees); a turning grid turns with the cone about as the planar model says, with a small
    chirality (a body twisted counter-clockwise slides a little more easily), and hardly at all with the pyramid
    (docs/fidelity.md, "In the plane")."""


PHYSICS_BACKENDS = ("auto", "pybullet", "quasistatic")

DEFAULT_PHYSICS = PhysicsParams()
"""The default: the quasi-static model for shapes on the ground, the PyBullet world at the fast setting for stacks."""

FAST_PHYSICS = PhysicsParams(backend="pybullet")
"""PyBullet at a step the speed targets allow (docs/fidelity.md measures how far it is from converged)."""

REFERENCE_PHYSICS = PhysicsParams(backend="pybullet", timestep=1 / 240, solver_iterations=50)
"""Small step and many solver iterations: what the fast setting is measured against."""

QUASISTATIC_PHYSICS = PhysicsParams(backend="quasistatic", timestep=1 / 200)
"""The inertia-free limit of the same assembly: the oracle of the PyBullet world, and a fast backend for chains."""

PHYSICS_PRESETS = {"default": DEFAULT_PHYSICS, "fast": FAST_PHYSICS, "reference": REFERENCE_PHYSICS, "quasistatic": QUASISTATIC_PHYSICS}


@dataclass(frozen=True, kw_only=True)
class LearnerParams:
    """Each unit's learner. Every unit gets its own copy and its own random stream."""

    step_size: float = 0.1
    """delta_s: a trial phase is the kept phase plus uniform(-1, 1) * step_size, modulo 1."""
    temperature: float = 0.5
    """T, mm/cycle: a worse trial (lower velocity by d) is accepted with probability exp(-d / T). Chosen as the
    spec asks: a noiseless 3-unit Thermal run accepts about 25% of trials once learned (docs/fidelity.md)."""
    cycles_per_step: int = 2
    """n_act: actuation cycles per learning step; a measurement is the displacement over them / n_act."""
    warmup_cycles: int = 1
    """cycles the units run at their initial phases before the first measurement, so that step 0 does not
    measure the start from rest (the first extension from rest is a one-off transient of several mm)."""
    discard_cycles: int = 1
    """cycles run after each phase change before the measurement starts. Without one, a unit's 2-cycle measurement
    also holds the change of its own offset in the chain between the window's edges, several mm/cycle after a phase
    change; the paper (whose velocity calculation is in a supplement we lack) reaches its first result only
    without that edge effect (docs/fidelity.md, S1 with 0 and 1)."""
    initial_memory: str = "measure"
    """what the memory holds before the first trial: 'measure' (velocity at the initial phase), '-inf' or 'zero'."""


INITIAL_MEMORY_CHOICES = ("measure", "-inf", "zero")




@dataclass(frozen=True, kw_only=True)
class FrictionFieldParams:
    """Ground friction that varies with position: mu(x, y) = mu0 (1 + amplitude f(x, y)), f a smooth periodic random
    field with values in [-1, 1], the same for every body (mu0 is the body's own friction)."""

    amplitude: float = 0.0
    """a, in [0, 1): 0 is a uniform ground; the spec suggests 0.2-0.4."""
    correlation_length: float = 0.06
    """m, shortest wavelength in the field (about one unit)."""
    period: float = 2.0
    """m, the field repeats with this period along x (and y): the length of the paper's circular track, unrolled."""
    two_d: bool = False
    """false: the field varies along x only (a track); true: along x and y (a plane)."""
    seed: int = 1
    """the same seed gives the same field."""


DAMAGE_MODES = ("no-inflate", "stuck", "dead")
"""no-inflate: the needle is gone, the bellows cannot extend but pump, vibration and learner go on; stuck: the
bellows keeps its length; dead: the unit stops everything (pump, vibration, learner)."""


@dataclass(frozen=True, kw_only=True)
class EnvironmentParams:
    """The world the robot runs in; events can change some of it during a run (morphbench.experiment.events)."""

    friction_scale: float = 1.0
    """multiplies every body's friction (a friction drop is an event that changes it)."""
    vibration: float = 1.0
    """factor on an active unit's friction while its own pump runs (the pump shakes the unit); 1 is no vibration,
    the spec suggests 0.8. The dummy never vibrates."""
    noise: float = 0.0
    """mm/cycle, standard deviation of Gaussian noise added to each measured velocity, on top of the sensor's own."""
    friction_field: FrictionFieldParams = field(default_factory=FrictionFieldParams)
    ground: GroundParams = field(default_factory=lambda: GroundParams())
    """the texture optical sensors look at (and videos show)."""


@dataclass(frozen=True, kw_only=True)
class GroundParams:
    """The textured ground that optical sensors look at: one tile, procedural or from an image file, centred on the
    world origin and repeated over the whole plane (morphbench.sensing.ground)."""

    image: str = ""
    """path of an image file used as the tile, read in greyscale; '' makes a procedural tile from the fields below."""
    seed: int = 1
    """seed of the procedural tile: the same seed gives the same ground."""
    grain: float = 0.003
    """m, feature size of the procedural tile: standard deviation of the Gaussian that smooths its white noise
    (2 pixels of the default optical sensor, which Lucas-Kanade tracks best)."""
    contrast: float = 0.5
    """in (0, 1], of the procedural tile: its grey levels have a standard deviation of contrast / 6 of the full range
    around mid-grey, so +-3 standard deviations span this fraction of black to white."""
    resolution: float = 0.0015
    """m, ground size of one tile pixel, for a procedural tile and an image file alike (the default is the optical
    sensor's pixel size)."""
    length: float = 2.0
    """m, procedural tile's extent along the world x axis (an image's extent is its size times the resolution)."""
    width: float = 0.5
    """m, procedural tile's extent along the world y axis."""


@dataclass(frozen=True, kw_only=True)
class OpticalParams:
    """Each unit's optical motion sensor (morphbench.sensing.optical): a small camera on the unit's underside that
    looks straight down at the ground, like an optical mouse, and tracks the image's motion between frames.

    Scaled to what the simulation affords: a real mouse sensor takes thousands of frames a second of pixels of about
    0.05 mm. Here 8 frames a second of 1.5 mm pixels keep the sensor's cost under a tenth of the physics' while the
    fastest units (up to about 10 mm per frame in long chains) still move only a few pixels between frames, the
    regime a mouse sensor works in. Finer pixels lower the error in mm but need a proportionally higher frame rate (units
    would move more pixels per frame), and the cost grows with the frame rate.
    """

    frame_rate: float = 8.0
    """Hz, frames per second: the sensor's sample rate."""
    patch_size: int = 32
    """px, side of the square image."""
    pixel_size: float = 0.0015
    """m, ground size of one image pixel when the sensor looks straight down (its nominal resolution)."""
    noise: float = 0.01
    """standard deviation of the Gaussian noise added to every pixel, as a fraction of the black-to-white range."""
    blur: float = 0.0
    """px, standard deviation of a Gaussian blur of the optics, applied before the noise (0: none)."""
    liftoff_height: float = 0.0015
    """m, above this height over the ground the sensor reports no motion, as a mouse does when lifted."""
    mount_x: float = 0.0
    """m, the sensor's position along the unit's forward axis, from the unit's centre."""
    mount_y: float = 0.0
    """m, the sensor's position along the unit's left axis, from the unit's centre."""
    mount_depth: float = 0.015
    """m, how far below the unit's centre (along the unit's own down axis) the sensor sits: half the unit's height
    puts it on the underside, where a unit resting on the ground has zero lift."""


@dataclass(frozen=True, kw_only=True)
class SensorParams:
    """How each unit measures its own displacement along its own forward axis."""

    kind: str = "optical"
    """'optical': an optical-flow sensor under the unit looking at the textured ground (OpticalParams), its images
    cut out of the texture; 'camera': the same sensor with its images rendered by PyBullet's own camera (about 60x
    slower, for validation); 'ideal': the unit's true displacement (ground truth, also recorded as u_true in every
    run)."""
    sample_period: float = 0.125
    """s, how often the ideal sensor reads the unit's pose; the ground truth of an optical run is sampled at the
    optical frame rate instead, so both read the same poses."""
    optical: OpticalParams = field(default_factory=lambda: OpticalParams())


SENSOR_KINDS = ("optical", "camera", "ideal")


@dataclass(frozen=True, kw_only=True)
class VideoParams:
    """An off-screen video of a run (morphbench.render): what it shows, how big, how fast. The container follows the
    output file's suffix: .mp4 (H.264 where this OpenCV build can write it, else MPEG-4 part 2) or .gif."""

    width: int = 640
    """px, frame width (an even number)."""
    height: int = 360
    """px, frame height (an even number)."""
    fps: float = 30.0
    """frames per second of the output video (at most 50 for a GIF: browsers slow faster GIFs down)."""
    speed: float = 1.0
    """playback speed: simulated seconds per video second (> 1 is a time-lapse); a frame every speed / fps
    simulated seconds."""
    steps: tuple[int, int | None] | None = None
    """learning steps to show, (first, last) inclusive, last None for 'to the end'; None shows every step. Step 0
    includes the warm-up before it."""
    distance: float = 0.0
    """m, from the camera to the point it looks at; 0 picks one that fits the whole assembly in the frame."""
    pitch: float = -30.0
    """degrees, camera elevation: 0 looks horizontally, -90 straight down. The camera looks along +y, so forward (+x)
    motion runs left to right in the image."""
    follow: bool = True
    """True: the camera follows the assembly (its mean body position, smoothed); False: it stays where it started."""
    follow_time: float = 4.0
    """s of simulated time, time constant of the camera's smoothing (two cycles by default, so it does not shake with
    each pump stroke)."""
    overlay: bool = True
    """draw simulated time, learning step, Ubar and each unit's phase on the frames."""
