'''Read a morphology file (TOML) into a validated ``Shape``; the one loader used by the CLI, the suites and the tests.

Every table but ``[assembly]`` is optional; what is left out takes the defaults of ``morphbench.params``. The full
reference, with a picture of each shipped file, is docs/morphologies.md. A chain::

    description = "three active units and a dummy on a straight track"
    heading = [1, 0, 0]   # optional: the direction the assembly is scored along (normalised; default +x)

    [assembly]
    generator = "chain"   # chain | grid | lattice | custom
    units = 3             # active units, unit 1 at the front
    dummy = true          # a passive unit behind the last active one (default true)

    [unit]                # morphbench.params.UnitParams: length, width, height (m), mass (kg), friction,
    mesh = "capsule"      #   and mesh: '' (a box, the default), box, capsule, cylinder, sphere or a mesh file
                          #   (.obj .stl .ply .glb .gltf, relative to this file), scaled to length x width x height
    [dummy]               # morphbench.params.DummyParams: mass (kg), friction; and mesh
    [actuator]            # morphbench.params.ActuatorParams: stroke, rest_gap (m), stiffness (N/m), damping (N s/m),
                          # max_force (N), tau_inflate, tau_vent, cycle_time (s), alpha (fraction of a cycle)

Bodies sit on a lattice: site (i, j, k) has its centre at x = i (length + rest_gap), y = j (width + rest_gap),
z = height / 2 + k (height + rest_gap); x is forward, y left, z up. A link joins two sites that differ by 1 along
exactly one axis; its axis is that lattice axis, its ``front`` the body at the larger coordinate, its ``rear`` the
other (a bellows pushes both apart along it).

A grid, ``rows`` chains of ``columns`` units side by side (row 1 at y = 0, the others towards -y), each unit's
bellows pushing against the body behind it in its row, neighbouring rows joined by passive links along y, and with
``dummy = true`` (the default) a dummy at the rear of every row::

    [assembly]
    generator = "grid"
    rows = 2
    columns = 3
    dummy = true

With ``actuated_axes = ["x", "y"]`` each unit also drives the link to the body in the next row (towards -y), so the
grid can push sideways and turn; ``["y"]`` makes the links along x passive (a lattice also takes "z": vertical
bellows that lift the layer above).

A lattice, ``layers`` such grids stacked along z (layer 1 on the ground), joined by passive links along z::

    [assembly]
    generator = "lattice"
    layers = 2
    rows = 2
    columns = 2

A custom assembly: each ``[[units]]`` table puts a body at an integer lattice site ``at = [i, j, k]`` (or
``[i, j]``; the lowest k used rests on the ground), optionally a dummy, with its own ``mass``, ``friction``,
``mesh`` and, for a unit that drives a bellows, ``stroke`` (stored on that bellows' ``Link.stroke``). The tables are
numbered from 1 in file order; each ``[[links]]`` table joins two of them, ``between = [a, b]`` (lattice
neighbours), and is either driven by the pump of ``unit = a`` (one of the two, not a dummy) or ``passive = true``::

    [assembly]
    generator = "custom"

    [[units]]
    at = [0, 0, 0]
    [[units]]
    at = [-1, 0, 0]
    friction = 0.45
    [[units]]
    at = [-1, -1, 0]
    dummy = true

    [[links]]
    between = [1, 2]
    unit = 1
    [[links]]
    between = [2, 3]
    passive = true

Unit order (unit 1, 2, ...: the learners, the records' ``unit`` column) is body order without the dummies: for the
generators layer by layer from the ground up, row by row from y = 0 towards -y, front to back within a row; for a
custom assembly the order of the ``[[units]]`` tables (list dummies last and a table's number is its unit's).
Link order: the bellows in the order of their units, then passive links along y, then along z; for a custom
assembly the order of the ``[[links]]`` tables. Links are numbered from 1 (in a chain with a dummy, link k is unit
k's bellows), as in run events.

Transforms, applied to the generated assembly in this order (morphbench.shapes.transforms)::

    [transform]
    shuffle = {seed = 3}                 # the units trade places by a seeded permutation; unit k keeps its learner
    cut = {link = 3}                     # remove link 3 (or several: a list); or instead
    # cut = {plane = "x", at = -0.175}   # remove every link crossing the plane x = -0.175 m
    rotate = 90                          # degrees, counter-clockwise seen from above: the assembly is placed on the
                                         #   ground turned about the vertical through its origin (``Shape.yaw``)

A file with a cut loads as one shape whose links no longer join the pieces (its bodies where they were). Sites,
links, cut planes and the heading are all given in the assembly's own frame; ``rotate`` only turns where it stands.

Any mistake raises ``ConfigError`` naming the file and the key (``units[2].at``, ``links[0].unit``: arrays of tables
are indexed from 0 in keys, as in every message of the project): an unknown key or generator, a wrong type, a value
out of range, two bodies on one site, a link to a body that does not exist or between bodies that are not
neighbours, a link driven by a dummy or by a body that is not one of its two, a disconnected assembly (unless cut
on purpose), a mesh that is neither a primitive nor a readable closed mesh file.
'''

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

