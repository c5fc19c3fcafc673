"""The planar quasi-static world: springs and Coulomb friction with no inertia, for assemblies lying on the ground.

The quasi-static model of a chain (``quasistatic.py``) in the plane: each body has a position (x, y) and a heading
theta, and over each tick its increment u_i = (dx, dy, dtheta) minimises the incremental energy

    E(u) = sum_links [psi(axial) + k_s/2 shear^2 + k_b/2 bend^2] + sum_i w_i sqrt(dx^2 + dy^2 + (rho_i dtheta)^2)

A link measures its two bodies in its own frame, turned by their mean heading: ``axial`` is the centre distance
along the link's rest axis less its pressure-driven rest length (``psi`` is k/2 z^2 with the force capped at
``max_force``, as in a chain), ``shear`` the sideways offset, ``bend`` the difference of headings. w_i is the body's
friction limit and rho_i its friction radius (the mean distance of its footprint from its centre, so that a body
turning on the spot meets the friction torque of a uniformly loaded footprint; the combined sliding-and-turning limit
is the ellipsoidal approximation of the limit surface, which keeps the energy convex).

Each tick the links' strains are linearised about the current poses (computed exactly, so errors do not add up over
ticks) and the convex problem is solved to a force tolerance by a semismooth Newton method: the bodies that slide
satisfy force balance with friction opposing their motion, the others satisfy the stick condition
|spring force| <= w_i (the torque scaled by rho_i). A Newton step is taken only where it lowers the residual without
raising the forward-backward envelope (a merit whose minimisers are the energy's), else a proximal gradient step that
lowers it for sure: the solve converges from any start, frictionless bodies and bodies on the verge of sliding
included (tests/test_planar_seeds.py). The Newton systems couple a body only to its neighbours. Below SPARSE_FROM
bodies they are solved banded (a lattice lists neighbours within a row of each other: a row's width squared per
body, N^2 on a square sheet); from it, by a sparse factorisation in nested dissection order (``cholesky``: N log N
memory, about N^1.5 work), which answers the same to rounding (tests/test_planar_sparse.py).
"""

from __future__ import annotations

import numba
import numpy as np

from morphbench.errors import ConfigError
from morphbench.params import EnvironmentParams, PhysicsParams
from morphbench.physics import cholesky
from morphbench.physics.bellows import Bellows, QuasiStatic
from morphbench.physics.friction import factors
from morphbench.shapes.model import Shape

_FLAT_TOLERANCE = 1e-9  # m: bodies whose centres differ in height by more than this are not on one layer
FORCE_TOLERANCE = 1e-10
"""N, largest force imbalance (and stick-condition violation) a solve leaves."""
SUFFICIENT = 1e-4
"""the least fraction of the residual a Newton step must remove to be taken."""
SPARSE_FROM = 128
"""bodies: a shape this large solves its Newton systems by the sparse factorisation (``cholesky``), whose work grows
as N log N against the band's N^2; smaller ones keep the banded solver (their runs' records unchanged)."""
ENVELOPE_ROUNDING = 1e-12
"""relative rise of the envelope a Newton step may make: its rounding near the solution, not a real rise."""


def check_one_layer(shape: Shape) -> None:
    """A ConfigError unless every body lies on the ground in one layer (not a stack): what the planar model needs."""
    heights = [body.position[2] for body in shape.bodies]
    if max(heights) - min(heights) > _FLAT_TOLERANCE:
        raise ConfigError(shape.source, "assembly", "one layer of bodies on the ground for the planar quasi-static "
                          "physics; use --physics fast or reference for stacks")


def friction_radius(length: float, width: float, samples: int = 64) -> float:
    """m, the mean distance of a uniformly loaded length x width footprint from its centre (midpoint rule)."""
    x = (np.arange(samples) + 0.5) / samples - 0.5
    xx, yy = np.meshgrid(x * length, x * width)
    return float(np.mean(np.hypot(xx, yy)))


