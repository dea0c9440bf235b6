"""Checking a user-given output path before any work, and turning a failed write into one line.

A command that writes to a path the user named calls :func:`check_output` first (before it
loads, fits, tracks or samples anything), so that a folder given for a file, a file given for a
folder, a parent that is a file, a location nobody may write to, or a suffix the writer does
not support is one :class:`~navbench.errors.ConfigError` naming the option and the path, not a
traceback after minutes of work. :func:`writing` turns an ``OSError`` that still happens while
writing (disk full, a race) into the same kind of one-line error. A command that never
overwrites writes through :func:`exclusive_output`: into a temporary path beside the output,
published by :func:`publish` in one step that fails if the output appeared meanwhile, so of two
processes writing one path exactly one succeeds and the other says "exists".

Light imports only (the CLI imports this module from its commands).
"""

from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path

from navbench.errors import ConfigError


def _where(option: str | None, path: Path) -> str:
    return f"{option} {path}" if option else str(path)


def _existing_ancestor(path: Path) -> Path:
    """The nearest ancestor of ``path`` (or ``path`` itself) that exists (``.`` for a relative
    path whose first part is new)."""
    a = path
    while not (a.exists() or a.is_symlink()):
        if a.parent == a:
            break
        a = a.parent
    return a


def check_output(path: str | Path, option: str | None = None, *, kind: str = "file",
                 suffixes: tuple[str, ...] | None = None, example: str | None = None) -> Path:
    """Refuse an output path that cannot be written; return it as a :class:`Path`.

    ``kind`` is ``"file"`` (the command writes the file ``path``) or ``"dir"`` (it writes into
    the folder ``path``, created if new). ``suffixes`` (lower case, with the dot): the file
    suffixes the writer supports (a file only). ``option`` names the option or argument in the
    message (``--out``); ``example`` is a path the message suggests.

    Refused, as one :class:`ConfigError`: a folder where a file is expected, a file where a
    folder is expected, an unsupported or missing suffix, a parent (or further ancestor) that
    is a file, and a location where no file can be created (checked by creating and removing
    a temporary file in the nearest existing folder: permissions alone do not tell for root,
    a read-only file system or ``/proc``).
    """
    if kind not in ("file", "dir"):
        raise ValueError(f"kind: expected 'file' or 'dir', got {kind!r}")
    p = Path(path)
    where = _where(option, p)
    eg = f" (e.g. {example})" if example else ""
    if kind == "file":
        if p.is_dir():
            raise ConfigError(f"{where}: is a folder; give a file name{eg}")
        if suffixes is not None and p.suffix.lower() not in suffixes:
            got = f"suffix {p.suffix!r}" if p.suffix else "no suffix"
            raise ConfigError(f"{where}: {got}; the file must end in {', '.join(suffixes)}{eg}")
        start = p.parent
    else:
        if (p.exists() or p.is_symlink()) and not p.is_dir():
            raise ConfigError(f"{where}: is a file, not a folder; give a folder{eg}")
        start = p
    a = _existing_ancestor(start)
    if not a.is_dir():
        raise ConfigError(f"{where}: {a} is a file, not a folder; give a path in a folder{eg}")
    import tempfile

    try:
        fd, probe = tempfile.mkstemp(prefix=".navbench-probe-", dir=a)
    except OSError as e:
        raise ConfigError(f"{where}: cannot write in {a} ({e.strerror or e}); give a path in a "
                          f"folder you can write{eg}") from None
    os.close(fd)
    try:
        os.unlink(probe)
    except OSError:
        pass
    return p


