"""The quasi-static world: springs and Coulomb friction with no inertia, for assemblies whose links lie on one axis.

Units weigh tens of grams and bellows move over tenths of a second, so inertia is negligible next to friction and a
chain follows the quasi-static evolution of its springs and friction (../shared/spec, section 3b). Over each tick the
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
from morphbench.shapes.model import Shape

_AXIS_TOLERANCE = 1e-9  # links whose directions differ by more than this are not on one axis


def chain_axis(shape: Shape) -> np.ndarray:
    """The unit vector every link of ``shape`` lies along; a ConfigError if the links are not all on one line
    through their bodies (a grid, a stack, a branched assembly)."""
    positions = np.array([body.position for body in shape.bodies], dtype=float)
    if not shape.links:
        return np.array([1.0, 0.0, 0.0])
    directions = [(positions[link.front] - positions[link.rear]) for link in shape.links]
    axis = directions[0] / np.linalg.norm(directions[0])
    degree = np.zeros(len(shape.bodies), dtype=int)
    for link, direction in zip(shape.links, directions):
        degree[link.front] += 1
        degree[link.rear] += 1
        if np.linalg.norm(np.cross(axis, direction / np.linalg.norm(direction))) > _AXIS_TOLERANCE:
            break
    else:
        if degree.max() <= 2:
            return axis
    raise ConfigError(shape.source, "assembly", "a chain (every link on one axis) for the quasi-static physics; "
                      "use --physics fast or reference for grids, stacks and branched shapes")


class QuasiStaticWorld(QuasiStatic):
    """The same interface as the PyBullet ``World``: set phases, advance ticks, read poses; damage, cuts, friction.

    Bodies move along the chain's axis only and keep their orientation; they rest on the ground at their shape's
    height. ``client`` is None: there is no PyBullet scene (a camera sensor needs one).
    """

    client = None

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

    @property
    def state(self) -> np.ndarray:
        return self.s

    def _solve(self, lengths, limits, record, states) -> None:
        actuator = self.shape.actuator
        _solve_ticks(self.s, lengths - self._empty_pitch, limits, self._order, self._starts, self._pair_link,
                     self._pair_sign, 1.0 / actuator.stiffness, actuator.max_force, record, states)

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


@numba.njit(cache=True)
def _solve_ticks(s, extension, limits, order, starts, pair_link, pair_sign, inverse_k, cap, record, states):
    """Advance the displacements ``s`` (in place) through the ticks of ``extension`` / ``limits``: one exact solve
    of the incremental energy per tick and piece; after tick t, ``s`` is copied to ``states[record[t]]`` if
    ``record[t]`` >= 0.

    Each body's graph is built in one pass over the incoming one, and clipped and passed through its spring in a
    second: O(n^2) per tick for n bodies, with the smallest constant (two passes over the breakpoints per body)."""
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
    for t in range(extension.shape[0]):
        for p in range(len(starts) - 1):
            a, b = starts[p], starts[p + 1]
            m = b - a
            # Forward: F_0 = w_0 |x|; F_{i+1}(y) = min_x F_i(x) + H(x - y - c_i) + w_{i+1} |y|.
            for i in range(m):
                body = order[a + i]
                w = limits[t, body]
                if i == 0:
                    xs[i, 0], ss[i, 0], xs[i, 1], ss[i, 1] = 0.0, -w, 0.0, w
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
                        xs[i, k], ss[i, k] = pu[j], ps[j] - w
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
                    xs[i, k], ss[i, k] = 0.0, lo - w
                    xs[i, k + 1], ss[i, k + 1] = 0.0, hi + w
                    k += 2
                    while j < cnt:
                        xs[i, k], ss[i, k] = pu[j], ps[j] + w
                        k += 1
                        j += 1
                    counts[i] = k
                if i == m - 1:
                    break
                # Pass F_i through spring i: clip at the force cap, then map x -> x - c + s / k.
                link = pair_link[a + i]
                c = pair_sign[a + i] * extension[t, link] - (s[body] - s[order[a + i + 1]])
                offsets[i] = c
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
                            cx[i, k], cs[i, k], cu[i, k] = x, -cap, x - c + -cap * inverse_k
                            k += 1
                        continue
                    if v > cap:
                        if q > 0 and ss[i, q - 1] < cap:
                            f = (cap - ss[i, q - 1]) / (v - ss[i, q - 1])
                            x = xs[i, q - 1] + f * (x - xs[i, q - 1])
                            cx[i, k], cs[i, k], cu[i, k] = x, cap, x - c + cap * inverse_k
                            k += 1
                        break
                    cx[i, k], cs[i, k], cu[i, k] = x, v, x - c + v * inverse_k
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
                    d[i] = cx[i, 0] if clip_lo[i] else y + offsets[i] - cs[i, 0] * inverse_k
                elif y >= cu[i, cnt - 1]:
                    d[i] = cx[i, cnt - 1] if clip_hi[i] else y + offsets[i] - cs[i, cnt - 1] * inverse_k
                else:
                    q = 1
                    while cu[i, q] < y:
                        q += 1
                    u0, u1 = cu[i, q - 1], cu[i, q]
                    f = 0.0 if u1 == u0 else (y - u0) / (u1 - u0)
                    d[i] = cx[i, q - 1] + f * (cx[i, q] - cx[i, q - 1])
            for i in range(m):
                s[order[a + i]] += d[i]
        if record[t] >= 0:
            states[record[t]] = s
