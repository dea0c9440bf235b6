"""Findings of the third blind probe (issue 34) fixed as classes: each test names its finding."""

from __future__ import annotations

import pytest
import typer

from tests.bad_input.conftest import assert_clean_error, assert_usage_error, nb


def _seed_options():
    from navbench.cli.main import app

    out = []

    def walk(cmd, path):
        for name, sub in getattr(cmd, "commands", {}).items():
            walk(sub, (*path, name))
        for p in getattr(cmd, "params", []):
            if "--seed" in getattr(p, "opts", ()):
                out.append((" ".join(path), p))

    walk(typer.main.get_command(app), ())
    return out


def test_every_seed_option_takes_exactly_the_seeds_numpy_accepts():
    """P-011: compare --seed had no lower bound (-1 was a numpy traceback); every --seed of
    every command is an integer in [0, 2**63 - 1], refused by click in one usage line."""
    seeds = _seed_options()
    assert len(seeds) >= 10, seeds
    for path, p in seeds:
        assert (p.min, p.max) == (0, 2**63 - 1), (path, p.min, p.max)


@pytest.mark.parametrize("value", ["-1", str(2**63)])
def test_compare_seed_out_of_range_is_a_usage_error(project, value):
    assert_usage_error(nb("compare", "--seed", value, "--pair", "no-map:ours"), "--seed")


@pytest.mark.parametrize("args", [["all", "--profile", "tiny.toml"], ["fit-map", "tiny", "--profile", "tiny.toml"],
                                  ["cache", "ls"], ["report", "--out", "rep"]])
def test_a_symbolic_link_loop_is_one_line_naming_the_path(project, args):
    """P-007: results/cache as a link loop was a traceback from ``all`` (``Path.resolve()``
    raises RuntimeError "Symlink loop"); that and the ELOOP of open/stat are one line, exit 2,
    for every command; nothing is removed."""
    (project / "results").mkdir()
    (project / "results" / "cache").symlink_to("cache.loop2")
    (project / "results" / "cache.loop2").symlink_to("cache")
    res = nb(*args)
    assert res.code == 2, res.output
    assert_clean_error(res)
    assert (project / "results" / "cache").is_symlink() and (project / "results" / "cache.loop2").is_symlink()


def test_the_loop_runtime_error_is_read_as_eloop():
    import errno

    from navbench.cli.main import _env_oserror

    try:
        try:
            raise RuntimeError("Symlink loop from '/x/results/cache'")
        except RuntimeError as e:
            raise ValueError("wrapped") from e
    except ValueError as outer:
        ose = _env_oserror(outer)
    assert ose is not None and ose.errno == errno.ELOOP and ose.filename == "/x/results/cache"
    assert _env_oserror(RuntimeError("something else")) is None


@pytest.mark.parametrize("edit, shown", [
    (lambda t: t.update(target_x=t["start_x"], target_y=t["start_y"]), "optimal_length"),  # was 0 / 0
    (lambda t: t.update(optimal_length=t["optimal_length"] + 5.0), "optimal_length: says"),
    (lambda t: t.update(start_x=-3.0), "start_x, start_y"),
])
def test_level_difficulty_checks_the_task_file_as_run_navigation_does(project, edit, shown):
    """P-008: level-difficulty read task files without the checks of run-navigation: a task whose
    start is its target was a ZeroDivisionError traceback, a wrong optimal_length was measured."""
    import json

    assert nb("sample-tasks", "tiny", "--count", "3").code == 0
    path = next((project / "tasks").glob("tiny-3-*.json"))
    assert nb("level-difficulty", "tiny").code == 0
    doc = json.loads(path.read_text())
    edit(doc["tasks"][0])
    path.write_text(json.dumps(doc))
    res = nb("level-difficulty", "tiny")
    assert res.code == 2, res.output
    assert_clean_error(res, path.name, "tasks[0]", shown)


