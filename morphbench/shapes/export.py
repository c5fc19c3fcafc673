"""A shape's geometry as meshes (trimesh), exported as a 3-D scene or drawn as an off-screen picture (matplotlib).

A body's geometry (``Body.mesh``) is
- ``''`` or ``'box'``: a box of the body's ``size``;
- a primitive name, ``'capsule'``, ``'cylinder'`` (both with their axis along the body's x, its forward axis) or
  ``'sphere'``, scaled to fill the body's ``size`` (so a 'sphere' of a 60 x 40 x 30 mm unit is an ellipsoid);
- a mesh file (``.obj``, ``.stl``, ``.ply``, ``.glb``/``.gltf``; a closed surface), scaled to the same bounding box.
``body_mesh`` returns it in the body's own frame: scaled to ``size``, then shifted so its centre of mass is at the
origin (the body's ``position``, the point PyBullet reports as the body's position). For a box and the primitives the
centre of mass is the centre of the box; for a mesh file it may be off by ``mass_properties(...).center_of_mass``.

``scene`` / ``export_scene`` build and write one mesh per body (units, dummies in different colours) and one thin
cylinder per link (actuated bellows and passive links in different colours); ``draw`` writes a top view and a side
view to a PNG. None of this needs a simulator; ``morphbench.physics.geometry`` makes PyBullet shapes of the same meshes.
"""

from __future__ import annotations

import functools
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from morphbench.shapes.model import Body, Shape

PRIMITIVES = ("box", "capsule", "cylinder", "sphere")
"""Names of the built-in geometries ('' is a box too)."""
MESH_SUFFIXES = (".obj", ".stl", ".ply", ".glb", ".gltf")
"""Mesh files a body's ``mesh`` may name."""
SCENE_SUFFIXES = (".glb", ".gltf", ".obj", ".ply")
"""What ``export_scene`` writes."""

UNIT_RGBA = (0.20, 0.45, 0.80, 1.0)
"""Active units (the colour of ``morphbench.physics.world``)."""
DUMMY_RGBA = (0.55, 0.55, 0.55, 1.0)
"""Dummies."""
BELLOWS_RGBA = (0.95, 0.50, 0.10, 1.0)
"""Actuated links: a unit's bellows."""
PASSIVE_RGBA = (0.15, 0.60, 0.30, 1.0)
"""Passive links."""


# --- one body's mesh ------------------------------------------------------------------------------------------------


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
    if not path.is_file():
        raise ValueError(f"an existing mesh file (relative paths start at the morphology file's directory: {path})")
    _unit_mesh(str(path))  # raises ValueError if it is not a closed surface
    return str(path)


@functools.lru_cache(maxsize=64)
def _unit_mesh(mesh: str):
    """The geometry in a unit cube centred on the origin (not yet scaled to a body), cached."""
    import trimesh

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
            raise ValueError(f"a readable mesh file ({type(exc).__name__}: {exc})") from None
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


# --- the whole shape ------------------------------------------------------------------------------------------------


def _rgba8(rgba) -> np.ndarray:
    return np.round(np.asarray(rgba) * 255).astype(np.uint8)


def _coloured(mesh, rgba):
    import trimesh

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
    import trimesh

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
    _write_atomic(path, data.encode("utf-8") if isinstance(data, str) else data)
    return path


