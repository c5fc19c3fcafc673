"""Physics fidelity: convergence, agreement with the quasi-static limit, invariants and the paper's first result,
for the PyBullet default and the quasi-static backend. Writes docs/fidelity.md.

    python benchmarks/fidelity.py --workers 2        # about 3 minutes on 2 cores
"""

from __future__ import annotations

import argparse
import dataclasses
import platform
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pybullet

from morphbench.experiment import RunConfig, measure, run, scan
from morphbench.experiment.scan import motion_at, velocity_at
from morphbench.files import write_text
from morphbench.params import (
    DEFAULT_PHYSICS,
    FAST_PHYSICS,
    MIN_FRICTION_INERTIA,
    QUASISTATIC_PHYSICS,
    REFERENCE_PHYSICS,
    EnvironmentParams,
    LearnerParams,
    PhysicsParams,
    SensorParams,
    friction_inertia,
)
from morphbench.physics import make_world, quasistatic_world
from morphbench.sensing import IdealSensor
from morphbench.shapes import load_shape, rotate, shape_from_table

DOC = Path(__file__).resolve().parent.parent / "docs" / "fidelity.md"
KEPT_FROM = "## The dynamic backend"
"""the page's sections from this heading on are another script's (benchmarks/dynamic_fidelity.py): kept as they are."""
CURVE_POINTS = 20  # dphi_2 = 0, 0.05, ..., 0.95
MAP_RESOLUTION = 10
CYCLES, DISCARD = 8, 2  # per scan point: cycles measured after cycles dropped


def chain(units: int, dummy_friction: float | None = None, **actuator):
    table = {"assembly": {"generator": "chain", "units": units, "dummy": True}, "actuator": actuator}
    if dummy_friction is not None:
        table["dummy"] = {"friction": dummy_friction}
    return shape_from_table(table, source=f"chain-{units}")


def curve(shape, physics: PhysicsParams, workers: int) -> np.ndarray:
    return scan(shape, CURVE_POINTS, physics=physics, cycles=CYCLES, discard=DISCARD, workers=workers).ubar.to_numpy()


def landscape(shape, physics: PhysicsParams, workers: int) -> np.ndarray:
    return scan(shape, MAP_RESOLUTION, physics=physics, cycles=CYCLES, discard=DISCARD,
                workers=workers).ubar.to_numpy()


def rms(a, b) -> float:
    return float(np.sqrt(np.mean((np.asarray(a) - np.asarray(b)) ** 2)))


def spread(shape, phases, physics: PhysicsParams, steps: int = 30) -> tuple[float, float]:
    """Mean and standard deviation of Ubar over successive 2-cycle windows at fixed phases."""
    with make_world(shape, physics) as world:
        world.set_phases(phases)
        world.advance(world.ticks_in(DISCARD * shape.actuator.cycle_time))
        x = [world.unit_poses()[0][:, 0]]
        for _ in range(steps):
            world.advance(world.ticks_in(2 * shape.actuator.cycle_time))
            x.append(world.unit_poses()[0][:, 0])
    ubar = (np.diff(np.array(x), axis=0) * 1000 / 2).mean(axis=1)
    return float(ubar.mean()), float(ubar.std())


def _s1_run(args) -> np.ndarray:
    shape, physics, learner_params, sensor, seed, steps = args
    records = run(RunConfig(shape=shape, physics=physics, learner_params=learner_params, sensor=sensor,
                            steps=steps, seed=seed))
    return records.steps().ubar_true.to_numpy()


def _steps(config: RunConfig):
    return run(config).steps()


