"""Scans of a damaged assembly and the scans of an experiment.

One tiny suite on the quasi-static backend (runs of 10-16 steps, scans of 4 x 4 and 10 points) is run once for the
module, in this process.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from morphbench.bench import load_suite, metrics as M, run_suite
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
