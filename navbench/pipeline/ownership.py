"""What the stage cache can prove is its own, and which entries a live process holds.

``navbench cache gc`` removes only what this module proves (docs/concepts/bad-input.md, "Cache
ownership and garbage collection"):

* **The root is a navbench cache.** Navbench writes the marker file :data:`MARKER` into a cache
  root when it creates it (or finds it empty). A root made by an older navbench has no marker
  and is recognised by its layout (:func:`layout_proof`): only folders at the top (no file),
  stage folders named like stages holding only folders (no file), ``refs/`` holding only
  ``.json`` files, and at least one entry with a manifest navbench wrote. ``results/`` (a
  database file, a report folder of files), a project folder (``README.md``, ``levels/*.json``)
  or a home directory fail it.
* **An entry is navbench's** when its ``manifest.json`` is one navbench writes
  (:func:`navbench_manifest`): a JSON object naming the entry's own stage and key (64 hex
  digits), a file list of sizes and sha256 digests, a format version, a creation time and a
  navbench version. A folder without one is never removed, only reported.
* **A live process holds an entry** when its holder file ``<root>/.holds/<pid>-<id>.hold``
  names it. Every process that looks up, loads or writes an entry appends the entry's
  ``stage/key`` line to its own holder file first (:func:`hold`); the file's first line names
  the process (pid, start token of :func:`~navbench.pipeline.executor.process_start_token`,
  host). A holder whose process is gone (or whose pid now belongs to another process) is
  stale: ignored, and removed by the next gc. A holder of another host cannot be checked and
  counts as live.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import socket
import threading
from dataclasses import dataclass
from pathlib import Path

MANIFEST = "manifest.json"
REFS_DIR = "refs"
HOLDS_DIR = ".holds"
#: The file navbench writes into a cache root it creates: what makes the root provably its own.
MARKER = ".navbench-cache"
_KEY = re.compile(r"[0-9a-f]{64}")
_STAGE = re.compile(r"[a-z][a-z0-9_-]*")
#: Names navbench gives temporary (``.tmp-KEY-PID-RAND``) and quarantined (``.bad-KEY-RAND``)
#: entries; nothing else hidden in a stage folder is navbench's to remove.
TMP_NAME = re.compile(r"\.tmp-[0-9a-f]{1,64}-\d+-[0-9a-f]{1,32}")
BAD_NAME = re.compile(r"\.bad-[0-9a-f]{1,64}-[0-9a-f]{1,32}")


# ---------------------------------------------------------------------------- the root
def write_marker(root: Path) -> None:
    """Mark ``root`` as a navbench cache (best effort: an unwritable root stays unmarked)."""
    from navbench import __version__

    try:
        fd = os.open(root / MARKER, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
    except OSError:
        return  # there already, or nowhere to write
    with os.fdopen(fd, "w") as f:
        json.dump({"navbench": "stage cache", "navbench_version": __version__}, f)
        f.write("\n")


def ensure_root(root: Path) -> None:
    """Create the cache root if needed; mark it when navbench created it or found it empty."""
    if (root / MARKER).is_file():
        return
    try:
        fresh = not root.exists() or (root.is_dir() and not any(root.iterdir()))
    except OSError:
        fresh = False
    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError as e:  # a parent that cannot be made (/proc/x, a file, a loop): one line (P-017)
        from navbench.errors import ArtifactError

        raise ArtifactError(f"{root}: cannot create the stage cache here ({e.strerror or e}; "
                            f"set --cache / NAVBENCH_CACHE to a folder that can be created)") from None
    if fresh:
        write_marker(root)


def is_entry_name(stage, key) -> bool:
    """Whether ``stage``/``key`` can name a cache entry (a stage name and 64 hex digits)."""
    return (isinstance(stage, str) and isinstance(key, str) and _STAGE.fullmatch(stage) is not None
            and _KEY.fullmatch(key) is not None)


def navbench_manifest(entry: Path) -> dict | None:
    """The manifest of cache entry ``entry`` (``<root>/<stage>/<key>``) when navbench wrote it,
    else ``None`` (absent, unreadable, a link, or not describing this very entry)."""
    mf = entry / MANIFEST
    try:
        if mf.is_symlink() or not mf.is_file() or mf.stat().st_size > 64 << 20:
            return None
        man = json.loads(mf.read_text())
    except (OSError, ValueError, RecursionError):
        return None
    if not isinstance(man, dict):
        return None
    files = man.get("files")
    ok = (man.get("stage") == entry.parent.name and man.get("key") == entry.name
          and _KEY.fullmatch(entry.name) is not None and isinstance(files, dict)
          and all(isinstance(m, dict) and isinstance(m.get("sha256"), str) and isinstance(m.get("size"), int)
                  for m in files.values())
          and isinstance(man.get("format_version"), int) and isinstance(man.get("created"), str)
          and isinstance(man.get("navbench_version"), str) and isinstance(man.get("inputs", {}), dict))
    return man if ok else None


def layout_proof(root: Path) -> str | None:
    """Why ``root`` (without :data:`MARKER`) is laid out as a navbench cache, or ``None``."""
    try:
        top = [p for p in root.iterdir() if not p.name.startswith(".")]
    except OSError:
        return None
    found = 0
    for sd in top:
        if sd.is_symlink() or not sd.is_dir():
            return None
        if sd.name == REFS_DIR:
            if any(not (p.name.startswith(".") or (p.suffix == ".json" and p.is_file()))
                   for p in sd.iterdir()):
                return None
            continue
        if not _STAGE.fullmatch(sd.name):
            return None
        for ad in sd.iterdir():
            if ad.name.startswith("."):
                continue
            if ad.is_symlink() or not ad.is_dir():
                return None
            if found == 0 and navbench_manifest(ad) is not None:
                found += 1
    return "laid out as a navbench cache" if found else None


def prove_root(root: Path, option: str = "--root") -> str:
    """How ``root`` is proven a navbench cache (``"marker"`` or the layout); else one
    :class:`~navbench.errors.ConfigError` that names a cache inside it, if there is one."""
    from navbench.errors import ConfigError

    if (root / MARKER).is_file():
        return "marker"
    why = layout_proof(root)
    if why:
        return why
    inside = [p for p in (root / "cache", root / "results" / "cache")
              if p.is_dir() and ((p / MARKER).is_file() or layout_proof(p))]
    hint = f"; did you mean {option} {inside[0]}?" if inside else " (a cache is e.g. results/cache)"
    raise ConfigError(f"{option} {root}: not a navbench cache (no {MARKER} file and not laid out "
                      f"as one), so nothing in it is removed{hint}")


# ---------------------------------------------------------------------------- holds (leases)
@dataclass
class _Holder:
    path: Path
    seen: set


_HOLDERS: dict[tuple[str, int], _Holder] = {}
_HOLDERS_EXIT: list = []  # the atexit hook is registered once
_LOCK = threading.Lock()


def _release_all() -> None:
    """At exit: this process's holder files go (a killed process's are stale for gc to remove)."""
    for (root, pid) in list(_HOLDERS):
        if pid == os.getpid():
            release(Path(root))


def _me() -> tuple[int, str | None]:
    from navbench.proc import process_start_token

    pid = os.getpid()
    return pid, process_start_token(pid)


def _holder_name(pid: int, token: str | None) -> str:
    tag = hashlib.sha256(f"{socket.gethostname()}|{token}".encode()).hexdigest()[:12]
    return f"{pid}-{tag}.hold"


def hold(root: Path, stage: str, key: str) -> None:
    """Record that this process uses entry ``stage/key`` of the cache ``root`` (until it exits,
    or :func:`release`). Best effort: a cache nobody may write to cannot be collected either."""
    pid = os.getpid()
    ident = (str(root.absolute()), pid)
    with _LOCK:
        h = _HOLDERS.get(ident)
        if h is not None and (stage, key) in h.seen:
            return
        try:
            if h is None:
                _pid, token = _me()
                d = root / HOLDS_DIR
                d.mkdir(parents=True, exist_ok=True)
                path = d / _holder_name(pid, token)
                with open(path, "w") as f:
                    f.write(json.dumps({"pid": pid, "start": token, "host": socket.gethostname()}) + "\n")
                h = _HOLDERS[ident] = _Holder(path, set())
                if not _HOLDERS_EXIT:
                    import atexit

                    atexit.register(_release_all)
                    _HOLDERS_EXIT.append(True)
            with open(h.path, "a") as f:
                f.write(f"{stage}/{key}\n")
            h.seen.add((stage, key))
        except OSError:
            pass


def release(root: Path) -> None:
    """Drop this process's holds on ``root`` (a library user between runs; exit does the same)."""
    with _LOCK:
        h = _HOLDERS.pop((str(root.absolute()), os.getpid()), None)
    if h is not None:
        try:
            h.path.unlink()
        except OSError:
            pass


