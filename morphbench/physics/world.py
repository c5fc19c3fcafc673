"""A shape built in its own PyBullet DIRECT client: one rigid body per unit, one soft bellows per link.

Each body stands on four small spheres at the corners of its footprint, so it touches the ground at four fixed
points; a box of its size, raised just off the ground, is what collides with other bodies (a mesh is only drawn).
Each link is a set of explicit spring-dampers between its two bodies, applied every tick as one force and one torque
per body (``_link_forces``, compiled):
- axial: along the centre line, rest length ``rest_gap + stroke * pressure``, force capped at ``max_force``;
- shear: the front centre's offset from the bodies' mean link axis, with the couple that conserves angular momentum;
- bending and twist: the relative rotation of the two bodies, across and about the mean axis.
No joints or constraints join the bodies. Measured against the quasi-static model (docs/fidelity.md): the box's own
contact points came and went from tick to tick, swinging each body's normal force between 0.2 and 3 times its
weight, and every rigid constraint let the solver shift weight between bodies by 5-8%; gaits live on friction
differences of 20-40%, so both biased and scattered the motion. Feet and springs leave each body carrying its own
weight (1.000 +- 0.002) and the world converged at 1/120 s. The springs are explicit, so the stiffnesses and the
timestep go together: 1/120 s takes the default stiffnesses; stiffer links or taller stacks need ``substeps``.
Only this package and the renderer talk to PyBullet; everything here takes and returns plain numpy arrays.
"""

from __future__ import annotations

import math

import numba
import numpy as np
import pybullet as pb

from morphbench.params import FAST_PHYSICS, EnvironmentParams, PhysicsParams
from morphbench.physics.bellows import FIELD_UPDATE_PERIOD, GRAVITY, Bellows
from morphbench.physics.geometry import body_shapes
from morphbench.physics.protocol import Scene
from morphbench.shapes.model import Shape

GROUND_FRICTION = 1.0  # Bullet multiplies the two bodies' coefficients, so a body's own value is the real one
FOOT_RADIUS = 0.002  # m, the spheres a body stands on, at the corners of its footprint
BOX_LIFT = 0.001  # m, gap between the colliding box and the ground
ROTATIONAL_INERTIA_SCALE = 4.0
"""Bodies turn with 4x their rotational inertia: it slows the rotational modes of the explicit bending and twist
springs enough for 1/120 s, and inertia is negligible next to friction at these speeds (chains are unaffected)."""


