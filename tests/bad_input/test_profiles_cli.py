"""Bad input to profiles, names on the command line, usage errors, report publishing and the
printing of user text (issue 11, the profiles/CLI part).

One case (or parametrised family) per failure the probe found:

1. ``--report`` / ``--out`` never delete or overwrite what navbench did not publish;
2. profile and level names are safe names (they become paths);
3. every profile field is checked for type and range, the message naming file and field;
4. estimator/noise names are checked before any stage runs; a broken estimator import is not
   "unknown estimator";
5. every usage error of every command is click's short usage message with exit 2;
6. sizes from the command line and profiles are bounded before planning;
7. user text (a level name holding rich markup) is printed literally.
"""

from __future__ import annotations

from pathlib import Path

import re
import sqlite3
import sys

import pytest

from .conftest import (TINY_PROFILE, assert_clean_error, assert_usage_error, nb, tree_snapshot,
                       written_outside)


def variant(section: str, key: str, value: str, base: str = TINY_PROFILE) -> str:
    """``base`` with ``key = value`` set in TOML table ``section`` ("" = top level); the table
    is appended when the profile has none."""
    lines = base.strip("\n").split("\n")
    header = f"[{section}]" if section else None
    start = 0 if header is None else next((i + 1 for i, ln in enumerate(lines) if ln.strip() == header), None)
    if start is None:
        return "\n".join(lines) + f"\n{header}\n{key} = {value}\n"
    end = next((i for i in range(start, len(lines)) if lines[i].startswith("[")), len(lines))
    for i in range(start, end):
        if re.match(rf"{re.escape(key)}\s*=", lines[i]):
            lines[i] = f"{key} = {value}"
            break
    else:
        lines.insert(start, f"{key} = {value}")
    return "\n".join(lines) + "\n"


def _rows(db_path) -> int:
    if not db_path.exists():
        return 0
    with sqlite3.connect(db_path) as con:
        return con.execute("SELECT COUNT(*) FROM episodes").fetchone()[0]


# ------------------------------------------------------------------ 1. report publishing

@pytest.mark.slow
def test_report_destination_never_loses_data(project):
    """A ``--report``/``--out`` over results/, ., levels/, tasks/, the cache or a user's folder is
    refused before any work and deletes nothing; a new or earlier-published folder works."""
    res = nb("all", "--profile", "tiny.toml", "--report", "published")
    assert res.code == 0, res.output
    assert (project / "published" / "index.html").is_file()
    assert (project / "published" / ".navbench-report").is_file()
    (project / "mine").mkdir()
    (project / "mine" / "notes.txt").write_text("keep me")
    (project / "tasks").mkdir()
    (project / "tasks" / "t.json").write_text("{}")
    rows = _rows(project / "results" / "navbench.db")
    assert rows > 0
    before = tree_snapshot(project)
    for dest in ("results", ".", "levels", "tasks", "results/cache", "results/cache/refs",
                 str(project), "mine", "tiny.toml", "results/navbench.db"):
        res = nb("all", "--profile", "tiny.toml", "--report", dest)
        assert_clean_error(res, "--report")
        res = nb("report", "--out", dest, "--boot", "10")
        assert_clean_error(res, "--out")
        assert tree_snapshot(project) == before, dest
    assert (project / "mine" / "notes.txt").read_text() == "keep me"
    assert _rows(project / "results" / "navbench.db") == rows
    # a published folder is replaced (the rerun is cached), a new one is created
    assert nb("all", "--profile", "tiny.toml", "--report", "published").code == 0
    assert nb("report", "--out", "published", "--boot", "10").code == 0
    assert nb("report", "--out", "fresh/report", "--boot", "10").code == 0
    assert (project / "fresh" / "report" / ".navbench-report").is_file()
    assert (project / "mine" / "notes.txt").read_text() == "keep me"
    assert _rows(project / "results" / "navbench.db") == rows
    assert not written_outside(before, tree_snapshot(project),
                               ("levels/", "tasks/", "results/", "published/", "fresh/"))


