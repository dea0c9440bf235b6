"""The content-addressed stage cache (the DVC idea: key first, then maybe compute).

An artifact is a directory ``<root>/<stage>/<key>/`` holding the stage's files and a
``manifest.json``::

    {"stage": ..., "key": ..., "config": {...}, "inputs": {"views": "<key>", ...},
     "format_version": 1, "created": "2026-01-01T00:00:00+00:00", "navbench_version": "0.1.0",
     "files": {"map.npz": {"sha256": "...", "size": 123}, ...}}

The key is :func:`stage_key`: sha256 of the sorted JSON of (stage name, resolved config, the keys
of its inputs, the artifact format version). It is computed *before* the stage runs, so a second
run with the same key does not run the stage at all. A file name alone is never trusted: every
load verifies the manifest and the size and sha256 of each file; an artifact that fails (truncated,
tampered, manifest missing) is moved aside with a warning and recomputed, never used.

Writes are atomic: the stage writes into a temporary directory ``<root>/<stage>/.tmp-<key>-...``
next to the final one, the manifest is written last, and the directory is renamed into place.
A crash leaves only a temporary directory behind, which :meth:`ArtifactStore.gc` removes.

Garbage collection (:meth:`ArtifactStore.gc`) keeps

* every artifact named in a *ref* file ``<root>/refs/<name>.json`` (each pipeline command writes
  the keys of its latest run there, one file per profile/command, see :meth:`ArtifactStore.set_ref`),
* the ``keep_newest`` newest artifacts of every stage (default 1),
* everything those depend on (their manifests' inputs, transitively),
* and every artifact of a per-item stage (``episode`` trajectories hang off their level, map
  and task set) whose inputs that are stored artifacts are all kept (inputs that name no
  stored artifact are content hashes of committed files such as ``levels/NAME.json``),

and removes all other artifacts and every stale temporary or quarantined directory. It removes
only what it can prove is navbench's (:mod:`navbench.pipeline.ownership`): the root must be a
navbench cache (the marker file navbench writes when it creates the root, or the layout of an
older cache), an entry must carry a manifest navbench wrote (a folder without one is reported,
never removed), and an entry a live process holds (every lookup, load and write records a hold
in ``<root>/.holds/``) is kept with its inputs.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import json
import os
import shutil
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable

from navbench import __version__
# where the cache is by default (re-exported: the report, which must never write over it, reads it too)
from navbench.config import CACHE_ENV, DEFAULT_CACHE, config_hash, default_cache_root, read_json, to_jsonable  # noqa: F401
from navbench.errors import ArtifactError
from navbench.safeio import load_json

from navbench.pipeline.ownership import BAD_NAME, MANIFEST, REFS_DIR, TMP_NAME, ensure_root, hold

TMP_PREFIX = ".tmp-"
BAD_PREFIX = ".bad-"
#: Stages whose artifacts are per-item children of others (kept while all their inputs are kept).
PER_ITEM_STAGES = frozenset({"episode"})

Log = Callable[[str], None]


def _noop(_msg: str) -> None:
    pass


def stage_key(stage: str, config: Any, inputs: dict[str, str], version: int) -> str:
    """sha256 hex of the sorted JSON of (stage, resolved config, input keys, format version)."""
    return config_hash({"stage": stage, "config": to_jsonable(config),
                        "inputs": dict(sorted(inputs.items())), "format_version": int(version)})


def file_sha256(path: Path, chunk: int = 1 << 20) -> str:
    """sha256 hex digest of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while True:
            b = f.read(chunk)
            if not b:
                break
            h.update(b)
    return h.hexdigest()


@dataclass(frozen=True)
class ArtifactInfo:
    """One stored artifact, as listed by :meth:`ArtifactStore.ls`.

    ``size`` in bytes (sum of its files), ``created`` an ISO-8601 UTC timestamp.
    """

    stage: str
    key: str
    path: Path
    size: int
    created: str
    inputs: dict[str, str]
    config: dict


