"""The one error type for bad input: it names where the input came from, the key and what was expected."""

from __future__ import annotations


class ConfigError(Exception):
    """Bad input from a file, the command line or a plug-in. The CLI prints it on one line and exits with 2."""

    def __init__(self, source: str, key: str, expected: str, got: object = ...):
        self.source, self.key, self.expected, self.got = str(source), key, expected, got
        message = f"{self.source}: {key}: expected {expected}"
        if got is not ...:
            message += f", got {got!r}"
        # one printable line, whatever a path or name in it holds
        super().__init__(message.replace("\r", "\\r").replace("\n", "\\n").replace("\0", "\\0"))


def require_integer(value: object, source: str, key: str, low: float, high: float = float("inf"),
                    expected: str | None = None) -> int:
    """``value`` if it is an integer (not a bool) in [low, high]; else ConfigError (by default 'an integer >= low')."""
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise ConfigError(source, key, expected or f"an integer >= {low:g}", value)
    return value


class PluginError(ConfigError):
    """A plug-in learner that raised, or returned or kept something unusable, during a run: named by its spec
    (``--learner``), the method and the unit. A ConfigError, so the CLI prints it on one line and exits with 2."""

    def __init__(self, spec: str, method: str, expected: str, got: object = ...):
        if got is not ...:
            # a plug-in's value may be anything: its repr is kept to one short line
            shown = " ".join(repr(got).split())
            expected += f", got {shown if len(shown) <= 80 else shown[:77] + '...'}"
        super().__init__("--learner", spec, f"{method} {expected}")
        self.method, self.got = method, got


class PhysicsError(Exception):
    """A run whose physics left the model's validity (a pose not finite, a body tipped over, launched or moving faster
    than its bellows can push it): which body, what and at which learning step, on one line. The CLI exits with 2."""

    def __init__(self, source: str, step: int, body: str, what: str):
        self.source, self.step, self.body, self.what = source, step, body, what
        super().__init__(f"{source}: physics left the model's validity at learning step {step}: {body} {what}")


class ActionError(ValueError):
    """An environment action that is not what the action space takes (morphbench.envs): named by its agent (or
    ``action`` of the central environment) and the space expected, on one line."""

    def __init__(self, source: str, agent: str, expected: str, got: object = ...):
        self.agent, self.expected, self.got = agent, expected, got
        message = f"{source}: {agent}: expected {expected}"
        if got is not ...:
            shown = " ".join(repr(got).split())  # an action may be anything: one short line
            message += f", got {shown if len(shown) <= 80 else shown[:77] + '...'}"
        super().__init__(message)


class EpisodeOver(RuntimeError):
    """``step()`` of an environment whose episode has ended (its last step, no agent left alive, or a PhysicsError):
    says which, and that ``reset()`` starts the next one."""