class World(Bellows):
    """One simulation: build it from a shape, set the units' phases, advance time, read the units' poses."""

    backend = "pybullet"

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
            fixedTimeStep=self.tick / physics.substeps,
            numSolverIterations=physics.solver_iterations,
            enableConeFriction=int(physics.cone_friction),
            physicsClientId=c,
        )
        self.ground = pb.createMultiBody(0, pb.createCollisionShape(pb.GEOM_PLANE, physicsClientId=c),
                                         physicsClientId=c)
        pb.changeDynamics(self.ground, -1, lateralFriction=GROUND_FRICTION, physicsClientId=c)
        self.bodies = [self._add_body(body, position.tolist()) for body, position in zip(shape.bodies, self._rest)]
        n_links = len(shape.links)
        # each link's length, shear offset and relative rotation at the previous substep: their rates damp the springs
        self._previous = (self._empty_pitch.copy(), np.zeros((n_links, 3)), np.zeros((n_links, 3)))
        self._applied_friction = self._base_friction.copy()
        self._apply_friction(self.poses()[0], np.zeros(shape.n_units, dtype=bool))
        # Settle with the bellows' springs holding their rest lengths (a stacked layer rests on them, not on the
        # layer below), then start the pumps' clock.
        self.time = 0.0
        self.advance(max(1, round(physics.settle_time / self.tick)), pumps=False)
        self.time = 0.0
        """s, time since the end of settling: the pumps' clock."""

    def _add_body(self, body, position) -> int:
        c, shapes = self.client, body_shapes(self.client, body)
        lx, ly, lz = (size / 2 for size in body.size)
        r = FOOT_RADIUS
        feet = [[sx * (lx - r), sy * (ly - r), r - lz] for sx in (-1, 1) for sy in (-1, 1)]
        collision = pb.createCollisionShapeArray(
            [pb.GEOM_SPHERE] * 4 + [pb.GEOM_BOX], radii=[r] * 4 + [0.0],
            halfExtents=[[0, 0, 0]] * 4 + [[lx, ly, lz - BOX_LIFT / 2]],
            collisionFramePositions=feet + [[0, 0, BOX_LIFT / 2]], physicsClientId=c)
        uid = pb.createMultiBody(body.mass, collision, shapes.visual, basePosition=position,
                                baseOrientation=self.shape.orientation, physicsClientId=c)
        pb.changeDynamics(uid, -1, lateralFriction=body.friction,
                          localInertiaDiagonal=[ROTATIONAL_INERTIA_SCALE * i for i in shapes.inertia],
                          physicsClientId=c)
        return uid

    def advance(self, n_ticks: int, on_tick=None, pumps: bool = True, every: int = 1) -> None:
        """Run ``n_ticks`` physics ticks. ``on_tick(k)`` is called after tick k (0-based) if given and k + 1 is a
        multiple of ``every``, with ``time`` and ``pressure`` already those at the end of that tick. With
        ``pumps=False`` every bellows stays empty."""
        if n_ticks <= 0:
            return
        start = self.time
        a = self.shape.actuator
        trajectory = self._pressures(start, n_ticks, pumps)
        rest_lengths = self._rest_lengths(trajectory)
        friction_ticks, pumping = self._friction_schedule(start, n_ticks) if pumps else (set(), None)
        substeps = self.physics.substeps
        h = self.tick / substeps
        stiffness = np.array([a.damping, a.max_force, a.shear_stiffness, a.shear_damping, a.bending_stiffness,
                              a.twist_stiffness, a.rotational_damping])
        c, bodies = self.client, self.bodies
        n = len(bodies)
        positions, orientations = np.empty((n, 3)), np.empty((n, 4))
        force, torque = np.empty((n, 3)), np.empty((n, 3))
        get_pose, push, turn, step, frame = (pb.getBasePositionAndOrientation, pb.applyExternalForce,
                                             pb.applyExternalTorque, pb.stepSimulation, pb.WORLD_FRAME)
        for k in range(n_ticks):
            for substep in range(substeps):
                # Hot loop: one pose read per body, one compiled call for every link, one force and torque per body.
                states = [get_pose(uid, physicsClientId=c) for uid in bodies]
                for b, (p, q) in enumerate(states):
                    positions[b], orientations[b] = p, q
                if substep == 0 and k in friction_ticks:
                    self._apply_friction(positions, None if pumping is None else pumping[k])
                _link_forces(positions, orientations, self._front, self._rear, self.intact, self._axes,
                             rest_lengths[k], *self._previous, h, self.link_stiffness, stiffness, force, torque)
                forces, torques = force.tolist(), torque.tolist()
                for b in range(n):
                    push(bodies[b], -1, forces[b], states[b][0], frame, physicsClientId=c)
                    turn(bodies[b], -1, torques[b], frame, physicsClientId=c)
                step(physicsClientId=c)
            if on_tick is not None and (k + 1) % every == 0:
                self.pressure, self.time = trajectory[k], start + (k + 1) * self.tick
                on_tick(k)
        self.pressure, self.time = trajectory[-1], start + n_ticks * self.tick

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

    def set_friction_scale(self, scale: float, bodies: str = "all") -> None:
        super().set_friction_scale(scale, bodies)
        self._apply_friction(self.poses()[0], None)

    @property
    def scene(self) -> Scene | None:
        """The client, bodies and ground plane (None once closed)."""
        return None if self.client is None else Scene(self.client, self.bodies, self.ground)

    def poses(self, which=None) -> tuple[np.ndarray, np.ndarray]:
        """Positions (N, 3, m) and orientations (N, 4 quaternions x, y, z, w) of the given bodies (default all)."""
        ids = self.bodies if which is None else [self.bodies[i] for i in which]
        states = [pb.getBasePositionAndOrientation(uid, physicsClientId=self.client) for uid in ids]
        return np.array([s[0] for s in states]), np.array([s[1] for s in states])

    def close(self) -> None:
        if self.client is not None and pb.isConnected(self.client):
            pb.disconnect(self.client)
        self.client = None


