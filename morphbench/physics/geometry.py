"""PyBullet collision and visual shapes of one body, and its mass properties, from its ``Body.mesh``.

- ``''`` / ``'box'``: PyBullet's own box of the body's size.
- ``'capsule'``, ``'cylinder'``, ``'sphere'`` or a mesh file (.obj, .stl, .ply, .glb, .gltf): the trimesh geometry of
  ``morphbench.shapes.export.body_mesh`` (scaled to the body's size, centre of mass at the body's origin), written
  once per process to a temporary .obj and loaded as ``GEOM_MESH``. PyBullet collides a moving body with the convex
  hull of such a mesh.

The inertia comes from trimesh, from the same geometry at the body's mass (uniform density): PyBullet's own estimate
for a mesh is the inertia of its bounding box, so a caller sets ``localInertiaDiagonal`` from ``BodyShapes.inertia``
(``changeDynamics``) after ``createMultiBody``. The centre of mass is the body's origin, so the body's position in
PyBullet is ``Body.position`` at rest whatever the geometry.

Every call passes the caller's client id.
"""

from __future__ import annotations

import atexit
import functools
import hashlib
import os
import shutil
import tempfile
from pathlib import Path
from typing import NamedTuple

import pybullet as pb

from morphbench.shapes.export import DUMMY_RGBA, UNIT_RGBA, body_mesh, mass_properties
from morphbench.shapes.model import Body

_CACHE_DIR: Path | None = None


class BodyShapes(NamedTuple):
    """What ``body_shapes`` returns; unpacks as ``collision, visual, inertia, center_of_mass = body_shapes(...)``."""

    collision: int
    """PyBullet collision shape id."""
    visual: int
    """PyBullet visual shape id."""
    inertia: tuple[float, float, float]
    """kg m^2, the body's inertia diagonal about its centre of mass in its own axes (localInertiaDiagonal)."""
    center_of_mass: tuple[float, float, float]
    """m, where the centre of mass of the geometry lies from the centre of its bounding box (zero for a box and the
    primitives); the geometry is already shifted so that the centre of mass is the body's origin."""


def body_shapes(client: int, body: Body, rgba: tuple[float, float, float, float] | None = None) -> BodyShapes:
    """Collision and visual shapes of ``body`` in PyBullet client ``client`` (colour ``rgba``, by default the
    unit or dummy colour), with its inertia diagonal and centre-of-mass offset (module docstring)."""
    colour = list(rgba if rgba is not None else (DUMMY_RGBA if body.dummy else UNIT_RGBA))
    props = mass_properties(body)
    if body.mesh in ("", "box"):
        half = [s / 2 for s in body.size]
        collision = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=half, physicsClientId=client)
        visual = pb.createVisualShape(pb.GEOM_BOX, halfExtents=half, rgbaColor=colour, physicsClientId=client)
    else:
        path = str(mesh_file(body))
        collision = pb.createCollisionShape(pb.GEOM_MESH, fileName=path, meshScale=[1, 1, 1], physicsClientId=client)
        visual = pb.createVisualShape(pb.GEOM_MESH, fileName=path, meshScale=[1, 1, 1], rgbaColor=colour,
                                      physicsClientId=client)
    if collision < 0 or visual < 0:
        raise RuntimeError(f"PyBullet could not make a shape of mesh {body.mesh!r} (size {body.size})")
    return BodyShapes(collision, visual, props.inertia_diagonal, props.center_of_mass)


def mesh_file(body: Body) -> Path:
    """The .obj of the body's geometry in its own frame (``body_mesh``), written once per process and kept until the
    process exits (PyBullet may read a visual mesh again when it builds a body)."""
    return _mesh_file(body.mesh, tuple(body.size), _cache_dir())


@functools.lru_cache(maxsize=256)
def _mesh_file(mesh_spec: str, size: tuple[float, float, float], directory: Path) -> Path:
    body = Body(position=(0.0, 0.0, 0.0), size=size, mass=1.0, friction=0.0, dummy=False, mesh=mesh_spec)
    data = body_mesh(body).export(file_type="obj", include_normals=False, include_color=False, include_texture=False)
    data = data.encode("utf-8") if isinstance(data, str) else data
    path = directory / f"{hashlib.sha256(data).hexdigest()[:24]}.obj"
    if not path.exists():
        tmp = path.with_name(f"{path.stem}.{os.getpid()}.tmp")  # processes may write the same mesh at once
        tmp.write_bytes(data)
        tmp.replace(path)
    return path


def _cache_dir() -> Path:
    global _CACHE_DIR
    if _CACHE_DIR is None or not _CACHE_DIR.is_dir():
        _CACHE_DIR = Path(tempfile.mkdtemp(prefix="morphbench-meshes-"))
        atexit.register(shutil.rmtree, _CACHE_DIR, True)
    return _CACHE_DIR