@pytest.mark.parametrize("box", [[[-1e300, -1e300, 0], [1e300, 1e300, 1.2]], [[0, 0, 0], [2e6, 5, 1.2]]])
def test_an_absurd_views_box_is_refused_in_intrinsics_json_and_in_a_views_file(project, box):
    """P-016: intrinsics.json's box of +-1e300 m was imported and a map fitted over it (cells
    1e298 m wide) and scored. A box corner beyond 1e6 m is refused by import-views and by the
    views-file loader (fit-map --views of a file written elsewhere)."""
    import json

    from navbench.errors import ArtifactError
    from navbench.geometry import Intrinsics
    from navbench.levelio import load_level
    from navbench.worldmodel.tum import export_views
    from navbench.worldmodel.views import collect_views, load_views, save_views

    v = collect_views(load_level(project / "levels" / "tiny.json"), 4, Intrinsics(16, 12, 7.5, 7.5, 8.0, 6.0), seed=0)
    seq = export_views(v, project / "seq")
    info = json.loads((seq / "intrinsics.json").read_text())
    info["box"] = box
    (seq / "intrinsics.json").write_text(json.dumps(info))
    res = nb("import-views", "seq", "--out", "v2.npz")
    assert res.code == 2, res.output
    assert_clean_error(res, "intrinsics.json", "box", "within 1e+06 m")
    assert not (project / "v2.npz").exists()
    v.box = (tuple(map(float, box[0])), tuple(map(float, box[1])))
    save_views(v, project / "far.npz")
    with pytest.raises(ArtifactError, match="beyond 1e"):
        load_views(project / "far.npz")
    res = nb("fit-map", "--views", "far.npz", "--profile", "tiny.toml", "--device", "cpu")
    assert res.code == 2, res.output
    assert_clean_error(res, "far.npz", "box")
    assert not (project / "results" / "cache" / "fit-map").exists()


def test_a_cache_root_that_cannot_be_created_is_one_line(project, monkeypatch):
    """P-017: NAVBENCH_CACHE under /proc (mkdir fails with ENOENT) was a traceback from the
    first write; the cache root is made in one place, which now names it in one line."""
    monkeypatch.setenv("NAVBENCH_CACHE", "/proc/navbench-probe/x")
    res = nb("fit-map", "tiny", "--profile", "tiny.toml", "--device", "cpu")
    assert res.code == 2, res.output
    assert_clean_error(res, "/proc/navbench-probe/x", "cannot create the stage cache")


def test_a_profile_that_is_a_link_loop_is_one_line(project):
    """P-018 (the P-007 class: resolve() raises RuntimeError on a loop)."""
    (project / "p.toml").symlink_to("p.toml.loop2")
    (project / "p.toml.loop2").symlink_to("p.toml")
    res = nb("all", "--profile", "p.toml")
    assert res.code == 2, res.output
    assert_clean_error(res, "p.toml", "symbolic-link loop")


def test_ctrl_c_while_the_cli_is_still_importing_is_one_line(project):
    """P-006: Ctrl-C in the first second (while ``navbench.cli.main`` imports typer, the
    commands and the bundled profiles) was a KeyboardInterrupt traceback and death by SIGINT;
    it is now the same ``interrupted`` line and exit 130 as later. SIGINT is set to its default
    action in the child, as in a terminal (a background job of a script ignores it)."""
    import os
    import signal
    import subprocess
    import sys
    import time
    from pathlib import Path

    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    for delay in (0.15, 0.3, 0.5):
        p = subprocess.Popen([sys.executable, "-m", "navbench.cli.main", "cache", "ls"], cwd=project,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                             preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
        time.sleep(delay)
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=60)
        assert "Traceback" not in err, (delay, err)
        if p.returncode == -signal.SIGINT and not err:
            continue  # killed before the interpreter had installed its own handler (a loaded
            # machine's start-up; CPython's, out of navbench's reach); the bug printed a traceback
        if p.returncode != 0:  # 0: it finished before the signal came (a fast machine)
            # 130, or death by SIGINT after the line: a shell reports both as status 130. The
            # second was seen once, in CI beside a loaded machine (2026-11-27, delay 0.5 s): the
            # line printed, then the process died by SIGINT (CPython re-raises SIGINT at exit
            # when its unhandled-interrupt flag is set; which path set it was not traced)
            assert p.returncode in (130, -signal.SIGINT) and err.strip().splitlines() == ["interrupted"], \
                (delay, p.returncode, err)


def test_a_library_import_keeps_its_own_ctrl_c():
    """The early handler is the navbench command's only: importing the CLI elsewhere (here,
    pytest) leaves SIGINT alone."""
    import signal

    import navbench.cli.main  # noqa: F401

    assert signal.getsignal(signal.SIGINT) is not navbench.cli._interrupted_during_import


def test_level_difficulty_refuses_a_task_file_of_another_level(project):
    """P-008 addendum: a task file saying "level": "other" was measured on this level."""
    import json

    assert nb("sample-tasks", "tiny", "--count", "3").code == 0
    path = next((project / "tasks").glob("tiny-3-*.json"))
    doc = json.loads(path.read_text())
    doc["level"] = "house-2"
    path.write_text(json.dumps(doc))
    res = nb("level-difficulty", "tiny")
    assert res.code == 2, res.output
    assert_clean_error(res, path.name, "level: says 'house-2'")


