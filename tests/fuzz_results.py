"""Damaged results directories, generated: every kind of damage ``morphbench check`` finds, and cases for
``report``, ``report --compare`` and ``check`` in tests/fuzzing.py's ``Case`` form.

``DAMAGES`` lists each kind of damage: a function that damages a copy of a finished results directory (``reference``:
a tiny suite on the quasi-static model, its report built), the path ``check`` must name, and what ``report`` does
with it: ``skip`` (exit 0, the job listed under 'Damaged jobs'; ``skip-last``: the plan's last run, whose rows of a
consolidated table were edited; ``skip-all``: every run, a consolidated steps or units table unreadable), ``refuse``
(exit 2, one line, nothing written), ``rebuild`` (exit 0: a consolidated table the report rebuilds from the jobs) or,
for ``compare`` kinds, what ``report --compare`` refuses (the damage is in the directory compared).
tests/test_check.py runs each kind once;
``random_cases(n, seed)`` draws cases of random kinds, jobs, offsets and commands for benchmarks/robustness.py.

``run_case`` (tests/fuzzing.py) judges a case; ``verdict(outcome)`` refines its verdict for ``check``, whose exit
status 1 (damage found, listed on stdout) is the promise kept, not a crash.
"""

from __future__ import annotations

import json
import math
import random
import shutil
import tempfile
import textwrap
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import pandas as pd

from fuzzing import Case, Outcome
from morphbench.bench.store import Store

ROOT = Path(__file__).resolve().parents[1]
SUITE = textwrap.dedent(f"""
    name = "damage"
    physics = "quasistatic"

    [[experiment]]
    name = "pair"
    shape = ["{ROOT / 'shapes' / 'chain-2.toml'}"]
    learner = {{name = ["thermal", "flaky"]}}
    seeds = 2
    steps = 3

    [[scan]]
    shape = "{ROOT / 'shapes' / 'chain-2.toml'}"
    resolution = 3
    cycles = 1
    discard = 0
    """)
"""four runs of 3 steps and a 3-point scan on the quasi-static model: a finished directory in about a second."""
REPORT_FILES = ("report.md", "report.html", "figures", "videos")
"""what a case leaves out of its copy of the directory (the report rewrites them; they make cases large)."""


class Inline:
    """An executor that runs the jobs one after another in this process (``run_suite`` takes any executor)."""

    def describe(self) -> str:
        return "inline"

    def run(self, jobs, fn):
        for job in jobs:
            yield job, fn(job)


def build(out: Path) -> Path:
    """The suite SUITE run into ``out`` with its report (no videos); returns the suite file's path."""
    from morphbench.bench import build_report, load_suite, run_suite

    out.mkdir(parents=True, exist_ok=True)
    suite_path = out.parent / f"{out.name}.toml"
    suite_path.write_text(SUITE)
    run_suite(load_suite(suite_path), out, Inline(), progress=False)
    build_report(out)
    return suite_path


_reference: list[Path] = []


def reference() -> Path:
    """A finished results directory of SUITE, built once per process (in a temporary directory)."""
    if not _reference:
        _reference.append(Path(tempfile.mkdtemp(prefix="morphbench-damage-")) / "R")
        build(_reference[0])
    return _reference[0]


# --- kinds of damage ------------------------------------------------------------------------------------------------

def _plan(root: Path) -> dict:
    return json.loads((root / "plan.json").read_text())


def _job(root: Path, kind: str, rng: random.Random | None) -> str:
    """A run's or scan part's directory, relative to ``root``: the first, or one ``rng`` picks."""
    plan = _plan(root)
    ids = [r["id"] for r in plan["runs"]] if kind == "run" else [p for s in plan["scans"] for p in s["parts"]]
    return f"{'runs' if kind == 'run' else 'scans'}/{ids[rng.randrange(len(ids)) if rng else 0]}"


def _cut(path: Path, rng: random.Random | None) -> str:
    data = path.read_bytes()
    keep = rng.randrange(len(data)) if rng else len(data) // 2
    path.write_bytes(data[:keep])
    return f"cut to {keep} of {len(data)} bytes"


def _flip(path: Path, rng: random.Random | None) -> str:
    """One byte inverted: at random, or in the footer's closing magic (always detectable)."""
    data = bytearray(path.read_bytes())
    at = rng.randrange(len(data)) if rng else len(data) - 1
    data[at] ^= 0xFF
    path.write_bytes(bytes(data))
    return f"byte {at} of {len(data)} inverted"


