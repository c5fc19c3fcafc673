"""The ``morphbench`` command: a thin layer over the Python API (``morphbench.experiment``).

Bad input exits with status 2 and one line naming the file or option, the key and what was expected.
"""

from __future__ import annotations

import argparse
import functools
import os
import sys
import warnings
from contextlib import nullcontext
from dataclasses import replace
from pathlib import Path

from morphbench import __version__
from morphbench.bench.cli import add_bench_commands
from morphbench.errors import ConfigError, PhysicsError
from morphbench.files import atomic_write, check_path, try_replace_directory
from morphbench.params import (
    COUNT,
    DEFAULT_SEED,
    DEFAULT_STEPS,
    ENVIRONMENT_PRESET,
    ENVIRONMENT_PRESETS,
    LEARNER_HELP,
    LEARNER_PRESETS,
    PHYSICS_PRESET,
    PHYSICS_PRESETS,
    SEED,
    SENSOR_KINDS,
    STEPS,
    EnvironmentParams,
    LearnerParams,
    SensorParams,
    learner_defaults,
    scan_environment,
)
from morphbench.render.options import add_render_arguments, video_params_from_args
from morphbench.rules import field_option, option_type
from morphbench.identity import config_identity, stable_hash
from morphbench.progress import announced, redrawn
from morphbench.shapes.cli import add_shapes_commands
from morphbench.shapes.loader import resolve_shape_path

EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130
RUN_FILES = {"units.parquet", "steps.parquet", "pieces.parquet", "summary.json", "learning_curve.png",
             "trajectory.png"}
"""what a run directory holds: all that ``run --overwrite`` may replace."""
TEMPORARY_NAME_ROOM = 32
"""characters a temporary name beside a file or directory adds to its name ('.NAME.tmp-PID')."""