def s1(shape, physics: PhysicsParams, peak: float, workers: int, seeds: int = 32, steps: int = 100,
       learner_params: LearnerParams = LearnerParams(), sensor: str = "ideal") -> dict:
    """The paper's first result: steps to first reach 0.8 of the scan's peak, how many reach it by step 60, and
    the mean true Ubar over steps 50-100 as a fraction of the peak."""
    jobs = [(shape, physics, learner_params, SensorParams(kind=sensor), seed, steps) for seed in range(seeds)]
    with ProcessPoolExecutor(workers) as pool:
        curves = list(pool.map(_s1_run, jobs))
    first = np.array([np.flatnonzero(u >= 0.8 * peak)[0] if np.any(u >= 0.8 * peak) else steps + 1 for u in curves])
    return {"median": float(np.median(first)), "by60": int(np.sum(first <= 60)), "seeds": seeds,
            "hold": float(np.mean([u[50:].mean() for u in curves]) / peak)}


def plane_section() -> list[str]:
    """Frame invariance and mirror symmetry in the plane: a chain and a grid turned on the ground, and a 2 x 2 grid
    whose sides run opposite gaits (it turns) against the same grid with the gaits swapped (its mirror image)."""
    pyramid = dataclasses.replace(FAST_PHYSICS, cone_friction=False)
    backends = (("PyBullet fast (friction cone)", FAST_PHYSICS), ("PyBullet fast, friction pyramid", pyramid),
                ("quasi-static", QUASISTATIC_PHYSICS))
    lines = ["", "## In the plane: frame invariance and mirror symmetry", "",
             f"Fixed phases, {CYCLES} cycles after {DISCARD}. Turned: the shape placed turned on the ground "
             "(`[transform] rotate`); the figure is the units' mean speed along their own axes over that of the "
             "unturned shape (target within 5% at 90 degrees).", "",
             "| shape, phases | turned by | " + " | ".join(name for name, _ in backends) + " |",
             "|---|---|" + "---|" * len(backends)]
    for path, phases in (("shapes/chain-2.toml", (0.0, 0.4)), ("shapes/grid-2x2.toml", (0.0, 0.4, 0.0, 0.4))):
        shape = load_shape(path)
        base = {name: motion_at(shape, phases, ph, cycles=CYCLES, discard=DISCARD).units.mean()
                for name, ph in backends}
        for degrees in (90, 30):
            ratios = [motion_at(rotate(shape, degrees), phases, ph, cycles=CYCLES, discard=DISCARD).units.mean()
                      / base[name] for name, ph in backends]
            lines.append(f"| {shape.name} {phases} | {degrees} | " + " | ".join(f"{r:.3f}" for r in ratios) + " |")
    grid = load_shape("shapes/grid-2x2.toml")
    forward, backward = (0.0, 0.4), (0.0, 0.6)
    lines += ["", "Mirror: rows 1 and 2 of grid-2x2 run the forward (0, 0.4) and backward (0, 0.6) gaits of a chain, "
              "then swapped: the motion should mirror (centroid x the same, y and the turn opposite). Per cycle: "
              "centroid velocity (mm/cycle) and turning rate (degrees/cycle).", "",
              "| backend | forward + backward: x, y, turn | swapped: x, y, turn | mirror error: x, y, turn |",
              "|---|---|---|---|"]
    for name, ph in backends:
        a = motion_at(grid, forward + backward, ph, cycles=CYCLES, discard=DISCARD)
        b = motion_at(grid, backward + forward, ph, cycles=CYCLES, discard=DISCARD)
        errors = (a.centroid[0] - b.centroid[0], a.centroid[1] + b.centroid[1], a.turning + b.turning)
        lines.append(f"| {name} | {a.centroid[0]:+.2f}, {a.centroid[1]:+.2f}, {a.turning:+.2f} | "
                     f"{b.centroid[0]:+.2f}, {b.centroid[1]:+.2f}, {b.turning:+.2f} | "
                     + ", ".join(f"{abs(e):.2f}" for e in errors) + " |")
    return lines


FRICTION_SCALES = (1.0, 0.5, 0.3, 0.2, 0.1, 0.05, 0.01, 1e-6)
VARIANT_SCALES = (1.0, 0.3, 0.1, 0.03, 0.01)
VARIANTS = {"default": {}, "tau x 2": {"tau_inflate": 0.6, "tau_vent": 0.6},
            "tau / 2": {"tau_inflate": 0.15, "tau_vent": 0.15}, "stroke / 2": {"stroke": 0.00525},
            "mass x 4": {"mass": 0.2}, "stiffness / 3": {"stiffness": 100.0}}
