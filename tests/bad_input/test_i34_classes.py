"""Issue 34, the classes of the second hostile-input probe, each closed in one place:

1. nesting deep enough to exhaust Python's recursion (:mod:`navbench.safeio`);
2. paths that are not regular files, and inputs large enough to make a check quadratic;
3. numbers that are finite but absurd (:mod:`navbench.pipeline.checks`, the CLI's float parser);
4. the environment (:func:`navbench.cli.main.main`);
5. interruption (Ctrl-C inside a kernel; the build folders a ``kill -9`` leaves);
6. messages that name the wrong thing.

Each test failed before its fix. The generated cases are in ``test_fuzz.py``.
"""

from __future__ import annotations

import errno
import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from .conftest import (TINY_PROFILE, assert_clean_error, assert_usage_error, db_row_counts, deadline,
                       nb, nb_subprocess, tree_snapshot)

DEEP = 100_000  # far past Python's recursion limit




# ----------------------------------------------------------------------------- 1. deep nesting

def test_deep_toml_profile_is_one_line_naming_the_file(project):
    Path("deep.toml").write_text('name = "x"\na = ' + "[" * DEEP + "]" * DEEP + "\n")
    assert_clean_error(nb("run-navigation", "--profile", "deep.toml"), "deep.toml", "nested")
    Path("deep2.toml").write_text('name = "x"\na = ' + "{b = " * 5000 + "1" + "}" * 5000 + "\n")
    assert_clean_error(nb("run-navigation", "--profile", "deep2.toml"), "deep2.toml", "nested")


@pytest.mark.parametrize("cmd", [
    ["track-sequence", "seq", "--map", "m.npz"],
    ["localize-eval", "tiny", "--map", "true"],
    ["track-eval", "tiny", "--map", "true", "--estimators", "ours"],
])
def test_deep_option_values_are_one_line(project, cmd):
    deep = "[" * 5000 + "]" * 5000  # under the length limit, past the recursion limit
    key = "ours.steps" if cmd[0] == "track-eval" else "steps"
    assert_clean_error(nb(*cmd, "-o", f"{key}={deep}"), "--option", "nested")


def test_deep_task_file_intrinsics_and_views_header_are_one_line(project, tmp_path):
    from navbench.errors import ArtifactError, TaskError
    from navbench.plan.tasks import read_task_file
    from navbench.worldmodel.tum import import_views as load_tum_views
    from navbench.worldmodel.views import load_views

    deep = "[" * DEEP + "]" * DEEP
    Path("tasks").mkdir()
    Path("tasks/t.json").write_text(deep)
    with pytest.raises(TaskError, match=r"tasks/t\.json: .*nested"):
        read_task_file("tasks/t.json")
    seq = tmp_path / "seq"
    seq.mkdir()
    (seq / "intrinsics.json").write_text(deep)
    with pytest.raises(ArtifactError, match="intrinsics.json: .*nested"):
        load_tum_views(seq)
    v = tmp_path / "views"
    v.mkdir()
    (v / "views.json").write_text(deep)
    with pytest.raises(ArtifactError, match="views.json: .*nested"):
        load_views(v)


def test_parsed_but_deep_documents_are_refused_before_any_recursive_walk(project):
    """A value 500 deep parses (the C parser's limit is higher) but would overflow a later
    recursive walk (hashing, validation): refused by the depth bound."""
    from navbench.errors import ConfigError
    from navbench.safeio import MAX_DEPTH, loads_json, parse_option_value

    doc = "[" * 500 + "]" * 500
    with pytest.raises(ConfigError, match=f"more than {MAX_DEPTH} levels"):
        loads_json(doc, "x.json", ConfigError)
    with pytest.raises(ConfigError, match="-o a: nested"):
        parse_option_value(doc, "-o a")
    assert loads_json("[" * MAX_DEPTH + "]" * MAX_DEPTH, "x", ConfigError) is not None


# ------------------------------------------------------------ 2. not regular files, huge inputs

