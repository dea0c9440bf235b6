"""Names a user types that become file names (levels, profiles, task files).

A level's name becomes ``levels/NAME.json``, ``results/levels/NAME.png`` and
``tasks/NAME-<count>-<hash>.json``; a profile's name becomes results paths. A name that held
``/``, ``..`` or an absolute path would write outside the project, so every such name must pass
:func:`check_name` before it is joined to a path. The rule is one short, portable pattern:
1-64 characters of ASCII letters, digits, ``_``, ``.`` and ``-``, starting with a letter or digit,
and no ``..`` anywhere.
"""

from __future__ import annotations

import re

from navbench.errors import ConfigError, NavbenchError

#: The safe-name pattern (see the module docstring).
SAFE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")
#: The rule in words, for error messages.
SAFE_NAME_RULE = ("1-64 characters of letters, digits, '_', '.' and '-', starting with a letter "
                  "or digit, without '..'")


def is_safe_name(name) -> bool:
    """True when ``name`` is a string matching :data:`SAFE_NAME` without ``..``."""
    return isinstance(name, str) and SAFE_NAME.fullmatch(name) is not None and ".." not in name


def check_name(kind: str, name, error: type[NavbenchError] = ConfigError) -> str:
    """Return ``name`` if it is safe to use as a file name, else raise ``error``.

    ``kind`` says what the name is and where it came from, and starts the message, e.g.
    ``check_name("level name", "../x")`` raises ``ConfigError("level name '../x' is not a safe
    name (...)")`` and ``check_name("levels/a.json: name", ..., LevelError)`` names the file and
    the field.
    """
    if not is_safe_name(name):
        raise error(f"{kind} {name!r} is not a safe name ({SAFE_NAME_RULE})")
    return name


def did_you_mean(name, known) -> str:
    """``" (did you mean 'house-1'?)"`` when ``known`` holds names close to ``name`` (difflib,
    at most three), else ``""``; for the message of an unknown level, profile, estimator or preset."""
    import difflib

    if not isinstance(name, str):
        return ""
    close = difflib.get_close_matches(name, [str(k) for k in known], n=3, cutoff=0.6)
    if not close:
        return ""
    return f" (did you mean {' or '.join(repr(c) for c in close)}?)"
