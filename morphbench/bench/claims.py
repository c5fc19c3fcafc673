"""The paper's findings, each checked against a suite's stored tables (no simulation).

The paper is Oliveri et al., "Continuous learning of emergent behavior in robotic matter", PNAS 118(21) e2017015118
(2021); docs/paper.md lists its findings with the figure each comes from, the experiment of benchmarks/paper.toml
that reproduces it and the claim here that checks it. morphbench's defaults are meant to reproduce its simulations;
claims whose scenario says '(hardware)' are findings of its experiments. Each ``Claim`` is one finding: an id, the
statement, the paper's value,
a function that measures the same quantity from the tables of a results directory (``runs``, ``steps``, ``units``,
``scans``, ``metrics``: morphbench.bench.store and metrics), a tolerance and the rule that decides whether it holds:

- ``within``: |measured - paper| <= tolerance;
- ``phase``: the same on the circle of phases (a distance in cycles, wrapped: 0.95 is 0.1 from 0.05);
- ``at most`` / ``at least``: measured <= paper + tolerance / measured >= paper - tolerance.

A measuring function returns a ``Measured`` (the value and what it was measured on) or, when the suite lacks what it
needs, a sentence saying what is missing: the claim is then 'not measured', never an error. ``check(tables)`` gives
one ``Verdict`` per claim, in the order of ``CLAIMS``. A new claim is one more entry of ``CLAIMS``.

Which claims a report checks follows its suite's name and the suites it includes (``claims_for``, from the plan's
``suite`` and ``includes``): the results of benchmarks/paper-hardware.toml (``HARDWARE_SUITE``, the paper's
experiments on the environment preset ``hardware``) are checked against ``HARDWARE_CLAIMS`` alone, every other
suite's (paper, paper-quick, smoke, ...) against ``CLAIMS``, as before. The hardware claims' ids start with ``hw-``;
six of them are the six hardware claims of ``CLAIMS`` (the same finding and rule, measured on the hardware suite's
experiments instead of the paper suite's options), the others are the experiments' findings the paper suite cannot
show (docs/hardware.md). A suite that includes others (``include``, morphbench.bench.suite) is checked against its
own claims merged with those of each included suite that has claims of its own (``SUITE_CLAIMS``): an included
claim replaces the claim of the same id where it stands, the others follow in their order. So a paper suite that
includes paper-hardware is checked against CLAIMS with its six hardware claims measured on paper-hardware's
experiments, then the other hardware claims (73 in all).

The tolerances are this project's reading of the paper's "about": a quarter of a peak of 4.5 mm/cycle, a tenth of a
cycle of phase, ten percentage points of acceptance. A qualitative finding is a comparison between two conditions of
the suite, measured as a difference (or a ratio) that the rule puts on the right side of zero (or one): Flaky's Ubar
after an event minus Thermal's, at least 0. No rule here holds by construction: each test of tests/test_claims.py
feeds a claim tables where it fails.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd

from morphbench.bench import metrics as M
from morphbench.params import LearnerParams

RULES = ("within", "phase", "at most", "at least")
PROMINENCE = 0.1
"""a local maximum of a curve is significant when it stands out by this fraction of the curve's range."""
BIMODAL = 5 / 9
"""Sarle's bimodality coefficient of a uniform distribution: above it, a distribution is taken as bimodal."""
LEARNED_AFTER = M.LEARNED_AFTER
WINDOW = 20
"""learning steps before and after an event over which acceptance is compared."""
MIN_STEPS = 2 * LEARNED_AFTER
"""the fewest learning steps of a condition a claim about learning is measured on: the paper's findings are about
learning done (after about LEARNED_AFTER steps) and what follows it; a shorter run measures the transient, and its
verdict would be a false 'no' (the smoke suite's 10-step runs)."""
TOO_SMALL = "too small a suite for it"
"""how the reason of a claim not measured on runs shorter than MIN_STEPS starts."""


@dataclass(frozen=True)
class Measured:
    value: float
    on: str
    """what it was measured on: 'scan S2 (50 points)', 'S1: chain-2 thermal (112 runs)'."""


@dataclass(frozen=True)
class Claim:
    id: str
    scenario: str
    """the experiment of benchmarks/paper.toml that reproduces it (S1, S2, ...), '(hardware)' for a finding of the
    paper's experiments."""
    statement: str
    paper: float
    unit: str
    measure: Callable[[dict[str, pd.DataFrame]], Measured | str]
    tolerance: float
    rule: str
    """one of RULES (see the module doc)."""
    source: str = ""
    """where the paper says it: 'Fig. 1F', 'SI Fig. S5C', 'Conclusion'."""
    suite: str = ""
    """the suite whose results it is measured on: '' the paper's study (benchmarks/paper.toml, and any suite the
    report checks against CLAIMS), HARDWARE_SUITE the hardware twin's (benchmarks/paper-hardware.toml)."""

    def holds(self, value: float) -> bool:
        return self.excess(value) <= 0.0

    def excess(self, value: float) -> float:
        """How far ``value`` lies beyond the rule's bound, in the claim's unit: <= 0 exactly when the claim holds
        (the calibration scores a candidate by it); infinite for a value that is not finite."""
        if not math.isfinite(value):
            return math.inf
        if self.rule == "within":
            return abs(value - self.paper) - self.tolerance
        if self.rule == "phase":
            distance = abs(value - self.paper) % 1.0
            return min(distance, 1.0 - distance) - self.tolerance
        if self.rule == "at most":
            return value - (self.paper + self.tolerance)
        if self.rule == "at least":
            return (self.paper - self.tolerance) - value
        raise ValueError(f"claim {self.id}: rule {self.rule!r} is not one of {RULES}")

    def rule_text(self) -> str:
        """How the measured value is judged, e.g. 'within 1 of 4.5'."""
        if self.rule in ("within", "phase"):
            circle = " (on the circle)" if self.rule == "phase" else ""
            return f"within {self.tolerance:.3g} of {self.paper:.3g}{circle}"
        bound = self.paper + self.tolerance if self.rule == "at most" else self.paper - self.tolerance
        return f"{self.rule} {bound:.3g}"


@dataclass(frozen=True)
class Verdict:
    claim: Claim
    measured: Measured | None
    holds: bool | None
    """None: not measured."""
    reason: str = ""
    """why it was not measured."""


def check(tables: dict[str, pd.DataFrame], claims: tuple[Claim, ...] | None = None) -> list[Verdict]:
    """Each claim measured on ``tables`` (any of runs, steps, units, scans, metrics may be missing or empty)."""
    verdicts = []
    for claim in CLAIMS if claims is None else claims:
        try:
            result = claim.measure(tables)
        except (KeyError, ValueError, TypeError, IndexError) as exc:  # a table without a column it needs
            result = f"the tables lack what it needs ({type(exc).__name__}: {exc})"
        if isinstance(result, str):
            verdicts.append(Verdict(claim, None, None, result))
        else:
            verdicts.append(Verdict(claim, result, claim.holds(result.value)))
    return verdicts


# --- what the claims are measured on --------------------------------------------------------------------------


def _table(tables: dict, name: str) -> pd.DataFrame:
    table = tables.get(name)
    return table if table is not None else pd.DataFrame()


def _default_ground(table: pd.DataFrame) -> pd.Series:
    """Rows on the default ground (all of them in tables written before grounds had ids)."""
    if "environment_id" not in table:
        return pd.Series(True, index=table.index)
    return table.environment_id.isna() | (table.environment_id == M._default_ground())


def scan_curve(tables: dict, n_units: int = 2, vibration: bool = False) -> tuple[pd.DataFrame, str] | str:
    """The points of the first complete healthy scan of ``n_units`` units on the default ground (``vibration``: on
    the first one whose environment sets the pump vibration instead), sorted by phase, and what it is."""
    scans = M.healthy_scans(_table(tables, "scans"))
    if scans is None or scans.empty or "n_units" not in scans:
        return "the suite has no scan results"
    mine = scans[scans.n_units == n_units]
    label = mine.environment.astype(str) if "environment" in mine else pd.Series("", index=mine.index)
    if vibration:
        mine = mine[label.str.contains("vibration=")]
        what = f"{n_units}-unit scan with pump vibration"
    else:
        mine = mine[_default_ground(mine)]
        what = f"{n_units}-unit scan on the default ground"
    for _, points in mine.groupby("scan_id", sort=False):
        if "samples" in points and len(points) < int(points.samples.iloc[0]):
            continue  # an interrupted scan: its extremes may be missing
        dphi = [f"dphi_{i}" for i in range(2, n_units + 1)]
        points = points.sort_values(dphi).reset_index(drop=True)
        return points, f"scan {points.scan.iloc[0]} ({len(points)} points)"
    return f"the suite has no complete healthy {what}"


def _curve_measure(quantity: Callable[[np.ndarray, np.ndarray], float], vibration: bool = False):
    def measure(tables: dict) -> Measured | str:
        found = scan_curve(tables, 2, vibration)
        if isinstance(found, str):
            return found
        points, on = found
        value = quantity(points.dphi_2.to_numpy(dtype=float), points.ubar.to_numpy(dtype=float))
        return Measured(value, on) if math.isfinite(value) else f"not defined on {on}"
    return measure


def antisymmetry(dphi: np.ndarray, ubar: np.ndarray) -> float:
    """How far a periodic curve is from U(dphi) = -U(1 - dphi): the rms of (U(d) + U(1 - d)) / 2 over the points whose
    mirror is also a point, over the largest |U| (0: exactly antisymmetric; NaN without mirrored points)."""
    lookup = {round(d % 1.0, 9): u for d, u in zip(dphi, ubar)}
    pairs = [(u, lookup[round((1.0 - d) % 1.0, 9)]) for d, u in zip(dphi, ubar) if round((1.0 - d) % 1.0, 9) in lookup]
    scale = float(np.max(np.abs(ubar))) if len(ubar) else 0.0
    if not pairs or scale == 0:
        return math.nan
    return float(np.sqrt(np.mean([((a + b) / 2) ** 2 for a, b in pairs])) / scale)


