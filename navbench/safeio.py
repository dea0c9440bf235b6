"""Reading what a user names, safely: one loader per format, one place for the limits (issue 34).

Every file navbench reads on a user's word (levels, task sets, profiles, ``intrinsics.json``,
TUM lists, manifests, map and views headers) and every ``-o KEY=VALUE`` value goes through
here, so that one set of rules holds everywhere:

- **Regular files only.** A directory, a FIFO (which would block for ever), a socket or a
  device (``/dev/zero`` never ends) is refused by ``stat`` before anything is opened, and the
  file is opened with ``O_NONBLOCK`` so that a FIFO swapped in after the check cannot block
  either (:func:`check_regular_file`, :func:`read_bytes`).
- **Bounded size.** A text document larger than :data:`MAX_TEXT_BYTES` is refused before it is
  read (a level or task file is kilobytes; validations that are linear on sane input must not
  meet a gigabyte).
- **Bounded nesting.** A document nested deeper than :data:`MAX_DEPTH` is refused, whether the
  parser itself runs out of recursion (``RecursionError`` is caught here) or the parsed value is
  merely deep (checked without recursion by :func:`check_depth`), so no later recursive walk
  (hashing, validation) can exhaust the stack.
- **Finite numbers.** ``NaN``, ``Infinity`` and literals that overflow a float (``1e400``) are
  refused where a user wrote them (``finite=True``), and integers longer than Python's digit
  limit give a message, not a ``ValueError`` traceback.

Each refusal is one line: ``error("<the path the user gave>: <what is wrong>")``, with the
caller's :class:`~navbench.errors.NavbenchError` subclass. Light imports only (the standard
library): the CLI uses this before any heavy module is loaded.
"""

from __future__ import annotations

import errno
import json
import math
import os
import stat
from pathlib import Path
from typing import Any

from navbench.errors import ConfigError, NavbenchError

#: Deepest nesting of lists/objects/tables in any document or option value navbench reads
#: (its own formats need at most 5).
MAX_DEPTH = 64
#: Largest JSON/TOML/text document navbench reads (bytes); its own are kilobytes to a few MB.
MAX_TEXT_BYTES = 64 * 1024 * 1024
#: Longest ``-o`` value (characters).
MAX_OPTION_CHARS = 100_000


