"""Malformed input, generated: mutations of the shipped files and bad command lines, and one way to run and judge them.

Used by ``tests/test_fuzz.py`` (hypothesis strategies, which shrink a failing case) and ``benchmarks/robustness.py``
(plain ``random.Random(seed)``: many cases, reproducible from the seed alone, with none of hypothesis's database or
health checks). Both drive the same generator: every random decision goes through a ``Chooser``, so a strategy
and a seeded generator make the same kinds of case.

Input kinds (``KINDS``):

- ``shape``: a mutated ``shapes/*.toml``, checked by ``morphbench shapes check FILE``;
- ``run``: a mutated ``examples/*.toml``, run by ``morphbench run FILE --steps 1 --out DIR``;
- ``suite``: a mutated, shrunk ``benchmarks/smoke.toml``, run by ``morphbench bench FILE --out DIR --no-report``;
- ``options``: random subsets of ``run/scan/shapes/bench/report`` options, mostly with bad values;
- ``plugin``: ``--learner`` specs that are malformed, or name a generated plug-in module that misbehaves.

Mutation families of the file kinds (``FAMILIES``): ``delete`` a key, add an ``unknown`` key, a wrong ``type``
(string, bool, array, table), an absurd ``number`` (0, -1, 1e-300, 1e300, 2**62, nan, inf, "nan"), a bad ``path`` (NUL
byte, 300-character name), a ``syntax`` error (truncated text, a stray character, bytes that are not UTF-8) and
``deep`` nesting (arrays or inline tables nested 3 to 5000 deep).

``run_case(case, workdir)`` runs one case in-process through ``morphbench.cli.main`` and returns an ``Outcome`` whose
``verdict`` is ``accepted``, ``refused`` (exit 2, one clean line, nothing written) or a crash kind.
"""

from __future__ import annotations

import contextlib
import datetime
import io
import itertools
import math
import os
import random
import re
import signal
import sys
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

ROOT = Path(__file__).resolve().parents[1]
SHAPES_DIR, EXAMPLES_DIR, BENCHMARKS_DIR = ROOT / "shapes", ROOT / "examples", ROOT / "benchmarks"
CHAIN2 = str(SHAPES_DIR / "chain-2.toml")

KINDS = ("shape", "run", "suite", "options", "plugin")
FAMILIES = ("delete", "unknown", "type", "number", "path", "syntax", "deep")
RUN_FILES = {"units.parquet", "steps.parquet", "pieces.parquet", "summary.json", "learning_curve.png",
             "trajectory.png"}
# A time limit here only catches a hang, never slowness: the cases take 1-3 s on an idle machine and several times
# that on a busy one. A hang is an absurd value that was accepted and computes for ever, which burns CPU time, a
# clock other processes do not advance: CPU_TIMEOUT_S (ITIMER_PROF, this process's CPU time) catches it however busy
# the machine is. A process blocked for ever (on a child process, a lock) burns none: the wall clock's TIMEOUT_S,
# minutes, is the backstop for that.
CPU_TIMEOUT_S = 60.0
"""CPU time (s) of the process running a case after which it is a crash ("timeout")."""
TIMEOUT_S = 300.0
"""Wall time (s) after which a case still running is a crash ("timeout"): one blocked for ever."""
BANNER = "pybullet build time"


# --- choosing: one interface over hypothesis and random.Random --------------------------------------------------------

class Chooser:
    """Every random decision of the generator: ``choice(options)`` and ``integer(low, high)`` (both ends included)."""

    def choice(self, options: Sequence[Any]) -> Any:
        raise NotImplementedError

    def integer(self, low: int, high: int) -> int:
        raise NotImplementedError


class RandomChooser(Chooser):
    def __init__(self, rng: random.Random):
        self.rng = rng

    def choice(self, options):
        return options[self.rng.randrange(len(options))]

    def integer(self, low, high):
        return self.rng.randint(low, high)


