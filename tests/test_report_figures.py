"""The paper's figures and claims in a suite's report: scans of a damaged assembly, the experiment's scans, the Ubar
distribution, events, landscapes with trails, positions, scaling, and the claims table.

One tiny suite on the quasi-static backend (runs of 10-16 steps, scans of 4 x 4 and 10 points) is run once for the
module, in this process; the pure functions are checked on tables built by hand, whose answers are known.
"""

from __future__ import annotations

import math
import re
import shutil

import numpy as np
import pandas as pd
import pytest

from morphbench.bench import build_report, claims as C, load_suite, metrics as M, run_suite
from morphbench.bench.report import _stretch
from morphbench.bench.store import Store
from morphbench.errors import ConfigError

from conftest import SHAPES_DIR as SHAPES, write_suite

SUITE = f"""
name = "figures"

[[experiment]]
name = "S1"
shape = "{SHAPES / 'chain-2.toml'}"
learner = {{name = "thermal"}}
seeds = 3
steps = 12

[[experiment]]
name = "S6"
shape = "{SHAPES / 'chain-3.toml'}"
learner = {{name = ["thermal", "flaky"]}}
scans = ["S3", "S3-damaged"]
seeds = 2
steps = 16
[[experiment.events]]
step = 8
kind = "damage"
unit = 2
mode = "no-inflate"

[[experiment]]
name = "S9"
shape = ["{SHAPES / 'chain-2.toml'}", "{SHAPES / 'chain-3.toml'}"]
learner = {{name = "thermal", step_size = [0.1, 0.025]}}
seeds = 2
steps = 10

[[experiment]]
name = "S11"
shape = "{SHAPES / 'chain-3.toml'}"
learner = {{name = "flaky"}}
environment = {{noise = [0.0, 0.5]}}
seeds = 2
steps = 10
[[experiment.events]]
step = 5
kind = "cut"
link = 2

[[scan]]
name = "S2"
shape = "{SHAPES / 'chain-2.toml'}"
resolution = 10
cycles = 2
discard = 1

[[scan]]
name = "S3"
shape = "{SHAPES / 'chain-3.toml'}"
resolution = 4
cycles = 2
discard = 1

[[scan]]
name = "S3-damaged"
shape = "{SHAPES / 'chain-3.toml'}"
resolution = 4
cycles = 2
discard = 1
damage = {{unit = 2, mode = "no-inflate"}}
"""


class InProcess:
    """An executor that runs each job here, one after the other (no worker processes to start)."""

    def describe(self) -> str:
        return "this process"

    def run(self, jobs, fn):
        for job in jobs:
            yield job, fn(job)


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    """(suite, results directory) of SUITE run on the quasi-static backend."""
    directory = tmp_path_factory.mktemp("figures")
    suite = load_suite(write_suite(directory, SUITE), physics="quasistatic")
    out = directory / "results"
    outcome = run_suite(suite, out, InProcess(), progress=False)
    assert outcome.failed == 0
    return suite, out


@pytest.fixture(scope="module")
def report(results):
    """The text of the results' report.md (its figures in the results directory)."""
    return build_report(results[1]).read_text()


# --- scans of a damaged assembly and the scans of an experiment -------------------------------------------------


def test_a_damaged_scan_measures_the_damaged_landscape(results):
    suite, out = results
    healthy, damaged = (next(s for s in suite.scans if s.name == name) for name in ("S3", "S3-damaged"))
    assert damaged.id != healthy.id and damaged.damage.unit == 2 and damaged.damage.mode == "no-inflate"
    assert healthy.columns["damage"] == "none" and damaged.columns["damage"] == "damage unit=2 mode=no-inflate"
    scans = pd.read_parquet(out / "scans.parquet")
    before = scans[scans.scan == "S3"].set_index(["dphi_2", "dphi_3"]).ubar
    after = scans[scans.scan == "S3-damaged"].set_index(["dphi_2", "dphi_3"]).ubar
    assert len(before) == len(after) == 16 and np.abs(before - after).max() > 1.0
    # unit 2's bellows never extends: where its pump switches on cannot matter, only unit 3's phase does
    spread = after.groupby(level="dphi_3").agg(lambda u: u.max() - u.min())
    assert spread.max() < 1e-6 and after.groupby(level="dphi_3").mean().std() > 0.5
    # a damaged landscape is no measure of what the healthy robot could do
    assert M.scan_best(scans)[(healthy.columns["shape_id"], "quasistatic", healthy.columns["environment_id"])] \
        == before.max()


