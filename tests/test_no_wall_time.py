"""No test asserts on elapsed time (issue 34): a machine shared by several people makes anything slow, so a time limit
in a test only catches a hang, and then it is generous: MIN_S or more. A test says what happened (which files were
written, how many renders ran, in which process), not how long it took.

``findings(sources)`` reads Python sources (ast) and names, as ``file:line: what``:

- a comparison of a time reading with a number under MIN_S (``assert time.perf_counter() - started < 10``). A time
  reading is a call of a clock (``time.time``, ``perf_counter``, ``monotonic``, ``process_time``, ``thread_time``
  and their ``_ns``, ``datetime.now``, ``utcnow``, ``today``, ``os.path.getmtime``, ``timeit.default_timer``), a
  stat's ``st_mtime``/``st_ctime``/``st_atime``, or a name assigned one: through arithmetic, ``round``/``abs``/
  ``min``/``max``/``float``/``int``/``sum``, ``.total_seconds()``, and the tuples that functions of the same files
  return, fixtures included (``out, text, seconds = page``; ``assert seconds < 30``). A number is a literal, a name
  assigned one (here or in another test module: ``fuzzing.TIMEOUT_S``), arithmetic of those, ``pytest.approx`` or
  ``timedelta`` of one. Two readings compared (a polling loop's ``time.monotonic() < deadline``, an mtime unchanged)
  are not flagged, but a deadline under MIN_S away is (``deadline = time.monotonic() + 5``);
- a time limit under MIN_S (and above 0: a timeout of 0 polls once): a keyword whose name says timeout or patience
  (``subprocess.run(..., timeout=10)``, ``run_case(..., timeout_s=8)``), a parameter default or a constant so named,
  ``wait``/``join``/``result``/``exception``'s first argument, ``asyncio.wait_for``'s second, ``signal.alarm`` and
  ``signal.setitimer``;
- a hypothesis deadline: ``settings(deadline=...)`` other than None, and ``@given`` without a ``settings(deadline=
  None)`` among its decorators (directly or through a name, here or imported), unless some file registers and loads a
  profile with ``deadline=None``: hypothesis's default is 200 ms of wall time per example.

CPU time (``process_time``, ``ITIMER_PROF``) is not advanced by the machine's other processes, but a tight bound on it
still asserts a speed, which slower hardware fails: it is allowed only as a hang guard, held to the same MIN_S as the
wall clock (tests/fuzzing.py's CPU_TIMEOUT_S is one). Names are tracked without flow (any assignment of a name in a
function counts for the whole function) and calls of functions by their name: precise enough for tests/, whose
files it must pass (``test_no_test_compares_elapsed_time_with_a_number``).
"""

from __future__ import annotations

import ast
import operator
import re
from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parent
MIN_S = 60.0
"""The shortest time limit a test may set (s): one that only a hang reaches."""

TIME_CLOCKS = {f"{name}{ns}" for name in ("time", "perf_counter", "monotonic", "process_time", "thread_time")
               for ns in ("", "_ns")}
NOW, NOW_OWNERS = {"now", "utcnow", "today"}, {"datetime", "date", "Timestamp"}
FILE_TIMES = {"getmtime", "getctime", "getatime"}
STAT_TIMES = {f"st_{kind}time{ns}" for kind in ("m", "c", "a") for ns in ("", "_ns")}
PASS_THROUGH = {"round", "abs", "float", "int", "max", "min", "sum"}
"""calls whose value is a time reading when an argument is."""
WAITS = {"wait": 0, "join": 0, "result": 0, "exception": 0, "wait_for": 1, "alarm": 0, "setitimer": 1}
"""calls that take a time limit as a positional argument: its index."""
LIMIT_NAME = re.compile(r"timeout|patience", re.I)
BINARY = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
          ast.FloorDiv: operator.floordiv, ast.Pow: operator.pow, ast.Mod: operator.mod}
