"""What an assembly is, as plain data: bodies at rest positions and the links between them.

No simulator here: the physics package builds a world from a ``Shape``; transforms and checks work on it directly.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from morphbench.params import ActuatorParams


@dataclass(frozen=True, kw_only=True)
class Body:
    """One rigid body of the assembly: an active unit or a passive dummy."""

    position: tuple[float, float, float]
    """m, centre of the body at rest, in the assembly frame (x forward, z up, the ground at z = 0)."""
    size: tuple[float, float, float]
    """m, box extents along x (forward), y, z."""
    mass: float
    """kg."""
    friction: float
    """Coulomb coefficient against the ground."""
    dummy: bool
    """True for a passive body: no actuator, no pump, no learner."""
    mesh: str = ""
    """'' for a box of ``size``; otherwise the body's geometry: a mesh file path or a trimesh primitive
    (morphbench.physics.geometry), scaled to fit ``size``."""


@dataclass(frozen=True, kw_only=True)
class Link:
    """A connection between two neighbouring bodies along the line joining their centres: a bellows driven by a
    unit's pump, or a passive spacer (``unit`` None) that holds its rest length.

    The link keeps the two bodies aligned (no relative rotation, no sideways offset) and leaves its own axis free
    for the bellows to extend; its axis points from ``rear`` to ``front``.
    """

    front: int
    """index into ``Shape.bodies`` of the body the bellows pushes along +axis."""
    rear: int
    """index into ``Shape.bodies`` of the body the bellows pushes along -axis."""
    unit: int | None
    """index into ``Shape.bodies`` of the active unit whose pump drives this bellows; None for a passive link."""
    stroke: float | None = None
    """m, this bellows' extension at full pressure with no load, when its unit overrides the shape's
    ``actuator.stroke`` (a per-unit ``stroke`` in a custom morphology file); None takes ``actuator.stroke``."""


@dataclass(frozen=True, kw_only=True)
class Shape:
    """A whole assembly, validated: what a morphology file describes."""

    name: str
    """short name, by default the file's stem."""
    source: str
    """where it was loaded from (a path), for messages."""
    bodies: tuple[Body, ...]
    links: tuple[Link, ...]
    actuator: ActuatorParams
    description: str = ""
    heading: tuple[float, float, float] = (1.0, 0.0, 0.0)
    """unit vector in the assembly frame: the direction the assembly is scored along (every unit's forward axis is
    its own body x axis, which at rest is the assembly's x axis)."""
    yaw: float = 0.0
    """rad, how the assembly is turned about the vertical through its frame's origin when it is placed on the
    ground (counter-clockwise seen from above): bodies, links and heading keep their assembly-frame values and every
    world places them turned by ``yaw``, the bodies' own axes with them."""

    @functools.cached_property  # read in every learning step; a frozen Shape never changes it
    def units(self) -> tuple[int, ...]:
        """Body indices of the active units, in unit order (unit 1 first): the units that run a learner."""
        return tuple(i for i, body in enumerate(self.bodies) if not body.dummy)

    @property
    def n_units(self) -> int:
        """Number of active units."""
        return len(self.units)

    @property
    def rotation(self) -> np.ndarray:
        """(3, 3) the turn by ``yaw`` from the assembly frame to the ground's frame."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    @property
    def orientation(self) -> tuple[float, float, float, float]:
        """Every body's orientation at rest on the ground: the quaternion (x, y, z, w) of the turn by ``yaw``."""
        return (0.0, 0.0, math.sin(self.yaw / 2), math.cos(self.yaw / 2))

    def placed_positions(self) -> np.ndarray:
        """(n_bodies, 3) m, the bodies' centres at rest on the ground (the assembly frame turned by ``yaw``)."""
        return np.array([body.position for body in self.bodies], dtype=float).reshape(-1, 3) @ self.rotation.T