def test_fifo_directory_and_device_are_refused_without_blocking(project, tmp_path):
    os.mkfifo("levels/fifo.json")
    os.mkfifo("fifo.toml")
    Path("dir.toml").mkdir()
    with deadline(60):
        assert_clean_error(nb("sample-tasks", "levels/fifo.json"), "levels/fifo.json", "FIFO")
        assert_clean_error(nb("sample-tasks", "/dev/zero"), "/dev/zero", "device")
        assert_clean_error(nb("run-navigation", "--profile", "fifo.toml"), "fifo.toml", "FIFO")
        assert_clean_error(nb("run-navigation", "--profile", "dir.toml"), "dir.toml", "directory")
        os.mkfifo("m.npz")
        assert_clean_error(nb("track-eval", "tiny", "--map", "m.npz", "--estimators", "ours"),
                           "m.npz", "FIFO")
        seq = tmp_path / "seq"
        seq.mkdir()
        os.mkfifo(seq / "intrinsics.json")
        assert_clean_error(nb("import-views", str(seq), "--out", "v.npz"), "intrinsics.json", "FIFO")


def test_huge_houseexpo_outline_is_refused_before_the_quadratic_check(project, tmp_path):
    n = 20_000
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    verts = np.c_[5 + 4 * np.cos(t), 5 + 4 * np.sin(t)].round(6).tolist()
    doc = tmp_path / "house.json"
    doc.write_text(json.dumps({"verts": verts, "bbox": {"min": [0, 0], "max": [10, 10]}}))
    with deadline(60):  # the check took minutes before
        res = nb("make-level", "big", "--seed", "0", "--from-houseexpo", str(doc))
    assert_clean_error(res, str(doc), "20000 points", "at most")
    assert not Path("levels/big.json").exists()


@pytest.mark.parametrize("far", [1e300, 1e-300])
def test_absurd_houseexpo_coordinates_are_one_line(project, tmp_path, far):
    """One vertex at 1e300 m (the rest collapse to a point once scaled: an IndexError)."""
    doc = tmp_path / "house.json"
    verts = [[0, 0], [6, 0], [6, 4], [far, far], [0, 6]]
    doc.write_text(json.dumps({"verts": verts, "bbox": {"min": [0, 0], "max": [max(6, far), max(6, far)]}}))
    res = nb("make-level", "far", "--seed", "0", "--from-houseexpo", str(doc))
    if far < 1:  # a tiny coordinate is a valid house
        assert res.code == 0, res.output
    else:
        assert_clean_error(res, str(doc), "verts")


def test_huge_text_file_is_refused_by_size_first(project):
    from navbench.errors import LevelError
    from navbench.levelio import MAX_LEVEL_BYTES, load_level

    with open("levels/huge.json", "wb") as f:
        f.truncate(MAX_LEVEL_BYTES + 1)  # sparse: no disk used
    with pytest.raises(LevelError, match="huge.json: .* MB; a level file may be at most"):
        load_level("levels/huge.json")


# ---------------------------------------------------------------- 3. finite but absurd numbers

def with_line(profile: str, section: str, line: str) -> str:
    """``profile`` with ``line`` in its ``[section]`` table (added when missing)."""
    head = f"[{section}]\n"
    return profile.replace(head, head + line + "\n", 1) if head in profile else profile + f"\n{head}{line}\n"


@pytest.mark.parametrize("section, line, named", [
    ("fit", "lr = 1e308", "lr"),
    ("fit", "lr = 1e30", "lr"),
    ("fit", "sigma2_init = 1e300", "sigma2_init"),
    ("navigation.episode.planner", "step = 1e-9", "planner.step"),
    ("navigation.goal_localizer", "lattice_step = 1e-9", "lattice_step"),
    ("fit", "lr = nan", "lr"),
    ("fit", "lr = inf", "lr"),
    ("fit", "lr = 1e400", "lr"),
    ("tasks", "seed = -1", "seed"),
])
def test_absurd_profile_numbers_are_refused_on_load(project, section, line, named):
    Path("bad.toml").write_text(with_line(TINY_PROFILE, section, line))
    res = nb("run-navigation", "--profile", "bad.toml", "--map", "true")
    assert_clean_error(res, "bad.toml", named)
    assert not Path("results/cache").exists()  # refused before any stage ran


def test_absurd_localizer_option_is_refused_before_the_bank(project):
    from navbench.cli.commands.localize_eval import _localizer_config
    from navbench.errors import ConfigError

    with pytest.raises(ConfigError, match="--option lattice_step: expected a number in"):
        _localizer_config(["lattice_step=1e-9"])
    with pytest.raises(ConfigError, match="not a finite number"):
        _localizer_config(["clearance=NaN"])


