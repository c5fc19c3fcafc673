"""The morphology loader: shipped files, defaults, and a ConfigError naming file, key and expectation for bad input."""

from __future__ import annotations

import dataclasses
import datetime
import math
import os
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from morphbench.errors import ConfigError
from morphbench.params import ActuatorParams, DummyParams, UnitParams
from morphbench.readers import params_from_table
from morphbench.rules import rule_of
from morphbench.shapes import Shape, load_shape, shape_from_table
from morphbench.shapes.loader import MAX_UNITS

from conftest import SHAPES_DIR, assert_config_error, write
from fuzzing import dump_toml

# the plain chains; the rest: test_shapes_library.py
SHIPPED = sorted(p for p in SHAPES_DIR.glob("chain-*.toml") if p.stem.removeprefix("chain-").isdigit())
ASSEMBLY = '[assembly]\ngenerator = "chain"\nunits = 2\n'


# --- the shipped files --------------------------------------------------------------------------------------------


def test_shapes_are_shipped():
    assert {p.name for p in SHIPPED} >= {"chain-2.toml", "chain-3.toml", "chain-7.toml", "chain-20.toml"}


@pytest.mark.parametrize("path", SHIPPED, ids=[p.name for p in SHIPPED])
def test_shipped_shape_loads(path: Path):
    assembly = tomllib.loads(path.read_text(encoding="utf-8"))["assembly"]
    n_units, has_dummy = assembly["units"], assembly.get("dummy", True)
    shape = load_shape(path)
    assert isinstance(shape, Shape)
    assert shape.name == path.stem
    assert shape.source == str(path)
    assert shape.description
    assert shape.n_units == n_units
    assert len(shape.bodies) == n_units + has_dummy
    assert len(shape.links) == (n_units if has_dummy else n_units - 1)
    if path.stem.startswith("chain-"):  # the file name says how many active units it has
        assert shape.n_units == int(path.stem.removeprefix("chain-"))
    # a straight chain along x, unit 1 at the front, the dummy (if any) at the rear, one bellows between neighbours
    xs = [body.position[0] for body in shape.bodies]
    assert xs == sorted(xs, reverse=True)
    assert [body.dummy for body in shape.bodies] == [False] * n_units + [True] * has_dummy
    assert [(link.front, link.rear, link.unit) for link in shape.links] == [
        (i, i + 1, i) for i in range(len(shape.links))]


@pytest.mark.parametrize("name, n_units", [("chain-2", 2), ("chain-3", 3), ("chain-7", 7), ("chain-20", 20)])
def test_shipped_chain_counts(name: str, n_units: int):
    shape = load_shape(SHAPES_DIR / f"{name}.toml")
    assert (shape.n_units, len(shape.bodies), len(shape.links)) == (n_units, n_units + 1, n_units)


# --- defaults and overrides ---------------------------------------------------------------------------------------


def test_left_out_tables_take_the_defaults_of_params(tmp_path: Path):
    shape = load_shape(write(tmp_path, ASSEMBLY, "minimal.toml"))
    unit, dummy = UnitParams(), DummyParams()
    assert shape.name == "minimal"
    assert shape.description == ""
    assert shape.actuator == ActuatorParams()
    assert len(shape.bodies) == 3  # dummy defaults to true
    for body in shape.bodies[:2]:
        assert (body.size, body.mass, body.friction) == (
            (unit.length, unit.width, unit.height), unit.mass, unit.friction)
    assert (shape.bodies[2].mass, shape.bodies[2].friction, shape.bodies[2].dummy) == (dummy.mass, dummy.friction, True)
    pitch = unit.length + ActuatorParams().rest_gap
    assert [b.position for b in shape.bodies] == [(-i * pitch, 0.0, unit.height / 2) for i in range(3)]


def test_given_values_override_the_defaults(tmp_path: Path):
    text = (
        'name = "custom"\ndescription = "non-ASCII is fine: µm, café"\n' + ASSEMBLY + "dummy = false\n"
        "[unit]\nmass = 0.2\nlength = 1\n[dummy]\nfriction = 0.0\n[actuator]\nstroke = 0.02\nalpha = 0.75\n"
    )
    shape = load_shape(write(tmp_path, text))
    assert shape.name == "custom"
    assert shape.description == "non-ASCII is fine: µm, café"
    assert shape.actuator == ActuatorParams(stroke=0.02, alpha=0.75)
    assert len(shape.bodies) == 2 and not any(b.dummy for b in shape.bodies)
    assert len(shape.links) == 1  # the last unit has no body behind it
    for body in shape.bodies:
        assert body.mass == 0.2
        assert body.friction == UnitParams().friction
        assert body.size == (1.0, UnitParams().width, UnitParams().height)
        assert type(body.size[0]) is float  # an integer in the file becomes a float