class DrawChooser(Chooser):
    """Decisions drawn from hypothesis (``draw`` of ``st.composite`` or ``st.data().draw``), so failures shrink."""

    def __init__(self, draw: Callable):
        from hypothesis import strategies as st  # here, not at module level: the benchmark needs no hypothesis

        self.draw, self.st = draw, st

    def choice(self, options):
        return self.draw(self.st.sampled_from(list(options)))

    def integer(self, low, high):
        return self.draw(self.st.integers(low, high))


# --- TOML out ---------------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Deep:
    """A value nested ``depth`` deep, written straight as text (a recursive writer, or reader, would overflow)."""

    depth: int
    table: bool = False

    def text(self) -> str:
        if self.table:
            return "{a = " * self.depth + "1" + " }" * self.depth
        return "[" * self.depth + "1" + "]" * self.depth


def toml_string(text: str) -> str:
    """A TOML basic string: quotes and backslashes escaped, every control character (DEL too) as \\uXXXX."""
    out = []
    for char in text:
        if char in '"\\':
            out.append("\\" + char)
        elif ord(char) < 0x20 or ord(char) == 0x7F:
            out.append(f"\\u{ord(char):04x}")
        else:
            out.append(char)
    return '"' + "".join(out) + '"'


def toml_value(value: Any) -> str:
    if isinstance(value, Deep):
        return value.text()
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return toml_string(value)
    if isinstance(value, (datetime.datetime, datetime.date, datetime.time)):
        return value.isoformat()
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{toml_string(k)} = {toml_value(v)}" for k, v in value.items()) + "}"
    raise TypeError(f"no TOML for {value!r}")


def dump_toml(doc: dict) -> str:
    """``doc`` as TOML: every top-level key on one line, nested tables inline (valid, if not pretty)."""
    return "".join(f"{toml_string(k)} = {toml_value(v)}\n" for k, v in doc.items())


# --- the valid files the mutations start from -------------------------------------------------------------------------

def _absolute(doc: dict, key: str, base: Path) -> None:
    """Make a relative file name under ``doc[key]`` (a string or a list of strings) absolute: the mutated copy is
    written elsewhere."""
    value = doc.get(key)
    if isinstance(value, str):
        doc[key] = str((base / value).resolve())
    elif isinstance(value, list):
        doc[key] = [str((base / v).resolve()) if isinstance(v, str) else v for v in value]


def seed_documents(kind: str) -> list[tuple[str, dict]]:
    """(name, table) of every valid file the mutations of ``kind`` start from."""
    if kind == "shape":
        return [(p.name, tomllib.loads(p.read_text())) for p in sorted(SHAPES_DIR.glob("*.toml"))]
    if kind == "run":
        seeds = []
        for p in sorted(EXAMPLES_DIR.glob("*.toml")):
            doc = tomllib.loads(p.read_text())
            _absolute(doc, "shape", p.parent)
            for event in doc.get("events", []):
                event["step"] = 1  # cases run 1 step (--steps 1), and an event after the last step is refused
            seeds.append((p.name, doc))
        return seeds
    if kind == "suite":
        # smoke.toml shrunk to one run of 1 step and a 2-point scan, so that an accepted suite takes seconds
        p = BENCHMARKS_DIR / "smoke.toml"
        doc = tomllib.loads(p.read_text())
        for experiment in doc["experiment"]:
            _absolute(experiment, "shape", p.parent)
            experiment.update(shape=experiment["shape"][:1], learner={"name": ["thermal"]},
                              environment={"noise": [0.5]}, seeds=1, steps=1)
        for scan in doc["scan"]:
            _absolute(scan, "shape", p.parent)
            scan.update(resolution=2, cycles=1, discard=0)
        return [(p.name, doc)]
    raise ValueError(kind)


# --- mutations --------------------------------------------------------------------------------------------------------

WRONG_TYPES: list[Any] = ["text", "", True, False, [1, 2], [], [[1], ["a"]], {"x": 1}, {}, [{"a": 1}]]
NUMBERS: list[Any] = [0, -1, 1, 0.0, -0.0, 1e-300, -1e-300, 1e300, -1e300, 2 ** 62, -(2 ** 62), 2 ** 63 - 1,
                      float("nan"), float("inf"), float("-inf"), "nan", "1e300", 0.5, 1.5]