@dataclass(frozen=True)
class Holder:
    """One holder file: ``live`` (its process runs, or it cannot be checked) and its entries."""

    path: Path
    pid: int | None
    host: str
    live: bool
    mine: bool
    entries: frozenset


def holders(root: Path) -> list[Holder]:
    """Every holder file under ``root`` (a malformed one is stale, not a hold)."""
    from navbench.proc import pid_alive

    d = root / HOLDS_DIR
    out = []
    if not d.is_dir() or d.is_symlink():
        return out
    me, my_token = _me()
    here = socket.gethostname()
    for p in sorted(d.iterdir()):
        if not p.name.endswith(".hold") or p.is_symlink() or not p.is_file():
            continue
        try:
            lines = p.read_text(errors="replace").splitlines()
            head = json.loads(lines[0]) if lines else None
        except (OSError, ValueError, RecursionError):
            head = None
        if not isinstance(head, dict) or not isinstance(head.get("pid"), int):
            out.append(Holder(p, None, "", False, False, frozenset()))
            continue
        pid, token, host = head["pid"], head.get("start"), str(head.get("host", ""))
        entries = frozenset(tuple(ln.split("/", 1)) for ln in lines[1:] if ln.count("/") == 1)
        mine = host == here and pid == me and token == my_token
        live = host != here or pid_alive(pid, token if isinstance(token, str) else None)
        out.append(Holder(p, pid, host, live, mine, entries))
    return out


def held_entries(root: Path) -> dict[tuple[str, str], Holder]:
    """``(stage, key) -> holder`` of the entries live processes other than this one hold."""
    out = {}
    for h in holders(root):
        if h.live and not h.mine:
            for e in h.entries:
                out.setdefault(e, h)
    return out
