"""The run loop: one world, one sensor bank, one controller (one learner per unit, or a centralized baseline),
learning steps of ``cycles_per_step`` cycles.

A run is driven through the phases of ``RunLoop`` by ``experiment.driver`` (``run``, ``run_batch``); the scans
measure fixed phases with ``measure``.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from morphbench.errors import ConfigError, PhysicsError
from morphbench.identity import shape_id
from morphbench.experiment.records import RunRecords
from morphbench.learning import Controller
from morphbench.experiment.events import CutEvent, Event, RunState, describe, parse_events
from morphbench.params import (
    DEFAULT_PHYSICS,
    DEFAULT_SEED,
    DEFAULT_STEPS,
    SENSOR_KINDS,
    EnvironmentParams,
    FrictionFieldParams,
    GroundParams,
    LearnerParams,
    PhysicsParams,
    SensorParams,
    check_run,
    learner_defaults,
)
from morphbench.physics import WorldInterface
from morphbench.physics.bellows import link_spans
from morphbench.physics.friction import FrictionField
from morphbench.physics.camera import CameraGround
from morphbench.readers import params_from_dict
from morphbench.sensing import GroundTexture, IdealSensor, OpticalSensor, Sensor
from morphbench.sensing.base import forward_axes, tilts
from morphbench.shapes import Shape, load_shape
from morphbench.streams import NOISE_STREAM, OPTICAL_STREAM


@dataclass(frozen=True, kw_only=True)
class RunConfig:
    """Everything that determines a run: the same config and seed give identical records."""

    shape: Shape
    learner: str = "thermal"
    """'thermal', 'flaky', 'averaged', 'adaptive', 'random', a centralized 'cmaes', 'random-search',
    'hill-climber', or a plug-in 'package.module:Class'."""
    learner_params: LearnerParams = None  # type: ignore[assignment]  # None: the learner's own (__post_init__)
    """the learners' parameters; by default the learner's own (``params.learner_defaults``)."""
    sensor: SensorParams = field(default_factory=SensorParams)
    environment: EnvironmentParams = field(default_factory=EnvironmentParams)
    events: tuple[Event, ...] = ()
    """applied at the start of their learning step (morphbench.experiment.events)."""
    physics: PhysicsParams = DEFAULT_PHYSICS
    steps: int = DEFAULT_STEPS
    """learning steps after the initial measurement (step 0)."""
    seed: int = DEFAULT_SEED

    def __post_init__(self):
        if self.learner_params is None:
            object.__setattr__(self, "learner_params", learner_defaults(self.learner))
        check_run(self, self.shape.source)

    def to_dict(self) -> dict:
        """JSON-ready: the shape by its file, every parameter by field (what summary.json stores)."""
        data = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        # The shape file by absolute path, so that a run can be replayed from anywhere.
        source = Path(self.shape.source)
        data["shape"] = {"name": self.shape.name, "source": str(source.resolve()) if source.is_file() else str(source),
                         "n_units": self.shape.n_units, "id": shape_id(self.shape)}  # checked at replay
        for key in ("learner_params", "sensor", "environment", "physics"):
            data[key] = dataclasses.asdict(data[key])
        data["events"] = [e.settings() for e in self.events]  # each its kind, step and own fields
        return data

    @classmethod
    def from_dict(cls, data: dict, source: str = "summary.json") -> RunConfig:
        """The config ``to_dict`` wrote, its shape reloaded from its file (to replay a finished run)."""
        try:
            shape = load_shape(data["shape"]["source"])
            return cls(
                shape=shape,
                learner=data["learner"],
                learner_params=params_from_dict(LearnerParams, data["learner_params"]),
                sensor=params_from_dict(SensorParams, data["sensor"]),
                environment=params_from_dict(EnvironmentParams, data["environment"]),
                events=parse_events(data["events"], source, shape.n_units, len(shape.links)),
                physics=params_from_dict(PhysicsParams, data["physics"]),
                steps=data["steps"],
                seed=data["seed"],
            )
        except (KeyError, TypeError) as exc:
            raise ConfigError(source, "config", f"a run configuration written by morphbench ({exc})") from None


def make_sensor(params: SensorParams, n_units: int, environment: EnvironmentParams, seed: int,
                world: WorldInterface | None = None) -> Sensor:
    """The sensor bank a run uses in ``world``; an optical one gets its own image-noise stream from the run seed."""
    if params.kind == "ideal":
        return IdealSensor(n_units, params.sample_period)
    if params.kind in ("optical", "camera"):
        rng = np.random.default_rng(np.random.SeedSequence([seed, OPTICAL_STREAM]))
        ground = ground_texture(environment.ground)
        if params.kind == "camera":
            if world is None:
                raise ValueError("make_sensor: the camera sensor renders its world's PyBullet scene; pass that world")
            if world.scene is None:
                raise ConfigError("--sensor", "sensor", "optical or ideal with the quasi-static physics (the camera "
                                  "sensor renders a PyBullet scene)", params.kind)
            ground = CameraGround(world.scene.client, ground)
        return OpticalSensor(n_units, params.optical, ground, rng, source="sensor.optical")
    raise ConfigError("--sensor", "sensor", f"one of {', '.join(SENSOR_KINDS)}", params.kind)


@functools.lru_cache(maxsize=4)
def ground_texture(params: GroundParams) -> GroundTexture:
    """Ground textures are built once per process (a few ms each) and shared: they are read-only."""
    return GroundTexture(params, source="environment.ground")


def measure(world: WorldInterface, sensors: list[Sensor], n_cycles: int,
            on_tick: Callable[[WorldInterface], None] | None = None) -> list[np.ndarray]:
    """Advance ``n_cycles`` actuation cycles at the world's current phases; each sensor bank's displacement (m).

    ``on_tick(world)``, if given, is called after every physics tick (for observers such as a video recorder)."""
    n_ticks = world.ticks_in(n_cycles * world.shape.actuator.cycle_time)
    measurement = Measurement(sensors, n_ticks, world.unit_poses(), world.ticks_in)
    return measurement.end(*world.advance_sampled(n_ticks, measurement.every, on_tick))


class Measurement:
    """Sensor banks measuring over the coming ``n_ticks`` ticks of a world: started at its units' current ``poses``,
    ended with the poses its ``advance_sampled(n_ticks, every)`` gives (so that several worlds, or the copies of one
    batched world, can be advanced together between the two; one bank can measure the units of every copy, side by
    side). ``ticks_in(seconds)`` is the world's."""

    def __init__(self, sensors: list[Sensor], n_ticks: int, poses: tuple[np.ndarray, np.ndarray],
                 ticks_in: Callable[[float], int]):
        self.sensors, self.n_ticks = sensors, n_ticks
        for sensor in sensors:
            sensor.reset(*poses)
        self.periods = [max(1, ticks_in(sensor.sample_period)) for sensor in sensors]
        self.every = math.gcd(*self.periods)
        """ticks between the poses the sensors need."""

    def end(self, positions: np.ndarray, orientations: np.ndarray) -> list[np.ndarray]:
        """Each bank's displacement (m), from the sampled poses (K, n_units, 3) and (K, n_units, 4)."""
        ticks = np.append(np.arange(self.every, self.n_ticks, self.every), self.n_ticks)  # the tick each follows
        for sensor, period in zip(self.sensors, self.periods):
            due = (ticks % period == 0) | (ticks == self.n_ticks)
            sensor.sample_many(positions[due], orientations[due])
        return [sensor.displacement() for sensor in self.sensors]


