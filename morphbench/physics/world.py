"""A shape built in its own PyBullet DIRECT client: one rigid body per unit, one bellows per link.

Each bellows joins its two bodies by
- a prismatic constraint that keeps them aligned and leaves the bellows axis free, and
- a spring-damper force along the axis, applied every physics tick, whose rest length grows with pressure
  (``rest_gap + stroke * pressure``) and whose magnitude is capped at ``max_force``.
The compliance matters: friction on neighbouring bodies differs by only ~20%, and a rigid (servo) bellows jerks at
each pump switch hard enough to drag the wrong body, so a unit and a dummy alone crept forward at up to 2 mm/cycle.
With the spring they stay put, as reciprocal motion must. The spring is explicit, so the stiffness and the timestep
are chosen together: 200 N/m with 50 g bodies is stable at 1/120 s in a 20-unit chain (500 N/m was not).
Only this package and the renderer talk to PyBullet; everything here takes and returns plain numpy arrays.
"""

from __future__ import annotations

import math

import numpy as np
import pybullet as pb

from morphbench.params import FAST_PHYSICS, PhysicsParams
from morphbench.physics.pressure import pressure_trajectory
from morphbench.shapes.model import Shape

GRAVITY = 9.81  # m/s^2
GROUND_FRICTION = 1.0  # Bullet multiplies the two bodies' coefficients, so a body's own value is the real one
UNIT_COLOUR = (0.20, 0.45, 0.80, 1.0)
DUMMY_COLOUR = (0.55, 0.55, 0.55, 1.0)


