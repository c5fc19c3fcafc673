"""morphbench: a PyBullet testbed for robotic matter.

Data flow: shape file -> assembly in a world -> sensors -> learners -> records -> metrics and plots.

Importing the package is cheap (no simulator, numpy or pandas): the command line starts fast, and each command imports
what it uses.
"""

from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

try:
    __version__ = version("morphbench")  # pyproject.toml is the one place the version is written
except PackageNotFoundError:  # a source tree on sys.path that was never installed
    __version__ = "unknown"

_HERE = Path(__file__).resolve().parent


def data_path(kind: str) -> Path:
    """The shipped ``shapes``, ``examples`` or ``benchmarks`` directory: ``morphbench/data/KIND`` in an installed
    wheel, the top-level ``KIND/`` of a source checkout (an editable install)."""
    installed = _HERE / "data" / kind
    return installed if installed.is_dir() else _HERE.parent / kind