class PlanarWorld(QuasiStatic):
    """The same interface as the other worlds: set phases, advance ticks, read poses; damage, cuts, friction.

    Bodies slide and turn on the ground at their shape's height. There is no PyBullet scene.
    """

    backend = "planar"

    def __init__(self, shape: Shape, physics: PhysicsParams, environment: EnvironmentParams = EnvironmentParams(),
                 sparse: bool | None = None):
        super().__init__(shape, environment)
        self.physics = physics
        self.tick = physics.timestep
        """s, one solve: pressures and poses are updated every tick."""
        check_one_layer(shape)
        self._plane_axes = np.ascontiguousarray(self._axes[:, :2])
        """each link's rest axis in its bodies' own frame, in the plane (one layer: its links are horizontal)."""
        self.q = np.zeros((len(shape.bodies), 3))
        """each body's (x, y) in m and heading in rad: positions start at rest, headings at the shape's yaw."""
        self.q[:, :2] = self._rest[:, :2]
        self.q[:, 2] = shape.yaw
        self._last = np.zeros_like(self.q)
        """the previous tick's increments: where the next solve starts from."""
        radii = {size: friction_radius(size[0], size[1]) for size in {body.size[:2] for body in shape.bodies}}
        self._rho = np.array([radii[body.size[:2]] for body in shape.bodies])
        self.sparse = len(shape.bodies) >= SPARSE_FROM if sparse is None else sparse
        """whether the Newton systems are solved by the sparse factorisation (else the banded one)."""
        self._pattern = cholesky.structure(self._rest[:, :2], self._front, self._rear) if self.sparse \
            else cholesky.NONE
        """the sparse factor's pattern of the Newton systems, or none."""
        self.newton_steps = 0
        """Newton steps taken so far (a measure of the solver's work)."""
        self.unconverged_ticks = 0
        """ticks whose solve stopped before meeting FORCE_TOLERANCE (expected 0)."""
        self.time = 0.0
        """s, the pumps' clock (nothing needs settling: bodies start at rest on the ground)."""

    @staticmethod
    def memory(bodies: int, links: int, ticks: int) -> float:
        """``Bellows.memory`` and the solver's: the Newton systems' factor and blocks, or the banded solver's dense
        Hessians."""
        if bodies >= SPARSE_FROM:
            solver = cholesky.memory(bodies) + 2 * (bodies + links) * 9 * 8
        else:
            solver = 3 * (3 * bodies) ** 2 * 8
        return Bellows.memory(bodies, links, ticks) + solver

    @property
    def state(self) -> np.ndarray:
        return self.q

    def _springs(self) -> np.ndarray:
        """(n_links, 3): each link's axial (N/m), shear (N/m) and bending (N m/rad) stiffness."""
        actuator = self.shape.actuator
        springs = np.empty((len(self.link_stiffness), 3))
        springs[:, 0] = self.link_stiffness
        springs[:, 1], springs[:, 2] = actuator.shear_stiffness, actuator.bending_stiffness
        return springs

    def _solve(self, lengths, limits, record, states, first_tick, field_every, modes, constants) -> None:
        total, failed = _solve_ticks(self.q, self._last, lengths, limits, self._front, self._rear, self._plane_axes,
                                     self.intact, self._springs(), self.shape.actuator.max_force, self._rho, record,
                                     states, first_tick, field_every, modes, constants, self._factor, self._pattern)
        self.newton_steps += total
        self.unconverged_ticks += failed

    def poses_of(self, states: np.ndarray, which) -> tuple[np.ndarray, np.ndarray]:
        index = np.asarray(which, dtype=int)
        k, n = len(states), len(index)
        positions = np.empty((k, n, 3))
        positions[:, :, :2] = states[:, index, :2]
        positions[:, :, 2] = self._rest[index, 2]
        half = states[:, index, 2] / 2
        orientations = np.zeros((k, n, 4))
        orientations[:, :, 2], orientations[:, :, 3] = np.sin(half), np.cos(half)
        return positions, orientations


