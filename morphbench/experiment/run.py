"""The run loop: one world, one sensor bank, one learner per unit, learning steps of ``cycles_per_step`` cycles.

The CLI, the scans and the tests all go through ``run`` (and ``measure`` for fixed phases).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from morphbench.errors import ConfigError
from morphbench.experiment.records import RunRecords
from morphbench.learning import load_learner_class, make_learners
from morphbench.experiment.events import Event
from morphbench.params import (
    DEFAULT_PHYSICS,
    SENSOR_KINDS,
    EnvironmentParams,
    GroundParams,
    LearnerParams,
    PhysicsParams,
    SensorParams,
)
from morphbench.physics import World, make_world
from morphbench.physics.camera import CameraGround
from morphbench.sensing import GroundTexture, IdealSensor, OpticalSensor, Sensor
from morphbench.sensing.base import forward_axes
from morphbench.shapes import Shape, load_shape, params_from_dict
from morphbench.shapes.transforms import shuffle_order

NOISE_STREAM = 1  # SeedSequence([seed, NOISE_STREAM, unit]) is unit's measurement-noise stream; 0 is its learner's
OPTICAL_STREAM = 5  # SeedSequence([seed, OPTICAL_STREAM]): the optical sensors' image noise


@dataclass(frozen=True, kw_only=True)
class RunConfig:
    """Everything that determines a run: the same config and seed give identical records."""

    shape: Shape
    learner: str = "thermal"
    """'thermal', 'flaky' or a plug-in 'package.module:Class'."""
    learner_params: LearnerParams = field(default_factory=LearnerParams)
    sensor: SensorParams = field(default_factory=SensorParams)
    environment: EnvironmentParams = field(default_factory=EnvironmentParams)
    events: tuple[Event, ...] = ()
    """applied at the start of their learning step (morphbench.experiment.events)."""
    physics: PhysicsParams = DEFAULT_PHYSICS
    steps: int = 100
    """learning steps after the initial measurement (step 0)."""
    seed: int = 0

    def to_dict(self) -> dict:
        """JSON-ready: the shape by its file, every parameter by field (what summary.json stores)."""
        data = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        # The shape file by absolute path, so that a run can be replayed from anywhere.
        source = Path(self.shape.source)
        data["shape"] = {"name": self.shape.name, "source": str(source.resolve()) if source.is_file() else str(source),
                         "n_units": self.shape.n_units}
        for key in ("learner_params", "sensor", "environment", "physics"):
            data[key] = dataclasses.asdict(data[key])
        data["events"] = [{k: v for k, v in dataclasses.asdict(e).items() if v is not None} for e in self.events]
        return data

    @classmethod
    def from_dict(cls, data: dict, source: str = "summary.json") -> RunConfig:
        """The config ``to_dict`` wrote, its shape reloaded from its file (to replay a finished run)."""
        try:
            return cls(
                shape=load_shape(data["shape"]["source"]),
                learner=data["learner"],
                learner_params=params_from_dict(LearnerParams, data["learner_params"]),
                sensor=params_from_dict(SensorParams, data["sensor"]),
                environment=params_from_dict(EnvironmentParams, data["environment"]),
                events=tuple(Event(**e) for e in data["events"]),
                physics=params_from_dict(PhysicsParams, data["physics"]),
                steps=data["steps"],
                seed=data["seed"],
            )
        except (KeyError, TypeError) as exc:
            raise ConfigError(source, "config", f"a run configuration written by morphbench ({exc})") from None


def make_sensor(params: SensorParams, n_units: int, environment: EnvironmentParams, seed: int,
                world: World | None = None) -> Sensor:
    """The sensor bank a run uses in ``world``; an optical one gets its own image-noise stream from the run seed."""
    if params.kind == "ideal":
        return IdealSensor(n_units, params.sample_period)
    if params.kind in ("optical", "camera"):
        rng = np.random.default_rng(np.random.SeedSequence([seed, OPTICAL_STREAM]))
        ground = ground_texture(environment.ground)
        if params.kind == "camera":
            if world is None:
                raise ValueError("make_sensor: the camera sensor renders its world's PyBullet scene; pass that world")
            if world.client is None:
                raise ConfigError("--sensor", "sensor", "optical or ideal with the quasi-static physics (the camera "
                                  "sensor renders a PyBullet scene)", params.kind)
            ground = CameraGround(world.client, ground)
        return OpticalSensor(n_units, params.optical, ground, rng, source="sensor.optical")
    raise ConfigError("--sensor", "sensor", f"one of {', '.join(SENSOR_KINDS)}", params.kind)


@functools.lru_cache(maxsize=4)
def ground_texture(params: GroundParams) -> GroundTexture:
    """Ground textures are built once per process (a few ms each) and shared: they are read-only."""
    return GroundTexture(params, source="environment.ground")


def measure(world: World, sensors: list[Sensor], n_cycles: int, on_tick: Callable[[World], None] | None = None
            ) -> list[np.ndarray]:
    """Advance ``n_cycles`` actuation cycles at the world's current phases; each sensor bank's displacement (m).

    ``on_tick(world)``, if given, is called after every physics tick (for observers such as a video recorder)."""
    n_ticks = world.ticks_in(n_cycles * world.shape.actuator.cycle_time)
    poses = world.unit_poses()
    for sensor in sensors:
        sensor.reset(*poses)
    periods = [max(1, world.ticks_in(sensor.sample_period)) for sensor in sensors]

    def sample_due(k: int) -> None:
        due = [s for s, every in zip(sensors, periods) if (k + 1) % every == 0 and k + 1 < n_ticks]
        if due:
            tick_poses = world.unit_poses()
            for sensor in due:
                sensor.sample(*tick_poses)
        if on_tick is not None:
            on_tick(world)

    # Without an observer the world only calls back on ticks where some sensor may be due.
    world.advance(n_ticks, sample_due, every=1 if on_tick is not None else math.gcd(*periods))
    poses = world.unit_poses()
    for sensor in sensors:
        sensor.sample(*poses)
    return [sensor.displacement() for sensor in sensors]


def run(config: RunConfig, progress: Callable[[int, RunRecords], None] | None = None,
        on_tick: Callable[[World], None] | None = None) -> RunRecords:
    """Learn for ``config.steps`` learning steps; ``progress(step, records)`` is called after each step and
    ``on_tick(world)`` after every physics tick of the warm-up and the steps (observers only: it must not change the
    world).

    Units keep their identity (learner, memory, noise stream, damage) when a shuffle moves them: ``order[p]`` is the
    unit at position p (0 = front), and the world sees phases by position.
    """
    shape, lp, n = config.shape, config.learner_params, config.shape.n_units
    learners = make_learners(load_learner_class(config.learner), lp, config.seed, n)
    noise_rngs = [np.random.default_rng(np.random.SeedSequence([config.seed, NOISE_STREAM, u])) for u in range(n)]
    records = RunRecords(config)
    order, damage, noise = np.arange(n), [""] * n, config.environment.noise
    events = {}
    for event in config.events:
        events.setdefault(event.step, []).append(event)
    started = time.perf_counter()
    cycle, to_mm_per_cycle = shape.actuator.cycle_time, 1000.0 / lp.cycles_per_step
    with make_world(shape, config.physics, config.environment, scene=config.sensor.kind == "camera") as world:
        sensor = make_sensor(config.sensor, n, config.environment, config.seed, world)
        # The ground truth is sampled on the sensor's ticks, so poses are read once; an ideal sensor is its own truth.
        truth = None if isinstance(sensor, IdealSensor) else IdealSensor(n, sample_period=sensor.sample_period)
        observe = (lambda k: on_tick(world)) if on_tick is not None else None
        world.set_phases([learner.phase for learner in learners])
        world.advance(world.ticks_in(lp.warmup_cycles * cycle), observe)
        for step in range(config.steps + 1):
            for event in events.get(step, ()):
                if event.kind == "friction":
                    world.set_friction_scale(event.scale)
                elif event.kind == "noise":
                    noise = event.sigma
                elif event.kind == "damage":
                    damage[event.unit - 1] = event.mode
                elif event.kind == "shuffle":
                    order = order[shuffle_order(n, event.seed)]  # the permutation of the shape transform
                elif event.kind == "cut":
                    world.cut(event.link - 1)
                if event.kind in ("damage", "shuffle"):
                    for p in range(n):  # damage travels with its unit
                        world.set_damage(p, damage[order[p]])
            position = np.argsort(order)  # position[u]: where unit u sits
            alive = np.array([d != "dead" for d in damage])
            # A dead unit's learner stops: it keeps its phase and gets no measurement.
            tried = np.array([learners[u].propose() if alive[u] else learners[u].phase for u in range(n)], dtype=float)
            world.set_phases(tried[order])
            world.advance(world.ticks_in(lp.discard_cycles * cycle), observe)
            if truth is None:
                sensed = true = measure(world, [sensor], lp.cycles_per_step, on_tick)[0]
            else:
                sensed, true = measure(world, [sensor, truth], lp.cycles_per_step, on_tick)
            u_true = true[position] * to_mm_per_cycle
            u_measured = sensed[position] * to_mm_per_cycle + np.array(
                [rng.normal(0.0, noise) if noise else 0.0 for rng in noise_rngs])
            u_measured[~alive] = np.nan
            # Each learner gets its own unit's measurement and nothing else.
            accepted = np.array([bool(learners[u].update(float(u_measured[u]))) if alive[u] else False for u in range(n)])
            kept = np.array([learner.phase for learner in learners], dtype=float)
            piece_of_body = {body: k for k, piece in enumerate(world.pieces()) for body in piece}
            piece = np.array([piece_of_body[shape.units[p]] for p in position]) + 1
            positions, orientations = world.unit_poses()  # the world lists units by position
            axes = forward_axes(orientations[position])
            records.add_step(step, world.time, tried, kept, u_measured, u_true, accepted, position + 1, piece,
                             positions[position, :2], np.arctan2(axes[:, 1], axes[:, 0]),
                             "; ".join(event.describe() for event in events.get(step, ())))
            if progress is not None:
                progress(step, records)
    records.finish(wall_time=time.perf_counter() - started)
    return records
