"""Every claim of the hardware twin (morphbench.bench.claims HARDWARE_CLAIMS, checked on the suite
benchmarks/paper-hardware.toml) holds on a synthetic suite built to agree with the paper's experiments, and fails on
a copy changed in the one way the claim speaks of: no rule holds by construction.

The synthetic suite has the hardware suite's experiments (hw-S1, hw-S4, hw-S6, hw-S8 runs) and its scans (hw-S2,
hw-S3 and hw-S6-damaged, each at four places of the track: NAME, NAME-at-1..3), built as tests/test_claims.py builds
the paper suite's (its learning curves, acceptance and scans), with a late fall of Thermal's Ubar where the paper
saw one.
"""

from __future__ import annotations

import copy
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from morphbench.bench import claims as C
from morphbench.bench import metrics as M

from test_claims import AXIS, bump, build_condition, build_scans, condition

PLACES = (-0.15, -0.05, 0.05, 0.15)
"""how far each place of the track lifts the whole 2-unit curve: they average to 0, so the mean is the base."""
CURVE = [0.0, 0.5, 1.5, 3.0, 4.5, 0.0, -3.0, -1.5, -0.5, 1.0]
"""the experiments' 2-unit curve (Fig. 1G-H): 4.5 at 0.4, -3 at 0.6, a local maximum of 1 at 0.9."""
MAP = bump((0.4, 0.8), 4.5) + bump((0.8, 0.3), 3.0)
AT_02, AT_08 = (4, 2), (4, 8)
"""the grid cells of the gaits (0.4, 0.2) and (0.4, 0.8) (AXIS is k / 10)."""
D2, D3 = np.meshgrid(AXIS, AXIS, indexing="ij")
DAMAGED = 2.0 + 2.0 * np.cos(2 * np.pi * (D2 - D3))
"""a damaged landscape whose maximum lies on dphi_2 = dphi_3 and which depends on unit 2's phase."""
FALL_AFTER = 250


def base() -> dict:
    event = (60, "damage unit=2 mode=open")
    conditions = {
        "hw-S1": condition("hw-S1", "chain-2", 2, steps=100, level=4.5, laggard=0.22, lagging=3, noise=0.3),
        "hw-S4-T": condition("hw-S4", steps=600, level=3.0, acceptance=0.5, late_acceptance=(30, 0.02),
                             noise=0.5, fall=1.0),
        "hw-S4-F": condition("hw-S4", learner="flaky", steps=600, level=4.0, acceptance=0.6, noise=0.5),
        "hw-S6-T": condition("hw-S6", level=3.0, event=event, after=1.0, acceptance_after=0.02),
        "hw-S6-F": condition("hw-S6", learner="flaky", level=3.0, acceptance=0.6, event=event, after=2.0,
                             acceptance_after=0.6),
        "hw-S8": condition("hw-S8", "chain-7", 7, steps=300, level=2.5, sd=0.6),
    }
    curves = [[v + lift for v in CURVE] for lift in PLACES]
    maps = [MAP.copy() for _ in PLACES]
    for grid, stop in zip(maps, (0.0, 1.0, 2.0, 2.5)):
        grid[AT_02] = stop  # (0.4, 0.2) stops at the start of the track and goes further on
    return {"conditions": conditions, "curves": curves, "maps": maps, "damaged": [DAMAGED.copy() for _ in PLACES]}


def _names(name: str, n: int) -> list[str]:
    return [name] + [f"{name}-at-{k}" for k in range(1, n)]


