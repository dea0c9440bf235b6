"""The navbench exception family.

Errors a user can cause (bad files, unreachable tasks, corrupt caches, bad options) derive from
:class:`NavbenchError`; the CLI prints them as one line and exits non-zero. Anything else is a
bug and keeps its traceback.
"""


class NavbenchError(Exception):
    """Base class for errors caused by input, not by a bug."""


class LevelError(NavbenchError):
    """A level file is malformed, has an unknown schema version, or fails validation."""


class ConfigError(NavbenchError):
    """A stage configuration or profile is invalid."""


class ArtifactError(NavbenchError):
    """A cached artifact or view collection is missing, truncated, corrupt or mismatched."""


class TaskError(NavbenchError):
    """A task or task set is malformed or infeasible (for example unreachable)."""


class PlanningError(NavbenchError):
    """Planning failed in a way the caller must hear about (not 'no plan', which is an outcome)."""


class TrackingError(NavbenchError):
    """A pose estimator was misused (unknown name, mismatched inputs)."""


class DatabaseError(NavbenchError):
    """The results database is unreachable or inconsistent."""


class PluginError(ConfigError):
    """A plugin (an entry point of another distribution) is broken: it fails to import, clashes
    with a built-in or another plugin, or does not declare what navbench needs."""


def caused_by_interrupt(e: BaseException) -> bool:
    """Whether ``e`` is, or was raised from or while handling, a ``KeyboardInterrupt``: Ctrl-C
    that arrives inside a numba or torch kernel comes back as ``SystemError(... returned a
    result with an exception set)`` chained to it, and is still the user's Ctrl-C."""
    seen = set()
    while e is not None and id(e) not in seen:
        if isinstance(e, KeyboardInterrupt):
            return True
        seen.add(id(e))
        e = e.__cause__ or e.__context__
    return False