TIMEDELTA = {"weeks": 604800.0, "days": 86400.0, "hours": 3600.0, "minutes": 60.0, "seconds": 1.0,
             "milliseconds": 1e-3, "microseconds": 1e-6}


def _name(node) -> str | None:
    """The last name of ``a.b.c`` or ``c``."""
    return node.id if isinstance(node, ast.Name) else node.attr if isinstance(node, ast.Attribute) else None


def _is_fixture(function) -> bool:
    return any(_name(d.func if isinstance(d, ast.Call) else d) == "fixture" for d in function.decorator_list)


def _own(nodes):
    """The nodes of a scope's statements; of the functions defined in it, the function node, its decorators and
    defaults, not its body (a scope of its own)."""
    stack = list(nodes)
    while stack:
        node = stack.pop()
        yield node
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            stack += [*node.decorator_list, *node.args.defaults, *(d for d in node.args.kw_defaults if d)]
        else:
            stack += ast.iter_child_nodes(node)


class Module:
    """One source file: its imports and its module-level numbers and hypothesis settings."""

    def __init__(self, name: str, tree: ast.Module):
        self.name, self.tree = name, tree
        self.time_aliases, self.clock_names = {"time"}, set()
        self.imports: dict[str, str] = {}  # local name -> module
        self.from_imports: dict[str, tuple[str, str]] = {}  # local name -> (module, name)
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for alias in node.names:
                    self.imports[alias.asname or alias.name.split(".")[0]] = alias.name
                    if alias.name == "time":
                        self.time_aliases.add(alias.asname or "time")
            elif isinstance(node, ast.ImportFrom) and node.module:
                for alias in node.names:
                    self.from_imports[alias.asname or alias.name] = (node.module, alias.name)
                    if node.module == "time" and alias.name in TIME_CLOCKS:
                        self.clock_names.add(alias.asname or alias.name)
        self.numbers: dict[str, float] = {}
        self.settings: dict[str, ast.Call] = {}  # NAME = settings(...)
        for node in tree.body:
            target, value = (node.targets[0], node.value) if isinstance(node, ast.Assign) and len(node.targets) == 1 \
                else (node.target, node.value) if isinstance(node, ast.AnnAssign) else (None, None)
            if isinstance(target, ast.Name) and isinstance(value, ast.Call) and _name(value.func) == "settings":
                self.settings[target.id] = value