from morphbench.errors import ConfigError
from morphbench.files import is_dir, is_file, read_toml
from morphbench.params import SEED, ActuatorParams, DummyParams, UnitParams
from morphbench.readers import check_keys, field_default, params_from_dict, params_from_table
from morphbench.rules import check, check_rule, expected
from morphbench.shapes.checks import check_shape
from morphbench.shapes.export import PRIMITIVES, check_mesh
from morphbench.shapes.generators import (MAX_BODIES, MAX_SITE, MAX_UNITS, TOO_MANY, CustomLink, CustomUnit, chain,
                                          custom, lattice)
from morphbench.shapes.model import Shape
from morphbench.shapes.transforms import PLANES, cut_apart, rotate, shuffle

# params_from_table, params_from_dict and field_default moved to morphbench.readers; still importable from here
__all__ = ["GENERATORS", "MAX_UNITS", "MAX_BODIES", "chain", "load_shape", "read_toml", "shape_from_table",
           "params_from_table", "params_from_dict", "field_default"]

GENERATORS = ("chain", "grid", "lattice", "custom")
ASSEMBLY_KEYS = {
    "chain": {"generator", "units", "dummy"},
    "grid": {"generator", "rows", "columns", "dummy", "actuated_axes"},
    "lattice": {"generator", "layers", "rows", "columns", "dummy", "actuated_axes"},
    "custom": {"generator"},
}
TOP_KEYS = {"name", "description", "heading", "assembly", "unit", "dummy", "actuator", "units", "links", "transform"}
UNIT_ENTRY_KEYS = {"at", "dummy", "mass", "friction", "stroke", "mesh"}
LINK_ENTRY_KEYS = {"between", "unit", "passive"}
TRANSFORM_KEYS = {"shuffle", "cut", "rotate"}

def load_shape(path: str | Path) -> Shape:
    """Load and validate one morphology file."""
    path = Path(path)
    return shape_from_table(read_toml(path, "morphology file"), source=str(path), default_name=path.stem)


def shape_from_table(table: dict[str, Any], *, source: str, default_name: str = "shape") -> Shape:
    """Build a ``Shape`` from an already-parsed TOML table (``source`` names it in messages; relative mesh paths
    start at its directory)."""
    check_keys(table, TOP_KEYS, source, prefix="")
    name = _string(table, "name", source, default_name)
    description = _string(table, "description", source, "")
    heading = _heading(table.get("heading", [1.0, 0.0, 0.0]), source)
    if "assembly" not in table:
        raise ConfigError(source, "assembly", "an [assembly] table with a generator")
    base = Path(source).parent
    unit, unit_mesh = _body_params(UnitParams, table.get("unit", {}), source, "unit", base)
    dummy, dummy_mesh = _body_params(DummyParams, table.get("dummy", {}), source, "dummy", base)
    actuator = params_from_table(ActuatorParams, table.get("actuator", {}), source, "actuator")
    assembly = _table(table, "assembly", source)
    generator = assembly.get("generator")
    if generator not in GENERATORS:
        raise ConfigError(source, "assembly.generator", f"one of {', '.join(GENERATORS)}", generator)
    check_keys(assembly, ASSEMBLY_KEYS[generator], source, prefix="assembly.")
    meshes = {"unit_mesh": unit_mesh, "dummy_mesh": dummy_mesh}
    if generator == "custom":
        units, links = _custom_tables(table, source, base)
        bodies, links = custom(units, links, unit, dummy, actuator, source=source, **meshes)
    else:
        for key in ("units", "links"):
            if key in table:
                raise ConfigError(source, key, f'no [[{key}]] tables with generator = "{generator}" '
                                  '(they describe a generator = "custom" assembly)')
        bodies, links = _generate(generator, assembly, unit, dummy, actuator, source, meshes)
    shape = Shape(name=name, source=source, description=description, bodies=bodies, links=links, actuator=actuator,
                  heading=heading)
    label = (lambda i: f"[[units]] {i + 1}") if generator == "custom" else (lambda i: f"body {i}")
    check_shape(shape, body_label=label)
    if "transform" in table:
        shape = _transform(_table(table, "transform", source), shape, source)
    return shape


