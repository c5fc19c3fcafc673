"""Suites whose workers crash, and results directories with another writer, generated as tests/fuzzing.py cases.

    import fuzz_suites, fuzzing
    for case in fuzz_suites.random_cases(20, seed=0):
        outcome = fuzzing.run_case(case, workdir)   # outcome.verdict: 'accepted', 'refused' or a crash kind

Every case is ``morphbench bench`` on a small suite (chain-2, 2 learning steps, 1 to 3 seeds of a plug-in learner and
of the thermal one), in one of three families (``FAMILIES``):

- ``crash``: the plug-in's run with one seed (or every seed) ends its worker process (``os._exit``, a signal, a real
  segfault) or raises an exception of any kind (KeyboardInterrupt, SystemExit, MemoryError, a bare BaseException),
  in ``__init__``, ``propose`` or ``update``; 1 or 2 workers, seeds batched or not (``--physics``). Promise: the
  suite goes on and records the failures, exit 1 (fuzzing.judge's *accepted*), in bounded time (a crash rerun for
  ever is a timeout).
- ``held``: another process holds the results directory (``files.directory_lock``) while the bench starts. Promise:
  exit 2, one line naming that process, nothing written (*refused*); a bench that goes on regardless meets a
  learner that never returns (a *timeout*).
- ``stale``: the directory holds what killed writers left: a lock file naming an ended process, temporaries of ended
  processes and of a running one. Promise: the bench runs (*accepted*).

A plug-in module is written as the extra file ``../plugins/NAME.py`` (run_case writes ``Case.plugin`` only for a
``--learner`` spec at the end of the command line, which ``bench`` has not; run_case puts that directory on the
path of the bench and its workers). In the ``held`` family, importing the module (in the bench's own process, while
it loads the suite) starts the other writer: a case has no other way to have a process running beside its command.
That writer lets go when the case's directory is removed, its parent ends, or after fuzzing.TIMEOUT_S.
"""

from __future__ import annotations

import itertools
import json
import os
import random
from typing import Sequence

import fuzzing
from fuzzing import CHAIN2, Case, Chooser, RandomChooser

KIND = "suites"
FAMILIES = ("crash", "held", "stale")
ARGV = ["bench", "{in}", "--out", "{out}", "--quiet", "--no-report"]
DEAD_PID = 4194305
"""Above the largest process id Linux gives (pid_max is at most 2**22): no process has it."""

ENDINGS = {  # how a run ends its worker process
    "os._exit(3)": "os._exit(3)",
    "os._exit(0)": "os._exit(0)",
    "SIGSEGV": "os.kill(os.getpid(), signal.SIGSEGV)",
    "SIGKILL": "os.kill(os.getpid(), signal.SIGKILL)",
    "SIGABRT": "os.abort()",
    "segfault": "ctypes.string_at(0)",  # a read of address 0 in C
}
RAISES = {  # what a run raises: each fails that run only
    "KeyboardInterrupt": "raise KeyboardInterrupt",
    "SystemExit": "raise SystemExit(5)",
    "sys.exit()": "sys.exit()",
    "GeneratorExit": "raise GeneratorExit",
    "MemoryError": "raise MemoryError",
    "BaseException": "raise BaseException('bare')",
    "BaseException subclass": "raise Odd('odd')",
}

CRASHING = '''
import ctypes, os, resource, signal, sys


class Odd(BaseException):
    pass


class Learner:
    """A greedy learner whose runs with a seed in SEEDS (None: every seed) do FAULT in {where}."""

    SEEDS = {seeds!r}

    def __init__(self, params, rng):
        self.seed = rng.bit_generator.seed_seq.entropy[0]  # the run's seed (learning/plugins.py unit_rng)
        self.rng, self.phase = rng, float(rng.uniform())
        self.maybe("init")

    def maybe(self, where):
        if where == {where!r} and (self.SEEDS is None or self.seed in self.SEEDS):
            resource.setrlimit(resource.RLIMIT_CORE, (0, 0))  # no core file
            {fault}

    def propose(self):
        self.maybe("propose")
        return (self.phase + 0.05) % 1.0

    def update(self, velocity):
        self.maybe("update")
        return False
'''

