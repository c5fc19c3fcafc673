"""The assembly's track in steps.parquet (centroid, heading, velocity along it), the turning rate, and the figures
and report columns built from them. Runs are a few steps of fixed gaits on the quasi-static default physics."""

from __future__ import annotations

import dataclasses
import json
import math
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from morphbench.bench import build_report
from morphbench.experiment.records import turning_rate
from morphbench.bench.store import Store
from morphbench.cli import main
from morphbench.experiment import RunConfig, run
from morphbench.experiment.records import RunRecords
from morphbench.params import LearnerParams
from morphbench.shapes import load_shape, shape_from_table

from conftest import SHAPES_DIR as SHAPES
CHAIN_2 = load_shape(SHAPES / "chain-2.toml")
TRACK_COLUMNS = ["x_m", "y_m", "heading_rad", "u_heading"]
FORWARD, BACKWARD = [0.0, 0.4], [0.0, 0.6]  # a 2-unit row's gaits (tests/test_planar.py)


class Gait:
    """A plug-in learner that plays a fixed sequence of phases, one per learning step, and accepts nothing. Set
    ``Gait.plan`` (one sequence per unit) before a run: instances are made in unit order and each takes the next."""

    plan: list[list[float]] = []

    def __init__(self, params, rng):
        self.sequence = Gait.plan.pop(0)
        self.phase, self.step = self.sequence[0], 0

    def propose(self):
        self.step += 1
        return self.sequence[self.step % len(self.sequence)]

    def update(self, velocity):
        return False


def gait_run(shape, plan: list[list[float]], steps: int = 6, discard: int = 0) -> RunRecords:
    Gait.plan = [list(sequence) for sequence in plan]
    return run(RunConfig(shape=shape, learner=f"{__name__}:Gait", steps=steps,
                         learner_params=LearnerParams(discard_cycles=discard)))


def grid_2x2():
    return shape_from_table({"assembly": {"generator": "grid", "rows": 2, "columns": 2, "dummy": True}}, source="test")


# unit 2 changes its phase every step, so the speed changes from step to step (and differs from Ubar where a cycle is
# discarded after each change: Ubar leaves it out)
CRAWL = [[0.0], [0.4, 0.3, 0.45]]


def test_a_crawling_chain_is_scored_by_its_centroid_along_x():
    records = gait_run(CHAIN_2, CRAWL)
    steps, units = records.steps(), records.units()
    assert list(steps.columns[-4:]) == TRACK_COLUMNS
    centroid = units.groupby("step")[["x_m", "y_m"]].mean()
    assert np.allclose(steps[["x_m", "y_m"]], centroid, rtol=0, atol=1e-15)
    cycles = np.diff(steps.time_s) / CHAIN_2.actuator.cycle_time
    by_hand = np.diff(centroid.x_m) * 1000.0 / cycles
    assert math.isnan(steps.u_heading.iloc[0])
    assert np.allclose(steps.u_heading.iloc[1:], by_hand, rtol=1e-12, atol=0)
    assert (by_hand > 1.0).all() and np.ptp(by_hand) > 0.1  # it crawls forward, at speeds that vary
    # with no discarded cycle (the default) a step's window is the whole step: the centroid's speed is Ubar's
    assert np.allclose(steps.u_heading.iloc[1:], steps.ubar_true.iloc[1:], rtol=1e-9, atol=1e-12)
    discarding = gait_run(CHAIN_2, CRAWL, discard=1).steps()
    assert not np.allclose(discarding.u_heading.iloc[1:], discarding.ubar_true.iloc[1:])
    assert np.abs(steps.heading_rad).max() < 1e-9
    summary = records.summary()
    assert summary["turning_rate_deg_per_cycle"] == 0.0
    assert summary["final_u_heading"] == pytest.approx(by_hand[-1])  # the last 10% of 6 steps is the last step


