"""The shape library and the extended file format: generators, custom assemblies, transforms, meshes, validation,
and the ``shapes`` commands (list, check, export, show)."""

from __future__ import annotations

import argparse
import tomllib
from pathlib import Path

import numpy as np
import pytest
import trimesh

from morphbench.errors import ConfigError
from morphbench.params import ActuatorParams, DummyParams, UnitParams
from morphbench.shapes import check_shape, components, is_connected, load_shape, shuffle
from morphbench.cli import main
from morphbench.shapes.cli import add_shapes_commands
from morphbench.shapes.drawing import draw
from morphbench.shapes.export import body_names, export_scene
from morphbench.shapes.loader import GENERATORS, MAX_UNITS
from conftest import LIBRARY, SHAPES_DIR, assert_config_error, run_cli, write

UNIT, DUMMY, ACTUATOR = UnitParams(), DummyParams(), ActuatorParams()
PITCH = (UNIT.length + ACTUATOR.rest_gap, UNIT.width + ACTUATOR.rest_gap, UNIT.height + ACTUATOR.rest_gap)


def has_cut(path: Path) -> bool:
    return "cut" in tomllib.loads(path.read_text(encoding="utf-8")).get("transform", {})


def lattice_site(shape, i: int) -> tuple[int, int, int]:
    x, y, z = shape.bodies[i].position
    site = (x / PITCH[0], y / PITCH[1], (z - UNIT.height / 2) / PITCH[2])
    assert np.allclose(site, np.round(site), atol=1e-9)
    return tuple(int(v) for v in np.round(site))


# --- the library ----------------------------------------------------------------------------------------------------

REQUIRED = ["chain-2", "chain-3", "chain-7", "chain-20", "grid-2x2", "grid-2x3", "grid-3x3", "stack-2x2x2",
            "custom-irregular", "chain-6-shuffled", "chain-6-cut", "chain-3-capsules"]


def test_library_has_the_required_files():
    names = {p.stem for p in LIBRARY}
    assert set(REQUIRED) <= names
    assert len(LIBRARY) >= 10


@pytest.mark.parametrize("path", LIBRARY, ids=[p.name for p in LIBRARY])
def test_every_library_file_loads_and_passes_the_checks(path: Path):
    shape = load_shape(path)
    assert shape.description
    assert shape.name == path.stem
    check_shape(shape, allow_disconnected=has_cut(path))
    assert is_connected(shape) != has_cut(path)  # only a cut file is in pieces
    assert shape.n_units >= 1
    for link in shape.links:
        assert link.unit is None or (link.unit in (link.front, link.rear) and not shape.bodies[link.unit].dummy)
    assert len({lattice_site(shape, i) for i in range(len(shape.bodies))}) == len(shape.bodies)


@pytest.mark.parametrize("name, counts", [
    ("grid-2x2", (4, 6, 7)), ("grid-2x3", (6, 8, 10)), ("grid-3x3", (9, 12, 17)), ("stack-2x2x2", (8, 12, 20)),
    ("custom-irregular", (4, 6, 5)), ("chain-6-shuffled", (6, 7, 6)), ("chain-6-cut", (6, 7, 5)),
    ("chain-3-capsules", (3, 4, 3)), ("chain-20", (20, 21, 20)),
])
def test_library_counts(name: str, counts):
    shape = load_shape(SHAPES_DIR / f"{name}.toml")
    assert (shape.n_units, len(shape.bodies), len(shape.links)) == counts


def test_chain_6_shuffled_is_chain_6_with_its_units_moved(tmp_path: Path):
    plain = load_shape(write(tmp_path, '[assembly]\ngenerator = "chain"\nunits = 6\n', "chain-6-shuffled.toml"))
    shuffled = load_shape(SHAPES_DIR / "chain-6-shuffled.toml")
    assert shuffled.bodies == shuffle(plain, 3).bodies and shuffled.links == shuffle(plain, 3).links
    assert shuffled.bodies != plain.bodies
    assert sorted(b.position for b in shuffled.bodies) == sorted(b.position for b in plain.bodies)


def test_chain_6_cut_is_two_halves():
    shape = load_shape(SHAPES_DIR / "chain-6-cut.toml")
    front, rear = components(shape)
    assert front == [0, 1, 2] and rear == [3, 4, 5, 6]
    assert [(link.front, link.rear, link.unit) for link in shape.links] == [
        (0, 1, 0), (1, 2, 1), (3, 4, 3), (4, 5, 4), (5, 6, 5)]


