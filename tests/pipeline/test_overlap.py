"""Overlap (issue 36): the levels after the first are built in a background process while the
episodes run. The same rows and artifacts as without it; ``--no-overlap`` keeps the old order
(every level's inputs, then every episode); Ctrl-C or SIGTERM during the background fit leaves
no process, no ``running`` run and no cache entry or temporary folder behind, and the rerun
finishes the measurement."""

from __future__ import annotations

import json
import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

from navbench.levelio import save_level
from navbench.results.breakdown import breakdown_rows, format_breakdown

from .test_stages import tiny_level

ROOT = Path(__file__).resolve().parents[2]

#: Two tiny levels with a fitted (tiny) map each, two workers: the overlapped path.
TWO = """
name = "two"
levels = ["tiny", "tiny2"]
[views]
camera = "half"
count = 12
seed = 0
eval_count = 4
eval_seed = 1
[fit]
steps = STEPS
grid_shape = [16, 12, 8]
n_samples = 40
images_per_batch = 4
pixels_per_image = 50
threads = 1
[tasks]
count = 3
[navigation]
estimators = ["gt", "dynamics"]
noise = ["low"]
workers = 2
"""


def two_levels(root: Path, steps: int = 3) -> Path:
    (root / "levels").mkdir(parents=True)
    save_level(tiny_level("tiny"), root / "levels" / "tiny.json")
    save_level(tiny_level("tiny2"), root / "levels" / "tiny2.json")
    (root / "two.toml").write_text(TWO.replace("STEPS", str(steps)))
    return root


def rows(db: Path) -> list[dict]:
    """Every stored column but run ids, times and timings (scripts/golden_rows.py's), sorted."""
    from tests.scripts import load_script

    cols = load_script("golden_rows").COLUMNS
    with sqlite3.connect(db) as con:
        got = con.execute(f"SELECT {', '.join(cols)} FROM episodes ORDER BY cell_key, task_id, seed").fetchall()
    return [dict(zip(cols, r)) for r in got]


def artifacts(cache: Path) -> dict[tuple[str, str], dict]:
    """``(stage, key) -> {file: sha256}`` of every cache entry (manifests' file lists); for a
    trajectory (``episode``), its arrays and fields but the wall-clock timings (``timings_ms``,
    ``plan_ms``), which differ between any two runs; for a map, its metrics but the fit's
    seconds."""
    import numpy as np

    out = {}
    for mf in sorted(cache.glob("*/*/manifest.json")):
        stage, key = mf.parent.parent.name, mf.parent.name
        if stage == "episode":
            with np.load(mf.parent / "episode.npz") as z:
                out[(stage, key)] = {k: z[k].tobytes() for k in z.files
                                     if not k.startswith("timings") and k != "__meta__"}
                meta = json.loads(bytes(z["__meta__"]).decode())
                out[(stage, key)]["__meta__"] = {k: v for k, v in meta.items() if not k.endswith("_ms")}
        else:
            out[(stage, key)] = files = json.loads(mf.read_text())["files"]
            if stage == "fit-map":  # the fit's metrics hold its wall-clock seconds
                metrics = json.loads((mf.parent / "metrics.json").read_text())
                files["metrics.json"] = {k: v for k, v in metrics.items() if not any(t in k for t in ("time", "second", "ms_"))}
    return out


def run_two(root: Path, overlap: bool, monkeypatch):
    from navbench.pipeline.run import run_profile

    monkeypatch.chdir(root)
    lines: list[str] = []
    result = run_profile("two.toml", db=f"sqlite:///{root / 'nb.db'}", cache_root=root / "cache",
                         until="navigation", progress=lines.append, overlap=overlap)
    return result, lines


