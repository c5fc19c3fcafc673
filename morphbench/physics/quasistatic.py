"""The quasi-static world: springs and Coulomb friction with no inertia, for assemblies whose links lie on one axis.

Units weigh tens of grams and bellows move over tenths of a second, so inertia is negligible next to friction and a
chain follows the quasi-static evolution of its springs and friction (docs/paper.md, The physics). Over each tick the
displacements d of the bodies along the axis minimise the incremental energy

    E(d) = sum_j H_j(d_a(j) - d_b(j) - c_j) + sum_i w_i |d_i|

where H_j is bellows j's elastic energy (k/2 z^2, its force capped at ``max_force``), c_j how far the bellows is
from its pressure-driven rest length, and w_i = mu_i m_i g body i's friction limit (times scale, field, vibration).
A body moves only when the spring forces on it exceed its friction, and then only as far as they do.

Along a chain the problem is a path, and it is solved exactly by dynamic programming on the derivative of the
energy (a monotone piecewise-linear graph per body, two breakpoints more per body): forward messages, then a
backward pass. The rate-independent solution depends on time only through the pressures, so a tick of a few ms is
converged (docs/fidelity.md). This is both a fast backend and the oracle the PyBullet world is tested against.
"""

from __future__ import annotations

import numba
import numpy as np

from morphbench.errors import ConfigError
from morphbench.params import EnvironmentParams, PhysicsParams
from morphbench.physics.bellows import QuasiStatic
from morphbench.physics.friction import factors
from morphbench.shapes.model import Shape

_AXIS_TOLERANCE = 1e-9  # links whose directions differ by more than this are not on one axis


def chain_axis(shape: Shape) -> np.ndarray:
    """The unit vector every link of ``shape`` lies along; a ConfigError if the links are not all on one line
    through their bodies (a grid, a stack, a branched assembly)."""
    positions = np.array([body.position for body in shape.bodies], dtype=float)
    if not shape.links:
        return np.array([1.0, 0.0, 0.0])
    front = np.array([link.front for link in shape.links])
    rear = np.array([link.rear for link in shape.links])
    directions = positions[front] - positions[rear]
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    axis = directions[0]
    degree = np.bincount(np.concatenate([front, rear]), minlength=len(shape.bodies))
    if np.linalg.norm(np.cross(axis, directions), axis=1).max() <= _AXIS_TOLERANCE and degree.max() <= 2:
        return axis
    raise ConfigError(shape.source, "assembly", "a chain (every link on one axis) for the quasi-static physics; "
                      "use --physics fast or reference for grids, stacks and branched shapes")