@numba.njit(cache=True, nogil=True)
def _link_jacobian(q, f, r, ax0, ax1, length, jac, strain):
    """Fill ``strain`` (axial less ``length``, shear, bend) of the link from body ``r`` to body ``f`` at the poses
    ``q`` and ``jac``, its derivative in (x_f, y_f, theta_f, x_r, y_r, theta_r): turning the frame turns the axes."""
    dx, dy = q[f, 0] - q[r, 0], q[f, 1] - q[r, 1]
    mean = 0.5 * (q[f, 2] + q[r, 2])
    c, s = np.cos(mean), np.sin(mean)
    ax, ay = c * ax0 - s * ax1, s * ax0 + c * ax1
    bx, by = -ay, ax
    along, across = dx * ax + dy * ay, dx * bx + dy * by
    strain[0], strain[1], strain[2] = along - length, across, q[f, 2] - q[r, 2]
    jac[0, 0], jac[0, 1], jac[0, 2], jac[0, 3], jac[0, 4], jac[0, 5] = ax, ay, 0.5 * across, -ax, -ay, 0.5 * across
    jac[1, 0], jac[1, 1], jac[1, 2], jac[1, 3], jac[1, 4], jac[1, 5] = bx, by, -0.5 * along, -bx, -by, -0.5 * along
    jac[2, 0], jac[2, 1], jac[2, 2], jac[2, 3], jac[2, 4], jac[2, 5] = 0.0, 0.0, 1.0, 0.0, 0.0, -1.0


@numba.njit(cache=True, nogil=True)
def _spring(m, z, k, cap):
    """(energy J, force, curvature) of strain component ``m`` at ``z`` (stiffness ``k``; the axial one capped)."""
    if m == 0 and abs(k * z) > cap:  # the bellows gives way at its force cap: linear energy, no stiffness
        return cap * abs(z) - 0.5 * cap * cap / k, cap if z > 0 else -cap, 0.0
    return 0.5 * k * z * z, k * z, k


@numba.njit(cache=True, nogil=True)
def _link_terms(q, u, front, rear, axes, intact, stiffness, cap, lengths, grad, hess):
    """Add the gradient and the (generalised) Hessian of the links' elastic energy at increments ``u`` (linearised
    strains about ``q``) into ``grad`` and ``hess``; returns that energy (J)."""
    energy = 0.0
    jac = np.empty((3, 6))
    strain = np.empty(3)
    index = np.empty(6, dtype=np.int64)
    for link in range(len(front)):
        if not intact[link]:
            continue
        f, r = front[link], rear[link]
        _link_jacobian(q, f, r, axes[link, 0], axes[link, 1], lengths[link], jac, strain)
        for j in range(3):
            index[j], index[3 + j] = 3 * f + j, 3 * r + j
        for m in range(3):
            z = strain[m]
            for j in range(6):
                z += jac[m, j] * u[index[j]]
            term, force, curvature = _spring(m, z, stiffness[link, m], cap)
            energy += term
            for j in range(6):
                grad[index[j]] += force * jac[m, j]
                if curvature != 0.0:
                    for i in range(6):
                        hess[index[i], index[j]] += curvature * jac[m, i] * jac[m, j]
    return energy


@numba.njit(cache=True, nogil=True)
def _link_blocks(q, u, front, rear, axes, intact, stiffness, cap, lengths, grad, blocks):
    """``_link_terms`` with the Hessian in 3 x 3 blocks: ``blocks[i]`` body i's own (added to), ``blocks[n +
    link]`` the link's front-rear block (overwritten; 0 for a cut link)."""
    n = len(grad) // 3
    energy = 0.0
    jac = np.empty((3, 6))
    strain = np.empty(3)
    for link in range(len(front)):
        blocks[n + link] = 0.0
        if not intact[link]:
            continue
        f, r = front[link], rear[link]
        _link_jacobian(q, f, r, axes[link, 0], axes[link, 1], lengths[link], jac, strain)
        for m in range(3):
            z = strain[m]
            for j in range(3):
                z += jac[m, j] * u[3 * f + j] + jac[m, 3 + j] * u[3 * r + j]
            term, force, curvature = _spring(m, z, stiffness[link, m], cap)
            energy += term
            for j in range(3):
                grad[3 * f + j] += force * jac[m, j]
                grad[3 * r + j] += force * jac[m, 3 + j]
            if curvature != 0.0:
                for i in range(3):
                    for j in range(3):
                        blocks[f, i, j] += curvature * jac[m, i] * jac[m, j]
                        blocks[r, i, j] += curvature * jac[m, 3 + i] * jac[m, 3 + j]
                        blocks[n + link, i, j] += curvature * jac[m, i] * jac[m, 3 + j]
    return energy


