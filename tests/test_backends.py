"""Two backends side by side: conditions paired across results directories, differences and disagreements."""

import shutil

import numpy as np
import pandas as pd
import pytest

from morphbench.bench import LocalExecutor, load_suite, run_suite
from morphbench.bench.backends import TABLE, compare, section
from morphbench.bench.report import build_report
from morphbench.errors import ConfigError

from conftest import TINY, run_cli, write_suite


@pytest.fixture(scope="module")
def two_backends(tmp_path_factory):
    """The tiny suite on the quasi-static preset and on PyBullet (fast), each with its report built."""
    directory = tmp_path_factory.mktemp("backends")
    suite_path = write_suite(directory, TINY)
    outs = []
    for physics in ("quasistatic", "fast"):
        out = directory / physics
        run_suite(load_suite(suite_path, physics=physics), out, LocalExecutor(2), progress=False)
        build_report(out)
        outs.append(out)
    return outs


def test_conditions_pair_across_backends(two_backends):
    table = compare(*two_backends)
    assert len(table) == 4  # two learners x two noise levels, each on both backends
    assert set(table.physics_a) == {"quasistatic"} and set(table.physics_b) == {"fast"}
    assert (table.runs_a == 2).all() and (table.runs_b == 2).all()
    np.testing.assert_allclose(table.final_ubar_diff, table.final_ubar_b - table.final_ubar_a)
    assert set(table.experiments) == {"pair"}


def metrics_dir(path, final_ubar, std, runs=10, physics="quasistatic"):
    """A results directory holding only the tables compare reads: one condition per value."""
    path.mkdir()
    ids = [f"c{i}" for i in range(len(final_ubar))]
    conditions = {"condition_id": ids, "shape": "chain-3", "learner": [f"l{i}" for i in range(len(ids))],
                  "physics": physics}
    pd.DataFrame({**conditions, "experiments": "E", "run_id": ids, "seed": 0, "status": "done"}).to_parquet(
        path / "runs.parquet")
    nan = np.full(len(ids), np.nan)
    pd.DataFrame({**conditions, "runs": runs, "failed": 0, "missing": 0, "final_ubar": final_ubar,
                  "final_ubar_std": std, "u_eq": final_ubar, "steps_to_threshold": nan,
                  "acceptance_mean": 0.25}).to_parquet(path / "metrics.parquet")
    return path


def test_a_difference_beyond_two_standard_errors_disagrees(tmp_path):
    """std 1 over 100 runs on each side: the combined standard error is sqrt(2) / 10 = 0.141, so 0.2 is within
    two of it and 0.4 is not."""
    a = metrics_dir(tmp_path / "a", [1.0, 1.0], [1.0, 1.0], runs=100)
    b = metrics_dir(tmp_path / "b", [1.2, 1.4], [1.0, 1.0], runs=100, physics="fast")
    table = compare(a, b).set_index("learner")
    assert table.final_ubar_se.to_numpy() == pytest.approx(np.sqrt(2) / 10)
    assert not table.disagree["l0"] and table.disagree["l1"]
    text = "\n".join(section(table.reset_index()))
    assert "disagree on 1 of 2 conditions" in text and "1.00 against 1.40" in text


def test_report_shows_the_comparison_it_was_given(two_backends, capsys):
    results = two_backends[0]
    code, _, err = run_cli(capsys, "report", str(results), "--compare", *map(str, two_backends))
    assert code == 0, err
    assert (results / f"{TABLE}.parquet").is_file()
    assert "## Backends side by side" in (results / "report.md").read_text()
    code, _, _ = run_cli(capsys, "report", str(results))  # kept from then on
    assert code == 0 and "## Backends side by side" in (results / "report.md").read_text()


def test_a_directory_without_metrics_is_a_clear_error(two_backends, tmp_path, capsys):
    code, _, err = run_cli(capsys, "report", str(two_backends[0]), "--compare", str(tmp_path), str(two_backends[1]))
    assert code == 2
    assert "metrics.parquet" in err and str(tmp_path) in err and "Traceback" not in err