@pytest.mark.parametrize("damage, key, expected", [
    ("{unit = 4, mode = 'no-inflate'}", "scan[0].damage.unit", "a unit number in [1, 3]"),
    ("{unit = 2, mode = 'broken'}", "scan[0].damage.mode", "one of no-inflate"),
    ("{unit = 2}", "scan[0].damage.mode", "a value (a damage event needs mode, unit)"),
    ("{unit = 2, mode = 'dead', step = 3}", "scan[0].damage.step", "one of the keys of a damage event: mode, unit"),
    ("2", "scan[0].damage", "a table of a damage event's fields"),
])
def test_a_scans_damage_is_checked_as_a_damage_event_is(tmp_path, damage, key, expected):
    text = f"""
        [[scan]]
        shape = "{SHAPES / 'chain-3.toml'}"
        damage = {damage}
    """
    with pytest.raises(ConfigError) as info:
        load_suite(write_suite(tmp_path, text))
    assert info.value.key == key and expected in str(info.value)


def test_an_experiments_scans_must_be_scans_of_the_suite(tmp_path):
    text = f"""
        [[experiment]]
        name = "S6"
        shape = "{SHAPES / 'chain-3.toml'}"
        scans = ["S3", "S4"]
        [[scan]]
        name = "S3"
        shape = "{SHAPES / 'chain-3.toml'}"
        [[scan]]
        shape = "{SHAPES / 'chain-3.toml'}"
        damage = {{unit = 2, mode = "no-inflate"}}
    """
    with pytest.raises(ConfigError) as info:
        load_suite(write_suite(tmp_path, text))
    assert info.value.key == "experiment[S6].scans" and "S3, chain-3-r20-unit2-no-inflate" in str(info.value)
    suite = load_suite(write_suite(tmp_path, text.replace('"S3", "S4"', '"S3"')))
    assert suite.experiments[0].scans == ("S3",) and list(suite.plan()["experiments"][0]["scans"]) == ["S3"]
    assert len(suite.runs) == 1  # not an axis


def test_a_scan_describes_the_stretch_of_a_run_whose_world_it_measured():
    steps = pd.DataFrame({"step": range(20), "event": [""] * 20})
    assert _stretch(steps, "none") == (0, math.inf)
    steps.loc[8, "event"] = "damage unit=2 mode=no-inflate"
    assert _stretch(steps, "none") == (0, 8)
    assert _stretch(steps, "damage unit=2 mode=no-inflate") == (8, math.inf)
    assert _stretch(steps, "damage unit=3 mode=no-inflate") is None
    steps.loc[12, "event"] = "friction scale=0.5"
    assert _stretch(steps, "damage unit=2 mode=no-inflate") == (8, 12)


# --- the tables the figures draw -------------------------------------------------------------------------------


def test_the_ubar_distribution_is_a_fraction_of_the_runs_at_each_step():
    steps = pd.DataFrame({"run_id": ["a", "b", "c", "d"] * 3, "step": np.repeat([0, 1, 2], 4),
                          "ubar_true": [0.1, 0.2, 0.9, 5.0, -3.0, 0.5, 0.6, 0.7, 1.5, 1.5, 1.5, np.nan]})
    k, fraction = M.ubar_distribution(steps, edges=[0.0, 1.0, 2.0])
    assert list(k) == [0, 1, 2] and fraction.shape == (2, 3)
    np.testing.assert_allclose(fraction.sum(axis=0), 1.0)  # values beyond the edges count in the end bins
    np.testing.assert_allclose(fraction[:, 0], [0.75, 0.25])
    np.testing.assert_allclose(fraction[:, 1], [1.0, 0.0])
    np.testing.assert_allclose(fraction[:, 2], [0.0, 1.0])  # over the 3 runs with a value


def test_the_ubar_distribution_of_a_stored_condition_sums_to_one_per_step(results):
    _, out = results
    steps = pd.read_parquet(out / "steps.parquet")
    mine = steps[steps.condition_id == steps.condition_id.iloc[-1]]
    edges = np.linspace(mine.ubar_true.min(), mine.ubar_true.max(), 41)
    k, fraction = M.ubar_distribution(mine, edges)
    assert len(k) == mine.step.nunique() and np.allclose(fraction.sum(axis=0), 1.0)
    assert np.allclose(fraction * mine.run_id.nunique(), np.round(fraction * mine.run_id.nunique()))


