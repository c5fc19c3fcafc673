"""Transforms of a ``Shape``: pure functions that return new shapes (the input is never changed).

- ``shuffle(shape, seed)``: the active units trade places by a seeded permutation. A unit is its body (mass,
  friction, mesh) with its pump, its bellows' stroke and its learner, so *unit k* after a shuffle is still the k-th
  unit of the original shape (the same learner, the same records column), now at another place; the places, the
  dummies and the links (by place) stay where they were, and each bellows is driven by whichever unit now sits where
  its driver sat. Unit 1 is therefore no longer necessarily at the front. The permutation is the one a run's shuffle
  event with the same seed draws (``morphbench.experiment.run``): unit ``order[p]`` moves to the place of unit p.
- ``cut(shape, link=..., plane=...)``: remove links and return the connected pieces, each a shape of its own.
- ``cut_apart(shape, ...)``: the same cut as one shape (bodies where they were, the cut links gone, so the pieces are
  no longer joined) and its pieces: what a morphology file's ``[transform] cut`` loads as.
- ``rotate(shape, degrees)``: the same assembly placed on the ground turned about the vertical (``Shape.yaw``).

Links are named here by their 0-based index into ``shape.links`` (as ``World.cut``); morphology files and run events
number them from 1.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable

import numpy as np

from morphbench.shapes.checks import components
from morphbench.shapes.model import Link, Shape
from morphbench.streams import SHUFFLE_STREAM

PLANES = ("x", "y", "z")


def shuffle_order(n_units: int, seed: int) -> np.ndarray:
    """``order[p]``: the unit (0-based, unit order) that moves to the place of unit p."""
    return np.random.default_rng(np.random.SeedSequence([seed, SHUFFLE_STREAM])).permutation(n_units)


def shuffle(shape: Shape, seed: int) -> Shape:
    """The shape with its active units moved by a seeded permutation (module docstring); every unit exactly once."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    units = shape.units
    order = shuffle_order(len(units), int(seed))
    moved = {units[p]: units[order[p]] for p in range(len(units))}  # the body now at body b's old place
    bodies = list(shape.bodies)
    for old, new in moved.items():
        bodies[new] = dataclasses.replace(shape.bodies[new], position=shape.bodies[old].position)
    stroke = {link.unit: link.stroke for link in shape.links if link.unit is not None}

    def at(b: int) -> int:
        return moved.get(b, b)

    links = []
    for link in shape.links:
        driver = None if link.unit is None else at(link.unit)
        links.append(Link(front=at(link.front), rear=at(link.rear), unit=driver,
                          stroke=None if driver is None else stroke.get(driver)))
    return dataclasses.replace(shape, bodies=tuple(bodies), links=tuple(links))


def rotate(shape: Shape, degrees: float) -> Shape:
    """The shape placed turned by ``degrees`` more about the vertical, counter-clockwise seen from above; its
    bodies, links and heading are unchanged in its own frame."""
    if not math.isfinite(degrees):
        raise ValueError(f"degrees must be finite, got {degrees!r}")
    return dataclasses.replace(shape, yaw=shape.yaw + math.radians(degrees))


def crossing_links(shape: Shape, plane: str, at: float) -> list[int]:
    """Indices of the links whose two bodies lie on opposite sides of the plane ``plane = at`` (m, assembly frame).

    Raises ValueError for an unknown plane or a plane through a body's centre (which side would it be on?)."""
    if plane not in PLANES:
        raise ValueError(f"plane must be one of x, y, z, got {plane!r}")
    axis = PLANES.index(plane)
    side = np.array([body.position[axis] for body in shape.bodies]) - float(at)
    on_plane = np.flatnonzero(np.abs(side) < 1e-9)
    if on_plane.size:
        raise ValueError(f"the plane {plane} = {at:g} passes through the centre of body {int(on_plane[0])}")
    side = np.sign(side)  # the sides alone: a product of two distances of 1e300 m overflows
    return [i for i, link in enumerate(shape.links) if side[link.front] * side[link.rear] < 0]


def _cut_indices(shape: Shape, link, plane, at) -> list[int]:
    if (link is None) == (plane is None):
        raise ValueError("give either link (one index or several) or plane (and at)")
    if plane is not None:
        if isinstance(plane, tuple):
            if at is not None:
                raise ValueError("give the plane as ('x', at) or as plane='x', at=..., not both")
            plane, at = plane
        if at is None:
            raise ValueError("a plane cut needs at (m)")
        cut = crossing_links(shape, plane, at)
        if not cut:
            raise ValueError(f"the plane {plane} = {at:g} cuts no link")
        return cut
    indices = [link] if isinstance(link, (int, np.integer)) else list(link)
    for i in indices:
        if isinstance(i, bool) or not isinstance(i, (int, np.integer)) or not 0 <= i < len(shape.links):
            raise ValueError(f"link must be an index into shape.links (0..{len(shape.links) - 1}), got {i!r}")
    if len(set(indices)) != len(indices) or not indices:
        raise ValueError(f"links to cut must be distinct and at least one, got {indices!r}")
    return sorted(int(i) for i in indices)


def remove_links(shape: Shape, indices: Iterable[int]) -> Shape:
    """The shape without the given links (0-based indices), the others in their order; bodies unchanged."""
    gone = set(indices)
    return dataclasses.replace(shape, links=tuple(link for i, link in enumerate(shape.links) if i not in gone))


def pieces(shape: Shape) -> list[Shape]:
    """The connected pieces of a shape, each a shape of its own: bodies in their order and where they were, links
    renumbered; the piece holding body 0 first. Piece k (from 1) is named ``NAME-pieceK``."""
    groups = components(shape)
    if len(groups) == 1:
        return [shape]
    out = []
    for k, group in enumerate(groups, start=1):
        new = {old: i for i, old in enumerate(group)}
        links = tuple(
            dataclasses.replace(link, front=new[link.front], rear=new[link.rear],
                                unit=None if link.unit is None else new[link.unit])
            for link in shape.links if link.front in new
        )
        out.append(dataclasses.replace(
            shape, name=f"{shape.name}-piece{k}", bodies=tuple(shape.bodies[i] for i in group), links=links,
            description=f"piece {k} of {len(groups)} of {shape.name}"
                        + (f": {shape.description}" if shape.description else ""),
        ))
    return out


def cut_apart(shape: Shape, link: int | Iterable[int] | None = None, plane: str | tuple[str, float] | None = None,
              at: float | None = None) -> tuple[Shape, list[Shape]]:
    """Cut links (``link``: an index or several into ``shape.links``) or every link crossing a plane (``plane`` one
    of 'x', 'y', 'z' and ``at`` in m, or ``plane=('x', at)``); return the cut shape as one (the links gone, bodies
    where they were) and its connected pieces. ValueError for a bad link, a plane through a body centre or one that
    cuts nothing."""
    whole = remove_links(shape, _cut_indices(shape, link, plane, at))
    return whole, pieces(whole)


def cut(shape: Shape, link: int | Iterable[int] | None = None, plane: str | tuple[str, float] | None = None,
        at: float | None = None) -> list[Shape]:
    """The connected pieces left by a cut (``cut_apart``): each unit and each body in exactly one piece."""
    return cut_apart(shape, link, plane, at)[1]
