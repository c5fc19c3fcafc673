"""Structural checks of a ``Shape`` (pure data, no simulator): what every assembly must satisfy to be built.

``check_shape`` raises ``ConfigError`` (source = the shape's source) for
- a link to a body that does not exist, a body linked to itself, or the same two bodies linked twice (``links[i]``);
- a link whose bodies are not lattice neighbours: their centres must be apart along exactly one axis, by the
  bodies' extent plus ``actuator.rest_gap``, with ``front`` at the larger coordinate (``links[i]``);
- a link driven by a body that is not one of its two, or by a dummy (``links[i].unit``);
- two bodies that overlap (``bodies[i]``);
- a heading that is not a unit vector (``heading``);
- a disconnected assembly (``links``), unless ``allow_disconnected`` (a shape cut on purpose).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from morphbench.errors import ConfigError
from morphbench.shapes.model import Shape

TOLERANCE = 1e-9
"""m, how far positions may be off the lattice (rounding)."""


def components(shape: Shape) -> list[list[int]]:
    """Connected groups of body indices over the shape's links, each sorted, the group holding body 0 first (the
    order of ``World.pieces``)."""
    return connected_groups(len(shape.bodies), [(link.front, link.rear) for link in shape.links])


def connected_groups(n: int, pairs) -> list[list[int]]:
    """Connected groups of the nodes 0..n-1 over the given (a, b) pairs, each sorted, sorted by their first node."""
    parent = list(range(n))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for a, b in pairs:
        parent[root(a)] = root(b)
    groups: dict[int, list[int]] = {}
    for node in range(n):
        groups.setdefault(root(node), []).append(node)
    return sorted(groups.values())


def is_connected(shape: Shape) -> bool:
    """True when every body is joined to every other through links (a shape of one body is connected)."""
    return len(components(shape)) <= 1


def check_shape(shape: Shape, *, allow_disconnected: bool = False,
                body_label: Callable[[int], str] = lambda i: f"body {i}") -> Shape:
    """Raise ConfigError if the shape cannot be built as a lattice assembly (module docstring); return it if it can.

    ``body_label(i)`` names body i in messages (the loader names the ``[[units]]`` tables of a custom file).
    """
    source, n = shape.source, len(shape.bodies)
    heading = np.asarray(shape.heading, dtype=float)
    if heading.shape != (3,) or not np.all(np.isfinite(heading)) or abs(np.linalg.norm(heading) - 1) > 1e-6:
        raise ConfigError(source, "heading", "a unit vector [x, y, z]", shape.heading)
    seen: dict[frozenset, int] = {}
    gap = shape.actuator.rest_gap
    for i, link in enumerate(shape.links):
        key = f"links[{i}]"
        if not (0 <= link.front < n and 0 <= link.rear < n):
            raise ConfigError(source, key, f"two body indices in 0..{n - 1}", (link.front, link.rear))
        if link.front == link.rear:
            raise ConfigError(source, key, "two different bodies", (link.front, link.rear))
        pair = frozenset((link.front, link.rear))
        if pair in seen:
            raise ConfigError(source, key, f"a pair of bodies not already linked (links[{seen[pair]}])",
                              (link.front, link.rear))
        seen[pair] = i
        front, rear = shape.bodies[link.front], shape.bodies[link.rear]
        d = np.subtract(front.position, rear.position)
        axis = int(np.argmax(np.abs(d)))
        pitch = (front.size[axis] + rear.size[axis]) / 2 + gap
        others = np.delete(np.abs(d), axis)
        if np.any(others > TOLERANCE) or abs(d[axis] - pitch) > TOLERANCE * max(1.0, pitch):
            raise ConfigError(
                source, key,
                f"lattice neighbours: the front centre {pitch:g} m ahead of the rear one along exactly one axis "
                f"({body_label(link.front)} is at {_fmt(front.position)}, {body_label(link.rear)} at "
                f"{_fmt(rear.position)})", (link.front, link.rear))
        if link.unit is not None:
            if link.unit not in (link.front, link.rear):
                raise ConfigError(source, f"{key}.unit", f"one of the link's two bodies ({body_label(link.front)} or "
                                  f"{body_label(link.rear)}), or None for a passive link", link.unit)
            if shape.bodies[link.unit].dummy:
                raise ConfigError(source, f"{key}.unit", f"an active unit: {body_label(link.unit)} is a dummy",
                                  link.unit)
        if link.stroke is not None and (link.unit is None or not np.isfinite(link.stroke) or link.stroke <= 0):
            raise ConfigError(source, f"{key}.stroke", "a stroke > 0 on an actuated link, or None", link.stroke)
    _check_overlaps(shape, body_label)
    if not allow_disconnected:
        groups = components(shape)
        if len(groups) > 1:
            stray = [body for group in groups[1:] for body in group]
            listed = ", ".join(body_label(b) for b in stray[:6]) + (", ..." if len(stray) > 6 else "")
            raise ConfigError(source, "links", f"a connected assembly, every body joined to {body_label(0)} through "
                              f"links (not joined: {listed})")
    return shape


def _check_overlaps(shape: Shape, body_label: Callable[[int], str]) -> None:
    """The first body j (then the first i < j) whose box overlaps another's: boxes overlap when apart by less than
    their half-sizes along every axis. Only bodies in the same or neighbouring cells of a grid as coarse as the
    largest body can overlap, so each body is compared with the few in its 27 cells (a 100,000-body sheet in a
    second, where every pair would take hours)."""
    if len(shape.bodies) < 2:
        return
    centres = np.array([b.position for b in shape.bodies])
    half = np.array([b.size for b in shape.bodies]) / 2
    width = np.maximum(2 * half.max(axis=0), TOLERANCE)
    cells = np.floor((centres - centres.min(axis=0)) / width).astype(np.int64) + 1
    span = cells.max(axis=0) + 2
    keys = (cells[:, 0] * span[1] + cells[:, 1]) * span[2] + cells[:, 2]
    order = np.argsort(keys, kind="stable")
    ordered = keys[order]
    first = None
    for offset in np.array(np.meshgrid([-1, 0, 1], [-1, 0, 1], [-1, 0, 1])).reshape(3, -1).T:
        target = ((cells[:, 0] + offset[0]) * span[1] + cells[:, 1] + offset[1]) * span[2] + cells[:, 2] + offset[2]
        start, end = np.searchsorted(ordered, target, "left"), np.searchsorted(ordered, target, "right")
        counts = end - start
        j = np.repeat(np.arange(len(centres)), counts)
        i = order[np.repeat(start - np.cumsum(counts) + counts, counts) + np.arange(counts.sum())]
        keep = i < j
        i, j = i[keep], j[keep]
        hits = np.all(np.abs(centres[i] - centres[j]) - (half[i] + half[j]) < -TOLERANCE, axis=1)
        if hits.any():
            pair = min(zip(j[hits].tolist(), i[hits].tolist()))
            first = pair if first is None else min(first, pair)
    if first is not None:
        j, i = first
        raise ConfigError(shape.source, f"bodies[{j}]", f"a place of its own: it overlaps {body_label(i)} "
                          f"(centres {_fmt(centres[i])} and {_fmt(centres[j])})", body_label(j))


def _fmt(position) -> str:
    return "(" + ", ".join(f"{float(v):.4g}" for v in position) + ")"