@pytest.mark.slow
def test_two_levels_give_the_same_rows_and_artifacts_with_and_without_overlap(tmp_path, monkeypatch):
    from navbench.pipeline import overlap

    monkeypatch.setattr(overlap, "AT_ONCE_MAX_CORES", 0)  # the order of a machine of > 2 cores
    on, on_lines = run_two(two_levels(tmp_path / "on"), True, monkeypatch)
    off, off_lines = run_two(two_levels(tmp_path / "off"), False, monkeypatch)
    # the overlapped path ran (tiny2 built in the background), the other did not
    assert any(ln.startswith("overlap: tiny2 built in a background process") for ln in on_lines), on_lines
    assert not any("overlap" in ln or ln.startswith("background") for ln in off_lines), off_lines
    # it started once tiny's views were collected, before tiny's fit: not beside those views
    # (on 16 cores the two levels' views shared the cores and the first level took 2x longer)
    start = next(i for i, ln in enumerate(on_lines) if ln.startswith("overlap: tiny2 built"))
    views = [i for i, ln in enumerate(on_lines) if ln.startswith("collect-views: computing")]
    fit = next(i for i, ln in enumerate(on_lines) if ln.startswith("fit-map: computing"))
    assert len(views) == 2 and max(views) < start < fit, on_lines
    assert not any(ln.startswith("background") for ln in on_lines[:start]), on_lines
    names = {r["name"] for r in on.breakdown}
    assert {"fit-map (overlapped)", "collect-views (overlapped)"} <= names, names
    assert not any(r["name"].endswith("(overlapped)") for r in off.breakdown)
    # the same rows, bit for bit, and the same cache entries with the same files
    got, want = rows(tmp_path / "on" / "nb.db"), rows(tmp_path / "off" / "nb.db")
    assert len(got) == 12 and {r["level"] for r in got} == {"tiny", "tiny2"}
    assert got == want
    a_on, a_off = artifacts(tmp_path / "on" / "cache"), artifacts(tmp_path / "off" / "cache")
    assert {s for s, _ in a_on} >= {"collect-views", "fit-map", "sample-tasks", "episode"}
    assert a_on == a_off
    assert [li.map.key for li in on.inputs] == [li.map.key for li in off.inputs]
    assert set(on.refs) == set(off.refs)  # the same gc roots
    assert (on.navigation.total, on.navigation.stored, len(on.navigation.cells)) == \
        (off.navigation.total, off.navigation.stored, len(off.navigation.cells)) == (12, 12, 4)
    # and the episodes of the overlapped run went in level by level
    with sqlite3.connect(tmp_path / "on" / "nb.db") as con:
        levels = [lv for (lv,) in con.execute("SELECT level FROM episodes ORDER BY id")]
    assert levels == sorted(levels, key=["tiny", "tiny2"].index)

    # --no-overlap is today's order: every level's inputs, then every episode
    first_episode = next(i for i, ln in enumerate(off_lines) if ln.startswith("episodes"))
    stages = [i for i, ln in enumerate(off_lines) if ln.split(":")[0] in
              ("collect-views", "fit-map", "sample-tasks", "make-level")]
    assert len([i for i in stages if off_lines[i].startswith("fit-map: computing")]) == 2
    assert max(stages) < first_episode, off_lines

    # on a machine of at most 2 cores it starts with the command, and the rows are the same
    monkeypatch.setattr(overlap, "AT_ONCE_MAX_CORES", 10 ** 6)
    early, early_lines = run_two(two_levels(tmp_path / "early"), True, monkeypatch)
    start = next(i for i, ln in enumerate(early_lines) if ln.startswith("overlap: tiny2 built"))
    assert start < min(i for i, ln in enumerate(early_lines) if ln.startswith("collect-views")), early_lines
    assert rows(tmp_path / "early" / "nb.db") == want
    assert artifacts(tmp_path / "early" / "cache") == a_off

    # a rerun of either finds everything stored and computes nothing
    again, again_lines = run_two(tmp_path / "on", True, monkeypatch)
    assert again.navigation.stored == 0 and again.navigation.already_done == 12
    assert not any(": computing" in ln for ln in again_lines), again_lines
    assert artifacts(tmp_path / "on" / "cache") == a_on


def test_the_background_starts_with_the_command_on_two_cores_and_after_the_views_above():
    from navbench.pipeline.overlap import starts_at_once

    assert starts_at_once(1) and starts_at_once(2)
    assert not starts_at_once(3) and not starts_at_once(16)
    assert starts_at_once() == ((os.cpu_count() or 1) <= 2)


