"""The HTML report from a synthetic database: figures embedded, CSVs written, no external
resources; a headless-Chromium check that every embedded figure decodes."""

from __future__ import annotations

import base64
import json
import re
import shutil
import subprocess
import sys
import types

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from navbench.errors import ArtifactError
from navbench.results.db import ResultsDB
from navbench.report.build import build_report
from navbench.results.score import score_table

from .test_db import FakeTask, episode

TEX = {"kind": "waves", "base": [0.5, 0.5, 0.5], "amp": [0.1, 0.1, 0.1],
       "waves": [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.5]]}
IMG_RE = re.compile(r'<img [^>]*src="data:image/png;base64,([A-Za-z0-9+/=]+)"')
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


def write_level(levels_dir, name="lvA", size=3.0):
    s = size
    doc = {"schema_version": 1, "name": name, "seed": 1, "width": s, "depth": s, "height": 1.2,
           "floor_texture": 0, "ceiling_texture": 0, "textures": [TEX],
           "walls": [{"a": [0, 0], "b": [s, 0], "thickness": 0.1, "texture": 0},
                     {"a": [s, 0], "b": [s, s], "thickness": 0.1, "texture": 0},
                     {"a": [s, s], "b": [0, s], "thickness": 0.1, "texture": 0},
                     {"a": [0, s], "b": [0, 0], "thickness": 0.1, "texture": 0}],
           "obstacles": [{"polygon": [[1.2, 1.2], [1.8, 1.2], [1.8, 1.8], [1.2, 1.8]],
                          "height": 0.4, "texture": 0}],
           "meta": {}}
    levels_dir.mkdir(parents=True, exist_ok=True)
    (levels_dir / f"{name}.json").write_text(json.dumps(doc))


def fill_db(db: ResultsDB) -> dict:
    """Two levels (only lvA has a file), three estimators x two noises x four tasks, tracking
    and bench rows, one map. Returns the fake trajectories by key."""
    rid = db.start_run("quick", "all", {"levels": ["lvA", "lvB"]}, "c" * 64)
    db.record_level("lvA", "hashA", {})
    db.record_level("lvB", "hashB", {})
    db.record_map("lvA", "mapA", {"depth_mae_m": 0.03, "rgb_l1": 0.05, "slice_precision": 0.9,
                                  "slice_recall": 0.8, "fit_seconds": 12.0, "steps": 500})
    tasks = [FakeTask(i, (0.5, 0.5 + 0.4 * i, 0.0), (2.5, 2.5 - 0.4 * i), 2.6) for i in range(4)]
    db.record_task_set("lvA", "tsA", tasks)
    rng = np.random.default_rng(0)
    rows, trajs = [], {}
    for level in ("lvA", "lvB"):
        for est, base in (("ours", 0.9), ("no-map", 0.6), ("dynamics", 0.5)):
            for noise, drop in (("low", 0.0), ("high", 0.3)):
                for t in tasks:
                    ok = bool(rng.random() < base - drop)
                    key = f"traj-{level}-{est}-{noise}-{t.id}"
                    rows.append(episode(f"{level}-{est}-{noise}", t.id, level=level, estimator=est,
                                        noise=noise, task_set_key="tsA" if level == "lvA" else "tsB",
                                        success=ok, spl_term=float(ok) * rng.uniform(0.7, 1.0),
                                        loc_rmse_m=float(rng.lognormal(-3, 1)),
                                        rot_rmse_deg=float(rng.lognormal(0, 1)),
                                        sim_ms=1.0, render_ms=4.0, estimate_ms=20.0 if est != "dynamics" else 0.1,
                                        plan_ms=2.0, control_ms=0.2, step_ms=27.0, traj_key=key))
                    n = 30
                    s = np.linspace(0, 1, n)[:, None]
                    true = np.hstack([np.array(t.start[:2]) + s * (np.array(t.target) - t.start[:2]),
                                      np.zeros((n, 1))])
                    trajs[key] = {"true_poses": true, "est_poses": true + rng.normal(0, 0.03, true.shape),
                                  "target": np.array(t.target)}
    db.add_episodes(rid, rows)
    db.add_tracking_rows(rid, [dict(study_key="st", level="lvA", estimator=e, trajectory_id=i, seed=0,
                                    loc_rmse_m=float(rng.lognormal(-3.5, 0.5)),
                                    rot_rmse_deg=float(rng.lognormal(0, 0.5)), step_ms_median=30.0,
                                    render_ms=5.0, estimate_ms=25.0)
                               for e in ("ours", "emission") for i in range(10)])
    db.add_bench_rows(rid, [dict(metric="render_ms", value=4.2, unit="ms"),
                            dict(metric="ours_step_ms", value=31.0, unit="ms")])
    db.finish_run(rid)
    return trajs