PATHS: list[str] = ["a\0b.toml", "shapes/chain-2.toml\0", "x" * 300 + ".toml", "/" + "y" * 300 + "/z.obj",
                    "d/" * 200 + "m.obj", "/nonexistent/file.toml", ".", "/", "", " ", "\n", "\u00e9\u2603.toml"]
DEPTHS = (3, 40, 900, 5000)
UNKNOWN_KEYS = ("colour", "zz_unknown", "", " ", "unit.mass", "\u00e9")
PATH_KEYS = {"shape": [("unit", "mesh"), ("dummy", "mesh")], "run": [("shape",), ("environment", "ground", "image")],
             "suite": [("experiment", 0, "shape"), ("scan", 0, "shape")]}
"""Where a file name can go, whether the seed file has one there or not."""


def _nodes(value: Any, path: tuple = ()) -> list[tuple[tuple, Any]]:
    """Every (path, value) below ``value``, tables and arrays included (not the root)."""
    out = []
    items = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, list) else ()
    for key, child in items:
        out.append((path + (key,), child))
        out.extend(_nodes(child, path + (key,)))
    return out


def _set(doc: Any, path: tuple, value: Any) -> None:
    for key in path[:-1]:
        if isinstance(doc, dict):
            doc = doc.setdefault(key, {})
        else:
            doc = doc[key]
    if isinstance(doc, dict) or (isinstance(doc, list) and path[-1] < len(doc)):
        doc[path[-1]] = value


def _name(path: tuple) -> str:
    return ".".join(f"[{k}]" if isinstance(k, int) else str(k) for k in path).replace(".[", "[")


def _copy(doc: dict) -> dict:
    return tomllib.loads(dump_toml(doc))  # a deep copy by round trip (the seeds hold nothing TOML cannot)


def mutate(kind: str, doc: dict, family: str, choose: Chooser) -> tuple[bytes, str]:
    """One mutation of ``doc`` (a valid table of ``kind``) in ``family``: (the file's bytes, what was done)."""
    doc = _copy(doc)
    nodes = _nodes(doc)
    leaves = [(p, v) for p, v in nodes if not isinstance(v, (dict, list))]
    if family == "delete":
        path, _ = choose.choice([(p, v) for p, v in nodes if isinstance(p[-1], str)])
        parent = doc
        for key in path[:-1]:
            parent = parent[key]
        del parent[path[-1]]
        return dump_toml(doc).encode(), f"delete {_name(path)}"
    if family == "unknown":
        tables = [()] + [p for p, v in nodes if isinstance(v, dict)]
        path = choose.choice(tables) + (choose.choice(UNKNOWN_KEYS),)
        _set(doc, path, 1)
        return dump_toml(doc).encode(), f"add {_name(path)} = 1"
    if family in ("type", "number", "deep"):
        path, old = choose.choice(leaves if family == "number" else nodes)
        if family == "type":
            value = choose.choice(WRONG_TYPES)
        elif family == "number":
            value = choose.choice(NUMBERS)
        else:
            value = Deep(choose.choice(DEPTHS), table=choose.choice((False, True)))
        _set(doc, path, value)
        return dump_toml(doc).encode(), f"{_name(path)} = {_short(value)} (was {_short(old)})"
    if family == "path":
        strings = [p for p, v in leaves if isinstance(v, str)]
        path = choose.choice(strings + PATH_KEYS[kind])
        value = choose.choice(PATHS)
        _set(doc, path, value)
        return dump_toml(doc).encode(), f"{_name(path)} = {_short(value)}"
    if family == "syntax":
        text = dump_toml(doc)
        how = choose.choice(("truncate", "insert", "latin-1", "empty", "nul"))
        at = choose.integer(0, len(text))
        if how == "truncate":
            return text[:at].encode(), f"truncated at {at} of {len(text)}"
        if how == "insert":
            char = choose.choice(list("[]{}=\"',#.\n\\") + ["[[", "]]", "= =", "\x07"])
            return (text[:at] + char + text[at:]).encode(), f"{char!r} inserted at {at}"
        if how == "latin-1":
            return text[:at].encode() + b"\xe9\xff" + text[at:].encode(), f"bytes e9 ff (not UTF-8) at {at}"
        if how == "nul":
            return text[:at].encode() + b"\0" + text[at:].encode(), f"a NUL byte at {at}"
        return b"", "an empty file"
    raise ValueError(family)