class _Parser(argparse.ArgumentParser):
    """argparse, but a bad option is one line (and exit 2) rather than the usage block."""

    def error(self, message: str):
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="morphbench", formatter_class=argparse.RawDescriptionHelpFormatter,
                     description="morphbench: robotic matter, assemblies of units that each learn, on their own, when "
                                 "to pump so that the whole moves.",
                     epilog="examples:\n"
                            "  morphbench run chain-2 --steps 100          a chain of 2 units learns (runs/...)\n"
                            "  morphbench shapes list                      the shipped shapes\n"
                            "  morphbench bench benchmarks/smoke.toml --out results/smoke   a suite and its report\n"
                            "  morphbench COMMAND --help                   a command's options")
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    run = sub.add_parser("run", help="learn a gait on a shape and write records, summary, a learning curve and the "
                                     "trajectory")
    run.add_argument("config", metavar="FILE",
                     help="a morphology file (shapes/chain-3.toml), the name of a shipped shape (chain-3; see "
                          "'morphbench shapes list') or a run configuration (examples/s6-damage.toml)")
    # Options default to None: given ones override the file, the others leave it as it is.
    run.add_argument("--learner", help=LEARNER_HELP)
    run.add_argument("--steps", type=option_type(STEPS),
                     help=f"learning steps after the initial measurement (default {DEFAULT_STEPS})")
    learner, sensor = LearnerParams(), SensorParams()
    run.add_argument("--seed", type=option_type(SEED), help=f"run seed (default {DEFAULT_SEED})")
    sparse = LEARNER_PRESETS["sparse"]
    run.add_argument("--temperature", type=field_option(LearnerParams, "temperature"),
                     help=f"T in mm/cycle, 0 greedy, inf accepts every trial (default {learner.temperature:g}; "
                          f"sparse {sparse.temperature:g})")
    run.add_argument("--step-size", type=field_option(LearnerParams, "step_size"),
                     help=f"delta_s in cycles (default {learner.step_size:g}; sparse {sparse.step_size:g})")
    run.add_argument("--cycles-per-step", type=field_option(LearnerParams, "cycles_per_step"),
                     help=f"pump cycles each learning step measures, after its discarded cycles (default "
                          f"{learner.cycles_per_step}; a step lasts discard_cycles + these, "
                          f"{learner.discard_cycles} + {learner.cycles_per_step} by default, "
                          f"{sparse.discard_cycles} + {sparse.cycles_per_step} for sparse)")
    run.add_argument("--sensor", choices=SENSOR_KINDS, help=f"how units measure their motion (default {sensor.kind})")
    run.add_argument("--noise", type=field_option(EnvironmentParams, "noise"),
                     help=f"Gaussian measurement noise, mm/cycle (default {EnvironmentParams().noise:g})")
    _add_physics(run, default=None)
    _add_environment(run, "the world the run is in: a preset (default: the file's, else default); the file's own "
                          "[environment] fields and --noise apply on top")
    run.add_argument("--out", help="output directory (default runs/NAME-LEARNER-seedS-ID, ID a short hash of the "
                                   "whole configuration: steps, sensor, noise, physics, ...)")
    run.add_argument("--overwrite", action="store_true",
                     help="replace an earlier run in --out (a directory holding only a run's files), whole")
    run.add_argument("--quiet", action="store_true", help="no progress bar")
    add_render_arguments(run)
    run.set_defaults(func=_warnings_unless_failed(_cmd_run))

    render = sub.add_parser("render", help="replay a finished run from its records and render it to a video, or "
                                           "map its kept phases at chosen steps (--phases)")
    render.add_argument("run_dir", metavar="RUN_DIR",
                        help="a directory written by morphbench run, or a suite's run: RESULTS_DIR/runs/RUN_ID")
    render.add_argument("--out", required=True,
                        help="the video to write (.mp4 or .gif), or with --phases the figure (.png)")
    render.add_argument("--phases", type=_step_list, metavar="STEP,STEP,...",
                        help="instead of a video, a PNG of the kept phases over the sheet at the end of these "
                             "learning steps, one panel each (read from units.parquet; nothing is simulated)")
    render.add_argument("--quiet", action="store_true")
    add_render_arguments(render, output=False)
    render.set_defaults(func=_warnings_unless_failed(_cmd_render))

    scan = sub.add_parser("scan", help="Ubar at fixed phases over all phase differences (no learning)")
    scan.add_argument("shape")
    scan.add_argument("--resolution", type=option_type(COUNT), default=20,
                      help="points per phase axis (default %(default)s)")
    scan.add_argument("--samples", type=option_type(COUNT),
                      help="random phase vectors for 4 or more units (default resolution^2)")
    scan.add_argument("--cycles", type=option_type(COUNT), default=None,
                      help="cycles measured per point")
    scan.add_argument("--seed", type=option_type(SEED), default=0)
    scan.add_argument("--workers", type=option_type(COUNT), default=1,
                      help="worker processes (default 1; at most the number of points and of CPUs are used)")
    _add_physics(scan, default="default")
    _add_environment(scan, "the ground and pumps the scan measures in: a preset's (without its noise and clocks: "
                           "a scan measures the true velocity on one clock; default: default)")
    scan.set_defaults(func=_warnings_unless_failed(_cmd_scan))
    add_shapes_commands(sub)
    add_bench_commands(sub)
    scan.add_argument("--out", help="output directory (default runs/scan-SHAPE)")
    scan.add_argument("--overwrite", action="store_true", help="replace an earlier scan in --out")
    scan.add_argument("--quiet", action="store_true")
    return parser


def _warnings_unless_failed(command):
    """``command`` with its warnings (numpy's RuntimeWarnings, say) shown after it succeeds and dropped if it fails:
    an error is one line."""

    @functools.wraps(command)
    def quiet(args) -> int:
        with warnings.catch_warnings(record=True) as caught:
            code = command(args)
        for w in caught:
            warnings.showwarning(w.message, w.category, w.filename, w.lineno)
        return code

    return quiet


def _add_physics(parser: argparse.ArgumentParser, default: str | None) -> None:
    parser.add_argument("--physics", choices=PHYSICS_PRESET.values, default=default,
                        help="physics: default (quasistatic on the ground, fast for stacks), fast (PyBullet), "
                             "reference (PyBullet, finer), quasistatic (springs and friction without inertia, exact; "
                             "one layer on the ground) or dynamic (the same springs with inertia and sticking "
                             "friction, linear in the units; one layer on the ground)")