def test_dummy_table_sets_the_dummy_body_only(tmp_path: Path):
    shape = load_shape(write(tmp_path, ASSEMBLY + "[dummy]\nmass = 0.5\nfriction = 0.0\n"))
    assert [b.mass for b in shape.bodies] == [UnitParams().mass, UnitParams().mass, 0.5]
    assert [b.friction for b in shape.bodies] == [UnitParams().friction, UnitParams().friction, 0.0]


@pytest.mark.parametrize("cls", [UnitParams, DummyParams, ActuatorParams])
def test_params_from_table(cls):
    assert params_from_table(cls, {}, "src", "section") == cls()
    first = dataclasses.fields(cls)[0]
    half = first.default / 2  # in range for the first field of each
    assert params_from_table(cls, {first.name: half}, "src", "section") == cls(**{first.name: half})
    with pytest.raises(ConfigError, match=r"^src: section\.bogus: expected one of the known keys"):
        params_from_table(cls, {"bogus": 1.0}, "src", "section")


def test_shape_from_table_names_its_source():
    table = tomllib.loads(ASSEMBLY)
    assert shape_from_table(table, source="mem").n_units == 2
    assert shape_from_table(table, source="mem").name == "shape"
    with pytest.raises(ConfigError, match=r"^mem: assembly\.units: expected an integer"):
        shape_from_table({"assembly": {"generator": "chain", "units": 0}}, source="mem")


def test_utf8_file_loads_whatever_the_locale(tmp_path: Path):
    """TOML is UTF-8: the loader must not decode with the locale's encoding (here ASCII)."""
    path = write(tmp_path, 'description = "µm café"\n' + ASSEMBLY)
    env = {**os.environ, "LC_ALL": "C", "LANG": "C", "PYTHONUTF8": "0", "PYTHONCOERCECLOCALE": "0"}
    code = "import sys; from morphbench.shapes import load_shape; print(ascii(load_shape(sys.argv[1]).description))"
    result = subprocess.run([sys.executable, "-c", code, str(path)], env=env, capture_output=True, text=True,
                            timeout=60)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == ascii("µm café")


def test_crlf_line_endings_load(tmp_path: Path):
    assert load_shape(write(tmp_path, ASSEMBLY.replace("\n", "\r\n"))).n_units == 2


# --- bad files: ConfigError naming the file, the dotted key and what was expected ----------------------------------

