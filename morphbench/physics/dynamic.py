"""The dynamic planar world: the planar model's springs with inertia, and Coulomb friction that sticks.

Every body is a rigid body in the plane: a position (x, y) and a heading theta, their velocities, its mass and its
rotational inertia about the vertical (``shapes.meshes.mass_properties``: the body's own geometry at its mass, as the
PyBullet world takes it, without that world's ROTATIONAL_INERTIA_SCALE). Links are the planar quasi-static model's
(``planar._link_jacobian``: axial along the link's rest axis turned by its bodies' mean heading, shear across it,
bend the difference of headings), each with a spring and a damper:

- axial: the bellows, rest length ``rest_gap + stroke * pressure`` (the shared pressure law, damage and cuts of
  ``Bellows``), stiffness per link (an open bellows' is its wall's), damping ``damping``, the sum capped at
  ``max_force`` as the PyBullet world caps it;
- shear: ``shear_stiffness`` and ``shear_damping``; bending: ``bending_stiffness`` and ``rotational_damping``.

Friction is the planar model's: each body's limit w = mu m g (its friction scale, the field under it, its pump's
vibration) on the combined sliding-and-turning ball |(F_x, F_y, torque / rho)| <= w, rho its friction radius. It is
applied at the velocity level, implicitly (stick-slip): after the springs' impulse over a step of h, a body stops if
the impulse that stops it, (m v_x, m v_y, I omega / rho), is within h w; else it slides and turns under the limit's
impulse opposing its motion, the exact minimiser of its kinetic energy plus h w |(v_x, v_y, rho omega)| (a scalar
equation per sliding body, solved by safeguarded Newton). So a body held by friction is at rest exactly, and
friction never reverses a motion, whatever the step.

Each step (semi-implicit Euler) is one loop over the links accumulating forces and one over the bodies updating their
velocities, then their poses: linear in the size of the assembly, no global solve. The step is ``PhysicsParams.
dynamic_step`` at most (each tick split into equal steps), chosen by convergence (benchmarks/dynamic_fidelity.py).
A batch's copies are the disjoint pieces of one world (``DynamicCopies``): each body's arithmetic is its own, so a
copy moves bit for bit as it does alone, and a batch of seeds is one compiled call.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from morphbench.errors import ConfigError
from morphbench.params import EnvironmentParams, PhysicsParams
from morphbench.physics.batch import Copies
from morphbench.physics.bellows import FIELD_UPDATE_PERIOD, Bellows
from morphbench.physics.friction import NO_FIELD, factors
from morphbench.physics.planar import PlanarWorld, _link_jacobian, check_one_layer, friction_radius
from morphbench.physics.pressure import _trajectory, pressure_trajectory
from morphbench.shapes.meshes import mass_properties
from morphbench.shapes.model import Shape

NEWTON_TOLERANCE = 1e-13
"""relative error of a sliding body's friction multiplier at which its Newton iteration stops."""


def check_dynamic(shape: Shape) -> None:
    """A ConfigError naming the backend unless ``shape`` lies in one layer on the ground (not a stack)."""
    try:
        check_one_layer(shape)
    except ConfigError:
        raise ConfigError(shape.source, "assembly", "one layer of bodies on the ground for the dynamic physics "
                          "(backend 'dynamic'); use --physics fast or reference for stacks") from None


def substeps(physics: PhysicsParams) -> int:
    """Integration steps per tick: the fewest that keep each at most ``physics.dynamic_step``."""
    return max(1, math.ceil(physics.timestep / physics.dynamic_step * (1 - 1e-12)))