def test_chain_3_capsules_units_are_capsules():
    shape = load_shape(SHAPES_DIR / "chain-3-capsules.toml")
    assert [b.mesh for b in shape.bodies] == ["capsule"] * 3 + [""]


def test_custom_irregular_has_a_dummy_a_passive_link_and_overrides():
    shape = load_shape(SHAPES_DIR / "custom-irregular.toml")
    assert [b.dummy for b in shape.bodies] == [False] * 4 + [True] * 2
    assert sum(link.unit is None for link in shape.links) == 1
    assert shape.bodies[3].mass == 0.06 and shape.bodies[5].friction == 0.8
    assert [link.stroke for link in shape.links if link.unit == 3] == [0.008]
    sites = [lattice_site(shape, i) for i in range(len(shape.bodies))]
    assert sites == [(0, 0, 0), (-1, 0, 0), (-2, 0, 0), (-2, -1, 0), (-3, -1, 0), (-3, 0, 0)]
    assert len({s[1] for s in sites}) == 2  # not a straight line


# --- generators: counts, places, unit order, link order -------------------------------------------------------------


def lattice_text(generator: str, dims: dict, dummy: bool) -> str:
    lines = [f'[assembly]\ngenerator = "{generator}"'] + [f"{k} = {v}" for k, v in dims.items()]
    return "\n".join(lines + [f"dummy = {'true' if dummy else 'false'}"]) + "\n"


@pytest.mark.parametrize("units", [1, 2, 5])
@pytest.mark.parametrize("dummy", [True, False])
def test_chain_counts(tmp_path: Path, units: int, dummy: bool):
    path = write(tmp_path, lattice_text("chain", {"units": units}, dummy))
    if units == 1 and not dummy:  # a lone unit's bellows has nothing to push against
        assert_config_error(path, "assembly.dummy", "true")
        return
    shape = load_shape(path)
    assert (shape.n_units, len(shape.bodies), len(shape.links)) == (units, units + dummy, units - 1 + dummy)


@pytest.mark.parametrize("layers, rows, columns", [(1, 1, 1), (1, 1, 4), (1, 2, 2), (1, 3, 2), (1, 4, 3), (2, 1, 1),
                                                   (2, 2, 2), (3, 2, 3), (2, 3, 1)])
@pytest.mark.parametrize("dummy", [True, False])
def test_grid_and_lattice_counts(tmp_path: Path, layers: int, rows: int, columns: int, dummy: bool):
    generator, dims = ("grid", {"rows": rows, "columns": columns}) if layers == 1 else \
        ("lattice", {"layers": layers, "rows": rows, "columns": columns})
    path = write(tmp_path, lattice_text(generator, dims, dummy))
    if columns == 1 and not dummy:  # a row of one unit: its bellows has nothing to push against
        assert_config_error(path, "assembly.dummy", "true")
        return
    shape = load_shape(path)
    per_row = columns + dummy
    bellows = layers * rows * (columns if dummy else columns - 1)
    across = layers * (rows - 1) * per_row
    up = (layers - 1) * rows * per_row
    assert shape.n_units == layers * rows * columns
    assert len(shape.bodies) == layers * rows * per_row
    assert len(shape.links) == bellows + across + up
    assert sum(link.unit is not None for link in shape.links) == bellows
    assert is_connected(shape)
    # links in order: bellows (by unit), then along y, then along z; front at the larger coordinate
    axes = [int(np.argmax(np.abs(np.subtract(shape.bodies[link.front].position, shape.bodies[link.rear].position))))
            for link in shape.links]
    assert axes == [0] * bellows + [1] * across + [2] * up
    for link in shape.links:
        d = np.subtract(shape.bodies[link.front].position, shape.bodies[link.rear].position)
        assert d.max() > 0 and np.isclose(d.max(), PITCH[int(np.argmax(d))])
    assert [link.unit for link in shape.links[:bellows]] == sorted(link.unit for link in shape.links[:bellows])
    # unit order: layer by layer (z up), row by row (y down from 0), front to back (x down from 0)
    sites = [lattice_site(shape, b) for b in shape.units]
    assert sites == sorted(sites, key=lambda s: (s[2], -s[1], -s[0]))
    assert sites[0] == (0, 0, 0)
    assert min(s[2] for s in sites) == 0  # the lowest layer on the ground
    for b in shape.bodies:
        assert b.position[2] >= UNIT.height / 2 - 1e-12
    if dummy:  # a dummy at the rear of every row
        dummies = [lattice_site(shape, i) for i, b in enumerate(shape.bodies) if b.dummy]
        assert sorted(dummies) == sorted((-columns, -r, k) for r in range(rows) for k in range(layers))