def local_maxima(ubar: np.ndarray, prominence: float = PROMINENCE) -> list[tuple[int, float]]:
    """The local maxima of a periodic curve sampled at equal steps, as (index, prominence), those whose prominence
    (how far it stands above the higher of the lowest points between it and a higher point on either side) is at
    least ``prominence`` times the curve's range; the global maximum's prominence is the range. Flat tops count once."""
    u = np.asarray(ubar, dtype=float)
    n, span = len(u), float(np.ptp(u)) if len(u) else 0.0
    if n < 3 or span == 0:
        return []
    found = []
    for i in range(n):
        if not (u[i] > u[i - 1] and u[i] >= u[(i + 1) % n]):
            continue
        lows = []
        for direction in (-1, 1):
            low, j = u[i], i
            for _ in range(n - 1):
                j = (j + direction) % n
                if u[j] > u[i]:
                    break
                low = min(low, u[j])
            else:
                low = u.min()  # no higher point: the global maximum
            lows.append(low)
        height = u[i] - max(lows)
        if height >= prominence * span:
            found.append((i, float(height)))
    return found


def _second_maximum(which: int):
    """A measuring function of the phase (``which`` 0) or Ubar (1) of the highest significant local maximum below the
    global one of the 2-unit curve with pump vibration: a curve without one does not have the claimed maximum (NaN,
    so the claim does not hold)."""
    def measure(tables: dict) -> Measured | str:
        found = scan_curve(tables, 2, vibration=True)
        if isinstance(found, str):
            return found
        points, on = found
        dphi, ubar = points.dphi_2.to_numpy(dtype=float), points.ubar.to_numpy(dtype=float)
        maxima = sorted(local_maxima(ubar), key=lambda m: -ubar[m[0]])
        if len(maxima) < 2:
            return Measured(math.nan, f"{on}: no second significant maximum")
        return Measured(float((dphi, ubar)[which][maxima[1][0]]), on)
    return measure


def condition(tables: dict, n_units: int, learner: str = "thermal", step_size: float = 0.1
              ) -> tuple[pd.Series, str] | str:
    """The metrics row of the first condition (suite order) with finished runs of ``n_units`` units learning with
    ``learner`` at ``step_size`` and the default temperature and protocol (LearnerParams), measuring with the ideal
    sensor, without noise or events, on the default ground, and what it is."""
    metrics = _table(tables, "metrics")
    needed = {"n_units", "learner", "noise", "events", "step_size"}
    if metrics.empty:
        return "the suite has no learning runs"
    if not needed <= set(metrics.columns):
        return f"the metrics lack {', '.join(sorted(needed - set(metrics.columns)))}"
    chosen = (metrics.n_units == n_units) & (metrics.learner == learner) & (metrics.noise == 0) \
        & (metrics.events == "none") & np.isclose(metrics.step_size.astype(float), step_size) \
        & _default_ground(metrics)
    if "sensor" in metrics:
        chosen &= metrics.sensor == "ideal"
    for name, value in dataclasses.asdict(LearnerParams()).items():
        if name != "step_size" and name in metrics:
            chosen &= metrics[name] == value
    mine = metrics[chosen]
    if "final_ubar" in mine:
        mine = mine[np.isfinite(mine.final_ubar.astype(float))]  # conditions with finished runs
    if mine.empty:
        return (f"the suite has no finished {n_units}-unit {learner} runs at step size {step_size:g} without noise "
                "or events on the default ground")
    mine = _long_enough(mine)
    if isinstance(mine, str):
        return mine
    row = mine.iloc[0]
    done = int(row.runs - row.get("failed", 0) - row.get("missing", 0))
    experiments = _experiments_of(tables, row.condition_id)
    return row, f"{experiments or 'condition'}: {row['shape']} {learner} ({done} runs)"


def _experiments_of(tables: dict, condition_id: str) -> str:
    runs = _table(tables, "runs")
    if runs.empty or "experiments" not in runs:
        return ""
    names = runs.experiments[runs.condition_id == condition_id].dropna()
    return ", ".join(dict.fromkeys(name for text in names for name in str(text).split(";") if name))


def _metric_measure(column: str, n_units: int, need_plateau: bool = False):
    """A measuring function of a column of the chosen condition's metrics (``condition``). With ``need_plateau``, not
    measured unless the fit found a plateau (no U_eq without one)."""
    def measure(tables: dict) -> Measured | str:
        found = condition(tables, n_units)
        if isinstance(found, str):
            return found
        row, on = found
        if need_plateau and not bool(row.get("plateau", False)):
            return f"no plateau on {on}: U_eq would be an extrapolation"
        value = float(row[column])
        return Measured(value, on) if math.isfinite(value) else f"not defined on {on}"
    return measure


def bimodality(values) -> float:
    """Sarle's bimodality coefficient (skewness^2 + 1) / (excess kurtosis + 3 (n-1)^2 / ((n-2)(n-3))), with the
    sample skewness and kurtosis: about 1/3 for a normal distribution, 5/9 for a uniform one, towards 1 for two
    separate modes. NaN for fewer than 4 values or no spread."""
    x = np.asarray(values, dtype=float)
    x = x[np.isfinite(x)]
    n = len(x)
    if n < 4 or np.std(x) == 0:
        return math.nan
    z = (x - x.mean()) / x.std()
    g = float(np.mean(z ** 3)) * math.sqrt(n * (n - 1)) / (n - 2)
    k = ((n + 1) * float(np.mean(z ** 4)) - 3 * (n - 1)) * (n - 1) / ((n - 2) * (n - 3))
    return (g ** 2 + 1) / (k + 3 * (n - 1) ** 2 / ((n - 2) * (n - 3)))


def _unimodal_after(tables: dict) -> Measured | str:
    found = condition(tables, 2)
    if isinstance(found, str):
        return found
    row, on = found
    steps = _table(tables, "steps")
    if steps.empty or "ubar_true" not in steps:
        return "the suite has no learning steps"
    late = steps[(steps.condition_id == row.condition_id) & (steps.step > LEARNED_AFTER)]
    per_run = late.groupby("run_id").ubar_true.mean()
    value = bimodality(per_run.to_numpy())
    if not math.isfinite(value):
        return f"fewer than 4 runs with steps after step {LEARNED_AFTER} on {on}"
    return Measured(value, f"{on}, each run's mean Ubar after step {LEARNED_AFTER}")


# --- conditions of the suite's experiments ---------------------------------------------------------------------


def _conditions(tables: dict, experiment: str, **match) -> pd.DataFrame | str:
    """The metrics rows (suite order) of the conditions whose runs belong to ``experiment`` and whose columns equal
    ``match`` (floats compared with np.isclose; ``environment`` is the ground's label), with finished runs."""
    metrics, runs = _table(tables, "metrics"), _table(tables, "runs")
    if metrics.empty:
        return "the suite has no learning runs"
    if runs.empty or "experiments" not in runs:
        return "the runs table lacks experiments"
    names = runs.experiments.fillna("").astype(str).str.split(";")
    ids = set(runs.condition_id[names.apply(lambda listed: experiment in listed)])
    chosen = metrics.condition_id.isin(ids)
    for column, value in match.items():
        if column not in metrics:
            return f"the metrics lack {column}"
        if isinstance(value, float):
            chosen &= np.isclose(metrics[column].astype(float), value)
        else:
            chosen &= metrics[column] == value
    mine = metrics[chosen]
    if "final_ubar" in mine:
        mine = mine[np.isfinite(mine.final_ubar.astype(float))]
    if mine.empty:
        wanted = ", ".join(f"{k} {v}" for k, v in match.items())
        return f"the suite has no finished runs of {experiment}" + (f" with {wanted}" if wanted else "")
    return _long_enough(mine)


def _long_enough(mine: pd.DataFrame) -> pd.DataFrame | str:
    """The conditions of ``mine`` (metrics rows) that learn for at least MIN_STEPS steps, or why there is none:
    the suite is too small for the claim, which is then not measured (never a 'no')."""
    if "steps" not in mine:
        return mine
    long = mine[mine.steps.astype(float) >= MIN_STEPS]
    if long.empty:
        return (f"{TOO_SMALL}: its runs learn for {int(mine.steps.max())} steps, the claim is about learning "
                f"done, measured on {MIN_STEPS} steps or more")
    return long


def _one(tables: dict, experiment: str, **match) -> tuple[pd.Series, str] | str:
    """The first condition of ``_conditions`` and what it is ('S5: chain-3 flaky (112 runs)')."""
    found = _conditions(tables, experiment, **match)
    if isinstance(found, str):
        return found
    row = found.iloc[0]
    done = int(row.runs - row.get("failed", 0) - row.get("missing", 0))
    extra = "".join(f", {k} {_text(row[k])}" for k in match if k not in ("learner", "n_units"))
    return row, f"{experiment}: {row['shape']} {row['learner']}{extra} ({done} runs)"


def _text(value) -> str:
    return f"{value:g}" if isinstance(value, (float, np.floating)) else str(value)


def _steps_of(tables: dict, row: pd.Series) -> pd.DataFrame:
    steps = _table(tables, "steps")
    if steps.empty:
        raise ValueError("the suite has no learning steps")
    return steps[steps.condition_id == row.condition_id]


def _units_of(tables: dict, row: pd.Series) -> pd.DataFrame:
    units, runs = _table(tables, "units"), _table(tables, "runs")
    if units.empty or runs.empty:
        raise ValueError("the suite has no per-unit records")
    return units[units.run_id.isin(runs.run_id[runs.condition_id == row.condition_id])]


def _event_step(row: pd.Series) -> int:
    step = float(row.get("recovery_step", math.nan))
    if not math.isfinite(step):
        raise ValueError(f"condition {row.condition_id} records no event")
    return int(step)


# what a condition is measured by: each takes the tables and the condition's metrics row

def final_ubar(tables: dict, row: pd.Series) -> float:
    return float(row.final_ubar)


def metric(column: str) -> Callable[[dict, pd.Series], float]:
    return lambda tables, row: float(row[column])