def test_each_event_has_its_recovery():
    k = np.arange(30)
    rows = []
    for run, back in enumerate([12, 10]):  # run r0 drops to 0 for two steps at the first event, r1 not at all
        ubar = np.where((k >= 10) & (k < back), 0.0, 4.0)
        ubar = np.where(k >= 20, 1.0, ubar)  # the second event, at step 20: never recovered from
        event = np.where(k == 10, "friction scale=0.5", np.where(k == 20, "cut link=1", ""))
        rows.append(pd.DataFrame({"condition_id": "c", "run_id": f"r{run}", "step": k, "ubar_true": ubar,
                                  "event": event}))
    first, second = M.event_recovery(pd.concat(rows), window=5).to_dict("records")
    assert (first["event_index"], first["event_step"], first["event"], first["runs"]) == (0, 10, "friction scale=0.5",
                                                                                          2)
    assert first["ubar_before"] == 4.0 and first["ubar_before_std"] == 0.0
    assert first["ubar_after"] == pytest.approx((2.4 + 4.0) / 2)  # steps 10-14: (0, 0, 4, 4, 4) and 4s
    assert first["ubar_end"] == 4.0  # steps 15-19, the last 5 before the next event
    assert first["recovery_steps"] == 1.0 and first["recovery_steps_std"] == pytest.approx(math.sqrt(2))
    assert first["recovered_fraction"] == 1.0  # 2 steps and 0 steps to regain 0.8 x 4
    assert (second["event_index"], second["event_step"], second["ubar_before"]) == (1, 20, 4.0)
    assert (second["ubar_after"], second["ubar_end"]) == (1.0, 1.0)
    assert math.isnan(second["recovery_steps"]) and second["recovered_fraction"] == 0.0


def test_phase_differences_are_by_position_and_wrapped():
    units = pd.DataFrame({"step": [0, 0, 0, 1, 1, 1], "unit": [1, 2, 3, 1, 2, 3], "position": [1, 2, 3, 3, 1, 2],
                          "phase_tried": [0.9, 0.1, 0.95, 0.2, 0.5, 0.25]})
    table = M.phase_differences(units)
    np.testing.assert_allclose(table.dphi_2, [0.2, 0.75])  # step 1: unit 3 is second, unit 2 in front
    np.testing.assert_allclose(table.dphi_3, [0.05, 0.7])
    assert ((table[["dphi_2", "dphi_3"]] >= 0) & (table[["dphi_2", "dphi_3"]] < 1)).all().all()


def test_each_piece_of_a_cut_is_scored_on_its_own():
    units = pd.DataFrame({"run_id": "r", "step": [1, 1, 1, 2, 2, 2], "unit": [1, 2, 3] * 2,
                          "piece": [1, 1, 1, 1, 2, 2], "u_true": [1.0, 2.0, 3.0, 1.0, 2.0, 4.0],
                          "u_measured": [1.0, 2.0, 3.0, 1.0, 2.0, np.nan]})  # unit 3 is dead at step 2
    table = M.piece_curves(units)
    assert table[["step", "piece", "n_units", "ubar"]].values.tolist() == [[1, 1, 3, 2.0], [2, 1, 1, 1.0],
                                                                          [2, 2, 1, 2.0]]


# --- the report ------------------------------------------------------------------------------------------------


def figures_named(report: str) -> list[str]:
    return re.findall(r"!\[[^\]]*\]\(figures/([^)]+)\)", report)


def test_every_figure_the_report_names_is_on_disk_and_the_paper_figures_are_there(results, report):
    _, out = results
    named = figures_named(report)
    assert named and all((out / "figures" / name).is_file() for name in named)
    assert len(named) == len(set(named))
    assert {"S1-ubar.png", "S1-acceptance.png", "S1-positions.png", "S6-landscapes.png", "S6-events.png",
            "S9-scaling.png", "S11-events.png", "scan-S3-damaged.png"} <= set(named)
    assert "S1-scaling.png" not in named and "S1-events.png" not in named  # one size, no events
    assert sorted(p.name for p in (out / "figures").glob("*.png")) == sorted(named)
    s6 = report.split("## S6")[1].split("## S9")[0]
    assert "| learner | event at | event | runs | Ubar before | Ubar after | Ubar at the end |" in s6
    assert s6.count("| 8 | damage unit=2 mode=no-inflate | 2 |") == 2