def test_report_that_fails_while_writing_keeps_the_earlier_report(project, monkeypatch):
    """``report --out``: a write failing halfway (disk full) is one error line; the earlier
    report stays whole and no half-built folder is left beside it."""
    import errno

    import navbench.report.build as report_mod

    assert nb("all", "--profile", "tiny.toml", "--report", "published").code == 0
    before = tree_snapshot(project)

    def full_disk(rdb, out, **kw):
        (Path(out) / "index.html").write_text("<html>half")
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(report_mod, "build_report", full_disk)
    res = nb("report", "--out", "published", "--boot", "10")
    assert_clean_error(res, "--out published", "No space left on device")
    assert tree_snapshot(project) == before
    res = nb("report", "--out", "new/rep", "--boot", "10")
    assert_clean_error(res, "--out new/rep")
    assert not list((project / "new").iterdir()), "a half-built report was left"


def test_publish_replaces_only_what_it_published(tmp_path):
    from navbench.report.publish import REPORT_MARKER, publish
    from navbench.errors import ConfigError

    src = tmp_path / "artifact"
    src.mkdir()
    (src / "index.html").write_text("<html>1</html>")
    (src / "manifest.json").write_text("{}")
    user = tmp_path / "user"
    user.mkdir()
    (user / "data.csv").write_text("x")
    with pytest.raises(ConfigError, match="not empty"):
        publish(src, user, [])
    assert (user / "data.csv").read_text() == "x"
    # siblings named like the old temporary folders are left alone
    (tmp_path / ".out.tmp").mkdir()
    (tmp_path / ".out.tmp" / "keep").write_text("k")
    out = publish(src, tmp_path / "out", [])
    assert (out / REPORT_MARKER).is_file() and not (out / "manifest.json").exists()
    (src / "index.html").write_text("<html>2</html>")
    publish(src, tmp_path / "out", [])
    assert (tmp_path / "out" / "index.html").read_text() == "<html>2</html>"
    assert (tmp_path / ".out.tmp" / "keep").read_text() == "k"
    assert sorted(p.name for p in tmp_path.iterdir()) == [".out.tmp", "artifact", "out", "user"]


# ------------------------------------------------------------------ 2-3. profile names and fields

BAD_FIELDS = [
    ("", "name", '"../../../escape"', "name"),
    ("", "name", '"a/b"', "name"),
    ("", "level_seed", '"one"', "level_seed"),
    ("", "level_seed", "-1", "level_seed"),
    ("", "levels", '["../x"]', "levels"),
    ("", "levels", "[]", "levels"),
    ("", "description", "3", "description"),
    ("views", "count", '"100"', "[views] count"),
    ("views", "count", "0", "[views] count"),
    ("views", "count", "true", "[views] count"),
    ("views", "camera", '"wide"', "[views] camera"),
    ("views", "eval_count", "1.5", "[views] eval_count"),
    ("views", "eval_seed", "0", "eval_seed"),  # the held-out views = the training views
    ("fit", "steps", '"fifty"', "[fit] steps"),
    ("fit", "steps", "-1", "[fit] steps"),
    ("fit", "lr", '"abc"', "[fit] lr"),
    ("fit", "lr", "-1", "[fit] lr"),
    ("fit", "lr", "nan", "[fit] lr"),
    ("fit", "grid_shape", "[16, 12]", "[fit] grid_shape"),
    ("fit", "grid_shape", "[16, 12, 0]", "[fit] grid_shape"),
    ("fit", "grid_shape", "[100000, 100000, 100]", "[fit] grid_shape"),
    ("fit", "threads", "true", "[fit] threads"),
    ("fit", "tau", "1.5", "[fit] tau"),
    ("fit", "init", '"solid"', "[fit] init"),
    ("fit", "device", '"tpu"', "[fit]"),
    ("fit", "nonsense", "1", "[fit] nonsense"),
    ("tasks", "count", '"100"', "[tasks] count"),
    ("tasks", "count", "true", "[tasks] count"),
    ("tasks", "seed", "-3", "[tasks] seed"),
    ("navigation", "seeds", "100000000", "[navigation] seeds"),
    ("navigation", "seeds", "0", "[navigation] seeds"),
    ("navigation", "workers", "-1", "[navigation] workers"),
    ("navigation", "workers", "100000", "[navigation] workers"),
    ("navigation", "estimators", '["dynamics", "ourz"]', "[navigation] estimators", "ourz", "dynamics"),
    ("navigation", "estimators", "[]", "[navigation] estimators"),
    ("navigation", "estimators", '["gt", "gt"]', "[navigation] estimators"),
    ("navigation", "noise", '["loud"]', "[navigation] noise", "loud", "mid"),
    ("navigation", "map", '"guess"', "[navigation] map"),
    ("navigation.episode", "max_steps", "-1", "[navigation.episode] max_steps"),
    ("navigation.episode", "max_steps", '"many"', "[navigation.episode] max_steps"),
    ("navigation.episode", "body_fixed_drive", "1", "[navigation.episode] body_fixed_drive"),
    ("navigation.episode", "goal_tolerance", "-0.5", "[navigation.episode] goal_tolerance"),
    ("navigation.episode", "nope", "1", "[navigation.episode] nope"),
    ("navigation.episode.planner", "step", '"x"', "[navigation.episode] planner.step"),
    ("navigation.episode.controller", "lookahead", "0", "[navigation.episode] controller.lookahead"),
    ("navigation.options.dynamics", "seed", "5", "[navigation.options.dynamics] seed"),
    ("navigation.options.ours", "seed", "5", "[navigation.options.ours] seed"),
    ("navigation.options.ours", "adam_steps", "0", "[navigation.options.ours] adam_steps"),
    ("navigation.options.ours", "adam_steps", "true", "[navigation.options.ours] adam_steps"),
    ("navigation.options.ours", "optimizer", '"sgd"', "[navigation.options.ours] optimizer"),
    ("navigation.options.ours", "prior_sigma", "[1]", "[navigation.options.ours] prior_sigma"),
    ("navigation.options.ours", "nonsense", "1", "[navigation.options.ours] nonsense"),
    ("navigation.options.emission", "steps", '"x"', "[navigation.options.emission] steps"),
    ("navigation.options.gt", "x", "1", "[navigation.options.gt]"),
    ("navigation.options.ourz", "x", "1", "[navigation.options.ourz]", "ourz"),
]


