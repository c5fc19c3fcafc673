"""The model of an expanded suite: its runs (RunSpec), scans (ScanSpec, split into ScanParts), experiments, and the
jobs an executor runs. bench/suite.py reads a suite file into it (through bench/expand.py); the runner, the store
and the report read it."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from morphbench import params as P
from morphbench.bench.cost import scan_point_cost
from morphbench.experiment.events import DamageEvent
from morphbench.experiment.run import RunConfig
from morphbench.shapes import Shape

SCAN_PART_POINTS = 20
"""A scan is split into jobs of this many points, so its points spread over the workers like runs do."""


@dataclass(frozen=True)
class RunSpec:
    """One learning run of a suite."""

    id: str
    condition_id: str
    condition: dict
    """flat, JSON-ready columns that name the condition (shape, learner, its parameters, noise, ...)."""
    seed: int
    config: RunConfig
    cost: float
    """relative cost estimate (bench/cost.py run_cost), for the progress bar and longest-first scheduling."""


@dataclass(frozen=True)
class ScanSpec:
    """One landscape scan, split into parts of at most SCAN_PART_POINTS points."""

    id: str
    name: str
    shape: Shape
    columns: dict
    """flat, JSON-ready description: scan, shape, shape_id, n_units, resolution, samples, cycles, ..."""
    physics: P.PhysicsParams
    cycles: int
    discard: int
    phases: np.ndarray
    environment: P.EnvironmentParams = field(default_factory=P.EnvironmentParams)
    damage: DamageEvent | None = None
    """the assembly's damage from the start (None: healthy)."""

    def part_ids(self) -> list[str]:
        n_parts = max(1, math.ceil(len(self.phases) / SCAN_PART_POINTS))
        return [f"{self.id}-{k:03d}" for k in range(n_parts)]


@dataclass(frozen=True)
class ScanPart:
    """The payload of a scan job: the points of one part of a scan and what each point needs."""

    shape: Shape
    phases: np.ndarray
    physics: P.PhysicsParams
    cycles: int
    discard: int
    environment: P.EnvironmentParams
    damage: DamageEvent | None = None


@dataclass(frozen=True)
class Job:
    """A unit of work for an executor: a run, or a part of a scan. ``payload`` is all a worker needs."""

    id: str
    kind: str
    """'run' or 'scan'."""
    payload: RunConfig | ScanPart
    cost: float


@dataclass(frozen=True)
class Experiment:
    name: str
    description: str
    run_ids: tuple[str, ...]
    condition_ids: tuple[str, ...]
    varying: tuple[str, ...]
    """condition columns that take more than one value in this experiment (what its figures tell apart)."""
    scans: tuple[str, ...] = ()
    """the names of the scans its figures use (its ``scans`` key; empty: found by shape, physics and ground)."""


@dataclass
class Suite:
    name: str
    description: str
    source: str
    text: str
    experiments: list[Experiment] = field(default_factory=list)
    runs: dict[str, RunSpec] = field(default_factory=dict)
    scans: list[ScanSpec] = field(default_factory=list)
    groups: dict[str, tuple[str, ...]] = field(default_factory=dict)
    """named lists of its experiments (the suite's ``groups``: ``morphbench leaderboard --tasks GROUP``)."""
    includes: tuple[str, ...] = ()
    """the names of the suites it includes (its ``include``; an included suite's own includes after it), in order:
    their experiments, runs, scans and groups are among its own."""

    def jobs(self) -> list[Job]:
        """Every job of the suite in a fixed order: runs as the experiments list them, then scan parts."""
        jobs = [Job(spec.id, "run", spec.config, spec.cost) for spec in self.runs.values()]
        for scan in self.scans:
            per_point = scan_point_cost(scan.shape, scan.cycles, scan.discard)
            for k, part_id in enumerate(scan.part_ids()):
                phases = scan.phases[k * SCAN_PART_POINTS:(k + 1) * SCAN_PART_POINTS]
                part = ScanPart(scan.shape, phases, scan.physics, scan.cycles, scan.discard, scan.environment,
                                scan.damage)
                jobs.append(Job(part_id, "scan", part, per_point * len(phases)))
        return jobs

    def plan(self) -> dict:
        """JSON-ready: what the results directory needs to rebuild tables and report without the suite file (and the
        included suites' names, which the report's claims follow, only if it has any: other plans stay as they
        were)."""
        plan = {
            "suite": self.name,
            "description": self.description,
            "source": self.source,
            "experiments": [dataclasses.asdict(e) for e in self.experiments],
            "runs": [
                {"id": r.id, "condition_id": r.condition_id, "condition": r.condition, "seed": r.seed}
                for r in self.runs.values()
            ],
            "scans": [{"id": s.id, "name": s.name, "columns": s.columns, "parts": s.part_ids()} for s in self.scans],
        }
        if self.includes:
            plan["includes"] = list(self.includes)
        return plan
