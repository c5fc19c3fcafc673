"""What software and machine results came from: the versions a bench ran with, recorded in ``DIR/environment.json``.

``record_session`` (called by ``run_suite`` after its jobs ran) appends one entry per bench that ran jobs into the
directory: when it started and ended, how many jobs it ran, on which executor, the machine, and
``software_versions()`` of the process that ran the bench (a Dask cluster's workers could have others).
``software_versions()`` reads installed metadata only: it imports none of the packages it lists.
"""

from __future__ import annotations

import json
import os
import platform
import time
from importlib import metadata
from pathlib import Path

from morphbench.files import write_text

ENVIRONMENT = "environment.json"
PACKAGES = (("numpy",), ("pybullet",), ("opencv-python-headless", "opencv-python", "opencv-contrib-python",
                                          "opencv-contrib-python-headless"),
            ("pandas",), ("pyarrow",), ("matplotlib",), ("numba",), ("trimesh",), ("av",), ("markdown-it-py",),
            ("tqdm",), ("cma",), ("dask",), ("pettingzoo",), ("gymnasium",))
"""The distributions whose versions are listed (each a tuple of alternative names: the first installed counts)."""


def software_versions() -> dict[str, str]:
    """{name: version} of morphbench, Python and the installed distributions of PACKAGES, in that order."""
    from morphbench import __version__

    versions = {"morphbench": __version__,
                "Python": f"{platform.python_version()} ({platform.python_implementation()})"}
    for names in PACKAGES:
        for name in names:
            try:
                versions[name] = metadata.version(name)
                break
            except metadata.PackageNotFoundError:
                continue
    return versions


def machine() -> str:
    """The operating system, its release, the architecture and the number of CPUs, in one line."""
    return f"{platform.system()} {platform.release()} {platform.machine()}, {os.cpu_count()} CPUs"


def record_session(root: str | Path, started: float, executor: str, done: int, failed: int) -> Path:
    """Append this bench's entry to ``root/environment.json`` (``started``: its ``time.time()``; ``executor``: what
    ran the jobs); returns the file's path."""
    path = Path(root) / ENVIRONMENT
    sessions = read_sessions(root)
    sessions.append({"started": _stamp(started), "finished": _stamp(time.time()), "jobs": done + failed,
                     "failed": failed, "executor": executor, "machine": machine(), "versions": software_versions()})
    write_text(path, json.dumps(sessions, indent=1) + "\n")
    return path


def read_sessions(root: str | Path) -> list[dict]:
    """The entries of ``root/environment.json`` (none if the file is missing or unreadable)."""
    try:
        sessions = json.loads((Path(root) / ENVIRONMENT).read_text())
    except (OSError, ValueError):
        return []
    return [s for s in sessions if isinstance(s, dict)] if isinstance(sessions, list) else []


def _stamp(seconds: float) -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%S%z", time.localtime(seconds))