@pytest.mark.parametrize("section,key,value,names", [(*c[:3], c[3:]) for c in BAD_FIELDS],
                         ids=[f"{c[0] or 'top'}.{c[1]}={c[2]}" for c in BAD_FIELDS])
def test_bad_profile_field_is_one_line_naming_file_and_field(project, tmp_path, section, key, value, names):
    (project / "bad.toml").write_text(variant(section, key, value))
    before = tree_snapshot(tmp_path)
    res = nb("run-navigation", "--profile", "bad.toml")
    assert_clean_error(res, "bad.toml", *names)
    assert tree_snapshot(tmp_path) == before  # nothing written: the profile fails before any stage


def test_valid_profile_variants_load_with_values_unchanged(project):
    """The checks accept what they should: ints for floats, options and episode tables; values
    are kept as written (so the cache keys of valid profiles do not change)."""
    from navbench.pipeline.profiles import load_profile

    text = variant("fit", "lr", "1")
    text = variant("navigation.episode", "max_steps", "50", text)
    text = variant("navigation.episode.planner", "step", "0.3", text)
    text = variant("navigation.options.ours", "prior_sigma", "[0.05, 0.1]", text)
    # under navbench-1, whose settings table is empty: only what the file writes
    text = variant("", "benchmark_version", '"navbench-1"', text)
    (project / "ok.toml").write_text(text)
    p = load_profile("ok.toml")
    assert p.fit["lr"] == 1 and isinstance(p.fit["lr"], int)
    assert p.episode == {"max_steps": 50, "planner": {"step": 0.3}}
    assert p.estimator_options == {"ours": {"prior_sigma": [0.05, 0.1]}}
    for name in ("quick", "paper", "six"):
        load_profile(name)


@pytest.mark.parametrize("arg", ["../../../escape", "../tiny", "/etc/passwd", "a b", ""])
def test_profile_argument_that_is_not_a_profile(project, tmp_path, arg):
    before = tree_snapshot(tmp_path)
    res = nb("run-navigation", "--profile", arg) if arg else nb("run-navigation", "--profile", "x..y")
    assert_clean_error(res, "--profile")
    assert tree_snapshot(tmp_path) == before


# ------------------------------------------------------------------ 4. names before any stage

