"""How an exception is told in one line, wherever the project reports one (a failed job, a bad plug-in or mesh)."""

from __future__ import annotations

import traceback


def describe(exc: BaseException, where: bool = True) -> str:
    """One line: the exception's type and message and, if ``where``, where it was raised (the innermost frame)."""
    text = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
    text = " ".join(text.split())
    frames = traceback.extract_tb(exc.__traceback__) if where else []
    if frames:
        last = frames[-1]
        text += f" (in {last.name}, {last.filename.rsplit('/', 1)[-1]}:{last.lineno})"
    return text