@numba.njit(cache=True, nogil=True)
def _solve_spd(K, b, width):
    """x with K x = b for a symmetric positive definite K (banded Cholesky: a lattice's bodies in row order couple
    only within a few rows, so the band is narrow; K is overwritten); NaN if K is not definite to rounding. K is 0
    more than ``width`` off its diagonal."""
    m = len(b)
    band = 0
    for i in range(m):
        for j in range(max(0, i - width), i):
            if K[i, j] != 0.0:
                band = max(band, i - j)
                break
    for j in range(m):
        first = max(0, j - band)
        d = K[j, j]
        for p in range(first, j):
            d -= K[j, p] * K[j, p]
        if not d > 0.0:  # not definite to rounding: no step (the caller falls back on a proximal gradient step)
            return np.full(m, np.nan)
        d = np.sqrt(d)
        K[j, j] = d
        for i in range(j + 1, min(m, j + band + 1)):
            v = K[i, j]
            for p in range(max(first, i - band), j):
                v -= K[i, p] * K[j, p]
            K[i, j] = v / d
    x = b.copy()
    for i in range(m):
        for p in range(max(0, i - band), i):
            x[i] -= K[i, p] * x[p]
        x[i] /= K[i, i]
    for i in range(m - 1, -1, -1):
        for p in range(i + 1, min(m, i + band + 1)):
            x[i] -= K[p, i] * x[p]
        x[i] /= K[i, i]
    return x


@numba.njit(cache=True, nogil=True)
def _reach(front, rear):
    """The farthest apart (in body order) two linked bodies are: the Hessian is 0 beyond 3 reach + 2 of its
    diagonal, so its passes keep to that band (a 200-row grid's are 70 times shorter)."""
    reach = 0
    for link in range(len(front)):
        reach = max(reach, abs(front[link] - rear[link]))
    return reach


@numba.njit(cache=True, nogil=True)
def _clear(hess, reach):
    """Zero the band of ``hess`` (the rest is 0 from the start and never written)."""
    size, band = len(hess), 3 * reach + 2
    if band + 1 >= size:
        hess[:, :] = 0.0
        return
    for a in range(size):
        for b in range(max(0, a - band), min(size, a + band + 1)):
            hess[a, b] = 0.0


@numba.njit(cache=True, nogil=True)
def _apply_root(n, root, x):
    """x <- (n n^T + root (I - n n^T)) x, in place (a 3-vector; n a unit vector)."""
    along = n[0] * x[0] + n[1] * x[1] + n[2] * x[2]
    for j in range(3):
        x[j] = root * x[j] + (1.0 - root) * along * n[j]


@numba.njit(cache=True, nogil=True)
def _slide(v, i, limits, gamma, direction):
    """Body ``i`` sliding (its gradient step ``v`` outside its friction ball): fills ``direction`` (the unit vector
    it slides along) and returns the square root of d prox along the other directions and the friction's stiffness
    across its motion (the Newton system's terms for the body)."""
    norm = np.sqrt(v[3 * i] ** 2 + v[3 * i + 1] ** 2 + v[3 * i + 2] ** 2)
    t = gamma * limits[i] / norm
    for j in range(3):
        direction[j] = v[3 * i + j] / norm
    return np.sqrt(1.0 - t), t / gamma


