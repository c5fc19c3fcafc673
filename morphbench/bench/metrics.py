"""Metrics of a suite's results: pure functions of DataFrames (the store's tables), no simulation, no files.

Per condition (a run's configuration without its seed), over its seeds:
- the learning curve: mean and quantiles of Ubar at each learning step, mean acceptance at each step (``curves``);
- final Ubar: each run's mean over its last 10% of learning steps, then mean and std over runs;
- U_eq, U_0, k_0: the fit ``U(k) = U_eq - (U_eq - U_0) exp(-k / k_0)`` to the seed-averaged curve
  (``fit_exponential``: a grid over k_0 with linear least squares for U_eq and U_0, refined by golden section);
- steps to reach ``THRESHOLD`` x U_eq: the first learning step at which each run's Ubar reaches it (mean and std
  over the runs that reach it, and the fraction that do); not defined (NaN) when U_eq <= 0 or the fit found no
  plateau within the window (``plateau`` False);
- acceptance at the end (mean over the last 10% of steps) and over the whole run;
- the assembly's velocity along its heading (each run's ``final_u_heading``) and its turning rate (each run's
  ``turning_rate_deg_per_cycle``, ``turning_rate``), mean and std over the finished runs that have them;
- the best Ubar of the suite's scans of the same shape (same shape content, same physics, same ground: the
  environment without its noise) and the fraction of it that learning reached (final Ubar / scan best);
- for conditions with events, recovery from the first one: the steps each run takes, from the event's step, to
  regain ``RECOVERY_FRACTION`` of its pre-event level (its mean Ubar over the ``RECOVERY_WINDOW`` steps before the
  event), ``recovery_steps`` (mean and std over the runs that do) and ``recovered_fraction`` (``recovery_steps``);
  ``event_recovery`` gives the same for every event, with Ubar before, just after and at the end of its stretch.

As the paper measures them (docs/paper.md): ``step_distribution`` (Fig. 1F: the per-step Ubar of every run after a
step, its ridge, the mode of a Gaussian kernel density of bandwidth ``RIDGE_BANDWIDTH``, and its mean),
``equilibrium`` (Fig. 4C-D: U_eq of the fit to the seed-averaged curve, steps to ``THRESHOLD`` x U_eq and the fraction
of runs that reach it) and ``memory_ubar`` (Ubar of the velocities the learners remember, beside the trial one).

For the figures: ``ubar_distribution`` (the fraction of a condition's runs in each Ubar bin at each step),
``piece_curves`` (Ubar of each piece of a cut assembly, from the units table) and ``phase_differences`` (the phase
differences a run tried, by position, as a landscape's axes).

Ubar here is ``ubar_true`` by default: the robot's true speed, which measurement noise does not blur (the
learners themselves only ever see ``ubar``, the measured one). Pass ``column='ubar'`` for the measured one.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pandas as pd

from morphbench.params import environment_id
from morphbench.bench.store import DAMAGED, SUMMARY_COLUMNS
from morphbench.experiment.records import final_value
from morphbench.learning.base import wrap_phases
from morphbench.params import EnvironmentParams

THRESHOLD = 0.8
PLATEAU_SPANS = 3.0
"""a fit has a plateau when k_0 <= (last step - first step) / PLATEAU_SPANS."""
QUANTILES = (0.1, 0.25, 0.5, 0.75, 0.9)
_GOLDEN = (math.sqrt(5) - 1) / 2
RECOVERY_FRACTION = 0.8
RECOVERY_WINDOW = 20
RIDGE_BANDWIDTH = 0.25
"""mm/cycle: the kernel's standard deviation for the ridge of a Ubar distribution (half the 0.5 mm/cycle bins of
the report's distribution figures). On the quick suite's S1 (800 values) the ridge is 4.70, 4.60 and 4.44 mm/cycle at
bandwidths 0.15, 0.25 and 0.5; with a few hundred values a narrower kernel can already pick a small cluster (a 4-run
3-unit Flaky condition: -0.01 at 0.15, 3.31 at 0.25)."""
LEARNED_AFTER = 20
"""the learning step after which the paper calls 2-unit learning done ("the distribution stabilizes ... after about
20 learning steps", Fig. 1F)."""


def fit_exponential(k, u, n_grid: int = 400) -> dict[str, float]:
    """Least-squares fit of ``u = U_eq - (U_eq - U_0) exp(-k / k_0)``: ``{'u_eq', 'u_0', 'k_0', 'rmse'}``.

    For a fixed k_0 the model is linear in (U_eq, U_0), so the fit scans k_0 over a log grid from a tenth of the
    smallest step spacing to 100x the span of ``k``, solves the linear least squares at each, then refines the best
    k_0 by golden-section search on log k_0 between its grid neighbours. ``plateau`` says whether the curve levels
    off inside the window: k_0 at most a third of the span of ``k`` (the fit covers 95% of its way from U_0 to U_eq).
    Without one, U_eq is an extrapolation far beyond the data and says little.
    """
    k = np.asarray(k, dtype=float)
    u = np.asarray(u, dtype=float)
    keep = np.isfinite(k) & np.isfinite(u)
    k, u = k[keep], u[keep]
    nan = {"u_eq": math.nan, "u_0": math.nan, "k_0": math.nan, "rmse": math.nan, "plateau": False}
    if len(k) < 3 or np.ptp(k) == 0:
        return nan
    span = float(np.ptp(k))
    spacing = float(np.min(np.diff(np.unique(k))))
    log_grid = np.linspace(math.log(spacing / 10), math.log(span * 100), n_grid)
    sse = np.array([_linear_fit(k, u, math.exp(g))[2] for g in log_grid])
    best = int(np.nanargmin(sse))
    lo, hi = log_grid[max(best - 1, 0)], log_grid[min(best + 1, n_grid - 1)]
    a, b = hi - _GOLDEN * (hi - lo), lo + _GOLDEN * (hi - lo)
    fa, fb = _linear_fit(k, u, math.exp(a))[2], _linear_fit(k, u, math.exp(b))[2]
    for _ in range(60):
        if fa < fb:
            hi, b, fb = b, a, fa
            a = hi - _GOLDEN * (hi - lo)
            fa = _linear_fit(k, u, math.exp(a))[2]
        else:
            lo, a, fa = a, b, fb
            b = lo + _GOLDEN * (hi - lo)
            fb = _linear_fit(k, u, math.exp(b))[2]
    log_k0 = (lo + hi) / 2
    if _linear_fit(k, u, math.exp(log_k0))[2] > sse[best]:
        log_k0 = log_grid[best]
    u_eq, u_0, error = _linear_fit(k, u, math.exp(log_k0))
    return {"u_eq": u_eq, "u_0": u_0, "k_0": math.exp(log_k0), "rmse": math.sqrt(error / len(k)),
            "plateau": math.exp(log_k0) <= span / PLATEAU_SPANS}


def _linear_fit(k: np.ndarray, u: np.ndarray, k0: float) -> tuple[float, float, float]:
    """(U_eq, U_0, sum of squared residuals) of the best fit at a fixed k_0."""
    e = np.exp(-k / k0)
    var = np.var(e)
    if var < 1e-300:  # exp(-k/k0) is constant over k: only the mean is determined
        mean = float(np.mean(u))
        return mean, mean, float(np.sum((u - mean) ** 2))
    slope = float(np.mean((e - e.mean()) * (u - u.mean())) / var)  # u = U_eq + slope * e, slope = U_0 - U_eq
    u_eq = float(u.mean() - slope * e.mean())
    residual = u - (u_eq + slope * e)
    return u_eq, u_eq + slope, float(np.sum(residual ** 2))


def steps_to_reach(steps: np.ndarray, ubar: np.ndarray, threshold: float) -> float:
    """The first learning step at which ``ubar >= threshold``, NaN if never (or if the threshold is NaN)."""
    if not math.isfinite(threshold):
        return math.nan
    reached = np.flatnonzero(np.asarray(ubar, dtype=float) >= threshold)
    return float(np.asarray(steps)[reached[0]]) if len(reached) else math.nan


def recovery_steps(steps, ubar, event_step: int, fraction: float = RECOVERY_FRACTION,
                   window: int = RECOVERY_WINDOW) -> float:
    """Steps from ``event_step`` to the first step at or after it whose Ubar regains ``fraction`` of the pre-event
    level (the mean Ubar over the ``window`` steps before the event, fewer if the run has fewer): 0 when the event
    did not bring Ubar below that, ``inf`` when the run never regains it ('never'), NaN when the pre-event level is
    not positive (no forward motion to regain) or there is no step before or after the event."""
    steps, ubar = np.asarray(steps), np.asarray(ubar, dtype=float)
    before = ubar[(steps < event_step) & (steps >= event_step - window)]
    after = steps >= event_step
    if not len(before) or not after.any():
        return math.nan
    level = float(np.mean(before))
    if not level > 0:
        return math.nan
    regained = np.flatnonzero(ubar[after] >= fraction * level)
    return float(steps[after][regained[0]] - event_step) if len(regained) else math.inf


def first_event_step(events) -> int | None:
    """The learning step of the first event recorded in a run's ``event`` column ('' where none), or None."""
    if events is None:
        return None
    happened = [i for i, text in enumerate(events) if isinstance(text, str) and text]
    return happened[0] if happened else None


def curves(steps: pd.DataFrame, column: str = "ubar_true") -> pd.DataFrame:
    """Per condition and learning step: runs, mean and quantiles (q10, q25, q50, q75, q90) of Ubar, mean acceptance."""
    if steps.empty:
        return pd.DataFrame(columns=["condition_id", "step", "runs", "mean", *_qnames(), "acceptance"])
    grouped = steps.groupby(["condition_id", "step"], sort=True)
    table = grouped[column].agg(runs="count", mean="mean").reset_index()
    quantiles = grouped[column].quantile(list(QUANTILES)).unstack()
    quantiles.columns = _qnames()
    table = table.join(quantiles, on=["condition_id", "step"])
    table["acceptance"] = grouped.acceptance.mean().to_numpy()
    return table


def ridge(values, bandwidth: float = RIDGE_BANDWIDTH) -> float:
    """The mode of the Gaussian kernel density of ``values`` with standard deviation ``bandwidth``: where a heat map
    of the distribution is brightest, exact to kernel_density's grid; NaN without a finite value."""
    grid = kernel_density(values, bandwidth)
    return math.nan if grid is None else float(grid[0][int(np.argmax(grid[1]))])


def kernel_density(values, bandwidth: float = RIDGE_BANDWIDTH) -> tuple[np.ndarray, np.ndarray] | None:
    """The Gaussian kernel density (standard deviation ``bandwidth``) of the finite ``values``, unnormalised, on a
    grid of bandwidth / 20 (values binned on it, the kernel convolved over the bins) reaching 4 bandwidths beyond
    them, zero at both ends: (grid points, density), or None without a finite value or a positive bandwidth."""
    x = np.asarray(values, dtype=float)
    x = x[np.isfinite(x)]
    if not len(x) or not bandwidth > 0:
        return None
    width = bandwidth / 20
    reach = int(math.ceil(4 * bandwidth / width))
    lo = x.min() - reach * width
    counts = np.bincount(np.round((x - lo) / width).astype(np.int64))
    counts = np.concatenate([counts, np.zeros(reach + 1)])
    kernel = np.exp(-0.5 * (np.arange(-reach, reach + 1) * width / bandwidth) ** 2)
    density = np.convolve(counts, kernel, mode="same")
    return lo + np.arange(len(density)) * width, density


def step_distribution(steps: pd.DataFrame, after: int = LEARNED_AFTER, column: str = "ubar_true",
                      bandwidth: float = RIDGE_BANDWIDTH) -> dict[str, float]:
    """Fig. 1F's distribution of Ubar over runs and learning steps after step ``after``, of one condition's steps:
    ``ridge`` (``ridge``), ``mean``, ``q99`` (the highest speeds it reaches now and then) and ``values`` (how many)."""
    values = steps.loc[steps.step > after, column].to_numpy(dtype=float)
    values = values[np.isfinite(values)]
    if not len(values):
        return {"ridge": math.nan, "mean": math.nan, "q99": math.nan, "values": 0}
    return {"ridge": ridge(values, bandwidth), "mean": float(values.mean()),
            "q99": float(np.quantile(values, 0.99)), "values": len(values)}


def equilibrium(steps: pd.DataFrame, column: str = "ubar_true", threshold: float = THRESHOLD) -> dict[str, float]:
    """Fig. 4C-D for one condition's steps: ``u_eq``, ``u_0``, ``k_0``, ``fit_rmse``, ``plateau`` of the fit to the
    seed-averaged curve (``fit_exponential``); ``threshold`` (``threshold`` x U_eq, NaN without a plateau or with
    U_eq <= 0: an extrapolated U_eq is no equilibrium), each run's first step at or above it (``steps_to_reach``):
    ``steps_to_threshold`` (mean) and ``steps_to_threshold_std`` over the runs that reach it, as Fig. 4D counts them,
    and ``reached_fraction``, the fraction of runs that do (NaN without a threshold)."""
    mean_curve = steps.groupby("step")[column].mean()
    fit = fit_exponential(mean_curve.index.to_numpy(), mean_curve.to_numpy())
    target = threshold * fit["u_eq"] if fit["u_eq"] > 0 and fit["plateau"] else math.nan
    per_run = [g.sort_values("step") for _, g in steps.groupby("run_id", sort=False)]
    reach = np.array([steps_to_reach(g.step.to_numpy(), g[column].to_numpy(), target) for g in per_run])
    return {"u_eq": fit["u_eq"], "u_0": fit["u_0"], "k_0": fit["k_0"], "fit_rmse": fit["rmse"],
            "plateau": fit["plateau"], "threshold": target, "steps_to_threshold": _mean(reach[np.isfinite(reach)]),
            "steps_to_threshold_std": _std(reach[np.isfinite(reach)]),
            "reached_fraction": float(np.isfinite(reach).mean()) if len(reach) and math.isfinite(target) else math.nan}


def memory_ubar(units: pd.DataFrame) -> pd.DataFrame:
    """Per run and step, the mean over the living units (a finite ``u_measured``) of ``u_memory`` (``ubar_memory``,
    what the learners remember), ``u_true`` (``ubar_true``, the trial's true speed) and ``u_measured`` (``ubar``):
    the remembered Ubar beside the trial one. Empty for units stored before ``u_memory`` existed."""
    columns = ["run_id", "step", "ubar_memory", "ubar_true", "ubar"]
    if units.empty or not {"run_id", "step", "u_memory", "u_true", "u_measured"} <= set(units.columns):
        return pd.DataFrame(columns=columns)
    living = units[units.u_measured.notna()]
    table = living.groupby(["run_id", "step"], sort=True).agg(ubar_memory=("u_memory", "mean"),
                                                              ubar_true=("u_true", "mean"), ubar=("u_measured", "mean"))
    return table.reset_index()[columns]


def condition_metrics(steps: pd.DataFrame, runs: pd.DataFrame, scans: pd.DataFrame | None = None,
                      column: str = "ubar_true", threshold: float = THRESHOLD) -> pd.DataFrame:
    """One row per condition of ``runs`` (see the module doc); ``steps`` and ``runs`` are the store's tables."""
    rows = []
    best = scan_best(scans) if scans is not None else {}
    condition_cols = condition_columns(runs)
    for condition_id, members in runs.groupby("condition_id", sort=False):
        row = members.iloc[0][condition_cols].to_dict()
        row["runs"] = len(members)
        row["failed"] = int((members.status == "failed").sum())
        row["missing"] = int(members.status.isin(("missing", DAMAGED)).sum())  # no result to use either way
        mine = steps[steps.condition_id == condition_id]
        per_run = [g.sort_values("step") for _, g in mine.groupby("run_id", sort=False)]
        finals = np.array([final_value(g.step, g[column]) for g in per_run])
        row["final_ubar"] = _mean(finals)
        row["final_ubar_std"] = _std(finals)
        row.update(equilibrium(mine, column, threshold))
        acceptance = mine.groupby("step").acceptance.mean()
        row["acceptance_final"] = final_value(acceptance.index, acceptance.to_numpy())
        row["acceptance_mean"] = float(acceptance[acceptance.index > 0].mean()) if len(acceptance) else math.nan
        done = members[members.status == "done"]
        row["final_u_heading"], row["final_u_heading_std"] = _over_runs(done, "final_u_heading")
        row["turning_rate"], row["turning_rate_std"] = _over_runs(done, "turning_rate_deg_per_cycle")
        row.update(_recovery(per_run, column))
        key = (row.get("shape_id"), row.get("physics"), row.get("environment_id", _default_ground()))
        row["scan_best_ubar"] = best.get(key, math.nan)
        row["learned_fraction"] = (row["final_ubar"] / row["scan_best_ubar"]
                                   if row["scan_best_ubar"] > 0 else math.nan)
        rows.append({"condition_id": condition_id, **row})
    return pd.DataFrame(rows)


def condition_columns(runs: pd.DataFrame) -> list[str]:
    """The columns of the store's runs table that make a condition (a run's configuration without its seed)."""
    return [c for c in runs.columns if c not in _RUN_ONLY]


def _recovery(per_run: list[pd.DataFrame], column: str) -> dict[str, float]:
    """recovery_step (the first event's step), recovery_steps (+ std) and recovered_fraction over the runs."""
    nan = {"recovery_step": math.nan, "recovery_steps": math.nan, "recovery_steps_std": math.nan,
           "recovered_fraction": math.nan}
    if not per_run or "event" not in per_run[0]:
        return nan
    values, event_steps = [], []
    for g in per_run:
        index = first_event_step(g.event.tolist())
        if index is None:
            continue
        event_steps.append(int(g.step.iloc[index]))
        values.append(recovery_steps(g.step.to_numpy(), g[column].to_numpy(), event_steps[-1]))
    values = np.array(values)
    defined = values[~np.isnan(values)]
    if not len(defined):
        return {**nan, "recovery_step": float(min(event_steps)) if event_steps else math.nan}
    finite = defined[np.isfinite(defined)]
    return {"recovery_step": float(min(event_steps)), "recovery_steps": _mean(finite),
            "recovery_steps_std": _std(finite), "recovered_fraction": float(len(finite) / len(defined))}


def _over_runs(runs: pd.DataFrame, column: str) -> tuple[float, float]:
    """Mean and std of a summary column of the runs table over the runs where it is finite (NaN, NaN without
    any: a run stored before the column existed has NaN there, a runs table built by hand may lack it)."""
    values = runs[column].to_numpy(dtype=float) if column in runs else np.array([])
    values = values[np.isfinite(values)]
    return _mean(values), _std(values)


def scan_best(scans: pd.DataFrame) -> dict[tuple, float]:
    """The highest Ubar of any healthy scan point, per (shape_id, physics, environment_id) (scans of results written
    before scans had environments: the default ground). A damaged scan is left out: it says nothing of what the
    healthy robot could do."""
    scans = healthy_scans(scans)
    if scans is None or scans.empty:
        return {}
    scans = scans if "environment_id" in scans else scans.assign(environment_id=_default_ground())
    scans = scans.fillna({"environment_id": _default_ground()})
    grouped = scans.groupby(["shape_id", "physics", "environment_id"]).ubar.max()
    return {key: float(value) for key, value in grouped.items()}


def healthy_scans(scans: pd.DataFrame | None) -> pd.DataFrame | None:
    """The points of the scans of an undamaged assembly (``damage`` 'none'; all of them in results written before
    scans could be damaged)."""
    if scans is None or "damage" not in scans:
        return scans
    return scans[scans.damage.isna() | (scans.damage == "none")]


def ubar_distribution(steps: pd.DataFrame, edges, column: str = "ubar_true") -> tuple[np.ndarray, np.ndarray]:
    """The distribution of one condition's per-run Ubar over its runs at each learning step: ``(learning steps,
    fraction)``, ``fraction[b, k]`` the fraction of the runs with a finite Ubar at step ``k`` whose Ubar falls in bin
    ``b`` of ``edges`` (increasing; a value outside them counts in the first or last bin, so each column sums to 1;
    a step where no run has a value is a column of zeros)."""
    edges = np.asarray(edges, dtype=float)
    table = steps[["step", column]].dropna()
    values = np.sort(table.step.unique())
    fraction = np.zeros((len(edges) - 1, len(values)))
    if not len(values):
        return values, fraction
    column_of = np.searchsorted(values, table.step.to_numpy())
    bins = np.clip(np.searchsorted(edges, table[column].to_numpy(dtype=float), side="right") - 1, 0, len(edges) - 2)
    np.add.at(fraction, (bins, column_of), 1.0)
    return values, fraction / np.maximum(fraction.sum(axis=0), 1.0)


def event_recovery(steps: pd.DataFrame, column: str = "ubar_true", fraction: float = RECOVERY_FRACTION,
                   window: int = RECOVERY_WINDOW) -> pd.DataFrame:
    """One row per condition and event (in step order; the events a step recorded, '; '-joined, are one event here):
    ``condition_id``, ``event_index`` (0 = first), ``event_step``, ``event`` (its text), ``runs`` (runs that recorded
    it), per run mean Ubar over the ``window`` steps before it (``ubar_before``), over the ``window`` steps from it on
    (``ubar_after``, the drop) and over the last ``window`` steps of its stretch, up to the next event or the run's end
    (``ubar_end``), each mean and ``_std`` over runs; ``recovery_steps`` (``recovery_steps``, within the stretch: mean
    and std over the runs that regain ``fraction`` of the level before) and ``recovered_fraction`` (of the runs where
    it is defined)."""
    columns = ["condition_id", "event_index", "event_step", "event", "runs", "ubar_before", "ubar_before_std",
               "ubar_after", "ubar_after_std", "ubar_end", "ubar_end_std", "recovery_steps", "recovery_steps_std",
               "recovered_fraction"]
    if steps.empty or "event" not in steps:
        return pd.DataFrame(columns=columns)
    marked = steps.event.notna() & steps.event.ne("")
    steps = steps[steps.run_id.isin(steps.run_id[marked].unique())]  # only runs with events: the loop costs per run
    found: dict[tuple, dict[str, list]] = {}
    for (condition_id, _), run in steps.groupby(["condition_id", "run_id"], sort=False):
        run = run.sort_values("step")
        k, u = run.step.to_numpy(), run[column].to_numpy(dtype=float)
        marked = [(int(step), text) for step, text in zip(k, run.event) if isinstance(text, str) and text]
        for index, (step, text) in enumerate(marked):
            end = marked[index + 1][0] if index + 1 < len(marked) else math.inf
            stretch = k < end
            values = found.setdefault((condition_id, index, step, text), {"before": [], "after": [], "end": [],
                                                                           "recovery": []})
            values["before"].append(_mean(u[(k < step) & (k >= step - window)]))
            values["after"].append(_mean(u[(k >= step) & (k < min(step + window, end))]))
            values["end"].append(_mean(u[stretch & (k >= step)][-window:]))
            values["recovery"].append(recovery_steps(k[stretch], u[stretch], step, fraction, window))
    rows = []
    for (condition_id, index, step, text), values in found.items():
        row = {"condition_id": condition_id, "event_index": index, "event_step": step, "event": text,
               "runs": len(values["before"])}
        for name in ("before", "after", "end"):
            finite = np.array(values[name])
            finite = finite[np.isfinite(finite)]
            row[f"ubar_{name}"], row[f"ubar_{name}_std"] = _mean(finite), _std(finite)
        recovery = np.array(values["recovery"])
        defined = recovery[~np.isnan(recovery)]
        recovered = defined[np.isfinite(defined)]
        row.update(recovery_steps=_mean(recovered), recovery_steps_std=_std(recovered),
                   recovered_fraction=float(len(recovered) / len(defined)) if len(defined) else math.nan)
        rows.append(row)
    return pd.DataFrame(rows, columns=columns)


def piece_curves(units: pd.DataFrame) -> pd.DataFrame:
    """Per run, step and piece of a cut assembly (units.parquet's ``piece``): ``ubar`` (mean ``u_true`` of the
    piece's units that are not dead, the way steps.parquet scores the whole assembly) and ``n_units``."""
    columns = ["run_id", "step", "piece", "n_units", "ubar"]
    if units.empty or not {"run_id", "step", "piece", "u_true"} <= set(units.columns):
        return pd.DataFrame(columns=columns)
    alive = units[units.u_measured.notna()] if "u_measured" in units else units
    table = alive.groupby(["run_id", "step", "piece"], sort=True).u_true.agg(n_units="count", ubar="mean")
    return table.reset_index()[columns]


def phase_differences(units: pd.DataFrame, column: str = "phase_tried") -> pd.DataFrame:
    """One run's phases as a landscape's coordinates: per step, ``dphi_2``, ``dphi_3``, ... the phase of the unit at
    position 2, 3, ... minus that of the unit at position 1 (the front), wrapped to [0, 1), as a scan's axes are.
    By position, not unit number: a scan knows only places in the chain (a shuffled unit moves on the map)."""
    order = "position" if "position" in units else "unit"
    wide = units.pivot_table(index="step", columns=order, values=column, aggfunc="first").sort_index()
    table = pd.DataFrame({"step": wide.index.to_numpy()})
    for place in wide.columns[1:]:
        table[f"dphi_{int(place)}"] = wrap_phases(wide[place].to_numpy() - wide[wide.columns[0]].to_numpy())
    return table


@functools.cache
def _default_ground() -> str:
    """The environment id of the default ground."""
    return environment_id(EnvironmentParams())


_RUN_ONLY = {"run_id", "condition_id", "experiments", "seed", "status", "error", *SUMMARY_COLUMNS, "wall_time_s"}


def _qnames() -> list[str]:
    return [f"q{round(q * 100):02d}" for q in QUANTILES]


def _mean(values: np.ndarray) -> float:
    return float(np.mean(values)) if len(values) else math.nan


def _std(values: np.ndarray) -> float:
    """Sample standard deviation over runs (NaN for fewer than two)."""
    return float(np.std(values, ddof=1)) if len(values) > 1 else math.nan
