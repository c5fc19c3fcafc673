"""Why the learners lose the gait as an assembly grows, measured four ways (issue 37, part 2), for chains of 2 to 100
units and square sheets of 4 to 1,024: the generated section of docs/scaling.md and its figures
(docs/media/scaling-*.png).

    python benchmarks/scaling_causes.py --workers 2                  # the section and figures (about 20 minutes)
    python benchmarks/scaling_causes.py --quick --workers 2 --doc /tmp/scaling.md    # a look (about 3 minutes;
                                                                                      # the page needs the markers)

(a), (b) and (c) are measured at fixed phases with no learner, each measurement a fresh world (``credit.
step_velocities``: ``SETTLE`` cycles at a base, then the base plus a phase change, each unit's velocity measured by the
ideal sensor cycle by cycle for ``HORIZON`` cycles; its last quarter is the settled gait). The bases: the assembly's
best travelling wave (the lag of benchmarks/waves.csv, measured here for an assembly it lacks) and ``random_bases``
random phase vectors. At each base, ``probes`` units (all of them in a smaller assembly) are probed:

(a) Signal. A probe changes its phase alone by -0.1, -0.05, +0.05 and +0.1 cycles: the change of its own measured
    velocity from the unchanged base's (its signal) and of the assembly's mean Ubar. Then ``joint`` trials in which
    every unit moves by its own uniform(-s, s) (Thermal: all units try) and as many in which each unit moves with
    probability p = 0.25 (sparse), the same draws, for s = 0.05 (sparse's step) and 0.1 (Thermal's): a probe's own
    part of what it then measures is its lone response at its own draw (interpolated between the lone trials), the
    rest is interference. The signal-to-interference ratio is the mean square own part of a uniform(-s, s) trial over
    the mean square interference, in the cycle sparse judges (the 2nd after the change) and in Thermal's (cycles 1-2);
    "right sign" is how often a trying unit's measured change has the sign of its own part.
(b) Trial-gait distance: the settled Ubar of each joint trial less the base's, |dU| and dU (the loss of a trial at the
    wave), against the RMS phase distance of the trial, sqrt(N / 3) s (sqrt(p N / 3) s when a fraction p tries).
(c) Transient: a probe's own velocity change cycle by cycle after its lone change against its settled change: the
    fraction of the settled change each cycle shows (the regression slope through 0 over the lone trials) and how
    often cycle 1, cycle 2 and cycles 1-2 have the wrong sign (over trials whose settled change is at least
    SIGN_FLOOR of their RMS).
(d) U_eq against the step size: Thermal and sparse (each at its own settings but the step size) at step sizes 0.025,
    0.05, 0.1 and 0.2, ``steps`` learning steps from random phases (seeds 0, 1, ...), ideal sensor; a run's U_eq is its
    mean true Ubar over the last third of its steps (the last 100 of 300), set against the best wave. A condition's
    seeds run as one batch (``experiment.driver.run_batch``) where the backend can hold them.

Physics: the default ('auto': the chain solver for chains, the planar solver for sheets of up to 100 units, the
dynamic model beyond). Everything drawn comes from ``--seed`` and each measurement or batch of runs is computed alone,
so the results are the same whatever ``--workers``.

Cost, measured on the 2-core machine (2026-12-03, beside other work; process CPU time), the model of ``cycle_cost``
and ``job_cost``: a fixed-phase measurement (a fresh world, 36 cycles of a chain, 10 of a sheet) 0.05 s for chain-100,
0.17 s for sheet-4x4, 1.3 s for sheet-8x8 (the planar solver), 0.18 s for sheet-16x16 and 0.7 s for sheet-32x32 (the
dynamic model); a 300-step learning run 0.2 s for chain-2 to chain-20, 0.5 s chain-50, 1.1 s chain-100, 2.4 s
sheet-2x2, 11 s sheet-4x4, about 2 min sheet-8x8, 11 s sheet-16x16 and 56 s sheet-32x32 (Thermal; sparse a little
less). In all about 430 CPU s for (a)-(c), half of it the 8 x 8 sheet, and 2,050 for (d), 960 of it the 8 x 8 sheet's
8 runs (hence 1 seed for it and for the 1,024-unit sheet, 2 for the 16- and 256-unit sheets): about 41 CPU minutes,
21 minutes on 2 idle cores (``--workers 2``). ``--quick``: about 6 CPU minutes, 3 on 2 cores. The script prints its
estimate (``estimate``) before it starts and its wall time in the section's last line.
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Callable, Mapping

import numpy as np

from morphbench.experiment.scan import wave_lags, wave_phases

sys.path.insert(0, str(Path(__file__).resolve().parent))
import credit  # noqa: E402  (a sibling script: the fixed-phase measurement of a phase change)
from waves import CSV as WAVES, CYCLES as WAVE_CYCLES, DISCARD as WAVE_DISCARD, wave_ubar  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
DOC = ROOT / "docs" / "scaling.md"
BEGIN = "<!-- generated by benchmarks/scaling_causes.py: edit that script, not this section -->"
END = "<!-- end of the section generated by benchmarks/scaling_causes.py -->"
CHAINS = (2, 5, 10, 20, 50, 100)
"""active units of the chains measured (each with a dummy at the rear: shapes/chain-N.toml, benchmarks/shapes/ for
50 and 100)."""
SHEETS = (2, 4, 8, 16, 32)
"""sides of the square sheets measured (benchmarks/shapes/sheet-NxN.toml)."""
SIGNAL_STEPS = (0.05, 0.1)
"""cycles, the step sizes of (a)-(c): sparse's and Thermal's."""
LEARNING_STEPS = (0.025, 0.05, 0.1, 0.2)
"""cycles, the step sizes of (d)."""
LEARNERS = ("thermal", "sparse")
SETTLE = {"chain": 4, "sheet": 2}
"""cycles at a base before its phase change."""
HORIZON = {"chain": 32, "sheet": 8}
"""cycles measured after a phase change; the last quarter is the settled gait. A unit's own change settles within 2-4
cycles in a sheet, but within 10 in chain-20 and 20-50 in chain-100 (measured), so chains are followed longer."""
SIGN_FLOOR = 0.1
"""(c) counts a lone trial's sign only if its settled change is at least this fraction of the RMS settled change."""
WINDOWS = ("1", "2", "1-2", "settled")
"""what a unit measures after a phase change: cycle 1, cycle 2 (sparse's), cycles 1-2 (Thermal's), the settled gait."""
REGIMES = ("all", "some")
"""who moves in a joint trial: every unit (Thermal), or each unit with probability p (sparse)."""