def ground_poses(positions: np.ndarray, orientations: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Units' places on the ground (n, 2), m, and headings (n,), rad from +x towards +y, from their poses."""
    axes = forward_axes(orientations)
    return positions[:, :2], np.arctan2(axes[:, 1], axes[:, 0])


@functools.lru_cache(maxsize=8)
def _field_shape(params: FrictionFieldParams) -> FrictionField:
    """The friction field's shape f, built once per field (its parameters are frozen)."""
    return FrictionField(params)


class RunLoop:
    """One run's world, sensors, controller and what events change; its methods are its part of each phase of a
    learning step: ``apply_events``, ``propose``, (the discarded cycles), ``start_measurement``, (the measured
    cycles), ``check_physics``, ``update``, ``record``. ``experiment.driver.Driver`` takes every run of a batch
    through the phases in that order, and does at once for all of them what is the same arithmetic on each (the
    trial phases set, the measured velocities, the validity tests when all pass, the records): ``run``, the suites
    and the environments all go through it."""

    def __init__(self, config: RunConfig, controller: Controller, world: WorldInterface,
                 on_tick: Callable[[WorldInterface], None] | None):
        n = config.shape.n_units
        self.config, self.controller, self.world, self.on_tick = config, controller, world, on_tick
        self._unit_bodies = np.array(config.shape.units, dtype=np.int64)
        self._normals: tuple[np.ndarray, int] | None = None
        """the units' standard normals read ahead (``noise``), and how many of them are used."""
        self.state = RunState.initial(n, config.environment.noise)
        self.events: dict[int, list[Event]] = {}
        for event in config.events:
            self.events.setdefault(event.step, []).append(event)
        self.sensor = make_sensor(config.sensor, n, config.environment, config.seed, world)
        # The ground truth is sampled on the sensor's ticks, so poses are read once; an ideal sensor is its own truth.
        self.truth = None if isinstance(self.sensor, IdealSensor) else IdealSensor(n, self.sensor.sample_period)
        self.observe = (lambda k: on_tick(world)) if on_tick is not None else None
        self.kept = controller.initial()
        """each unit's kept phase in [0, 1), from the controller once per step."""
        self.validity = _Validity(config.shape, world, config.events)
        cycle, lp = config.shape.actuator.cycle_time, config.learner_params
        self.warmup_ticks = world.ticks_in(lp.warmup_cycles * cycle)
        self.discard_ticks = world.ticks_in(lp.discard_cycles * cycle)
        """ticks run after each phase change before measuring (the transient dropped)."""
        self.measured_ticks = world.ticks_in(lp.cycles_per_step * cycle)
        self._place()

    @functools.cached_property
    def noise_rngs(self) -> list[np.random.Generator]:
        """Each unit's measurement noise stream, made when a run first has noise (most never do)."""
        seed = self.config.seed
        return [np.random.default_rng(np.random.SeedSequence([seed, NOISE_STREAM, u]))
                for u in range(self.config.shape.n_units)]

    def noise_sigma(self, sigma: float, positions: np.ndarray) -> np.ndarray:
        """The units' measurement noise (mm/cycle) where they stand, ``positions`` (n_units, 3) m in unit order, on a
        ground the noise depends on: ``sigma`` times 1 + noise_ground f(x, y) (EnvironmentParams.noise_ground; f the
        friction field's shape). Its callers ask only when noise_ground is set: the poses cost a step otherwise."""
        environment = self.config.environment
        field = _field_shape(environment.friction_field)
        return sigma * (1.0 + environment.noise_ground * field(positions[:, 0], positions[:, 1]))

    def noise(self, sigma: float) -> np.ndarray:
        """Each unit's next measurement noise (mm/cycle, unit order), ``rng.normal(0.0, sigma)`` from its own stream:
        the same doubles, from its standard normals read ahead NOISE_BLOCK at a time (numpy's normal is 0.0 + sigma
        times the next one), so a step costs no Python per unit."""
        if self._normals is None or self._normals[1] == NOISE_BLOCK:
            normals = np.empty((len(self.noise_rngs), NOISE_BLOCK))
            for row, rng in zip(normals, self.noise_rngs):
                rng.standard_normal(out=row)
            self._normals = normals, 0
        normals, used = self._normals
        self._normals = normals, used + 1
        return 0.0 + sigma * normals[:, used]

    def _place(self) -> None:
        """``position[u]``, where unit u sits (``RunState.position``), ``piece[u]``, the 1-based piece of the world
        it belongs to, and ``alive[u]``: only events change them (a shuffle, a cut, a damage), so they are found
        once after each step that has any, not every step."""
        self.position, self.alive = self.state.position(), self.state.alive()
        piece_of_body = np.zeros(len(self.config.shape.bodies), dtype=np.int64)
        for k, piece in enumerate(self.world.pieces()):
            piece_of_body[piece] = k
        self.piece = piece_of_body[self._unit_bodies[self.position]] + 1

    def apply_events(self, step: int) -> list[Event]:
        """The events of ``step``, applied in their order."""
        applied = self.events.get(step, [])
        for event in applied:
            event.apply(self.world, self.state)
        if applied:
            self._place()
        return applied

    def propose(self, step: int) -> np.ndarray:
        """Each unit's trial phase from the controller (a dead unit keeps its phase and gets no measurement); the
        driver sets them in the world, by position."""
        return self.controller.propose(step, self.alive)

    def start_measurement(self) -> Measurement:
        """The sensors (and the ground truth) start measuring the ``cycles_per_step`` cycles after the discarded
        ones."""
        return Measurement([self.sensor] if self.truth is None else [self.sensor, self.truth], self.measured_ticks,
                           self.world.unit_poses(), self.world.ticks_in)

    def check_physics(self, step: int, samples: tuple[np.ndarray, np.ndarray]) -> None:
        """A PhysicsError if the world has left the model's validity since the previous check, or at any of the
        measured cycles' ``samples`` (the units' sampled poses)."""
        self.validity.check(step, self.state.order, samples)

    @staticmethod
    def all_inside(loops: list[RunLoop], step: int, samples: tuple[np.ndarray, np.ndarray],
                   poses: tuple[np.ndarray, np.ndarray]) -> bool:
        """Whether every run of ``loops`` (runs of one configuration but for the seed) is surely still in the model's
        validity, from its units' ``samples`` and its bodies' ``poses`` now, stacked run by run: ``_Validity``'s
        tests at once over them all. If so, their ``check_physics`` of this step is done; else it finds what
        fails."""
        return _Validity.all_inside([loop.validity for loop in loops], step, samples, poses)

    def update(self, u_measured: np.ndarray, step: int) -> np.ndarray:
        """The controller gets the measurements (a per-unit learner its own unit's only); whether each unit accepted
        its trial."""
        accepted, self.kept = self.controller.update(step, u_measured, self.alive)
        return accepted

    def record(self, records: RunRecords, step: int, tried: np.ndarray, u_measured: np.ndarray, u_true: np.ndarray,
               accepted: np.ndarray, applied: list[Event]) -> None:
        """The step's row per unit, with its position, piece and pose, and the events applied (units on clocks of
        their own record run by run; ``Driver`` stores the same rows of a batch's runs at once)."""
        xy, heading = ground_poses(*self.world.unit_poses())  # units by position
        position = self.position
        records.add_step(step, self.world.time, tried, self.kept, u_measured, u_true, accepted, position + 1,
                         self.piece, xy[position], heading[position], describe(applied), self.controller.memory())


NOISE_BLOCK = 64
"""standard normals read ahead from each unit's noise stream at a time (``RunLoop.noise``)."""
MAX_TILT_DEG = 45.0
"""A body tipped further than this from upright has left the model: units slide upright on their four feet."""
MAX_REACH_PER_CYCLE = 3.0
"""In bellows reaches per cycle, the fastest a body may move (see ``_Validity``)."""
UPRIGHT_MARGIN = 1e-9
"""How far above cos(MAX_TILT_DEG) a body's upright component must be to pass without the tilt detector."""
SQUARED_MARGIN = 1e-12
"""relative margin of the squared spans that ``_Validity._surely_inside`` compares squared link lengths with."""
LINKS_AT_ONCE = 8192
"""links whose lengths ``_Validity._surely_inside`` finds at a time, in every frame."""
LINK_MARGIN = 0.25
"""In bellows reaches, how far a link's length may leave the span its bellows holds it in (see ``_Validity``)."""


def bellows_reach(shape: Shape, strokes: np.ndarray | None = None) -> float:
    """m, a bellows' reach in ``shape``: its longest stroke, at most its largest body's size."""
    strokes = link_spans(shape)[1] if strokes is None else strokes
    return min(max([shape.actuator.stroke, *strokes]), max(max(body.size) for body in shape.bodies))


def max_speed(shape: Shape) -> float:
    """m/cycle, the fastest a body of ``shape`` may move before a run of it stops with a PhysicsError (``_Validity``):
    MAX_REACH_PER_CYCLE bellows reaches per cycle."""
    return MAX_REACH_PER_CYCLE * bellows_reach(shape)


class _Validity:
    """Checks that a world is still in the model's validity, from the bodies' poses at each check and the units'
    poses at every sample of the measured cycles (the sensors' samples), so that motion inside the window counts, not
    only where it ends:

    - every position and orientation is finite;
    - no body is tilted more than MAX_TILT_DEG from upright (the angle of its own z axis from the vertical);
    - no body has risen above its rest height by more than its own height (launched: units slide on the ground or on
      the layer below, a lifting bellows raises one by a stroke);
    - no body moves faster, over the cycles since the previous check, than MAX_REACH_PER_CYCLE bellows reaches per
      cycle. A bellows inflates and vents once per cycle, so each changes its two bodies' spacing by at most one reach
      per cycle, and the fastest gait of the library moves well under one stroke per cycle (docs/morphologies.md);
      3 leaves room for transients such as a cut or a damaged bellows letting go. The reach is the largest stroke,
      but at most the largest body's size: the model's bellows sits between neighbours and pushes along their centre
      line, which a bellows longer than a unit no longer does (so an absurd stroke is caught, not licensed);
    - every link not cut holds its two bodies' centres at a distance its bellows can have: from empty to full, give or
      take what its force cap stretches or compresses it (max_force / stiffness), and LINK_MARGIN of its reach. Only a
      load beyond the cap takes a bellows further (the quasi-static model lets it give way: its bodies are torn apart
      or pushed through each other), or an explicit spring too stiff for PyBullet's step, which chatters at its cap:
      the issue's 30-unit chain at 1e7 N/m left the span by 185 mm (3.7 strokes), chain-3 at 900 N/m and chain-2 at
      1500 N/m by 0.8 to 1.5 strokes, while the library's shapes on both backends, at equal, alternating, wave and
      random phases, stay within 2 mm (0.2 strokes) of empty to full and never reach their cap.

    A bound on the speed, path or excursion of a body inside the window would not separate the two: a body is carried
    by every bellows between it and where its assembly holds, so a healthy quasi-static 30-unit chain with rigid
    bellows of 5 cm, pumping in phase, swings its front unit 27 reaches per cycle, more than the exploding one's 16.
    """

    def __init__(self, shape: Shape, world: WorldInterface, events: tuple[Event, ...] = ()):
        self.shape, self.world = shape, world
        self.rest_height = shape.placed_positions()[:, 2]
        self.height = np.array([body.size[2] for body in shape.bodies], dtype=float)
        pitch, strokes = link_spans(shape)
        reach = bellows_reach(shape, strokes)
        self.max_speed = MAX_REACH_PER_CYCLE * reach
        """m/cycle (``max_speed``)."""
        actuator = shape.actuator
        give = actuator.max_force / actuator.stiffness + LINK_MARGIN * np.minimum(strokes, reach)
        self.span = pitch - give, pitch + strokes + give
        """m, per link: the shortest and longest centre-to-centre distance its bellows holds its bodies at."""
        self.ends = np.array([(link.front, link.rear) for link in shape.links], dtype=int).reshape(-1, 2)
        self.cuts = [(event.step, event.link - 1) for event in events if isinstance(event, CutEvent)]
        self.positions, self.time = world.poses()[0], world.time
        self.units, self.bodies = np.array(shape.units, dtype=int), np.arange(len(shape.bodies))
        self.min_upright = math.cos(math.radians(MAX_TILT_DEG)) + UPRIGHT_MARGIN
        self._link_cache: dict = {}

    def check(self, step: int, order: np.ndarray, samples: tuple[np.ndarray, np.ndarray]) -> None:
        """A PhysicsError naming the first body (or link) found outside the model (unit numbers by identity:
        ``order[p]`` is the unit at position p); ``samples`` are the units' sampled poses of the measured cycles,
        (K, n_units, 3) positions and (K, n_units, 4) quaternions, as ``advance_sampled`` gives them. The first
        detector that fires names what it found first, in the order above."""
        positions, orientations = self.world.poses()
        frames = [(self.units, *samples),  # the units inside the window
                  (self.bodies, positions[None], orientations[None])]  # every body at its end
        if not self._surely_inside(step, frames, positions, self.positions):
            for bodies, frame_positions, frame_orientations in frames:
                self._check_bodies(step, order, bodies, frame_positions, frame_orientations)
            self._check_speed(step, order, positions)
            for bodies, frame_positions, _ in frames:
                self._check_links(step, order, bodies, frame_positions)
        self.positions, self.time = positions, self.world.time

    @staticmethod
    def all_inside(validities: list[_Validity], step: int, samples: tuple[np.ndarray, np.ndarray],
                   poses: tuple[np.ndarray, np.ndarray]) -> bool:
        """``_surely_inside`` of several worlds at once (one validity each, of the same shape and events, checked at
        the same times): their units' ``samples`` (worlds, K, n_units, 3) and (..., 4) and their bodies' ``poses``
        now (worlds, n_bodies, 3) and (..., 4). If every one passes, each validity moves on to its world's poses, as
        its ``check`` would."""
        first = validities[0]
        positions, orientations = poses
        frames = [(first.units, *samples), (first.bodies, positions[:, None], orientations[:, None])]
        if not first._surely_inside(step, frames, positions, np.stack([v.positions for v in validities])):
            return False
        for validity, moved in zip(validities, positions):
            validity.positions, validity.time = moved, validity.world.time
        return True

    def _surely_inside(self, step: int, frames: list, positions: np.ndarray, previous: np.ndarray) -> bool:
        """Whether every detector passes, found at once (nearly every step of nearly every run): the detectors
        themselves run only otherwise, and find what fails. Conservative: a tilt within UPRIGHT_MARGIN of the
        bound is left to them; every other test is theirs, on the same numbers. ``frames`` as ``check`` makes
        them, ``positions`` every body's now and ``previous`` at the previous check, all with any leading axes (the
        runs of a batch)."""
        for bodies, frame_positions, frame_orientations in frames:
            if not (np.isfinite(frame_positions).all() and np.isfinite(frame_orientations).all()):
                return False
            q = frame_orientations
            upright = 1.0 - 2.0 * (q[..., 0] ** 2 + q[..., 1] ** 2) / (q * q).sum(axis=-1)  # cos of the tilt
            if not (upright >= self.min_upright).all():
                return False
            if not (frame_positions[..., 2] - self.rest_height[bodies] <= self.height[bodies]).all():
                return False
            if not self._links_surely_within(step, bodies, frame_positions):
                return False
        return bool((self._speeds(positions, previous)[1] <= self.max_speed).all())

    def _links_surely_within(self, step: int, bodies: np.ndarray, positions: np.ndarray) -> bool:
        """Whether every link of ``_links`` is surely within its span in each of the frames ``positions``, from its
        squared length against its span's squared ends brought in by SQUARED_MARGIN (no square root: the length of
        ``_link_lengths`` is within a few units in the last place of the root of the squared one, so a link that
        passes here passes ``_check_links``; one that does not, or a length that is not finite, overflows or
        underflows, is left to it)."""
        _, front, rear, low, high = self._link_table(step, bodies)
        for first in range(0, len(front), LINKS_AT_ONCE):  # a few megabytes at a time, whatever the assembly
            block = slice(first, first + LINKS_AT_ONCE)
            d = np.take(positions, front[block], axis=-2) - np.take(positions, rear[block], axis=-2)
            squared = np.einsum("...i,...i->...", d, d)
            if not ((squared >= low[block]) & (squared <= high[block])).all():
                return False
        return True

    def _speeds(self, positions: np.ndarray, previous: np.ndarray) -> tuple[float, np.ndarray]:
        """The cycles since the previous check, and every body's speed over them (m/cycle), from its positions then
        and now."""
        cycles = (self.world.time - self.time) / self.shape.actuator.cycle_time
        d = positions - previous
        moved = np.hypot(np.hypot(d[..., 0], d[..., 1]), d[..., 2])  # hypot: no overflow when a body flew off
        return cycles, moved / cycles if cycles > 0 else np.zeros(moved.shape)

    def _links(self, step: int, bodies: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The links not cut by ``step`` with both bodies among ``bodies``, and their ends' columns in ``bodies``
        (kept while no cut changes them: they are asked twice a step)."""
        return self._link_table(step, bodies)[:3]

    def _link_table(self, step: int, bodies: np.ndarray) -> tuple[np.ndarray, ...]:
        """``_links``, and the squared ends of their spans brought in by SQUARED_MARGIN (none below for a span that
        starts at or below 0), found again only when a cut changes them."""
        cut = frozenset(link for at, link in self.cuts if at <= step)
        key = (cut, len(bodies))
        if key not in self._link_cache:
            column = np.full(len(self.shape.bodies), -1)
            column[bodies] = np.arange(len(bodies))
            keep = (column[self.ends] >= 0).all(axis=1)
            keep[sorted(cut)] = False
            links = np.flatnonzero(keep)
            short, long = self.span[0][links], self.span[1][links]
            low = np.where(short > 0, short * short * (1 + SQUARED_MARGIN), -np.inf)
            self._link_cache[key] = (links, column[self.ends[links, 0]], column[self.ends[links, 1]], low,
                                     long * long * (1 - SQUARED_MARGIN))
        return self._link_cache[key]

    def _link_lengths(self, step: int, bodies: np.ndarray, positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``_links`` and each one's length in each of the frames ``positions`` (..., K, len(bodies), 3)."""
        links, front, rear = self._links(step, bodies)
        d = positions[..., front, :] - positions[..., rear, :]
        return links, np.hypot(np.hypot(d[..., 0], d[..., 1]), d[..., 2])

    def _check_bodies(self, step: int, order: np.ndarray, bodies: np.ndarray, positions: np.ndarray,
                      orientations: np.ndarray) -> None:
        """Finite, upright and on the ground: ``positions`` (K, len(bodies), 3) and ``orientations`` (K, ..., 4) of
        ``bodies`` in K frames."""
        finite = np.isfinite(positions).all(axis=2) & np.isfinite(orientations).all(axis=2)
        tilt = tilts(orientations.reshape(-1, 4)).reshape(finite.shape)
        rise = positions[..., 2] - self.rest_height[bodies]
        height = self.height[bodies]
        for outside in (~finite, ~(tilt <= MAX_TILT_DEG), ~(rise <= height)):
            if not outside.any():  # nearly always: name the first one found otherwise
                continue
            k, i = np.argwhere(outside)[0]
            if not finite[k, i]:
                what = f"has a pose that is not finite (position {positions[k, i].tolist()}, orientation " \
                       f"{orientations[k, i].tolist()})"
            elif tilt[k, i] > MAX_TILT_DEG:
                what = f"tipped over (tilted {tilt[k, i]:.0f} degrees from upright, more than {MAX_TILT_DEG:.0f})"
            else:
                what = f"was launched ({1000 * rise[k, i]:.4g} mm above its rest height, more than its own height " \
                       f"of {1000 * height[i]:.4g} mm)"
            raise PhysicsError(self.shape.source, step, self._name(bodies[i], order), what)

    def _check_speed(self, step: int, order: np.ndarray, positions: np.ndarray) -> None:
        """Every body's speed since the previous check, from its position then and ``positions`` now."""
        cycles, speed = self._speeds(positions, self.positions)
        for body in np.flatnonzero(~(speed <= self.max_speed)):
            reach = 1000 * self.max_speed / MAX_REACH_PER_CYCLE
            raise PhysicsError(self.shape.source, step, self._name(body, order),
                               f"moved {1000 * speed[body]:.4g} mm/cycle over {cycles:g} cycles, faster than its "
                               f"bellows can push it (at most {MAX_REACH_PER_CYCLE:g} x {reach:.4g} mm per cycle: the "
                               f"bellows' stroke, at most a body's size)")

    def _check_links(self, step: int, order: np.ndarray, bodies: np.ndarray, positions: np.ndarray) -> None:
        """Every link not cut by ``step`` with both bodies among ``bodies`` within its span, in each of the frames
        ``positions`` (K, len(bodies), 3)."""
        links, length = self._link_lengths(step, bodies, positions)
        short, long = self.span[0][links], self.span[1][links]
        outside = (length < short) | (length > long)
        if not outside.any():
            return
        k, i = np.argwhere(outside)[0]
        j, (a, b) = links[i], self.ends[links[i]]
        if length[k, i] > long[i]:
            bound, side, what = long[i], "more than the full length plus", "torn apart"
        else:
            bound, side, what = short[i], "less than the empty length minus", "pushed into each other"
        raise PhysicsError(self.shape.source, step, f"link {j + 1}",
                           f"({self._name(a, order)} to {self._name(b, order)}) held its bodies' centres "
                           f"{1000 * length[k, i]:.4g} mm apart, {side} its force cap's give and {LINK_MARGIN:g} of "
                           f"its reach ({1000 * bound:.4g} mm): its bodies were {what}")

    def _name(self, body: int, order: np.ndarray) -> str:
        units = self.shape.units
        if body in units:
            return f"unit {int(order[units.index(body)]) + 1}"
        return f"dummy body {body}"