def _edit_table(path: Path, edit: Callable[[pd.DataFrame], pd.DataFrame]) -> None:
    edit(pd.read_parquet(path)).to_parquet(path, index=False)


def _set_last(column: str, value):
    def edit(table: pd.DataFrame) -> pd.DataFrame:
        table[column] = table[column].astype(object) if isinstance(value, str) else table[column]
        table.loc[table.index[-1], column] = value
        return table
    return edit


def _result(edit: Callable[[dict], object]):
    def damage(path: Path, rng) -> str:
        result = json.loads(path.read_text())
        path.write_text(json.dumps(edit(result)))
        return "edited"
    return damage


def _bytes(data: bytes):
    def damage(path: Path, rng) -> str:
        if path.is_dir():
            shutil.rmtree(path)
        else:
            path.unlink(missing_ok=True)
        path.write_bytes(data)
        return f"{len(data)} bytes"
    return damage


def _directory(path: Path, rng) -> str:
    path.unlink()
    path.mkdir()
    (path / "stray").write_bytes(b"x")  # a file in it: an empty directory would not survive a copy into a Case
    return "a directory"


def _remove(path: Path, rng) -> str:
    path.unlink()
    return "removed"


def _plan_edit(edit: Callable[[dict], None]):
    def damage(path: Path, rng) -> str:
        plan = json.loads(path.read_text())
        edit(plan)
        path.write_text(json.dumps(plan))
        return "edited"
    return damage


def _table_edit(edit):
    def damage(path: Path, rng) -> str:
        _edit_table(path, edit)
        return "edited"
    return damage


@dataclass(frozen=True)
class Kind:
    """One kind of damage: ``apply(path, rng)`` to the file ``where`` names (a job's file: '<run>/steps.parquet',
    '<scan>/points.parquet'; else relative to the directory), and what report does with it (see the module doc). A
    run's table is damaged in its directory, where a bench killed before consolidating leaves it (the reference's
    runs are consolidated: their rows are written back first, ``Store.restore``)."""

    name: str
    where: str
    apply: Callable[[Path, random.Random | None], str]
    report: str
    """'skip', 'skip-last', 'skip-all', 'refuse', 'rebuild' or 'compare' (report --compare refuses; check finds it
    in metrics or runs)."""
    check: bool = True
    """whether check finds it (a missing runs.parquet is no damage: the tables are rebuilt)."""

    def path(self, root: Path, rng: random.Random | None = None) -> Path:
        for marker, kind in (("<run>", "run"), ("<scan>", "scan")):
            if self.where.startswith(marker):
                job = _job(root, kind, rng)
                if kind == "run" and self.where.endswith(".parquet"):
                    Store(root).restore(Path(job).name)
                return root / (job + self.where[len(marker):])
        return root / self.where

    def damage(self, root: Path, rng: random.Random | None = None) -> tuple[Path, str]:
        """Damage the results directory ``root``; (the damaged path, what was done)."""
        path = self.path(root, rng)
        return path, self.apply(path, rng)


