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
    from navbench.pipeline.db import ResultsDB
    from navbench.pipeline.report import build_report, store_loaders
    from navbench.pipeline.report_topviews import TOPVIEWS_PER_GROUP

    root, _ = online_run
    monkeypatch.chdir(root)
    db = ResultsDB(f"sqlite:///{root / 'onl.db'}")
    loaders = store_loaders(root / "results" / "cache")
    goals = _goals_html(build_report(db, tmp_path / "with", *loaders, levels_dir=root / "levels",
                                     n_boot=50, preset="nrns").read_text())
    captions = re.findall(r"<figcaption>([^<]*top views[^<]*)</figcaption>", goals)
    assert len(captions) == 1  # one level, one set of conditions
    cap = captions[0]
    assert cap.startswith("tiny: top views of the first 2 of 2 online image-goal episodes")
    assert "conditions: map=online, mapping=perfect, pose=true" in cap
    assert "explored area not" not in cap and "not stored" not in cap  # the seen cells were drawn
    # the goal-image strip of the level and the new top views: two embedded images
    assert goals.count("<img ") == 2 and "unavailable" not in goals
    assert TOPVIEWS_PER_GROUP >= 2
    # without a trajectory loader: a note instead of the figure, the rest unchanged
    bare = _goals_html(build_report(db, tmp_path / "bare", levels_dir=root / "levels", n_boot=50,
                                    preset="nrns").read_text())
    assert bare.count("<img ") == 1 and "top views skipped" in bare


def test_stored_known_cells_reach_the_report(online_run):  # noqa: F811
    from navbench.pipeline.artifacts import TRAJ_FILE, load_record
    from navbench.pipeline.cache import ArtifactStore
    from navbench.pipeline.db import ResultsDB
    from navbench.pipeline.report import store_loaders
    from navbench.pipeline.report_topviews import known_grid
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
    from navbench.pipeline.db import ResultsDB
    from navbench.pipeline.report import _Page
    from navbench.pipeline.report_goals import section_goals
    from navbench.pipeline.score_presets import apply_preset

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


@pytest.mark.parametrize("success,reason,expected", [
    (True, "reached", "success"), (False, "reached", "failed: stopped too far"),
    (False, "step-limit", "failed: step-limit"), (False, "explored", "failed: explored")])
def test_panel_outcome(success, reason, expected):
    import pandas as pd

    from navbench.pipeline.report_topviews import _outcome

    assert _outcome(pd.Series({"success": success, "end_reason": reason})) == expected