@pytest.mark.parametrize("args, option", [
    (["export-trajectories", "--dt", "nan"], "--dt"),
    (["export-trajectories", "--dt", "inf"], "--dt"),
    (["make-level", "x", "--seed", "0", "--size", "nan"], "--size"),
    (["import-views", "d", "--out", "v.npz", "--max-dt", "-inf"], "--max-dt"),
    (["import-views", "d", "--out", "v.npz", "--fx", "1e400"], "--fx"),
])
def test_non_finite_cli_numbers_are_one_line_naming_the_option(project, args, option):
    """Every float option of every command (one parser, :func:`navbench.cli.main._finite_numbers`)."""
    res = nb(*args)
    assert_clean_error(res, option, "finite")
    assert res.code == 2


@pytest.mark.parametrize("args, option", [
    (["sample-tasks", "tiny", "--seed", "-1"], "--seed"),
    (["score", "--seed", "-5"], "--seed"),
    (["bench", "--seed", "-5"], "--seed"),
    (["sample-tasks", "tiny", "--count", "1" + "0" * 30], "--count"),
])
def test_negative_seeds_and_huge_integers_are_usage_errors(project, args, option):
    assert_usage_error(nb(*args), option)


def test_nan_and_infinity_in_option_values_are_refused(project):
    for value in ("NaN", "Infinity", "-Infinity", "1e400", "nan", "inf"):
        res = nb("track-sequence", "seq", "--map", "m.npz", "-o", f"prior_sigma={value}")
        assert_clean_error(res, "--option prior_sigma", "finite")


def test_a_diverged_fit_fails_in_one_line_and_caches_nothing(project, monkeypatch):
    import navbench.worldmodel.fit as fit

    real = fit.fit_map

    def diverging(views, config, progress=None, **kw):
        vmap, metrics = real(views, config, progress=progress, **kw)
        vmap.col[...] = np.inf  # what lr = 1e30 produced: a map with infinite colours
        return vmap, metrics

    monkeypatch.setattr(fit, "fit_map", diverging)
    res = nb("fit-map", "tiny", "--profile", "tiny.toml", "--db", "sqlite:///results/navbench.db")
    assert_clean_error(res, "diverged", "colour")
    fm = Path("results/cache/fit-map")
    assert not fm.exists() or not list(fm.iterdir())  # neither the artifact nor a temp folder
    assert not any(k.endswith(":maps") and v for k, v in db_row_counts(project).items())


# ---------------------------------------------------------------------------- 4. environment

@pytest.mark.parametrize("var, value", [
    ("NUMBA_NUM_THREADS", "abc"), ("NUMBA_NUM_THREADS", "0"), ("OMP_NUM_THREADS", "-3"),
    ("OMP_NUM_THREADS", "lots"), ("NUMBA_CACHE_DIR", "/dev/null/cache"), ("NUMBA_CACHE_DIR", ""),
])
def test_unusable_environment_variables_are_refused_in_one_line(project, monkeypatch, var, value):
    monkeypatch.setenv(var, value)
    res = nb("sample-tasks", "tiny", "--count", "2")
    assert_clean_error(res, var)
    assert res.code == 2 and not Path("tasks").exists()


def test_garbage_mplbackend_and_ascii_streams_still_work(project):
    env = {"MPLBACKEND": "no-such-backend", "PYTHONIOENCODING": "ascii"}
    res = nb_subprocess("show-level", "tiny", "--out", "tiny.png", cwd=project, env=env)
    assert res.code == 0, res.output
    assert Path("tiny.png").stat().st_size > 0
    # a message holding a character the stream cannot encode is still one line
    res = nb_subprocess("show-level", "levels/caf\u00e9.json", cwd=project, env=env)
    assert_clean_error(res, "levels/caf")


def test_cache_path_that_is_a_file_is_one_line(project):
    Path("results").mkdir()
    Path("results/cache").write_text("not a folder")
    res = nb("fit-map", "tiny", "--profile", "tiny.toml")
    assert_clean_error(res, "results/cache")
    assert Path("results/cache").read_text() == "not a folder"


def test_disk_full_while_the_map_is_written_is_one_line_and_leaves_no_temp(project, monkeypatch):
    from navbench.worldmodel.grid import VoxelMap

    def full(self, path, *a, **kw):
        Path(path).write_bytes(b"partial")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))

    monkeypatch.setattr(VoxelMap, "save", full)
    res = nb("fit-map", "tiny", "--profile", "tiny.toml")
    assert_clean_error(res, "No space left on device", "map.npz")
    fm = Path("results/cache/fit-map")
    assert not fm.exists() or not list(fm.iterdir())


