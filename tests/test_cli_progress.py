"""Long work shows it is under way from its first second (issue 34: a 200 x 200 sheet printed nothing for minutes
while it was read, generated, checked, built or drawn): ``progress.announced`` and ``redrawn``. No test here
measures time: they wait for what a clock thread writes (up to PATIENCE_S, a hang), or set its delay beyond reach."""

from __future__ import annotations

import threading
import time

import pytest

from morphbench import progress

from conftest import SHAPES_DIR, run_cli, shown_lines

PATIENCE_S = 60.0


def _threads(name: str) -> list[threading.Thread]:
    return [thread for thread in threading.enumerate() if thread.name == name]


def test_work_still_going_after_the_delay_is_announced_with_its_time_and_its_line_ended(capsys, monkeypatch):
    monkeypatch.setattr(progress, "ANNOUNCE_AFTER_S", 0.0)
    seen = ""
    with progress.announced("building the world of 40,000 bodies"):
        deadline = time.monotonic() + PATIENCE_S
        while "building the world of 40,000 bodies... " not in seen and time.monotonic() < deadline:
            time.sleep(0.01)
            seen += capsys.readouterr().err
    seen += capsys.readouterr().err
    assert seen.startswith("\rbuilding the world of 40,000 bodies... ") and seen.endswith(" s\n")
    assert not _threads("morphbench-announce")  # the clock stops with the work


def test_work_done_before_the_delay_and_quiet_work_say_nothing(capsys, monkeypatch):
    monkeypatch.setattr(progress, "ANNOUNCE_AFTER_S", 3600.0)
    with progress.announced("reading, generating and checking chain-2"):
        pass
    monkeypatch.setattr(progress, "ANNOUNCE_AFTER_S", 0.0)
    with progress.announced("reading, generating and checking chain-2", quiet=True):
        assert not _threads("morphbench-announce")  # nothing that could write
    assert capsys.readouterr().err == ""


def test_an_error_in_announced_work_erases_its_line_before_the_error_is_printed(capsys, monkeypatch):
    monkeypatch.setattr(progress, "ANNOUNCE_AFTER_S", 0.0)
    with pytest.raises(ValueError):
        with progress.announced("drawing"):
            deadline = time.monotonic() + PATIENCE_S
            while "drawing" not in capsys.readouterr().err and time.monotonic() < deadline:
                time.sleep(0.01)
            raise ValueError("bad")
    err = capsys.readouterr().err  # the CLI's one-line error is then the only line a terminal shows
    assert err.endswith("\r") and shown_lines(err) == []


class _Bar:
    """What ``redrawn`` uses of a tqdm bar."""

    disable = False

    def __init__(self):
        self.redrawn = 0

    def refresh(self):
        self.redrawn += 1


def test_a_bar_is_redrawn_while_its_block_runs_and_no_more_after(monkeypatch):
    bar = _Bar()
    with progress.redrawn(bar):
        deadline = time.monotonic() + PATIENCE_S
        while bar.redrawn < 2 and time.monotonic() < deadline:
            time.sleep(0.05)
        assert bar.redrawn >= 2  # its elapsed time goes on between its updates
    assert not _threads("morphbench-redraw")
    bar.disable = True
    with progress.redrawn(bar):
        assert not _threads("morphbench-redraw")  # a disabled bar (--quiet) gets no clock


def test_a_runs_bar_says_the_world_is_being_built_until_its_first_step_ends(tmp_path, capsys):
    code, _, err = run_cli(capsys, "run", str(SHAPES_DIR / "chain-2.toml"), "--steps", "1", "--out",
                           str(tmp_path / "run"))
    assert code == 0, err
    # the bar's lines (on a busy machine, reading the shape and writing the records may be announced around it)
    bars = [line for line in err.replace("\r", "\n").splitlines() if line.startswith("chain-2 thermal")]
    assert bars[0].startswith("chain-2 thermal: building the world of 3 bodies (a first run compiles its solver, "
                              "once), warming it up and measuring step 0: ")
    assert bars[-1].startswith("chain-2 thermal: 100%")


def test_the_compiled_physics_lets_the_progress_clock_run():
    """Every compiled kernel of physics/ releases the interpreter's lock (nogil): a step of a large world takes
    minutes inside one call, and a kernel that held the lock would stop the clock of ``announced`` and ``redrawn``."""
    import importlib
    import pkgutil

    import numba

    import morphbench.physics as physics

    kernels = []
    for module in pkgutil.iter_modules(physics.__path__):
        loaded = importlib.import_module(f"morphbench.physics.{module.name}")
        kernels += [(f"{module.name}.{name}", value) for name, value in vars(loaded).items()
                    if isinstance(value, numba.core.registry.CPUDispatcher) and value.__module__ == loaded.__name__]
    assert len(kernels) >= 20
    assert [name for name, kernel in kernels if not kernel.targetoptions.get("nogil")] == []


def test_the_run_s_time_left_leaves_out_its_first_step(capsys, monkeypatch, tmp_path):
    """Step 0 builds the world (and, on a first run, compiles the solver: 15 s against a step's 0.1 s): the bar's
    time left comes from the steps after it. A fake clock: step 0 takes 100 s, each later step 1 s; after step 2 of
    10, 8 steps are left at 1 s each (the old bar said 06:24, from 102 s for 2 steps)."""
    import tqdm.std
    from types import SimpleNamespace

    import morphbench.experiment as experiment

    clock = SimpleNamespace(now=1000.0)
    monkeypatch.setattr(tqdm.std, "time", lambda: clock.now)

    def fake_run(config, progress, recorder):
        records = SimpleNamespace(n_steps=1, last_ubar=1.0)
        for step, seconds in enumerate([100.0, 1.0, 1.0]):
            clock.now += seconds
            progress(step, records)
        raise KeyboardInterrupt  # nothing to write: the bar is what is tested

    monkeypatch.setattr(experiment, "run", fake_run)
    code, _, err = run_cli(capsys, "run", str(SHAPES_DIR / "chain-2.toml"), "--steps", "10", "--out",
                           str(tmp_path / "out"))
    assert code != 0 and "interrupted" in err
    last = err.split("\r")[-2] if "\r" in err else err
    assert "3/11" in last and "<00:08" in last, last