def _short(value: Any, width: int = 40) -> str:
    text = value.text() if isinstance(value, Deep) else repr(value)
    if isinstance(value, Deep):
        return f"<{'table' if value.table else 'array'} nested {value.depth} deep>"
    return text if len(text) <= width else text[:width - 3] + "..."


# --- cases ------------------------------------------------------------------------------------------------------------

@dataclass
class Case:
    """One generated input: a file to write (``data``, for the file kinds) and/or a command line. In ``argv``,
    ``{in}`` is the mutated file, ``{out}`` the output path, ``{dir}`` the case's input directory."""

    kind: str
    family: str
    description: str
    argv: list[str]
    data: bytes | None = None
    plugin: str | None = None  # a plug-in module's source, written as {dir}/plugins/NAME.py
    extra: dict[str, bytes] = field(default_factory=dict)  # more input files, by name under {dir}

    def short(self, width: int = 110) -> str:
        text = f"{self.family}: {self.description}"
        text = text if len(text) <= width else text[:width - 3] + "..."
        return text.replace("|", "\\|")


def file_case(kind: str, choose: Chooser, families: Sequence[str] = FAMILIES) -> Case:
    name, doc = choose.choice(seed_documents(kind))
    family = choose.choice(list(families))
    data, what = mutate(kind, doc, family, choose)
    argv = {"shape": ["shapes", "check", "{in}"],
            "run": ["run", "{in}", "--steps", "1", "--quiet", "--out", "{out}"],
            "suite": ["bench", "{in}", "--out", "{out}", "--quiet", "--no-report", "--workers", "1"]}[kind]
    return Case(kind, family, f"{name}: {what}", argv, data)


BAD_NUMBERS = ["-1", "x", "1e300", "nan", "inf", "-inf", str(2 ** 62), "1.5", "", " ", "0x10", "1_000", "\0"]
OPTION_VALUES: dict[str, dict[str, list[str]]] = {
    # command: option: values (all bad unless listed in GOOD below)
    "run": {"--learner": ["", "nope", "x:y", "os:path", "thermal:", ":", "a" * 300, "math:pi", "builtins:object",
                          "thermal", "flaky", "averaged", "adaptive", "random"],
            "--steps": BAD_NUMBERS + ["0"], "--seed": BAD_NUMBERS + ["3", "0"],
            "--temperature": ["-1", "nan", "x", "-inf", "", "1e-300", "inf", "0"],
            "--step-size": ["2", "-0.1", "nan", "1.0000001", "inf", "0", "1"],
            "--cycles-per-step": ["0", "-1", "1.5", "nan", "x", "1"],
            "--sensor": ["bogus", "", "IDEAL", "ideal"], "--noise": ["-1", "nan", "inf", "-0.0001", "0.5"],
            "--physics": ["bogus", "", "quasistatic"],
            "--out": ["{dir}/a\0b", "{dir}/" + "o" * 300, "{dir}/file.txt", "{dir}/file.txt/sub"],
            "--video": ["{dir}/v.txt", "{dir}/v\0.mp4", "{dir}/" + "v" * 300 + ".gif", "{dir}/missing/dir/v.gif"],
            "--video-speed": ["0", "-1", "nan", "inf", "x"], "--video-steps": ["5:1", "a:b", "-1:2", "1", "1:2:3"],
            "--video-width": ["0", "-5", "x", "1.5"], "--bogus": [], "--overwrite": [], "--quiet": []},
    "scan": {"--resolution": ["0", "-1", "x", "1.5", "nan", "1"], "--samples": ["0", "-1", "x", "nan"],
             "--cycles": ["0", "-1", "x", "1e300"], "--seed": ["-1", "x", "nan", "5"],
             # --workers: never a huge number, which would start that many processes on a shared machine
             "--workers": ["0", "-1", "x", "1.5", ""], "--physics": ["bogus", "quasistatic"],
             "--out": ["{dir}/a\0b", "{dir}/" + "o" * 300, "{dir}/file.txt"], "--bogus": []},
    "bench": {"--workers": ["0", "-1", "x", "1.5", "", "nan"], "--resume": [], "--retry-failed": [], "--bogus": [],
              "--out": ["{dir}/a\0b", "{dir}/" + "o" * 300, "{dir}/file.txt", ""]},
}
GOOD = {"thermal", "flaky", "averaged", "adaptive", "random", "0", "1", "3", "5", "0.5", "ideal", "quasistatic", "inf",
        "1e-300"}