def test_an_empty_views_file_is_refused_naming_it(project):
    """P-019: a views file of 0 views was refused by export-views naming the level inside, not
    the file; every reader of views files now refuses it on load, naming the file."""
    import numpy as np

    from navbench.geometry import Intrinsics
    from navbench.levelio import load_level
    from navbench.worldmodel.views import collect_views, save_views

    v = collect_views(load_level(project / "levels" / "tiny.json"), 2, Intrinsics(16, 12, 7.5, 7.5, 8.0, 6.0), seed=0)
    save_views(v.subset(np.zeros(0, dtype=np.int64)), project / "empty.npz")
    for args in (["export-views", "empty.npz", "exv"],
                 ["fit-map", "--views", "empty.npz", "--profile", "tiny.toml", "--device", "cpu"]):
        res = nb(*args)
        assert res.code == 2, res.output
        assert_clean_error(res, "empty.npz", "holds no views")
    assert not (project / "exv").exists()


def test_a_refused_run_adds_to_its_cache_ref_never_replaces_it(project):
    """P-005: a run-navigation refused part-way (here: a map file that does not load) rewrote
    ``refs/run-navigation-<profile>.json`` with the few entries it had touched, so the last
    finished run's episodes and task set lost gc's protection. An unfinished run now adds to
    the ref; a finished one replaces it."""
    import json

    args = ["run-navigation", "--profile", "tiny.toml", "--estimators", "gt"]
    assert nb(*args, "--set", "navigation.map=true").code == 0
    ref = project / "results" / "cache" / "refs" / "run-navigation-tinytest.json"
    before = {tuple(x) for x in json.loads(ref.read_text())["artifacts"]}
    assert any(s == "episode" for s, _ in before)
    (project / "bad.npz").write_text("not a map")
    res = nb(*args, "--set", "navigation.map=bad.npz")
    assert res.code == 2, res.output
    after = {tuple(x) for x in json.loads(ref.read_text())["artifacts"]}
    assert before <= after, sorted(before - after)
    dry = nb("cache", "gc", "--keep-newest", "0", "--dry-run")
    assert dry.code == 0, dry.output
    for stage, key in before:
        assert key[:12] not in dry.out, (stage, key, dry.out)


def test_a_refused_run_writes_no_cache_ref(project):
    """Rerun of the third probe: a run-navigation refused for a map file that does not load
    (a refused command stores nothing and its run is discarded) still created
    ``refs/run-navigation-<profile>.json``: a write by a refused command. It writes none now."""
    (project / "bad.npz").write_text("not a map")
    res = nb("run-navigation", "--profile", "tiny.toml", "--estimators", "gt", "--set", "navigation.map=bad.npz")
    assert res.code == 2, res.output
    refs = project / "results" / "cache" / "refs"
    assert not refs.exists() or not any(refs.iterdir()), sorted(refs.iterdir())


@pytest.mark.parametrize("option, value", [("--max-tilt", "1e300"), ("--max-tilt", "181"),
                                           ("--max-dt", "1e300"), ("--max-height-dev", "1e9"),
                                           ("--fx", "1e300"), ("--cx", "-1e300")])
def test_absurd_import_tolerances_are_refused(project, option, value):
    """P-020: --max-tilt 1e300 silently disabled the tilt check; the import options now have
    the bound of every float setting (1e6; a tilt at most 180 degrees)."""
    (project / "seq").mkdir()
    res = nb("import-views", "seq", "--out", "v.npz", option, value)
    assert res.code == 2, res.output
    assert_clean_error(res, option)


def test_report_levels_that_is_a_file_is_refused(project):
    """P-020: report --levels FILE was ignored (rc 0, a report without the level figures)."""
    (project / "notlevels.txt").write_text("x")
    res = nb("report", "--levels", "notlevels.txt", "--out", "rep")
    assert res.code == 2, res.output
    assert_clean_error(res, "--levels", "not a folder")
    assert not (project / "rep").exists()


@pytest.mark.parametrize("name", ["", "   "])
def test_an_empty_profile_name_is_refused_not_the_default(project, name):
    """Rerun of the third probe on the fixed code: ``--profile ''`` ran the default profile
    (minutes of work for a typo); an empty name is now one line naming the choices."""
    res = nb("all", "--profile", name)
    assert_clean_error(res, "--profile", "empty profile name")
    assert res.code == 2
    assert not (project / "results" / "navbench.db").exists()


def test_cache_ls_of_an_unknown_stage_is_refused_with_the_nearest_name(project):
    """Rerun of the third probe: ``cache ls --stage fitmap`` listed an empty table with exit 0,
    as if nothing were cached; a stage that does not exist is one line naming the stages."""
    res = nb("cache", "ls", "--stage", "fitmap")
    assert_clean_error(res, "--stage", "fitmap", "did you mean 'fit-map'")
    assert res.code == 2
    assert nb("cache", "ls", "--stage", "fit-map").code == 0
