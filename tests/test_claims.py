"""Every claim of morphbench.bench.claims holds on a synthetic suite built to agree with the paper, and fails on a
copy changed in the one way the claim speaks of: no rule holds by construction.

The synthetic suite has the paper suite's experiments (S1, S4-S11 runs; S2, S2-vibration, S3, S3-ground-*, S6-damaged
and S7 scans) with learning curves U(k) = level - (level - u0) exp(-k / k0) plus noise, constant acceptance (changed
at an event), remembered velocities a fixed excess above the true ones, and the tables metrics computes from them.
"""

import math
import re
import zlib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from morphbench.bench import claims as C
from morphbench.bench import metrics as M

DEFAULT = M._default_ground()
AXIS = np.arange(10) / 10
SAWTOOTH = [0.0, 0.5, 1.4, 3.1, 4.6, 0.0, -4.6, -3.1, -1.4, -0.5]
HARDWARE = [0.0, 0.5, 1.5, 3.0, 4.0, 0.0, -3.0, -1.5, 1.0, 0.0]


def bump(at, height, width=0.02):
    """A periodic Gaussian bump on the 10 x 10 grid of (dphi_2, dphi_3)."""
    d2 = (AXIS[:, None] - at[0] + 0.5) % 1 - 0.5
    d3 = (AXIS[None, :] - at[1] + 0.5) % 1 - 0.5
    return height * np.exp(-(d2 ** 2 + d3 ** 2) / width)


def condition(experiments, shape="chain-3", n_units=3, learner="thermal", noise=0.0, step_size=0.1,
              environment="default", environment_id=DEFAULT, **curve):
    spec = {"experiments": experiments, "shape": shape, "n_units": n_units, "learner": learner, "noise": noise,
            "step_size": step_size, "environment": environment, "environment_id": environment_id, "runs": 8,
            "steps": 120, "level": 2.5, "u0": 0.0, "k0": 5.0, "sd": 0.3, "acceptance": 0.3, "excess": 0.5,
            "phase": 0.4, "event": None, "after": None, "acceptance_after": None, "late_acceptance": None,
            "laggard": None, "lagging": 1, "pieces": None}
    spec.update(curve)
    return spec


def base() -> dict:
    s3 = bump((0.4, 0.8), 4.5) + bump((0.8, 0.3), 3.0)
    grounds = {}
    for k in (1, 2, 3):
        grid = s3.copy()
        grid[4, 2] = float(k)  # (0.4, 0.2) depends on the ground, (0.4, 0.8) does not
        grounds[f"S3-ground-{k}"] = grid
    events = {"S5": "friction scale=0.5 bodies=passive", "S5-uniform": "friction scale=0.6",
              "S6": "damage unit=2 mode=open", "S10": "shuffle seed=3",
              "S11": "cut link=3"}
    conditions = {
        "S1": condition("S1", "chain-2", 2, steps=100, level=4.5),
        "T0": condition("S4", environment="uniform", level=2.6, acceptance=0.25),
        "T1": condition("S4", environment="uniform", noise=1.0, level=2.0, acceptance=0.1, excess=1.5),
        "F0": condition("S4", learner="flaky", environment="uniform", level=4.0, acceptance=0.6),
        "F1": condition("S4", learner="flaky", environment="uniform", noise=1.0, level=2.5, acceptance=0.6),
        "TF1": condition("S4", environment="friction-field", environment_id="field", noise=1.0, level=1.5),
        "FF1": condition("S4", learner="flaky", environment="friction-field", environment_id="field", noise=1.0,
                         level=2.0, acceptance=0.6),
        "S7-1": condition("S7", learner="flaky", environment="friction-1", level=3.0, acceptance=0.6),
        "S7-15": condition("S7", learner="flaky", environment="friction-1.5", environment_id="f15", level=1.0,
                           acceptance=0.7),
        "S8": condition("S8", "chain-7", 7, level=2.5, sd=0.6),
    }
    for name, after in (("S5", (1.5, 2.5)), ("S6", (1.0, 2.0))):
        conditions[f"{name}-T"] = condition(name, level=3.0, event=(60, events[name]), after=after[0],
                                            acceptance_after=0.1)
        conditions[f"{name}-F"] = condition(name, learner="flaky", level=3.0, acceptance=0.6,
                                            event=(60, events[name]), after=after[1], acceptance_after=0.6)
    conditions["S5-uniform-T"] = condition("S5-uniform", level=3.0, event=(60, events["S5-uniform"]), after=3.6)
    conditions["S10"] = condition("S10", "chain-7", 7, learner="flaky", level=2.0, event=(60, events["S10"]),
                                  after=2.0)
    conditions["S11"] = condition("S11", "chain-7", 7, learner="flaky", level=2.0, event=(60, events["S11"]),
                                  after=1.5, pieces=(1.5, 1.0))
    for n, level in ((2, 3.0), (3, 2.6), (7, 2.1), (15, 1.75), (20, 1.7)):
        conditions[f"S9-{n}"] = condition("S9", f"chain-{n}", n, level=level, k0=22.0, sd=0.05)
        conditions[f"S9-{n}-s"] = condition("S9", f"chain-{n}", n, step_size=0.025, level=1.2 * level, k0=35.0,
                                            sd=0.05, laggard=0.5)
    scans = {"S2": (2, SAWTOOTH, "default", DEFAULT, "none"),
             "S2-vibration": (2, HARDWARE, "vibration=0.8", "shaken", "none"),
             "S3": (3, s3, "default", DEFAULT, "none"),
             "S7": (3, np.where(s3 > 2.0, 3.0, 0.0), "friction_scale=1.5", "f15", "none"),
             "S6-damaged": (3, bump((0.2, 0.2), 4.0), "default", DEFAULT, "damage unit=2 mode=open"),
             **{name: (3, grid, "friction_field", f"g{name[-1]}", "none") for name, grid in grounds.items()}}
    return {"conditions": conditions, "scans": scans}