BAD = [
    # unknown keys
    ("unknown-top-level", 'colour = "red"\n' + ASSEMBLY, "colour", "one of the known keys"),
    ("unknown-unit", ASSEMBLY + "[unit]\ncolour = 1\n", "unit.colour", "one of the known keys"),
    ("unknown-dummy", ASSEMBLY + "[dummy]\nlength = 0.1\n", "dummy.length", "one of the known keys friction, mass"),
    ("unknown-actuator", ASSEMBLY + "[actuator]\npressure = 1.0\n", "actuator.pressure", "one of the known keys"),
    ("unknown-assembly", ASSEMBLY + "count = 2\n", "assembly.count", "one of the known keys dummy, generator, units"),
    ("unknown-nested-table", ASSEMBLY + "[unit.extra]\na = 1\n", "unit.extra", "one of the known keys"),
    # wrong types
    ("string-for-number", ASSEMBLY + '[unit]\nmass = "heavy"\n', "unit.mass", "a number in"),
    ("bool-for-number", ASSEMBLY + "[actuator]\nstroke = true\n", "actuator.stroke", "a number in"),
    ("array-for-number", ASSEMBLY + "[dummy]\nmass = [1, 2]\n", "dummy.mass", "a number in"),
    ("date-for-number", ASSEMBLY + "[actuator]\ncycle_time = 1979-05-27\n", "actuator.cycle_time", "a number in"),
    ("number-for-bool", ASSEMBLY + "dummy = 1\n", "assembly.dummy", "true or false"),
    ("string-for-bool", ASSEMBLY + 'dummy = "yes"\n', "assembly.dummy", "true or false"),
    ("number-for-name", "name = 3\n" + ASSEMBLY, "name", "a string"),
    ("bool-for-description", "description = false\n" + ASSEMBLY, "description", "a string"),
    ("number-for-table", "unit = 3\n" + ASSEMBLY, "unit", "a table of UnitParams fields"),
    ("array-of-tables", ASSEMBLY + "[[actuator]]\nstroke = 0.01\n", "actuator", "a table of ActuatorParams fields"),
    ("number-for-assembly", "assembly = 3\n", "assembly", "a table"),
    # out of range
    ("negative-mass", ASSEMBLY + "[unit]\nmass = -0.05\n", "unit.mass", "a number in [0.001, 10] (kg)"),
    ("zero-dummy-mass", ASSEMBLY + "[dummy]\nmass = 0\n", "dummy.mass", "a number in [0.001, 10] (kg)"),
    ("zero-stroke", ASSEMBLY + "[actuator]\nstroke = 0.0\n", "actuator.stroke", "a number in [0.0001, 0.1] (m)"),
    ("negative-friction", ASSEMBLY + "[unit]\nfriction = -0.1\n", "unit.friction", "a number in [0, 10]"),
    ("alpha-0", ASSEMBLY + "[actuator]\nalpha = 0\n", "actuator.alpha", "a number in [0.01, 0.99]"),
    ("alpha-1", ASSEMBLY + "[actuator]\nalpha = 1.0\n", "actuator.alpha", "a number in [0.01, 0.99]"),
    ("nan", ASSEMBLY + "[unit]\nlength = nan\n", "unit.length", "a number in"),
    ("alpha-nan", ASSEMBLY + "[actuator]\nalpha = nan\n", "actuator.alpha", "a number in [0.01, 0.99]"),
    ("inf", ASSEMBLY + "[actuator]\ncycle_time = inf\n", "actuator.cycle_time", "a number in"),
    ("minus-inf", ASSEMBLY + "[dummy]\nfriction = -inf\n", "dummy.friction", "a number in"),
    ("plus-inf", ASSEMBLY + "[actuator]\nmax_force = +inf\n", "actuator.max_force", "a number in"),
    # the assembly
    ("missing-assembly", 'description = "no assembly"\n[unit]\nmass = 0.1\n', "assembly", "an [assembly] table"),
    ("unknown-generator", '[assembly]\ngenerator = "ring"\nunits = 2\n', "assembly.generator", "one of chain"),
    ("missing-generator", "[assembly]\nunits = 2\n", "assembly.generator", "one of chain"),
    ("units-0", '[assembly]\ngenerator = "chain"\nunits = 0\n', "assembly.units", f"[1, {MAX_UNITS}]"),
    ("units-100001", '[assembly]\ngenerator = "chain"\nunits = 100001\n', "assembly.units",
     f"[1, {MAX_UNITS}] (a larger assembly takes over 4 CPU s per simulated second, a 300-step run over 80 minutes)"),
    ("units-2.5", '[assembly]\ngenerator = "chain"\nunits = 2.5\n', "assembly.units", "an integer number"),
    ("units-2.0", '[assembly]\ngenerator = "chain"\nunits = 2.0\n', "assembly.units", "an integer number"),
    ("units-true", '[assembly]\ngenerator = "chain"\nunits = true\n', "assembly.units", "an integer number"),
    ("units-string", '[assembly]\ngenerator = "chain"\nunits = "2"\n', "assembly.units", "an integer number"),
    ("missing-units", '[assembly]\ngenerator = "chain"\n', "assembly.units", "an integer number"),
    ("single-unit-no-dummy", '[assembly]\ngenerator = "chain"\nunits = 1\ndummy = false\n', "assembly.dummy", "true"),
    # not TOML
    ("syntax", "[assembly\ngenerator = chain\n", "(syntax)", "valid TOML"),
    ("duplicate-key", ASSEMBLY + "units = 3\n", "(syntax)", "valid TOML"),
    ("empty-file", "", "assembly", "an [assembly] table"),
]