# ---------------------------------------------------------------------------- 5. interruption

def test_ctrl_c_inside_a_kernel_is_one_line_exit_130_and_no_temp(project, monkeypatch):
    """Ctrl-C during a numba kernel comes back as SystemError(...) from KeyboardInterrupt
    (a standalone fit-map printed that chain)."""
    import navbench.worldmodel.fit as fit

    def interrupted(*a, **kw):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as e:
            raise SystemError("CPUDispatcher(<function gather_cells>) returned a result with an "
                              "exception set") from e

    monkeypatch.setattr(fit, "fit_map", interrupted)
    res = nb("fit-map", "tiny", "--profile", "tiny.toml")
    assert res.code == 130, res.output
    assert "Traceback" not in res.output and "SystemError" not in res.output
    assert len([ln for ln in res.output.splitlines() if "interrupted" in ln]) == 1
    fm = Path("results/cache/fit-map")
    assert not fm.exists() or not list(fm.iterdir())


@pytest.mark.slow
def test_real_sigint_during_fit_map_is_one_line(project):
    """A real Ctrl-C during the fit: it aborted the process ("terminate called after throwing
    an instance of 'pybind11::error_already_set'") or printed a SystemError chain."""
    Path("long.toml").write_text(TINY_PROFILE.replace("steps = 3", "steps = 100000"))
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    # SIGINT's default action restored in the child (a shell's background job ignores it)
    p = subprocess.Popen([sys.executable, "-m", "navbench.cli.main", "fit-map", "tiny", "--profile",
                          "long.toml"], cwd=project, env=env, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        import time

        t0 = time.monotonic()
        while time.monotonic() - t0 < 240:  # until the fit's temp folder exists
            fm = project / "results/cache/fit-map"
            if fm.is_dir() and any(fm.iterdir()):
                break
            time.sleep(0.2)
        time.sleep(1.5)  # into the fit's kernels
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=120)
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode == 130, err
    assert "Traceback" not in out + err and "interrupted" in out + err, out + err
    assert len([ln for ln in (out + err).splitlines() if "interrupted" in ln]) == 1
    fm = project / "results/cache/fit-map"
    assert not fm.exists() or not list(fm.iterdir())


def test_deferred_interrupt_is_raised_at_the_checkpoint_not_before():
    from navbench.interrupts import checked, checkpoint, deferred

    calls = []
    # a suite started from a background job inherits SIGINT ignored, where deferred() rightly
    # does nothing: give this test Python's default handler, as an interactive run has
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            with deferred():
                os.kill(os.getpid(), signal.SIGINT)  # handled at once, in this (main) thread
                calls.append("after the signal")  # not interrupted here
                checked(lambda: calls.append("progress"))()  # raises before calling it
        assert calls == ["after the signal"]
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
        checkpoint()  # nothing pending any more
    finally:
        signal.signal(signal.SIGINT, before)


def _dead_owner() -> tuple[int, str | None]:
    from navbench.pipeline.executor import process_start_token

    p = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    token = process_start_token(p.pid)
    p.kill()
    p.wait()
    return p.pid, token


def test_stale_report_build_folders_are_removed_only_when_provably_ours(project):
    from navbench.outpath import BUILD_OWNER_FILE, make_build_dir, remove_stale_build_dirs

    dest = project / "results" / "report"
    dest.parent.mkdir(parents=True)
    pid, token = _dead_owner()
    stale = dest.parent / ".report.dead1234.build"
    stale.mkdir()
    (stale / "index.html").write_text("half")
    (stale / BUILD_OWNER_FILE).write_text(json.dumps({"pid": pid, "start_token": token, "dest": "report"}))
    stale_tmp = dest.parent / ".report.dead5678.tmp"
    stale_tmp.mkdir()
    (stale_tmp / BUILD_OWNER_FILE).write_text(json.dumps({"pid": pid, "start_token": token, "dest": "report"}))
    foreign = dest.parent / ".report.user.build"  # no owner file: not provably ours
    foreign.mkdir()
    (foreign / "notes.txt").write_text("mine")
    other = dest.parent / ".report.other.build"  # owned by another output's build
    other.mkdir()
    (other / BUILD_OWNER_FILE).write_text(json.dumps({"pid": pid, "start_token": token, "dest": "x"}))
    live = make_build_dir(dest)  # this process: alive
    removed = remove_stale_build_dirs(dest)
    assert sorted(removed) == sorted([stale, stale_tmp])
    assert not stale.exists() and not stale_tmp.exists()
    assert (foreign / "notes.txt").read_text() == "mine" and other.is_dir() and live.is_dir()


