"""Generators: the bodies and links of the assemblies a morphology file can describe (pure data, no simulator).

Every generator places bodies on one lattice (docs/morphologies.md): the site ``(i, j, k)`` has its body centre at

    x = i * (length + rest_gap),  y = j * (width + rest_gap),  z = height / 2 + k * (height + rest_gap)

(x forward, y to the left, z up, the ground at z = 0), so neighbouring bodies are ``rest_gap`` apart face to face and a
link always joins two sites that differ by 1 along exactly one axis. A link's axis is that lattice axis; its ``front``
is the body at the larger coordinate along it, its ``rear`` the other.

- ``chain``: one row along x, unit 1 at the front (site (0, 0, 0)), the rest behind it towards -x, the dummy last.
- ``grid``: ``rows`` such chains side by side, row 1 at y = 0 and the others towards -y (to the right), each unit's
  bellows pushing against the body behind it in its row; neighbouring rows are joined by passive links along y.
- ``lattice``: ``layers`` such grids stacked along z (layer 1 on the ground), joined by passive links along z.
- ``actuated_axes`` (grid and lattice, default ``("x",)``): the lattice axes along which each unit drives the link
  to the body behind it (x: in its row; y: in the next row; z: the layer below); links along other axes are passive.
- ``custom``: units at given lattice sites and explicit links (``CustomUnit``, ``CustomLink``).

Unit order (unit 1, 2, ...; the order of learners and of the records) is body order without the dummies. For the
generators it is layer by layer from the ground up, row by row from row 1 (y = 0) to the right, and front to back
within a row; a row's dummy follows its last unit. For ``custom`` it is the order of the ``[[units]]`` tables.

Link order (the number a ``cut`` or a run's cut event names, 1-based in files): for the generators, first the links
along x in unit order (so in a chain with a dummy, link k is unit k's bellows), then the links along y (layer by
layer, row pair by row pair, front to back), then those along z; for ``custom`` the order of the ``[[links]]``
tables.
"""

from __future__ import annotations

from dataclasses import dataclass

from morphbench.errors import ConfigError
from morphbench.params import ActuatorParams, DummyParams, UnitParams
from morphbench.shapes.model import Body, Link

MAX_UNITS = 100_000
"""Most active units in one assembly (whatever the generator): the dynamic model, the cheapest, costs 3.9 CPU s per
simulated second at 316 x 316 units (benchmarks/RESULTS.md), so a 300-step run of a larger sheet would take over 80
minutes on one core (and the exact planar solver, whose work per tick grows as N^1.6, over an hour per simulated
second)."""
TOO_MANY = "a larger assembly takes over 4 CPU s per simulated second, a 300-step run over 80 minutes"
"""why MAX_UNITS, in the messages that refuse more."""
MAX_BODIES = 2 * MAX_UNITS
"""Most bodies (active units and dummies) in one assembly."""
MAX_SITE = 1000
"""Largest lattice coordinate (in absolute value) of a custom unit."""
AXES = "xyz"


def site_position(site: tuple[int, int, int], unit: UnitParams, actuator: ActuatorParams) -> tuple[float, float, float]:
    """m, the body centre of lattice site ``(i, j, k)`` (k = 0 rests on the ground)."""
    i, j, k = site
    gap = actuator.rest_gap
    return (
        float(i * (unit.length + gap)),
        float(j * (unit.width + gap)),
        float(unit.height / 2 + k * (unit.height + gap)),
    )


def _body(site, unit: UnitParams, dummy: DummyParams, actuator: ActuatorParams, is_dummy: bool, mesh: str) -> Body:
    params = dummy if is_dummy else unit
    return Body(position=site_position(site, unit, actuator), size=(unit.length, unit.width, unit.height),
                mass=params.mass, friction=params.friction, dummy=is_dummy, mesh=mesh)


