"""benchmarks/credit.py: a unit's own share of what it measures. The estimator on made-up velocities whose answers are
known, one measurement of a real chain (deterministic; a shift of every phase is a shift of time), and a page without
the section's markers refused before anything is measured."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from conftest import BENCHMARKS_DIR, SHAPES_DIR


def _script():
    spec = importlib.util.spec_from_file_location("credit_script", BENCHMARKS_DIR / "credit.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _moves(trials: int, units: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.vstack([np.zeros(units), rng.uniform(-0.1, 0.1, size=(trials, units))])


def test_own_share_is_one_half_for_a_phase_difference_and_zero_for_an_unrelated_unit():
    share = _script().own_share
    moves = _moves(4000, 3)
    # unit 1 and 2 respond to their phase difference only; unit 3 to nothing of its own (unit 1's trial)
    velocities = np.stack([2.0 * (moves[:, 1] - moves[:, 0]), -0.5 * (moves[:, 1] - moves[:, 0]), 3.0 * moves[:, 0]],
                          axis=1) + 1.0
    shares = share(moves, velocities)
    assert shares[:2] == pytest.approx([0.5, 0.5], abs=0.03)
    assert abs(shares[2]) < 0.01
    # a unit that answers its own trial alone explains all of its change (less the unrelated mean, 1 / (K - 1))
    assert share(moves[:50], 4.0 * moves[:50])[0] == pytest.approx(1.0 - 1.0 / 48)


def test_unrelated_velocities_average_no_share():
    moves = _moves(40, 500, seed=1)
    noise = np.random.default_rng(2).normal(size=moves.shape)
    assert abs(_script().own_share(moves, noise).mean()) < 0.005  # r^2's mean without relation, 1 / 39, removed


def test_a_chain_measures_the_same_twice_and_a_common_phase_shift_leaves_its_gait():
    from morphbench.shapes import load_shape

    script = _script()
    shape = load_shape(SHAPES_DIR / "chain-2.toml")
    phases, trial = np.array([0.0, 0.3]), np.array([0.05, -0.02])
    first = script.step_velocities(shape, phases, trial, settle=2)
    assert first.shape == (2, 2)
    assert np.array_equal(first, script.step_velocities(shape, phases, trial, settle=2))
    assert np.all(np.abs(first) > 0.1)  # the chain moves (mm/cycle)
    # both phases moved alike: the same gait shifted in time, so the cycles after the step measure the same velocity
    shifted = script.step_velocities(shape, phases, np.array([0.07, 0.07]), settle=2)
    still = script.step_velocities(shape, phases, np.zeros(2), settle=2)
    assert shifted[1] == pytest.approx(still[1], abs=0.005 * np.abs(still[1]).max())


def test_a_page_without_the_markers_is_refused_before_measuring(tmp_path, capsys):
    page = tmp_path / "page.md"
    page.write_text("no markers here\n")
    assert _script().main(["--bases", "1", "--trials", "3", "--doc", str(page)]) == 2
    assert "markers" in capsys.readouterr().err
    assert page.read_text() == "no markers here\n"
    assert not (tmp_path / "media").exists()