def ubar_after_event(tables: dict, row: pd.Series) -> float:
    """The mean true Ubar over every run and every step from the condition's first event on."""
    steps = _steps_of(tables, row)
    return float(steps.ubar_true[steps.step >= _event_step(row)].mean())


def acceptance_ratio(tables: dict, row: pd.Series) -> float:
    """Mean acceptance over the WINDOW steps from the first event on, over that of the WINDOW steps before it."""
    steps, event = _steps_of(tables, row), _event_step(row)
    before = steps.acceptance[(steps.step < event) & (steps.step >= event - WINDOW)].mean()
    after = steps.acceptance[(steps.step >= event) & (steps.step < event + WINDOW)].mean()
    return float(after / before) if before > 0 else math.nan


def ubar_change(tables: dict, row: pd.Series) -> float:
    """Mean true Ubar over the WINDOW steps from the first event on, minus that of the WINDOW steps before it."""
    steps, event = _steps_of(tables, row), _event_step(row)
    before = steps.ubar_true[(steps.step < event) & (steps.step >= event - WINDOW)].mean()
    after = steps.ubar_true[(steps.step >= event) & (steps.step < event + WINDOW)].mean()
    return float(after - before)


def acceptance_change(tables: dict, row: pd.Series) -> float:
    """Mean acceptance over the WINDOW steps from the first event on, minus that of the WINDOW steps before it."""
    steps, event = _steps_of(tables, row), _event_step(row)
    before = steps.acceptance[(steps.step < event) & (steps.step >= event - WINDOW)].mean()
    after = steps.acceptance[(steps.step >= event) & (steps.step < event + WINDOW)].mean()
    return float(after - before)


def kept_level(tables: dict, row: pd.Series) -> float:
    """Mean true Ubar over the last WINDOW steps of the runs over that of the WINDOW steps before the first event:
    how much of its level the assembly has again at the end."""
    steps, event = _steps_of(tables, row), _event_step(row)
    before = steps.ubar_true[(steps.step < event) & (steps.step >= event - WINDOW)].mean()
    end = steps.ubar_true[steps.step > steps.step.max() - WINDOW].mean()
    return float(end / before) if before > 0 else math.nan