class Checker:
    """``findings`` over a set of modules (they may import one another's numbers, fixtures and settings)."""

    def __init__(self, sources: dict[str, str]):
        self.modules = {Path(file).stem: (file, Module(Path(file).stem, ast.parse(text, file)))
                        for file, text in sources.items()}
        self.returns: dict[tuple[str, str], object] = {}  # (module, function) -> True (a reading) or tuple positions
        self.fixtures: dict[str, object] = {}  # fixture name -> the same
        for _ in range(2):  # module numbers may name numbers of other modules
            for _, module in self.modules.values():
                scope = Scope(self, module, module.tree.body, None)
                module.numbers.update(scope.numbers)
        for _ in range(10):  # what functions return, through the functions they call, until nothing changes
            before = (dict(self.returns), dict(self.fixtures))
            self.scopes = []
            for _, module in self.modules.values():
                self._analyse(module, module.tree.body, None, None)
            if (self.returns, self.fixtures) == before:
                break

    def _analyse(self, module: Module, body, function, parent) -> None:
        scope = Scope(self, module, body, parent, function)
        self.scopes.append(scope)
        if function is not None:
            value = scope.returned()
            if value:
                self.returns[(module.name, function.name)] = value
                if _is_fixture(function):
                    self.fixtures[function.name] = value
        for node in scope.nodes:
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                self._analyse(module, node.body, node, scope)

    def number(self, module: Module, name: str, attribute: str | None = None) -> float | None:
        """A module-level number: ``name`` in ``module`` (imported or its own), or ``name.attribute``."""
        if attribute is not None:
            other = self.modules.get(module.imports.get(name, ""))
            return other[1].numbers.get(attribute) if other else None
        if name in module.numbers:
            return module.numbers[name]
        source, original = module.from_imports.get(name, ("", ""))
        return self.modules[source][1].numbers.get(original) if source in self.modules else None

    def settings(self, module: Module, node) -> ast.Call | None:
        """The ``settings(...)`` call a decorator is or names."""
        if isinstance(node, ast.Call) and _name(node.func) == "settings":
            return node
        if isinstance(node, ast.Name):
            if node.id in module.settings:
                return module.settings[node.id]
            source, original = module.from_imports.get(node.id, ("", ""))
            return self.modules[source][1].settings.get(original) if source in self.modules else None
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name):
            other = self.modules.get(module.imports.get(node.value.id, ""))
            return other[1].settings.get(node.attr) if other else None
        return None

    def without_deadline(self, module: Module, call: ast.Call | None) -> bool:
        """Whether hypothesis ``settings(...)`` set deadline=None (or inherit it from settings they name)."""
        if call is None:
            return False
        for keyword in call.keywords:
            if keyword.arg == "deadline":
                return isinstance(keyword.value, ast.Constant) and keyword.value.value is None
        return bool(call.args) and self.without_deadline(module, self.settings(module, call.args[0]))

    def findings(self) -> list[str]:
        profile = any(isinstance(n, ast.Call) and _name(n.func) == "register_profile"
                      and self.without_deadline(m, n) for _, m in self.modules.values() for n in ast.walk(m.tree))
        found = set()
        for scope in self.scopes:
            file = self.modules[scope.module.name][0]
            for line, what in scope.findings(given_needs_settings=not profile):
                found.add((file, line, what))
        return [f"{file}:{line}: {what}" for file, line, what in sorted(found)]