def build(world) -> dict[str, pd.DataFrame]:
    specs = {}
    for key, n, damage in (("curves", 2, "none"), ("maps", 3, "none"), ("damaged", 3, "damage unit=2 mode=open")):
        scan = {"curves": "hw-S2", "maps": "hw-S3", "damaged": "hw-S6-damaged"}[key]
        for name, values in zip(_names(scan, len(world[key])), world[key]):
            specs[name] = (n, values, "hardware", f"ground-{name}", damage)
    scans = build_scans(specs)
    parts = []
    for name, spec in world["conditions"].items():
        spec = dict(spec)
        fall = spec.pop("fall", 0.0)
        runs, steps, units = build_condition(name, spec)
        late = steps.step > FALL_AFTER
        steps.loc[late, ["ubar", "ubar_true"]] -= fall  # the experiments' Thermal falls after about 200 steps
        parts.append((runs, steps, units, M.condition_metrics(steps, runs, scans), M.curves(steps)))
    tables = {name: pd.concat([part[i] for part in parts], ignore_index=True)
              for i, name in enumerate(("runs", "steps", "units", "metrics", "curves"))}
    return {**tables, "scans": scans}


def each(key: str, change):
    """A change of every place's scan ``key`` (curves, maps, damaged) by ``change(values, place)``."""
    def apply(world):
        world[key] = [change(values, place) for place, values in enumerate(world[key])]
    return apply


def spec(name: str, **fields):
    def apply(world):
        world["conditions"][name].update(fields)
    return apply


def cell(at, values):
    """Set the grid cell ``at`` of every place's map to its value in ``values``."""
    def change(grid, place):
        grid = grid.copy()
        grid[at] = values[place]
        return grid
    return each("maps", change)


def curve(values):
    return each("curves", lambda old, place: [v + PLACES[place] for v in values])


FAILING = {
    "hw-peak": curve([v * 0.5 if v > 0 else v for v in CURVE]),
    "hw-peak-at": curve(list(np.roll(CURVE, 2))),
    "hw-trough": curve([v if v > -2 else -1.0 for v in CURVE]),
    "hw-trough-at": curve(list(np.roll(CURVE, 2))),
    "hw-local-max": curve(CURVE[:9] + [-0.2]),
    "hw-local-max-at": curve([0.0, 0.5, 1.5, 3.0, 4.5, 0.0, -3.0, 1.0, -1.5, -0.5]),
    "hw-S1-ridge": spec("hw-S1", level=3.0),
    "hw-S1-second-mode": spec("hw-S1", laggard=None),
    "hw-3-gait": each("maps", lambda grid, place: np.where(grid > 4.0, 2.0, grid)),
    "hw-3-maximum-at": each("maps", lambda grid, place: np.where(MAP > 4.0, 2.5, grid) + bump((0.8, 0.3), 1.5)),
    "hw-3-track": lambda world: (cell(AT_02, (1.0, 1.0, 1.0, 1.0))(world), cell(AT_08, (4.5, 3.5, 5.5, 4.5))(world)),
    "hw-3-stops": cell(AT_02, (1.0, 1.5, 2.0, 2.5)),
    "hw-3-goes": cell(AT_02, (0.0, 0.5, 0.2, 0.4)),
    "hw-3-robust": cell(AT_08, (4.5, 4.5, 2.0, 4.5)),
    "hw-thermal-improves": spec("hw-S4-T", u0=4.0),
    "hw-thermal-acceptance": spec("hw-S4-T", late_acceptance=None),
    "hw-thermal-falls": spec("hw-S4-T", fall=0.0),
    "hw-flaky-level": spec("hw-S4-F", level=2.0),
    "hw-flaky-acceptance": spec("hw-S4-F", acceptance=0.3),
    "hw-flaky-ahead": spec("hw-S4-F", level=1.5),
    "hw-damaged-optimum": each("damaged", lambda grid, place: 2.0 + 2.0 * np.cos(2 * np.pi * (D2 - D3 - 0.5))),
    "hw-damaged-phase": each("damaged", lambda grid, place: 2.0 + 2.0 * np.cos(2 * np.pi * D3)),
    "hw-damage-thermal-stuck": spec("hw-S6-T", acceptance_after=0.3),
    "hw-damage-flaky-adapts": spec("hw-S6-F", after=0.5),
    "hw-7-level": spec("hw-S8", level=4.0),
}


@pytest.fixture(scope="module")
def agreeing() -> dict[str, C.Verdict]:
    return {v.claim.id: v for v in C.check(build(base()), C.HARDWARE_CLAIMS)}