def test_scoring_the_chain_backwards_flips_the_sign_of_u_heading():
    forward = gait_run(CHAIN_2, CRAWL).steps()
    backward = gait_run(dataclasses.replace(CHAIN_2, heading=(-1.0, 0.0, 0.0)), CRAWL).steps()
    assert np.allclose(backward.heading_rad, np.pi, rtol=0, atol=1e-9)
    assert np.allclose(backward.u_heading.iloc[1:], -forward.u_heading.iloc[1:], rtol=1e-12, atol=0)
    pd.testing.assert_frame_equal(backward[["x_m", "y_m"]], forward[["x_m", "y_m"]])  # the same motion


def synthetic_records(rate_deg: float, heading=(1.0, 0.0, 0.0), n_steps: int = 12) -> RunRecords:
    """Two units turning together at ``rate_deg`` per cycle, 0.6 rad apart, headings wrapped into (-pi, pi] as the
    run loop records them: they cross pi at different steps. Step 0 is off the line (turning_rate leaves it out)."""
    shape = dataclasses.replace(CHAIN_2, heading=heading)
    records = RunRecords(RunConfig(shape=shape))
    cycle = shape.actuator.cycle_time
    for step in range(n_steps):
        time_s = 3 * cycle * (step + 1)
        centre = math.radians(150 + rate_deg * time_s / cycle) - (0.5 if step == 0 else 0.0)
        wrapped = np.angle(np.exp(1j * (centre + np.array([-0.3, 0.3]))))
        records.add_step(step, time_s, np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(2, bool),
                         np.array([1, 2]), np.array([1, 1]), np.zeros((2, 2)), wrapped)
    return records


def test_turning_rate_is_the_slope_of_the_unwrapped_heading():
    rate = 7.5  # deg per cycle: 22.5 degrees a step, past 180 degrees by step 2
    records = synthetic_records(rate)
    steps = records.steps()
    assert records.units().heading_rad.abs().max() <= np.pi
    assert steps.heading_rad.max() > np.pi + 1.0  # unwrapped: runs on past pi
    assert np.allclose(np.diff(steps.heading_rad.iloc[1:]), math.radians(3 * rate), rtol=1e-12, atol=0)
    assert turning_rate(steps, CHAIN_2.actuator.cycle_time) == pytest.approx(rate, rel=1e-9)
    assert records.summary()["turning_rate_deg_per_cycle"] == pytest.approx(rate, rel=1e-9)
    assert math.isnan(turning_rate(steps.iloc[:2], CHAIN_2.actuator.cycle_time))  # one learning step


def test_a_heading_off_the_ground_has_no_heading_turning_rate_or_u_heading():
    records = synthetic_records(7.5, heading=(0.0, 0.0, 1.0))
    steps = records.steps()
    assert steps.heading_rad.isna().all() and steps.u_heading.isna().all()
    assert steps[["x_m", "y_m"]].notna().all().all()
    summary = records.summary()
    assert math.isnan(summary["turning_rate_deg_per_cycle"]) and math.isnan(summary["final_u_heading"])


def test_a_grid_whose_sides_disagree_records_its_turn():
    """Row 1 (the left side) runs the forward gait and row 2 the backward one: the grid turns clockwise (as in
    tests/test_planar.py); swapping the sides turns it the other way."""
    left = gait_run(grid_2x2(), [[p] for p in FORWARD + BACKWARD])
    right = gait_run(grid_2x2(), [[p] for p in BACKWARD + FORWARD])
    for records, sign in ((left, -1), (right, 1)):
        steps = records.steps()
        change = steps.heading_rad.iloc[-1] - steps.heading_rad.iloc[1]
        rate = records.summary()["turning_rate_deg_per_cycle"]
        assert np.sign(rate) == np.sign(change) == sign
        assert abs(rate) > 0.1  # deg per cycle
        cycles = (steps.time_s.iloc[-1] - steps.time_s.iloc[1]) / grid_2x2().actuator.cycle_time
        assert rate == pytest.approx(math.degrees(change) / cycles, rel=1e-6)  # it turns steadily
        # u_heading projects each step's displacement on the heading at the step before
        heading = steps.heading_rad.to_numpy()[:-1]
        along = np.diff(steps.x_m) * np.cos(heading) + np.diff(steps.y_m) * np.sin(heading)
        by_hand = 1000.0 * along / (np.diff(steps.time_s) / grid_2x2().actuator.cycle_time)
        assert np.allclose(steps.u_heading.iloc[1:], by_hand, rtol=1e-12, atol=0)
    assert left.summary()["turning_rate_deg_per_cycle"] == pytest.approx(
        -right.summary()["turning_rate_deg_per_cycle"], rel=1e-6)