def test_layers_sit_on_each_other(tmp_path: Path):
    shape = load_shape(write(tmp_path, lattice_text("lattice", {"layers": 3, "rows": 1, "columns": 1}, True)))
    zs = sorted({b.position[2] for b in shape.bodies})
    assert zs == pytest.approx([UNIT.height / 2 + k * (UNIT.height + ACTUATOR.rest_gap) for k in range(3)])


def test_grid_rows_are_joined_by_passive_links(tmp_path: Path):
    shape = load_shape(write(tmp_path, lattice_text("grid", {"rows": 2, "columns": 2}, True)))
    # bodies: row 1 = units 1, 2, dummy; row 2 = units 3, 4, dummy
    assert [(link.front, link.rear, link.unit) for link in shape.links] == [
        (0, 1, 0), (1, 2, 1), (3, 4, 3), (4, 5, 4), (0, 3, None), (1, 4, None), (2, 5, None)]


CUSTOM_HEAD = '[assembly]\ngenerator = "custom"\n'


def units_text(*sites, dummies=(), extra: dict | None = None) -> str:
    out = []
    for n, site in enumerate(sites, start=1):
        out.append(f"[[units]]\nat = {list(site)}\n" + ("dummy = true\n" if n in dummies else "")
                   + "".join(f"{k} = {v}\n" for k, v in (extra or {}).get(n, {}).items()))
    return "".join(out)


def links_text(*links) -> str:
    out = []
    for link in links:
        a, b, unit = link
        out.append(f"[[links]]\nbetween = [{a}, {b}]\n" + ("passive = true\n" if unit is None else f"unit = {unit}\n"))
    return "".join(out)


def test_custom_places_front_and_rear(tmp_path: Path):
    text = CUSTOM_HEAD + units_text((0, 0, 0), (1, 0, 0), (1, 1, 0), (1, 1, 1), dummies=(4,)) \
        + links_text((1, 2, 1), (3, 2, 2), (3, 4, None))
    shape = load_shape(write(tmp_path, text))
    assert shape.units == (0, 1, 2)
    # the front is the body at the larger coordinate along the link's axis, whatever the order of `between`
    assert [(link.front, link.rear, link.unit) for link in shape.links] == [(1, 0, 0), (2, 1, 1), (3, 2, None)]
    assert shape.bodies[3].position == pytest.approx((PITCH[0], PITCH[1], UNIT.height / 2 + PITCH[2]))


def test_custom_lowest_layer_rests_on_the_ground_and_two_coordinates_mean_k_0(tmp_path: Path):
    text = CUSTOM_HEAD + "[[units]]\nat = [0, 0, 5]\n[[units]]\nat = [-1, 0, 5]\ndummy = true\n" + links_text((1, 2, 1))
    assert [b.position[2] for b in load_shape(write(tmp_path, text)).bodies] == [UNIT.height / 2] * 2
    text = CUSTOM_HEAD + "[[units]]\nat = [0, 0]\n[[units]]\nat = [-1, 0]\ndummy = true\n" + links_text((1, 2, 1))
    assert [b.position[2] for b in load_shape(write(tmp_path, text)).bodies] == [UNIT.height / 2] * 2


def test_custom_per_unit_overrides_and_defaults(tmp_path: Path):
    text = ("[unit]\nmass = 0.07\nmesh = \"sphere\"\n[dummy]\nfriction = 0.9\n" + CUSTOM_HEAD
            + units_text((0, 0, 0), (-1, 0, 0), (-2, 0, 0), dummies=(3,),
                         extra={1: {"mass": 0.04, "friction": 0.3, "stroke": 0.005, "mesh": '"cylinder"'},
                                3: {"mass": 0.2, "mesh": '"box"'}})
            + links_text((1, 2, 1), (2, 3, 2)))
    shape = load_shape(write(tmp_path, text))
    assert [(b.mass, b.friction, b.mesh) for b in shape.bodies] == [
        (0.04, 0.3, "cylinder"), (0.07, UNIT.friction, "sphere"), (0.2, 0.9, "box")]
    assert [link.stroke for link in shape.links] == [0.005, None]