@numba.njit(cache=True, nogil=True)
def _residual(q, z, scale, front, rear, axes, intact, stiffness, cap, lengths, limits, gamma, work):
    """The proximal-gradient residual z - prox(z - gamma grad) in the scaled increments z = (dx, dy, rho dtheta);
    fills the ``work`` arrays (``_workspace``): the gradient step ``v``, ``prox`` and the smooth part's gradient
    and Hessian (in z). Returns its largest entry over gamma (the largest force imbalance, N) and the
    forward-backward envelope at z (J): the energy f + h (springs f, friction h) of the proximal gradient step's
    linear model, f(z) + grad (p - z) + |p - z|^2 / 2 gamma + h(p) at p = prox. It is at least the energy at p, and
    the step lowers it by at least |p - z|^2 (1 / gamma - L) / 2 (L the largest curvature of f): the merit that
    makes the solver converge (``_solve_tick``)."""
    grad, hess, blocks, v, prox = work
    n = len(limits)
    u = z / scale
    grad[:] = 0.0
    if len(hess):
        reach = _reach(front, rear)
        _clear(hess, reach)
        envelope = _link_terms(q, u, front, rear, axes, intact, stiffness, cap, lengths, grad, hess)
        band = 3 * reach + 2
        for a in range(3 * n):
            grad[a] /= scale[a]
            for b in range(max(0, a - band), min(3 * n, a + band + 1)):
                if hess[a, b] != 0.0:  # most entries are 0 (bodies far apart); a division costs more than the test
                    hess[a, b] /= scale[a] * scale[b]
    else:
        blocks[:n] = 0.0
        envelope = _link_blocks(q, u, front, rear, axes, intact, stiffness, cap, lengths, grad, blocks)
        _scale_blocks(grad, blocks, front, rear, scale)
    worst = 0.0
    for i in range(n):
        norm = 0.0
        for j in range(3):
            v[3 * i + j] = z[3 * i + j] - gamma * grad[3 * i + j]
            norm += v[3 * i + j] ** 2
        norm = np.sqrt(norm)
        shrink = max(0.0, 1.0 - gamma * limits[i] / norm) if norm > 0.0 else 0.0
        envelope += limits[i] * shrink * norm
        for j in range(3):
            prox[3 * i + j] = shrink * v[3 * i + j]
            step = prox[3 * i + j] - z[3 * i + j]
            envelope += grad[3 * i + j] * step + 0.5 * step * step / gamma
            worst = max(worst, abs(step) / gamma)
    # max() passes NaN over: increments that are not finite must never pass for a solution or an improvement
    return (worst, envelope) if np.isfinite(envelope) else (np.inf, np.inf)


@numba.njit(cache=True, nogil=True)
def _scale_blocks(grad, blocks, front, rear, scale):
    """The gradient and the block Hessian in the scaled increments z (divided by the scale of their rows and
    columns)."""
    n = len(grad) // 3
    for i in range(n):
        for a in range(3):
            grad[3 * i + a] /= scale[3 * i + a]
            for b in range(3):
                blocks[i, a, b] /= scale[3 * i + a] * scale[3 * i + b]
    for link in range(len(front)):
        for a in range(3):
            for b in range(3):
                blocks[n + link, a, b] /= scale[3 * front[link] + a] * scale[3 * rear[link] + b]


@numba.njit(cache=True, nogil=True)
def _step_size(q, front, rear, axes, intact, stiffness, lengths, scale, work):
    """1 / (a bound on the largest eigenvalue of the scaled Hessian): its uncapped largest row sum (Gershgorin)."""
    grad, hess, blocks, _, _ = work
    n = len(scale) // 3
    grad[:] = 0.0
    top = 0.0
    if len(hess):
        reach = _reach(front, rear)
        band = 3 * reach + 2
        _clear(hess, reach)
        _link_terms(q, np.zeros(3 * n), front, rear, axes, intact, stiffness, np.inf, lengths, grad, hess)
        for a in range(3 * n):
            row = 0.0
            for b in range(max(0, a - band), min(3 * n, a + band + 1)):
                row += abs(hess[a, b]) / (scale[a] * scale[b])
            top = max(top, row)
        return top
    blocks[:n] = 0.0
    _link_blocks(q, np.zeros(3 * n), front, rear, axes, intact, stiffness, np.inf, lengths, grad, blocks)
    _scale_blocks(grad, blocks, front, rear, scale)
    rows = np.zeros(3 * n)
    for i in range(n):
        for a in range(3):
            for b in range(3):
                rows[3 * i + a] += abs(blocks[i, a, b])
    for link in range(len(front)):
        f, r = front[link], rear[link]
        for a in range(3):
            for b in range(3):
                rows[3 * f + a] += abs(blocks[n + link, a, b])
                rows[3 * r + b] += abs(blocks[n + link, a, b])
    return rows.max() if n else 0.0