"""changes of chain-2 (mass: every body's)."""


def _gait(args) -> float:
    """Ubar (mm/cycle, true) at fixed phases with every friction times a scale. The quasi-static world is built
    directly: make_world refuses it outside its range, which is what is measured here."""
    shape, phases, physics, scale = args
    environment = EnvironmentParams(friction_scale=scale)
    quasistatic = physics.backend == "quasistatic"
    with (quasistatic_world if quasistatic else make_world)(shape, physics, environment) as world:
        world.set_phases(phases)
        world.advance(world.ticks_in(DISCARD * shape.actuator.cycle_time))
        (displacement,) = measure(world, [IdealSensor(shape.n_units, sample_period=0.5)], CYCLES)
    return 1000 * float(np.mean(displacement)) / CYCLES


def _variant(shape, changes: dict):
    changes = dict(changes)
    if "mass" in changes:
        mass = changes.pop("mass")
        shape = dataclasses.replace(shape, bodies=tuple(dataclasses.replace(b, mass=mass) for b in shape.bodies))
    return dataclasses.replace(shape, actuator=dataclasses.replace(shape.actuator, **changes))


def friction_section(workers: int) -> list[str]:
    """Where the quasi-static model stops holding as friction falls against inertia: gaits at fixed phases on both
    backends over friction scales, and how the parting moves with the pressure time constant, the stroke, the mass
    and the stiffness (params.friction_inertia)."""
    chain2, chain3 = load_shape("shapes/chain-2.toml"), load_shape("shapes/chain-3.toml")
    rng = np.random.default_rng(0)
    sets = [(chain2, [(0.0, d) for d in np.arange(10) / 10]),
            (chain3, [(0.0, *rng.uniform(size=2)) for _ in range(10)])]
    jobs = [(shape, phases, physics, scale) for scale in FRICTION_SCALES for shape, points in sets
            for phases in points for physics in (QUASISTATIC_PHYSICS, FAST_PHYSICS)]
    jobs += [(_variant(chain2, changes), (0.0, 0.4), physics, scale) for changes in VARIANTS.values()
             for scale in VARIANT_SCALES for physics in (QUASISTATIC_PHYSICS, FAST_PHYSICS)]
    with ProcessPoolExecutor(workers) as pool:
        gaits = iter(pool.map(_gait, jobs))
    ratio = {shape.name: friction_inertia(shape, EnvironmentParams())[0] for shape, _ in sets}
    lowest = max(MIN_FRICTION_INERTIA / r for r in ratio.values())
    lines = ["", "## Friction against inertia", "",
             "The quasi-static model neglects inertia, which holds while friction dominates the inertial force of the "
             "bellows' motion. Per unit of mass that is Pi = mu g tau^2 / stroke (`params.friction_inertia`: a "
             "bellows starts to move with the acceleration stroke / tau^2; mu is the bodies' mean friction "
             "coefficient weighted by mass, times the friction scale, at its lowest under the pumps' vibration and "
             "the friction field; tau the faster pressure time constant, the largest stroke): "
             + ", ".join(f"{r:.1f} for {name}" for name, r in ratio.items()) + " at the defaults. The quasi-static "
             f"backend refuses Pi < {MIN_FRICTION_INERTIA:g} (`MIN_FRICTION_INERTIA`; for these chains a friction "
             f"scale below {lowest:.2f}): a run configuration is refused before anything is simulated, `auto` refuses "
             "rather than switch to PyBullet, and a friction event below it stops the run at its step "
             "(PhysicsError).", "",
             f"Gaits at fixed phases ({CYCLES} cycles after {DISCARD}, true Ubar in mm/cycle), every friction times "
             "the scale, PyBullet fast against quasi-static: chain-2 over dphi_2 = 0, 0.1, ..., 0.9 and chain-3 over "
             "10 random phase pairs. Targets of the pages above: rms <= 0.4 on the 2-unit curve, <= 0.6 over 3-unit "
             "phases.", "",
             "| friction scale | Pi chain-2 | chain-2 rms | chain-2 at (0, 0.4): quasi-static, PyBullet | Pi chain-3 "
             "| chain-3 rms | in range |", "|---|---|---|---|---|---|---|"]
    held, missed = [], []  # (Pi, scale) of the rows within and beyond both targets
    for scale in FRICTION_SCALES:
        cells, within = [f"{scale:g}"], True
        for (shape, points), name, target in zip(sets, ("chain-2", "chain-3"), (0.4, 0.6)):
            pairs = np.array([[next(gaits), next(gaits)] for _ in points])
            cells += [f"{friction_inertia(shape, EnvironmentParams(), scale)[0]:.3g}",
                      f"{rms(pairs[:, 0], pairs[:, 1]):.2f}"]
            within &= rms(pairs[:, 0], pairs[:, 1]) <= target
            if name == "chain-2":
                cells.append(f"{pairs[4, 0]:+.2f}, {pairs[4, 1]:+.2f}")
        ratio_of_row = min(friction_inertia(shape, EnvironmentParams(), scale)[0] for shape, _ in sets)
        cells.append("yes" if ratio_of_row >= MIN_FRICTION_INERTIA else "no")
        (held if within else missed).append((ratio_of_row, scale))
        lines.append("| " + " | ".join(cells) + " |")
    last, first = min(held), max(missed)
    lines += ["", f"Both targets hold down to Pi {last[0]:.3g} (scale {last[1]:g}) and are missed from Pi "
              f"{first[0]:.3g} (scale {first[1]:g}) down: the bound is the round figure just above the last row "
              "that holds them, so the quasi-static backend runs nothing further from PyBullet than the pages above "
              "allow."]
    lines += ["", "Pi is what decides: chain-2 at (0, 0.4) with the pressure time constants, the stroke, every body's "
              "mass or the bellows' stiffness changed; at each friction scale PyBullet's gait minus the quasi-static "
              "one, as a fraction of the fastest quasi-static gait of the row (Pi in brackets). The scale where they "
              "part by 10% moves with tau^2 / stroke and hardly with the mass or the stiffness: they part near the "
              "same Pi, 2 to 4. (With 4 times the mass or a third of the stiffness, friction at scale 1 holds the "
              "bellows back and both backends barely move.)", "",
              "| chain-2 | " + " | ".join(f"{scale:g}" for scale in VARIANT_SCALES) + " |",
              "|---|" + "---|" * len(VARIANT_SCALES)]
    for name, changes in VARIANTS.items():
        shape = _variant(chain2, changes)
        pairs = np.array([[next(gaits), next(gaits)] for _ in VARIANT_SCALES])
        parting = 100 * (pairs[:, 1] - pairs[:, 0]) / np.abs(pairs[:, 0]).max()
        ratios = [friction_inertia(shape, EnvironmentParams(), scale)[0] for scale in VARIANT_SCALES]
        lines.append(f"| {name} | " + " | ".join(f"{d:+.0f}% ({r:.3g})" for d, r in zip(parting, ratios)) + " |")
    return lines