def _add_environment(parser: argparse.ArgumentParser, what: str) -> None:
    parser.add_argument("--environment", choices=ENVIRONMENT_PRESET.values, default=None,
                        help=f"{what}. default: a uniform ground, no vibration, noise or clocks of their own; "
                             "hardware: the paper's robots on their track (pump vibration, a friction field, sensor "
                             "noise, clocks of their own: docs/hardware.md)")


def _run_dir(out: str, overwrite: bool) -> Path:
    """The run directory, checked before anything is simulated: a new or empty directory, or with ``overwrite`` one
    that holds only an earlier run's files (it is replaced whole), where the file system lets it be written."""
    path = check_path(out, "--out", room=TEMPORARY_NAME_ROOM)
    if path.exists() and not path.is_dir():
        raise ConfigError("--out", out, "a directory (this is a file)")
    if path.is_dir():
        entries = set(os.listdir(path))
        if "summary.json" in entries and not overwrite:
            raise ConfigError("--out", out, "a new directory: it already holds summary.json, a run of this "
                                            "configuration if the name is the default (pass --overwrite to replace "
                                            "it, or another --out to keep both)")
        if entries and not overwrite:
            raise ConfigError("--out", out, f"a new or empty directory (it holds {sorted(entries)[0]})")
        if entries - RUN_FILES:
            raise ConfigError("--out", out, f"a directory holding only a run's files, to be replaced whole (it also "
                                            f"holds {sorted(entries - RUN_FILES)[0]})")
        if os.path.ismount(path):
            raise ConfigError("--out", out, "a directory that can be replaced (this is a mount point)")
    ancestor = Path(os.path.abspath(path)).parent
    while not ancestor.exists():
        ancestor = ancestor.parent
    if not ancestor.is_dir() or not os.access(ancestor, os.W_OK | os.X_OK):
        raise ConfigError("--out", out, f"a directory that can be written ({ancestor} is not a writable directory)")
    try:
        try_replace_directory(path)  # what RunRecords.write makes first
    except OSError as exc:
        where = f": {exc.filename}" if exc.filename else ""
        raise ConfigError("--out", out, f"a directory that can be written ({exc.strerror or exc}{where})") from None
    return path


def _output_dir(out: str, marker: str, overwrite: bool) -> Path:
    """The output directory, refusing to overwrite an earlier result unless asked to."""
    path = check_path(out, "--out", room=TEMPORARY_NAME_ROOM)
    if path.exists() and not path.is_dir():
        raise ConfigError("--out", out, "a directory (this is a file)")
    if (path / marker).exists() and not overwrite:
        raise ConfigError("--out", out, f"a new directory: it already holds {marker} (pass --overwrite to replace it)")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError("--out", out, f"a directory that can be created ({exc.strerror})") from None
    return path


def _with_options(config, args):
    """The configuration with the command-line options that were given."""
    learner = {"temperature": args.temperature, "step_size": args.step_size, "cycles_per_step": args.cycles_per_step}
    top = {"learner": args.learner, "steps": args.steps, "seed": args.seed}  # --physics: load_run_config merges it
    base = config.learner_params
    if args.learner is not None and base == learner_defaults(config.learner):  # the file set none of its own
        base = learner_defaults(args.learner)
    return replace(
        config,
        **{key: value for key, value in top.items() if value is not None},
        learner_params=replace(base, **{k: v for k, v in learner.items() if v is not None}),
        sensor=replace(config.sensor, kind=args.sensor or config.sensor.kind),
        environment=replace(config.environment, noise=config.environment.noise if args.noise is None else args.noise),
    )


def _say_backend(config, quiet: bool) -> None:
    """A word on stderr when the sensor, not the shape, decides the physics: the camera renders its images in a
    PyBullet scene, so a shape the default would simulate on a quasi-static model runs on PyBullet."""
    from morphbench.physics import resolve_backend

    scene = config.sensor.kind == "camera"
    if quiet or not scene:
        return
    backend = resolve_backend(config.shape, config.physics, config.environment, scene=True)
    if backend != resolve_backend(config.shape, config.physics, config.environment, scene=False):
        print(f"morphbench: the camera sensor renders its images in a scene of the {backend} backend: this run is "
              f"simulated there, not on the model the physics would pick without it", file=sys.stderr)


