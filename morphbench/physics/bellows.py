"""What every world keeps of its bellows and pumps, whatever computes the motion (pure numpy): which unit drives each
link, strokes, empty lengths, phases, pressures, damage and cuts, and the friction each body starts from."""

from __future__ import annotations

import numpy as np

from morphbench.params import DAMAGE_MODES, GRAVITY, EnvironmentParams, check_quasistatic_friction
from morphbench.physics.friction import NO_FIELD, FrictionField
from morphbench.physics.pressure import pressure_trajectory
from morphbench.physics.protocol import Scene
from morphbench.shapes.checks import connected_groups
from morphbench.shapes.model import Shape

FIELD_UPDATE_PERIOD = 0.1  # s: units move well under a millimetre in this time, the field varies over centimetres


def link_spans(shape: Shape) -> tuple[np.ndarray, np.ndarray]:
    """m, per link: the centre-to-centre distance of its two bodies at rest with its bellows empty, and its bellows'
    stroke (a unit may override the shape's)."""
    rest = shape.placed_positions()
    pitch = np.array([np.linalg.norm(rest[link.front] - rest[link.rear]) for link in shape.links])
    strokes = np.array([shape.actuator.stroke if link.stroke is None else link.stroke for link in shape.links])
    return pitch, strokes


class Bellows:
    """The base of every world (physics.protocol.WorldInterface); a subclass sets ``tick`` (s), ``backend`` and
    moves the bodies."""

    @staticmethod
    def memory(bodies: int, links: int, ticks: int) -> float:
        """bytes a world of that many bodies and links holds that grow with its size, over an advance of ``ticks``:
        the pressures, rest lengths and friction limits of every tick (8 bytes per tick and link or body in each)."""
        return ticks * (4 * links + 2 * bodies) * 8

    tick: float
    backend: str
    scene: Scene | None = None
    """a world with a PyBullet scene of its own gives it (World)."""

    def __init__(self, shape: Shape, environment: EnvironmentParams):
        self.shape, self.environment = shape, environment
        self._rest = shape.placed_positions()
        """m, each body's position at rest (empty bellows) on the ground."""
        self._links = [(link.front, link.rear) for link in shape.links]
        unit_index = {body: k for k, body in enumerate(shape.units)}
        self.link_units = np.array([-1 if link.unit is None else unit_index[link.unit] for link in shape.links],
                                   dtype=int)
        """for each link, the index (in unit order) of the unit whose pump drives it; -1 for a passive link."""
        self._actuated = self.link_units >= 0
        self._empty_pitch, self._strokes = link_spans(shape)
        """m, per link: its bodies' centre-to-centre distance with the bellows empty; the bellows' stroke."""
        self._front = np.array([f for f, _ in self._links], dtype=np.int64)
        self._rear = np.array([r for _, r in self._links], dtype=np.int64)
        own = np.array([body.position for body in shape.bodies], dtype=float)
        self._axes = np.reshape([(own[f] - own[r]) / p for (f, r), p in zip(self._links, self._empty_pitch)], (-1, 3))
        """each link's unit axis from rear to front at rest in the assembly's frame, which is also both bodies' own
        frame (every body starts turned by the shape's yaw)."""
        self.intact = np.ones(len(shape.links), dtype=bool)
        """for each link, False once it has been cut."""
        self._pieces: tuple[bytes, list[list[int]]] | None = None
        self.pressure = np.zeros(len(shape.links))
        """current pressure (0..1) of each bellows."""
        self.phases = np.zeros(shape.n_units)
        """current phase (0..1) of each active unit's pump."""
        self.periods = np.full(shape.n_units, shape.actuator.cycle_time)
        """s, each active unit's pump period: the cycle time on its own clock (``set_clock_rates``)."""
        self.damage = ["" for _ in shape.units]
        """per active unit (unit order): '' (healthy) or a mode of DAMAGE_MODES."""
        self._blocked = np.zeros(shape.n_units, dtype=bool)
        """per active unit, whether its damage keeps its bellows from inflating ('no-inflate', 'open', 'dead')."""
        self._dead = np.zeros(shape.n_units, dtype=bool)
        """per active unit, whether it is dead (no pump, no vibration)."""
        self.link_stiffness = np.full(len(shape.links), shape.actuator.stiffness)
        """N/m, each link's axial stiffness (a bellows open to the air: ``ActuatorParams.open_stiffness``)."""
        self._stuck_length = np.full(len(shape.links), np.nan)
        self._any_stuck = False
        self._extends = self._extending()
        self._friction_scale = np.full(len(shape.bodies), environment.friction_scale)
        """each body's friction scale: the environment's, until a friction event changes it."""
        self._field = FrictionField(environment.friction_field) if environment.friction_field.amplitude > 0 else None
        self._field_modes = NO_FIELD if self._field is None else self._field.compiled()
        self._base_friction = np.array([body.friction for body in shape.bodies])
        self._weights = np.array([body.mass * GRAVITY for body in shape.bodies])
        """N, each body's weight."""
        self._unit_bodies = np.array(shape.units, dtype=int)

    def set_phases(self, phases) -> None:
        """Set every active unit's phase (unit order, values in [0, 1))."""
        phases = np.asarray(phases, dtype=float)
        if phases.shape != self.phases.shape:
            raise ValueError(f"expected {self.phases.shape[0]} phases, got {phases.shape}")
        self.phases = np.mod(phases, 1.0)

    def set_clock_rates(self, errors, first: int = 0) -> None:
        """The clock rate error e of the active units from ``first`` on (unit order): each one's pump period becomes
        cycle_time * (1 + e)."""
        errors = np.asarray(errors, dtype=float)
        if errors.ndim != 1 or first + len(errors) > len(self.periods):
            raise ValueError(f"expected at most {len(self.periods) - first} clock rate errors, got {errors.shape}")
        self.periods[first:first + len(errors)] = self.shape.actuator.cycle_time * (1.0 + errors)

    def ticks_in(self, duration: float) -> int:
        """How many control ticks make ``duration`` seconds (durations are whole numbers of ticks)."""
        return max(0, round(duration / self.tick))

    def _pressures(self, start: float, n_ticks: int, pumps: bool) -> np.ndarray:
        """(n_ticks, n_links) pressure of each bellows at the end of each coming tick (0 with ``pumps`` off)."""
        # A passive link has no pump: its pressure trajectory is computed (phase 0) and then zeroed.
        driver = np.maximum(self.link_units, 0)
        trajectory = pressure_trajectory(self.pressure, self.phases[driver], start, self.tick, n_ticks,
                                         self.shape.actuator, self.periods[driver])
        return trajectory * (self._actuated if pumps else 0.0)

    def _rest_lengths(self, trajectory: np.ndarray) -> np.ndarray:
        """(n_ticks, n_links) rest length of each bellows: a damaged one cannot inflate, a stuck one keeps its
        length."""
        rest = self._empty_pitch + self._strokes * trajectory * self._extends
        if self._any_stuck:
            stuck = ~np.isnan(self._stuck_length)
            rest[:, stuck] = self._stuck_length[stuck]
        return rest

    def _extending(self) -> np.ndarray:
        """1.0 for each link whose bellows can inflate (driven by a unit not damaged 'no-inflate', 'open' or
        'dead'), else 0.0."""
        extends = self._actuated.copy()
        extends[extends] = ~self._blocked[self.link_units[extends]]
        return extends.astype(float)

    def _pumping(self, start: float, n_ticks: int) -> np.ndarray:
        """(n_ticks, n_units) whether each unit's pump runs at the start of each coming tick (a dead one never)."""
        t = start + self.tick * np.arange(n_ticks)
        pumping = np.mod(t[:, None] / self.periods - self.phases, 1.0) < self.shape.actuator.alpha
        return pumping & ~self._dead

    def set_damage(self, unit: int, mode: str) -> None:
        """Damage the active unit at ``unit`` (unit order, 0-based): 'no-inflate' (its bellows cannot extend; pump and
        vibration go on), 'open' (no-inflate, and the bellows, open to the air, resists with its wall's
        ``open_stiffness`` only), 'stuck' (its bellows keeps its current length), 'dead' (no pump, no vibration); ''
        heals."""
        if mode not in ("",) + DAMAGE_MODES:
            raise ValueError(f"damage mode must be '' (healthy) or one of {DAMAGE_MODES}, got {mode!r}")
        if self.damage[unit] == mode:
            return
        self.damage[unit] = mode
        self._blocked[unit], self._dead[unit] = mode in ("no-inflate", "open", "dead"), mode == "dead"
        self._extends = self._extending()
        driven = self.link_units == unit
        actuator = self.shape.actuator
        self.link_stiffness[driven] = actuator.open_stiffness if mode == "open" else actuator.stiffness
        self._stuck_length[driven] = (self._empty_pitch + self._strokes * self.pressure)[driven] \
            if mode == "stuck" else np.nan
        self._any_stuck = bool(np.isfinite(self._stuck_length).any())

    def set_friction_scale(self, scale: float, bodies: str = "all") -> None:
        """Multiply the friction of ``bodies`` (params.FRICTION_TARGETS) by ``scale`` from now on (instead of the
        environment's scale)."""
        self._friction_scale[self._targets(bodies)] = scale

    def _targets(self, bodies: str) -> np.ndarray:
        """Per body: whether it is among ``bodies`` ('all', 'active' units or 'passive' ones)."""
        active = np.zeros(len(self._friction_scale), dtype=bool)
        active[self._unit_bodies] = True
        targets = {"all": np.ones_like(active), "active": active, "passive": ~active}
        if bodies not in targets:
            raise ValueError(f"friction targets must be one of {tuple(targets)}, got {bodies!r}")
        return targets[bodies]

    def cut(self, link: int) -> None:
        """Cut link ``link`` (index into shape.links): its springs are gone; the pieces move apart freely."""
        self.intact[link] = False

    def pieces(self) -> list[list[int]]:
        """Connected groups of body indices over the intact links, the piece holding body 0 first."""
        key = self.intact.tobytes()  # read every learning step, changed only by a cut
        if self._pieces is None or self._pieces[0] != key:
            groups = connected_groups(len(self.shape.bodies),
                                      [link for link, intact in zip(self._links, self.intact) if intact])
            self._pieces = (key, groups)
        return [list(group) for group in self._pieces[1]]

    def advance(self, n_ticks: int, on_tick=None, pumps: bool = True, every: int = 1) -> None:
        """Run ``n_ticks`` ticks. ``on_tick(k)`` is called after tick k (0-based) if given and k + 1 is a multiple
        of ``every``, with ``time`` and ``pressure`` already those at the end of that tick. With ``pumps=False``
        every bellows stays empty."""
        raise NotImplementedError

    def advance_sampled(self, n_ticks: int, every: int, on_tick=None) -> tuple[np.ndarray, np.ndarray]:
        """Run ``n_ticks`` ticks with the pumps on; the active units' poses (unit order) after ticks ``every``,
        2 ``every``, ... before the last, and after the last: (K, n_units, 3) positions (m) and (K, n_units, 4)
        quaternions (x, y, z, w). ``on_tick(self)``, if given, is called after every tick (an observer)."""
        samples = []

        def collect(k: int) -> None:
            if (k + 1) % every == 0 and k + 1 < n_ticks:
                samples.append(self.unit_poses())
            if on_tick is not None:
                on_tick(self)

        self.advance(n_ticks, collect, every=1 if on_tick is not None else every)
        samples.append(self.unit_poses())
        positions, orientations = zip(*samples)
        return np.stack(positions), np.stack(orientations)

    def unit_poses(self) -> tuple[np.ndarray, np.ndarray]:
        """Poses of the active units, in unit order."""
        return self.poses(self.shape.units)

    def poses(self, which=None) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError

    def close(self) -> None:
        """Release what the world holds (a subclass with a simulator client disconnects it)."""

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class QuasiStatic(Bellows):
    """The base of the worlds without inertia (QuasiStaticWorld, PlanarWorld): with no velocities to carry, ticks
    are solved in batches by the subclass's compiled ``relax_ticks``, which moves its ``state`` array; ``poses_of``
    turns states into poses, so sampled poses are recorded inside the compiled loop, not by a callback per sample."""

    state: np.ndarray
    """each body's coordinates (a subclass's own layout)."""
    _factor: np.ndarray
    """each body's friction field factor at its last reading (the solvers read the field every FIELD_UPDATE_PERIOD
    from the start of an advance, and keep it in between)."""

    def __init__(self, shape: Shape, environment: EnvironmentParams):
        super().__init__(shape, environment)
        self._factor = np.ones(len(shape.bodies))

    def set_friction_scale(self, scale: float, bodies: str = "all") -> None:
        """As for every world; a ConfigError if ``scale`` takes friction below the model's range (and nothing
        changes; checked as if every body took it, which is the lower bound)."""
        check_quasistatic_friction(self.shape, self.environment, self.shape.source, scale)
        super().set_friction_scale(scale, bodies)

    def relax_ticks(self, lengths, limits, record=None, states=None, first_tick: int | None = None) -> None:
        """Solve one tick per row: ``lengths`` (n_ticks, n_links) each link's rest length (m), ``limits``
        (n_ticks, n_bodies) each body's friction limit (N) on a uniform ground. After tick t, if ``record[t]`` >= 0,
        the state is copied into row ``record[t]`` of ``states`` (from ``new_states``). With ``first_tick`` (the
        index of the first row among the ticks of an ``advance``), the limits are scaled by the friction field at
        the bodies' places, read again every FIELD_UPDATE_PERIOD from the start of the advance."""
        lengths, limits = np.asarray(lengths, dtype=float), np.asarray(limits, dtype=float)
        if record is None:
            record, states = np.full(len(lengths), -1, dtype=np.int64), self.new_states(0)
        field, every = NO_FIELD, 0
        if first_tick is not None and self._field is not None:
            field, every = self._field_modes, max(1, round(FIELD_UPDATE_PERIOD / self.tick))
        self._solve(lengths, limits, record, states, first_tick or 0, every, *field)

    def _solve(self, lengths: np.ndarray, limits: np.ndarray, record: np.ndarray, states: np.ndarray,
               first_tick: int, field_every: int, modes: np.ndarray, constants: np.ndarray) -> None:
        """``relax_ticks`` with every argument given (the subclass's compiled solver; the field as
        ``friction.factors`` takes it, read when (first_tick + t) is a multiple of field_every > 0)."""
        raise NotImplementedError

    def poses_of(self, states: np.ndarray, which) -> tuple[np.ndarray, np.ndarray]:
        """(K, n, 3) positions and (K, n, 4) quaternions of the bodies ``which`` in each of K states."""
        raise NotImplementedError

    def new_states(self, n: int) -> np.ndarray:
        """Room for ``n`` copies of the state."""
        return np.empty((n,) + self.state.shape)

    def poses(self, which=None) -> tuple[np.ndarray, np.ndarray]:
        index = np.arange(len(self.shape.bodies)) if which is None else which
        positions, orientations = self.poses_of(self.state[None], index)
        return positions[0], orientations[0]

    def advance(self, n_ticks: int, on_tick=None, pumps: bool = True, every: int = 1) -> None:
        self._advance(n_ticks, on_tick, pumps, every)

    def advance_sampled(self, n_ticks: int, every: int, on_tick=None) -> tuple[np.ndarray, np.ndarray]:
        if on_tick is not None or n_ticks <= 0:
            return super().advance_sampled(n_ticks, every, on_tick)
        sampled = np.arange(every, n_ticks, every) - 1  # the ticks k with k + 1 a multiple of every, before the last
        record = np.full(n_ticks, -1, dtype=np.int64)
        record[sampled] = np.arange(len(sampled))
        record[-1] = len(sampled)
        states = self.new_states(len(sampled) + 1)
        self._advance(n_ticks, None, True, every, record, states)
        return self.poses_of(states, self.shape.units)

    def _friction_limits(self, start: float, n_ticks: int, pumps: bool) -> np.ndarray:
        """(n_ticks, n_bodies) N, each body's friction limit on a uniform ground over the coming ticks: its friction
        times its scale and weight, a pumping unit's times the vibration (the field is read by the solvers at the
        bodies' places)."""
        friction = self._base_friction * self._friction_scale
        if pumps and self.environment.vibration != 1.0:
            friction = np.repeat(friction[None], n_ticks, axis=0)
            friction[:, self._unit_bodies] *= np.where(self._pumping(start, n_ticks), self.environment.vibration, 1.0)
            return friction * self._weights
        return np.broadcast_to(friction * self._weights, (n_ticks, len(friction)))

    def _advance(self, n_ticks: int, on_tick, pumps: bool, every: int, record=None, states=None) -> None:
        """``advance`` of a quasi-static world: pressures, rest lengths and friction limits for the coming ticks,
        then ``relax_ticks`` over segments that end where a callback is due (``record`` and ``states`` as there);
        the solver reads the friction field at the bodies' places itself."""
        if n_ticks <= 0:
            return
        start = self.time
        trajectory = self._pressures(start, n_ticks, pumps)
        lengths = self._rest_lengths(trajectory)  # (n_ticks, n_links)
        limits = self._friction_limits(start, n_ticks, pumps)
        ends = list(range(every, n_ticks, every)) + [n_ticks] if on_tick is not None else [n_ticks]
        begin = 0
        for end in ends:
            self.relax_ticks(lengths[begin:end], limits[begin:end], None if record is None else record[begin:end],
                             states, first_tick=begin)
            if on_tick is not None and end % every == 0:
                self.pressure, self.time = trajectory[end - 1], start + end * self.tick
                on_tick(end - 1)
            begin = end
        self.pressure, self.time = trajectory[-1], start + n_ticks * self.tick
