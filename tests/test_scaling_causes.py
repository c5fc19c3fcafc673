"""benchmarks/scaling_causes.py: why the learners lose the gait as an assembly grows. Its measures on made-up
velocities whose answers are known (the signal-to-interference ratio, the transient's shares and sign errors, the
trial gait's distance), its seeded draws, a chain built in memory like its file, one small run of the whole script
on chain-2, and the page its section goes into."""

from __future__ import annotations

import importlib.util
import math
import sys

import numpy as np
import pandas as pd
import pytest

from morphbench.experiment.scan import grid_places

from conftest import BENCHMARKS_DIR, ROOT


def _script():
    spec = importlib.util.spec_from_file_location("scaling_causes_script", BENCHMARKS_DIR / "scaling_causes.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up by name
    spec.loader.exec_module(module)
    return module


S = _script()


def test_a_unit_s_own_part_is_interpolated_through_its_lone_trials():
    moves = S.lone_moves()
    assert list(moves) == [-0.1, -0.05, 0.05, 0.1]
    changes = 3.0 * moves  # a unit whose own velocity answers its own change linearly
    assert S.own_response(moves, changes, np.array([-0.1, -0.02, 0.0, 0.07])) == pytest.approx([-0.3, -0.06, 0, 0.21])
    # the mean square of k * e over e uniform in (-s, s) is k^2 s^2 / 3
    assert S.signal_power(moves, changes, 0.1) == pytest.approx(9 * 0.01 / 3, rel=1e-3)
    assert S.signal_power(moves, changes, 0.05) == pytest.approx(9 * 0.0025 / 3, rel=1e-3)
    # a bent response is followed through 0, between its nodes only
    bent = np.array([1.0, 0.2, 0.4, 2.0])
    assert S.own_response(moves, bent, np.array([-0.075, 0.025])) == pytest.approx([0.6, 0.2])


def test_the_signal_to_interference_ratio_of_made_up_numbers():
    value, log_se = S.ratio(np.array([2.0, 4.0]), np.array([1.0, -1.0, 2.0, -2.0]))
    assert value == pytest.approx(3.0 / 2.5)
    assert log_se > 0
    assert S.ratio(np.array([1.0]), np.zeros(3))[0] == math.inf  # no interference at all
    assert S.ratio(np.ones(4), np.ones(4)) == (1.0, 0.0)  # no spread: no uncertainty


def _measured(n_units=3, own=2.0, cross=0.5, trials=400, step=0.1, horizon=4, p=0.25, seed=0):
    """A made-up assembly at one base whose units' velocities are linear in the phase changes: a unit's change is
    ``own`` times its own plus ``cross`` times each other's, from cycle 1 on."""
    assembly = S.Assembly("chain", n_units)
    effect = np.full((n_units, n_units), cross) + np.eye(n_units) * (own - cross)  # (unit, changed unit)
    probes = np.arange(n_units)

    def run(changes):  # (K, N) -> (K, H, N)
        return np.repeat((changes @ effect.T)[:, None, :], horizon, axis=1)

    lone = np.zeros((n_units, len(S.lone_moves()), n_units))
    for unit in probes:
        lone[unit, :, unit] = S.lone_moves()
    lone = run(lone.reshape(-1, n_units)).reshape(n_units, len(S.lone_moves()), horizon, n_units)
    joint = {}
    for s in S.SIGNAL_STEPS:
        for regime, moves in S.joint_moves(n_units, trials, s, p, seed, 1).items():
            joint[(s, regime)] = (moves, run(moves))
    return S.BaseMeasured(assembly, 1, probes, np.zeros((horizon, n_units)), lone, joint)


def test_a_linear_assembly_s_signal_and_interference():
    """Each unit's own part is exactly own * its change, the rest cross * the others' changes: the ratio is
    own^2 s^2 / 3 over cross^2 (N - 1) s^2 / 3 when all move, p times that interference when a fraction p does."""
    measured = _measured()
    row = S.summarise_signal([measured], 0.1)
    assert row["own"] == pytest.approx(2.0 * 0.1)  # a lone +-step changes the unit's own velocity by 2 x 0.1
    assert row["ubar"] == pytest.approx((2.0 + 2 * 0.5) / 3 * 0.1)  # and the mean of the three by (2 + 2 x 0.5) / 3
    assert row[("sir", "all", "2")][0] == pytest.approx(4.0 / (0.25 * 2), rel=0.15)
    assert row[("sir", "some", "2")][0] == pytest.approx(4.0 / (0.25 * 2 * 0.25), rel=0.25)
    assert row[("sir", "all", "1-2")][0] == pytest.approx(row[("sir", "all", "2")][0])  # no transient here
    parts = S.base_signal(measured, 0.1)
    drawn, _ = measured.joint[(0.1, "all")]
    others = 0.5 * (drawn.sum(axis=1, keepdims=True) - drawn)
    assert parts["interference"][("all", "2")] == pytest.approx(others.ravel())
    # the settled Ubar of a trial: the mean over units of their changes
    assert parts["du"]["all"] == pytest.approx((drawn @ (np.full((3, 3), 0.5) + 1.5 * np.eye(3)).T).mean(axis=1))
    assert row["distance"]["all"] == pytest.approx(math.sqrt(3 / 3) * 0.1)
    assert row["distance"]["some"] == pytest.approx(math.sqrt(0.25 * 3 / 3) * 0.1)
    assert 0.5 < row[("right", "all", "2")] <= 1.0


def test_a_unit_alone_has_every_sign_right():
    row = S.summarise_signal([_measured(cross=0.0)], 0.05)
    assert row[("sir", "all", "2")][0] == math.inf
    assert row[("right", "all", "2")] == 1.0 and row[("right", "some", "2")] == 1.0


def test_the_transient_s_shares_and_sign_errors():
    settled = np.array([1.0, -2.0, 0.5, -1.0, 0.01])
    own = np.stack([-0.5 * settled, 0.9 * settled, settled, settled], axis=1)  # cycle 1 backwards, cycle 2 short
    assert S.transient_fractions(own, settled) == pytest.approx([-0.5, 0.9, 1.0, 1.0])
    assert S.sign_errors(own[:, 0], settled) == (1.0, 4)  # the tiny last trial is not counted (SIGN_FLOOR)
    assert S.sign_errors(own[:, 1], settled) == (0.0, 4)
    assert S.sign_errors(own[:, 0], settled, floor=0.0) == (1.0, 5)
    assert math.isnan(S.sign_errors(own[:, 0], np.zeros(5))[0])
    assert np.all(np.isnan(S.transient_fractions(own, np.zeros(5))))


def test_windows_of_what_a_unit_measures():
    per_cycle = np.arange(2 * 8 * 3, dtype=float).reshape(2, 8, 3)
    windows = S.windowed(per_cycle)
    assert windows["1"] == pytest.approx(per_cycle[:, 0])
    assert windows["2"] == pytest.approx(per_cycle[:, 1])
    assert windows["1-2"] == pytest.approx(per_cycle[:, :2].mean(axis=1))
    assert windows["settled"] == pytest.approx(per_cycle[:, 6:].mean(axis=1))  # the last quarter of 8 cycles
    own, settled = S.base_transient(_measured(horizon=8))
    assert own.shape == (3 * 4, 8) and settled == pytest.approx(own[:, -1])


def test_the_draws_are_seeded():
    probes = S.probe_units(256, 8, seed=0, base=1)
    assert np.array_equal(probes, S.probe_units(256, 8, seed=0, base=1))
    assert len(set(probes)) == 8 and np.all(np.diff(probes) > 0) and probes.max() < 256
    assert not np.array_equal(probes, S.probe_units(256, 8, seed=0, base=2))
    assert np.array_equal(S.probe_units(5, 8, seed=0, base=1), np.arange(5))  # every unit of a small assembly
    moves = S.joint_moves(1000, 20, 0.1, 0.25, seed=3, base=0)
    again = S.joint_moves(1000, 20, 0.1, 0.25, seed=3, base=0)
    assert all(np.array_equal(moves[k], again[k]) for k in S.REGIMES)
    assert np.abs(moves["all"]).max() <= 0.1
    tried = moves["some"] != 0
    assert np.array_equal(moves["some"][tried], moves["all"][tried])  # the same draws where a unit tries
    assert tried.mean() == pytest.approx(0.25, abs=0.02)
    assert not np.array_equal(moves["all"], S.joint_moves(1000, 20, 0.1, 0.25, seed=3, base=1)["all"])
    assert not np.array_equal(moves["all"][:, :5], S.joint_moves(1000, 20, 0.05, 0.25, seed=3, base=0)["all"][:, :5])


def test_the_bases_a_wave_and_seeded_random_phases():
    sheet = S.BY_NAME["sheet-4x4"]
    wave = S.base_phases(sheet, 0, seed=0, lag=0.25)
    columns, _ = grid_places(S.shape_of(sheet.name))
    assert wave == pytest.approx(np.mod(0.25 * columns, 1.0))
    random = S.base_phases(sheet, 1, seed=0, lag=0.25)
    assert np.array_equal(random, S.base_phases(sheet, 1, seed=0, lag=0.4))
    assert not np.array_equal(random, S.base_phases(sheet, 2, seed=0, lag=0.25))
    assert random.shape == (16,) and np.all((random >= 0) & (random < 1))


def test_every_assembly_of_the_study_has_its_morphology_file():
    """Chains from the library or the benchmarks' own shapes (50 and 100 units), sheets from benchmarks/shapes/."""
    for assembly in S.ASSEMBLIES:
        assert assembly.path.is_file(), assembly.name
        assert S.shape_of(assembly.name).n_units == assembly.n_units


def test_a_run_s_level_and_a_learner_s_shares():
    steps = pd.DataFrame({"step": np.arange(31), "ubar_true": np.r_[np.zeros(21), np.ones(10)]})
    assert S.level(steps, 30) == 1.0  # the last third: steps 21-30
    rows = S.summarise_learning({0.05: [1.0, 3.0], 0.1: [2.0, float("nan")], 0.2: [4.0]}, wave=4.0)
    assert rows[0.05]["share"] == 0.5 and rows[0.05]["share_se"] == pytest.approx(0.25)
    assert rows[0.1]["runs"] == 1 and rows[0.1]["failed"] == 1
    assert S.best_step(rows) == 0.2


def test_every_assembly_of_the_study_has_its_seeds_and_cost():
    assert [a.name for a in S.ASSEMBLIES] == [f"chain-{n}" for n in (2, 5, 10, 20, 50, 100)] + \
        [f"sheet-{n}x{n}" for n in (2, 4, 8, 16, 32)]
    for plan in (S.FULL, S.QUICK):
        assert set(plan.seeds) == set(S.BY_NAME) and min(plan.seeds.values()) >= 1
    assert 0 < S.estimate(S.QUICK, list(S.ASSEMBLIES)) < S.estimate(S.FULL, list(S.ASSEMBLIES))


def _page(path):
    path.write_text(f"# A page\n\n{S.BEGIN}\nold\n{S.END}\n\nThe end.\n")
    return path


def test_the_script_on_chain_2(tmp_path, capsys):
    """The whole script, quick, on the smallest assembly with one worker: the four tables and figures, written
    between the markers."""
    page = _page(tmp_path / "page.md")
    assert S.main(["--quick", "--shapes", "chain-2", "--doc", str(page)]) == 0
    text = page.read_text()
    assert text.startswith("# A page") and text.endswith("The end.\n") and "old" not in text
    for title in ("(a) Signal", "(b) The trial gait", "(c) The transient", "(d) U_eq against the step size"):
        assert f"### {title}" in text
    for name, _, _ in S.FIGURES:
        assert f"(media/{name})" in text and (tmp_path / "media" / name).stat().st_size > 1000
    assert "| chain-2 | 2 | wave | 0.05 |" in text and "| chain-2 | 2 | sparse | 1 |" in capsys.readouterr().out
    assert "`python benchmarks/scaling_causes.py --quick --shapes chain-2 --seed 0`" in text


def test_a_page_without_the_markers_is_refused_before_measuring(tmp_path, capsys):
    page = tmp_path / "page.md"
    page.write_text("no markers\n")
    assert S.main(["--quick", "--shapes", "chain-2", "--doc", str(page)]) == 2
    assert "markers" in capsys.readouterr().err and page.read_text() == "no markers\n"
    assert not (tmp_path / "media").exists()


def test_the_docs_page_holds_the_section_and_the_index_links_it():
    page = (ROOT / "docs" / "scaling.md").read_text(encoding="utf-8")
    assert page.index(S.BEGIN) < page.index(S.END)
    assert "python benchmarks/scaling_causes.py --workers 2" in page
    assert "(scaling.md)" in (ROOT / "docs" / "README.md").read_text(encoding="utf-8")