def fake_loader(trajs, broken=()):
    def load(key):
        if key in broken:
            raise ArtifactError(f"no episode artifact with key {key[:12]}")
        return trajs[key]
    return load


@pytest.fixture
def synthetic(tmp_path):
    db = ResultsDB(f"sqlite:///{tmp_path / 'r.db'}")
    trajs = fill_db(db)
    write_level(tmp_path / "levels", "lvA")
    yield db, trajs, tmp_path
    db.close()


@pytest.fixture
def fake_isometric(monkeypatch):
    """A stand-in for navbench.worldmodel.plots.draw_isometric (draws the map's occupancy)."""
    calls = []

    def draw_isometric(ax, vmap):
        calls.append(vmap)
        occ = vmap.occ if hasattr(vmap, "occ") else vmap["occ"]
        ax.imshow(occ.max(axis=2).T, origin="lower")

    mod = types.ModuleType("navbench.worldmodel.plots")
    mod.draw_isometric = draw_isometric
    monkeypatch.setitem(sys.modules, "navbench.worldmodel.plots", mod)
    return calls


def _images(text):
    return [base64.b64decode(m) for m in IMG_RE.findall(text)]


def test_report_embeds_every_figure_and_writes_csvs(synthetic, fake_isometric):
    db, trajs, tmp = synthetic
    broken = {"traj-lvA-ours-low-0"}
    out = tmp / "report"
    index = build_report(db, out, load_trajectory=fake_loader(trajs, broken),
                         load_map=lambda key: {"occ": np.random.default_rng(1).random((8, 8, 3))},
                         levels_dir=tmp / "levels", n_boot=200)
    assert index == out / "index.html"
    text = index.read_text()
    assert text.count("<img ") == text.count('src="data:image/png;base64,') == 6
    # SPL bars, paired differences, RMSE CDFs, runtime bars, one level (lvB has no file), one
    # isometric map
    images = _images(text)
    assert len(images) == 6
    from PIL import Image
    import io

    for png in images:
        assert png[:8] == b"\x89PNG\r\n\x1a\n"
        w, h = Image.open(io.BytesIO(png)).size
        assert w > 100 and h > 100
    assert len(fake_isometric) == 1
    # no external resources
    assert not re.search(r'(src|href)="(https?:)?//', text)
    assert "<script" not in text and "<link" not in text and "@import" not in text
    # notes for what could not be drawn
    assert "lvB: no level file" in text.replace("Level lvB", "lvB")
    assert "unavailable" in text  # the broken trajectory
    # CSV files for every table, linked from the page
    for name in ("runs", "spl_table", "spl_paper", "scores", "tracking_summary", "runtime", "maps", "bench"):
        assert (out / f"{name}.csv").is_file(), name
        assert f'href="{name}.csv"' in text
    spl = pd.read_csv(out / "spl_table.csv", index_col=0)
    table = score_table(db, n_boot=200)
    ours_low = table[(table["level"] == "all") & (table["estimator"] == "ours") & (table["noise"] == "low")].iloc[0]
    assert spl.loc["low", "ours"].startswith(f"{ours_low['spl']:.2f} [")
    assert list(spl.index) == ["high", "low"]
    scores = pd.read_csv(out / "scores.csv")
    assert set(scores["level"]) == {"lvA", "lvB", "all"} and len(scores) == 18
    tracking = pd.read_csv(out / "tracking_summary.csv")
    assert set(tracking["estimator"]) == {"ours", "emission"} and set(tracking["trajectories"]) == {10}
    runtime = pd.read_csv(out / "runtime.csv", index_col=0)
    assert runtime.loc["ours", "estimate"] == 20.0 and runtime.loc["ours", "step_ms"] == 27.0
    assert pd.read_csv(out / "bench.csv")["metric"].tolist() == ["render_ms", "ours_step_ms"]
    history = pd.read_csv(out / "bench_history.csv", index_col=[0, 1, 2])
    assert history.index.tolist() == [("render_ms", "ms", "cpu"), ("ours_step_ms", "ms", "cpu")]
    assert history.shape[1] == 1 and history.columns[0].startswith("run ")
    assert history.iloc[:, 0].tolist() == [4.2, 31.0]
    assert pd.read_csv(out / "maps.csv")["depth_mae_m"].tolist() == [0.03]