def fmt(values) -> str:
    return " | ".join(f"{v:+.2f}" for v in values)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default=str(DOC))
    args = parser.parse_args()
    w = args.workers
    started = time.perf_counter()
    chain2, chain3 = load_shape("shapes/chain-2.toml"), load_shape("shapes/chain-3.toml")
    actuator = chain2.actuator
    half = dataclasses.replace(REFERENCE_PHYSICS, timestep=REFERENCE_PHYSICS.timestep / 2)
    lines = [
        "# Physics fidelity",
        "",
        f"Generated by `python benchmarks/fidelity.py --workers {w}` on {time.strftime('%Y-%m-%d')} "
        f"({platform.machine()}, {platform.python_version()}, PyBullet API {pybullet.getAPIVersion()}). "
        "Every figure on this page comes from that command; rerun it when the physics or a default changes.",
        "",
        f"Settings: default `{DEFAULT_PHYSICS}` (a chain runs on the quasi-static model at this timestep); PyBullet "
        f"fast `{FAST_PHYSICS}`; PyBullet reference `{REFERENCE_PHYSICS}`; quasi-static `{QUASISTATIC_PHYSICS}`. "
        f"Scans: unit 1 at phase 0, a fresh world per point, {DISCARD} cycles dropped, "
        f"{CYCLES} measured; true velocities (mm/cycle).",
        "",
    ]
    curves = {name: curve(chain2, physics, w) for name, physics in
              (("PyBullet fast", FAST_PHYSICS), ("PyBullet reference", REFERENCE_PHYSICS),
               ("PyBullet reference, half timestep", half), ("quasi-static", QUASISTATIC_PHYSICS),
               ("quasi-static, half timestep", dataclasses.replace(QUASISTATIC_PHYSICS,
                                                                   timestep=QUASISTATIC_PHYSICS.timestep / 2)),
               ("default (quasi-static at the default timestep)", DEFAULT_PHYSICS))}
    d = np.arange(CURVE_POINTS) / CURVE_POINTS
    lines += ["## The 2-unit curve", "", "| setting | " + " | ".join(f"{x:.2f}" for x in d) + " |",
              "|---|" + "---|" * CURVE_POINTS]
    lines += [f"| {name} | {fmt(c)} |" for name, c in curves.items()]
    qs, default = curves["quasi-static"], curves["PyBullet fast"]
    peak = float(qs.max())
    lines += ["", "| comparison | rms (mm/cycle) | max abs | target |", "|---|---|---|---|",
              *(f"| {a} vs {b} | {rms(curves[a], curves[b]):.2f} | {np.abs(curves[a] - curves[b]).max():.2f} | "
                f"{target} |" for a, b, target in (
                    ("PyBullet reference", "PyBullet reference, half timestep", "rms <= 0.15"),
                    ("PyBullet fast", "PyBullet reference", "rms <= 0.3, max <= 0.6"),
                    ("PyBullet fast", "quasi-static", "rms <= 0.4"),
                    ("quasi-static", "quasi-static, half timestep", "rms <= 0.15"),
                    ("default (quasi-static at the default timestep)", "quasi-static", "rms <= 0.15")))]
    for name, c in (("PyBullet fast", default), ("quasi-static", qs)):
        lo, hi = int(np.argmin(c)), int(np.argmax(c))
        flat = np.abs(c[(d >= 0.1 - 1e-9) & (d <= 0.35 + 1e-9) | (d >= 0.65 - 1e-9) & (d <= 0.9 + 1e-9)]).min()
        lines.append("")
        lines.append(f"Calibration ({name}): maximum {c[hi]:+.2f} at {d[hi]:.2f} (target +4.5 +- 0.5 at 0.35-0.45), "
                     f"minimum {c[lo]:+.2f} at {d[lo]:.2f} (target -5 to -3 at 0.55-0.65), smallest |Ubar| over "
                     f"[0.1, 0.35] and [0.65, 0.9] {flat:.2f} (target >= 0.3).")

    maps = {name: landscape(chain3, physics, w) for name, physics in
            (("PyBullet fast", FAST_PHYSICS), ("PyBullet reference", REFERENCE_PHYSICS),
             ("quasi-static", QUASISTATIC_PHYSICS))}
    lines += ["", f"## The 3-unit map ({MAP_RESOLUTION} x {MAP_RESOLUTION})", "",
              "| comparison | rms (mm/cycle) | max abs | target |", "|---|---|---|---|",
              *(f"| {a} vs {b} | {rms(maps[a], maps[b]):.2f} | {np.abs(maps[a] - maps[b]).max():.2f} | {target} |"
                for a, b, target in (("PyBullet fast", "PyBullet reference", "rms <= 0.5"),
                                     ("PyBullet fast", "quasi-static", "rms <= 0.6"))), ""]
    axis = np.arange(MAP_RESOLUTION) / MAP_RESOLUTION
    for name, values in maps.items():
        k = int(np.argmax(values))
        lines.append(f"- {name}: maximum {values[k]:+.2f} at (dphi_2, dphi_3) = ({axis[k // MAP_RESOLUTION]:.1f}, "
                     f"{axis[k % MAP_RESOLUTION]:.1f}), minimum {values.min():+.2f}")

    lines += ["", "## Stiffness sweep: towards the rigid limit", "",
              "The bellows' stiffness times 1, 3 and 10 (PyBullet at the default setting where it stays finite) "
              "against the quasi-static model with the same stiffness and with rigid bellows.", "",
              "| stiffness (N/m) | PyBullet vs quasi-static, rms | PyBullet vs rigid, rms | "
              "quasi-static vs rigid, rms | PyBullet peak | quasi-static peak |", "|---|---|---|---|---|---|"]
    rigid = curve(chain(2, stiffness=1e7), QUASISTATIC_PHYSICS, w)
    for factor in (1, 3, 10):
        shape = chain(2, stiffness=actuator.stiffness * factor)
        q = curve(shape, QUASISTATIC_PHYSICS, w)
        try:
            p = curve(shape, FAST_PHYSICS, w)
        except Exception as exc:  # an unstable setting is a result here, not a crash of the benchmark
            lines.append(f"| {actuator.stiffness * factor:g} | unstable ({type(exc).__name__}) | | "
                         f"{rms(q, rigid):.2f} | | {q.max():+.2f} |")
            continue
        ok = np.all(np.isfinite(p)) and np.abs(p).max() < 50
        lines.append(f"| {actuator.stiffness * factor:g} | {rms(p, q):.2f} | {rms(p, rigid):.2f} | "
                     f"{rms(q, rigid):.2f} | {p.max():+.2f}{'' if ok else ' (unstable)'} | {q.max():+.2f} |")
    lines.append(f"\nRigid limit (quasi-static, 10^7 N/m): {fmt(rigid[::2])} at dphi_2 = 0, 0.1, ..., 0.9.")

    lines += ["", "## Invariants (ideal sensor, no noise)", "",
              "| check | PyBullet fast | quasi-static | target |", "|---|---|---|---|"]
    phases1 = (0.0, 0.25, 0.5, 0.75)
    for name, fn, target in (
        ("a unit and a dummy alone, max |U| over phases 0, 0.25, 0.5, 0.75",
         lambda ph: max(abs(velocity_at(chain(1), [p], physics=ph, cycles=CYCLES)[0]) for p in phases1), "<= 0.1"),
        *((f"chain-{n} at equal phases, |Ubar|",
           (lambda n: lambda ph: abs(velocity_at(chain(n), np.zeros(n), physics=ph, cycles=CYCLES).mean()))(n),
           "<= 0.2") for n in (2, 3, 7)),
    ):
        lines.append(f"| {name} | {fn(FAST_PHYSICS):.3f} | {fn(QUASISTATIC_PHYSICS):.3f} | {target} |")
    equal = {name: curve(chain(2, dummy_friction=chain2.bodies[0].friction), ph, w)
             for name, ph in (("PyBullet fast", FAST_PHYSICS), ("quasi-static", QUASISTATIC_PHYSICS))}
    mirror = {name: float(np.abs(c[1:] + c[1:][::-1]).max()) for name, c in equal.items()}
    lines.append(f"| equal friction everywhere, max |U(d) + U(1 - d)| over the curve | {mirror['PyBullet fast']:.2f} | "
                 f"{mirror['quasi-static']:.2f} | <= 0.3 |")
    for shape, phases in ((chain2, (0, 0.4)), (chain2, (0, 0.6)), (chain2, (0, 0.8)), (chain3, (0, 0.4, 0.8))):
        (m_d, s_d), (m_q, s_q) = (spread(shape, phases, ph) for ph in (FAST_PHYSICS, QUASISTATIC_PHYSICS))
        lines.append(f"| std of 2-cycle Ubar over 30 steps at {phases} (mean) | {s_d:.3f} ({m_d:+.2f}) | "
                     f"{s_q:.3f} ({m_q:+.2f}) | <= 0.15 |")

    lines += plane_section()
    lines += friction_section(w)
    lines += ["", "## The paper's first result (S1)", "",
              "chain-2, Thermal, default parameters, seeds 0-31, 100 learning steps. Reach: the first step whose "
              "true Ubar is at least 0.8 of the quasi-static scan's peak "
              f"({peak:+.2f} mm/cycle); hold: mean true Ubar over steps 50-100 over that peak. The protocol row "
              "says how many cycles are run after each phase change before the 2-cycle measurement starts "
              "(`discard_cycles`).", "",
              "| backend | sensor | discard_cycles | median steps to reach | runs reaching by step 60 | hold "
              "| target |",
              "|---|---|---|---|---|---|---|"]
    default_lp = LearnerParams()
    protocols = sorted({default_lp.discard_cycles, 0, 1})
    for name, physics in (("default (quasi-static)", DEFAULT_PHYSICS), ("PyBullet fast", FAST_PHYSICS)):
        for discard in protocols:
            r = s1(chain2, physics, peak, w, learner_params=dataclasses.replace(default_lp, discard_cycles=discard))
            default_mark = " (default)" if discard == default_lp.discard_cycles else ""
            lines.append(f"| {name} | ideal | {discard}{default_mark} | {r['median']:.1f} | {r['by60']} of "
                         f"{r['seeds']} | {r['hold']:.2f} | <= 20, >= 30, >= 0.5 |")
    r = s1(chain2, DEFAULT_PHYSICS, peak, w, seeds=8, sensor="optical")
    lines.append(f"| default (quasi-static) | optical | {default_lp.discard_cycles} (default) | {r['median']:.1f} | "
                 f"{r['by60']} of {r['seeds']} | {r['hold']:.2f} | all 8 by step 60 |")
    lines += ["", "## Temperature", "",
              "The paper's rule (Fig. 2B; docs/paper.md): a noiseless 3-unit Thermal run accepts about 25% of trials "
              "once learned (chain-3, default physics, ideal sensor, seeds 0-15, 300 steps, acceptance and true Ubar "
              "over steps 150-300).",
              "", "| T (mm/cycle) | acceptance | Ubar |", "|---|---|---|"]
    for temperature in sorted({0.25, 0.5, default_lp.temperature, 0.7, 1.0}):
        lp = dataclasses.replace(default_lp, temperature=temperature)
        jobs = [RunConfig(shape=chain3, learner_params=lp, sensor=SensorParams(kind="ideal"), steps=300, seed=seed)
                for seed in range(16)]
        with ProcessPoolExecutor(w) as pool:
            tables = list(pool.map(_steps, jobs))
        mark = " (default)" if temperature == default_lp.temperature else ""
        lines.append(f"| {temperature}{mark} | {np.mean([t.acceptance.iloc[150:].mean() for t in tables]):.2f} | "
                     f"{np.mean([t.ubar_true.iloc[150:].mean() for t in tables]):+.2f} |")
    lines += ["", f"Benchmark wall time: {time.perf_counter() - started:.0f} s.", ""]
    write_page(Path(args.out), lines)
    print("\n".join(lines))


def write_page(out: Path, lines: list[str]) -> Path:
    """``out`` rewritten with ``lines``, its sections from KEPT_FROM on kept as they are (another script's)."""
    kept = out.read_text(encoding="utf-8") if out.is_file() else ""
    kept = kept[kept.index(KEPT_FROM):] if KEPT_FROM in kept else ""
    return write_text(out, "\n".join(lines) + ("\n" + kept if kept else ""))


if __name__ == "__main__":
    main()