def curve(spec, rng) -> tuple[np.ndarray, np.ndarray]:
    """(runs x steps+1) true Ubar and acceptance of a condition."""
    k = np.arange(spec["steps"] + 1)
    level = np.full((spec["runs"], len(k)), float(spec["level"]))
    if spec["laggard"] is not None:
        level[:spec["lagging"]] *= spec["laggard"]  # runs that level off lower
    u = level - (level - spec["u0"]) * np.exp(-k / spec["k0"])
    acceptance = np.full(u.shape, float(spec["acceptance"]))
    if spec["late_acceptance"] is not None:
        acceptance[:, k >= spec["late_acceptance"][0]] = spec["late_acceptance"][1]
    if spec["event"] is not None:
        later = k >= spec["event"][0]
        u[:, later] = spec["after"]
        if spec["acceptance_after"] is not None:
            acceptance[:, later] = spec["acceptance_after"]
    return u + rng.normal(0.0, spec["sd"], u.shape), acceptance


_BUILT: dict = {}
"""the tables of each condition by its content (a changed world rebuilds only what it changed)."""


def build(world) -> dict[str, pd.DataFrame]:
    scans = build_scans(world["scans"])
    best = M.scan_best(scans)
    parts = []
    for name, spec in world["conditions"].items():
        key = (name, repr(sorted(spec.items())))
        if key not in _BUILT:
            _BUILT[key] = build_condition(name, spec)
        runs, steps, units = _BUILT[key]
        ground = (spec["shape"], "quasistatic", spec["environment_id"])
        measured = key + (best.get(ground),)
        if measured not in _BUILT:
            _BUILT[measured] = (M.condition_metrics(steps, runs, scans), M.curves(steps))
        parts.append((runs, steps, units, *_BUILT[measured]))
    tables = {name: pd.concat([part[i] for part in parts], ignore_index=True)
              for i, name in enumerate(("runs", "steps", "units", "metrics", "curves"))}
    return {**tables, "scans": scans}


