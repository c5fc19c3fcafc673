"""A shape as a 3-D scene (trimesh): one mesh per body (units, dummies in different colours) and one thin cylinder
per link (actuated bellows and passive links in different colours), written as .glb, .gltf, .obj or .ply.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from morphbench.files import write_bytes
from morphbench.lazy import import_keeping_interrupts
from morphbench.shapes.colours import BELLOWS_RGBA, DUMMY_RGBA, PASSIVE_RGBA, UNIT_RGBA
from morphbench.shapes.meshes import body_mesh
from morphbench.shapes.model import Shape

# Re-exported for the modules that import them from here (shapes.loader, shapes.cli, physics.geometry).
from morphbench.shapes.drawing import draw  # noqa: E402
from morphbench.shapes.meshes import PRIMITIVES, check_mesh, mass_properties  # noqa: E402

__all__ = ["DUMMY_RGBA", "PRIMITIVES", "SCENE_SUFFIXES", "UNIT_RGBA", "body_mesh", "body_names", "check_mesh", "draw",
           "export_scene", "link_segment", "mass_properties", "scene"]

SCENE_SUFFIXES = (".glb", ".gltf", ".obj", ".ply")
"""What ``export_scene`` writes."""


def _rgba8(rgba) -> np.ndarray:
    return np.round(np.asarray(rgba) * 255).astype(np.uint8)


def _coloured(mesh, rgba):
    trimesh = import_keeping_interrupts("trimesh")

    mesh.visual = trimesh.visual.ColorVisuals(mesh, vertex_colors=np.tile(_rgba8(rgba), (len(mesh.vertices), 1)))
    return mesh


def body_names(shape: Shape) -> list[str]:
    """Each body's name in exported scenes: ``unit-K`` (K the unit number, from 1) or ``dummy-J`` (J from 1)."""
    names, n_units, n_dummies = [], 0, 0
    for body in shape.bodies:
        if body.dummy:
            n_dummies += 1
            names.append(f"dummy-{n_dummies}")
        else:
            n_units += 1
            names.append(f"unit-{n_units}")
    return names


def link_segment(shape: Shape, index: int) -> tuple[np.ndarray, np.ndarray]:
    """The gap a link spans: from the rear body's face to the front body's face along the line joining their
    centres (the centres themselves if the bodies touch)."""
    link = shape.links[index]
    front, rear = shape.bodies[link.front], shape.bodies[link.rear]
    a, b = np.asarray(rear.position, dtype=float), np.asarray(front.position, dtype=float)
    d = b - a
    length = float(np.linalg.norm(d))
    axis = d / length
    inset_rear = float(np.abs(axis) @ np.asarray(rear.size)) / 2
    inset_front = float(np.abs(axis) @ np.asarray(front.size)) / 2
    if length - inset_rear - inset_front < 1e-6:
        return a, b
    return a + axis * inset_rear, b - axis * inset_front


def scene(shape: Shape):
    """A ``trimesh.Scene``: one mesh per body (named by ``body_names``) and one cylinder per link (``bellows-I`` for
    an actuated link, ``link-I`` for a passive one, I its 1-based number), in the assembly frame."""
    trimesh = import_keeping_interrupts("trimesh")

    out = trimesh.Scene()
    for name, body in zip(body_names(shape), shape.bodies):
        mesh = body_mesh(body)
        mesh.apply_translation(body.position)
        out.add_geometry(_coloured(mesh, DUMMY_RGBA if body.dummy else UNIT_RGBA), node_name=name, geom_name=name)
    thickness = min(min(b.size[1:]) for b in shape.bodies) if shape.bodies else 0.0
    for i, link in enumerate(shape.links):
        start, end = link_segment(shape, i)
        actuated = link.unit is not None
        radius = thickness * (0.2 if actuated else 0.08)
        cylinder = trimesh.creation.cylinder(radius=radius, segment=np.array([start, end]), sections=16)
        name = f"{'bellows' if actuated else 'link'}-{i + 1}"
        out.add_geometry(_coloured(cylinder, BELLOWS_RGBA if actuated else PASSIVE_RGBA), node_name=name,
                         geom_name=name)
    out.metadata["name"] = shape.name
    out.metadata["description"] = shape.description
    return out


def export_scene(shape: Shape, path: str | Path) -> Path:
    """Write ``scene(shape)`` to ``path``: .glb or .gltf (one mesh per body and link, buffers embedded), .obj or .ply
    (one merged mesh with vertex colours). The file is written under a temporary name and renamed."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in SCENE_SUFFIXES:
        raise ValueError(f"a file name ending in {', '.join(SCENE_SUFFIXES)}")
    s = scene(shape)
    if suffix == ".gltf":
        data = s.export(file_type="gltf", embed_buffers=True)["model.gltf"]
    else:
        data = s.export(file_type=suffix[1:])
    return write_bytes(path, data.encode("utf-8") if isinstance(data, str) else data)
