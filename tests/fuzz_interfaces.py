"""Malformed input at the interfaces tests/fuzzing.py does not reach: environment actions, replays of tampered runs and
oversized plans. Cases are ``fuzzing.Case`` objects and are judged into ``fuzzing.Outcome`` verdicts, so
``benchmarks/robustness.py`` can count them beside the others.

Input kinds (``KINDS``):

- ``env``: one ``step()`` of ``ParallelEnv`` or ``CentralEnv`` (chain-2, quasi-static) with a generated action: a
  bool, a string, bytes, a huge int, a date, a dict, a complex number, None, NaN, arrays of the wrong shape or dtype,
  unknown or missing agents, a step after the episode is over, and valid phases. ``data`` holds the action as a
  Python expression (``np``, ``datetime`` and ``math`` in scope), ``argv`` is ``["env", "parallel"|"central",
  "valid"|"invalid"]``. It runs in-process, not through the CLI: ``run_case`` here judges it. A valid action is
  ``accepted`` if the step ran and the phase taken is the action wrapped modulo 1; an invalid one ``refused`` if
  ``ActionError`` or ``EpisodeOver`` was raised with one line naming the agent (or ``action``/``actions``) and nothing
  ran. Anything else is a crash kind.
- ``render``: ``morphbench render`` of a finished 1-step run (made once per process) whose ``summary.json`` or
  ``steps.parquet`` was tampered with (a key deleted, a wrong type, an absurd number, another shape file, a broken
  file), through ``fuzzing.run_case``.
- ``plan``: ``scan`` and ``bench`` asking for more points, seeds or combinations than the declared limits
  (``params.MAX_SCAN_POINTS``, ``params.MAX_SUITE_RUNS``), through ``fuzzing.run_case``: each must be refused at
  once (one line, exit 2), never built.

``random_cases(n, seed)`` gives ``n`` cases over the three kinds from ``random.Random(seed)``; ``run_case(case,
workdir)`` runs any of them (the CLI kinds through ``fuzzing.run_case``).
"""

from __future__ import annotations

import datetime
import functools
import json
import math
import random
import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

import fuzzing
from fuzzing import CHAIN2, NUMBERS, SHAPES_DIR, WRONG_TYPES, Case, Outcome, RandomChooser

KINDS = ("env", "render", "plan")
SMALL_VIDEO = ["--video-width", "32", "--video-height", "32", "--video-fps", "2", "--quiet"]

# --- env ----------------------------------------------------------------------------------------------------------

VALID_ACTIONS = ["0.3", "0", "1", "-0.25", "1.75", "np.float32(0.5)", "np.int64(2)", "np.array(0.5)",
                 "np.array([0.75], dtype=np.float32)", "[0.1]", "(0.9,)", "999999.5"]
INVALID_ACTIONS = ["True", "False", "np.bool_(True)", "'0.3'", "b'0.3'", "2 ** 1000", "-(2 ** 70)", "1e7",
                   "datetime.datetime(2020, 1, 1)", "datetime.timedelta(1)", "{'phase': 0.3}", "0.3 + 0j", "None",
                   "math.nan", "math.inf", "-math.inf", "[0.1, 0.2]", "[]", "()", "np.array([0.1, 0.2])",
                   "np.array([True])", "np.array(['0.3'])", "np.array(0.3 + 1j)", "[[0.3]]", "object()", "...",
                   "np.array([np.nan])", "np.zeros((1, 1, 2))", "[None]", "['x']", "range(1)", "{0.3}",
                   "np.datetime64('2020-01-01')", "float('1e309')", "np.float16(np.inf)"]
CENTRAL_VALID = ["np.full(2, 0.3)", "[0.1, 0.2]", "np.array([1, 2])", "(0.5, -0.5)", "np.array([0.1, 0.2], "
                 "dtype=np.float32)"]
