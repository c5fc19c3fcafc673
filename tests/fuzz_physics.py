"""Extreme but valid physics, generated: run files whose every number is inside its declared range, pushed to the
ends of it, on both backends. tests/fuzzing.py's cases mutate files into bad input; these stay valid input, so the
promise is about what comes out.

A case is ``morphbench run FILE --steps 2`` of a chain, a grid or a ring with 1 to 4 parameters drawn from the ends
of their ranges (stiffness, stroke, pressure time constants, masses, friction, friction scale, vibration, noise, the
timestep) on ``quasistatic``, ``fast`` or the default physics. Promise: either the run is refused in one line (exit
2: a parameter outside what the backend can answer for, a PhysicsError at a step), or it finishes with every recorded
velocity finite and below what the bellows can reach (``garbage`` otherwise: a run that passed its validity checks
with a result no physics gives).

    import fuzz_physics
    for case in fuzz_physics.random_cases(20, seed=0):
        outcome = fuzz_physics.run_case(case, workdir)   # outcome.verdict
"""

from __future__ import annotations

import json
import math
import random
from pathlib import Path

import fuzzing
from fuzzing import Case, Outcome

ROOT = Path(__file__).resolve().parents[1]
SHAPES = ("chain-2", "chain-3", "chain-7", "grid-2x2", "ring-8")
PHYSICS = ("quasistatic", "fast", "default")
EXTREMES = {
    ("actuator", "stiffness"): [1e-3, 0.1, 5.0, 3e3, 1e5, 1e7],
    ("actuator", "stroke"): [1e-4, 1e-3, 0.03, 0.05, 0.1],
    ("actuator", "tau_inflate"): [1e-3, 0.01, 5.0, 100.0],
    ("actuator", "tau_vent"): [1e-3, 0.01, 5.0, 100.0],
    ("actuator", "max_force"): [1e-3, 0.05, 100.0, 1e3],
    ("actuator", "damping"): [1e-6, 1e-3, 50.0, 1e3],
    ("actuator", "alpha"): [0.01, 0.05, 0.95, 0.99],
    ("unit", "mass"): [1e-3, 0.01, 2.0, 10.0],
    ("unit", "friction"): [0.0, 1e-3, 2.0, 10.0],
    ("dummy", "friction"): [0.0, 1e-3, 5.0, 10.0],
    ("dummy", "mass"): [1e-3, 10.0],
    ("environment", "friction_scale"): [1e-6, 0.05, 0.2, 5.0, 100.0],
    ("environment", "vibration"): [1e-3, 0.1, 5.0, 10.0],
    ("environment", "noise"): [0.0, 100.0, 1000.0],
    ("physics", "timestep"): [1e-3, 0.02, 0.05],
}
"""Values at or near the ends of each parameter's declared range (morphbench.params)."""
SHAPE_SECTIONS = ("actuator", "unit", "dummy")
"""Sections that belong to the morphology (the rest to the run file)."""


def _value(v) -> str:
    return repr(v) if isinstance(v, float) else str(v)


def physics_case(rng: random.Random) -> Case:
    shape = rng.choice(SHAPES)
    physics = rng.choice(PHYSICS)
    chosen = rng.sample(sorted(EXTREMES), rng.randint(1, 4))
    values = {key: rng.choice(EXTREMES[key]) for key in chosen}
    base = (ROOT / "shapes" / f"{shape}.toml").read_text()
    sections: dict[str, list[str]] = {}
    for (section, name), v in values.items():
        if section in SHAPE_SECTIONS:
            sections.setdefault(section, []).append(f"{name} = {_value(v)}\n")
    shape_text = base
    for section, lines in sections.items():  # into the library file's own section if it has one, else a new one
        header = f"[{section}]\n"
        shape_text = (shape_text.replace(header, header + "".join(lines), 1) if header in shape_text
                      else shape_text + "\n" + header + "".join(lines))
    run = {section: {} for section in ("environment", "physics")}
    for (section, name), v in values.items():
        if section in run:
            run[section][name] = v
    if physics != "default":
        run["physics"]["preset"] = physics
    text = 'shape = "shape.toml"\nsteps = 2\n[sensor]\nkind = "ideal"\n' + "".join(
        f"[{section}]\n" + "".join(f"{k} = {_value(v) if not isinstance(v, str) else repr(v)}\n" for k, v in
                                   table.items()) for section, table in run.items() if table)
    what = ", ".join(f"{section}.{name} = {v:g}" for (section, name), v in values.items())
    return Case("physics", physics, f"{shape}: {what}", ["run", "{in}", "--quiet", "--out", "{out}"],
                data=text.replace("'", '"').encode(), extra={"shape.toml": shape_text.encode()})


def random_cases(n: int, seed: int) -> list[Case]:
    rng = random.Random(f"physics-{seed}")
    return [physics_case(rng) for _ in range(n)]


def run_case(case: Case, workdir: Path, timeout_s: float = fuzzing.TIMEOUT_S) -> Outcome:
    """``fuzzing.run_case``, then an accepted run's records checked: every velocity finite and below what the
    bellows can reach (3 strokes per cycle, the validity check's own bound, with the noise on the measured one)."""
    outcome = fuzzing.run_case(case, workdir, timeout_s)
    if outcome.verdict == "accepted":
        outcome.verdict = _garbage(workdir / "out") or "accepted"
    return outcome


def _garbage(out: Path) -> str | None:
    import pandas as pd

    summary = json.loads((out / "summary.json").read_text())
    config = summary["config"]
    shape_file = Path(config["shape"]["source"])
    stroke_mm = 1000 * _stroke(shape_file)
    units = pd.read_parquet(out / "units.parquet")
    true = units.u_true.dropna().abs()
    if not all(math.isfinite(v) for v in true):
        return "garbage: a true velocity that is not finite"
    if len(true) and true.max() > 3 * stroke_mm + 1e-9:
        return f"garbage: a unit at {true.max():.3g} mm/cycle, beyond 3 strokes of {stroke_mm:g} mm a cycle"
    return None


def _stroke(shape_file: Path) -> float:
    from morphbench.shapes.loader import load_shape

    return load_shape(shape_file).actuator.stroke