@pytest.mark.parametrize("args,names", [
    (["--estimators", "dynamics,ourz"], ["--estimators", "ourz", "dynamics", "gt"]),
    (["--estimators", ",,"], ["--estimators"]),
    (["--estimators", ""], ["--estimators"]),
    (["--noise", "low,loud"], ["--noise", "loud"]),
    (["--noise", ","], ["--noise"]),
    (["--map", "guess"], ["--map"]),
    (["../escape"], ["LEVELS", "../escape"]),
    (["tiny", "[/x]"], ["LEVELS", "[/x]"]),
])
def test_bad_names_fail_before_any_stage(project, tmp_path, args, names):
    before = tree_snapshot(tmp_path)
    res = nb("run-navigation", "--profile", "tiny.toml", *args)
    assert_clean_error(res, *names)
    assert tree_snapshot(tmp_path) == before  # no views, map, tasks, database rows
    assert not (project / "results").exists()


def test_track_eval_checks_estimator_names_first(project, tmp_path):
    before = tree_snapshot(tmp_path)
    assert_clean_error(nb("track-eval", "tiny", "--estimators", "dynamics,ourz"), "--estimators", "ourz")
    assert_clean_error(nb("track-eval", "tiny", "--estimators", ",,"), "--estimators")
    assert_clean_error(nb("track-eval", "tiny", "-o", "ourz.steps=3"), "--option", "ourz")
    assert tree_snapshot(tmp_path) == before


def test_broken_estimator_import_is_not_unknown_estimator(monkeypatch):
    """registry.py must not swallow an import error of an estimator module."""
    monkeypatch.delitem(sys.modules, "navbench.track.registry", raising=False)
    monkeypatch.setitem(sys.modules, "navbench.track.emission", None)  # import raises ImportError
    with pytest.raises(ImportError, match="navbench.track.emission"):
        import navbench.track.registry  # noqa: F401


# ------------------------------------------------------------------ 5. usage errors, every command

def _commands():
    """``[(path, click command)]`` of every leaf command of the app."""
    import typer.main

    from navbench.cli.main import app

    out = []

    def walk(cmd, path):
        subs = getattr(cmd, "commands", None)
        if subs:
            for name, sub in sorted(subs.items()):
                walk(sub, [*path, name])
        else:
            out.append((tuple(path), cmd))

    walk(typer.main.get_command(app), [])
    return out


COMMANDS = _commands()


def _required_args(cmd) -> list[str]:
    return ["tiny" for p in cmd.params if p.param_type_name == "argument" and p.required]


def test_every_command_is_covered():
    names = {" ".join(p) for p, _ in COMMANDS}
    assert {"all", "score", "report", "run-navigation", "cache gc", "db runs", "track-eval"} <= names


@pytest.mark.parametrize("path", [p for p, _ in COMMANDS], ids=[" ".join(p) for p, _ in COMMANDS])
def test_unknown_option_is_usage_error(project, path):
    cmd = dict(COMMANDS)[path]
    assert_usage_error(nb(*path, *_required_args(cmd), "--no-such-option"), "--no-such-option")


RANGED = [(path, p.opts[0], value)
          for path, cmd in COMMANDS for p in cmd.params if p.param_type_name == "option"
          for value in ([p.min - 1] if getattr(p, "min", None) is not None else [])
          + ([p.max + 1] if getattr(p, "max", None) is not None else [])]


@pytest.mark.parametrize("path,option,value", RANGED,
                         ids=[f"{' '.join(p)} {o} {v}" for p, o, v in RANGED])
def test_out_of_range_option_is_usage_error(project, tmp_path, path, option, value):
    cmd = dict(COMMANDS)[path]
    before = tree_snapshot(tmp_path)
    assert_usage_error(nb(*path, *_required_args(cmd), option, str(value)), option)
    assert tree_snapshot(tmp_path) == before


def test_every_count_option_is_bounded_above():
    """Options that allocate or loop in proportion to their value have a maximum (item 6)."""
    unbounded = [f"{' '.join(path)} {p.opts[0]}" for path, cmd in COMMANDS for p in cmd.params
                 if p.param_type_name == "option" and getattr(p, "min", None) is not None
                 and getattr(p, "max", None) is None
                 and p.name not in ("seed", "keep_newest", "last", "chunk", "count")]
    assert not unbounded, unbounded


WITH_ARGS = [(p, c) for p, c in COMMANDS if _required_args(c)]


@pytest.mark.parametrize("path", [p for p, _ in WITH_ARGS], ids=[" ".join(p) for p, _ in WITH_ARGS])
def test_missing_argument_is_usage_error(project, path):
    assert_usage_error(nb(*path), "Missing")