class DynamicWorld(Bellows):
    """The same interface as the other worlds: set phases, advance ticks, read poses; damage, cuts, friction.

    Bodies slide and turn on the ground at their shape's height with their inertia. There is no PyBullet scene.
    """

    backend = "dynamic"

    def __init__(self, shape: Shape, physics: PhysicsParams, environment: EnvironmentParams = EnvironmentParams()):
        super().__init__(shape, environment)
        check_dynamic(shape)
        self.physics = physics
        self.tick = physics.timestep
        """s, one tick: pressures are exact at its ends, poses read and callbacks made at them."""
        self.substeps = substeps(physics)
        """integration steps per tick."""
        self._plane_axes = np.ascontiguousarray(self._axes[:, :2])
        """each link's rest axis in its bodies' own frame, in the plane (one layer: its links are horizontal)."""
        self.q = np.zeros((len(shape.bodies), 3))
        """each body's (x, y) in m and heading in rad: positions start at rest, headings at the shape's yaw."""
        self.q[:, :2] = self._rest[:, :2]
        self.q[:, 2] = shape.yaw
        self.v = np.zeros_like(self.q)
        """each body's velocity (m/s, m/s, rad/s): every body starts at rest."""
        self._mass = np.array([body.mass for body in shape.bodies], dtype=float)
        self._inertia = np.array([mass_properties(body).inertia_diagonal[2] for body in shape.bodies])
        """kg m^2, each body's rotational inertia about the vertical through its centre."""
        radii = {size: friction_radius(size[0], size[1]) for size in {body.size[:2] for body in shape.bodies}}
        self._rho = np.array([radii[body.size[:2]] for body in shape.bodies])
        self._factor = np.ones(len(shape.bodies))
        """each body's friction field factor at its last reading (every FIELD_UPDATE_PERIOD from the start of an
        advance, as the quasi-static worlds read it)."""
        actuator = shape.actuator
        self._damping = np.array([actuator.damping, actuator.shear_damping, actuator.rotational_damping])
        self.time = 0.0
        """s, the pumps' clock (nothing needs settling: bodies start at rest on the ground)."""

    # the planar quasi-static world's, on the same state: (x, y, heading) per body at the shape's height, and each
    # link's axial, shear and bending stiffness
    poses_of = PlanarWorld.poses_of
    _springs = PlanarWorld._springs

    @staticmethod
    def memory(bodies: int, links: int, ticks: int) -> float:
        """bytes it holds that grow with its size: each body's state, mass and friction, each link's springs and
        geometry (about 16 and 12 doubles); an advance holds nothing per tick (its ticks are made in the loop)."""
        return (16 * bodies + 12 * links) * 8

    def poses(self, which=None) -> tuple[np.ndarray, np.ndarray]:
        index = np.arange(len(self.shape.bodies)) if which is None else which
        positions, orientations = self.poses_of(self.q[None], index)
        return positions[0], orientations[0]

    def advance(self, n_ticks: int, on_tick=None, pumps: bool = True, every: int = 1) -> None:
        if n_ticks <= 0:
            return
        start, actuator = self.time, self.shape.actuator
        driver = np.maximum(self.link_units, 0)  # as ``_pressures``: a passive link's pressure is computed, then 0
        phases, periods = self.phases[driver], self.periods[driver]
        pressure_trajectory(self.pressure, phases, start, self.tick, 0, actuator, periods)  # its checks alone
        gate = self._actuated.astype(float) if pumps else np.zeros(len(self.link_units))
        lengths = self._rest_lengths(self.pressure[None])[0]  # the rest lengths now, where the first tick starts
        friction = self._base_friction * self._friction_scale  # as ``QuasiStatic._friction_limits``, tick by tick
        vibration = self.environment.vibration if pumps else 1.0
        modes, constants = NO_FIELD if self._field is None else self._field_modes
        field_every = 0 if self._field is None else max(1, round(FIELD_UPDATE_PERIOD / self.tick))
        springs = self._springs()
        stuck = self._stuck_length if self._any_stuck else np.full(len(self.link_units), np.nan)
        pressure = np.array(self.pressure, dtype=float)
        ends = list(range(every, n_ticks, every)) + [n_ticks] if on_tick is not None else [n_ticks]
        begin = 0
        for end in ends:
            _integrate(self.q, self.v, pressure, lengths, begin, end, start, self.tick, phases, periods, actuator.alpha,
                       actuator.tau_inflate, actuator.tau_vent, gate, self._empty_pitch, self._strokes,
                       self._extends, stuck, friction, self._weights, vibration, self._unit_bodies, self.phases,
                       self.periods, self._dead, self._front, self._rear, self._plane_axes, self.intact, springs,
                       self._damping, actuator.max_force, self._mass, self._inertia, self._rho, self.substeps,
                       self.tick / self.substeps, field_every, modes, constants, self._factor)
            if on_tick is not None and end % every == 0:
                self.pressure, self.time = pressure.copy(), start + end * self.tick
                on_tick(end - 1)
            begin = end
        self.pressure, self.time = pressure, start + n_ticks * self.tick