def _generate(generator: str, assembly: dict[str, Any], unit: UnitParams, dummy: DummyParams,
              actuator: ActuatorParams, source: str, meshes: dict[str, str]):
    has_dummy = assembly.get("dummy", True)
    if generator == "chain":
        n_units = _count(assembly, "units", source, f"an integer number of active units in [1, {MAX_UNITS}]")
        dims = (1, 1, n_units)
    else:
        layers = _count(assembly, "layers", source, f"an integer number of layers in [1, {MAX_UNITS}]") \
            if generator == "lattice" else 1
        rows = _count(assembly, "rows", source, f"an integer number of rows in [1, {MAX_UNITS}]")
        columns = _count(assembly, "columns", source, f"an integer number of units per row in [1, {MAX_UNITS}]")
        if layers * rows * columns > MAX_UNITS:
            product = ("layers x " if generator == "lattice" else "") + f"rows x columns = {layers * rows * columns}"
            raise ConfigError(source, "assembly.columns", f"at most {MAX_UNITS} active units in all ({product}; "
                              f"{TOO_MANY})", columns)
        dims = (layers, rows, columns)
    if not isinstance(has_dummy, bool):
        raise ConfigError(source, "assembly.dummy", "true or false", has_dummy)
    if dims[2] == 1 and not has_dummy:
        what = "a single unit's" if generator == "chain" else "a row of one unit: its"
        raise ConfigError(source, "assembly.dummy", f"true: {what} bellows needs a body to push against", False)
    if generator == "chain":
        return chain(dims[2], has_dummy, unit, dummy, actuator, **meshes)
    axes = ("x", "y", "z") if generator == "lattice" else ("x", "y")  # exact names: "" and "xy" are substrings of "xyz"
    actuated = assembly.get("actuated_axes", ["x"])
    if not (isinstance(actuated, list) and actuated and all(isinstance(a, str) and a in axes for a in actuated)
            and len(set(actuated)) == len(actuated)):
        raise ConfigError(source, "assembly.actuated_axes", f"a non-empty list of distinct axes among "
                          f"{', '.join(repr(a) for a in axes)} (along which each unit drives a bellows)", actuated)
    return lattice(*dims, has_dummy, unit, dummy, actuator, **meshes, actuated_axes=tuple(actuated))


def _count(assembly: dict[str, Any], key: str, source: str, expected: str) -> int:
    value = assembly.get(key)
    if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= MAX_UNITS:
        why = f" ({TOO_MANY})" if not isinstance(value, bool) and isinstance(value, int) and value > MAX_UNITS else ""
        raise ConfigError(source, f"assembly.{key}", expected + why, value if key in assembly else ...)
    return value


