"""A run's steps and pieces tables: their means (records.group_means) against pandas' groupby of the units table."""

import dataclasses
import math

import numpy as np
import pandas as pd
import pytest

from morphbench.experiment.config import load_run_config
from morphbench.experiment.driver import run
from morphbench.experiment.events import parse_events
from morphbench.experiment.records import PIECE_COLUMNS, group_means
from morphbench.params import EnvironmentParams
from tests.conftest import ROOT

PANDAS_3 = int(pd.__version__.split(".")[0]) == 3


def random_groups(rng, rows, units, n_groups, nan, in_order):
    values = rng.normal(size=(rows, units)) * rng.choice([1e-3, 1.0, 1e3], size=units)
    values[rng.random(values.shape) < nan] = np.nan
    groups = rng.integers(-1, n_groups, size=(rows, units))
    if in_order:
        groups.sort(axis=1)
    return values, groups


@pytest.mark.parametrize("nan", [0.0, 0.2])
@pytest.mark.parametrize("in_order", [True, False])
def test_group_means_are_pandas_groupby_means(nan, in_order):
    rng = np.random.default_rng(7)
    values, groups = random_groups(rng, 400, 9, 3, nan, in_order)
    (means,), sizes = group_means((values,), groups, 3)
    row, unit = np.nonzero(groups >= 0)
    long = pd.DataFrame({"row": row, "group": groups[row, unit], "value": values[row, unit]})
    grouped = long.groupby(["row", "group"], sort=True)
    expected = np.full((400, 3), np.nan)
    expected_sizes = np.zeros((400, 3), dtype=np.int64)
    index = grouped.value.mean().index
    rows, which = index.get_level_values(0), index.get_level_values(1)
    expected[rows, which] = grouped.value.mean().to_numpy()
    expected_sizes[rows, which] = grouped.size().to_numpy()
    assert np.array_equal(sizes, expected_sizes)
    entries = [values[r][(groups[r] == g) & ~np.isnan(values[r])] for r, g in zip(rows, which)]
    defined = np.array([len(e) > 0 for e in entries])
    exact = np.array([math.fsum(e) / len(e) for e in entries if len(e)])
    scale = np.array([np.abs(e).sum() / len(e) for e in entries if len(e)])  # rounding is relative to the terms
    assert (np.abs(means[rows, which][defined] - exact) <= 4 * np.finfo(float).eps * scale).all()
    assert np.isnan(means[rows, which][~defined]).all()
    if PANDAS_3:  # the same arithmetic, bit for bit (pandas 3 sums sorted groups without NaN by np.add.reduceat)
        assert np.array_equal(means, expected, equal_nan=True)


def pandas_tables(units: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Per step and per step and piece, the scored units' means as a pandas groupby gives them (what the tables
    were built with before ``group_means``)."""
    living = units[units.u_measured.notna()]

    def scored(keys):
        grouped = living.groupby(keys, sort=True)
        return pd.DataFrame({"n_units": grouped.size(), "ubar": grouped.u_measured.mean(),
                             "ubar_true": grouped.u_true.mean(),
                             "acceptance": grouped.accepted.mean().astype(float)}).reset_index()

    return scored(["step"]), scored(["step", "piece"])[list(PIECE_COLUMNS)]


def test_a_cut_damaged_shuffled_noisy_run_keeps_its_tables_as_pandas_builds_them():
    config = load_run_config(ROOT / "shapes" / "chain-7.toml")
    events = parse_events([{"step": 4, "kind": "cut", "link": 3}, {"step": 8, "kind": "damage", "unit": 2,
                                                                     "mode": "dead"},
                           {"step": 10, "kind": "shuffle", "seed": 3}], "test", 7, 6)
    records = run(dataclasses.replace(config, steps=14, seed=2, events=events,
                                      environment=EnvironmentParams(noise=1.0)))
    units, steps, pieces = records.units(), records.steps(), records.pieces()
    by_step, by_piece = pandas_tables(units)
    assert pieces.piece.nunique() == 2 and units.u_measured.isna().any()
    for column in ("ubar", "ubar_true", "acceptance"):
        assert np.array_equal(steps[column].to_numpy(), by_step[column].to_numpy(), equal_nan=True)
    pd.testing.assert_frame_equal(pieces, by_piece, check_exact=True)
    track = units.assign(cos=np.cos(units.heading_rad), sin=np.sin(units.heading_rad)).groupby("step").mean()
    assert np.array_equal(steps.x_m.to_numpy(), track.x_m.to_numpy())
    assert np.array_equal(steps.y_m.to_numpy(), track.y_m.to_numpy())