@pytest.mark.parametrize("text, key, expected", [case[1:] for case in BAD], ids=[case[0] for case in BAD])
def test_bad_file(tmp_path: Path, text: str, key: str, expected: str):
    error = assert_config_error(write(tmp_path, text), key, expected)
    if error.got is not ...:
        assert str(error).endswith(f", got {error.got!r}")  # and says what it found


def test_values_are_echoed(tmp_path: Path):
    error = assert_config_error(write(tmp_path, ASSEMBLY + "[unit]\nmass = -0.05\n"), "unit.mass", "[0.001, 10]")
    assert str(error).endswith("got -0.05")


def test_missing_file(tmp_path: Path):
    assert_config_error(tmp_path / "nosuch.toml", "(file)", "an existing morphology file")


def test_directory_given_as_the_file(tmp_path: Path):
    directory = tmp_path / "shape.toml"
    directory.mkdir()
    assert_config_error(directory, "(file)", "a readable UTF-8 TOML file")


def test_non_utf8_bytes(tmp_path: Path):
    path = write(tmp_path, b'description = "caf\xe9 \xff"\n' + ASSEMBLY.encode())
    assert_config_error(path, "(file)", "a readable UTF-8 TOML file")


def test_path_may_be_a_string(tmp_path: Path):
    path = write(tmp_path, ASSEMBLY)
    assert load_shape(str(path)).source == str(path)
    assert_config_error(write(tmp_path, "[assembly]\n", "bad.toml"), "assembly.generator", "one of chain")


# --- property-based: random valid tables load exactly; mutated ones give ConfigError -------------------------------

SECTIONS = {"unit": UnitParams, "dummy": DummyParams, "actuator": ActuatorParams}
TOP_KEYS = {"name", "description", "assembly", *SECTIONS}
ASSEMBLY_KEYS = {"generator", "units", "dummy"}

FAST = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def _valid_number(cls, key: str):
    """Any number the field's own rule (morphbench.params) accepts."""
    rule = rule_of(cls, key)[0]
    return st.floats(rule.low, rule.high, exclude_min=not rule.low_inclusive, exclude_max=not rule.high_inclusive)


def _section(cls):
    return st.fixed_dictionaries({}, optional={f.name: _valid_number(cls, f.name) for f in dataclasses.fields(cls)})


text = st.text(st.characters(blacklist_categories=("Cs",)), max_size=12)


@st.composite
def valid_tables(draw) -> dict:
    units = draw(st.integers(1, 30) | st.just(200))
    assembly = {"generator": "chain", "units": units}
    dummy = draw(st.none() | st.booleans())
    if dummy is not None and (units > 1 or dummy):
        assembly["dummy"] = dummy
    table = draw(st.fixed_dictionaries({}, optional={"name": text, "description": text}))
    for section, cls in SECTIONS.items():
        values = draw(st.none() | _section(cls))
        if values is not None:
            table[section] = values
    table["assembly"] = assembly
    return table


@FAST
@given(table=valid_tables())
def test_random_valid_tables_load_with_exactly_their_values(table: dict):
    with tempfile.TemporaryDirectory() as directory:
        path = Path(directory) / "random.toml"
        path.write_text(dump_toml(table), encoding="utf-8")
        shape = load_shape(path)
    params = {s: cls(**{k: float(v) for k, v in table.get(s, {}).items()}) for s, cls in SECTIONS.items()}
    unit, dummy = params["unit"], params["dummy"]
    n_units, has_dummy = table["assembly"]["units"], table["assembly"].get("dummy", True)
    assert shape.name == table.get("name", "random")
    assert shape.description == table.get("description", "")
    assert shape.actuator == params["actuator"]
    assert shape.n_units == n_units
    assert len(shape.bodies) == n_units + has_dummy
    assert len(shape.links) == (n_units if has_dummy else n_units - 1)
    for body in shape.bodies:
        assert body.size == (unit.length, unit.width, unit.height)
        expected = dummy if body.dummy else unit
        assert (body.mass, body.friction) == (expected.mass, expected.friction)
        assert all(type(v) is float for v in (body.mass, body.friction, *body.size))


datetimes = st.sampled_from(
    [datetime.date(1979, 5, 27), datetime.time(7, 32), datetime.datetime(1979, 5, 27, 7, 32),
     datetime.datetime(1979, 5, 27, 7, 32, tzinfo=datetime.timezone.utc)]
)
ints = st.integers(-(2**63), 2**63 - 1)
floats = st.floats(allow_nan=True, allow_infinity=True)
lists = st.lists(st.integers(-5, 5) | text, max_size=3)
dicts = st.dictionaries(text, st.integers(-5, 5), max_size=2)
any_value = st.booleans() | ints | floats | text | lists | dicts | datetimes