def test_report_without_optional_parts(synthetic, monkeypatch):
    """No loaders, no isometric drawer, episodes-based CDFs: notes instead of figures."""
    db, _, tmp = synthetic
    monkeypatch.setitem(sys.modules, "navbench.worldmodel.plots", None)  # import fails
    index = build_report(db, tmp / "r2", levels_dir=tmp / "levels", n_boot=50)
    text = index.read_text()
    assert len(_images(text)) == 5  # SPL, claim, CDFs, runtime, level lvA without trajectories
    assert "draw_isometric is not available" in text
    assert "No trajectory loader given" in text


def test_a_running_run_is_explained(synthetic):
    db, _, tmp = synthetic
    assert "had not finished" not in build_report(db, tmp / "r3", levels_dir=tmp / "levels",
                                                  n_boot=20).read_text()
    db.start_run("quick", "all", {}, "d" * 64)  # the run writing the report, as in `navbench all`
    text = build_report(db, tmp / "r4", levels_dir=tmp / "levels", n_boot=20).read_text()
    assert "had not finished when this page was written" in text


def test_a_long_run_history_shows_the_newest_runs_and_keeps_all_in_the_csv(tmp_path):
    from navbench.report.build import RUNS_SHOWN

    with ResultsDB(f"sqlite:///{tmp_path / 'h.db'}") as db:
        ids = [db.start_run(f"p{k}", f"navbench all --profile p{k}", {}, "e" * 64)
               for k in range(RUNS_SHOWN + 3)]
        for i in ids:
            db.finish_run(i)
        index = build_report(db, tmp_path / "out", levels_dir=tmp_path / "nolevels")
    runs_html = index.read_text().split('id="runs"')[1].split("<h2")[0]
    shown = re.findall(r"navbench all --profile p(\d+)", runs_html.split("</figure>")[0])
    assert shown == [str(k) for k in range(3, RUNS_SHOWN + 3)]
    assert f"the newest {RUNS_SHOWN} of {RUNS_SHOWN + 3} runs" in runs_html
    assert list(pd.read_csv(tmp_path / "out" / "runs.csv")["id"]) == ids


def test_bench_history_puts_runs_side_by_side(tmp_path):
    """Three bench runs, two devices, a metric missing from one run: one column per run, oldest
    first, the last BENCH_HISTORY_RUNS only."""
    from navbench.report import build as rep

    with ResultsDB(f"sqlite:///{tmp_path / 'h.db'}") as db:
        for k in range(3):
            rid = db.start_run("bench", "bench", {}, "h")
            rows = [dict(metric="fit_step_ms", value=10.0 + k, unit="ms"),
                    dict(metric="fit_step_ms", value=1.0 + k, unit="ms", device="cuda:0")]
            if k != 1:
                rows.append(dict(metric="plan_ms", value=2.0, unit="ms"))
            db.add_bench_rows(rid, rows)
            db.finish_run(rid)
        rep.BENCH_HISTORY_RUNS, old = 2, rep.BENCH_HISTORY_RUNS
        try:
            build_report(db, tmp_path / "out", levels_dir=tmp_path / "nolevels")
        finally:
            rep.BENCH_HISTORY_RUNS = old
    h = pd.read_csv(tmp_path / "out" / "bench_history.csv", index_col=[0, 1, 2])
    assert [c.split(",")[0] for c in h.columns] == ["run 2", "run 3"]
    assert h.loc[("fit_step_ms", "ms", "cpu")].tolist() == [11.0, 12.0]
    assert h.loc[("fit_step_ms", "ms", "cuda:0")].tolist() == [2.0, 3.0]
    assert np.isnan(h.loc[("plan_ms", "ms", "cpu")].iloc[0]) and h.loc[("plan_ms", "ms", "cpu")].iloc[1] == 2.0