HELD = '''
import multiprocessing, os, subprocess, sys, threading, time

HOLDER = {holder!r}


class OtherWriterFailed(BaseException):
    """Not an Exception: the bench must not take it for a bad plug-in (a refusal), but the case crash."""


if multiprocessing.parent_process() is None:  # in the bench's own process, not in a worker of it
    OUT = os.path.join(os.path.dirname(os.getcwd()), "out")  # run_case runs the command in DIR/cwd, --out DIR/out
    _holder = subprocess.Popen([sys.executable, "-c", HOLDER, OUT, "{patience}"], stdout=subprocess.PIPE,
                               stdin=subprocess.DEVNULL)
    if _holder.stdout.readline().strip() != b"held":
        raise OtherWriterFailed("the other writer did not take the lock")
    threading.Thread(target=_holder.wait, daemon=True).start()  # reaped when it lets go (this module stays imported)


class Learner:
    def __init__(self, params, rng):
        # only a bench that was not refused runs a learner: it waits here until the case is a timeout, a crash
        time.sleep(3600)
        self.phase = 0.5

    def propose(self):
        return 0.5

    def update(self, velocity):
        return False
'''

HOLDER = '''
import os, sys, time
from morphbench.files import directory_lock

out, patience, parent = sys.argv[1], float(sys.argv[2]), os.getppid()
case = os.path.join(os.path.dirname(out), "cwd")
with directory_lock(out):
    print("held", flush=True)
    deadline = time.monotonic() + patience
    while os.path.isdir(case) and os.getppid() == parent and time.monotonic() < deadline:
        time.sleep(0.05)
'''

_counter = itertools.count()


def _module_name() -> str:
    # a name never used before in this process: an imported module stays in sys.modules
    return f"mb_fuzz_suites_{os.getpid()}_{next(_counter)}"


def _suite(learners: list[str], seeds: int) -> bytes:
    return fuzzing.dump_toml({
        "name": "fuzz-suites",
        "experiment": [{"name": "faults", "shape": CHAIN2, "learner": {"name": learners}, "seeds": seeds, "steps": 2}],
    }).encode()


def crash_case(choose: Chooser) -> Case:
    how = choose.choice(list(ENDINGS) + list(RAISES))
    where = choose.choice(("init", "propose", "update"))
    seeds = choose.integer(1, 3)
    culprits = choose.choice((None, (0,), (seeds - 1,)))
    workers = choose.choice(("1", "2"))
    physics = choose.choice(("quasistatic", "fast")) if choose.integer(0, 3) == 0 else "quasistatic"
    name = _module_name()
    source = CRASHING.format(seeds=culprits, where=where, fault={**ENDINGS, **RAISES}[how])
    argv = ARGV + ["--workers", workers, "--physics", physics]
    who = "every seed" if culprits is None else f"seed {culprits[0]} of {seeds}"
    return Case(KIND, "crash", f"{how} in {where}, {who}, {workers} worker(s), {physics}", argv,
                _suite(["thermal", f"{name}:Learner"], seeds), extra={f"../plugins/{name}.py": source.encode()})


def held_case(choose: Chooser) -> Case:
    name = _module_name()
    source = HELD.format(holder=HOLDER, patience=fuzzing.TIMEOUT_S)
    # the lock file is there before the command (an input, not its output), as a bench that ran before left it
    extra = {f"../plugins/{name}.py": source.encode(), "../out/.lock": b""}
    resume = choose.choice(([], ["--resume"], ["--retry-failed"]))
    return Case(KIND, "held", "another process holds the directory" + (f" ({resume[0]})" if resume else ""),
                ARGV + ["--workers", "1"] + resume, _suite([f"{name}:Learner"], 1), extra=extra)


def stale_case(choose: Chooser) -> Case:
    lock = choose.choice((b"", b"{", json.dumps({"pid": DEAD_PID, "host": "elsewhere", "command": "bench"}).encode(),
                          b"\xff\xfe not text"))
    extra = {"../out/.lock": lock}
    left = choose.choice(([], [f".plan.json.tmp-{DEAD_PID}"], [f".runs.parquet.tmp-{DEAD_PID}.parquet"],
                          [f".plan.json.tmp-{DEAD_PID}", ".runs.parquet.tmp-1.parquet"]))
    for temporary in left:
        extra[f"../out/{temporary}"] = b"half"
    described = f"lock file {lock[:20]!r}, temporaries {left or 'none'}"
    return Case(KIND, "stale", described, ARGV + ["--workers", "1"], _suite(["thermal"], choose.integer(1, 2)),
                extra=extra)


def make_case(choose: Chooser, families: Sequence[str] = FAMILIES) -> Case:
    family = choose.choice(list(families))
    return {"crash": crash_case, "held": held_case, "stale": stale_case}[family](choose)


def random_cases(n: int, seed: int, families: Sequence[str] = FAMILIES) -> list[Case]:
    """``n`` cases from ``random.Random(seed)``: the same seed, the same cases (plug-in module names aside, which
    are new in each process)."""
    rng = RandomChooser(random.Random(f"{KIND}-{seed}"))
    return [make_case(rng, families) for _ in range(n)]