POSITIONAL_BAD = ["{dir}/missing.toml", "{dir}/a\0b.toml", "{dir}/" + "p" * 300 + ".toml", "{dir}", "{dir}/file.txt",
                  "", "-", "nonexistent-shape-name", "{dir}/bad.toml"]
SHAPES_BAD_OUT = ["{dir}/x.txt", "{dir}/a\0b.glb", "{dir}/" + "e" * 300 + ".png", "{dir}", "{dir}/no/such/dir/x.png",
                  "{dir}/file.txt/x.png"]


def is_pending(value: str) -> bool:
    """A value fixes on another branch are about: a NUL byte, a name longer than a file system allows, or a count
    (2**62) no upper bound refuses yet."""
    return "\0" in value or any(len(part) > 255 for part in value.split("/")) or value == str(2 ** 62)


def options_case(choose: Chooser, pending: bool = True) -> Case:
    """A command with a random subset of its options, mostly with bad values, or a bad positional argument;
    ``pending=False`` leaves out what fixes on another branch are about: values with a NUL byte or an over-long
    name, and ``report`` of a file."""
    choose = _Filtered(choose, pending)
    command = choose.choice(("run", "scan", "shapes", "bench", "report"))
    extra = {"file.txt": b"not a directory\n", "bad.toml": b"[assembly\n"}
    if command == "shapes":
        sub = choose.choice(("check", "export", "show", "list"))
        if sub == "list":
            argv = ["shapes", "list", choose.choice(POSITIONAL_BAD + ["{dir}/empty"])]
        else:
            file = choose.choice([CHAIN2] + POSITIONAL_BAD)
            flag = {"check": None, "export": "--out", "show": "--png"}[sub]
            argv = ["shapes", sub, file] + ([flag, choose.choice(SHAPES_BAD_OUT + ["{out}.png", "{out}.glb"])]
                                            if flag else [])
            if file == CHAIN2 and (flag is None or argv[-1].startswith("{out}")):
                argv.append("--bogus")  # keep the case bad: an option shapes does not have
        return Case("options", f"shapes {sub}", " ".join(argv), argv, extra=extra)
    if command == "report":
        target = choose.choice([t for t in POSITIONAL_BAD if pending or t not in ("{dir}/file.txt", "{dir}/bad.toml")]
                               + ["{dir}/empty", "{dir}/garbage-results"])
        extra["garbage-results/runs.parquet"] = b"PAR1 not really"
        return Case("options", "report", f"report {target}", ["report", target], extra=extra)
    pool = OPTION_VALUES[command]
    base = {"run": ["run", CHAIN2, "--steps", "1", "--quiet", "--sensor", "ideal", "--out", "{out}"],
            "scan": ["scan", CHAIN2, "--resolution", "2", "--cycles", "1", "--quiet", "--out", "{out}"],
            "bench": ["bench", "{dir}/tiny.toml", "--out", "{out}", "--quiet", "--no-report",
                      "--workers", "1"]}[command]
    if command == "bench":
        extra["tiny.toml"] = dump_toml(seed_documents("suite")[0][1]).encode()
    if choose.integer(0, 4) == 0:  # a bad positional argument instead of the file
        argv = list(base)
        argv[1] = choose.choice(POSITIONAL_BAD)
        return Case("options", f"{command} positional", " ".join(argv), argv, extra=extra)
    names = list(pool)
    chosen = []
    for _ in range(choose.integer(1, 3)):
        name = choose.choice([n for n in names if not pool[n] or choose.usable(pool[n])])
        value = choose.choice(pool[name]) if pool[name] else None
        chosen.append((name, value))
    argv = list(base)
    for name, value in chosen:
        if name in argv[2:]:  # the option is already in the base line: the fuzzed value replaces it
            at = argv.index(name, 2)
            del argv[at:at + 2]
        argv += [name] if value is None else [name, value]
    shown = " ".join(f"{n} {v!r}" if v is not None else n for n, v in chosen)
    return Case("options", command, f"{command} ... {shown}", argv, extra=extra)


