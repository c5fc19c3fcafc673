"""Transforms: shuffle and cut keep every unit exactly once; cut pieces are connected and disjoint; shuffles repeat."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from morphbench.errors import ConfigError
from morphbench.params import ActuatorParams, DummyParams, UnitParams
from morphbench.shapes import Shape, check_shape, components, cut, cut_apart, is_connected, pieces, shuffle
from morphbench.shapes.generators import chain, lattice
from morphbench.shapes.transforms import crossing_links, shuffle_order

FAST = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
UNIT, DUMMY, ACTUATOR = UnitParams(), DummyParams(), ActuatorParams()


def tagged(bodies, links, name="shape") -> Shape:
    """A shape whose bodies each have their own mass (and units their own stroke), so identities can be followed."""
    bodies = tuple(dataclasses.replace(b, mass=0.05 + 0.001 * i) for i, b in enumerate(bodies))
    links = tuple(dataclasses.replace(link, stroke=None if link.unit is None else 0.01 + 0.0001 * link.unit)
                  for link in links)
    return Shape(name=name, source=f"<{name}>", bodies=bodies, links=links, actuator=ACTUATOR)


@st.composite
def shapes(draw) -> Shape:
    kind = draw(st.sampled_from(["chain", "grid", "lattice"]))
    has_dummy = draw(st.booleans())
    if kind == "chain":
        n = draw(st.integers(1 if has_dummy else 2, 25))
        return tagged(*chain(n, has_dummy, UNIT, DUMMY, ACTUATOR), name=f"chain-{n}")
    layers = 1 if kind == "grid" else draw(st.integers(1, 3))
    rows, columns = draw(st.integers(1, 4)), draw(st.integers(1 if has_dummy else 2, 5))
    return tagged(*lattice(layers, rows, columns, has_dummy, UNIT, DUMMY, ACTUATOR), name=f"{kind}")


seeds = st.integers(0, 2**32 - 1)


def identity(body) -> float:
    return body.mass


def unit_ids(shape: Shape) -> list[float]:
    return [identity(shape.bodies[b]) for b in shape.units]


def positions(shape: Shape, which=None) -> list[tuple]:
    return sorted(shape.bodies[i].position for i in (range(len(shape.bodies)) if which is None else which))


def link_places(shape: Shape) -> set:
    """Each link by the places it joins and the place of the unit driving it."""
    place = [b.position for b in shape.bodies]
    return {(place[link.front], place[link.rear], None if link.unit is None else place[link.unit])
            for link in shape.links}


# --- shuffle --------------------------------------------------------------------------------------------------------


@FAST
@given(shape=shapes(), seed=seeds)
def test_shuffle_keeps_every_unit_exactly_once(shape: Shape, seed: int):
    out = shuffle(shape, seed)
    check_shape(out)
    assert out.n_units == shape.n_units
    assert unit_ids(out) == unit_ids(shape)  # unit k is still unit k: same body, so the same learner
    assert positions(out, out.units) == positions(shape, shape.units)  # each place taken by exactly one unit
    assert [b for b in out.bodies if b.dummy] == [b for b in shape.bodies if b.dummy]  # dummies stay put
    assert link_places(out) == link_places(shape)  # the same links at the same places, driven by whoever is there
    drivers = {link.unit for link in shape.links}
    for link in out.links:  # a unit's bellows keeps its own stroke (a unit that drove none had none: the default)
        if link.unit is not None:
            assert link.stroke == (0.01 + 0.0001 * link.unit if link.unit in drivers else None)


@FAST
@given(shape=shapes(), seed=seeds)
def test_shuffle_is_reproducible_and_is_the_run_events_permutation(shape: Shape, seed: int):
    assert shuffle(shape, seed) == shuffle(shape, seed)
    order, units = shuffle_order(shape.n_units, seed), shape.units
    out = shuffle(shape, seed)
    rng = np.random.default_rng(np.random.SeedSequence([seed, 4]))  # what experiment.run draws for a shuffle event
    assert np.array_equal(order, rng.permutation(shape.n_units))
    for p in range(shape.n_units):  # unit order[p] moved to where unit p was
        assert out.bodies[units[order[p]]].position == shape.bodies[units[p]].position


def test_shuffle_moves_units_for_most_seeds():
    shape = tagged(*chain(6, True, UNIT, DUMMY, ACTUATOR))
    moved = [shuffle(shape, seed).bodies != shape.bodies for seed in range(20)]
    assert sum(moved) >= 18
    assert shuffle(shape, 1) != shuffle(shape, 2)


@pytest.mark.parametrize("seed", [-1, 1.5, True, "3"])
def test_shuffle_rejects_bad_seeds(seed):
    with pytest.raises(ValueError, match="seed"):
        shuffle(tagged(*chain(3, True, UNIT, DUMMY, ACTUATOR)), seed)


# --- cut ------------------------------------------------------------------------------------------------------------


def assert_partition(shape: Shape, parts: list[Shape], n_cut: int) -> None:
    """Pieces: each connected, none sharing a body, together every body and every unit exactly once."""
    for part in parts:
        assert is_connected(part)
        check_shape(part)
    ids = sorted(identity(b) for part in parts for b in part.bodies)
    assert ids == sorted(identity(b) for b in shape.bodies)  # every body once: disjoint and complete
    assert sorted(u for part in parts for u in unit_ids(part)) == sorted(unit_ids(shape))
    assert sum(part.n_units for part in parts) == shape.n_units
    assert sum(len(part.links) for part in parts) == len(shape.links) - n_cut
    for part in parts:  # bodies where they were, unit order kept within a piece
        assert all(b in shape.bodies for b in part.bodies)
        assert unit_ids(part) == sorted(unit_ids(part))


@FAST
@given(shape=shapes(), data=st.data())
def test_cut_links_partitions_the_units(shape: Shape, data):
    assume(shape.links)
    chosen = data.draw(st.lists(st.integers(0, len(shape.links) - 1), min_size=1, max_size=len(shape.links),
                                unique=True))
    parts = cut(shape, link=chosen)
    assert_partition(shape, parts, len(chosen))
    whole, again = cut_apart(shape, link=chosen)
    assert again == parts
    assert whole.bodies == shape.bodies and len(whole.links) == len(shape.links) - len(chosen)
    assert len(components(whole)) == len(parts)
    check_shape(whole, allow_disconnected=True)
    if len(parts) > 1:
        with pytest.raises(ConfigError, match="links: expected a connected assembly"):
            check_shape(whole)


@FAST
@given(shape=shapes(), data=st.data())
def test_cut_by_plane_partitions_the_units(shape: Shape, data):
    axis = data.draw(st.sampled_from("xyz"))
    k = "xyz".index(axis)
    coordinates = sorted({b.position[k] for b in shape.bodies})
    assume(len(coordinates) >= 2)
    i = data.draw(st.integers(0, len(coordinates) - 2))
    at = (coordinates[i] + coordinates[i + 1]) / 2  # between two layers of sites
    crossing = crossing_links(shape, axis, at)
    parts = cut(shape, plane=axis, at=at)
    assert_partition(shape, parts, len(crossing))
    for part in parts:  # no piece straddles the plane
        sides = {b.position[k] > at for b in part.bodies}
        assert len(sides) == 1
    assert cut(shape, plane=(axis, at)) == parts


@FAST
@given(shape=shapes(), seed=seeds, data=st.data())
def test_shuffle_then_cut_keeps_every_unit_once(shape: Shape, seed: int, data):
    assume(shape.links)
    link = data.draw(st.integers(0, len(shape.links) - 1))
    parts = cut(shuffle(shape, seed), link=link)
    assert sorted(u for part in parts for u in unit_ids(part)) == sorted(unit_ids(shape))


def test_cut_a_chain_in_half():
    shape = tagged(*chain(6, True, UNIT, DUMMY, ACTUATOR), name="chain-6")
    front, rear = cut(shape, link=2)  # unit 3's bellows
    assert (front.n_units, len(front.bodies), len(front.links)) == (3, 3, 2)
    assert (rear.n_units, len(rear.bodies), len(rear.links)) == (3, 4, 3)
    assert (front.name, rear.name) == ("chain-6-piece1", "chain-6-piece2")
    assert cut(shape, plane="x", at=-0.175) == [front, rear]  # between x = -0.14 and -0.21
    assert pieces(shape) == [shape]


def test_a_cut_that_separates_nothing_leaves_one_piece():
    shape = tagged(*lattice(1, 2, 2, False, UNIT, DUMMY, ACTUATOR))  # a ring of four links
    (piece,) = cut(shape, link=0)
    assert len(piece.links) == 3 and piece.bodies == shape.bodies


@pytest.mark.parametrize("kwargs, message", [
    ({}, "either link"),
    ({"link": 0, "plane": "x", "at": 0.0}, "either link"),
    ({"link": 7}, "index into shape.links"),
    ({"link": -1}, "index into shape.links"),
    ({"link": [0, 0]}, "distinct"),
    ({"link": []}, "at least one"),
    ({"plane": "w", "at": 0.0}, "one of x, y, z"),
    ({"plane": "x"}, "needs at"),
    ({"plane": "x", "at": 0.0}, "passes through the centre of body 0"),
    ({"plane": "x", "at": 1.0}, "cuts no link"),
    ({"plane": "z", "at": 0.1}, "cuts no link"),
    ({"plane": ("x", -0.035), "at": 1.0}, "not both"),
])
def test_cut_rejects(kwargs, message):
    with pytest.raises(ValueError, match=message):
        cut(tagged(*chain(3, True, UNIT, DUMMY, ACTUATOR)), **kwargs)
