"""The stage cache: key before compute, hits skip the stage, corruption is recomputed."""

from __future__ import annotations

import json
import os

import pytest

from navbench.errors import ArtifactError
from navbench.pipeline.cache import ArtifactStore, run_stage, stage_key


class Counter:
    """A compute function that records its calls and writes deterministic files."""

    def __init__(self, payload: bytes = b"hello"):
        self.calls = 0
        self.payload = payload

    def __call__(self, d):
        self.calls += 1
        (d / "data.bin").write_bytes(self.payload)
        (d / "sub").mkdir()
        (d / "sub" / "meta.json").write_text(json.dumps({"n": self.calls}))


@pytest.fixture
def store(tmp_path):
    return ArtifactStore(tmp_path / "cache")


def test_key_depends_on_every_part_and_not_on_dict_order():
    base = stage_key("fit-map", {"steps": 10, "lr": 0.05}, {"views": "a", "eval": "b"}, 1)
    assert base == stage_key("fit-map", {"lr": 0.05, "steps": 10}, {"eval": "b", "views": "a"}, 1)
    assert base != stage_key("fit-map", {"steps": 11, "lr": 0.05}, {"views": "a", "eval": "b"}, 1)
    assert base != stage_key("fit-map", {"steps": 10, "lr": 0.05}, {"views": "c", "eval": "b"}, 1)
    assert base != stage_key("fit-map", {"steps": 10, "lr": 0.05}, {"views": "a", "eval": "b"}, 2)
    assert base != stage_key("collect-views", {"steps": 10, "lr": 0.05}, {"views": "a", "eval": "b"}, 1)
    assert len(base) == 64


def test_hit_does_not_call_the_stage(store):
    f = Counter()
    p1, k1, c1 = run_stage(store, "s", {"a": 1}, {}, 1, f)
    p2, k2, c2 = run_stage(store, "s", {"a": 1}, {}, 1, f)
    assert (c1, c2) == (False, True)
    assert f.calls == 1
    assert (p1, k1) == (p2, k2)
    assert (p2 / "data.bin").read_bytes() == b"hello"


def test_force_recomputes(store):
    f = Counter()
    run_stage(store, "s", {"a": 1}, {}, 1, f)
    _, _, cached = run_stage(store, "s", {"a": 1}, {}, 1, f, force=True)
    assert not cached and f.calls == 2


def test_an_artifact_installed_meanwhile_is_kept_not_replaced(store):
    """Two processes computing the same stage: the second to finish keeps the first's artifact
    (a reader of it must never see it vanish); only --force (replace) swaps it."""
    key = stage_key("s", {"a": 1}, {}, 1)
    first = Counter(b"first")

    def racing(d):  # another process installs the same key while this one computes
        store.write("s", key, first, config={"a": 1}, inputs={}, version=1)
        (d / "data.bin").write_bytes(b"second")

    path = store.write("s", key, racing, config={"a": 1}, inputs={}, version=1)
    assert (path / "data.bin").read_bytes() == b"first"
    inode = (path / "data.bin").stat().st_ino
    assert not [p for p in path.parent.iterdir() if p.name != key]  # our temp dir is gone
    store.write("s", key, Counter(b"third"), config={"a": 1}, inputs={}, version=1)
    assert (path / "data.bin").stat().st_ino == inode
    store.write("s", key, Counter(b"forced"), config={"a": 1}, inputs={}, version=1, replace=True)
    assert (path / "data.bin").read_bytes() == b"forced"
    store.verify("s", key)


def test_manifest_records_config_inputs_and_checksums(store):
    p, k, _ = run_stage(store, "s", {"a": 1}, {"up": "k0"}, 3, Counter())
    man = json.loads((p / "manifest.json").read_text())
    assert man["stage"] == "s" and man["key"] == k and man["config"] == {"a": 1}
    assert man["inputs"] == {"up": "k0"} and man["format_version"] == 3
    assert set(man["files"]) == {"data.bin", "sub/meta.json"}
    assert man["files"]["data.bin"]["size"] == 5
    assert man["navbench_version"] and man["created"]


@pytest.mark.parametrize("damage", ["truncate", "tamper", "delete", "manifest"])
def test_damaged_artifact_is_recomputed_with_a_warning(store, damage):
    f = Counter()
    p, k, _ = run_stage(store, "s", {"a": 1}, {}, 1, f)
    target = p / "data.bin"
    if damage == "truncate":
        target.write_bytes(b"hel")
    elif damage == "tamper":
        target.write_bytes(b"jello")  # same size, different bytes
    elif damage == "delete":
        target.unlink()
    else:
        (p / "manifest.json").write_text("{not json")
    with pytest.raises(ArtifactError):
        store.load("s", k)
    msgs = []
    p2, k2, cached = run_stage(store, "s", {"a": 1}, {}, 1, f, log=msgs.append)
    assert not cached and f.calls == 2 and k2 == k
    assert (p2 / "data.bin").read_bytes() == b"hello"
    assert any("warning" in m for m in msgs)
    store.verify("s", k)  # the recomputed artifact is valid


def test_failed_compute_leaves_nothing(store):
    def boom(d):
        (d / "partial").write_text("x")
        raise RuntimeError("stage crashed")

    with pytest.raises(RuntimeError):
        run_stage(store, "s", {"a": 1}, {}, 1, boom)
    assert list((store.root / "s").iterdir()) == []
    f = Counter()
    _, _, cached = run_stage(store, "s", {"a": 1}, {}, 1, f)
    assert not cached and f.calls == 1


