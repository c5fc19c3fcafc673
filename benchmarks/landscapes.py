"""What S5's and S6's changes do to the 3-unit landscape: where its best gait goes and what the old one gives.

    python benchmarks/landscapes.py [--resolution 20]

The 3-unit landscape (chain-3, unit 1 at phase 0, Ubar over (dphi_2, dphi_3), default physics) intact and after each
change the paper suite's S5, S5-uniform and S6 make, and the alternatives docs/paper.md ("S5 and S6") weighs: every
body's friction x0.6 (S5-uniform), the passive dummy's x0.5 (S5), unit 2's bellows unable to inflate but as stiff as
one holding air (`no-inflate`), and open to the air (`open`, S6). For each: the best gait and where, and the intact
optimum's Ubar after the change (how far Thermal's memory is left behind). Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

from morphbench.experiment.events import DamageEvent
from morphbench.experiment.scan import scan
from morphbench.params import EnvironmentParams
from morphbench.shapes.loader import load_shape

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--resolution", type=int, default=20)
    args = parser.parse_args(argv)
    shape = load_shape(ROOT / "shapes" / "chain-3.toml")
    dummy = len(shape.bodies) - 1
    slick_dummy = dataclasses.replace(shape, bodies=tuple(
        dataclasses.replace(body, friction=body.friction * 0.5) if i == dummy else body
        for i, body in enumerate(shape.bodies)))
    changes = {
        "intact": dict(shape=shape),
        "every body's friction x0.6 (S5-uniform)": dict(shape=shape, environment=EnvironmentParams(friction_scale=0.6)),
        "the dummy's friction x0.5 (S5)": dict(shape=slick_dummy),
        "unit 2 no-inflate": dict(shape=shape, damage=DamageEvent(step=0, unit=2, mode="no-inflate")),
        "unit 2 open, its needle removed (S6)": dict(shape=shape, damage=DamageEvent(step=0, unit=2, mode="open")),
    }
    print("| landscape | best gait (mm/cycle) | at (dphi_2, dphi_3) | the intact optimum's Ubar |")
    print("|---|---|---|---|")
    optimum = None
    for name, change in changes.items():
        table = scan(change.pop("shape"), args.resolution, **change)
        best = table.loc[table.ubar.idxmax()]
        optimum = table.ubar.idxmax() if optimum is None else optimum
        print(f"| {name} | {best.ubar:+.2f} | ({best.dphi_2:.2f}, {best.dphi_3:.2f}) | {table.ubar[optimum]:+.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
