"""The planar solver's sparse path (physics/cholesky.py): the factorisation against numpy, the same motion as the
banded solver on every library shape in one layer, the plane's symmetries on a sheet above SPARSE_FROM (the limits
of a shape's size: tests/test_limits.py)."""

import numpy as np
import pytest

from morphbench.params import DEFAULT_PHYSICS, QUASISTATIC_PHYSICS
from morphbench.errors import ConfigError
from morphbench.physics import PlanarWorld, check_one_layer, cholesky, planar
from morphbench.shapes import load_shape, rotate

from conftest import SHAPES_DIR, sheet
from test_planar import mirrored

AGREE = 1e-9
"""m (and rad), how far the two solvers' poses may part over a run of 480 ticks: each tick's answer balances forces
to FORCE_TOLERANCE (1e-10 N), which moves a body by at most about 1e-12 m against the softest spring (100 N/m)."""
TIE = 1e-7
"""m, the same for a shape with a piece whose bodies' frictions tie (chains cut into a piece of 2 or 3 bodies): the
energy is flat along that piece's common slide, so answers meeting the same force tolerance part by more (2e-8 m
over 480 ticks; the other library shapes within 1e-9)."""


def block_system(points, front, rear, seed):
    """A random symmetric positive definite matrix with the links' block pattern (dense), and its blocks stored in
    the factor's pattern."""
    rng = np.random.default_rng(seed)
    n = len(points)
    dense = np.zeros((3 * n, 3 * n))
    for f, r in zip(front, rear):
        block = rng.normal(size=(3, 3))
        dense[3 * f:3 * f + 3, 3 * r:3 * r + 3] += block
        dense[3 * r:3 * r + 3, 3 * f:3 * f + 3] += block.T
    dense += np.kron(np.eye(n), np.eye(3)) * (np.abs(dense).sum(axis=1).max() + 1)  # diagonally dominant
    pattern = cholesky.structure(points, front, rear)
    blocks = np.zeros((len(pattern.rows), 3, 3))
    for i in range(n):
        blocks[pattern.columns[pattern.position[i]]] = dense[3 * i:3 * i + 3, 3 * i:3 * i + 3]
    for link, (f, r) in enumerate(zip(front, rear)):
        block = dense[3 * f:3 * f + 3, 3 * r:3 * r + 3]
        blocks[pattern.link_slots[link]] = block if pattern.position[f] > pattern.position[r] else block.T
    return dense, pattern, blocks


def lattice_links(sites):
    index = {site: k for k, site in enumerate(sites)}
    pairs = [(index[(i + di, j + dj)], k) for (i, j), k in index.items() for di, dj in ((1, 0), (0, 1))
             if (i + di, j + dj) in index]
    return np.array([f for f, _ in pairs], dtype=np.int64), np.array([r for _, r in pairs], dtype=np.int64)


@pytest.mark.parametrize("seed", range(4))
def test_the_factorisation_solves_as_numpy_does(seed):
    """A random planar patch (holes, shuffled body order, sometimes two pieces) and a random matrix on its links."""
    rng = np.random.default_rng(seed)
    sites = [(i, j) for i in range(15) for j in range(11) if rng.random() < 0.8 and not (seed == 3 and i == 7)]
    sites = [sites[k] for k in rng.permutation(len(sites))]
    front, rear = lattice_links(sites)
    dense, pattern, blocks = block_system(np.array(sites, dtype=float), front, rear, seed)
    assert sorted(pattern.position) == list(range(len(sites)))
    assert cholesky.factor(blocks, pattern.columns, pattern.rows, pattern.row_starts, pattern.row_slots,
                           pattern.row_columns, np.empty(len(sites), dtype=np.int64))
    b = rng.normal(size=3 * len(sites))
    x = np.empty((len(sites), 3))
    x[pattern.position] = b.reshape(-1, 3)
    cholesky.solve(blocks, pattern.columns, pattern.rows, x)
    assert np.abs(x[pattern.position].ravel() - np.linalg.solve(dense, b)).max() < 1e-12


def test_a_matrix_that_is_not_definite_is_refused():
    front, rear = lattice_links([(i, j) for i in range(4) for j in range(4)])
    dense, pattern, blocks = block_system(np.array([(i, j) for i in range(4) for j in range(4)], float), front,
                                          rear, 0)
    blocks[pattern.columns[5]] *= -1
    assert not cholesky.factor(blocks, pattern.columns, pattern.rows, pattern.row_starts, pattern.row_slots,
                               pattern.row_columns, np.empty(16, dtype=np.int64))


