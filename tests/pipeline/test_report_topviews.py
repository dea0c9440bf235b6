"""The report's top views of online image-goal episodes (issue 15 section 5): the report of a tiny
``--map online`` run embeds one figure per level and conditions in its goals section, with the
explored cells the artifact stores; a report without online rows is unchanged there."""

from __future__ import annotations

import re

import numpy as np
import pytest

from tests.pipeline.test_online_nav import online_run  # noqa: F401 (the module-scoped run)


def _goals_html(html: str) -> str:
    return html.split('id="goals"')[1].split("<h2")[0]


def test_online_report_has_top_views(online_run, tmp_path, monkeypatch):  # noqa: F811
    from navbench.results.db import ResultsDB
    from navbench.pipeline.loaders import store_loaders
    from navbench.report.build import build_report
    from navbench.report.topviews import TOPVIEWS_PER_GROUP

    root, _ = online_run
    monkeypatch.chdir(root)
    db = ResultsDB(f"sqlite:///{root / 'onl.db'}")
    loaders = store_loaders(root / "results" / "cache")
    goals = _goals_html(build_report(db, tmp_path / "with", *loaders, levels_dir=root / "levels",
                                     n_boot=50, preset="nrns").read_text())
    captions = re.findall(r"<figcaption>([^<]*top views[^<]*)</figcaption>", goals)
    assert len(captions) == 1  # one level, one set of conditions
    cap = captions[0]
    assert cap.startswith("tiny: top views of 2 of 2 online image-goal episodes (the first of each difficulty")
    assert "conditions: texture=table, map=online, mapping=perfect, pose=true" in cap  # navbench-5's camera
    assert "explored area not" not in cap and "not stored" not in cap  # the seen cells were drawn
    # the top views, each with its goal image beneath: the level's goal-image strip is not
    # drawn a second time for online episodes
    assert goals.count("<img ") == 1 and "unavailable" not in goals
    assert "goal images (task, localisation status" not in goals
    assert TOPVIEWS_PER_GROUP >= 2
    # without a trajectory loader: a note instead of the figure, the rest unchanged
    bare = _goals_html(build_report(db, tmp_path / "bare", levels_dir=root / "levels", n_boot=50,
                                    preset="nrns").read_text())
    # (then the strip shows the online episodes' goal images)
    assert bare.count("<img ") == 1 and "top views skipped" in bare
    assert "goal images (task, localisation status" in bare


def test_stored_known_cells_reach_the_report(online_run):  # noqa: F811
    from navbench.pipeline.artifacts import TRAJ_FILE, load_record
    from navbench.pipeline.cache import ArtifactStore
    from navbench.results.db import ResultsDB
    from navbench.pipeline.loaders import store_loaders
    from navbench.report.topviews import known_grid
    from navbench.nav.imagenav import OnlineEpisodeRecord

    root, result = online_run
    rows = ResultsDB(f"sqlite:///{root / 'onl.db'}").episodes_frame()
    load_trajectory, load_map = store_loaders(root / "results" / "cache")
    store = ArtifactStore(root / "results" / "cache")
    for r in rows.itertuples():
        tr = load_trajectory(r.traj_key)
        rec = load_record(store.load("episode", r.traj_key) / TRAJ_FILE, OnlineEpisodeRecord)
        assert np.array_equal(tr["known"], rec.known) and tr["seen_share"] == rec.seen_share
        vmap = load_map(r.map_key)
        _, xs, ys = vmap.occupancy_slice("band")  # the grid the loop marked its seen cells on
        gx, gy = known_grid(vmap, tr["known"].shape)
        assert np.array_equal(gx, xs) and np.array_equal(gy, ys)
    assert known_grid(load_map(rows["map_key"].iloc[0]), (1, 1)) is None


def test_report_without_online_rows_is_unchanged(online_run, tmp_path):  # noqa: F811
    """The same rows as known-map image goals: the goals section with the loaders given is the
    one without them, and no trajectory is loaded."""
    from navbench.results.db import ResultsDB
    from navbench.report.build import _Page
    from navbench.report.goals import section_goals
    from navbench.results.presets import apply_preset

    root, _ = online_run
    db = ResultsDB(f"sqlite:///{root / 'onl.db'}")
    eps = apply_preset(db.episodes_frame(), "nrns")
    eps = eps.assign(goal_status=eps["goal_status"].str.removeprefix("online-").replace(
        {"matched": "ok", "weak": "failed", "none": "failed"}))
    calls = []

    def loader(key):
        calls.append(key)
        raise AssertionError("no trajectory is loaded without online rows")

    pages = []
    for extra in ((), (loader, loader)):
        page = _Page(tmp_path)
        section_goals(page, eps, root / "levels", db.tasks_frame(), *extra)
        pages.append(page.sections)
    assert pages[0] == pages[1] and not calls
    assert sum(s.count("<img ") for s in pages[0]) == 1  # the goal images strip only