def test_find_resolves_abbreviated_keys(store):
    _, k, _ = run_stage(store, "s", {"a": 1}, {}, 1, Counter())
    assert store.find(k[:10]) == ("s", k)
    with pytest.raises(ArtifactError):
        store.find("0000000000")
    with pytest.raises(ArtifactError):
        store.find("ab")


def test_gc_keeps_refs_their_inputs_and_newest(store):
    _, up_old, _ = run_stage(store, "up", {"v": 0}, {}, 1, Counter())
    _, up, _ = run_stage(store, "up", {"v": 1}, {}, 1, Counter())
    _, down_old, _ = run_stage(store, "down", {"v": 0}, {"up": up}, 1, Counter())
    _, down, _ = run_stage(store, "down", {"v": 1}, {"up": up_old}, 1, Counter())
    _, ep_kept, _ = run_stage(store, "episode", {"t": 0}, {"up": up_old}, 1, Counter())
    _, ep_gone, _ = run_stage(store, "episode", {"t": 1}, {"up": up}, 1, Counter())
    # "level" names a committed file's content hash, not a stored artifact: it does not block
    _, ep_ext, _ = run_stage(store, "episode", {"t": 2}, {"up": up_old, "level": "f" * 64}, 1, Counter())
    stale = store.root / "up" / ".tmp-deadbeef-999999999-abcd"
    stale.mkdir()
    store.set_ref("quick", [("down", down)])
    # keep_newest=0: only the ref and what it depends on survive
    removable = store.gc(keep_newest=0, dry_run=True).removed
    names = {p.name for p in removable}
    assert names == {up, down_old, ep_gone, stale.name}
    assert all(p.exists() for p in removable)  # dry run removes nothing
    store.gc(keep_newest=0)
    left = {(i.stage, i.key) for i in store.ls()}
    assert left == {("up", up_old), ("down", down), ("episode", ep_kept), ("episode", ep_ext)}
    assert not stale.exists()


def test_gc_keep_newest_per_stage(store):
    keys = [run_stage(store, "s", {"v": v}, {}, 1, Counter())[1] for v in range(3)]
    for i, k in enumerate(keys):  # make creation order unambiguous
        p = store.path("s", k) / "manifest.json"
        man = json.loads(p.read_text())
        man["created"] = f"2026-01-0{i + 1}T00:00:00+00:00"
        p.write_text(json.dumps(man))
    store.gc(keep_newest=1)
    assert [i.key for i in store.ls()] == [keys[-1]]


def test_live_writer_temp_dir_is_not_collected(store):
    from navbench.pipeline.ownership import ensure_root

    ensure_root(store.root)  # as the writer's store.write does before its temp dir
    (store.root / "s").mkdir(parents=True)
    mine = store.root / "s" / f".tmp-abc-{os.getpid()}-1234"
    mine.mkdir()
    assert mine not in store.gc(dry_run=True).removed


def test_cache_cli_ls_and_gc(store):
    from typer.testing import CliRunner

    from navbench.cli.main import app

    _, old, _ = run_stage(store, "s", {"v": 0}, {}, 1, Counter())
    _, new, _ = run_stage(store, "s", {"v": 1}, {"up": old}, 1, Counter())
    runner = CliRunner()
    res = runner.invoke(app, ["cache", "ls", "--root", str(store.root)])
    assert res.exit_code == 0, res.output
    assert old[:12] in res.output and new[:12] in res.output
    res = runner.invoke(app, ["cache", "gc", "--keep-newest", "0", "--dry-run", "--root", str(store.root)])
    assert res.exit_code == 0 and "would remove 2 entries" in res.output
    assert len(store.ls()) == 2
    store.set_ref("quick", [("s", new)])
    res = runner.invoke(app, ["cache", "gc", "--keep-newest", "0", "--root", str(store.root)])
    assert res.exit_code == 0 and "removed 0 entries" in res.output  # `old` is an input of `new`


def test_an_artifact_that_would_not_load_is_never_cached(store):
    """Issue 34: a stage that wrote an array of Python objects was cached, so every rerun failed
    the same way. Such a file, or whatever the stage's own loader refuses, is one ArtifactError
    and nothing is installed; the next run computes again."""
    import numpy as np

    def objects(d):
        np.savez(d / "study.npz", ok=np.zeros(3), bad=np.array([None, np.zeros(2)], dtype=object))

    for _ in range(2):
        with pytest.raises(ArtifactError, match=r"array of Python objects \(study.npz:bad\)"):
            run_stage(store, "s", {"a": 1}, {}, 1, objects)
        assert list((store.root / "s").iterdir()) == []

    def loader(d):
        raise ValueError("study.npz: no 'trajectories'")

    f = Counter()
    with pytest.raises(ArtifactError, match="does not load back .*no 'trajectories'"):
        run_stage(store, "s", {"a": 2}, {}, 1, f, validate=loader)
    assert list((store.root / "s").iterdir()) == []
    _, _, cached = run_stage(store, "s", {"a": 2}, {}, 1, f, validate=lambda d: None)
    assert not cached and f.calls == 2