class ArtifactStore:
    """A directory of verified, content-addressed stage artifacts (see the module docstring);
    ``root`` ``None``: :func:`default_cache_root`."""

    def __init__(self, root: str | Path | None = None):
        self.root = Path(root) if root is not None else default_cache_root()

    # ------------------------------------------------------------------ paths and lookup
    def path(self, stage: str, key: str) -> Path:
        """Where the artifact ``key`` of ``stage`` lives (it may not exist)."""
        if not stage or "/" in stage or stage.startswith("."):
            raise ArtifactError(f"invalid stage name {stage!r}")
        return self.root / stage / key

    def verify(self, stage: str, key: str) -> dict:
        """Check the artifact's manifest and every file's size and sha256; return the manifest.

        Raises :class:`ArtifactError` naming the first problem.
        """
        d = self.path(stage, key)
        mf = d / MANIFEST
        man = read_json(mf, ArtifactError, f"{d}: no manifest", "unreadable manifest")
        if not isinstance(man, dict) or man.get("key") != key or man.get("stage") != stage:
            raise ArtifactError(f"{mf}: manifest does not describe {stage}/{key[:12]}")
        files = man.get("files")
        if not isinstance(files, dict):
            raise ArtifactError(f"{mf}: manifest has no file list")
        for rel, meta in files.items():
            if not isinstance(meta, dict):  # a damaged manifest: one line, not an AttributeError
                raise ArtifactError(f"{mf}: malformed entry for file {rel!r}")
            p = d / rel
            if not p.is_file():
                raise ArtifactError(f"{d}: file {rel} is missing")
            if p.stat().st_size != meta.get("size"):
                raise ArtifactError(f"{d}: file {rel} has size {p.stat().st_size}, "
                                    f"expected {meta.get('size')} (truncated?)")
            if file_sha256(p) != meta.get("sha256"):
                raise ArtifactError(f"{d}: file {rel} fails its checksum (modified?)")
        return man

    def lookup(self, stage: str, key: str, log: Log = _noop) -> Path | None:
        """The verified artifact's directory, or ``None`` when absent.

        A present but invalid artifact is quarantined (moved aside, then deleted) with a warning
        through ``log`` and reported as absent, so the caller recomputes it.
        """
        d = self.path(stage, key)
        if not d.exists():
            return None
        hold(self.root, stage, key)  # before the check: a gc that runs meanwhile sees it
        try:
            self.verify(stage, key)
        except ArtifactError as e:
            log(f"warning: {e}; discarding it and recomputing")
            self._discard(d)
            return None
        return d

    def load(self, stage: str, key: str) -> Path:
        """The verified artifact's directory; :class:`ArtifactError` if absent or invalid."""
        d = self.path(stage, key)
        if not d.exists():
            raise ArtifactError(f"no {stage} artifact with key {key[:12]} in {self.root}")
        hold(self.root, stage, key)
        self.verify(stage, key)
        return d

    def find(self, key_prefix: str, stage: str | tuple[str, ...] | None = None) -> tuple[str, str]:
        """Resolve a (possibly abbreviated, >= 6 hex digits) key to ``(stage, full key)`` among
        the artifacts of ``stage`` (a name, a tuple of names, or ``None``: any stage). A key
        that names only another stage's artifact says which stage that is."""
        if len(key_prefix) < 6:
            raise ArtifactError(f"key {key_prefix!r} is too short (give at least 6 hex digits)")
        stages = (stage,) if isinstance(stage, str) else stage
        every = [(a.stage, a.key) for a in self._iter_dirs() if a.key.startswith(key_prefix)]
        hits = [h for h in every if stages is None or h[0] in stages]
        if not hits:
            where = f"{' or '.join(stages)} " if stages else ""
            others = sorted({s for s, _ in every})
            if others:
                raise ArtifactError(f"key {key_prefix!r} names a {' or '.join(others)} artifact, "
                                    f"not one of {', '.join(stages)}")
            raise ArtifactError(f"no {where}artifact with that key ({key_prefix!r}) in {self.root}")
        if len(hits) > 1:
            raise ArtifactError(f"key {key_prefix!r} is ambiguous ({len(hits)} artifacts); give "
                                f"more digits")
        return hits[0]

    # ------------------------------------------------------------------ writing
    def write(self, stage: str, key: str, compute: Callable[[Path], None], *, config: Any,
              inputs: dict[str, str], version: int, log: Log = _noop,
              replace: bool = False, validate: Callable[[Path], None] | None = None) -> Path:
        """Run ``compute(tmpdir)`` and atomically install its files as artifact ``key``.

        ``compute`` writes plain files (subdirectories allowed) into ``tmpdir``; the manifest is
        added here. A valid artifact with this key that appeared meanwhile (another process
        computing the same stage) is kept and ours dropped, so a concurrent reader of it never
        sees it vanish; it is replaced only with ``replace`` (``--force``). An invalid one is
        always replaced. Nothing that fails to load is installed: an ``.npy`` / ``.npz`` file
        holding an array of Python objects (which navbench never unpickles) is one
        :class:`ArtifactError`, and so is whatever ``validate(tmpdir)`` (the stage's own loader)
        raises.
        """
        final = self.path(stage, key)
        ensure_root(self.root)
        hold(self.root, stage, key)  # ours (and the inputs this process read) until it exits
        final.parent.mkdir(parents=True, exist_ok=True)
        tmp = final.parent / f"{TMP_PREFIX}{key[:16]}-{os.getpid()}-{uuid.uuid4().hex[:8]}"
        tmp.mkdir()
        try:
            compute(tmp)
            _refuse_object_arrays(tmp, stage)
            if validate is not None:
                try:
                    validate(tmp)
                except ArtifactError:
                    raise
                except Exception as e:  # noqa: BLE001 - a stage's loader: what it says, one line
                    raise ArtifactError(f"{stage}: the artifact just computed does not load back "
                                        f"({type(e).__name__}: {e}); nothing was cached") from None
            files = {}
            for p in sorted(tmp.rglob("*")):
                if p.is_file() and p.name != MANIFEST:
                    files[p.relative_to(tmp).as_posix()] = {"sha256": file_sha256(p),
                                                            "size": p.stat().st_size}
            man = {
                "stage": stage, "key": key, "config": to_jsonable(config),
                "inputs": dict(sorted(inputs.items())), "format_version": int(version),
                "created": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
                "navbench_version": __version__, "files": files,
            }
            with open(tmp / MANIFEST, "w") as f:
                json.dump(man, f, indent=1, sort_keys=True)
                f.flush()
                os.fsync(f.fileno())
            if final.exists():
                if not replace and self.lookup(stage, key, log) is not None:
                    shutil.rmtree(tmp, ignore_errors=True)
                    return final
                self._discard(final)
            try:
                os.rename(tmp, final)
            except OSError:
                # another process installed the same key first: theirs is as good as ours
                if self.lookup(stage, key, log) is None:
                    raise
                shutil.rmtree(tmp, ignore_errors=True)
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise
        return final

    def _discard(self, d: Path) -> None:
        bad = d.parent / f"{BAD_PREFIX}{d.name[:16]}-{uuid.uuid4().hex[:8]}"
        try:
            os.rename(d, bad)
        except OSError:
            bad = d
        shutil.rmtree(bad, ignore_errors=True)

    # ------------------------------------------------------------------ refs (gc roots)
    def set_ref(self, name: str, keys: Iterable[tuple[str, str]], merge: bool = False) -> Path:
        """Record ``(stage, key)`` pairs used by the latest run called ``name`` (a gc root).

        ``merge``: add them to what the ref holds instead of replacing it: a run that failed,
        was refused or was interrupted touched only part of its inputs, and replacing the ref
        with those would leave the last finished run's other entries unprotected from gc
        (issue 34, P-005). A ref that cannot be read is replaced."""
        ensure_root(self.root)
        d = self.root / REFS_DIR
        d.mkdir(parents=True, exist_ok=True)
        from navbench.outpath import write_text_atomic

        keys = {(s, k) for s, k in keys}
        if merge and (d / f"{name}.json").exists():
            try:
                keys |= set(read_ref(d / f"{name}.json"))
            except ArtifactError:
                pass
        return write_text_atomic(d / f"{name}.json", json.dumps(
            {"name": name, "updated": time.time(), "artifacts": sorted(keys)}, indent=1))

    def refs(self) -> dict[str, list[tuple[str, str]]]:
        """All ref files: name -> list of ``(stage, key)``. A ref that cannot be read (not a
        regular file, a dangling link, a FIFO, not JSON, not ``{"artifacts": [[stage, key],
        ...]}`` with stage names and 64-hex keys) raises one-line
        :class:`~navbench.errors.ArtifactError` naming it: gc cannot tell what it protects, so
        it must not run as if it were absent (issue 34)."""
        out = {}
        d = self.root / REFS_DIR
        if not d.is_dir():
            if d.exists() or d.is_symlink():
                raise ArtifactError(f"{d}: the refs folder is not a directory; cannot tell which "
                                    "entries the latest runs use (move it aside, then rerun the runs)")
            return out
        for p in sorted(d.glob("*.json")):
            out[p.stem] = read_ref(p)
        return out

    # ------------------------------------------------------------------ listing and gc
    def _iter_dirs(self):
        if not self.root.is_dir():
            return
        for sd in sorted(self.root.iterdir()):
            if not sd.is_dir() or sd.name == REFS_DIR or sd.name.startswith("."):
                continue
            for ad in sorted(sd.iterdir()):
                if ad.is_dir() and not ad.name.startswith("."):
                    yield _Dir(sd.name, ad.name, ad)

    def ls(self, stage: str | None = None) -> list[ArtifactInfo]:
        """Every artifact with a readable manifest (not re-verified), oldest first."""
        out = []
        for a in self._iter_dirs():
            if stage is not None and a.stage != stage:
                continue
            try:
                man = load_json(a.path / MANIFEST, ArtifactError)  # safeio: deep, FIFO, huge
                size = sum(int(m["size"]) for m in man["files"].values())
                out.append(ArtifactInfo(a.stage, a.key, a.path, size, man.get("created", ""),
                                        dict(man.get("inputs", {})), dict(man.get("config", {}))))
            except (OSError, ArtifactError, KeyError, TypeError, ValueError, AttributeError):
                out.append(ArtifactInfo(a.stage, a.key, a.path, 0, "", {}, {}))
        out.sort(key=lambda i: (i.created, i.stage, i.key))
        return out

    def stale_temp_dirs(self, min_age_s: float = 0.0) -> list[Path]:
        """Temporary and quarantined directories navbench made (by their names; never a link)
        whose writer is gone (temporary ones), older than ``min_age_s``."""
        out = []
        if not self.root.is_dir():
            return out
        now = time.time()
        for sd in self.root.iterdir():
            if sd.is_symlink() or not sd.is_dir():
                continue
            for d in sd.iterdir():
                tmp = TMP_NAME.fullmatch(d.name) is not None
                if not (tmp or BAD_NAME.fullmatch(d.name)) or d.is_symlink() or not d.is_dir():
                    continue
                if tmp and _writer_alive(d.name):
                    continue
                if now - d.lstat().st_mtime >= min_age_s:
                    out.append(d)
        return sorted(out)

    def gc(self, keep_newest: int = 1, dry_run: bool = False) -> "GcReport":
        """Remove what no run refers to (policy: module docstring), only from a root proven to be
        a navbench cache and only entries whose manifest navbench wrote, never one a live
        process holds (:mod:`navbench.pipeline.ownership`). ``dry_run``: remove nothing and
        report what a real run would remove. A root that is not a navbench cache raises
        :class:`~navbench.errors.ConfigError` before anything is touched."""
        from navbench.pipeline.ownership import held_entries, holders, navbench_manifest, prove_root

        if not self.root.is_dir():
            return GcReport("no cache", dry_run)
        report = GcReport(prove_root(self.root), dry_run)
        infos = []
        for sd in sorted(self.root.iterdir()):
            if sd.name.startswith(".") or sd.name == REFS_DIR:
                continue
            if sd.is_symlink() or not sd.is_dir():
                report.foreign.append((sd, "a link" if sd.is_symlink() else "a file"))
                continue
            for ad in sorted(sd.iterdir()):
                if ad.name.startswith("."):
                    if (TMP_NAME.fullmatch(ad.name) or BAD_NAME.fullmatch(ad.name)) and ad.is_symlink():
                        report.foreign.append((ad, "a link, which navbench never makes"))
                    continue
                man = None if ad.is_symlink() else navbench_manifest(ad)
                if man is None:
                    why = ("a link" if ad.is_symlink() else "a file" if not ad.is_dir()
                           else "no manifest navbench wrote")
                    report.foreign.append((ad, why))
                    continue
                size = sum(int(m["size"]) for m in man["files"].values())
                infos.append(ArtifactInfo(sd.name, ad.name, ad, size, man["created"],
                                          dict(man.get("inputs", {})), dict(man.get("config") or {})))
        infos.sort(key=lambda i: (i.created, i.stage, i.key))
        held = held_entries(self.root)
        kept = self._kept(infos, keep_newest, set(held))
        for i in infos:
            if (i.stage, i.key) in held and (i.stage, i.key) in kept:
                report.held.append((i.path, f"pid {held[(i.stage, i.key)].pid}"))
        doomed = [i for i in infos if (i.stage, i.key) not in kept]
        stale = self.stale_temp_dirs()
        dead = [h.path for h in holders(self.root) if not h.live]
        if dry_run:
            report.removed = [i.path for i in doomed] + stale + dead
            return report
        aside = []
        for i in doomed:  # out of readers' sight first, then a second look at the holders
            bad = i.path.parent / f"{BAD_PREFIX}{i.key[:16]}-{uuid.uuid4().hex[:8]}"
            try:
                os.rename(i.path, bad)
            except OSError as e:
                report.failed.append((i.path, e.strerror or str(e)))
                continue
            aside.append((i, bad))
        late = held_entries(self.root)
        for i, bad in aside:
            if (i.stage, i.key) in late:  # a process took it meanwhile: put it back
                try:
                    os.rename(bad, i.path)
                    report.held.append((i.path, f"pid {late[(i.stage, i.key)].pid}"))
                    continue
                except OSError:
                    pass  # it was recomputed meanwhile: ours is a spare copy
            self._remove(bad, i.path, report)
        for d in stale:
            self._remove(d, d, report)
        for p in dead:
            try:
                p.unlink()
                report.removed.append(p)
            except FileNotFoundError:
                pass
            except OSError as e:
                report.failed.append((p, e.strerror or str(e)))
        return report

    @staticmethod
    def _remove(path: Path, shown: Path, report: "GcReport") -> None:
        errors = []
        shutil.rmtree(path, onerror=lambda _f, p, exc: errors.append(f"{p}: {exc[1]}"))
        if path.exists() or path.is_symlink():
            report.failed.append((shown, errors[0] if errors else "still there"))
        else:
            report.removed.append(shown)

    def _kept(self, infos: list[ArtifactInfo], keep_newest: int,
              held: set[tuple[str, str]]) -> set[tuple[str, str]]:
        """The entries gc keeps: refs, the newest per stage, held ones, their inputs, and the
        per-item entries whose stored inputs are all kept."""
        by_key = {(i.stage, i.key): i for i in infos}
        roots: set[tuple[str, str]] = {k for k in held if k in by_key}
        for keys in self.refs().values():
            roots.update(k for k in keys if k in by_key)
        per_stage: dict[str, list[ArtifactInfo]] = {}
        for i in infos:
            per_stage.setdefault(i.stage, []).append(i)
        for stage, items in per_stage.items():
            if stage in PER_ITEM_STAGES or keep_newest <= 0:
                continue
            roots.update((i.stage, i.key) for i in items[-keep_newest:])
        # input keys name no stage: index every artifact by key
        stage_of: dict[str, list[str]] = {}
        for s, k in by_key:
            stage_of.setdefault(k, []).append(s)
        kept: set[tuple[str, str]] = set()
        todo = list(roots)
        while todo:
            sk = todo.pop()
            if sk in kept:
                continue
            kept.add(sk)
            for ik in by_key[sk].inputs.values():
                todo.extend((s, ik) for s in stage_of.get(ik, []))
        kept_keys = {k for _, k in kept}
        for i in infos:
            # input keys that name no stored artifact are content hashes of committed files
            stored_inputs = [v for v in i.inputs.values() if v in stage_of]
            if i.stage in PER_ITEM_STAGES and stored_inputs and all(v in kept_keys for v in stored_inputs):
                kept.add((i.stage, i.key))
        return kept