@dataclasses.dataclass(frozen=True)
class Assembly:
    kind: str
    """'chain' or 'sheet'."""
    side: int
    """a chain's units, a sheet's side."""

    @property
    def name(self) -> str:
        return f"chain-{self.side}" if self.kind == "chain" else f"sheet-{self.side}x{self.side}"

    @property
    def n_units(self) -> int:
        return self.side if self.kind == "chain" else self.side ** 2

    @property
    def path(self) -> Path:
        """its morphology file: the library's (shapes/) or the benchmarks' own (chains of 50 and 100, the sheets)."""
        library = ROOT / "shapes" / f"{self.name}.toml"
        return library if library.is_file() else ROOT / "benchmarks" / "shapes" / f"{self.name}.toml"


ASSEMBLIES = tuple(Assembly("chain", n) for n in CHAINS) + tuple(Assembly("sheet", n) for n in SHEETS)
BY_NAME = {a.name: a for a in ASSEMBLIES}


@functools.lru_cache(maxsize=None)
def shape_of(name: str):
    """The assembly's shape, from its morphology file."""
    from morphbench.shapes import load_shape

    return load_shape(BY_NAME[name].path)


@dataclasses.dataclass(frozen=True)
class Plan:
    """How much is measured."""

    probes: int
    """units probed per base (every unit of a smaller assembly)."""
    random_bases: int
    """random bases per assembly, beside its best wave."""
    joint: int
    """joint trials per base, step size and regime."""
    steps: int
    """learning steps of a run of (d)."""
    seeds: Mapping[str, int]
    """runs per learner and step size in (d), by assembly."""


FULL = Plan(probes=8, random_bases=2, joint=8, steps=300,
            seeds={"chain-2": 16, "chain-5": 16, "chain-10": 16, "chain-20": 16, "chain-50": 8, "chain-100": 8,
                   "sheet-2x2": 8, "sheet-4x4": 2, "sheet-8x8": 1, "sheet-16x16": 2, "sheet-32x32": 1})
QUICK = Plan(probes=4, random_bases=1, joint=4, steps=40, seeds={a.name: 1 for a in ASSEMBLIES})


# --- what is drawn -------------------------------------------------------------------------------------------------

def base_phases(assembly: Assembly, base: int, seed: int, lag: float) -> np.ndarray:
    """Base 0 is the travelling wave of lag ``lag`` (the unit in column c at c * lag mod 1), base b >= 1 the b-th
    random phase vector."""
    if base == 0:
        return wave_phases(shape_of(assembly.name), [lag])[0]
    return np.random.default_rng([seed, 1, assembly.n_units, base]).random(assembly.n_units)


def probe_units(n_units: int, count: int, seed: int, base: int) -> np.ndarray:
    """The units probed at a base: ``count`` distinct units drawn from the seed (all, in order, if there are no
    more)."""
    if n_units <= count:
        return np.arange(n_units)
    return np.sort(np.random.default_rng([seed, 2, n_units, base]).choice(n_units, size=count, replace=False))


def joint_moves(n_units: int, trials: int, step: float, p: float, seed: int, base: int) -> dict[str, np.ndarray]:
    """(trials, n_units) phase changes of the joint trials at a base, by regime: 'all', each unit uniform(-step,
    step); 'some', the same draws where a unit tries (probability p), else 0."""
    rng = np.random.default_rng([seed, 3, n_units, base, round(step * 10000)])
    draws = rng.uniform(-step, step, size=(trials, n_units))
    tries = rng.random((trials, n_units)) < p
    return {"all": draws, "some": np.where(tries, draws, 0.0)}


def lone_moves() -> np.ndarray:
    """The phase changes of a probe's lone trials, cycles: -0.1, -0.05, 0.05, 0.1."""
    return np.array(sorted([-s for s in SIGNAL_STEPS] + list(SIGNAL_STEPS)))


# --- the measurements, as pure functions of the velocities ---------------------------------------------------------