class Scope:
    """The statements of a module or function: the names there that hold a time reading, a tuple with some, a number
    or a deadline (those of the enclosing scopes too)."""

    def __init__(self, checker: Checker, module: Module, body, parent: Scope | None, function=None):
        self.checker, self.module, self.function = checker, module, function
        self.nodes = list(_own(body))
        self.readings: set[str] = set(parent.readings) if parent else set()
        self.tuples: dict[str, frozenset] = dict(parent.tuples) if parent else {}
        self.numbers: dict[str, float] = dict(parent.numbers) if parent else {}
        self.deadlines: dict[str, float] = dict(parent.deadlines) if parent else {}
        arguments = function.args if function is not None else None
        names = [a.arg for a in (*arguments.posonlyargs, *arguments.args, *arguments.kwonlyargs)] if arguments else []
        for name in names:  # a parameter hides what the name was outside; a fixture's value is what it returns
            self.readings.discard(name)
            self.tuples.pop(name, None)
            self.numbers.pop(name, None)
            value = checker.fixtures.get(name)
            if value is True:
                self.readings.add(name)
            elif value:
                self.tuples[name] = value
        assigned = [(t, n.value) for n in self.nodes if isinstance(n, ast.Assign) for t in n.targets]
        assigned += [(n.target, n.value) for n in self.nodes if isinstance(n, (ast.AnnAssign, ast.NamedExpr))
                     and n.value is not None]
        values: dict[str, list] = {}
        for target, value in assigned:
            if isinstance(target, ast.Name):
                values.setdefault(target.id, []).append(self.number(value))
        for name, numbers in values.items():
            if None not in numbers and len(set(numbers)) == 1:
                self.numbers[name] = numbers[0]
        state = None
        while state != (len(self.readings), len(self.tuples), len(self.deadlines)):
            state = (len(self.readings), len(self.tuples), len(self.deadlines))
            for target, value in assigned:
                self._bind(target, value)
            for node in self.nodes:
                if isinstance(node, ast.AugAssign) and isinstance(node.target, ast.Name) and self.reading(node.value):
                    self.readings.add(node.target.id)

    def _bind(self, target, value) -> None:
        if isinstance(target, ast.Name):
            if self.reading(value):
                self.readings.add(target.id)
                if self.deadline(value) is not None:
                    self.deadlines[target.id] = self.deadline(value)
            elif self.positions(value):
                self.tuples[target.id] = self.positions(value)
        elif isinstance(target, (ast.Tuple, ast.List)):
            if isinstance(value, (ast.Tuple, ast.List)) and len(value.elts) == len(target.elts):
                for t, v in zip(target.elts, value.elts):
                    self._bind(t, v)
                return
            for k in self.positions(value) or ():
                if k < len(target.elts) and isinstance(target.elts[k], ast.Name):
                    self.readings.add(target.elts[k].id)

    def _returned_by(self, call: ast.Call):
        """What a function of the checked files returns, for a call of it."""
        returns, f = self.checker.returns, call.func
        if isinstance(f, ast.Name):
            source, original = self.module.from_imports.get(f.id, (self.module.name, f.id))
            return returns.get((source, original))
        if isinstance(f, ast.Attribute) and isinstance(f.value, ast.Name) and f.value.id in self.module.imports:
            return returns.get((self.module.imports[f.value.id], f.attr))
        return None

    def clock(self, call: ast.Call) -> bool:
        f = call.func
        if isinstance(f, ast.Name):
            return f.id in self.module.clock_names
        if isinstance(f, ast.Attribute):
            return ((f.attr in TIME_CLOCKS and isinstance(f.value, ast.Name) and f.value.id in self.module.time_aliases)
                    or (f.attr in NOW and _name(f.value) in NOW_OWNERS) or f.attr in FILE_TIMES
                    or f.attr == "default_timer")
        return False

    def reading(self, node) -> bool:
        """Whether ``node``'s value is a time reading (or arithmetic of one)."""
        if isinstance(node, ast.Call):
            if self.clock(node) or self._returned_by(node) is True:
                return True
            if isinstance(node.func, ast.Attribute) and node.func.attr == "total_seconds":
                return self.reading(node.func.value)
            return _name(node.func) in PASS_THROUGH and any(self.reading(a) for a in node.args)
        if isinstance(node, ast.Attribute):
            return node.attr in STAT_TIMES
        if isinstance(node, ast.Name):
            return node.id in self.readings
        if isinstance(node, ast.BinOp):
            return self.reading(node.left) or self.reading(node.right)
        if isinstance(node, ast.UnaryOp):
            return self.reading(node.operand)
        if isinstance(node, ast.IfExp):
            return self.reading(node.body) or self.reading(node.orelse)
        if isinstance(node, ast.NamedExpr):
            return self.reading(node.value)
        if isinstance(node, ast.Subscript) and isinstance(node.value, ast.Name):
            index = node.slice
            return node.value.id in self.readings or (isinstance(index, ast.Constant) and index.value in
                                                      self.tuples.get(node.value.id, ()))
        return False

    def positions(self, node) -> frozenset:
        """The positions of a tuple value that hold time readings."""
        if isinstance(node, (ast.Tuple, ast.List)):
            return frozenset(k for k, e in enumerate(node.elts) if self.reading(e))
        if isinstance(node, ast.Name):
            return self.tuples.get(node.id, frozenset())
        if isinstance(node, ast.Call):
            value = self._returned_by(node)
            return value if isinstance(value, frozenset) else frozenset()
        return frozenset()

    def number(self, node) -> float | None:
        """``node``'s value if it is a number this scope knows (s, for a timedelta)."""
        if isinstance(node, ast.Constant):
            ok = isinstance(node.value, (int, float)) and not isinstance(node.value, bool)
            return float(node.value) if ok else None
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            value = self.number(node.operand)
            return None if value is None else -value if isinstance(node.op, ast.USub) else value
        if isinstance(node, ast.BinOp) and type(node.op) in BINARY:
            left, right = self.number(node.left), self.number(node.right)
            try:
                return None if left is None or right is None else float(BINARY[type(node.op)](left, right))
            except (ArithmeticError, ValueError):
                return None
        if isinstance(node, ast.Name):
            return self.numbers[node.id] if node.id in self.numbers else self.checker.number(self.module, node.id)
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name):
            return self.checker.number(self.module, node.value.id, node.attr)
        if isinstance(node, ast.Call):
            name = _name(node.func)
            if name in ("approx", "float", "int") and node.args:
                return self.number(node.args[0])
            if name == "timedelta":
                parts = [(self.number(a), unit) for a, unit in zip(node.args, ("days", "seconds", "microseconds"))]
                parts += [(self.number(k.value), k.arg) for k in node.keywords]
                if parts and all(value is not None and unit in TIMEDELTA for value, unit in parts):
                    return sum(value * TIMEDELTA[unit] for value, unit in parts)
        return None

    def short(self, node) -> float | None:
        """``node``'s value if it is a number under MIN_S."""
        value = self.number(node)
        return value if value is not None and value < MIN_S else None

    def limit(self, node) -> float | None:
        """``node``'s value if it is a time limit that is too short (above 0: a timeout of 0 polls once)."""
        value = self.short(node)
        return value if value is not None and value > 0 else None

    def deadline(self, node) -> float | None:
        """How far away a deadline under MIN_S is: a reading plus or minus a short time, or a name assigned one."""
        if isinstance(node, ast.Name):
            return self.deadlines.get(node.id)
        if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Add, ast.Sub)):
            for reading, other in ((node.left, node.right), (node.right, node.left)):
                if self.reading(reading) and self.limit(other) is not None:
                    return self.limit(other)
        return None

    def returned(self):
        """What this function returns (or yields): True for a time reading, or the positions of a tuple's."""
        values = [n.value for n in self.nodes if isinstance(n, (ast.Return, ast.Yield)) and n.value is not None]
        if any(self.reading(v) for v in values):
            return True
        return frozenset().union(*(self.positions(v) for v in values))

    def findings(self, given_needs_settings: bool = True):
        """(line, what) of every time assertion and short time limit of this scope."""
        for node in self.nodes:
            if isinstance(node, ast.Compare):
                operands = [node.left, *node.comparators]
                for a in operands:
                    others = [b for b in operands if b is not a]
                    if not self.reading(a):
                        continue
                    number = next((self.short(b) for b in others if self.short(b) is not None), None)
                    deadline = next((self.deadline(b) for b in others if self.deadline(b) is not None), None)
                    if number is not None:
                        yield node.lineno, f"compares a time reading with {number:g}"
                        break
                    if deadline is not None:
                        yield node.lineno, f"waits for a deadline {deadline:g} s away"
                        break
            elif isinstance(node, ast.Call):
                yield from self._call(node)
            elif isinstance(node, (ast.Assign, ast.AnnAssign)):
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                for target in targets:
                    if isinstance(target, ast.Name) and LIMIT_NAME.search(target.id) and node.value is not None \
                            and self.limit(node.value) is not None:
                        yield node.lineno, f"{target.id} = {self.limit(node.value):g} s"
            elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                yield from self._function(node, given_needs_settings)

    def _call(self, node: ast.Call):
        for keyword in node.keywords:
            if keyword.arg is None:
                continue
            if keyword.arg == "deadline" and _name(node.func) == "settings":
                if not (isinstance(keyword.value, ast.Constant) and keyword.value.value is None):
                    yield node.lineno, "a hypothesis deadline (wall time per example): deadline=None"
            elif LIMIT_NAME.search(keyword.arg) and self.limit(keyword.value) is not None:
                yield node.lineno, f"{keyword.arg}={self.limit(keyword.value):g}"
        index = WAITS.get(_name(node.func))
        if index is not None and isinstance(node.func, ast.Attribute) and len(node.args) > index \
                and self.limit(node.args[index]) is not None:
            yield node.lineno, f"{node.func.attr}(...) with a time limit of {self.limit(node.args[index]):g} s"

    def _function(self, node, given_needs_settings: bool):
        arguments = node.args
        positional = [*arguments.posonlyargs, *arguments.args]
        defaults = list(zip(positional[len(positional) - len(arguments.defaults):], arguments.defaults))
        defaults += [(a, d) for a, d in zip(arguments.kwonlyargs, arguments.kw_defaults) if d is not None]
        for argument, default in defaults:
            if LIMIT_NAME.search(argument.arg) and self.limit(default) is not None:
                yield node.lineno, f"parameter {argument.arg} defaults to {self.limit(default):g} s"
        given = any(isinstance(d, ast.Call) and _name(d.func) == "given" for d in node.decorator_list)
        checker = self.checker
        if given and given_needs_settings and not any(checker.without_deadline(self.module, checker.settings(
                self.module, d)) for d in node.decorator_list):
            yield node.lineno, "@given without settings(deadline=None): hypothesis's default deadline is 200 ms"