@dataclass
class GcReport:
    """What :meth:`ArtifactStore.gc` did: ``removed`` (with ``dry_run``: what it would remove),
    ``held`` (kept: a live process holds them), ``foreign`` (not navbench's, left in place, with
    why), ``failed`` (could not be removed, with why); ``proof``: how the root was proven."""

    proof: str
    dry_run: bool = False
    removed: list = field(default_factory=list)
    held: list = field(default_factory=list)
    foreign: list = field(default_factory=list)
    failed: list = field(default_factory=list)


@dataclass(frozen=True)
class _Dir:
    stage: str
    key: str
    path: Path


def _writer_alive(name: str) -> bool:
    """Whether the process that owns temp dir ``.tmp-<key>-<pid>-<rand>`` still runs
    (:func:`navbench.proc.pid_alive`: a zombie does not)."""
    from navbench.proc import pid_alive

    try:
        pid = int(name.split("-")[2])
    except (IndexError, ValueError):
        return False
    return pid == os.getpid() or pid_alive(pid)


def read_ref(p: Path) -> list[tuple[str, str]]:
    """The ``(stage, key)`` pairs of the ref file ``p`` (through :mod:`navbench.safeio`: a
    regular file only, never blocking), or one-line :class:`ArtifactError` naming it."""
    from navbench.pipeline.ownership import is_entry_name

    how = ("; rerun the command that wrote it (e.g. navbench all) or move it aside, "
           "then run cache gc again")
    if p.is_symlink() and not p.exists():
        raise ArtifactError(f"{p}: a link to a missing file ({os.readlink(p)}){how}")
    try:
        doc = load_json(p, ArtifactError, "ref file")
    except ArtifactError as e:
        raise ArtifactError(f"{e}{how}") from None
    arts = doc.get("artifacts") if isinstance(doc, dict) else None
    if not isinstance(arts, list) or not all(
            isinstance(x, list) and len(x) == 2 and is_entry_name(*x) for x in arts):
        raise ArtifactError(f"{p}: not a ref file navbench wrote (it needs \"artifacts\": "
                            f"[[stage, 64-hex key], ...]){how}")
    return [(s, k) for s, k in arts]