class World:
    """One simulation: build it from a shape, set the units' phases, advance time, read the units' poses."""

    def __init__(self, shape: Shape, physics: PhysicsParams = FAST_PHYSICS):
        self.shape, self.physics = shape, physics
        self.tick = physics.timestep
        """s, one physics step: pressures and bellows forces are updated every tick."""
        self.client = pb.connect(pb.DIRECT)
        c = self.client
        pb.setGravity(0, 0, -GRAVITY, physicsClientId=c)
        pb.setPhysicsEngineParameter(
            fixedTimeStep=self.tick,
            numSolverIterations=physics.solver_iterations,
            physicsClientId=c,
        )
        self.ground = pb.createMultiBody(0, pb.createCollisionShape(pb.GEOM_PLANE, physicsClientId=c), physicsClientId=c)
        pb.changeDynamics(self.ground, -1, lateralFriction=GROUND_FRICTION, physicsClientId=c)
        self.bodies = [self._add_body(body) for body in shape.bodies]
        self._unit_index = {body: k for k, body in enumerate(shape.units)}
        self.link_units = np.array([self._unit_index[link.unit] for link in shape.links], dtype=int)
        """for each link, the index (in unit order) of the unit whose pump drives it."""
        for link in shape.links:
            self._align(link)
        self._links = [(link.front, link.rear) for link in shape.links]
        self._empty_pitch = np.array([self._pitch(link) for link in shape.links])
        """m, centre-to-centre distance of each link's two bodies when its bellows is empty."""
        self._lengths = self._empty_pitch.tolist()
        """m, each bellows' length at the previous tick (its rate of change damps the spring)."""
        self.pressure = np.zeros(len(shape.links))
        """current pressure (0..1) of each bellows."""
        self.phases = np.zeros(shape.n_units)
        """current phase (0..1) of each active unit's pump."""
        for _ in range(max(1, round(physics.settle_time / self.tick))):
            pb.stepSimulation(physicsClientId=c)
        self.time = 0.0
        """s, time since the end of settling: the pumps' clock."""

    def _add_body(self, body) -> int:
        c = self.client
        half = [s / 2 for s in body.size]
        collision = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=half, physicsClientId=c)
        colour = DUMMY_COLOUR if body.dummy else UNIT_COLOUR
        visual = pb.createVisualShape(pb.GEOM_BOX, halfExtents=half, rgbaColor=colour, physicsClientId=c)
        uid = pb.createMultiBody(body.mass, collision, visual, basePosition=body.position, physicsClientId=c)
        pb.changeDynamics(uid, -1, lateralFriction=body.friction, physicsClientId=c)
        return uid

    def _align(self, link) -> None:
        c, pitch = self.client, self._pitch(link)
        pb.createConstraint(
            self.bodies[link.front], -1, self.bodies[link.rear], -1, pb.JOINT_PRISMATIC, [1, 0, 0],
            [-pitch / 2, 0, 0], [pitch / 2, 0, 0], physicsClientId=c,
        )

    def _pitch(self, link) -> float:
        front, rear = self.shape.bodies[link.front], self.shape.bodies[link.rear]
        return (front.size[0] + rear.size[0]) / 2 + self.shape.actuator.rest_gap

    def set_phases(self, phases) -> None:
        """Set every active unit's phase (unit order, values in [0, 1))."""
        phases = np.asarray(phases, dtype=float)
        if phases.shape != self.phases.shape:
            raise ValueError(f"expected {self.phases.shape[0]} phases, got {phases.shape}")
        self.phases = np.mod(phases, 1.0)

    def ticks_in(self, duration: float) -> int:
        """How many control ticks make ``duration`` seconds (durations are whole numbers of ticks)."""
        return max(0, round(duration / self.tick))

    def advance(self, n_ticks: int, on_tick=None) -> None:
        """Run ``n_ticks`` physics ticks. ``on_tick(k)`` is called after tick k (0-based) if given, with ``time`` and
        ``pressure`` already those at the end of that tick."""
        if n_ticks <= 0:
            return
        start = self.time
        trajectory = pressure_trajectory(
            self.pressure, self.phases[self.link_units], self.time, self.tick, n_ticks, self.shape.actuator
        )
        actuator = self.shape.actuator
        rest_lengths = (self._empty_pitch + actuator.stroke * trajectory).tolist()
        stiffness, damping, cap, dt = actuator.stiffness, actuator.damping, actuator.max_force, self.tick
        c, bodies, links, lengths = self.client, self.bodies, self._links, self._lengths
        get_pose, push, step, frame = pb.getBasePositionAndOrientation, pb.applyExternalForce, pb.stepSimulation, pb.WORLD_FRAME
        for k in range(n_ticks):
            # Hot loop, plain floats: one pose read per body, one force per body and bellows, one solver call.
            positions = [get_pose(uid, physicsClientId=c)[0] for uid in bodies]
            for i, ((front, rear), rest) in enumerate(zip(links, rest_lengths[k])):
                (xf, yf, zf), (xr, yr, zr) = positions[front], positions[rear]
                dx, dy, dz = xf - xr, yf - yr, zf - zr
                length = math.sqrt(dx * dx + dy * dy + dz * dz)
                force = stiffness * (rest - length) - damping * (length - lengths[i]) / dt
                force = max(-cap, min(cap, force)) / length  # > 0 pushes the bodies apart
                lengths[i] = length
                push(bodies[front], -1, (force * dx, force * dy, force * dz), positions[front], frame, physicsClientId=c)
                push(bodies[rear], -1, (-force * dx, -force * dy, -force * dz), positions[rear], frame, physicsClientId=c)
            step(physicsClientId=c)
            if on_tick is not None:
                self.pressure, self.time = trajectory[k], start + (k + 1) * dt
                on_tick(k)
        self.pressure, self.time = trajectory[-1], start + n_ticks * dt

    def poses(self, which=None) -> tuple[np.ndarray, np.ndarray]:
        """Positions (N, 3, m) and orientations (N, 4 quaternions x, y, z, w) of the given bodies (default all)."""
        ids = self.bodies if which is None else [self.bodies[i] for i in which]
        states = [pb.getBasePositionAndOrientation(uid, physicsClientId=self.client) for uid in ids]
        return np.array([s[0] for s in states]), np.array([s[1] for s in states])

    def unit_poses(self) -> tuple[np.ndarray, np.ndarray]:
        """Poses of the active units, in unit order."""
        return self.poses(self.shape.units)

    def close(self) -> None:
        if self.client is not None and pb.isConnected(self.client):
            pb.disconnect(self.client)
        self.client = None

    def __enter__(self) -> World:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
