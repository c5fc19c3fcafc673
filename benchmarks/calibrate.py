"""Calibration against the paper's whole simulation study: a parameter set scored on its findings.

    python benchmarks/calibrate.py [--seeds 16] [--trials 40] [--seed 0] [--out docs/calibration.md]
    python benchmarks/calibrate.py --evaluate --start tau_inflate=0.7 tau_vent=0.1 stroke=0.014 temperature=0.5
    python benchmarks/calibrate.py --targets hardware [--seeds 8] [--trials 40] [--workers 2]
    python benchmarks/calibrate.py --targets hardware --evaluate --start vibration=0.75 noise=0.8
    python benchmarks/calibrate.py --targets hardware --ablation --seeds 56
    python benchmarks/calibrate.py --targets hardware --ablation --scans-only --workers 1

The paper does not give its model's parameters. What it leaves open, and what a pneumatic unit of its size could
have (the ranges of ``SPACE``), is searched with CMA-ES (the ``cma`` package the project already uses for its
centralized baseline), on the quasi-static backend with the ideal sensor, at reduced seeds, with the paper's
protocol (``cycles_per_step`` = 2, no discarded cycle). Every candidate is the same physics for every scenario: no
parameter is set per scenario.

Each finding (``FINDINGS``) is measured the way the paper measures it and scored by how far it is from holding
(0 when it holds); a candidate's score is the sum, so the search trades findings against each other and the report
says which hold for each candidate. ``--evaluate`` scores the ``--start`` parameter set alone and prints its findings.

``--targets hardware`` calibrates the environment preset ``hardware`` (params.HARDWARE_ENVIRONMENT) against the
paper's experiments instead: it searches only the effects' parameters (``HARDWARE_SPACE``: pump vibration, the
friction field's amplitude and length, the measurement noise, the clocks' drift), never the learners or the
physics of the defaults. A candidate is the hardware suite (benchmarks/paper-hardware.toml) with those fields set in
every experiment's and scan's environment, at ``--seeds`` seeds per condition, run through the bench (``--workers``
processes) into a temporary directory, and scored on the suite's own claims (claims.HARDWARE_CLAIMS, as its report
measures them): each claim's distance from holding (``claim_distance``, capped), summed (``hardware_score``).
``--ablation`` evaluates the ``--start`` candidate and the same with each effect switched off alone (``ABLATIONS``)
and prints docs/hardware.md's ablation table: which finding needs which effect.
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import math
import os
import platform
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

from morphbench.experiment.driver import run_batch  # noqa: E402
from morphbench.experiment.events import DamageEvent, FrictionEvent  # noqa: E402
from morphbench.experiment.run import RunConfig  # noqa: E402
from morphbench.experiment.scan import scan  # noqa: E402
from morphbench.bench.claims import WINDOW  # noqa: E402
from morphbench.bench.metrics import LEARNED_AFTER, fit_exponential, ridge  # noqa: E402
from morphbench.params import (  # noqa: E402
    HARDWARE_ENVIRONMENT,
    MIN_FRICTION_INERTIA,
    EnvironmentParams,
    LearnerParams,
    SensorParams,
    friction_inertia,
)
from morphbench.shapes.loader import load_shape  # noqa: E402


@dataclass(frozen=True)
class Bound:
    low: float
    high: float
    log: bool
    why: str


SPACE: dict[str, Bound] = {
    "tau_inflate": Bound(0.1, 1.5, True, "s: a small diaphragm pump fills a bellows of a few cm^3 in 0.1-1.5 s"),
    "tau_vent": Bound(0.05, 1.0, True, "s: the needle vents the bellows in 0.05-1 s"),
    "stroke": Bound(0.005, 0.025, False, "m: a bellows of a 60 mm unit extends 5-25 mm"),
    "temperature": Bound(0.1, 2.0, True, "mm/cycle: the learners' T (the paper gives no value)"),
    "dummy_friction": Bound(0.5, 1.0, False, "the dummy's Coulomb coefficient against the units' 0.5"),
    "open_stiffness": Bound(5.0, 150.0, True, "N/m: a bellows open to the air (S6's removed needle) resists with its "
                            "elastomer wall alone, softer than the 300 N/m of one holding air"),
}
"""What the paper leaves open and the range a real unit could have."""

BASE = {"tau_inflate": 0.3, "tau_vent": 0.3, "stroke": 0.0105, "temperature": 0.5, "dummy_friction": 0.7,
        "open_stiffness": 30.0}
"""The defaults before this calibration (params.py of 2026-12-01)."""

PROTOCOL = {"cycles_per_step": 2, "discard_cycles": 0}
"""The paper's learning step: 2 cycles measured, none discarded (``--discard`` changes the second)."""