class _Filtered(Chooser):
    """A chooser that, unless ``pending``, never picks a string value ``is_pending`` holds for."""

    def __init__(self, inner: Chooser, pending: bool):
        self.inner, self.pending = inner, pending

    def usable(self, options) -> list:
        return [o for o in options if self.pending or not (isinstance(o, str) and is_pending(o))]

    def choice(self, options):
        return self.inner.choice(self.usable(options))

    def integer(self, low, high):
        return self.inner.integer(low, high)


PLUGIN_TEMPLATE = '''
import math, sys
{module_level}

class Learner:
    def __init__(self{init_args}):
        {init}
        self.phase = 0.25

    def propose(self):
        {propose}
        return 0.5

    def update(self, velocity):
        {update}
        return True
{tail}
'''
PLUGIN_FAULTS = {
    "module_level": ["raise ImportError('no hardware')", "import no_such_module_mb", "sys.exit(0)", "1/0",
                     "def __getattr__(name):\n    raise RuntimeError(name)", "x = ("],
    "init_args": [", params", ", params, rng, extra", ", *, params, rng"],
    "init": ["raise RuntimeError('boom')", "sys.exit(1)", "raise MemoryError()", "raise RecursionError()",
             "self.phase = None; return", "raise SystemExit('why')"],
    "propose": ["return None", "return 'x'", "return [0.1]", "return math.nan", "return math.inf", "return True",
                "return 1e300", "return 2 ** 62", "return 1j", "raise ValueError('v')", "return self",
                "raise GeneratorExit()", "sys.exit()"],
    "update": ["raise KeyError('k')", "self.phase = math.nan", "self.phase = 'front'", "return None",
               "return 'yes'", "self.phase = -1e300", "raise StopIteration", "del self.phase"],
    "tail": ["Learner = 3", "Learner = None", "del Learner",
             "class Learner2:\n    phase = property(lambda self: 1 / 0)\nLearner = Learner2"],
}
SPECS_BAD = ["", " ", ":", "a:", ":b", "a:b:c", "1mod:Cls", "mod-x:Cls", "os:path", "os:getcwd", "math:pi",
             "builtins:object", "builtins:int", "morphbench:NoSuchThing", "no_such_mb_module:Cls", "thermal ",
             "THERMAL", "a" * 300 + ":B", "a\0b:C", "sys:exit", "os.path:join"]
_plugin_counter = itertools.count()


def plugin_case(choose: Chooser) -> Case:
    """A malformed ``--learner`` spec, or a generated plug-in module with one fault."""
    argv = ["run", CHAIN2, "--steps", "1", "--quiet", "--sensor", "ideal", "--out", "{out}", "--learner"]
    if choose.integer(0, 2) == 0:
        spec = choose.choice(SPECS_BAD)
        return Case("plugin", "spec", f"--learner {spec!r}"[:120], argv + [spec])
    slot = choose.choice(list(PLUGIN_FAULTS))
    fault = choose.choice(PLUGIN_FAULTS[slot])
    slots = {"module_level": "", "init_args": ", params, rng", "init": "pass", "propose": "pass", "update": "pass",
             "tail": "", slot: fault}
    # a name never used before in this process: an imported module stays in sys.modules
    name = f"mb_fuzz_plugin_{os.getpid()}_{next(_plugin_counter)}"
    return Case("plugin", f"plug-in {slot}", f"{slot}: {fault}", argv + [f"{name}:Learner"],
                plugin=PLUGIN_TEMPLATE.format(**slots))