def acceptance_spread(tables: dict, row: pd.Series) -> float:
    """The range of the mean acceptance over blocks of 50 learning steps after step LEARNED_AFTER."""
    steps = _steps_of(tables, row)
    late = steps[steps.step > LEARNED_AFTER]
    blocks = late.groupby((late.step - LEARNED_AFTER - 1) // 50).acceptance.mean()
    return float(np.ptp(blocks.to_numpy())) if len(blocks) > 1 else math.nan


def distribution(key: str) -> Callable[[dict, pd.Series], float]:
    """A value of metrics.step_distribution (Fig. 1F) of the condition's true Ubar after step LEARNED_AFTER."""
    return lambda tables, row: float(M.step_distribution(_steps_of(tables, row))[key])


def learned_by(step: int) -> Callable[[dict, pd.Series], float]:
    """The seed-averaged true Ubar over steps ``step`` +- 2 as a fraction of U_eq (NaN without a plateau)."""
    def value(tables: dict, row: pd.Series) -> float:
        if not bool(row.get("plateau", False)) or not row.u_eq > 0:
            return math.nan
        steps = _steps_of(tables, row)
        return float(steps.ubar_true[(steps.step >= step - 2) & (steps.step <= step + 2)].mean() / row.u_eq)
    return value


def improvement(tables: dict, row: pd.Series) -> float:
    """Seed-averaged true Ubar over steps 45-55 minus over steps 0-5: the first 50 steps' gain."""
    steps = _steps_of(tables, row)
    late = steps.ubar_true[(steps.step >= 45) & (steps.step <= 55)].mean()
    return float(late - steps.ubar_true[steps.step <= 5].mean())


def memory_excess(tables: dict, row: pd.Series) -> float:
    """Mean remembered minus true trial Ubar after step LEARNED_AFTER (metrics.memory_ubar): how far the memory
    overestimates what the units now do."""
    table = M.memory_ubar(_units_of(tables, row))
    late = table[table.step > LEARNED_AFTER]
    if late.empty:
        raise ValueError("the per-unit records lack u_memory")
    return float((late.ubar_memory - late.ubar_true).mean())


def learned_phase_difference(tables: dict, row: pd.Series) -> float:
    """The circular mean over runs and steps after LEARNED_AFTER of the kept phase of the unit at position 2 minus
    that of position 1 (a 2-unit assembly's gait, on the 2-unit scan's axis)."""
    units = _units_of(tables, row)
    units = units[units.step > LEARNED_AFTER]
    wide = units.pivot_table(index=["run_id", "step"], columns="position", values="phase_kept", aggfunc="first")
    angle = 2 * np.pi * (wide[2] - wide[1]).to_numpy(dtype=float)
    return float(np.angle(np.mean(np.exp(1j * angle))) / (2 * np.pi) % 1.0)


def weakest_piece(tables: dict, row: pd.Series) -> float:
    """The lowest, over the pieces after the cut, of the piece's Ubar over the last WINDOW steps (all runs)."""
    curves = M.piece_curves(_units_of(tables, row))
    late = curves[curves.step > curves.step.max() - WINDOW]
    by_piece = late.groupby("piece").ubar.mean()
    if len(by_piece) < 2:
        raise ValueError("the runs record no cut into pieces")
    return float(by_piece.min())


def _of(experiment: str, value: Callable[[dict, pd.Series], float], **match):
    """A measuring function: ``value`` of the first condition of ``experiment`` matching ``match``."""
    def measure(tables: dict) -> Measured | str:
        found = _one(tables, experiment, **match)
        if isinstance(found, str):
            return found
        row, on = found
        result = value(tables, row)
        return Measured(result, on) if math.isfinite(result) else f"not defined on {on}"
    return measure


def _versus(experiment: str, value: Callable[[dict, pd.Series], float], first: dict, second: dict,
            ratio: bool = False):
    """A measuring function: ``value`` of the condition ``first`` minus (``ratio``: over) that of ``second``."""
    def measure(tables: dict) -> Measured | str:
        a, b = _one(tables, experiment, **first), _one(tables, experiment, **second)
        for found in (a, b):
            if isinstance(found, str):
                return found
        x, y = value(tables, a[0]), value(tables, b[0])
        result = (x / y if y > 0 else math.nan) if ratio else x - y
        on = f"{a[1]} ({x:.3g}) {'over' if ratio else 'minus'} {b[1].split(': ', 1)[1]} ({y:.3g})"
        return Measured(result, on) if math.isfinite(result) else f"not defined on {on}"
    return measure


def _extreme_noise(tables: dict, **match) -> float | str:
    """The highest noise level of S4's conditions (on ``match``'s ground)."""
    found = _conditions(tables, "S4", **match)
    return found if isinstance(found, str) else float(found.noise.max())


def _noise_versus(value, first: dict, second: dict, noisy_first: bool = True, noisy_second: bool = True,
                  ratio: bool = False):
    """``_versus`` on S4 at its highest noise level (``noisy_*`` False: that side noiseless)."""
    def measure(tables: dict) -> Measured | str:
        sigma = _extreme_noise(tables, environment=first.get("environment", "uniform"))
        if isinstance(sigma, str):
            return sigma
        if not sigma > 0:
            return "S4 has no noisy condition"
        a = {**first, "noise": sigma if noisy_first else 0.0}
        b = {**second, "noise": sigma if noisy_second else 0.0}
        return _versus("S4", value, a, b, ratio)(tables)
    return measure


def _across(experiment: str, value: Callable[[dict, pd.Series], float], column: str, combine, **match):
    """A measuring function: ``combine(levels, values)`` of ``value`` over the conditions of ``experiment`` matching
    ``match``, by their ``column`` (sorted; conditions without a value left out)."""
    def measure(tables: dict) -> Measured | str:
        found = _conditions(tables, experiment, **match)
        if isinstance(found, str):
            return found
        pairs = sorted((float(row[column]), value(tables, row)) for _, row in found.iterrows())
        pairs = [(level, v) for level, v in pairs if math.isfinite(v)]
        if len(pairs) < 2:
            return f"{experiment} has fewer than two {column} levels with a value"
        levels, values = (np.array(x) for x in zip(*pairs))
        result = float(combine(levels, values))
        on = f"{experiment}: {column} " + ", ".join(f"{_text(level)}: {v:.3g}" for level, v in pairs)
        return Measured(result, on) if math.isfinite(result) else f"not defined on {on}"
    return measure


def _paired(value: Callable[[dict, pd.Series], float]):
    """S9: the fraction of sizes N at which the small step size's ``value`` exceeds the default step size's."""
    def measure(tables: dict) -> Measured | str:
        found = _conditions(tables, "S9", learner="thermal")
        if isinstance(found, str):
            return found
        sizes = sorted(set(found.step_size.astype(float)))
        if len(sizes) < 2:
            return "S9 has one step size"
        small, large = sizes[0], sizes[-1]
        wins, compared = 0, []
        for n in sorted(set(found.n_units)):
            rows = found[found.n_units == n]
            a = rows[np.isclose(rows.step_size.astype(float), small)]
            b = rows[np.isclose(rows.step_size.astype(float), large)]
            if a.empty or b.empty:
                continue
            x, y = value(tables, a.iloc[0]), value(tables, b.iloc[0])
            if math.isfinite(x) and math.isfinite(y):
                wins += x > y
                compared.append(f"N={n}: {x:.3g} vs {y:.3g}")
        if not compared:
            return "S9 has no size N with a value at both step sizes"
        return Measured(wins / len(compared), f"S9 at step size {small:g} vs {large:g}: " + ", ".join(compared))
    return measure


def _spearman(levels: np.ndarray, values: np.ndarray) -> float:
    """Spearman's rank correlation: Pearson's of the ranks (ties averaged), which is what pandas' 'spearman' computes
    through SciPy, a package morphbench does not need otherwise."""
    return float(pd.Series(levels).rank().corr(pd.Series(values).rank()))


def _largest_two(levels: np.ndarray, values: np.ndarray) -> float:
    """The relative difference of the values at the two largest levels: |v[-1] / v[-2] - 1|."""
    return abs(values[-1] / values[-2] - 1) if values[-2] > 0 else math.nan


def _plateau_u_eq(tables: dict, row: pd.Series) -> float:
    return float(row.u_eq) if bool(row.get("plateau", False)) else math.nan


def _steps_reached(tables: dict, row: pd.Series) -> float:
    return float(row.steps_to_threshold) if bool(row.get("plateau", False)) else math.nan


def _missed(tables: dict, row: pd.Series) -> float:
    return 1.0 - float(row.reached_fraction) if bool(row.get("plateau", False)) else math.nan


def _k0(tables: dict, row: pd.Series) -> float:
    return float(row.k_0) if bool(row.get("plateau", False)) else math.nan


def _log2_ratio(value: Callable[[dict, pd.Series], float], first: tuple[str, dict], second: tuple[str, dict]):
    """|log2| of ``value`` of one condition over another's: 0 when equal, 1 when a factor of 2 apart."""
    return _pair(value, first, second,
                 lambda x, y: abs(math.log2(x / y)) if x > 0 and y > 0 else math.nan, "against")


def _between(value: Callable[[dict, pd.Series], float], first: tuple[str, dict], second: tuple[str, dict]):
    """``value`` of a condition of one experiment minus that of a condition of another."""
    return _pair(value, first, second, lambda x, y: x - y, "minus")


def _pair(value: Callable[[dict, pd.Series], float], first: tuple[str, dict], second: tuple[str, dict],
          combine: Callable[[float, float], float], word: str):
    """A measure of two conditions (an experiment and its settings each): ``combine`` of their ``value``s."""
    def measure(tables: dict) -> Measured | str:
        a, b = _one(tables, first[0], **first[1]), _one(tables, second[0], **second[1])
        for found in (a, b):
            if isinstance(found, str):
                return found
        x, y = value(tables, a[0]), value(tables, b[0])
        result, on = combine(x, y), f"{a[1]} ({x:.3g}) {word} {b[1]} ({y:.3g})"
        return Measured(result, on) if math.isfinite(result) else f"not defined on {on}"
    return measure


def _s1_mean_of_peak(tables: dict) -> Measured | str:
    found, curve = _one(tables, "S1"), scan_curve(tables, 2)
    for part in (found, curve):
        if isinstance(part, str):
            return part
    peak = float(curve[0].ubar.max())
    mean = distribution("mean")(tables, found[0])
    if not peak > 0 or not math.isfinite(mean):
        return f"not defined on {found[1]} and {curve[1]}"
    return Measured(mean / peak, f"{found[1]}: mean {mean:.3g} over the peak {peak:.3g} of {curve[1]}")


# --- 3-unit landscapes ------------------------------------------------------------------------------------------


def landscape(tables: dict, name: str) -> tuple[np.ndarray, np.ndarray, str] | str:
    """The complete 3-unit scan ``name`` as a grid ``ubar[i, j]`` at dphi_2 = axis[i], dphi_3 = axis[j]."""
    scans = _table(tables, "scans")
    if scans.empty or "scan" not in scans:
        return "the suite has no scan results"
    points = scans[scans.scan == name]
    if points.empty or "dphi_3" not in points:
        return f"the suite has no 3-unit scan {name}"
    grid = points.pivot_table(index="dphi_2", columns="dphi_3", values="ubar", aggfunc="first")
    if grid.isna().any().any() or grid.shape[0] != grid.shape[1] or grid.shape[0] < 3:
        return f"scan {name} is not a complete square grid yet"
    return grid.to_numpy(dtype=float), grid.index.to_numpy(dtype=float), f"scan {name} ({grid.size} points)"


def peaks(grid: np.ndarray, prominence: float = PROMINENCE) -> list[tuple[tuple[int, int], float]]:
    """The maxima of a periodic landscape (8 neighbours, wrapping at both edges) and their prominences, those at
    least ``prominence`` times its range: cells are added from the highest down, each joining its added neighbours'
    groups; where two groups meet, the one with the lower peak ends, its prominence its peak minus the meeting
    height. The global maximum's prominence is the range."""
    n, m = grid.shape
    order = np.argsort(-grid, axis=None, kind="stable")
    parent: dict[int, int] = {}
    top: dict[int, int] = {}
    found: list[tuple[tuple[int, int], float]] = []

    def root(cell: int) -> int:
        while parent[cell] != cell:
            parent[cell] = parent[parent[cell]]
            cell = parent[cell]
        return cell

    flat = grid.ravel()
    for cell in order:
        cell = int(cell)
        parent[cell], top[cell] = cell, cell
        i, j = divmod(cell, m)
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                other = ((i + di) % n) * m + (j + dj) % m
                if other == cell or other not in parent:
                    continue
                a, b = root(cell), root(other)
                if a == b:
                    continue
                low, high = (a, b) if flat[top[a]] < flat[top[b]] else (b, a)
                if top[low] != cell:
                    found.append((divmod(top[low], m), float(flat[top[low]] - flat[cell])))
                parent[low] = high
    best = int(order[0])
    found.append((divmod(best, m), float(np.ptp(grid))))
    span = float(np.ptp(grid))
    return [(tuple(int(x) for x in at), height) for at, height in found if span > 0 and height >= prominence * span]


def abruptness(grid: np.ndarray) -> float:
    """The share of a periodic landscape's total variation (the sum of |dU| between neighbours along both axes)
    carried by its largest tenth of steps: about 0.25 on a smooth landscape, towards 1 on plateaus with sharp edges."""
    steps = np.abs(np.concatenate([(np.roll(grid, -1, 0) - grid).ravel(), (np.roll(grid, -1, 1) - grid).ravel()]))
    total = steps.sum()
    if not total > 0:
        return math.nan
    largest = np.sort(steps)[::-1][:max(1, len(steps) // 10)]
    return float(largest.sum() / total)


def _landscape_measure(name: str, quantity: Callable[[np.ndarray, np.ndarray], float]):
    def measure(tables: dict) -> Measured | str:
        found = landscape(tables, name)
        if isinstance(found, str):
            return found
        grid, axis, on = found
        value = quantity(grid, axis)
        return Measured(value, on) if math.isfinite(value) else f"not defined on {on}"
    return measure


def _at(grid: np.ndarray, axis: np.ndarray, dphi_2: float, dphi_3: float) -> float:
    """The grid's value at the point nearest (dphi_2, dphi_3) if it lies within half a grid step of it."""
    step = 1.0 / len(axis)
    distance = np.abs((axis - np.array([[dphi_2], [dphi_3]]) + 0.5) % 1.0 - 0.5)
    i, j = (int(np.argmin(row)) for row in distance)
    if distance[0, i] > step / 2 + 1e-9 or distance[1, j] > step / 2 + 1e-9:
        return math.nan
    return float(grid[i, j])


def _diagonal_distance(grid: np.ndarray, axis: np.ndarray) -> float:
    """How far the landscape's maximum is from dphi_2 = dphi_3, in cycles on the circle."""
    i, j = np.unravel_index(int(np.argmax(grid)), grid.shape)
    d = abs(axis[i] - axis[j]) % 1.0
    return float(min(d, 1.0 - d))


def _two_landscapes(first: str, second: str, quantity: Callable[[np.ndarray, np.ndarray], float], ratio=False):
    """``quantity`` of scan ``first`` against that of ``second`` (minus, or over); with ``quantity`` None, the
    Pearson correlation of the two grids."""
    def measure(tables: dict) -> Measured | str:
        a, b = landscape(tables, first), landscape(tables, second)
        for found in (a, b):
            if isinstance(found, str):
                return found
        if a[0].shape != b[0].shape:
            return f"{a[2]} and {b[2]} have different grids"
        if quantity is None:
            value = float(np.corrcoef(a[0].ravel(), b[0].ravel())[0, 1])
            return Measured(value, f"{a[2]} against {b[2]}")
        x, y = quantity(a[0], a[1]), quantity(b[0], b[1])
        return Measured(x - y, f"{a[2]} ({x:.3g}) minus {b[2]} ({y:.3g})")
    return measure


def _ground_spread(tables: dict) -> Measured | str:
    """The std over the S3-ground-* scans (one 3-unit landscape per friction field) at (0.4, 0.2) minus that at
    (0.4, 0.8): where the paper's track made the robot stop in places and where it did not."""
    scans = _table(tables, "scans")
    if scans.empty or "scan" not in scans:
        return "the suite has no scan results"
    names = sorted(name for name in scans.scan.unique() if str(name).startswith("S3-ground-"))
    grids = [landscape(tables, name) for name in names]
    grids = [g for g in grids if not isinstance(g, str)]
    if len(grids) < 2:
        return "the suite has fewer than two complete S3-ground-* scans (3-unit landscapes on varied grounds)"
    fragile = np.std([_at(g, axis, 0.4, 0.2) for g, axis, _ in grids])
    robust = np.std([_at(g, axis, 0.4, 0.8) for g, axis, _ in grids])
    return Measured(float(fragile - robust), f"{len(grids)} S3-ground scans: std {fragile:.3g} at (0.4, 0.2), "
                                              f"{robust:.3g} at (0.4, 0.8)")


def _hardware_gait(tables: dict) -> Measured | str:
    return _landscape_measure("S3", lambda g, axis: _at(g, axis, 0.4, 0.8))(tables)


T, F = {"learner": "thermal"}, {"learner": "flaky"}
UNIFORM = {"environment": "uniform"}
FIELD = {"environment": "friction-field"}
ONE_X_FRICTION = {"environment_id": M._default_ground()}
"""S7's ground at 1x friction: the default one, whose runs S4's uniform ground shares (and names)."""

CLAIMS: tuple[Claim, ...] = (
    # S2: the 2-unit curve (Fig. 1G)
    Claim("scan-2-peak", "S2", "The 2-unit scan's forward maximum is about 4.5 mm/cycle.", 4.5, "mm/cycle",
          _curve_measure(lambda d, u: float(np.max(u))), 1.0, "within", "Fig. 1G"),
    Claim("scan-2-peak-at", "S2", "The 2-unit scan peaks at a phase difference of about 0.4 (about alpha: a "
          "peristaltic wave).", 0.4, "cycles", _curve_measure(lambda d, u: float(d[np.argmax(u)])), 0.1, "phase",
          "Fig. 1G; SI Fig. S2"),
    Claim("scan-2-trough", "S2", "The model's 2-unit curve is about -4.5 mm/cycle at its minimum (symmetric "
          "forward and backward motion).", -4.5, "mm/cycle", _curve_measure(lambda d, u: float(np.min(u))), 1.0,
          "within", "Fig. 1G"),
    Claim("scan-2-trough-at", "S2", "The model's 2-unit curve has its minimum near a phase difference of 0.6.", 0.6,
          "cycles", _curve_measure(lambda d, u: float(d[np.argmin(u)])), 0.1, "phase", "Fig. 1G"),
    Claim("scan-2-antisymmetric", "S2", "The model's 2-unit curve is about antisymmetric: U(dphi) = -U(1 - dphi) "
          "(measured: rms of (U(d) + U(1-d))/2 over max |U|).", 0.0, "", _curve_measure(antisymmetry), 0.15,
          "at most", "Fig. 1G"),
    Claim("scan-2-one-optimum", "S2", "The model's 2-unit curve has no significant local optima (measured: maxima "
          f"standing out by {PROMINENCE:.0%} of its range: 1 is the peak alone).", 1, "",
          _curve_measure(lambda d, u: float(len(local_maxima(u)))), 0.0, "within", "Fig. 1G, Results of Two Units"),
    # S1: 2 units learning (Fig. 1D-F)
    Claim("S1-ridge", "S1", f"After about {LEARNED_AFTER} steps the 2-unit simulations' Ubar is distributed around "
          f"4.5 mm/cycle (measured: the ridge of the per-step trial Ubar after step {LEARNED_AFTER}, the mode of a "
          f"kernel density of bandwidth {M.RIDGE_BANDWIDTH:g} mm/cycle).", 4.5, "mm/cycle",
          _of("S1", distribution("ridge")), 0.5, "within", "Fig. 1F"),
    Claim("S1-around-optimum", "S1", "... with random perturbations around the optimal behaviour (measured: the mean "
          "of that distribution over the 2-unit scan's peak).", 0.75, "of the peak", _s1_mean_of_peak, 0.0,
          "at least", "Fig. 1F, Results of Two Units"),
    Claim("S1-level", "S1", "2-unit Thermal learning reaches about 4.5 mm/cycle (measured: U_eq of the fit to the "
          "seed-averaged curve).", 4.5, "mm/cycle", _metric_measure("u_eq", 2, need_plateau=True), 1.0, "within",
          "Fig. 1E-F"),
    Claim("S1-by-step-20", "S1", "The robot reaches its fastest speed after about 20 learning steps (measured: the "
          "seed-averaged Ubar over steps 18-22 over U_eq).", 0.8, "of U_eq", _of("S1", learned_by(20)), 0.0,
          "at least", "Fig. 1D-F"),
    Claim("S1-unimodal", "S1", f"The distribution of Ubar over seeds is unimodal after about {LEARNED_AFTER} steps "
          "(measured: Sarle's bimodality coefficient of each run's mean Ubar, above 5/9 bimodal).", BIMODAL, "",
          _unimodal_after, 0.0, "at most", "Fig. 1F"),
    Claim("S1-gait", "S1", "The learned phase difference is about 0.4, the scan's optimum (measured: circular mean "
          f"of the kept phi_2 - phi_1 after step {LEARNED_AFTER}).", 0.4, "cycles", _of("S1", learned_phase_difference),
          0.1, "phase", "Fig. 1D, Results of Two Units"),
    # S3: the 3-unit landscape (Fig. 2C)
    Claim("S3-maxima", "S3", f"The 3-unit landscape has multiple maxima (measured: maxima standing out by "
          f"{PROMINENCE:.0%} of its range).", 2, "maxima", _landscape_measure("S3", lambda g, a: float(len(peaks(g)))),
          0.0, "at least", "Fig. 2C"),
    # S4: 3 units, Thermal against Flaky, noise (Fig. 2A-B, 2G-H; SI Fig. S5)
    Claim("T-acceptance", "S4", "A noiseless 3-unit Thermal simulation accepts about 25% of trials once learned "
          "(measured: mean acceptance over the last 10% of steps).", 0.25, "of trials",
          _metric_measure("acceptance_final", 3), 0.1, "within", "Fig. 2B"),
    Claim("S4-thermal-improves", "S4", "3-unit Thermal simulations improve Ubar over the first about 50 steps and "
          "stabilise at a positive mean (measured: seed-averaged Ubar at steps 45-55 minus at steps 0-5).", 0.0,
          "mm/cycle", _of("S4", improvement, noise=0.0, **T, **UNIFORM), 0.0, "at least", "Fig. 2A"),
    Claim("S4-flaky-level", "S4", "With 3 units, Flaky reaches about 4 mm/cycle (measured: final Ubar, noiseless).",
          4.0, "mm/cycle", _of("S4", final_ubar, noise=0.0, **F, **UNIFORM), 1.0, "within", "Fig. 2G"),
    Claim("S4-flaky-acceptance", "S4", "Flaky accepts about 60% of trials (measured: mean acceptance, noiseless).",
          0.6, "of trials", _of("S4", metric("acceptance_mean"), noise=0.0, **F, **UNIFORM), 0.1, "within",
          "Fig. 2H"),
    Claim("S4-flaky-steady", "S4", "... independent of the learning step (measured: range of its acceptance over "
          f"blocks of 50 steps after step {LEARNED_AFTER}).", 0.0, "", _of("S4", acceptance_spread, noise=0.0, **F,
                                                                              **UNIFORM), 0.1, "at most", "Fig. 2H"),
    Claim("S4-flaky-noise-free", "S4", "Flaky's acceptance is not affected by the noise level (measured: range of "
          "its mean acceptance over the noise levels).", 0.0, "", _across("S4", metric("acceptance_mean"), "noise",
                                                                          lambda x, v: np.ptp(v), **F, **UNIFORM),
          0.1, "at most", "SI Fig. S5C"),
    Claim("S4-thermal-noise-acceptance", "S4", "Thermal's acceptance falls with noise (measured: its mean "
          "acceptance at the highest noise level minus noiseless).", -0.1, "", _noise_versus(
              metric("acceptance_mean"), {**T, **UNIFORM}, {**T, **UNIFORM}, noisy_second=False), 0.0, "at most",
          "SI Fig. S5C; A More Robust Learning Strategy"),
    Claim("S4-thermal-noise-ubar", "S4", "Noise reduces Thermal's ability to learn (measured: its final Ubar at the "
          "highest noise level minus noiseless).", 0.0, "mm/cycle", _noise_versus(
              final_ubar, {**T, **UNIFORM}, {**T, **UNIFORM}, noisy_second=False), 0.0, "at most",
          "SI Fig. S5A-B"),
    Claim("S4-thermal-memory", "S4", "Under noise, Thermal's memory overestimates the velocity the units now reach "
          "(measured: remembered minus true trial Ubar, highest noise level minus noiseless).", 0.0, "mm/cycle",
          _noise_versus(memory_excess, {**T, **UNIFORM}, {**T, **UNIFORM}, noisy_second=False), 0.0, "at least",
          "A More Robust Learning Strategy"),
    Claim("S4-flaky-noise", "S4", "Under noise Flaky is at least as fast as Thermal (measured: final Ubar, Flaky "
          "minus Thermal, highest noise level).", 0.0, "mm/cycle",
          _noise_versus(final_ubar, {**F, **UNIFORM}, {**T, **UNIFORM}), 0.0, "at least",
          "Fig. 2A, 2G; SI Fig. S5"),
    Claim("S4-flaky-field", "S4", "On a ground whose friction varies, with noise, Flaky is at least as fast as "
          "Thermal (measured: final Ubar, Flaky minus Thermal, friction field, highest noise level).", 0.0,
          "mm/cycle", _noise_versus(final_ubar, {**F, **FIELD}, {**T, **FIELD}), 0.0, "at least",
          "Fig. 2A, 2G (experiments); A More Robust Learning Strategy"),
    # S5: friction drop (SI Fig. S6)
    Claim("S5-flaky-after", "S5", "After a sudden change of friction Flaky re-adapts and Thermal does not "
          "(measured: Ubar from the event on, Flaky minus Thermal).", 0.0, "mm/cycle",
          _versus("S5", ubar_after_event, F, T), 0.0, "at least", "SI Fig. S6"),
    Claim("S5-thermal-stops", "S5", "After the change Thermal stops accepting (measured: its acceptance over the "
          f"{WINDOW} steps after the event over the {WINDOW} before).", 0.5, "", _of("S5", acceptance_ratio, **T),
          0.0, "at most", "SI Fig. S6; A More Robust Learning Strategy"),
    Claim("S5-flaky-accepts", "S5", "Flaky keeps accepting after the change (measured: its acceptance over the "
          f"{WINDOW} steps after the event minus the {WINDOW} before).", 0.0, "", _of("S5", acceptance_change, **F),
          0.1, "within", "SI Fig. S6; Fig. 2H"),
    Claim("S5-uniform-faster", "S5-uniform", "Not the paper's: a drop of every body's friction alike speeds a "
          "learned gait up, since in the quasi-static limit only the bellows' compliance notices it (measured: "
          f"Thermal's Ubar over the {WINDOW} steps after the drop minus the {WINDOW} before).", 0.0, "mm/cycle",
          _of("S5-uniform", ubar_change, **T), 0.0, "at least", "docs/paper.md, S5"),
    # S6: damage (Fig. 3; SI Figs. S4, S7)
    Claim("S6-flaky-after", "S6", "After the damage Flaky adapts and Thermal gets stuck (measured: Ubar from the "
          "damage on, Flaky minus Thermal).", 0.0, "mm/cycle", _versus("S6", ubar_after_event, F, T), 0.0,
          "at least", "Fig. 3E-F; SI Fig. S7"),
    Claim("S6-thermal-stuck", "S6", "Thermal gets stuck at a phase after the damage (measured: its acceptance over "
          f"the {WINDOW} steps after the damage over the {WINDOW} before).", 0.5, "", _of("S6", acceptance_ratio, **T),
          0.0, "at most", "Fig. 3E; SI Fig. S7"),
    Claim("S6-landscape", "S6", "The damage dramatically alters the behaviours the robot can exhibit (measured: "
          "correlation of the 3-unit landscape before and after it).", 0.5, "", _two_landscapes("S3", "S6-damaged",
                                                                                               None), 0.0,
          "at most", "Fig. 3C-D; SI Fig. S4"),
    # S7: higher friction (SI Fig. S3E-F)
    Claim("S7-abrupt", "S7", "At higher friction the landscape changes abruptly with phase: plateaus with sharp "
          "edges (measured: abruptness, the share of its variation in its largest tenth of steps, at 1.5x friction "
          "minus at 1x).", 0.0, "", _two_landscapes("S7", "S3", lambda g, a: abruptness(g)), 0.0, "at least",
          "SI Fig. S3E-F; A More Robust Learning Strategy"),
    Claim("S7-flaky-resets", "S7", "... where Flaky's memory resets almost at once and it accepts nearly any phase "
          "(measured: Flaky's mean acceptance at 1.5x friction minus at 1x).", 0.0, "",
          _versus("S7", metric("acceptance_mean"), {**F, "environment": "friction-1.5"},
                  {**F, **ONE_X_FRICTION}), 0.0, "at least", "A More Robust Learning Strategy"),
    Claim("S7-flaky-struggles", "S7", "... so Flaky starts to have problems (measured: Flaky's final Ubar as a "
          "fraction of its landscape's best, 1.5x friction minus 1x).", 0.0, "",
          _versus("S7", metric("learned_fraction"), {**F, "environment": "friction-1.5"},
                  {**F, **ONE_X_FRICTION}), 0.0, "at most", "A More Robust Learning Strategy"),
    # S8: 7 units (Fig. 4A-B)
    Claim("S8-level", "S8", "With 7 units the average velocity is about 2.5 mm/cycle (measured: final Ubar).", 2.5,
          "mm/cycle", _of("S8", final_ubar, n_units=7, **T), 1.0, "within", "Fig. 4B"),
    Claim("S8-below-3", "S8", "... lower than with 3 units (measured: final Ubar, 7 units minus 3, Thermal, "
          "noiseless).", 0.0, "mm/cycle", _between(final_ubar, ("S8", {"n_units": 7, **T}),
                                                  ("S4", {"noise": 0.0, **T, **UNIFORM})), 0.0, "at most", "Fig. 4B"),
    Claim("S8-rate", "S8", "... learnt within a comparable number of steps (measured: |log2| of the fit's k_0, 7 "
          "units over 3).", 0.0, "", _log2_ratio(_k0, ("S8", {"n_units": 7, **T}),
                                                  ("S4", {"noise": 0.0, **T, **UNIFORM})), 1.0, "at most", "Fig. 4B"),
    Claim("S8-peaks", "S8", "The 7-unit robot occasionally reaches about 4 mm/cycle but cannot maintain it "
          f"(measured: the 99th percentile of per-step trial Ubar after step {LEARNED_AFTER}).", 4.0, "mm/cycle",
          _of("S8", distribution("q99"), n_units=7, **T), 1.0, "within", "Fig. 4B"),
    # S9: scaling (Fig. 4C-D)
    Claim("S9-falls", "S9", "U_eq decreases with the number of units (measured: Spearman correlation of U_eq with "
          "N, step size 0.1).", -0.8, "", _across("S9", _plateau_u_eq, "n_units", _spearman, step_size=0.1, **T), 0.0,
          "at most", "Fig. 4C"),
    Claim("S9-levels-off", "S9", "... and levels off (measured: relative difference of U_eq at the two largest N).",
          0.0, "", _across("S9", _plateau_u_eq, "n_units", _largest_two, step_size=0.1, **T), 0.2, "at most",
          "Fig. 4C"),
    Claim("S9-asymptote", "S9", "... near 1.7 mm/cycle (measured: U_eq at the largest N).", 1.7, "mm/cycle",
          _across("S9", _plateau_u_eq, "n_units", lambda x, v: v[-1], step_size=0.1, **T), 0.5, "within", "Fig. 4C"),
    Claim("S9-rate-flat", "S9", f"The number of units does not affect the rate of learning (measured: largest over "
          f"smallest mean steps to {M.THRESHOLD:g} U_eq over N).", 1.0, "", _across(
              "S9", _steps_reached, "n_units", lambda x, v: v.max() / v.min() if v.min() > 0 else math.nan,
              step_size=0.1, **T), 1.0, "at most", "Fig. 4D"),
    Claim("S9-35-steps", "S9", f"On average the units need about 35 steps to reach {M.THRESHOLD:g} U_eq (measured: "
          "mean over N of the mean steps, as Fig. 4D counts them).", 35, "steps", _across(
              "S9", _steps_reached, "n_units", lambda x, v: v.mean(), step_size=0.1, **T), 15.0, "within",
          "Fig. 4D"),
    Claim("S9-small-step-higher", "S9", "A smaller step size gives a higher U_eq (measured: fraction of the sizes N "
          "where U_eq at 0.025 exceeds U_eq at 0.1).", 1.0, "of sizes", _paired(_plateau_u_eq), 0.2,
          "at least", "Fig. 4C"),
    Claim("S9-small-step-slower", "S9", "... at the cost of learning rate (measured: fraction of the sizes N where "
          f"the steps to {M.THRESHOLD:g} U_eq at 0.025 exceed those at 0.1).", 1.0, "of sizes",
          _paired(_steps_reached), 0.2, "at least", "Fig. 4D"),
    Claim("S9-small-step-misses", "S9", f"At step size 0.025 some runs do not reach {M.THRESHOLD:g} U_eq (measured: "
          "the largest fraction of runs that do not, over N).", 0.01, "of runs",
          _across("S9", _missed, "n_units", lambda x, v: v.max(), step_size=0.025, **T), 0.0, "at least",
          "Fig. 4D; SI Fig. S8B"),
    # S10, S11: shuffle and cut (Conclusion; Movie S5)
    Claim("S10-relearns", "S10", "Reordered units keep their ability to learn (measured: Flaky's Ubar over the last "
          f"{WINDOW} steps over that of the {WINDOW} before the shuffle).", 0.8, "", _of("S10", kept_level, **F), 0.0,
          "at least", "Conclusion; Movie S5 (experiments)"),
    Claim("S11-both-learn", "S11", "Cut in two, both parts keep learning to move (measured: the lower of the two "
          f"pieces' Ubar over the last {WINDOW} steps, Flaky).", 0.5, "mm/cycle", _of("S11", weakest_piece, **F), 0.0,
          "at least", "Conclusion"),
    # findings of the paper's experiments: the hardware, modelled by morphbench's options
    Claim("hw-trough", "S2 (hardware)", "With pump vibration (the hardware), the 2-unit curve is about -3 mm/cycle "
          "at its minimum.", -3.0, "mm/cycle", _curve_measure(lambda d, u: float(np.min(u)), vibration=True), 1.0,
          "within", "Fig. 1G-H"),
    Claim("hw-local-max", "S2 (hardware)", "With pump vibration (the hardware), the 2-unit curve has a local maximum "
          "of about 1 mm/cycle ...", 1.0, "mm/cycle", _second_maximum(1), 0.5, "within", "Fig. 1F-H"),
    Claim("hw-local-max-at", "S2 (hardware)", "... near a phase difference of 0.9.", 0.9, "cycles", _second_maximum(0),
          0.1, "phase", "Fig. 1G-H"),
    Claim("hw-3-gait", "S3 (hardware)", "The 3-unit gait (0.4, 0.8) is a maximum of about 4.5 mm/cycle (measured: "
          "the 3-unit landscape there).", 4.5, "mm/cycle", _hardware_gait, 1.0, "within", "Fig. 2D-F"),
    Claim("hw-3-track", "S3 (hardware)", "The gait (0.4, 0.2) depends on where the robot is on the track, (0.4, 0.8) "
          "does not (measured: std over landscapes on varied grounds, there minus at (0.4, 0.8)).", 0.0, "mm/cycle",
          _ground_spread, 0.0, "at least", "Fig. 2E-F; SI Figs. S3, S4A"),
    Claim("hw-damaged-optimum", "S6 (hardware)", "After the damage the global optimum has units 2 and 3 actuating "
          "together (measured: distance of the damaged landscape's maximum from dphi_2 = dphi_3).", 0.0, "cycles",
          _landscape_measure("S6-damaged", _diagonal_distance), 0.1, "at most", "Fig. 3D; Adaptivity to Damage"),
)
"""The paper's findings, statement by statement, in the order of docs/paper.md."""


# --- the paper's experiments, on the hardware twin (benchmarks/paper-hardware.toml; docs/hardware.md) -------------

HARDWARE_SUITE = "paper-hardware"
"""the name of the suite whose results HARDWARE_CLAIMS are measured on (benchmarks/paper-hardware.toml)."""
MIN_TRACK_PLACES = 2
"""the fewest places along the track a claim about the track reads (scans NAME, NAME-at-1, ...)."""
STOPPED = 0.5
"""mm/cycle: a gait slower than this at a place of the track has stopped there (Fig. 2F: "a complete stop")."""
TRACK_SPREAD = 0.25
"""mm/cycle: the least difference of spreads over the track (hw-3-track) that shows one gait depends on the place
and the other does not; the paper suite's hw-3-track asks only for a difference >= 0, which equal grounds meet."""


def _track_names(tables: dict, name: str) -> list[str]:
    """The suite's scans of one gait map along the track: ``name`` (at the start) and ``name-at-1``, ``name-at-2``,
    ... (at other places: the environment's friction_field.offset), in that order."""
    scans = _table(tables, "scans")
    if scans.empty or "scan" not in scans:
        return []
    names = [str(n) for n in scans.scan.unique()]
    at = sorted((n for n in names if n.startswith(f"{name}-at-") and n[len(name) + 4:].isdigit()),
                key=lambda n: int(n[len(name) + 4:]))
    return ([name] if name in names else []) + at


def track_curves(tables: dict, name: str) -> tuple[np.ndarray, np.ndarray, str] | str:
    """The complete 2-unit curves of ``_track_names(name)`` as ``(dphi, ubar[place, point])``, and what they are."""
    scans = _table(tables, "scans")
    curves, axis = [], None
    for scan in _track_names(tables, name):
        points = scans[scans.scan == scan]
        if "dphi_2" not in points or "dphi_3" in points.dropna(axis=1, how="all"):
            continue
        if "samples" in points and len(points) < int(points.samples.iloc[0]):
            continue  # an unfinished scan: its extremes may be missing
        points = points.sort_values("dphi_2")
        dphi = points.dphi_2.to_numpy(dtype=float)
        if axis is not None and (len(dphi) != len(axis) or not np.allclose(dphi, axis)):
            return f"the scans {name}, {name}-at-* have different phase grids"
        axis = dphi
        curves.append(points.ubar.to_numpy(dtype=float))
    if not curves:
        return f"the suite has no complete 2-unit scan {name} (or {name}-at-*)"
    return axis, np.array(curves), f"scan {name} at {len(curves)} places of the track ({len(axis)} points each)"


def track_maps(tables: dict, name: str) -> tuple[np.ndarray, np.ndarray, str] | str:
    """The complete 3-unit landscapes of ``_track_names(name)`` as ``(grids[place, i, j], axis)``, and what they are."""
    grids, axis = [], None
    for scan in _track_names(tables, name):
        found = landscape(tables, scan)
        if isinstance(found, str):
            continue
        if axis is not None and (found[0].shape != grids[0].shape or not np.allclose(found[1], axis)):
            return f"the scans {name}, {name}-at-* have different grids"
        grids.append(found[0])
        axis = found[1]
    if not grids:
        return f"the suite has no complete 3-unit scan {name} (or {name}-at-*)"
    return np.array(grids), axis, f"scan {name} at {len(grids)} places of the track ({grids[0].size} points each)"


def _track_curve_measure(quantity: Callable[[np.ndarray, np.ndarray], float], name: str = "hw-S2"):
    """A measuring function of ``quantity(dphi, ubar)`` of the 2-unit curve averaged over the places of the track:
    what the robot does at those phases wherever it is (the experiments' curve, Fig. 1G-H)."""
    def measure(tables: dict) -> Measured | str:
        found = track_curves(tables, name)
        if isinstance(found, str):
            return found
        dphi, curves, on = found
        value = quantity(dphi, curves.mean(axis=0))  # NaN: what is claimed is not there (no second maximum)
        return Measured(value, f"the mean over {on}" + ("" if math.isfinite(value) else ": none found"))
    return measure


def _second_of(which: int):
    """``quantity`` for _track_curve_measure: the phase (``which`` 0) or Ubar (1) of the curve's highest significant
    local maximum below its global one (NaN without one: the claimed maximum is not there)."""
    def quantity(dphi: np.ndarray, ubar: np.ndarray) -> float:
        maxima = sorted(local_maxima(ubar), key=lambda m: -ubar[m[0]])
        return float((dphi, ubar)[which][maxima[1][0]]) if len(maxima) >= 2 else math.nan
    return quantity


def _track_map_measure(quantity: Callable[[np.ndarray, np.ndarray], float], name: str = "hw-S3",
                       places: int = 1):
    """A measuring function of ``quantity(grids, axis)`` of the 3-unit landscapes at the places of the track
    (``grids[place, i, j]``; at least ``places`` of them)."""
    def measure(tables: dict) -> Measured | str:
        found = track_maps(tables, name)
        if isinstance(found, str):
            return found
        grids, axis, on = found
        if len(grids) < places:
            return f"{on}: a claim about the track needs {places} places or more"
        value = quantity(grids, axis)
        return Measured(value, on) if math.isfinite(value) else f"not defined on {on}"
    return measure


def _torus_distance(axis: np.ndarray, i: int, j: int, dphi_2: float, dphi_3: float) -> float:
    d = np.abs((np.array([axis[i], axis[j]]) - np.array([dphi_2, dphi_3]) + 0.5) % 1.0 - 0.5)
    return float(np.hypot(*d))


def _mean_map_maximum_from(dphi_2: float, dphi_3: float):
    """How far (in cycles, on the torus) the maximum of the mean landscape over the places lies from the point."""
    def quantity(grids: np.ndarray, axis: np.ndarray) -> float:
        i, j = np.unravel_index(int(np.argmax(grids.mean(axis=0))), grids.shape[1:])
        return _torus_distance(axis, int(i), int(j), dphi_2, dphi_3)
    return quantity


def _over_places(reduce, dphi_2: float, dphi_3: float):
    """``reduce`` over the places of the landscapes' values at (dphi_2, dphi_3)."""
    return lambda grids, axis: float(reduce([_at(g, axis, dphi_2, dphi_3) for g in grids]))


def _track_spread(grids: np.ndarray, axis: np.ndarray) -> float:
    """The std over the places at (0.4, 0.2) minus that at (0.4, 0.8) (as hw-3-track on the paper suite)."""
    return float(np.std([_at(g, axis, 0.4, 0.2) for g in grids]) - np.std([_at(g, axis, 0.4, 0.8) for g in grids]))


def _mean_map(quantity: Callable[[np.ndarray, np.ndarray], float]):
    return lambda grids, axis: quantity(grids.mean(axis=0), axis)


def damaged_phase_share(grid: np.ndarray, axis: np.ndarray) -> float:
    """How much the damaged unit 2's phase still matters on a landscape ``grid[i, j]`` (dphi_2 = axis[i], unit 2's
    phase with unit 1 at 0): the mean over dphi_3 of the std of Ubar along dphi_2, over the std of the whole map. 0
    when unit 2's phase changes nothing (a unit that only pumps air out of an open bellows, without vibration)."""
    spread = float(np.std(grid))
    return float(np.mean(np.std(grid, axis=0)) / spread) if spread > 0 else math.nan


def density_modes(values, bandwidth: float = M.RIDGE_BANDWIDTH, prominence: float = PROMINENCE
                  ) -> list[tuple[float, float]]:
    """The modes of the Gaussian kernel density of ``values`` (standard deviation ``bandwidth``, on metrics.ridge's
    grid of bandwidth / 20) that stand out by ``prominence`` of its highest density, as (where, density), the
    highest first."""
    grid = M.kernel_density(values, bandwidth)
    if grid is None:
        return []
    where, density = grid  # zero at both ends: the curve's wrap is no mode
    found = [(float(where[i]), float(density[i])) for i, _ in local_maxima(density, prominence)]
    return sorted(found, key=lambda mode: -mode[1])


def second_mode(tables: dict, row: pd.Series) -> float:
    """Where the second-highest mode of the distribution of the condition's per-step measured Ubar after step
    LEARNED_AFTER lies (Fig. 1F's experiments: a second optimum); NaN with one mode only."""
    steps = _steps_of(tables, row)
    modes = density_modes(steps.ubar[steps.step > LEARNED_AFTER])
    return float(modes[1][0]) if len(modes) >= 2 else math.nan


def _second_mode_of(experiment: str):
    """A measuring function of ``second_mode`` of the experiment's first condition: one mode only is a value (NaN)
    that does not hold, not a claim left unmeasured."""
    def measure(tables: dict) -> Measured | str:
        found = _one(tables, experiment)
        if isinstance(found, str):
            return found
        row, on = found
        value = second_mode(tables, row)
        return Measured(value, on if math.isfinite(value) else f"{on}: one mode only")
    return measure


def measured_ridge(tables: dict, row: pd.Series) -> float:
    """The highest mode of the per-step measured Ubar after step LEARNED_AFTER (Fig. 1F's ridge, as the units
    measured it)."""
    steps = _steps_of(tables, row)
    return M.ridge(steps.ubar[steps.step > LEARNED_AFTER].to_numpy(dtype=float))


def acceptance_between(first: int, last: int) -> Callable[[dict, pd.Series], float]:
    """The mean acceptance over every run's learning steps ``first`` to ``last``."""
    def value(tables: dict, row: pd.Series) -> float:
        steps = _steps_of(tables, row)
        return float(steps.acceptance[(steps.step >= first) & (steps.step <= last)].mean())
    return value


def late_fall(first: int = 150, last: int = 250, window: int = 100) -> Callable[[dict, pd.Series], float]:
    """The seed-averaged true Ubar over the last ``window`` steps minus that over steps ``first`` to ``last``:
    negative when the mean falls late in learning (NaN when the runs end before ``last`` + ``window``)."""
    def value(tables: dict, row: pd.Series) -> float:
        steps = _steps_of(tables, row)
        end = int(steps.step.max())
        if end < last + window:
            return math.nan
        late = steps.ubar_true[steps.step > end - window].mean()
        return float(late - steps.ubar_true[(steps.step >= first) & (steps.step <= last)].mean())
    return value


def acceptance_after_event(tables: dict, row: pd.Series) -> float:
    """The mean acceptance over the WINDOW steps from the first event on."""
    steps, event = _steps_of(tables, row), _event_step(row)
    return float(steps.acceptance[(steps.step >= event) & (steps.step < event + WINDOW)].mean())


def _hw(claim_id: str, scenario: str, statement: str, paper: float, unit: str, measure, tolerance: float, rule: str,
        source: str) -> Claim:
    return Claim(claim_id, f"{scenario} (hardware)", statement, paper, unit, measure, tolerance, rule, source,
                 HARDWARE_SUITE)


HARDWARE_CLAIMS: tuple[Claim, ...] = (
    # hw-S2: the 2-unit curve along the track (Fig. 1G-H)
    _hw("hw-peak", "hw-S2", "The experiments' 2-unit curve has its maximum at about 4.5 mm/cycle (measured: the "
        "curve averaged over the places of the track).", 4.5, "mm/cycle",
        _track_curve_measure(lambda d, u: float(np.max(u))), 1.0, "within", "Fig. 1G-H"),
    _hw("hw-peak-at", "hw-S2", "... at a phase difference of about 0.4.", 0.4, "cycles",
        _track_curve_measure(lambda d, u: float(d[np.argmax(u)])), 0.1, "phase", "Fig. 1G-H"),
    _hw("hw-trough", "hw-S2", "With pump vibration (the hardware), the 2-unit curve is about -3 mm/cycle at its "
        "minimum.", -3.0, "mm/cycle", _track_curve_measure(lambda d, u: float(np.min(u))), 1.0, "within",
        "Fig. 1G-H"),
    _hw("hw-trough-at", "hw-S2", "... near a phase difference of 0.6 (the reversed gait).", 0.6, "cycles",
        _track_curve_measure(lambda d, u: float(d[np.argmin(u)])), 0.1, "phase", "Fig. 1G-H"),
    _hw("hw-local-max", "hw-S2", "With pump vibration (the hardware), the 2-unit curve has a local maximum of about "
        "1 mm/cycle ...", 1.0, "mm/cycle", _track_curve_measure(_second_of(1)), 0.5, "within", "Fig. 1F-H"),
    _hw("hw-local-max-at", "hw-S2", "... near a phase difference of 0.9.", 0.9, "cycles",
        _track_curve_measure(_second_of(0)), 0.1, "phase", "Fig. 1G-H"),
    # hw-S1: 2 units learning (Fig. 1F)
    _hw("hw-S1-ridge", "hw-S1", f"After about {LEARNED_AFTER} steps the experiments' 2-unit Ubar is distributed "
        f"around 4.5 mm/cycle (measured: the highest mode of the per-step measured Ubar after step {LEARNED_AFTER}).",
        4.5, "mm/cycle", _of("hw-S1", measured_ridge), 0.5, "within", "Fig. 1F"),
    _hw("hw-S1-second-mode", "hw-S1", "... with a second optimum at about 1 mm/cycle (measured: the second-highest "
        f"mode of that distribution, standing out by {PROMINENCE:.0%} of its density).", 1.0, "mm/cycle",
        _second_mode_of("hw-S1"), 0.5, "within", "Fig. 1F; Results of Two Units"),
    # hw-S3: the 3-unit landscape at places along the track (Fig. 2D-F; SI Figs. S3, S4A)
    _hw("hw-3-gait", "hw-S3", "The 3-unit gait (0.4, 0.8) is a maximum of about 4.5 mm/cycle (measured: the "
        "landscape averaged over the places of the track, there).", 4.5, "mm/cycle",
        _track_map_measure(_mean_map(lambda g, a: _at(g, a, 0.4, 0.8))), 1.0, "within", "Fig. 2D-F"),
    _hw("hw-3-maximum-at", "hw-S3", "... the experiments' global maximum (measured: distance of the averaged "
        "landscape's maximum from (0.4, 0.8), on the torus).", 0.0, "cycles", _track_map_measure(
            _mean_map_maximum_from(0.4, 0.8)), 0.1, "at most", "Fig. 2D"),
    _hw("hw-3-track", "hw-S3", "The gait (0.4, 0.2) depends on where the robot is on the track, (0.4, 0.8) does not "
        "(measured: std over the places of the track, there minus at (0.4, 0.8); unlike the paper suite's, a track "
        f"the same everywhere does not pass: at least {TRACK_SPREAD:g} mm/cycle).", TRACK_SPREAD, "mm/cycle",
        _track_map_measure(_track_spread, places=MIN_TRACK_PLACES), 0.0, "at least", "Fig. 2E-F; SI Figs. S3, S4A"),
    _hw("hw-3-stops", "hw-S3", "The gait (0.4, 0.2) comes to a complete stop on some parts of the track (measured: "
        "its lowest Ubar over the places).", 0.0, "mm/cycle", _track_map_measure(
            _over_places(min, 0.4, 0.2), places=MIN_TRACK_PLACES), STOPPED, "within", "Fig. 2F; Movie S2"),
    _hw("hw-3-goes", "hw-S3", "... and reaches about 2 mm/cycle on others (measured: its highest Ubar over the "
        "places).", 2.0, "mm/cycle", _track_map_measure(_over_places(max, 0.4, 0.2), places=MIN_TRACK_PLACES), 1.0,
        "within", "Fig. 2F; Movie S2"),
    _hw("hw-3-robust", "hw-S3", "The gait (0.4, 0.8) keeps about 4.5 mm/cycle all along the track (measured: its "
        "lowest Ubar over the places).", 4.5, "mm/cycle", _track_map_measure(
            _over_places(min, 0.4, 0.8), places=MIN_TRACK_PLACES), 1.0, "at least", "Fig. 2E-F; Movie S2"),
    # hw-S4: 3 units learning, Thermal and Flaky (Fig. 2A-B, 2G-H)
    _hw("hw-thermal-improves", "hw-S4", "In the experiments too, 3-unit Thermal learning improves Ubar over the "
        "first about 50 steps (measured: seed-averaged Ubar at steps 45-55 minus at steps 0-5).", 0.0, "mm/cycle",
        _of("hw-S4", improvement, **T), 0.0, "at least", "Fig. 2A"),
    _hw("hw-thermal-acceptance", "hw-S4", "The experiments' Thermal acceptance approaches zero soon after the "
        "learning starts (measured: mean acceptance over steps 50-100).", 0.0, "of trials",
        _of("hw-S4", acceptance_between(50, 100), **T), 0.1, "at most", "Fig. 2B"),
    _hw("hw-thermal-falls", "hw-S4", "... and the mean Ubar decreases after about 200 steps (measured: seed-averaged "
        "Ubar over the last 100 steps minus over steps 150-250).", -0.25, "mm/cycle", _of("hw-S4", late_fall(), **T),
        0.0, "at most", "Fig. 2A"),
    _hw("hw-flaky-level", "hw-S4", "With Flaky the experiments reach about 4 mm/cycle (measured: final Ubar).", 4.0,
        "mm/cycle", _of("hw-S4", final_ubar, **F), 1.0, "within", "Fig. 2G"),
    _hw("hw-flaky-acceptance", "hw-S4", "... accepting about 60% of the trials, whatever the step (measured: mean "
        "acceptance).", 0.6, "of trials", _of("hw-S4", metric("acceptance_mean"), **F), 0.1, "within", "Fig. 2H"),
    _hw("hw-flaky-ahead", "hw-S4", "On the hardware Flaky adapts to the noise and the track where Thermal does not "
        "(measured: final Ubar, Flaky minus Thermal).", 0.0, "mm/cycle", _versus("hw-S4", final_ubar, F, T), 0.0,
        "at least", "Fig. 2A, 2G; A More Robust Learning Strategy"),
    # hw-S6: the needle removed at step 300 (Fig. 3; SI Fig. S7)
    _hw("hw-damaged-optimum", "hw-S6", "After the damage the global optimum has units 2 and 3 actuating together "
        "(measured: distance of the damaged landscape's maximum, averaged over the places of the track, from "
        "dphi_2 = dphi_3).", 0.0, "cycles", _track_map_measure(_mean_map(_diagonal_distance), "hw-S6-damaged"), 0.1,
        "at most", "Fig. 3D; Adaptivity to Damage"),
    _hw("hw-damaged-phase", "hw-S6", "The damaged unit's phase still matters: by pumping it changes its friction "
        "(measured: mean std of the damaged landscape along unit 2's phase over its whole std, averaged over the "
        "places).", 0.3, "", _track_map_measure(_mean_map(damaged_phase_share), "hw-S6-damaged"), 0.0, "at least",
        "Adaptivity to Damage; SI Fig. S7"),
    _hw("hw-damage-thermal-stuck", "hw-S6", "After the damage Thermal gets stuck at a phase (measured: its mean "
        f"acceptance over the {WINDOW} steps after the damage).", 0.0, "of trials",
        _of("hw-S6", acceptance_after_event, **T), 0.1, "at most", "Fig. 3E; Movie S3"),
    _hw("hw-damage-flaky-adapts", "hw-S6", "... while Flaky overcomes the damage by adapting its phases (measured: "
        "Ubar from the damage on, Flaky minus Thermal).", 0.0, "mm/cycle", _versus("hw-S6", ubar_after_event, F, T),
        0.0, "at least", "Fig. 3E-F; Movie S3"),
    # hw-S8: 7 units (Fig. 4B)
    _hw("hw-7-level", "hw-S8", "The experiments' 7-unit robot moves at about 2.5 mm/cycle after 300 steps (measured: "
        "final Ubar of 300-step runs).", 2.5, "mm/cycle", _of("hw-S8", final_ubar, n_units=7, **T), 1.0, "within",
        "Fig. 4B"),
)
"""The paper's experimental findings, checked on the hardware twin's results (benchmarks/paper-hardware.toml, the
environment preset ``hardware``; docs/hardware.md lists them with the effects each needs)."""

SUITE_CLAIMS: dict[str, tuple[Claim, ...]] = {HARDWARE_SUITE: HARDWARE_CLAIMS}
"""The suites checked against claims of their own, by suite name."""


def claims_for(suite: str | None, includes: tuple[str, ...] | list[str] = ()) -> tuple[Claim, ...]:
    """The claims a report on suite ``suite`` checks: the suite's own (SUITE_CLAIMS), else the paper's, CLAIMS; then,
    for each suite of ``includes`` (the names of those it includes) that has claims of its own, each of them in place
    of the claim of the same id, the others after (the tuple itself when that changes none)."""
    own = SUITE_CLAIMS.get(suite or "", CLAIMS)
    merged = {claim.id: claim for claim in own}  # a replaced id keeps its place
    for name in includes:
        merged.update((claim.id, claim) for claim in SUITE_CLAIMS.get(name, ()))
    claims = tuple(merged.values())
    return own if len(claims) == len(own) and all(a is b for a, b in zip(claims, own)) else claims