def test_report_run_removes_a_killed_reports_build_folder(project):
    from navbench.outpath import BUILD_OWNER_FILE
    from navbench.results.db import ResultsDB

    Path("results").mkdir()
    with ResultsDB("sqlite:///results/navbench.db"):
        pass
    pid, token = _dead_owner()
    stale = Path("results/.report.killed.build")
    stale.mkdir()
    (stale / BUILD_OWNER_FILE).write_text(json.dumps({"pid": pid, "start_token": token, "dest": "report"}))
    nb("report", "--db", "sqlite:///results/navbench.db", "--out", "results/report")
    assert not stale.exists()
    assert not list(Path("results").glob(".report.*"))


# ------------------------------------------------------------------- 6. the wrong thing named

def test_refused_executor_or_address_inserts_no_run(project):
    Path("results").mkdir()
    from navbench.results.db import ResultsDB

    with ResultsDB("sqlite:///results/navbench.db"):
        pass
    before = db_row_counts(project)
    assert_clean_error(nb("run-navigation", "--profile", "tiny.toml", "--map", "true",
                          "--executor", "bogus"), "bogus")
    assert_clean_error(nb("run-navigation", "--profile", "tiny.toml", "--map", "true",
                          "--address", "10.0.0.1:6379"), "--address")
    assert db_row_counts(project) == before  # no failed run for the next run to "resume"


def test_task_file_errors_name_the_users_file_not_the_cache_copy(project):
    res = nb("sample-tasks", "tiny", "--count", "4", "--seed", "0")
    assert res.code == 0, res.output
    f = next(Path("tasks").glob("tiny-4-*.json"))
    doc = json.loads(f.read_text())
    doc["tasks"][1]["optimal_length"] += 1.0  # an edit the user made to the larger set
    f.write_text(json.dumps(doc))
    Path("t3.toml").write_text(TINY_PROFILE.replace("count = 3", "count = 3\nseed = 0"))
    res = nb("run-navigation", "--profile", "t3.toml", "--map", "true")
    assert_clean_error(res, str(f), "tasks[1]")
    assert "results/cache" not in res.err


@pytest.mark.parametrize("field, value", [("fx", True), ("width", True), ("depth_scale", True),
                                          ("cx", "320"), ("camera_height", False)])
def test_booleans_and_strings_are_not_numbers_in_intrinsics(project, tmp_path, field, value):
    from navbench.errors import ArtifactError
    from navbench.worldmodel.tum import import_views as load_tum_views

    seq = tmp_path / "seq"
    seq.mkdir()
    info = {"width": 64, "height": 48, "fx": 50.0, "fy": 50.0, "cx": 32.0, "cy": 24.0,
            "depth_scale": 5000.0, "camera_height": 0.5}
    info[field] = value
    (seq / "intrinsics.json").write_text(json.dumps(info))
    with pytest.raises(ArtifactError, match=r"intrinsics\.json"):
        load_tum_views(seq)


def test_invariant_holds_for_the_class_tests(project):
    """A sample of the above through the whole invariant: nothing written outside, nothing
    removed, no row added."""
    before, rows = tree_snapshot(project.parent), db_row_counts(project)
    Path("deep.toml").write_text('name = "x"\na = ' + "[" * DEEP + "]" * DEEP)
    snap = tree_snapshot(project.parent)
    for args in (["run-navigation", "--profile", "deep.toml"],
                 ["sample-tasks", "/dev/zero"], ["score", "--seed", "-1"]):
        res = nb(*args)
        assert res.code == 2 and "Traceback" not in res.output
    assert tree_snapshot(project.parent) == snap
    assert db_row_counts(project) == rows and set(before) <= set(snap)


def test_read_only_results_folder_is_one_line(project, monkeypatch):
    """A read-only ``results/`` (simulated: the tests run as root, whom permissions do not stop)."""
    real = Path.mkdir

    def readonly(self, *a, **kw):
        if "results" in self.parts:
            raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(self))
        return real(self, *a, **kw)

    monkeypatch.setattr(Path, "mkdir", readonly)
    res = nb("fit-map", "tiny", "--profile", "tiny.toml")
    assert_clean_error(res, "results", "Read-only file system")
    assert res.code == 2