def test_report_scope_and_the_mixed_setups_warning(synthetic):
    """A second setup of lvA/ours/low (another cell, another run) is pooled by a report of the
    whole database, with a warning; the report of the first grid's cells (what `navbench all`
    writes) or of one run leaves it out."""
    db, _, tmp = synthetic
    cells = set(db.episodes_frame()["cell_key"])
    r2 = db.start_run("paper", "all", {}, "e" * 64)
    db.add_episodes(r2, [episode("other-setup", 0, level="lvA", estimator="ours", noise="low",
                                 success=False, spl_term=0.0)])
    text = build_report(db, tmp / "all", levels_dir=tmp / "levels", n_boot=20).read_text()
    assert "pool episodes of several setups" in text and "lvA/ours/low" in text
    for kw in ({"cell_keys": cells}, {"run": 1}):
        out = tmp / f"scoped-{len(kw)}-{next(iter(kw))}"
        text = build_report(db, out, levels_dir=tmp / "levels", n_boot=20, **kw).read_text()
        assert "several setups" not in text
        scores = pd.read_csv(out / "scores.csv")
        row = scores[(scores["level"] == "lvA") & (scores["estimator"] == "ours") & (scores["noise"] == "low")]
        assert row["episodes"].tolist() == [4] and set(scores["setups"]) == {1}  # 4 tasks, 1 setup
    one = build_report(db, tmp / "r2", levels_dir=tmp / "levels", n_boot=20, run=r2)
    assert pd.read_csv(one.parent / "scores.csv")["episodes"].tolist() == [1, 1]


def test_report_on_empty_database(tmp_path):
    with ResultsDB(f"sqlite:///{tmp_path / 'e.db'}") as db:
        index = build_report(db, tmp_path / "out", levels_dir=tmp_path / "nolevels")
    text = index.read_text()
    assert "<img" not in text and "No navigation episodes stored yet" in text
    assert text.startswith("<!DOCTYPE html>") and text.rstrip().endswith("</html>")


def test_report_cli(synthetic, fake_isometric):
    from navbench.cli.main import app

    db, _, tmp = synthetic
    out = tmp / "cli-report"
    res = CliRunner().invoke(app, ["report", "--db", db.url, "--out", str(out), "--levels",
                                   str(tmp / "levels"), "--cache", str(tmp / "nocache"), "--boot", "50"])
    assert res.exit_code == 0, res.output
    text = (out / "index.html").read_text()
    # the stage cache is empty: trajectories and the map are reported unavailable, figures remain
    assert "unavailable" in text and len(_images(text)) == 5


def test_report_cli_missing_database_is_one_line(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "navbench.cli.main", "report", "--db",
                           f"sqlite:///{tmp_path / 'none.db'}", "--out", str(tmp_path / "o")],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert proc.stderr.startswith("error: no results database") and proc.stderr.count("\n") == 1


CHECK_SCRIPT = """<script>
window.addEventListener('load', function () {
  var imgs = Array.prototype.slice.call(document.images);
  var ok = imgs.filter(function (i) { return i.complete && i.naturalWidth > 0 && i.naturalHeight > 0; });
  var m = document.createElement('pre');
  m.id = 'nb-check';
  m.textContent = 'NBCHECK images=' + imgs.length + ' decoded=' + ok.length + ' END';
  document.body.appendChild(m);
});
</script>"""


def run_chromium(args, tmp_path, timeout=180):
    profile = tmp_path / "chromium-profile"
    cmd = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
           "--disable-background-networking", "--disable-component-update", "--disable-sync",
           "--disable-dev-shm-usage", f"--user-data-dir={profile}", "--virtual-time-budget=10000", *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)