def test_the_claims_section_checks_the_stored_tables(results, report):
    _, out = results
    claims = report.split("## Claims")[1]
    scans = pd.read_parquet(out / "scans.parquet")
    curve = scans[scans.scan == "S2"]
    peak = curve.ubar.max()
    row = next(line for line in claims.splitlines() if line.startswith("| scan-2-peak |"))
    assert f"| {peak:.3g} mm/cycle | scan S2 (10 points) |" in row
    assert row.endswith(f"| {'yes' if abs(peak - 4.5) <= 1 else 'no'} |")
    assert "| hw-trough |" in claims and "the suite has no complete healthy 2-unit scan with pump vibration" in claims
    assert claims.count("| not measured |") >= 3


def test_a_report_of_partial_results_says_what_it_left_out(results, tmp_path):
    _, out = results
    partial = tmp_path / "partial"
    partial.mkdir()
    shutil.copy(out / "plan.json", partial / "plan.json")
    tables = Store(out).consolidate(write=False)
    s6 = tables["runs"].condition_id[tables["runs"].experiments.str.contains("S6")].unique()
    tables["steps"] = tables["steps"][~tables["steps"].condition_id.isin(s6)].drop(columns=["x_m", "y_m"])
    tables["runs"].loc[tables["runs"].condition_id.isin(s6), "status"] = "missing"
    tables["units"] = pd.DataFrame(columns=["run_id"])  # results stored before units.parquet had positions
    scans = tables["scans"]
    tables["scans"] = scans[(scans.scan != "S2") & ~((scans.scan == "S3") & (scans.dphi_2 > 0.3))].drop(
        columns=["damage"])  # S2 unfinished, S3 half-measured, and a scans table older than damaged scans
    report = build_report(partial, tables).read_text()
    assert "## S6" in report and "No finished runs yet." in report.split("## S6")[1].split("## S9")[0]
    assert "Start and end positions: not drawn" in report
    assert "Landscape S3: not drawn (8 of 16 points measured yet)." in report
    assert "scan-2-peak" in report and "the suite has no complete healthy 2-unit scan" in report
    assert all((partial / "figures" / name).is_file() for name in figures_named(report))


# --- the claims, on tables built by hand -----------------------------------------------------------------------


def scan_table(values, name="S2", **columns) -> pd.DataFrame:
    """A 2-unit scan at dphi = k / len(values)."""
    n = len(values)
    return pd.DataFrame({"scan_id": name, "scan": name, "n_units": 2, "samples": n, "damage": "none",
                         "environment_id": M._default_ground(), "environment": "default",
                         "dphi_2": np.arange(n) / n, "ubar": values, **columns})


SAWTOOTH = [0.0, 0.5, 1.4, 3.1, 4.6, 0.0, -4.6, -3.1, -1.4, -0.5]
"""antisymmetric, one peak of 4.6 at 0.4 and a trough of -4.6 at 0.6."""


def verdicts(tables) -> dict[str, C.Verdict]:
    return {v.claim.id: v for v in C.check(tables)}