def test_the_suite_tables_and_report_carry_the_track(reference, tmp_path):
    _, results, outcome = reference
    out = tmp_path / "results"
    shutil.copytree(results, out)
    runs, steps = outcome.tables["runs"], outcome.tables["steps"]
    assert {"final_u_heading", "turning_rate_deg_per_cycle"} <= set(runs.columns)
    assert list(steps.columns[-4:]) == TRACK_COLUMNS and steps.x_m.notna().all()
    summary = json.loads((out / "runs" / runs.run_id.iloc[0] / "result.json").read_text())["summary"]
    assert runs.final_u_heading.iloc[0] == pytest.approx(summary["final_u_heading"])
    report = build_report(out).read_text()
    table_header = next(line for line in report.splitlines() if line.startswith("| learner"))
    assert "| U along heading | turning rate (deg/cycle) |" in table_header
    assert "![trajectories](figures/pair-trajectories.png)" in report
    assert (out / "figures" / "pair-trajectories.png").read_bytes().startswith(b"\x89PNG")
    metrics = pd.read_parquet(out / "metrics.parquet")
    assert (metrics.turning_rate == 0).all()  # chains do not turn
    means = runs.groupby("condition_id", sort=False).final_u_heading.mean()
    assert np.allclose(metrics.set_index("condition_id").final_u_heading.loc[means.index], means)


def test_a_store_of_runs_from_before_the_track_still_reports(reference, tmp_path):
    """Runs stored before steps.parquet had the track and summaries its values (a store being resumed) are
    consolidated with NaN there and left out of the trajectories; with none left, there is no trajectory figure."""
    _, results, _ = reference
    out = tmp_path / "results"
    shutil.copytree(results, out)
    run_dirs = sorted((out / "runs").iterdir())
    for run_dir in run_dirs:  # each run's rows back in its own directory, as a store being resumed holds them
        Store(out).restore(run_dir.name)
    for run_dir in run_dirs[1:]:
        make_old(run_dir)
    tables = Store(out).consolidate()
    runs = tables["runs"].set_index("run_id")
    assert runs.final_u_heading.notna().sum() == 1 and runs.final_u_heading[run_dirs[0].name] == pytest.approx(
        json.loads((run_dirs[0] / "result.json").read_text())["summary"]["final_u_heading"])
    assert tables["steps"].groupby("run_id").x_m.apply(lambda x: x.notna().all()).sum() == 1
    assert "pair-trajectories.png" in build_report(out).read_text()
    Store(out).restore(run_dirs[0].name)  # the report's consolidation took its rows in again
    make_old(run_dirs[0])
    report = build_report(out).read_text()
    assert "U along heading" in report and "![trajectories]" not in report
    assert not (out / "figures" / "pair-trajectories.png").exists()


def make_old(run_dir: Path) -> None:
    """The run directory as it was written before the track existed."""
    steps = pd.read_parquet(run_dir / "steps.parquet")
    steps.drop(columns=TRACK_COLUMNS).to_parquet(run_dir / "steps.parquet", index=False)
    result = json.loads((run_dir / "result.json").read_text())
    for key in ("final_u_heading", "turning_rate_deg_per_cycle"):
        result["summary"].pop(key)
    (run_dir / "result.json").write_text(json.dumps(result))


def test_morphbench_run_writes_the_trajectory_figure(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", str(SHAPES / "chain-2.toml"), "--steps", "3", "--out", str(out), "--quiet"]) == 0
    assert "trajectory.png" in capsys.readouterr().out
    assert (out / "trajectory.png").read_bytes().startswith(b"\x89PNG")
    steps = pd.read_parquet(out / "steps.parquet")
    assert list(steps.columns[-4:]) == TRACK_COLUMNS and steps.x_m.notna().all()
