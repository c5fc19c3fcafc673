"""Reading and writing the project's files (standard library only, so any module may use it).

A file written through ``atomic_write`` (or a ``Replacement``, for a file written over time like a video) is written
under a temporary name in its own directory and renamed onto its name, so a reader sees the old file or the new one,
never half of one, and a killed process leaves only a ``.NAME.tmp-PID`` file behind (which ``bench.store`` clears
once ``is_stale`` says its process is gone). A directory of files that belong together (a run) is written whole by
``replace_directory``. A directory that one process at a time may write (a suite's results) is held by
``directory_lock``. TOML files are read by ``read_toml``, with one message for each way a file can be bad; a
document's generated section is rewritten by ``replace_section``.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import fcntl
import json
import os
import re
import shlex
import shutil
import socket
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


def _temporary_directory(path: Path) -> Path:
    """The hidden directory beside ``path`` that ``replace_directory`` writes into (``is_stale`` knows its name)."""
    return path.with_name(f".{path.name}.tmp-{os.getpid()}")


def try_replace_directory(path: str | os.PathLike) -> None:
    """Make what ``replace_directory(path, ...)`` makes first (the missing parents of ``path``, its temporary
    directory, a file in it) and remove it all again; the OSError the file system gives if it cannot. The access
    bits say yes where the file system says no (root in /proc, a read-only mount): work found unwritable only after
    it is done is lost."""
    target = Path(os.path.abspath(path))
    made: list[Path] = []
    try:
        for parent in reversed(target.parents):
            if not parent.exists():
                parent.mkdir()
                made.append(parent)
        probe = _temporary_directory(target)  # one left by a killed process of this id is the writer's to clear
        probe.mkdir(exist_ok=True)
        made.append(probe)
        (probe / "summary.json").write_bytes(b"{}")
        made.append(probe / "summary.json")
    finally:
        for made_path in reversed(made):  # the file, the temporary, then the parents, deepest first
            try:
                if made_path.is_dir():
                    made_path.rmdir()
                else:
                    made_path.unlink()
            except OSError:
                pass


def replace_directory(path: str | os.PathLike, write: Callable[[Path], object]) -> Path:
    """Call ``write(tmp)`` on a new directory beside ``path``, then swap it in for ``path`` whole and remove the old
    one: whatever happens, ``path`` holds the old directory (or nothing, if there was none) or the new one complete,
    never a mix. The swap is one atomic exchange where the system has it (Linux), else two renames with Ctrl-C held
    off in between; Ctrl-C before it leaves ``path`` as it was. A killed process leaves at most a hidden
    ``.NAME.tmp-PID`` directory beside ``path`` (or, killed between the two renames, the old one as
    ``.NAME.old-PID``)."""
    given, path = Path(path), Path(os.path.abspath(path))
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = _temporary_directory(path)
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


LOCK = ".lock"
"""The lock file of a directory held by ``directory_lock``."""
_held: dict[str, tuple[int, int]] = {}
"""The locks this process holds: lock path -> (file descriptor, depth)."""


@contextmanager
def directory_lock(directory: str | os.PathLike, source: str = "--out"):
    """Hold ``directory`` (which must exist) for this process: an exclusive ``flock`` on ``directory/.lock``, whose
    text says who holds it (pid, host, command). Held again by the same process, it nests. Held by another process,
    it is a ConfigError naming ``source``, the directory and that process. The kernel drops the lock when the process
    ends, however it ends, so a killed holder leaves no stale lock; the file itself stays (removing it would let a
    second process lock a new file while a third still holds the old one)."""
    path = os.path.join(os.path.realpath(directory), LOCK)
    if path in _held:
        fd, depth = _held[path]
        _held[path] = fd, depth + 1
        try:
            yield
        finally:
            _held[path] = fd, depth
        return
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
    except OSError as exc:
        raise ConfigError(source, str(directory), f"a directory this process can write ({exc.strerror})") from None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError as exc:
        holder = _lock_holder(fd) if isinstance(exc, BlockingIOError) else f"its lock failed: {exc.strerror}"
        os.close(fd)
        raise ConfigError(source, str(directory), f"a directory no other process is writing ({holder})") from None
    try:
        me = {"pid": os.getpid(), "host": socket.gethostname(), "command": _command_line()}
        os.ftruncate(fd, 0)
        os.pwrite(fd, (json.dumps(me) + "\n").encode(), 0)
        _held[path] = fd, 1
        yield
    finally:
        _held.pop(path, None)
        os.ftruncate(fd, 0)  # before the lock goes: the next holder writes its own
        os.close(fd)


def _lock_holder(fd: int) -> str:
    """Who holds a lock, as its file says (the holder writes it just after locking: it may not have yet)."""
    try:
        holder = json.loads(os.pread(fd, 4096, 0))
        command = " ".join(str(holder["command"]).split())
        command = command if len(command) <= 300 else command[:297] + "..."
        return f"process {int(holder['pid'])} on {holder['host']} holds it: {command}"
    except (OSError, ValueError, KeyError, TypeError):
        return f"another process holds its {LOCK}"


def _command_line() -> str:
    """This process's command line as typed (``python -m morphbench.cli bench ...``), or as sys.argv has it."""
    try:
        words = Path("/proc/self/cmdline").read_bytes().split(b"\0")[:-1]
        return shlex.join(os.fsdecode(word) for word in words)
    except OSError:
        return shlex.join([sys.executable, *sys.argv])