def test_overlap_applies_only_where_it_can_pay():
    from navbench.pipeline.overlap import overlap_applies
    from navbench.pipeline.profiles import Profile

    two = Profile("p", levels=("a", "b"))
    assert overlap_applies(two, "local", 2) is None
    assert overlap_applies(two, "ray", 0) is None
    assert overlap_applies(two, "local", 1) == "--workers 1 runs everything in this process"
    assert overlap_applies(Profile("p", levels=("a",)), "local", 2) == "one level"
    assert overlap_applies(Profile("p", levels=("a", "b"), map_source="true"), "local", 2) == "no map is fitted"


def test_summed_summary_adds_the_levels():
    from navbench.pipeline.overlap import summed_summary
    from navbench.pipeline.stages import NavigationSummary

    a = NavigationSummary(["c1"], total=4, already_done=1, ran=3, stored=3, steps=30, store_s=0.5,
                          component_s={"sim": 1.0}, estimator_s={"gt": [1.0, 30]}, seconds=2.0)
    b = NavigationSummary(["c2"], total=2, ran=2, stored=2, steps=10, store_s=0.25,
                          component_s={"sim": 0.5, "plan": 0.1}, estimator_s={"gt": [0.5, 10]}, seconds=1.0)
    s = summed_summary([a, b])
    assert (s.cells, s.total, s.already_done, s.ran, s.stored, s.steps) == (["c1", "c2"], 6, 1, 5, 5, 40)
    assert s.component_s == {"sim": 1.5, "plan": 0.1} and s.estimator_s == {"gt": [1.5, 40]}
    assert (s.store_s, s.seconds) == (0.75, 3.0)


def test_breakdown_says_wall_and_summed_when_stages_overlap():
    timings = [("collect-views", 1.0, False), ("fit-map", 10.0, False),
               ("collect-views", 2.0, False, True), ("fit-map", 12.0, False, True)]
    rows_ = breakdown_rows(timings, wall_s=15.0)
    by = {r["name"]: r for r in rows_}
    assert by["fit-map"]["seconds"] == 10.0 and by["fit-map (overlapped)"]["seconds"] == 12.0
    assert by["run"] == {"kind": "wall", "name": "run", "seconds": 15.0, "count": 1, "cached": 0}
    text = format_breakdown(rows_)
    assert "total (summed)" in text and "25.00" in text  # 1 + 10 + 2 + 12
    wall = next(ln for ln in text.splitlines() if ln.startswith("wall"))
    assert "15.00" in wall and "sum exceeds the wall time" in wall
    # without overlap the sum is the total, and the wall line says nothing more
    plain = format_breakdown(breakdown_rows(timings[:2], wall_s=11.5))
    assert "total (summed)" not in plain and "\ntotal " in plain
    assert next(ln for ln in plain.splitlines() if ln.startswith("wall")).split() == ["wall", "11.50"]


# ---------------------------------------------------------------------------- interruption

def _tmp_dirs(cache: Path) -> list[Path]:
    return sorted(cache.glob("*/.tmp-*")) if cache.is_dir() else []


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:  # a zombie is gone for our purpose
        return Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.slow