CENTRAL_INVALID = ["np.zeros(3)", "np.zeros(1)", "np.zeros((2, 1))", "[0.1, '0.2']", "[True, False]", "None", "0.3",
                   "{'unit_1': 0.3}", "np.array([0.1, np.nan])", "np.array([0.1, np.inf])", "[0.1, [0.2]]",
                   "np.array([1 + 0j, 0])", "'01'", "[2 ** 1000, 0.1]", "np.array(['a', 'b'])",
                   "[datetime.datetime(2020, 1, 1)] * 2"]
AGENT_FAULTS = ["unknown agent", "missing agent", "not a dict", "after the episode"]


def env_case(choose: fuzzing.Chooser) -> Case:
    which = choose.choice(("parallel", "parallel", "central"))
    if which == "central":
        valid = choose.integer(0, 3) == 0
        action = choose.choice(CENTRAL_VALID if valid else CENTRAL_INVALID)
        return Case("env", "central action", f"CentralEnv.step({action})", ["env", which, _validity(valid)],
                    action.encode())
    if choose.integer(0, 5) == 0:
        fault = choose.choice(AGENT_FAULTS)
        return Case("env", "agents", fault, ["env", which, "invalid", fault], b"0.3")
    valid = choose.integer(0, 3) == 0
    action = choose.choice(VALID_ACTIONS if valid else INVALID_ACTIONS)
    return Case("env", "action", f"unit_2's action {action}", ["env", which, _validity(valid)], action.encode())


def _validity(valid: bool) -> str:
    return "valid" if valid else "invalid"


@functools.lru_cache(maxsize=None)
def _environment(which: str):
    from morphbench.envs import CentralEnv, ParallelEnv

    cls = CentralEnv if which == "central" else ParallelEnv
    return cls(CHAIN2, steps=3, physics="quasistatic")


def run_env_case(case: Case) -> Outcome:
    """Step an environment with the case's action; the verdict as ``fuzzing.judge`` would give it."""
    from morphbench.errors import ActionError, EpisodeOver

    which, expected = case.argv[1], case.argv[2]
    fault = case.argv[3] if len(case.argv) > 3 else None
    env = _environment(which)
    parallel = env.parallel if which == "central" else env
    action = eval(case.data.decode(), {"np": np, "datetime": datetime, "math": math})  # the generator's own text
    exception, err, verdict = None, "", ""
    env.reset(seed=0)
    if fault == "after the episode":
        while parallel.agents:
            parallel.step(dict.fromkeys(parallel.agents, 0.5))
    before = parallel.learning_step
    if which == "central":
        call = (env.step, action)
    else:
        actions = {"unit_1": 0.5, "unit_2": action}
        if fault == "unknown agent":
            actions["unit_7"] = 0.5
        elif fault == "missing agent":
            del actions["unit_2"]
        call = (parallel.step, [0.5, action] if fault == "not a dict" else actions)
    try:
        call[0](call[1])
    except (ActionError, EpisodeOver) as exc:
        err = str(exc)
        named = any(name in err for name in ("unit_", ": action:", ": actions:", "episode is over"))
        verdict = ("refused good action" if expected == "valid" else
                   "refused, several lines" if "\n" in err else
                   "refused, names no agent" if not named else
                   "refused after stepping" if parallel.learning_step != before else "refused")
    except BaseException as exc:  # noqa: B036 - what escapes is what is measured, KeyboardInterrupt aside
        if isinstance(exc, KeyboardInterrupt):
            raise
        exception, verdict = exc, f"exception {type(exc).__name__}"
    else:
        verdict = "accepted" if expected == "valid" and _took(parallel, which, action) else (
            "accepted, phase not the action" if expected == "valid" else "accepted bad action")
    return Outcome(case, 0 if verdict == "accepted" else 2, "", err, exception, [], verdict)


def _took(parallel, which: str, action: Any) -> bool:
    """Whether the phases run are the action wrapped modulo 1 (unit 2's, or every unit's for the central env)."""
    wanted = np.asarray(action, dtype=float).reshape(-1) % 1.0
    ran = parallel.phases() if which == "central" else parallel.phases()[1:2]
    return bool(np.allclose(np.minimum(abs(ran - wanted), 1 - abs(ran - wanted)), 0, atol=1e-6))


# --- render -------------------------------------------------------------------------------------------------------