def test_heading_is_normalised(tmp_path: Path):
    shape = load_shape(write(tmp_path, 'heading = [0, 3, 4]\n[assembly]\ngenerator = "chain"\nunits = 2\n'))
    assert shape.heading == pytest.approx((0.0, 0.6, 0.8))
    assert load_shape(write(tmp_path, '[assembly]\ngenerator = "chain"\nunits = 2\n')).heading == (1.0, 0.0, 0.0)


def test_mesh_paths_start_at_the_file(tmp_path: Path):
    (tmp_path / "meshes").mkdir()
    trimesh.creation.icosphere().export(tmp_path / "meshes" / "ball.stl")
    (tmp_path / "sub").mkdir()
    text = '[assembly]\ngenerator = "chain"\nunits = 2\n[unit]\nmesh = "../meshes/ball.stl"\n'
    shape = load_shape(write(tmp_path / "sub", text))
    assert Path(shape.bodies[0].mesh).resolve() == (tmp_path / "meshes" / "ball.stl").resolve()
    assert shape.bodies[2].mesh == ""


def test_transforms_in_a_file(tmp_path: Path):
    base = '[assembly]\ngenerator = "grid"\nrows = 2\ncolumns = 3\n'
    plain = load_shape(write(tmp_path, base))
    both = load_shape(write(tmp_path, base + '[transform]\nshuffle = {seed = 5}\ncut = {plane = "y", at = -0.025}\n'))
    assert len(components(both)) == 2 and both.n_units == 6
    # only the rungs crossed y
    assert both.links == tuple(link for link in shuffle(plain, 5).links if link.unit is not None)
    several = load_shape(write(tmp_path, base + "[transform]\ncut = {link = [1, 5]}\n"))
    assert len(several.links) == len(plain.links) - 2 and several.links[0] == plain.links[1]


# --- bad input: ConfigError naming the file, the key and what was expected ------------------------------------------

CHAIN = '[assembly]\ngenerator = "chain"\nunits = 3\n'
GRID = '[assembly]\ngenerator = "grid"\nrows = 2\ncolumns = 2\n'
TWO = CUSTOM_HEAD + units_text((0, 0, 0), (-1, 0, 0), dummies=(2,))