def _cmd_run(args) -> int:
    from tqdm import tqdm

    from morphbench import plots
    from morphbench.experiment import load_run_config, run
    from morphbench.experiment.config import check_events_happen
    from morphbench.learning import load_learner_class
    from morphbench.render import open_recorder

    with announced(f"reading, generating and checking {args.config}", args.quiet):
        config = _with_options(load_run_config(resolve_shape_path(args.config), physics=args.physics,
                                               environment=args.environment), args)
    if args.steps is not None:
        check_events_happen(config, "--steps", str(args.steps))
    load_learner_class(config.learner)  # fail on a bad plug-in before simulating
    _say_backend(config, args.quiet)
    name = Path(args.config).stem
    learner_name = config.learner.rsplit(":", 1)[-1].lower()
    # --out '' is refused (as bench refuses it), not taken for the default. The default names the configuration by a
    # short hash of all it is (steps, sensor, noise, physics, ...): runs that differ never share a directory, and the
    # same configuration, which gives the same records, finds its earlier run
    default = f"runs/{name}-{learner_name}-seed{config.seed}-{stable_hash(config_identity(config, ''), 6)}"
    out = _run_dir(default if args.out is None else args.out, args.overwrite)
    video = (open_recorder(config.shape, check_path(args.video, "--video", room=TEMPORARY_NAME_ROOM),
                           video_params_from_args(args, config.steps))
             if args.video else nullcontext())
    title = f"{name}, {learner_name}, seed {config.seed}"

    def figures(directory: Path) -> None:
        plots.learning_curve(records.steps(), records.units(), directory / "learning_curve.png", title=title)
        plots.trajectory_figure(records.steps(), directory / "trajectory.png", title=title)

    bodies = len(config.shape.bodies)
    try:
        # until its first step ends, the bar says what is under way (a large world is built and warmed up for
        # minutes), and it is redrawn every second while Python runs (building the world, between advances)
        with video as recorder, tqdm(total=config.steps + 1, unit="step", disable=args.quiet, smoothing=0,
                                     desc=f"{name} {learner_name}: building the world of {bodies:,} bodies (a first "
                                          f"run compiles its solver, once), warming it up and measuring step 0"
                                     ) as bar, redrawn(bar):
            def progress(step, records):
                if step == 0 and not bar.disable:  # the time left is the later steps' rate: step 0 also built
                    bar.set_description_str(f"{name} {learner_name}", refresh=False)  # (and compiled) the world
                    bar.reset()
                    bar.initial = 1
                    bar.update(1)
                    bar.last_print_t = bar.start_t = bar._time()
                else:
                    bar.update(1)
                if records.n_steps:  # units on clocks of their own record a step once the next is under way
                    bar.set_postfix_str(f"Ubar {records.last_ubar:+.2f} mm/cycle")
                if recorder is not None:
                    recorder.progress(step, records)

            records = run(config, progress, recorder)
        with announced(f"writing the records and figures of {bodies:,} bodies to {out}", args.quiet):
            records.write(out, figures)
    except KeyboardInterrupt:
        print(f"morphbench: interrupted; nothing of this run was written to {out}", file=sys.stderr)
        return EXIT_INTERRUPTED
    summary = records.summary()
    print(f"{name}: final Ubar {summary['final_ubar']:+.2f} mm/cycle (true {summary['final_ubar_true']:+.2f}), "
          f"mean acceptance {summary['mean_acceptance']:.2f}, {summary['wall_time_s']:.1f} s wall time")
    if len(summary["final_ubar_by_piece"]) > 1:
        print("  pieces: " + ", ".join(f"{k}: {v:+.2f}" for k, v in summary["final_ubar_by_piece"].items()))
    print(f"records in {out}/ (units.parquet, steps.parquet, pieces.parquet, summary.json, learning_curve.png, "
          "trajectory.png)")
    if args.video:
        print(f"video in {args.video}")
    return 0