def _custom_tables(table: dict[str, Any], source: str, base: Path) -> tuple[list[CustomUnit], list[CustomLink]]:
    """The [[units]] and [[links]] tables of a custom assembly, each value type-checked (the structure is checked by
    ``generators.custom``)."""
    entries = table.get("units")
    if not isinstance(entries, list) or not entries or not all(isinstance(e, dict) for e in entries):
        raise ConfigError(source, "units", 'one or more [[units]] tables (generator = "custom" places each body at a '
                          "lattice site, at = [i, j, k])", entries if "units" in table else ...)
    if len(entries) > MAX_BODIES:
        raise ConfigError(source, "units", f"at most {MAX_BODIES} [[units]] tables ({TOO_MANY})", len(entries))
    units = []
    for i, entry in enumerate(entries):
        where = f"units[{i}]"
        check_keys(entry, UNIT_ENTRY_KEYS, source, prefix=f"{where}.")
        at = entry.get("at")
        if not (isinstance(at, list) and len(at) in (2, 3)
                and all(isinstance(v, int) and not isinstance(v, bool) and abs(v) <= MAX_SITE for v in at)):
            raise ConfigError(source, f"{where}.at", f"a lattice site [i, j, k] (or [i, j]) of integers in "
                              f"[-{MAX_SITE}, {MAX_SITE}]", at if "at" in entry else ...)
        is_dummy = entry.get("dummy", False)
        if not isinstance(is_dummy, bool):
            raise ConfigError(source, f"{where}.dummy", "true or false", is_dummy)
        values = {}
        for key, owner in (("mass", UnitParams), ("friction", UnitParams), ("stroke", ActuatorParams)):
            if key in entry:
                values[key] = check(owner, key, entry[key], source, f"{where}.{key}")
        if "mesh" in entry:
            values["mesh"] = _mesh(entry["mesh"], source, f"{where}.mesh", base)
        units.append(CustomUnit(at=tuple(at) + (0,) * (3 - len(at)), dummy=is_dummy, **values))
    items = table.get("links", [])
    if not isinstance(items, list) or not all(isinstance(e, dict) for e in items):
        raise ConfigError(source, "links", "[[links]] tables (between = [a, b], and unit = a or passive = true)", items)
    links = []
    for i, item in enumerate(items):
        where = f"links[{i}]"
        check_keys(item, LINK_ENTRY_KEYS, source, prefix=f"{where}.")
        between = item.get("between")
        if not (isinstance(between, list) and len(between) == 2
                and all(isinstance(v, int) and not isinstance(v, bool) for v in between)):
            raise ConfigError(source, f"{where}.between",
                              "two [[units]] numbers [a, b] (1 is the first [[units]] table)",
                              between if "between" in item else ...)
        passive = item.get("passive", False)
        if not isinstance(passive, bool):
            raise ConfigError(source, f"{where}.passive", "true or false", passive)
        if passive and "unit" in item:
            raise ConfigError(source, f"{where}.unit", "no unit on a passive link (passive = true)", item["unit"])
        driver = item.get("unit")
        if not passive and (isinstance(driver, bool) or not isinstance(driver, int)):
            raise ConfigError(source, f"{where}.unit", f"the number of the unit whose pump drives this link (one of "
                              f"{between}), or passive = true", driver if "unit" in item else ...)
        links.append(CustomLink(between=(between[0], between[1]), unit=None if passive else driver))
    return units, links


