"""docs/results.md cannot rot: its pandas and DuckDB examples run on a tiny suite's results and agree with each other
and with the report's own metrics and curves, and every consolidated table's columns are documented there."""

from __future__ import annotations

import re
import shutil

import numpy as np
import pandas as pd
import pytest

from morphbench.bench import build_report

from conftest import ROOT

DOC = ROOT / "docs" / "results.md"
PLACEHOLDER = "results/pq"


@pytest.fixture(scope="module")
def results(reference, tmp_path_factory):
    """A copy of the tiny suite's results with its report (no videos): the results directory."""
    out = tmp_path_factory.mktemp("doc") / "results"
    shutil.copytree(reference[1], out)
    build_report(out)
    return out


def code_blocks(language: str = "python") -> list[str]:
    return re.findall(rf"^```{language}\n(.*?)^```", DOC.read_text(), re.M | re.S)


def test_the_examples_run_and_agree(results, capsys):
    blocks = code_blocks()
    assert len(blocks) == 4 and PLACEHOLDER in blocks[0]
    namespace: dict = {}
    for block in blocks:
        exec(compile(block.replace(PLACEHOLDER, str(results)), str(DOC), "exec"), namespace)
    assert capsys.readouterr().out  # they print their tables

    metrics = pd.read_parquet(results / "metrics.parquet")
    final, final_sql = namespace["final"], namespace["final_sql"]
    assert len(final) == len(final_sql) == len(metrics) == 4
    both = final.merge(final_sql, on="condition_id", suffixes=("", "_sql")).merge(metrics, on="condition_id",
                                                                                   suffixes=("", "_metrics"))
    assert len(both) == 4
    np.testing.assert_allclose(both.final_ubar, both.final_ubar_sql)
    np.testing.assert_allclose(both.final_ubar, both.final_ubar_metrics)  # the report's final Ubar
    np.testing.assert_allclose(both["std"], both.std_sql)
    assert (both.runs == 2).all() and (both.runs_sql == 2).all()

    curves = pd.read_parquet(results / "curves.parquet").merge(metrics[["condition_id", "learner", "noise"]])
    curves = curves[curves.step > 0].set_index(["learner", "noise", "step"]).acceptance.sort_index()
    acceptance = namespace["acceptance"].stack(["learner", "noise"]).reorder_levels(["learner", "noise", "step"])
    sql = namespace["acceptance_sql"].set_index(["learner", "noise", "step"]).acceptance.sort_index()
    np.testing.assert_allclose(acceptance.sort_index().to_numpy(), sql.to_numpy())
    np.testing.assert_allclose(sql.to_numpy(), curves.to_numpy())

    kept = namespace["kept"]
    assert len(kept) == 8 * 2  # the last step of 8 runs of 2 units
    assert kept.phase_kept.between(0, 1).all()


def test_every_column_of_every_table_is_documented(results):
    text = DOC.read_text()
    documented = set(re.findall(r"`([a-z0-9_]+)`", text))
    for name in ("runs", "steps", "units", "scans", "jobs", "curves", "metrics"):
        assert f"## {name}.parquet" in text
        columns = pd.read_parquet(results / f"{name}.parquet").columns
        missing = [c for c in columns if c not in documented and not re.fullmatch(r"dphi_\d+", c)]
        assert not missing, f"{name}.parquet: {missing} not in docs/results.md"
