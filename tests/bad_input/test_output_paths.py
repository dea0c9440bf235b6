"""Probe: every command that writes to a path the user names (``--out``, ``--report``, ``DIR``).

A wrong output path -- a suffix the writer does not support, a folder where a file goes, a
file where a folder goes, a parent that is a file, a place nobody can write (``/proc``) -- is
one ``error:`` line naming the path, exit 2, checked before the work, and nothing written:
no half file, no stray folder, no input overwritten. Paths holding rich markup are printed
as text.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.bad_input.conftest import assert_clean_error, nb, tree_snapshot
from tests.bad_input.test_levels_tasks import TRUE_MAP_PROFILE
from tests.bad_input.test_views import make_tum


UNWRITABLE = Path("/proc/navbench-out")  # /proc refuses new files, even to root


@pytest.fixture
def afile(project) -> Path:
    """A regular file in the project, used where a folder is expected."""
    p = project / "afile"
    p.write_text("keep me\n")
    return p


@pytest.fixture
def adir(project) -> Path:
    """A non-empty folder in the project, used where a file is expected."""
    d = project / "adir"
    d.mkdir()
    (d / "keep").write_text("keep me\n")
    return d


def _unchanged(project: Path, before: dict) -> None:
    after = tree_snapshot(project)
    assert after == before, sorted(set(after.items()) ^ set(before.items()))


def _bad(project: Path, kind: str) -> tuple[str, str]:
    """``(path given, text the error must name)`` for a bad output of ``kind``."""
    return {
        "parent-file": ("afile/x", "afile is a file, not a folder"),
        "unwritable": (str(UNWRITABLE), "cannot write in /proc"),
    }[kind]


# ------------------------------------------------------------------ show-level --out FILE

@pytest.mark.parametrize("out, says", [
    ("x.txt", "suffix '.txt'"),
    ("nosuffix", "no suffix"),
    ("adir", "is a folder"),
    ("afile/x.png", "afile is a file, not a folder"),
    (str(UNWRITABLE / "x.png"), "cannot write in /proc"),
])
def test_show_level_bad_out(project, afile, adir, out, says):
    before = tree_snapshot(project)
    res = nb("show-level", "tiny", "--out", out)
    assert_clean_error(res, f"--out {out}", says)
    assert res.code == 2
    _unchanged(project, before)  # no x.txt, no nosuffix.png / adir.png, no temporary file


def test_show_level_unsupported_suffix_names_the_accepted_ones(project):
    res = nb("show-level", "tiny", "--out", "x.txt")
    assert_clean_error(res, "x.txt", ".png", ".svg", ".pdf")


def test_show_level_other_formats_and_markup_still_work(project):
    for out in ("a.svg", "b.PNG", "[bold]c[/x].pdf"):
        res = nb("show-level", "tiny", "--out", out)
        assert res.code == 0, res.output
        assert Path(out).is_file() and Path(out).stat().st_size > 0
        assert out in res.out.replace("\n", "")
    assert not [p for p in project.rglob("*") if ".tmp" in p.name]


# ------------------------------------------------------------------ sample-tasks --out DIR

@pytest.mark.parametrize("out, says", [
    ("levels/tiny.json", "names a file"),  # once: the level silently overwritten by the tasks
    ("t.json", "names a file"),
    ("afile", "is a file, not a folder"),
    ("afile/sub", "afile is a file, not a folder"),
    (str(UNWRITABLE), "cannot write in /proc"),
])
def test_sample_tasks_bad_out(project, afile, out, says):
    level = (project / "levels" / "tiny.json").read_text()
    before = tree_snapshot(project)
    res = nb("sample-tasks", "tiny", "--count", "2", "--out", out)
    assert_clean_error(res, f"--out {out}", says)
    _unchanged(project, before)
    assert (project / "levels" / "tiny.json").read_text() == level
    assert afile.read_text() == "keep me\n"


def test_sample_tasks_out_is_always_a_folder(project):
    res = nb("sample-tasks", "tiny", "--count", "2", "--out", "tasks.v2")
    assert res.code == 0, res.output
    assert Path("tasks.v2").is_dir() and len(list(Path("tasks.v2").glob("tiny-2-*.json"))) == 1


# ------------------------------------------------------------------ report --out / all --report

@pytest.mark.parametrize("case", ["parent-file", "unwritable", "html"])
def test_report_bad_out(project, afile, case):
    out, says = ("rep.html", "the report is a folder") if case == "html" else _bad(project, case)
    before = tree_snapshot(project)
    res = nb("report", "--boot", "10", "--trajectories", "0", "--out", out)
    assert_clean_error(res, f"--out {out}", says)
    _unchanged(project, before)
    assert not Path("rep.html").exists()


@pytest.mark.parametrize("case", ["parent-file", "unwritable", "html"])
def test_all_bad_report_is_refused_before_any_work(project, afile, case):
    out, says = ("rep.html", "the report is a folder") if case == "html" else _bad(project, case)
    res = nb("all", "--profile", "tiny.toml", "--report", out)
    assert_clean_error(res, f"--report {out}", says)
    assert not (project / "results").exists()  # no stage ran, no database made


# ------------------------------------------------------------------ import-views / export-views

@pytest.fixture
def tum(tmp_path) -> Path:
    return make_tum(tmp_path / "seq")


@pytest.mark.parametrize("out, says", [
    ("afile/v.npz", "afile is a file, not a folder"),
    ("afile/vdir", "afile is a file, not a folder"),
    (str(UNWRITABLE / "v.npz"), "cannot write in /proc"),
    ("v.txt", "a views artifact is a folder"),
    ("v.NPZ", "not .NPZ"),
])
def test_import_views_bad_out(project, afile, tum, out, says):
    before = tree_snapshot(project)
    res = nb("import-views", tum, "--out", out)
    assert_clean_error(res, f"--out {out}", says)
    _unchanged(project, before)


def test_import_and_export_views_print_markup_paths_as_text(project, tum):
    views = "[bold]v[/x].npz"
    res = nb("import-views", tum, "--out", views)
    assert res.code == 0 and "Traceback" not in res.output, res.output
    assert views in res.out.replace("\n", "") and Path(views).is_file()
    out = "[bold]t[/y]"
    res = nb("export-views", views, out)
    assert res.code == 0 and "Traceback" not in res.output, res.output
    assert out in res.out.replace("\n", "")
    assert (Path(out) / "groundtruth.txt").is_file()


@pytest.mark.parametrize("out, says", [
    ("afile", "is a file, not a folder"),
    ("afile/sub", "afile is a file, not a folder"),
    (str(UNWRITABLE), "cannot write in /proc"),
])
def test_export_views_bad_dir(project, afile, tum, out, says):
    assert nb("import-views", tum, "--out", "v.npz").code == 0
    before = tree_snapshot(project)
    res = nb("export-views", "v.npz", out)
    assert_clean_error(res, f"DIR {out}", says)
    _unchanged(project, before)


# ------------------------------------------------------------------ track-sequence --out FILE

@pytest.mark.parametrize("out, says", [
    ("est.png", "suffix '.png'"),
    ("levels/tiny.json", "suffix '.json'"),
    ("adir", "is a folder"),
    ("afile/est.txt", "afile is a file, not a folder"),
    (str(UNWRITABLE / "est.txt"), "cannot write in /proc"),
])
def test_track_sequence_bad_out(project, afile, adir, tum, out, says):
    before = tree_snapshot(project)
    res = nb("track-sequence", tum, "--estimator", "dynamics", "--no-store", "--out", out)
    assert_clean_error(res, f"--out {out}", says)
    _unchanged(project, before)


def test_track_sequence_never_overwrites_its_inputs(project, tum):
    gt = tum / "groundtruth.txt"
    text = gt.read_text()
    res = nb("track-sequence", tum, "--estimator", "dynamics", "--no-store", "--out", gt)
    assert_clean_error(res, f"--out {gt}", "is an input")
    assert gt.read_text() == text
    odo = project / "odo.txt"
    odo.write_text(text)
    res = nb("track-sequence", tum, "--estimator", "dynamics", "--no-store", "--odometry", odo,
             "--out", odo)
    assert_clean_error(res, f"--out {odo}", "is an input")
    assert odo.read_text() == text


def test_track_sequence_good_out(project, tum):
    res = nb("track-sequence", tum, "--estimator", "dynamics", "--no-store", "--out", "[b]e[/x].txt")
    assert res.code == 0, res.output
    lines = Path("[b]e[/x].txt").read_text().splitlines()
    assert len(lines) == 3 and all(len(ln.split()) == 8 for ln in lines)
    assert not [p for p in project.rglob("*") if ".tmp" in p.name]


# ------------------------------------------------------------------ export-trajectories DIR

@pytest.mark.parametrize("out, says", [
    ("afile", "is a file, not a folder"),
    ("afile/sub", "afile is a file, not a folder"),
    (str(UNWRITABLE), "cannot write in /proc"),
])
def test_export_trajectories_bad_dir_before_the_database(project, afile, out, says):
    res = nb("export-trajectories", out)
    assert_clean_error(res, f"DIR {out}", says)
    assert not (project / "results").exists()  # refused before the database was opened


def test_export_trajectories_failed_write_leaves_no_partial_export(project, monkeypatch):
    (project / "tinytrue.toml").write_text(TRUE_MAP_PROFILE)
    res = nb("run-navigation", "--profile", "tinytrue.toml")
    assert res.code == 0, res.output
    import navbench.worldmodel.tumtraj as tumtraj

    real, calls = tumtraj.write_trajectory, []

    def failing(path, *a, **k):  # the first file is written, the second fails (disk full)
        calls.append(path)
        if len(calls) > 1:
            raise OSError(28, "No space left on device")
        return real(path, *a, **k)

    monkeypatch.setattr(tumtraj, "write_trajectory", failing)
    res = nb("export-trajectories", "traj")
    assert_clean_error(res, "traj", "No space left on device")
    assert len(calls) == 2 and not Path("traj").exists()
    monkeypatch.setattr(tumtraj, "write_trajectory", real)
    res = nb("export-trajectories", "traj")
    assert res.code == 0, res.output
    assert (Path("traj") / "index.csv").is_file()


# ------------------------------------------------------------------ make-level

def test_make_level_when_levels_is_a_file(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    Path("levels").write_text("not a folder\n")
    res = nb("make-level", "foo", "--seed", "1")
    assert_clean_error(res, "levels/foo.json", "levels is a file, not a folder")
    assert Path("levels").read_text() == "not a folder\n"


def test_make_level_over_a_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    Path("levels/foo.json").mkdir(parents=True)
    res = nb("make-level", "foo", "--seed", "1", "--force")
    assert_clean_error(res, "levels/foo.json", "is a folder")
    assert Path("levels/foo.json").is_dir()


# ------------------------------------------------------------------ cache --root, --db sqlite folder

@pytest.mark.parametrize("cmd", [("cache", "ls"), ("cache", "gc"), ("cache", "gc", "--dry-run")])
def test_cache_root_that_is_a_file(project, afile, cmd):
    before = tree_snapshot(project)
    res = nb(*cmd, "--root", "afile")
    assert_clean_error(res, "--root afile", "is a file, not a cache folder")
    _unchanged(project, before)


def test_cache_root_that_does_not_exist_is_an_empty_cache(project):
    res = nb("cache", "ls", "--root", "nope")
    assert res.code == 0 and "no cache at nope yet: 0 artifacts" in res.out, res.output
    res = nb("cache", "gc", "--root", "nope")
    assert res.code == 0 and "nothing to remove" in res.out, res.output
    assert not (project / "nope").exists()


def test_db_folder_under_a_file_names_the_file(project, afile):
    """Creating a database (run-navigation, all, ...) under a file: the message names the file."""
    from navbench.errors import DatabaseError
    from navbench.results.db import ResultsDB

    with pytest.raises(DatabaseError, match="afile/x.db: afile is a file, not a folder$"):
        ResultsDB("sqlite:///afile/x.db", create=True)
    assert afile.read_text() == "keep me\n"
