"""Issue 34, third probe round: what a blind probe still found after the first two rounds.

Each test fails on the code before its fix: an unreadable ref made ``cache gc`` collect an
entry the latest run uses; a dangling committed task file, a NaN inside an ``-o`` list, a
60 000-deep ``--set`` value gave tracebacks; an unusable ``NUMBA_CACHE_DIR`` and a ``--cache``
that is not a folder were accepted.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from navbench.pipeline.cache import ArtifactStore, run_stage
from tests.bad_input.conftest import assert_clean_error, nb, tree_snapshot
from tests.pipeline.test_cache import Counter


# ----------------------------------------------------------------------------- cache gc, bad refs
def _ref_damage(p: Path, kind: str) -> None:
    good = p.read_text()
    p.unlink()
    if kind == "truncated":
        p.write_text(good[: len(good) // 2])
    elif kind == "traversal":
        p.write_text(json.dumps({"name": "all-tiny", "updated": 0,
                                 "artifacts": [["..", "../../notes"], ["s", "../../../notes"]]}))
    elif kind == "bad-pairs":
        p.write_text(json.dumps({"name": "all-tiny", "artifacts": [[1, 2, 3], None, "x"]}))
    elif kind == "dict":
        p.write_text(json.dumps({"name": "all-tiny", "artifacts": {}}))
    elif kind == "list":
        p.write_text("[]")
    elif kind == "dangling":
        p.symlink_to(p.parent / "gone.json")
    elif kind == "fifo":
        os.mkfifo(p)
    elif kind == "directory":
        p.mkdir()
    elif kind == "latin1":
        p.write_bytes(good.replace('"name"', '"n\xe4me"').encode("latin-1"))
    else:
        raise ValueError(kind)


@pytest.mark.parametrize("dry", [False, True])
@pytest.mark.parametrize("kind", ["truncated", "traversal", "bad-pairs", "dict", "list", "dangling",
                                  "fifo", "directory", "latin1"])
def test_gc_refuses_when_a_ref_cannot_be_read_and_removes_nothing(tmp_path, monkeypatch, kind, dry):
    root = tmp_path / "cache"
    store = ArtifactStore(root)
    keys = [run_stage(store, "s", {"v": v}, {}, 1, Counter())[1] for v in range(3)]
    ref = store.set_ref("all-tiny", [("s", keys[0])])  # the latest run uses the oldest entry
    _ref_damage(ref, kind)
    monkeypatch.chdir(tmp_path)
    before = tree_snapshot(root)
    res = nb("cache", "gc", "--keep-newest", "0", "--root", "cache", *(["--dry-run"] if dry else []))
    assert res.code == 2, res.output
    assert_clean_error(res, "all-tiny.json")
    assert "would remove" not in res.out and "removed" not in res.out
    assert tree_snapshot(root) == before
    assert all((root / "s" / k / "manifest.json").is_file() for k in keys)


def test_gc_reads_a_utf16_ref_or_refuses_it_never_ignores_it(tmp_path, monkeypatch):
    root = tmp_path / "cache"
    store = ArtifactStore(root)
    keys = [run_stage(store, "s", {"v": v}, {}, 1, Counter())[1] for v in range(2)]
    ref = store.set_ref("all-tiny", [("s", keys[0])])
    ref.write_bytes(ref.read_text().encode("utf-16"))
    monkeypatch.chdir(tmp_path)
    res = nb("cache", "gc", "--keep-newest", "0", "--root", "cache")
    assert "Traceback" not in res.output
    assert (root / "s" / keys[0] / "manifest.json").is_file()  # what the ref names is kept
    if res.code != 0:
        assert_clean_error(res, "all-tiny.json")


def test_gc_refuses_a_refs_folder_that_is_a_file(tmp_path, monkeypatch):
    root = tmp_path / "cache"
    store = ArtifactStore(root)
    keys = [run_stage(store, "s", {"v": v}, {}, 1, Counter())[1] for v in range(2)]
    (root / "refs").write_text("not a folder")
    monkeypatch.chdir(tmp_path)
    res = nb("cache", "gc", "--keep-newest", "0", "--root", "cache")
    assert_clean_error(res, "refs")
    assert all((root / "s" / k).is_dir() for k in keys)


def test_gc_still_keeps_a_ref_of_entries_that_are_gone(tmp_path, monkeypatch):
    """A well-formed ref naming a key no longer stored is no reason to refuse."""
    root = tmp_path / "cache"
    store = ArtifactStore(root)
    keys = [run_stage(store, "s", {"v": v}, {}, 1, Counter())[1] for v in range(2)]
    store.set_ref("all-tiny", [("s", keys[0]), ("fit-map", "0" * 64)])
    rep = store.gc(keep_newest=0)
    assert [p.name for p in rep.removed] == [keys[1]] and (root / "s" / keys[0]).is_dir()


# ----------------------------------------------------------------------------- task files
@pytest.mark.parametrize("args", [["tiny", "--count", "2"], []])
def test_level_difficulty_refuses_a_dangling_task_file_in_one_line(project, args):
    (project / "tasks").mkdir()
    (project / "tasks" / "tiny-200-730d65ed.json").symlink_to(project / "no" / "such" / "target")
    res = nb("level-difficulty", *args)
    assert res.code == 2, res.output
    assert_clean_error(res, "tiny-200-730d65ed.json")


# ----------------------------------------------------------------------------- -o values
@pytest.mark.parametrize("value", ["[nan,1,1]", "[1,inf]", "abc", "[true,1]", "[[1],2]"])
def test_track_sequence_checks_estimator_options_before_reading_anything(project, value):
    from tests.bad_input.test_views import make_tum

    tum = make_tum(project.parent / "tum")
    res = nb("track-sequence", tum, "--no-store", "--out", "est.txt", "--estimator", "ours",
             "--map", "nothere.npz", "-o", f"prior_sigma={value}")
    assert res.code == 2, res.output
    assert_clean_error(res, "prior_sigma")
    assert not (project / "est.txt").exists()


@pytest.mark.parametrize("value", ["[nan,1,1]", [float("nan"), 1.0], [True, 1], "12", [[1], 2]])
def test_estimator_option_conversion_refuses_what_is_no_list_of_finite_numbers(value):
    """The conversion every estimator runs on its options (a library user, a plugin): one
    TrackingError naming the option, never a ValueError from float('[')."""
    from navbench.errors import TrackingError
    from navbench.track.base import config_from_options
    from navbench.track.trackconfig import TrackerConfig

    with pytest.raises(TrackingError, match="prior_sigma"):
        config_from_options(TrackerConfig(), {"prior_sigma": value}, "tracker")
    assert config_from_options(TrackerConfig(), {"prior_sigma": [1, 2.5]}, "t").prior_sigma == (1.0, 2.5)


# ----------------------------------------------------------------------------- --set values
_DEEP = "[" * 45_000 + "1" + "]" * 45_000  # under the length limit, far over the depth limit


@pytest.mark.parametrize("item, says", [
    (f"fit.lr={_DEEP}", "nested more than 64 levels deep"),
    (f"levels={_DEEP}", "nested more than 64 levels deep"),
    (f"navigation.options.ours.prior_sigma={_DEEP}", "nested more than 64 levels deep"),
    ("fit.lr=" + "[" * 70 + "]" * 70, "nested more than 64 levels deep"),
    ("tasks.count=" + "9" * 5000, "digits"),
    ("fit.lr=[" + "1," * 60_000 + "1]", "at most 100000"),
])
def test_set_values_are_held_to_the_limits_of_option_values(project, item, says):
    before = tree_snapshot(project)
    res = nb("all", "--profile", "tiny.toml", "--set", item)
    assert res.code == 2, res.output[-2000:]
    assert_clean_error(res, "--set " + item.split("=")[0], says)
    assert len(res.err) < 1000
    assert tree_snapshot(project) == before


# ----------------------------------------------------------------------------- environment
@pytest.mark.skipif(not Path("/proc/self").exists(), reason="needs Linux /proc")
@pytest.mark.parametrize("value", ["/proc/nope", "/proc/nope/deeper", "/proc/self"])
def test_a_numba_cache_dir_that_cannot_be_made_or_written_is_refused(project, monkeypatch, value):
    """Permission bits say yes to root on /proc; only trying to make the folder and a file in
    it tells (numba then wrote its cache beside the package and the command exited 0)."""
    monkeypatch.setenv("NUMBA_CACHE_DIR", value)
    res = nb("sample-tasks", "tiny", "--count", "2")
    assert res.code == 2, res.output
    assert_clean_error(res, "NUMBA_CACHE_DIR", value)
    assert not Path("tasks").exists()


def test_a_numba_cache_dir_that_can_be_made_is_made_and_used(project, monkeypatch, tmp_path):
    folder = tmp_path / "new" / "numba"
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(folder))
    res = nb("sample-tasks", "tiny", "--count", "2")
    assert res.code == 0, res.output
    assert folder.is_dir() and not [p for p in folder.iterdir() if p.name.startswith(".navbench-probe")]


# ----------------------------------------------------------------------------- report --cache
@pytest.mark.parametrize("case", ["dev-zero", "default-is-a-file", "file", "dangling"])
def test_report_refuses_a_cache_that_is_not_a_folder(project, case):
    from navbench.results.db import ResultsDB

    Path("results").mkdir()
    with ResultsDB("sqlite:///results/navbench.db"):
        pass
    args, named = [], "results/cache"
    if case == "dev-zero":
        args, named = ["--cache", "/dev/zero"], "/dev/zero"
    elif case == "default-is-a-file":
        Path("results/cache").write_text("my notes, not a cache\n")
    elif case == "file":
        Path("notes.txt").write_text("mine\n")
        args, named = ["--cache", "notes.txt"], "notes.txt"
    else:
        Path("results/cache").symlink_to(project / "gone")
    before = tree_snapshot(project)
    res = nb("report", "--boot", "10", *args)
    assert res.code == 2, res.output
    assert_clean_error(res, "--cache", named, "not a folder")
    assert tree_snapshot(project) == before and not Path("results/report").exists()


def test_a_ctrl_c_swallowed_by_a_finaliser_ends_the_command_as_interrupted(monkeypatch, capsys):
    """A Ctrl-C that lands in a weakref callback (the blind probe's `report` at 1.9 s: "Exception
    ignored in: <function WeakKeyDictionary...> KeyboardInterrupt" with a traceback, then exit 0)
    prints nothing there, and the command ends with one line and exit 130; any other
    unraisable error still goes to Python's own hook."""
    import sys
    import weakref
    from types import SimpleNamespace

    import typer

    from navbench.cli import main as cli_main

    class Thing:
        pass

    def callback(_ref):
        raise KeyboardInterrupt

    monkeypatch.setattr(cli_main, "_SWALLOWED_INTERRUPT", [])
    monkeypatch.setattr(sys, "unraisablehook", cli_main._unraisable_hook)
    thing = Thing()
    ref = weakref.ref(thing, callback)
    del thing  # the callback raises KeyboardInterrupt: unraisable
    assert ref() is None and cli_main._SWALLOWED_INTERRUPT == [True]
    assert "Traceback" not in capsys.readouterr().err

    seen = []
    monkeypatch.setattr(sys, "__unraisablehook__", lambda u: seen.append(u.exc_type))
    cli_main._unraisable_hook(SimpleNamespace(exc_type=ValueError, exc_value=ValueError("x"),
                                              exc_traceback=None, err_msg=None, object=None))
    assert seen == [ValueError]

    # a command that finished after such a Ctrl-C ends as interrupted: one line, exit 130
    app = typer.Typer()

    @app.command()
    def work() -> None:
        cli_main._SWALLOWED_INTERRUPT.append(True)

    monkeypatch.setattr(cli_main, "app", app)
    with pytest.raises(SystemExit) as e:
        cli_main.main([])
    assert e.value.code == 130
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert err == ["interrupted"]


def test_goal_localizer_fields_with_their_own_range_take_negative_values():
    """`row_top` (the signature's top elevation, default -0.3) has the range [-10, 10]: its own
    default was refused by a blanket ">= 0" rule; fields without a range of their own keep it."""
    from navbench.pipeline.checks import _check_goal_localizer, _Invalid

    _check_goal_localizer({"row_top": -0.3, "row_step": -0.1})
    with pytest.raises(_Invalid, match="row_top"):
        _check_goal_localizer({"row_top": -20.0})
    with pytest.raises(_Invalid, match="nms_radius: .*>= 0"):
        _check_goal_localizer({"nms_radius": -1.0})