@numba.njit(cache=True, nogil=True)
def _solve_tick(q, u, lengths, limits, front, rear, axes, intact, stiffness, cap, scale, work, t_work, system):
    """Increments ``u`` (3 n, updated in place from its initial guess) minimising the tick's incremental energy;
    returns the number of Newton steps, -1 if FORCE_TOLERANCE was not met.

    Semismooth Newton on the fixed point z = prox(z - gamma grad f(z)) of the proximal gradient method (the prox
    of the friction term shrinks each body's scaled increment towards 0 by gamma w_i): where the gradient step leaves
    a body inside its friction ball it sticks (z_i = 0), elsewhere the Newton system couples the sliding bodies
    through the springs and the friction's stiffness across their motion. A step that does not lower the residual
    without raising the forward-backward envelope (or has no finite value) gives way to the proximal gradient step
    itself, which always lowers the envelope (see the line search).

    ``scale`` is the friction metric (1, 1, rho) per body; ``work`` and ``t_work`` are workspace (``_workspace``:
    the gradient, Hessian, gradient step and prox of the current and of the trial increments), overwritten;
    ``system`` the sparse factor's pattern and workspace (``_workspace``), empty for the banded one."""
    n = len(limits)
    z = u * scale
    top = _step_size(q, front, rear, axes, intact, stiffness, lengths, scale, work)
    gamma = 1.0 / max(top, 1e-12)
    floor = 1e-9 * top  # keeps the Newton system definite where a sliding group's motion is undetermined to first order
    worst, merit = _residual(q, z, scale, front, rear, axes, intact, stiffness, cap, lengths, limits, gamma, work)
    dz = np.empty(3 * n)
    for iterations in range(200):
        if worst <= FORCE_TOLERANCE:
            u[:] = z / scale
            return iterations
        # Sticking bodies go to rest; the sliding ones solve the reduced Newton system.
        active = np.zeros(n, dtype=np.bool_)
        count = 0
        for i in range(n):
            if work[4][3 * i] != 0.0 or work[4][3 * i + 1] != 0.0 or work[4][3 * i + 2] != 0.0:
                active[i] = True
                count += 1
            for j in range(3):
                dz[3 * i + j] = -z[3 * i + j] if not active[i] else 0.0
        # The Newton system J dz = -r (J = I - D (I - gamma H), D = d prox: n n^T + (1 - t)(I - n n^T) for a body
        # sliding along n, t = gamma w / |v|) made symmetric by S = D^(1/2): dz = S y with
        # (S H S + t / gamma (I - n n^T)) y = -S^-1 r / gamma - S H dz_sticking. Dividing by D instead (the
        # friction's curvature w / |z| across the motion) overflows for a body that barely slides.
        if count > 0 and len(work[1]):
            _banded_step(z, work, limits, gamma, floor, active, count, front, rear, dz)
        elif count > 0:
            _sparse_step(z, work, limits, gamma, floor, active, front, rear, intact, system, dz)
        # A Newton step is taken if it lowers the residual by a fixed fraction without raising the envelope; else
        # the proximal gradient step, which lowers the envelope by |r|^2 (1 / gamma - L) / 2 and does not raise
        # the residual's norm. So neither undoes the other, and the residual goes to 0 from any start (alternating
        # them on the residual alone could cycle: most ticks of grids with frictionless bodies never converged).
        length = 1.0
        newton = False
        for _ in range(12 if np.isfinite(np.sum(dz)) else 0):
            trial = z + length * dz
            t_worst, t_merit = _residual(q, trial, scale, front, rear, axes, intact, stiffness, cap, lengths, limits,
                                         gamma, t_work)
            if t_worst < (1.0 - SUFFICIENT) * worst and t_merit <= merit + ENVELOPE_ROUNDING * abs(merit):
                newton = True
                break
            length *= 0.5
        if not newton:
            trial = work[4].copy()  # the proximal gradient step
            t_worst, t_merit = _residual(q, trial, scale, front, rear, axes, intact, stiffness, cap, lengths, limits,
                                         gamma, t_work)
        z = trial
        worst, merit = t_worst, t_merit
        work, t_work = t_work, work
    u[:] = z / scale
    return -1