def build_condition(name: str, spec: dict) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """The runs, steps and units tables of one condition (its own random stream)."""
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    runs, steps, units = [], [], []
    columns = {key: spec[key] for key in ("shape", "n_units", "learner", "noise", "step_size", "environment",
                                          "environment_id")}
    columns.update(shape_id=spec["shape"], physics="quasistatic", steps=spec["steps"],
                   events=f"step {spec['event'][0]} {spec['event'][1]}" if spec["event"] else "none")
    u, acceptance = curve(spec, rng)
    k = np.arange(spec["steps"] + 1)
    for r in range(spec["runs"]):
        run_id = f"{name}-{r}"
        runs.append({"run_id": run_id, "condition_id": name, "experiments": spec["experiments"], **columns,
                     "seed": r, "status": "done"})
        event = np.where(k == spec["event"][0], spec["event"][1], "") if spec["event"] else np.full(len(k), "")
        steps.append(pd.DataFrame({"run_id": run_id, "condition_id": name, **columns, "step": k,
                                   "ubar": u[r] + rng.normal(0.0, spec["noise"], len(k)), "ubar_true": u[r],
                                   "acceptance": acceptance[r], "event": event}))
        n = spec["n_units"]
        piece = np.ones((len(k), n), dtype=int)
        true = np.repeat(u[r][:, None], n, axis=1)
        if spec["pieces"] is not None:
            cut = k >= spec["event"][0]
            piece[cut, 3:] = 2
            true[cut, :3], true[cut, 3:] = spec["pieces"][0], spec["pieces"][1]
        phase = np.zeros((len(k), n))
        phase[:, 1] = spec["phase"]
        places = np.tile(np.arange(1, n + 1), len(k))
        units.append(pd.DataFrame({"run_id": run_id, "step": np.repeat(k, n), "unit": places, "position": places,
                                   "piece": piece.ravel(), "phase_kept": ((0.1 + phase) % 1.0).ravel(),
                                   "u_measured": true.ravel(), "u_true": true.ravel(),
                                   "u_memory": true.ravel() + spec["excess"]}))
    return pd.DataFrame(runs), pd.concat(steps, ignore_index=True), pd.concat(units, ignore_index=True)


def build_scans(specs: dict) -> pd.DataFrame:
    scans = []
    for name, (n, values, environment, ground, damage) in specs.items():
        values = np.asarray(values, dtype=float)
        if n == 2:
            points = pd.DataFrame({"dphi_2": AXIS, "ubar": values})
        else:
            d2, d3 = np.meshgrid(AXIS, AXIS, indexing="ij")
            points = pd.DataFrame({"dphi_2": d2.ravel(), "dphi_3": d3.ravel(), "ubar": values.ravel()})
        scans.append(points.assign(scan_id=name, scan=name, n_units=n, samples=len(points), shape=f"chain-{n}",
                                   shape_id=f"chain-{n}", physics="quasistatic", environment=environment,
                                   environment_id=ground, damage=damage))
    return pd.concat(scans, ignore_index=True)


def changed(**edits):
    """A change of the base world: ``condition=dict`` of fields to set, ``scan=values``."""
    def change(world):
        for key, value in edits.items():
            if key in world["conditions"]:
                world["conditions"][key].update(value)
            else:
                n, _, *rest = world["scans"][key]
                world["scans"][key] = (n, value, *rest)
    return change


def each_s9(step_size: float, **fields):
    def change(world):
        for spec in world["conditions"].values():
            if spec["experiments"] == "S9" and spec["step_size"] == step_size:
                spec.update({k: v(spec) if callable(v) else v for k, v in fields.items()})
    return change


def also(*changes):
    def change(world):
        for one in changes:
            one(world)
    return change