def _refuse_object_arrays(d: Path, stage: str) -> None:
    """:class:`ArtifactError` when an ``.npy`` or ``.npz`` file under ``d`` holds an array of Python
    objects (it could only be read back by unpickling, which navbench never does). Reads the
    array headers only."""
    import zipfile

    from numpy.lib import format as npformat

    def has_objects(f) -> bool:
        major, _minor = npformat.read_magic(f)
        read = npformat.read_array_header_1_0 if major == 1 else npformat.read_array_header_2_0
        return bool(read(f)[2].hasobject)

    for p in sorted(d.rglob("*")):
        bad = None
        try:
            if p.suffix == ".npy" and p.is_file():
                with open(p, "rb") as f:
                    bad = p.name if has_objects(f) else None
            elif p.suffix == ".npz" and p.is_file():
                with zipfile.ZipFile(p) as z:
                    for name in z.namelist():
                        with z.open(name) as f:
                            if name.endswith(".npy") and has_objects(f):
                                bad = f"{p.name}:{name[:-4]}"
                                break
        except (OSError, ValueError, zipfile.BadZipFile) as e:
            raise ArtifactError(f"{stage}: the artifact just computed has an unreadable "
                                f"{p.relative_to(d)} ({e}); nothing was cached") from None
        if bad:
            raise ArtifactError(f"{stage}: the artifact just computed holds an array of Python "
                                f"objects ({bad}), which navbench cannot load; nothing was cached")


def run_stage(store: ArtifactStore, stage: str, config: Any, inputs: dict[str, str], version: int,
              compute: Callable[[Path], None], force: bool = False,
              log: Log = _noop, validate: Callable[[Path], None] | None = None) -> tuple[Path, str, bool]:
    """Return ``(artifact dir, key, cached)``, running ``compute(tmpdir)`` only on a miss.

    The key (:func:`stage_key`) is computed first; a verified artifact with that key is reused
    (``cached=True``, ``compute`` is not called) unless ``force``. A corrupt one is discarded
    with a warning and recomputed.
    """
    key = stage_key(stage, config, inputs, version)
    if not force:
        hit = store.lookup(stage, key, log)
        if hit is not None:
            log(f"{stage}: cached {key[:12]}")
            return hit, key, True
    log(f"{stage}: computing {key[:12]}")
    path = store.write(stage, key, compute, config=config, inputs=inputs, version=version, log=log,
                       replace=force, validate=validate)
    return path, key, False
