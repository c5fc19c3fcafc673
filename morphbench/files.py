"""Reading and writing the project's files (standard library only, so any module may use it).

A file written through ``atomic_write`` (or a ``Replacement``, for a file written over time like a video) is written
under a temporary name in its own directory and renamed onto its name, so a reader sees the old file or the new one,
never half of one, and a killed process leaves only a ``.NAME.tmp-PID`` file behind (which ``bench.store`` clears). TOML files are read by ``read_toml``, with one message for each way a file can be bad.
"""

from __future__ import annotations

import os
import tomllib
from pathlib import Path
from typing import Any, Callable

from morphbench.errors import ConfigError


class Replacement:
    """A temporary name ``tmp`` beside ``path``, renamed onto it by ``commit()`` or removed by ``discard()``.

    As a context manager it gives ``tmp`` and, when the block ends, commits if nothing was raised; either way no
    temporary file is left. ``tmp`` keeps ``path``'s suffix: matplotlib and OpenCV pick the format from it.
    """

    def __init__(self, path: str | os.PathLike):
        self.path = Path(path)
        self.tmp = self.path.with_name(f".{self.path.name}.tmp-{os.getpid()}{self.path.suffix}")

    def commit(self) -> Path:
        os.replace(self.tmp, self.path)
        return self.path

    def discard(self) -> None:
        self.tmp.unlink(missing_ok=True)

    def __enter__(self) -> Path:
        return self.tmp

    def __exit__(self, exc_type, exc, traceback) -> None:
        try:
            if exc_type is None:
                self.commit()
        finally:
            self.discard()


def atomic_write(path: str | os.PathLike, write: Callable[[Path], object]) -> Path:
    """Call ``write(tmp_path)``, then rename the result onto ``path`` (its directory is created if need be)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with Replacement(path) as tmp:
        write(tmp)
    return path


def write_text(path: str | os.PathLike, text: str) -> Path:
    """``text`` as UTF-8 into ``path``, atomically."""
    return atomic_write(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


def write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """``data`` into ``path``, atomically."""
    return atomic_write(path, lambda tmp: tmp.write_bytes(data))


def read_toml(path: Path, what: str) -> dict[str, Any]:
    """A TOML file's table; a missing, unreadable or malformed file is a ConfigError naming it (``what`` says what
    the file should be, e.g. 'morphology file')."""
    return read_toml_with_text(path, what)[0]


def read_toml_with_text(path: Path, what: str) -> tuple[dict[str, Any], str]:
    """``read_toml``'s table and the text it was parsed from (for a copy of the file as it was read)."""
    try:
        text = path.read_text(encoding="utf-8")  # TOML is UTF-8 whatever the locale
    except FileNotFoundError:
        raise ConfigError(path, "(file)", f"an existing {what} (.toml)") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(path, "(file)", f"a readable UTF-8 TOML file ({exc})") from None
    try:
        return tomllib.loads(text), text
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(path, "(syntax)", f"valid TOML ({exc})") from None