BAD = [
    ("unknown-generator", '[assembly]\ngenerator = "ring"\n', "assembly.generator",
     "one of chain, grid, lattice, custom"),
    ("grid-with-units", GRID + "units = 4\n", "assembly.units",
     "one of the known keys actuated_axes, columns, dummy, generator, rows"),
    ("grid-missing-rows", '[assembly]\ngenerator = "grid"\ncolumns = 2\n', "assembly.rows",
     "an integer number of rows"),
    ("grid-zero-columns", GRID.replace("columns = 2", "columns = 0"), "assembly.columns",
     f"units per row in [1, {MAX_UNITS}]"),
    ("grid-too-big", '[assembly]\ngenerator = "grid"\nrows = 400\ncolumns = 251\n', "assembly.columns",
     f"at most {MAX_UNITS} active units in all (rows x columns = 100400; a larger assembly takes over 4 CPU s per "
     "simulated second, a 300-step run over 80 minutes)"),
    ("grid-row-of-one-no-dummy", '[assembly]\ngenerator = "grid"\nrows = 3\ncolumns = 1\ndummy = false\n',
     "assembly.dummy", "true: a row of one unit"),
    ("lattice-missing-layers", '[assembly]\ngenerator = "lattice"\nrows = 2\ncolumns = 2\n', "assembly.layers",
     "an integer number of layers"),
    ("lattice-float-layers", '[assembly]\ngenerator = "lattice"\nlayers = 1.5\nrows = 2\ncolumns = 2\n',
     "assembly.layers", "an integer number of layers"),
    ("custom-with-units-count", CUSTOM_HEAD + "units = 3\n", "assembly.units", "one of the known keys generator"),
    ("custom-without-units", CUSTOM_HEAD, "units", "one or more [[units]] tables"),
    ("custom-units-not-tables", "units = [1, 2]\n" + CUSTOM_HEAD, "units", "one or more [[units]] tables"),
    ("units-with-chain", CHAIN + "[[units]]\nat = [0, 0, 0]\n", "units", 'with generator = "chain"'),
    ("links-with-grid", GRID + "[[links]]\nbetween = [1, 2]\nunit = 1\n", "links", 'with generator = "grid"'),
    ("unknown-unit-key", CUSTOM_HEAD + "[[units]]\nat = [0, 0, 0]\ncolour = 1\n", "units[0].colour",
     "one of the known keys at, dummy, friction, mass, mesh, stroke"),
    ("unknown-link-key", TWO + "[[links]]\nbetween = [1, 2]\nunit = 1\nforce = 2\n", "links[0].force",
     "one of the known keys between, passive, unit"),
    ("missing-at", CUSTOM_HEAD + "[[units]]\ndummy = true\n", "units[0].at", "a lattice site [i, j, k]"),
    ("float-at", CUSTOM_HEAD + "[[units]]\nat = [0.5, 0, 0]\n", "units[0].at", "a lattice site [i, j, k]"),
    ("long-at", CUSTOM_HEAD + "[[units]]\nat = [0, 0, 0, 0]\n", "units[0].at", "a lattice site [i, j, k]"),
    ("bool-dummy", CUSTOM_HEAD + "[[units]]\nat = [0, 0, 0]\ndummy = 1\n", "units[0].dummy", "true or false"),
    ("negative-mass", CUSTOM_HEAD + "[[units]]\nat = [0, 0, 0]\nmass = -1\n", "units[0].mass",
     "a number in [0.001, 10] (kg)"),
    ("negative-friction", CUSTOM_HEAD + "[[units]]\nat = [0, 0, 0]\nfriction = -1\n", "units[0].friction",
     "a number in [0, 10]"),
    ("overlap", CUSTOM_HEAD + units_text((0, 0, 0), (-1, 0, 0), (0, 0, 0)) + links_text((1, 2, 1)),
     "units[2].at", "a lattice site of its own (units[0]"),
    ("only-dummies", CUSTOM_HEAD + units_text((0, 0, 0), dummies=(1,)), "units", "without dummy = true"),
    ("link-to-nothing", TWO + links_text((1, 3, 1)), "links[0].between", "two [[units]] numbers in 1..2"),
    ("link-to-zero", TWO + links_text((0, 1, 1)), "links[0].between", "two [[units]] numbers in 1..2"),
    ("link-to-itself", TWO + links_text((1, 1, 1)), "links[0].between", "two different [[units]] numbers"),
    ("link-not-neighbours", CUSTOM_HEAD + units_text((0, 0, 0), (-2, 0, 0)) + links_text((1, 2, 1)),
     "links[0].between", "lattice neighbours"),
    ("link-diagonal", CUSTOM_HEAD + units_text((0, 0, 0), (-1, -1, 0)) + links_text((1, 2, 1)),
     "links[0].between", "lattice neighbours"),
    ("link-twice", TWO + links_text((1, 2, 1), (2, 1, None)), "links[1].between", "a pair not already linked"),
    ("actuator-not-in-link",
     CUSTOM_HEAD + units_text((0, 0, 0), (-1, 0, 0), (-2, 0, 0)) + links_text((1, 2, 3), (2, 3, 2)),
     "links[0].unit", "one of the link's two bodies 1 or 2"),
    ("actuator-is-dummy", TWO + links_text((1, 2, 2)), "links[0].unit", "an active unit: [[units]] 2 is a dummy"),
    ("link-neither-unit-nor-passive", TWO + "[[links]]\nbetween = [1, 2]\n", "links[0].unit", "or passive = true"),
    ("passive-with-unit", TWO + "[[links]]\nbetween = [1, 2]\nunit = 1\npassive = true\n", "links[0].unit",
     "no unit on a passive link"),
    ("between-one", TWO + "[[links]]\nbetween = [1]\nunit = 1\n", "links[0].between", "two [[units]] numbers [a, b]"),
    ("disconnected", CUSTOM_HEAD + units_text((0, 0, 0), (-1, 0, 0), (-3, 0, 0), (-4, 0, 0), dummies=(2, 4))
     + links_text((1, 2, 1), (3, 4, 3)), "links", "a connected assembly"),
    ("disconnected-no-links", CUSTOM_HEAD + units_text((0, 0, 0), (-1, 0, 0)), "links", "not joined: [[units]] 2"),
    ("stroke-on-dummy", CUSTOM_HEAD + units_text((0, 0, 0), (-1, 0, 0), dummies=(2,), extra={2: {"stroke": 0.01}})
     + links_text((1, 2, 1)), "units[1].stroke", "no stroke on a dummy"),
    ("stroke-on-undriven-unit", CUSTOM_HEAD + units_text((0, 0, 0), (-1, 0, 0), extra={2: {"stroke": 0.01}})
     + links_text((1, 2, 1)), "units[1].stroke", "a stroke only on a unit that drives a bellows"),
    ("heading-zero", "heading = [0, 0, 0]\n" + CHAIN, "heading", "not all zero"),
    ("heading-short", "heading = [1, 0]\n" + CHAIN, "heading", "three finite numbers"),
    ("heading-string", 'heading = "north"\n' + CHAIN, "heading", "three finite numbers"),
    ("transform-unknown", CHAIN + "[transform]\nmirror = true\n", "transform.mirror",
     "one of the known keys cut, rotate, shuffle"),
    ("transform-not-table", "transform = 3\n" + CHAIN, "transform", "a table"),
    ("shuffle-negative-seed", CHAIN + "[transform]\nshuffle = {seed = -1}\n", "transform.shuffle.seed",
     "an integer in [0, 9223372036854775807]"),
    ("shuffle-no-seed", CHAIN + "[transform]\nshuffle = {}\n", "transform.shuffle.seed",
     "an integer in [0, 9223372036854775807]"),
    ("shuffle-bad-key", CHAIN + "[transform]\nshuffle = {seed = 1, times = 2}\n", "transform.shuffle.times",
     "one of the known keys seed"),
    ("cut-link-0", CHAIN + "[transform]\ncut = {link = 0}\n", "transform.cut.link", "a link number in [1, 3]"),
    ("cut-link-too-big", CHAIN + "[transform]\ncut = {link = 4}\n", "transform.cut.link", "a link number in [1, 3]"),
    ("cut-link-twice", CHAIN + "[transform]\ncut = {link = [2, 2]}\n", "transform.cut.link", "distinct"),
    ("cut-link-and-plane", CHAIN + '[transform]\ncut = {link = 1, plane = "x", at = 0.1}\n', "transform.cut",
     "either link"),
    ("cut-empty", CHAIN + "[transform]\ncut = {}\n", "transform.cut", "either link"),
    ("cut-plane-w", CHAIN + '[transform]\ncut = {plane = "w", at = 0.1}\n', "transform.cut.plane", "one of x, y, z"),
    ("cut-plane-no-at", CHAIN + '[transform]\ncut = {plane = "x"}\n', "transform.cut.at", "a finite number"),
    ("cut-plane-through-body", CHAIN + '[transform]\ncut = {plane = "x", at = -0.07}\n', "transform.cut.at",
     "passes through the centre of body 1"),
    ("cut-plane-cuts-nothing", CHAIN + '[transform]\ncut = {plane = "x", at = 0.5}\n', "transform.cut.at",
     "cuts no link"),
    ("mesh-unknown-primitive", CHAIN + '[unit]\nmesh = "cube"\n', "unit.mesh", "one of box, capsule, cylinder, sphere"),
    ("mesh-missing-file", CHAIN + '[dummy]\nmesh = "nosuch.stl"\n', "dummy.mesh", "an existing mesh file"),
    ("mesh-not-string", CHAIN + "[unit]\nmesh = 3\n", "unit.mesh", "a string"),
    ("custom-mesh-unknown", CUSTOM_HEAD + '[[units]]\nat = [0, 0, 0]\nmesh = "torus"\n', "units[0].mesh",
     "one of box, capsule"),
    ("unknown-unit-key-lists-mesh", CHAIN + "[unit]\ncolour = 1\n", "unit.colour", "mass, mesh, width"),
]


