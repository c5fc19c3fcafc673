"""benchmarks/scaling_2d.py: the 2-D scaling study's section (table, findings, figure) from a results directory's
metrics, on made-up metrics whose answers are known."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pandas as pd

from conftest import BENCHMARKS_DIR


def _script():
    spec = importlib.util.spec_from_file_location("scaling_2d_script", BENCHMARKS_DIR / "scaling_2d.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


GAINS = [(2.0, 2.2), (1.0, 1.4), (1.5, 1.7), (-0.1, 0.0), (0.05, 0.25)]
"""each condition's runs' gains (final true Ubar less step 1's, mm/cycle): means 2.1, 1.2, 1.6, -0.05 and 0.15, with
standard errors 0.1, 0.2, 0.1, 0.05 and 0.1."""


def _metrics(directory: Path) -> Path:
    """Five conditions: three that learned (one without a plateau), one whose runs end below their start, and the
    same sheet again with its units discarding 2 cycles of each step, whose fit ends far above the fit's start U_0
    but whose runs gain less than 2 standard errors: it learned nothing."""
    rows = [  # shape, n_units, learner, runs, u_eq, plateau, final_ubar, std, u_0
        ("chain-2", 2, "thermal", 16, 2.5, True, 2.4, 0.4, 0.3),
        ("chain-3", 3, "thermal", 16, 9.9, False, 1.8, 1.6, 0.9),
        ("sheet-2x2", 4, "thermal", 8, 1.5, True, 1.4, 0.8, -0.2),
        ("sheet-16x16", 256, "thermal", 4, 0.15, True, 0.15, 0.05, 0.3),
        ("sheet-16x16", 256, "thermal", 4, 0.9, True, 0.9, 0.1, 0.2),
    ]
    table = pd.DataFrame(rows, columns=["shape", "n_units", "learner", "runs", "u_eq", "plateau", "final_ubar",
                                        "final_ubar_std", "u_0"])
    table = table.assign(steps=300, steps_to_threshold=[15.0, float("nan"), 9.0, 0.0, 40.0],
                         steps_to_threshold_std=[18.0, float("nan"), 9.0, 0.0, 10.0],
                         reached_fraction=[1.0, float("nan"), 1.0, 1.0, 0.75], discard_cycles=[0, 0, 0, 0, 2],
                         condition_id=[f"c{i}" for i in range(len(rows))])
    table.to_parquet(directory / "metrics.parquet")
    runs = [(f"c{i}-{j}", f"c{i}", 0.3 + j, 0.3 + j + gain) for i, pair in enumerate(GAINS)
            for j, gain in enumerate(pair)]
    runs.append(("failed", "c0", 0.0, float("nan")))  # a failed run counts for nothing
    pd.DataFrame({"run_id": [r[0] for r in runs], "condition_id": [r[1] for r in runs],
                  "status": ["done"] * (len(runs) - 1) + ["failed"], "final_ubar_true": [r[3] for r in runs],
                  "backend": [("quasistatic" if r[1] < "c2" else "planar" if r[1] == "c2" else "dynamic")
                              for r in runs]}).to_parquet(directory / "runs.parquet")
    # best waves of chain-2 and the 16 x 16 sheet (chain-3 and sheet-2x2 not measured), and of a shape not studied
    pd.DataFrame({"shape": ["chain-2", "sheet-16x16", "ring-8"], "wave": [5.0, 3.0, 1.0]}).to_csv(
        directory / "waves.csv", index=False)
    # a run's gain counts from step 1, measured as the later steps are; step 0 (no phase change before it) is not it
    steps = [(run_id, step, value) for run_id, _, start, _ in runs
             for step, value in ((0, start + 5.0), (1, start), (2, start + 1.0))]
    pd.DataFrame(steps, columns=["run_id", "step", "ubar_true"]).to_parquet(directory / "steps.parquet")
    return directory


def test_the_section_says_which_assemblies_learned_and_how_fast(tmp_path):
    script = _script()
    metrics = script.read_metrics(_metrics(tmp_path), tmp_path / "waves.csv")
    rows = {line.split(" | ")[0].strip("| "): line for line in script.table(metrics)[2:]}
    # SE 0.4 / 4 = 0.1, of 2.5; U_eq 2.5 of the best wave's 5.0
    assert "| 2 | quasistatic | thermal | 16 | +2.50 | 4% | +5.00 | +0.50 | +2.10 +- 0.10 | yes | 15 +- 18 | 100% |" \
        in rows["chain-2"]
    assert "+1.80 (final Ubar: no plateau) | 22% | - | - |" in rows["chain-3"]  # no best wave measured: no ratio
    assert "| yes | - | - |" in rows["chain-3"] and "| planar |" in rows["sheet-2x2"]
    # below its start: no steps
    assert "| dynamic | thermal | 4 | +0.15 | 17% | +3.00 | +0.05 | -0.05 +- 0.05 | no | - | - |" in rows["sheet-16x16"]
    after = rows["sheet-16x16 (2 cycles discarded)"]  # the same sheet, named apart; U_eq 0.9 against U_0 0.2, but
    assert "| 256 | dynamic | thermal | 4 | +0.90 | 6% | +3.00 | +0.30 | +0.15 +- 0.10 | no | - | - |" in after
    findings = script.findings(metrics)  # ... its runs gained < 2 SE
    assert "- chains, thermal: U_eq +2.50 mm/cycle at N = 2 (0.50 of its best wave), +1.80 at N = 3." in findings
    assert "- sheets, thermal: U_eq +1.50 mm/cycle at N = 4, +0.15 at N = 256 (0.05 of its best wave)." in findings
    assert "- sheets, thermal (2 cycles discarded): U_eq +0.90 mm/cycle at N = 256 (0.30 of its best wave)." \
        in findings
    assert any(line.endswith("(no gait learned in 300 steps): sheet-16x16 thermal, sheet-16x16 (2 cycles discarded) "
                             "thermal.") for line in findings)
    assert findings[-1] == ("- Standard error under 10% of U_eq: 2 of 5 conditions (chain-2 thermal, "
                           "sheet-16x16 (2 cycles discarded) thermal).")


def test_the_command_rewrites_its_section_and_refuses_a_directory_without_metrics(tmp_path, capsys):
    script = _script()
    doc = tmp_path / "page.md"
    doc.write_text(f"head\n{script.BEGIN}\nold\n{script.END}\ntail\n")
    waves = ["--waves", str(tmp_path / "waves.csv")]
    assert script.main([str(_metrics(tmp_path)), "--doc", str(doc), *waves]) == 0
    text = doc.read_text()
    assert text.startswith(f"head\n{script.BEGIN}\n") and text.endswith(f"{script.END}\ntail\n")
    assert "old" not in text and "| sheet-2x2 | 4 | planar | thermal | 8 |" in text
    assert "](media/scaling-2d.png)" in text and (tmp_path / "media" / "scaling-2d.png").is_file()
    empty = tmp_path / "empty"
    empty.mkdir()
    assert script.main([str(empty), "--doc", str(doc), *waves]) == 2
    assert f"{empty}: metrics.parquet: expected the results directory" in capsys.readouterr().err
    assert script.main([str(tmp_path), "--doc", str(doc), "--waves", str(empty / "waves.csv")]) == 2
    assert "waves.csv: file: expected the best waves written by `python benchmarks/waves.py`" in capsys.readouterr().err
    assert doc.read_text() == text  # nothing written
