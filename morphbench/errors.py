"""The one error type for bad input: it names where the input came from, the key and what was expected."""

from __future__ import annotations


class ConfigError(Exception):
    """Bad input from a file, the command line or a plug-in. The CLI prints it on one line and exits with 2."""

    def __init__(self, source: str, key: str, expected: str, got: object = ...):
        self.source, self.key, self.expected, self.got = str(source), key, expected, got
        message = f"{self.source}: {key}: expected {expected}"
        if got is not ...:
            message += f", got {got!r}"
        super().__init__(message)