@pytest.mark.parametrize("text, key, expected", [case[1:] for case in BAD], ids=[case[0] for case in BAD])
def test_bad_file(tmp_path: Path, text: str, key: str, expected: str):
    assert_config_error(write(tmp_path, text), key, expected)


def test_mesh_that_is_not_closed(tmp_path: Path):
    open_box = trimesh.creation.box()
    open_box.update_faces(np.arange(len(open_box.faces)) > 1)
    open_box.export(tmp_path / "open.stl")
    assert_config_error(write(tmp_path, CHAIN + '[unit]\nmesh = "open.stl"\n'), "unit.mesh", "a closed")


def test_an_unknown_generator_is_rejected_naming_every_generator(tmp_path: Path):
    assert_config_error(write(tmp_path, '[assembly]\ngenerator = "ring"\n'), "assembly.generator",
                        f"one of {', '.join(GENERATORS)}")


# --- export and show ------------------------------------------------------------------------------------------------

PICTURED = ["grid-2x3", "stack-2x2x2", "custom-irregular", "chain-3-capsules", "chain-6-cut"]


@pytest.mark.parametrize("name", PICTURED)
def test_export_glb_has_one_geometry_per_body_and_link(tmp_path: Path, name: str):
    shape = load_shape(SHAPES_DIR / f"{name}.toml")
    out = export_scene(shape, tmp_path / f"{name}.glb")
    scene = trimesh.load(out)
    assert isinstance(scene, trimesh.Scene)
    assert len(scene.geometry) == len(shape.bodies) + len(shape.links)
    names = set(scene.geometry)
    assert set(body_names(shape)) <= names
    assert sum(n.startswith("bellows-") for n in names) == sum(link.unit is not None for link in shape.links)
    assert sum(n.startswith("link-") for n in names) == sum(link.unit is None for link in shape.links)
    for body, body_name in zip(shape.bodies, body_names(shape)):  # each body where it is, at its size
        geometry = scene.geometry[body_name]
        transform = scene.graph.get(body_name)[0]
        bounds = trimesh.transform_points(geometry.bounds, transform)
        assert np.allclose(bounds.mean(axis=0), body.position, atol=1e-6)
        assert np.allclose(np.diff(bounds, axis=0)[0], body.size, atol=1e-6)
    colours = {tuple(scene.geometry[n].visual.vertex_colors[0]) for n in ("unit-1", "dummy-1")}
    assert len(colours) == 2  # units and dummies told apart


