"""A body's geometry as a mesh (trimesh) and its mass properties; the checks of a body's ``mesh`` spec.

A body's geometry (``Body.mesh``) is
- ``''`` or ``'box'``: a box of the body's ``size``;
- a primitive name, ``'capsule'``, ``'cylinder'`` (both with their axis along the body's x, its forward axis) or
  ``'sphere'``, scaled to fill the body's ``size`` (so a 'sphere' of a 60 x 40 x 30 mm unit is an ellipsoid);
- a mesh file (``.obj``, ``.stl``, ``.ply``, ``.glb``/``.gltf``; a closed surface), scaled to the same bounding box.
``body_mesh`` returns it in the body's own frame: scaled to ``size``, then shifted so its centre of mass is at the
origin (the body's ``position``, the point PyBullet reports as the body's position). For a box and the primitives the
centre of mass is the centre of the box; for a mesh file it may be off by ``mass_properties(...).center_of_mass``.
None of this needs a simulator; ``morphbench.physics.geometry`` makes PyBullet shapes of the same meshes.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from morphbench.failures import describe
from morphbench.files import is_file
from morphbench.lazy import import_keeping_interrupts
from morphbench.shapes.model import Body

PRIMITIVES = ("box", "capsule", "cylinder", "sphere")
"""Names of the built-in geometries ('' is a box too)."""
MESH_SUFFIXES = (".obj", ".stl", ".ply", ".glb", ".gltf")
"""Mesh files a body's ``mesh`` may name."""


def is_primitive(mesh: str) -> bool:
    return mesh in ("",) + PRIMITIVES


def check_mesh(mesh: str, base: str | Path = ".") -> str:
    """The mesh spec as a body stores it: a primitive name as is, a file path resolved against ``base`` (the
    directory of the morphology file). Raises ValueError (with what was expected) for an unknown primitive, a file
    with another suffix, a missing or unreadable file, or a mesh that is not a closed surface."""
    if is_primitive(mesh):
        return mesh
    path = Path(mesh)
    if path.suffix.lower() not in MESH_SUFFIXES:
        raise ValueError(f"'' (a box), one of {', '.join(PRIMITIVES)} or a mesh file ({', '.join(MESH_SUFFIXES)})")
    if not path.is_absolute():
        path = Path(base) / path
    if not is_file(path):
        raise ValueError(f"an existing mesh file (relative paths start at the morphology file's directory: {path})")
    _unit_mesh(str(path))  # raises ValueError if it is not a closed surface
    return str(path)


@functools.lru_cache(maxsize=64)
def _unit_mesh(mesh: str):
    """The geometry in a unit cube centred on the origin (not yet scaled to a body), cached."""
    trimesh = import_keeping_interrupts("trimesh")

    if mesh in ("", "box"):
        return trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    if mesh == "sphere":
        base = trimesh.creation.icosphere(subdivisions=3)
    elif mesh == "capsule":
        base = trimesh.creation.capsule(height=1.0, radius=0.5, count=[32, 16])
    elif mesh == "cylinder":
        base = trimesh.creation.cylinder(radius=0.5, height=1.0, sections=32)
    else:
        try:
            base = trimesh.load(mesh, force="mesh")
        except Exception as exc:  # trimesh raises many types for a bad file
            raise ValueError(f"a readable mesh file ({describe(exc, where=False)})") from None
        if not isinstance(base, trimesh.Trimesh) or len(base.faces) == 0:
            raise ValueError("a mesh file with at least one triangle")
        if not base.is_volume:
            raise ValueError("a closed (watertight, consistently wound) mesh: its volume and inertia must be defined")
    if mesh in ("capsule", "cylinder"):  # trimesh builds them along z; a unit's long axis is x
        base.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0.0, 1.0, 0.0]))
    return _fit(base, (1.0, 1.0, 1.0))


def _fit(mesh, size):
    """A copy scaled (per axis) so its bounding box is ``size``, centred on the origin."""
    mesh = mesh.copy()
    lo, hi = mesh.bounds
    extent = np.where(hi - lo > 0, hi - lo, 1.0)
    mesh.apply_translation(-(lo + hi) / 2)
    scale = np.asarray(size, dtype=float) / extent
    if not np.allclose(scale, 1.0):
        mesh.apply_transform(np.diag([*scale, 1.0]))
    return mesh


@dataclass(frozen=True)
class MassProperties:
    """A body's mass properties from its mesh (trimesh), at the body's mass and uniform density."""

    center_of_mass: tuple[float, float, float]
    """m, offset of the centre of mass from the centre of the body's bounding box (zero for symmetric geometry)."""
    inertia: np.ndarray
    """kg m^2, 3 x 3 inertia tensor about the centre of mass, in the body's axes."""
    volume: float
    """m^3."""

    @property
    def inertia_diagonal(self) -> tuple[float, float, float]:
        """kg m^2, the tensor's diagonal (PyBullet's localInertiaDiagonal; exact for geometry symmetric about the
        body's axes, which is every primitive; the products of inertia of an asymmetric mesh are left out)."""
        return tuple(float(v) for v in np.diag(self.inertia))


def mass_properties(body: Body) -> MassProperties:
    """Centre of mass and inertia of the body's geometry scaled to its size, at its mass (uniform density)."""
    return _mass_properties(body.mesh, tuple(body.size), float(body.mass))


@functools.lru_cache(maxsize=256)
def _mass_properties(mesh_spec: str, size: tuple[float, float, float], mass: float) -> MassProperties:
    mesh = _fit(_unit_mesh(mesh_spec), size)
    volume = float(mesh.volume)
    mesh.density = mass / volume
    inertia = np.array(mesh.moment_inertia, dtype=float)
    inertia.flags.writeable = False  # shared by every caller (cached)
    return MassProperties(center_of_mass=tuple(float(v) for v in mesh.center_mass), inertia=inertia, volume=volume)


def body_mesh(body: Body):
    """The body's geometry (a ``trimesh.Trimesh``) in its own frame: scaled to ``size``, centre of mass at the
    origin."""
    mesh = _fit(_unit_mesh(body.mesh), body.size)
    if not is_primitive(body.mesh):
        mesh.apply_translation(-np.asarray(mesh.center_mass))
    return mesh