class QuasiStaticWorld(QuasiStatic):
    """The same interface as the PyBullet ``World``: set phases, advance ticks, read poses; damage, cuts, friction.

    Bodies move along the chain's axis only and keep their orientation; they rest on the ground at their shape's
    height. There is no PyBullet scene (a camera sensor needs one).
    """

    backend = "quasistatic"

    def __init__(self, shape: Shape, physics: PhysicsParams, environment: EnvironmentParams = EnvironmentParams()):
        super().__init__(shape, environment)
        self.physics = physics
        self.axis = shape.rotation @ chain_axis(shape)
        """the chain's axis on the ground."""
        self.tick = physics.timestep
        """s, one solve: pressures and positions are updated every tick."""
        self.s = np.zeros(len(shape.bodies))
        """m, each body's displacement along the axis from its rest position."""
        # +1 where a link's front lies along +axis from its rear: its length is pitch + sign * (s_front - s_rear).
        self._sign = np.array([np.sign(np.dot(self._rest[f] - self._rest[r], self.axis)) for f, r in self._links])
        self._build_paths()
        self._rest_xy = np.ascontiguousarray(self._rest[:, :2])
        self._axis_xy = np.ascontiguousarray(self.axis[:2])
        self._orientation = np.asarray(shape.orientation, dtype=float)
        """every body's quaternion (x, y, z, w): bodies keep the shape's orientation."""
        self.time = 0.0
        """s, the pumps' clock (nothing needs settling: bodies start at rest on the ground)."""

    def _build_paths(self) -> None:
        """Each piece as a path of bodies from one end to the other, with the link between consecutive bodies."""
        order, starts, pair_link, pair_sign = [], [0], [], []
        intact_links = [(i, f, r) for i, (f, r) in enumerate(self._links) if self.intact[i]]
        for piece in self.pieces():
            neighbours = {body: [] for body in piece}
            for i, f, r in intact_links:
                if f in neighbours:
                    neighbours[f].append((r, i))
                    neighbours[r].append((f, i))
            ends = [body for body in piece if len(neighbours[body]) <= 1]
            previous, body = -1, min(ends)
            while True:
                order.append(body)
                step = [(other, i) for other, i in neighbours[body] if other != previous]
                if not step:
                    break
                (other, i), previous = step[0], body
                # The pair's target difference s_body - s_other is pair_sign * (length - pitch).
                pair_link.append(i)
                pair_sign.append(self._sign[i] if self._links[i][0] == body else -self._sign[i])
                body = other
            pair_link.append(-1)  # no pair after a piece's last body
            pair_sign.append(0.0)
            starts.append(len(order))
        self._order = np.array(order, dtype=np.int64)
        self._starts = np.array(starts, dtype=np.int64)
        self._pair_link = np.array(pair_link, dtype=np.int64)
        self._pair_sign = np.array(pair_sign, dtype=float)
        self._sliding = np.zeros(len(order), dtype=np.int64)
        """by place along the paths, how each body moved in the last tick (+1, -1, 0 at rest): the next tick's
        first guess (see ``_solve_ticks``)."""
        self._capped = np.zeros(len(order), dtype=np.int64)
        """by place along the paths, whether the spring after each body was at +cap, -cap (+1, -1) or not (0)."""

    @property
    def state(self) -> np.ndarray:
        return self.s

    def _solve(self, lengths, limits, record, states, first_tick, field_every, modes, constants) -> None:
        actuator = self.shape.actuator
        _solve_ticks(self.s, lengths - self._empty_pitch, limits, self._order, self._starts, self._pair_link,
                     self._pair_sign, self.link_stiffness, actuator.max_force, record, states, self._sliding,
                     self._capped, PATTERN_MIN_BODIES, first_tick, field_every, modes, constants, self._factor,
                     self._rest_xy, self._axis_xy)

    def poses_of(self, states: np.ndarray, which) -> tuple[np.ndarray, np.ndarray]:
        index = np.asarray(which, dtype=int)
        positions = self._rest[index] + states[:, index, None] * self.axis
        orientations = np.empty(positions.shape[:2] + (4,))
        orientations[...] = self._orientation
        return positions, orientations

    def relax(self, extension, limits) -> None:
        """One tick: move the bodies to the minimiser of the incremental energy, given each bellows' extension
        beyond its empty length (m, one per link) and each body's friction limit (N, one per body)."""
        self.relax_ticks((self._empty_pitch + np.asarray(extension, dtype=float))[None, :],
                         np.asarray(limits, dtype=float)[None, :])

    def cut(self, link: int) -> None:
        if self.intact[link]:
            self.intact[link] = False
            self._build_paths()