@pytest.mark.parametrize("suffix", [".gltf", ".obj", ".ply"])
def test_export_other_formats(tmp_path: Path, suffix: str):
    shape = load_shape(SHAPES_DIR / "grid-2x2.toml")
    out = export_scene(shape, tmp_path / f"grid{suffix}")
    assert out.is_file() and out.stat().st_size > 0
    loaded = trimesh.load(out)
    if suffix == ".gltf":
        assert len(loaded.geometry) == len(shape.bodies) + len(shape.links)
    else:  # one merged mesh
        assert len(loaded.vertices) > 8 * len(shape.bodies)
    assert [p.name for p in tmp_path.iterdir()] == [out.name]  # one file, buffers embedded


@pytest.mark.parametrize("name", PICTURED)
def test_show_writes_a_png(tmp_path: Path, name: str):
    out = draw(load_shape(SHAPES_DIR / f"{name}.toml"), tmp_path / "pictures" / f"{name}.png")
    data = out.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000
    assert [p.name for p in out.parent.iterdir()] == [out.name]


# --- the shapes commands --------------------------------------------------------------------------------------------


def test_list_shows_every_file(capsys):
    code, out, err = run_cli(capsys, "shapes", "list", str(SHAPES_DIR))
    assert code == 0 and not err
    lines = out.splitlines()
    assert lines[0].split() == ["name", "units", "bodies", "links", "description"]
    assert len(lines) == 1 + len(LIBRARY)
    rows = {line.split()[0]: line.split() for line in lines[1:]}
    assert rows["grid-3x3"][1:4] == ["9", "12", "17"]
    assert " ".join(rows["stack-2x2x2"][4:]) == load_shape(SHAPES_DIR / "stack-2x2x2.toml").description


def test_list_of_a_directory_with_a_bad_file(tmp_path: Path, capsys):
    write(tmp_path, CHAIN, "a.toml")
    write(tmp_path, '[assembly]\ngenerator = "ring"\n', "b.toml")
    code, out, err = run_cli(capsys, "shapes", "list", str(tmp_path))
    assert code == 2 and err.count("\n") == 1 and f"{tmp_path / 'b.toml'}: assembly.generator" in err
    code, _, err = run_cli(capsys, "shapes", "list", str(tmp_path / "nosuch"))
    assert code == 2 and "a directory of morphology files" in err