def make_case(kind: str, choose: Chooser, families: Sequence[str] = FAMILIES, pending: bool = True) -> Case:
    if kind == "options":
        return options_case(choose, pending)
    if kind == "plugin":
        return plugin_case(choose)
    return file_case(kind, choose, families)


def cases(kind: str, families: Sequence[str] = FAMILIES, pending: bool = True):
    """A hypothesis strategy of ``Case`` of ``kind`` (imports hypothesis only when called)."""
    from hypothesis import strategies as st

    return st.composite(lambda draw: make_case(kind, DrawChooser(draw), families, pending))()


def random_cases(kind: str, n: int, seed: int, families: Sequence[str] = FAMILIES):
    """``n`` cases of ``kind`` from ``random.Random(seed)``: the same seed, the same cases."""
    rng = RandomChooser(random.Random(f"{kind}-{seed}"))
    return [make_case(kind, rng, families) for _ in range(n)]


# --- running and judging ----------------------------------------------------------------------------------------------

class CaseTimeout(BaseException):
    """Raised by SIGPROF or SIGALRM in a case that hangs (BaseException: no ``except Exception`` swallows it)."""


@dataclass
class Outcome:
    case: Case
    status: Any
    out: str
    err: str
    exception: BaseException | None
    written: list[str]
    verdict: str = ""

    def line(self) -> str:
        return self.err.strip().splitlines()[0] if self.err.strip() else ""


def _fill(text: str, directory: Path, out: Path) -> str:
    return text.replace("{in}", str(directory / "input.toml")).replace("{out}", str(out)).replace("{dir}",
                                                                                                  str(directory))


def _listing(root: Path) -> set[str]:
    return {str(p.relative_to(root)) for p in root.rglob("*")}


def prepare(case: Case, workdir: Path) -> tuple[list[str], Path, Path]:
    """Write the case's files under ``workdir``; (argv, input directory, output path)."""
    directory, out = workdir / "in", workdir / "out"
    directory.mkdir(parents=True)
    (directory / "empty").mkdir()
    if case.data is not None:
        (directory / "input.toml").write_bytes(case.data)
    for name, data in case.extra.items():
        (directory / name).parent.mkdir(parents=True, exist_ok=True)
        (directory / name).write_bytes(data)
    if case.plugin is not None:
        (workdir / "plugins").mkdir()
        module = case.argv[-1].split(":")[0]
        (workdir / "plugins" / f"{module}.py").write_text(case.plugin)
    return [_fill(a, directory, out) for a in case.argv], directory, out