@pytest.mark.browser
@pytest.mark.skipif(CHROMIUM is None, reason="chromium is not installed (apt-get install chromium)")
def test_report_renders_in_headless_chromium(synthetic, fake_isometric):
    db, trajs, tmp = synthetic
    out = tmp / "report"
    index = build_report(db, out, load_trajectory=fake_loader(trajs),
                         load_map=lambda key: {"occ": np.ones((4, 4, 2))},
                         levels_dir=tmp / "levels", n_boot=50)
    text = index.read_text()
    n = len(_images(text))
    assert n == 6
    # a copy of the page with a probe that records, after load, how many images decoded
    probe = out / "probe.html"
    probe.write_text(text.replace("</body>", CHECK_SCRIPT + "</body>"))
    proc = run_chromium(["--dump-dom", probe.as_uri()], tmp)
    found = re.search(r"NBCHECK images=(\d+) decoded=(\d+) END", proc.stdout)
    assert found, f"probe marker missing; chromium rc={proc.returncode} stderr={proc.stderr[-500:]}"
    assert (int(found.group(1)), int(found.group(2))) == (n, n)
    assert "navbench report" in proc.stdout


def test_report_from_real_records_through_the_stage_cache(tmp_path, fake_isometric):
    """EpisodeRecord -> score_episode -> episodes row; trajectory and map as verified cache
    artifacts read back by store_loaders (the path `navbench report` takes)."""
    from navbench.nav.episode import EpisodeRecord
    from navbench.nav.metrics import score_episode
    from navbench.pipeline.cache import ArtifactStore
    from navbench.results.db import episode_row_from_score
    from navbench.pipeline.loaders import store_loaders
    from navbench.pipeline.artifacts import MAP_FILE, TRAJ_FILE, save_record
    from navbench.worldmodel.grid import GridSpec, VoxelMap, save_map

    store = ArtifactStore(tmp_path / "cache")
    t = np.linspace(0, 1, 21)
    true = np.stack([0.5 + 2 * t, 0.5 + 2 * t, np.full_like(t, np.pi / 4)], axis=1)
    rec = EpisodeRecord(level="lvA", task_id=0, estimator="ours", noise="low", seed=0,
                        start=true[0], target=np.array([2.5, 2.5]), optimal_length=2.9,
                        true_poses=true, est_poses=true + 0.01, controls=np.zeros((20, 3)),
                        collided=False, collision_step=-1, plan=np.zeros((0, 2)), replans=0,
                        end_reason="reached",
                        timings_ms={k: np.full(20, 1.0) for k in ("sim", "render", "estimate", "plan", "control")})
    store.write("episode", "ek" * 32, lambda d: save_record(rec, d / TRAJ_FILE),
                config={"cell": "c"}, inputs={}, version=1)
    vmap = VoxelMap(GridSpec((0, 0, 0), (3, 3, 1.2), (6, 6, 3)), np.zeros((6, 6, 3)), np.zeros((6, 6, 3, 3)))
    store.write("fit-map", "mk" * 32, lambda d: save_map(vmap, d / MAP_FILE), config={}, inputs={}, version=1)

    score = score_episode(rec)
    meta = dict(level="lvA", map_key="mk" * 32, task_set_key="tsA", estimator="ours",
                estimator_options={}, noise="low", seed=0, task_id=0, timings_ms=rec.timings_ms)
    with ResultsDB(f"sqlite:///{tmp_path / 'r.db'}") as db:
        rid = db.start_run("quick", "run-navigation", {}, "h")
        db.record_level("lvA", "hashA", {})
        db.record_map("lvA", "mk" * 32, {"depth_mae_m": 0.1})
        assert db.add_episodes(rid, [episode_row_from_score("c", meta, score, "ek" * 32)]) == 1
        row = db.episodes_frame().iloc[0]
        assert bool(row["success"]) and row["step_ms"] == pytest.approx(5.0)
        assert row["end_reason"] == "reached" and not bool(row["collided"])
        write_level(tmp_path / "levels", "lvA")
        load_trajectory, load_map = store_loaders(tmp_path / "cache")
        assert np.allclose(load_trajectory("ek" * 32)["est_poses"], true + 0.01)
        index = build_report(db, tmp_path / "out", load_trajectory, load_map,
                             levels_dir=tmp_path / "levels", n_boot=50)
    text = index.read_text()
    # Fig. 3 draws the episode (task 0) over the learned planning slice of its map
    assert "tasks 0 by every estimator" in text and "unavailable" not in text
    assert len(fake_isometric) == 1 and isinstance(fake_isometric[0], VoxelMap)