@pytest.mark.parametrize("args", [["score", "--format", "xml"], ["all", "--workers", "-1"],
                                  ["run-navigation", "--count", "0"], ["nonsense-command"],
                                  ["score", "--boot", "many"]])
def test_usage_errors_from_the_probe(project, args):
    assert_usage_error(nb(*args))


def test_exit_and_abort_keep_their_codes(monkeypatch):
    import typer

    from navbench.cli import main as cli_main

    sub = typer.Typer()

    @sub.command()
    def leave():
        raise typer.Exit(4)

    @sub.command()
    def stop():
        raise typer.Abort()

    monkeypatch.setattr(cli_main, "app", sub)
    assert nb("leave").code == 4
    res = nb("stop")
    assert res.code == 1 and "Traceback" not in res.output


# ------------------------------------------------------------------ 6. sizes

def test_seeds_beyond_the_limit_fail_at_once(project, tmp_path):
    before = tree_snapshot(tmp_path)
    assert_usage_error(nb("run-navigation", "--profile", "tiny.toml", "--seeds", "100000000"), "--seeds")
    assert tree_snapshot(tmp_path) == before


def test_grid_beyond_ten_million_episodes_is_refused_before_planning(project, tmp_path):
    (project / "big.toml").write_text(variant("tasks", "count", "100000"))
    before = tree_snapshot(tmp_path)
    res = nb("run-navigation", "--profile", "big.toml", "--seeds", "10000")
    assert_clean_error(res, "2,000,000,000 episodes", "10,000,000")
    assert tree_snapshot(tmp_path) == before


# ------------------------------------------------------------------ 7. user text is not markup

def test_markup_in_a_stored_level_name_is_printed_literally(project, monkeypatch):
    from navbench.cli import _common
    from navbench.results.db import ResultsDB
    from tests.pipeline.test_db import episode

    db = ResultsDB("sqlite:///results/navbench.db")
    run = db.start_run("[bold]p[/x]", "navbench [/x]", {}, "k")
    db.add_episodes(run, [episode("c1", 0, level="[/x]", estimator="ours", success=True, spl_term=0.5),
                          episode("c1", 1, level="[/x]", estimator="ours", success=False, spl_term=0.0)])
    db.finish_run(run)
    db.close()
    monkeypatch.setattr(_common.console, "_width", 300)  # no wrapping inside the table cells
    res = nb("score", "--boot", "20")
    assert res.code == 0, res.output
    assert "[/x]" in res.out
    res = nb("db", "runs")
    assert res.code == 0, res.output
    assert "[/x]" in res.out and "[bold]p" in res.out


def test_markup_in_an_error_message_is_printed_literally(project):
    res = nb("run-navigation", "--profile", "[/x].toml")
    assert_clean_error(res, "[/x]")


def test_a_republish_never_takes_a_users_file_with_it(tmp_path):
    """A published report folder is navbench's, but a file a user put in it is not: the republish
    (which swaps the folder whole) is refused in one line and the file survives; without it the
    republish goes through. An older marker (before it listed the files) allows only index.html
    and the CSV tables at the top."""
    from navbench.errors import ConfigError
    from navbench.report.publish import REPORT_MARKER, publish

    src = tmp_path / "artifact"
    src.mkdir()
    (src / "index.html").write_text("<html>1</html>")
    (src / "scores.csv").write_text("a\n")
    out = publish(src, tmp_path / "out", [])
    (out / "my-annotations.txt").write_text("mine")
    with pytest.raises(ConfigError, match="my-annotations.txt") as e:
        publish(src, out, [])
    assert "\n" not in str(e.value)
    assert (out / "my-annotations.txt").read_text() == "mine"
    (out / "my-annotations.txt").unlink()
    (src / "index.html").write_text("<html>2</html>")
    publish(src, out, [])
    assert (out / "index.html").read_text() == "<html>2</html>"
    # a marker written before the list: index.html and CSVs are navbench's, anything else is not
    (out / REPORT_MARKER).write_text("written by navbench; the next report replaces this folder\n")
    publish(src, out, [])
    (out / REPORT_MARKER).write_text("written by navbench; the next report replaces this folder\n")
    (out / "notes").mkdir()
    (out / "notes" / "n.txt").write_text("n")
    with pytest.raises(ConfigError, match="notes/n.txt"):
        publish(src, out, [])
    assert (out / "notes" / "n.txt").read_text() == "n"