def _kind(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a directory"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISSOCK(mode):
        return "a socket"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device file"
    return "not a regular file"


def names_a_file(name_or_path: str, suffix: str = ".json") -> bool:
    """Whether a "name or path" argument is a path: it ends in ``suffix`` or exists and is not
    a folder (a file, a FIFO, ``/dev/zero``). Such an argument is
    then read as a file, and refused as one (:func:`check_regular_file`), instead of being
    judged as a name. (A folder in the working directory that happens to carry a level's name
    does not turn the name into a path.)"""
    p = Path(name_or_path)
    return p.suffix == suffix or ((p.exists() or p.is_symlink()) and not p.is_dir())


def check_regular_file(path: str | Path, error: type[NavbenchError] = NavbenchError,
                       what: str = "file", max_bytes: int | None = None) -> os.stat_result:
    """``os.stat(path)`` when ``path`` is a regular file (symlinks followed) of at most
    ``max_bytes``; else ``error("<path>: ...")`` saying it is missing, a directory, a FIFO, a
    device, or too large. Never opens the file (a FIFO cannot block)."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise error(f"{path}: no such {what}") from None
    except OSError as e:
        raise error(f"{path}: cannot read the {what} ({e.strerror or e})") from None
    if not stat.S_ISREG(st.st_mode):
        raise error(f"{path}: is {_kind(st.st_mode)}, not a {what} (a regular file)")
    if max_bytes is not None and st.st_size > max_bytes:
        raise error(f"{path}: {st.st_size / 1e6:.1f} MB; a {what} may be at most "
                    f"{max_bytes / 1e6:.0f} MB")
    return st


def read_bytes(path: str | Path, error: type[NavbenchError] = NavbenchError, what: str = "file",
               max_bytes: int = MAX_TEXT_BYTES) -> bytes:
    """The bytes of the regular file ``path`` (at most ``max_bytes``), opened with
    ``O_NONBLOCK`` and checked again on the open descriptor; one-line ``error`` otherwise."""
    check_regular_file(path, error, what, max_bytes)
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    except OSError as e:
        raise error(f"{path}: cannot read the {what} ({e.strerror or e})") from None
    try:
        st = os.fstat(fd)  # the path may have been swapped since the stat
        if not stat.S_ISREG(st.st_mode):
            raise error(f"{path}: is {_kind(st.st_mode)}, not a {what} (a regular file)")
        chunks, total = [], 0
        while True:
            try:
                b = os.read(fd, 1 << 20)
            except OSError as e:
                raise error(f"{path}: cannot read the {what} ({e.strerror or e})") from None
            if not b:
                break
            total += len(b)
            if total > max_bytes:
                raise error(f"{path}: more than {max_bytes / 1e6:.0f} MB; a {what} may be at most "
                            f"{max_bytes / 1e6:.0f} MB")
            chunks.append(b)
        return b"".join(chunks)
    finally:
        os.close(fd)


def read_text(path: str | Path, error: type[NavbenchError] = NavbenchError, what: str = "file",
              max_bytes: int = MAX_TEXT_BYTES) -> str:
    """:func:`read_bytes` decoded as UTF-8; a file that is not UTF-8 text is one-line ``error``."""
    data = read_bytes(path, error, what, max_bytes)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise error(f"{path}: not UTF-8 text (byte {e.start})") from None


def check_depth(obj: Any, source: str, error: type[NavbenchError] = NavbenchError,
                max_depth: int = MAX_DEPTH) -> None:
    """``error("<source>: nested more than <max_depth> levels deep")`` when lists/dicts in
    ``obj`` nest deeper than ``max_depth``; iterative, so it cannot itself run out of stack."""
    stack = [(obj, 1)]
    while stack:
        v, d = stack.pop()
        if isinstance(v, (list, tuple, dict)):
            if d > max_depth:
                raise error(f"{source}: nested more than {max_depth} levels deep")
            stack.extend((x, d + 1) for x in (v.values() if isinstance(v, dict) else v))


def _finite_float(s: str) -> float:
    x = float(s)
    if not math.isfinite(x):
        raise _NonFinite(s)
    return x


class _NonFinite(ValueError):
    def __init__(self, literal: str):
        super().__init__(literal)
        self.literal = literal


def _refuse_constant(s: str):
    raise _NonFinite(s)


def loads_json(text: str | bytes, source: str, error: type[NavbenchError] = NavbenchError,
               finite: bool = False, max_depth: int = MAX_DEPTH) -> Any:
    """The JSON value in ``text``; one-line ``error("<source>: ...")`` when it is not JSON, is
    nested deeper than ``max_depth``, holds an integer too long to read, or (``finite``) holds
    ``NaN``, ``Infinity`` or a number that overflows a float."""
    kw = {"parse_float": _finite_float, "parse_constant": _refuse_constant} if finite else {}
    try:
        doc = json.loads(text, **kw)
    except _NonFinite as e:
        raise error(f"{source}: {e.literal!r} is not a finite number") from None
    except RecursionError:
        raise error(f"{source}: not valid JSON (nested more than {max_depth} levels deep)") from None
    except json.JSONDecodeError as e:
        raise error(f"{source}: not valid JSON ({e})") from None
    except UnicodeDecodeError as e:
        raise error(f"{source}: not UTF-8 text (byte {e.start})") from None
    except ValueError as e:  # an integer literal longer than Python's digit limit
        raise error(f"{source}: not a readable JSON document ({str(e).splitlines()[0]})") from None
    check_depth(doc, source, error, max_depth)
    return doc


def load_json(path: str | Path, error: type[NavbenchError] = NavbenchError, what: str = "JSON file",
              finite: bool = False, max_bytes: int = MAX_TEXT_BYTES) -> Any:
    """The JSON document in the regular file ``path``: :func:`read_bytes` then :func:`loads_json`."""
    return loads_json(read_bytes(path, error, what, max_bytes), str(path), error, finite)


def loads_toml(text: str, source: str, error: type[NavbenchError] = ConfigError,
               max_depth: int = MAX_DEPTH, finite: bool = False) -> dict:
    """The TOML document in ``text`` with deep nesting (and with ``finite``, non-finite floats:
    ``inf``, ``nan``, ``1e400``) refused; one-line ``error("<source>: ...")``. Documents with
    a validator that names the field (profiles) leave ``finite`` off: it says more."""
    import tomllib

    try:
        doc = tomllib.loads(text, parse_float=_finite_float if finite else float)
    except _NonFinite as e:
        raise error(f"{source}: {e.literal!r} is not a finite number") from None
    except RecursionError:
        raise error(f"{source}: not valid TOML (nested more than {max_depth} levels deep)") from None
    except tomllib.TOMLDecodeError as e:
        raise error(f"{source}: not valid TOML ({e})") from None
    except ValueError as e:  # an integer literal longer than Python's digit limit
        raise error(f"{source}: not a readable TOML document ({str(e).splitlines()[0]})") from None
    check_depth(doc, source, error, max_depth)
    return doc


def load_toml(path: str | Path, error: type[NavbenchError] = ConfigError, what: str = "TOML file",
              max_bytes: int = MAX_TEXT_BYTES) -> dict:
    """The TOML document in the regular file ``path`` (see :func:`loads_toml`)."""
    text = read_text(path, error, what, max_bytes)
    return loads_toml(text, str(path), error)


def parse_option_value(value: str, label: str, error: type[NavbenchError] = ConfigError) -> Any:
    """A ``-o KEY=VALUE`` value: JSON when it parses (numbers, lists, true/false, objects), else
    the string itself. Refused in one line naming ``label``: NaN and infinities, values nested
    deeper than :data:`MAX_DEPTH`, integers too long to read, values over
    :data:`MAX_OPTION_CHARS` characters."""
    if len(value) > MAX_OPTION_CHARS:
        raise error(f"{label}: a value of {len(value)} characters; at most {MAX_OPTION_CHARS}")
    try:
        v = json.loads(value, parse_float=_finite_float, parse_constant=_refuse_constant)
    except _NonFinite as e:
        raise error(f"{label}: {e.literal!r} is not a finite number") from None
    except RecursionError:
        raise error(f"{label}: nested more than {MAX_DEPTH} levels deep") from None
    except json.JSONDecodeError:
        stripped = value.strip().lower().lstrip("+-")
        if stripped in ("nan", "inf", "infinity"):
            raise error(f"{label}: {value!r} is not a finite number") from None
        return value
    except ValueError as e:
        raise error(f"{label}: {str(e).splitlines()[0]}") from None
    check_depth(v, label, error)
    return v


def is_disk_full(e: BaseException) -> bool:
    """Whether ``e`` is an OSError for a full disk or quota (ENOSPC, EDQUOT)."""
    return isinstance(e, OSError) and e.errno in (errno.ENOSPC, getattr(errno, "EDQUOT", -1))