@numba.njit(cache=True, nogil=True)
def _banded_step(z, work, limits, gamma, floor, active, count, front, rear, dz):
    """The Newton step of the sliding bodies into ``dz`` (the sticking ones' already there), through the reduced
    system in body order (banded Cholesky: a small shape's, about a row's width squared per body)."""
    _, hess, _, v, prox = work
    n = len(limits)
    reach = _reach(front, rear)
    band = 3 * reach + 2
    r = np.empty(3)
    m = 3 * count
    dofs = np.empty(m, dtype=np.int64)
    c = 0
    for i in range(n):
        if active[i]:
            for j in range(3):
                dofs[c] = 3 * i + j
                c += 1
    nrm = np.empty((count, 3))
    root = np.empty(count)
    across = np.empty(count)
    for c in range(count):
        root[c], across[c] = _slide(v, dofs[3 * c] // 3, limits, gamma, nrm[c])
    M = np.empty((m, m))
    rhs = np.empty(m)
    for a in range(m):
        acc = 0.0
        for b in range(max(0, dofs[a] - band), min(3 * n, dofs[a] + band + 1)):
            acc += hess[dofs[a], b] * dz[b]  # the sticking bodies' return to rest
        rhs[a] = -acc
    for c in range(count):
        for d in range(count):  # S_c H_cd S_d, block by block (most blocks are 0: bodies far apart)
            if abs(dofs[3 * c] - dofs[3 * d]) > 3 * reach:
                M[3 * c:3 * c + 3, 3 * d:3 * d + 3] = 0.0
                continue
            nonzero = False
            for j in range(3):
                for col in range(3):
                    M[3 * c + j, 3 * d + col] = h = hess[dofs[3 * c + j], dofs[3 * d + col]]
                    nonzero = nonzero or h != 0.0
            if nonzero:
                for j in range(3):
                    _apply_root(nrm[d], root[d], M[3 * c + j, 3 * d:3 * d + 3])
                for col in range(3):
                    _apply_root(nrm[c], root[c], M[3 * c:3 * c + 3, 3 * d + col])
        _apply_root(nrm[c], root[c], rhs[3 * c:3 * c + 3])
        i = dofs[3 * c] // 3
        for j in range(3):
            r[j] = z[3 * i + j] - prox[3 * i + j]
        _apply_root(nrm[c], 1.0 / root[c], r)
        for j in range(3):
            rhs[3 * c + j] -= r[j] / gamma
            M[3 * c + j, 3 * c + j] += floor + across[c]
            for col in range(3):
                M[3 * c + j, 3 * c + col] -= across[c] * nrm[c, j] * nrm[c, col]
    step = _solve_spd(M, rhs, band)
    for c in range(count):
        _apply_root(nrm[c], root[c], step[3 * c:3 * c + 3])
    for a in range(m):
        dz[dofs[a]] = step[a]


@numba.njit(cache=True, nogil=True)
def _sparse_step(z, work, limits, gamma, floor, active, front, rear, intact, system, dz):
    """``_banded_step`` through the whole system in nested dissection order (``cholesky``): a sticking body's rows
    are the identity's, so the pattern and its factor's are the shape's whatever slides."""
    _, _, blocks, v, prox = work
    pattern, factor_blocks, where, x = system
    position, columns, rows = pattern.position, pattern.columns, pattern.rows
    n = len(limits)
    nrm = np.zeros((n, 3))
    root, across = np.ones(n), np.zeros(n)
    r = np.empty(3)
    factor_blocks[:] = 0.0
    for i in range(n):
        p = position[i]
        d = factor_blocks[columns[p]]
        if not active[i]:
            for j in range(3):
                d[j, j] = 1.0
                x[p, j] = dz[3 * i + j]
            continue
        root[i], across[i] = _slide(v, i, limits, gamma, nrm[i])
        d[:, :] = blocks[i]
        for j in range(3):
            _apply_root(nrm[i], root[i], d[j, :])
        for col in range(3):
            _apply_root(nrm[i], root[i], d[:, col])
        x[p] = 0.0
    for link in range(len(front)):
        f, r_ = front[link], rear[link]
        if not intact[link] or not (active[f] or active[r_]):
            continue
        h = blocks[n + link]  # H_fr: the front body's rows, the rear's columns
        if active[f] and active[r_]:
            target = factor_blocks[pattern.link_slots[link]]
            # the block stored is S_f H_fr S_r, or its transpose where the rear body is eliminated last
            row, col_body = (f, r_) if position[f] > position[r_] else (r_, f)
            for j in range(3):
                for col in range(3):
                    target[j, col] += h[j, col] if row == f else h[col, j]
            for j in range(3):
                _apply_root(nrm[col_body], root[col_body], target[j, :])
            for col in range(3):
                _apply_root(nrm[row], root[row], target[:, col])
        elif active[f]:  # the sticking rear body's return to rest
            for j in range(3):
                x[position[f], j] -= h[j, 0] * dz[3 * r_] + h[j, 1] * dz[3 * r_ + 1] + h[j, 2] * dz[3 * r_ + 2]
        else:
            for j in range(3):
                x[position[r_], j] -= h[0, j] * dz[3 * f] + h[1, j] * dz[3 * f + 1] + h[2, j] * dz[3 * f + 2]
    for i in range(n):
        if not active[i]:
            continue
        p = position[i]
        d = factor_blocks[columns[p]]
        _apply_root(nrm[i], root[i], x[p])
        for j in range(3):
            r[j] = z[3 * i + j] - prox[3 * i + j]
        _apply_root(nrm[i], 1.0 / root[i], r)
        for j in range(3):
            x[p, j] -= r[j] / gamma
            d[j, j] += floor + across[i]
            for col in range(3):
                d[j, col] -= across[i] * nrm[i, j] * nrm[i, col]
    if not cholesky.factor(factor_blocks, columns, rows, pattern.row_starts, pattern.row_slots, pattern.row_columns,
                           where):
        dz[:] = np.nan  # not definite to rounding: no step (the caller falls back on a proximal gradient step)
        return
    cholesky.solve(factor_blocks, columns, rows, x)
    for i in range(n):
        if active[i]:
            _apply_root(nrm[i], root[i], x[position[i]])
            for j in range(3):
                dz[3 * i + j] = x[position[i], j]


@numba.njit(cache=True, nogil=True)
def _workspace(n, links, sparse):
    """The arrays one evaluation of ``_residual`` fills: gradient, Hessian (dense for the banded solver, (0, 0)
    else), its 3 x 3 blocks (per body, then per link; none for the banded solver), gradient step and prox."""
    hess = np.zeros((0, 0)) if sparse else np.zeros((3 * n, 3 * n))
    blocks = np.zeros((n + links, 3, 3) if sparse else (0, 3, 3))
    return np.empty(3 * n), hess, blocks, np.empty(3 * n), np.empty(3 * n)


@numba.njit(cache=True, nogil=True)
def _solve_ticks(q, last, lengths, limits, front, rear, axes, intact, stiffness, cap, rho, record, states,
                 first_tick, field_every, modes, constants, factor, pattern):
    """Advance the poses ``q`` (n, 3, in place) through the ticks of ``lengths`` / ``limits``; ``last`` holds the
    previous increments, each tick's first guess. After tick t, ``q`` is copied to ``states[record[t]]`` if
    ``record[t]`` >= 0. The limits are scaled by the friction field (``friction.factors``) at the bodies' places,
    read into ``factor`` (kept between calls) when first_tick + t is a multiple of field_every > 0. ``pattern``: the
    sparse factor's (``cholesky.structure``), or empty for the banded solver."""
    n = q.shape[0]
    u = np.empty(3 * n)
    scale = np.ones(3 * n)  # the friction metric: (1, 1, rho) per body
    scale[2::3] = rho
    sparse = len(pattern.columns) > 0
    work, t_work = _workspace(n, len(front), sparse), _workspace(n, len(front), sparse)
    system = (pattern, np.zeros((len(pattern.rows), 3, 3)), np.empty(n, dtype=np.int64), np.empty((n, 3)))
    total, failed = 0, 0
    w = np.empty(n)
    for t in range(lengths.shape[0]):
        if field_every > 0 and (first_tick + t) % field_every == 0:
            factors(q[:, 0].copy(), q[:, 1].copy(), modes, constants, factor)
        for i in range(n):
            w[i] = limits[t, i] * factor[i] if field_every > 0 else limits[t, i]
        for i in range(n):
            for j in range(3):
                u[3 * i + j] = last[i, j]
        iterations = _solve_tick(q, u, lengths[t], w, front, rear, axes, intact, stiffness, cap, scale, work, t_work,
                                 system)
        if iterations < 0:
            failed += 1
        else:
            total += iterations
        for i in range(n):
            for j in range(3):
                last[i, j] = u[3 * i + j]
                q[i, j] += u[3 * i + j]
        if record[t] >= 0:
            states[record[t]] = q
    return total, failed