def run_case(case: Case, workdir: Path, timeout_s: float = TIMEOUT_S, cpu_timeout_s: float = CPU_TIMEOUT_S) -> Outcome:
    """Run ``case`` through ``morphbench.cli.main`` in-process with ``workdir`` (new, empty) as the working directory,
    stdout and stderr captured; judge it (``Outcome.verdict``). A case still running after ``timeout_s`` of wall time
    or ``cpu_timeout_s`` of this process's CPU time is a timeout."""
    from morphbench.cli import main

    workdir.mkdir(parents=True, exist_ok=True)
    argv, directory, out = prepare(case, workdir)
    cwd = workdir / "cwd"
    cwd.mkdir()
    before = _listing(workdir)
    stdout, stderr = io.StringIO(), io.StringIO()
    status, exception = None, None
    old_cwd, old_path, old_bytecode = os.getcwd(), list(sys.path), sys.dont_write_bytecode
    plugins = str(workdir / "plugins")
    old_env = os.environ.get("PYTHONPATH")

    def alarm(signum, frame):
        raise CaseTimeout(f"still running after {timeout_s:g} s")

    def cpu_alarm(signum, frame):
        raise CaseTimeout(f"still running after {cpu_timeout_s:g} s of CPU time")

    old_handler = signal.signal(signal.SIGALRM, alarm)
    old_cpu_handler = signal.signal(signal.SIGPROF, cpu_alarm)
    try:
        os.chdir(cwd)
        sys.path.insert(0, plugins)
        os.environ["PYTHONPATH"] = os.pathsep.join(p for p in (plugins, old_env) if p)  # the suite's workers too
        sys.dont_write_bytecode = True  # no __pycache__ beside a plug-in: the listing compares what morphbench wrote
        signal.setitimer(signal.ITIMER_REAL, timeout_s)
        signal.setitimer(signal.ITIMER_PROF, cpu_timeout_s)
        with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
            try:
                status = main(argv)
            except SystemExit as exc:  # argparse's errors, --version
                status = exc.code
    except BaseException as exc:  # noqa: B036 - a crash of the CLI is what is measured, KeyboardInterrupt aside
        if isinstance(exc, KeyboardInterrupt):
            raise
        exception = exc
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.setitimer(signal.ITIMER_PROF, 0)
        signal.signal(signal.SIGALRM, old_handler)
        signal.signal(signal.SIGPROF, old_cpu_handler)
        os.chdir(old_cwd)
        sys.path[:] = old_path
        sys.dont_write_bytecode = old_bytecode
        if old_env is None:
            os.environ.pop("PYTHONPATH", None)
        else:
            os.environ["PYTHONPATH"] = old_env
        if case.plugin is not None:
            sys.modules.pop(case.argv[-1].split(":")[0], None)
    written = sorted(_listing(workdir) - before)
    outcome = Outcome(case, status, stdout.getvalue(), stderr.getvalue(), exception, written)
    outcome.verdict = judge(outcome, argv, out)
    return outcome


def judge(o: Outcome, argv: list[str], out: Path) -> str:
    """``accepted``, ``refused`` (the promise kept) or what broke it, as a crash kind."""
    if o.exception is not None:
        return f"exception {type(o.exception).__name__}" if not isinstance(o.exception, CaseTimeout) else "timeout"
    lines = [line for line in o.err.splitlines() if line.strip()]
    if "Traceback" in o.err:
        return "traceback on stderr"
    if o.status == 0:
        return accepted_problem(o, argv, out) or "accepted"
    if o.status == 1 and argv[0] == "bench" and (out / "runs.parquet").exists():
        return "accepted"  # a suite that loaded and ran; runs that failed are recorded (exit 1), not bad input
    if o.status != 2:
        return f"exit status {o.status!r}"
    if not lines:
        return "exit 2, stderr empty"
    if len(lines) > 1:
        return "exit 2, several lines on stderr"
    if not is_error_line(lines[0]):
        return "exit 2, line not from morphbench"
    if o.written:
        return "exit 2, output left behind"
    return "refused"


def accepted_problem(o: Outcome, argv: list[str], out: Path) -> str | None:
    """None if an accepted command wrote everything it promises, else what is missing."""
    if argv[0] == "run":
        target = Path(argv[argv.index("--out") + 1]) if "--out" in argv else None
        if target is None or not target.is_dir() or not RUN_FILES <= {p.name for p in target.iterdir()}:
            return "exit 0, run directory incomplete"
    elif argv[0] == "bench" and not (out / "runs.parquet").exists():
        return "exit 0, results incomplete"
    elif argv[0] == "scan" and not {"scan.csv", "scan.png"} <= {p.name for p in out.glob("*")}:
        return "exit 0, scan incomplete"
    return None


ERROR_LINE = re.compile(r"morphbench( [a-z]+)*: error: \S")
"""morphbench's one line: ``morphbench: error: ...`` or argparse's ``morphbench run: error: ...``."""


def is_error_line(line: str) -> bool:
    return ERROR_LINE.match(line) is not None


def is_banner(line: str) -> bool:
    return line.startswith(BANNER)