def windowed(per_cycle: np.ndarray) -> dict[str, np.ndarray]:
    """Per WINDOWS, the velocities (..., N) from velocities cycle by cycle (..., H, N): cycle 1, cycle 2, cycles 1-2
    and the settled gait (the last quarter of the H cycles)."""
    horizon = per_cycle.shape[-2]
    return {"1": per_cycle[..., 0, :], "2": per_cycle[..., 1, :], "1-2": per_cycle[..., :2, :].mean(axis=-2),
            "settled": per_cycle[..., horizon - max(1, horizon // 4):, :].mean(axis=-2)}


def own_response(moves: np.ndarray, changes: np.ndarray, at: np.ndarray) -> np.ndarray:
    """A unit's own change at the phase changes ``at``, interpolated linearly through its lone trials (``changes`` at
    ``moves``, sorted) and 0 at 0."""
    nodes = np.concatenate([moves[moves < 0], [0.0], moves[moves > 0]])
    values = np.concatenate([changes[moves < 0], [0.0], changes[moves > 0]])
    return np.interp(at, nodes, values)


def signal_power(moves: np.ndarray, changes: np.ndarray, step: float) -> float:
    """The mean square of a unit's own change over a uniform(-step, step) trial (``own_response``; exact: on each
    piece between nodes the square of a line integrates as (b - a) (f_a^2 + f_a f_b + f_b^2) / 3)."""
    inner = moves[np.abs(moves) < step]
    x = np.unique(np.concatenate([[-step, 0.0, step], inner]))
    f = own_response(moves, changes, x)
    return float(np.sum(np.diff(x) * (f[:-1] ** 2 + f[:-1] * f[1:] + f[1:] ** 2) / 3) / (2 * step))


def ratio(signal: np.ndarray, interference: np.ndarray) -> tuple[float, float]:
    """The signal-to-interference ratio, mean(signal) / mean(interference ** 2) (``signal``: each probe's mean square
    own change), and the standard error of its logarithm (delta method, the two means independent)."""
    signal, noise = np.asarray(signal, dtype=float), np.asarray(interference, dtype=float) ** 2
    if noise.mean() == 0:
        return math.inf, math.nan
    value = signal.mean() / noise.mean()
    spread = [np.var(x, ddof=1) / len(x) / x.mean() ** 2 if len(x) > 1 and x.mean() > 0 else 0.0
              for x in (signal, noise)]
    return float(value), float(math.sqrt(sum(spread)))


def transient_fractions(own: np.ndarray, settled: np.ndarray) -> np.ndarray:
    """Per cycle after a lone change (``own``: (trials, H), a unit's own velocity change cycle by cycle), the
    fraction of the settled change (``settled``: (trials,)) it shows: the least-squares slope through 0."""
    norm = float(np.sum(settled ** 2))
    return own.T @ settled / norm if norm > 0 else np.full(own.shape[1], np.nan)


def sign_errors(seen: np.ndarray, settled: np.ndarray, floor: float = SIGN_FLOOR) -> tuple[float, int]:
    """How often ``seen`` (a measured change per trial) has the other sign than the settled change, over the trials
    whose settled change is at least ``floor`` of their RMS; and the number of such trials."""
    counted = np.abs(settled) >= floor * math.sqrt(np.mean(settled ** 2)) if len(settled) else np.zeros(0, bool)
    counted &= settled != 0
    if not counted.any():
        return math.nan, 0
    return float(np.mean(np.sign(seen[counted]) != np.sign(settled[counted]))), int(counted.sum())


def phase_distance(n_units: int, step: float, fraction: float = 1.0) -> float:
    """cycles, the RMS distance of a joint trial from its base: sqrt(fraction * N / 3) * step."""
    return math.sqrt(fraction * n_units / 3.0) * step


@dataclasses.dataclass
class BaseMeasured:
    """What was measured at one base of one assembly (velocities cycle by cycle, mm/cycle)."""

    assembly: Assembly
    base: int
    """0 the wave, >= 1 a random base."""
    probes: np.ndarray
    control: np.ndarray
    """(H, N): at the base, no change."""
    lone: np.ndarray
    """(probes, lone moves, H, N): each probe's lone trials (``lone_moves``)."""
    joint: dict
    """(step, regime) -> (moves (J, N), velocities (J, H, N))."""


def base_signal(measured: BaseMeasured, step: float) -> dict:
    """(a) and (b) at one base and step size: per window, each probe's signal power (``signal``), the full step's own
    changes (``own``, lone +-step) and their Ubar changes (``ubar``); per regime and window the interference of every
    probe in every joint trial (``interference``) and whether a trying probe's measured change had its own part's
    sign (``right``); per regime each joint trial's settled Ubar change (``du``)."""
    moves, probes = lone_moves(), measured.probes
    control = windowed(measured.control)
    lone = windowed(measured.lone)  # each (probes, moves, N)
    full = np.isclose(np.abs(moves), step)
    out: dict = {"signal": {}, "own": {}, "ubar": {}, "interference": {}, "right": {}, "du": {}}
    for window in WINDOWS:
        own = lone[window][np.arange(len(probes)), :, probes] - control[window][probes][:, None]  # (probes, moves)
        out["signal"][window] = np.array([signal_power(moves, row, step) for row in own])
        out["own"][window] = own[:, full].ravel()
        out["ubar"][window] = (lone[window] - control[window]).mean(axis=-1)[:, full].ravel()
        for regime in REGIMES:
            drawn, velocities = measured.joint[(step, regime)]
            seen = windowed(velocities)[window][:, probes] - control[window][probes]  # (J, probes)
            mine = drawn[:, probes]
            part = np.stack([own_response(moves, own[k], mine[:, k]) for k in range(len(probes))], axis=1)
            out["interference"][(regime, window)] = (seen - part).ravel()
            tried = mine != 0
            out["right"][(regime, window)] = (np.sign(seen[tried]) == np.sign(part[tried])).astype(float)
    for regime in REGIMES:
        _, velocities = measured.joint[(step, regime)]
        out["du"][regime] = (windowed(velocities)["settled"] - control["settled"]).mean(axis=-1)
    return out


def base_transient(measured: BaseMeasured) -> tuple[np.ndarray, np.ndarray]:
    """(c) at one base: every lone trial's own velocity change cycle by cycle, (trials, H), and its settled change."""
    probes = measured.probes
    own = measured.lone[np.arange(len(probes)), :, :, probes] - measured.control[:, probes].T[:, None, :]
    own = own.reshape(-1, own.shape[-1])  # (probes x moves, H)
    settled = windowed(own[..., None])["settled"][:, 0]
    return own, settled


# --- jobs -------------------------------------------------------------------------------------------------------------

def cycle_cost(assembly: Assembly) -> float:
    """CPU s per simulated cycle (measured; for the estimate and the order of the jobs only)."""
    n = assembly.n_units
    if assembly.kind == "chain":
        return 1e-4 + 1.8e-5 * n
    if n <= 100:  # the planar solver
        return 0.2 * (n / 64) ** 1.65
    return 0.09 * (n / 1024) ** 1.12  # the dynamic model


def _simulate(job) -> np.ndarray:
    """(changes, H, N): the velocities cycle by cycle after each phase change from a base (a fresh world each)."""
    _, name, phases, changes, settle, horizon = job
    shape = shape_of(name)
    return np.stack([credit.step_velocities(shape, phases, change, settle, windows=horizon, cycles=1)
                     for change in changes])


def _learn(job) -> list[float]:
    """Each seed's U_eq (mm/cycle, NaN for a run that failed): its mean true Ubar over its last third of steps."""
    from morphbench.experiment.driver import batchable, run_batch
    from morphbench.experiment.run import RunConfig
    from morphbench.params import SensorParams, learner_defaults

    _, name, learner, step_size, steps, seeds = job
    params = dataclasses.replace(learner_defaults(learner), step_size=step_size)
    configs = [RunConfig(shape=shape_of(name), learner=learner, learner_params=params,
                         sensor=SensorParams(kind="ideal"), steps=steps, seed=seed) for seed in seeds]
    outcomes = run_batch(configs) if batchable(configs[0]) else [run_batch([c])[0] for c in configs]
    return [level(o.steps(), steps) if not isinstance(o, BaseException) else math.nan for o in outcomes]


def _wave(job) -> float:
    _, name, phases = job
    return wave_ubar((str(BY_NAME[name].path), phases))


WORK: dict[str, Callable] = {"sim": _simulate, "learn": _learn, "wave": _wave}


def _work(job):
    return WORK[job[0]](job)


def level(steps, n_steps: int) -> float:
    """A run's U_eq: its mean true Ubar over its last third of learning steps (steps table: ``step``, ``ubar_true``)."""
    window = max(1, n_steps // 3)
    return float(steps.ubar_true[steps.step > n_steps - window].mean())


FIXED_PHASES = 0.6
"""a cycle at fixed phases costs about this fraction of a learning run's (whose phases change every 2 cycles)."""


def job_cost(job) -> float:
    """CPU s a job is expected to take (``cycle_cost``; a fixed-phase measurement's world built in about 0.1 ms per
    unit)."""
    assembly = BY_NAME[job[1]]
    build = 1e-4 * assembly.n_units
    if job[0] == "sim":
        cycles = SETTLE[assembly.kind] + HORIZON[assembly.kind]
        return len(job[3]) * (cycles * FIXED_PHASES * cycle_cost(assembly) + build)
    if job[0] == "learn":
        return len(job[5]) * (2 * job[4] + 1) * cycle_cost(assembly)
    return (WAVE_CYCLES + WAVE_DISCARD) * FIXED_PHASES * cycle_cost(assembly) + build


def execute(jobs: list, workers: int, label: str) -> list:
    """Every job's result, in the jobs' order (the longest started first; the same results whatever ``workers``)."""
    from tqdm import tqdm

    from morphbench.progress import redrawn

    costs = [job_cost(job) for job in jobs]
    order = sorted(range(len(jobs)), key=lambda j: -costs[j])
    results: list = [None] * len(jobs)
    bar = tqdm(total=sum(costs), desc=label, unit="CPU s", smoothing=0, file=sys.stderr,
               disable=not jobs, bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} estimated CPU s [{elapsed}<{remaining}]")
    with redrawn(bar):
        if workers == 1:
            for j in order:
                results[j] = _work(jobs[j])
                bar.update(min(costs[j], bar.total - bar.n))
        else:
            with ProcessPoolExecutor(max_workers=workers) as pool:
                for j, result in zip(order, pool.map(_work, [jobs[j] for j in order], chunksize=1)):
                    results[j] = result
                    bar.update(min(costs[j], bar.total - bar.n))
    bar.close()
    return results


def read_waves(path: Path = WAVES) -> dict[str, tuple[float, float]]:
    """Each assembly's best travelling wave in benchmarks/waves.csv: name -> (lag, Ubar in mm/cycle)."""
    import pandas as pd

    from morphbench.errors import ConfigError

    if not Path(path).is_file():
        raise ConfigError(path, "file", "the best waves written by `python benchmarks/waves.py`")
    table = pd.read_csv(path)
    if not {"shape", "delta", "wave"} <= set(table.columns):
        raise ConfigError(path, "columns", "shape, delta and wave, as benchmarks/waves.py writes them",
                          list(table.columns))
    return {row.shape: (float(row.delta), float(row.wave)) for row in table.itertuples()}


def best_waves(assemblies: list[Assembly], workers: int, resolution: int = 40,
               path: Path = WAVES) -> dict[str, tuple[float, float, bool]]:
    """name -> (lag, Ubar, measured here): benchmarks/waves.csv's best wave, or for an assembly it lacks the best of
    ``resolution`` lags measured here as waves.py measures them."""
    known = read_waves(path)
    missing = [a for a in assemblies if a.name not in known]
    lags = wave_lags(resolution)
    jobs = [("wave", a.name, base_phases(a, 0, 0, lag)) for a in missing for lag in lags]
    values = np.array(execute(jobs, workers, "best waves")).reshape(len(missing), resolution) if missing else []
    out = {a.name: (*known[a.name], False) for a in assemblies if a.name in known}
    for a, row in zip(missing, values):
        out[a.name] = (float(lags[np.argmax(row)]), float(np.max(row)), True)
    return out


def fixed_phase_jobs(assembly: Assembly, plan: Plan, seed: int, lag: float) -> list[tuple]:
    """The measurements of (a)-(c) for one assembly: per base, its control, its probes' lone trials and its joint
    trials, as jobs (``_simulate``)."""
    from morphbench.params import LearnerParams

    p, n = LearnerParams().trial_probability, assembly.n_units
    settle, horizon = SETTLE[assembly.kind], HORIZON[assembly.kind]
    jobs = []
    for base in range(1 + plan.random_bases):
        phases = base_phases(assembly, base, seed, lag)
        probes = probe_units(n, plan.probes, seed, base)
        lone = np.zeros((len(probes) * len(lone_moves()), n))
        for k, (unit, move) in enumerate((u, m) for u in probes for m in lone_moves()):
            lone[k, unit] = move
        jobs.append(("sim", assembly.name, phases, np.zeros((1, n)), settle, horizon))
        jobs.append(("sim", assembly.name, phases, lone, settle, horizon))
        for step in SIGNAL_STEPS:
            for regime, moves in joint_moves(n, plan.joint, step, p, seed, base).items():
                jobs.append(("sim", assembly.name, phases, moves, settle, horizon))
    return jobs


def collect(assembly: Assembly, plan: Plan, seed: int, jobs: list, results: list) -> list[BaseMeasured]:
    """The bases' measurements from ``fixed_phase_jobs``' jobs and their results."""
    out, at = [], 0
    per_base = 2 + len(SIGNAL_STEPS) * len(REGIMES)
    for base in range(1 + plan.random_bases):
        mine, got = jobs[at:at + per_base], results[at:at + per_base]
        probes = probe_units(assembly.n_units, plan.probes, seed, base)
        lone = got[1].reshape(len(probes), len(lone_moves()), *got[1].shape[1:])
        joint = {}
        for k, (step, regime) in enumerate((s, r) for s in SIGNAL_STEPS for r in REGIMES):
            joint[(step, regime)] = (mine[2 + k][3], got[2 + k])
        out.append(BaseMeasured(assembly, base, probes, got[0][0], lone, joint))
        at += per_base
    return out


def learning_jobs(assembly: Assembly, plan: Plan) -> list[tuple]:
    """(d) for one assembly: one job per learner and step size, its seeds together."""
    seeds = tuple(range(plan.seeds[assembly.name]))
    return [("learn", assembly.name, learner, step, plan.steps, seeds) for learner in LEARNERS
            for step in LEARNING_STEPS]


# --- from the measurements to the tables ------------------------------------------------------------------------------

def summarise_signal(bases: list[BaseMeasured], step: float) -> dict:
    """(a) and (b) of a set of bases (the wave, or the random ones) at one step size, pooled over them."""
    parts = [base_signal(b, step) for b in bases]

    def pool(key, sub):
        return np.concatenate([part[key][sub] for part in parts])

    from morphbench.params import LearnerParams

    n, p = bases[0].assembly.n_units, LearnerParams().trial_probability
    row = {"own": _rms(pool("own", "2")), "ubar": _rms(pool("ubar", "settled")),
           "kept": float(np.mean([windowed(b.control)["settled"].mean() for b in bases])),
           "distance": {"all": phase_distance(n, step), "some": phase_distance(n, step, p)}}
    for regime in REGIMES:
        for window in ("2", "1-2"):
            row[("sir", regime, window)] = ratio(pool("signal", window), pool("interference", (regime, window)))
            row[("noise", regime, window)] = _rms(pool("interference", (regime, window)))
            right = pool("right", (regime, window))
            row[("right", regime, window)] = float(right.mean()) if len(right) else math.nan
        du = pool("du", regime)
        row[("du", regime)] = (float(np.mean(np.abs(du))), _se(np.abs(du)), float(np.mean(du)), _se(du))
    return row


def summarise_transient(bases: list[BaseMeasured]) -> dict:
    """(c) of a set of bases, pooled: the fraction of the settled change per cycle, and the sign errors."""
    own, settled = (np.concatenate(x) for x in zip(*(base_transient(b) for b in bases)))
    seen = windowed(own[..., None])
    return {"fractions": transient_fractions(own, settled), "trials": len(settled),
            "wrong": {window: sign_errors(seen[window][:, 0], settled) for window in ("1", "2", "1-2")}}


def summarise_learning(levels: dict, wave: float) -> dict:
    """(d) of one assembly and learner: per step size, the runs' mean U_eq, its standard error and both as a share of
    the best wave."""
    out = {}
    for step, values in levels.items():
        values = np.asarray(values, dtype=float)
        good = values[np.isfinite(values)]
        mean = float(good.mean()) if len(good) else math.nan
        se = float(good.std(ddof=1) / math.sqrt(len(good))) if len(good) > 1 else math.nan
        out[step] = {"runs": len(good), "failed": len(values) - len(good), "level": mean, "se": se,
                     "share": mean / wave, "share_se": se / wave}
    return out


def _rms(x) -> float:
    x = np.asarray(x, dtype=float)
    return float(np.sqrt(np.mean(x ** 2))) if len(x) else math.nan


def _se(x) -> float:
    x = np.asarray(x, dtype=float)
    return float(np.std(x, ddof=1) / math.sqrt(len(x))) if len(x) > 1 else math.nan


def measure_all(plan: Plan, assemblies: list[Assembly], seed: int, workers: int) -> dict:
    """Every measurement: ``waves`` (name -> lag, Ubar, measured here), ``signal`` ((name, base kind, step) -> row),
    ``transient`` ((name, base kind) -> row), ``learning`` ((name, learner) -> per step size)."""
    waves = best_waves(assemblies, workers)
    fixed = {a.name: fixed_phase_jobs(a, plan, seed, waves[a.name][0]) for a in assemblies}
    learning = {a.name: learning_jobs(a, plan) for a in assemblies}
    jobs = [job for a in assemblies for job in fixed[a.name] + learning[a.name]]
    results = execute(jobs, workers, "scaling causes")
    out: dict = {"waves": waves, "signal": {}, "transient": {}, "learning": {}}
    at = 0
    for a in assemblies:
        got = results[at:at + len(fixed[a.name])]
        at += len(fixed[a.name])
        bases = collect(a, plan, seed, fixed[a.name], got)
        for kind, chosen in (("wave", bases[:1]), ("random", bases[1:])):
            if not chosen:
                continue
            out["transient"][(a.name, kind)] = summarise_transient(chosen)
            for step in SIGNAL_STEPS:
                out["signal"][(a.name, kind, step)] = summarise_signal(chosen, step)
        levels = results[at:at + len(learning[a.name])]
        at += len(learning[a.name])
        for learner in LEARNERS:
            mine = {job[3]: value for job, value in zip(learning[a.name], levels) if job[2] == learner}
            out["learning"][(a.name, learner)] = summarise_learning(mine, waves[a.name][1])
    return out


# --- the section ------------------------------------------------------------------------------------------------------

def _ratio_cell(value: tuple[float, float]) -> str:
    sir, log_se = value
    if not math.isfinite(sir):
        return "-"
    return f"{sir:.3g} (x/ {math.exp(log_se):.2f})" if math.isfinite(log_se) else f"{sir:.3g}"


def _share(value: float) -> str:
    return "-" if not math.isfinite(value) else f"{value:.0%}"


def signal_table(results: dict, assemblies: list[Assembly]) -> list[str]:
    lines = ["| assembly | N | base | step | a lone step's own change, cycle 2 (RMS, mm/cycle) | its change of Ubar, "
             "settled (RMS) | interference, all move, cycle 2 (RMS) | S/I: all move, cycle 2 | S/I: all move, cycles "
             "1-2 (Thermal) | interference, p try, cycle 2 (RMS) | S/I: p try, cycle 2 (sparse) | right sign: Thermal "
             "| right sign: sparse |", "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for a, kind, step, row in _signal_rows(results, assemblies):
        lines.append(f"| {a.name} | {a.n_units} | {kind} | {step:g} | {row['own']:.3f} | {row['ubar']:.4f} | "
                     f"{row[('noise', 'all', '2')]:.3f} | {_ratio_cell(row[('sir', 'all', '2')])} | "
                     f"{_ratio_cell(row[('sir', 'all', '1-2')])} | {row[('noise', 'some', '2')]:.3f} | "
                     f"{_ratio_cell(row[('sir', 'some', '2')])} | {_share(row[('right', 'all', '1-2')])} | "
                     f"{_share(row[('right', 'some', '2')])} |")
    return lines


def _signal_rows(results: dict, assemblies: list[Assembly]):
    """(assembly, base kind, step size, its measurements of (a) and (b)) for every one measured, in table order."""
    for a in assemblies:
        for kind in ("wave", "random"):
            for step in SIGNAL_STEPS:
                row = results["signal"].get((a.name, kind, step))
                if row is not None:
                    yield a, kind, step, row


def distance_table(results: dict, assemblies: list[Assembly]) -> list[str]:
    lines = ["| assembly | N | base | step | Ubar of the kept gait (mm/cycle) | all move: RMS phase distance "
             "(cycles) | mean abs(dU) (+- SE) | mean dU (+- SE) | p try: RMS phase distance | mean abs(dU) | mean dU |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for a, kind, step, row in _signal_rows(results, assemblies):
        cells = []
        for regime in REGIMES:
            absolute, absolute_se, signed, signed_se = row[("du", regime)]
            cells.append(f"{row['distance'][regime]:.3f} | {absolute:.3f} +- {absolute_se:.3f} | "
                         f"{signed:+.3f} +- {signed_se:.3f}")
        lines.append(f"| {a.name} | {a.n_units} | {kind} | {step:g} | {row['kept']:+.2f} | " + " | ".join(cells) + " |")
    return lines


def transient_table(results: dict, assemblies: list[Assembly]) -> list[str]:
    lines = ["| assembly | N | base | lone trials | share of the settled change in cycle 1 | cycle 2 | cycles 1-2 | "
             "cycle 3 | cycle 4 | wrong sign: cycle 1 | cycle 2 (sparse) | cycles 1-2 (Thermal) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for a in assemblies:
        for kind in ("wave", "random"):
            row = results["transient"].get((a.name, kind))
            if row is None:
                continue
            f = row["fractions"]
            wrong = [row["wrong"][w] for w in ("1", "2", "1-2")]
            lines.append(f"| {a.name} | {a.n_units} | {kind} | {row['trials']} | {f[0]:.2f} | {f[1]:.2f} | "
                         f"{(f[0] + f[1]) / 2:.2f} | {f[2]:.2f} | {f[3]:.2f} | "
                         + " | ".join(f"{_share(e)} of {n}" for e, n in wrong) + " |")
    return lines


def learning_table(results: dict, assemblies: list[Assembly]) -> list[str]:
    steps = " | ".join(f"step {s:g}" for s in LEARNING_STEPS)
    lines = [f"| assembly | N | learner | runs per step size | the best wave (mm/cycle) | U_eq / best wave (+- SE): "
             f"{steps} | the best step |", "|---|---|---|---|---|" + "---|" * len(LEARNING_STEPS) + "---|"]
    for a in assemblies:
        lag, wave, here = results["waves"][a.name]
        for learner in LEARNERS:
            row = results["learning"].get((a.name, learner))
            if row is None:
                continue
            cells = [f"{r['share']:+.2f}" + (f" +- {r['share_se']:.2f}" if math.isfinite(r["share_se"]) else "")
                     + (f" ({r['failed']} failed)" if r["failed"] else "") for r in row.values()]
            runs = max(r["runs"] + r["failed"] for r in row.values())
            lines.append(f"| {a.name} | {a.n_units} | {learner} | {runs} | {wave:+.2f}"
                         f"{' (measured here)' if here else ''} | " + " | ".join(cells) + f" | {best_step(row):g} |")
    return lines


def best_step(row: dict) -> float:
    """The step size of the highest share of the best wave in (d) (NaN shares last)."""
    return max(row, key=lambda s: row[s]["share"] if math.isfinite(row[s]["share"]) else -math.inf)


def findings(results: dict, assemblies: list[Assembly]) -> list[str]:
    """One line per kind of assembly and measurement: from its smallest to its largest assembly."""
    thermal, sparse = max(SIGNAL_STEPS), min(SIGNAL_STEPS)
    signal, transient, learning = results["signal"], results["transient"], results["learning"]
    lines = []
    for kind, mine in _kinds(assemblies):
        first, last = mine[0], mine[-1]

        def span(get, fmt="{:.3g}"):
            ends = [first] if first is last else [first, last]
            return ", ".join(f"{fmt.format(get(a))} at N = {a.n_units}" for a in ends)

        def sir(regime, window, step, base="random"):
            return lambda a: signal[(a.name, base, step)][("sir", regime, window)][0]

        def loss(regime, step):
            return lambda a: signal[(a.name, "wave", step)][("du", regime)][2]

        def seen(index):
            return lambda a: transient[(a.name, "random")]["fractions"][index]

        lines += [f"- {kind}s, (a): S/I at random bases of Thermal's trial (all move, step {thermal:g}, cycles 1-2) "
                  f"{span(sir('all', '1-2', thermal))}; of sparse's (p try, step {sparse:g}, cycle 2) "
                  f"{span(sir('some', '2', sparse))}; of Thermal's at the wave "
                  f"{span(sir('all', '1-2', thermal, 'wave'))}.",
                  f"- {kind}s, (b): the mean change of the settled Ubar (mm/cycle) by a trial at the wave, Thermal's "
                  f"(all move, step {thermal:g}) {span(loss('all', thermal), '{:+.2f}')}; sparse's (p try, step "
                  f"{sparse:g}) {span(loss('some', sparse), '{:+.2f}')}.",
                  f"- {kind}s, (c): at random bases the share of a unit's settled own change seen in cycle 1 "
                  f"{span(seen(0), '{:.2f}')}, in cycle 2 {span(seen(1), '{:.2f}')}; cycle 1 of the wrong sign in "
                  f"{span(lambda a: transient[(a.name, 'random')]['wrong']['1'][0], '{:.0%}')} of the lone trials."]
        for learner in LEARNERS:
            def best(a, learner=learner):
                return best_step(learning[(a.name, learner)])

            def share(a, learner=learner):
                return learning[(a.name, learner)][best(a)]["share"]

            lines.append(f"- {kind}s, (d): {learner}'s best step size {span(best, '{:g}')}; its U_eq there, as a share "
                         f"of the best wave, {span(share, '{:.2f}')}.")
    return lines


# --- figures ----------------------------------------------------------------------------------------------------------

def _kinds(assemblies):
    return [(kind, [a for a in assemblies if a.kind == kind]) for kind in ("chain", "sheet")
            if any(a.kind == kind for a in assemblies)]


LEARNER_SERIES = (("all", "1-2", max(SIGNAL_STEPS), "all move, cycles 1-2 (Thermal)"),
                  ("all", "2", min(SIGNAL_STEPS), "all move, cycle 2"),
                  ("some", "2", min(SIGNAL_STEPS), "p try, cycle 2 (sparse)"))
"""the trials the figures of (a) and (b) show: Thermal's as it runs, Thermal's crowd at sparse's step and window, and
sparse's as it runs (regime, window, step size, label)."""


def _log_n(ax, n) -> None:
    """A logarithmic axis of N marked at the assemblies' sizes."""
    ax.set_xscale("log")
    ax.set_xticks(n, [f"{int(v)}" for v in n])
    ax.minorticks_off()
    ax.tick_params(axis="x", labelsize="x-small")
    ax.set_xlabel("units N")


def signal_figure(results: dict, assemblies: list[Assembly], path: Path) -> Path:
    from matplotlib import pyplot as plt

    from morphbench import plots

    kinds = _kinds(assemblies)
    fig, axes = plt.subplots(2, len(kinds), figsize=(5.5 * len(kinds), 7), squeeze=False, sharey=True)
    for column, (kind, mine) in enumerate(kinds):
        n = np.array([a.n_units for a in mine], dtype=float)
        for row, base in enumerate(("wave", "random")):
            ax = axes[row, column]
            for (regime, window, step, label), fmt in zip(LEARNER_SERIES, ("o-", "s--", "^-")):
                values = [results["signal"][(a.name, base, step)][("sir", regime, window)] for a in mine]
                sir = np.array([v[0] for v in values])
                factor = np.exp(np.nan_to_num(np.array([v[1] for v in values])))
                ax.errorbar(n, sir, yerr=[sir - sir / factor, sir * factor - sir], fmt=fmt, capsize=3,
                            label=f"{label}, step {step:g}")
            ax.axhline(1.0, color="k", lw=0.8, ls=":")
            _log_n(ax, n)
            ax.set_yscale("log")
            ax.set_title(f"{kind}s, at {'the best wave' if base == 'wave' else 'random phases'}", fontsize="small")
        axes[0, column].legend(fontsize="x-small")
    for ax in axes[:, 0]:
        ax.set_ylabel("signal / interference (mean squares)")
    fig.suptitle("(a) a unit's own part of what it measures against the others' (S/I 1: as much of each)",
                 fontsize="small")
    return plots.save_figure(fig, path, dpi=100)


def distance_figure(results: dict, assemblies: list[Assembly], path: Path) -> Path:
    from matplotlib import pyplot as plt

    from morphbench import plots

    kinds = _kinds(assemblies)
    fig, axes = plt.subplots(2, len(kinds), figsize=(5.5 * len(kinds), 7), squeeze=False)
    for column, (kind, mine) in enumerate(kinds):
        n = np.array([a.n_units for a in mine], dtype=float)
        for k, (regime, _, step, label) in enumerate(LEARNER_SERIES):
            colour = f"C{k}"
            label = f"{label.split(',')[0]}, step {step:g}"
            for base, fmt in (("wave", "o-"), ("random", "s--")):
                rows = [results["signal"][(a.name, base, step)][("du", regime)] for a in mine]
                axes[0, column].errorbar(n, [r[0] for r in rows], yerr=[r[1] for r in rows], fmt=fmt, capsize=2,
                                         color=colour, label=f"{label}, {base}")
                if base == "wave":
                    axes[1, column].errorbar(n, [r[2] for r in rows], yerr=[r[3] for r in rows], fmt=fmt, capsize=2,
                                             color=colour, label=label)
        axes[0, column].set_yscale("log")
        axes[1, column].axhline(0.0, color="k", lw=0.8)
        for ax in axes[:, column]:
            _log_n(ax, n)
        axes[0, column].set_title(f"{kind}s: mean abs(dU), the trial's settled gait less the kept one",
                                  fontsize="small")
        axes[1, column].set_title(f"{kind}s: mean dU of a trial at the best wave", fontsize="small")
        axes[0, column].legend(fontsize="xx-small")
        axes[1, column].legend(fontsize="xx-small")
    for ax in axes[:, 0]:
        ax.set_ylabel("mm/cycle")
    fig.suptitle("(b) how far a trial's gait is from the kept one", fontsize="small")
    return plots.save_figure(fig, path, dpi=100)


def transient_figure(results: dict, assemblies: list[Assembly], path: Path) -> Path:
    from matplotlib import pyplot as plt

    from morphbench import plots

    kinds = _kinds(assemblies)
    fig, axes = plt.subplots(1, len(kinds) + 1, figsize=(5 * (len(kinds) + 1), 4), squeeze=False)
    axes = axes[0]
    for column, (kind, mine) in enumerate(kinds):
        ax = axes[column]
        for k, a in enumerate(mine):
            f = results["transient"][(a.name, "random")]["fractions"][:8]
            ax.plot(np.arange(1, len(f) + 1), f, "o-", color=plt.cm.viridis(k / max(1, len(mine) - 1) * 0.9),
                    label=f"N = {a.n_units}")
        ax.axhline(1.0, color="k", lw=0.8, ls=":")
        ax.set_xlabel("cycle after the phase change")
        ax.set_title(f"{kind}s, random bases: share of the settled own change", fontsize="small")
        ax.legend(fontsize="x-small")
        for window, fmt in (("1", "o-"), ("2", "s--"), ("1-2", "^:")):
            n = [a.n_units for a in mine]
            axes[-1].plot(n, [results["transient"][(a.name, "random")]["wrong"][window][0] for a in mine], fmt,
                          label=f"{kind}s, cycle{'s' if '-' in window else ''} {window}")
    axes[0].set_ylabel("measured change / settled change")
    _log_n(axes[-1], np.array(sorted({a.n_units for a in assemblies}), dtype=float))
    axes[-1].set_ylabel("lone trials of the wrong sign")
    axes[-1].set_title("random bases: a measurement's sign against the settled change's", fontsize="small")
    axes[-1].legend(fontsize="x-small")
    fig.suptitle("(c) the transient of a unit's own phase change", fontsize="small")
    return plots.save_figure(fig, path, dpi=100)


def learning_figure(results: dict, assemblies: list[Assembly], path: Path) -> Path:
    from matplotlib import pyplot as plt

    from morphbench import plots

    kinds = _kinds(assemblies)
    fig, axes = plt.subplots(len(kinds), len(LEARNERS), figsize=(11, 4 * len(kinds)), squeeze=False, sharey=True)
    for row, (kind, mine) in enumerate(kinds):
        for column, learner in enumerate(LEARNERS):
            ax = axes[row, column]
            for k, a in enumerate(mine):
                cells = results["learning"][(a.name, learner)]
                ax.errorbar(list(cells), [c["share"] for c in cells.values()],
                            yerr=[np.nan_to_num(c["share_se"]) for c in cells.values()], fmt="o-", capsize=3,
                            color=plt.cm.viridis(k / max(1, len(mine) - 1) * 0.9), label=f"N = {a.n_units}")
            ax.set_xscale("log", base=2)
            ax.set_xticks(LEARNING_STEPS, [f"{s:g}" for s in LEARNING_STEPS])
            ax.axhline(0.0, color="k", lw=0.8)
            ax.set_xlabel("step size (cycles)")
            ax.set_title(f"{kind}s, {learner}", fontsize="small")
            ax.legend(fontsize="x-small")
        axes[row, 0].set_ylabel("U_eq / the best wave")
    fig.suptitle("(d) U_eq against the step size", fontsize="small")
    return plots.save_figure(fig, path, dpi=100)


FIGURES = (("scaling-signal.png", signal_figure, "(a) signal against interference"),
           ("scaling-distance.png", distance_figure, "(b) the trial gait's distance from the kept gait"),
           ("scaling-transient.png", transient_figure, "(c) the transient after a phase change"),
           ("scaling-steps.png", learning_figure, "(d) U_eq against the step size"))


def section(results: dict, assemblies: list[Assembly], plan: Plan, media: Path) -> tuple[list[str], list[str]]:
    """(the lines printed, the section's lines), its figures drawn into ``media``."""
    from morphbench.params import LearnerParams

    p = LearnerParams().trial_probability
    drawn = {name: make(results, assemblies, media / name).name for name, make, _ in FIGURES}
    waves = [f"{a.name} (lag {results['waves'][a.name][0]:.3f}, {results['waves'][a.name][1]:+.2f} mm/cycle)"
             for a in assemblies if results["waves"][a.name][2]]
    tables = [
        ("### (a) Signal against interference", FIGURES[0],
         f"At each base: {plan.probes} probed units (every unit of a smaller assembly), {plan.joint} joint trials per "
         f"step size and regime; the wave is one base, the random rows pool {plan.random_bases} random "
         f"base{'s' if plan.random_bases > 1 else ''}. S/I: mean "
         "square own part of a uniform trial over mean square interference (x/ its standard error as a factor); "
         f"'p try': each other unit tries with probability p = {p:g}; 'right sign': trying units whose measured "
         "change had the sign of their own part (Thermal: all move, cycles 1-2; sparse: p try, cycle 2).",
         signal_table),
        ("### (b) The trial gait's distance from the kept gait", FIGURES[1],
         "dU: the settled Ubar of a joint trial less the base's (mm/cycle), over the joint trials of (a).",
         distance_table),
        ("### (c) The transient after a phase change", FIGURES[2],
         f"Over the probes' lone trials (+-{min(SIGNAL_STEPS):g} and +-{max(SIGNAL_STEPS):g}); the settled change is "
         f"the mean of the last quarter of {HORIZON['chain']} cycles in chains, {HORIZON['sheet']} in sheets; signs "
         f"counted where the settled change is at least {SIGN_FLOOR:g} of the RMS one.", transient_table),
        ("### (d) U_eq against the step size", FIGURES[3],
         f"U_eq: a run's mean true Ubar over the last {max(1, plan.steps // 3)} of its {plan.steps} steps; each "
         "learner at its own settings but the step size (sparse's own is 0.05, Thermal's 0.1)"
         + (f"; best waves measured here: {', '.join(waves)}" if waves else "") + ".", learning_table),
    ]
    printed, lines = [], []
    for title, (name, _, alt), about, make in tables:
        body = make(results, assemblies)
        lines += [title, "", f"![{alt}](media/{drawn[name]})", "", about, "", *body, ""]
        printed += [title, *body, ""]
    found = findings(results, assemblies)
    lines += ["### In numbers", "", *found]
    return printed + found, lines


def main(argv: list[str] | None = None) -> int:
    from morphbench.errors import ConfigError
    from morphbench.files import check_section, write_section

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer probes, trials, bases, steps and seeds: a look")
    parser.add_argument("--shapes", nargs="+", choices=list(BY_NAME), metavar="NAME",
                        help=f"only these assemblies (default: all of {', '.join(BY_NAME)})")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--doc", default=str(DOC), help="the page whose generated section is rewritten")
    args = parser.parse_args(argv)
    if args.workers < 1:
        parser.error("--workers >= 1 is needed")
    plan = QUICK if args.quick else FULL
    assemblies = [a for a in ASSEMBLIES if not args.shapes or a.name in args.shapes]
    try:
        check_section(args.doc, BEGIN, END)  # before measuring; the page is left as it was
        read_waves()
    except ConfigError as exc:
        print(f"scaling_causes.py: error: {exc}", file=sys.stderr)
        return 2
    cost = estimate(plan, assemblies)
    print(f"scaling_causes.py: about {cost / 60:.1f} CPU minutes ({cost / 60 / args.workers:.1f} minutes on "
          f"{args.workers} idle cores)", file=sys.stderr)
    started = time.perf_counter()
    results = measure_all(plan, assemblies, args.seed, args.workers)
    printed, lines = section(results, assemblies, plan, Path(args.doc).parent / "media")
    options = " --quick" * args.quick + (f" --shapes {' '.join(args.shapes)}" if args.shapes else "")
    write_section(args.doc, BEGIN, END, lines,
                  f"Generated by `python benchmarks/scaling_causes.py{options} --seed {args.seed}` on "
                  f"{time.strftime('%Y-%m-%d')} (ideal sensor, default physics; {time.perf_counter() - started:.0f} s "
                  f"with {args.workers} workers).")
    print("\n".join(printed))
    return 0


def estimate(plan: Plan, assemblies: list[Assembly]) -> float:
    """CPU s the measurements are expected to take (``job_cost``; the best waves to measure left out)."""
    total = 0.0
    for a in assemblies:
        n = a.n_units
        per_base = 1 + min(n, plan.probes) * len(lone_moves()) + len(SIGNAL_STEPS) * len(REGIMES) * plan.joint
        total += (1 + plan.random_bases) * job_cost(("sim", a.name, None, np.zeros((per_base, 0)), None, None))
        total += sum(map(job_cost, learning_jobs(a, plan)))
    return total


if __name__ == "__main__":
    sys.exit(main())