def test_check_prints_ok_lines(capsys):
    code, out, err = run_cli(capsys, "shapes", "check", *map(str, LIBRARY))
    assert code == 0 and not err
    lines = out.splitlines()
    assert len(lines) == len(LIBRARY) and all(line.startswith("OK ") for line in lines)
    assert "2 pieces (cut)" in next(line for line in lines if "chain-6-cut" in line)


def test_check_stops_at_the_first_bad_file(tmp_path: Path, capsys):
    bad = write(tmp_path, TWO + links_text((1, 3, 1)), "bad.toml")
    worse = write(tmp_path, "[assembly\n", "worse.toml")
    code, out, err = run_cli(capsys, "shapes", "check", str(SHAPES_DIR / "chain-2.toml"), str(bad), str(worse))
    assert code == 2
    assert out.startswith("OK ") and out.count("\n") == 1
    assert err == f"morphbench: error: {bad}: links[0].between: expected two [[units]] numbers in 1..2 " \
                  f"(1 is the first [[units]] table), got [1, 3]\n"


def test_export_and_show_commands(tmp_path: Path, capsys):
    source = str(SHAPES_DIR / "custom-irregular.toml")
    code, out, err = run_cli(capsys, "shapes", "export", source, "--out", str(tmp_path / "c.glb"))
    assert code == 0 and (tmp_path / "c.glb").is_file() and "custom-irregular" in out
    code, out, err = run_cli(capsys, "shapes", "show", source, "--png", str(tmp_path / "c.png"))
    assert code == 0 and (tmp_path / "c.png").read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize("argv, expected", [
    (["export", "{shape}", "--out", "{tmp}/x.stl"], "--out: {tmp}/x.stl: expected a file name ending in .glb, .gltf"),
    (["export", "{shape}", "--out", "{tmp}"], "expected a file name ending in"),
    (["show", "{shape}", "--png", "{tmp}/x.jpg"], "--png: {tmp}/x.jpg: expected a file name ending in .png"),
    (["export", "{tmp}/nosuch.toml", "--out", "{tmp}/x.glb"], "{tmp}/nosuch.toml: (file): expected an existing"),
    (["show", "{tmp}/nosuch.toml", "--png", "{tmp}/x.png"], "{tmp}/nosuch.toml: (file): expected an existing"),
])
def test_bad_command_input_exits_2_with_one_line(tmp_path: Path, capsys, argv, expected):
    argv = [a.format(shape=SHAPES_DIR / "chain-2.toml", tmp=tmp_path) for a in argv]
    code, out, err = run_cli(capsys, "shapes", *argv)
    assert code == 2 and err.count("\n") == 1
    assert expected.format(tmp=tmp_path) in err
    assert not any(p.suffix in (".stl", ".jpg", ".glb", ".png") for p in tmp_path.iterdir())


def test_bad_options_exit_2(capsys):
    with pytest.raises(SystemExit) as info:
        main(["shapes", "export", str(SHAPES_DIR / "chain-2.toml")])  # --out is required
    assert info.value.code == 2
    assert "--out" in capsys.readouterr().err


def test_commands_plug_into_another_parser(tmp_path: Path, capsys):
    parser = argparse.ArgumentParser(prog="morphbench")
    sub = parser.add_subparsers(dest="command", required=True)
    add_shapes_commands(sub)
    args = parser.parse_args(["shapes", "check", str(SHAPES_DIR / "grid-2x2.toml")])
    assert args.command == "shapes" and args.func(args) == 0
    assert capsys.readouterr().out.startswith("OK ")
    args = parser.parse_args(["shapes", "check", str(write(tmp_path, '[assembly]\ngenerator = "ring"\n'))])
    with pytest.raises(ConfigError, match="assembly.generator"):
        args.func(args)


def test_default_directory_is_the_library(monkeypatch, tmp_path: Path, capsys):
    monkeypatch.chdir(tmp_path)  # no ./shapes here: the shipped library
    code, out, _ = run_cli(capsys, "shapes", "list")
    assert code == 0 and len(out.splitlines()) == 1 + len(LIBRARY)
    (tmp_path / "shapes").mkdir()
    write(tmp_path / "shapes", CHAIN, "mine.toml")
    code, out, _ = run_cli(capsys, "shapes", "list")
    assert code == 0 and out.splitlines()[1].split()[0] == "mine"