def test_report_states_the_claim_the_failures_and_the_speed_beside_the_paper(synthetic):
    """Issue 16's sections: paired differences per noise (with their CSV), end reasons and the
    per-episode CSV, Fig. 4c beside the paper's figures with the conditions."""
    db, trajs, tmp = synthetic
    out = tmp / "r-claim"
    text = build_report(db, out, load_trajectory=fake_loader(trajs), levels_dir=tmp / "levels",
                        n_boot=100).read_text()
    for anchor in ('id="claim"', 'id="failures"'):
        assert anchor in text
    for name in ("claim_low", "claim_high", "paired_differences", "end_reasons", "episodes",
                 "runtime_vs_paper"):
        assert (out / f"{name}.csv").is_file() and f'href="{name}.csv"' in text, name
    paired = pd.read_csv(out / "paired_differences.csv")
    # 2 levels + pooled, 2 noises, 2 comparisons; every ours episode has both partners
    assert len(paired) == 12 and (paired["pairs"][paired["level"] != "all"] == 4).all()
    assert (paired["unpaired_reference"] == 0).all() and (paired["unpaired_other"] == 0).all()
    eps = pd.read_csv(out / "episodes.csv")
    assert len(eps) == 2 * 3 * 2 * 4 and {"end_reason", "collided", "success", "task_id", "seed"} <= set(eps.columns)
    reasons = pd.read_csv(out / "end_reasons.csv")
    assert reasons["episodes"].sum() == len(eps) and (reasons["reached"] == reasons["episodes"]).all()
    assert (reasons["failed"] == reasons["episodes"] - [
        int(eps[(eps["estimator"] == e) & (eps["noise"] == n)]["success"].sum())
        for e, n in zip(reasons["estimator"], reasons["noise"])]).all()
    speed = pd.read_csv(out / "runtime_vs_paper.csv", index_col=0)
    assert speed["paper (GPU)"].tolist() == [50.0, 60.0, 250.0, 62.0, 16.1]
    assert speed.iloc[0, 0] == 4.0 and speed.iloc[3, 0] == 27.0  # ours' render and full step
    assert "single-threaded" in text and "Quadro RTX 8000" in text


def test_estimators_that_do_no_tracking_work_get_no_rate(tmp_path):
    """dynamics renders and optimises nothing: no '0.0 ms (23900 Hz)' row, a note instead."""
    db = ResultsDB(f"sqlite:///{tmp_path / 'r.db'}")
    rid = db.start_run("quick", "all", {}, "e" * 64)
    rows = []
    for t in range(3):
        rows.append(episode("c-ours", t, estimator="ours", sim_ms=1.0, render_ms=4.0, estimate_ms=10.0,
                            plan_ms=0.0, control_ms=0.1, step_ms=15.1))
        rows.append(episode("c-dyn", t, estimator="dynamics", sim_ms=0.02, render_ms=0.0,
                            estimate_ms=0.003, plan_ms=0.0, control_ms=0.02, step_ms=0.042))
    db.add_episodes(rid, rows)
    db.finish_run(rid)
    out = tmp_path / "rep"
    text = build_report(db, out, levels_dir=tmp_path / "levels", n_boot=20).read_text()
    db.close()
    scores = pd.read_csv(out / "scores.csv")
    dyn = scores[scores["estimator"] == "dynamics"]
    assert dyn["step_hz"].isna().all() and (~dyn["tracking_work"].astype(bool)).all()
    assert scores[scores["estimator"] == "ours"]["step_hz"].notna().all()
    runtime = pd.read_csv(out / "runtime.csv", index_col=0)
    assert np.isnan(runtime.loc["dynamics", "step_hz"]) and runtime.loc["ours", "step_hz"] > 0
    assert "dynamics: no per-step tracking work" in text
    assert "23809" not in text and "23810" not in text  # 1000 / 0.042