def findings(sources: dict[str, str]) -> list[str]:
    """``file:line: what`` for every comparison of a time reading with a number, and every time limit, under MIN_S
    in ``sources`` (file name -> Python source; a file's stem is its module name)."""
    checker = Checker(sources)
    return checker.findings()


def test_no_test_compares_elapsed_time_with_a_number():
    files = sorted(TESTS.glob("*.py"))
    assert len(files) > 50 and TESTS / "test_report_html.py" in files and TESTS / "fuzzing.py" in files
    found = findings({str(path.relative_to(TESTS.parent)): path.read_text(encoding="utf-8") for path in files})
    assert not found, ("time limits a busy machine may reach: assert what happened instead, or give a hang "
                       f"{MIN_S:g} s or more (tests/test_no_wall_time.py):\n" + "\n".join(found))


# --- the check itself: what it must flag, what it must not ---------------------------------------------------------

FLAGGED = {
    "elapsed in the assertion": """
import time
def test_reuse(page):
    started = time.perf_counter()
    build_report(page)
    assert time.perf_counter() - started < 10
""",
    "elapsed from a fixture's tuple": """
import time
import pytest

@pytest.fixture(scope="module")
def page(tmp_path_factory):
    started = time.perf_counter()
    build_report(tmp_path_factory)
    return 1, "text", time.perf_counter() - started

def test_page(page):
    out, text, seconds = page
    assert seconds < 30  # the whole report
""",
    "elapsed through a helper, a name and round": """
from time import perf_counter as clock
LIMIT = 2 * 3
def took(started):
    return clock() - started
def test_quick():
    t0 = clock()
    spent = round(took(t0), 1)
    assert 0 <= spent <= LIMIT
""",
    "a datetime difference": """
from datetime import datetime, timedelta
def test_now():
    start = datetime.now()
    run()
    assert datetime.now() - start < timedelta(seconds=5)
    assert (datetime.now() - start).total_seconds() < 5
""",
    "an mtime's age": """
import time
def test_fresh(path):
    assert time.time() - path.stat().st_mtime < 5
""",
    "CPU time": """
import time
def test_cpu():
    cpu = time.process_time()
    work()
    elapsed = time.process_time() - cpu
    assert elapsed < 1.5
""",
    "a short polling deadline": """
import time
def test_poll(started):
    deadline = time.monotonic() + 5
    while not started.exists() and time.monotonic() < deadline:
        time.sleep(0.05)
""",
    "a short timeout keyword": """
import subprocess
def test_cli():
    subprocess.run(["morphbench"], timeout=10)
""",
    "the fuzz case's 8 s": """
import fuzzing
def check(case, directory):
    return fuzzing.run_case(case, directory, timeout_s=8)  # accepted cases take < 3 s
""",
    "a short timeout constant, default and timer": """
import signal
TIMEOUT_S = 8.0
def run_case(case, workdir, timeout_s: float = TIMEOUT_S):
    signal.setitimer(signal.ITIMER_REAL, 8)
""",
    "short waits": """
def test_wait(process, thread, future):
    process.wait(5)
    thread.join(timeout=2.5)
    future.result(30)
""",
    "a hypothesis deadline": """
from hypothesis import given, settings, strategies as st
@settings(deadline=500)
@given(st.integers())
def test_a(x):
    pass
@given(st.integers())
def test_b(x):
    pass
""",
}
"""Each flagged at least once."""