S3_GRID = bump((0.4, 0.8), 4.5) + bump((0.8, 0.3), 3.0)
FAILING = {
    "scan-2-peak": changed(S2=[v * 0.5 for v in SAWTOOTH]),
    "scan-2-peak-at": changed(S2=list(np.roll(SAWTOOTH, 2))),
    "scan-2-trough": changed(S2=[v if v > 0 else 0.3 * v for v in SAWTOOTH]),
    "scan-2-trough-at": changed(S2=list(np.roll(SAWTOOTH, 2))),
    "scan-2-antisymmetric": changed(S2=[0.0, 1.0, 4.6, 1.0, 0.0, -1.0, -4.6, -1.0, 1.5, 0.0]),
    "scan-2-one-optimum": changed(S2=[0.0, 1.0, 4.6, 1.0, 0.0, -1.0, -4.6, -1.0, 1.5, 0.0]),
    "S1-ridge": changed(S1={"level": 3.0}),
    "S1-around-optimum": changed(S1={"level": 3.0}),
    "S1-level": changed(S1={"level": 3.0}),
    "S1-by-step-20": changed(S1={"k0": 30.0}),
    "S1-unimodal": changed(S1={"laggard": 0.2, "lagging": 20, "runs": 40}),
    "S1-gait": changed(S1={"phase": 0.7}),
    "S3-maxima": changed(S3=bump((0.4, 0.8), 4.5)),
    "T-acceptance": changed(T0={"acceptance": 0.6}),
    "S4-thermal-improves": changed(T0={"u0": 4.0}),
    "S4-flaky-level": changed(F0={"level": 2.0}),
    "S4-flaky-acceptance": changed(F0={"acceptance": 0.3}),
    "S4-flaky-steady": changed(F0={"late_acceptance": (71, 0.3)}),
    "S4-flaky-noise-free": changed(F1={"acceptance": 0.3}),
    "S4-thermal-noise-acceptance": changed(T1={"acceptance": 0.25}),
    "S4-thermal-noise-ubar": changed(T1={"level": 3.0}),
    "S4-thermal-memory": changed(T1={"excess": 0.0}),
    "S4-flaky-noise": changed(F1={"level": 1.5}),
    "S4-flaky-field": changed(FF1={"level": 1.0}),
    "S5-flaky-after": changed(**{"S5-F": {"after": 1.0}}),
    "S5-thermal-stops": changed(**{"S5-T": {"acceptance_after": 0.3}}),
    "S5-flaky-accepts": changed(**{"S5-F": {"acceptance_after": 0.3}}),
    "S5-uniform-faster": changed(**{"S5-uniform-T": {"after": 2.5}}),
    "S6-flaky-after": changed(**{"S6-F": {"after": 0.5}}),
    "S6-thermal-stuck": changed(**{"S6-T": {"acceptance_after": 0.3}}),
    "S6-landscape": changed(**{"S6-damaged": S3_GRID}),
    "S7-abrupt": changed(S7=2.0 + 0.5 * np.cos(2 * np.pi * AXIS)[:, None] * np.ones(10)),
    "S7-flaky-resets": changed(**{"S7-15": {"acceptance": 0.5}}),
    "S7-flaky-struggles": changed(**{"S7-15": {"level": 2.5}}),
    "S8-level": changed(S8={"level": 4.0}),
    "S8-below-3": changed(S8={"level": 3.0}),
    "S8-rate": changed(S8={"k0": 30.0}),
    "S8-peaks": changed(S8={"sd": 0.1}),
    "S9-falls": each_s9(0.1, level=lambda spec: 1.0 + spec["n_units"] / 10),
    "S9-levels-off": changed(**{"S9-20": {"level": 1.0}}),
    "S9-asymptote": each_s9(0.1, level=lambda spec: spec["level"] + 1.0),
    "S9-rate-flat": changed(**{"S9-20": {"k0": 8.0}}),
    "S9-35-steps": each_s9(0.1, k0=8.0),
    "S9-small-step-higher": each_s9(0.025, level=lambda spec: spec["level"] / 1.2 * 0.8),
    "S9-small-step-slower": each_s9(0.025, k0=10.0),
    "S9-small-step-misses": each_s9(0.025, laggard=None),
    "S10-relearns": changed(S10={"after": 1.0}),
    "S11-both-learn": changed(S11={"pieces": (1.5, 0.0)}),
    "hw-trough": changed(**{"S2-vibration": [v if v > -2 else -1.0 for v in HARDWARE]}),
    "hw-local-max": changed(**{"S2-vibration": [0.0, 0.5, 1.5, 3.0, 4.0, 0.0, -3.0, -1.5, -0.5, 0.0]}),
    "hw-local-max-at": changed(**{"S2-vibration": [0.0, 0.5, 1.5, 3.0, 4.0, 0.0, -3.0, 1.0, -1.5, 0.0]}),
    "hw-3-gait": changed(S3=bump((0.4, 0.8), 2.0) + bump((0.8, 0.3), 3.0)),
    "hw-3-track": also(*(changed(**{f"S3-ground-{k}": np.where(np.arange(100).reshape(10, 10) == 48, float(k),
                                                                 S3_GRID)}) for k in (1, 2, 3))),
    "hw-damaged-optimum": changed(**{"S6-damaged": bump((0.2, 0.6), 4.0)}),
}