class DynamicCopies(Copies):
    """``count`` copies of ``shape`` in one DynamicWorld, one per run of a batch (``batch.Copies``)."""

    world_class = DynamicWorld


@numba.njit(cache=True, nogil=True)
def _stick_slip(z, masses, limit):
    """The velocity (in the friction metric z = (v_x, v_y, rho omega)) that minimises
    sum_j masses_j / 2 (z_j - z0_j)^2 + limit |z| over z, from the free velocity z0 (in ``z``, overwritten), with
    ``masses`` (m, m, I / rho^2) and ``limit`` the friction impulse h w (N s). At rest if the impulse that stops the
    body, |masses z0|, is within the limit; else z_j = masses_j z0_j / (masses_j + lam), lam > 0 the root of
    lam |z(lam)| = limit (safeguarded Newton), bracketed by the isotropic answers with the smallest and largest
    mass."""
    a0, a1, a2 = masses[0] * z[0], masses[1] * z[1], masses[2] * z[2]
    impulse = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
    if impulse <= limit:
        z[0] = z[1] = z[2] = 0.0
        return
    if limit <= 0.0:
        return
    low = limit * min(masses[0], masses[2]) / (impulse - limit)
    high = limit * max(masses[0], masses[2]) / (impulse - limit)
    # the isotropic answer with the masses weighted by the impulse's parts (exact for an isotropic body)
    lam = limit * (a0 * a0 * masses[0] + a1 * a1 * masses[1] + a2 * a2 * masses[2]) / (impulse * impulse) \
        / (impulse - limit)
    for _ in range(60):
        # g(lam) = lam |z(lam)| - limit, increasing in lam; g' from the same sums
        s0, s1, s2 = masses[0] + lam, masses[1] + lam, masses[2] + lam
        b0, b1, b2 = a0 / s0, a1 / s1, a2 / s2
        norm = math.sqrt(b0 * b0 + b1 * b1 + b2 * b2)
        g = lam * norm - limit
        if g > 0.0:
            high = lam
        else:
            low = lam
        # d|z|/dlam = -sum b_j^2 / s_j / |z|
        slope = norm - lam * (b0 * b0 / s0 + b1 * b1 / s1 + b2 * b2 / s2) / norm
        step = lam - g / slope if slope > 0.0 else 0.5 * (low + high)
        if abs(step - lam) <= NEWTON_TOLERANCE * lam:  # converged (before the bracket, which rounding may cross)
            lam = step
            break
        lam = step if low < step < high else 0.5 * (low + high)
    z[0], z[1], z[2] = a0 / (masses[0] + lam), a1 / (masses[1] + lam), a2 / (masses[2] + lam)


@numba.njit(cache=True, nogil=True)
def _step(q, v, rest, w, front, rear, axes, intact, springs, damping, cap, mass, inertia, rho, h, force, jac,
          strain, z, metric):
    """One semi-implicit Euler step of h s: every intact link's spring-damper forces into ``force`` (a loop over the
    links), then each body's velocity from them and its stick-slip friction, then its pose from that velocity (a
    loop over the bodies). ``rest`` each link's rest length now, ``w`` each body's friction limit (N)."""
    n = q.shape[0]
    force[:, :] = 0.0
    c_axial, c_shear, c_turn = damping[0], damping[1], damping[2]
    for link in range(len(front)):
        if not intact[link]:
            continue
        f, r = front[link], rear[link]
        _link_jacobian(q, f, r, axes[link, 0], axes[link, 1], rest[link], jac, strain)
        rate0 = rate1 = rate2 = 0.0
        for j in range(3):
            rate0 += jac[0, j] * v[f, j] + jac[0, 3 + j] * v[r, j]
            rate1 += jac[1, j] * v[f, j] + jac[1, 3 + j] * v[r, j]
            rate2 += jac[2, j] * v[f, j] + jac[2, 3 + j] * v[r, j]
        axial = springs[link, 0] * strain[0] + c_axial * rate0
        axial = max(-cap, min(cap, axial))  # the bellows gives way at its force cap
        shear = springs[link, 1] * strain[1] + c_shear * rate1
        bend = springs[link, 2] * strain[2] + c_turn * rate2
        for j in range(3):
            force[f, j] -= axial * jac[0, j] + shear * jac[1, j] + bend * jac[2, j]
            force[r, j] -= axial * jac[0, 3 + j] + shear * jac[1, 3 + j] + bend * jac[2, 3 + j]
    for i in range(n):
        metric[0] = metric[1] = mass[i]
        metric[2] = inertia[i] / (rho[i] * rho[i])
        z[0] = v[i, 0] + h * force[i, 0] / mass[i]
        z[1] = v[i, 1] + h * force[i, 1] / mass[i]
        z[2] = (v[i, 2] + h * force[i, 2] / inertia[i]) * rho[i]
        _stick_slip(z, metric, h * w[i])
        v[i, 0], v[i, 1], v[i, 2] = z[0], z[1], z[2] / rho[i]
        for j in range(3):
            q[i, j] += h * v[i, j]