WRONG_TYPE = {
    "number": st.booleans() | text | lists | dicts | datetimes,
    "units": st.booleans() | floats | text | lists | dicts | datetimes,
    "bool": ints | floats | text | lists | dicts | datetimes,
    "str": st.booleans() | ints | floats | lists | dicts | datetimes,
    "generator": st.booleans() | ints | floats | text.filter(lambda s: s != "chain") | lists | dicts | datetimes,
    "section": st.booleans() | ints | floats | text | lists | datetimes,
}
NUMBER_FIELDS = [(s, f.name) for s, cls in SECTIONS.items() for f in dataclasses.fields(cls)]
TYPED_FIELDS = [*((f"{s}.{k}", "number") for s, k in NUMBER_FIELDS),
                ("name", "str"), ("description", "str"),
                ("assembly.generator", "generator"), ("assembly.units", "units"), ("assembly.dummy", "bool"),
                *((s, "section") for s in SECTIONS)]


def _out_of_range(cls, key: str):
    """NaN, an infinity or a number just outside either end of the field's rule."""
    rule = rule_of(cls, key)[0]
    return (st.just(math.nan) | st.just(math.inf) | st.just(-math.inf)
            | st.floats(max_value=rule.low, exclude_max=rule.low_inclusive)
            | st.floats(min_value=rule.high, exclude_min=rule.high_inclusive))


def _set(table: dict, dotted: str, value) -> None:
    if "." in dotted:
        section, key = dotted.split(".")
        table.setdefault(section, {})[key] = value
    else:
        table[dotted] = value


@st.composite
def malformed_tables(draw) -> tuple[dict, str]:
    """A valid table with exactly one mistake, and the dotted key the error must name."""
    table = draw(valid_tables())
    mistake = draw(st.sampled_from(["unknown key", "wrong type", "out of range", "bad units"]))
    if mistake == "unknown key":
        where = draw(st.sampled_from(["", "assembly", *SECTIONS]))
        allowed = TOP_KEYS if not where else ASSEMBLY_KEYS if where == "assembly" else {
            f.name for f in dataclasses.fields(SECTIONS[where])}
        key = draw(text.filter(lambda k: k not in allowed))
        dotted = f"{where}.{key}" if where else key
        if where:
            table.setdefault(where, {})[key] = draw(any_value)
        else:
            table[key] = draw(any_value)
        return table, dotted
    if mistake == "wrong type":
        dotted, kind = draw(st.sampled_from(TYPED_FIELDS))
        _set(table, dotted, draw(WRONG_TYPE[kind]))
        return table, dotted
    if mistake == "out of range":
        section, key = draw(st.sampled_from(NUMBER_FIELDS))
        _set(table, f"{section}.{key}", draw(_out_of_range(SECTIONS[section], key)))
        return table, f"{section}.{key}"
    _set(table, "assembly.units",
         draw(st.integers(max_value=0) | st.integers(min_value=MAX_UNITS + 1, max_value=2**63 - 1)))
    return table, "assembly.units"


@FAST
@given(case=malformed_tables())
def test_random_malformed_tables_raise_config_error(case: tuple[dict, str]):
    table, dotted = case
    with tempfile.TemporaryDirectory() as directory:
        path = Path(directory) / "malformed.toml"
        path.write_text(dump_toml(table), encoding="utf-8")
        with pytest.raises(ConfigError) as info:  # any other exception fails the test
            load_shape(path)
    message = str(info.value)
    assert str(path) in message
    assert info.value.key == dotted
    shown = dotted.replace("\r", "\\r").replace("\n", "\\n").replace("\0", "\\0")  # a message is one line, with no NUL
    assert f": {shown}: expected " in message


@FAST
@given(data=st.binary(max_size=200))
def test_random_bytes_raise_config_error_or_load(data: bytes):
    with tempfile.TemporaryDirectory() as directory:
        path = Path(directory) / "bytes.toml"
        path.write_bytes(data)
        try:
            load_shape(path)
        except ConfigError as error:
            assert str(path) in str(error)
