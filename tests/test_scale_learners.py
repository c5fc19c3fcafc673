"""benchmarks/scale_learners.py: each learner's level over its last 100 steps against the best wave, on made-up
tables whose answers are known."""

from __future__ import annotations

import importlib.util

import numpy as np
import pandas as pd

from conftest import BENCHMARKS_DIR


def _script():
    spec = importlib.util.spec_from_file_location("scale_learners_script", BENCHMARKS_DIR / "scale_learners.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _results(directory):
    """300 steps. chain-20: two sparse runs at 3.0 and 3.4 from step 101 (1.0 before), two thermal at 0.2 and 0.4; a
    failed run counts for nothing; the best wave 5.0. sheet-16x16: one sparse run at 1.2, best wave 6.0."""
    runs = [("a", "chain-20", "sparse", 3.0), ("b", "chain-20", "sparse", 3.4), ("c", "chain-20", "thermal", 0.2),
            ("d", "chain-20", "thermal", 0.4), ("e", "sheet-16x16", "sparse", 1.2), ("f", "chain-20", "sparse", 9.0)]
    pd.DataFrame({"run_id": [r[0] for r in runs], "shape": [r[1] for r in runs], "learner": [r[2] for r in runs],
                  "status": ["done"] * 5 + ["failed"], "steps": 300}).to_parquet(directory / "runs.parquet")
    steps = [(run_id, step, level if step > 100 else 1.0) for run_id, _, _, level in runs for step in range(301)]
    pd.DataFrame(steps, columns=["run_id", "step", "ubar_true"]).to_parquet(directory / "steps.parquet")
    pd.DataFrame({"shape": ["chain-20", "sheet-16x16"], "wave": [5.0, 6.0]}).to_csv(directory / "waves.csv",
                                                                                     index=False)
    return directory


def test_levels_are_the_last_100_steps_against_the_best_wave(tmp_path):
    script = _script()
    rows = script.levels(_results(tmp_path), tmp_path / "waves.csv").set_index(["shape", "learner"])
    sparse = rows.loc[("chain-20", "sparse")]
    assert sparse.runs == 2 and np.isclose(sparse.level, 3.2) and np.isclose(sparse.share, 0.64)
    assert np.isclose(sparse.se, np.std([3.0, 3.4], ddof=1) / 2 ** 0.5)
    lines = script.table(rows.reset_index(), 300)
    assert lines[0].startswith("| assembly | learner | runs | true Ubar, steps 201-300 (mm/cycle, +- SE) | its rise "
                               "from steps 101-200")
    assert "| chain-20 | sparse | 2 | +3.20 +- 0.20 | +0.00 +- 0.00 | +5.00 | 0.64 +- 0.04 | 0.5: met |" in lines
    assert "| chain-20 | thermal | 2 | +0.30 +- 0.10 | +0.00 +- 0.00 | +5.00 | 0.06 +- 0.02 | 0.5: not met |" in lines
    assert any(line.startswith("| sheet-16x16 | sparse | 1 | +1.20") and line.endswith("| 0.3: not met |")
               for line in lines)


def test_the_command_rewrites_its_section_or_refuses_a_directory_without_runs(tmp_path, capsys):
    script = _script()
    doc = tmp_path / "page.md"
    doc.write_text(f"head\n{script.BEGIN}\nold\n{script.END}\ntail\n")
    assert script.main([str(_results(tmp_path)), "--doc", str(doc), "--waves", str(tmp_path / "waves.csv")]) == 0
    text = doc.read_text()
    assert "old" not in text and "| chain-20 | sparse | 2 |" in text and text.endswith(f"{script.END}\ntail\n")
    empty = tmp_path / "empty"
    empty.mkdir()
    assert script.main([str(empty), "--doc", str(doc), "--waves", str(tmp_path / "waves.csv")]) == 2
    assert "runs.parquet: expected the results directory" in capsys.readouterr().err and doc.read_text() == text