DAMAGES = [
    # a job's tables
    Kind("steps empty", "<run>/steps.parquet", _bytes(b""), "skip"),
    Kind("steps truncated", "<run>/steps.parquet", _cut, "skip"),
    Kind("steps byte-flipped", "<run>/steps.parquet", _flip, "skip"),
    Kind("units truncated", "<run>/units.parquet", _cut, "skip"),
    Kind("units byte-flipped", "<run>/units.parquet", _flip, "skip"),
    Kind("points truncated", "<scan>/points.parquet", _cut, "skip"),
    Kind("steps a directory", "<run>/steps.parquet", _directory, "skip"),
    Kind("steps of a foreign schema", "<run>/steps.parquet",
         _table_edit(lambda t: pd.DataFrame({"dphi_2": [0.5], "ubar": [1.0]})), "skip"),
    Kind("steps without ubar_true", "<run>/steps.parquet", _table_edit(lambda t: t.drop(columns=["ubar_true"])),
         "skip"),
    Kind("steps with an unknown column", "<run>/steps.parquet", _table_edit(lambda t: t.assign(extra=1.0)), "skip"),
    Kind("steps ubar as text", "<run>/steps.parquet", _table_edit(lambda t: t.assign(ubar=t.ubar.astype(str))),
         "skip"),
    Kind("steps with inf", "<run>/steps.parquet", _table_edit(_set_last("ubar_true", math.inf)), "skip"),
    Kind("steps with NaN step time", "<run>/steps.parquet", _table_edit(_set_last("time_s", math.nan)), "skip"),
    Kind("steps a row short", "<run>/steps.parquet", _table_edit(lambda t: t.iloc[:-1]), "skip"),
    Kind("units a row short", "<run>/units.parquet", _table_edit(lambda t: t.iloc[:-1]), "skip"),
    Kind("points with inf", "<scan>/points.parquet", _table_edit(_set_last("ubar", -math.inf)), "skip"),
    Kind("points without dphi_2", "<scan>/points.parquet", _table_edit(lambda t: t.drop(columns=["dphi_2"])),
         "skip"),
    # a job's result.json
    Kind("result missing", "<run>/result.json", _remove, "skip"),
    Kind("result empty", "<run>/result.json", _bytes(b""), "skip"),
    Kind("result {}", "<run>/result.json", _bytes(b"{}"), "skip"),
    Kind("result []", "<run>/result.json", _bytes(b"[]"), "skip"),
    Kind("result binary", "<run>/result.json", _bytes(bytes(range(256))), "skip"),
    Kind("result a directory", "<run>/result.json", _directory, "skip"),
    Kind("result of an unknown status", "<run>/result.json", _result(lambda r: {**r, "status": "finished"}), "skip"),
    Kind("result with an infinite summary", "<run>/result.json",
         _result(lambda r: {**r, "summary": {**r["summary"], "final_ubar_true": math.inf}}), "skip"),
    Kind("result without a summary", "<run>/result.json", _result(lambda r: {**r, "summary": None}), "skip"),
    Kind("result of another job", "<run>/result.json", _result(lambda r: {**r, "job_id": "000000000000"}), "skip"),
    Kind("scan result of a run", "<scan>/result.json", _result(lambda r: {**r, "kind": "run"}), "skip"),
    Kind("result wall time text", "<run>/result.json", _result(lambda r: {**r, "wall_time_s": "fast"}), "skip"),
    Kind("job directory a file", "<run>", lambda p, rng: (shutil.rmtree(p), p.write_bytes(b"x"), "a file")[-1],
         "skip"),
    # the directory: the report refuses in one line
    Kind("plan truncated", "plan.json", _cut, "refuse"),
    Kind("plan empty", "plan.json", _bytes(b""), "refuse"),
    Kind("plan []", "plan.json", _bytes(b"[]"), "refuse"),
    Kind("plan a directory", "plan.json", _directory, "refuse"),
    Kind("plan experiment ../../evil", "plan.json",
         _plan_edit(lambda p: p["experiments"][0].update(name="../../evil")), "refuse"),
    Kind("plan run id a path", "plan.json", _plan_edit(lambda p: p["runs"][0].update(id="../x")), "refuse"),
    Kind("plan scan named /tmp/x", "plan.json", _plan_edit(lambda p: p["scans"][0].update(name="/tmp/x")), "refuse"),
    Kind("plan without runs", "plan.json", _plan_edit(lambda p: p.pop("runs")), "refuse"),
    Kind("plan unknown run in an experiment", "plan.json",
         _plan_edit(lambda p: p["experiments"][0]["run_ids"].append("ffffffffffff")), "refuse"),
    Kind("plan experiment twice", "plan.json",
         _plan_edit(lambda p: p["experiments"].append(dict(p["experiments"][0]))), "refuse"),
    Kind("plan setting named status", "plan.json",
         _plan_edit(lambda p: p["runs"][0]["condition"].update(status="x")), "refuse"),
    Kind("plan varying an unknown setting", "plan.json",
         _plan_edit(lambda p: p["experiments"][0]["varying"].append("colour")), "refuse"),
    Kind("plan run without a shape", "plan.json", _plan_edit(lambda p: p["runs"][0]["condition"].pop("shape")),
         "refuse"),
    Kind("runs a file", "runs", lambda p, rng: (shutil.rmtree(p), p.write_bytes(b"x"), "a file")[-1], "refuse"),
    Kind("backends table corrupt", "backends.parquet", _bytes(b"PAR1 not a table PAR1"), "refuse"),
    # consolidated tables: the report rebuilds them from the jobs
    Kind("runs table truncated", "runs.parquet", _cut, "rebuild"),
    Kind("jobs table byte-flipped", "jobs.parquet", _flip, "rebuild"),
    Kind("runs table with inf", "runs.parquet", _table_edit(_set_last("final_ubar_true", math.inf)), "rebuild"),
    # the consolidated runs' rows: their runs are damaged (the rows are their only copy)
    Kind("steps table without the last run", "steps.parquet",
         _table_edit(lambda t: t[t.run_id != t.run_id.iloc[-1]]), "skip-last"),
    Kind("steps table a row short", "steps.parquet", _table_edit(lambda t: t.iloc[:-1]), "skip-last"),
    Kind("units table with inf", "units.parquet", _table_edit(_set_last("u_true", math.inf)), "skip-last"),
    Kind("steps table with NaN step time", "steps.parquet", _table_edit(_set_last("time_s", math.nan)), "skip-last"),
    Kind("steps table truncated", "steps.parquet", _cut, "skip-all"),
    Kind("units table byte-flipped", "units.parquet", _flip, "skip-all"),
    Kind("units table a directory", "units.parquet", _directory, "skip-all"),
    Kind("steps table with an unknown column", "steps.parquet", _table_edit(lambda t: t.assign(extra=1.0)),
         "skip-all"),
    Kind("units table without u_true", "units.parquet", _table_edit(lambda t: t.drop(columns=["u_true"])),
         "skip-all"),
    Kind("jobs table stale status", "jobs.parquet", _table_edit(_set_last("status", "finished")), "rebuild"),
    # what report --compare reads
    Kind("metrics corrupt", "metrics.parquet", _cut, "compare"),
    Kind("metrics without final_ubar_std", "metrics.parquet",
         _table_edit(lambda t: t.drop(columns=["final_ubar_std"])), "compare"),
    Kind("metrics without physics", "metrics.parquet", _table_edit(lambda t: t.drop(columns=["physics"])),
         "compare"),
    Kind("metrics with inf", "metrics.parquet", _table_edit(_set_last("final_ubar", math.inf)), "compare"),
    Kind("metrics final_ubar as text", "metrics.parquet",
         _table_edit(lambda t: t.assign(final_ubar=t.final_ubar.astype(str))), "compare"),
    Kind("runs table missing", "runs.parquet", _remove, "compare", check=False),
]
"""Every kind of damage (names unique)."""