EVENT_STEP = 100
"""the step of S5's and S6's events in the runs here (300 in the paper suite, whose runs are longer)."""
S6_DAMAGE = "open"
"""S6: the paper removes unit 2's venting needle (benchmarks/paper.toml)."""
S5_DROP = FrictionEvent(step=EVENT_STEP, scale=0.5, bodies="passive")
"""S5: the dummy's friction halves (benchmarks/paper.toml; docs/paper.md says why not every body's)."""


def shape(n: int, candidate: dict):
    base = load_shape(ROOT / "shapes" / f"chain-{n}.toml")
    actuator = dataclasses.replace(base.actuator, tau_inflate=candidate["tau_inflate"],
                                   tau_vent=candidate["tau_vent"], stroke=candidate["stroke"],
                                   open_stiffness=candidate["open_stiffness"])
    bodies = tuple(dataclasses.replace(b, friction=candidate["dummy_friction"]) if b.dummy else b for b in base.bodies)
    return dataclasses.replace(base, actuator=actuator, bodies=bodies)


def runs(candidate: dict, n: int, learner: str, seeds: int, steps: int, events=(), noise: float = 0.0,
         step_size: float = 0.1):
    """The per-step tables (step, ubar_true, acceptance) of ``seeds`` runs of one condition, run as one batch."""
    params = LearnerParams(temperature=candidate["temperature"], step_size=step_size, **PROTOCOL)
    configs = [RunConfig(shape=shape(n, candidate), learner=learner, learner_params=params,
                         sensor=SensorParams(kind="ideal"), environment=EnvironmentParams(noise=noise),
                         events=tuple(events), steps=steps, seed=seed) for seed in range(seeds)]
    tables = []
    for records in run_batch(configs):
        if isinstance(records, BaseException):
            raise records
        tables.append(records.steps())
    return tables


def curve(tables, column: str = "ubar_true") -> np.ndarray:
    return np.mean([t[column].to_numpy() for t in tables], axis=0)


@dataclass
class Finding:
    name: str
    statement: str
    measure: Callable[[dict], tuple[float, float]]
    """candidate's measured tables -> (value, distance from holding, 0 if it holds)."""