SHAPE_SWAPS = [str(SHAPES_DIR / "chain-3.toml"), str(SHAPES_DIR / "chain-3-capsules.toml"), "/nonexistent/s.toml",
               str(SHAPES_DIR), "", "a\0b.toml", str(fuzzing.EXAMPLES_DIR / "s6-damage.toml")]
"""shape files a tampered summary.json may name instead of the run's: others, none, a directory, a run file."""
STEPS_FAULTS = ["step as strings", "ubar as strings", "no ubar column", "a step missing", "steps repeated",
                "garbage bytes", "empty table", "ubar shifted"]


@functools.lru_cache(maxsize=None)
def finished_run() -> dict[str, bytes]:
    """The files of a finished 1-step chain-2 run (quasi-static, ideal sensor), made once per process."""
    from morphbench.experiment import RunConfig, run
    from morphbench.params import QUASISTATIC_PHYSICS, SensorParams
    from morphbench.shapes import load_shape

    records = run(RunConfig(shape=load_shape(CHAIN2), steps=1, sensor=SensorParams(kind="ideal"),
                            physics=QUASISTATIC_PHYSICS))
    directory = Path(tempfile.mkdtemp(prefix="mb-fuzz-run-"))
    try:
        records.write(directory / "run")
        return {p.name: p.read_bytes() for p in (directory / "run").iterdir() if p.suffix in (".json", ".parquet")}
    finally:
        shutil.rmtree(directory)


def render_case(choose: fuzzing.Chooser) -> Case:
    files = dict(finished_run())
    summary = json.loads(files["summary.json"])
    family = choose.choice(("config", "config", "shape", "steps", "syntax"))
    if family == "config":
        nodes = [(p, v) for p, v in fuzzing._nodes(summary["config"]) if not p or p[0] != "shape"]
        path, old = choose.choice(nodes)
        how = choose.choice(("delete", "type", "number"))
        if how == "delete" and isinstance(path[-1], str):
            parent = summary["config"]
            for key in path[:-1]:
                parent = parent[key]
            del parent[path[-1]]
            what = f"config.{fuzzing._name(path)} deleted"
        else:
            value = choose.choice(WRONG_TYPES if how == "type" else NUMBERS)
            fuzzing._set(summary["config"], path, value)
            what = f"config.{fuzzing._name(path)} = {fuzzing._short(value)} (was {fuzzing._short(old)})"
    elif family == "shape":
        source = choose.choice(SHAPE_SWAPS)
        key = choose.choice(("source", "source", "name", "n_units", "id"))
        value = source if key == "source" else choose.choice(["chain-3", 3, "", None, "0" * 12, 2.0])
        summary["config"]["shape"][key] = value
        what = f"config.shape.{key} = {fuzzing._short(value)}"
    elif family == "steps":
        fault = choose.choice(STEPS_FAULTS)
        files["steps.parquet"] = _tampered_steps(files["steps.parquet"], fault)
        what = f"steps.parquet: {fault}"
    else:
        text = files["summary.json"]
        at = choose.integer(0, len(text))
        files["summary.json"] = text[:at] + choose.choice([b"", b"}", b"\xff", b"\0", b"[["])
        what = f"summary.json cut or broken at {at}"
    if family != "steps" and family != "syntax":
        files["summary.json"] = json.dumps(summary).encode()
    argv = ["render", "{dir}/run", "--out", "{out}.gif", *SMALL_VIDEO]
    return Case("render", family, what, argv, extra={f"run/{name}": data for name, data in files.items()})


def _tampered_steps(data: bytes, fault: str) -> bytes:
    import io

    import pandas as pd

    if fault == "garbage bytes":
        return b"PAR1 not really" + data[:40]
    table = pd.read_parquet(io.BytesIO(data))
    table = {"step as strings": lambda t: t.astype({"step": str}),
             "ubar as strings": lambda t: t.astype({"ubar": str}),
             "no ubar column": lambda t: t.drop(columns="ubar"),
             "a step missing": lambda t: t[t.step != 1],
             "steps repeated": lambda t: pd.concat([t, t]),
             "empty table": lambda t: t.iloc[:0],
             "ubar shifted": lambda t: t.assign(ubar=t.ubar + 0.5)}[fault](table)
    out = io.BytesIO()
    table.to_parquet(out, index=False)
    return out.getvalue()