NOT_FLAGGED = """
import os, random, subprocess, time
import pytest
from hypothesis import given, settings, strategies as st

PATIENCE_S = 120.0
FAST = settings(max_examples=5, deadline=None)

def test_renders(page):
    n_renders = len(page)
    assert n_renders == 1
    before = page.stat().st_mtime_ns
    assert page.stat().st_mtime_ns == before  # not written again
    os.utime(page, ns=(before - 1, before - 1))

def test_poll(process, started):
    deadline = time.monotonic() + PATIENCE_S
    while not started.exists() and time.monotonic() < deadline:
        time.sleep(0.05)
    process.wait(PATIENCE_S)
    process.wait(0)
    subprocess.run(["x"], timeout=120)
    assert ", ".join(["a", "b"]) == "a, b"

def test_killed(rng=random.Random(1)):
    started = time.perf_counter()
    full = time.perf_counter() - started
    time.sleep(rng.uniform(0.5 * full, 1.1 * full))
    print(f"done in {time.perf_counter() - started:.0f} s")

def test_video(duration, simulated):
    assert 8 <= simulated <= 20 and duration == pytest.approx(simulated, abs=0.2)

@FAST
@given(st.integers())
def test_fast(x):
    pass

@settings(FAST, max_examples=10)
@given(st.integers())
def test_fast_too(x):
    pass
"""