def test_missing_trajectories_are_a_note_naming_level_and_conditions(online_run, tmp_path):  # noqa: F811
    """Rows whose trajectory artifacts are not in this cache (run on another machine): one note
    naming the level, its conditions and how many of the drawn episodes are missing; no figure."""
    from navbench.results.db import ResultsDB
    from navbench.report.build import _Page
    from navbench.report.topviews import section_online_topviews
    from navbench.results.score import select_episodes
    from navbench.results.presets import apply_preset

    root, _ = online_run
    db = ResultsDB(f"sqlite:///{root / 'onl.db'}")
    eps = apply_preset(select_episodes(db), "nrns")  # as build_report selects them: with conditions

    def gone(key):
        raise KeyError(key)

    page = _Page(tmp_path)
    section_online_topviews(page, eps, root / "levels", gone, None)
    notes = [s for s in page.sections if "unavailable" in s]
    assert notes == ['<p class="note">tiny (texture=table, map=online, mapping=perfect, pose=true): 2 of its 2 online '
                     'trajectory artifact(s) unavailable (not in this cache: run elsewhere, or removed)</p>']
    assert page.figures == 0


@pytest.mark.parametrize("success,reason,expected", [
    (True, "reached", "success"), (False, "reached", "failed: stopped too far"),
    (False, "step-limit", "failed: step-limit"), (False, "explored", "failed: explored")])
def test_panel_outcome(success, reason, expected):
    import pandas as pd

    from navbench.report.topviews import _outcome

    assert _outcome(pd.Series({"success": success, "end_reason": reason})) == expected


def test_first_episodes_take_each_difficulty_in_turn():
    import pandas as pd

    from navbench.report.topviews import first_episodes

    rows = pd.DataFrame({"task_id": range(9), "noise": "mid", "estimator": "gt", "seed": 0,
                         "difficulty": ["easy"] * 3 + ["medium"] * 3 + ["hard"] * 3})
    assert first_episodes(rows, 6)["task_id"].tolist() == [0, 3, 6, 1, 4, 7]
    shuffled = rows.sample(frac=1.0, random_state=1)  # the order of the rows does not matter
    assert first_episodes(shuffled, 4)["task_id"].tolist() == [0, 3, 6, 1]
    assert first_episodes(rows.drop(columns=["difficulty"]), 2)["task_id"].tolist() == [0, 1]


def test_draw_panels_with_estimates_and_missing_parts():
    """Two estimators (titles name them), an estimate apart from the truth, an episode without
    stored seen cells and one without a goal heading: every panel and goal image axis drawn."""
    import pandas as pd
    from matplotlib.figure import Figure

    from navbench.report.topviews import draw_online_topviews
    from tests.pipeline.test_stages import tiny_level

    level = tiny_level()
    true = np.array([[0.6, 0.6, 0.0], [1.0, 0.8, 0.1], [1.5, 1.0, 0.2]])
    xs, ys = np.arange(0.05, 3.0, 0.1), np.arange(0.05, 2.4, 0.1)
    known = np.zeros((len(xs), len(ys)), bool)
    known[:10, :8] = True
    eps = [(pd.Series({"task_id": 0, "difficulty": "easy", "estimator": "ours", "noise": "mid",
                       "success": True, "end_reason": "reached", "goal_heading": 0.3,
                       "goal_status": "online-matched"}),
            {"true_poses": true, "est_poses": true + 0.05, "target": np.array([1.6, 1.0]),
             "known": known, "seen_share": 0.4}),
           (pd.Series({"task_id": 1, "estimator": "gt", "noise": "mid", "success": False,
                       "end_reason": "step-limit", "goal_heading": float("nan")}),
            {"true_poses": true, "est_poses": true, "target": np.array([2.5, 2.0])})]
    fig = Figure()
    draw_online_topviews(fig, level, eps, (xs, ys), several=True)
    titles = [ax.get_title() for ax in fig.axes]
    assert len(fig.axes) == 4 and titles[0].startswith("task 0 (easy), ours, mid\nsuccess, 2 steps, seen 40 %")
    assert titles[2] == "task 1, gt, mid\nfailed: step-limit, 2 steps"
    assert len(fig.axes[0].images) == 1 and len(fig.axes[2].images) == 0  # seen cells: only where stored
    assert len(fig.axes[1].images) == 1 and len(fig.axes[3].images) == 0  # no heading: no goal image