# --- cases ------------------------------------------------------------------------------------------------------------

def _files(root: Path, prefix: str) -> dict[str, bytes]:
    """Every file under ``root`` but the report's, by ``prefix/relative path``."""
    out = {}
    for path in sorted(root.rglob("*")):
        relative = path.relative_to(root)
        if path.is_file() and relative.parts[0] not in REPORT_FILES:
            out[f"{prefix}/{relative}"] = path.read_bytes()
    return out


def random_cases(n: int, seed: int) -> list[Case]:
    """``n`` cases from ``random.Random(f"results-{seed}")``: a kind of DAMAGES on a random job (offsets and bytes at
    random), run through ``report DIR``, ``report DIR --compare A B`` (the damage in A for compare kinds) or
    ``check DIR``. Kind 'results', family the kind's name."""
    rng = random.Random(f"results-{seed}")
    source = reference()
    cases = []
    for _ in range(n):
        kind = rng.choice(DAMAGES)
        command = "compare" if kind.report == "compare" and rng.randrange(3) else rng.choice(("report", "check"))
        with tempfile.TemporaryDirectory() as directory:
            copy = Path(directory) / "R"
            shutil.copytree(source, copy, ignore=shutil.ignore_patterns(*REPORT_FILES))
            path, what = kind.damage(copy, rng)
            damaged = _files(copy, "R")
        clean = _files(source, "B")
        description = f"{kind.name}: {path.relative_to(copy)} {what}"
        if command == "compare":
            extra = {**{"A" + name[1:]: data for name, data in damaged.items()}, **clean,
                     **{"R" + name[1:]: data for name, data in clean.items()}}
            argv = ["report", "{dir}/R", "--compare", "{dir}/A", "{dir}/B", "--no-videos"]
        else:
            extra = damaged
            argv = ["report", "{dir}/R", "--no-videos"] if command == "report" else ["check", "{dir}/R"]
        cases.append(Case("results", kind.name, f"{' '.join(argv[:1])} {description}", argv, extra=extra))
    return cases


def verdict(outcome: Outcome) -> str:
    """fuzzing.judge's verdict, but ``check`` exiting 1 with its findings on stdout and nothing on stderr is
    'accepted' (it found damage, as it should)."""
    o = outcome
    if (o.case.argv[0] == "check" and o.status == 1 and o.exception is None and not o.err.strip()
            and o.out.strip()):
        return "accepted"
    return o.verdict