@pytest.fixture(scope="module")
def agreeing() -> dict[str, C.Verdict]:
    return {v.claim.id: v for v in C.check(build(base()))}


def test_every_claim_has_a_table_where_it_fails():
    assert set(FAILING) == {claim.id for claim in C.CLAIMS}
    assert len(C.CLAIMS) >= 25 + 6
    assert sum("(hardware)" not in claim.scenario for claim in C.CLAIMS) >= 25
    assert all(claim.source for claim in C.CLAIMS)


@pytest.mark.parametrize("claim_id", [claim.id for claim in C.CLAIMS])
def test_the_claim_holds_where_the_paper_is_right_and_fails_where_it_is_not(agreeing, claim_id):
    verdict = agreeing[claim_id]
    assert verdict.holds is True, (claim_id, verdict.reason or verdict.measured)
    world = base()
    FAILING[claim_id](world)
    claim = next(c for c in C.CLAIMS if c.id == claim_id)
    failed = C.check(build(world), (claim,))[0]
    assert failed.holds is False, (claim_id, failed.reason or failed.measured)


def test_the_landscape_measures_have_their_textbook_answers():
    two = bump((0.4, 0.8), 4.5) + bump((0.8, 0.3), 3.0)
    found = C.peaks(two)
    assert sorted(at for at, _ in found) == [(4, 8), (8, 3)]
    assert dict(found)[(8, 3)] == pytest.approx(3.0, abs=0.1)  # its saddle with the higher peak is near 0
    assert [at for at, _ in C.peaks(bump((0.1, 0.9), 1.0))] == [(1, 9)]  # wraps at both edges: one peak
    assert C.abruptness(np.where(two > 2, 1.0, 0.0)) == pytest.approx(1.0)
    assert C.abruptness(two) < 0.6
    assert math.isnan(C.abruptness(np.ones((4, 4))))


def test_docs_paper_lists_every_claim_in_order():
    text = (Path(__file__).resolve().parents[1] / "docs" / "paper.md").read_text(encoding="utf-8")
    listed = re.findall(r"^\| ((?:scan-2|S\d+|T|hw)-[\w-]+) \|", text, flags=re.MULTILINE)
    assert listed == [claim.id for claim in C.CLAIMS]


def test_a_suite_too_short_for_a_claim_says_so_instead_of_no(agreeing):
    """Runs that end before learning is done (the smoke suite's 10 steps) measure no claim about learning: each is
    'not measured', saying the suite is too small, never a 'no'; the landscapes' claims are measured as before."""
    world = base()
    for spec in world["conditions"].values():
        spec["steps"] = C.MIN_STEPS - 1
        if spec["event"] is not None:  # the event inside the shorter runs
            spec["event"] = (C.MIN_STEPS // 2, spec["event"][1])
    verdicts = C.check(build(world))
    short = [v for v in verdicts if v.holds is None and "too small a suite" in v.reason]
    assert short and all(v.holds is not False for v in verdicts)
    for verdict in verdicts:
        if verdict.holds is not None:  # what is still measured does not depend on the runs' length
            assert verdict.measured.on.startswith("scan") or "scan" in verdict.measured.on, verdict.claim.id
    assert all(agreeing[v.claim.id].holds is True for v in short)
    from morphbench.bench.report import _claims_section, _duration

    summary = _claims_section(build(world))[4]
    assert summary.endswith(f"not measured; {len(short)} of them because this suite's runs are too short for them).")
    assert (_duration(0.4), _duration(150)) == ("0.4 s", "2.5 min")
