"""benchmarks/dynamic_fidelity.py: the library it compares (one-layer shapes only, each with the quasi-static model
'default' runs for it), its tables on one tiny case (chain-2, 2 seeds, a few steps, 2 landscape points) with the
columns the page shows, and a page without the section's markers refused before anything is measured."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from conftest import BENCHMARKS_DIR, LIBRARY


@pytest.fixture
def script(monkeypatch):
    monkeypatch.syspath_prepend(str(BENCHMARKS_DIR))  # it imports benchmarks/fidelity.py, as when run from there
    spec = importlib.util.spec_from_file_location("dynamic_fidelity_script", BENCHMARKS_DIR / "dynamic_fidelity.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_library_is_its_one_layer_shapes_on_their_default_quasistatic_model(script):
    shapes = {name: model for name, _, model in script.library()}
    assert "stack-2x2x2" not in shapes and "stack-2x2x2-lift" not in shapes
    assert len(shapes) == len(LIBRARY) - 2
    assert shapes["chain-2"] == "quasistatic" and shapes["grid-3x3"] == "planar" and shapes["sheet-10x10"] == "planar"
    assert [name for name, _, _ in script.library(["grid-2x2", "chain-3"])] == ["grid-2x2", "chain-3"]
    with pytest.raises(ValueError, match="stack-2x2x2"):
        script.library(["stack-2x2x2"])


def test_one_tiny_case_gives_both_tables_with_their_columns(script):
    (name, path, model), = script.library(["chain-2"])
    landscape = script.landscape_row(name, path, model, points=2, seed=0)
    learning = script.learning_row(name, path, seeds=2, quasistatic_seeds=2, steps=3)
    assert landscape["dynamic"].shape == landscape["quasistatic"].shape == (2,)
    assert 0 < landscape["inertia"] < 1  # friction dominates: the quasi-static model's range
    assert learning["seeds"] == (2, 2) and learning["failed"] == (0, 0)
    assert learning["agree"] == (learning["z"] <= 2)
    assert learning["se"] == pytest.approx(np.hypot(learning["dynamic"][1], learning["quasistatic"][1]))
    for lines, columns in ((script.landscape_table([landscape]), script.LANDSCAPE_COLUMNS),
                           (script.learning_table([learning]), script.LEARNING_COLUMNS)):
        header, rule, row = lines
        assert header == "| " + " | ".join(columns) + " |"
        assert rule.count("---") == len(columns)
        assert row.startswith("| chain-2 |") and row.count("|") == len(columns) + 1
    text = "\n".join(script.library_lines([landscape], [learning], points=2, steps=3, large_from=50))
    assert "1 of 1 shapes agree" in text or "0 of 1 shapes agree" in text


def test_a_page_without_the_markers_is_refused_before_measuring(script, tmp_path, capsys):
    page = tmp_path / "page.md"
    page.write_text("no markers here\n")
    assert script.main(["--write", "--shapes", "chain-2", "--seeds", "2", "--steps", "2", "--doc", str(page)]) == 2
    assert "markers" in capsys.readouterr().err
    assert page.read_text() == "no markers here\n"


def test_fidelity_py_rewrites_its_part_of_the_page_and_keeps_the_dynamic_section(script, tmp_path):
    """benchmarks/fidelity.py writes docs/fidelity.md up to the dynamic backend's section, which it keeps."""
    import fidelity

    page = tmp_path / "fidelity.md"
    page.write_text(f"# old head\n\nold figures\n\n{fidelity.KEPT_FROM}\n\nkept table\n", encoding="utf-8")
    fidelity.write_page(page, ["# Fidelity", "", "new figures", ""])
    assert page.read_text(encoding="utf-8") == f"# Fidelity\n\nnew figures\n\n{fidelity.KEPT_FROM}\n\nkept table\n"
    bare = tmp_path / "bare.md"
    fidelity.write_page(bare, ["# Fidelity", ""])
    assert bare.read_text(encoding="utf-8") == "# Fidelity\n"