def test_nested_dissection_fills_a_sheet_less_than_its_band():
    """A 40 x 40 sheet: in row order the factor fills the band (40 blocks below each diagonal); dissected it holds
    under half of that."""
    front, rear = lattice_links([(i, j) for i in range(40) for j in range(40)])
    pattern = cholesky.structure(np.array([(i, j) for i in range(40) for j in range(40)], float), front, rear)
    assert len(pattern.rows) < 0.5 * 41 * 1600


def both(shape, physics=QUASISTATIC_PHYSICS):
    return PlanarWorld(shape, physics, sparse=True), PlanarWorld(shape, physics, sparse=False)


def one_layer_library() -> list[str]:
    """Every library shape the planar world can hold (chains too, whose default is the chain solver)."""
    names = []
    for path in sorted(SHAPES_DIR.glob("*.toml")):
        try:
            check_one_layer(load_shape(path))
        except ConfigError:
            continue
        names.append(path.stem)
    return names


@pytest.mark.parametrize("name", one_layer_library())
def test_the_sparse_path_moves_every_library_shape_as_the_banded_one(name):
    shape = load_shape(SHAPES_DIR / f"{name}.toml")
    phases = np.random.default_rng(len(name)).random(shape.n_units)
    worlds = both(shape, DEFAULT_PHYSICS)
    for world in worlds:
        world.set_phases(phases)
        world.advance(world.ticks_in(2.0))
        world.cut(len(shape.links) // 2)  # and a piece moving apart
        world.advance(world.ticks_in(2.0))
        assert world.unconverged_ticks == 0
    sparse, banded = worlds
    assert np.abs(sparse.q - banded.q).max() < (TIE if name.startswith("chain") else AGREE)
    assert abs(sparse.newton_steps - banded.newton_steps) <= 0.01 * banded.newton_steps


def test_a_sheet_takes_the_sparse_path_and_a_library_shape_the_banded_one():
    assert len(sheet(12, 11).bodies) >= planar.SPARSE_FROM
    assert PlanarWorld(sheet(12, 11), QUASISTATIC_PHYSICS).sparse
    for name in one_layer_library():  # so the library's records stay bit for bit what they were
        assert not PlanarWorld(load_shape(SHAPES_DIR / f"{name}.toml"), QUASISTATIC_PHYSICS).sparse


def trajectory(shape, phases, seconds=1.0):
    world = PlanarWorld(shape, QUASISTATIC_PHYSICS)
    world.set_phases(phases)
    world.advance(world.ticks_in(seconds))
    assert world.unconverged_ticks == 0
    return world.q.copy()


def test_turning_a_sheet_turns_its_motion_on_the_sparse_path():
    shape = sheet(12, 11)
    phases = np.random.default_rng(1).random(shape.n_units)
    base, turned = trajectory(shape, phases), trajectory(rotate(shape, 90), phases)
    assert np.abs(turned[:, 0] + base[:, 1]).max() < AGREE  # x' = -y
    assert np.abs(turned[:, 1] - base[:, 0]).max() < AGREE  # y' = x
    assert np.abs(turned[:, 2] - base[:, 2] - np.pi / 2).max() < AGREE
    assert np.ptp(base[:, 2]) > 1e-4  # the units' different gaits do turn the bodies


def test_a_mirrored_sheet_moves_as_the_mirror_image_on_the_sparse_path():
    shape = sheet(12, 11)
    phases = np.random.default_rng(2).random(shape.n_units)
    moved, mirror = trajectory(shape, phases), trajectory(mirrored(shape), phases)
    assert np.abs(mirror[:, 0] - moved[:, 0]).max() < AGREE
    assert np.abs(mirror[:, 1] + moved[:, 1]).max() < AGREE
    assert np.abs(mirror[:, 2] + moved[:, 2]).max() < AGREE


def test_the_tick_breakdown_measures_a_small_sheet():
    """benchmarks/cost_per_unit.py --breakdown reaches into the solver's pieces: they still take what it gives."""
    import importlib.util

    from conftest import BENCHMARKS_DIR

    spec = importlib.util.spec_from_file_location("cost_per_unit_script", BENCHMARKS_DIR / "cost_per_unit.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    row = script.breakdown(4, 3)
    assert row["units"] == 16 and row["newton"] >= 1.0 and 0.0 < row["sliding"] <= 1.0
    assert all(row[key] > 0.0 for key in ("tick", "residual", "system", "solve"))