@numba.njit(cache=True, nogil=True)
def _solve_ticks(s, extension, limits, order, starts, pair_link, pair_sign, stiffness, cap, record, states, sigma,
                 capped, guess_from, first_tick, field_every, modes, constants, factor, rest_xy, axis_xy):
    """Advance the displacements ``s`` (in place) through the ticks of ``extension`` / ``limits``: one exact solve
    of the incremental energy per tick and piece; after tick t, ``s`` is copied to ``states[record[t]]`` if
    ``record[t]`` >= 0. The limits are scaled by the friction field (``friction.factors``) at the bodies' places,
    read into ``factor`` (kept between calls) when first_tick + t is a multiple of field_every > 0 (places:
    ``rest_xy`` + s ``axis_xy``).

    In a piece of at least ``guess_from`` bodies, each tick first tries the previous tick's pattern (``sigma``:
    which bodies slide, and which way; ``capped``: which bellows are at their force cap, both by place along the
    path): with it the minimiser solves one tridiagonal system, and it is the exact one if it meets every optimality
    condition (``_try_pattern``). Otherwise, and in smaller pieces, the dynamic programme on the derivative of the
    energy finds it, and its pattern is kept for the next tick's guess."""
    n = len(order)
    width = 2 * n + 4
    xs = np.empty((n, width))  # breakpoints (x, s) of each body's subgradient graph, its own friction added
    ss = np.empty((n, width))
    cx = np.empty((n, width))  # the same clipped at the force cap (x, s), and where each lands through the spring (u)
    cs = np.empty((n, width))
    cu = np.empty((n, width))
    counts = np.empty(n, dtype=np.int64)
    clipped = np.empty(n, dtype=np.int64)
    clip_lo = np.empty(n, dtype=np.bool_)
    clip_hi = np.empty(n, dtype=np.bool_)
    offsets = np.empty(n)
    d = np.empty(n)
    work = np.empty((5, n))
    ks = np.empty(n)  # each spring's stiffness along the path, and its inverse
    inverse_k = np.empty(n)
    n_bodies = len(s)
    at_x, at_y = np.empty(n_bodies), np.empty(n_bodies)  # the bodies' places where the field is read
    w = np.empty(n_bodies)
    for t in range(extension.shape[0]):
        if field_every > 0 and (first_tick + t) % field_every == 0:
            for body in range(n_bodies):
                at_x[body] = rest_xy[body, 0] + s[body] * axis_xy[0]
                at_y[body] = rest_xy[body, 1] + s[body] * axis_xy[1]
            factors(at_x, at_y, modes, constants, factor)
        for body in range(n_bodies):
            w[body] = limits[t, body] * factor[body] if field_every > 0 else limits[t, body]
        for p in range(len(starts) - 1):
            a, b = starts[p], starts[p + 1]
            m = b - a
            for i in range(m - 1):  # how far spring i (between the path's bodies i and i + 1) is from its rest
                offsets[i] = (pair_sign[a + i] * extension[t, pair_link[a + i]]
                              - (s[order[a + i]] - s[order[a + i + 1]]))
            guess = m >= guess_from
            for i in range(m - 1):
                ks[i] = stiffness[pair_link[a + i]]
                inverse_k[i] = 1.0 / ks[i]
            solved = guess and _try_pattern(a, m, order, w, offsets, ks, cap, sigma, capped, d, work)
            if not solved:  # the dynamic programme: exact, O(n^2) for n bodies (two passes over the breakpoints each)
                # Forward: F_0 = w_0 |x|; F_{i+1}(y) = min_x F_i(x) + H(x - y - c_i) + w_{i+1} |y|.
                for i in range(m):
                    body = order[a + i]
                    wi = w[body]
                    if i == 0:
                        xs[i, 0], ss[i, 0], xs[i, 1], ss[i, 1] = 0.0, -wi, 0.0, wi
                        counts[i] = 2
                    else:
                        # The incoming message's graph (points (pu, ps), horizontal rays at both ends), with a jump of
                        # 2 w inserted at 0.
                        k = 0
                        cnt = clipped[i - 1]
                        pu = cu[i - 1]
                        ps = cs[i - 1]
                        j = 0
                        while j < cnt and pu[j] < 0.0:
                            xs[i, k], ss[i, k] = pu[j], ps[j] - wi
                            k += 1
                            j += 1
                        if j < cnt and pu[j] == 0.0:
                            lo = ps[j]
                            while j < cnt and pu[j] == 0.0:
                                hi = ps[j]
                                j += 1
                        else:
                            if j == 0:
                                lo = ps[0]
                            elif j == cnt:
                                lo = ps[cnt - 1]
                            else:
                                x0, x1 = pu[j - 1], pu[j]
                                lo = ps[j - 1] + (ps[j] - ps[j - 1]) * (0.0 - x0) / (x1 - x0)
                            hi = lo
                        xs[i, k], ss[i, k] = 0.0, lo - wi
                        xs[i, k + 1], ss[i, k + 1] = 0.0, hi + wi
                        k += 2
                        while j < cnt:
                            xs[i, k], ss[i, k] = pu[j], ps[j] + wi
                            k += 1
                            j += 1
                        counts[i] = k
                    if i == m - 1:
                        break
                    # Pass F_i through spring i: clip at the force cap, then map x -> x - c + s / k.
                    c = offsets[i]
                    cnt = counts[i]
                    k = 0
                    clip_lo[i] = ss[i, 0] < -cap
                    clip_hi[i] = ss[i, cnt - 1] > cap
                    for q in range(cnt):
                        x, v = xs[i, q], ss[i, q]
                        if v < -cap:
                            if q + 1 < cnt and ss[i, q + 1] > -cap:  # the crossing of -cap
                                f = (-cap - v) / (ss[i, q + 1] - v)
                                x = x + f * (xs[i, q + 1] - x)
                                cx[i, k], cs[i, k], cu[i, k] = x, -cap, x - c + -cap * inverse_k[i]
                                k += 1
                            continue
                        if v > cap:
                            if q > 0 and ss[i, q - 1] < cap:
                                f = (cap - ss[i, q - 1]) / (v - ss[i, q - 1])
                                x = xs[i, q - 1] + f * (x - xs[i, q - 1])
                                cx[i, k], cs[i, k], cu[i, k] = x, cap, x - c + cap * inverse_k[i]
                                k += 1
                            break
                        cx[i, k], cs[i, k], cu[i, k] = x, v, x - c + v * inverse_k[i]
                        k += 1
                    clipped[i] = k
                # The last body: where its subgradient graph crosses 0 (the point of the zero set nearest no motion).
                i = m - 1
                cnt = counts[i]
                lo_x, hi_x = -np.inf, np.inf
                if ss[i, 0] < 0.0:
                    lo_x = np.inf
                    for q in range(1, cnt):
                        if ss[i, q] >= 0.0:
                            v0 = ss[i, q - 1]
                            lo_x = xs[i, q - 1] + (xs[i, q] - xs[i, q - 1]) * (0.0 - v0) / (ss[i, q] - v0)
                            break
                if ss[i, cnt - 1] > 0.0:
                    hi_x = -np.inf
                    for q in range(cnt - 2, -1, -1):
                        if ss[i, q] <= 0.0:
                            v0 = ss[i, q + 1]
                            hi_x = xs[i, q + 1] + (xs[i, q] - xs[i, q + 1]) * (0.0 - v0) / (ss[i, q] - v0)
                            break
                d[i] = min(max(0.0, lo_x), hi_x)
                # Backward: body i's displacement from body i + 1's, through the map x -> u of spring i.
                for i in range(m - 2, -1, -1):
                    y = d[i + 1]
                    cnt = clipped[i]
                    if y <= cu[i, 0]:
                        d[i] = cx[i, 0] if clip_lo[i] else y + offsets[i] - cs[i, 0] * inverse_k[i]
                    elif y >= cu[i, cnt - 1]:
                        d[i] = cx[i, cnt - 1] if clip_hi[i] else y + offsets[i] - cs[i, cnt - 1] * inverse_k[i]
                    else:
                        q = 1
                        while cu[i, q] < y:
                            q += 1
                        u0, u1 = cu[i, q - 1], cu[i, q]
                        f = 0.0 if u1 == u0 else (y - u0) / (u1 - u0)
                        d[i] = cx[i, q - 1] + f * (cx[i, q] - cx[i, q - 1])
            if guess and not solved:  # the programme's pattern is the next tick's guess
                for i in range(m):
                    sigma[a + i] = 0 if abs(d[i]) <= STUCK else (1 if d[i] > 0.0 else -1)
                for i in range(m - 1):
                    force = ks[i] * (d[i] - d[i + 1] - offsets[i])
                    capped[a + i] = 1 if force >= cap else (-1 if force <= -cap else 0)
            for i in range(m):
                s[order[a + i]] += d[i]
        if record[t] >= 0:
            states[record[t]] = s