def write_text_atomic(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` through a temporary file beside it, renamed over it: a
    reader never sees half a file, and a failed write leaves neither half a file nor the
    temporary one. The folder must exist; an ``OSError`` propagates."""
    p = Path(path)
    tmp = p.with_name(f".{p.name}.{os.getpid()}.tmp")
    try:
        tmp.write_text(text, encoding="utf-8")
        tmp.replace(p)
    except BaseException:
        try:
            tmp.unlink(missing_ok=True)
        except OSError:
            pass
        raise
    return p


@contextmanager
def writing(path: str | Path, option: str | None = None, what: str = "the output"):
    """Turn an ``OSError`` raised inside the block into one :class:`ConfigError` naming
    ``option`` and ``path``."""
    try:
        yield
    except OSError as e:
        raise ConfigError(f"{_where(option, Path(path))}: cannot write {what} "
                          f"({e.strerror or e})") from None


def _exists_error(path: Path, option: str | None) -> ConfigError:
    return ConfigError(f"{_where(option, path)}: exists (written meanwhile, perhaps by another "
                       f"navbench process); nothing was overwritten: choose a new path")


def publish(tmp: str | Path, path: str | Path, option: str | None = None) -> Path:
    """Move the finished ``tmp`` (a file or a folder beside ``path``) to ``path`` in one step that
    fails when ``path`` appeared meanwhile: of two writers racing for one path, exactly one
    wins and the other gets one :class:`ConfigError` ("exists"), never a silent overwrite.

    A file is hard-linked into place (``link`` never replaces), else reserved with ``O_EXCL``
    and renamed over its reservation; a folder is renamed into place (which replaces only an
    empty folder: the "new or empty" output folders)."""
    import errno

    tmp, p = Path(tmp), Path(path)
    if tmp.is_dir() and not tmp.is_symlink():
        try:
            os.rename(tmp, p)
        except OSError as e:
            if e.errno in (errno.EEXIST, errno.ENOTEMPTY, errno.ENOTDIR, errno.EISDIR):
                raise _exists_error(p, option) from None
            raise
        return p
    try:
        os.link(tmp, p)
    except FileExistsError:
        raise _exists_error(p, option) from None
    except OSError:  # no hard links here (some network or FAT file systems): reserve, then rename
        try:
            os.close(os.open(p, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644))
        except FileExistsError:
            raise _exists_error(p, option) from None
        os.replace(tmp, p)
    else:
        os.unlink(tmp)
    return p


@contextmanager
def exclusive_output(path: str | Path, option: str | None = None, what: str = "the output"):
    """Yield a temporary path beside ``path`` (same suffix) for the writer to create as a file or
    a folder; when the block succeeds, :func:`publish` it at ``path``. Whatever fails, the
    temporary path is gone afterwards; an ``OSError`` becomes one :class:`ConfigError`."""
    import shutil
    import uuid

    p = Path(path)
    tmp = p.with_name(f".{p.name}.{os.getpid()}-{uuid.uuid4().hex[:8]}.part{p.suffix}")
    try:
        with writing(p, option, what):
            yield tmp
            publish(tmp, p, option)
    finally:
        if tmp.is_dir() and not tmp.is_symlink():
            shutil.rmtree(tmp, ignore_errors=True)
        else:
            try:
                tmp.unlink(missing_ok=True)
            except OSError:
                pass


# ------------------------------------------------- build folders beside an output (issue 34)

#: The file in a build folder that proves navbench made it: the pid and start token of the
#: process that did (:func:`navbench.proc.process_start_token`).
BUILD_OWNER_FILE = ".navbench-build.json"


#: Suffixes of the folders :func:`make_build_dir` makes (the report's build, publish's swap).
BUILD_SUFFIXES = (".build", ".tmp")


def make_build_dir(dest: str | Path, suffix: str = ".build") -> Path:
    """A new empty folder ``.<dest name>.<random>.build`` beside ``dest`` that holds
    :data:`BUILD_OWNER_FILE` (this process's pid and start token), so that a later run can
    prove it is navbench's and that its maker is dead (:func:`remove_stale_build_dirs`)."""
    import json
    import tempfile

    from navbench.proc import process_start_token

    dest = Path(dest)
    assert suffix in BUILD_SUFFIXES
    build = Path(tempfile.mkdtemp(prefix=f".{dest.name}.", suffix=suffix, dir=dest.parent))
    owner = {"pid": os.getpid(), "start_token": process_start_token(os.getpid()), "dest": dest.name}
    (build / BUILD_OWNER_FILE).write_text(json.dumps(owner, sort_keys=True))
    return build


def remove_stale_build_dirs(dest: str | Path) -> list[Path]:
    """Remove the build folders of ``dest`` left by a process that was killed (``kill -9``
    skips every cleanup) and return them. A folder is removed only when navbench provably made
    it: a real folder (not a link) named like :func:`make_build_dir`'s whose
    :data:`BUILD_OWNER_FILE` names ``dest`` and a pid that no longer runs the process that
    wrote it (:func:`navbench.proc.pid_alive` with its start token). Anything else,
    a folder of a live run included, is left alone."""
    import json
    import shutil

    from navbench.proc import pid_alive

    dest = Path(dest)
    removed = []
    if not dest.parent.is_dir():
        return removed
    found = [d for s in BUILD_SUFFIXES for d in dest.parent.glob(f".{dest.name}.*{s}")]
    for d in sorted(found):
        try:
            if d.is_symlink() or not d.is_dir():
                continue
            owner = json.loads((d / BUILD_OWNER_FILE).read_text())
            pid, token = owner["pid"], owner.get("start_token")
            if owner.get("dest") != dest.name or not isinstance(pid, int) or isinstance(pid, bool):
                continue
        except (OSError, ValueError, KeyError, TypeError, RecursionError):
            continue  # no proof of ownership: not ours to remove
        if pid == os.getpid() or pid_alive(pid, token):
            continue
        shutil.rmtree(d, ignore_errors=True)
        removed.append(d)
    return removed