def lattice(layers: int, rows: int, columns: int, has_dummy: bool, unit: UnitParams, dummy: DummyParams,
            actuator: ActuatorParams, *, unit_mesh: str = "", dummy_mesh: str = "",
            actuated_axes: tuple[str, ...] = ("x",)) -> tuple[tuple[Body, ...], tuple[Link, ...]]:
    """Bodies and links of ``layers`` x ``rows`` x ``columns`` active units (and a dummy at the rear of every row).

    Row r (0-based) of layer l holds units at sites (0, -r, l), (-1, -r, l), ..., (1 - columns, -r, l) and its dummy
    at (-columns, -r, l). Neighbouring bodies of a row are linked along x, neighbouring rows along y and neighbouring
    layers along z, at every column (dummies included). Along each axis of ``actuated_axes`` a unit's pump drives
    the link to the body behind it: the next body of its row (x), the body in the next row (y, towards -y), the body
    below it (z: vertical bellows lift the layer above); every other link is passive. One pump may drive up to three
    bellows, which then inflate together.
    """
    per_row = columns + (1 if has_dummy else 0)
    index = {}  # (layer, row, column) -> body index
    bodies = []
    for layer in range(layers):
        for row in range(rows):
            for column in range(per_row):
                is_dummy = column == columns
                index[layer, row, column] = len(bodies)
                bodies.append(_body((-column, -row, layer), unit, dummy, actuator, is_dummy,
                                    dummy_mesh if is_dummy else unit_mesh))

    def link(front: int, rear: int, axis: str) -> Link:
        driven = axis in actuated_axes and not bodies[front].dummy
        return Link(front=front, rear=rear, unit=front if driven else None)

    links = []
    for (layer, row, column), b in index.items():  # along x, in unit order
        if column + 1 < per_row:
            links.append(link(b, index[layer, row, column + 1], "x"))
    for layer in range(layers):  # along y
        for row in range(rows - 1):
            for column in range(per_row):
                links.append(link(index[layer, row, column], index[layer, row + 1, column], "y"))
    for layer in range(layers - 1):  # along z
        for row in range(rows):
            for column in range(per_row):
                links.append(link(index[layer + 1, row, column], index[layer, row, column], "z"))
    return tuple(bodies), tuple(links)


def grid(rows: int, columns: int, has_dummy: bool, unit: UnitParams, dummy: DummyParams, actuator: ActuatorParams,
         *, unit_mesh: str = "", dummy_mesh: str = "", actuated_axes: tuple[str, ...] = ("x",)):
    """Bodies and links of ``rows`` rows of ``columns`` units in the ground plane (a one-layer ``lattice``)."""
    return lattice(1, rows, columns, has_dummy, unit, dummy, actuator, unit_mesh=unit_mesh, dummy_mesh=dummy_mesh,
                   actuated_axes=actuated_axes)


def chain(n_units: int, has_dummy: bool, unit: UnitParams, dummy: DummyParams, actuator: ActuatorParams,
          *, unit_mesh: str = "", dummy_mesh: str = ""):
    """Bodies and links of a straight chain along x: unit 1 at the front (largest x), the dummy at the rear.

    Unit i's bellows sits between unit i and the next body towards the rear; the last active unit of a chain with no
    dummy has no body behind it, so it has no bellows (it is still a unit and still learns).
    """
    return lattice(1, 1, n_units, has_dummy, unit, dummy, actuator, unit_mesh=unit_mesh, dummy_mesh=dummy_mesh)


@dataclass(frozen=True, kw_only=True)
class CustomUnit:
    """One ``[[units]]`` table of a custom morphology: a body at a lattice site."""

    at: tuple[int, int, int]
    """lattice site (i, j, k); the lowest k used rests on the ground."""
    dummy: bool = False
    """a passive body: no pump, no learner."""
    mass: float | None = None
    """kg, overrides ``[unit] mass`` (or ``[dummy] mass``)."""
    friction: float | None = None
    """overrides ``[unit] friction`` (or ``[dummy] friction``)."""
    stroke: float | None = None
    """m, overrides ``[actuator] stroke`` for the bellows this unit drives (not on a dummy)."""
    mesh: str | None = None
    """overrides ``[unit] mesh`` (or ``[dummy] mesh``): '' a box, a primitive name or a mesh file path."""


@dataclass(frozen=True, kw_only=True)
class CustomLink:
    """One ``[[links]]`` table: two neighbouring bodies, numbered from 1 in ``[[units]]`` order as in the file."""

    between: tuple[int, int]
    """the two bodies' numbers (1 = the first [[units]] table)."""
    unit: int | None
    """the number of the unit whose pump drives this bellows (one of ``between``); None for a passive link."""