# --- plans --------------------------------------------------------------------------------------------------------

def plan_case(choose: fuzzing.Chooser) -> Case:
    from morphbench.params import MAX_SCAN_POINTS, MAX_SUITE_RUNS

    if choose.integer(0, 1) == 0:
        shape, units = choose.choice([("chain-2", 2), ("chain-3", 3), ("chain-5", 5), ("grid-3x3", 9)])
        # past the limit: resolution^2 points for 3 units and beyond (the smallest, 317, is 100,489); 2 units can
        # only ask for more than a resolution may be
        smallest = math.isqrt(MAX_SCAN_POINTS) + 1
        value = choose.choice(["10001", str(10 ** 8)] if units == 2 else [str(smallest), "1000", "10000"])
        argv = ["scan", shape, "--resolution", value, "--cycles", "1", "--quiet", "--out", "{out}"]
        return Case("plan", "scan", f"scan {shape} --resolution {value}", argv)
    doc = fuzzing.seed_documents("suite")[0][1]
    experiment = doc["experiment"][0]
    how = choose.choice(("seeds", "seed list", "axes", "experiments", "scan"))
    if how == "seeds":
        experiment["seeds"] = choose.choice([MAX_SUITE_RUNS + 1, 10 ** 6, 10 ** 9, 2 ** 62])
        what = f"seeds = {experiment['seeds']}"
    elif how == "seed list":
        experiment.pop("seeds", None)
        experiment["seed"] = list(range(MAX_SUITE_RUNS + choose.integer(1, 1000)))
        what = f"seed = [0 .. {len(experiment['seed']) - 1}]"
    elif how == "axes":
        width = choose.choice([400, 1000])
        experiment["learner"] = {"name": ["thermal"], "step_size": [k / width for k in range(width)],
                                 "temperature": [k / 10 for k in range(1, 1 + MAX_SUITE_RUNS // width + 1)]}
        what = f"learner axes of {width} x {MAX_SUITE_RUNS // width + 1} values"
    elif how == "experiments":
        half = MAX_SUITE_RUNS // 2 + 1
        experiment["seeds"] = half
        doc["experiment"].append({**experiment, "name": "again", "shape": experiment["shape"],
                                  "steps": experiment["steps"] + 1})
        what = f"two experiments of {half} seeds"
    else:
        doc["scan"][0]["resolution"] = choose.choice([10 ** 5 + 1, 10 ** 6, 10000])
        doc["scan"][0]["shape"] = str(SHAPES_DIR / "chain-3.toml")
        what = f"scan resolution {doc['scan'][0]['resolution']} on chain-3"
    argv = ["bench", "{in}", "--out", "{out}", "--quiet", "--no-report", "--workers", "1"]
    return Case("plan", "suite", what, argv, fuzzing.dump_toml(doc).encode())


# --- all ----------------------------------------------------------------------------------------------------------

MAKERS = {"env": env_case, "render": render_case, "plan": plan_case}


def make_case(kind: str, choose: fuzzing.Chooser) -> Case:
    return MAKERS[kind](choose)


def random_cases(n: int, seed: int, kinds: tuple[str, ...] = KINDS) -> list[Case]:
    """``n`` cases over ``kinds`` (in turn) from ``random.Random(seed)``: the same seed, the same cases."""
    choose = RandomChooser(random.Random(f"interfaces-{seed}"))
    return [make_case(kinds[i % len(kinds)], choose) for i in range(n)]


def run_case(case: Case, workdir: Path, timeout_s: float = fuzzing.TIMEOUT_S) -> Outcome:
    """Run and judge one case: an ``env`` case in-process here, the others through ``fuzzing.run_case``."""
    if case.kind == "env":
        return run_env_case(case)
    return fuzzing.run_case(case, workdir, timeout_s=timeout_s)