@numba.njit(cache=True, nogil=True)
def _integrate(q, v, pressure, lengths, first, last, t0, tick, phases, periods, alpha, tau_inflate, tau_vent, gate,
               pitch, strokes, extends, stuck, friction, weights, vibration, unit_bodies, unit_phases, unit_periods,
               dead, front, rear, axes, intact, springs, damping, cap, mass, inertia, rho, steps, h, field_every,
               modes, constants, factor):
    """Advance poses ``q`` and velocities ``v`` (n, 3, in place) through ticks ``first`` to ``last`` (0-based, of an
    advance that started at ``t0``), ``steps`` steps of h per tick. Each tick's pressures are those of
    ``Bellows._pressures`` (the pressure law ``pressure._trajectory`` from ``pressure``, each link's pump ``phases``
    and ``periods``, times ``gate``: 1 for a pumped link, else 0) and its rest lengths those of ``_rest_lengths``
    (``pitch`` + ``strokes`` x pressure x ``extends``, or a stuck bellows' ``stuck`` length where it is not NaN), the
    same numbers in the same order, found tick by tick instead of for every tick of the advance at once: nothing
    here grows with the number of ticks. ``pressure`` and ``lengths`` (each link's rest length) are where the first
    tick starts on entry and where the last ends on return; the rest lengths are interpolated linearly inside a tick.
    Each body's friction limit on a uniform ground is that of ``QuasiStatic._friction_limits``: its ``friction``
    (its scale's) times its weight, a unit's times ``vibration`` at the ticks its pump starts running (``_pumping``:
    by its unit's phase and period, unless ``dead``; 1.0 is none), scaled by the friction field (``friction.factors``)
    at the bodies' places, read into ``factor`` (kept between calls) when the tick's index is a multiple of
    field_every > 0."""
    n, n_links = q.shape[0], len(front)
    force = np.zeros((n, 3))
    jac, strain = np.empty((3, 6)), np.empty(3)
    z, metric = np.empty(3), np.empty(3)
    rest = np.empty(n_links)
    w, limits = np.empty(n), np.empty(n)
    for i in range(n):
        limits[i] = friction[i] * weights[i]
    start = lengths.copy()
    for k in range(first, last):
        # the tick of ``_trajectory(p, ..., t0, tick, n_ticks, ...)``'s row k: it starts at t0 + tick * k
        row = _trajectory(pressure, phases, t0 + tick * k, tick, 1, periods, alpha, tau_inflate, tau_vent)[0]
        for link in range(n_links):
            pressure[link] = row[link] * gate[link]
            length = pitch[link] + strokes[link] * pressure[link] * extends[link]
            lengths[link] = length if math.isnan(stuck[link]) else stuck[link]
        if field_every > 0 and k % field_every == 0:
            factors(q[:, 0].copy(), q[:, 1].copy(), modes, constants, factor)
        if vibration != 1.0:
            time = t0 + tick * k  # the tick's start, as ``_pumping`` takes it
            for u in range(len(unit_bodies)):
                b = unit_bodies[u]
                pumping = (time / unit_periods[u] - unit_phases[u]) % 1.0 < alpha and not dead[u]
                limits[b] = friction[b] * (vibration if pumping else 1.0) * weights[b]
        for i in range(n):
            w[i] = limits[i] * factor[i] if field_every > 0 else limits[i]
        for s in range(steps):
            fraction = (s + 1) / steps
            for link in range(n_links):
                rest[link] = start[link] + fraction * (lengths[link] - start[link])
            _step(q, v, rest, w, front, rear, axes, intact, springs, damping, cap, mass, inertia, rho, h, force,
                  jac, strain, z, metric)
        for link in range(n_links):
            start[link] = lengths[link]