def test_the_scan_claims_measure_a_known_curve():
    found = verdicts({"scans": scan_table(SAWTOOTH)})
    assert found["scan-2-peak"].measured.value == 4.6 and found["scan-2-peak"].holds
    assert found["scan-2-peak-at"].measured.value == pytest.approx(0.4) and found["scan-2-peak-at"].holds
    assert found["scan-2-trough"].measured.value == -4.6 and found["scan-2-trough-at"].holds
    assert found["scan-2-antisymmetric"].measured.value == pytest.approx(0.0) and found["scan-2-antisymmetric"].holds
    assert found["scan-2-one-optimum"].measured.value == 1 and found["scan-2-one-optimum"].holds
    assert found["scan-2-peak"].measured.on == "scan S2 (10 points)"
    # a bump at 0.8 standing out by more than a tenth of the range is a second optimum; the peak moved to 0.2 fails
    bumped = verdicts({"scans": scan_table([0.0, 1.0, 4.6, 1.0, 0.0, -1.0, -4.6, -1.0, 1.5, 0.0])})
    assert bumped["scan-2-one-optimum"].measured.value == 2 and not bumped["scan-2-one-optimum"].holds
    assert bumped["scan-2-peak-at"].measured.value == pytest.approx(0.2) and not bumped["scan-2-peak-at"].holds
    assert bumped["scan-2-antisymmetric"].measured.value > 0.15 and not bumped["scan-2-antisymmetric"].holds
    # a damaged scan, another ground or an unfinished scan is not the 2-unit scan the paper speaks of
    for other in (scan_table(SAWTOOTH, damage="damage unit=2 mode=no-inflate"),
                  scan_table(SAWTOOTH, environment_id="elsewhere"), scan_table(SAWTOOTH, samples=20)):
        assert verdicts({"scans": other})["scan-2-peak"].holds is None
    # with pump vibration, the hardware's curve: -3 near 0.6 and a local maximum of about 1 near 0.9
    hardware = scan_table([0.0, 0.5, 1.5, 3.0, 4.0, 0.0, -3.0, -1.5, 1.0, 0.0], environment="vibration=0.8",
                          environment_id="shaken")
    hw = verdicts({"scans": hardware})
    assert hw["hw-trough"].holds and hw["hw-local-max"].measured.value == 1.0 and hw["hw-local-max-at"].holds
    assert hw["scan-2-peak"].holds is None  # its ground is not the default one


def test_a_claim_without_its_data_is_not_measured_and_says_why():
    for tables in ({}, {"scans": pd.DataFrame()}, {"scans": pd.DataFrame({"scan_id": ["x"], "ubar": [1.0]})},
                   {"metrics": pd.DataFrame({"condition_id": ["c"]})}):
        for verdict in C.check(tables):
            assert verdict.holds is None and verdict.measured is None and verdict.reason
    reasons = {v.claim.id: v.reason for v in C.check({"metrics": pd.DataFrame({"condition_id": ["c"]})})}
    assert reasons["S1-level"].startswith("the metrics lack events, learner, n_units, noise")


def metrics_row(**values) -> dict:
    row = {"condition_id": "c2", "shape": "chain-2", "n_units": 2, "learner": "thermal", "noise": 0.0,
           "events": "none", "step_size": 0.1, "environment_id": M._default_ground(), "runs": 112, "failed": 0,
           "missing": 0, "final_ubar": 4.0, "u_eq": 4.4, "plateau": True, "steps_to_threshold": 12.0,
           "reached_fraction": 1.0, "acceptance_final": 0.3}
    return {**row, **values}


def test_the_learning_claims_read_the_first_matching_condition():
    metrics = pd.DataFrame([metrics_row(condition_id="noisy", noise=0.5, u_eq=0.0), metrics_row(),
                            metrics_row(condition_id="c3", shape="chain-3", n_units=3, acceptance_final=0.6)])
    runs = pd.DataFrame({"run_id": ["a"], "condition_id": ["c2"], "experiments": ["S1;S9"]})
    found = verdicts({"metrics": metrics, "runs": runs})
    assert found["S1-level"].measured.value == 4.4 and found["S1-level"].holds
    assert found["S1-level"].measured.on == "S1, S9: chain-2 thermal (112 runs)"
    assert found["T-acceptance"].measured.value == 0.6 and not found["T-acceptance"].holds
    flat = verdicts({"metrics": pd.DataFrame([metrics_row(plateau=False)])})
    assert flat["S1-level"].holds is None and "no plateau" in flat["S1-level"].reason


def test_local_maxima_and_bimodality_have_their_textbook_answers():
    assert C.local_maxima(np.array(SAWTOOTH)) == [(4, pytest.approx(9.2))]
    assert [i for i, _ in C.local_maxima(np.array([0, 2, 0, 1, 0, 3, 0.0]))] == [1, 3, 5]
    assert [i for i, _ in C.local_maxima(np.array([0, 2, 0, 0.1, 0, 3, 0.0]))] == [1, 5]  # 0.1 of 3 is too small
    rng = np.random.default_rng(0)
    assert C.bimodality(rng.normal(size=2000)) == pytest.approx(1 / 3, abs=0.03)
    assert C.bimodality(rng.uniform(size=2000)) == pytest.approx(5 / 9, abs=0.03)
    assert C.bimodality(np.r_[rng.normal(0, 0.1, 500), rng.normal(5, 0.1, 500)]) > 0.9
    assert math.isnan(C.bimodality([1.0, 2.0, 3.0]))