def _transform(transform: dict[str, Any], shape: Shape, source: str) -> Shape:
    """Apply a [transform] table: shuffle first, then cut, then rotate."""
    check_keys(transform, TRANSFORM_KEYS, source, prefix="transform.")
    if "shuffle" in transform:
        spec = transform["shuffle"]
        if not isinstance(spec, dict):
            raise ConfigError(source, "transform.shuffle", "a table {seed = N}", spec)
        check_keys(spec, {"seed"}, source, prefix="transform.shuffle.")
        if "seed" not in spec:
            raise ConfigError(source, "transform.shuffle.seed", expected(SEED))
        shape = shuffle(shape, check_rule(SEED, "", spec["seed"], source, "transform.shuffle.seed"))
    if "cut" in transform:
        spec = transform["cut"]
        if not isinstance(spec, dict):
            raise ConfigError(source, "transform.cut", '{link = N}, {link = [N, M]} or {plane = "x", at = X}', spec)
        check_keys(spec, {"link", "plane", "at"}, source, prefix="transform.cut.")
        if ("link" in spec) == ("plane" in spec) or ("link" in spec and "at" in spec):
            raise ConfigError(source, "transform.cut", 'either link = N (or a list) or plane = "x" | "y" | "z" with at')
        n_links = len(shape.links)
        if "link" in spec:
            value = spec["link"]
            numbers = value if isinstance(value, list) else [value]
            valid = all(isinstance(v, int) and not isinstance(v, bool) and 1 <= v <= n_links for v in numbers)
            if not numbers or not valid or len(set(numbers)) != len(numbers):
                raise ConfigError(source, "transform.cut.link",
                                  f"a link number in [1, {n_links}] or a list of distinct ones", value)
            shape, _ = cut_apart(shape, link=[v - 1 for v in numbers])
        else:
            plane, at = spec["plane"], spec.get("at")
            if not isinstance(plane, str) or plane not in PLANES:
                raise ConfigError(source, "transform.cut.plane", "one of x, y, z", plane)
            if isinstance(at, bool) or not isinstance(at, (int, float)) or not math.isfinite(at):
                raise ConfigError(source, "transform.cut.at", "a finite number (m, where the plane crosses its axis)",
                                  at if "at" in spec else ...)
            try:
                shape, _ = cut_apart(shape, plane=plane, at=float(at))
            except ValueError as exc:
                raise ConfigError(source, "transform.cut.at", f"a plane between body centres that cuts a link ({exc})",
                                  at) from None
    if "rotate" in transform:
        degrees = transform["rotate"]
        if isinstance(degrees, bool) or not isinstance(degrees, (int, float)) or not -360 <= degrees <= 360:
            raise ConfigError(source, "transform.rotate", "degrees in [-360, 360] (counter-clockwise seen from above)",
                              degrees)
        shape = rotate(shape, float(degrees))
    return shape


def _body_params(cls: type, value: Any, source: str, section: str, base: Path):
    """A [unit] or [dummy] table: the parameter dataclass and the mesh."""
    if not isinstance(value, dict):
        raise ConfigError(source, section, f"a table of {cls.__name__} fields", value)
    check_keys(value, {f.name for f in dataclasses.fields(cls)} | {"mesh"}, source, prefix=f"{section}.")
    table = dict(value)
    mesh = _mesh(table.pop("mesh"), source, f"{section}.mesh", base) if "mesh" in table else ""
    return params_from_table(cls, table, source, section), mesh


def _mesh(value: Any, source: str, key: str, base: Path) -> str:
    expected = f"'' (a box), one of {', '.join(PRIMITIVES)} or a mesh file path"
    if not isinstance(value, str):
        raise ConfigError(source, key, f"a string: {expected}", value)
    try:
        return check_mesh(value, base)
    except ValueError as exc:
        raise ConfigError(source, key, str(exc), value) from None


def _heading(value: Any, source: str) -> tuple[float, float, float]:
    ok = (isinstance(value, list) and len(value) == 3
          and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value))
    norm = math.sqrt(sum(float(v) ** 2 for v in value)) if ok else 0.0
    if not ok or norm < 1e-12:
        raise ConfigError(source, "heading", "three finite numbers [x, y, z], not all zero", value)
    return tuple(float(v) / norm for v in value)


def _string(table: dict[str, Any], key: str, source: str, default: str) -> str:
    value = table.get(key, default)
    if not isinstance(value, str):
        raise ConfigError(source, key, "a string", value)
    return value


def _table(table: dict[str, Any], key: str, source: str) -> dict[str, Any]:
    value = table[key]
    if not isinstance(value, dict):
        raise ConfigError(source, key, "a table", value)
    return value


def resolve_shape_path(name: str | Path) -> Path:
    """The file a command-line shape argument means: ``name`` itself, unless it is a bare name (no ``.toml``, no
    directory) that is not a file here, which names a shape of the shipped library (``chain-2``); a bare name that is
    in neither is a ConfigError listing the library."""
    path = Path(name)
    if is_file(path) or is_dir(path) or path.suffix == ".toml" or len(path.parts) != 1:
        return path
    from morphbench import data_path

    library = data_path("shapes")
    shipped = library / f"{path.name}.toml"
    if shipped.is_file():
        return shipped
    names = ", ".join(sorted(p.stem for p in library.glob("*.toml")))
    raise ConfigError(str(name), "(shape)", f"a morphology file or the name of a shipped shape ({names})")
