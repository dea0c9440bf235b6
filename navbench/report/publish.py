"""Publishing a report folder without ever losing data: a destination is replaced only when it
is new, empty, or a report navbench published before (it holds :data:`REPORT_MARKER`), and never
when it is, contains or lies inside the cache, the database, the level or the task folders.
"""

from __future__ import annotations

from pathlib import Path


#: The file that marks a folder as a report navbench published (the only folders it replaces).
REPORT_MARKER = ".navbench-report"


def protected_paths(db_url: str | None = None, cache_root: str | Path | None = None,
                    levels_dir: str | Path = "levels", tasks_dir: str | Path = "tasks") -> list[Path]:
    """What a report must never be written over, into or around: the stage cache, the SQLite
    database file, the level and task folders."""
    from navbench.results.db import resolve_db_url

    from navbench.config import default_cache_root

    paths = [Path(cache_root) if cache_root is not None else default_cache_root(), Path(levels_dir), Path(tasks_dir)]
    url = resolve_db_url(db_url)
    if url.startswith("sqlite:///"):
        db_file = url[len("sqlite:///"):].split("?", 1)[0]
        if db_file and db_file != ":memory:":
            paths.append(Path(db_file).expanduser())
    return paths


def check_report_dir(dest: str | Path, option: str, protected: list[Path]) -> Path:
    """Refuse a report destination that could lose data; returns ``dest``.

    Allowed: a folder that does not exist yet, an empty folder, or a folder navbench published
    before (it holds :data:`REPORT_MARKER`). Refused (:class:`ConfigError` naming ``option``): a
    file, a new name ending in .html, a path under a file or where nothing can be written
    (:func:`navbench.outpath.check_output`), a symbolic link, a non-empty folder without the marker (``results/``, ``.``, a user's
    folder), and anything that is, contains or lies inside one of the ``protected`` paths.
    """
    from navbench.errors import ConfigError

    dest = Path(dest)
    where = f"{option} {dest}"
    if dest.is_symlink():
        raise ConfigError(f"{where}: is a symbolic link; give a real folder")
    if dest.exists() and not dest.is_dir():
        raise ConfigError(f"{where}: is a file, not a folder")
    if not dest.exists() and dest.suffix.lower() in (".html", ".htm"):
        raise ConfigError(f"{where}: names a file, but the report is a folder (index.html and "
                          "the CSV tables go in it); give a folder, e.g. results/report")
    from navbench.outpath import check_output

    # a parent that is a file, or a place nobody can write (/proc, read-only): before any work
    check_output(dest, option, kind="dir", example="results/report")
    target = dest.resolve()
    for p in protected:
        q = p.resolve()
        if target == q or q.is_relative_to(target) or target.is_relative_to(q):
            raise ConfigError(f"{where}: overlaps {p} (the report must not be written into, over "
                              "or around the cache, the database, levels or tasks); choose "
                              "another folder, e.g. results/report")
    if dest.is_dir() and any(dest.iterdir()) and not (dest / REPORT_MARKER).is_file():
        raise ConfigError(f"{where}: the folder is not empty and is not a report navbench "
                          f"published (no {REPORT_MARKER} file); choose a new or empty folder")
    if dest.is_dir() and (dest / REPORT_MARKER).is_file():
        foreign = foreign_files(dest)
        if foreign:  # a republish replaces the folder whole: it would take these with it
            shown = ", ".join(foreign[:3]) + (f" and {len(foreign) - 3} more" if len(foreign) > 3 else "")
            raise ConfigError(f"{where}: holds {len(foreign)} file(s) navbench did not write there "
                              f"({shown}); move them out of the report folder, or choose another folder")
    return dest


def _written(folder: Path) -> set[str] | None:
    """The files the marker says navbench published in ``folder`` (``None``: a marker written
    before it listed them)."""
    import json

    try:
        doc = json.loads((folder / REPORT_MARKER).read_text(encoding="utf-8"))
        files = doc["files"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    return {f for f in files if isinstance(f, str)} if isinstance(files, list) else None


def foreign_files(folder: Path) -> list[str]:
    """Files in a published report ``folder`` that navbench did not write there: not among those
    its marker lists (or, for an older marker without the list, not ``index.html`` or a ``.csv``
    table at the top), links and folders included. A republish must not remove them."""
    written = _written(folder)
    out = []
    for p in sorted(folder.rglob("*")):
        rel = p.relative_to(folder).as_posix()
        if rel == REPORT_MARKER or (p.is_dir() and not p.is_symlink()):
            continue
        ours = (rel in written) if written is not None else (
            "/" not in rel and (rel == "index.html" or rel.endswith(".csv")))
        if not ours or p.is_symlink():
            out.append(rel)
    return out


def publish(src_dir: Path, dest: Path, protected: list[Path] | None = None,
            option: str = "--report") -> Path:
    """Copy an artifact's files (not its manifest) to ``dest``, replaced atomically.

    Only a folder :func:`check_report_dir` accepts is replaced; the published folder gets the
    :data:`REPORT_MARKER` file. The temporary folders are new ones (``mkdtemp``) beside ``dest``,
    so nothing that navbench did not create is removed.
    """
    import shutil

    protected = protected if protected is not None else protected_paths()
    dest = check_report_dir(dest, option, protected)
    from navbench.outpath import BUILD_OWNER_FILE, make_build_dir, writing

    with writing(dest, option, "the report"):
        dest.parent.mkdir(parents=True, exist_ok=True)
        work = make_build_dir(dest, ".tmp")  # owned: a killed run's is removed by the next
    try:
        with writing(dest, option, "the report"):  # disk full, a race: one line
            new, old = work / "new", work / "old"
            shutil.copytree(src_dir, new, ignore=shutil.ignore_patterns("manifest.json", BUILD_OWNER_FILE))
            mark_report_dir(new)
            if dest.exists():
                check_report_dir(dest, option, protected)  # still a published report just before the swap
                dest.rename(old)
            try:
                new.rename(dest)
            except OSError:
                if old.exists():
                    old.rename(dest)
                raise
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return dest


def mark_report_dir(folder: Path) -> None:
    """Mark ``folder`` as a report navbench wrote, listing the files it holds (so a later report
    may replace it, and only when nothing else was put there: :func:`foreign_files`)."""
    import json

    folder = Path(folder)
    files = sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*")
                   if p.is_file() and p.name != REPORT_MARKER)
    doc = {"written_by": "navbench", "note": "the next report replaces this folder", "files": files}
    (folder / REPORT_MARKER).write_text(json.dumps(doc, indent=1) + "\n")
