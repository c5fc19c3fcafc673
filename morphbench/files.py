"""Reading and writing the project's files (standard library only, so any module may use it).

A file written through ``atomic_write`` (or a ``Replacement``, for a file written over time like a video) is written
under a temporary name in its own directory and renamed onto its name, so a reader sees the old file or the new one,
never half of one, and a killed process leaves only a ``.NAME.tmp-PID`` file behind (which ``bench.store`` clears).
A directory of files that belong together (a run) is written whole by ``replace_directory``. TOML files are read by
``read_toml``, with one message for each way a file can be bad.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import shutil
import signal
import sys
import threading
import tomllib
from contextlib import contextmanager
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


def replace_directory(path: str | os.PathLike, write: Callable[[Path], object]) -> Path:
    """Call ``write(tmp)`` on a new directory beside ``path``, then swap it in for ``path`` whole and remove the old
    one: whatever happens, ``path`` holds the old directory (or nothing, if there was none) or the new one complete,
    never a mix. The swap is one atomic exchange where the system has it (Linux), else two renames with Ctrl-C held
    off in between; Ctrl-C before it leaves ``path`` as it was. A killed process leaves at most a hidden
    ``.NAME.tmp-PID`` directory beside ``path`` (or, killed between the two renames, the old one as
    ``.NAME.old-PID``)."""
    given, path = Path(path), Path(os.path.abspath(path))
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    shutil.rmtree(tmp, ignore_errors=True)  # a killed earlier process of the same id
    tmp.mkdir()
    try:
        write(tmp)
        with _interrupts_held():
            if not path.exists():
                os.rename(tmp, path)
                return given
            if not _exchange(tmp, path):
                old = path.with_name(f".{path.name}.old-{os.getpid()}")
                os.rename(path, old)
                try:
                    os.rename(tmp, path)
                except OSError:
                    os.rename(old, path)
                    raise
                os.rename(old, tmp)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)  # the new files on failure, the old directory after the swap
    return given


def _exchange(a: Path, b: Path) -> bool:
    """Swap two paths in one step (Linux renameat2 RENAME_EXCHANGE); False where the system or file system lacks it."""
    if not sys.platform.startswith("linux"):
        return False
    libc = ctypes.CDLL(ctypes.util.find_library("c"), use_errno=True)
    if not hasattr(libc, "renameat2"):
        return False
    at_cwd, rename_exchange = -100, 2
    if libc.renameat2(at_cwd, os.fsencode(a), at_cwd, os.fsencode(b), rename_exchange) == 0:
        return True
    return False  # e.g. EINVAL on a file system without exchange: the two renames do it


@contextmanager
def _interrupts_held():
    """The block is a commit: Ctrl-C during it is held off and then dropped, as if it had come just after the
    commit (only the main thread receives it, so elsewhere there is nothing to hold)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        if signal.SIGINT in signal.sigpending():
            signal.sigwait({signal.SIGINT})
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def is_file(path: str | os.PathLike) -> bool:
    """Whether ``path`` names an existing file; False (not an OSError) for a name the file system cannot take."""
    try:
        return Path(path).is_file()
    except (OSError, ValueError):  # a name longer than NAME_MAX, a NUL byte
        return False


def is_dir(path: str | os.PathLike) -> bool:
    """Whether ``path`` names an existing directory; False for a name the file system cannot take."""
    try:
        return Path(path).is_dir()
    except (OSError, ValueError):
        return False


def check_path(text: str, source: str, key: str | None = None, room: int = 0) -> Path:
    """``text`` as a Path if the file system can take it: no NUL byte, each name at most NAME_MAX (less ``room``
    characters for a temporary name made from it) and the whole at most PATH_MAX; else ConfigError naming ``source``
    (the option or file) and ``key`` (default: the path itself)."""
    key = text if key is None else key
    if not text:
        raise ConfigError(source, "''", "a path, not an empty string")
    if "\0" in text:
        raise ConfigError(source, key, "a path without a NUL byte")
    path = Path(text)
    ancestor = os.path.abspath(path)
    while not os.path.exists(ancestor):  # False for a name too long, too
        ancestor = os.path.dirname(ancestor)
    name_max = _pathconf(ancestor, "PC_NAME_MAX", 255) - room
    path_max = _pathconf(ancestor, "PC_PATH_MAX", 4096) - room
    longest = max((len(os.fsencode(part)) for part in path.parts), default=0)
    if longest > name_max or len(os.fsencode(os.path.abspath(path))) >= path_max:
        raise ConfigError(source, key[:80] + ("..." if len(key) > 80 else ""),
                          f"a path whose names are at most {name_max} bytes and that is shorter than {path_max} bytes "
                          "in all (what this file system takes)")
    return path


def _pathconf(path: Path, name: str, default: int) -> int:
    try:
        return os.pathconf(path, name)
    except (OSError, ValueError, AttributeError):  # not a POSIX system, or no such limit here
        return default


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
    except ValueError:  # a NUL byte in the path
        raise ConfigError(path, "(file)", "a path without a NUL byte") from None
    try:
        return tomllib.loads(text), text
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(path, "(syntax)", f"valid TOML ({exc})") from None
    except RecursionError:  # tomllib descends once per level of nested arrays and inline tables
        raise ConfigError(path, "(syntax)",
                          "TOML nested less deeply (arrays or inline tables thousands deep)") from None