def test_the_hardware_claims_are_the_hardware_suites_own():
    ids = [claim.id for claim in C.HARDWARE_CLAIMS]
    assert set(FAILING) == set(ids) and len(ids) == len(set(ids))
    assert all(i.startswith("hw-") and "(hardware)" in c.scenario for i, c in zip(ids, C.HARDWARE_CLAIMS))
    assert all(c.source and c.suite == C.HARDWARE_SUITE for c in C.HARDWARE_CLAIMS)
    assert all(c.suite == "" for c in C.CLAIMS)
    # the six hardware claims of the paper suite, measured here on the preset
    assert {c.id for c in C.CLAIMS if c.id.startswith("hw-")} <= set(ids)
    assert C.claims_for(C.HARDWARE_SUITE) is C.HARDWARE_CLAIMS
    assert all(C.claims_for(name) is C.CLAIMS for name in ("paper", "paper-quick", "smoke", None, ""))
    assert len(C.CLAIMS) == 54  # the paper suite's count, unchanged


@pytest.mark.parametrize("claim_id", [claim.id for claim in C.HARDWARE_CLAIMS])
def test_the_claim_holds_where_the_experiments_agree_and_fails_where_they_do_not(agreeing, claim_id):
    verdict = agreeing[claim_id]
    assert verdict.holds is True, (claim_id, verdict.reason or verdict.measured)
    world = copy.deepcopy(base())
    FAILING[claim_id](world)
    claim = next(c for c in C.HARDWARE_CLAIMS if c.id == claim_id)
    failed = C.check(build(world), (claim,))[0]
    assert failed.holds is False, (claim_id, failed.reason or failed.measured)


def test_claims_about_the_track_need_two_places_of_it():
    world = base()
    for key in ("curves", "maps", "damaged"):
        world[key] = world[key][:1]
    verdicts = {v.claim.id: v for v in C.check(build(world), C.HARDWARE_CLAIMS)}
    for claim_id in ("hw-3-track", "hw-3-stops", "hw-3-goes", "hw-3-robust"):
        assert verdicts[claim_id].holds is None and "places" in verdicts[claim_id].reason
    assert verdicts["hw-3-gait"].holds is True  # one place is a map of its own


def test_the_paper_suites_tables_measure_no_hardware_claim_and_the_report_picks_by_suite():
    from morphbench.bench.report import _claims_section

    tables = build(base())
    assert all(v.holds is None for v in C.check(tables))  # the paper's claims read S1, S2, ...: not here
    summary = _claims_section(tables, C.HARDWARE_SUITE)
    assert f"of {len(C.HARDWARE_CLAIMS)} claims hold" in summary[4] and "hardware twin" in summary[2]
    assert "of 54 claims hold" in _claims_section(tables)[4]
    assert "of 54 claims hold" in _claims_section(tables, "paper")[4]


def test_density_modes_find_both_modes_and_only_significant_ones():
    rng = np.random.default_rng(0)
    two = np.concatenate([rng.normal(4.5, 0.3, 600), rng.normal(1.0, 0.3, 200)])
    modes = C.density_modes(two)
    assert len(modes) == 2 and abs(modes[0][0] - 4.5) < 0.15 and abs(modes[1][0] - 1.0) < 0.15
    assert len(C.density_modes(rng.normal(2.0, 0.5, 800))) == 1
    assert C.density_modes([]) == []


def test_damaged_phase_share_is_zero_when_unit_2s_phase_changes_nothing():
    assert C.damaged_phase_share(2.0 + np.cos(2 * np.pi * D3), AXIS) == pytest.approx(0.0, abs=1e-12)
    assert C.damaged_phase_share(DAMAGED, AXIS) == pytest.approx(1.0)


def test_docs_hardware_lists_every_hardware_claim_in_order():
    text = (Path(__file__).resolve().parents[1] / "docs" / "hardware.md").read_text(encoding="utf-8")
    listed = re.findall(r"^\| (hw-[\w-]+) \|", text, flags=re.MULTILINE)
    assert listed == [claim.id for claim in C.HARDWARE_CLAIMS]
