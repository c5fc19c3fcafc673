"""Long work that shows it is under way from its first second: ``announced`` (work that counts no steps: reading,
generating and checking a large shape, building its world, drawing it) and ``redrawn`` (a progress bar whose clock
goes on between its updates). Both on stderr, threads of their own; nothing else of the package."""

from __future__ import annotations

import sys
import threading
import time
from contextlib import contextmanager

ANNOUNCE_AFTER_S = 1.0
"""s: work still going after this long is announced on stderr with its running time (shorter work says nothing)."""


@contextmanager
def announced(text: str, quiet: bool = False):
    """Run the block; once it has run ANNOUNCE_AFTER_S, ``text`` on stderr with the seconds it has taken, redrawn
    every second until it ends: work that counts no steps (reading, generating and checking a large shape, building
    its world, drawing it) shows from its first second that it is under way. Its line stays when the work ends, and is
    erased when the work fails: the one-line error that follows is then the only line the terminal shows. Nothing
    with ``quiet``."""
    if quiet:
        yield
        return
    started, done, failed = time.monotonic(), threading.Event(), []

    def show(end: str = "") -> str:
        line = f"{text}... {time.monotonic() - started:.0f} s"
        sys.stderr.write(f"\r{line}{end}")
        sys.stderr.flush()
        return line

    def clock() -> None:
        if done.wait(ANNOUNCE_AFTER_S):
            return
        line = show()
        while not done.wait(1.0):
            line = show()
        sys.stderr.write(f"\r{' ' * len(line)}\r" if failed else "\n")
        sys.stderr.flush()

    thread = threading.Thread(target=clock, daemon=True, name="morphbench-announce")
    thread.start()
    try:
        yield
    except BaseException:
        failed.append(True)
        raise
    finally:
        done.set()
        thread.join()


@contextmanager
def redrawn(bar):
    """``bar`` (tqdm) redrawn every second while the block runs, so that its elapsed time goes on between its
    updates (a large world takes seconds to build; a step of it, minutes). Only while the work lets this thread run:
    the compiled physics solvers hold the interpreter's lock, so the clock stands still inside one advance."""
    done = threading.Event()

    def clock() -> None:
        while not done.wait(1.0):
            bar.refresh()

    thread = threading.Thread(target=clock, daemon=True, name="morphbench-redraw")
    if not bar.disable:
        thread.start()
    try:
        yield bar
    finally:
        done.set()
        if thread.is_alive():
            thread.join()
