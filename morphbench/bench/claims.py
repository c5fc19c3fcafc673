"""The paper's quantitative statements, each checked against a suite's stored tables (no simulation).

The spec (shared/spec/robotic-matter.md, section 3) quotes the numbers the paper reports; morphbench's defaults are
calibrated to reproduce its simulations. Each ``Claim`` here is one of them: an id, the statement, the paper's value,
a function that measures the same quantity from the tables of a results directory (``runs``, ``steps``, ``units``,
``scans``, ``metrics``: morphbench.bench.store and metrics), a tolerance and the rule that decides whether it holds:

- ``within``: |measured - paper| <= tolerance;
- ``phase``: the same on the circle of phases (a distance in cycles, wrapped: 0.95 is 0.1 from 0.05);
- ``at most`` / ``at least``: measured <= paper + tolerance / measured >= paper - tolerance.

A measuring function returns a ``Measured`` (the value and what it was measured on) or, when the suite lacks what it
needs, a sentence saying what is missing: the claim is then 'not measured', never an error. ``check(tables)`` gives
one ``Verdict`` per claim, in the order of ``CLAIMS``. A new claim is one more entry of ``CLAIMS``.

The tolerances are this project's reading of the paper's "about": a quarter of a peak of 4.5 mm/cycle, a tenth of a
cycle of phase, ten percentage points of acceptance.
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
LEARNED_AFTER = 20
"""the learning step after which the paper calls 2-unit Thermal learning done (its distribution unimodal)."""


@dataclass(frozen=True)
class Measured:
    value: float
    on: str
    """what it was measured on: 'scan S2 (50 points)', 'S1: chain-2 thermal (112 runs)'."""


@dataclass(frozen=True)
class Claim:
    id: str
    scenario: str
    """the spec's scenario (S1, S2, ...) or 'calibration'."""
    statement: str
    paper: float
    unit: str
    measure: Callable[[dict[str, pd.DataFrame]], Measured | str]
    tolerance: float
    rule: str
    """one of RULES (see the module doc)."""

    def holds(self, value: float) -> bool:
        if not math.isfinite(value):
            return False
        if self.rule == "within":
            return abs(value - self.paper) <= self.tolerance
        if self.rule == "phase":
            distance = abs(value - self.paper) % 1.0
            return min(distance, 1.0 - distance) <= self.tolerance
        if self.rule == "at most":
            return value <= self.paper + self.tolerance
        if self.rule == "at least":
            return value >= self.paper - self.tolerance
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
    measured unless the fit found a plateau (no U_eq, and no steps to reach a fraction of it, without one); steps to
    the threshold that no run reached are infinite (the claim does not hold)."""
    def measure(tables: dict) -> Measured | str:
        found = condition(tables, n_units)
        if isinstance(found, str):
            return found
        row, on = found
        if need_plateau and not bool(row.get("plateau", False)):
            return f"no plateau on {on}: U_eq would be an extrapolation"
        value = float(row[column])
        if column == "steps_to_threshold" and not math.isfinite(value) and row.get("reached_fraction") == 0:
            return Measured(math.inf, f"{on}: no run reached it")
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


CLAIMS: tuple[Claim, ...] = (
    Claim("scan-2-peak", "S2", "The 2-unit scan's forward maximum is about 4.5 mm/cycle.", 4.5, "mm/cycle",
          _curve_measure(lambda d, u: float(np.max(u))), 1.0, "within"),
    Claim("scan-2-peak-at", "S2", "The 2-unit scan peaks at a phase difference of about 0.4 (about alpha: a "
          "peristaltic wave).", 0.4, "cycles", _curve_measure(lambda d, u: float(d[np.argmax(u)])), 0.1, "phase"),
    Claim("scan-2-trough", "S2", "The model's 2-unit curve is about -4.5 mm/cycle at its minimum.", -4.5, "mm/cycle",
          _curve_measure(lambda d, u: float(np.min(u))), 1.0, "within"),
    Claim("scan-2-trough-at", "S2", "The model's 2-unit curve has its minimum near a phase difference of 0.6.", 0.6,
          "cycles", _curve_measure(lambda d, u: float(d[np.argmin(u)])), 0.1, "phase"),
    Claim("scan-2-antisymmetric", "S2", "The model's 2-unit curve is about antisymmetric: U(dphi) = -U(1 - dphi) "
          "(measured: rms of (U(d) + U(1-d))/2 over max |U|).", 0.0, "", _curve_measure(antisymmetry), 0.15,
          "at most"),
    Claim("scan-2-one-optimum", "S2", "The model's 2-unit curve has no significant local optima (measured: maxima "
          f"standing out by {PROMINENCE:.0%} of its range: 1 is the peak alone).", 1, "",
          _curve_measure(lambda d, u: float(len(local_maxima(u)))), 0.0, "within"),
    Claim("S1-level", "S1", "2-unit Thermal learning reaches about 4.5 mm/cycle (measured: U_eq of the fit to the "
          "seed-averaged curve).", 4.5, "mm/cycle", _metric_measure("u_eq", 2, need_plateau=True), 1.0, "within"),
    Claim("S1-speed", "S1", f"... within about {LEARNED_AFTER} learning steps (measured: mean steps to "
          f"{M.THRESHOLD:g} U_eq).", LEARNED_AFTER, "steps", _metric_measure("steps_to_threshold", 2, True), 10.0,
          "at most"),
    Claim("S1-every-run", "S1", f"... in every one of 112 simulations (measured: the fraction of runs reaching "
          f"{M.THRESHOLD:g} U_eq).", 1.0, "of runs", _metric_measure("reached_fraction", 2, True), 0.0,
          "at least"),
    Claim("S1-unimodal", "S1", f"The distribution of Ubar over seeds is unimodal after about {LEARNED_AFTER} steps "
          "(measured: Sarle's bimodality coefficient, above 5/9 bimodal).", BIMODAL, "", _unimodal_after, 0.0,
          "at most"),
    Claim("T-acceptance", "calibration", "A noiseless 3-unit Thermal simulation accepts about 25% of trials once "
          "learned (measured: mean acceptance over the last 10% of steps).", 0.25, "of trials",
          _metric_measure("acceptance_final", 3), 0.1, "within"),
    Claim("hw-trough", "S2 (hardware)", "With pump vibration (the hardware), the 2-unit curve is about -3 mm/cycle "
          "at its minimum.", -3.0, "mm/cycle", _curve_measure(lambda d, u: float(np.min(u)), vibration=True), 1.0,
          "within"),
    Claim("hw-local-max", "S2 (hardware)", "With pump vibration (the hardware), the 2-unit curve has a local maximum "
          "of about 1 mm/cycle ...", 1.0, "mm/cycle", _second_maximum(1), 0.5, "within"),
    Claim("hw-local-max-at", "S2 (hardware)", "... near a phase difference of 0.9.", 0.9, "cycles", _second_maximum(0),
          0.1, "phase"),
)
"""Section 3 of the spec, statement by statement."""