@numba.njit(cache=True, nogil=True)
def _rotate(q, v):
    """v turned by the unit quaternion q = (x, y, z, w)."""
    x, y, z, w = q[0], q[1], q[2], q[3]
    cx, cy, cz = y * v[2] - z * v[1], z * v[0] - x * v[2], x * v[1] - y * v[0]
    return np.array([v[0] + 2 * (w * cx + y * cz - z * cy),
                     v[1] + 2 * (w * cy + z * cx - x * cz),
                     v[2] + 2 * (w * cz + x * cy - y * cx)])


@numba.njit(cache=True, nogil=True)
def _link_forces(positions, orientations, front, rear, intact, axes, rest, last_length, last_shear, last_turn, h,
                 axial_stiffness, stiffness, force, torque):
    """Every intact link's spring-damper force and torque on its two bodies, summed into ``force`` and ``torque``
    (world frame); ``last_*`` hold each link's length, shear offset and relative rotation at the previous substep
    (updated). ``axial_stiffness``: each link's k; ``stiffness``: axial c, cap; shear k, c; bending k, twist k,
    rotational c."""
    c, cap, k_shear, c_shear, k_bend, k_twist, c_turn = stiffness
    force[:] = 0.0
    torque[:] = 0.0
    for j in range(len(front)):
        if not intact[j]:
            continue
        f, r = front[j], rear[j]
        d = positions[f] - positions[r]
        length = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        axial = axial_stiffness[j] * (rest[j] - length) - c * (length - last_length[j]) / h
        axial = max(-cap, min(cap, axial)) / length  # > 0 pushes the bodies apart
        last_length[j] = length
        mean = _rotate(orientations[f], axes[j]) + _rotate(orientations[r], axes[j])
        mean /= math.sqrt(mean[0] ** 2 + mean[1] ** 2 + mean[2] ** 2)
        offset = d - (d[0] * mean[0] + d[1] * mean[1] + d[2] * mean[2]) * mean
        shear = -k_shear * offset - c_shear * (offset - last_shear[j]) / h
        last_shear[j] = offset
        # relative rotation vector of q_f * conj(q_r)
        x1, y1, z1, w1 = orientations[f]
        x2, y2, z2, w2 = -orientations[r, 0], -orientations[r, 1], -orientations[r, 2], orientations[r, 3]
        w = w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2
        vx = w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2
        vy = w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2
        vz = w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2
        if w < 0:
            w, vx, vy, vz = -w, -vx, -vy, -vz
        s = math.sqrt(vx * vx + vy * vy + vz * vz)
        scale = 2.0 * math.atan2(s, w) / s if s > 1e-12 else 2.0
        turn = np.array([vx * scale, vy * scale, vz * scale])
        twist = (turn[0] * mean[0] + turn[1] * mean[1] + turn[2] * mean[2]) * mean
        moment = -k_bend * (turn - twist) - k_twist * twist - c_turn * (turn - last_turn[j]) / h
        last_turn[j] = turn
        # the shear forces act at the bodies' centres, a link-length apart: half their couple on each body
        couple = np.array([d[1] * shear[2] - d[2] * shear[1], d[2] * shear[0] - d[0] * shear[2],
                           d[0] * shear[1] - d[1] * shear[0]])
        for a in range(3):
            push = axial * d[a] + shear[a]
            force[f, a] += push
            force[r, a] -= push
            torque[f, a] += moment[a] - 0.5 * couple[a]
            torque[r, a] -= moment[a] + 0.5 * couple[a]
