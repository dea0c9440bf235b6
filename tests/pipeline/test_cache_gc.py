"""``cache gc`` removes only what it proves is its own (issue 34): a root that is a navbench
cache, entries whose manifest navbench wrote, none a live process holds; --dry-run lists
exactly what a real run then removes; nothing is called removed that was not."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from navbench.pipeline.cache import ArtifactStore, run_stage
from navbench.pipeline.ownership import HOLDS_DIR, MARKER
from scripts._env import pythonpath_first
from tests.bad_input.conftest import assert_clean_error, nb, tree_snapshot
from tests.pipeline.test_cache import Counter

REPO = Path(__file__).resolve().parents[2]


def _cache(root: Path, n: int = 3) -> list[str]:
    """``n`` unreferenced artifacts of stage ``s`` in ``root`` (all removable at keep 0)."""
    store = ArtifactStore(root)
    return [run_stage(store, "s", {"v": v}, {}, 1, Counter())[1] for v in range(n)]


def _project(tmp_path: Path) -> Path:
    """A project folder: results/cache (a real cache), a published report, a database file."""
    proj = tmp_path / "proj"
    _cache(proj / "results" / "cache")
    rep = proj / "results" / "report"
    rep.mkdir(parents=True)
    (rep / "index.html").write_text("<html>report</html>")
    (rep / ".navbench-report").write_text("{}")
    (proj / "results" / "runs.db").write_bytes(b"SQLite format 3\0")
    (proj / "README.md").write_text("# my project\n")
    (proj / "levels").mkdir()
    (proj / "levels" / "a.json").write_text("{}")
    return proj


@pytest.mark.parametrize("root", ["results", ".", "results/report", "levels"])
@pytest.mark.parametrize("dry", [False, True])
def test_a_root_that_is_not_a_navbench_cache_is_refused_and_nothing_goes(tmp_path, monkeypatch, root, dry):
    proj = _project(tmp_path)
    monkeypatch.chdir(proj)
    before = tree_snapshot(proj)
    res = nb("cache", "gc", "--keep-newest", "0", "--root", root, *(["--dry-run"] if dry else []))
    assert res.code == 2, res.output
    assert_clean_error(res, f"--root {root}", "not a navbench cache")
    if root in ("results", "."):  # the slip it probably was is named
        assert "results/cache" in res.err
    assert tree_snapshot(proj) == before


def test_a_folder_without_a_manifest_navbench_wrote_is_never_removed(tmp_path, monkeypatch):
    root = tmp_path / "cache"
    keys = _cache(root, 2)
    mine = root / "s" / "my-notes"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep me")
    fake = root / "s" / ("ab" * 32)  # a key-like name whose manifest navbench did not write
    fake.mkdir()
    (fake / "manifest.json").write_text(json.dumps({"stage": "other", "key": "x"}))
    (root / "other").mkdir()
    (root / "other" / "loose.bin").write_bytes(b"x")  # a file where an entry would be
    monkeypatch.chdir(tmp_path)
    res = nb("cache", "gc", "--keep-newest", "0", "--root", "cache")
    assert res.code == 0, res.output
    assert (mine / "notes.txt").read_text() == "keep me" and (fake / "manifest.json").is_file()
    assert (root / "other" / "loose.bin").is_file()
    assert not any((root / "s" / k).exists() for k in keys)
    for p in (mine, fake, root / "other" / "loose.bin"):
        assert f"left {Path('cache') / p.relative_to(root)}: not navbench's" in res.out
    assert "removed 2 entries, 3 not navbench's" in res.out


def test_a_cache_of_an_older_navbench_without_marker_is_recognised_by_its_layout(tmp_path):
    root = tmp_path / "cache"
    keys = _cache(root, 2)
    (root / MARKER).unlink()
    ArtifactStore(root).set_ref("quick", [("s", keys[1])])
    assert not (root / MARKER).exists()  # a root navbench did not create is not claimed later
    rep = ArtifactStore(root).gc(keep_newest=0)
    assert rep.proof == "laid out as a navbench cache"
    assert [p.name for p in rep.removed] == [keys[0]] and (root / "s" / keys[1]).is_dir()


def _holder(root: Path, stage: str, key: str) -> subprocess.Popen:
    """Another process that loads ``stage/key`` (a run reading its input) and waits on stdin."""
    code = ("import sys; from navbench.pipeline.cache import ArtifactStore; "
            "ArtifactStore(sys.argv[1]).load(sys.argv[2], sys.argv[3]); print('held', flush=True); "
            "sys.stdin.read()")
    env = {**os.environ, "PYTHONPATH": pythonpath_first(REPO)}
    p = subprocess.Popen([sys.executable, "-c", code, str(root), stage, key], stdin=subprocess.PIPE,
                         stdout=subprocess.PIPE, text=True, env=env)
    assert p.stdout.readline().strip() == "held"
    return p


def test_keep_newest_0_keeps_what_a_live_process_holds_and_not_after_it_ends(tmp_path, monkeypatch):
    root = tmp_path / "cache"
    keys = _cache(root, 3)
    p = _holder(root, "s", keys[0])
    try:
        monkeypatch.chdir(tmp_path)
        res = nb("cache", "gc", "--keep-newest", "0", "--root", "cache")
        assert res.code == 0, res.output
        assert (root / "s" / keys[0] / "data.bin").read_bytes() == b"hello"
        assert not (root / "s" / keys[1]).exists() and not (root / "s" / keys[2]).exists()
        assert f"kept {Path('cache/s') / keys[0]}: in use by a running navbench process (pid {p.pid})" in res.out
        assert "removed 2 entries, 1 in use" in res.out
    finally:
        p.stdin.close()
        p.wait(timeout=30)
    # the holder is gone: its hold is stale, and the entry and the stale holder file go
    rep = ArtifactStore(root).gc(keep_newest=0)
    assert (root / "s" / keys[0]) in rep.removed and not (root / "s" / keys[0]).exists()
    assert not list((root / HOLDS_DIR).glob(f"{p.pid}-*.hold"))
    assert list((root / HOLDS_DIR).glob(f"{os.getpid()}-*.hold"))  # this live process's own stays


def test_a_holder_that_appears_while_gc_runs_gets_its_entry_back(tmp_path, monkeypatch):
    """The second look: an entry moved aside, then held by a process before the removal, is put
    back (the race of a run that starts reading while gc collects)."""
    from navbench.pipeline import cache as cache_mod

    root = tmp_path / "cache"
    keys = _cache(root, 2)
    real = cache_mod.ArtifactStore._kept
    procs = []

    def kept_then_a_run_starts(self, *a, **k):
        out = real(self, *a, **k)
        # after gc decided, before it moves anything aside: a run takes keys[0] (its load sees
        # the entry; the move aside happens after the holder line is written)
        procs.append(_holder(root, "s", keys[0]))
        return out

    monkeypatch.setattr(cache_mod.ArtifactStore, "_kept", kept_then_a_run_starts)
    try:
        rep = ArtifactStore(root).gc(keep_newest=0)
        assert (root / "s" / keys[0] / "data.bin").read_bytes() == b"hello"
        assert [p for p, _ in rep.held] == [root / "s" / keys[0]]
        assert rep.removed == [root / "s" / keys[1]]
    finally:
        for p in procs:
            p.stdin.close()
            p.wait(timeout=30)


def test_dry_run_lists_exactly_what_a_real_run_then_removes(tmp_path, monkeypatch):
    root = tmp_path / "cache"
    keys = _cache(root, 4)
    store = ArtifactStore(root)
    store.set_ref("quick", [("s", keys[3])])
    stale = root / "s" / ".tmp-deadbeef-999999999-abcd"
    stale.mkdir()
    (root / "s" / "not-ours").mkdir()
    dead = root / HOLDS_DIR / "999999999-000000000000.hold"
    dead.parent.mkdir(exist_ok=True)
    dead.write_text(json.dumps({"pid": 999999999, "start": None, "host": os.uname().nodename}) +
                    f"\ns/{keys[0]}\n")
    p = _holder(root, "s", keys[1])
    try:
        monkeypatch.chdir(tmp_path)
        dry = nb("cache", "gc", "--keep-newest", "0", "--dry-run", "--root", "cache")
        assert dry.code == 0, dry.output
        would = sorted(ln[len("would remove "):] for ln in dry.out.splitlines() if ln.startswith("would remove cache"))
        assert would == sorted(str(Path("cache") / x) for x in
                               (f"s/{keys[0]}", f"s/{keys[2]}", "s/.tmp-deadbeef-999999999-abcd",
                                f"{HOLDS_DIR}/{dead.name}"))
        assert all((tmp_path / w).exists() for w in would)  # a dry run removes nothing
        real = nb("cache", "gc", "--keep-newest", "0", "--root", "cache")
        assert real.code == 0, real.output
        removed = sorted(ln[len("removed "):] for ln in real.out.splitlines() if ln.startswith("removed cache"))
        assert removed == would
        assert not any((tmp_path / w).exists() for w in removed)
        assert (root / "s" / keys[1]).is_dir() and (root / "s" / keys[3]).is_dir()
        assert (root / "s" / "not-ours").is_dir()
    finally:
        p.stdin.close()
        p.wait(timeout=30)


def test_a_quarantine_named_link_is_left_and_never_called_removed(tmp_path, monkeypatch):
    root = tmp_path / "cache"
    _cache(root, 1)
    target = tmp_path / "precious"
    target.mkdir()
    (target / "data.txt").write_text("mine")
    link = root / "s" / ".bad-0123456789abcdef-deadbeef"
    link.symlink_to(target, target_is_directory=True)
    entry_link = root / "s" / ("cd" * 32)
    entry_link.symlink_to(target, target_is_directory=True)
    monkeypatch.chdir(tmp_path)
    res = nb("cache", "gc", "--keep-newest", "0", "--root", "cache")
    assert res.code == 0, res.output
    assert link.is_symlink() and entry_link.is_symlink() and (target / "data.txt").read_text() == "mine"
    assert f"removed {Path('cache') / link.relative_to(root)}" not in res.out
    assert f"left {Path('cache') / link.relative_to(root)}: not navbench's" in res.out
    assert "removed 1 entries, 2 not navbench's" in res.out


def test_a_new_cache_root_gets_the_marker_and_an_existing_folder_does_not(tmp_path):
    _cache(tmp_path / "fresh", 1)
    assert (tmp_path / "fresh" / MARKER).is_file()
    busy = tmp_path / "busy"
    busy.mkdir()
    (busy / "thesis.tex").write_text("x")
    _cache(busy, 1)  # a user pointed a cache at a folder of theirs: navbench does not claim it
    assert not (busy / MARKER).exists()
    before = tree_snapshot(busy)
    from navbench.errors import ConfigError

    with pytest.raises(ConfigError, match="not a navbench cache"):
        ArtifactStore(busy).gc(keep_newest=0)
    assert tree_snapshot(busy) == before


def test_temp_dirs_of_live_writers_stay_and_of_zombies_go(tmp_path, monkeypatch):
    """A temp dir is kept while its writer runs; a writer that exited but was not reaped (a
    zombie) writes nothing more, so its temp dir is stale (``navbench.proc.pid_alive``)."""
    root = tmp_path / "cache"
    _cache(root, 1)
    live = subprocess.Popen([sys.executable, "-c", "import sys; sys.stdin.read()"], stdin=subprocess.PIPE)
    zombie = subprocess.Popen([sys.executable, "-c", "pass"])
    try:
        for _ in range(200):  # wait until it has exited (not reaped: no wait() before the gc)
            with open(f"/proc/{zombie.pid}/stat") as f:
                if f.read().rsplit(")", 1)[1].split()[0] == "Z":
                    break
            time.sleep(0.05)
        kept = root / "s" / f".tmp-abc-{live.pid}-1"
        gone = root / "s" / f".tmp-abc-{zombie.pid}-1"
        kept.mkdir()
        gone.mkdir()
        monkeypatch.chdir(tmp_path)
        r = nb("cache", "gc", "--keep-newest", "1", "--root", "cache")
        assert r.code == 0, r.output
        assert kept.is_dir() and not gone.exists()
    finally:
        live.stdin.close()
        live.wait(timeout=30)
        zombie.wait(timeout=30)