_TEMPORARY = re.compile(r"\.(?:.*[.-])?(?:tmp|old)-(?:.*-)?(\d+)(?:\.\w+)?")
"""The names temporaries get: ``.NAME.tmp-PID[.SUFFIX]``, ``.NAME.old-PID`` (above) and bench.store's
``.tmp-JOB-PID``, ``.tmp-old-JOB-PID``; group 1 is the writing process's id."""


def is_stale(path: str | os.PathLike) -> bool:
    """Whether ``path`` is a temporary (by its name) that no running process is writing: its process has ended, or it
    is this process's own, left by an earlier process of the same id (call it before writing anything). A temporary
    of another running process, or a name that is no temporary's, is not stale."""
    match = _TEMPORARY.fullmatch(Path(path).name)
    if match is None:
        return False
    pid = int(match.group(1))
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except PermissionError:  # another user's process
        return False
    except (ProcessLookupError, OverflowError):  # ended; an id beyond any, which ``kill`` refuses
        return True
    return False


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


def present(path: str | os.PathLike) -> bool:
    """Whether anything is at ``path`` (a file, a directory, a symlink even if broken). Where ``os.path.lexists``
    says False, a path this process may not look at (a directory above it it may not search) raises
    PermissionError: a directory it may not read is not an empty one."""
    try:
        os.lstat(path)
    except (FileNotFoundError, NotADirectoryError):
        return False
    return True


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


def check_section(path: str | os.PathLike, begin: str, end: str) -> str:
    """The text of ``path``; a ConfigError naming the file unless it holds both markers of a generated section (a
    script checks before it spends minutes measuring what it would write there)."""
    text = Path(path).read_text(encoding="utf-8") if Path(path).is_file() else ""
    if begin not in text or end not in text:
        raise ConfigError(path, "(file)", f"the generated-section markers {begin} and {end}")
    return text


def write_section(path: str | os.PathLike, begin: str, end: str, lines: list[str], footer: str) -> Path:
    """``replace_section`` with a section of ``lines`` then ``footer`` (how it was generated), set off by blank
    lines."""
    return replace_section(path, begin, end, "\n".join(["", "", *lines, "", footer, "", ""]))


def replace_section(path: str | os.PathLike, begin: str, end: str, section: str) -> Path:
    """Rewrite, atomically, the text between the markers ``begin`` and ``end`` of ``path`` (a document's generated
    section; the markers and the rest are kept); a ConfigError naming the file if a marker is missing."""
    head, rest = check_section(path, begin, end).split(begin, 1)
    return write_text(path, head + begin + section + end + rest.split(end, 1)[1])