def _write_atomic(path: Path, data: bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def draw(shape: Shape, path: str | Path, dpi: int = 120) -> Path:
    """An off-screen picture (PNG) of the shape at rest: a top view (x forward to the right, y up the page) and a
    side view (x to the right, z up), units numbered, dummies marked D, actuated and passive links in their colours,
    the heading as an arrow, with a legend."""
    from matplotlib.figure import Figure  # no pyplot: no global backend, nothing left open
    from matplotlib.lines import Line2D
    from matplotlib.patches import FancyBboxPatch, Patch

    path = Path(path)
    centres = np.array([b.position for b in shape.bodies], dtype=float)
    sizes = np.array([b.size for b in shape.bodies], dtype=float)
    lo, hi = (centres - sizes / 2).min(axis=0), (centres + sizes / 2).max(axis=0)
    lo[2] = min(lo[2], 0.0)
    span = np.maximum(hi - lo, 1e-3)
    pad = 0.1 * span + 0.015  # m around the bodies, per axis
    extent = span + 2 * pad
    width = 9.0
    heights = [max(1.2, width * extent[1] / extent[0]), max(1.0, width * extent[2] / extent[0])]
    scale = min(1.0, 10.0 / sum(heights))
    fig = Figure(figsize=(width * scale, sum(heights) * scale + 1.6))
    top, side = fig.subplots(2, 1, gridspec_kw={"height_ratios": heights})
    labels, n = [], 0
    for body in shape.bodies:
        n += not body.dummy
        labels.append("D" if body.dummy else str(n))
    views = ((top, (0, 1), 2, "top view (x forward, y left)"), (side, (0, 2), 1, "side view (x forward, z up)"))
    for ax, (u, v), depth, title in views:
        # Bodies from the farthest to the nearest (lowest first from above, leftmost first from the side), then links
        # over them, then one label per place (bodies one behind the other share it: "1/5", nearest last).
        near = centres[:, depth] if depth == 2 else -centres[:, depth]
        order = np.argsort(near, kind="stable")
        places: dict[tuple[float, float], list[int]] = {}
        for i in order:
            body = shape.bodies[i]
            (cx, cy), (w, h) = centres[i, [u, v]], sizes[i, [u, v]]
            rounding = 0.0 if body.mesh in ("", "box") else 0.45 * min(w, h)
            colour = DUMMY_RGBA if body.dummy else UNIT_RGBA
            ax.add_patch(FancyBboxPatch((cx - w / 2 + rounding, cy - h / 2 + rounding), w - 2 * rounding,
                                        h - 2 * rounding, boxstyle=f"round,pad={rounding}", facecolor=colour[:3],
                                        alpha=0.85, edgecolor="black", linewidth=0.6, zorder=1))
            places.setdefault((round(cx, 9), round(cy, 9)), []).append(i)
        for link in shape.links:
            a, b = centres[link.rear, [u, v]], centres[link.front, [u, v]]
            actuated = link.unit is not None
            ax.plot([a[0], b[0]], [a[1], b[1]], color=(BELLOWS_RGBA if actuated else PASSIVE_RGBA)[:3],
                    linewidth=3.0 if actuated else 1.6, linestyle="-" if actuated else "--", zorder=2,
                    solid_capstyle="round")
        for (cx, cy), bodies in places.items():
            nearest = shape.bodies[bodies[-1]]
            ax.text(cx, cy, "/".join(labels[i] for i in bodies), ha="center", va="center", fontsize=7,
                    color="white", weight="bold", zorder=3,
                    bbox={"boxstyle": "round,pad=0.15", "facecolor": (DUMMY_RGBA if nearest.dummy else UNIT_RGBA)[:3],
                          "edgecolor": "none"})
        ax.set_xlim(lo[u] - pad[u], hi[u] + pad[u])
        ax.set_ylim((-0.004 if v == 2 else lo[v] - pad[v]), hi[v] + pad[v])
        ax.set_aspect("equal")
        ax.set_title(title, fontsize=9)
        ax.set_xlabel(f"{'xyz'[u]} (m)", fontsize=8)
        ax.set_ylabel(f"{'xyz'[v]} (m)", fontsize=8)
        ax.tick_params(labelsize=7)
    side.axhline(0.0, color="saddlebrown", linewidth=1.5, zorder=0)
    heading = np.asarray(shape.heading, dtype=float)
    if np.linalg.norm(heading[:2]) > 1e-9:
        arrow = heading[:2] / np.linalg.norm(heading[:2]) * 0.8 * min(pad[0], pad[1])
        start = np.array([hi[0] + 0.5 * pad[0], hi[1] + 0.5 * pad[1]]) - arrow / 2
        top.annotate("", xy=start + arrow, xytext=start, arrowprops={"arrowstyle": "->", "color": "black"})
        top.text(*(start + arrow / 2), "heading", fontsize=7, ha="center", va="bottom")
    handles = [Patch(color=UNIT_RGBA[:3], label="unit (unit number)"), Patch(color=DUMMY_RGBA[:3], label="dummy (D)"),
               Line2D([], [], color=BELLOWS_RGBA[:3], linewidth=3.0, label="bellows (actuated link)"),
               Line2D([], [], color=PASSIVE_RGBA[:3], linewidth=1.6, linestyle="--", label="passive link")]
    fig.legend(handles=handles, loc="lower center", ncol=4, fontsize=8, frameon=False)
    summary = f"{shape.name}: {shape.n_units} units, {len(shape.bodies)} bodies, {len(shape.links)} links"
    fig.suptitle(summary + (f"\n{shape.description}" if shape.description else ""), fontsize=9)
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp.png")
    try:
        fig.savefig(tmp, dpi=dpi, format="png")
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path
