"""The front page's pictures (README.md), made by morphbench itself: `python docs/make_media.py` rewrites
docs/media/chain-3.gif (chain-3 finding its gait: its first 30 learning steps, 2 minutes of simulated time played in
6 s) and docs/media/learning-curve.png (the same run's learning curve). Deterministic: the same files every time.

Off-screen (PyBullet's TinyRenderer); about 10 s on one core. ``--out DIR`` and ``--steps N`` (a shorter run, for the
tests) write elsewhere.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
from pathlib import Path

from morphbench import cli

MEDIA = Path(__file__).resolve().parent / "media"
GIF, CURVE = "chain-3.gif", "learning-curve.png"
"""the files README.md shows."""
SEED = 2
"""a seed whose chain finds its gait (Ubar above +3 mm/cycle) within the video's 30 steps."""
VIDEO = ["--video-width", "400", "--video-height", "224", "--video-fps", "10", "--video-speed", "30"]
"""small frames at 10 frames per second: a GIF of about 1 MB; 30 simulated seconds per video second."""


def make_media(out: Path = MEDIA, steps: int = 40) -> list[Path]:
    """Run chain-3 (Thermal, optical sensors, the default physics) for ``steps`` learning steps with a video of the
    first 30; write the GIF and the learning curve into ``out``; return their paths."""
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        run_dir = Path(tmp) / "run"
        code = cli.main(["run", "chain-3", "--learner", "thermal", "--steps", str(steps), "--seed", str(SEED),
                         "--quiet", "--out", str(run_dir), "--video", str(out / GIF), *VIDEO,
                         "--video-steps", f"0:{min(30, steps)}"])
        if code:
            raise SystemExit(code)
        shutil.copyfile(run_dir / "learning_curve.png", out / CURVE)
    return [out / GIF, out / CURVE]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=MEDIA, help="directory to write into (default docs/media)")
    parser.add_argument("--steps", type=int, default=40, help="learning steps of the run (default 40)")
    args = parser.parse_args(argv)
    for path in make_media(args.out, args.steps):
        print(f"{path} ({path.stat().st_size / 1000:.0f} kB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