def test_the_claims_page_lists_exactly_the_verdicts_that_differ(two_backends):
    """benchmarks/claims_backends.py: each backend's claims as its report counts them, and the differing ones."""
    import importlib.util
    from pathlib import Path

    from morphbench.bench.report import claims_of

    spec = importlib.util.spec_from_file_location(
        "claims_backends", Path(__file__).resolve().parents[1] / "benchmarks" / "claims_backends.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    first, second = (claims_of(out) for out in two_backends)
    report = (two_backends[0] / "report.md").read_text()
    assert f"{sum(v.holds is True for v in first)} of {len(first)} claims hold" in report
    text = module.page(*two_backends)
    differ = [x.claim.id for x, y in zip(first, second) if x.holds != y.holds]
    assert f"{len(differ)} verdicts differ" in text
    claims_table = text.split("verdicts differ:")[1].split("Condition by condition")[0]
    listed = [line.split(" | ")[0][2:] for line in claims_table.splitlines()[3:] if line.startswith("| ")]
    assert listed == differ


def test_the_paper_claims_sections_count_as_the_report_and_list_what_fails(two_backends, tmp_path, monkeypatch):
    """benchmarks/paper_claims.py: the count the report gives, the claims that do not hold, written between the
    markers of both pages (a page without them refused before anything is measured)."""
    import importlib.util
    from pathlib import Path

    from morphbench.bench.report import claims_of
    from morphbench.errors import ConfigError

    spec = importlib.util.spec_from_file_location(
        "paper_claims", Path(__file__).resolve().parents[1] / "benchmarks" / "paper_claims.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    results = two_backends[0]
    verdicts = claims_of(results)
    held = sum(v.holds is True for v in verdicts)
    assert f"{held} of {len(verdicts)} claims hold" in (results / "report.md").read_text()
    assert module.counts(verdicts).startswith(f"{held} of the {len(verdicts)} claims hold")
    pages = {name: tmp_path / f"{name}.md" for name in ("paper", "calibration")}
    for name, markers in (("paper", module.STANDS), ("calibration", module.FAILING)):
        pages[name].write_text(f"# {name}\n\n{markers[0]}\nstale text\n{markers[1]}\n\nkept\n")
    monkeypatch.setattr(module, "PAPER", pages["paper"])
    monkeypatch.setattr(module, "CALIBRATION", pages["calibration"])
    assert module.main([str(results)]) == 0
    table = pages["calibration"].read_text()
    listed = [line.split(" | ")[0][2:] for line in table.splitlines() if line.startswith("| ") and "---" not in line]
    assert listed[1:] == [v.claim.id for v in verdicts if v.holds is not True]
    assert "stale text" not in table and table.endswith("\nkept\n") and module.counts(verdicts) in table
    assert module.counts(verdicts) in pages["paper"].read_text()
    pages["paper"].write_text("# no markers\n")
    with pytest.raises(ConfigError, match="paper.md"):
        module.main([str(results)])


@pytest.mark.parametrize("name, key", [("metrics", "condition_id"), ("runs", "run_id")])
def test_a_row_twice_is_refused_naming_the_file(two_backends, tmp_path, capsys, name, key):
    """Each condition would be paired twice (two conditions, four pairs) and the comparison written as sound."""
    a = metrics_dir(tmp_path / "a", [1.0, 1.2], [0.1, 0.1])
    b = metrics_dir(tmp_path / "b", [1.1, 1.3], [0.1, 0.1], physics="fast")
    assert len(compare(a, b)) == 2
    table = pd.read_parquet(b / f"{name}.parquet")
    pd.concat([table, table.iloc[:1]]).to_parquet(b / f"{name}.parquet")
    with pytest.raises(ConfigError, match=rf"^{b}: {name}.parquet: expected one row per {key}, got c0 2 times$"):
        compare(a, b)
    target = tmp_path / "target"
    shutil.copytree(two_backends[0], target, ignore=shutil.ignore_patterns(f"{TABLE}.parquet"))
    code, _, err = run_cli(capsys, "report", str(target), "--compare", str(a), str(b), "--no-videos")
    assert code == 2 and f"{b}: {name}.parquet: expected one row per {key}" in err and "Traceback" not in err
    assert not (target / f"{TABLE}.parquet").exists()


def test_a_directory_compared_with_itself_is_refused(two_backends, tmp_path, capsys):
    results = two_backends[0]
    (tmp_path / "link").symlink_to(results)
    for spelling in (results, f"{results}/", results / ".." / results.name, tmp_path / "link"):
        with pytest.raises(ConfigError, match=r"^--compare: .*: expected a results directory other than "):
            compare(results, spelling)
    code, _, err = run_cli(capsys, "report", str(results), "--compare", str(results), str(tmp_path / "link"))
    assert code == 2 and "the same directory compared with itself" in err and "Traceback" not in err
    assert len(compare(*two_backends)) == 4  # two directories are still compared