@pytest.mark.parametrize("name", FLAGGED)
def test_the_check_flags_time_assertions_and_short_limits(name):
    found = findings({f"tests/example_{name.replace(' ', '_')}.py": FLAGGED[name]})
    assert found, name
    assert all(re.match(r"tests/example_\S+\.py:\d+: ", line) for line in found)  # file and line


def test_the_check_counts_every_case_of_an_example():
    assert len(findings({"tests/ex.py": FLAGGED["a datetime difference"]})) == 2
    assert len(findings({"tests/ex.py": FLAGGED["short waits"]})) == 3
    assert len(findings({"tests/ex.py": FLAGGED["a hypothesis deadline"]})) == 3  # its settings, both tests
    assert len(findings({"tests/ex.py": FLAGGED["a short timeout constant, default and timer"]})) == 3
    assert findings({"tests/ex.py": FLAGGED["elapsed from a fixture's tuple"]}) == [
        "tests/ex.py:13: compares a time reading with 30"]


def test_the_check_leaves_counts_polls_and_generous_limits_alone():
    assert findings({"tests/example_fine.py": NOT_FLAGGED}) == []


def test_numbers_and_settings_of_other_test_modules_count():
    constants = "TIMEOUT_S = 300.0\nQUICK_S = 5\nfrom hypothesis import settings\nFAST = settings(deadline=None)\n"
    user = ("import fuzzing\nfrom fuzzing import QUICK_S, FAST\nfrom hypothesis import given\n"
            "def check(case):\n    fuzzing.run_case(case, timeout_s=fuzzing.TIMEOUT_S)\n"
            "    fuzzing.run_case(case, timeout_s=QUICK_S)\n"
            "@FAST\n@given(1)\ndef test_x(x):\n    pass\n")
    assert findings({"tests/fuzzing.py": constants, "tests/user.py": user}) == ["tests/user.py:6: timeout_s=5"]