STUCK = 1e-14
"""m: a tick's displacement this small is a body at rest (the programme's rounding), not one sliding."""


@numba.njit(cache=True, nogil=True, inline="always")  # a call would cost more than a small chain's solve
def _try_pattern(a, m, order, limits, offsets, k, cap, sigma, capped, d, work):
    """The minimiser of one piece's incremental energy, found from a guess of how it moves: into ``d``, True, when
    found; False when ``PATTERN_TRIES`` guesses fail (``d`` then holds nothing useful).

    A guess says which bodies slide and which way (``sigma``: +1, -1, 0 at rest) and which springs are at their force
    cap (``capped``: +1, -1 at +-cap, 0 not). Sliding bodies balance their springs against their friction (sum of
    spring forces = sigma w), bodies at rest have d = 0: a tridiagonal system in d, solved by elimination (an
    M-matrix: no pivoting needed). Its solution is a minimiser if it meets every optimality condition: each
    sliding body moves its way, each body at rest is held by its friction, each spring is capped exactly where the
    guess says. Where one fails, the guess is mended there (a body moving against its way stops, a body its friction
    no longer holds slides the way it is pushed, a spring crosses its cap) and tried again (a primal-dual active set
    method). A group of sliding bodies that no resting body anchors through uncapped springs is singular: the
    guess fails. So does a piece with a body without friction, which may leave the minimiser not unique (free between
    two capped springs): the programme's choice among minimisers, the one nearest no motion, is kept."""
    lower, diag, upper, rhs, force = work[0], work[1], work[2], work[3], work[4]
    stiffest = 0.0  # the scale below which a pivot is zero
    for i in range(m - 1):
        stiffest = max(stiffest, k[i])
    for i in range(m):
        if not limits[order[a + i]] > 0.0:
            return False
    for _ in range(PATTERN_TRIES):
        for i in range(m):
            if sigma[a + i] == 0:
                lower[i], diag[i], upper[i], rhs[i] = 0.0, 1.0, 0.0, 0.0
                continue
            # F_j = u_j k_j (d_j - d_j+1 - c_j) + C_j for spring j; body i slides when F_i-1 - F_i = sigma_i w_i,
            # here as (k_i-1 + k_i) d_i - k_i-1 d_i-1 - k_i d_i+1 = -sigma_i w_i - k_i-1 c_i-1 + k_i c_i + C_i-1 - C_i
            # (u = 1 both sides).
            total = -sigma[a + i] * limits[order[a + i]]
            lo = up = 0.0
            if i > 0:
                if capped[a + i - 1] == 0:
                    lo = k[i - 1]
                    total -= lo * offsets[i - 1]
                else:
                    total += capped[a + i - 1] * cap
            if i < m - 1:
                if capped[a + i] == 0:
                    up = k[i]
                    total += up * offsets[i]
                else:
                    total -= capped[a + i] * cap
            lower[i], diag[i], upper[i], rhs[i] = -lo, lo + up, -up, total
        for i in range(m):  # forward elimination
            pivot = diag[i] - (lower[i] * upper[i - 1] if i > 0 else 0.0)
            if not abs(pivot) > 1e-9 * stiffest:
                return False
            upper[i] = upper[i] / pivot
            rhs[i] = (rhs[i] - (lower[i] * rhs[i - 1] if i > 0 else 0.0)) / pivot
        d[m - 1] = rhs[m - 1]
        for i in range(m - 2, -1, -1):
            d[i] = rhs[i] - upper[i] * d[i + 1]
        met = True
        for i in range(m - 1):
            f = k[i] * (d[i] - d[i + 1] - offsets[i])
            state = capped[a + i]
            force[i] = f if state == 0 else state * cap
            if state == 0 and not abs(f) <= cap:
                capped[a + i] = 1 if f > 0.0 else -1
                met = False
            elif (state == 1 and not f >= cap) or (state == -1 and not f <= -cap):
                capped[a + i] = 0
                met = False
        for i in range(m):
            if sigma[a + i] != 0:
                if not sigma[a + i] * d[i] > 0.0:
                    sigma[a + i] = 0
                    met = False
            else:
                net = (force[i - 1] if i > 0 else 0.0) - (force[i] if i < m - 1 else 0.0)
                if not abs(net) <= limits[order[a + i]]:
                    sigma[a + i] = 1 if net > 0.0 else -1
                    met = False
        if met:
            return True
    return False


PATTERN_TRIES = 4
"""guesses a tick may try before the dynamic programme settles it."""
PATTERN_MIN_BODIES = 8
"""pieces with fewer bodies go straight to the programme, which is cheaper for them than a guess."""