@pytest.mark.parametrize("how", ["ctrl-c", "sigterm"])
def test_interrupt_during_the_background_fit_leaves_nothing_and_the_rerun_finishes(tmp_path, how):
    """The signal arrives while the background process fits tiny2 (its temporary folder is in
    the cache): a terminal's Ctrl-C (SIGINT to the whole process group) or a ``kill`` of the
    command alone (SIGTERM)."""
    root = two_levels(tmp_path / "p", steps=200)
    cache = root / "results" / "cache"
    env = {**os.environ, "PYTHONPATH": str(ROOT), "NAVBENCH_DB": f"sqlite:///{root / 'nb.db'}"}
    cmd = [sys.executable, "-m", "navbench.cli.main", "all", "--profile", "two.toml", "--report", "rep"]
    p = subprocess.Popen(cmd, cwd=root, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         start_new_session=True,
                         # a background shell may have left SIGINT ignored; a terminal would not
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    background = None
    try:
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline and p.poll() is None and background is None:
            for d in _tmp_dirs(cache):  # .tmp-<key16>-<pid>-<rand>: a fit of another process
                pid = int(d.name.split("-")[2])
                if d.parent.name == "fit-map" and pid != p.pid:
                    background = pid
            time.sleep(0.05)
        assert background is not None and p.poll() is None, "the background fit was not seen running"
        time.sleep(0.5)  # into its steps
        if how == "ctrl-c":
            os.killpg(p.pid, signal.SIGINT)
        else:
            p.send_signal(signal.SIGTERM)
        out, err = p.communicate(timeout=120)
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait()
    assert p.returncode == 130, err[-3000:]
    assert "Traceback" not in out + err, err[-3000:]
    deadline = time.monotonic() + 10
    while _pid_alive(background) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not _pid_alive(background), "the background process outlived the command"
    assert _tmp_dirs(cache) == []  # no half-written folder, and no entry: every one verifies
    from navbench.pipeline.cache import ArtifactStore

    store = ArtifactStore(cache)
    for a in store.ls():
        store.verify(a.stage, a.key)
    with sqlite3.connect(root / "nb.db") as con:
        assert [s for (s,) in con.execute("SELECT status FROM runs ORDER BY id")] == ["interrupted"]

    res = subprocess.run(cmd, cwd=root, env=env, capture_output=True, text=True, timeout=900)
    assert res.returncode == 0, res.stderr[-3000:]
    assert "run 2 resumes run(s) 1" in res.stdout + res.stderr
    got = rows(root / "nb.db")
    assert len(got) == 12 == len({(r["cell_key"], r["task_id"], r["seed"]) for r in got})
    with sqlite3.connect(root / "nb.db") as con:
        assert [s for (s,) in con.execute("SELECT status FROM runs ORDER BY id")] == ["interrupted", "done"]


@pytest.mark.slow
def test_a_background_process_that_dies_costs_only_time(tmp_path, monkeypatch):
    """kill -9 of the background process in the middle of tiny2's fit: this process builds
    tiny2 itself, says so, and the run finishes with every episode."""
    import threading

    root = two_levels(tmp_path / "p", steps=200)
    killed: list[int] = []

    def killer() -> None:
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline and not killed:
            for d in _tmp_dirs(root / "cache"):
                pid = int(d.name.split("-")[2])
                if d.parent.name == "fit-map" and pid != os.getpid():
                    time.sleep(0.5)
                    os.kill(pid, signal.SIGKILL)
                    killed.append(pid)
                    break
            time.sleep(0.05)

    t = threading.Thread(target=killer, daemon=True)
    t.start()
    result, lines = run_two(root, True, monkeypatch)
    t.join(1)
    assert killed, "the background fit was not seen running"
    assert any(ln.startswith("overlap: the background process ended (exit status -9) before building tiny2")
               for ln in lines), lines
    assert result.navigation.stored == 12 and {li.map.name for li in result.inputs} == {"tiny", "tiny2"}
    assert not any(r["name"].endswith("(overlapped)") and r["name"].startswith("fit-map")
                   for r in result.breakdown)  # tiny2's fit ran here
    assert not _pid_alive(killed[0])


def test_the_background_context_keys_stages_as_the_command_under_any_version(tmp_path, monkeypatch):
    """A paper run under navbench-2 showed the background process building every level under
    other keys than the command (its context bypassed the version's key part), so the command
    built each level again. Both contexts now key a stage the same way under every version."""
    from navbench import benchmark
    from navbench.pipeline.cache import ArtifactStore
    from navbench.pipeline.overlap import _RecordingContext
    from navbench.pipeline.stages.context import StageContext

    store = ArtifactStore(tmp_path / "cache")
    for version in benchmark.VERSIONS:
        a = StageContext(store=store, benchmark_version=version)
        b = _RecordingContext(store=store, benchmark_version=version)
        for stage in ("make-level", "collect-views", "fit-map", "sample-tasks"):
            cfg = {"x": 1}
            assert a.keyed(stage, cfg) == b.keyed(stage, cfg)
        b.calls = []
        ka = a.run("collect-views", {"x": 1}, {}, lambda d: (d / "f").write_text("a"))[1]
        kb = b.run("collect-views", {"x": 1}, {}, lambda d: (d / "f").write_text("a"))[1]
        assert ka == kb, version
    assert StageContext(store=store, benchmark_version="navbench-2").keyed("collect-views", {"x": 1}) != {"x": 1}