def custom(units: list[CustomUnit], links: list[CustomLink], unit: UnitParams, dummy: DummyParams,
           actuator: ActuatorParams, *, source: str = "custom", unit_mesh: str = "", dummy_mesh: str = ""):
    """Bodies (in ``units`` order) and links (in ``links`` order) of a custom assembly.

    Raises ConfigError (``source``, keys ``units[i].at``, ``links[i].between``, ... with i the 0-based position of
    the table, as in every error message of the project) for two bodies on one site, a link to a body that does not
    exist, a link between bodies that are not lattice neighbours, the same link twice, a link driven by a body that
    is not one of its two or is a dummy, and a stroke on a unit that drives no bellows. Connectivity is checked by
    ``morphbench.shapes.checks`` (a cut may disconnect a shape on purpose).
    """
    if not units:
        raise ConfigError(source, "units", "at least one [[units]] table")
    n = len(units)
    if n > MAX_BODIES:
        raise ConfigError(source, "units", f"at most {MAX_BODIES} [[units]] tables ({TOO_MANY})", n)
    n_active = sum(not u.dummy for u in units)
    if not 1 <= n_active <= MAX_UNITS:
        raise ConfigError(source, "units", f"between 1 and {MAX_UNITS} [[units]] tables without dummy = true "
                          f"({TOO_MANY})", n_active)
    taken: dict[tuple[int, int, int], int] = {}
    for i, entry in enumerate(units):
        if entry.at in taken:
            raise ConfigError(source, f"units[{i}].at", f"a lattice site of its own (units[{taken[entry.at]}], "
                              f"[[units]] number {taken[entry.at] + 1}, is already there)", list(entry.at))
        taken[entry.at] = i
        if entry.dummy and entry.stroke is not None:
            raise ConfigError(source, f"units[{i}].stroke", "no stroke on a dummy (it has no bellows)", entry.stroke)
    k0 = min(entry.at[2] for entry in units)
    bodies = []
    for entry in units:
        params = dummy if entry.dummy else unit
        mesh = entry.mesh if entry.mesh is not None else (dummy_mesh if entry.dummy else unit_mesh)
        i, j, k = entry.at
        bodies.append(Body(
            position=site_position((i, j, k - k0), unit, actuator), size=(unit.length, unit.width, unit.height),
            mass=params.mass if entry.mass is None else entry.mass,
            friction=params.friction if entry.friction is None else entry.friction,
            dummy=entry.dummy, mesh=mesh,
        ))
    out = []
    seen: dict[frozenset, int] = {}
    driving: set[int] = set()
    for li, link in enumerate(links):
        a, b = link.between
        for number in (a, b):
            if not 1 <= number <= n:
                raise ConfigError(source, f"links[{li}].between",
                                  f"two [[units]] numbers in 1..{n} (1 is the first [[units]] table)", [a, b])
        if a == b:
            raise ConfigError(source, f"links[{li}].between", "two different [[units]] numbers", [a, b])
        sa, sb = units[a - 1].at, units[b - 1].at
        diff = [q - p for p, q in zip(sa, sb)]
        if sorted(abs(d) for d in diff) != [0, 0, 1]:
            raise ConfigError(source, f"links[{li}].between",
                              f"lattice neighbours, sites differing by 1 along exactly one axis ([[units]] {a} is at "
                              f"{list(sa)}, {b} at {list(sb)})", [a, b])
        pair = frozenset((a, b))
        if pair in seen:
            raise ConfigError(source, f"links[{li}].between", f"a pair not already linked (links[{seen[pair]}])",
                              [a, b])
        seen[pair] = li
        axis = next(q for q in range(3) if diff[q])
        front, rear = (b, a) if diff[axis] > 0 else (a, b)
        driver = None
        stroke = None
        if link.unit is not None:
            if link.unit not in (a, b):
                raise ConfigError(source, f"links[{li}].unit",
                                  f"one of the link's two bodies {a} or {b} (the unit whose pump drives it)", link.unit)
            if units[link.unit - 1].dummy:
                raise ConfigError(source, f"links[{li}].unit",
                                  f"an active unit: [[units]] {link.unit} is a dummy (no pump); or passive = true",
                                  link.unit)
            driver = link.unit - 1
            driving.add(driver)
            stroke = units[driver].stroke
        out.append(Link(front=front - 1, rear=rear - 1, unit=driver, stroke=stroke))
    for i, entry in enumerate(units):
        if entry.stroke is not None and i not in driving:
            raise ConfigError(source, f"units[{i}].stroke", "a stroke only on a unit that drives a bellows "
                              "(a [[links]] table with unit = its number)", entry.stroke)
    return tuple(bodies), tuple(out)