def measure_all(candidate: dict, seeds: int) -> dict:
    """Every table the findings read, for one candidate."""
    m: dict = {}
    m["curve"] = scan(shape(2, candidate), 40).ubar.to_numpy()
    m["s1"] = runs(candidate, 2, "thermal", seeds, 100)
    for learner in ("thermal", "flaky"):
        m[f"s4-{learner}"] = runs(candidate, 3, learner, seeds, 200)
        m[f"noise-{learner}"] = runs(candidate, 3, learner, seeds, 200, noise=1.0)
        m[f"s6-{learner}"] = runs(candidate, 3, learner, seeds, 200,
                                  events=[DamageEvent(step=EVENT_STEP, unit=2, mode=S6_DAMAGE)])
        m[f"s5-{learner}"] = runs(candidate, 3, learner, seeds, 200, events=[S5_DROP])
    for n in (15, 20):
        m[f"s9-{n}"] = runs(candidate, n, "thermal", max(4, seeds // 2), 200)
    return m


def ceiling(u: np.ndarray, step_size: float = 0.1) -> float:
    """The best expected trial Ubar over kept phase differences, over the peak: both units perturb by uniform(-1, 1)
    x ``step_size``, so a trial's phase difference spreads as a triangle of half-width 2 ``step_size`` around the
    kept one (``u``: the curve at evenly spaced phase differences)."""
    n = len(u)
    offsets = np.arange(-n // 2, n // 2) / n
    kernel = np.clip(1 - np.abs(offsets) / (2 * step_size), 0, None)
    kernel /= kernel.sum()
    expected = [sum(kernel[j] * u[(i + j - n // 2) % n] for j in range(n)) for i in range(n)]
    return float(max(expected) / u.max())


def _off(excess: float) -> float:
    """How far a finding is from holding, given by how much a measure exceeds its bound; a measure that could not
    be made (NaN) never holds."""
    return float("inf") if math.isnan(excess) else max(0.0, excess)


def _after(tables, column, first, last=None):
    return float(np.mean([t[column].to_numpy()[first:last].mean() for t in tables]))


def _s1(m):
    """S1's per-step Ubar of every run after the learning the paper calls done (Fig. 1F), as the claims take it."""
    return np.concatenate([t.ubar_true.to_numpy()[t.step.to_numpy() > LEARNED_AFTER] for t in m["s1"]])


def _lead(m, event: str) -> float:
    """Flaky's Ubar minus Thermal's from the event on (steps EVENT_STEP on), as the claims measure it."""
    return (_after(m[f"{event}-flaky"], "ubar_true", EVENT_STEP)
            - _after(m[f"{event}-thermal"], "ubar_true", EVENT_STEP))


def _freeze(m) -> float:
    """Thermal's acceptance over the WINDOW steps from the damage on over that of the WINDOW steps before it."""
    tables = m["s6-thermal"]
    before = _after(tables, "acceptance", EVENT_STEP - WINDOW, EVENT_STEP)
    return _after(tables, "acceptance", EVENT_STEP, EVENT_STEP + WINDOW) / max(1e-9, before)


def _ueq(tables) -> float:
    """U_eq of the fit to the seed-averaged curve; NaN where the curve has no plateau in the window (an extrapolated
    U_eq says little)."""
    fit = fit_exponential(np.arange(len(tables[0])), curve(tables))
    return float(fit["u_eq"]) if fit.get("plateau", True) else float("nan")


FINDINGS = [
    Finding("curve-peak", "2 units: the curve's peak is about 4.5 mm/cycle at a phase difference of about 0.4",
            lambda m: (float(m["curve"].max()), max(0.0, abs(m["curve"].max() - 4.5) - 0.5)
                       + max(0, abs(np.argmax(m["curve"]) / 40 - 0.4) - 0.05) * 10)),
    Finding("s1-ceiling", "2 units: some kept phase difference gives trials of at least 0.75 of the peak on average "
            "(what S1's mean needs)", lambda m: (ceiling(m["curve"]), max(0.0, 0.75 - ceiling(m["curve"])) * 4)),
    Finding("s1-ridge", "S1: the per-step Ubar after step 20 is distributed around 4.5 (its ridge, as the claims "
            "measure it: 4.5 +- 0.5)",
            lambda m: (ridge(_s1(m)), max(0.0, abs(ridge(_s1(m)) - 4.5) - 0.5))),
    Finding("s1-mean", "S1: the mean per-step Ubar after step 20 is at least 0.75 of the curve's peak",
            lambda m: (float(_s1(m).mean() / m["curve"].max()),
                       max(0.0, 0.75 - _s1(m).mean() / m["curve"].max()) * 4)),
    Finding("s4-acceptance", "3 units, no noise: Thermal accepts about 25% of trials once learned (0.2-0.3)",
            lambda m: (_after(m["s4-thermal"], "acceptance", 50),
                       max(0.0, abs(_after(m["s4-thermal"], "acceptance", 50) - 0.25) - 0.05) * 10)),
    Finding("s4-flaky", "3 units: Flaky reaches about 4 mm/cycle (at least 3)",
            lambda m: (_after(m["s4-flaky"], "ubar_true", 150),
                       max(0.0, 3.0 - _after(m["s4-flaky"], "ubar_true", 150)))),
    Finding("noise", "3 units, noise sigma 1.0: Flaky at least as fast as Thermal",
            lambda m: (_after(m["noise-flaky"], "ubar_true", 150) - _after(m["noise-thermal"], "ubar_true", 150),
                       max(0.0, _after(m["noise-thermal"], "ubar_true", 150)
                           - _after(m["noise-flaky"], "ubar_true", 150)))),
    Finding("s6-flaky", "damage: Flaky at least as fast as Thermal from it on (claim S6-flaky-after)",
            lambda m: (_lead(m, "s6"), max(0.0, -_lead(m, "s6")))),
    Finding("s6-freeze", f"damage: Thermal's acceptance over the {WINDOW} steps after it is below half that of the "
            f"{WINDOW} before (claim S6-thermal-stuck)", lambda m: (_freeze(m), max(0.0, _freeze(m) - 0.5) * 4)),
    Finding("s5-flaky", "friction drop: Flaky at least as fast as Thermal from it on (claim S5-flaky-after)",
            lambda m: (_lead(m, "s5"), max(0.0, -_lead(m, "s5")))),
    Finding("s9-plateau", "scaling: U_eq at N = 15 and 20 within 20% of each other",
            lambda m: (_ueq(m["s9-20"]) / _ueq(m["s9-15"]),
                       _off(abs(_ueq(m["s9-20"]) / _ueq(m["s9-15"]) - 1) - 0.2) * 5)),
]


LOWEST_FRICTION = S5_DROP.scale
"""The lowest friction the paper's scenarios put the chain on, relative to the default (S5's drop, taken as if it
acted on every body: the model's bound is then met everywhere)."""


def in_range(candidate: dict) -> float:
    """How many times the quasi-static model's bound the candidate's friction against inertia is, on the lowest
    friction of the paper's scenarios (below 1 the model does not hold there: params.friction_inertia)."""
    ratio, *_ = friction_inertia(shape(3, candidate), EnvironmentParams(friction_scale=LOWEST_FRICTION))
    return ratio / MIN_FRICTION_INERTIA


def evaluate(candidate: dict, seeds: int) -> tuple[float, list[tuple[str, float, float]]]:
    margin = in_range(candidate)
    if margin < 1:  # outside the physics the model can answer for: not simulated, scored by how far out it is
        return 100.0 + 100.0 * (1 - margin), [(f.name, float("nan"), 3.0) for f in FINDINGS]
    m = measure_all(candidate, seeds)
    rows = []
    for finding in FINDINGS:
        value, distance = finding.measure(m)
        # capped, so that one finding far from holding cannot hide what the others do
        rows.append((finding.name, float(value), min(float(distance), 3.0) if np.isfinite(distance) else 3.0))
    return sum(d for _, _, d in rows), rows


def to_unit(candidate: dict, space: dict[str, Bound] = SPACE) -> np.ndarray:
    return np.array([(math.log(candidate[k]) - math.log(b.low)) / (math.log(b.high) - math.log(b.low)) if b.log
                     else (candidate[k] - b.low) / (b.high - b.low) for k, b in space.items()])


def from_unit(x, space: dict[str, Bound] = SPACE) -> dict:
    x = np.clip(x, 0.0, 1.0)
    return {k: float(math.exp(math.log(b.low) + v * (math.log(b.high) - math.log(b.low))) if b.log
                     else b.low + v * (b.high - b.low)) for (k, b), v in zip(space.items(), x)}


# --- the hardware target set: the environment preset 'hardware' against the paper's experiments -------------------

HARDWARE_SPACE: dict[str, Bound] = {
    "vibration": Bound(0.5, 1.0, False, "factor on a unit's friction while its own pump runs (1: none); in the "
                       "quasi-static chain-2 it turns the simultaneous gait into a ratchet below the dummy's friction "
                       "over the units' (0.7)"),
    "field_amplitude": Bound(0.0, 0.5, False, "the track's friction varies by +-amplitude (docs/paper.md: 0.2-0.4)"),
    "field_length": Bound(0.06, 1.0, True, "m: the field's shortest wavelength, from one unit to half the 2 m track"),
    "noise": Bound(0.05, 1.5, True, "mm/cycle: Gaussian noise on each measured velocity (SI Fig. S5: 0.25-1)"),
    "clock_drift": Bound(1e-5, 0.01, True, "a unit's pump period error at most: a crystal (1e-5) to an RC "
                         "oscillator (0.01)"),
}
"""The effects' parameters and the range the paper's robots could have; nothing of the learners or the units."""

HARDWARE_BASE = {"vibration": HARDWARE_ENVIRONMENT.vibration,
                 "field_amplitude": HARDWARE_ENVIRONMENT.friction_field.amplitude,
                 "field_length": HARDWARE_ENVIRONMENT.friction_field.correlation_length,
                 "noise": HARDWARE_ENVIRONMENT.noise, "clock_drift": HARDWARE_ENVIRONMENT.clock_drift}
"""Where the search starts: the preset as it stands (params.HARDWARE_ENVIRONMENT). The search of
docs/calibration-hardware.md, which calibrated it, started from the provisional values before it: rerun it with
``--start vibration=0.8 field_amplitude=0.3 field_length=0.25 noise=0.5 clock_drift=0.001``."""

HARDWARE_FIXED = {"clock_offset": HARDWARE_ENVIRONMENT.clock_offset, "noise_ground": HARDWARE_ENVIRONMENT.noise_ground}
"""Fields of the preset a hardware candidate may set (``--start``) but the search does not vary: the units' own
step starts (each unit's offset over its learning step), a fact of clocks the robots do not share; and how the
noise depends on the ground (EnvironmentParams.noise_ground, added after the search: ``--evaluate`` measures it)."""

ABLATIONS: dict[str, dict[str, float]] = {
    "no vibration": {"vibration": 1.0},
    "no field": {"field_amplitude": 0.0},
    "no noise": {"noise": 0.0},
    "one clock": {"clock_drift": 0.0, "clock_offset": 0.0},
}
"""docs/hardware.md's ablation table: each effect of the preset switched off alone (``--ablation``)."""

HARDWARE_SUITE_FILE = ROOT / "benchmarks" / "paper-hardware.toml"
CLAIM_SCALE = {"mm/cycle": 1.0, "cycles": 0.1, "of trials": 0.1, "": 0.1}
"""What one unit of distance from holding is, by a claim's unit: 1 mm/cycle, a tenth of a cycle, ten points of
acceptance, a tenth of a ratio; any other unit counts as is."""
CAP = 3.0
"""the most one claim adds to a score (a claim not measured, or never defined, adds it): one finding far from
holding cannot hide what the others do."""


def claim_distance(claim, value: float) -> float:
    """How far ``value`` is from making ``claim`` hold, in units of CLAIM_SCALE: 0 when it holds, CAP at most (and
    for a value that is not finite)."""
    if value is None or not math.isfinite(value):
        return CAP
    return min(CAP, max(0.0, claim.excess(value)) / CLAIM_SCALE.get(claim.unit, 1.0))


def hardware_score(verdicts) -> tuple[float, list[tuple[str, float, float, bool]]]:
    """The score of a candidate's verdicts (claims.check on its results) and its rows (claim id, measured value or
    NaN, distance, whether it was measured): the sum of the distances, a claim not measured at CAP."""
    rows = []
    for verdict in verdicts:
        value = verdict.measured.value if verdict.measured is not None else float("nan")
        rows.append((verdict.claim.id, float(value), claim_distance(verdict.claim, value),
                     verdict.measured is not None))
    return sum(row[2] for row in rows), rows


def hardware_environment(candidate: dict, for_scan: bool = False) -> dict:
    """The environment fields a candidate sets on top of the preset 'hardware' (a scan's: its ground and pumps only,
    without noise and clocks)."""
    table = {"preset": "hardware", "vibration": candidate["vibration"],
             "friction_field": {"amplitude": candidate["field_amplitude"],
                                "correlation_length": candidate["field_length"]}}
    if not for_scan:
        table.update(noise=candidate["noise"], clock_drift=candidate["clock_drift"],
                     **{key: candidate.get(key, value) for key, value in HARDWARE_FIXED.items()})
    return table


def ablations(candidate: dict) -> dict[str, dict]:
    """The candidate, and the candidate with each effect of ABLATIONS switched off alone, by column name."""
    return {"preset": dict(candidate), **{name: {**candidate, **off} for name, off in ABLATIONS.items()}}


def ablation_table(results: dict[str, list]) -> list[str]:
    """docs/hardware.md's ablation table from ``{column: hardware_score rows}``: per claim, 'holds' or 'no (value)'
    in each column, 'not measured' where the claim could not be measured."""
    columns = list(results)
    lines = ["| claim | " + " | ".join(columns) + " |", "|---|" + "---|" * len(columns)]
    for i, (claim_id, *_) in enumerate(results[columns[0]]):
        cells = []
        for column in columns:
            _, value, distance, measured = results[column][i]
            cells.append("not measured" if not measured else "holds" if distance == 0 else
                         f"no ({value:.3g})" if math.isfinite(value) else "no (none found)")
        lines.append(f"| `{claim_id}` | " + " | ".join(cells) + " |")
    return lines


def hardware_suite_table(candidate: dict, seeds: int, table: dict | None = None, scans_only: bool = False) -> dict:
    """The hardware suite's table (benchmarks/paper-hardware.toml, or ``table``) with the candidate's environment in
    every experiment and scan (a scan's own friction_field.offset kept: its place on the track) and ``seeds`` seeds
    per condition (``scans_only``: its scans alone, seconds where the runs take minutes); its name stays, so that its
    results are checked against the hardware claims."""
    if table is None:
        from morphbench.files import read_toml
        table = read_toml(HARDWARE_SUITE_FILE, "suite file")
    table = dict(table)
    if scans_only:
        table["experiment"] = []
    for key, for_scan in (("experiment", False), ("scan", True)):
        entries = []
        for entry in table.get(key, []):
            entry = dict(entry)
            own = entry.get("environment", {})
            own = {"preset": own} if isinstance(own, str) else dict(own)
            wanted = hardware_environment(candidate, for_scan)
            wanted["friction_field"] = {**wanted["friction_field"], **own.get("friction_field", {})}
            entry["environment"] = {**own, **wanted}
            if not for_scan:
                entry["seeds"] = seeds
            entries.append(entry)
        table[key] = entries
    return table


def evaluate_hardware(candidate: dict, seeds: int, workers: int, scans_only: bool = False
                      ) -> tuple[float, list[tuple[str, float, float, bool]]]:
    """Run the hardware suite with the candidate's environment into a temporary directory and score its claims
    (``scans_only``: its scans alone; the claims on learning runs are then not measured)."""
    from morphbench.bench.executors import LocalExecutor
    from morphbench.bench.report import claims_of
    from morphbench.bench.runner import run_suite
    from morphbench.bench.suite import suite_from_table

    suite = suite_from_table(hardware_suite_table(candidate, seeds, scans_only=scans_only),
                             source=str(HARDWARE_SUITE_FILE),
                             base=HARDWARE_SUITE_FILE.parent, default_name="paper-hardware")
    with tempfile.TemporaryDirectory(prefix="calibrate-hardware-") as out:
        run_suite(suite, out, LocalExecutor(workers), progress=False)
        return hardware_score(claims_of(out))


def describe(candidate: dict) -> str:
    return ", ".join(f"{k} {v:.4g}" for k, v in candidate.items())


def report(history: list, seeds: int, command: str, wall_s: float, hardware: bool = False) -> str:
    history = sorted(history, key=lambda h: h[1])
    space = HARDWARE_SPACE if hardware else SPACE
    if hardware:
        from morphbench.bench.claims import HARDWARE_CLAIMS
        findings = [(c.id, f"{c.statement} Holds if {c.rule_text()} {c.unit}.".strip()) for c in HARDWARE_CLAIMS]
        what = ["Generated by `benchmarks/calibrate.py --targets hardware`. Each candidate is the environment preset",
                "'hardware' with these effects, the suite benchmarks/paper-hardware.toml run on it, scored on its "
                "claims. A claim's",
                f"distance is 0 when it holds (at most {CAP:g}; not measured: {CAP:g}); the score is their sum."]
        title = "# Calibration of the hardware preset against the paper's experiments"
    else:
        findings = [(f.name, f.statement) for f in FINDINGS]
        what = ["Generated by `benchmarks/calibrate.py`. Each candidate is one physics for every scenario, scored on "
                "the",
                "paper's simulation findings (quasi-static backend, ideal sensor, 2 cycles measured a step, "
                f"{PROTOCOL['discard_cycles']} discarded",
                "after each phase change). A finding's distance is 0 when it holds; the score is their sum."]
        title = "# Calibration against the paper's findings"
    lines = [title, "",
             f"{datetime.date.today().isoformat()}, {platform.node() or 'machine'}: {os.cpu_count()} cores. "
             f"{len(history)} candidates, {seeds} seeds each, {wall_s / 60:.0f} min. Command: `{command}`", "",
             *what, "", "## The ranges searched", "", "| parameter | range | why |", "|---|---|---|"]
    lines += [f"| {k} | {b.low:g} - {b.high:g} | {b.why} |" for k, b in space.items()]
    lines += ["", "## The findings", "", "| id | statement |", "|---|---|"]
    lines += [f"| {name} | {statement} |" for name, statement in findings]
    lines += ["", "## Candidates, best first", "",
              "| # | parameters | score | holds | " + " | ".join(name for name, _ in findings) + " |",
              "|---:|---|---:|---:|" + "---:|" * len(findings)]
    for i, (candidate, score, rows) in enumerate(history[:15], 1):
        held = sum(d == 0 for _, _, d, *_ in rows)
        cells = " | ".join(f"{v:.2f}{'' if d == 0 else ' ✗'}" for _, v, d, *_ in rows)
        lines.append(f"| {i} | {describe(candidate)} | {score:.2f} | {held}/{len(rows)} | {cells} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=None,
                        help="seeds per condition (default 16; --targets hardware: 8)")
    parser.add_argument("--trials", type=int, default=40)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default=str(ROOT / "docs" / "calibration-search.md"))
    parser.add_argument("--start", nargs="*", metavar="NAME=VALUE", default=[],
                        help="where the search starts (the other parameters at BASE)")
    parser.add_argument("--evaluate", action="store_true", help="score the --start candidate only")
    parser.add_argument("--discard", type=int, default=PROTOCOL["discard_cycles"],
                        help="cycles discarded after each phase change (the paper's protocol: 0)")
    parser.add_argument("--targets", choices=("simulation", "hardware"), default="simulation",
                        help="simulation: the paper's simulation findings, searching what the paper leaves open of "
                             "the model (SPACE); hardware: its experiments' findings on the suite "
                             "benchmarks/paper-hardware.toml, searching the effects of the preset 'hardware' only "
                             "(HARDWARE_SPACE)")
    parser.add_argument("--workers", type=int, default=2, help="--targets hardware: bench worker processes")
    parser.add_argument("--ablation", action="store_true",
                        help="--targets hardware: evaluate the --start candidate and the same with each effect "
                             "switched off alone, and print docs/hardware.md's ablation table")
    parser.add_argument("--scans-only", action="store_true",
                        help="--targets hardware: the suite's scans alone (seconds: the claims on landscapes; those "
                             "on learning runs are not measured)")
    args = parser.parse_args(argv)
    hardware = args.targets == "hardware"
    space = HARDWARE_SPACE if hardware else SPACE
    args.seeds = args.seeds or (8 if hardware else 16)
    if hardware and args.out == parser.get_default("out"):
        args.out = str(ROOT / "docs" / "calibration-hardware.md")
    PROTOCOL["discard_cycles"] = args.discard
    candidate = dict(HARDWARE_BASE if hardware else BASE)
    known = {**space, **(HARDWARE_FIXED if hardware else {})}
    for item in args.start:
        key, _, value = item.partition("=")
        if key not in known:
            parser.error(f"--start: unknown parameter {key!r} (expected one of {', '.join(known)})")
        candidate[key] = float(value)
    for flag in ("ablation", "scans_only"):
        if getattr(args, flag) and not hardware:
            parser.error(f"--{flag.replace('_', '-')}: with --targets hardware only")

    def score_of(candidate: dict) -> tuple[float, list]:
        if hardware:
            return evaluate_hardware(candidate, args.seeds, args.workers, args.scans_only)
        return evaluate(candidate, args.seeds)

    if args.ablation:
        results = {}
        for name, changed in ablations(candidate).items():
            started = time.perf_counter()
            score, results[name] = score_of(changed)
            print(f"{name}: {describe(changed)}: score {score:.2f} ({time.perf_counter() - started:.0f} s)",
                  flush=True)
        print("\n".join(ablation_table(results)))
        return 0
    if args.evaluate:
        started = time.perf_counter()
        score, rows = score_of(candidate)
        print(f"{describe(candidate)}: score {score:.2f} ({time.perf_counter() - started:.0f} s)")
        for name, value, distance, *_ in rows:
            print(f"  {name:14s} {value:+.3f}  {'holds' if distance == 0 else f'off by {distance:.2f}'}")
        return 0
    import cma

    started = time.perf_counter()
    history = []
    es = cma.CMAEvolutionStrategy(to_unit(candidate, space), 0.25, {"bounds": [0, 1], "seed": args.seed + 1,
                                                                   "verbose": -9, "popsize": 8})
    while len(history) < args.trials:
        xs = es.ask()
        scores = []
        for x in xs:
            candidate = from_unit(x, space)
            score, rows = score_of(candidate)
            history.append((candidate, score, rows))
            scores.append(score)
            print(f"[{len(history)}] {describe(candidate)}: {score:.2f}", flush=True)
        es.tell(xs, scores)
        Path(args.out).write_text(report(history, args.seeds, "python benchmarks/calibrate.py " + " ".join(
            sys.argv[1:]), time.perf_counter() - started, hardware))
    return 0


if __name__ == "__main__":
    sys.exit(main())