def _cmd_render(args) -> int:
    from tqdm import tqdm

    from morphbench.render import phase_maps, render_run

    if args.phases is not None:
        with _replayable(args.run_dir, units=True) as run_dir:
            path = phase_maps(run_dir, check_path(args.out, "--out", room=TEMPORARY_NAME_ROOM), args.phases)
        print(f"phase maps in {path}")
        return 0

    bars = []  # drawn at the replay's first step, after its checks: a run refused shows no bar before its error

    def progress(done, total):
        if not bars:
            bars.append(tqdm(desc=f"replay {args.run_dir}", unit="step", total=total, disable=args.quiet))
        bars[0].update(done - bars[0].n)

    try:
        with _replayable(args.run_dir) as run_dir:
            path = render_run(run_dir, args.out, video_params_from_args(args), progress)
    finally:
        for bar in bars:
            bar.close()
    print(f"video in {path}")
    return 0


def _replayable(run_dir: str, units: bool = False):
    """The directory to replay ``run_dir`` from: itself, or for a suite's run whose rows the consolidated tables
    hold (``DIR/runs/<id>`` keeps only its result.json), a temporary one the results store gives (with its
    units.parquet if ``units``)."""
    path = Path(run_dir)
    root = path.parent.parent
    if path.parent.name == "runs" and (root / "plan.json").is_file() and not (path / "steps.parquet").exists():
        from morphbench.bench.store import Store

        return Store(root).replayable(path.name, units=units)
    return nullcontext(run_dir)


def _step_list(text: str) -> list[int]:
    """'0,50,100' -> [0, 50, 100]: learning steps, each a whole number >= 0, in the order given."""
    try:
        steps = [int(part) for part in text.split(",")]
    except ValueError:
        steps = [-1]
    if any(step < 0 for step in steps) or len(set(steps)) != len(steps):
        raise argparse.ArgumentTypeError(f"expected learning steps STEP,STEP,... (whole numbers >= 0, each once), "
                                         f"got {text!r}")
    return steps


def _cmd_scan(args) -> int:
    from tqdm import tqdm

    from morphbench import plots
    from morphbench.experiment import scan, scan_phases
    from morphbench.experiment.scan import DEFAULT_CYCLES, check_scan_size
    from morphbench.shapes import load_shape

    shape = load_shape(resolve_shape_path(args.shape))
    if shape.n_units < 2:
        raise ConfigError(args.shape, "assembly.units", "at least 2 active units to scan phase differences", 1)
    sampled = shape.n_units > 3 and args.samples
    check_scan_size(shape.n_units, args.resolution, args.samples, "--samples" if sampled else "--resolution",
                    f"{shape.name} ({shape.n_units} units)")
    out = _output_dir(f"runs/scan-{shape.name}" if args.out is None else args.out, "scan.csv", args.overwrite)
    n_points = len(scan_phases(shape.n_units, args.resolution, args.samples))
    with tqdm(total=n_points, desc=f"scan {shape.name}", unit="point", disable=args.quiet) as bar:
        table = scan(shape, args.resolution, physics=PHYSICS_PRESETS[args.physics],
                     environment=scan_environment(ENVIRONMENT_PRESETS[args.environment or "default"]),
                     cycles=args.cycles or DEFAULT_CYCLES, samples=args.samples, seed=args.seed,
                     workers=min(args.workers, n_points, os.cpu_count() or 1), progress=bar.update)
    atomic_write(out / "scan.csv", lambda tmp: table.to_csv(tmp, index=False, float_format="%.6g"))
    plots.scan_figure(table, out / "scan.png", title=f"{shape.name}: Ubar at fixed phases")
    best = table.loc[table.ubar.idxmax()]
    worst = table.loc[table.ubar.idxmin()]
    dphi = [c for c in table.columns if c.startswith("dphi_")]

    def describe(row) -> str:
        return ", ".join(f"{c} = {row[c]:.3f}" for c in dphi)

    print(f"{shape.name}: max Ubar {best.ubar:+.2f} mm/cycle at {describe(best)}; "
          f"min {worst.ubar:+.2f} at {describe(worst)}")
    if len(dphi) == 1:
        print(table.to_string(index=False, float_format=lambda v: f"{v:+.2f}"))
    print(f"scan in {out}/ (scan.csv, scan.png)")
    return 0


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        return args.func(args)
    except (ConfigError, PhysicsError) as exc:  # bad input, a failing plug-in (PluginError), physics off the model
        print(f"morphbench: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:  # before a command has anything to keep (loading, checking); runs and suites say more
        print("morphbench: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


if __name__ == "__main__":
    sys.exit(main())
