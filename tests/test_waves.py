"""benchmarks/waves.py: the travelling waves it places on a sheet, a known answer of the physics it measures (a wave
along the heading moves a sheet straight), and a page without the section's markers refused."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from morphbench.experiment.scan import grid_places

from conftest import BENCHMARKS_DIR


def _script():
    spec = importlib.util.spec_from_file_location("waves_script", BENCHMARKS_DIR / "waves.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_waves_run_from_the_front_back():
    from morphbench.shapes import load_shape

    script = _script()
    shape = load_shape(BENCHMARKS_DIR / "shapes" / "sheet-4x4.toml")
    columns, rows = grid_places(shape)
    xy = np.array([shape.bodies[body].position[:2] for body in shape.units])
    assert sorted(set(columns)) == sorted(set(rows)) == [0, 1, 2, 3]
    assert np.all(xy[columns == 0, 0] == xy[:, 0].max())  # column 0 is the front (heading +x)
    planned = script.points(shape, resolution=4, samples=3, seed=0)
    assert [kind for kind, _, _ in planned] == ["wave"] * 4 + ["random"] * 3
    wave = planned[1][2]  # delta 0.25: a quarter cycle later per column back
    assert np.allclose(wave, np.mod(0.25 * columns, 1.0))


def test_a_wave_along_the_heading_moves_a_sheet_straight():
    """Every unit of a column shares its phase in such a wave, so a link across the heading joins two bellows in
    phase and the sheet is its own mirror image across the heading: it moves along it without drifting or turning."""
    from morphbench.experiment.scan import motion_at
    from morphbench.shapes import load_shape

    script = _script()
    shape = load_shape(BENCHMARKS_DIR / "shapes" / "sheet-2x2.toml")
    columns, _ = grid_places(shape)
    motion = motion_at(shape, np.mod(0.3 * columns, 1.0), cycles=4, discard=2)
    assert motion.centroid[0] > 0.5  # mm/cycle
    assert abs(motion.centroid[1]) < 1e-9 and abs(motion.turning) < 1e-9
    assert script.wave_ubar((str(BENCHMARKS_DIR / "shapes" / "sheet-2x2.toml"), np.mod(0.3 * columns, 1.0))) == \
        pytest.approx(float(np.mean(motion.units)))


def test_a_page_without_the_markers_is_refused_before_measuring(tmp_path, capsys):
    page = tmp_path / "page.md"
    page.write_text("no markers\n")
    assert _script().main(["--resolution", "2", "--samples", "2", "--doc", str(page)]) == 2
    assert "markers" in capsys.readouterr().err and page.read_text() == "no markers\n"


def test_the_best_waves_file_is_what_the_scaling_study_reads(tmp_path):
    """waves.py's file, read by benchmarks/scaling_2d.py: each assembly's best wave by its shape's name."""
    script = _script()
    rows = [{"shape": "chain-2", "n_units": 2, "backend": "quasistatic", "wave": (0.375, 4.9),
             "random": (0.1, 1.5, 2.0)},
            {"shape": "sheet-32x32", "n_units": 1024, "backend": "dynamic", "wave": (0.4, 6.1),
             "random": (0.0, 0.2, 0.3)}]
    script.write_csv(rows, tmp_path / "waves.csv")
    spec = importlib.util.spec_from_file_location("scaling_2d_script", BENCHMARKS_DIR / "scaling_2d.py")
    scaling = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(scaling)
    waves = scaling.best_waves(tmp_path / "waves.csv")
    assert dict(zip(waves["shape"], waves["wave"])) == {"chain-2": 4.9, "sheet-32x32": 6.1}


def test_the_assemblies_measured_are_the_scaling_study_s():
    """What waves.py measures follows benchmarks/scaling-2d.toml: its chains, then its sheets, by size."""
    names = [shape.name for _, shape in _script().assemblies()]
    assert names == [f"chain-{n}" for n in (2, 3, 5, 7, 10, 15, 20)] + \
        [f"sheet-{n}x{n}" for n in (2, 4, 8, 16, 32, 64, 100)]
