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

from morphbench.params import FAST_PHYSICS, EnvironmentParams, PhysicsParams
from morphbench.physics.bellows import FIELD_UPDATE_PERIOD, GRAVITY, Bellows
from morphbench.physics.geometry import body_shapes
from morphbench.shapes.model import Shape

GROUND_FRICTION = 1.0  # Bullet multiplies the two bodies' coefficients, so a body's own value is the real one


class World(Bellows):
    """One simulation: build it from a shape, set the units' phases, advance time, read the units' poses."""

    def __init__(self, shape: Shape, physics: PhysicsParams = FAST_PHYSICS,
                 environment: EnvironmentParams = EnvironmentParams()):
        super().__init__(shape, environment)
        self.physics = physics
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
        self._alignments = [self._align(i) for i in range(len(shape.links))]
        self._lengths = self._empty_pitch.tolist()
        """m, each bellows' length at the previous tick (its rate of change damps the spring)."""
        self._applied_friction = self._base_friction.copy()
        self._apply_friction(self.poses()[0], np.zeros(shape.n_units, dtype=bool))
        # Settle with the bellows' springs holding their rest lengths (a stacked layer rests on them, not on the
        # layer below), then start the pumps' clock.
        self.time = 0.0
        self.advance(max(1, round(physics.settle_time / self.tick)), pumps=False)
        self.time = 0.0
        """s, time since the end of settling: the pumps' clock."""

    def _add_body(self, body) -> int:
        c, shapes = self.client, body_shapes(self.client, body)
        uid = pb.createMultiBody(body.mass, shapes.collision, shapes.visual, basePosition=body.position,
                                 physicsClientId=c)
        pb.changeDynamics(uid, -1, lateralFriction=body.friction, localInertiaDiagonal=shapes.inertia,
                          physicsClientId=c)
        return uid

    def _align(self, i: int) -> int:
        """A prismatic constraint along the link's axis: bodies keep their relative orientation and sideways offset.

        In a closed loop of links this also makes parallel links of a ladder share their extension (the rows of a
        grid are locked together along the rows), a stiff lateral coupling documented in docs/morphologies.md.
        """
        (front, rear), pitch = self._links[i], self._empty_pitch[i]
        axis = (self._rest[front] - self._rest[rear]) / pitch
        return pb.createConstraint(
            self.bodies[front], -1, self.bodies[rear], -1, pb.JOINT_PRISMATIC, axis.tolist(),
            (-axis * pitch / 2).tolist(), (axis * pitch / 2).tolist(), physicsClientId=self.client,
        )

    def advance(self, n_ticks: int, on_tick=None, pumps: bool = True, every: int = 1) -> None:
        """Run ``n_ticks`` physics ticks. ``on_tick(k)`` is called after tick k (0-based) if given and k + 1 is a
        multiple of ``every``, with ``time`` and ``pressure`` already those at the end of that tick. With
        ``pumps=False`` every bellows stays empty."""
        if n_ticks <= 0:
            return
        start = self.time
        actuator = self.shape.actuator
        trajectory = self._pressures(start, n_ticks, pumps)
        rest_lengths = self._rest_lengths(trajectory).tolist()
        friction_ticks, pumping = self._friction_schedule(start, n_ticks) if pumps else (set(), None)
        stiffness, damping, cap, dt = actuator.stiffness, actuator.damping, actuator.max_force, self.tick
        c, bodies, lengths = self.client, self.bodies, self._lengths
        links = [(i, front, rear) for i, (front, rear) in enumerate(self._links) if self.intact[i]]
        get_pose, push, step, frame = pb.getBasePositionAndOrientation, pb.applyExternalForce, pb.stepSimulation, pb.WORLD_FRAME
        for k in range(n_ticks):
            # Hot loop, plain floats: one pose read per body, one force per body and bellows, one solver call.
            positions = [get_pose(uid, physicsClientId=c)[0] for uid in bodies]
            if k in friction_ticks:
                self._apply_friction(positions, None if pumping is None else pumping[k])
            rest_k = rest_lengths[k]
            for i, front, rear in links:
                (xf, yf, zf), (xr, yr, zr) = positions[front], positions[rear]
                dx, dy, dz = xf - xr, yf - yr, zf - zr
                length = math.sqrt(dx * dx + dy * dy + dz * dz)
                force = stiffness * (rest_k[i] - length) - damping * (length - lengths[i]) / dt
                force = max(-cap, min(cap, force)) / length  # > 0 pushes the bodies apart
                lengths[i] = length
                push(bodies[front], -1, (force * dx, force * dy, force * dz), positions[front], frame, physicsClientId=c)
                push(bodies[rear], -1, (-force * dx, -force * dy, -force * dz), positions[rear], frame, physicsClientId=c)
            step(physicsClientId=c)
            if on_tick is not None and (k + 1) % every == 0:
                self.pressure, self.time = trajectory[k], start + (k + 1) * dt
                on_tick(k)
        self.pressure, self.time = trajectory[-1], start + n_ticks * dt

    def _friction_schedule(self, start: float, n_ticks: int) -> tuple[set[int], np.ndarray | None]:
        """Ticks at which friction must be set again (pump switches when vibrating, field updates) and, when the
        pumps vibrate, which pumps run at each tick."""
        ticks: set[int] = set()
        pumping = None
        if self.environment.vibration != 1.0:
            pumping = self._pumping(start, n_ticks)
            switches = np.flatnonzero(np.any(pumping[1:] != pumping[:-1], axis=1)) + 1
            ticks.update(switches.tolist())
            ticks.add(0)
        if self._field is not None:
            ticks.update(range(0, n_ticks, max(1, round(FIELD_UPDATE_PERIOD / self.tick))))
        return ticks, pumping

    def _apply_friction(self, positions, pumping) -> None:
        """Set each body's friction from the scale, the field under it and its pump's vibration (changed ones only)."""
        friction = self._base_friction * self._friction_scale
        if self._field is not None:
            xy = np.asarray(positions)[:, :2]
            friction = self._field.friction(friction, xy[:, 0], xy[:, 1])
        if pumping is not None:
            friction[self._unit_bodies[pumping]] *= self.environment.vibration
        for i in np.flatnonzero(np.abs(friction - self._applied_friction) > 1e-9):
            pb.changeDynamics(self.bodies[i], -1, lateralFriction=float(friction[i]), physicsClientId=self.client)
        self._applied_friction = friction

    def set_friction_scale(self, scale: float) -> None:
        """Multiply every body's friction by ``scale`` from now on (instead of the environment's scale)."""
        self._friction_scale = scale
        self._apply_friction(self.poses()[0], None)

    def cut(self, link: int) -> None:
        """Cut link ``link`` (index into shape.links): its bellows and alignment are gone; the pieces move apart freely."""
        if self.intact[link]:
            pb.removeConstraint(self._alignments[link], physicsClientId=self.client)
            self.intact[link] = False

    def poses(self, which=None) -> tuple[np.ndarray, np.ndarray]:
        """Positions (N, 3, m) and orientations (N, 4 quaternions x, y, z, w) of the given bodies (default all)."""
        ids = self.bodies if which is None else [self.bodies[i] for i in which]
        states = [pb.getBasePositionAndOrientation(uid, physicsClientId=self.client) for uid in ids]
        return np.array([s[0] for s in states]), np.array([s[1] for s in states])

    def close(self) -> None:
        if self.client is not None and pb.isConnected(self.client):
            pb.disconnect(self.client)
        self.client = None
