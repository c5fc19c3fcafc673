"""Body geometry: PyBullet shapes of boxes, primitives and mesh files, and their mass properties from trimesh."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pybullet as pb
import pytest
import trimesh

from morphbench.physics.geometry import BodyShapes, body_shapes, mesh_file
from morphbench.shapes.meshes import PRIMITIVES, body_mesh, check_mesh, mass_properties
from morphbench.shapes.model import Body

SIZE = (0.06, 0.04, 0.03)
MASS = 0.05


def body(mesh: str = "", size=SIZE, mass=MASS, dummy=False) -> Body:
    return Body(position=(0.0, 0.0, size[2] / 2), size=size, mass=mass, friction=0.5, dummy=dummy, mesh=mesh)


@pytest.fixture
def client():
    c = pb.connect(pb.DIRECT)
    pb.setGravity(0, 0, -9.81, physicsClientId=c)
    plane = pb.createCollisionShape(pb.GEOM_PLANE, physicsClientId=c)
    pb.createMultiBody(0, plane, physicsClientId=c)
    yield c
    pb.disconnect(c)


def build(client: int, b: Body) -> tuple[int, BodyShapes]:
    shapes = body_shapes(client, b)
    uid = pb.createMultiBody(b.mass, shapes.collision, shapes.visual, basePosition=b.position, physicsClientId=client)
    pb.changeDynamics(uid, -1, localInertiaDiagonal=shapes.inertia, physicsClientId=client)
    return uid, shapes


def settle(client: int, uid: int, seconds: float = 1.0):
    for _ in range(round(seconds * 240)):
        pb.stepSimulation(physicsClientId=client)
    return pb.getBasePositionAndOrientation(uid, physicsClientId=client)


def box_inertia(mass, size):
    a, b, c = size
    return (mass / 12 * (b * b + c * c), mass / 12 * (a * a + c * c), mass / 12 * (a * a + b * b))


def closed_mesh_file(directory: Path, suffix: str) -> Path:
    """An asymmetric closed mesh (a cone lying along x, its tip at +x) in a file."""
    cone = trimesh.creation.cone(radius=1.0, height=3.0, sections=24)
    cone.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, [0, 1, 0]))
    path = directory / f"cone{suffix}"
    cone.export(path)
    return path


# --- mass properties ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("mesh", ["", "box"])
def test_box_inertia_matches_the_analytic_formula(mesh: str):
    props = mass_properties(body(mesh))
    assert props.inertia_diagonal == pytest.approx(box_inertia(MASS, SIZE), rel=1e-9)
    assert props.center_of_mass == pytest.approx((0, 0, 0), abs=1e-12)
    assert props.volume == pytest.approx(np.prod(SIZE), rel=1e-9)
    assert np.allclose(props.inertia, np.diag(props.inertia_diagonal), atol=1e-15)


def test_inertia_scales_with_mass_and_size():
    small, heavy = mass_properties(body("capsule")), mass_properties(body("capsule", mass=2 * MASS))
    assert np.allclose(heavy.inertia, 2 * small.inertia)
    big = mass_properties(body("capsule", size=tuple(2 * s for s in SIZE)))
    assert np.allclose(big.inertia, 4 * small.inertia)  # same mass, lengths doubled


def test_sphere_is_the_ellipsoid_filling_the_box():
    props = mass_properties(body("sphere"))
    a, b, c = (s / 2 for s in SIZE)
    assert props.volume == pytest.approx(4 / 3 * math.pi * a * b * c, rel=0.02)  # an icosphere, slightly inside
    expected = (MASS / 5 * (b * b + c * c), MASS / 5 * (a * a + c * c), MASS / 5 * (a * a + b * b))
    assert props.inertia_diagonal == pytest.approx(expected, rel=0.03)


def test_cylinder_axis_runs_along_x():
    props = mass_properties(body("cylinder", size=(0.06, 0.04, 0.04)))
    r, length = 0.02, 0.06
    assert props.volume == pytest.approx(math.pi * r * r * length, rel=0.01)
    axial, transverse = MASS * r * r / 2, MASS * (3 * r * r + length * length) / 12
    assert props.inertia_diagonal == pytest.approx((axial, transverse, transverse), rel=0.02)


@pytest.mark.parametrize("mesh", PRIMITIVES)
def test_primitives_fill_the_body_box_centred(mesh: str):
    m = body_mesh(body(mesh))
    assert np.allclose(m.extents, SIZE)
    assert np.allclose(m.bounds.mean(axis=0), 0.0, atol=1e-12)
    assert m.is_volume
    assert np.allclose(mass_properties(body(mesh)).center_of_mass, 0.0, atol=1e-12)


def test_mesh_file_is_scaled_to_the_body_and_centred_on_its_centre_of_mass(tmp_path: Path):
    path = check_mesh(str(closed_mesh_file(tmp_path, ".stl")))
    b = body(path)
    m = body_mesh(b)
    assert np.allclose(m.extents, SIZE)
    assert np.allclose(m.center_mass, 0.0, atol=1e-12)
    props = mass_properties(b)
    # a cone's centre of mass is a quarter of its height from the base: the tip is at +x, so the centre is behind
    assert props.center_of_mass[0] == pytest.approx(-SIZE[0] / 4, rel=1e-3)
    assert props.volume == pytest.approx(math.pi * SIZE[1] / 2 * SIZE[2] / 2 * SIZE[0] / 3, rel=0.02)


# --- PyBullet shapes in a real DIRECT client ------------------------------------------------------------------------


def test_box_in_pybullet(client: int):
    uid, shapes = build(client, body())
    assert shapes.inertia == pytest.approx(box_inertia(MASS, SIZE))
    mass, _, inertia = pb.getDynamicsInfo(uid, -1, physicsClientId=client)[:3]
    assert mass == pytest.approx(MASS)
    assert inertia == pytest.approx(box_inertia(MASS, SIZE), rel=1e-6)
    lo, hi = pb.getAABB(uid, physicsClientId=client)
    assert np.subtract(hi, lo) == pytest.approx(SIZE, abs=2e-3)  # Bullet pads AABBs a little
    (x, y, z), orientation = settle(client, uid)
    assert z == pytest.approx(SIZE[2] / 2, abs=1e-3)
    assert abs(x) < 1e-4 and abs(y) < 1e-4


@pytest.mark.parametrize("mesh", ["capsule", "cylinder", "sphere"])
def test_primitive_in_pybullet(client: int, mesh: str):
    b = body(mesh)
    uid, shapes = build(client, b)
    info = pb.getDynamicsInfo(uid, -1, physicsClientId=client)
    assert info[2] == pytest.approx(mass_properties(b).inertia_diagonal, rel=1e-6)
    visual = pb.getVisualShapeData(uid, physicsClientId=client)
    assert visual and visual[0][2] == pb.GEOM_MESH
    collision = pb.getCollisionShapeData(uid, -1, physicsClientId=client)
    assert collision[0][2] == pb.GEOM_MESH
    (_, _, z), orientation = settle(client, uid)
    # resting on its lowest point, give or take Bullet's collision margin around a convex hull
    assert z == pytest.approx(SIZE[2] / 2, abs=2.5e-3)
    assert np.allclose(orientation, (0, 0, 0, 1), atol=0.05)  # it lies flat along x and does not roll


@pytest.mark.parametrize("suffix", [".obj", ".stl", ".ply", ".glb"])
def test_mesh_file_in_pybullet(client: int, tmp_path: Path, suffix: str):
    b = body(check_mesh(str(closed_mesh_file(tmp_path, suffix))))
    uid, shapes = build(client, b)
    assert shapes.center_of_mass[0] == pytest.approx(-SIZE[0] / 4, rel=1e-3)
    lo, hi = pb.getAABB(uid, physicsClientId=client)
    padding = np.subtract(hi, lo) - SIZE  # Bullet pads a mesh's box by its collision margin, the same on every axis
    assert np.all(padding >= 0) and np.all(padding < 5e-3) and np.ptp(padding) < 1e-6
    assert pb.getDynamicsInfo(uid, -1, physicsClientId=client)[2] == pytest.approx(shapes.inertia, rel=1e-6)


def test_dummy_colour_and_given_colour(client: int):
    unit, dummy = body_shapes(client, body()), body_shapes(client, body(dummy=True))
    red = body_shapes(client, body("capsule"), rgba=(1.0, 0.0, 0.0, 1.0))
    colours = []
    for shapes, b in ((unit, body()), (dummy, body(dummy=True)), (red, body("capsule"))):
        uid = pb.createMultiBody(b.mass, shapes.collision, shapes.visual, basePosition=(0, 0, 1),
                                 physicsClientId=client)
        colours.append(tuple(pb.getVisualShapeData(uid, physicsClientId=client)[0][7]))
    assert colours[0] != colours[1]
    assert colours[2] == pytest.approx((1.0, 0.0, 0.0, 1.0))


def test_mesh_files_are_written_once(tmp_path: Path):
    a, b = mesh_file(body("capsule")), mesh_file(body("capsule", dummy=True))
    assert a == b and a.is_file() and a.suffix == ".obj"
    assert mesh_file(body("sphere")) != a
    assert trimesh.load(a, force="mesh").extents == pytest.approx(SIZE, rel=1e-6)


def test_unpacks_as_a_tuple(client: int):
    collision, visual, inertia, centre = body_shapes(client, body())
    assert collision >= 0 and visual >= 0 and len(inertia) == 3 and len(centre) == 3


@pytest.mark.parametrize("spec, expected", [
    ("cube", "a mesh file"), ("missing.obj", "an existing mesh file"), ("mesh.fbx", "a mesh file"),
])
def test_check_mesh_rejects(tmp_path: Path, spec: str, expected: str):
    with pytest.raises(ValueError, match=expected):
        check_mesh(spec, tmp_path)


def test_check_mesh_rejects_an_open_surface(tmp_path: Path):
    open_box = trimesh.creation.box()
    open_box.update_faces(np.arange(len(open_box.faces)) > 1)  # two triangles gone: a hole
    open_box.export(tmp_path / "open.stl")
    with pytest.raises(ValueError, match="closed"):
        check_mesh("open.stl", tmp_path)
    (tmp_path / "garbage.obj").write_text("not a mesh\n")
    with pytest.raises(ValueError, match="at least one triangle|readable"):
        check_mesh("garbage.obj", tmp_path)
